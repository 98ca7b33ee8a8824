//! The pipeline thread: one cycle per period, within a budget.
//!
//! Each cycle takes the events that arrived, the attitude that covers them, runs the
//! pipeline, publishes its health and any roll decision, and measures itself. A
//! cycle over budget makes the next ones cheaper ([`super::shed`]); a late cycle
//! skips the missed periods instead of running back to back. The MAVLink side never
//! waits for this thread: everything leaves it through non-blocking sends.

pub mod shed;

use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde::{Deserialize, Serialize};
use tokio::sync::watch;

use crate::clock::DaemonClock;
use crate::logging::Throttle;
use faithd_core::attitude::AttitudeLog;
use faithd_core::decide::{Action, Decision};
use faithd_core::event::Event;
use faithd_core::invalid::{Invalid, check};
use faithd_core::pipeline::{Pipeline, PipelineConfig};
use faithd_core::safety::gate::{PipelineProblem, PipelineStatus};
use faithd_formats::window_log::WindowLine;
use faithd_formats::window_log::WindowLogLine;
use shed::Shedder;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DaemonConfig {
    /// Pipeline cycle period (10 ms = 100 decisions per second).
    pub period_us: i64,
    /// A cycle longer than this is an overrun: the next cycles shed load.
    pub budget_us: i64,
    /// Load shedding never goes below these.
    pub shed_min_vectors: usize,
    pub shed_min_iterations: u32,
    /// No event batch for this long: the camera is gone, the pipeline unhealthy.
    pub event_stale_us: i64,
}

impl Default for DaemonConfig {
    fn default() -> Self {
        Self {
            period_us: 10_000,
            budget_us: 8_000,
            shed_min_vectors: 300,
            shed_min_iterations: 13,
            event_stale_us: 200_000,
        }
    }
}

impl DaemonConfig {
    /// `[daemon]`: a period of 1 to 100 ms and a budget within it.
    pub fn validate(&self) -> Result<(), Invalid> {
        let d = self;
        check(
            (1000..=100_000).contains(&d.period_us),
            "daemon.period_us",
            || format!("must be 1 to 100 ms, got {}", d.period_us),
        )?;
        check(
            d.budget_us > 0 && d.budget_us <= d.period_us,
            "daemon.budget_us",
            || {
                format!(
                    "must be positive and at most period_us, got {}",
                    d.budget_us
                )
            },
        )?;
        check(d.shed_min_vectors >= 1, "daemon.shed_min_vectors", || {
            "must be at least 1".into()
        })?;
        check(
            d.shed_min_iterations >= 1,
            "daemon.shed_min_iterations",
            || "must be at least 1".into(),
        )?;
        check(
            (1000..=10_000_000).contains(&d.event_stale_us),
            "daemon.event_stale_us",
            || format!("must be 1 ms to 10 s, got {}", d.event_stale_us),
        )
    }
}

/// Repeated warnings (overruns) are logged at most this often, with a count.
const LOG_EVERY_US: i64 = 5_000_000;

/// A roll decision and the newest event of the window that produced it.
#[derive(Clone, Copy, Debug)]
pub struct RollDecision {
    pub decision: Decision,
    pub last_event_us: i64,
}

pub struct CycleIo {
    pub events: Receiver<Vec<Event>>,
    pub attitude: Arc<Mutex<AttitudeLog>>,
    pub status: watch::Sender<PipelineStatus>,
    /// The newest roll decision: a newer one replaces one the commander has not
    /// read yet (it only acts on fresh decisions), so none is ever refused.
    pub decisions: watch::Sender<Option<RollDecision>>,
    pub recorder: Option<crate::record::Recorder>,
    /// Set when the daemon stops: the thread ends at its next period.
    pub stop: Arc<std::sync::atomic::AtomicBool>,
}

