//! Real DAVIS240C recordings (the Event Camera Dataset's slices kept beside the project
//! in `../shared/real-events/`, not in it: see its README) through every event reader
//! faithd has and through the whole pipeline: real sensor noise, real event rates and
//! real edges, where the generated scenes of the other tests have none.
//!
//! Each recording is read from its text file, written by faithd's own writers as AEDAT
//! 2.0, AEDAT 3.1, AEDAT 4.0 (uncompressed, LZ4, zstd) and text, and read back through
//! each reader and through the live camera's reader (the events laid out in libcaer's
//! polarity packets): the same events every time. Each file then goes through `faithd
//! replay`'s own path: the same windows from every format, no panic, normal flow at
//! speeds a hand-held or slider-mounted camera gives, vectors in every window after the
//! first. slider_depth has truth: its camera translates along its +x axis, so the focus
//! of expansion lies at infinity to the right, and FAITH says so in 16 of the 17
//! windows with at least 40 vectors.
//!
//! When `../shared/real-events/` is absent each test says so in one line and passes.

use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};

use faithd::replay::{AttitudeInput, replay};
use faithd_core::camera::CameraIntrinsics;
use faithd_core::event::{Event, Polarity};
use faithd_core::foe::{FoeEstimate, Side};
use faithd_core::pipeline::PipelineConfig;
use faithd_formats::events::aedat2::Aedat2Writer;
use faithd_formats::events::aedat3::Aedat3Writer;
use faithd_formats::events::aedat4::{Aedat4Config, Aedat4Writer, Compression};
use faithd_formats::events::text::TextWriter;
use faithd_formats::events::{Format, detect_format, open_events, open_reader, read_all};

/// The recordings and how many events each holds (their README).
pub(crate) const RECORDINGS: [(&str, usize); 9] = [
    ("davis240c/boxes_rotation", 30_000),
    ("davis240c/boxes_translation", 30_000),
    ("davis240c/dynamic_rotation", 30_000),
    ("davis240c/dynamic_translation", 30_000),
    ("davis240c/poster_rotation", 30_000),
    ("davis240c/poster_translation", 30_000),
    ("davis240c/shapes_rotation", 30_000),
    ("davis240c/shapes_translation", 30_000),
    ("slider_depth", 50_000),
];

/// `daemon.period_us`: the windows `faithd replay` cuts by default.
const WINDOW_US: i64 = 10_000;

/// The recordings' directory, or `None` (and one line on the real standard error,
/// which the harness does not capture) when it is not beside the project.
pub(crate) fn real_events() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/real-events");
    if dir.join("slider_depth/events.txt").is_file() {
        Some(dir)
    } else {
        let _ = writeln!(
            std::io::stderr(),
            "skipped: {} is absent (real DAVIS240C recordings kept beside the project)",
            dir.display()
        );
        None
    }
}

/// The recording's pinhole intrinsics from its calib.txt (`fx fy cx cy k1 k2 p1 p2
/// k3`; the events are not undistorted, and neither is anything here).
pub(crate) fn intrinsics(dir: &Path) -> CameraIntrinsics {
    let text = std::fs::read_to_string(dir.join("calib.txt")).unwrap();
    let v: Vec<f64> = text
        .split_whitespace()
        .map(|s| s.parse().unwrap())
        .collect();
    CameraIntrinsics {
        width_px: 240,
        height_px: 180,
        fx_px: v[0],
        fy_px: v[1],
        cx_px: v[2],
        cy_px: v[3],
    }
}

fn text_events(dir: &Path) -> Vec<Event> {
    let mut reader = open_events(dir.join("events.txt")).unwrap();
    assert_eq!(reader.format(), Format::Text);
    read_all(&mut *reader).unwrap()
}

/// The recording in every format faithd writes, by name, as faithd's writers make them.
fn every_format(events: &[Event]) -> Vec<(&'static str, Vec<u8>)> {
    let mut out = Vec::new();
    let mut w = Aedat2Writer::new(Vec::new()).unwrap();
    w.write_events(events).unwrap();
    out.push(("aedat2", w.finish().unwrap()));
    let mut w = Aedat3Writer::new(Vec::new()).unwrap();
    w.write_events(events).unwrap();
    out.push(("aedat3", w.finish().unwrap()));
    for (name, compression) in [
        ("aedat4", Compression::None),
        ("aedat4-lz4", Compression::Lz4),
        ("aedat4-zstd", Compression::Zstd),
    ] {
        let config = Aedat4Config {
            compression,
            ..Aedat4Config::default()
        };
        let mut w = Aedat4Writer::new(Cursor::new(Vec::new()), config).unwrap();
        // As the recorder writes them: one batch per camera container (about 1 ms).
        for batch in events.chunk_by(|a, b| a.t_us / 1_000 == b.t_us / 1_000) {
            w.write_events(batch).unwrap();
        }
        out.push((name, w.finish().unwrap().into_inner()));
    }
    let mut w = TextWriter::new(Vec::new());
    w.write_events(events).unwrap();
    out.push(("text", w.finish().unwrap()));
    out
}

