//! The daemon's one clock: monotonic microseconds since start. Every timestamp the
//! adapters hand the core (events, attitude, RC, decisions) is on this clock.
//!
//! The recordings stamp MAVLink frames in Unix time, as .tlog readers expect; they use
//! the Unix time of the daemon's start plus this clock, not the wall clock of the
//! moment, so a replay can put every frame back on the daemon clock exactly (the
//! start's Unix time is written into the window log).

use std::time::{Instant, SystemTime, UNIX_EPOCH};

#[derive(Clone, Copy, Debug)]
pub struct DaemonClock {
    start: Instant,
    start_unix_us: i64,
}

impl DaemonClock {
    pub fn start() -> Self {
        let start_unix_us = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| i64::try_from(d.as_micros()).unwrap_or(0));
        Self {
            start: Instant::now(),
            start_unix_us,
        }
    }

    pub fn now_us(&self) -> i64 {
        i64::try_from(self.start.elapsed().as_micros()).unwrap_or(i64::MAX)
    }

    /// Unix time (microseconds) of the daemon clock's zero.
    pub fn start_unix_us(&self) -> i64 {
        self.start_unix_us
    }

    /// Unix time of `t_us` on this clock, for .tlog stamps.
    pub fn unix_us(&self, t_us: i64) -> u64 {
        u64::try_from(self.start_unix_us.saturating_add(t_us)).unwrap_or(0)
    }
}

impl faithd_core::pipeline::StageClock for DaemonClock {
    fn now_ns(&mut self) -> u64 {
        u64::try_from(self.start.elapsed().as_nanos()).unwrap_or(u64::MAX)
    }
}
