//! iNav's MSP port on a pseudo-terminal, answered by faithd's model of iNav.

use std::os::fd::OwnedFd;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use faithd_inav::msp::{InavMsp, Pilot, Setup};

use super::autopilot::{Controls, PILOT_ROLL_US};
use super::{hold_output, poll_until, raw_pty};

/// iNav's MSP port on a pseudo-terminal, answered by faithd's own model of iNav as it
/// behaves on a flight controller (`faithd_inav::msp`: one command per
/// 10 ms, a 256-byte receive ring, the override's timing and scaling, modes). It
/// records the roll the model's iNav uses every millisecond, and what crossed the
/// port. A model encodes our assumptions: `tests/testsuite/inav_sitl.rs` holds faithd to iNav's
/// own firmware; these tests cover what SITL cannot be made to do (stale telemetry,
/// garbage on the wire, a vanishing port) and run in CI, which has no SITL.
pub struct MspMock {
    pub slave_path: PathBuf,
    /// (time, roll value the model's iNav uses)
    pub roll_log: Arc<Mutex<Vec<(Instant, u16)>>>,
    /// Every MSP_SET_RAW_RC iNav served: (time, channels).
    pub frames: Arc<Mutex<Vec<Written>>>,
    /// Every request that reached the port, and every one iNav answered.
    pub traffic: Arc<Mutex<Traffic>>,
    /// A set-up change to make while faithd runs (a configurator on another port).
    setup_change: Arc<Mutex<Option<Setup>>>,
    setup: Setup,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    _slave: OwnedFd,
    /// A timed test: no heavy test runs while iNav's port does (dropped last).
    _cpu: super::cpu::Slot,
}

/// One MSP_SET_RAW_RC iNav served: when, and its channels.
pub type Written = (Instant, Vec<u16>);

/// What crossed the port: requests as they arrived, commands as iNav served them.
#[derive(Clone, Debug, Default)]
pub struct Traffic {
    pub arrived: Vec<(Instant, u16)>,
    pub served: Vec<(Instant, u16)>,
    pub bytes_lost: u64,
}

pub fn is_roll(v: u16) -> bool {
    v == 1200 || v == 1800
}

impl MspMock {
    pub fn start(controls: Arc<Controls>) -> Self {
        Self::start_with(controls, Setup::default())
    }

    /// The port of a flight controller set up as `setup` says.
    pub fn start_with(controls: Arc<Controls>, setup: Setup) -> Self {
        let cpu = super::cpu::timed();
        let (master, slave, slave_path) = raw_pty();
        let roll_log = Arc::new(Mutex::new(Vec::new()));
        let frames = Arc::new(Mutex::new(Vec::new()));
        let traffic = Arc::new(Mutex::new(Traffic::default()));
        let setup_change = Arc::new(Mutex::new(None));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (roll_log, frames, traffic, setup_change, stop) = (
                roll_log.clone(),
                frames.clone(),
                traffic.clone(),
                setup_change.clone(),
                stop.clone(),
            );
            let setup = setup.clone();
            std::thread::spawn(move || {
                let start = Instant::now();
                let at = |t_us: i64| start + Duration::from_micros(t_us as u64);
                let mut fc = InavMsp::new(setup, 0);
                let mut buf = [0u8; 4096];
                let mut seen = (0, 0, 0);
                while !stop.load(Ordering::Relaxed) {
                    let mut fds = [nix::poll::PollFd::new(
                        std::os::fd::AsFd::as_fd(&master),
                        nix::poll::PollFlags::POLLIN,
                    )];
                    let ready = nix::poll::poll(&mut fds, 1u16).unwrap_or(0) > 0;
                    if let Some(s) = setup_change.lock().unwrap().take() {
                        fc.setup = s;
                    }
                    let now_us = start.elapsed().as_micros() as i64;
                    let switch_us = controls.switch_us.load(Ordering::Relaxed);
                    let mut pilot = Pilot::flying([
                        PILOT_ROLL_US,
                        1500,
                        1500,
                        1400,
                        1900,
                        switch_us,
                        1000,
                        1000,
                    ]);
                    pilot.armed = controls.armed.load(Ordering::Relaxed);
                    pilot.failsafe = controls.system_status.load(Ordering::Relaxed) >= 5;
                    fc.set_pilot(pilot);
                    fc.ignore_frames = controls.override_ignored.load(Ordering::Relaxed);
                    if ready
                        && let Ok(n) = nix::unistd::read(&master, &mut buf)
                        && n > 0
                    {
                        fc.receive(&buf[..n], now_us);
                    }
                    fc.advance(now_us);
                    let out = fc.take_output();
                    if !out.is_empty() {
                        let _ = nix::unistd::write(&master, &out);
                    }
                    let log = &fc.log;
                    frames.lock().unwrap().extend(
                        log.frames[seen.0..]
                            .iter()
                            .map(|(t, ch)| (at(*t), ch.clone())),
                    );
                    {
                        let mut traffic = traffic.lock().unwrap();
                        traffic
                            .arrived
                            .extend(log.arrived[seen.1..].iter().map(|(t, c)| (at(*t), *c)));
                        traffic
                            .served
                            .extend(log.served[seen.2..].iter().map(|(t, c)| (at(*t), *c)));
                        traffic.bytes_lost = log.bytes_lost;
                    }
                    seen = (log.frames.len(), log.arrived.len(), log.served.len());
                    let roll_us = fc.roll_in_use();
                    controls.roll_us.store(roll_us, Ordering::Relaxed);
                    roll_log.lock().unwrap().push((at(now_us), roll_us));
                }
            })
        };
        MspMock {
            slave_path,
            roll_log,
            frames,
            traffic,
            setup_change,
            setup,
            stop,
            thread: Some(thread),
            _slave: slave,
            _cpu: cpu,
        }
    }

    /// Changes iNav's set-up while it runs, as a configurator or a script on another
    /// MSP port would (no reboot: what iNav fixes at boot stays).
    pub fn change_setup(&mut self, change: impl FnOnce(&mut Setup)) {
        change(&mut self.setup);
        *self.setup_change.lock().unwrap() = Some(self.setup.clone());
    }

    /// Suspends (or resumes) output on faithd's side of the port, as a UART held
    /// off by flow control: faithd's writes stop completing.
    pub fn hold_faithds_writes(&self, held: bool) {
        hold_output(&self._slave, held);
    }

    /// faithd's `[command]` section for this port.
    pub fn command_toml(&self) -> String {
        format!(
            "[command.sink]\nkind = \"msp\"\nendpoint = \"serial:{}\"\n",
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
