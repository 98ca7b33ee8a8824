//! The daemon's one clock: monotonic microseconds since start. Every timestamp the
//! adapters hand the core (events, attitude, RC, decisions) is on this clock.
//!
//! The clock is handed to every task from outside (as copper-rs hands its robot
//! clock to tasks): in flight it is the wall clock; in a simulated flight
//! ([`DaemonClock::simulated`]) it is the simulated time of a tokio runtime whose
//! clock is paused and advanced by the simulation, so the same tasks, timers and
//! timeouts run in simulated time, faster than real time and the same on every run.
//!
//! The recordings stamp MAVLink frames in Unix time, as .tlog readers expect; they use
//! the Unix time of the daemon's start plus this clock, not the wall clock of the
//! moment, so a replay can put every frame back on the daemon clock exactly (the
//! start's Unix time is written into the window log).

use std::time::{Instant, SystemTime, UNIX_EPOCH};

#[derive(Clone, Copy, Debug)]
pub struct DaemonClock {
    origin: Origin,
    start_unix_us: i64,
}

/// Where the clock's zero is, and so which time it reads.
#[derive(Clone, Copy, Debug)]
enum Origin {
    /// The process's monotonic clock: flight, bench, tests in real time.
    Wall(Instant),
    /// tokio's clock, paused and advanced by a simulation: read only from tasks of
    /// that runtime (outside a runtime tokio reads the wall clock).
    Simulated(tokio::time::Instant),
}

impl DaemonClock {
    /// The wall clock, from now.
    pub fn start() -> Self {
        let start_unix_us = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| i64::try_from(d.as_micros()).unwrap_or(0));
        Self {
            origin: Origin::Wall(Instant::now()),
            start_unix_us,
        }
    }

    /// The simulated time of the current tokio runtime, from now; `start_unix_us` is
    /// what the simulation calls the Unix time of its zero (recordings, logs), fixed
    /// so that a simulated flight is the same on every run. Call it inside a runtime
    /// whose clock is paused (`start_paused`): with a running clock it would be a
    /// wall clock that only reads correctly from the runtime's threads.
    pub fn simulated(start_unix_us: i64) -> Self {
        Self {
            origin: Origin::Simulated(tokio::time::Instant::now()),
            start_unix_us,
        }
    }

    /// Whether this is a simulation's clock.
    pub fn is_simulated(&self) -> bool {
        matches!(self.origin, Origin::Simulated(_))
    }

    pub fn now_us(&self) -> i64 {
        let elapsed = match self.origin {
            Origin::Wall(start) => start.elapsed(),
            Origin::Simulated(start) => tokio::time::Instant::now().duration_since(start),
        };
        i64::try_from(elapsed.as_micros()).unwrap_or(i64::MAX)
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

/// The process's monotonic clock, for the pipeline's stage timings: compute time is
/// measured on the wall clock even in a simulated flight, where it is then charged
/// in simulated time (`cycle::compute`).
#[derive(Clone, Copy, Debug)]
pub struct WallStageClock(Instant);

impl WallStageClock {
    pub fn new() -> Self {
        Self(Instant::now())
    }
}

impl Default for WallStageClock {
    fn default() -> Self {
        Self::new()
    }
}

impl faithd_core::pipeline::StageClock for WallStageClock {
    fn now_ns(&mut self) -> u64 {
        u64::try_from(self.0.elapsed().as_nanos()).unwrap_or(u64::MAX)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(start_paused = true)]
    async fn a_simulated_clock_moves_only_with_simulated_time() {
        let clock = DaemonClock::simulated(1_700_000_000_000_000);
        assert_eq!(clock.now_us(), 0);
        // Real time passes; simulated time does not.
        std::thread::sleep(std::time::Duration::from_millis(5));
        assert_eq!(clock.now_us(), 0);
        tokio::time::sleep(std::time::Duration::from_millis(1500)).await;
        assert_eq!(clock.now_us(), 1_500_000);
        assert_eq!(clock.unix_us(clock.now_us()), 1_700_000_001_500_000);
        assert!(clock.is_simulated());
    }
}