/// The events as libcaer hands them to the live camera's reader: polarity packets of
/// at most 4096 events (libcaer's DAVIS packet size), the time's upper bits in the
/// header's overflow counter, every 7th event doubled as an invalid one to be skipped.
fn through_libcaer_packets(events: &[Event]) -> Vec<Event> {
    let mut out = Vec::new();
    for chunk in events.chunks(2048) {
        let overflow = (chunk[0].t_us >> 31) as i32;
        let mut words: Vec<(u32, i32)> = Vec::new();
        for (k, e) in chunk.iter().enumerate() {
            assert_eq!(e.t_us >> 31, i64::from(overflow), "one overflow per packet");
            let data = u32::from(e.x_px) << 17
                | u32::from(e.y_px) << 2
                | u32::from(e.polarity == Polarity::On) << 1;
            let ts = (e.t_us & 0x7FFF_FFFF) as i32;
            if k % 7 == 3 {
                words.push((data ^ 0x0002_0000, ts));
            }
            words.push((data | 1, ts));
        }
        let capacity = 4096;
        assert!(words.len() <= capacity);
        let mut packet = vec![0u8; libcaer_sys::PACKET_HEADER_BYTES + 8 * capacity];
        let header: [i32; 6] = [
            8,
            4,
            overflow,
            capacity as i32,
            words.len() as i32,
            chunk.len() as i32,
        ];
        packet[..2].copy_from_slice(&libcaer_sys::POLARITY_EVENT.to_le_bytes());
        packet[2..4].copy_from_slice(&1i16.to_le_bytes());
        for (k, v) in header.iter().enumerate() {
            packet[4 + 4 * k..8 + 4 * k].copy_from_slice(&v.to_le_bytes());
        }
        for (k, (data, ts)) in words.iter().enumerate() {
            let at = libcaer_sys::PACKET_HEADER_BYTES + 8 * k;
            packet[at..at + 4].copy_from_slice(&data.to_le_bytes());
            packet[at + 4..at + 8].copy_from_slice(&ts.to_le_bytes());
        }
        let mut read = Vec::new();
        // libcaer-sys's reader of libcaer's packet memory is `unsafe` by its FFI nature.
        #[allow(unsafe_code)]
        // SAFETY: a whole packet (header and capacity) in memory we own.
        let whole = unsafe { libcaer_sys::read_polarity_packet(packet.as_mut_ptr(), &mut read) };
        assert!(whole);
        out.extend(
            read.iter()
                .map(|p| Event::new(p.t_us, p.x, p.y, Polarity::from_bool(p.on))),
        );
    }
    out
}

#[test]
fn every_reader_reads_every_real_recording_event_for_event() {
    let Some(root) = real_events() else { return };
    for (name, count) in RECORDINGS {
        let events = text_events(&root.join(name));
        assert_eq!(events.len(), count, "{name}");
        assert!(
            events.iter().all(|e| e.x_px < 240 && e.y_px < 180),
            "{name}: an event off the DAVIS240's array"
        );
        assert!(
            events.is_sorted_by_key(|e| e.t_us),
            "{name}: time goes back"
        );
        for (format, bytes) in every_format(&events) {
            let detected = detect_format(&bytes).unwrap();
            let mut reader = open_reader(Cursor::new(bytes), detected).unwrap();
            assert_eq!(
                read_all(&mut *reader).unwrap(),
                events,
                "{name} through {format} ({detected:?})"
            );
        }
        assert_eq!(
            through_libcaer_packets(&events),
            events,
            "{name} through libcaer's packets"
        );
    }
}

/// What a test keeps of one replayed window.
#[derive(Clone, Debug, PartialEq)]
struct Window {
    events: usize,
    vectors: usize,
    foe: FoeEstimate,
    /// Median normal-flow speed, px/s (0 without vectors).
    median_speed_px_s: f64,
    /// Median horizontal flow component, px/s.
    median_u_px_s: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// `faithd replay`'s own path over `path` with the recording's intrinsics, no
/// attitude (derotation off), `daemon.period_us` windows.
fn replay_windows(path: &Path, camera: CameraIntrinsics) -> (Vec<Window>, String) {
    let config = PipelineConfig {
        camera,
        ..PipelineConfig::default()
    };
    let mut windows = Vec::new();
    let mut watch = |events: &[Event], report: &faithd_core::pipeline::WindowReport<'_>| {
        windows.push(Window {
            events: events.len(),
            vectors: report.vectors.len(),
            foe: report.foe,
            median_speed_px_s: median(
                report
                    .vectors
                    .iter()
                    .map(|v| v.u_px_s.hypot(v.v_px_s))
                    .collect(),
            ),
            median_u_px_s: median(report.vectors.iter().map(|v| v.u_px_s).collect()),
        });
        Ok(())
    };
    let mut lines = Vec::new();
    let n = replay(
        path,
        AttitudeInput::None,
        config,
        WINDOW_US,
        true,
        &mut lines,
        &mut watch,
    )
    .unwrap()
    .windows;
    assert_eq!(n, windows.len());
    (windows, String::from_utf8(lines).unwrap())
}

