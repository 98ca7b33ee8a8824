//! AEDAT 4 interoperability with an independent implementation: iniVation's
//! dv-processing (Python package `dv-processing`), driven through the scripts in
//! `tests/py/`.
//!
//! Both directions are checked for every compression type: files dv-processing writes
//! must read back in faithd event for event, and files faithd writes (as it records
//! flights) must open in dv-processing with every event intact.
//!
//! Without dv-processing for Python (`bash tests/peers/prepare` at the repository's
//! root installs it) these tests skip with one line, and fail in CI. `FAITHD_PYTHON`
//! names another interpreter.

mod peer;

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::process::Command;

use faithd_core::event::{Event, Polarity};
use faithd_formats::events::aedat4::{Aedat4Config, Aedat4Writer, Compression};
use faithd_formats::events::{Format, open_events, read_all};

const EVENT_COUNT: u64 = 3000;
const T0_US: i64 = 1_700_000_000_000_000;
const MODULUS: u128 = (1 << 61) - 1;

/// Event `i` of the list `tests/py/known_events.py` defines.
fn known_event(i: u64) -> Event {
    Event::new(
        T0_US + 37 * i as i64 + (i / 7) as i64,
        ((7919 * i) % 240) as u16,
        ((104_729 * i + 13) % 180) as u16,
        Polarity::from_bool(((2_654_435_761 * i) >> 7) & 1 == 1),
    )
}

fn known_events() -> Vec<Event> {
    (0..EVENT_COUNT).map(known_event).collect()
}

/// The checksum of `known_events.py`.
fn checksum(events: &[Event]) -> u128 {
    events.iter().enumerate().fold(0u128, |total, (i, e)| {
        let term = (e.t_us as u128 * 1_000_003
            + u128::from(e.x_px) * 1009
            + u128::from(e.y_px) * 31
            + e.polarity.index() as u128)
            % MODULUS;
        (total + term * (i as u128 + 1)) % MODULUS
    })
}

fn python() -> String {
    std::env::var("FAITHD_PYTHON").unwrap_or_else(|_| "python3".to_string())
}

/// Runs a script of `tests/py/` and returns its standard output, failing the test
/// with the script's own words when it fails.
fn run_script(script: &str, args: &[&str]) -> String {
    let scripts = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/py");
    let output = Command::new(python())
        .arg(scripts.join(script))
        .args(args)
        .current_dir(&scripts)
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "cannot run `{}` ({e}): these tests need Python 3 with iniVation's dv-processing \
                 (`bash tests/peers/prepare`)",
                python()
            )
        });
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.code() != Some(3),
        "dv-processing is missing: {stderr}\nrun `bash tests/peers/prepare`"
    );
    assert!(
        output.status.success(),
        "{script} {args:?} failed ({}):\n{stderr}",
        output.status
    );
    String::from_utf8(output.stdout).expect("script output is UTF-8")
}

/// A scratch directory unique to this test process and test.
fn scratch_dir(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "faithd-aedat4-interop-{}-{test}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).expect("create scratch directory");
    dir
}

#[test]
fn files_written_by_dv_processing_read_exactly() {
    if !peer::python_module(
        &python(),
        "dv_processing",
        "files_written_by_dv_processing_read_exactly",
    ) {
        return;
    }
    let dir = scratch_dir("dv-writes");
    let expected = known_events();
    for compression in Compression::ALL {
        let path = dir.join(format!("{}.aedat4", compression.name()));
        let path_text = path.to_str().expect("UTF-8 temp path");
        run_script(
            "dv_write_events.py",
            &[path_text, compression.name(), &EVENT_COUNT.to_string()],
        );
        let mut reader = open_events(&path).expect("open the dv-processing file");
        assert_eq!(reader.format(), Format::Aedat4);
        let events = read_all(&mut *reader).unwrap_or_else(|e| {
            panic!(
                "reading the {} file written by dv-processing: {e}",
                compression.name()
            )
        });
        assert_eq!(events.len(), expected.len(), "{}", compression.name());
        for (i, (got, want)) in events.iter().zip(&expected).enumerate() {
            assert_eq!(got, want, "event {i} of the {} file", compression.name());
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[derive(serde::Deserialize)]
struct DvReport {
    count: u64,
    first: Option<[i64; 4]>,
    last: Option<[i64; 4]>,
    checksum: u128,
    width: Option<u32>,
    height: Option<u32>,
}

fn as_row(e: &Event) -> [i64; 4] {
    [
        e.t_us,
        i64::from(e.x_px),
        i64::from(e.y_px),
        e.polarity.index() as i64,
    ]
}

/// Writes the known events with faithd in uneven batches, the way the daemon records.
fn write_with_faithd(path: &Path, compression: Compression, finish: bool) {
    let config = Aedat4Config {
        compression,
        ..Aedat4Config::default()
    };
    let mut writer = Aedat4Writer::new(BufWriter::new(File::create(path).expect("create")), config)
        .expect("write the header");
    let events = known_events();
    for batch in events.chunks(700) {
        writer.write_events(batch).expect("write a packet");
    }
    if finish {
        writer.finish().expect("finish the recording");
    }
}

fn check_dv_reads(path: &Path, what: &str) {
    let path_text = path.to_str().expect("UTF-8 temp path");
    let stdout = run_script("dv_read_events.py", &[path_text, &EVENT_COUNT.to_string()]);
    let report: DvReport = serde_json::from_str(stdout.trim())
        .unwrap_or_else(|e| panic!("dv_read_events.py printed {stdout:?}: {e}"));
    let expected = known_events();
    assert_eq!(report.count, EVENT_COUNT, "{what}");
    assert_eq!(report.first, expected.first().map(as_row), "{what}");
    assert_eq!(report.last, expected.last().map(as_row), "{what}");
    assert_eq!(report.checksum, checksum(&expected), "{what}");
    assert_eq!(
        (report.width, report.height),
        (Some(240), Some(180)),
        "{what}"
    );
}

#[test]
fn files_written_by_faithd_read_in_dv_processing() {
    if !peer::python_module(
        &python(),
        "dv_processing",
        "files_written_by_faithd_read_in_dv_processing",
    ) {
        return;
    }
    let dir = scratch_dir("faithd-writes");
    for compression in Compression::ALL {
        let path = dir.join(format!("{}.aedat4", compression.name()));
        write_with_faithd(&path, compression, true);
        check_dv_reads(&path, compression.name());
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_recording_cut_short_still_reads_in_dv_processing_and_faithd() {
    if !peer::python_module(
        &python(),
        "dv_processing",
        "a_recording_cut_short_still_reads_in_dv_processing_and_faithd",
    ) {
        return;
    }
    let dir = scratch_dir("cut-short");
    let path = dir.join("cut.aedat4");
    write_with_faithd(&path, Compression::Lz4, false);
    check_dv_reads(&path, "unfinished LZ4 recording");
    let mut reader = open_events(&path).expect("open");
    assert_eq!(read_all(&mut *reader).expect("read"), known_events());
    std::fs::remove_dir_all(&dir).ok();
}
