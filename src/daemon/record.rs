//! Records every flight: the camera stream as AEDAT 4.0 (opens in DV and
//! dv-processing) and the MAVLink traffic both ways as .tlog (opens in ground-station
//! tools and pymavlink), so any decision can be replayed and explained afterwards.
//!
//! The recorder has its own thread and a bounded queue; producers never wait for it
//! (a full queue drops the item and counts it). Files rotate at `max_file_bytes`,
//! and the oldest recordings are deleted to keep the directory under `max_total_bytes`.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};

use mavlink::MavHeader;
use mavlink::dialects::common::MavMessage;
use serde::{Deserialize, Serialize};

use std::io::Write;

use crate::event::Event;
use crate::link::tlog::TlogWriter;
use crate::source::aedat4::{Aedat4Config, Aedat4Writer};
use crate::window_log::WindowLogHeader;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecordConfig {
    pub enabled: bool,
    /// Directory of the recordings (the service's state directory).
    pub dir: PathBuf,
    /// A file reaching this size is closed and the next one started.
    pub max_file_bytes: u64,
    /// The oldest recordings are deleted to keep the directory under this.
    pub max_total_bytes: u64,
}

impl Default for RecordConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            dir: PathBuf::from("/var/lib/faithd/flights"),
            max_file_bytes: 256 * 1024 * 1024,
            max_total_bytes: 4 * 1024 * 1024 * 1024,
        }
    }
}

pub enum Item {
    Events(Vec<Event>),
    /// Close the files properly (AEDAT 4 packet index) and acknowledge.
    Finish(std::sync::mpsc::Sender<()>),
    /// Boxed: a MAVLink message is large next to the other variants.
    Mavlink(Box<MavlinkRecord>),
    /// One line of the window log (serialised by the pipeline thread).
    Window(String),
}

pub struct MavlinkRecord {
    pub t_unix_us: u64,
    pub header: MavHeader,
    pub msg: MavMessage,
}

/// The producers' end: cloneable, never blocks.
#[derive(Clone)]
pub struct Recorder {
    tx: SyncSender<Item>,
}

impl Recorder {
    /// Closes the files; waits at most a second for the recorder to say it did.
    pub fn finish(&self) {
        let (ack_tx, ack_rx) = std::sync::mpsc::channel();
        if self.tx.send(Item::Finish(ack_tx)).is_ok() {
            let _ = ack_rx.recv_timeout(std::time::Duration::from_secs(1));
        }
    }

    pub fn send(&self, item: Item) {
        match self.tx.try_send(item) {
            Ok(()) | Err(TrySendError::Disconnected(_)) => {}
            Err(TrySendError::Full(_)) => {
                tracing::warn!("recorder behind: one item not recorded");
            }
        }
    }
}

/// Starts the recorder thread; `None` (and a log line) when recording is off or the
/// directory cannot be made.
///
/// `window_log_header` opens every window-log file (see [`crate::window_log`]).
pub fn start(config: &RecordConfig, window_log_header: &WindowLogHeader) -> Option<Recorder> {
    if !config.enabled {
        tracing::info!("flight recording off");
        return None;
    }
    if let Err(e) = std::fs::create_dir_all(&config.dir) {
        tracing::error!(dir = %config.dir.display(), "cannot record flights: {e}");
        return None;
    }
    let (tx, rx) = std::sync::mpsc::sync_channel(4096);
    let config = config.clone();
    let header = serde_json::to_string(window_log_header).expect("header serialises");
    std::thread::Builder::new()
        .name("faithd-record".into())
        .spawn(move || run(config, header, rx))
        .expect("spawn recorder thread");
    Some(Recorder { tx })
}

struct Files {
    events: Option<Aedat4Writer<File>>,
    events_bytes: u64,
    tlog: Option<TlogWriter<File>>,
    tlog_bytes: u64,
    /// The window log and the part it belongs to (it follows the event file's).
    windows: Option<(u32, std::io::BufWriter<File>)>,
    part: u32,
}

fn unix_now_s() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

fn run(config: RecordConfig, window_log_header: String, rx: Receiver<Item>) {
    let stem = format!("flight-{}", unix_now_s());
    tracing::info!(dir = %config.dir.display(), %stem, "recording this flight");
    let mut files = Files {
        events: None,
        events_bytes: 0,
        tlog: None,
        tlog_bytes: 0,
        windows: None,
        part: 0,
    };
    while let Ok(item) = rx.recv() {
        if let Item::Finish(ack) = item {
            close(&mut files);
            let _ = ack.send(());
            return;
        }
        if let Err(e) = write(&config, &stem, &window_log_header, &mut files, item) {
            tracing::error!("recording failed, continuing without it: {e}");
            return;
        }
    }
    close(&mut files);
}

