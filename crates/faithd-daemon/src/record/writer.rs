//! The recorder thread: three streams of files (events, MAVLink, windows), each
//! rotating at `max_file_bytes`, all inside the disk budget.
//!
//! Every write puts whole records on disk or none. The room for a record is reserved
//! on the card first (`fallocate`, keeping the file's size), so a full card refuses
//! the record before any of it is written: a process killed at any moment leaves
//! whole records only. Where the filesystem cannot reserve (exFAT), a write that fails
//! halfway is cut back to the last whole record, and a kill between the two leaves a
//! torn last record (said once in the log). What was written before a fault always
//! reads back, and a full card never deletes it. Nothing here ends the
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
    /// The end of the room reserved so far: a packet's reservation is a bound, and
    /// what the last one did not use is given back when the file closes.
    reserved_to_bytes: u64,
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
    /// Whether the card's filesystem reserves room (`fallocate`); false after its
    /// first refusal.
    can_reserve: bool,
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
            can_reserve: true,
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
        let reserved = reserve(
            &mut self.can_reserve,
            file.writer.get_mut(),
            before,
            bound_bytes,
        );
        reserved.map_err(|e| Loss::NoSpace(format!("{}: {e}", file.name)))?;
        file.reserved_to_bytes = file.reserved_to_bytes.max(before + bound_bytes);
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
        let part = self.events_part + 1;
        let name = stem::file_name(&self.stem, part, ".aedat4");
        let path = self.dir.join(&name);
        let file = create_new(&path, 4096, &mut self.can_reserve)?;
        self.events_part = part;
        match Aedat4Writer::new(file, self.aedat.clone()) {
            Ok(writer) => {
                self.budget.wrote(writer.written_bytes());
                self.events = Some(EventFile {
                    name,
                    writer,
                    reserved_to_bytes: 4096,
                });
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
            let reserved_to_bytes = file.reserved_to_bytes;
            match file.writer.finish() {
                Ok(f) => {
                    unreserve_after(&f, reserved_to_bytes);
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
        let (part, ext) = {
            let stream = self.stream(kind);
            (stream.part + 1, stream.ext)
        };
        let name = stem::file_name(&self.stem, part, ext);
        let path = self.dir.join(&name);
        let file = create_new(
            &path,
            header_bytes + first_record_bytes,
            &mut self.can_reserve,
        )?;
        let stream = self.stream(kind);
        // A part number is used once a file of it exists: a card that refuses
        // files leaves no gaps in the numbering.
        stream.part = part;
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
        let stream = match kind {
            StreamKind::Tlog => &mut self.tlog,
            StreamKind::Windows => &mut self.windows,
        };
        let open = stream.open.as_mut().expect("opened by the caller");
        let len = record.len() as u64;
        reserve(&mut self.can_reserve, &open.file, open.bytes, len)
            .map_err(|e| Loss::NoSpace(format!("{}: {e}", open.name)))?;
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

/// Creates a file that must not exist yet (an earlier flight is never truncated),
/// with room reserved for its first `first_bytes`.
///
/// A card without that room gets no file: an empty or headless file left by a kill
/// between creating it and removing it again would be a recording no tool reads, and
/// on a full card the open is tried again with every item.
fn create_new(
    path: &std::path::Path,
    first_bytes: u64,
    can_reserve: &mut bool,
) -> Result<File, Loss> {
    let no_space = |why: String| Loss::NoSpace(format!("{}: {why}", path.display()));
    if let Some(dir) = path.parent()
        && let Ok(card) = nix::sys::statvfs::statvfs(dir)
    {
        // The casts widen on 32-bit boards, where the block size is 32 bits.
        #[allow(clippy::unnecessary_cast)]
        let block_bytes = card.fragment_size() as u64;
        #[allow(clippy::unnecessary_cast)]
        let free_bytes = card.blocks_available() as u64 * block_bytes;
        if free_bytes < first_bytes + block_bytes {
            return Err(no_space(format!(
                "not created: {free_bytes} bytes free on the card, {first_bytes} needed"
            )));
        }
    }
    let file = File::options()
        .write(true)
        .create_new(true)
        .open(path)
        .map_err(|e| {
            let why = format!("cannot create: {e}");
            if e.kind() == std::io::ErrorKind::StorageFull {
                no_space(why)
            } else {
                Loss::Write(format!("{}: {why}", path.display()))
            }
        })?;
    if let Err(e) = reserve(can_reserve, &file, 0, first_bytes) {
        let _ = std::fs::remove_file(path);
        return Err(no_space(format!("not created: {e}")));
    }
    Ok(file)
}

/// Reserves `len_bytes` of the card at `at_bytes` in `file` without changing its size:
/// `Err` (no room) means nothing of the record may be written. A filesystem that has
/// no reservation is said once, and writes go on unreserved.
fn reserve(
    can_reserve: &mut bool,
    file: &File,
    at_bytes: u64,
    len_bytes: u64,
) -> Result<(), std::io::Error> {
    use nix::fcntl::{FallocateFlags, fallocate};
    if !*can_reserve || len_bytes == 0 {
        return Ok(());
    }
    let (Ok(at), Ok(len)) = (i64::try_from(at_bytes), i64::try_from(len_bytes)) else {
        return Ok(());
    };
    match fallocate(file, FallocateFlags::FALLOC_FL_KEEP_SIZE, at, len) {
        Ok(()) => Ok(()),
        Err(nix::errno::Errno::EOPNOTSUPP) => {
            *can_reserve = false;
            tracing::warn!(
                "recording: the card's filesystem cannot reserve room for a record (fallocate); \
                 a write that fails on a full card is cut back, but a kill at that moment can \
                 leave a torn last record"
            );
            Ok(())
        }
        Err(errno) => Err(std::io::Error::from(errno)),
    }
}

/// Gives back the room reserved past the end of a closed file (best effort: a
/// filesystem without hole punching frees it when the file is released, or keeps
/// it, at most one packet's bound).
fn unreserve_after(file: &File, reserved_to_bytes: u64) {
    use nix::fcntl::{FallocateFlags, fallocate};
    let Ok(end) = file.metadata().map(|m| m.len()) else {
        return;
    };
    if let (Ok(at), Ok(len)) = (
        i64::try_from(end),
        i64::try_from(reserved_to_bytes.saturating_sub(end)),
    ) && len > 0
    {
        let punch = FallocateFlags::FALLOC_FL_PUNCH_HOLE | FallocateFlags::FALLOC_FL_KEEP_SIZE;
        let _ = fallocate(file, punch, at, len);
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::process::Command;

    /// A tmpfs as a small SD card, unmounted on drop.
    struct Card(tempfile::TempDir);

    impl Card {
        fn mount(size: &str) -> Self {
            assert!(
                nix::unistd::geteuid().is_root(),
                "this test mounts a tmpfs as a full SD card: run it as root (CI does)"
            );
            let dir = tempfile::tempdir().unwrap();
            let status = Command::new("mount")
                .args(["-t", "tmpfs", "-o", &format!("size={size},mode=0700")])
                .arg("faithd-test-card")
                .arg(dir.path())
                .status()
                .expect("mount");
            assert!(status.success(), "mount -t tmpfs failed");
            Card(dir)
        }
    }

    impl Drop for Card {
        fn drop(&mut self) {
            let _ = Command::new("umount").arg("-l").arg(self.0.path()).status();
        }
    }

    #[test]
    fn a_reserved_record_is_written_whole_on_a_full_card_and_one_without_room_is_refused() {
        let card = Card::mount("64k");
        let mut log = File::create(card.0.path().join("log")).unwrap();
        let mut can_reserve = true;
        reserve(&mut can_reserve, &log, 0, 5000).unwrap();
        assert_eq!(
            log.metadata().unwrap().len(),
            0,
            "the reservation kept the size"
        );

        // Another file takes every byte left.
        let mut filler = File::create(card.0.path().join("filler")).unwrap();
        let page = [7u8; 4096];
        let full = loop {
            if let Err(e) = filler.write_all(&page) {
                break e;
            }
        };
        assert_eq!(full.kind(), std::io::ErrorKind::StorageFull);

        log.write_all(&[b'x'; 5000]).unwrap();
        let refused = reserve(&mut can_reserve, &log, 5000, 5000).unwrap_err();
        assert_eq!(refused.kind(), std::io::ErrorKind::StorageFull);
        assert!(can_reserve, "tmpfs reserves");
        assert_eq!(log.metadata().unwrap().len(), 5000);
        assert_eq!(
            std::fs::read(card.0.path().join("log")).unwrap(),
            [b'x'; 5000]
        );
    }

    #[test]
    fn the_room_a_closed_file_did_not_use_is_given_back() {
        use std::os::unix::fs::MetadataExt;
        let card = Card::mount("1m");
        let mut file = File::create(card.0.path().join("events")).unwrap();
        let mut can_reserve = true;
        reserve(&mut can_reserve, &file, 0, 256 * 1024).unwrap();
        file.write_all(&[1u8; 100]).unwrap();
        assert!(file.metadata().unwrap().blocks() * 512 >= 256 * 1024);
        unreserve_after(&file, 256 * 1024);
        let kept_bytes = file.metadata().unwrap().blocks() * 512;
        assert!(kept_bytes <= 4096, "{kept_bytes} bytes still allocated");
        assert_eq!(
            std::fs::read(card.0.path().join("events")).unwrap(),
            [1u8; 100]
        );
    }
}
