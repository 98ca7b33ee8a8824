use std::path::Path;
use std::time::Duration;

use mavlink::MavHeader;
use mavlink::dialects::common::{ATTITUDE_DATA, MavMessage};

use super::*;
use faithd_core::event::Polarity;
use faithd_formats::events::aedat4::Aedat4Reader;
use faithd_formats::events::{EventReader, read_all};

fn header(width_px: u16, height_px: u16) -> WindowLogHeader {
    let mut pipeline = faithd_core::pipeline::PipelineConfig::default();
    pipeline.camera.width_px = width_px;
    pipeline.camera.height_px = height_px;
    WindowLogHeader {
        faithd_window_log: faithd_formats::window_log::WINDOW_LOG_VERSION,
        faithd_version: "test".into(),
        clock_start_unix_us: 0,
        own_system_id: 1,
        own_component_id: 191,
        autopilot_system_id: 1,
        autopilot_component_id: Some(1),
        clock_sync_window: 1,
        pipeline,
    }
}

fn config(dir: &Path, max_file_bytes: u64, max_total_bytes: u64) -> RecordConfig {
    RecordConfig {
        enabled: true,
        dir: dir.to_path_buf(),
        max_file_bytes,
        max_total_bytes,
        max_queue_bytes: 8 * 1024 * 1024,
        sync_interval_ms: 50,
    }
}

fn attitude(t_unix_us: u64) -> Item {
    Item::Mavlink(Box::new(MavlinkRecord {
        t_unix_us,
        header: MavHeader::default(),
        msg: MavMessage::ATTITUDE(ATTITUDE_DATA::default()),
    }))
}

fn finish(recorder: &Recorder) -> Counts {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap()
        .block_on(recorder.finish())
        .expect("the recorder closes its files")
}

/// Bytes of the recorder's files in `dir`, and their names.
fn on_disk(dir: &Path) -> (u64, Vec<String>) {
    let mut names = Vec::new();
    let mut total = 0;
    for e in std::fs::read_dir(dir).unwrap() {
        let e = e.unwrap();
        let name = e.file_name().to_string_lossy().into_owned();
        if stem::is_recording(&name) {
            total += e.metadata().unwrap().len();
            names.push(name);
        }
    }
    names.sort();
    (total, names)
}

#[test]
fn the_queue_is_bounded_in_bytes_and_counts_what_it_drops() {
    // A recorder whose disk never answers: nothing leaves the queue.
    let (tx, _rx) = std::sync::mpsc::channel();
    let recorder = Recorder {
        tx,
        max_queue_bytes: 1024 * 1024,
        stats: Arc::new(Stats::default()),
    };
    let batch = || Item::Events(vec![Event::new(0, 1, 1, Polarity::On); 2000]);
    let per_batch = batch().queued_bytes();
    assert!(per_batch >= 2000 * 16, "{per_batch}");
    for _ in 0..1000 {
        recorder.send(batch());
        recorder.send(Item::Window("x".repeat(200)));
        assert!(recorder.queued_bytes() <= 1024 * 1024);
    }
    let counts = recorder.stats().counts();
    let queued = 1024 * 1024 / per_batch;
    // At most `queued` batches fit; every other batch was dropped and counted.
    assert!(counts.dropped_queue_full >= 1000 - queued, "{counts:?}");
    assert!(recorder.queued_bytes() > 1024 * 1024 - per_batch);
}

