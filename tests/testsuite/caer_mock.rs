//! The libcaer adapter against the C mock of libcaer (built as a shared library by
//! libcaer-sys's `mock` feature, a dev-dependency) and loaded at run time exactly as
//! libcaer is: real FFI calls, real packet memory laid out as libcaer 3.x lays it out
//! (packed containers of four slots, NULLs, special, frame and IMU packets between the
//! polarity ones), a scripted disconnect announced from another thread, a blocking
//! DataGet that gives up after about a second, unknown settings refused, DataStop on
//! a device never started aborting the process (libcaer would crash there), a settable
//! sensor size, and a device clock paced in real time with settable drift and latency.

// Calls into libcaer (the mock, or the real library) and reads the memory it
// hands over: foreign code, so `unsafe`, each block with why it holds.
#![allow(unsafe_code)]

use crate::common;

use std::sync::{Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

use faithd::clock::DaemonClock;
use faithd::shutdown::Shutdown;
use faithd::source::CaerDevice;
use faithd::source::SourceIo;
use faithd::source::caer::{
    Camera, CameraError, Ended, RetryTiming, SensorSize, SessionError, Setting, no_camera, run,
    serve_device,
};
use faithd_core::event::{Event, Polarity};
use libcaer_sys::mock::{
    COUNT_CLOSES, COUNT_SHUTDOWN_CALLS, COUNT_STARTS, COUNT_STOPS, FAIL_DATA_START,
    FAIL_DEFAULT_CONFIG, FAIL_INFO, LIBRARY, QUEUED_AFTER_UNPLUG, Script, UNUSABLE_BUSY,
    UNUSABLE_PERMISSION, UNUSABLE_VERSION,
};
use libcaer_sys::{
    Container, FRAME_EVENT, IMU6_EVENT, INLINE_IN_LIBCAER, Libcaer, POLARITY_EVENT, SPECIAL_EVENT,
};

const DVS240: SensorSize = SensorSize {
    width_px: 240,
    height_px: 180,
};

/// The DAVIS240 configured, with these settings.
fn davis240(settings: &[Setting]) -> Camera {
    Camera {
        device: CaerDevice::Davis240,
        settings: settings.to_vec(),
        expected: DVS240,
    }
}

/// A camera thread's side of a run nobody stops: the test ends it through the
/// pipeline's end of the channel, or through the mock's script.
fn io(clock: DaemonClock, batches: &std::sync::mpsc::SyncSender<Vec<Event>>) -> SourceIo {
    SourceIo {
        clock,
        batches: batches.clone(),
        stop: Shutdown::new().handle(),
    }
}

/// Retries from `first_ms`, doubling up to 100 ms: a test's camera returns quickly.
fn retry_ms(first_ms: u64) -> RetryTiming {
    RetryTiming {
        first: Duration::from_millis(first_ms.min(50)),
        longest: Duration::from_millis(first_ms),
    }
}

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
    script.set(50, 0);
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    let clock = DaemonClock::start();
    let ended = serve_device(
        &lib,
        &davis240(&[(5, 1, 24575), (5, 3, 42)]),
        &io(clock, &tx),
    )
    .unwrap();
    assert_eq!(ended, Ended::DeviceLost);
    assert_eq!(script.config_value(5, 3), 42);
    assert_eq!(
        script.config_value(-2, 1),
        0,
        "non-blocking: the camera thread waits between reads where it hears a stop"
    );
    let batches: Vec<_> = rx.try_iter().collect();
    assert_eq!(
        batches.len(),
        50 + QUEUED_AFTER_UNPLUG,
        "the containers queued when it went away are delivered too"
    );
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
    script.set(20, 3);
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    let source = std::thread::spawn(move || {
        run(
            &lib,
            &davis240(&[]),
            &io(DaemonClock::start(), &tx),
            retry_ms(100),
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
    assert_eq!(script.open_attempts(), 5);
    drop(rx);
    assert_eq!(source.join().unwrap(), Ok(()));
}

#[test]
fn a_camera_of_another_size_is_refused_for_good_with_what_to_change() {
    let _device = device();
    let (lib, script) = mock();
    // 50 containers a session: a source that took the camera returns soon.
    script.set(50, 0);
    script.sensor(346, 260);
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    let clock = DaemonClock::start();
    let davis346 = SensorSize {
        width_px: 346,
        height_px: 260,
    };
    let mismatch = CameraError::OtherCamera {
        found: "DAVIS346",
        size: davis346,
        configured: CaerDevice::Davis240,
    };
    assert_eq!(
        serve_device(&lib, &davis240(&[]), &io(clock, &tx)),
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
        let result = run(&source_lib, &davis240(&[]), &io(clock, &tx), retry_ms(100));
        let _ = done_tx.send(result);
    });
    let result = done_rx
        .recv_timeout(Duration::from_secs(5))
        .expect("the source keeps running with the wrong camera");
    assert_eq!(result, Err(mismatch.clone()));
    assert_eq!(script.open_attempts(), 2, "one open each, no retry");
    assert!(rx.try_recv().is_err());
    assert_eq!(
        mismatch.to_string(),
        "camera is a DAVIS346 (346x260 px) but source.device is \"davis240\": set source.device for this camera (\"davis240\", \"davis346\" or \"dvxplorer\") and pipeline.camera for its size"
    );
    // The same camera configured as what it is streams.
    script.set(5, 0);
    script.sensor(346, 260);
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    assert_eq!(
        serve_device(
            &lib,
            &Camera {
                device: CaerDevice::Davis346,
                settings: Vec::new(),
                expected: davis346
            },
            &io(clock, &tx)
        ),
        Ok(Ended::DeviceLost)
    );
    assert_eq!(rx.try_iter().count(), 5 + QUEUED_AFTER_UNPLUG);
}

/// A device clock 2 % slow and 0.2 to 3 ms of USB latency per container, for 2.5 s:
/// the events' daemon times follow when they really happened (the mock knows), to
/// within a few milliseconds once a second of drift has been seen. The offset fixed at
/// the first event would be 20 ms off after that second, and 50 ms at the end.
#[test]
fn event_times_follow_a_drifting_device_clock_through_usb_latency() {
    let _cpu = crate::common::cpu::timed();
    let _device = device();
    let (lib, script) = mock();
    script.set(2_500, 0);
    script.clock(0.98, 200, 3_000);
    let (tx, rx) = std::sync::mpsc::sync_channel(10_000);
    // The daemon clock's zero on CLOCK_MONOTONIC, to within the two readings.
    let before_us = script.now_us();
    let clock = DaemonClock::start();
    let after_us = script.now_us();
    let zero_us = (before_us + after_us) / 2;
    assert!(after_us - before_us < 200);
    let ended = serve_device(&lib, &davis240(&[]), &io(clock, &tx)).unwrap();
    assert_eq!(ended, Ended::DeviceLost);
    let batches: Vec<_> = rx.try_iter().collect();
    assert_eq!(batches.len(), 2_500 + QUEUED_AFTER_UNPLUG, "none dropped");
    let mut previous_us = i64::MIN;
    let mut worst_us = 0;
    for (k, batch) in batches.iter().enumerate() {
        for e in batch {
            // Container k holds device times k ms + row us (the mock's stream).
            let device_us = k as i64 * 1_000 + i64::from(e.y_px);
            let truth_us = script.true_host_us(device_us) - zero_us;
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

/// (DataStarts that succeeded, DataStops, Closes) since the script was set.
fn lifecycle(script: &Script) -> (i32, i32, i32) {
    (
        script.count(COUNT_STARTS),
        script.count(COUNT_STOPS),
        script.count(COUNT_CLOSES),
    )
}

/// Every way a session can refuse or fail before streaming closes the device and
/// never calls caerDeviceDataStop on it unless caerDeviceDataStart succeeded: the mock
/// aborts the whole test binary on such a call, as libcaer crashes on it
/// (`the_mock_aborts_on_data_stop_of_a_device_never_started` shows it does).
#[test]
fn every_refusal_path_closes_the_device_and_stops_only_what_was_started() {
    let _device = device();
    let (lib, script) = mock();
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    let session = |settings: &[(i8, u8, u32)]| {
        serve_device(&lib, &davis240(settings), &io(DaemonClock::start(), &tx))
    };

    // A DAVIS346 where a DVS240 is configured.
    script.set(50, 0);
    script.sensor(346, 260);
    assert!(matches!(
        session(&[]),
        Err(SessionError::Refused(CameraError::OtherCamera { .. }))
    ));
    assert_eq!(lifecycle(&script), (0, 0, 1), "size mismatch");

    // A camera that does not report its DVS size.
    script.set(50, 0);
    script.fail(FAIL_INFO);
    assert_eq!(
        session(&[]),
        Err(SessionError::Retry(
            "the camera did not report its DVS size".into()
        ))
    );
    assert_eq!(lifecycle(&script), (0, 0, 1), "no DVS size");

    // libcaer's default configuration refused.
    script.set(50, 0);
    script.fail(FAIL_DEFAULT_CONFIG);
    assert_eq!(
        session(&[]),
        Err(SessionError::Retry("default configuration refused".into()))
    );
    assert_eq!(lifecycle(&script), (0, 0, 1), "default config refused");

    // The transfer does not start.
    script.set(50, 0);
    script.fail(FAIL_DATA_START);
    assert_eq!(
        session(&[]),
        Err(SessionError::Retry("data transfer could not start".into()))
    );
    assert_eq!(lifecycle(&script), (0, 0, 1), "failed start");

    // A setting the camera does not have: started, so stopped, then closed.
    script.set(50, 0);
    assert_eq!(
        session(&[(5, 1, 24575), (7, 0, 1)]),
        Err(SessionError::Refused(CameraError::SettingRefused {
            index: 1,
            setting: (7, 0, 1)
        }))
    );
    assert_eq!(lifecycle(&script), (1, 1, 1), "refused setting");

    // The camera goes away at once, then no camera to open: nothing to close.
    script.set(0, 3);
    assert_eq!(session(&[]), Ok(Ended::DeviceLost));
    assert_eq!(
        session(&[]),
        Err(SessionError::Retry(no_camera(CaerDevice::Davis240)))
    );
    assert_eq!(lifecycle(&script), (1, 1, 1), "no camera");
    assert_eq!(
        rx.try_iter().count(),
        QUEUED_AFTER_UNPLUG,
        "no events from any of them but the lost camera's queued ones"
    );
}

/// The guard the refusal test stands on: the mock really aborts (as libcaer really
/// crashes) when DataStop reaches a device never started. Run in a child process, as
/// it kills the process it runs in.
#[test]
fn the_mock_aborts_on_data_stop_of_a_device_never_started() {
    use std::os::unix::process::ExitStatusExt;
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "caer_mock::data_stop_before_data_start_in_a_child",
            "--ignored",
            "--nocapture",
        ])
        .env("CAER_MOCK_ABORT_CHILD", "1")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        out.status.signal(),
        Some(nix::sys::signal::Signal::SIGABRT as i32),
        "{stderr}"
    );
    assert!(stderr.contains("never started"), "{stderr}");
}

#[test]
#[ignore = "aborts its process: run by the_mock_aborts_on_data_stop_of_a_device_never_started"]
fn data_stop_before_data_start_in_a_child() {
    if std::env::var_os("CAER_MOCK_ABORT_CHILD").is_none() {
        return;
    }
    let (lib, _script) = mock();
    // SAFETY: a call into the loaded library with plain values and a handle it returned.
    let handle = unsafe { (lib.caerDeviceOpen)(1, 4, 0, 0, std::ptr::null()) };
    assert!(!handle.is_null());
    // SAFETY: a call into the loaded library with plain values and a handle it returned.
    unsafe { (lib.caerDeviceDataStop)(handle) };
    unreachable!("the mock returned from DataStop on a device never started");
}

/// caerDeviceDataStart turns the APS and the IMU on again, whatever was set before
/// it: faithd turns them off after it, then applies its settings. The frames and IMU
/// samples already in flight still arrive, between the polarity packets, and are
/// skipped.
#[test]
fn settings_and_the_aps_and_imu_off_are_written_after_data_start() {
    let _device = device();
    let (lib, script) = mock();
    script.set(50, 0);
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    let settings = [(5, 1, 24575), (5, 2, 16399)];
    let ended = serve_device(&lib, &davis240(&settings), &io(DaemonClock::start(), &tx)).unwrap();
    assert_eq!(ended, Ended::DeviceLost);
    for (module, param, value) in settings {
        assert_eq!(script.config_value(module, param), i64::from(value));
        assert_eq!(
            script.config_written_while_started(module, param),
            1,
            "({module}, {param}) written before DataStart, which undoes run flags"
        );
    }
    for (module, param) in [(2, 4), (3, 2), (3, 3), (3, 4)] {
        assert_eq!(
            script.config_written_while_started(module, param),
            1,
            "({module}, {param}) not turned off after DataStart"
        );
    }
    let served = |t: i16| script.packets_served(i32::from(t));
    assert_eq!(served(POLARITY_EVENT), 50 + QUEUED_AFTER_UNPLUG as i32);
    // Four containers were in flight when the APS and the IMU went off.
    assert!(
        (1..=2).contains(&served(FRAME_EVENT)),
        "{}",
        served(FRAME_EVENT)
    );
    assert!(
        (1..=4).contains(&served(IMU6_EVENT)),
        "{}",
        served(IMU6_EVENT)
    );
    assert!(
        served(SPECIAL_EVENT) >= 2,
        "the timestamp reset and an input edge"
    );
    let batches: Vec<_> = rx.try_iter().collect();
    assert_eq!(batches.len(), 50 + QUEUED_AFTER_UNPLUG);
    assert_eq!(
        script.config_value(-3, 1),
        1_000,
        "1 ms containers asked for (libcaer's default is 10 ms)"
    );
    assert!(
        batches.iter().all(|b| b.len() == 180),
        "one millisecond (one edge column) a container"
    );
}

/// A setting libcaer refuses is a configuration error that names the entry: the
/// source stops at once instead of reopening the camera to be refused again.
#[test]
fn a_refused_setting_stops_the_source_at_once_naming_the_entry() {
    let _device = device();
    let (_, script) = mock();
    script.set(50, 0);
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    let (done_tx, done_rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let lib = Libcaer::load(Some(LIBRARY)).unwrap();
        let result = run(
            &lib,
            &davis240(&[(5, 1, 24575), (5, 200, 1)]),
            &io(DaemonClock::start(), &tx),
            retry_ms(100),
        );
        let _ = done_tx.send(result);
    });
    let err = done_rx
        .recv_timeout(Duration::from_secs(5))
        .expect("the source keeps retrying a refused setting")
        .unwrap_err();
    assert_eq!(
        err,
        CameraError::SettingRefused {
            index: 1,
            setting: (5, 200, 1)
        }
    );
    assert_eq!(err.key(), "source.caer_settings");
    assert!(
        err.to_string()
            .starts_with("entry [1] = [5, 200, 1] refused by libcaer"),
        "{err}"
    );
    assert_eq!(script.open_attempts(), 1, "no retry");
    assert!(rx.try_recv().is_err());
}

/// libcaer's blocking DataGet gives up with NULL only after 1.11-1.22 s without data
/// (measured on libcaer 3.3.x); in non-blocking mode it returns at once.
#[test]
fn a_blocking_data_get_gives_up_only_after_more_than_a_second_without_data() {
    let _device = device();
    let (lib, script) = mock();
    script.set(100, 0);
    script.quiet(0, 10_000_000);
    // SAFETY: a call into the loaded library with plain values and a handle it returned.
    unsafe {
        let mut handle = (lib.caerDeviceOpen)(1, 4, 0, 0, std::ptr::null());
        assert!(!handle.is_null());
        assert!((lib.caerDeviceConfigSet)(handle, -2, 1, 1));
        assert!((lib.caerDeviceDataStart)(
            handle,
            None,
            None,
            std::ptr::null_mut(),
            None,
            std::ptr::null_mut()
        ));
        // First the timestamp reset, in a container of its own.
        let reset = Container::from_raw((lib.caerDeviceDataGet)(handle)).unwrap();
        assert_eq!(reset.packets_number(), 1);
        drop(reset);
        let asked = Instant::now();
        assert!((lib.caerDeviceDataGet)(handle).is_null());
        let waited = asked.elapsed();
        assert!(
            waited >= Duration::from_millis(1110) && waited < Duration::from_millis(1500),
            "{waited:?}"
        );
        assert!((lib.caerDeviceConfigSet)(handle, -2, 1, 0));
        let asked = Instant::now();
        assert!((lib.caerDeviceDataGet)(handle).is_null());
        assert!(asked.elapsed() < Duration::from_millis(50));
        assert!((lib.caerDeviceDataStop)(handle));
        assert!((lib.caerDeviceClose)(&mut handle));
    }
}

/// A dark scene (no events for 2.5 s: three empty blocking DataGets) is not a lost
/// camera: the session goes on and its events after the gap are 2.5 s later.
#[test]
fn a_dark_scene_is_not_a_lost_camera() {
    let _device = device();
    let (lib, script) = mock();
    script.set(10, 0);
    script.quiet(5, 2_500_000);
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    let started = Instant::now();
    let ended = serve_device(&lib, &davis240(&[]), &io(DaemonClock::start(), &tx)).unwrap();
    assert_eq!(ended, Ended::DeviceLost);
    assert!(started.elapsed() >= Duration::from_millis(2_500));
    let batches: Vec<_> = rx.try_iter().collect();
    assert_eq!(batches.len(), 10 + QUEUED_AFTER_UNPLUG);
    let gap_us = batches[5][0].t_us - batches[4][0].t_us;
    assert!(
        (2_400_000..2_700_000).contains(&gap_us),
        "{gap_us} us between the edges before and after the dark"
    );
    assert_eq!(script.count(COUNT_SHUTDOWN_CALLS), 1);
}

static CALLBACK_THREAD: Mutex<Option<std::thread::ThreadId>> = Mutex::new(None);

unsafe extern "C" fn note_the_callbacks_thread(flag: *mut std::ffi::c_void) {
    *CALLBACK_THREAD.lock().unwrap() = Some(std::thread::current().id());
    // SAFETY: the flag is the AtomicBool the test owns until the device is closed.
    let flag = unsafe { &*(flag as *const std::sync::atomic::AtomicBool) };
    flag.store(true, std::sync::atomic::Ordering::SeqCst);
}

/// As libcaer's USB thread does, the mock stops the transfers when the device goes
/// away (DataGet returns NULL at once) and calls the shutdown callback from its own
/// thread, not from within DataGet.
#[test]
fn the_shutdown_callback_comes_from_another_thread() {
    let _device = device();
    let (lib, script) = mock();
    script.set(3, 0);
    let lost = Box::new(std::sync::atomic::AtomicBool::new(false));
    // SAFETY: a call into the loaded library with plain values and a handle it returned.
    unsafe {
        let mut handle = (lib.caerDeviceOpen)(1, 4, 0, 0, std::ptr::null());
        assert!((lib.caerDeviceConfigSet)(handle, -2, 1, 1));
        assert!((lib.caerDeviceDataStart)(
            handle,
            None,
            None,
            std::ptr::null_mut(),
            Some(note_the_callbacks_thread),
            &*lost as *const _ as *mut std::ffi::c_void,
        ));
        let mut containers = 0;
        loop {
            let c = (lib.caerDeviceDataGet)(handle);
            if c.is_null() {
                break;
            }
            containers += 1;
            drop(Container::from_raw(c));
        }
        assert_eq!(containers, 4, "the timestamp reset, then three");
        assert!(common::poll_until(Duration::from_secs(1), || lost
            .load(std::sync::atomic::Ordering::SeqCst)));
        assert!((lib.caerDeviceDataStop)(handle));
        assert!((lib.caerDeviceClose)(&mut handle));
    }
    let thread = CALLBACK_THREAD.lock().unwrap().take();
    assert!(thread.is_some());
    assert_ne!(thread, Some(std::thread::current().id()));
}

/// The container the mock builds is libcaer's: packed, the slot count at byte 24 and
/// the pointers from 28, four slots indexed by event type with NULLs, and the
/// statistics libcaer's setter keeps; faithd's reader takes only the polarity events.
#[test]
fn containers_are_laid_out_and_read_as_libcaers() {
    // The mock counts the packets it builds: not while another test counts them.
    let _device = device();
    let (_, script) = mock();
    let raw = script.container(0, 1_000, 7);
    let bytes =
        // SAFETY: within the packet or container the library laid out (its header and capacity).
        |at: usize, n: usize| unsafe { std::slice::from_raw_parts(raw.cast::<u8>().add(at), n) };
    let i64_at = |at| i64::from_le_bytes(bytes(at, 8).try_into().unwrap());
    let i32_at = |at| i32::from_le_bytes(bytes(at, 4).try_into().unwrap());
    assert_eq!(i32_at(24), 4, "eventPacketsNumber at 24");
    assert_eq!(
        i64_at(0),
        1_000,
        "lowestEventTimestamp: the first polarity event"
    );
    assert_eq!(i64_at(8), 1_500, "highestEventTimestamp: the IMU sample");
    assert_eq!((i32_at(16), i32_at(20)), (184, 183), "events, valid events");
    // SAFETY: a container the library allocated and handed over, freed once by its drop.
    let c = unsafe { Container::from_raw(raw) }.unwrap();
    let kind = |n| {
        c.packet(n)
            // SAFETY: within the packet or container the library laid out (its header and capacity).
            .map(|p| unsafe { p.cast::<i16>().read_unaligned() })
    };
    assert_eq!(
        [kind(0), kind(1), kind(2), kind(3)],
        [
            Some(SPECIAL_EVENT),
            Some(POLARITY_EVENT),
            Some(FRAME_EVENT),
            Some(IMU6_EVENT)
        ]
    );
    let mut events = Vec::new();
    for p in c.packets() {
        // SAFETY: a live packet of a live container (header and capacity in memory).
        unsafe { libcaer_sys::read_polarity_packet(p, &mut events) };
    }
    assert_eq!(events.len(), 180);
    assert!(events.iter().all(|e| e.x == 7 && e.on));
    assert_eq!(events.last().map(|e| e.t_us), Some(1_179));
    drop(c);

    // An odd container: no special packet, no frame.
    // SAFETY: a container the library allocated and handed over, freed once by its drop.
    let c = unsafe { Container::from_raw(script.container(1, 2_000, 8)) }.unwrap();
    assert_eq!(c.packets_number(), 4);
    assert!(c.packet(0).is_none() && c.packet(2).is_none());
    assert!(c.packet(1).is_some() && c.packet(3).is_some());
    drop(c);

    // The timestamp reset alone: one slot, a special packet, no polarity event.
    // SAFETY: a container the library allocated and handed over, freed once by its drop.
    let c = unsafe { Container::from_raw(script.timestamp_reset_container()) }.unwrap();
    assert_eq!(c.packets_number(), 1);
    let special = c.packet(0).unwrap();
    // SAFETY: within the packet or container the library laid out (its header and capacity).
    let word = unsafe { special.add(28).cast::<u32>().read_unaligned() };
    // SAFETY: within the packet or container the library laid out (its header and capacity).
    let ts = unsafe { special.add(32).cast::<i32>().read_unaligned() };
    assert_eq!(((word >> 1) & 0x7F, word & 1, ts), (1, 1, i32::MAX));
    let mut events = Vec::new();
    // SAFETY: a live packet of a live container (header and capacity in memory).
    assert!(!unsafe { libcaer_sys::read_polarity_packet(special, &mut events) });
    assert!(events.is_empty());
}

/// The device functions libcaer 3.3.9's shared library exports (`nm -D`; 3.3.15's
/// too), of which faithd loads some; the container functions are not among them.
const LIBCAER_3_DEVICE_EXPORTS: [&str; 13] = [
    "caerDVXplorerInfoGet",
    "caerDavisInfoGet",
    "caerDeviceClose",
    "caerDeviceConfigGet",
    "caerDeviceConfigGet64",
    "caerDeviceConfigSet",
    "caerDeviceDataGet",
    "caerDeviceDataStart",
    "caerDeviceDataStop",
    "caerDeviceDiscover",
    "caerDeviceDiscoverOpen",
    "caerDeviceOpen",
    "caerDeviceSendDefaultConfig",
];

/// faithd loads by name only what libcaer 3.x exports, and the mock, like libcaer,
/// does not export the container functions its header makes static inline: a faithd
/// that loaded them by name would fail to load the mock as it failed on the real
/// library (`tests/testsuite/libcaer_real.rs` checks the real one when given its path).
#[test]
fn faithd_loads_only_what_libcaer_exports_and_the_mock_exports_no_inline_function() {
    for symbol in libcaer_sys::LOADED_SYMBOLS {
        assert!(
            LIBCAER_3_DEVICE_EXPORTS.contains(symbol),
            "{symbol} is not exported by libcaer 3"
        );
    }
    for symbol in INLINE_IN_LIBCAER {
        assert!(
            !libcaer_sys::exports(LIBRARY, symbol).unwrap(),
            "the mock exports {symbol}, libcaer does not"
        );
    }
    for symbol in libcaer_sys::LOADED_SYMBOLS {
        assert!(libcaer_sys::exports(LIBRARY, symbol).unwrap(), "{symbol}");
    }
    Libcaer::load(Some(LIBRARY)).expect("loads with no inline function exported");
}

/// `faithd run` on a camera that refuses a setting: exit 2, the key and the entry.
/// The background-activity filter is an address every DAVIS has in libcaer's header,
/// but this camera lacks the filter (`dvsHasBackgroundActivityFilter` false), so
/// libcaer refuses it only when it is written.
#[test]
fn faithd_run_refuses_a_setting_the_camera_does_not_take_naming_it() {
    use common::autopilot::{Controls, MockAutopilot};
    let mock = MockAutopilot::start(std::sync::Arc::new(Controls::default()));
    let dir = common::TempDir::new("caer-setting");
    let config = dir.0.join("faithd.toml");
    let toml = mock
        .service_toml(&common::caer_mock_library(), "enabled = false")
        .replace(
            "kind = \"caer\"\n",
            "kind = \"caer\"\ncaer_settings = [[5, 1, 24575], [5, 2, 16399], [1, 31, 1]]\n",
        );
    std::fs::write(&config, toml).unwrap();
    let output = crate::common::faithd()
        .args(["run", "--config"])
        .arg(&config)
        .env("RUST_LOG", "info")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{text}");
    assert!(
        text.contains("`source.caer_settings`: entry [2] = [1, 31, 1] refused by libcaer"),
        "{text}"
    );
}

/// What `faithd run` on the mock did around a SIGTERM.
struct Sigtermed {
    /// From the signal to the process's exit.
    took: Duration,
    status: std::process::ExitStatus,
    journal: String,
    /// The mock's log of device calls (Open, DataStart, DataStop, Close), in order.
    calls: Vec<String>,
}

/// `faithd run` on the mock libcaer with `env`, until `ready` holds on its journal
/// (5 s at most); then SIGTERM, and what it did.
fn faithd_run_until_sigterm(
    tag: &str,
    env: &[(&str, &str)],
    ready: impl Fn(&str) -> bool,
) -> Sigtermed {
    faithd_run_until_sigterm_with(tag, env, "", ready)
}

/// [`faithd_run_until_sigterm`] with more `[source]` lines.
fn faithd_run_until_sigterm_with(
    tag: &str,
    env: &[(&str, &str)],
    source: &str,
    ready: impl Fn(&str) -> bool,
) -> Sigtermed {
    use common::autopilot::{Controls, MockAutopilot};
    let mock = MockAutopilot::start(std::sync::Arc::new(Controls::default()));
    let dir = common::TempDir::new(tag);
    let config = dir.0.join("faithd.toml");
    let toml = mock
        .service_toml(&common::caer_mock_library(), "enabled = false")
        .replace("kind = \"caer\"\n", &format!("kind = \"caer\"\n{source}"));
    std::fs::write(&config, toml).unwrap();
    let (log, calls) = (dir.0.join("faithd.log"), dir.0.join("calls.log"));
    let mut child = crate::common::faithd()
        .args(["run", "--config"])
        .arg(&config)
        .envs(env.iter().copied())
        .env("CAER_MOCK_LOG", &calls)
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let reached = common::poll_until(Duration::from_secs(5), || {
        std::fs::read_to_string(&log).is_ok_and(|t| ready(&t))
    });
    let signalled = Instant::now();
    let _ = nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGTERM,
    );
    let status = child.wait().unwrap();
    let took = signalled.elapsed();
    let journal = std::fs::read_to_string(&log).unwrap();
    assert!(
        reached,
        "the camera never reached the state under test:\n{journal}"
    );
    let calls = std::fs::read_to_string(&calls)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.split_once(' ').map(|(_, call)| call.to_string()))
        .collect();
    eprintln!("{tag}: SIGTERM to exit {} ms", took.as_millis());
    Sigtermed {
        took,
        status,
        journal,
        calls,
    }
}

