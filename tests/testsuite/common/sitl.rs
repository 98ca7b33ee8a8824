//! iNav's own firmware in the tests: its software-in-the-loop build (SITL), set up
//! from the committed CLI scripts, the pilot's radio played on a real iNav receiver
//! protocol (IBUS), and a monitor that reads back over MSP what iNav really uses.
//!
//! The project carries no iNav code and no recipe that builds it: the tests take the
//! path of a SITL executable built beside the project from `INAV_SITL` (iNav 9.1, with
//! the board's serial timing: `../shared/inav.md` says how) and, when it is unset, skip
//! with one line (`require_sitl!`). Its UARTs are TCP
//! listeners: UART n on `base + n - 1`. The set-up used here:
//! UART1 = MSP (CLI, this harness), UART2 = MSP (the monitor), UART3 = MAVLink
//! telemetry (faithd), UART4 = MSP (faithd's roll stream), UART5 = the pilot's IBUS
//! receiver.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU16, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use faithd::command::msp::{self, Decoder, Frame};

use super::TempDir;

/// The committed set-up: the pilot's vehicle, then faithd's part (hil/inav/faithd.cli).
pub const PILOT_CLI: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/inav/pilot.cli");
pub const FAITHD_CLI: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/hil/inav/faithd.cli");

/// UART numbers of the set-up (1-based, as iNav names them).
pub const UART_CLI: u16 = 1;
pub const UART_MONITOR: u16 = 2;
pub const UART_MAVLINK: u16 = 3;
pub const UART_MSP_FAITHD: u16 = 4;
pub const UART_RADIO: u16 = 5;

/// MSP commands the harness uses.
const MSP_RC: u16 = 105;
const MSP2_INAV_STATUS: u16 = 0x2000;
const MSP_BOXIDS: u16 = 119;

/// iNav's arming flags (fc/runtime_config.h).
pub const ARMED: u32 = 1 << 2;
const ARMING_DISABLED_ARM_SWITCH: u32 = 1 << 14;
/// Every "arming disabled" flag (bits 6 to 30).
const ARMING_BLOCKERS: u32 = 0x7FFF_FFC0;

/// Microseconds since the Unix epoch: the time base shared with faithd's journal.
pub fn unix_us() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .expect("clock after 1970")
        .as_micros() as i64
}

/// The environment variable that names iNav's SITL executable.
pub const SITL_VAR: &str = "INAV_SITL";

/// The SITL executable named by `INAV_SITL`, or `None` when it is unset. A path that
/// is set but names no file is a mistake in the set-up, not a reason to skip: it
/// panics with the path.
pub fn executable() -> Option<PathBuf> {
    let path = PathBuf::from(std::env::var_os(SITL_VAR)?);
    assert!(
        path.is_file(),
        "{SITL_VAR}={} names no file: build iNav 9.1's SITL beside the project \
         (../shared/inav.md) and point {SITL_VAR} at its executable",
        path.display()
    );
    Some(path)
}

/// Returns from the calling test, with one line on stderr, when no SITL is named.
#[macro_export]
macro_rules! require_sitl {
    () => {
        if $crate::common::sitl::executable().is_none() {
            // Straight to the process's stderr: the test harness captures eprintln!.
            use std::io::Write as _;
            let _ = writeln!(
                std::io::stderr(),
                "skipped: {} is not set (the path of an iNav 9.1 SITL built with the board's \
                 serial timing; ../shared/inav.md)",
                $crate::common::sitl::SITL_VAR
            );
            return;
        }
    };
}

/// Eight consecutive free TCP ports (SITL's UARTs), distinct for every SITL this
/// process starts, and all below the kernel's ephemeral range: SITL binds a UART's
/// port again each time it restarts after `save`, and a port in the ephemeral
/// range can be taken in between by any outgoing connection on the machine (CI
/// once lost UART5 that way: "Unable to bind socket").
fn free_base_port() -> u16 {
    const LOWEST: u16 = 10_000;
    const STRIDE: u16 = 10;
    static NEXT: AtomicU16 = AtomicU16::new(0);
    let ephemeral_low = std::fs::read_to_string("/proc/sys/net/ipv4/ip_local_port_range")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<u16>().ok())
        .unwrap_or(32_768);
    let slots = (ephemeral_low.saturating_sub(LOWEST) / STRIDE).max(1);
    let first_slot = (std::process::id() % u32::from(slots)) as u16;
    loop {
        let slot = (first_slot + NEXT.fetch_add(1, Ordering::Relaxed)) % slots;
        let base = LOWEST + slot * STRIDE;
        let free = (base..base + 8).all(|p| {
            TcpListener::bind(("::", p)).is_ok() && TcpListener::bind(("0.0.0.0", p)).is_ok()
        });
        if free {
            return base;
        }
    }
}

