//! A mock iNav autopilot on a real pseudo-terminal, speaking real MAVLink 2 bytes,
//! and a guard that runs the real `faithd run` binary against it; iNav's own
//! firmware (SITL) in [`sitl`].

#![allow(dead_code)]

pub mod sitl;

use std::io::Read;
use std::os::fd::OwnedFd;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU16, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use faithd::closed_loop::inav_mavlink;
use mavlink::MavHeader;
use mavlink::dialects::common::*;

/// Polls `pred` every 5 ms until it holds or `timeout` passes; its last answer.
pub fn poll_until(timeout: Duration, mut pred: impl FnMut() -> bool) -> bool {
    let deadline = Instant::now() + timeout;
    while Instant::now() < deadline {
        if pred() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    pred()
}

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
    /// iNav ignores faithd's frames although its set-up reads right (a fault the
    /// roll confirmation must catch).
    pub override_ignored: AtomicBool,
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
            override_ignored: AtomicBool::new(false),
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
    pub slave_path: PathBuf,
    /// iNav's MSP port for faithd's roll stream, on a pseudo-terminal of its own.
    pub msp: MspMock,
}

/// The pilot's roll stick in the mock: off centre, so whose value iNav uses is clear.
pub const PILOT_ROLL_US: u16 = 1440;

/// tcflow on a pseudo-terminal's slave: TCOOFF stops what is written to it from
/// leaving (its writers block), TCOON lets it go again.
fn hold_output(slave: &OwnedFd, held: bool) {
    use nix::sys::termios::{FlowArg, tcflow};
    let action = if held {
        FlowArg::TCOOFF
    } else {
        FlowArg::TCOON
    };
    tcflow(slave, action).expect("tcflow");
}

