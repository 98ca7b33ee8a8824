//! One window through every stage: events and attitude in, decision out.
//!
//! The pipeline owns every buffer it needs, so a steady stream of windows allocates
//! nothing once warmed up. It never reads a clock: stage timings come from the
//! caller's [`StageClock`], which is a real monotonic clock in the daemon and a
//! counter (or nothing) in replays and tests.

use serde::{Deserialize, Serialize};

use crate::invalid::{Invalid, check};

use crate::attitude::AttitudeSample;
use crate::camera::CameraIntrinsics;
use crate::cluster::{
    ClusterStats, Dbscan, DbscanConfig, cluster_features, cluster_stats, expansion,
};
use crate::decide::{Action, Decision, DecisionConfig, Reason, decide};
use crate::derotate::{DerotationConfig, DerotationStats, Derotator};
use crate::event::Event;
use crate::flow::{FlowConfig, FlowStats, FlowVector, NormalFlow};
use crate::foe::{
    Faith, FaithConfig, FoeEstimate, FoeEstimator, FoeMethod, HalfPlaneMap, HalfPlaneMapConfig,
    Nesw, VecIntersections, VecIntersectionsConfig,
};
use crate::ttc::{TtcConfig, ttc_at_s};

/// Every tunable of the core, as it appears under `[pipeline]` in faithd.toml.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PipelineConfig {
    /// Seed of every random choice (FAITH's RANSAC); each window derives its own from
    /// it and the window time, so any window replays on its own.
    pub seed: u64,
    /// Flow older than this is forgotten, microseconds. Decisions run far more often
    /// than one window's events can support a fit, so they look at this much history.
    pub history_us: i64,
    /// At most this many (newest) vectors go to FOE and clustering: bounds the cost.
    pub max_vectors: usize,
    pub foe_method: FoeMethod,
    pub camera: CameraIntrinsics,
    pub flow: FlowConfig,
    pub derotation: DerotationConfig,
    pub faith: FaithConfig,
    pub half_planes: HalfPlaneMapConfig,
    pub vec_intersections: VecIntersectionsConfig,
    pub ttc: TtcConfig,
    pub cluster: DbscanConfig,
    pub decision: DecisionConfig,
    /// The FOE acted on is the median of the last this many windows' estimates (1 =
    /// the window's own). The heading changes slowly next to a 10 ms window, while
    /// one window's FOE can be pulled 20 px by a passing edge.
    pub foe_smoothing_windows: usize,
}

impl Default for PipelineConfig {
    fn default() -> Self {
        Self {
            seed: 0x5eed_fa17,
            history_us: 50_000,
            max_vectors: 3_000,
            foe_method: FoeMethod::Faith,
            camera: CameraIntrinsics::default(),
            flow: FlowConfig::default(),
            derotation: DerotationConfig::default(),
            faith: FaithConfig::default(),
            half_planes: HalfPlaneMapConfig::default(),
            vec_intersections: VecIntersectionsConfig::default(),
            ttc: TtcConfig::default(),
            cluster: DbscanConfig::default(),
            decision: DecisionConfig::default(),
            foe_smoothing_windows: 8,
        }
    }
}

impl PipelineConfig {
    /// Every check of `[pipeline]`: the daemon's, and the replay's of the settings a
    /// window log carries, before anything is allocated from them.
    pub fn validate(&self) -> Result<(), Invalid> {
        self.camera.validate()?;
        check(
            (1..=10_000_000).contains(&self.history_us),
            "pipeline.history_us",
            || format!("must be 1 us to 10 s, got {}", self.history_us),
        )?;
        check(
            (1..=100_000).contains(&self.max_vectors),
            "pipeline.max_vectors",
            || {
                format!(
                    "must be 1 to 100000 (buffers are sized from it), got {}",
                    self.max_vectors
                )
            },
        )?;
        check(
            (1..=100).contains(&self.foe_smoothing_windows),
            "pipeline.foe_smoothing_windows",
            || format!("must be 1 to 100, got {}", self.foe_smoothing_windows),
        )?;

        self.flow.validate()?;
        self.derotation.validate()?;
        self.faith.validate()?;
        self.ttc.validate()?;
        self.cluster.validate()?;
        self.decision.validate()?;
        Ok(())
    }
}

/// The caller's monotonic clock, read between stages to time them.
pub trait StageClock {
    fn now_ns(&mut self) -> u64;
}

/// A clock that never moves: for replays that do not need timings.
pub struct NoClock;

impl StageClock for NoClock {
    fn now_ns(&mut self) -> u64 {
        0
    }
}