/// One running iNav SITL; killed on drop.
pub struct Sitl {
    child: Child,
    pub base_port: u16,
    dir: TempDir,
    /// UARTs (1-based) the saved set-up gives a function: each must listen again
    /// after a save before the set-up is in effect.
    uarts: Mutex<std::collections::BTreeSet<u16>>,
    /// A timed test: iNav's serial task keeps the board's 10 ms only on an idle core
    /// (dropped last).
    _cpu: super::cpu::Slot,
}

impl Sitl {
    /// Starts a fresh SITL (empty EEPROM) and waits for its CLI port.
    pub fn start() -> Self {
        Self::start_with(&[])
    }

    /// A fresh SITL with `args` on its command line (`--sim=rf ...` for a simulator).
    pub fn start_with(args: &[String]) -> Self {
        let exe = executable().expect("INAV_SITL is not set: call require_sitl!() first");
        let cpu = super::cpu::timed();
        let dir = TempDir::new("sitl");
        let base_port = free_base_port();
        let log = std::fs::File::create(dir.0.join("sitl.log")).unwrap();
        let mut command = Command::new(exe);
        // SITL's TCP "UARTs" write with send() and no MSG_NOSIGNAL: a client that
        // hangs up while iNav still answers it (the CLI after `save`, a monitor at the
        // end of a test, faithd stopping) kills SITL with SIGPIPE, which a real UART
        // never does. SIGPIPE ignored (inherited across exec, also by SITL's own
        // restart after `save`) turns that into the EPIPE a UART's silence amounts to.
        // SAFETY: signal() is async-signal-safe; nothing else runs between fork and exec.
        unsafe {
            use std::os::unix::process::CommandExt;
            command.pre_exec(|| {
                nix::sys::signal::signal(
                    nix::sys::signal::Signal::SIGPIPE,
                    nix::sys::signal::SigHandler::SigIgn,
                )
                .map(|_| ())
                .map_err(std::io::Error::from)
            });
        }
        let child = command
            .arg(format!("--tcpbaseport={base_port}"))
            .arg(format!("--path={}", dir.0.join("eeprom.bin").display()))
            .args(args)
            .current_dir(&dir.0)
            .stdin(Stdio::null())
            .stdout(log.try_clone().unwrap())
            .stderr(log)
            .spawn()
            .expect("start SITL");
        let sitl = Sitl {
            child,
            base_port,
            dir,
            uarts: Mutex::new([UART_CLI, UART_MONITOR].into()),
            _cpu: cpu,
        };
        sitl.wait_for_msp(Duration::from_secs(10));
        sitl
    }

    /// A fresh SITL with the pilot's set-up and faithd's committed script applied,
    /// then `extra` CLI lines, saved.
    pub fn with_committed_setup(extra: &[&str]) -> Self {
        let sitl = Sitl::start();
        let mut lines = read_script(PILOT_CLI);
        lines.extend(read_script(FAITHD_CLI));
        lines.extend(extra.iter().map(|l| l.to_string()));
        sitl.cli_save(&lines);
        sitl
    }

    pub fn port(&self, uart: u16) -> u16 {
        self.base_port + uart - 1
    }

    pub fn endpoint(&self, uart: u16) -> String {
        format!("tcp:127.0.0.1:{}", self.port(uart))
    }

    /// SITL's own output, for failure messages.
    pub fn log(&self) -> String {
        std::fs::read_to_string(self.dir.0.join("sitl.log")).unwrap_or_default()
    }

