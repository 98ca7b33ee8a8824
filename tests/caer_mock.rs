//! The libcaer adapter against the C mock of libcaer (built as a shared library by
//! libcaer-sys's `mock` feature, a dev-dependency) and loaded at run time exactly as
//! libcaer is: real FFI calls, real packet memory, a scripted disconnect, a settable
//! sensor size, and a device clock paced in real time with settable drift and latency.

use std::sync::{Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

use faithd::clock::DaemonClock;
use faithd::source::caer::{CameraError, Ended, SensorSize, SessionError, run, serve_device};
use faithd_core::event::Polarity;
use libcaer_sys::Libcaer;
use libcaer_sys::mock::{LIBRARY, Script};

const DVS240: SensorSize = SensorSize {
    width_px: 240,
    height_px: 180,
};

fn mock() -> (Libcaer, Script) {
    (
        Libcaer::load(Some(LIBRARY)).expect("the mock libcaer loads"),
        Script::load(),
    )
}

/// The mock is one global device: one test at a time.
static DEVICE: Mutex<()> = Mutex::new(());

/// Takes the device; a test that failed holding it leaves it usable (every test
/// scripts it afresh), so one failure does not fail the rest.
fn device() -> MutexGuard<'static, ()> {
    DEVICE.lock().unwrap_or_else(PoisonError::into_inner)
}

#[test]
fn a_session_streams_valid_events_applies_settings_and_reports_the_loss() {
    let _device = device();
    let (lib, script) = mock();
    unsafe { (script.set)(50, 0) };
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    let clock = DaemonClock::start();
    let ended = serve_device(&lib, &[(5, 0, 1), (5, 3, 42)], DVS240, clock, &tx).unwrap();
    assert_eq!(ended, Ended::DeviceLost);
    assert_eq!(unsafe { (script.config_value)(5, 3) }, 42);
    assert_eq!(
        unsafe { (script.config_value)(-2, 1) },
        1,
        "blocking mode set"
    );
    let batches: Vec<_> = rx.try_iter().collect();
    assert_eq!(batches.len(), 50);
    for (k, b) in batches.iter().enumerate() {
        assert_eq!(b.len(), 180, "the invalid event is skipped");
        assert!(
            b.iter()
                .all(|e| e.x_px as usize == k && e.polarity == Polarity::On)
        );
        assert_eq!(b.iter().map(|e| e.y_px).max(), Some(179));
    }
    // Device time 1 ms per container, on the daemon clock: never backwards, never
    // stretched beyond the device's 49 ms, never after the session ended.
    let times: Vec<i64> = batches.iter().flatten().map(|e| e.t_us).collect();
    assert!(times.is_sorted(), "time went backwards");
    let dt = batches[49][0].t_us - batches[0][0].t_us;
    assert!(dt <= 49_000, "{dt}");
    assert!(*times.last().unwrap() <= clock.now_us());
}

#[test]
fn the_source_reopens_the_camera_when_it_returns_and_stops_with_the_pipeline() {
    let _device = device();
    let (lib, script) = mock();
    unsafe { (script.set)(20, 3) };
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    let source = std::thread::spawn(move || {
        run(
            &lib,
            Vec::new(),
            DVS240,
            DaemonClock::start(),
            tx,
            Duration::from_millis(100),
        )
    });
    let mut events = 0;
    let deadline = Instant::now() + Duration::from_secs(5);
    while events < 30 * 180 && Instant::now() < deadline {
        if let Ok(b) = rx.recv_timeout(Duration::from_millis(100)) {
            events += b.len();
        }
    }
    assert!(
        events >= 30 * 180,
        "only {events} events: the camera did not come back"
    );
    // One open, three refused while it was gone, one that found it again.
    assert_eq!(unsafe { (script.open_attempts)() }, 5);
    drop(rx);
    assert_eq!(source.join().unwrap(), Ok(()));
}