#[test]
fn the_pipeline_runs_on_every_real_recording_in_every_format() {
    let Some(root) = real_events() else { return };
    let scratch = tempfile::tempdir().unwrap();
    let mut report = String::new();
    for (name, count) in RECORDINGS {
        let dir = root.join(name);
        let camera = intrinsics(&dir);
        let (windows, lines) = replay_windows(&dir.join("events.txt"), camera);
        let events = text_events(&dir);
        let span_us = events.last().unwrap().t_us - events[0].t_us;
        // Windows end at the first event + k * 10 ms, the last one past the last event.
        assert_eq!(
            windows.len() as i64,
            span_us / WINDOW_US + 1,
            "{name}: {windows:?}"
        );
        assert_eq!(windows.iter().map(|w| w.events).sum::<usize>(), count);
        // The first window starts on an empty surface of active events; every later
        // one has flow, at speeds a hand-held or slider camera gives its edges (normal
        // flow, which is never faster than the edge itself).
        for (k, w) in windows.iter().enumerate().skip(1) {
            assert!(w.vectors >= 40, "{name} window {k}: {w:?}");
            assert!(
                (50.0..3_000.0).contains(&w.median_speed_px_s),
                "{name} window {k}: {w:?}"
            );
            assert!(
                !matches!(w.foe, FoeEstimate::Insufficient { .. }),
                "{name} window {k}: {w:?}"
            );
        }
        // The same windows from every format faithd reads, through its streaming
        // readers from files, as `faithd replay --events FILE` reads them.
        for (format, bytes) in every_format(&events) {
            let file = scratch.path().join(format!(
                "{}.{}",
                name.replace('/', "-"),
                if format == "text" { "txt" } else { "aedat" }
            ));
            std::fs::write(&file, bytes).unwrap();
            let (again, again_lines) = replay_windows(&file, camera);
            assert_eq!(again, windows, "{name} as {format}");
            assert_eq!(again_lines, lines, "{name} as {format}");
        }
        let speeds: Vec<String> = windows
            .iter()
            .map(|w| format!("{:.0}", w.median_speed_px_s))
            .collect();
        report.push_str(&format!(
            "{name}: {} windows, vectors {:?}, median speeds {:?} px/s\n",
            windows.len(),
            windows.iter().map(|w| w.vectors).collect::<Vec<_>>(),
            speeds
        ));
    }
    let _ = std::io::stderr().write_all(report.as_bytes());
}

/// slider_depth: a camera on a linear slider translating along its +x axis at about
/// 0.3 m/s, without rotation. Its focus of expansion lies at infinity on the right,
/// and the static scene flows left. Measured with `faithd replay --events
/// .../slider_depth/events.txt` and the slider's intrinsics: 18 windows, 17 with at
/// least 40 vectors, 16 of them unbounded to the right (the other, the second window
/// with 44 vectors, a point near the right edge).
#[test]
fn slider_depth_has_its_focus_of_expansion_beyond_the_right_edge() {
    let Some(root) = real_events() else { return };
    let dir = root.join("slider_depth");
    let camera = intrinsics(&dir);
    assert!((camera.fx_px - 335.4).abs() < 0.1, "the slider's own lens");
    let (windows, _) = replay_windows(&dir.join("events.txt"), camera);
    assert_eq!(windows.len(), 18);
    let enough: Vec<&Window> = windows.iter().filter(|w| w.vectors >= 40).collect();
    assert_eq!(enough.len(), 17, "{windows:?}");
    let right = enough
        .iter()
        .filter(|w| {
            matches!(
                w.foe,
                FoeEstimate::Unbounded {
                    side: Side::Right,
                    ..
                }
            )
        })
        .count();
    assert!(right >= 16, "{right} of 17 unbounded right: {windows:?}");
    for w in &enough {
        // Translating right: the scene's edges move left across the image, at about
        // fx * 0.3 m/s / depth: 100 px/s for a scene a metre away (fx 335 px).
        assert!(w.median_u_px_s < 0.0, "{w:?}");
        assert!((50.0..300.0).contains(&w.median_speed_px_s), "{w:?}");
    }
    let _ = writeln!(
        std::io::stderr(),
        "slider_depth: {right} of {} windows with >= 40 vectors unbounded right; median speeds {:?} px/s",
        enough.len(),
        enough
            .iter()
            .map(|w| w.median_speed_px_s.round())
            .collect::<Vec<_>>()
    );
}
