//! iNav's own firmware in the tests: the lab's SITL harness
//! (`faithd_lab::inav_sitl`, a dev-dependency so that the flight build's tests have
//! it too: the SITL process set up from the committed CLI scripts, the
//! pilot's radio on IBUS, a monitor reading back over MSP what iNav really uses),
//! with what a test adds: a CPU slot (iNav's serial task keeps the board's 10 ms
//! only on an idle core), panics instead of errors, and the skip without SITL.
//!
//! The project carries no iNav code and no recipe that builds it: the tests take the
//! path of a SITL executable built beside the project from `INAV_SITL` (iNav 9.1, with
//! the board's serial timing: `../shared/inav.md` says how) and, when it is unset, skip
//! with one line (`require_sitl!`).

use std::ops::Deref;
use std::path::PathBuf;

pub use faithd_lab::inav_sitl::clock::unix_us;
pub use faithd_lab::inav_sitl::monitor::{MODE_ANGLE, MODE_FAILSAFE, MODE_MSP_RC_OVERRIDE};
pub use faithd_lab::inav_sitl::msp_client::MspClient;
pub use faithd_lab::inav_sitl::process::{UART_CLI, UART_MAVLINK, UART_MONITOR, UART_MSP_FAITHD};
pub use faithd_lab::inav_sitl::radio::{
    AUTO_US, CH_ROLL, CH_SWITCH, CH_THROTTLE, MANUAL_US, PILOT_CHANNELS, PILOT_ROLL_US,
};
use faithd_lab::inav_sitl::{monitor, process, radio};

/// The committed set-up: the pilot's vehicle, then faithd's part (hil/inav/faithd.cli).
pub const PILOT_CLI: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/inav/pilot.cli");
pub const FAITHD_CLI: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/hil/inav/faithd.cli");
/// faithd's part for a flight controller without MAVLink: two MSP ports.
pub const FAITHD_MSP_CLI: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/hil/inav/faithd-msp.cli");
/// The custom OSD elements that show faithd's state in the pilot's goggles.
pub const OSD_CLI: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/hil/inav/osd.cli");

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

/// One running iNav SITL, holding a timed test's CPU slot; killed on drop.
pub struct Sitl {
    inner: process::Sitl,
    /// Dropped last: the SITL process goes first.
    _cpu: super::cpu::Slot,
}

impl Deref for Sitl {
    type Target = process::Sitl;
    fn deref(&self) -> &process::Sitl {
        &self.inner
    }
}

impl Sitl {
    /// Starts a fresh SITL (empty EEPROM) and waits for its CLI port.
    pub fn start() -> Self {
        Self::start_with(&[])
    }

    /// A fresh SITL with `args` on its command line (`--sim=rf ...` for a simulator).
    pub fn start_with(args: &[String]) -> Self {
        Self::try_start_with(args).unwrap_or_else(|e| panic!("{e}"))
    }

    /// [`Sitl::start_with`], with SITL's failure to start as an error (a SITL that
    /// ended by itself is [`process::SitlError::Crashed`]).
    pub fn try_start_with(args: &[String]) -> Result<Self, process::SitlError> {
        let exe = executable().expect("INAV_SITL is not set: call require_sitl!() first");
        let cpu = super::cpu::timed();
        let inner = process::Sitl::start(&exe, args)?;
        Ok(Sitl { inner, _cpu: cpu })
    }

    /// A fresh SITL with the pilot's set-up and faithd's committed script applied,
    /// then `extra` CLI lines, saved.
    pub fn with_committed_setup(extra: &[&str]) -> Self {
        Self::with_scripts(&[FAITHD_CLI], extra)
    }

    /// A fresh SITL with the pilot's set-up, then each of faithd's `scripts`, then
    /// `extra` CLI lines, saved.
    pub fn with_scripts(scripts: &[&str], extra: &[&str]) -> Self {
        let sitl = Sitl::start();
        let mut lines = read_script(PILOT_CLI);
        for script in scripts {
            lines.extend(read_script(script));
        }
        lines.extend(extra.iter().map(|l| l.to_string()));
        sitl.cli_save(&lines);
        sitl
    }

    /// Runs CLI lines on UART1 and returns what the CLI printed.
    pub fn cli(&self, lines: &[String]) -> String {
        self.inner.cli(lines).unwrap_or_else(|e| panic!("{e}"))
    }

    /// Runs CLI lines, then `save`, and waits for the restarted SITL; panics on a
    /// line iNav refused.
    pub fn cli_save(&self, lines: &[String]) {
        self.try_cli_save(lines).unwrap_or_else(|e| panic!("{e}"))
    }

    pub fn try_cli_save(&self, lines: &[String]) -> Result<(), process::SitlError> {
        self.inner.cli_save(lines)
    }
}

/// The lines of a CLI script without comments and blank lines.
pub fn read_script(path: &str) -> Vec<String> {
    process::script_lines(&std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}")))
}

/// The pilot's radio (IBUS into UART5).
pub struct Radio(radio::Radio);

impl Deref for Radio {
    type Target = radio::Radio;
    fn deref(&self) -> &radio::Radio {
        &self.0
    }
}

impl Radio {
    /// Sticks centred, throttle low, ARM low, switch in MANUAL.
    pub fn start(sitl: &Sitl) -> Self {
        Radio(radio::Radio::start(sitl).unwrap_or_else(|e| panic!("{e}")))
    }
}

/// MSP_RC and the status read back from UART2 every 10 ms.
pub struct Monitor(monitor::Monitor);

impl Deref for Monitor {
    type Target = monitor::Monitor;
    fn deref(&self) -> &monitor::Monitor {
        &self.0
    }
}

impl Monitor {
    /// On UART1, the CLI's port, when UART2 cannot be an MSP port.
    pub fn start_on(sitl: &Sitl, uart: u16) -> Self {
        Monitor(monitor::Monitor::start_on(sitl, uart).unwrap_or_else(|e| panic!("{e}")))
    }

    pub fn start(sitl: &Sitl) -> Self {
        Monitor(monitor::Monitor::start(sitl).unwrap_or_else(|e| panic!("{e}")))
    }
}

/// The pilot arms (panics when iNav will not).
pub fn arm(radio: &Radio, monitor: &Monitor, sitl: &Sitl) {
    monitor::arm(radio, monitor, sitl).unwrap_or_else(|e| panic!("{e}"));
}
