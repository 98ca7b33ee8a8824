//! A mock iNav autopilot on a real pseudo-terminal: real MAVLink 2 bytes in both
//! directions, telemetry at iNav's rates, and the faults a test flips on
//! ([`Controls`]): a silent link, garbage, held output, another system's frames. Or,
//! for a board without MAVLink ([`MockAutopilot::start_msp_only`]), two MSP ports of
//! one modelled iNav and no MAVLink at all.

use std::io::Read;
use std::os::fd::OwnedFd;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU16, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use faithd_inav::mavlink as inav_mavlink;
use faithd_inav::msp::{Motion, Setup};
use mavlink::MavHeader;
use mavlink::dialects::common::*;

use super::msp::MspMock;
use super::{hold_output, poll_until, raw_pty};

/// Values the test flips while the mock runs.
pub struct Controls {
    pub switch_us: AtomicU16,
    pub armed: AtomicBool,
    pub send_attitude: AtomicBool,
    pub send_rc: AtomicBool,
    /// Interleave random garbage and truncated frames with the real ones.
    pub garbage: AtomicBool,
    /// Roll channel as iNav uses it (the MSP model's answer), echoed in RC_CHANNELS
    /// chan1 as iNav reports it.
    pub roll_us: AtomicU16,
    /// HEARTBEAT system_status (MAV_STATE; 4 ACTIVE, 5 CRITICAL = iNav's failsafe).
    pub system_status: AtomicU8,
    /// The pilot's receiver as SYS_STATUS reports it.
    pub radio_healthy: AtomicBool,
    /// SYS_STATUS sent at all (iNav: mavlink_ext_status_rate = 10, every 120 ms).
    pub send_sys_status: AtomicBool,
    /// iNav ignores faithd's frames although its set-up reads right (a fault the
    /// roll confirmation must catch).
    pub override_ignored: AtomicBool,
    /// The vehicle's motion as iNav estimates it, in iNav's units and signs: what the
    /// model answers MSP_ATTITUDE and MSP_RAW_IMU with (MSP ports only; the MAVLink
    /// telemetry's ATTITUDE stays level at yaw 0.3 rad).
    pub motion: Mutex<Motion>,
    /// The MAVLink ATTITUDE's body rates wobble (iNav's deg/s, a few a second, never
    /// twice the same): a replay fed other samples than a window had derotates it
    /// otherwise, where still rates would hide which samples it took.
    pub wobble: AtomicBool,
}

impl Default for Controls {
    fn default() -> Self {
        Self {
            switch_us: AtomicU16::new(1900),
            armed: AtomicBool::new(true),
            send_attitude: AtomicBool::new(true),
            send_rc: AtomicBool::new(true),
            garbage: AtomicBool::new(false),
            roll_us: AtomicU16::new(PILOT_ROLL_US),
            system_status: AtomicU8::new(4),
            radio_healthy: AtomicBool::new(true),
            send_sys_status: AtomicBool::new(true),
            override_ignored: AtomicBool::new(false),
            // Level, heading 30 degrees, still.
            motion: Mutex::new(Motion {
                yaw_ddeg: 300,
                ..Motion::default()
            }),
            wobble: AtomicBool::new(false),
        }
    }
}

/// One message the mock received, with its arrival time.
#[derive(Clone, Debug)]
pub struct Received {
    pub at: Instant,
    pub header: MavHeader,
    pub msg: MavMessage,
}

/// When the mock wrote its last RC_CHANNELS, and with which switch value.
#[derive(Clone, Copy, Debug)]
pub struct RcSent {
    pub at: Instant,
    pub switch_us: u16,
}

pub struct MockAutopilot {
    pub controls: Arc<Controls>,
    pub received: Arc<Mutex<Vec<Received>>>,
    pub rc_sent: Arc<Mutex<Vec<RcSent>>>,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
    slave: Option<OwnedFd>,
    /// Kept here too, so a quiet mock's port stays open with what it holds.
    master: Option<Arc<OwnedFd>>,
    /// MAVLink's pseudo-terminal (empty for a mock without MAVLink).
    pub slave_path: PathBuf,
    /// iNav's MSP port for faithd's roll stream, on a pseudo-terminal of its own.
    pub msp: MspMock,
    /// A second MSP port of the same iNav, for faithd's telemetry when the board has
    /// no MAVLink ([`MockAutopilot::start_msp_only`]).
    pub telemetry: Option<MspMock>,
    /// A timed test: no heavy test runs while the mock does (dropped last).
    _cpu: super::cpu::Slot,
}

/// The pilot's roll stick in the mock: off centre, so whose value iNav uses is clear.
pub const PILOT_ROLL_US: u16 = 1440;

