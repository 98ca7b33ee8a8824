//! A flight made late on purpose replays exactly. On a loaded companion board a
//! pipeline window can run after an ATTITUDE frame was recorded and before its sample
//! reached the pipeline; the window log names the samples each window had, and the
//! replay feeds those. The test hook `FAITHD_TEST_LATE_ATTITUDE_US` makes that the
//! normal case (every sample 15 ms late, at the mock's 20 ms ATTITUDE), and the
//! mock's rates wobble, so a replay fed other samples than a window had would
//! derotate it otherwise.

use crate::common;

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use common::autopilot::{Controls, MockAutopilot};
use common::daemon::Daemon;
use common::recording::{Flight, flight};
use faithd_formats::tlog::TlogReader;
use mavlink::dialects::common::MavMessage;

fn json_lines(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// From the files alone: the windows that had fewer attitude samples than the .tlog
/// shows had arrived by their end, and all windows.
fn late_windows(rec: &Flight) -> (usize, usize) {
    let log = json_lines(&rec.windows);
    let clock_start_unix_us = log[0]["clock_start_unix_us"].as_i64().unwrap();
    let mut arrivals = Vec::new();
    let mut tlog = TlogReader::new(std::fs::File::open(&rec.tlog).unwrap());
    while let Some(r) = tlog.next_record().unwrap() {
        let from_autopilot = r.header.system_id == 1 && r.header.component_id == 1;
        if from_autopilot && matches!(r.message, Some(MavMessage::ATTITUDE(_))) {
            arrivals.push(r.t_unix_us as i64 - clock_start_unix_us);
        }
    }
    let late = log[1..]
        .iter()
        .filter(|w| {
            let t_us = w["t_us"].as_i64().unwrap();
            let had = w["attitude"]["to"].as_u64().expect("attitude.to") as usize;
            arrivals.partition_point(|&a| a <= t_us) > had
        })
        .count();
    (late, log.len() - 1)
}

fn replay(rec: &Flight, windows: &Path) -> (Option<i32>, String) {
    let out = common::faithd()
        .args(["replay", "--json", "--events"])
        .arg(&rec.events)
        .arg("--mavlink")
        .arg(&rec.tlog)
        .arg("--windows")
        .arg(windows)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_flight_whose_attitude_reached_the_pipeline_late_replays_exactly() {
    let controls = Controls::default();
    controls.wobble.store(true, Ordering::Relaxed);
    let mock = MockAutopilot::start(Arc::new(controls));
    let mut daemon = Daemon::start_with_env(
        &format!("serial:{}", mock.slave_path.display()),
        &mock.command_toml(),
        &[("FAITHD_TEST_LATE_ATTITUDE_US", "15000")],
    );
    // The first approach and its roll call, or at least 4 s of flight.
    mock.msp
        .wait_for(Duration::from_secs(4), |m| m.first_roll().is_some());
    std::thread::sleep(Duration::from_millis(300));
    assert!(daemon.stop().success(), "{}", daemon.log());
    assert!(
        daemon
            .log()
            .contains("test hook FAITHD_TEST_LATE_ATTITUDE_US"),
        "the journal names the hook: {}",
        daemon.log()
    );
    let rec = flight(&daemon.flights_dir());
    let (late, windows) = late_windows(&rec);
    eprintln!("measured: {late} of {windows} windows ran before attitude that had arrived");
    assert!(windows > 100, "{windows} windows logged");
    assert!(
        late * 5 > windows,
        "the hook made only {late} of {windows} windows late"
    );

    let (code, stderr) = replay(&rec, &rec.windows);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "replayed {windows} windows: every one as decided in flight"
        )),
        "{stderr}"
    );
    assert!(
        stderr.contains(&format!("{late} windows ran in flight before attitude")),
        "the replay counts the late windows as the files do: {stderr}"
    );
    let flown = json_lines(&rec.windows);
    let derotated = flown[1..].iter().filter(|w| w["derotated"] == true).count();
    assert!(
        derotated * 10 > windows * 9,
        "15 ms late is within the hold: only {derotated} of {windows} derotated"
    );

    // The same flight replayed as faithd did before windows named their samples (a
    // version-3 log: each window takes the samples whose frames were recorded before
    // it): a figure, not a verdict, since a late sample may change nothing compared.
    let old = rec.windows.with_extension("v3.jsonl");
    let mut text = String::new();
    for (k, mut line) in flown.into_iter().enumerate() {
        if k == 0 {
            line["faithd_window_log"] = 3.into();
        } else {
            line.as_object_mut().unwrap().remove("attitude");
        }
        text.push_str(&format!("{line}\n"));
    }
    std::fs::write(&old, text).unwrap();
    let (code, stderr) = replay(&rec, &old);
    eprintln!("measured: replayed by arrival stamps (exit {code:?}): {stderr}");
    assert!(
        stderr.contains("from before windows named their attitude samples"),
        "{stderr}"
    );
}
