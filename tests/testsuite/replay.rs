//! `faithd replay` on recorded files: the same events in AEDAT 4.0 (with a .tlog) and
//! in the datasets' text format (with imu.txt) replay to the same decisions as the
//! pipeline run directly, identically every time; damage is refused with its offset.

use crate::common;

use std::path::Path;

use faithd_core::camera::CameraIntrinsics;
use faithd_core::pipeline::{NoClock, Pipeline, PipelineConfig};
use faithd_core::synth::{LoomingEdges, looming_edge_events};
use faithd_formats::events::aedat4::{Aedat4Config, Aedat4Writer};
use faithd_formats::events::text::TextWriter;

fn events() -> Vec<faithd_core::event::Event> {
    let mut scene = LoomingEdges::pole_ahead((125.0, 88.0));
    scene.duration_s = 0.6;
    scene.noise_rate_hz = 0.5;
    looming_edge_events(&CameraIntrinsics::dvs240(), &scene, 5)
}

pub(crate) fn replay(args: &[&str]) -> (i32, String, String) {
    let out = crate::common::faithd()
        .arg("replay")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

fn decisions(stdout: &str) -> Vec<serde_json::Value> {
    stdout
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["decision"].clone())
        .collect()
}

pub(crate) fn write_inputs(dir: &Path) {
    let ev = events();
    let file = std::fs::File::create(dir.join("flight.aedat4")).unwrap();
    let mut w = Aedat4Writer::new(file, Aedat4Config::default()).unwrap();
    for chunk in ev.chunks(5000) {
        w.write_events(chunk).unwrap();
    }
    w.finish().unwrap();
    let mut t = TextWriter::new(std::fs::File::create(dir.join("events.txt")).unwrap());
    t.write_events(&ev).unwrap();
    t.finish().unwrap();
    // Level flight: attitude every 10 ms, in the events' time base.
    common::recording::write_level_tlog(&dir.join("flight.tlog"), 700);
    let imu: String = (0..=70u32)
        .map(|k| format!("{:.6} 0 0 9.81 0 0 0\n", f64::from(k) * 0.01))
        .collect();
    std::fs::write(dir.join("imu.txt"), imu).unwrap();
}

