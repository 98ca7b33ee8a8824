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