/// Runs until the event source hangs up or `io.stop` is set.
pub fn run(pipeline_config: PipelineConfig, config: DaemonConfig, clock: DaemonClock, io: CycleIo) {
    let mut pipeline = Pipeline::new(pipeline_config);
    let mut shedder = Shedder::new(
        pipeline_config.max_vectors,
        pipeline_config.faith.iterations,
        config.shed_min_vectors,
        config.shed_min_iterations,
    );
    let mut pending: Vec<Event> = Vec::new();
    let mut attitude = Vec::new();
    let mut last_batch_us = clock.now_us();
    let mut last_logged: Option<(
        std::mem::Discriminant<Action>,
        std::mem::Discriminant<faithd_core::decide::Reason>,
    )> = None;
    let mut next_us = clock.now_us() + config.period_us;
    let mut stage_clock = clock;
    // The load-shedding settings in force, for the window log.
    let mut max_vectors = pipeline_config.max_vectors;
    let mut foe_iterations = pipeline_config.faith.iterations;
    let mut overrun_log = Throttle::new(LOG_EVERY_US);
    loop {
        if io.stop.load(std::sync::atomic::Ordering::Acquire) {
            return;
        }
        // Wait for the period's end, taking batches as they come.
        loop {
            let now = clock.now_us();
            if now >= next_us {
                break;
            }
            match io
                .events
                .recv_timeout(Duration::from_micros((next_us - now) as u64))
            {
                Ok(batch) => {
                    last_batch_us = clock.now_us();
                    if let (Some(r), false) = (&io.recorder, batch.is_empty()) {
                        r.send(crate::record::Item::Events(batch.clone()));
                    }
                    pending.extend(batch);
                }
                Err(RecvTimeoutError::Timeout) => break,
                Err(RecvTimeoutError::Disconnected) => {
                    tracing::warn!("event source ended; pipeline thread stops");
                    return;
                }
            }
        }
        let started_us = clock.now_us();
        let window_end_us = started_us;
        let take = faithd_core::window::events_until(&pending, window_end_us);
        io.attitude
            .lock()
            .expect("attitude log lock")
            .copy_for_window(window_end_us, pipeline_config.history_us, &mut attitude);
        let last_event_us = pending[..take].last().map_or(window_end_us, |e| e.t_us);
        let report =
            pipeline.process_window(&pending[..take], &attitude, window_end_us, &mut stage_clock);
        let decision = report.decision;
        let derotated = report.derotation.applied;
        let window_line = io
            .recorder
            .as_ref()
            .map(|_| WindowLine::from_report(window_end_us, take, &report));
        pending.drain(..take);

        let problem = if started_us - last_batch_us > config.event_stale_us {
            Some(PipelineProblem::NoEvents)
        } else if !derotated {
            Some(PipelineProblem::NoAttitude)
        } else {
            None
        };
        io.status.send_replace(PipelineStatus {
            last_cycle_us: Some(started_us),
            problem,
        });
        let key = (
            std::mem::discriminant(&decision.action),
            std::mem::discriminant(&decision.reason),
        );
        if last_logged != Some(key) {
            tracing::info!(t_us = decision.t_us, "decision: {decision}");
            last_logged = Some(key);
        } else {
            tracing::debug!(t_us = decision.t_us, "decision: {decision}");
        }
        if matches!(decision.action, Action::Roll { .. }) {
            io.decisions.send_replace(Some(RollDecision {
                decision,
                last_event_us,
            }));
        }
        if let (Some(recorder), Some(line)) = (&io.recorder, window_line) {
            let logged = WindowLogLine {
                line: &line,
                max_vectors,
                foe_iterations,
            };
            recorder.send(crate::record::Item::Window(
                serde_json::to_string(&logged).expect("window line serialises"),
            ));
        }

        let cycle_us = clock.now_us() - started_us;
        if let Some(load) = shedder.observe(cycle_us, config.budget_us) {
            pipeline.set_max_vectors(load.max_vectors);
            pipeline.set_foe_iterations(load.iterations);
            (max_vectors, foe_iterations) = (load.max_vectors, load.iterations);
            tracing::warn!(
                level = load.level,
                max_vectors = load.max_vectors,
                iterations = load.iterations,
                "load level changed"
            );
        }
        if cycle_us > config.budget_us {
            overrun_log.event(clock.now_us(), |since| {
                tracing::warn!(
                    cycle_us,
                    budget_us = config.budget_us,
                    overruns = shedder.overruns,
                    since_last_line = since,
                    "cycle overran its budget"
                )
            });
        }
        next_us += config.period_us;
        let now = clock.now_us();
        if now >= next_us {
            // Late: skip the missed periods rather than run back to back.
            let missed = (now - next_us) / config.period_us + 1;
            next_us += missed * config.period_us;
        }
    }
}
