//! The disk budget: the bytes of every recording in the directory (this flight's and
//! earlier ones', all three kinds of file) counted at start and kept up to date on
//! every write and deletion, so `max_total_bytes` holds at all times, not only when a
//! file rotates.
//!
//! Room is made by deleting whole closed files, oldest first, this flight's last:
//! a board whose clock restarts at an old time writes files that look older than the
//! previous flight's, and they must not go first for that.

use std::path::{Path, PathBuf};
use std::time::SystemTime;

use super::stem;

pub struct Budget {
    dir: PathBuf,
    /// This flight's stem: its files are deleted only when nothing else is left.
    stem: String,
    max_total_bytes: u64,
    total_bytes: u64,
}

/// One recording on disk, as the budget sees it.
struct OnDisk {
    this_flight: bool,
    modified: SystemTime,
    name: String,
    bytes: u64,
}

/// No room could be made: every file left is one being written.
#[derive(Debug, PartialEq, Eq)]
pub struct NoRoom {
    pub needed_bytes: u64,
    pub total_bytes: u64,
}

impl Budget {
    /// Counts what `dir` holds already.
    pub fn open(dir: &Path, stem: &str, max_total_bytes: u64) -> Self {
        let total_bytes = recordings(dir, stem).iter().map(|f| f.bytes).sum();
        Self {
            dir: dir.to_path_buf(),
            stem: stem.to_string(),
            max_total_bytes,
            total_bytes,
        }
    }

    pub fn total_bytes(&self) -> u64 {
        self.total_bytes
    }

    /// Bytes written to (or cut from) a recording.
    pub fn wrote(&mut self, bytes: u64) {
        self.total_bytes += bytes;
    }

    pub fn cut(&mut self, bytes: u64) {
        self.total_bytes = self.total_bytes.saturating_sub(bytes);
    }

    /// Makes room for `bytes` more within the budget by deleting closed recordings;
    /// `open` names the files being written, which are never deleted. Returns how
    /// many files it deleted.
    pub fn make_room(&mut self, bytes: u64, open: &[&str]) -> Result<u64, NoRoom> {
        let mut deleted = 0;
        if self.total_bytes + bytes <= self.max_total_bytes {
            return Ok(deleted);
        }
        for file in self.deletable(open) {
            if self.total_bytes + bytes <= self.max_total_bytes {
                break;
            }
            if self.delete(&file) {
                deleted += 1;
            }
        }
        if self.total_bytes + bytes <= self.max_total_bytes {
            Ok(deleted)
        } else {
            Err(NoRoom {
                needed_bytes: bytes,
                total_bytes: self.total_bytes,
            })
        }
    }

    fn deletable(&self, open: &[&str]) -> Vec<OnDisk> {
        let mut files: Vec<OnDisk> = recordings(&self.dir, &self.stem)
            .into_iter()
            .filter(|f| !open.contains(&f.name.as_str()))
            .collect();
        files.sort_by(|a, b| {
            (a.this_flight, a.modified, &a.name).cmp(&(b.this_flight, b.modified, &b.name))
        });
        files
    }

    fn delete(&mut self, file: &OnDisk) -> bool {
        let path = self.dir.join(&file.name);
        match std::fs::remove_file(&path) {
            Ok(()) => {
                self.cut(file.bytes);
                tracing::warn!(
                    path = %path.display(),
                    bytes = file.bytes,
                    "recording budget: oldest recording deleted"
                );
                true
            }
            Err(e) => {
                tracing::error!(path = %path.display(), "recording budget: cannot delete: {e}");
                false
            }
        }
    }
}

fn recordings(dir: &Path, this_stem: &str) -> Vec<OnDisk> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let this_prefix = format!("{this_stem}-");
    entries
        .filter_map(Result::ok)
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            if !stem::is_recording(&name) {
                return None;
            }
            let meta = e.metadata().ok().filter(|m| m.is_file())?;
            Some(OnDisk {
                this_flight: name.starts_with(&this_prefix),
                modified: meta.modified().unwrap_or(SystemTime::UNIX_EPOCH),
                bytes: meta.len(),
                name,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, bytes: usize) {
        std::fs::write(dir.join(name), vec![0u8; bytes]).unwrap();
        // Distinct modification times, in creation order.
        std::thread::sleep(std::time::Duration::from_millis(15));
    }

    fn left(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn room_is_made_from_the_oldest_closed_recordings_of_every_kind() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "flight-1-001.windows.jsonl", 1000);
        write(dir.path(), "flight-1-001.tlog", 1000);
        write(dir.path(), "flight-2-001.aedat4", 1000);
        write(dir.path(), "notes.txt", 5000);
        let mut budget = Budget::open(dir.path(), "flight-3", 3000);
        assert_eq!(budget.total_bytes(), 3000, "notes.txt is not a recording");
        assert_eq!(budget.make_room(500, &[]), Ok(1));
        assert_eq!(budget.total_bytes(), 2000);
        assert_eq!(
            left(dir.path()),
            ["flight-1-001.tlog", "flight-2-001.aedat4", "notes.txt"]
        );
    }

    #[test]
    fn this_flights_files_go_last_and_open_files_never() {
        let dir = tempfile::tempdir().unwrap();
        // This flight's closed part is older by its clock than the previous flight.
        write(dir.path(), "flight-5-001.tlog", 1000);
        write(dir.path(), "flight-9-001.tlog", 1000);
        write(dir.path(), "flight-5-002.tlog", 1000);
        let mut budget = Budget::open(dir.path(), "flight-5", 3000);
        assert_eq!(budget.make_room(1000, &["flight-5-002.tlog"]), Ok(1));
        assert_eq!(left(dir.path()), ["flight-5-001.tlog", "flight-5-002.tlog"]);
        assert_eq!(budget.make_room(1500, &["flight-5-002.tlog"]), Ok(1));
        assert_eq!(left(dir.path()), ["flight-5-002.tlog"]);
        assert_eq!(
            budget.make_room(2500, &["flight-5-002.tlog"]),
            Err(NoRoom {
                needed_bytes: 2500,
                total_bytes: 1000
            })
        );
        assert_eq!(left(dir.path()), ["flight-5-002.tlog"]);
    }
}
