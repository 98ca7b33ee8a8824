//! Which events belong to a pipeline window: one rule for the daemon, replay, the demo
//! and the simulated flights, so a flight replayed is windowed exactly as it flew.
//!
//! A window ending at `end_us` takes every pending event stamped at or before
//! `end_us`: the daemon closes its window at "now", and an event stamped now has
//! already arrived.

use crate::event::Event;

/// How many of `pending` (time-ordered) belong to the window ending at `end_us`.
pub fn events_until(pending: &[Event], end_us: i64) -> usize {
    pending.partition_point(|e| e.t_us <= end_us)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::event::Polarity;

    #[test]
    fn an_event_at_the_window_end_belongs_to_that_window() {
        let at = |t_us| Event::new(t_us, 0, 0, Polarity::On);
        let pending = [at(5), at(10), at(10), at(11)];
        assert_eq!(events_until(&pending, 9), 1);
        assert_eq!(events_until(&pending, 10), 3);
        assert_eq!(events_until(&pending, 11), 4);
        assert_eq!(events_until(&[], 11), 0);
    }
}