#[test]
fn aedat4_and_text_replay_to_the_pipelines_own_decisions_every_time() {
    let dir = common::TempDir::new("replay");
    write_inputs(&dir.0);
    let aedat = dir.0.join("flight.aedat4");
    let tlog = dir.0.join("flight.tlog");
    let args = [
        "--events",
        aedat.to_str().unwrap(),
        "--mavlink",
        tlog.to_str().unwrap(),
        "--json",
    ];
    let (code, first, err) = replay(&args);
    assert_eq!(code, 0, "{err}");
    let (_, second, _) = replay(&args);
    assert_eq!(first, second, "a recording replays identically");

    // The same pipeline run directly over the same events, window by window.
    let ev = events();
    let attitude: Vec<_> = (0..=70)
        .map(|k| faithd_core::attitude::AttitudeSample {
            t_us: k * 10_000,
            ..Default::default()
        })
        .collect();
    let mut pipeline = Pipeline::new(PipelineConfig::default());
    let mut direct = Vec::new();
    let mut end = ev[0].t_us + 10_000;
    let mut start = 0;
    while start < ev.len() {
        let stop = start + faithd_core::window::events_until(&ev[start..], end);
        let r = pipeline.process_window(&ev[start..stop], &attitude, end, &mut NoClock);
        direct.push(serde_json::to_value(r.decision).unwrap());
        start = stop;
        end += 10_000;
    }
    let replayed = decisions(&first);
    assert_eq!(replayed.len(), direct.len(), "window count");
    for (k, (a, b)) in replayed.iter().zip(&direct).enumerate() {
        assert_eq!(a, b, "window {k}");
    }
    assert!(
        replayed.iter().any(|d| d["action"]["kind"] == "roll"),
        "the approach is avoided in replay too"
    );

    let text = dir.0.join("events.txt");
    let imu = dir.0.join("imu.txt");
    let (code, text_out, err) = replay(&[
        "--events",
        text.to_str().unwrap(),
        "--imu",
        imu.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(decisions(&text_out), replayed, "text and AEDAT 4 agree");
}

#[test]
fn a_damaged_recording_is_refused_with_its_byte_offset() {
    let dir = common::TempDir::new("replay-bad");
    write_inputs(&dir.0);
    let path = dir.0.join("flight.aedat4");
    let mut bytes = std::fs::read(&path).unwrap();
    let cut = bytes.len() * 2 / 3;
    bytes.truncate(cut);
    std::fs::write(&path, &bytes).unwrap();
    let (code, _, err) = replay(&["--events", path.to_str().unwrap(), "--json"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("byte") || err.contains("offset"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// A timestamp no clock can hold used to overflow the window arithmetic: a panic in
/// debug builds, an endless loop in release. Now it is refused, naming the event.
#[test]
fn a_time_beyond_any_clock_is_refused_not_looped_on() {
    let dir = common::TempDir::new("replay-huge-time");
    let path = dir.0.join("events.txt");
    std::fs::write(&path, "0.000001 3 4 1\n9223372036854.775807 0 0 1\n").unwrap();
    let started = std::time::Instant::now();
    let (code, _, err) = replay(&["--events", path.to_str().unwrap(), "--json"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("event 1 has time 9223372036854775807 us"),
        "{err}"
    );
    assert!(started.elapsed() < std::time::Duration::from_secs(10));
}

/// The first line of a window log as the daemon writes it, with `pipeline`.
fn log_header(
    pipeline: faithd_core::pipeline::PipelineConfig,
) -> faithd_formats::window_log::WindowLogHeader {
    faithd_formats::window_log::WindowLogHeader {
        faithd_window_log: faithd_formats::window_log::WINDOW_LOG_VERSION,
        faithd_version: "0.1.0".into(),
        clock_start_unix_us: 0,
        own_system_id: 1,
        own_component_id: 191,
        autopilot_system_id: 1,
        autopilot_component_id: Some(1),
        clock_sync_window: 50,
        pipeline,
    }
}

/// A window log's header is a configuration like any other: the daemon's checks apply
/// before a replay sizes anything from it.
#[test]
fn a_crafted_window_log_header_is_refused_before_it_allocates() {
    let dir = common::TempDir::new("replay-crafted-log");
    write_inputs(&dir.0);
    let header = log_header(faithd_core::pipeline::PipelineConfig {
        max_vectors: 1_000_000_000_000,
        ..Default::default()
    });
    let log = dir.0.join("flight.windows.jsonl");
    std::fs::write(
        &log,
        format!("{}\n", serde_json::to_string(&header).unwrap()),
    )
    .unwrap();
    let events = dir.0.join("flight.aedat4");
    let (code, _, err) = replay(&[
        "--events",
        events.to_str().unwrap(),
        "--windows",
        log.to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("pipeline.max_vectors"), "{err}");
    assert!(err.contains("line 1"), "{err}");
}

/// A daemon killed (or a battery pulled) while it wrote a window line leaves that
/// line cut short at the end of the log: replay goes up to the line before and says
/// so. The same damage anywhere else is still refused with its line number.
#[test]
fn a_window_log_cut_short_by_a_kill_replays_up_to_its_last_whole_line() {
    let dir = common::TempDir::new("replay-torn-log");
    write_inputs(&dir.0);
    let header = log_header(faithd_core::pipeline::PipelineConfig::default());
    let header = serde_json::to_string(&header).unwrap();
    let events = dir.0.join("flight.aedat4");
    let log = dir.0.join("flight.windows.jsonl");
    let run = |text: &str| {
        std::fs::write(&log, text).unwrap();
        replay(&[
            "--events",
            events.to_str().unwrap(),
            "--windows",
            log.to_str().unwrap(),
        ])
    };
    let (code, _, err) = run(&format!("{header}\n{{\"t_us\":12"));
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("cut short"), "{err}");
    let (code, _, err) = run(&format!("{header}\n{{\"t_us\":12\n{{\"t_us\":13}}\n"));
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("line 2"), "{err}");
}

/// A long replay shows how far it has got on a terminal: with its standard error on
/// a pseudo-terminal and its windows' lines going to a file, the terminal sees the
/// count of windows replayed; the file gets the lines and nothing of the bar.
#[test]
fn a_replay_counts_its_windows_on_a_terminal_and_not_in_its_output() {
    use std::io::Read;
    let dir = common::TempDir::new("replay-progress");
    write_inputs(&dir.0);
    let aedat = dir.0.join("flight.aedat4");
    let pty = nix::pty::openpty(None, None).unwrap();
    let child = crate::common::faithd()
        .args(["replay", "--events", aedat.to_str().unwrap()])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::from(pty.slave))
        .spawn()
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success());
    // The child has exited and its end of the terminal is closed: read what it drew.
    let mut terminal = Vec::new();
    let mut master = std::fs::File::from(pty.master);
    let mut buf = [0u8; 4096];
    loop {
        match master.read(&mut buf) {
            Ok(0) | Err(_) => break,
            Ok(n) => terminal.extend_from_slice(&buf[..n]),
        }
    }
    let terminal = String::from_utf8_lossy(&terminal);
    assert!(terminal.contains("windows replayed"), "{terminal:?}");
    let lines = String::from_utf8(out.stdout).unwrap();
    assert!(lines.lines().count() > 30, "{lines}");
    assert!(!lines.contains("windows replayed") && !lines.contains('\r'));
}