/// Time spent in each stage of one window, nanoseconds of the caller's clock.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct StageTimings {
    pub flow_ns: u64,
    pub derotate_ns: u64,
    pub foe_ns: u64,
    pub ttc_ns: u64,
    pub cluster_ns: u64,
    pub decide_ns: u64,
}

impl StageTimings {
    pub fn total_ns(&self) -> u64 {
        self.flow_ns
            + self.derotate_ns
            + self.foe_ns
            + self.ttc_ns
            + self.cluster_ns
            + self.decide_ns
    }
}

/// What the pipeline has done so far, kept by its driver (the daemon's pipeline
/// thread, or task in a simulated flight) for the ground station's plots: running
/// totals, so a reader that looks now and then gets rates and means over the time
/// between two looks whatever it missed, and the newest window's estimates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PipelineTelemetry {
    /// Windows run, and the events they took.
    pub windows: u64,
    pub events: u64,
    /// The windows' cycle times added up, microseconds: measured in flight, charged
    /// in a simulated flight (the time the target board would have needed).
    pub cycle_us_total: i64,
    /// The newest window's FOE, when it has one in the view.
    pub foe_px: Option<(f64, f64)>,
    /// The mean TTC of the newest window's obstacle: the most urgent cluster in the
    /// way, or else the nearest cluster.
    pub obstacle_ttc_s: Option<f64>,
}

/// Everything one window produced, borrowed from the pipeline's buffers.
#[derive(Debug)]
pub struct WindowReport<'a> {
    pub t_us: i64,
    pub flow_stats: FlowStats,
    pub derotation: DerotationStats,
    /// The derotated flow the FOE and clusters were computed on.
    pub vectors: &'a [FlowVector],
    pub foe: FoeEstimate,
    /// TTC per vector, seconds; NaN where the vector contradicts the FOE.
    pub ttc_s: &'a [f64],
    /// Cluster per vector; `None` for noise or vectors without a TTC.
    pub labels: &'a [Option<u32>],
    pub clusters: &'a [ClusterStats],
    pub decision: Decision,
    pub timings: StageTimings,
}

/// The FOE method in use; FAITH, with its reusable buffers, is the large one.
enum Estimator {
    Faith(Box<Faith>),
    HalfPlanes(HalfPlaneMap),
    Nesw(Nesw),
    VecIntersections(VecIntersections),
}

impl Estimator {
    fn as_dyn(&mut self) -> &mut dyn FoeEstimator {
        match self {
            Estimator::Faith(e) => e.as_mut(),
            Estimator::HalfPlanes(e) => e,
            Estimator::Nesw(e) => e,
            Estimator::VecIntersections(e) => e,
        }
    }
}

/// The whole core, stateful across windows only through the event surface and the
/// flow history.
pub struct Pipeline {
    config: PipelineConfig,
    flow: NormalFlow,
    derotator: Derotator,
    estimator: Estimator,
    dbscan: Dbscan,
    fresh: Vec<FlowVector>,
    history: Vec<FlowVector>,
    /// The tight vectors of the history, the FOE's input (see `FlowVector::tight`).
    foe_input: Vec<FlowVector>,
    ttc: Vec<f64>,
    clustered: Vec<usize>,
    xy_px: Vec<(f64, f64)>,
    ttc_clustered: Vec<f64>,
    features: Vec<[f64; 3]>,
    cluster_labels: Vec<Option<u32>>,
    labels: Vec<Option<u32>>,
    clusters: Vec<ClusterStats>,
    /// Consecutive windows that called for a roll.
    /// One bit per recent window, newest lowest: did it call for a roll?
    recent_calls: u64,
    /// The last windows' FOE points, for the median.
    recent_foe_px: std::collections::VecDeque<(f64, f64)>,
    /// Scratch for that median, kept so a window allocates nothing.
    median_scratch: Vec<f64>,
}

