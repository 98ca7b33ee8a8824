//! Maps the autopilot's boot clock onto the daemon's clock.
//!
//! ATTITUDE carries `time_boot_ms`, the autopilot's time of the measurement. The
//! daemon stamps each message when it arrives; arrival = measurement + transport
//! delay, and the delay is never negative. The smallest (arrival - remote) over a
//! recent window is therefore the best estimate of the clock offset: it belongs to
//! the least delayed message and is not fooled by queueing on the serial line.

use std::collections::VecDeque;

#[derive(Clone, Debug)]
pub struct ClockSync {
    window: usize,
    offsets_us: VecDeque<i64>,
    last_remote_us: Option<i64>,
}

impl ClockSync {
    /// `window`: how many recent samples the minimum is taken over (at 50 Hz, 250 is
    /// five seconds: long enough to catch an undelayed frame, short enough to follow
    /// the drift between two crystals).
    pub fn new(window: usize) -> Self {
        Self {
            window: window.max(1),
            offsets_us: VecDeque::with_capacity(window.max(1)),
            last_remote_us: None,
        }
    }

    /// Records one message sent at `remote_us` (autopilot clock) and received at
    /// `local_us` (daemon clock); returns its measurement time on the daemon clock.
    pub fn observe(&mut self, remote_us: i64, local_us: i64) -> i64 {
        if self.last_remote_us.is_some_and(|last| remote_us < last) {
            // The autopilot rebooted: its clock started again from zero.
            self.offsets_us.clear();
        }
        self.last_remote_us = Some(remote_us);
        if self.offsets_us.len() == self.window {
            self.offsets_us.pop_front();
        }
        self.offsets_us.push_back(local_us - remote_us);
        self.to_local(remote_us)
    }

    /// How many recent samples the minimum is taken over.
    pub fn window(&self) -> usize {
        self.window
    }

    fn to_local(&self, remote_us: i64) -> i64 {
        let offset = self.offsets_us.iter().copied().min().unwrap_or(0);
        remote_us + offset
    }
}

impl Default for ClockSync {
    fn default() -> Self {
        Self::new(super::CLOCK_SYNC_WINDOW)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimum_delay_wins() {
        let mut s = ClockSync::new(100);
        // True offset 5 s; delays 3, 1, 7 ms.
        s.observe(1_000_000, 6_003_000);
        s.observe(1_020_000, 6_021_000);
        let t = s.observe(1_040_000, 6_047_000);
        assert_eq!(t, 6_041_000, "stamped with the 1 ms delay, the least seen");
    }

    #[test]
    fn reboot_resets() {
        let mut s = ClockSync::new(100);
        s.observe(50_000_000, 60_000_000);
        let t = s.observe(1_000, 60_100_000);
        assert_eq!(t, 60_100_000);
    }
}