/// Within this of SIGTERM faithd has released the roll (up to three centre frames
/// 40 ms apart), stopped every task and thread and exited; a camera thread parked in
/// libcaer's blocking read (1.11-1.22 s without data) could not.
const EXIT_WITHIN: Duration = Duration::from_millis(1000);

/// `faithd run` with no camera on USB (the mock's camera gone at once and never
/// back, as the real libcaer is with nothing plugged in): it keeps trying, says so,
/// and on SIGTERM stops waiting at once and exits 0, the one device it had opened
/// stopped and closed.
#[test]
fn faithd_run_without_a_camera_says_so_and_stops_cleanly() {
    let run = faithd_run_until_sigterm(
        "caer-none",
        &[
            ("CAER_MOCK_DISCONNECT_AFTER", "0"),
            ("CAER_MOCK_FAILED_OPENS", "1000000"),
        ],
        |t| t.matches(&no_camera(CaerDevice::Davis240)).count() >= 2,
    );
    let text = &run.journal;
    assert_eq!(run.status.code(), Some(0), "{text}");
    assert!(run.took < EXIT_WITHIN, "{:?}\n{text}", run.took);
    assert!(
        text.contains("camera: stopped while waiting to retry"),
        "{text}"
    );
    assert!(!text.contains("did not stop within"), "{text}");
    assert_eq!(
        run.calls
            .iter()
            .filter(|c| *c != "Open" && *c != "Discover")
            .collect::<Vec<_>>(),
        ["DataStart", "DataStop", "Close"],
        "{:?}",
        run.calls
    );
}

