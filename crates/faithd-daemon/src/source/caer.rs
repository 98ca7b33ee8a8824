//! The live camera: a DVS240/DAVIS240 through libcaer, opened at run time
//! ([`libcaer_sys::Libcaer`]).
//!
//! Opens the first DAVIS on USB, refuses it for good when its DVS size is not the
//! configured one (a DAVIS346 read as a 240x180 would be silently cropped, and the
//! intrinsics would be wrong with it), starts the transfer, turns the APS and IMU off
//! again (faithd uses neither), applies the configured (module, parameter, value)
//! settings, and hands polarity events to the pipeline on the daemon's clock: the
//! device clock is mapped by a [`DeviceClock`], which removes USB latency and follows
//! the crystal's drift. When the device vanishes (libcaer's shutdown callback), the
//! source says so, sends nothing (the pipeline goes unhealthy, the safety gate
//! releases), and keeps trying to reopen it with backoff; each session maps its clock
//! afresh.
//!
//! The camera thread never parks inside libcaer: data exchange is non-blocking and the
//! thread waits between empty reads on the run's [`Stop`], 1 ms at a time as libcaer's
//! own blocking mode does (`src/data_exchange.h`, `dataExchangeGet`: a 1 ms
//! `thrd_sleep`, then retry). A blocking read hears nothing for the 1.11-1.22 s it
//! takes to give up without data (measured on libcaer 3.3.x), and calling
//! `caerDeviceDataStop` from the stopping thread instead is not safe: it empties and
//! frees the ring buffer (`davisDataStop` -> `dataExchangeBufferEmpty`,
//! `freeAllDataMemory` in `src/davis.c`) that a concurrent `caerDeviceDataGet` reads.
//! So a stop is heard within about a millisecond in every state: retrying, streaming,
//! in a dark scene; the device is then stopped (if started) and closed.
//!
//! The order of calls follows libcaer 3.x's DAVIS driver (`src/davis.c`, 3.3.9):
//! `caerDeviceDataStart` writes every run flag on (DVS, APS, IMU, external input)
//! once its transfers run, so whatever is set before it about those is undone;
//! `caerDeviceDataStop` empties a ring buffer that only a successful DataStart made,
//! so it is called only then ([`Device`]); `caerDeviceClose` always.

// Calls into libcaer (foreign code) and reads the memory it hands over.
#![allow(unsafe_code)]

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError};
use std::time::Duration;

use libcaer_sys::{self as caer, Container, Libcaer};

use crate::clock::DaemonClock;
use crate::shutdown::Stop;
use crate::source::SourceIo;
use crate::source::caer_device::{CONTAINER_INTERVAL_US, CaerDevice, chip_name};
pub use crate::source::caer_device::{SensorSize, Setting};
use crate::source::device_clock::{DeviceClock, DeviceClockConfig, Observed};
use faithd_core::event::{Event, Polarity};

unsafe extern "C" fn on_shutdown(ptr: *mut std::ffi::c_void) {
    // SAFETY: `ptr` is the `AtomicBool` a [`Device`] owns and frees only after
    // caerDeviceDataStop/Close, which end libcaer's USB thread, the caller.
    let flag = unsafe { &*(ptr as *const AtomicBool) };
    flag.store(true, Ordering::SeqCst);
}

/// The camera faithd is to stream from: which one, the settings to write once it
/// streams, and the DVS size the pipeline is configured for.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Camera {
    pub device: CaerDevice,
    pub settings: Vec<Setting>,
    pub expected: SensorSize,
}

/// A camera that cannot be used as configured: reopening it will not help, so the
/// source stops and the daemon refuses to go on (exit 2, not restarted).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CameraError {
    #[error(
        "camera is a {found} ({size}) but source.device is \"{}\": set source.device for this camera (\"davis240\", \"davis346\" or \"dvxplorer\") and pipeline.camera for its size",
        configured.key()
    )]
    OtherCamera {
        found: &'static str,
        size: SensorSize,
        configured: CaerDevice,
    },
    #[error(
        "camera is {camera} but pipeline.camera is {configured}: set pipeline.camera.width_px/height_px (and the intrinsics) for this camera"
    )]
    SizeMismatch {
        camera: SensorSize,
        configured: SensorSize,
    },
    /// libcaer refused one of `source.caer_settings`: a value this camera does not
    /// take. Retrying would be refused the same way.
    #[error(
        "entry [{index}] = [{}, {}, {}] refused by libcaer: this camera does not take the value; fix or remove it (libcaer's devices/davis.h or devices/dvxplorer.h)",
        setting.0, setting.1, setting.2
    )]
    SettingRefused { index: usize, setting: Setting },
}

