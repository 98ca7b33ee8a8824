//! The live camera: a DVS240/DAVIS240 through libcaer, opened at run time
//! ([`libcaer_sys::Libcaer`]).
//!
//! Opens the first DAVIS on USB, refuses it for good when its DVS size is not the
//! configured one (a DAVIS346 read as a 240x180 would be silently cropped, and the
//! intrinsics would be wrong with it), applies the configured (module, parameter,
//! value) settings after libcaer's defaults, and hands polarity events to the pipeline
//! on the daemon's clock: the device clock is mapped by a [`DeviceClock`], which removes
//! USB latency and follows the crystal's drift. When the device vanishes (libcaer's
//! shutdown callback, or no data), the source says so, sends nothing (the pipeline goes
//! unhealthy, the safety gate releases), and keeps trying to reopen it with backoff;
//! each session maps its clock afresh.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError};
use std::time::Duration;

use libcaer_sys::{self as caer, Libcaer};

use crate::clock::DaemonClock;
use crate::source::device_clock::{DeviceClock, DeviceClockConfig, Observed};
use faithd_core::event::{Event, Polarity};

/// One libcaer configuration write.
pub type Setting = (i8, u8, u32);

unsafe extern "C" fn on_shutdown(ptr: *mut std::ffi::c_void) {
    // SAFETY: `ptr` is the `AtomicBool` that `serve_device` keeps alive until after
    // caerDeviceDataStop/Close, which end the callbacks.
    let flag = unsafe { &*(ptr as *const AtomicBool) };
    flag.store(true, Ordering::SeqCst);
}

/// A DVS resolution in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SensorSize {
    pub width_px: u16,
    pub height_px: u16,
}

impl std::fmt::Display for SensorSize {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{} px", self.width_px, self.height_px)
    }
}

/// A camera that cannot be used as configured: reopening it will not help, so the
/// source stops.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CameraError {
    #[error(
        "camera is {camera} but pipeline.camera is {configured}: set pipeline.camera.width_px/height_px (and the intrinsics) for this camera, or connect the DVS240"
    )]
    SizeMismatch {
        camera: SensorSize,
        configured: SensorSize,
    },
}

/// Why a device session ended.
#[derive(Debug, PartialEq, Eq)]
pub enum Ended {
    /// The pipeline hung up: the daemon is stopping.
    Receiver,
    /// The device went away.
    DeviceLost,
}

/// Why a device session could not run.
#[derive(Debug, PartialEq, Eq)]
pub enum SessionError {
    /// Worth another try: no camera yet, a refused setting, a transfer that would not
    /// start.
    Retry(String),
    /// Not worth another try: the camera is not the one configured.
    Refused(CameraError),
}

impl std::fmt::Display for SessionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SessionError::Retry(why) => f.write_str(why),
            SessionError::Refused(e) => e.fmt(f),
        }
    }
}

/// Runs until the pipeline hangs up (`Ok`), reopening the device whenever it is lost,
/// or until the camera turns out not to be the configured one (`Err`: a configuration
/// error, which no retry mends).
pub fn run(
    lib: &Libcaer,
    settings: Vec<Setting>,
    expected: SensorSize,
    clock: DaemonClock,
    batches: SyncSender<Vec<Event>>,
    max_backoff: Duration,
) -> Result<(), CameraError> {
    let mut backoff = Duration::from_millis(50);
    loop {
        match serve_device(lib, &settings, expected, clock, &batches) {
            Ok(Ended::Receiver) => return Ok(()),
            Ok(Ended::DeviceLost) => {
                tracing::error!("camera lost: no events until it is back; reopening");
                backoff = Duration::from_millis(50);
            }
            Err(SessionError::Refused(e)) => return Err(e),
            Err(SessionError::Retry(why)) => {
                tracing::warn!("camera: {why}; retry in {} ms", backoff.as_millis())
            }
        }
        std::thread::sleep(backoff);
        backoff = (backoff * 2).min(max_backoff);
    }
}

/// Opens, configures and streams one device session.
pub fn serve_device(
    lib: &Libcaer,
    settings: &[Setting],
    expected: SensorSize,
    clock: DaemonClock,
    batches: &SyncSender<Vec<Event>>,
) -> Result<Ended, SessionError> {
    // SAFETY: plain FFI calls on a handle libcaer gave us, closed exactly once below.
    let mut handle =
        unsafe { (lib.caerDeviceOpen)(1, caer::CAER_DEVICE_DAVIS, 0, 0, std::ptr::null()) };
    if handle.is_null() {
        return Err(SessionError::Retry(
            "no DAVIS camera could be opened".into(),
        ));
    }
    let lost = Box::new(AtomicBool::new(false));
    let result = check_size(lib, handle, expected)
        .and_then(|()| stream(lib, handle, settings, clock, batches, &lost));
    // SAFETY: stop before close; the callback flag outlives both.
    unsafe {
        (lib.caerDeviceDataStop)(handle);
        (lib.caerDeviceClose)(&mut handle);
    }
    drop(lost);
    result
}

/// Refuses a camera whose DVS size is not the configured one. A size libcaer cannot
/// report (all zeros: the handle went bad) is worth another try.
fn check_size(
    lib: &Libcaer,
    handle: caer::caerDeviceHandle,
    expected: SensorSize,
) -> Result<(), SessionError> {
    // SAFETY: `handle` is open; the struct is returned by value (layout pinned in
    // libcaer-sys).
    let info = unsafe { (lib.caerDavisInfoGet)(handle) };
    let Some((width_px, height_px)) = info.dvs_size_px() else {
        return Err(SessionError::Retry(
            "the camera did not report its DVS size".into(),
        ));
    };
    let camera = SensorSize {
        width_px,
        height_px,
    };
    if camera != expected {
        return Err(SessionError::Refused(CameraError::SizeMismatch {
            camera,
            configured: expected,
        }));
    }
    Ok(())
}

