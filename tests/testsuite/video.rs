//! Flight videos (`--video`): a replay and a simulated flight written as an animated
//! GIF, PNG frames and MP4, read back by decoders (ffprobe for the MP4) and checked
//! by their pixels: a frame per window, the FOE's cross where the pipeline put it,
//! the roll on the time bar from the window that called for it, the gate's colours
//! and the true FOE of a simulated flight. An MP4 without ffmpeg is refused.

#![cfg(feature = "sim")]

use crate::common;

use std::path::Path;
use std::process::{Command, Output};

use faithd::video::canvas::{self, Canvas};
use faithd::video::time_bar::{self, TimeBar};
use faithd::video::{TimeSpan, View};
use faithd_core::camera::CameraIntrinsics;
use faithd_core::pipeline::PipelineConfig;
use faithd_core::synth::{LoomingEdges, looming_edge_events};
use faithd_formats::events::aedat4::{Aedat4Config, Aedat4Writer};
use plotters::style::RGBColor;

/// A 0.6 s approach to a pole dead ahead (events as AEDAT 4, level attitude as a
/// .tlog): the replay rolls on it part way.
fn write_recording(dir: &Path) {
    let mut scene = LoomingEdges::pole_ahead((125.0, 88.0));
    scene.duration_s = 0.6;
    scene.noise_rate_hz = 0.5;
    let events = looming_edge_events(&CameraIntrinsics::dvs240(), &scene, 5);
    let file = std::fs::File::create(dir.join("flight.aedat4")).unwrap();
    let mut w = Aedat4Writer::new(file, Aedat4Config::default()).unwrap();
    for chunk in events.chunks(5000) {
        w.write_events(chunk).unwrap();
    }
    w.finish().unwrap();
    common::recording::write_level_tlog(&dir.join("flight.tlog"), 700);
}

fn faithd(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_faithd"))
        .args(args)
        .output()
        .unwrap()
}

fn ok(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{stderr}");
    stderr
}