/// Exit 0 within [`EXIT_WITHIN`], the camera's own line in the journal, and the
/// one device opened, started, stopped and closed, in that order.
fn assert_streaming_camera_stopped_and_closed(run: &Sigtermed) {
    let text = &run.journal;
    assert_eq!(run.status.code(), Some(0), "{text}");
    assert!(run.took < EXIT_WITHIN, "{:?}\n{text}", run.took);
    assert!(text.contains("camera stopped and closed"), "{text}");
    assert_eq!(run.calls, ["Open", "DataStart", "DataStop", "Close"]);
}

/// SIGTERM while the camera streams: the transfer is stopped and the device closed
/// before faithd exits 0.
#[test]
fn faithd_run_stops_the_camera_and_closes_it_on_sigterm_while_streaming() {
    let run = faithd_run_until_sigterm("caer-streaming", &[], |t| {
        t.contains("camera open: streaming") && t.contains("ready:")
    });
    assert_streaming_camera_stopped_and_closed(&run);
}

/// SIGTERM in a dark scene (no events for a minute, where a blocking read would sit
/// in libcaer): the same clean stop.
#[test]
fn faithd_run_stops_the_camera_and_closes_it_on_sigterm_in_a_dark_scene() {
    let run = faithd_run_until_sigterm("caer-dark", &[("CAER_MOCK_QUIET", "5,60000000")], |t| {
        t.contains("camera open: streaming") && t.contains("ready:")
    });
    assert_streaming_camera_stopped_and_closed(&run);
}