fn stream(
    lib: &Libcaer,
    handle: caer::caerDeviceHandle,
    settings: &[Setting],
    clock: DaemonClock,
    batches: &SyncSender<Vec<Event>>,
    lost: &AtomicBool,
) -> Result<Ended, SessionError> {
    start(lib, handle, settings, lost).map_err(SessionError::Retry)?;
    tracing::info!("camera open: streaming");
    let mut device_clock = DeviceClock::new(DeviceClockConfig::default());
    let mut polarity = Vec::new();
    loop {
        // SAFETY: `handle` is open and streaming; the container is freed below.
        let container = unsafe { (lib.caerDeviceDataGet)(handle) };
        if container.is_null() {
            if lost.load(Ordering::SeqCst) {
                return Ok(Ended::DeviceLost);
            }
            std::thread::sleep(Duration::from_micros(500));
            continue;
        }
        // Taken before parsing: the nearer to the arrival, the lower the envelope.
        let arrival_us = clock.now_us();
        polarity.clear();
        // SAFETY: the container and its packets are live until freed.
        unsafe {
            let n = (lib.caerEventPacketContainerGetEventPacketsNumber)(container);
            for k in 0..n.max(0) {
                let packet = (lib.caerEventPacketContainerGetEventPacket)(container, k);
                caer::read_polarity_packet(packet, &mut polarity);
            }
            (lib.caerEventPacketContainerFree)(container);
        }
        let Some(batch) = on_daemon_clock(&mut device_clock, &polarity, arrival_us) else {
            continue;
        };
        match batches.try_send(batch) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) => {
                tracing::warn!("pipeline not keeping up: camera packet dropped")
            }
            Err(TrySendError::Disconnected(_)) => return Ok(Ended::Receiver),
        }
    }
}

/// The container's events on the daemon clock, or `None` when it held none. The
/// newest event and the arrival time feed the device-clock mapping first.
fn on_daemon_clock(
    device_clock: &mut DeviceClock,
    polarity: &[caer::Polarity],
    arrival_us: i64,
) -> Option<Vec<Event>> {
    let newest_us = polarity.iter().map(|p| p.t_us).max()?;
    if let Observed::Reseeded(jump) = device_clock.observe(newest_us, arrival_us) {
        tracing::warn!("camera clock: {jump}; mapping it onto the daemon clock afresh");
    }
    let batch = polarity
        .iter()
        .map(|p| {
            let t_us = device_clock.map(p.t_us);
            Event::new(t_us, p.x, p.y, Polarity::from_bool(p.on))
        })
        .collect();
    Some(batch)
}

/// Sends libcaer's defaults and the configured settings, and starts the transfer.
fn start(
    lib: &Libcaer,
    handle: caer::caerDeviceHandle,
    settings: &[Setting],
    lost: &AtomicBool,
) -> Result<(), String> {
    // SAFETY: `handle` is open; settings are plain values.
    unsafe {
        if !(lib.caerDeviceSendDefaultConfig)(handle) {
            return Err("default configuration refused".into());
        }
        (lib.caerDeviceConfigSet)(
            handle,
            caer::CAER_HOST_CONFIG_DATAEXCHANGE,
            caer::CAER_HOST_CONFIG_DATAEXCHANGE_BLOCKING,
            1,
        );
        for &(module, param, value) in settings {
            if !(lib.caerDeviceConfigSet)(handle, module, param, value) {
                return Err(format!("setting ({module}, {param}) = {value} refused"));
            }
        }
        let flag = lost as *const AtomicBool as *mut std::ffi::c_void;
        if !(lib.caerDeviceDataStart)(
            handle,
            None,
            None,
            std::ptr::null_mut(),
            Some(on_shutdown),
            flag,
        ) {
            return Err("data transfer could not start".into());
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_size_mismatch_says_which_keys_to_change() {
        let e = CameraError::SizeMismatch {
            camera: SensorSize {
                width_px: 346,
                height_px: 260,
            },
            configured: SensorSize {
                width_px: 240,
                height_px: 180,
            },
        };
        assert_eq!(
            e.to_string(),
            "camera is 346x260 px but pipeline.camera is 240x180 px: set pipeline.camera.width_px/height_px (and the intrinsics) for this camera, or connect the DVS240"
        );
    }

    #[test]
    fn a_container_maps_its_events_in_order_up_to_its_arrival() {
        let mut device_clock = DeviceClock::new(DeviceClockConfig::default());
        let event = |t_us| caer::Polarity {
            t_us,
            x: 1,
            y: 2,
            on: true,
        };
        assert_eq!(on_daemon_clock(&mut device_clock, &[], 5_000), None);
        let batch = on_daemon_clock(&mut device_clock, &[event(100), event(400)], 5_000).unwrap();
        let times: Vec<i64> = batch.iter().map(|e| e.t_us).collect();
        assert_eq!(times, [4_700, 5_000], "the newest event at the arrival");
        // Less latency on the next container: the offset drops, time does not go back.
        let batch = on_daemon_clock(&mut device_clock, &[event(500), event(1_400)], 5_100).unwrap();
        let times: Vec<i64> = batch.iter().map(|e| e.t_us).collect();
        assert_eq!(times, [5_000, 5_100]);
    }
}