impl Pipeline {
    pub fn new(config: PipelineConfig) -> Self {
        let cam = config.camera;
        let estimator = match config.foe_method {
            FoeMethod::Faith => {
                let mut faith = Faith::new(cam, config.faith);
                faith.reserve(config.max_vectors);
                Estimator::Faith(Box::new(faith))
            }
            FoeMethod::HalfPlanes => {
                Estimator::HalfPlanes(HalfPlaneMap::new(cam, config.half_planes))
            }
            FoeMethod::Nesw => Estimator::Nesw(Nesw::new(cam)),
            FoeMethod::VecIntersections => {
                Estimator::VecIntersections(VecIntersections::new(cam, config.vec_intersections))
            }
        };
        Self {
            flow: NormalFlow::new(&cam, config.flow),
            derotator: Derotator::new(cam, config.derotation),
            estimator,
            dbscan: Dbscan::with_capacity(config.cluster, config.max_vectors),
            fresh: Vec::with_capacity(config.max_vectors),
            history: Vec::with_capacity(2 * config.max_vectors),
            foe_input: Vec::with_capacity(config.max_vectors),
            ttc: Vec::with_capacity(2 * config.max_vectors),
            clustered: Vec::with_capacity(config.max_vectors),
            xy_px: Vec::with_capacity(config.max_vectors),
            ttc_clustered: Vec::with_capacity(config.max_vectors),
            features: Vec::with_capacity(config.max_vectors),
            cluster_labels: Vec::with_capacity(config.max_vectors),
            labels: Vec::with_capacity(2 * config.max_vectors),
            clusters: Vec::new(),
            recent_calls: 0,
            recent_foe_px: std::collections::VecDeque::with_capacity(
                config.foe_smoothing_windows.max(1),
            ),
            median_scratch: Vec::with_capacity(config.foe_smoothing_windows.max(1)),
            config,
        }
    }

    pub fn config(&self) -> &PipelineConfig {
        &self.config
    }

    /// Lowers FAITH's iteration count (load shedding); other methods ignore it.
    pub fn set_foe_iterations(&mut self, iterations: u32) {
        if let Estimator::Faith(f) = &mut self.estimator {
            f.set_iterations(iterations);
        }
    }

    /// Bounds the vectors used per decision (load shedding).
    pub fn set_max_vectors(&mut self, max_vectors: usize) {
        self.config.max_vectors = max_vectors.max(1);
    }

    /// Bounds the plane fits per window (load shedding).
    pub fn set_max_fits(&mut self, max_fits: usize) {
        self.config.flow.max_fits_per_window = max_fits.max(1);
    }

    /// Bounds the events per window that reach the flow (load shedding); never above
    /// the configured bound, which sized the buffer they are kept in.
    pub fn set_max_events(&mut self, max_events: usize) {
        self.config.flow.max_events_per_window =
            max_events.clamp(1, self.flow.config().max_events_per_window);
    }

    /// Forgets all state, e.g. after the camera reconnected.
    pub fn reset(&mut self) {
        self.flow.reset();
        self.history.clear();
        self.recent_calls = 0;
        self.recent_foe_px.clear();
    }

    /// Runs one window: `events` (time-ordered, all newer than the previous window's)
    /// and the attitude samples covering them, decided at `window_end_us`.
    pub fn process_window(
        &mut self,
        events: &[Event],
        attitude: &[AttitudeSample],
        window_end_us: i64,
        clock: &mut dyn StageClock,
    ) -> WindowReport<'_> {
        let mut timings = StageTimings::default();
        let mut t0 = clock.now_ns();
        let mut lap = |clock: &mut dyn StageClock| {
            let t = clock.now_ns();
            let dt = t.saturating_sub(t0);
            t0 = t;
            dt
        };

        self.fresh.clear();
        self.flow.process_window_within(
            events,
            self.config.flow.max_events_per_window,
            self.config.flow.max_fits_per_window,
            &mut self.fresh,
        );
        let flow_stats = self.flow.take_stats();
        timings.flow_ns = lap(clock);

        let derotation = self
            .derotator
            .derotate_all(&mut self.fresh, attitude, window_end_us);
        if derotation.state.usable() {
            self.history.extend_from_slice(&self.fresh);
        } else {
            // Rotating flow would poison the FOE for the whole history span.
            self.history.clear();
            self.recent_foe_px.clear();
        }
        self.trim_history(window_end_us);
        timings.derotate_ns = lap(clock);

        let seed = window_seed(self.config.seed, window_end_us);
        self.foe_input.clear();
        self.foe_input
            .extend(self.history.iter().filter(|v| v.tight));
        let raw_foe = self.estimator.as_dyn().estimate(&self.foe_input, seed);
        let foe = self.smooth(raw_foe);
        timings.foe_ns = lap(clock);

        self.compute_ttc(&foe, window_end_us);
        timings.ttc_ns = lap(clock);

        self.cluster(foe.point());
        timings.cluster_ns = lap(clock);

        let decision = self.confirm(decide(
            window_end_us,
            &self.config.decision,
            f64::from(self.config.camera.width_px),
            derotation.state.usable(),
            self.foe_input.len(),
            &foe,
            &self.clusters,
        ));
        timings.decide_ns = lap(clock);