#[test]
fn the_budget_holds_at_all_times_for_a_flight_without_camera() {
    // Only MAVLink and windows, as with no camera or a static scene: both rotate and
    // the oldest parts go, and the directory never holds more than the budget.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("flight-1-001.tlog"), vec![0u8; 100_000]).unwrap();
    let (max_file, max_total) = (64 * 1024, 256 * 1024);
    let recorder = start(&config(dir.path(), max_file, max_total), &header(240, 180)).unwrap();
    let mut max_seen = 0;
    for k in 0..20_000u64 {
        recorder.send(attitude(k));
        recorder.send(Item::Window(format!(
            "{{\"t_us\":{k},\"pad\":\"{}\"}}",
            "y".repeat(150)
        )));
        if k % 500 == 0 {
            // Let the writer catch up (this test is about the budget, not about how
            // fast a loaded machine writes): then nothing is dropped for a full queue.
            let deadline = std::time::Instant::now() + Duration::from_secs(10);
            while recorder.queued_bytes() > 0 && std::time::Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(1));
            }
            max_seen = max_seen.max(on_disk(dir.path()).0);
        }
    }
    let counts = finish(&recorder);
    let (total, names) = on_disk(dir.path());
    assert!(max_seen <= max_total, "{max_seen} > {max_total}");
    assert!(total <= max_total, "{total} > {max_total}: {names:?}");
    assert_eq!(counts.mavlink_written, 20_000, "{counts}");
    assert_eq!(counts.windows_written, 20_000, "{counts}");
    assert_eq!(counts.losses(), 0, "{counts}");
    assert!(counts.files_deleted > 10, "{counts}");
    assert!(
        !names.contains(&"flight-1-001.tlog".to_string()),
        "{names:?}"
    );
    // Parts rotate: the newest windows are in the last part, each part within its size.
    let last_window = names
        .iter()
        .rfind(|n| n.ends_with(".windows.jsonl"))
        .unwrap();
    assert!(!last_window.ends_with("-001.windows.jsonl"), "{names:?}");
    let text = std::fs::read_to_string(dir.path().join(last_window)).unwrap();
    assert!(text.starts_with("{\"faithd_window_log\""), "header first");
    assert!(text.trim_end().ends_with("\"}"), "whole lines");
    assert!(text.contains("\"t_us\":19999,"));
    for name in &names {
        let len = std::fs::metadata(dir.path().join(name)).unwrap().len();
        assert!(len <= max_file, "{name}: {len}");
    }
}

#[test]
fn bad_events_are_skipped_and_the_configured_sensor_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let recorder = start(&config(dir.path(), 1 << 20, 1 << 24), &header(346, 260)).unwrap();
    recorder.send(Item::Events(vec![
        Event::new(10, 300, 250, Polarity::On),
        Event::new(20, 346, 10, Polarity::On), // off the sensor
        Event::new(30, 5, 5, Polarity::Off),
    ]));
    recorder.send(Item::Events(vec![
        Event::new(25, 6, 6, Polarity::On), // back in time
        Event::new(40, 7, 7, Polarity::On),
    ]));
    let counts = finish(&recorder);
    assert_eq!(counts.bad_events, 2, "{counts}");
    assert_eq!(counts.events_written, 3, "{counts}");
    let (_, names) = on_disk(dir.path());
    let path = dir
        .path()
        .join(names.iter().find(|n| n.ends_with(".aedat4")).unwrap());
    let mut reader = Aedat4Reader::new(std::fs::File::open(path).unwrap()).unwrap();
    let stream = &reader.streams()[0];
    assert_eq!((stream.width_px, stream.height_px), (Some(346), Some(260)));
    let events = read_all(&mut reader as &mut dyn EventReader).unwrap();
    let times: Vec<i64> = events.iter().map(|e| e.t_us).collect();
    assert_eq!(times, [10, 30, 40]);
}

#[test]
fn two_flights_in_the_same_second_never_share_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), 1 << 20, 1 << 24);
    let first = start(&cfg, &header(240, 180)).unwrap();
    first.send(attitude(1));
    first.send(Item::Window("{\"flight\":1}".into()));
    finish(&first);
    let (_, before) = on_disk(dir.path());
    let sizes: Vec<u64> = before
        .iter()
        .map(|n| std::fs::metadata(dir.path().join(n)).unwrap().len())
        .collect();
    // The clock of a board without RTC restores the same second: simulate it by
    // choosing the stem the first flight had.
    let stem_first = before[0].rsplit_once('-').unwrap().0.to_string();
    assert_eq!(
        stem::choose(dir.path(), stem_first["flight-".len()..].parse().unwrap()),
        format!("{stem_first}_2")
    );
    let second = start(&cfg, &header(240, 180)).unwrap();
    second.send(attitude(2));
    second.send(Item::Window("{\"flight\":2}".into()));
    finish(&second);
    for (name, size) in before.iter().zip(sizes) {
        let now = std::fs::metadata(dir.path().join(name)).unwrap().len();
        assert_eq!(now, size, "{name} changed");
    }
    assert_eq!(on_disk(dir.path()).1.len(), 2 * before.len());
}