/// Runs the source on a thread of its own with a stop of its own, waits until
/// `reached` says the camera is in the state under test, asks it to stop, and
/// returns how long the source took to return and what it returned.
fn stop_when(
    lib: Libcaer,
    mut reached: impl FnMut(&std::sync::mpsc::Receiver<Vec<Event>>) -> bool,
) -> (Duration, Result<(), CameraError>) {
    let shutdown = Shutdown::new();
    let (tx, rx) = std::sync::mpsc::sync_channel(10_000);
    let io = SourceIo {
        clock: DaemonClock::start(),
        batches: tx,
        stop: shutdown.handle(),
    };
    let source = std::thread::spawn(move || run(&lib, &davis240(&[]), &io, RetryTiming::DEFAULT));
    assert!(
        common::poll_until(Duration::from_secs(5), || reached(&rx)),
        "the camera never reached the state under test"
    );
    let asked = Instant::now();
    shutdown.request();
    let ended = source.join().unwrap();
    let took = asked.elapsed();
    eprintln!("camera thread: stop to return {} us", took.as_micros());
    (took, ended)
}

/// The stop reaches the camera thread within 200 ms in each state it can be in,
/// and a started device is stopped and every opened one closed.
const STOP_HEARD_WITHIN: Duration = Duration::from_millis(200);

