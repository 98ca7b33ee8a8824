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

use crate::clock::{DaemonClock, WallStageClock};
use crate::logging::Throttle;
use faithd_core::attitude::AttitudeLog;
use faithd_core::decide::{Action, Decision};
use faithd_core::event::Event;
use faithd_core::invalid::{Invalid, check};
use faithd_core::pipeline::{
    Pipeline, PipelineConfig, PipelineTelemetry, StageClock, WindowReport,
};
use faithd_core::safety::gate::{PipelineProblem, PipelineStatus};
use faithd_formats::window_log::WindowLine;
use faithd_formats::window_log::WindowLogLine;
use shed::{Load, Shedder};

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
    pub shed_min_fits: usize,
    /// ...and the events per window that reach the flow, halved only once the three
    /// above are at their floors: 30,000 (3 Mev/s), a quarter of a DVS240's peak,
    /// whose flow costs 2 to 7 ms at the Atom's factor (240 x 180 to 640 x 480).
    pub shed_min_events: usize,
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
            shed_min_fits: 250,
            shed_min_events: 30_000,
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
        check(d.shed_min_fits >= 1, "daemon.shed_min_fits", || {
            "must be at least 1".into()
        })?;
        check(d.shed_min_events >= 1, "daemon.shed_min_events", || {
            "must be at least 1".into()
        })?;
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
    pub outputs: CycleOutputs,
    /// The run's stop: the driver ends at its next period once it is requested.
    pub stop: crate::shutdown::Stop,
}

/// Where a cycle's results go.
pub struct CycleOutputs {
    pub status: watch::Sender<PipelineStatus>,
    /// The newest roll decision: a newer one replaces one the commander has not
    /// read yet (it only acts on fresh decisions), so none is ever refused.
    pub decisions: watch::Sender<Option<RollDecision>>,
    /// What the pipeline is seeing and costing, for the ground station's plots.
    pub telemetry: watch::Sender<PipelineTelemetry>,
    pub recorder: Option<crate::record::Recorder>,
}

/// What one window asked of the processor: the counts its compute time follows.
/// A simulated flight charges the time from these (`compute`), so that the same
/// flight costs the same on any machine and under any load.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Work {
    /// Events in the window.
    pub events: usize,
    /// Of them, left out before the flow: the window had more than its event cap.
    pub skipped: usize,
    /// Events that reached a plane fit (in view, not refractory, within the cap).
    pub fits: usize,
    /// Flow vectors the window produced (derotated).
    pub new_vectors: usize,
    /// Vectors of the history (TTC, box checks).
    pub history_vectors: usize,
    /// Vectors FAITH took, and its iterations.
    pub foe_vectors: usize,
    pub foe_iterations: u32,
    /// Vectors with a TTC: DBSCAN's points.
    pub clustered: usize,
}

impl Work {
    /// The counts of a window of `events` events that FAITH ran with `foe_iterations`.
    pub fn of(report: &WindowReport<'_>, events: usize, foe_iterations: u32) -> Self {
        let stats = report.flow_stats;
        Work {
            events,
            skipped: stats.skipped as usize,
            fits: stats
                .events
                .saturating_sub(stats.out_of_view + stats.refractory + stats.not_fitted)
                as usize,
            new_vectors: stats.vectors as usize,
            history_vectors: report.vectors.len(),
            foe_vectors: report.decision.vectors,
            foe_iterations,
            clustered: report.ttc_s.iter().filter(|t| t.is_finite()).count(),
        }
    }
}

/// One window's results, held until its compute is over: only then do they leave
/// the pipeline (in flight, that is when the thread gets there; in a simulated
/// flight, when the simulated board would have finished).
pub struct WindowOutcome {
    pub started_us: i64,
    status: PipelineStatus,
    decision: Decision,
    last_event_us: i64,
    window_log: Option<String>,
    pub work: Work,
    /// The stages' compute time on this machine's wall clock.
    pub measured_ns: u64,
    pub timings: faithd_core::pipeline::StageTimings,
}

