//! One iNav SITL process, set up through its CLI as a person sets up a board.
//!
//! Its UARTs are TCP listeners: UART n on `base + n - 1`. The set-up the lab and the
//! tests use: UART1 = MSP (CLI), UART2 = MSP (the monitor), UART3 = MAVLink telemetry
//! (faithd), UART4 = MSP (faithd's roll stream), UART5 = the pilot's IBUS receiver.
//! Facts about SITL (sockets kept through the 1 s reboot after `save`, SIGPIPE on a
//! client that hangs up, UARTs that listen only once their function is saved) are
//! from iNav 9.1's src/main/target/SITL (serial_tcp.c, target.c) and were seen on it.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU16, Ordering};
use std::time::{Duration, Instant};

use super::msp_client::{MSP_BOXIDS, MspClient, read_timed_out};

/// UART numbers of the set-up (1-based, as iNav names them).
pub const UART_CLI: u16 = 1;
pub const UART_MONITOR: u16 = 2;
pub const UART_MAVLINK: u16 = 3;
pub const UART_MSP_FAITHD: u16 = 4;
pub const UART_RADIO: u16 = 5;

/// What went wrong with SITL, with its own output when it helps.
#[derive(Debug, thiserror::Error)]
pub enum SitlError {
    /// The SITL process ended on its own before it answered: iNav 9.1's SITL with
    /// `--sim=rf` sometimes dies of SIGSEGV while it starts (at its first boot or
    /// at the reboot after `save`), before anything flies. A fresh one may start.
    #[error("SITL ended by itself ({status}) before it answered; its log:\n{log}")]
    Crashed { status: String, log: String },
    #[error("{0}")]
    Other(String),
}

/// Eight consecutive free TCP ports (SITL's UARTs), distinct for every SITL this
/// process starts, and all below the kernel's ephemeral range: SITL binds a UART's
/// port again each time it restarts after `save`, and a port in the ephemeral range
/// can be taken in between by any outgoing connection on the machine.
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
    child: Mutex<Child>,
    pub base_port: u16,
    dir: tempfile::TempDir,
    /// UARTs (1-based) the saved set-up gives a function: each must listen again
    /// after a save before the set-up is in effect.
    uarts: Mutex<std::collections::BTreeSet<u16>>,
}

impl Sitl {
    /// Starts `exe` with an empty EEPROM and `args` on its command line (`--sim=rf
    /// ...` for a simulator); waits for its CLI port.
    pub fn start(exe: &Path, args: &[String]) -> Result<Self, SitlError> {
        let dir = tempfile::Builder::new()
            .prefix("faithd-sitl-")
            .tempdir()
            .map_err(|e| SitlError::Other(format!("a scratch directory for SITL: {e}")))?;
        let base_port = free_base_port();
        let log = std::fs::File::create(dir.path().join("sitl.log"))
            .map_err(|e| SitlError::Other(format!("SITL's log file: {e}")))?;
        let log_err = log
            .try_clone()
            .map_err(|e| SitlError::Other(format!("SITL's log file: {e}")))?;
        let mut command = Command::new(exe);
        // SITL's TCP "UARTs" write with send() and no MSG_NOSIGNAL: a client that
        // hangs up while iNav still answers it kills SITL with SIGPIPE, which a real
        // UART never does. SIGPIPE ignored (inherited across exec, also by SITL's own
        // restart after `save`) turns that into the EPIPE a UART's silence amounts to.
        // pre_exec: a libc call in the child before exec.
        #[allow(unsafe_code)]
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
            .arg(format!(
                "--path={}",
                dir.path().join("eeprom.bin").display()
            ))
            .args(args)
            .current_dir(dir.path())
            .stdin(Stdio::null())
            .stdout(log)
            .stderr(log_err)
            .spawn()
            .map_err(|e| SitlError::Other(format!("cannot start SITL {}: {e}", exe.display())))?;
        let sitl = Sitl {
            child: Mutex::new(child),
            base_port,
            dir,
            uarts: Mutex::new([UART_CLI, UART_MONITOR].into()),
        };
        sitl.wait_for_msp(Duration::from_secs(10))?;
        Ok(sitl)
    }

    pub fn port(&self, uart: u16) -> u16 {
        self.base_port + uart - 1
    }

    /// A UART as faithd's configuration names it.
    pub fn endpoint(&self, uart: u16) -> String {
        format!("tcp:127.0.0.1:{}", self.port(uart))
    }

    /// SITL's own output, for failure messages.
    pub fn log(&self) -> String {
        std::fs::read_to_string(self.dir.path().join("sitl.log")).unwrap_or_default()
    }

    /// Its working directory (EEPROM, log).
    pub fn dir(&self) -> PathBuf {
        self.dir.path().to_path_buf()
    }

    pub fn pid(&self) -> u32 {
        self.child.lock().expect("child lock").id()
    }

