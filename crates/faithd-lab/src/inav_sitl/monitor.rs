//! What iNav really uses, read back over MSP on its own UART: the channels after
//! every override (MSP_RC) and its status (arming flags, active modes), every 10 ms.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::clock::unix_us;
use super::msp_client::{MSP_BOXIDS, MSP_RC, MSP2_INAV_STATUS, MspClient};
use super::process::{Sitl, SitlError, UART_MONITOR};
use super::radio::{CH_ARM, Radio};

/// iNav's arming flags (fc/runtime_config.h).
pub const ARMED: u32 = 1 << 2;
const ARMING_DISABLED_ARM_SWITCH: u32 = 1 << 14;
/// Every "arming disabled" flag (bits 6 to 30).
const ARMING_BLOCKERS: u32 = 0x7FFF_FFC0;

/// iNav's mode ids (permanent, fc/fc_msp_box.c).
pub const MODE_ANGLE: u8 = 1;
pub const MODE_FAILSAFE: u8 = 27;
pub const MODE_MSP_RC_OVERRIDE: u8 = 50;

/// What iNav reported at one moment: the channels it uses (MSP_RC, iNav's order:
/// roll, pitch, yaw, throttle, then AUX1...) and its status.
#[derive(Clone, Debug)]
pub struct Sample {
    pub t_us: i64,
    pub rc: Vec<u16>,
    pub arming_flags: u32,
    /// Permanent ids of the modes active (fc/fc_msp_box.c).
    pub modes: Vec<u8>,
    /// iNav's eight global variables (MSP2_INAV_GVAR_STATUS), read with every fifth
    /// sample; `None` in the others.
    pub gvars: Option<[i32; 8]>,
}

impl Sample {
    pub fn roll(&self) -> u16 {
        self.rc[0]
    }
    pub fn armed(&self) -> bool {
        self.arming_flags & ARMED != 0
    }
    pub fn mode(&self, permanent_id: u8) -> bool {
        self.modes.contains(&permanent_id)
    }
}

/// MSP2_INAV_GVAR_STATUS: the global variables, int32 each (fc/fc_msp.c).
const MSP2_INAV_GVAR_STATUS: u16 = 0x2027;

/// Reads MSP_RC and MSP2_INAV_STATUS from UART2 every 10 ms (and the global
/// variables with every fifth sample).
pub struct Monitor {
    pub samples: Arc<Mutex<Vec<Sample>>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Monitor {
    pub fn start(sitl: &Sitl) -> Result<Self, SitlError> {
        Self::start_on(sitl, UART_MONITOR)
    }

    /// The monitor on `uart` (UART1, the CLI's, when UART2 cannot be an MSP port:
    /// iNav allows three).
    pub fn start_on(sitl: &Sitl, uart: u16) -> Result<Self, SitlError> {
        let mut client = MspClient::connect(sitl.port(uart))
            .map_err(|e| SitlError::Other(format!("the monitor's UART{uart}: {e}")))?;
        let box_ids = client
            .request(MSP_BOXIDS, &[])
            .map_err(|e| SitlError::Other(format!("MSP_BOXIDS: {e}")))?;
        let samples = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (samples, stop) = (samples.clone(), stop.clone());
            std::thread::spawn(move || {
                let mut n = 0u64;
                while !stop.load(Ordering::Relaxed) {
                    n += 1;
                    let next = Instant::now() + Duration::from_millis(10);
                    let t_us = unix_us();
                    let (Ok(rc), Ok(status)) = (
                        client.request(MSP_RC, &[]),
                        client.request(MSP2_INAV_STATUS, &[]),
                    ) else {
                        continue;
                    };
                    samples.lock().expect("samples lock").push(Sample {
                        t_us,
                        rc: rc
                            .chunks_exact(2)
                            .map(|c| u16::from_le_bytes([c[0], c[1]]))
                            .collect(),
                        arming_flags: u32_at(&status, 9),
                        modes: active_modes(&status[13.min(status.len())..], &box_ids),
                        gvars: n
                            .is_multiple_of(5)
                            .then(|| client.request(MSP2_INAV_GVAR_STATUS, &[]).ok())
                            .flatten()
                            .map(|g| std::array::from_fn(|i| i32_at(&g, 4 * i))),
                    });
                    if let Some(wait) = next.checked_duration_since(Instant::now()) {
                        std::thread::sleep(wait);
                    }
                }
            })
        };
        Ok(Monitor {
            samples,
            stop,
            thread: Some(thread),
        })
    }

    pub fn latest(&self) -> Option<Sample> {
        self.samples.lock().expect("samples lock").last().cloned()
    }

    /// Samples taken from `from_us` to `to_us` (Unix time).
    pub fn between(&self, from_us: i64, to_us: i64) -> Vec<Sample> {
        self.samples
            .lock()
            .expect("samples lock")
            .iter()
            .filter(|s| s.t_us >= from_us && s.t_us <= to_us)
            .cloned()
            .collect()
    }

    /// Waits until the latest sample satisfies `pred`.
    pub fn wait_until(&self, timeout: Duration, pred: impl Fn(&Sample) -> bool) -> Option<Sample> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(s) = self.latest().filter(|s| pred(s)) {
                return Some(s);
            }
            if Instant::now() > deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

impl Drop for Monitor {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn u32_at(b: &[u8], i: usize) -> u32 {
    b.get(i..i + 4)
        .map_or(0, |s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

/// MSP2_INAV_STATUS's mode bits are positions in MSP_BOXIDS's list.
fn active_modes(bits: &[u8], box_ids: &[u8]) -> Vec<u8> {
    box_ids
        .iter()
        .enumerate()
        .filter(|(i, _)| bits.get(i / 8).is_some_and(|b| b & (1 << (i % 8)) != 0))
        .map(|(_, id)| *id)
        .collect()
}

/// The pilot arms: waits until iNav has no reason to refuse but the ARM switch
/// (sensor calibration ends 3-4 s after boot), raises ARM, waits for ARMED.
pub fn arm(radio: &Radio, monitor: &Monitor, sitl: &Sitl) -> Result<(), SitlError> {
    let ready = monitor.wait_until(Duration::from_secs(20), |s| {
        s.arming_flags & ARMING_BLOCKERS & !ARMING_DISABLED_ARM_SWITCH == 0
    });
    if ready.is_none() {
        return Err(SitlError::Other(format!(
            "SITL never became armable: flags {:#x}; SITL log:\n{}",
            monitor.latest().map_or(0, |s| s.arming_flags),
            sitl.log()
        )));
    }
    for _ in 0..3 {
        radio.set(CH_ARM, 1000);
        std::thread::sleep(Duration::from_millis(150));
        radio.set(CH_ARM, 1900);
        if monitor
            .wait_until(Duration::from_secs(2), |s| s.armed())
            .is_some()
        {
            return Ok(());
        }
    }
    Err(SitlError::Other(format!(
        "SITL did not arm: flags {:#x}",
        monitor.latest().map_or(0, |s| s.arming_flags)
    )))
}

fn i32_at(bytes: &[u8], at: usize) -> i32 {
    bytes
        .get(at..at + 4)
        .map_or(0, |b| i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}