#[test]
fn a_stop_while_streaming_stops_the_transfer_and_closes_the_device_at_once() {
    let _device = device();
    let (lib, script) = mock();
    script.set(1_000_000, 0);
    let mut batches = 0;
    let (took, ended) = stop_when(lib, |rx| {
        batches += rx.try_iter().count();
        batches >= 20
    });
    assert_eq!(ended, Ok(()));
    assert!(took < STOP_HEARD_WITHIN, "{took:?}");
    assert_eq!(lifecycle(&script), (1, 1, 1));
}

/// In a dark scene the old blocking read sat in libcaer for 1.11-1.22 s; the
/// non-blocking reads with a wait on the stop hear it at once.
#[test]
fn a_stop_in_a_dark_scene_is_heard_at_once_where_a_blocking_read_would_wait_over_a_second() {
    let _device = device();
    let (lib, script) = mock();
    script.set(1_000_000, 0);
    script.quiet(5, 60_000_000);
    let mut batches = 0;
    let mut dark_since: Option<Instant> = None;
    let (took, ended) = stop_when(lib, |rx| {
        batches += rx.try_iter().count();
        if batches >= 5 && dark_since.is_none() {
            dark_since = Some(Instant::now());
        }
        dark_since.is_some_and(|t| t.elapsed() > Duration::from_millis(300))
    });
    assert_eq!(batches, 5, "the scene went dark after five containers");
    assert_eq!(ended, Ok(()));
    assert!(took < STOP_HEARD_WITHIN, "{took:?}");
    assert_eq!(lifecycle(&script), (1, 1, 1));
    assert_eq!(script.config_value(-2, 1), 0, "never blocking");
}

