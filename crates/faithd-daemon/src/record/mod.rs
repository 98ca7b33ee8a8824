//! Records every flight: the camera stream as AEDAT 4.0 (opens in DV and
//! dv-processing), the MAVLink traffic both ways as .tlog (opens in ground-station
//! tools and pymavlink) and the pipeline's windows as a window log, so any decision
//! can be replayed and explained afterwards.
//!
//! The recorder runs on its own thread behind a queue bounded in bytes: producers
//! never wait for it, and what does not fit is dropped and counted, never silently
//! (an unbounded backlog on a slow SD card would end in an OOM kill mid-roll).
//! On disk, `max_total_bytes` holds for everything the recorder writes, at all
//! times ([`budget`]); a full disk costs the items that do not fit, not the
//! recording; names never collide with an earlier flight's ([`stem`]).

pub mod budget;
pub mod stem;
mod writer;

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::Sender;

use mavlink::MavHeader;
use mavlink::dialects::common::MavMessage;
use serde::{Deserialize, Serialize};

use faithd_core::event::Event;
use faithd_core::invalid::{Invalid, check};
use faithd_formats::window_log::WindowLogHeader;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecordConfig {
    pub enabled: bool,
    /// Directory of the recordings (the service's state directory).
    pub dir: PathBuf,
    /// A file reaching this size is closed and the next one started.
    pub max_file_bytes: u64,
    /// Everything faithd's recordings hold in `dir` stays under this; the oldest
    /// files go first.
    pub max_total_bytes: u64,
    /// Items waiting for the disk stay under this; more are dropped and counted.
    pub max_queue_bytes: u64,
    /// Written data reaches the card at least this often (a pulled battery loses at
    /// most this much).
    pub sync_interval_ms: u64,
}

impl Default for RecordConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            dir: PathBuf::from("/var/lib/faithd/flights"),
            max_file_bytes: 256 * 1024 * 1024,
            max_total_bytes: 4 * 1024 * 1024 * 1024,
            max_queue_bytes: 32 * 1024 * 1024,
            sync_interval_ms: 1000,
        }
    }
}

impl RecordConfig {
    /// `[record]`: parts big enough, a budget that holds three open parts and one to spare.
    pub fn validate(&self) -> Result<(), Invalid> {
        const MIB: u64 = 1024 * 1024;
        let r = self;
        if !r.enabled {
            return Ok(());
        }
        check(!r.dir.as_os_str().is_empty(), "record.dir", || {
            "must name a directory".into()
        })?;
        check(r.max_file_bytes >= MIB, "record.max_file_bytes", || {
            format!(
                "must be at least 1 MiB ({MIB}), got {}: smaller parts would open a file per batch",
                r.max_file_bytes
            )
        })?;
        // Three files are open at a time (events, MAVLink, windows), each up to a part:
        // one more part of room keeps the budget from deleting what is being written.
        check(
            r.max_total_bytes >= 4 * r.max_file_bytes,
            "record.max_total_bytes",
            || {
                format!(
                    "must be at least four times record.max_file_bytes ({}), got {}: three files are written at once and the budget needs a part to spare",
                    4 * r.max_file_bytes,
                    r.max_total_bytes
                )
            },
        )?;
        check(
            (MIB..=1024 * MIB).contains(&r.max_queue_bytes),
            "record.max_queue_bytes",
            || {
                format!(
                    "must be 1 MiB to 1 GiB, got {}: the queue is memory the daemon holds while the card is slow",
                    r.max_queue_bytes
                )
            },
        )?;
        check(
            (10..=60_000).contains(&r.sync_interval_ms),
            "record.sync_interval_ms",
            || format!("must be 10 to 60000 ms, got {}", r.sync_interval_ms),
        )
    }
}

pub enum Item {
    Events(Vec<Event>),
    /// Close the files and acknowledge with what was recorded.
    Finish(tokio::sync::oneshot::Sender<Counts>),
    /// Boxed: a MAVLink message is large next to the other variants.
    Mavlink(Box<MavlinkRecord>),
    /// One line of the window log (serialised by the pipeline thread).
    Window(String),
}

impl Item {
    /// Memory the item holds while queued.
    fn queued_bytes(&self) -> u64 {
        let heap = match self {
            Item::Events(events) => events.capacity() * size_of::<Event>(),
            Item::Finish(_) => 0,
            Item::Mavlink(_) => size_of::<MavlinkRecord>(),
            Item::Window(line) => line.capacity(),
        };
        (heap + size_of::<Item>()) as u64
    }
}

pub struct MavlinkRecord {
    pub t_unix_us: u64,
    pub header: MavHeader,
    pub msg: MavMessage,
}

/// What the recorder wrote and what it could not, by cause; reported in the journal
/// (throttled) while it changes and once at the end.
#[derive(Default)]
pub struct Stats {
    pub events_written: AtomicU64,
    pub mavlink_written: AtomicU64,
    pub windows_written: AtomicU64,
    /// Items dropped because the queue held `max_queue_bytes` already.
    pub dropped_queue_full: AtomicU64,
    /// Events off the configured sensor or going back in time.
    pub bad_events: AtomicU64,
    /// Items that did not fit the budget or the disk.
    pub dropped_no_space: AtomicU64,
    /// Items lost to any other write error.
    pub dropped_write_error: AtomicU64,
    /// Recordings deleted to stay within `max_total_bytes`.
    pub files_deleted: AtomicU64,
    queued_bytes: AtomicU64,
}