/// Blocking `Read` over byte chunks from the poll thread; EOF when it stops.
struct ChunkReader {
    rx: mpsc::Receiver<Vec<u8>>,
    pending: Vec<u8>,
}

impl Read for ChunkReader {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.pending.is_empty() {
            match self.rx.recv() {
                Ok(chunk) => self.pending = chunk,
                Err(_) => return Ok(0),
            }
        }
        let n = buf.len().min(self.pending.len());
        buf[..n].copy_from_slice(&self.pending[..n]);
        self.pending.drain(..n);
        Ok(n)
    }
}

fn encode(seq: u8, msg: &MavMessage) -> Vec<u8> {
    let (mut out, mut seq) = (Vec::new(), seq);
    inav_mavlink::encode(&mut out, &mut seq, msg);
    out
}

/// RC_CHANNELS of the mock: the pilot's throttle at 1400, the switch on channel 6.
fn rc_channels(boot_ms: u32, switch_us: u16, roll_us: u16) -> MavMessage {
    inav_mavlink::rc_channels(
        boot_ms,
        [roll_us, 1500, 1400, 1500, 1900, switch_us, 1000, 1000],
        200,
    )
}

/// HEARTBEAT with the MAV_STATE number the test sets (5 CRITICAL: iNav's failsafe).
fn heartbeat(armed: bool, system_status: u8) -> MavMessage {
    let state = match system_status {
        5 => MavState::MAV_STATE_CRITICAL,
        6 => MavState::MAV_STATE_EMERGENCY,
        _ => MavState::MAV_STATE_ACTIVE,
    };
    inav_mavlink::heartbeat(armed, state)
}

impl MockAutopilot {
    /// Starts the mock on a new pseudo-terminal; faithd connects to `slave_path`
    /// (or to a symlink the test points at it).
    pub fn start(controls: Arc<Controls>) -> Self {
        Self::start_with(controls, Setup::default())
    }