/// With no camera the thread waits between attempts (up to 2 s): the stop cuts the
/// wait short. The session that found the camera before it vanished was stopped and
/// closed; the refused opens left nothing open.
#[test]
fn a_stop_while_retrying_without_a_camera_cuts_the_wait_short() {
    let _device = device();
    let (lib, script) = mock();
    script.set(0, 1_000_000);
    let (took, ended) = stop_when(lib, |_| script.open_attempts() >= 5);
    assert_eq!(ended, Ok(()));
    assert!(took < STOP_HEARD_WITHIN, "{took:?}");
    assert_eq!(lifecycle(&script), (1, 1, 1));
}

/// When no camera opens, faithd says which of the causes libcaer's discovery tells
/// apart it is, and what fixes it: none on USB, no permission, firmware too old, or
/// claimed by another program (discovery opens without claiming, so it passes).
#[test]
fn a_camera_that_does_not_open_is_explained_by_its_cause_and_its_fix() {
    let _device = device();
    let (lib, script) = mock();
    let (tx, _rx) = std::sync::mpsc::sync_channel(1000);
    let session = || serve_device(&lib, &davis240(&[]), &io(DaemonClock::start(), &tx));
    let cases = [
        (UNUSABLE_PERMISSION, "a DAVIS camera is on USB (bus 1, address 5) but could not be opened: no permission on its device node (install the udev rule: docs/camera.md; then unplug and replug it)".to_string()),
        (UNUSABLE_VERSION, "a DAVIS240 is on USB (bus 1, address 5) but its firmware (3) or logic (17) is not the version this libcaer requires: update the camera's firmware with iniVation's DV software (docs/camera.md)".to_string()),
        (UNUSABLE_BUSY, "a DAVIS240 is on USB (bus 1, address 5) but libcaer could not claim it: another program has it open (DV, or a second faithd: `fuser -v /dev/bus/usb/001/005`)".to_string()),
    ];
    for (why, said) in cases {
        script.set(50, 0);
        script.unusable(why);
        assert_eq!(session(), Err(SessionError::Retry(said)));
        assert_eq!(lifecycle(&script), (0, 0, 0), "nothing opened");
    }
    // A DVXplorer where a DAVIS240 is configured: no DAVIS on USB.
    script.set(50, 0);
    script.device(libcaer_sys::CAER_DEVICE_DVXPLORER);
    assert_eq!(
        session(),
        Err(SessionError::Retry(no_camera(CaerDevice::Davis240)))
    );
    assert_eq!(
        no_camera(CaerDevice::Davis240),
        "no DAVIS240 on USB (source.device = \"davis240\"): plug it in; `lsusb -d 152a:` lists iniVation's cameras"
    );
}

