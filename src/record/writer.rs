//! The recorder thread: three streams of files (events, MAVLink, windows), each
//! rotating at `max_file_bytes`, all inside the disk budget.
//!
//! Every write puts whole records on disk or none: a write that fails halfway (a full
//! card) is cut back to the last whole record, so what was written before the fault
//! always reads back, and a full card never deletes it. Nothing here ends the
//! recording: a bad event is skipped, an item that finds no room is dropped, a file
//! that cannot be opened is tried again with the next item; each is counted and
//! reported.

use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use super::budget::Budget;
use super::{Counts, Item, MavlinkRecord, RecordConfig, Stats, stem};
use faithd_core::event::Event;
use faithd_formats::events::SourceError;
use faithd_formats::events::aedat4::{Aedat4Config, Aedat4Writer};
use faithd_formats::tlog;

pub(super) struct Setup {
    pub config: RecordConfig,
    pub stem: String,
    pub window_log_header: String,
    pub sensor_px: (u16, u16),
}

/// Losses are reported at most this often while they grow.
const REPORT_EVERY: Duration = Duration::from_secs(5);

pub(super) fn run(setup: Setup, rx: Receiver<Item>, stats: &Stats) {
    tracing::info!(dir = %setup.config.dir.display(), stem = %setup.stem, "recording this flight");
    let sync_every = Duration::from_millis(setup.config.sync_interval_ms.max(1));
    let mut recording = Recording::new(setup, stats);
    let mut last_sync = Instant::now();
    let mut last_report = Instant::now();
    let mut reported = Counts::default();
    loop {
        match rx.recv_timeout(sync_every.min(REPORT_EVERY)) {
            Ok(Item::Finish(ack)) => {
                recording.close();
                let counts = stats.counts();
                tracing::info!("recording closed: {counts}");
                let _ = ack.send(counts);
                return;
            }
            Ok(item) => {
                stats
                    .queued_bytes
                    .fetch_sub(item.queued_bytes(), Ordering::AcqRel);
                recording.write(item);
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => {
                recording.close();
                return;
            }
        }
        if last_sync.elapsed() >= sync_every {
            recording.sync();
            last_sync = Instant::now();
        }
        if last_report.elapsed() >= REPORT_EVERY {
            let counts = stats.counts();
            if counts.losses() != reported.losses() {
                tracing::warn!("recording is losing data: {counts}");
                reported = counts;
            }
            last_report = Instant::now();
        }
    }
}

/// Why an item was not recorded.
enum Loss {
    /// The budget or the disk had no room.
    NoSpace(String),
    Write(String),
}

/// A raw stream (MAVLink or windows): files of whole records.
struct RawStream {
    ext: &'static str,
    /// The first line of every file, if the format has one.
    header: Option<Vec<u8>>,
    part: u32,
    open: Option<OpenFile>,
}

struct OpenFile {
    name: String,
    file: File,
    bytes: u64,
}

struct EventFile {
    name: String,
    writer: Aedat4Writer<File>,
}

struct Recording<'a> {
    dir: PathBuf,
    stem: String,
    max_file_bytes: u64,
    budget: Budget,
    stats: &'a Stats,
    aedat: Aedat4Config,
    events: Option<EventFile>,
    events_part: u32,
    last_event_t_us: Option<i64>,
    tlog: RawStream,
    windows: RawStream,
    record: Vec<u8>,
    good: Vec<Event>,
    /// The last error logged and when: repeats are counted, not logged each time.
    last_error: Option<(String, Instant)>,
}

impl<'a> Recording<'a> {
    fn new(setup: Setup, stats: &'a Stats) -> Self {
        let Setup {
            config,
            stem,
            window_log_header,
            sensor_px,
        } = setup;
        Self {
            budget: Budget::open(&config.dir, &stem, config.max_total_bytes),
            dir: config.dir,
            stem,
            max_file_bytes: config.max_file_bytes,
            stats,
            aedat: Aedat4Config {
                width_px: sensor_px.0,
                height_px: sensor_px.1,
                ..Aedat4Config::default()
            },
            events: None,
            events_part: 0,
            last_event_t_us: None,
            tlog: RawStream {
                ext: ".tlog",
                header: None,
                part: 0,
                open: None,
            },
            windows: RawStream {
                ext: ".windows.jsonl",
                header: Some(format!("{window_log_header}\n").into_bytes()),
                part: 0,
                open: None,
            },
            record: Vec::with_capacity(512),
            good: Vec::new(),
            last_error: None,
        }
    }

