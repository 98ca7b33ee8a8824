//! Recorded inputs for the replay tests: what a flight's recorder would have written.

use std::path::Path;

use faithd_formats::tlog::TlogWriter;
use mavlink::MavHeader;
use mavlink::dialects::common::{ATTITUDE_DATA, MavMessage};

/// A .tlog of level flight: ATTITUDE every 10 ms from boot time 0 to `last_ms`, from
/// system 1, component 1, stamped from an arbitrary Unix time on.
pub fn write_level_tlog(path: &Path, last_ms: u32) {
    let mut tlog = TlogWriter::new(std::fs::File::create(path).unwrap());
    for k in 0..=last_ms / 10 {
        let header = MavHeader {
            system_id: 1,
            component_id: 1,
            sequence: k as u8,
        };
        let msg = MavMessage::ATTITUDE(ATTITUDE_DATA {
            time_boot_ms: k * 10,
            ..Default::default()
        });
        tlog.write(1_700_000_000_000_000 + u64::from(k) * 10_000, header, &msg)
            .unwrap();
    }
    tlog.flush().unwrap();
}

/// The three files of one flight the daemon recorded into `dir`.
pub struct Flight {
    pub events: std::path::PathBuf,
    pub tlog: std::path::PathBuf,
    pub windows: std::path::PathBuf,
}

/// The flight in `dir` (a test's flights directory holds one).
pub fn flight(dir: &Path) -> Flight {
    let mut names: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    let find = |suffix: &str| {
        names
            .iter()
            .find(|p| p.to_string_lossy().ends_with(suffix))
            .unwrap_or_else(|| panic!("no {suffix} in {names:?}"))
            .clone()
    };
    Flight {
        events: find(".aedat4"),
        tlog: find(".tlog"),
        windows: find(".windows.jsonl"),
    }
}