        WindowReport {
            t_us: window_end_us,
            flow_stats,
            derotation,
            vectors: &self.history,
            foe,
            ttc_s: &self.ttc,
            labels: &self.labels,
            clusters: &self.clusters,
            decision,
            timings,
        }
    }

    /// Replaces a point FOE by the median of the recent ones.
    fn smooth(&mut self, foe: FoeEstimate) -> FoeEstimate {
        let FoeEstimate::Point {
            x_px,
            y_px,
            support,
        } = foe
        else {
            return foe;
        };
        let keep = self.config.foe_smoothing_windows.max(1);
        if self.recent_foe_px.len() >= keep {
            self.recent_foe_px.pop_front();
        }
        self.recent_foe_px.push_back((x_px, y_px));
        let scratch = &mut self.median_scratch;
        let mut median = |values: &mut dyn Iterator<Item = f64>| {
            scratch.clear();
            scratch.extend(values);
            scratch.sort_by(f64::total_cmp);
            let n = scratch.len();
            if n % 2 == 1 {
                scratch[n / 2]
            } else {
                0.5 * (scratch[n / 2 - 1] + scratch[n / 2])
            }
        };
        let x_px = median(&mut self.recent_foe_px.iter().map(|p| p.0));
        let y_px = median(&mut self.recent_foe_px.iter().map(|p| p.1));
        FoeEstimate::Point {
            x_px,
            y_px,
            support,
        }
    }

    /// Holds a roll back until `confirm_windows` of the last `confirm_span_windows`
    /// windows, this one included, have called for it.
    fn confirm(&mut self, mut decision: Decision) -> Decision {
        let calls = matches!(decision.reason, Reason::ObstacleAhead { .. });
        self.recent_calls = (self.recent_calls << 1) | u64::from(calls);
        let Reason::ObstacleAhead { ttc_s, .. } = decision.reason else {
            return decision;
        };
        let span = self.config.decision.confirm_span_windows.clamp(1, 64);
        let mask = u64::MAX >> (64 - span);
        let windows = (self.recent_calls & mask).count_ones();
        let needed = self.config.decision.confirm_windows;
        if windows < needed {
            decision.action = Action::Hold;
            decision.reason = Reason::Unconfirmed {
                ttc_s,
                windows,
                needed,
            };
        }
        decision
    }

    fn trim_history(&mut self, window_end_us: i64) {
        let oldest_us = window_end_us.saturating_sub(self.config.history_us);
        let stale = self.history.partition_point(|v| v.t_us < oldest_us);
        let over = (self.history.len() - stale).saturating_sub(self.config.max_vectors);
        self.history.drain(..stale + over);
    }

    /// Every history vector's TTC at the end of the window.
    fn compute_ttc(&mut self, foe: &FoeEstimate, window_end_us: i64) {
        self.ttc.clear();
        match foe.point() {
            Some(foe_px) => {
                self.ttc.extend(self.history.iter().map(|v| {
                    ttc_at_s(v, foe_px, window_end_us, &self.config.ttc).unwrap_or(f64::NAN)
                }))
            }
            None => self.ttc.resize(self.history.len(), f64::NAN),
        }
    }

    /// DBSCAN over the vectors with a TTC, and each cluster's statistics and own
    /// expansion (about the FOE's row; the clusters need a TTC, so an FOE point).
    fn cluster(&mut self, foe_px: Option<(f64, f64)>) {
        self.clustered.clear();
        self.xy_px.clear();
        self.ttc_clustered.clear();
        for (i, (v, &t)) in self.history.iter().zip(&self.ttc).enumerate() {
            if t.is_finite() {
                self.clustered.push(i);
                self.xy_px.push((v.x_px, v.y_px));
                self.ttc_clustered.push(t);
            }
        }
        let cam = &self.config.camera;
        cluster_features(
            &self.xy_px,
            &self.ttc_clustered,
            cam.width_px,
            cam.height_px,
            &mut self.features,
        );
        self.dbscan.run(&self.features, &mut self.cluster_labels);
        cluster_stats(
            &self.xy_px,
            &self.ttc_clustered,
            &self.cluster_labels,
            &mut self.clusters,
        );
        self.labels.clear();
        self.labels.resize(self.history.len(), None);
        for (k, &i) in self.clustered.iter().enumerate() {
            self.labels[i] = self.cluster_labels[k];
        }
        for c in &mut self.clusters {
            let inside = |v: &&FlowVector| {
                (c.min_x_px..=c.max_x_px).contains(&v.x_px)
                    && (c.min_y_px..=c.max_y_px).contains(&v.y_px)
            };
            c.expansion = foe_px
                .and_then(|(_, foe_y_px)| expansion(self.history.iter().filter(inside), foe_y_px));
        }
    }
}

/// Per-window seed: SplitMix64 of the configured seed and the window time.
pub fn window_seed(seed: u64, window_end_us: i64) -> u64 {
    let mut z = seed ^ (window_end_us as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}