/// A DVXplorer (640 x 480 and the Lite's 320 x 240) through its own info call and
/// modules: it streams with the IMU off after DataStart (it has no APS), takes its
/// own bias module and refuses a DAVIS bias; a DAVIS346 configured as a DVXplorer
/// is refused naming source.device.
#[test]
fn a_dvxplorer_streams_through_its_own_info_and_modules() {
    let _device = device();
    let (lib, script) = mock();
    let (tx, rx) = std::sync::mpsc::sync_channel(1000);
    let dvxplorer = |w: u16, h: u16, settings: &[Setting]| Camera {
        device: CaerDevice::Dvxplorer,
        settings: settings.to_vec(),
        expected: SensorSize {
            width_px: w,
            height_px: h,
        },
    };
    for (w, h) in [(640_u16, 480_u16), (320, 240)] {
        script.set(20, 0);
        script.device(libcaer_sys::CAER_DEVICE_DVXPLORER);
        script.sensor(w as i16, h as i16);
        let bias_simple_high = (23, 20, 3);
        let ended = serve_device(
            &lib,
            &dvxplorer(w, h, &[bias_simple_high]),
            &io(DaemonClock::start(), &tx),
        );
        assert_eq!(ended, Ok(Ended::DeviceLost), "{w}x{h}");
        assert_eq!(script.config_value(23, 20), 3);
        for param in [2, 3, 4] {
            assert_eq!(script.config_written_while_started(3, param), 1);
            assert_eq!(script.config_value(3, param), 0, "IMU off");
        }
        assert_eq!(script.config_value(2, 4), -1, "no APS to turn off");
        let batches: Vec<_> = rx.try_iter().collect();
        assert_eq!(batches.len(), 20 + QUEUED_AFTER_UNPLUG);
        assert!(batches.iter().flatten().all(|e| e.x_px < w && e.y_px < h));
    }
    script.set(20, 0);
    script.device(libcaer_sys::CAER_DEVICE_DVXPLORER);
    script.sensor(640, 480);
    assert_eq!(
        serve_device(
            &lib,
            &dvxplorer(640, 480, &[(5, 1, 24575)]),
            &io(DaemonClock::start(), &tx)
        ),
        Err(SessionError::Refused(CameraError::SettingRefused {
            index: 0,
            setting: (5, 1, 24575)
        }))
    );
    script.set(20, 0);
    script.sensor(346, 260);
    assert_eq!(
        serve_device(
            &lib,
            &Camera {
                device: CaerDevice::Davis240,
                settings: Vec::new(),
                expected: DVS240
            },
            &io(DaemonClock::start(), &tx)
        ),
        Err(SessionError::Refused(CameraError::OtherCamera {
            found: "DAVIS346",
            size: SensorSize {
                width_px: 346,
                height_px: 260
            },
            configured: CaerDevice::Davis240
        }))
    );
}