impl CameraError {
    /// The configuration key to change.
    pub fn key(&self) -> &'static str {
        match self {
            CameraError::OtherCamera { .. } => "source.device",
            CameraError::SizeMismatch { .. } => "pipeline.camera.width_px",
            CameraError::SettingRefused { .. } => "source.caer_settings",
        }
    }
}

/// Why a device session ended.
#[derive(Debug, PartialEq, Eq)]
pub enum Ended {
    /// The daemon asked the camera to stop.
    Stopped,
    /// The pipeline hung up.
    Receiver,
    /// The device went away.
    DeviceLost,
}

/// Why a device session could not run.
#[derive(Debug, PartialEq, Eq)]
pub enum SessionError {
    /// Worth another try: no camera yet, a size it could not report, a transfer that
    /// would not start.
    Retry(String),
    /// Not worth another try: the camera or a setting contradicts the configuration.
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

/// `kind = "caer"`: loads libcaer (the configured file, or the loader's search for
/// libcaer.so.3) and returns the camera thread's work, or the key to change.
pub fn prepare(
    config: super::CaerSource,
    camera: faithd_core::camera::CameraIntrinsics,
) -> Result<super::SourceFn, super::Refusal> {
    let lib = load(&config)?;
    tracing::info!(library = %lib.path, device = config.device.key(), "libcaer loaded");
    let retry = config.retry();
    let camera = Camera {
        device: config.device,
        settings: config.caer_settings,
        expected: SensorSize {
            width_px: camera.width_px,
            height_px: camera.height_px,
        },
    };
    Ok(Box::new(move |io| {
        run(&lib, &camera, &io, retry).map_err(|e| super::Refusal {
            key: e.key(),
            reason: e.to_string(),
        })
    }))
}

/// Loads the configured libcaer, or says which key to change and how: what
/// `faithd run` does first, and what `faithd check-config` checks.
pub fn load(config: &super::CaerSource) -> Result<Libcaer, super::Refusal> {
    let path = (!config.libcaer_path.is_empty()).then_some(config.libcaer_path.as_str());
    Libcaer::load(path).map_err(|e| super::Refusal {
        key: "source.libcaer_path",
        reason: format!(
            "{e}; install iniVation's libcaer 3 (it is not in Debian: see docs/camera.md) or name its file here"
        ),
    })
}

/// How soon a camera that could not be opened is tried again: the first wait, doubled
/// after every failure up to the longest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RetryTiming {
    pub first: Duration,
    pub longest: Duration,
}

impl RetryTiming {
    /// A camera plugged in is found within 2 s; an absent one costs an open every 2 s.
    pub const DEFAULT: RetryTiming = RetryTiming {
        first: Duration::from_millis(50),
        longest: Duration::from_secs(2),
    };
}

/// How long the camera thread waits after an empty read before the next: libcaer's
/// own pace in blocking mode (`dataExchangeGet`'s 1 ms sleep), so events wait no
/// longer than they would there, and a stop is heard at once.
const NO_DATA_WAIT: Duration = Duration::from_millis(1);

/// Runs until the daemon stops it or the pipeline hangs up (`Ok`), reopening the
/// device whenever it is lost, or until the camera or a setting contradicts the
/// configuration (`Err`: a configuration error, which no retry mends).
pub fn run(
    lib: &Libcaer,
    camera: &Camera,
    io: &SourceIo,
    retry: RetryTiming,
) -> Result<(), CameraError> {
    let mut backoff = retry.first;
    loop {
        match serve_device(lib, camera, io) {
            Ok(Ended::Stopped) => {
                tracing::info!("camera stopped and closed");
                return Ok(());
            }
            Ok(Ended::Receiver) => return Ok(()),
            Ok(Ended::DeviceLost) => {
                backoff = retry.first;
                tracing::error!(
                    "camera lost: no events until it is back; reopening in {} ms",
                    backoff.as_millis()
                );
            }
            Err(SessionError::Refused(e)) => return Err(e),
            Err(SessionError::Retry(why)) => {
                tracing::warn!("camera: {why}; retry in {} ms", backoff.as_millis())
            }
        }
        if io.stop.wait_timeout(backoff) {
            tracing::info!("camera: stopped while waiting to retry");
            return Ok(());
        }
        backoff = (backoff * 2).min(retry.longest);
    }
}

/// An open libcaer device. Dropping it stops the data transfer if, and only if, it
/// was started, then closes the device; the shutdown flag libcaer's USB thread writes
/// is freed only after both, which end that thread.
struct Device<'a> {
    lib: &'a Libcaer,
    handle: caer::caerDeviceHandle,
    started: bool,
    lost: Box<AtomicBool>,
}

