//! The harness's time base: the wall clock in Unix microseconds, as faithd's journal
//! stamps its lines, so that what the radio sent and what the monitor read line up
//! with the daemon's log.

use std::time::{SystemTime, UNIX_EPOCH};

/// Microseconds since the Unix epoch: the time base shared with faithd's journal.
pub fn unix_us() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as i64)
}