/// The pipeline's state between windows: the pipeline, the events not yet taken,
/// load shedding and what was logged last. [`drive`] runs it, paced as its caller
/// says: on a thread on the wall clock in flight ([`run`]), as a task in simulated
/// time in the lab.
pub struct Cycle {
    pipeline_config: PipelineConfig,
    config: DaemonConfig,
    pipeline: Pipeline,
    shedder: Shedder,
    pending: Vec<Event>,
    attitude: Vec<faithd_core::attitude::AttitudeSample>,
    last_batch_us: i64,
    last_logged: Option<(
        std::mem::Discriminant<Action>,
        std::mem::Discriminant<faithd_core::decide::Reason>,
    )>,
    /// The load-shedding settings in force, for the window log.
    max_vectors: usize,
    foe_iterations: u32,
    max_fits: usize,
    max_events: usize,
    overrun_log: Throttle,
    /// Windows over the event cap, logged at most every `LOG_EVERY_US`.
    capped_log: Throttle,
    telemetry: PipelineTelemetry,
    /// Hears every window (a simulated flight's video).
    window_tap: Option<WindowTap>,
}

/// Hears each window's events and everything the pipeline made of them.
pub type WindowTap = Box<dyn FnMut(&[Event], &WindowReport<'_>) + Send>;

impl Cycle {
    pub fn new(pipeline_config: PipelineConfig, config: DaemonConfig, now_us: i64) -> Self {
        Self {
            pipeline: Pipeline::new(pipeline_config),
            shedder: Shedder::new(
                Load {
                    level: 0,
                    max_vectors: pipeline_config.max_vectors,
                    iterations: pipeline_config.faith.iterations,
                    max_fits: pipeline_config.flow.max_fits_per_window,
                    max_events: pipeline_config.flow.max_events_per_window,
                },
                Load {
                    level: 0,
                    max_vectors: config.shed_min_vectors,
                    iterations: config.shed_min_iterations,
                    max_fits: config.shed_min_fits,
                    max_events: config.shed_min_events,
                },
            ),
            pending: Vec::new(),
            attitude: Vec::new(),
            last_batch_us: now_us,
            last_logged: None,
            max_vectors: pipeline_config.max_vectors,
            foe_iterations: pipeline_config.faith.iterations,
            max_fits: pipeline_config.flow.max_fits_per_window,
            max_events: pipeline_config.flow.max_events_per_window,
            overrun_log: Throttle::new(LOG_EVERY_US),
            capped_log: Throttle::new(LOG_EVERY_US),
            telemetry: PipelineTelemetry::default(),
            window_tap: None,
            pipeline_config,
            config,
        }
    }

    /// Hands every window from now on to `tap` as well.
    pub fn tap_windows(&mut self, tap: WindowTap) {
        self.window_tap = Some(tap);
    }

    /// Takes a batch of events that arrived at `now_us` (recording it).
    pub fn take(
        &mut self,
        batch: Vec<Event>,
        now_us: i64,
        recorder: Option<&crate::record::Recorder>,
    ) {
        self.last_batch_us = now_us;
        if let (Some(r), false) = (recorder, batch.is_empty()) {
            r.send(crate::record::Item::Events(batch.clone()));
        }
        self.pending.extend(batch);
    }

    /// Runs the window that ends at `window_end_us` on the events taken so far and
    /// the attitude that covers them. `recording` asks for the window log line.
    pub fn run_window(
        &mut self,
        window_end_us: i64,
        attitude: &Mutex<AttitudeLog>,
        stage_clock: &mut dyn StageClock,
        recording: bool,
    ) -> WindowOutcome {
        let take = faithd_core::window::events_until(&self.pending, window_end_us);
        let attitude_used = attitude.lock().expect("attitude log lock").copy_for_window(
            window_end_us,
            self.pipeline_config.history_us,
            &mut self.attitude,
        );
        let last_event_us = self.pending[..take]
            .last()
            .map_or(window_end_us, |e| e.t_us);
        let report = self.pipeline.process_window(
            &self.pending[..take],
            &self.attitude,
            window_end_us,
            stage_clock,
        );
        if let Some(tap) = &mut self.window_tap {
            tap(&self.pending[..take], &report);
        }
        let decision = report.decision;
        let work = Work::of(&report, take, self.foe_iterations);
        let timings = report.timings;
        let measured_ns = timings.total_ns();
        let window_log = recording.then(|| {
            let line = WindowLine::from_report(window_end_us, take, &report);
            let logged = WindowLogLine {
                line: &line,
                max_vectors: self.max_vectors,
                foe_iterations: self.foe_iterations,
                max_fits: self.max_fits,
                max_events: self.max_events,
                attitude: attitude_used,
            };
            serde_json::to_string(&logged).expect("window line serialises")
        });
        let usable = report.derotation.state.usable();
        self.pending.drain(..take);
        let problem = if window_end_us - self.last_batch_us > self.config.event_stale_us {
            Some(PipelineProblem::NoEvents)
        } else if !usable {
            Some(PipelineProblem::NoAttitude)
        } else {
            None
        };
        WindowOutcome {
            started_us: window_end_us,
            status: PipelineStatus {
                last_cycle_us: Some(window_end_us),
                problem,
            },
            decision,
            last_event_us,
            window_log,
            work,
            measured_ns,
            timings,
        }
    }

    /// Hands a window's results on: the pipeline's health, a roll decision, the
    /// window log line; logs a decision that differs in kind from the last one.
    pub fn publish(&mut self, outcome: WindowOutcome, outputs: &CycleOutputs) {
        let WindowOutcome {
            status,
            decision,
            last_event_us,
            window_log,
            work,
            ..
        } = outcome;
        outputs.status.send_replace(status);
        if work.skipped > 0 {
            let max_events = self.max_events;
            self.capped_log.event(decision.t_us, |windows| {
                tracing::warn!(
                    events = work.events,
                    skipped = work.skipped,
                    max_events,
                    windows_since_last_line = windows,
                    "window over the event cap: evenly spaced runs of its events kept"
                )
            });
        }
        self.telemetry.events += work.events as u64;
        self.telemetry.foe_px = decision.foe_px;
        self.telemetry.obstacle_ttc_s = decision.obstacle.map(|o| o.mean_ttc_s);
        let key = (
            std::mem::discriminant(&decision.action),
            std::mem::discriminant(&decision.reason),
        );
        if self.last_logged != Some(key) {
            tracing::info!(t_us = decision.t_us, "decision: {decision}");
            self.last_logged = Some(key);
        } else {
            tracing::debug!(t_us = decision.t_us, "decision: {decision}");
        }
        if matches!(decision.action, Action::Roll { .. }) {
            outputs.decisions.send_replace(Some(RollDecision {
                decision,
                last_event_us,
            }));
        }
        if let (Some(recorder), Some(line)) = (&outputs.recorder, window_log) {
            recorder.send(crate::record::Item::Window(line));
        }
    }

    /// Accounts a cycle that took `cycle_us`: over budget, the next ones shed load;
    /// a calm stretch restores it.
    pub fn account(&mut self, cycle_us: i64, now_us: i64) {
        self.telemetry.windows += 1;
        self.telemetry.cycle_us_total += cycle_us;
        let budget_us = self.config.budget_us;
        if let Some(load) = self.shedder.observe(cycle_us, budget_us) {
            self.pipeline.set_max_vectors(load.max_vectors);
            self.pipeline.set_foe_iterations(load.iterations);
            self.pipeline.set_max_fits(load.max_fits);
            self.pipeline.set_max_events(load.max_events);
            (self.max_vectors, self.foe_iterations, self.max_fits) =
                (load.max_vectors, load.iterations, load.max_fits);
            self.max_events = load.max_events;
            tracing::warn!(
                level = load.level,
                max_vectors = load.max_vectors,
                iterations = load.iterations,
                max_fits = load.max_fits,
                max_events = load.max_events,
                "load level changed"
            );
        }
        if cycle_us > budget_us {
            let overruns = self.shedder.overruns;
            self.overrun_log.event(now_us, |since| {
                tracing::warn!(
                    cycle_us,
                    budget_us,
                    overruns,
                    since_last_line = since,
                    "cycle overran its budget"
                )
            });
        }
    }

    /// Hands the running totals on, once a window is published and accounted.
    pub fn report_telemetry(&self, outputs: &CycleOutputs) {
        outputs.telemetry.send_replace(self.telemetry);
    }

    /// Cycles over budget since start.
    pub fn overruns(&self) -> u64 {
        self.shedder.overruns
    }

    /// The load level in force (0 = full load).
    pub fn load_level(&self) -> u32 {
        self.shedder.load().level
    }

    /// The next period's end after one that ended at `next_us`, skipping periods
    /// already missed rather than running back to back.
    pub fn next_period(&self, next_us: i64, now_us: i64) -> i64 {
        let period_us = self.config.period_us;
        let next_us = next_us + period_us;
        if now_us >= next_us {
            let missed = (now_us - next_us) / period_us + 1;
            return next_us + missed * period_us;
        }
        next_us
    }
}

/// What differs between the flight and the lab in running the pipeline: how the
/// driver waits for a period's end (and hears the camera meanwhile), and how long a
/// window's compute counts. The flight waits on the wall clock and counts what it
/// measured; the lab waits in simulated time and charges what the target board
/// would have needed. Everything else is [`drive`]'s, the same in both.
pub trait Pacing {
    /// Waits until `until_us` on the daemon clock, handing every batch of events that
    /// arrives meanwhile to `take` with its arrival time. `false` when the camera has
    /// hung up.
    fn wait_until(
        &mut self,
        until_us: i64,
        events: &mut Receiver<Vec<Event>>,
        take: &mut (dyn FnMut(Vec<Event>, i64) + Send),
    ) -> impl std::future::Future<Output = bool>;

    /// A window's compute, begun at `started_us`, is done: how long it counts (the
    /// driver publishes the window's results only after this returns).
    fn computed(
        &mut self,
        started_us: i64,
        outcome: &WindowOutcome,
    ) -> impl std::future::Future<Output = i64>;

    /// Hears every finished cycle: what it cost and the load level after it.
    fn cycled(&mut self, _cycle: CycleReport) {}
}

/// One cycle, as the driver counted it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CycleReport {
    pub started_us: i64,
    /// The time the window's compute counted for ([`Pacing::computed`]).
    pub charged_us: i64,
    pub work: Work,
    /// The load level after the cycle (0 = full load).
    pub load_level: u32,
}