impl<'a> Device<'a> {
    fn open(lib: &'a Libcaer, device: CaerDevice) -> Option<Self> {
        let device_type = device.libcaer_type();
        // SAFETY: a plain FFI call; a non-NULL handle is closed exactly once, on drop.
        let handle = unsafe { (lib.caerDeviceOpen)(1, device_type, 0, 0, std::ptr::null()) };
        (!handle.is_null()).then(|| Self {
            lib,
            handle,
            started: false,
            lost: Box::new(AtomicBool::new(false)),
        })
    }

    /// `caerDeviceConfigSet`: whether libcaer took it.
    fn set(&self, (module, param, value): Setting) -> bool {
        // SAFETY: the handle is open; settings are plain values.
        unsafe { (self.lib.caerDeviceConfigSet)(self.handle, module, param, value) }
    }

    /// `caerDeviceDataStart`, with the shutdown callback on this device's flag.
    fn start(&mut self) -> bool {
        let flag = &*self.lost as *const AtomicBool as *mut std::ffi::c_void;
        // SAFETY: the handle is open; the flag lives until after DataStop and Close.
        self.started = unsafe {
            (self.lib.caerDeviceDataStart)(
                self.handle,
                None,
                None,
                std::ptr::null_mut(),
                Some(on_shutdown),
                flag,
            )
        };
        self.started
    }

    fn lost(&self) -> bool {
        self.lost.load(Ordering::SeqCst)
    }

    /// The DVS size and chip identifier from the family's own info call (libcaer 3
    /// has no generic one), or `None` when libcaer could not tell (all zeros).
    fn dvs_size_and_chip(&self, device: CaerDevice) -> Option<(SensorSize, i16)> {
        let ((width_px, height_px), chip_id) = match device {
            CaerDevice::Davis240 | CaerDevice::Davis346 => {
                // SAFETY: the handle is open; the struct is returned by value (layout
                // pinned in libcaer-sys).
                let info = unsafe { (self.lib.caerDavisInfoGet)(self.handle) };
                (info.dvs_size_px()?, info.chipID)
            }
            CaerDevice::Dvxplorer => {
                // SAFETY: as above, for the DVXplorer's info.
                let info = unsafe { (self.lib.caerDVXplorerInfoGet)(self.handle) };
                (info.dvs_size_px()?, info.chipID)
            }
        };
        let size = SensorSize {
            width_px,
            height_px,
        };
        Some((size, chip_id))
    }
}

impl Drop for Device<'_> {
    fn drop(&mut self) {
        // SAFETY: the handle is open; DataStop only after a successful DataStart.
        unsafe {
            if self.started {
                (self.lib.caerDeviceDataStop)(self.handle);
            }
            (self.lib.caerDeviceClose)(&mut self.handle);
        }
    }
}

/// Opens, configures and streams one device session; the device is stopped (when it
/// was started) and closed before this returns, whatever the reason.
pub fn serve_device(lib: &Libcaer, camera: &Camera, io: &SourceIo) -> Result<Ended, SessionError> {
    let Some(mut device) = Device::open(lib, camera.device) else {
        return Err(SessionError::Retry(why_not_opened(lib, camera.device)));
    };
    check_camera(&device, camera)?;
    start(&mut device, camera)?;
    tracing::info!("camera open: streaming");
    stream(&device, io.clock, &io.batches, &io.stop)
}

/// What to tell the builder when `caerDeviceOpen` found nothing to open. libcaer's
/// open fails the same way (NULL) whatever the cause, but its discovery, which
/// opens each device without claiming it (`usbDeviceFind`, `src/usb_utils.c`),
/// says whether one is there, whether it could be opened, and whether its
/// firmware and logic are the ones libcaer requires; one that passes all three
/// and still does not open could not be claimed: another program holds it.
pub fn why_not_opened(lib: &Libcaer, device: CaerDevice) -> String {
    let Some(found) = lib.discover(device.libcaer_type()) else {
        return "libusb could not list the USB devices (libcaer's discovery failed)".into();
    };
    let Some(camera) = found.first() else {
        return no_camera(device);
    };
    // A device libusb could not open has told nothing of its chip.
    let name = if camera.error_open {
        match camera.device_type {
            caer::CAER_DEVICE_DAVIS => "DAVIS camera",
            _ => "DVXplorer",
        }
    } else {
        chip_name(camera.device_type, camera.chip_id)
    };
    let at = format!(
        "a {name} is on USB (bus {}, address {})",
        camera.usb_bus, camera.usb_address
    );
    if camera.error_open {
        format!(
            "{at} but could not be opened: no permission on its device node (install the udev rule: docs/camera.md; then unplug and replug it)"
        )
    } else if camera.error_version {
        format!(
            "{at} but its firmware ({}) or logic ({}) is not the version this libcaer requires: update the camera's firmware with iniVation's DV software (docs/camera.md)",
            camera.firmware_version, camera.logic_version
        )
    } else {
        format!(
            "{at} but libcaer could not claim it: another program has it open (DV, or a second faithd: `fuser -v /dev/bus/usb/{:03}/{:03}`)",
            camera.usb_bus, camera.usb_address
        )
    }
}

