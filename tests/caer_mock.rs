//! The libcaer adapter against the C mock of libcaer (built as a shared library by
//! libcaer-sys's `mock` feature, a dev-dependency) and loaded at run time exactly as
//! libcaer is: real FFI calls, real packet memory, a scripted disconnect.

use std::sync::Mutex;
use std::time::{Duration, Instant};

use faithd::daemon::clock::DaemonClock;
use faithd::event::Polarity;
use faithd::source::caer::{Ended, run, serve_device};
use libcaer_sys::Libcaer;
use libcaer_sys::mock::{LIBRARY, Script};

fn mock() -> (Libcaer, Script) {
    (
        Libcaer::load(Some(LIBRARY)).expect("the mock libcaer loads"),
        Script::load(),
    )
}

/// The mock is one global device: one test at a time.
static DEVICE: Mutex<()> = Mutex::new(());

#[test]
fn a_session_streams_valid_events_applies_settings_and_reports_the_loss() {
    let _device = DEVICE.lock().unwrap();
    let (lib, script) = mock();
    unsafe { (script.set)(50, 0) };
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    let clock = DaemonClock::start();
    let ended = serve_device(&lib, &[(5, 0, 1), (5, 3, 42)], clock, &tx).unwrap();
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
    // Device time 1 ms per container, mapped onto the daemon clock at the first event.
    let dt = batches[49][0].t_us - batches[0][0].t_us;
    assert_eq!(dt, 49_000);
}

#[test]
fn the_source_reopens_the_camera_when_it_returns_and_stops_with_the_pipeline() {
    let _device = DEVICE.lock().unwrap();
    let (lib, script) = mock();
    unsafe { (script.set)(20, 3) };
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    let source = std::thread::spawn(move || {
        run(
            &lib,
            Vec::new(),
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
    source.join().unwrap();
}
