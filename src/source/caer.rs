//! The live camera: a DVS240/DAVIS240 through libcaer, opened at run time
//! ([`libcaer_sys::Libcaer`]).
//!
//! Opens the first DAVIS on USB, applies the configured (module, parameter, value)
//! settings after libcaer's defaults, and hands polarity events to the pipeline on
//! the daemon's clock (the device clock's offset is fixed at the first event). When
//! the device vanishes (libcaer's shutdown callback, or no data), the source says so,
//! sends nothing (the pipeline goes unhealthy, the safety gate releases), and keeps
//! trying to reopen it with backoff.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError};
use std::time::Duration;

use libcaer_sys::{self as caer, Libcaer};

use crate::daemon::clock::DaemonClock;
use crate::event::{Event, Polarity};

/// One libcaer configuration write.
pub type Setting = (i8, u8, u32);

unsafe extern "C" fn on_shutdown(ptr: *mut std::ffi::c_void) {
    // SAFETY: `ptr` is the `AtomicBool` that `serve_device` keeps alive until after
    // caerDeviceDataStop/Close, which end the callbacks.
    let flag = unsafe { &*(ptr as *const AtomicBool) };
    flag.store(true, Ordering::SeqCst);
}

/// Why a device session ended.
#[derive(Debug, PartialEq, Eq)]
pub enum Ended {
    /// The pipeline hung up: the daemon is stopping.
    Receiver,
    /// The device went away.
    DeviceLost,
}

/// Runs until the pipeline hangs up, reopening the device whenever it is lost.
pub fn run(
    lib: &Libcaer,
    settings: Vec<Setting>,
    clock: DaemonClock,
    batches: SyncSender<Vec<Event>>,
    max_backoff: Duration,
) {
    let mut backoff = Duration::from_millis(50);
    loop {
        match serve_device(lib, &settings, clock, &batches) {
            Ok(Ended::Receiver) => return,
            Ok(Ended::DeviceLost) => {
                tracing::error!("camera lost: no events until it is back; reopening");
                backoff = Duration::from_millis(50);
            }
            Err(why) => tracing::warn!("camera: {why}; retry in {} ms", backoff.as_millis()),
        }
        std::thread::sleep(backoff);
        backoff = (backoff * 2).min(max_backoff);
    }
}

/// Opens, configures and streams one device session.
pub fn serve_device(
    lib: &Libcaer,
    settings: &[Setting],
    clock: DaemonClock,
    batches: &SyncSender<Vec<Event>>,
) -> Result<Ended, String> {
    // SAFETY: plain FFI calls on a handle libcaer gave us, closed exactly once below.
    let mut handle =
        unsafe { (lib.caerDeviceOpen)(1, caer::CAER_DEVICE_DAVIS, 0, 0, std::ptr::null()) };
    if handle.is_null() {
        return Err("no DAVIS camera could be opened".into());
    }
    let lost = Box::new(AtomicBool::new(false));
    let result = stream(lib, handle, settings, clock, batches, &lost);
    // SAFETY: stop before close; the callback flag outlives both.
    unsafe {
        (lib.caerDeviceDataStop)(handle);
        (lib.caerDeviceClose)(&mut handle);
    }
    drop(lost);
    result
}

fn stream(
    lib: &Libcaer,
    handle: caer::caerDeviceHandle,
    settings: &[Setting],
    clock: DaemonClock,
    batches: &SyncSender<Vec<Event>>,
    lost: &AtomicBool,
) -> Result<Ended, String> {
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
    tracing::info!("camera open: streaming");
    let mut offset_us: Option<i64> = None;
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
        let Some(first) = polarity.first() else {
            continue;
        };
        let offset = *offset_us.get_or_insert(clock.now_us() - first.t_us);
        let batch: Vec<Event> = polarity
            .iter()
            .map(|p| Event::new(p.t_us + offset, p.x, p.y, Polarity::from_bool(p.on)))
            .collect();
        match batches.try_send(batch) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) => {
                tracing::warn!("pipeline not keeping up: camera packet dropped")
            }
            Err(TrySendError::Disconnected(_)) => return Ok(Ended::Receiver),
        }
    }
}