    fn write(&mut self, item: Item) {
        let (result, written) = match item {
            Item::Finish(_) => return,
            Item::Events(events) => {
                let result = self.write_events(&events);
                (result, &self.stats.events_written)
            }
            Item::Mavlink(record) => {
                let MavlinkRecord {
                    t_unix_us,
                    header,
                    msg,
                } = *record;
                self.record.clear();
                let result = match tlog::encode_record(&mut self.record, t_unix_us, header, &msg) {
                    Ok(()) => self.append(StreamKind::Tlog).map(|()| 1),
                    Err(e) => Err(Loss::Write(format!("MAVLink message not encodable: {e}"))),
                };
                (result, &self.stats.mavlink_written)
            }
            Item::Window(line) => {
                self.record.clear();
                self.record.extend_from_slice(line.as_bytes());
                self.record.push(b'\n');
                let result = self.append(StreamKind::Windows).map(|()| 1);
                (result, &self.stats.windows_written)
            }
        };
        match result {
            Ok(n) => Stats::add(written, n),
            Err(Loss::NoSpace(why)) => {
                Stats::add(&self.stats.dropped_no_space, 1);
                self.log_error(why);
            }
            Err(Loss::Write(why)) => {
                Stats::add(&self.stats.dropped_write_error, 1);
                self.log_error(why);
            }
        }
    }

    fn log_error(&mut self, why: String) {
        let repeat = self
            .last_error
            .as_ref()
            .is_some_and(|(last, at)| *last == why && at.elapsed() < REPORT_EVERY);
        if !repeat {
            tracing::error!("recording: {why} (item dropped; recording goes on)");
            self.last_error = Some((why, Instant::now()));
        }
    }

    fn open_names(&self) -> Vec<String> {
        let mut names = Vec::with_capacity(3);
        if let Some(e) = &self.events {
            names.push(e.name.clone());
        }
        for stream in [&self.tlog, &self.windows] {
            if let Some(open) = &stream.open {
                names.push(open.name.clone());
            }
        }
        names
    }

    /// Makes room for `bytes` in the budget, counting what it deleted.
    fn make_room(&mut self, bytes: u64) -> Result<(), Loss> {
        let open = self.open_names();
        let open: Vec<&str> = open.iter().map(String::as_str).collect();
        match self.budget.make_room(bytes, &open) {
            Ok(deleted) => {
                Stats::add(&self.stats.files_deleted, deleted);
                Ok(())
            }
            Err(no) => Err(Loss::NoSpace(format!(
                "record.max_total_bytes reached: {} bytes more do not fit beside the {} bytes of the files being written",
                no.needed_bytes, no.total_bytes
            ))),
        }
    }

    /// Skips events the event file cannot hold (off the sensor, or going back in
    /// time), counts them, and writes the rest as packets.
    fn write_events(&mut self, events: &[Event]) -> Result<u64, Loss> {
        let (width_px, height_px) = (self.aedat.width_px, self.aedat.height_px);
        self.good.clear();
        let mut last = self.last_event_t_us;
        for e in events {
            let on_sensor = e.x_px < width_px && e.y_px < height_px;
            let in_order = last.is_none_or(|t| e.t_us >= t);
            if on_sensor && in_order && e.t_us.abs() <= Event::MAX_ABS_T_US {
                self.good.push(*e);
                last = Some(e.t_us);
            }
        }
        let bad = (events.len() - self.good.len()) as u64;
        if bad > 0 {
            let before = self.stats.bad_events.fetch_add(bad, Ordering::Relaxed);
            if before == 0 {
                tracing::warn!(
                    width_px,
                    height_px,
                    "recording: events off the sensor or going back in time skipped (counted; totals in the recorder's reports)"
                );
            }
        }
        if self.good.is_empty() {
            return Ok(0);
        }
        self.last_event_t_us = last;
        // Packet headers and flatbuffer tables stay well under 16 bytes per event
        // beside the 16 of the event itself, compression or not.
        let bound_bytes = 256 + 32 * self.good.len() as u64;
        if let Some(file) = &self.events
            && file.writer.written_bytes() + bound_bytes > self.max_file_bytes
        {
            self.close_events();
        }
        if self.events.is_none() {
            self.open_events()?;
        }
        self.make_room(bound_bytes)?;
        let file = self.events.as_mut().expect("opened above");
        let before = file.writer.written_bytes();
        let result = file.writer.write_events(&self.good);
        let after = file.writer.written_bytes();
        self.budget.wrote(after - before);
        match result {
            Ok(()) => Ok(self.good.len() as u64),
            Err(e) => {
                // Cut back to the last whole packet so the file stays readable.
                let cut = cut_back(file.writer.get_mut(), after);
                let why = format!("{}: {e}{}", file.name, cut.unwrap_or_default());
                Err(if is_storage_full(&e) {
                    Loss::NoSpace(why)
                } else {
                    Loss::Write(why)
                })
            }
        }
    }

    fn open_events(&mut self) -> Result<(), Loss> {
        self.make_room(4096)?;
        self.events_part += 1;
        let name = stem::file_name(&self.stem, self.events_part, ".aedat4");
        let path = self.dir.join(&name);
        let file = create_new(&path)?;
        match Aedat4Writer::new(file, self.aedat.clone()) {
            Ok(writer) => {
                self.budget.wrote(writer.written_bytes());
                self.events = Some(EventFile { name, writer });
                Ok(())
            }
            Err(e) => {
                let _ = std::fs::remove_file(&path);
                let why = format!("{}: header not written: {e}", path.display());
                if is_storage_full(&e) {
                    Err(Loss::NoSpace(why))
                } else {
                    Err(Loss::Write(why))
                }
            }
        }
    }