    fn wait_for_msp(&self, timeout: Duration) {
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if let Ok(mut port) = MspClient::connect(self.port(UART_CLI))
                && port.request(MSP_BOXIDS, &[]).is_ok()
            {
                return;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        panic!(
            "SITL's MSP port did not answer ({}); SITL log:\n{}",
            self.process_state(),
            self.log()
        );
    }

    /// The SITL process's state and, where gdb is installed, its threads' stacks.
    fn process_state(&self) -> String {
        let pid = self.child.id();
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
        let stacks = Command::new("gdb")
            .args([
                "-p",
                &pid.to_string(),
                "-batch",
                "-ex",
                "thread apply all bt",
            ])
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
            .unwrap_or_default();
        format!("process {pid}: {stat}\n{stacks}")
    }

    /// Runs CLI lines on UART1 and returns what the CLI printed. A connection that
    /// SITL resets (it rebinds its sockets while it settles after boot) is retried.
    pub fn cli(&self, lines: &[String]) -> String {
        let mut last = None;
        for _ in 0..5 {
            match self.try_cli(lines) {
                Ok(out) => return out,
                Err(e) => last = Some(e),
            }
            std::thread::sleep(Duration::from_millis(300));
            self.wait_for_msp(Duration::from_secs(10));
        }
        panic!(
            "SITL's CLI kept failing: {last:?}; SITL log:\n{}",
            self.log()
        );
    }

    fn try_cli(&self, lines: &[String]) -> std::io::Result<String> {
        let mut s = TcpStream::connect(("127.0.0.1", self.port(UART_CLI)))?;
        s.set_read_timeout(Some(Duration::from_millis(50)))?;
        let mut out = Vec::new();
        cli_line(&mut s, "#", Duration::from_millis(300), &mut out)?;
        // A client SITL has not yet seen leave still holds the UART: this one then
        // waits unanswered. Reconnect rather than type into the void.
        let entered = Instant::now() + Duration::from_secs(2);
        while !String::from_utf8_lossy(&out).contains("CLI") {
            if Instant::now() > entered {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::TimedOut,
                    "the CLI did not answer `#`",
                ));
            }
            cli_line(&mut s, "", Duration::from_millis(100), &mut out)?;
        }
        for line in lines {
            cli_line(&mut s, line, Duration::from_millis(60), &mut out)?;
        }
        Ok(String::from_utf8_lossy(&out).into_owned())
    }

    /// Runs CLI lines, then `save`: iNav writes its EEPROM and restarts (it waits
    /// 1 s, then execs itself again); returns once the new process answers MSP and
    /// listens on every UART the set-up uses (the telemetry and receiver UARTs come
    /// up about 1.5 s after the others). Panics on a line iNav refused.
    pub fn cli_save(&self, lines: &[String]) {
        for line in lines {
            let words: Vec<&str> = line.split_whitespace().collect();
            if let ["serial", index, function, ..] = words[..]
                && let (Ok(i), Ok(f)) = (index.parse::<u16>(), function.parse::<u32>())
            {
                // Serial RX (64) listens only with receiver_type = SERIAL: the radio
                // waits for it on its own.
                let mut uarts = self.uarts.lock().unwrap();
                if (f == 0 || f == 64) && i + 1 > UART_MONITOR {
                    uarts.remove(&(i + 1));
                } else if f != 0 {
                    uarts.insert(i + 1);
                }
            }
        }
        let mut all = lines.to_vec();
        all.push("save".into());
        let out = self.cli(&all);
        for bad in ["Invalid", "ERROR", "Unknown command", "Parse error"] {
            assert!(
                !out.contains(bad),
                "iNav refused a CLI line ({bad}):\n{out}"
            );
        }
        assert!(out.contains("Rebooting"), "no reboot after save:\n{out}");
        // The old process keeps its sockets through its 1 s reboot delay.
        std::thread::sleep(Duration::from_millis(1300));
        self.wait_for_msp(Duration::from_secs(10));
        let uarts = self.uarts.lock().unwrap().clone();
        let deadline = Instant::now() + Duration::from_secs(10);
        for uart in uarts {
            while TcpStream::connect(("127.0.0.1", self.port(uart))).is_err() {
                assert!(
                    Instant::now() < deadline,
                    "UART{uart} never listened after the save; SITL log:\n{}",
                    self.log()
                );
                std::thread::sleep(Duration::from_millis(50));
            }
        }
    }
}

impl Drop for Sitl {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A read that ran into the socket's read timeout (nothing came): not an error here.
fn read_timed_out(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
    )
}

