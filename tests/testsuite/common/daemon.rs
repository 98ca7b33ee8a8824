//! The real `faithd run` binary as a child process, with its own scratch directory
//! and log.

use std::path::PathBuf;
use std::process::{Child, Stdio};
use std::time::Duration;

use super::autopilot::MockAutopilot;
use super::{TempDir, poll_until};

/// `faithd run` as a child process; killed (SIGTERM, then SIGKILL) on drop.
pub struct Daemon {
    child: Child,
    pub log_path: PathBuf,
    _dir: TempDir,
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

    /// As [`Daemon::start`], with extra environment variables. The simulated camera's
    /// first approach starts at 1 s, after the roll stream's 800 ms warm-up: its roll
    /// calls come 0.1 to 0.35 s into the approach, and at 0.6 s they could end before
    /// the gate may open.
    pub fn start_with_env(endpoint: &str, extra: &str, env: &[(&str, &str)]) -> Self {
        Self::start_config(
            &format!(
                "[mavlink]\nendpoint = \"{endpoint}\"\nreconnect_min_us = 50000\nreconnect_max_us = 200000\n\
                 [source]\nkind = \"sim\"\nfirst_approach_us = 1000000\nrepeat_us = 4000000\n{extra}"
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
        let child = crate::common::faithd()
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