fn close(files: &mut Files) {
    if let Some(w) = files.events.take()
        && let Err(e) = w.finish()
    {
        tracing::error!("closing the event recording: {e}");
    }
    if let Some(mut t) = files.tlog.take() {
        let _ = t.flush();
    }
    if let Some((_, mut w)) = files.windows.take() {
        let _ = w.flush();
    }
}

fn write(
    config: &RecordConfig,
    stem: &str,
    window_log_header: &str,
    files: &mut Files,
    item: Item,
) -> Result<(), String> {
    match item {
        Item::Finish(_) => Ok(()),
        Item::Window(line) => {
            let part = files.part.max(1);
            if files.windows.as_ref().is_none_or(|(p, _)| *p != part) {
                if let Some((_, mut w)) = files.windows.take() {
                    w.flush().map_err(|e| e.to_string())?;
                }
                let path = config.dir.join(format!("{stem}-{part:03}.windows.jsonl"));
                let file = File::create(&path).map_err(|e| format!("{}: {e}", path.display()))?;
                let mut w = std::io::BufWriter::new(file);
                writeln!(w, "{window_log_header}").map_err(|e| e.to_string())?;
                files.windows = Some((part, w));
            }
            let (_, w) = files.windows.as_mut().expect("opened above");
            writeln!(w, "{line}").map_err(|e| e.to_string())
        }
        Item::Events(events) => {
            if files.events.is_none() || files.events_bytes >= config.max_file_bytes {
                if let Some(w) = files.events.take() {
                    w.finish().map_err(|e| e.to_string())?;
                }
                files.part += 1;
                let path = config.dir.join(format!("{stem}-{:03}.aedat4", files.part));
                make_room(
                    &config.dir,
                    config.max_total_bytes.saturating_sub(config.max_file_bytes),
                );
                let file = File::create(&path).map_err(|e| format!("{}: {e}", path.display()))?;
                let w =
                    Aedat4Writer::new(file, Aedat4Config::default()).map_err(|e| e.to_string())?;
                files.events = Some(w);
                files.events_bytes = 0;
            }
            files.events_bytes += 16 * events.len() as u64;
            files
                .events
                .as_mut()
                .expect("opened above")
                .write_events(&events)
                .map_err(|e| e.to_string())
        }
        Item::Mavlink(record) => {
            let MavlinkRecord {
                t_unix_us,
                header,
                msg,
            } = *record;
            if files.tlog.is_none() || files.tlog_bytes >= config.max_file_bytes {
                if let Some(mut t) = files.tlog.take() {
                    t.flush().map_err(|e| e.to_string())?;
                }
                let path = config
                    .dir
                    .join(format!("{stem}-{:03}.tlog", files.part.max(1)));
                let file = File::options()
                    .create(true)
                    .append(true)
                    .open(&path)
                    .map_err(|e| format!("{}: {e}", path.display()))?;
                files.tlog = Some(TlogWriter::new(file));
                files.tlog_bytes = 0;
            }
            files.tlog_bytes += 40;
            files
                .tlog
                .as_mut()
                .expect("opened above")
                .write(t_unix_us, header, &msg)
                .map_err(|e| e.to_string())
        }
    }
}

/// Deletes the oldest recordings until the directory holds at most `budget` bytes.
fn make_room(dir: &Path, budget: u64) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut files: Vec<(std::time::SystemTime, u64, PathBuf)> = entries
        .filter_map(Result::ok)
        .filter(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name.starts_with("flight-") && (name.ends_with(".aedat4") || name.ends_with(".tlog"))
        })
        .filter_map(|e| {
            let meta = e.metadata().ok()?;
            Some((meta.modified().ok()?, meta.len(), e.path()))
        })
        .collect();
    files.sort();
    let mut total: u64 = files.iter().map(|f| f.1).sum();
    for (_, len, path) in files {
        if total <= budget {
            break;
        }
        if std::fs::remove_file(&path).is_ok() {
            tracing::warn!(path = %path.display(), "disk limit: oldest recording deleted");
            total -= len;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn make_room_deletes_the_oldest_first() {
        let dir = std::env::temp_dir().join(format!("faithd-record-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for k in 0..4 {
            std::fs::write(dir.join(format!("flight-{k}-001.tlog")), vec![0u8; 1000]).unwrap();
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        std::fs::write(dir.join("notes.txt"), vec![0u8; 5000]).unwrap();
        make_room(&dir, 2500);
        let mut left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(
            left,
            ["flight-2-001.tlog", "flight-3-001.tlog", "notes.txt"]
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
