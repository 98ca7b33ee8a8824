//! The HIL bench script (`hil/bench_check.py`, pymavlink) against the mock iNav on a
//! real pseudo-terminal: rates, the switch test and a timed test roll echoed back in
//! RC_CHANNELS, written to a report. Needs python3 with pymavlink (`.ci/run`).

mod common;

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use common::{Controls, MockAutopilot, TempDir};

#[test]
fn bench_script_measures_rates_switch_and_a_timed_roll() {
    let controls = Arc::new(Controls::default());
    controls.switch_us.store(1000, Ordering::Relaxed);
    let mock = MockAutopilot::start(controls.clone());
    let dir = TempDir::new("hil");
    let report = dir.0.join("report.json");
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/hil/bench_check.py");
    let child = std::process::Command::new("python3")
        .arg(script)
        .arg("--device")
        .arg(&mock.slave_path)
        .arg("--non-interactive")
        .arg("--report")
        .arg(&report)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("python3 is needed for the HIL script test");
    // The pilot: MANUAL for the rate check and the first switch reading, then AUTO.
    std::thread::sleep(Duration::from_secs(7));
    controls.switch_us.store(1900, Ordering::Relaxed);
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "bench script failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["heartbeat"], true);
    let att = r["rates_hz"]["ATTITUDE"].as_f64().unwrap();
    assert!((40.0..=55.0).contains(&att), "ATTITUDE at {att} Hz");
    assert_eq!(r["manual_value_us"], 1000);
    assert_eq!(r["auto_value_us"], 1900);
    let roll = &r["test_roll"];
    assert_eq!(roll["echo_seen"], true, "{roll}");
    let delay = roll["echo_delay_ms"].as_f64().unwrap();
    assert!(delay < 60.0, "echo after {delay} ms");
    let held = roll["echo_held_s"].as_f64().unwrap();
    assert!((1.4..=1.6).contains(&held), "echo held {held} s");
}
