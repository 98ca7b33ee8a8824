//! The journal, written off the hot paths.
//!
//! Log lines go to stderr (journald under systemd) through a queue and a writer
//! thread: a stalled journal never blocks the pipeline, the link or the commander.
//! When the queue is full lines are dropped, counted, and the count is reported
//! ([`dropped_lines`]) once the journal catches up.

use std::sync::OnceLock;

use tracing_appender::non_blocking::{ErrorCounter, NonBlockingBuilder, WorkerGuard};

static DROPPED: OnceLock<ErrorCounter> = OnceLock::new();

/// Lines the queue holds before dropping.
const QUEUE_LINES: usize = 16_384;

/// Installs the subscriber; keep the guard alive until exit (it flushes the queue).
pub fn init(default_filter: &str) -> WorkerGuard {
    let (writer, guard) = NonBlockingBuilder::default()
        .lossy(true)
        .buffered_lines_limit(QUEUE_LINES)
        .thread_name("faithd-log")
        .finish(std::io::stderr());
    let _ = DROPPED.set(writer.error_counter());
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default_filter)),
        )
        .with_writer(writer)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    guard
}

/// Log lines dropped so far because the journal fell behind (0 without [`init`]).
pub fn dropped_lines() -> usize {
    DROPPED.get().map_or(0, ErrorCounter::dropped_lines)
}
/// Logs the first of a run of events at once and then at most once per period, with
/// how many happened since the last line.
#[derive(Debug)]
pub struct Throttle {
    period_us: i64,
    last_line_us: Option<i64>,
    since: u64,
}

impl Throttle {
    pub fn new(period_us: i64) -> Self {
        Self {
            period_us,
            last_line_us: None,
            since: 0,
        }
    }

    /// Counts one event; calls `log` with the count since the last line when due.
    pub fn event(&mut self, now_us: i64, log: impl FnOnce(u64)) {
        self.since += 1;
        if self
            .last_line_us
            .is_none_or(|t| now_us - t >= self.period_us)
        {
            log(self.since);
            self.since = 0;
            self.last_line_us = Some(now_us);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Throttle;

    #[test]
    fn a_throttle_logs_the_first_then_once_per_period_with_the_count() {
        let mut throttle = Throttle::new(1000);
        let mut lines = Vec::new();
        for t in 0..2500 {
            throttle.event(t, |n| lines.push((t, n)));
        }
        assert_eq!(lines, [(0, 1), (1000, 1000), (2000, 1000)]);
    }
}