/// The one pipeline driver: a window at every period's end on the events that
/// arrived, its results published once its compute is done, load shed after an
/// overrun, until the camera hangs up or `io.stop` is requested.
pub async fn drive(mut cycle: Cycle, clock: DaemonClock, io: CycleIo, pacing: &mut impl Pacing) {
    let CycleIo {
        mut events,
        attitude,
        outputs,
        stop,
    } = io;
    let mut stage_clock = WallStageClock::new();
    let recording = outputs.recorder.is_some();
    let mut next_us = clock.now_us() + cycle.config.period_us;
    loop {
        if stop.is_requested() {
            return;
        }
        let recorder = outputs.recorder.as_ref();
        let alive = pacing
            .wait_until(next_us, &mut events, &mut |batch, at_us| {
                cycle.take(batch, at_us, recorder)
            })
            .await;
        if !alive {
            // The camera ends first when the run stops: that is no news.
            if !stop.is_requested() {
                tracing::warn!("event source ended; the pipeline stops");
            }
            return;
        }
        let started_us = clock.now_us();
        let outcome = cycle.run_window(started_us, &attitude, &mut stage_clock, recording);
        let charged_us = pacing.computed(started_us, &outcome).await;
        let work = outcome.work;
        cycle.publish(outcome, &outputs);
        let now_us = clock.now_us();
        cycle.account(charged_us, now_us);
        cycle.report_telemetry(&outputs);
        pacing.cycled(CycleReport {
            started_us,
            charged_us,
            work,
            load_level: cycle.load_level(),
        });
        next_us = cycle.next_period(next_us, now_us);
    }
}