/// Left to libcaer's default container interval, the mock packs 10 ms of events a
/// container, as libcaer 3.3.15 was measured to (about 100 containers a second).
#[test]
fn the_mock_packs_ten_millisecond_containers_unless_told_otherwise() {
    let _device = device();
    let (lib, script) = mock();
    script.set(1_000, 0);
    // SAFETY: plain calls on a handle this test opens, starts, stops and closes.
    unsafe {
        let mut h = (lib.caerDeviceOpen)(1, libcaer_sys::CAER_DEVICE_DAVIS, 0, 0, std::ptr::null());
        assert!(!h.is_null());
        assert!((lib.caerDeviceDataStart)(
            h,
            None,
            None,
            std::ptr::null_mut(),
            None,
            std::ptr::null_mut()
        ));
        let mut spans_us = Vec::new();
        let deadline = Instant::now() + Duration::from_secs(2);
        while spans_us.len() < 5 && Instant::now() < deadline {
            let Some(c) = Container::from_raw((lib.caerDeviceDataGet)(h)) else {
                std::thread::sleep(Duration::from_millis(1));
                continue;
            };
            let mut events = Vec::new();
            for p in c.packets() {
                libcaer_sys::read_polarity_packet(p, &mut events);
            }
            if let (Some(first), Some(last)) = (events.first(), events.last()) {
                spans_us.push((events.len(), last.t_us - first.t_us));
            }
        }
        assert!((lib.caerDeviceDataStop)(h));
        assert!((lib.caerDeviceClose)(&mut h));
        assert_eq!(spans_us.len(), 5);
        assert!(
            spans_us
                .iter()
                .all(|&(n, span)| n == 1_800 && span == 9_179),
            "{spans_us:?}"
        );
    }
}

/// The camera's reopen timing is configured: the journal's retry waits start at
/// source.reopen_min_us and double up to source.reopen_max_us.
#[test]
fn faithd_run_reopens_the_camera_on_the_configured_timing() {
    let run = faithd_run_until_sigterm_with(
        "caer-reopen",
        &[
            ("CAER_MOCK_DISCONNECT_AFTER", "0"),
            ("CAER_MOCK_FAILED_OPENS", "1000000"),
        ],
        "reopen_min_us = 20000\nreopen_max_us = 80000\n",
        |t| t.matches("retry in 80 ms").count() >= 2,
    );
    let text = &run.journal;
    assert_eq!(run.status.code(), Some(0), "{text}");
    let waits: Vec<&str> = text
        .lines()
        .filter_map(|l| {
            l.split(" in ")
                .last()
                .filter(|_| l.contains("retry in ") || l.contains("reopening in "))
        })
        .take(4)
        .collect();
    assert_eq!(waits, ["20 ms", "40 ms", "80 ms", "80 ms"], "{text}");
}

/// `faithd check-config` refuses a libcaer_path that faithd run would refuse: no
/// such file, a directory, a file that is not a library; it takes the mock (a
/// library exporting every function faithd loads).
#[test]
fn check_config_refuses_a_libcaer_path_that_is_not_a_library() {
    let dir = common::TempDir::new("caer-check");
    let not_a_library = dir.0.join("libcaer.so.3");
    std::fs::write(&not_a_library, "not ELF").unwrap();
    let missing = dir.0.join("missing.so");
    let cases = [
        (missing.display().to_string(), "No such file"),
        (dir.0.display().to_string(), "is a directory"),
        (
            not_a_library.display().to_string(),
            "is not a shared library for this machine",
        ),
    ];
    let config = dir.0.join("faithd.toml");
    for (path, why) in cases {
        std::fs::write(
            &config,
            format!("[source]\nkind = \"caer\"\nlibcaer_path = \"{path}\"\n"),
        )
        .unwrap();
        let out = common::faithd()
            .args(["check-config"])
            .arg(&config)
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{path}: {text}");
        assert!(
            text.contains("`source.libcaer_path`") && text.contains(why),
            "{path}: {text}"
        );
    }
    let mock = common::caer_mock_library();
    std::fs::write(
        &config,
        format!("[source]\nkind = \"caer\"\nlibcaer_path = \"{mock}\"\n"),
    )
    .unwrap();
    let out = common::faithd()
        .args(["check-config"])
        .arg(&config)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
