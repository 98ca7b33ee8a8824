//! Names of a flight's files: `flight-<unix seconds>-<part>.<ext>`.
//!
//! A board without a real-time clock comes back from a pulled battery at the time it
//! last saved, so two flights can start in the same second. The stem takes a suffix
//! (`flight-<s>_2`) when any file of that second exists, and every file is created
//! exclusively, so a flight can never truncate another.

use std::path::Path;

/// Prefix of every file the recorder writes.
pub const PREFIX: &str = "flight-";

/// Extensions of the recorder's files.
pub const EXTENSIONS: [&str; 3] = [".aedat4", ".tlog", ".windows.jsonl"];

/// Whether `name` is one of the recorder's files (and so counted in the budget).
pub fn is_recording(name: &str) -> bool {
    name.starts_with(PREFIX) && EXTENSIONS.iter().any(|ext| name.ends_with(ext))
}

pub fn unix_now_s() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// The first stem for `now_s` that no file in `dir` uses.
pub fn choose(dir: &Path, now_s: u64) -> String {
    let names: Vec<String> = std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    let base = format!("{PREFIX}{now_s}");
    let taken = |stem: &str| {
        let with_part = format!("{stem}-");
        names.iter().any(|n| n.starts_with(&with_part))
    };
    if !taken(&base) {
        return base;
    }
    (2u32..)
        .map(|k| format!("{base}_{k}"))
        .find(|stem| !taken(stem))
        .expect("some suffix is free")
}

/// The file of `part` of a stream.
pub fn file_name(stem: &str, part: u32, ext: &str) -> String {
    format!("{stem}-{part:03}{ext}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_flight_in_the_same_second_gets_its_own_stem() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(choose(dir.path(), 1000), "flight-1000");
        std::fs::write(dir.path().join("flight-1000-001.tlog"), b"x").unwrap();
        assert_eq!(choose(dir.path(), 1000), "flight-1000_2");
        std::fs::write(dir.path().join("flight-1000_2-003.windows.jsonl"), b"x").unwrap();
        assert_eq!(choose(dir.path(), 1000), "flight-1000_3");
        // Another second's files do not count, nor does a prefix of a longer number.
        assert_eq!(choose(dir.path(), 100), "flight-100");
    }

    #[test]
    fn only_the_recorders_files_are_recordings() {
        assert!(is_recording("flight-1-001.aedat4"));
        assert!(is_recording("flight-1_2-004.windows.jsonl"));
        assert!(is_recording("flight-1-001.tlog"));
        assert!(!is_recording("notes.txt"));
        assert!(!is_recording("flight-plan.txt"));
        assert!(!is_recording("other-1-001.tlog"));
    }
}