/// `faithd replay --json` of the recording in `dir` with `extra` arguments: every
/// window's JSON line.
fn replay(dir: &Path, extra: &[&str]) -> Vec<serde_json::Value> {
    let (events, tlog) = (dir.join("flight.aedat4"), dir.join("flight.tlog"));
    let mut args = vec![
        "replay",
        "--json",
        "--events",
        events.to_str().unwrap(),
        "--mavlink",
        tlog.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let out = faithd(&args);
    ok(&out);
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// Every frame of an animated GIF, as RGB.
fn gif_frames(path: &Path) -> Vec<Canvas> {
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::RGBA);
    let mut decoder = options
        .read_info(std::fs::File::open(path).unwrap())
        .unwrap();
    let mut frames = Vec::new();
    while let Some(frame) = decoder.read_next_frame().unwrap() {
        let mut canvas = Canvas::new(u32::from(frame.width), u32::from(frame.height));
        for (rgb, rgba) in canvas
            .rgb
            .chunks_exact_mut(3)
            .zip(frame.buffer.chunks_exact(4))
        {
            rgb.copy_from_slice(&rgba[..3]);
        }
        frames.push(canvas);
    }
    frames
}

fn png_frame(path: &Path) -> Canvas {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut canvas = Canvas::new(reader.info().width, reader.info().height);
    assert_eq!(reader.info().color_type, png::ColorType::Rgb);
    reader.next_frame(&mut canvas.rgb).unwrap();
    canvas
}

fn close(a: RGBColor, b: RGBColor) -> bool {
    [(a.0, b.0), (a.1, b.1), (a.2, b.2)]
        .iter()
        .all(|&(x, y)| x.abs_diff(y) <= 12)
}

/// The pixels of `colour` in the rectangle from `(x0, y0)` to `(x1, y1)`
/// (exclusive): how many, and their centroid.
fn find(
    frame: &Canvas,
    colour: RGBColor,
    (x0, y0): (u32, u32),
    (x1, y1): (u32, u32),
) -> (usize, (f64, f64)) {
    let mut n = 0;
    let (mut sx, mut sy) = (0.0, 0.0);
    for y in y0..y1.min(frame.height) {
        for x in x0..x1.min(frame.width) {
            if close(frame.pixel(x, y), colour) {
                n += 1;
                sx += f64::from(x);
                sy += f64::from(y);
            }
        }
    }
    (n, (sx / n.max(1) as f64, sy / n.max(1) as f64))
}

/// Pixels of `colour` along the middle row of a time bar lane (`rows` in the bar).
fn in_lane(frame: &Canvas, rows: (i64, i64), colour: RGBColor) -> usize {
    let y = frame.height - time_bar::HEIGHT + ((rows.0 + rows.1) / 2) as u32;
    find(frame, colour, (0, y), (frame.width, y + 1)).0
}

fn is_roll(window: &serde_json::Value) -> bool {
    window["decision"]["action"]["kind"] == "roll"
}

#[test]
fn a_replay_becomes_a_gif_with_a_frame_per_window_showing_its_foe_and_roll() {
    let _cpu = crate::common::cpu::heavy();
    let dir = common::TempDir::new("video-gif");
    write_recording(&dir.0);
    let gif_path = dir.0.join("flight.gif");
    let windows = replay(&dir.0, &["--video", gif_path.to_str().unwrap()]);
    let frames = gif_frames(&gif_path);
    assert_eq!(frames.len(), windows.len(), "a frame per window");
    let view = View::of(&PipelineConfig::default());
    let (view_w, view_h) = view.size();
    for f in &frames {
        assert_eq!((f.width, f.height), (frames[0].width, frames[0].height));
    }
    assert!(frames[0].width > view_w && frames[0].height > view_h + time_bar::HEIGHT);

    // The FOE's yellow cross is centred where the window put the FOE.
    let mut checked = 0;
    for (w, f) in windows.iter().zip(&frames) {
        let (Some(x), Some(y)) = (w["foe"]["x_px"].as_f64(), w["foe"]["y_px"].as_f64()) else {
            continue;
        };
        let (n, (cx, cy)) = find(f, canvas::FOE_ESTIMATED, (0, 0), (view_w, view_h));
        let (ex, ey) = view.at(x, y);
        assert!(n > 40, "window {}: {n} FOE pixels", w["t_us"]);
        assert!(
            (cx - f64::from(ex)).abs() < 3.0 && (cy - f64::from(ey)).abs() < 3.0,
            "window {}: FOE drawn about ({cx:.1}, {cy:.1}), at ({ex}, {ey})",
            w["t_us"]
        );
        checked += 1;
    }
    assert!(checked > windows.len() / 2, "{checked} windows with an FOE");

    // The roll appears on the time bar with the first window that calls for it and
    // stays; a replay knows no gate (grey, never green or red).
    let first_roll = windows.iter().position(is_roll).expect("the replay rolls");
    assert!(first_roll > 0);
    let roll_rows = TimeBar::roll_rows();
    for (k, f) in frames.iter().enumerate() {
        let roll = in_lane(f, roll_rows, canvas::ROLL);
        assert_eq!(roll > 0, k >= first_roll, "frame {k}: {roll} roll pixels");
        assert_eq!(in_lane(f, TimeBar::gate_rows(), canvas::GATE_OPEN), 0);
        assert_eq!(in_lane(f, TimeBar::gate_rows(), canvas::GATE_CLOSED), 0);
        // No true FOE without a simulator.
        assert_eq!(find(f, canvas::FOE_TRUE, (0, 0), (view_w, view_h)).0, 0);
    }
}

#[test]
fn png_frames_are_the_same_pictures_one_file_a_window() {
    let _cpu = crate::common::cpu::heavy();
    let dir = common::TempDir::new("video-png");
    write_recording(&dir.0);
    let frames_dir = dir.0.join("frames");
    let frames_arg = format!("{}/", frames_dir.display());
    let windows = replay(&dir.0, &["--video", &frames_arg, "--video-speed", "0.1"]);
    let mut names: Vec<_> = std::fs::read_dir(&frames_dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names.len(), windows.len());
    assert_eq!(names[0], "frame-00001.png");
    let k = windows.iter().position(is_roll).unwrap();
    let frame = png_frame(&frames_dir.join(&names[k]));
    let view = View::of(&PipelineConfig::default());
    let (x, y) = (
        windows[k]["foe"]["x_px"].as_f64().unwrap(),
        windows[k]["foe"]["y_px"].as_f64().unwrap(),
    );
    let (view_w, view_h) = view.size();
    let (_, (cx, cy)) = find(&frame, canvas::FOE_ESTIMATED, (0, 0), (view_w, view_h));
    let (ex, ey) = view.at(x, y);
    assert!((cx - f64::from(ex)).abs() < 3.0 && (cy - f64::from(ey)).abs() < 3.0);
    // The window that rolls draws its obstacle's box in the roll's colour.
    assert!(find(&frame, canvas::ROLL, (0, 0), (view_w, view_h)).0 > 100);
}

#[test]
fn a_simulated_flight_films_the_gate_the_roll_on_inav_and_the_true_foe() {
    let _cpu = crate::common::cpu::heavy();
    let dir = common::TempDir::new("video-demo");
    let gif_path = dir.0.join("demo.gif");
    let plot = dir.0.join("flight.png");
    let out = faithd(&[
        "demo",
        "--camera",
        "line",
        "--json",
        "--plot",
        plot.to_str().unwrap(),
        "--video",
        gif_path.to_str().unwrap(),
    ]);
    let stderr = ok(&out);
    let outcome: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let decision_s = outcome["decision_s"].as_f64().expect("the demo rolls");
    let frames = gif_frames(&gif_path);
    assert!(
        stderr.contains(&format!("({} frames of", frames.len())),
        "{stderr}"
    );
    // The flight, not the daemon's lead-in: 3.25 s at 100 windows a second.
    assert!(
        (300..=340).contains(&frames.len()),
        "{} frames",
        frames.len()
    );

    let gate = TimeBar::gate_rows();
    let roll = TimeBar::roll_rows();
    let early = &frames[30];
    let last = frames.last().unwrap();
    // The pilot's switch goes to AUTO 0.5 s in: closed first, open later.
    assert!(in_lane(early, gate, canvas::GATE_CLOSED) > 0);
    assert_eq!(in_lane(early, gate, canvas::GATE_OPEN), 0);
    assert!(in_lane(last, gate, canvas::GATE_OPEN) > 0);
    // iNav's roll: none before the decision, on the bar after it.
    let decided = (decision_s * 100.0) as usize;
    assert_eq!(in_lane(&frames[decided - 5], roll, canvas::ROLL), 0);
    assert!(in_lane(&frames[decided + 20], roll, canvas::ROLL) > 0);
    assert!(in_lane(last, roll, canvas::ROLL) > 0);
    // The true FOE's green ring is in the picture.
    let (view_w, view_h) = View::of(&PipelineConfig::default()).size();
    assert!(find(&frames[50], canvas::FOE_TRUE, (0, 0), (view_w, view_h)).0 > 40);
}

#[test]
fn an_mp4_has_every_window_for_ffprobe() {
    let _cpu = crate::common::cpu::heavy();
    let have = |tool: &str| {
        Command::new(tool)
            .arg("-version")
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if !(have("ffmpeg") && have("ffprobe")) {
        eprintln!("skipped: no ffmpeg/ffprobe (apt install ffmpeg)");
        return;
    }
    let dir = common::TempDir::new("video-mp4");
    write_recording(&dir.0);
    let mp4 = dir.0.join("flight.mp4");
    let windows = replay(&dir.0, &["--video", mp4.to_str().unwrap()]);
    let out = Command::new("ffprobe")
        .args(["-v", "error", "-count_frames", "-select_streams", "v:0"])
        .args(["-show_entries", "stream=nb_read_frames,width,height"])
        .args(["-of", "csv=p=0"])
        .arg(&mp4)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let probed = String::from_utf8(out.stdout).unwrap();
    let fields: Vec<u64> = probed
        .trim()
        .split(',')
        .map(|f| f.parse().unwrap())
        .collect();
    let renderer_size = faithd::video::render::Renderer::new(
        View::of(&PipelineConfig::default()),
        String::new(),
        TimeSpan {
            start_us: 0,
            end_us: 1,
        },
    )
    .unwrap()
    .size();
    assert_eq!(
        fields,
        [
            u64::from(renderer_size.0),
            u64::from(renderer_size.1),
            windows.len() as u64
        ],
        "ffprobe: {probed}"
    );
}

#[test]
fn an_mp4_without_ffmpeg_is_refused_before_anything_is_flown_or_drawn() {
    let _cpu = crate::common::cpu::heavy();
    let dir = common::TempDir::new("video-no-ffmpeg");
    write_recording(&dir.0);
    let empty = dir.0.join("no-tools");
    std::fs::create_dir(&empty).unwrap();
    let mp4 = dir.0.join("flight.mp4");
    for args in [
        vec!["demo", "--camera", "line", "--video", mp4.to_str().unwrap()],
        vec![
            "replay",
            "--events",
            dir.0.join("flight.aedat4").to_str().unwrap(),
            "--video",
            mp4.to_str().unwrap(),
        ],
    ] {
        let started = std::time::Instant::now();
        let out = Command::new(env!("CARGO_BIN_EXE_faithd"))
            .args(&args)
            .env("PATH", &empty)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains("ffmpeg") && stderr.contains("apt install ffmpeg"),
            "{stderr}"
        );
        assert!(stderr.contains(".gif"), "{stderr}");
        assert!(!mp4.exists());
        assert!(started.elapsed().as_secs_f64() < 1.0, "refused at once");
    }
}