#[test]
fn a_camera_of_another_size_is_refused_for_good_with_what_to_change() {
    let _device = device();
    let (lib, script) = mock();
    unsafe {
        // 50 containers a session: a source that took the camera returns soon.
        (script.set)(50, 0);
        (script.sensor)(346, 260);
    }
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    let clock = DaemonClock::start();
    let davis346 = SensorSize {
        width_px: 346,
        height_px: 260,
    };
    let mismatch = CameraError::SizeMismatch {
        camera: davis346,
        configured: DVS240,
    };
    assert_eq!(
        serve_device(&lib, &[], DVS240, clock, &tx),
        Err(SessionError::Refused(mismatch.clone()))
    );
    assert!(
        rx.try_recv().is_err(),
        "not one event from the wrong camera"
    );
    // The source stops instead of reopening the camera forever (a thread of its own,
    // with its own handle on the same mock, so that a source that never stops fails
    // the test instead of hanging it).
    let (done_tx, done_rx) = std::sync::mpsc::channel();
    let source_lib = Libcaer::load(Some(LIBRARY)).unwrap();
    std::thread::spawn(move || {
        let result = run(
            &source_lib,
            Vec::new(),
            DVS240,
            clock,
            tx,
            Duration::from_millis(100),
        );
        let _ = done_tx.send(result);
    });
    let result = done_rx
        .recv_timeout(Duration::from_secs(5))
        .expect("the source keeps running with the wrong camera");
    assert_eq!(result, Err(mismatch.clone()));
    assert_eq!(
        unsafe { (script.open_attempts)() },
        2,
        "one open each, no retry"
    );
    assert!(rx.try_recv().is_err());
    assert_eq!(
        mismatch.to_string(),
        "camera is 346x260 px but pipeline.camera is 240x180 px: set pipeline.camera.width_px/height_px (and the intrinsics) for this camera, or connect the DVS240"
    );
    // The same camera configured as what it is streams.
    unsafe { (script.set)(5, 0) };
    unsafe { (script.sensor)(346, 260) };
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    assert_eq!(
        serve_device(&lib, &[], davis346, clock, &tx),
        Ok(Ended::DeviceLost)
    );
    assert_eq!(rx.try_iter().count(), 5);
}

/// A device clock 2 % slow and 0.2 to 3 ms of USB latency per container, for 2.5 s:
/// the events' daemon times follow when they really happened (the mock knows), to
/// within a few milliseconds once a second of drift has been seen. The offset fixed at
/// the first event would be 20 ms off after that second, and 50 ms at the end.
#[test]
fn event_times_follow_a_drifting_device_clock_through_usb_latency() {
    let _device = device();
    let (lib, script) = mock();
    unsafe {
        (script.set)(2_500, 0);
        (script.clock)(0.98, 200, 3_000);
    }
    let (tx, rx) = std::sync::mpsc::sync_channel(10_000);
    // The daemon clock's zero on CLOCK_MONOTONIC, to within the two readings.
    let before_us = unsafe { (script.now_us)() };
    let clock = DaemonClock::start();
    let after_us = unsafe { (script.now_us)() };
    let zero_us = (before_us + after_us) / 2;
    assert!(after_us - before_us < 200);
    let ended = serve_device(&lib, &[], DVS240, clock, &tx).unwrap();
    assert_eq!(ended, Ended::DeviceLost);
    let batches: Vec<_> = rx.try_iter().collect();
    assert_eq!(batches.len(), 2_500, "none dropped");
    let mut previous_us = i64::MIN;
    let mut worst_us = 0;
    for (k, batch) in batches.iter().enumerate() {
        for e in batch {
            // Container k holds device times k ms + row us (the mock's stream).
            let device_us = k as i64 * 1_000 + i64::from(e.y_px);
            let truth_us = unsafe { (script.true_host_us)(device_us) } - zero_us;
            assert!(
                e.t_us >= previous_us,
                "time went backwards in container {k}"
            );
            previous_us = e.t_us;
            if device_us >= 1_000_000 {
                worst_us = worst_us.max((e.t_us - truth_us).abs());
            }
        }
    }
    assert!(worst_us < 3_000, "event times off by up to {worst_us} us");
}
