//! Test support, by concern: a mock iNav autopilot speaking MAVLink 2 on a real
//! pseudo-terminal ([`autopilot`]), iNav's MSP port answered by faithd's model of
//! iNav ([`msp`]), the real `faithd run` binary as a child process ([`daemon`]), and
//! iNav's own firmware (SITL) in [`sitl`], the other test peers in [`peers`], and
//! which tests may share the cores in [`cpu`].

#![allow(dead_code)]

pub mod autopilot;
pub mod cpu;
pub mod daemon;
pub mod msp;
pub mod peers;
pub mod recording;
pub mod sitl;
pub mod wiretap;

use std::os::fd::OwnedFd;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

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

/// tcflow on a pseudo-terminal's slave: TCOOFF stops what is written to it from
/// leaving (its writers block), TCOON lets it go again.
pub fn hold_output(slave: &OwnedFd, held: bool) {
    use nix::sys::termios::{FlowArg, tcflow};
    let action = if held {
        FlowArg::TCOOFF
    } else {
        FlowArg::TCOON
    };
    tcflow(slave, action).expect("tcflow");
}

/// Points `link` at `target`, atomically replacing what was there.
pub fn point_symlink(link: &Path, target: &Path) {
    let tmp = link.with_extension("new");
    let _ = std::fs::remove_file(&tmp);
    std::os::unix::fs::symlink(target, &tmp).unwrap();
    std::fs::rename(&tmp, link).unwrap();
}

/// How long systemd waits before it restarts a faithd that died (`RestartSec=` of the
/// shipped unit, systemd/faithd.service): what the tests of a kill wait too, so the
/// figures they measure are those a builder gets.
pub fn unit_restart_delay() -> Duration {
    let unit = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/systemd/faithd.service"
    ))
    .expect("the unit");
    let value = unit
        .lines()
        .find_map(|l| l.strip_prefix("RestartSec="))
        .expect("RestartSec= in the unit")
        .trim();
    match value.strip_suffix("ms") {
        Some(ms) => Duration::from_millis(ms.parse().expect("RestartSec in ms")),
        None => Duration::from_secs_f64(
            value
                .trim_end_matches('s')
                .parse()
                .expect("RestartSec in s"),
        ),
    }
}

/// The `faithd` binary under test: the one cargo built for these tests, or, when
/// `FAITHD_UNDER_TEST` is set, the command it names (words split on whitespace), such
/// as `qemu-aarch64 -L / target/aarch64-unknown-linux-gnu/release/faithd`: the same
/// tests then drive another architecture's flight build (.ci/run does).
pub fn faithd() -> std::process::Command {
    match faithd_under_test() {
        Some(words) => {
            let mut command = std::process::Command::new(&words[0]);
            command.args(&words[1..]);
            command
        }
        None => std::process::Command::new(env!("CARGO_BIN_EXE_faithd")),
    }
}

/// Whether the binary under test has the simulation commands (`sim` feature): the
/// one cargo built has them when these tests do; `FAITHD_UNDER_TEST` names a flight
/// build, as the packages ship.
pub fn sim_built() -> bool {
    cfg!(feature = "sim") && faithd_under_test().is_none()
}

/// The C mock of libcaer for the binary under test to open: the one built for these
/// tests, or for another architecture's build the one `FAITHD_UNDER_TEST_CAER_MOCK`
/// names (built for that architecture from libcaer-sys/mock/caer_mock.c; .ci/run
/// does), since a program loads only libraries of its own architecture.
pub fn caer_mock_library() -> String {
    if faithd_under_test().is_none() {
        return libcaer_sys::mock::LIBRARY.to_string();
    }
    std::env::var("FAITHD_UNDER_TEST_CAER_MOCK").expect(
        "FAITHD_UNDER_TEST is set but FAITHD_UNDER_TEST_CAER_MOCK is not: name the C mock \
         of libcaer built for that build's architecture",
    )
}

/// `FAITHD_UNDER_TEST` split into words, when it names a command.
pub fn faithd_under_test() -> Option<Vec<String>> {
    let words: Vec<String> = std::env::var("FAITHD_UNDER_TEST")
        .ok()?
        .split_whitespace()
        .map(str::to_string)
        .collect();
    (!words.is_empty()).then_some(words)
}
