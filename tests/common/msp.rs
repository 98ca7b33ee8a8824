//! iNav's MSP port on a pseudo-terminal, answered by faithd's model of iNav.

use std::os::fd::OwnedFd;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::autopilot::{Controls, PILOT_ROLL_US};
use super::{hold_output, poll_until, raw_pty};

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
