//! The daemon's one clock: monotonic microseconds since start. Every timestamp the
//! adapters hand the core (events, attitude, RC, decisions) is on this clock.

use std::time::Instant;

#[derive(Clone, Copy, Debug)]
pub struct DaemonClock(Instant);

impl DaemonClock {
    pub fn start() -> Self {
        Self(Instant::now())
    }

    pub fn now_us(&self) -> i64 {
        i64::try_from(self.0.elapsed().as_micros()).unwrap_or(i64::MAX)
    }
}

impl crate::pipeline::StageClock for DaemonClock {
    fn now_ns(&mut self) -> u64 {
        u64::try_from(self.0.elapsed().as_nanos()).unwrap_or(u64::MAX)
    }
}
