//! A test hook that hands attitude to the pipeline late, as a loaded companion board
//! does: the link records each frame at once, and the sample reaches the pipeline's
//! log `FAITHD_TEST_LATE_ATTITUDE_US` later. Replay must still feed every window the
//! samples it had (docs/recordings.md); this makes the late case the normal one in a
//! test instead of a rare one under load. Never set in flight: the journal warns.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::sync::mpsc;

use faithd_core::attitude::{AttitudeLog, AttitudeSample};

/// The environment variable that sets the hook.
pub const VARIABLE: &str = "FAITHD_TEST_LATE_ATTITUDE_US";

/// The delay the environment asks for: `None` when unset, an error naming the value
/// when it is not 1 us to 1 s.
pub fn delay_from_env() -> Result<Option<Duration>, String> {
    let Some(text) = std::env::var_os(VARIABLE) else {
        return Ok(None);
    };
    let text = text.to_string_lossy();
    match text.trim().parse::<u64>() {
        Ok(us @ 1..=1_000_000) => Ok(Some(Duration::from_micros(us))),
        _ => Err(format!(
            "must be a delay of 1 to 1000000 us, got {text:?} (unset it outside tests)"
        )),
    }
}

/// Where late samples go: each is pushed `delay` after it was handed over, in order.
pub type LateSender = mpsc::UnboundedSender<(tokio::time::Instant, AttitudeSample)>;

/// Starts the task that pushes each sample into `log` once its delay is over.
pub fn start(delay: Duration, log: Arc<Mutex<AttitudeLog>>) -> LateSender {
    tracing::warn!(
        delay_us = delay.as_micros() as u64,
        "test hook {VARIABLE}: attitude reaches the pipeline late; never set it in flight"
    );
    let (tx, mut rx) = mpsc::unbounded_channel::<(tokio::time::Instant, AttitudeSample)>();
    tokio::spawn(async move {
        while let Some((handed_at, sample)) = rx.recv().await {
            tokio::time::sleep_until(handed_at + delay).await;
            log.lock().expect("attitude log lock").push(sample);
        }
    });
    tx
}