/// A snapshot of [`Stats`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    pub events_written: u64,
    pub mavlink_written: u64,
    pub windows_written: u64,
    pub dropped_queue_full: u64,
    pub bad_events: u64,
    pub dropped_no_space: u64,
    pub dropped_write_error: u64,
    pub files_deleted: u64,
}

impl Stats {
    pub fn counts(&self) -> Counts {
        let get = |c: &AtomicU64| c.load(Ordering::Relaxed);
        Counts {
            events_written: get(&self.events_written),
            mavlink_written: get(&self.mavlink_written),
            windows_written: get(&self.windows_written),
            dropped_queue_full: get(&self.dropped_queue_full),
            bad_events: get(&self.bad_events),
            dropped_no_space: get(&self.dropped_no_space),
            dropped_write_error: get(&self.dropped_write_error),
            files_deleted: get(&self.files_deleted),
        }
    }

    fn add(counter: &AtomicU64, n: u64) {
        counter.fetch_add(n, Ordering::Relaxed);
    }
}

impl Counts {
    /// Anything lost or skipped.
    pub fn losses(&self) -> u64 {
        self.dropped_queue_full + self.bad_events + self.dropped_no_space + self.dropped_write_error
    }
}

impl std::fmt::Display for Counts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} events, {} MAVLink messages, {} windows written; dropped: {} items with the queue full, {} bad events, {} items for want of space, {} items on write errors; {} old files deleted",
            self.events_written,
            self.mavlink_written,
            self.windows_written,
            self.dropped_queue_full,
            self.bad_events,
            self.dropped_no_space,
            self.dropped_write_error,
            self.files_deleted
        )
    }
}

/// The producers' end: cloneable, never blocks.
#[derive(Clone)]
pub struct Recorder {
    tx: Sender<Item>,
    max_queue_bytes: u64,
    stats: Arc<Stats>,
}

impl Recorder {
    /// Queues an item unless the queue holds `max_queue_bytes`; a drop is counted,
    /// and the first of a run of drops is logged at once (the rest in the recorder's
    /// periodic report).
    pub fn send(&self, item: Item) {
        let bytes = item.queued_bytes();
        let before = self.stats.queued_bytes.fetch_add(bytes, Ordering::AcqRel);
        if before + bytes > self.max_queue_bytes {
            self.stats.queued_bytes.fetch_sub(bytes, Ordering::AcqRel);
            let dropped = self
                .stats
                .dropped_queue_full
                .fetch_add(1, Ordering::Relaxed);
            if dropped == 0 {
                tracing::warn!(
                    max_queue_bytes = self.max_queue_bytes,
                    "recorder behind the data: dropping what does not fit its queue (counted; totals in the recorder's reports)"
                );
            }
            return;
        }
        if self.tx.send(item).is_err() {
            self.stats.queued_bytes.fetch_sub(bytes, Ordering::AcqRel);
        }
    }

    /// Closes the files; waits at most two seconds for the recorder to say it did,
    /// without blocking the runtime it is called on.
    pub async fn finish(&self) -> Option<Counts> {
        let (ack_tx, ack_rx) = tokio::sync::oneshot::channel();
        self.tx.send(Item::Finish(ack_tx)).ok()?;
        match tokio::time::timeout(std::time::Duration::from_secs(2), ack_rx).await {
            Ok(Ok(counts)) => Some(counts),
            _ => {
                tracing::error!("the recorder did not close its files within 2 s");
                None
            }
        }
    }

    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Bytes waiting in the queue now.
    pub fn queued_bytes(&self) -> u64 {
        self.stats.queued_bytes.load(Ordering::Acquire)
    }
}

/// Starts the recorder thread; `None` (and a log line) when recording is off or the
/// directory cannot be made.
///
/// `window_log_header` opens every window-log file (see [`faithd_formats::window_log`]); its
/// camera is the sensor the event files declare.
pub fn start(config: &RecordConfig, window_log_header: &WindowLogHeader) -> Option<Recorder> {
    if !config.enabled {
        tracing::info!("flight recording off");
        return None;
    }
    if let Err(e) = std::fs::create_dir_all(&config.dir) {
        tracing::error!(dir = %config.dir.display(), "cannot record flights: {e}");
        return None;
    }
    let (tx, rx) = std::sync::mpsc::channel();
    let stats = Arc::new(Stats::default());
    let setup = writer::Setup {
        config: config.clone(),
        stem: stem::choose(&config.dir, stem::unix_now_s()),
        window_log_header: serde_json::to_string(window_log_header).expect("header serialises"),
        sensor_px: (
            window_log_header.pipeline.camera.width_px,
            window_log_header.pipeline.camera.height_px,
        ),
    };
    let thread_stats = stats.clone();
    std::thread::Builder::new()
        .name("faithd-record".into())
        .spawn(move || writer::run(setup, rx, &thread_stats))
        .expect("spawn recorder thread");
    Some(Recorder {
        tx,
        max_queue_bytes: config.max_queue_bytes,
        stats,
    })
}

#[cfg(test)]
mod tests;