    /// The mock of a flight controller set up as `setup` says (its MSP port).
    pub fn start_with(controls: Arc<Controls>, setup: Setup) -> Self {
        let cpu = super::cpu::timed();
        let (master, slave, slave_path) = raw_pty();
        let master = Arc::new(master);
        let stop = Arc::new(AtomicBool::new(false));
        let received = Arc::new(Mutex::new(Vec::new()));
        let rc_sent = Arc::new(Mutex::new(Vec::new()));
        let (chunk_tx, chunk_rx) = mpsc::channel();
        let mut threads = Vec::new();

        // Poll + read the master; bytes to the parser thread.
        {
            let (master, stop) = (master.clone(), stop.clone());
            threads.push(std::thread::spawn(move || {
                let mut buf = [0u8; 4096];
                while !stop.load(Ordering::Relaxed) {
                    let mut fds = [nix::poll::PollFd::new(
                        std::os::fd::AsFd::as_fd(&*master),
                        nix::poll::PollFlags::POLLIN,
                    )];
                    if nix::poll::poll(&mut fds, 10u16).unwrap_or(0) <= 0 {
                        continue;
                    }
                    match nix::unistd::read(&*master, &mut buf) {
                        Ok(n) if n > 0 => {
                            if chunk_tx.send(buf[..n].to_vec()).is_err() {
                                return;
                            }
                        }
                        _ => std::thread::sleep(Duration::from_millis(2)),
                    }
                }
            }));
        }
        // Parse what faithd wrote.
        {
            let received = received.clone();
            threads.push(std::thread::spawn(move || {
                let mut reader = mavlink::MavlinkReader::new(ChunkReader {
                    rx: chunk_rx,
                    pending: Vec::new(),
                });
                // Like iNav beside a radio receiver, RC_CHANNELS_OVERRIDE changes nothing.
                while let Ok((header, msg)) = reader.read_any_message::<MavMessage>() {
                    received.lock().unwrap().push(Received {
                        at: Instant::now(),
                        header,
                        msg,
                    });
                }
            }));
        }
        // Telemetry: ATTITUDE and RC_CHANNELS every 20 ms, twice iNav's fastest (40 ms,
        // telemetry/mavlink.c): on a loaded two-core test machine a thread can be
        // late by tens of milliseconds, and at iNav's own rate that alone would make
        // ATTITUDE stale (100 ms) in a test about something else. The closed loop's
        // simulated iNav and the SITL tests run at iNav's 40 ms. SYS_STATUS every
        // 120 ms and HEARTBEAT once a second, as iNav sends them.
        {
            let (master, stop, controls, rc_sent) = (
                master.clone(),
                stop.clone(),
                controls.clone(),
                rc_sent.clone(),
            );
            threads.push(std::thread::spawn(move || {
                let start = Instant::now();
                let mut seq = 0u8;
                let mut rng = 0x2545_f491_4f6c_dd1du64;
                let mut tick = 0u64;
                while !stop.load(Ordering::Relaxed) {
                    let boot_ms = start.elapsed().as_millis() as u32;
                    let mut out = Vec::new();
                    if controls.send_attitude.load(Ordering::Relaxed) {
                        let wobble = controls.wobble.load(Ordering::Relaxed);
                        out.extend(encode(seq, &attitude(boot_ms, wobble)));
                        seq = seq.wrapping_add(1);
                    }
                    let switch_us = controls.switch_us.load(Ordering::Relaxed);
                    let send_rc = controls.send_rc.load(Ordering::Relaxed);
                    if send_rc {
                        let roll_us = controls.roll_us.load(Ordering::Relaxed);
                        out.extend(encode(seq, &rc_channels(boot_ms, switch_us, roll_us)));
                        seq = seq.wrapping_add(1);
                    }
                    if tick.is_multiple_of(50) {
                        out.extend(encode(
                            seq,
                            &heartbeat(
                                controls.armed.load(Ordering::Relaxed),
                                controls.system_status.load(Ordering::Relaxed),
                            ),
                        ));
                        seq = seq.wrapping_add(1);
                    }
                    if tick.is_multiple_of(6) && controls.send_sys_status.load(Ordering::Relaxed) {
                        out.extend(encode(
                            seq,
                            &inav_mavlink::sys_status(
                                controls.radio_healthy.load(Ordering::Relaxed),
                            ),
                        ));
                        seq = seq.wrapping_add(1);
                    }
                    if controls.garbage.load(Ordering::Relaxed) {
                        out = with_garbage(out, &mut rng, seq);
                    }
                    // Stamped before the write: faithd may answer before write() returns.
                    let sent_at = Instant::now();
                    // A full buffer (nobody reading the port) loses bytes, as a UART would.
                    let _ = nix::unistd::write(&*master, &out);
                    if send_rc {
                        rc_sent.lock().unwrap().push(RcSent {
                            at: sent_at,
                            switch_us,
                        });
                    }
                    tick += 1;
                    // On a fixed schedule, not a fixed pause: a late tick does not
                    // delay the ones after it.
                    let next = start + Duration::from_millis(20) * tick as u32;
                    if let Some(wait) = next.checked_duration_since(Instant::now()) {
                        std::thread::sleep(wait);
                    }
                }
            }));
        }
        MockAutopilot {
            msp: MspMock::start_with(controls.clone(), setup),
            telemetry: None,
            controls,
            received,
            rc_sent,
            stop,
            threads,
            slave: Some(slave),
            master: Some(master),
            slave_path,
            _cpu: cpu,
        }
    }

    /// The mock of a flight controller without MAVLink (an iNav board that speaks MSP
    /// only), set up as `setup` says: no MAVLink port and no MAVLink thread, and two
    /// MSP ports of one modelled iNav ([`MspMock::start_board`]), `msp` for the roll
    /// stream and `telemetry` for what faithd reads. They share the override, the
    /// modes and the global variables, as two UARTs of one board do. The MAVLink
    /// methods have nothing to act on ([`Self::hold_faithds_writes`] panics).
    pub fn start_msp_only(controls: Arc<Controls>, setup: Setup) -> MockAutopilot {
        let cpu = super::cpu::timed();
        let mut ports = MspMock::start_board(controls.clone(), setup, 2);
        let telemetry = ports.pop();
        let msp = ports.pop().expect("the command port");
        MockAutopilot {
            msp,
            telemetry,
            controls,
            received: Arc::new(Mutex::new(Vec::new())),
            rc_sent: Arc::new(Mutex::new(Vec::new())),
            stop: Arc::new(AtomicBool::new(false)),
            threads: Vec::new(),
            slave: None,
            master: None,
            slave_path: PathBuf::new(),
            _cpu: cpu,
        }
    }

    /// faithd's `[telemetry]` and `[command.sink]` sections for a mock started with
    /// [`Self::start_msp_only`].
    pub fn msp_only_toml(&self) -> String {
        let telemetry = self
            .telemetry
            .as_ref()
            .expect("a mock started with start_msp_only");
        format!(
            "[telemetry]\nkind = \"msp\"\nendpoint = \"serial:{}\"\n\n{}",
            telemetry.slave_path.display(),
            self.msp.command_toml()
        )
    }

