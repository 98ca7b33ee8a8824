//! `faithd sim` and `faithd demo` as a user runs them: the same seed gives the same
//! JSON, byte for byte, however many flights fly at once and whatever else the
//! machine is doing; a pipe gets lines, never a progress bar.

use std::process::{Command, Output};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

fn faithd(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_faithd"))
        .args(args)
        .output()
        .expect("run faithd")
}

/// Keeps every core busy until dropped.
struct Load {
    stop: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
}

impl Load {
    fn start() -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let cores = std::thread::available_parallelism().map_or(2, |n| n.get());
        let threads = (0..cores)
            .map(|_| {
                let stop = stop.clone();
                std::thread::spawn(move || {
                    let mut x = 1u64;
                    while !stop.load(Ordering::Relaxed) {
                        x = std::hint::black_box(x.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ 7);
                    }
                })
            })
            .collect();
        Self { stop, threads }
    }
}

impl Drop for Load {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

#[test]
fn the_same_seed_gives_the_same_json_at_any_parallelism_and_load() {
    let _cpu = crate::common::cpu::heavy();
    let dir = tempfile::tempdir().unwrap();
    let plot = dir.path().join("outcome.png");
    let plot_arg = plot.to_str().unwrap();
    let args = [
        "sim", "--runs", "3", "--seed", "5", "--json", "--plot", plot_arg,
    ];
    let alone = faithd(&[&args[..], &["--threads", "1"]].concat());
    assert!(
        alone.status.success(),
        "{}",
        String::from_utf8_lossy(&alone.stderr)
    );
    let loaded = {
        let _load = Load::start();
        faithd(&[&args[..], &["--threads", "3"]].concat())
    };
    assert!(loaded.status.success());
    assert_eq!(
        String::from_utf8_lossy(&alone.stdout),
        String::from_utf8_lossy(&loaded.stdout)
    );
    let summary: serde_json::Value = serde_json::from_slice(&alone.stdout).unwrap();
    assert_eq!(summary["runs"], 3);
    assert_eq!(summary["camera"], "dvs");
    assert_eq!(summary["compute"], "model");
    assert!(summary["cycles"].as_u64().unwrap() > 600, "{summary}");
    // The published keys are still there.
    for key in [
        "collision_courses",
        "avoided",
        "near_passes",
        "false_avoidances",
        "success_rate",
        "latency_ms_p50",
        "latency_ms_p99",
        "seed",
        "ttc_at_decision_s_p50",
    ] {
        assert!(summary.get(key).is_some(), "{key} missing: {summary}");
    }
    // The outcome picture: a PNG of the plot's size.
    let png = std::fs::read(&plot).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let width = u32::from_be_bytes(png[16..20].try_into().unwrap());
    let height = u32::from_be_bytes(png[20..24].try_into().unwrap());
    assert_eq!((width, height), (900, 520));
    // Piped, the log is lines: one per flight and the timing, no bar.
    let log = String::from_utf8_lossy(&alone.stderr);
    assert!(!log.contains('\r') && !log.contains("\u{1b}["), "{log:?}");
    assert_eq!(
        log.lines().filter(|l| l.starts_with('[')).count(),
        3,
        "{log}"
    );
}

#[test]
fn the_demo_flies_on_the_atom_board_and_reports_its_cycles() {
    let _cpu = crate::common::cpu::heavy();
    let out = faithd(&[
        "demo",
        "--json",
        "--cpu-scale",
        "atom",
        "--plot",
        "/dev/null",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let o: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(o["spec"]["camera"], "dvs");
    assert_eq!(o["spec"]["scene"], "arena");
    let cycles = o["pipeline"]["cycles"].as_u64().unwrap();
    assert!(cycles > 200, "{o}");
    // Seven times this machine's compute: a median cycle of several milliseconds.
    assert!(
        o["pipeline"]["charged_us_p50"].as_f64().unwrap() > 3000.0,
        "{o}"
    );
}

#[test]
fn a_bad_cpu_scale_is_refused_with_the_reason() {
    let _cpu = crate::common::cpu::heavy();
    let out = faithd(&["sim", "--cpu-scale", "fast"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("neither a number nor `atom`"), "{err}");
    let out = faithd(&["demo", "--cpu-scale", "0"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("0.01 to 100"));
}

/// `faithd sim --autopilot inav-sitl` needs iNav's SITL: without one it says where
/// to get it and flies nothing; a path that names no file is refused with the path.
#[test]
fn inav_in_the_loop_without_its_sitl_is_refused_with_where_to_get_it() {
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_faithd"))
            .args(args)
            .env_remove("INAV_SITL")
            .output()
            .expect("run faithd")
    };
    let out = run(&["sim", "--autopilot", "inav-sitl", "--runs", "1"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--inav-sitl PATH or INAV_SITL"), "{err}");
    assert!(!err.contains("flight 1"), "{err}");
    let out = run(&[
        "sim",
        "--autopilot",
        "inav-sitl",
        "--inav-sitl",
        "/nonexistent/inav_SITL",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("/nonexistent/inav_SITL: no such file"),
        "{err}"
    );
    // The link is how faithd reads iNav's SITL: the model has none.
    let out = run(&["sim", "--link", "msp", "--runs", "1"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--link") && err.contains("--autopilot inav-sitl"),
        "{err}"
    );
    assert!(!err.contains("flight 1"), "{err}");
}

/// The README's first command, as a new user runs it: the summary on standard output,
/// and a journal of the gate, the manoeuvre and the daemon's start and stop, not a
/// line per window (350 of them once buried the summary above the fold).
#[test]
fn the_demo_prints_its_summary_and_a_journal_without_a_line_per_window() {
    let _cpu = crate::common::cpu::heavy();
    let dir = crate::common::TempDir::new("demo-output");
    let out = Command::new(env!("CARGO_BIN_EXE_faithd"))
        .args(["demo", "--plot"])
        .arg(dir.0.join("demo.png"))
        .env_remove("RUST_LOG")
        .output()
        .expect("run faithd");
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{stderr}");
    assert!(
        stdout.starts_with("faithd demo: closed-loop flight at a pole\n"),
        "{stdout}"
    );
    assert!(stdout.contains("\n  result: "), "{stdout}");
    assert_eq!(
        stderr.matches("decision:").count(),
        0,
        "per-window decisions in the demo's journal:\n{stderr}"
    );
    assert!(stderr.contains("manoeuvre started"), "{stderr}");
    assert!(stderr.contains("safety gate open"), "{stderr}");
    assert!(
        stderr.lines().count() < 80,
        "{} journal lines:\n{stderr}",
        stderr.lines().count()
    );
}

/// `bench pipeline --camera`: the streams at the camera's size, and the figures that
/// say whether the pipeline kept up (no timing is asserted: the machine is shared).
#[test]
fn bench_pipeline_runs_at_a_cameras_size_and_reports_whether_it_kept_up() {
    let _cpu = crate::common::cpu::heavy();
    let run = |args: &[&str]| {
        let out = faithd(&[&["bench", "pipeline", "--seconds", "0.05", "--json"], args].concat());
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let davis = run(&["--events-per-s", "200000"]);
    assert_eq!(davis["camera"], "davis240");
    assert_eq!(
        (davis["width_px"].as_u64(), davis["height_px"].as_u64()),
        (Some(240), Some(180))
    );
    let dvx = run(&["--camera", "dvxplorer", "--events-per-s", "200000,400000"]);
    assert_eq!(dvx["camera"], "dvxplorer");
    assert_eq!(
        (dvx["width_px"].as_u64(), dvx["height_px"].as_u64()),
        (Some(640), Some(480))
    );
    assert_eq!(
        (dvx["period_us"].as_i64(), dvx["budget_us"].as_i64()),
        (Some(10_000), Some(8_000))
    );
    let streams = dvx["streams"].as_array().unwrap();
    assert_eq!(streams.len(), 2, "{dvx}");
    for key in [
        "window_us_p50",
        "window_us_p99",
        "stages_us",
        "overruns",
        "shed_windows",
        "max_load_level",
        "late_windows",
        "backlog_us_max",
        "take_us_p50",
        "take_us_p99",
        "flow_events_per_window_p50",
        "capped_windows",
        "events_per_window_p50",
    ] {
        assert!(
            streams[0]["report"].get(key).is_some(),
            "{key} missing: {dvx}"
        );
    }
    // The scene's edges are multiplied to about the rate asked for, whatever the camera.
    let rate = streams[1]["report"]["events_per_s"].as_f64().unwrap();
    assert!((300_000.0..500_000.0).contains(&rate), "{rate}");
}

/// A window over the event cap keeps that many of its events, and says so.
#[test]
fn bench_pipeline_reports_the_windows_over_the_event_cap() {
    let _cpu = crate::common::cpu::heavy();
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("faithd.toml");
    std::fs::write(&config, "[pipeline.flow]\nmax_events_per_window = 5000\n").unwrap();
    let out = faithd(&[
        "bench",
        "pipeline",
        "--camera",
        "dvxplorer",
        "--events-per-s",
        "2000000",
        "--seconds",
        "0.05",
        "--config",
        config.to_str().unwrap(),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let o: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let report = &o["streams"][0]["report"];
    assert_eq!(
        report["flow_events_per_window_p50"].as_f64(),
        Some(5000.0),
        "{o}"
    );
    let (capped, windows) = (
        report["capped_windows"].as_u64().unwrap(),
        report["windows"].as_u64().unwrap(),
    );
    // Every window but the stream's short last one holds about 20,000 events.
    assert!(capped + 1 >= windows && capped > 0, "{o}");
}

/// `--camera` takes the presets' names; any other is refused with them.
#[test]
fn a_bad_camera_is_refused_with_the_cameras_there_are() {
    for args in [
        &["bench", "pipeline", "--camera", "dvs640"][..],
        &["bench", "foe", "--camera", "davis640"][..],
    ] {
        let out = faithd(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("the cameras are davis240, davis346, dvxplorer, dvxplorer-lite"),
            "{args:?}: {err}"
        );
        assert!(out.stdout.is_empty(), "{args:?}");
    }
}

/// `bench foe --attitude-link`: the report names the link derotation's rates came
/// over and gives the rotating flights' errors apart; a wrong link is refused with
/// the links there are.
#[test]
fn bench_foe_derotates_with_the_link_asked_for() {
    let _cpu = crate::common::cpu::heavy();
    let dir = tempfile::tempdir().unwrap();
    let out = faithd(&[
        "bench",
        "foe",
        "--attitude-link",
        "msp",
        "--rotation",
        "--trajectories",
        "3",
        "--json",
        "--plot-dir",
        dir.path().to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let o: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(o["attitude_link"], "msp");
    assert_eq!(o["rotating_trajectories"].as_u64(), Some(1));
    assert!(o["per_trajectory"][2]["rotating"].as_bool().unwrap(), "{o}");
    assert!(
        o["methods"][0]["rotating_mean_error_deg"]
            .as_f64()
            .is_some(),
        "{o}"
    );
    let bad = faithd(&["bench", "foe", "--attitude-link", "crsf"]);
    assert_eq!(bad.status.code(), Some(2));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("the links are imu, mavlink, msp"), "{err}");
    assert!(bad.stdout.is_empty());
}

/// `bench foe --camera`: the same flights rendered at the camera's size.
#[test]
fn bench_foe_flies_the_camera_asked_for() {
    let _cpu = crate::common::cpu::heavy();
    let dir = tempfile::tempdir().unwrap();
    let out = faithd(&[
        "bench",
        "foe",
        "--camera",
        "dvxplorer-lite",
        "--trajectories",
        "1",
        "--max-vectors",
        "3000",
        "--json",
        "--plot-dir",
        dir.path().to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let o: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(o["camera"], "dvxplorer-lite");
    assert_eq!(
        (o["width_px"].as_u64(), o["height_px"].as_u64()),
        (Some(320), Some(240))
    );
    assert_eq!(o["max_vectors"].as_u64(), Some(3000));
    assert_eq!(
        (o["trajectories"].as_u64(), o["seed"].as_u64()),
        (Some(1), Some(1))
    );
    let names: Vec<&str> = o["methods"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names[0], "faith", "{o}");
    assert!(o["methods"][0]["mean_error_deg"].as_f64().is_some(), "{o}");
}
