//! `faithd replay` refuses or names what it cannot trust: attitude on another clock,
//! an empty attitude file, one that covers part of the flight, a bad number; and each
//! window says honestly whether its flow was derotated. Each replays on every core
//! it gets (under qemu, an emulated one), so none runs beside a timed test.

use crate::common;
use crate::replay::{replay, write_inputs};

use std::path::Path;

fn lines(stdout: &str) -> Vec<serde_json::Value> {
    stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// An imu.txt of level flight every 10 ms from `from_s` for `count` samples.
fn write_imu(path: &Path, from_s: f64, count: u32) {
    let imu: String = (0..count)
        .map(|k| format!("{:.6} 0 0 9.81 0 0 0\n", from_s + f64::from(k) * 0.01))
        .collect();
    std::fs::write(path, imu).unwrap();
}

fn replay_imu(dir: &Path, imu: &Path, extra: &[&str]) -> (i32, String, String) {
    let events = dir.join("events.txt");
    let mut args = vec![
        "--events",
        events.to_str().unwrap(),
        "--imu",
        imu.to_str().unwrap(),
        "--json",
    ];
    args.extend_from_slice(extra);
    replay(&args)
}

#[test]
fn attitude_on_another_clock_is_refused_with_both_spans_and_the_shift_that_fixes_it() {
    let _cpu = common::cpu::heavy();
    let dir = common::TempDir::new("replay-other-clock");
    write_inputs(&dir.0);
    let imu = dir.0.join("late-imu.txt");
    write_imu(&imu, 1000.0, 71);
    let (code, out, err) = replay_imu(&dir.0, &imu, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(out.is_empty(), "nothing replayed: {out}");
    assert!(err.contains("do not overlap"), "{err}");
    assert!(err.contains("1000.000000 s to 1000.700000 s"), "{err}");
    let shift = err
        .split("--attitude-offset-us ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .unwrap_or_else(|| panic!("no offset named: {err}"));
    let shift_us: i64 = shift.parse().unwrap();
    assert!((-1_000_000_000..=-999_900_000).contains(&shift_us), "{err}");

    // The shift it names puts the attitude on the events: every window derotated.
    let (code, out, err) = replay_imu(&dir.0, &imu, &["--attitude-offset-us", shift]);
    assert_eq!(code, 0, "{err}");
    let windows = lines(&out);
    assert!(windows.len() > 50);
    assert!(
        windows
            .iter()
            .all(|w| w["derotated"] == true && w["derotation"] == "applied"),
        "{out}"
    );
}

#[test]
fn an_attitude_file_without_samples_is_refused() {
    let _cpu = common::cpu::heavy();
    let dir = common::TempDir::new("replay-empty-imu");
    write_inputs(&dir.0);
    let imu = dir.0.join("empty-imu.txt");
    std::fs::write(&imu, "# t ax ay az gx gy gz\n\n").unwrap();
    let (code, out, err) = replay_imu(&dir.0, &imu, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(out.is_empty());
    assert!(
        err.contains("empty-imu.txt: holds no attitude samples"),
        "{err}"
    );

    let tlog = dir.0.join("empty.tlog");
    std::fs::write(&tlog, b"").unwrap();
    let events = dir.0.join("flight.aedat4");
    let (code, _, err) = replay(&[
        "--events",
        events.to_str().unwrap(),
        "--mavlink",
        tlog.to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("empty.tlog: holds no attitude samples"),
        "{err}"
    );
}

/// Attitude for the first 0.3 s of a 0.6 s flight: the replay runs, says how much
/// is covered and which windows went without derotation, and those windows say so.
#[test]
fn attitude_that_covers_part_of_the_flight_is_named_window_by_window() {
    let _cpu = common::cpu::heavy();
    let dir = common::TempDir::new("replay-part-imu");
    write_inputs(&dir.0);
    let imu = dir.0.join("half-imu.txt");
    write_imu(&imu, 0.0, 31);
    let (code, out, err) = replay_imu(&dir.0, &imu, &[]);
    assert_eq!(code, 0, "{err}");
    let windows = lines(&out);
    let missed: Vec<&serde_json::Value> =
        windows.iter().filter(|w| w["derotated"] == false).collect();
    assert!(!missed.is_empty() && missed.len() < windows.len(), "{out}");
    assert!(missed.iter().all(|w| w["derotation"] == "not_covered"));
    // Past 0.3 s plus the 100 ms hold, and nowhere before.
    let first_missed = missed[0]["t_us"].as_i64().unwrap();
    assert!(
        (400_000..=420_000).contains(&first_missed),
        "{first_missed}"
    );
    assert!(
        windows
            .iter()
            .filter(|w| w["t_us"].as_i64().unwrap() < 400_000)
            .all(|w| w["derotated"] == true)
    );
    assert!(
        err.contains(&format!(
            "{} of {} windows ran without derotation",
            missed.len(),
            windows.len()
        )),
        "{err}"
    );
    let last_missed = missed.last().unwrap()["t_us"].as_i64().unwrap();
    assert!(
        err.contains(&format!(
            "{} windows from {first_missed} us to {last_missed} us",
            missed.len()
        )),
        "{err}"
    );
    let covers: f64 = err
        .split("covers ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("no share: {err}"));
    assert!((45.0..=55.0).contains(&covers), "{err}");

    // Attitude from 0.3 s on: the first windows, before it less the hold, go without.
    write_imu(&imu, 0.3, 41);
    let (code, out, err) = replay_imu(&dir.0, &imu, &[]);
    assert_eq!(code, 0, "{err}");
    let windows = lines(&out);
    let first_derotated = windows.iter().position(|w| w["derotated"] == true).unwrap();
    assert!(
        first_derotated > 0
            && windows[..first_derotated]
                .iter()
                .all(|w| w["derotation"] == "not_covered")
    );
    assert!(
        err.contains(&format!(
            "{first_derotated} of {} windows ran without derotation",
            windows.len()
        )),
        "{err}"
    );
}

#[test]
fn a_bad_number_is_refused_with_its_line_column_and_field() {
    let _cpu = common::cpu::heavy();
    let dir = common::TempDir::new("replay-nan-imu");
    write_inputs(&dir.0);
    let imu = dir.0.join("nan-imu.txt");
    std::fs::write(
        &imu,
        "0.00 0 0 9.81 0 0 0\n0.01 0 0 9.81 0 0 0\n0.02 0 0 9.81 nan 0 0\n",
    )
    .unwrap();
    let (code, _, err) = replay_imu(&dir.0, &imu, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("nan-imu.txt, line 3: column 15 (gx): `nan` is not a finite number"),
        "{err}"
    );
    std::fs::write(&imu, "0.00 0 0 9.81 0 0 0\n0.01 0 0 9,81 0 0 0\n").unwrap();
    let (code, _, err) = replay_imu(&dir.0, &imu, &[]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("line 2: column 10 (az): `9,81` is not a number"),
        "{err}"
    );
    std::fs::write(&imu, "0.00 0 0 9.81 0 0\n").unwrap();
    let (_, _, err) = replay_imu(&dir.0, &imu, &[]);
    assert!(err.contains("line 1: expected 7 numbers"), "{err}");
}

/// Without attitude the replay runs with derotation off, and no window claims to be
/// derotated.
#[test]
fn without_attitude_no_window_says_derotated() {
    let _cpu = common::cpu::heavy();
    let dir = common::TempDir::new("replay-no-imu");
    write_inputs(&dir.0);
    let events = dir.0.join("events.txt");
    let (code, out, err) = replay(&["--events", events.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("derotation is off"), "{err}");
    let windows = lines(&out);
    assert!(windows.len() > 50);
    assert!(
        windows
            .iter()
            .all(|w| w["derotated"] == false && w["derotation"] == "off"),
        "{out}"
    );
}