/// Flight: the wall clock, the camera's batches taken as they come, a window's
/// compute counted as measured.
struct WallPacing {
    clock: DaemonClock,
}

impl Pacing for WallPacing {
    async fn wait_until(
        &mut self,
        until_us: i64,
        events: &mut Receiver<Vec<Event>>,
        take: &mut (dyn FnMut(Vec<Event>, i64) + Send),
    ) -> bool {
        loop {
            let now_us = self.clock.now_us();
            if now_us >= until_us {
                return true;
            }
            match events.recv_timeout(Duration::from_micros((until_us - now_us) as u64)) {
                Ok(batch) => take(batch, self.clock.now_us()),
                Err(RecvTimeoutError::Timeout) => return true,
                Err(RecvTimeoutError::Disconnected) => return false,
            }
        }
    }

    async fn computed(&mut self, started_us: i64, _outcome: &WindowOutcome) -> i64 {
        self.clock.now_us() - started_us
    }
}

/// Runs the pipeline on its own thread (flight) until the event source hangs up or
/// `io.stop` is requested: [`drive`] on the wall clock. The thread blocks in the camera's
/// channel between windows, never in a runtime shared with the MAVLink side.
pub fn run(pipeline_config: PipelineConfig, config: DaemonConfig, clock: DaemonClock, io: CycleIo) {
    let cycle = Cycle::new(pipeline_config, config, clock.now_us());
    let mut pacing = WallPacing { clock };
    // WallPacing never yields: its waits block this thread, which is the pipeline's
    // alone; a current-thread runtime only polls the driver.
    let runtime = tokio::runtime::Builder::new_current_thread()
        .build()
        .expect("a current-thread runtime needs no resources");
    runtime.block_on(drive(cycle, clock, io, &mut pacing));
}