/// What `serve_device` says when no camera of the configured kind is on USB.
pub fn no_camera(device: CaerDevice) -> String {
    format!(
        "no {} on USB (source.device = \"{}\"): plug it in; `lsusb -d 152a:` lists iniVation's cameras",
        device.name(),
        device.key()
    )
}

/// Refuses a camera of another kind than configured, or whose DVS size is not the
/// configured one. A size libcaer cannot report (all zeros: the handle went bad) is
/// worth another try.
fn check_camera(device: &Device<'_>, camera: &Camera) -> Result<(), SessionError> {
    let Some((size, chip_id)) = device.dvs_size_and_chip(camera.device) else {
        return Err(SessionError::Retry(
            "the camera did not report its DVS size".into(),
        ));
    };
    if !camera.device.sizes().contains(&size) {
        return Err(SessionError::Refused(CameraError::OtherCamera {
            found: chip_name(camera.device.libcaer_type(), chip_id),
            size,
            configured: camera.device,
        }));
    }
    if size != camera.expected {
        return Err(SessionError::Refused(CameraError::SizeMismatch {
            camera: size,
            configured: camera.expected,
        }));
    }
    Ok(())
}

/// Sends libcaer's defaults, asks for non-blocking data exchange, starts the transfer,
/// then turns off what DataStart turned on and faithd does not use
/// ([`CaerDevice::own_settings`]) and applies the configured settings, in that order, so that
/// nothing DataStart writes undoes them.
fn start(device: &mut Device<'_>, camera: &Camera) -> Result<(), SessionError> {
    // SAFETY: the handle is open.
    if !unsafe { (device.lib.caerDeviceSendDefaultConfig)(device.handle) } {
        return Err(SessionError::Retry("default configuration refused".into()));
    }
    let non_blocking = (
        caer::CAER_HOST_CONFIG_DATAEXCHANGE,
        caer::CAER_HOST_CONFIG_DATAEXCHANGE_BLOCKING,
        0,
    );
    if !device.set(non_blocking) {
        return Err(SessionError::Retry(
            "non-blocking data exchange refused".into(),
        ));
    }
    let interval = (
        caer::CAER_HOST_CONFIG_PACKETS,
        caer::CAER_HOST_CONFIG_PACKETS_MAX_CONTAINER_INTERVAL,
        CONTAINER_INTERVAL_US,
    );
    if !device.set(interval) {
        // Not fatal: events then wait for libcaer's default 10 ms containers.
        tracing::warn!("camera: a {CONTAINER_INTERVAL_US} us container interval refused");
    }
    if !device.start() {
        return Err(SessionError::Retry("data transfer could not start".into()));
    }
    for &own in camera.device.own_settings() {
        if !device.set(own) {
            // Not fatal: the packets are discarded either way, at some USB cost.
            tracing::warn!(
                "camera: turning off ({}, {}) refused; its packets will be discarded",
                own.0,
                own.1
            );
        }
    }
    for (index, &setting) in camera.settings.iter().enumerate() {
        if !device.set(setting) {
            return Err(SessionError::Refused(CameraError::SettingRefused {
                index,
                setting,
            }));
        }
    }
    Ok(())
}

fn stream(
    device: &Device<'_>,
    clock: DaemonClock,
    batches: &SyncSender<Vec<Event>>,
    stop: &Stop,
) -> Result<Ended, SessionError> {
    let mut device_clock = DeviceClock::new(DeviceClockConfig::default());
    let mut polarity = Vec::new();
    loop {
        if stop.is_requested() {
            return Ok(Ended::Stopped);
        }
        // SAFETY: the handle is open and streaming; the container is ours to free.
        let raw = unsafe { (device.lib.caerDeviceDataGet)(device.handle) };
        // SAFETY: libcaer allocated it (calloc) and handed it over.
        let Some(container) = (unsafe { Container::from_raw(raw) }) else {
            // NULL: nothing ready yet (non-blocking), or the transfers stopped
            // because the device went away; libcaer's USB thread then calls the
            // shutdown callback, maybe a little after.
            if device.lost() {
                return Ok(Ended::DeviceLost);
            }
            stop.wait_timeout(NO_DATA_WAIT);
            continue;
        };
        // Taken before parsing: the nearer to the arrival, the lower the envelope.
        let arrival_us = clock.now_us();
        polarity.clear();
        for packet in container.packets() {
            // SAFETY: the packet lives as long as the container, freed below.
            unsafe { caer::read_polarity_packet(packet, &mut polarity) };
        }
        drop(container);
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
            "camera is 346x260 px but pipeline.camera is 240x180 px: set pipeline.camera.width_px/height_px (and the intrinsics) for this camera"
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