    /// How SITL ended, if it has.
    fn ended(&self) -> Option<String> {
        let status = self.child.lock().expect("child lock").try_wait().ok()??;
        Some(
            match std::os::unix::process::ExitStatusExt::signal(&status) {
                Some(11) => "SIGSEGV".to_string(),
                Some(signal) => format!("signal {signal}"),
                None => status.to_string(),
            },
        )
    }

    fn wait_for_msp(&self, timeout: Duration) -> Result<(), SitlError> {
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if let Ok(mut port) = MspClient::connect(self.port(UART_CLI))
                && port.request(MSP_BOXIDS, &[]).is_ok()
            {
                return Ok(());
            }
            if let Some(status) = self.ended() {
                return Err(SitlError::Crashed {
                    status,
                    log: self.log(),
                });
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        Err(SitlError::Other(format!(
            "SITL's MSP port (UART1, TCP {}) did not answer in {timeout:?}; SITL log:\n{}\n{}",
            self.port(UART_CLI),
            self.log(),
            self.process_state()
        )))
    }

    /// The SITL process's state, its sockets and, where gdb is installed, its
    /// threads' stacks: what a stuck SITL was waiting for.
    fn process_state(&self) -> String {
        let pid = self.pid().to_string();
        let run = |program: &str, args: &[&str]| {
            Command::new(program)
                .args(args)
                .output()
                .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
                .unwrap_or_default()
        };
        format!(
            "process {pid}: {}\nits sockets:\n{}\nits threads:\n{}",
            std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default(),
            run("ss", &["-tanp"])
                .lines()
                .filter(|l| l.contains(&format!("pid={pid},")) || l.contains(":18083"))
                .take(40)
                .collect::<Vec<_>>()
                .join("\n"),
            run("gdb", &["-p", &pid, "-batch", "-ex", "thread apply all bt"])
        )
    }

    /// Runs CLI lines on UART1 and returns what the CLI printed. A connection that
    /// SITL resets (it rebinds its sockets while it settles after boot) is retried.
    pub fn cli(&self, lines: &[String]) -> Result<String, SitlError> {
        let mut last = None;
        for _ in 0..5 {
            match self.try_cli(lines) {
                Ok(out) => return Ok(out),
                Err(e) => last = Some(e),
            }
            std::thread::sleep(Duration::from_millis(300));
            self.wait_for_msp(Duration::from_secs(10))?;
        }
        Err(SitlError::Other(format!(
            "SITL's CLI kept failing: {last:?}; SITL log:\n{}",
            self.log()
        )))
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
    /// up about 1.5 s after the others). A line iNav refused is an error.
    pub fn cli_save(&self, lines: &[String]) -> Result<(), SitlError> {
        for line in lines {
            let words: Vec<&str> = line.split_whitespace().collect();
            if let ["serial", index, function, ..] = words[..]
                && let (Ok(i), Ok(f)) = (index.parse::<u16>(), function.parse::<u32>())
            {
                // Serial RX (64) listens only with receiver_type = SERIAL: the radio
                // waits for it on its own. A port given no function (UART2 too,
                // when the monitor moves to UART1) is not waited for.
                let mut uarts = self.uarts.lock().expect("uarts lock");
                if (f == 0 || f == 64) && i + 1 > UART_CLI {
                    uarts.remove(&(i + 1));
                } else if f != 0 {
                    uarts.insert(i + 1);
                }
            }
        }
        let mut all = lines.to_vec();
        all.push("save".into());
        let out = self.cli(&all)?;
        for bad in ["Invalid", "ERROR", "Unknown command", "Parse error"] {
            if out.contains(bad) {
                return Err(SitlError::Other(format!(
                    "iNav refused a CLI line ({bad}):\n{out}"
                )));
            }
        }
        if !out.contains("Rebooting") {
            return Err(SitlError::Other(format!("no reboot after save:\n{out}")));
        }
        // The old process keeps its sockets through its 1 s reboot delay.
        std::thread::sleep(Duration::from_millis(1300));
        self.wait_for_msp(Duration::from_secs(10))?;
        let uarts = self.uarts.lock().expect("uarts lock").clone();
        let deadline = Instant::now() + Duration::from_secs(10);
        for uart in uarts {
            while TcpStream::connect(("127.0.0.1", self.port(uart))).is_err() {
                if Instant::now() > deadline {
                    return Err(SitlError::Other(format!(
                        "UART{uart} never listened after the save; SITL log:\n{}",
                        self.log()
                    )));
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        }
        Ok(())
    }
}

impl Drop for Sitl {
    fn drop(&mut self) {
        let child = self.child.get_mut().unwrap_or_else(|e| e.into_inner());
        let _ = child.kill();
        let _ = child.wait();
    }
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
pub fn script_lines(text: &str) -> Vec<String> {
    text.lines()
        .map(|l| l.split('#').next().unwrap_or("").trim().to_string())
        .filter(|l| !l.is_empty())
        .collect()
}