pub fn raw_pty() -> (OwnedFd, OwnedFd, PathBuf) {
    let pty = nix::pty::openpty(None, None).expect("openpty");
    let mut t = nix::sys::termios::tcgetattr(&pty.slave).expect("tcgetattr");
    nix::sys::termios::cfmakeraw(&mut t);
    nix::sys::termios::tcsetattr(&pty.slave, nix::sys::termios::SetArg::TCSANOW, &t)
        .expect("tcsetattr");
    let path = nix::unistd::ttyname(&pty.slave).expect("ttyname");
    let flags = nix::fcntl::fcntl(&pty.master, nix::fcntl::FcntlArg::F_GETFL).unwrap();
    let mut flags = nix::fcntl::OFlag::from_bits_truncate(flags);
    flags.insert(nix::fcntl::OFlag::O_NONBLOCK);
    nix::fcntl::fcntl(&pty.master, nix::fcntl::FcntlArg::F_SETFL(flags)).unwrap();
    (pty.master, pty.slave, path)
}

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
        // Telemetry: ATTITUDE at 50 Hz, RC_CHANNELS at 50 Hz, HEARTBEAT at 5 Hz.
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
                        out.extend(encode(seq, &attitude(boot_ms)));
                        seq = seq.wrapping_add(1);
                    }
                    let switch_us = controls.switch_us.load(Ordering::Relaxed);
                    let send_rc = controls.send_rc.load(Ordering::Relaxed);
                    if send_rc {
                        let roll_us = controls.roll_us.load(Ordering::Relaxed);
                        out.extend(encode(seq, &rc_channels(boot_ms, switch_us, roll_us)));
                        seq = seq.wrapping_add(1);
                    }
                    if tick.is_multiple_of(10) {
                        out.extend(encode(
                            seq,
                            &heartbeat(
                                controls.armed.load(Ordering::Relaxed),
                                controls.system_status.load(Ordering::Relaxed),
                            ),
                        ));
                        seq = seq.wrapping_add(1);
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
                    std::thread::sleep(Duration::from_millis(20));
                }
            }));
        }
        MockAutopilot {
            msp: MspMock::start(controls.clone()),
            controls,
            received,
            rc_sent,
            stop,
            threads,
            slave: Some(slave),
            master: Some(master),
            slave_path,
        }
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
        faithd::link::endpoint::Endpoint,
        faithd::link::endpoint::Endpoint,
    ) {
        use faithd::link::endpoint::Endpoint;
        let text = format!(
            "[mavlink]\nendpoint = \"serial:{}\"\n{}[source]\nkind = \"sim\"\n{source}[record]\nenabled = false\n",
            self.slave_path.display(),
            self.command_toml()
        );
        let config = faithd::config::FaithdConfig::parse(&text).unwrap();
        let endpoint = Endpoint::parse(&config.mavlink.endpoint, config.mavlink.baud).unwrap();
        let msp = Endpoint::parse(&config.command.msp_endpoint, config.command.msp_baud).unwrap();
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

    pub fn overrides(&self) -> Vec<(Instant, RC_CHANNELS_OVERRIDE_DATA)> {
        self.received
            .lock()
            .unwrap()
            .iter()
            .filter_map(|r| match &r.msg {
                MavMessage::RC_CHANNELS_OVERRIDE(o) => Some((r.at, o.clone())),
                _ => None,
            })
            .collect()
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

fn attitude(boot_ms: u32) -> MavMessage {
    MavMessage::ATTITUDE(ATTITUDE_DATA {
        time_boot_ms: boot_ms,
        roll: 0.0,
        pitch: 0.0,
        yaw: 0.3,
        rollspeed: 0.0,
        pitchspeed: 0.0,
        yawspeed: 0.0,
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

/// `faithd run` as a child process; killed (SIGTERM, then SIGKILL) on drop.
pub struct Daemon {
    child: Child,
    pub log_path: PathBuf,
    _dir: TempDir,
}

/// A scratch directory (the `tempfile` crate), removed when dropped; `.0` is its path.
pub struct TempDir(pub PathBuf, #[allow(dead_code)] tempfile::TempDir);

impl TempDir {
    pub fn new(tag: &str) -> Self {
        let dir = tempfile::Builder::new()
            .prefix(&format!("faithd-test-{tag}-"))
            .tempdir()
            .expect("a scratch directory");
        TempDir(dir.path().to_path_buf(), dir)
    }
}

impl Daemon {
    /// Starts faithd with the shipped defaults plus `extra` TOML, talking MAVLink to
    /// `endpoint` (`extra` must name the MSP port: [`MspMock::command_toml`]).
    pub fn start(endpoint: &str, extra: &str) -> Self {
        Self::start_with_env(endpoint, extra, &[])
    }

    /// Starts faithd against a mock autopilot: MAVLink on its pseudo-terminal, the
    /// roll stream on its MSP pseudo-terminal, plus `extra` TOML.
    pub fn start_mock(mock: &MockAutopilot, extra: &str) -> Self {
        Self::start(
            &format!("serial:{}", mock.slave_path.display()),
            &format!("{}{extra}", mock.command_toml()),
        )
    }

    /// As [`Daemon::start`], with extra environment variables.
    pub fn start_with_env(endpoint: &str, extra: &str, env: &[(&str, &str)]) -> Self {
        Self::start_config(
            &format!(
                "[mavlink]\nendpoint = \"{endpoint}\"\nreconnect_min_us = 50000\nreconnect_max_us = 200000\n\
                 [source]\nkind = \"sim\"\nsim_first_approach_us = 600000\nsim_repeat_us = 4000000\n{extra}"
            ),
            env,
        )
    }

    /// Starts `faithd run --simulated-camera` on `config` (TOML); recordings go to
    /// [`Daemon::flights_dir`] unless the config says otherwise.
    pub fn start_config(config_text: &str, env: &[(&str, &str)]) -> Self {
        let dir = TempDir::new("daemon");
        let config = dir.0.join("faithd.toml");
        let record = if config_text.contains("[record]") {
            String::new()
        } else {
            format!("[record]\ndir = \"{}\"\n", dir.0.join("flights").display())
        };
        std::fs::write(&config, format!("{config_text}\n{record}")).unwrap();
        let log_path = dir.0.join("faithd.log");
        let log = std::fs::File::create(&log_path).unwrap();
        let child = Command::new(env!("CARGO_BIN_EXE_faithd"))
            .arg("run")
            .arg("--simulated-camera")
            .arg("--config")
            .arg(&config)
            .env("RUST_LOG", "info")
            .envs(env.iter().copied())
            .stdout(Stdio::null())
            .stderr(log)
            .spawn()
            .expect("start faithd");
        Daemon {
            child,
            log_path,
            _dir: dir,
        }
    }

    /// Where this daemon records its flights.
    pub fn flights_dir(&self) -> PathBuf {
        self._dir.0.join("flights")
    }

    pub fn log(&self) -> String {
        std::fs::read_to_string(&self.log_path).unwrap_or_default()
    }

    pub fn is_running(&mut self) -> bool {
        self.child.try_wait().unwrap().is_none()
    }

    /// SIGTERM and wait: faithd releases the roll channel and exits 0.
    pub fn stop(&mut self) -> std::process::ExitStatus {
        self.signal(nix::sys::signal::Signal::SIGTERM)
    }

    /// Sends `signal` and waits for the exit.
    pub fn signal(&mut self, signal: nix::sys::signal::Signal) -> std::process::ExitStatus {
        let _ = nix::sys::signal::kill(nix::unistd::Pid::from_raw(self.child.id() as i32), signal);
        self.child.wait().unwrap()
    }

    /// Waits until the journal holds `needle` (or `timeout` passes).
    pub fn wait_for_log(&self, needle: &str, timeout: Duration) -> bool {
        poll_until(timeout, || self.log().contains(needle))
    }
}

impl Drop for Daemon {
    fn drop(&mut self) {
        if self.is_running() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Points `link` at `target`, atomically replacing what was there.
pub fn point_symlink(link: &Path, target: &Path) {
    let tmp = link.with_extension("new");
    let _ = std::fs::remove_file(&tmp);
    std::os::unix::fs::symlink(target, &tmp).unwrap();
    std::fs::rename(&tmp, link).unwrap();
}

/// iNav's MSP port on a pseudo-terminal, answered by faithd's own model of iNav
/// (`faithd::closed_loop::inav_msp`: the committed set-up, MSP RC override timing as
/// measured on SITL). It records the roll the model says iNav uses, every 5 ms and
/// at every frame. A model encodes our assumptions: `tests/inav_sitl.rs` holds faithd
/// to iNav's own firmware; these tests cover what SITL cannot be made to do (stale
/// telemetry, garbage on the wire, a vanishing port).
pub struct MspMock {
    pub slave_path: PathBuf,
    /// (time, roll value the model's iNav uses)
    pub roll_log: Arc<Mutex<Vec<(Instant, u16)>>>,
    /// Every MSP_SET_RAW_RC faithd wrote: (time, channels).
    pub frames: Arc<Mutex<Vec<Written>>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    _slave: OwnedFd,
}

/// One MSP_SET_RAW_RC faithd wrote: when, and its channels.
pub type Written = (Instant, Vec<u16>);

pub fn is_roll(v: u16) -> bool {
    v == 1200 || v == 1800
}

impl MspMock {
    pub fn start(controls: Arc<Controls>) -> Self {
        use faithd::closed_loop::inav_msp::{FcView, InavMsp, Setup};
        let (master, slave, slave_path) = raw_pty();
        let roll_log = Arc::new(Mutex::new(Vec::new()));
        let frames = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (roll_log, frames, stop) = (roll_log.clone(), frames.clone(), stop.clone());
            std::thread::spawn(move || {
                let start = Instant::now();
                let mut fc = InavMsp::new(Setup::default());
                let mut buf = [0u8; 4096];
                let mut seen_frames = 0;
                while !stop.load(Ordering::Relaxed) {
                    let mut fds = [nix::poll::PollFd::new(
                        std::os::fd::AsFd::as_fd(&master),
                        nix::poll::PollFlags::POLLIN,
                    )];
                    let ready = nix::poll::poll(&mut fds, 5u16).unwrap_or(0) > 0;
                    let now = Instant::now();
                    let now_us = (now - start).as_micros() as i64;
                    let switch_us = controls.switch_us.load(Ordering::Relaxed);
                    let in_use = |fc: &InavMsp| {
                        if controls.override_ignored.load(Ordering::Relaxed) {
                            PILOT_ROLL_US
                        } else {
                            fc.roll_in_use(now_us, switch_us, PILOT_ROLL_US)
                        }
                    };
                    let roll_us = in_use(&fc);
                    let view = FcView {
                        rc_in_use: [roll_us, 1500, 1500, 1400, 1900, switch_us, 1000, 1000],
                        armed: controls.armed.load(Ordering::Relaxed),
                        failsafe: controls.system_status.load(Ordering::Relaxed) >= 5,
                    };
                    if ready
                        && let Ok(n) = nix::unistd::read(&master, &mut buf)
                        && n > 0
                    {
                        let reply = fc.receive(&buf[..n], now_us, view);
                        let _ = nix::unistd::write(&master, &reply);
                        let mut f = frames.lock().unwrap();
                        for (_, ch) in &fc.frames[seen_frames..] {
                            f.push((now, ch.clone()));
                        }
                        seen_frames = fc.frames.len();
                    }
                    let roll_us = in_use(&fc);
                    controls.roll_us.store(roll_us, Ordering::Relaxed);
                    roll_log.lock().unwrap().push((now, roll_us));
                }
            })
        };
        MspMock {
            slave_path,
            roll_log,
            frames,
            stop,
            thread: Some(thread),
            _slave: slave,
        }
    }

    /// Suspends (or resumes) output on faithd's side of the port, as a UART held
    /// off by flow control: faithd's writes stop completing.
    pub fn hold_faithds_writes(&self, held: bool) {
        hold_output(&self._slave, held);
    }

    /// faithd's `[command]` section for this port.
    pub fn command_toml(&self) -> String {
        format!(
            "[command]\nmsp_endpoint = \"serial:{}\"\n",
            self.slave_path.display()
        )
    }

    /// When iNav first used a roll (1200 or 1800).
    pub fn first_roll(&self) -> Option<Instant> {
        self.roll_after(Instant::now() - Duration::from_secs(3600))
    }

    /// When iNav first used a roll at or after `t`.
    pub fn roll_after(&self, t: Instant) -> Option<Instant> {
        self.roll_log
            .lock()
            .unwrap()
            .iter()
            .find(|(at, v)| *at >= t && is_roll(*v))
            .map(|(at, _)| *at)
    }

    /// When iNav first used something other than a roll at or after `t`.
    pub fn unrolled_after(&self, t: Instant) -> Option<(Instant, u16)> {
        self.roll_log
            .lock()
            .unwrap()
            .iter()
            .find(|(at, v)| *at >= t && !is_roll(*v))
            .copied()
    }

    /// Waits until `pred` holds (or `timeout` passes).
    pub fn wait_for(&self, timeout: Duration, pred: impl Fn(&MspMock) -> bool) -> bool {
        poll_until(timeout, || pred(self))
    }
}

impl Drop for MspMock {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