    fn close_events(&mut self) {
        if let Some(file) = self.events.take() {
            match file.writer.finish() {
                Ok(f) => {
                    let _ = f.sync_data();
                }
                Err(e) => tracing::error!("closing {}: {e}", file.name),
            }
        }
    }

    /// Appends `self.record` to a raw stream as one record.
    fn append(&mut self, kind: StreamKind) -> Result<(), Loss> {
        let len = self.record.len() as u64;
        let max_file_bytes = self.max_file_bytes;
        let stream = self.stream(kind);
        if stream
            .open
            .as_ref()
            .is_some_and(|o| o.bytes > 0 && o.bytes + len > max_file_bytes)
            && let Some(old) = stream.open.take()
        {
            let _ = old.file.sync_data();
        }
        if self.stream(kind).open.is_none() {
            self.open_raw(kind, len)?;
        }
        self.make_room(len)?;
        let record = std::mem::take(&mut self.record);
        let result = self.write_record(kind, &record);
        self.record = record;
        result
    }

    fn stream(&mut self, kind: StreamKind) -> &mut RawStream {
        match kind {
            StreamKind::Tlog => &mut self.tlog,
            StreamKind::Windows => &mut self.windows,
        }
    }

    fn open_raw(&mut self, kind: StreamKind, first_record_bytes: u64) -> Result<(), Loss> {
        let header_bytes = self.stream(kind).header.as_ref().map_or(0, Vec::len) as u64;
        self.make_room(header_bytes + first_record_bytes)?;
        let stem = self.stem.clone();
        let dir = self.dir.clone();
        let stream = self.stream(kind);
        stream.part += 1;
        let name = stem::file_name(&stem, stream.part, stream.ext);
        let path = dir.join(&name);
        let file = create_new(&path)?;
        stream.open = Some(OpenFile {
            name,
            file,
            bytes: 0,
        });
        if let Some(header) = stream.header.clone()
            && let Err(loss) = self.write_record(kind, &header)
        {
            // A file without its header is no window log: start over next time.
            self.stream(kind).open = None;
            let _ = std::fs::remove_file(&path);
            return Err(loss);
        }
        Ok(())
    }

    /// Writes one record to the open file of `kind`, whole or not at all.
    ///
    /// A full card drops the record rather than delete anything: what was recorded
    /// before the fault is kept (only `max_total_bytes` deletes, oldest first).
    fn write_record(&mut self, kind: StreamKind, record: &[u8]) -> Result<(), Loss> {
        let open = self
            .stream(kind)
            .open
            .as_mut()
            .expect("opened by the caller");
        match open.file.write_all(record) {
            Ok(()) => {
                open.bytes += record.len() as u64;
                self.budget.wrote(record.len() as u64);
                Ok(())
            }
            Err(e) => {
                let cut = cut_back(&mut open.file, open.bytes);
                let why = format!("{}: {e}{}", open.name, cut.unwrap_or_default());
                Err(if e.kind() == std::io::ErrorKind::StorageFull {
                    Loss::NoSpace(why)
                } else {
                    Loss::Write(why)
                })
            }
        }
    }

    /// Puts what was written on the card (a pulled battery loses only what came
    /// after).
    fn sync(&mut self) {
        if let Some(e) = &mut self.events {
            let _ = e.writer.get_mut().sync_data();
        }
        for stream in [&self.tlog, &self.windows] {
            if let Some(open) = &stream.open {
                let _ = open.file.sync_data();
            }
        }
    }

    fn close(&mut self) {
        self.close_events();
        for stream in [&mut self.tlog, &mut self.windows] {
            if let Some(open) = stream.open.take() {
                let _ = open.file.sync_data();
            }
        }
    }
}

#[derive(Clone, Copy)]
enum StreamKind {
    Tlog,
    Windows,
}

/// Creates a file that must not exist yet: an earlier flight is never truncated.
fn create_new(path: &std::path::Path) -> Result<File, Loss> {
    File::options()
        .write(true)
        .create_new(true)
        .open(path)
        .map_err(|e| {
            let why = format!("{}: cannot create: {e}", path.display());
            if e.kind() == std::io::ErrorKind::StorageFull {
                Loss::NoSpace(why)
            } else {
                Loss::Write(why)
            }
        })
}

/// Cuts a file back to `good_bytes` after a failed write; `Some(note)` when even
/// that failed (the file may end in a partial record).
fn cut_back(file: &mut File, good_bytes: u64) -> Option<String> {
    let result = file
        .set_len(good_bytes)
        .and_then(|()| file.seek(SeekFrom::Start(good_bytes)).map(|_| ()));
    result
        .err()
        .map(|e| format!("; cutting back to {good_bytes} bytes failed too: {e}"))
}

fn is_storage_full(e: &SourceError) -> bool {
    matches!(e, SourceError::Io { source, .. } if source.kind() == std::io::ErrorKind::StorageFull)
}