/// Types one CLI line and collects what comes back for `settle`.
fn cli_line(
    s: &mut TcpStream,
    line: &str,
    settle: Duration,
    out: &mut Vec<u8>,
) -> std::io::Result<()> {
    s.write_all(line.as_bytes())?;
    s.write_all(b"\r\n")?;
    let until = Instant::now() + settle;
    let mut buf = [0u8; 4096];
    while Instant::now() < until {
        match s.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => out.extend_from_slice(&buf[..n]),
            Err(e) if read_timed_out(&e) => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// The lines of a CLI script without comments and blank lines.
pub fn read_script(path: &str) -> Vec<String> {
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .lines()
        .map(|l| l.split('#').next().unwrap().trim().to_string())
        .filter(|l| !l.is_empty())
        .collect()
}

/// A blocking MSP v2 client for the harness's own ports.
pub struct MspClient {
    stream: TcpStream,
    decoder: Decoder,
    frames: Vec<Frame>,
}

impl MspClient {
    pub fn connect(port: u16) -> std::io::Result<Self> {
        let stream = TcpStream::connect(("127.0.0.1", port))?;
        stream.set_nodelay(true)?;
        stream.set_read_timeout(Some(Duration::from_millis(20)))?;
        Ok(Self {
            stream,
            decoder: Decoder::default(),
            frames: Vec::new(),
        })
    }

    /// Sends `command` and waits up to 500 ms for its reply.
    pub fn request(&mut self, command: u16, payload: &[u8]) -> std::io::Result<Vec<u8>> {
        self.stream
            .write_all(&msp::encode_request(command, payload))?;
        let deadline = Instant::now() + Duration::from_millis(500);
        let mut buf = [0u8; 1024];
        while Instant::now() < deadline {
            if let Some(i) = self.frames.iter().position(|f| f.command == command) {
                let f = self.frames.remove(i);
                self.frames.clear();
                return match f.direction {
                    b'>' => Ok(f.payload),
                    _ => Err(std::io::Error::other(format!("MSP {command} refused"))),
                };
            }
            match self.stream.read(&mut buf) {
                Ok(0) => return Err(std::io::ErrorKind::UnexpectedEof.into()),
                Ok(n) => self.decoder.push(&buf[..n], &mut self.frames),
                Err(e) if read_timed_out(&e) => {}
                Err(e) => return Err(e),
            }
        }
        Err(std::io::ErrorKind::TimedOut.into())
    }
}

/// Channel values of the pilot's radio, in radio order (1-based channel n at n-1).
pub const PILOT_CHANNELS: usize = 14;

/// What the radio sent: (unix us, channels).
pub type RadioFrame = (i64, [u16; PILOT_CHANNELS]);

/// The pilot's radio: IBUS frames (the FlySky protocol, 14 channels) into SITL's
/// serial receiver every 7 ms, as an IBUS receiver sends them.
pub struct Radio {
    channels: Arc<Mutex<[u16; PILOT_CHANNELS]>>,
    on: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    /// When each change of the channels was first sent: (unix us, channels).
    pub sent: Arc<Mutex<Vec<RadioFrame>>>,
    thread: Option<JoinHandle<()>>,
}

/// Radio channels of the set-up (1-based).
pub const CH_ROLL: usize = 1;
pub const CH_THROTTLE: usize = 3;
pub const CH_ARM: usize = 5;
pub const CH_SWITCH: usize = 6;
/// The pilot's roll stick while faithd runs: off centre, so that whose value iNav
/// uses is never in doubt.
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

impl Radio {
    /// Sticks centred, throttle low, ARM low, switch in MANUAL.
    pub fn start(sitl: &Sitl) -> Self {
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
                Err(e) if Instant::now() > deadline => panic!("radio port: {e}"),
                Err(_) => std::thread::sleep(Duration::from_millis(50)),
            }
        };
        stream.set_nodelay(true).unwrap();
        let thread = {
            let (channels, on, stop, sent) =
                (channels.clone(), on.clone(), stop.clone(), sent.clone());
            std::thread::spawn(move || {
                let mut last = None;
                let mut next = Instant::now();
                while !stop.load(Ordering::Relaxed) {
                    if on.load(Ordering::Relaxed) {
                        let now = *channels.lock().unwrap();
                        let t = unix_us();
                        if stream.write_all(&ibus_frame(&now)).is_err() {
                            return;
                        }
                        if last != Some(now) {
                            sent.lock().unwrap().push((t, now));
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
        Radio {
            channels,
            on,
            stop,
            sent,
            thread: Some(thread),
        }
    }

    /// Sets radio channel `ch` (1-based); returns the Unix time of the change.
    pub fn set(&self, ch: usize, value_us: u16) -> i64 {
        self.channels.lock().unwrap()[ch - 1] = value_us;
        unix_us()
    }

    pub fn channels(&self) -> [u16; PILOT_CHANNELS] {
        *self.channels.lock().unwrap()
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

/// What iNav reported at one moment: the channels it uses (MSP_RC, iNav's order:
/// roll, pitch, yaw, throttle, then AUX1...) and its status.
#[derive(Clone, Debug)]
pub struct Sample {
    pub t_us: i64,
    pub rc: Vec<u16>,
    pub arming_flags: u32,
    /// Permanent ids of the modes active (fc/fc_msp_box.c).
    pub modes: Vec<u8>,
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

/// iNav's mode ids (permanent).
pub const MODE_ANGLE: u8 = 1;
pub const MODE_FAILSAFE: u8 = 27;
pub const MODE_MSP_RC_OVERRIDE: u8 = 50;

/// Reads MSP_RC and MSP2_INAV_STATUS from UART2 every 10 ms.
pub struct Monitor {
    pub samples: Arc<Mutex<Vec<Sample>>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Monitor {
    pub fn start(sitl: &Sitl) -> Self {
        let mut client = MspClient::connect(sitl.port(UART_MONITOR)).expect("monitor port");
        let box_ids = client.request(MSP_BOXIDS, &[]).expect("MSP_BOXIDS");
        let samples = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (samples, stop) = (samples.clone(), stop.clone());
            std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    let next = Instant::now() + Duration::from_millis(10);
                    let t_us = unix_us();
                    let (Ok(rc), Ok(status)) = (
                        client.request(MSP_RC, &[]),
                        client.request(MSP2_INAV_STATUS, &[]),
                    ) else {
                        continue;
                    };
                    samples.lock().unwrap().push(Sample {
                        t_us,
                        rc: rc
                            .chunks_exact(2)
                            .map(|c| u16::from_le_bytes([c[0], c[1]]))
                            .collect(),
                        arming_flags: u32_at(&status, 9),
                        modes: active_modes(&status[13.min(status.len())..], &box_ids),
                    });
                    if let Some(wait) = next.checked_duration_since(Instant::now()) {
                        std::thread::sleep(wait);
                    }
                }
            })
        };
        Monitor {
            samples,
            stop,
            thread: Some(thread),
        }
    }

    pub fn latest(&self) -> Option<Sample> {
        self.samples.lock().unwrap().last().cloned()
    }

    /// Samples taken from `from_us` to `to_us` (Unix time).
    pub fn between(&self, from_us: i64, to_us: i64) -> Vec<Sample> {
        self.samples
            .lock()
            .unwrap()
            .iter()
            .filter(|s| s.t_us >= from_us && s.t_us <= to_us)
            .cloned()
            .collect()
    }

    /// Waits until the latest sample satisfies `pred`.
    pub fn wait_until(&self, timeout: Duration, pred: impl Fn(&Sample) -> bool) -> Option<Sample> {
        let mut found = None;
        super::poll_until(timeout, || {
            found = self.latest().filter(|s| pred(s));
            found.is_some()
        });
        found
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
pub fn arm(radio: &Radio, monitor: &Monitor, sitl: &Sitl) {
    let ready = monitor.wait_until(Duration::from_secs(20), |s| {
        s.arming_flags & ARMING_BLOCKERS & !ARMING_DISABLED_ARM_SWITCH == 0
    });
    assert!(
        ready.is_some(),
        "SITL never became armable: flags {:#x}; SITL log:\n{}",
        monitor.latest().map_or(0, |s| s.arming_flags),
        sitl.log()
    );
    for _ in 0..3 {
        radio.set(CH_ARM, 1000);
        std::thread::sleep(Duration::from_millis(150));
        radio.set(CH_ARM, 1900);
        if monitor
            .wait_until(Duration::from_secs(2), |s| s.armed())
            .is_some()
        {
            return;
        }
    }
    panic!(
        "SITL did not arm: flags {:#x}",
        monitor.latest().map_or(0, |s| s.arming_flags)
    );
}
