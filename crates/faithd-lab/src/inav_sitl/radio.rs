//! The pilot's radio: IBUS frames (FlySky's serial receiver protocol, 14 channels)
//! into SITL's serial receiver UART every 7 ms, as an IBUS receiver sends them
//! (iNav 9.1 src/main/rx/ibus.c reads the 0x20 0x40 header, 14 little-endian
//! channels and 0xFFFF minus the byte sum).

use std::io::Write;
use std::net::TcpStream;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::clock::unix_us;
use super::process::{Sitl, SitlError, UART_RADIO};

/// Channel values of the pilot's radio, in radio order (1-based channel n at n-1).
pub const PILOT_CHANNELS: usize = 14;

/// What the radio sent: (unix us, channels).
pub type RadioFrame = (i64, [u16; PILOT_CHANNELS]);

/// Radio channels of the set-up (1-based; AETR as iNav's default map reads them).
pub const CH_ROLL: usize = 1;
pub const CH_PITCH: usize = 2;
pub const CH_THROTTLE: usize = 3;
pub const CH_YAW: usize = 4;
pub const CH_ARM: usize = 5;
pub const CH_SWITCH: usize = 6;
/// The pilot's roll stick while faithd runs in the route tests: off centre, so that
/// whose value iNav uses is never in doubt.
pub const PILOT_ROLL_US: u16 = 1440;
pub const AUTO_US: u16 = 1900;
pub const MANUAL_US: u16 = 1000;

/// One IBUS frame: 0x20 0x40, 14 channels LE, then 0xFFFF minus the byte sum.
pub fn ibus_frame(channels: &[u16; PILOT_CHANNELS]) -> Vec<u8> {
    let mut f = vec![0x20, 0x40];
    for v in channels {
        f.extend_from_slice(&v.to_le_bytes());
    }
    let sum: u16 = f.iter().fold(0u16, |s, b| s.wrapping_add(u16::from(*b)));
    f.extend_from_slice(&(0xFFFF - sum).to_le_bytes());
    f
}

pub struct Radio {
    channels: Arc<Mutex<[u16; PILOT_CHANNELS]>>,
    on: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    /// When each change of the channels was first sent: (unix us, channels).
    pub sent: Arc<Mutex<Vec<RadioFrame>>>,
    thread: Option<JoinHandle<()>>,
}

impl Radio {
    /// Sticks centred, throttle low, ARM low, switch in MANUAL.
    pub fn start(sitl: &Sitl) -> Result<Self, SitlError> {
        let mut initial = [1500u16; PILOT_CHANNELS];
        initial[CH_THROTTLE - 1] = 1000;
        initial[CH_ARM - 1] = 1000;
        initial[CH_SWITCH - 1] = MANUAL_US;
        let channels = Arc::new(Mutex::new(initial));
        let on = Arc::new(AtomicBool::new(true));
        let stop = Arc::new(AtomicBool::new(false));
        let sent = Arc::new(Mutex::new(Vec::new()));
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut stream = loop {
            match TcpStream::connect(("127.0.0.1", sitl.port(UART_RADIO))) {
                Ok(s) => break s,
                Err(e) if Instant::now() > deadline => {
                    return Err(SitlError::Other(format!(
                        "the receiver's UART{UART_RADIO} never listened: {e}"
                    )));
                }
                Err(_) => std::thread::sleep(Duration::from_millis(50)),
            }
        };
        stream
            .set_nodelay(true)
            .map_err(|e| SitlError::Other(format!("radio socket: {e}")))?;
        let thread = {
            let (channels, on, stop, sent) =
                (channels.clone(), on.clone(), stop.clone(), sent.clone());
            std::thread::spawn(move || {
                let mut last = None;
                let mut next = Instant::now();
                while !stop.load(Ordering::Relaxed) {
                    if on.load(Ordering::Relaxed) {
                        let now = *channels.lock().expect("channels lock");
                        let t = unix_us();
                        if stream.write_all(&ibus_frame(&now)).is_err() {
                            return;
                        }
                        if last != Some(now) {
                            sent.lock().expect("sent lock").push((t, now));
                            last = Some(now);
                        }
                    }
                    next += Duration::from_millis(7);
                    if let Some(wait) = next.checked_duration_since(Instant::now()) {
                        std::thread::sleep(wait);
                    } else {
                        next = Instant::now();
                    }
                }
            })
        };
        Ok(Radio {
            channels,
            on,
            stop,
            sent,
            thread: Some(thread),
        })
    }

    /// Sets radio channel `ch` (1-based); returns the Unix time of the change.
    pub fn set(&self, ch: usize, value_us: u16) -> i64 {
        self.channels.lock().expect("channels lock")[ch - 1] = value_us;
        unix_us()
    }

    pub fn channels(&self) -> [u16; PILOT_CHANNELS] {
        *self.channels.lock().expect("channels lock")
    }

    /// Radio loss (out of range, receiver unplugged): no more frames until `true`.
    pub fn transmit(&self, on: bool) {
        self.on.store(on, Ordering::Relaxed);
    }
}

impl Drop for Radio {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