    /// Stops all telemetry but keeps the port open: what was written and not read
    /// stays queued in it.
    pub fn go_quiet(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            t.join().unwrap();
        }
    }

    /// Holds (or lets go) faithd's writes on the MAVLink port.
    pub fn hold_faithds_writes(&self, held: bool) {
        hold_output(self.slave.as_ref().expect("port plugged"), held);
    }

    /// Closes the MAVLink port alone (its cable out); the MSP port stays.
    pub fn unplug_mavlink(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            t.join().unwrap();
        }
        self.slave = None;
        self.master = None;
    }

    /// faithd's `[command]` section for this mock's MSP port.
    pub fn command_toml(&self) -> String {
        self.msp.command_toml()
    }

    /// A config as the service runs it (the camera through libcaer, no simulated
    /// source) against this mock: libcaer from `libcaer_path`, `record` as the
    /// `[record]` section's body.
    pub fn service_toml(&self, libcaer_path: &str, record: &str) -> String {
        format!(
            "[mavlink]\nendpoint = \"serial:{}\"\n{}[source]\nkind = \"caer\"\nlibcaer_path = \"{libcaer_path}\"\n[record]\n{record}\n",
            self.slave_path.display(),
            self.command_toml()
        )
    }

    /// For `faithd::daemon::serve` in the test's own process: the config (simulated
    /// camera with `source` TOML lines, no recording) and both endpoints on this mock.
    pub fn serve_config(
        &self,
        source: &str,
    ) -> (
        faithd::config::FaithdConfig,
        faithd::transport::Endpoint,
        faithd::transport::Endpoint,
    ) {
        let text = format!(
            "[mavlink]\nendpoint = \"serial:{}\"\n{}[source]\nkind = \"sim\"\n{source}[record]\nenabled = false\n",
            self.slave_path.display(),
            self.command_toml()
        );
        let config = faithd::config::FaithdConfig::parse(&text).unwrap();
        let endpoint = config.mavlink.port();
        let msp = config.command.msp_port();
        (config, endpoint, msp)
    }

    /// The roll iNav used, by time: see [`MspMock::first_roll`].
    pub fn first_roll(&self) -> Option<Instant> {
        self.msp.first_roll()
    }

    /// Closes the MAVLink and MSP ports: faithd sees both devices vanish.
    pub fn unplug(mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            t.join().unwrap();
        }
    }

    pub fn heartbeats(&self) -> usize {
        self.received
            .lock()
            .unwrap()
            .iter()
            .filter(|r| {
                matches!(&r.msg, MavMessage::HEARTBEAT(h) if h.mavtype == MavType::MAV_TYPE_ONBOARD_CONTROLLER)
                    && r.header.component_id == 191
            })
            .count()
    }

    /// Waits until `pred` holds for the received messages, or `timeout` passes.
    pub fn wait_for(&self, timeout: Duration, pred: impl Fn(&MockAutopilot) -> bool) -> bool {
        poll_until(timeout, || pred(self))
    }
}

impl Drop for MockAutopilot {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// iNav's ATTITUDE at `boot_ms`: level, still or (`wobble`) turning back and forth at
/// up to 8 deg/s in yaw and 4 in pitch (telemetry/mavlink.c sends the gyro in deg/s).
fn attitude(boot_ms: u32, wobble: bool) -> MavMessage {
    let phase = f64::from(boot_ms) * 1e-3 * std::f64::consts::TAU * 1.3;
    let (yawspeed, pitchspeed) = if wobble {
        (
            (8.0 * phase.sin()) as f32,
            (4.0 * (1.7 * phase).cos()) as f32,
        )
    } else {
        (0.0, 0.0)
    };
    MavMessage::ATTITUDE(ATTITUDE_DATA {
        time_boot_ms: boot_ms,
        roll: 0.0,
        pitch: 0.0,
        yaw: 0.3,
        rollspeed: 0.0,
        pitchspeed,
        yawspeed,
    })
}

/// Random bytes, a truncated frame and a frame with a broken checksum around `frames`.
fn with_garbage(frames: Vec<u8>, rng: &mut u64, seq: u8) -> Vec<u8> {
    let mut next = || {
        *rng ^= *rng << 13;
        *rng ^= *rng >> 7;
        *rng ^= *rng << 17;
        *rng
    };
    let mut out: Vec<u8> = (0..(next() % 40)).map(|_| next() as u8).collect();
    out.push(0xFD); // a start marker with nothing sensible after it
    let hb = encode(seq, &heartbeat(false, 4));
    out.extend_from_slice(&hb[..hb.len() / 2]); // truncated: would say "disarmed"
    let mut bad = encode(seq, &heartbeat(false, 4));
    let n = bad.len();
    bad[n - 1] ^= 0x55; // checksum broken: must be dropped, not believed
    out.extend(bad);
    out.extend(frames);
    out
}
