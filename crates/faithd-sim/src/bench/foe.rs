//! `faithd bench foe`: the paper's Table I on the built-in simulator.
//!
//! Every trajectory is simulated once; its events go through the normal flow and
//! derotation stages once; then all four FOE methods run on the very same flow
//! history at the same evaluation instants, so their errors and times compare like
//! with like. The error of a window is the angle between the viewing rays of the
//! estimated and the true FOE (the course error of the paper).

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::Serialize;

use crate::world::{AttitudeLink, DvsConfig, ImuConfig, SceneKind, Trajectory, simulate};
use faithd_core::camera::{CameraIntrinsics, CameraPreset};
use faithd_core::derotate::{DerotationConfig, Derotator};
use faithd_core::flow::{FlowConfig, FlowVector, NormalFlow};
use faithd_core::foe::{
    Faith, FaithConfig, FoeEstimate, FoeEstimator, HalfPlaneMap, HalfPlaneMapConfig, Nesw,
    VecIntersections, VecIntersectionsConfig,
};

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchFoeOptions {
    pub trajectories: usize,
    pub seed: u64,
    /// Length of each simulated flight, seconds.
    pub duration_s: f64,
    /// Flow history given to the FOE methods at each evaluation, microseconds.
    pub history_us: i64,
    /// Evaluations per trajectory, evenly spread after the first history span.
    pub windows: usize,
    /// Worker threads (trajectories run in parallel).
    pub threads: usize,
    /// Extra FAITH variants to compare (name, config), e.g. the paper's own.
    pub variants: Vec<(String, FaithConfig)>,
    /// Add body rotation (yaw and pitch oscillations) to every third flight, so
    /// derotation is exercised. The paper's benchmark flew without rotation.
    pub rotation: bool,
    /// The camera flown: the same flights and scenes whatever it is (every preset
    /// has the DVS240's field of view), rendered at its size.
    pub camera: CameraPreset,
    /// At most this many (newest) vectors of the history, as the pipeline's
    /// `max_vectors` (3000); `None` gives the methods the whole history.
    pub max_vectors: Option<usize>,
    /// The link the body rates come over before derotation: the simulator's gyro as
    /// it is (the default), or as iNav's MAVLink or MSP telemetry delivers it.
    pub attitude_link: AttitudeLink,
}

impl Default for BenchFoeOptions {
    fn default() -> Self {
        Self {
            trajectories: 100,
            seed: 1,
            duration_s: 0.45,
            history_us: 50_000,
            windows: 4,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            variants: vec![
                (
                    "faith_directions".to_string(),
                    FaithConfig::directions_only(),
                ),
                ("faith_paper".to_string(), FaithConfig::paper()),
            ],
            rotation: false,
            camera: CameraPreset::Davis240,
            max_vectors: None,
            attitude_link: AttitudeLink::Imu,
        }
    }
}

/// One row of the table.
#[derive(Clone, Debug, Serialize)]
pub struct MethodResult {
    pub name: String,
    /// Mean over trajectories of each trajectory's mean course error, degrees.
    pub mean_error_deg: f64,
    /// Standard deviation of the per-trajectory mean errors, degrees.
    pub std_error_deg: f64,
    /// Median of the per-trajectory mean errors, degrees.
    pub median_error_deg: f64,
    /// Mean and median of the per-trajectory mean errors over the rotating flights
    /// alone, degrees (`None` when no flight rotates).
    pub rotating_mean_error_deg: Option<f64>,
    pub rotating_median_error_deg: Option<f64>,
    /// Median compute time per 1000 flow vectors, microseconds.
    pub us_per_1000_vectors: f64,
    pub us_per_1000_vectors_p10: f64,
    pub us_per_1000_vectors_p90: f64,
    /// Windows where the method gave no point (unbounded or insufficient); they count
    /// as 90 degrees of error.
    pub failed_windows: usize,
}

/// One simulated flight and its per-method mean errors.
#[derive(Clone, Debug, Serialize)]
pub struct TrajectoryResult {
    pub index: usize,
    pub scene: SceneKind,
    pub sway: bool,
    pub rotating: bool,
    pub course_deg: f64,
    pub events: usize,
    pub mean_vectors: f64,
    /// Mean error per method, in the order of the report's `methods`.
    pub mean_error_deg: Vec<f64>,
}

/// The whole run; `trajectories`, `seed` and `methods` are the published JSON keys.
#[derive(Clone, Debug, Serialize)]
pub struct BenchFoeReport {
    pub trajectories: usize,
    pub seed: u64,
    pub camera: CameraPreset,
    pub width_px: u16,
    pub height_px: u16,
    pub max_vectors: Option<usize>,
    /// The link derotation's body rates came over.
    pub attitude_link: AttitudeLink,
    /// Flights flown with body rotation (`rotation`), evaluated or not.
    pub rotating_trajectories: usize,
    pub methods: Vec<MethodResult>,
    pub windows: usize,
    pub per_trajectory: Vec<TrajectoryResult>,
    /// The last window of the first flight, for the example figure.
    #[serde(skip)]
    pub example: Option<ExampleFrame>,
}

/// Everything needed to draw one evaluation window.
#[derive(Clone, Debug)]
pub struct ExampleFrame {
    pub scene: &'static str,
    pub course_deg: f64,
    pub t_us: i64,
    pub width_px: u16,
    pub height_px: u16,
    pub events: Vec<faithd_core::event::Event>,
    pub vectors: Vec<FlowVector>,
    pub truth_px: (f64, f64),
    pub estimates: Vec<(String, FoeEstimate)>,
}

/// A planned flight: which scene and how it flies.
#[derive(Clone, Copy, Debug)]
pub struct PlannedFlight {
    pub scene: SceneKind,
    pub trajectory: Trajectory,
    pub sway: bool,
    pub rotating: bool,
}

/// The flights of a run: scenes in turn, courses spread over -30..30 degrees, every
/// other flight swaying (its FOE moves), and with `rotation` every third one rotating.
pub fn plan_flights(n: usize, seed: u64, rotation: bool) -> Vec<PlannedFlight> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x7ab1e1);
    (0..n)
        .map(|i| {
            let scene = SceneKind::ALL[i % SceneKind::ALL.len()];
            let slot = (i as f64 + rng.random_range(0.0..1.0)) / n.max(1) as f64;
            let course_deg = -30.0 + 60.0 * slot;
            let heading_deg = rng.random_range(-10.0..10.0);
            let start = [
                -4.0,
                rng.random_range(-0.5..0.5),
                rng.random_range(-1.4..-1.0),
            ];
            let mut t =
                Trajectory::straight(start, heading_deg, course_deg, rng.random_range(1.0..2.5));
            let sway = (i / SceneKind::ALL.len()) % 2 == 1;
            if sway {
                t.sway_m_s = rng.random_range(0.3..0.8);
                t.sway_hz = rng.random_range(0.8..1.5);
            }
            // Drawn even when unused, so a flight is the same with or without rotation.
            let (yaw_amp, yaw_hz) = (rng.random_range(1.0..4.0), rng.random_range(0.5..1.0));
            let (pitch_amp, pitch_hz) = (rng.random_range(0.5..2.0), rng.random_range(0.5..1.0));
            let rotating = rotation && i % 3 == 2;
            if rotating {
                t.yaw_amp_deg = yaw_amp;
                t.yaw_hz = yaw_hz;
                t.pitch_amp_deg = pitch_amp;
                t.pitch_hz = pitch_hz;
            }
            PlannedFlight {
                scene,
                trajectory: t,
                sway,
                rotating,
            }
        })
        .collect()
}

/// One flight's summary, its evaluated windows and its last window for a figure.
type FlightOutcome = (TrajectoryResult, Vec<WindowSample>, Option<ExampleFrame>);

struct WindowSample {
    errors_deg: Vec<f64>,
    us_per_1000: Vec<f64>,
    failed: Vec<bool>,
    vectors: usize,
}

/// The estimators of one run, in report order.
fn estimators(
    camera: CameraIntrinsics,
    options: &BenchFoeOptions,
) -> Vec<(String, Box<dyn FoeEstimator>)> {
    let mut v: Vec<(String, Box<dyn FoeEstimator>)> = vec![
        (
            "faith".into(),
            Box::new(Faith::new(camera, FaithConfig::default())),
        ),
        (
            "half_planes".into(),
            Box::new(HalfPlaneMap::new(camera, HalfPlaneMapConfig::default())),
        ),
        ("nesw".into(), Box::new(Nesw::new(camera))),
        (
            "vec_intersections".into(),
            Box::new(VecIntersections::new(
                camera,
                VecIntersectionsConfig::default(),
            )),
        ),
    ];
    for (name, config) in &options.variants {
        v.push((name.clone(), Box::new(Faith::new(camera, *config))));
    }
    v
}

/// Angle between estimate and truth; an unbounded estimate points 89+ degrees out.
fn error_deg(camera: &CameraIntrinsics, estimate: &FoeEstimate, truth: (f64, f64)) -> Option<f64> {
    match *estimate {
        FoeEstimate::Point { x_px, y_px, .. } => {
            Some(camera.angle_between_deg((x_px, y_px), truth))
        }
        _ => None,
    }
}

fn run_flight(
    index: usize,
    flight: &PlannedFlight,
    options: &BenchFoeOptions,
    methods: &mut [(String, Box<dyn FoeEstimator>)],
) -> FlightOutcome {
    let camera = options.camera.intrinsics();
    let flight_seed = faithd_core::pipeline::window_seed(options.seed, index as i64);
    let scene = flight.scene.build(flight_seed);
    let run = simulate(
        &scene,
        &flight.trajectory,
        camera,
        DvsConfig::default(),
        ImuConfig::default(),
        options.duration_s,
        flight_seed,
    );
    let mut flow = NormalFlow::new(&camera, FlowConfig::default());
    let mut vectors: Vec<FlowVector> = Vec::new();
    flow.process(&run.events, &mut vectors);
    let attitude = options.attitude_link.deliver(&run.attitude);
    let last_vector_us = vectors.iter().map(|v| v.t_us).max().unwrap_or(0);
    Derotator::new(camera, DerotationConfig::default()).derotate_all(
        &mut vectors,
        &attitude,
        last_vector_us,
    );

    let end_us = (options.duration_s * 1e6) as i64;
    let first_us = options.history_us * 2;
    let step_us = (end_us - first_us) / options.windows.max(1) as i64;
    let mut samples = Vec::new();
    let mut example = None;
    for w in 0..options.windows {
        let t_us = first_us + step_us * (w as i64 + 1);
        let window = &foe_input(&vectors, t_us, options)[..];
        let Some(truth) = run.truth_at(t_us - options.history_us / 2) else {
            continue;
        };
        if window.len() < 50 || !camera.contains(truth.0, truth.1) {
            continue;
        }
        let mut sample = WindowSample {
            errors_deg: Vec::new(),
            us_per_1000: Vec::new(),
            failed: Vec::new(),
            vectors: window.len(),
        };
        let mut estimates = Vec::new();
        for (name, method) in methods.iter_mut() {
            let seed = faithd_core::pipeline::window_seed(flight_seed, t_us);
            let started = Instant::now();
            let estimate = method.estimate(window, seed);
            let us = started.elapsed().as_secs_f64() * 1e6;
            let err = error_deg(&camera, &estimate, truth);
            estimates.push((name.clone(), estimate));
            sample.failed.push(err.is_none());
            sample.errors_deg.push(err.unwrap_or(90.0));
            sample.us_per_1000.push(us * 1000.0 / window.len() as f64);
        }
        samples.push(sample);
        let lo_ev = run
            .events
            .partition_point(|e| e.t_us < t_us - options.history_us);
        let hi_ev = run.events.partition_point(|e| e.t_us < t_us);
        example = Some(ExampleFrame {
            scene: flight.scene.name(),
            course_deg: flight.trajectory.course_deg,
            t_us,
            width_px: camera.width_px,
            height_px: camera.height_px,
            events: run.events[lo_ev..hi_ev].to_vec(),
            vectors: window.to_vec(),
            truth_px: truth,
            estimates,
        });
    }
    let n_methods = methods.len();
    let mean_error_deg = (0..n_methods)
        .map(|m| mean(samples.iter().map(|s| s.errors_deg[m])))
        .collect();
    let result = TrajectoryResult {
        index,
        scene: flight.scene,
        sway: flight.sway,
        rotating: flight.rotating,
        course_deg: flight.trajectory.course_deg,
        events: run.events.len(),
        mean_vectors: mean(samples.iter().map(|s| s.vectors as f64)),
        mean_error_deg,
    };
    (result, samples, example)
}

/// What the pipeline gives its FOE estimator at `t_us`: the tight vectors of the
/// history (of its newest `max_vectors` with a cap).
fn foe_input(vectors: &[FlowVector], t_us: i64, options: &BenchFoeOptions) -> Vec<FlowVector> {
    let mut lo = vectors.partition_point(|v| v.t_us < t_us - options.history_us);
    let hi = vectors.partition_point(|v| v.t_us < t_us);
    if let Some(cap) = options.max_vectors {
        lo = lo.max(hi.saturating_sub(cap));
    }
    vectors[lo..hi]
        .iter()
        .filter(|v| v.tight)
        .copied()
        .collect()
}

fn mean(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 { f64::NAN } else { sum / n as f64 }
}

/// The median of `values` (the mean of the middle two of an even count).
fn median(values: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.collect();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i]
}

/// Runs the benchmark; `progress` is told of each finished trajectory.
pub fn run(
    options: &BenchFoeOptions,
    progress: &(dyn Fn(usize, &TrajectoryResult) + Sync),
) -> BenchFoeReport {
    let camera = options.camera.intrinsics();
    let flights = plan_flights(options.trajectories, options.seed, options.rotation);
    let names: Vec<String> = estimators(camera, options)
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<FlightOutcome>>> =
        Mutex::new((0..flights.len()).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..options.threads.max(1) {
            scope.spawn(|| {
                let mut methods = estimators(camera, options);
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= flights.len() {
                        break;
                    }
                    let out = run_flight(i, &flights[i], options, &mut methods);
                    let finished = done.fetch_add(1, Ordering::Relaxed) + 1;
                    progress(finished, &out.0);
                    results.lock().expect("no panics while holding the lock")[i] = Some(out);
                }
            });
        }
    });
    let results: Vec<_> = results
        .into_inner()
        .expect("workers finished")
        .into_iter()
        .flatten()
        .collect();

    let methods = names
        .iter()
        .enumerate()
        .map(|(m, name)| {
            let per_traj: Vec<f64> = results
                .iter()
                .map(|(t, _, _)| t.mean_error_deg[m])
                .filter(|e| e.is_finite())
                .collect();
            let mu = mean(per_traj.iter().copied());
            let var = mean(per_traj.iter().map(|e| (e - mu) * (e - mu)));
            let rotating: Vec<f64> = results
                .iter()
                .filter(|(t, _, _)| t.rotating)
                .map(|(t, _, _)| t.mean_error_deg[m])
                .filter(|e| e.is_finite())
                .collect();
            let any_rotating = !rotating.is_empty();
            let mut times: Vec<f64> = results
                .iter()
                .flat_map(|(_, s, _)| s.iter().map(move |w| w.us_per_1000[m]))
                .collect();
            times.sort_by(f64::total_cmp);
            let failed_windows = results
                .iter()
                .flat_map(|(_, s, _)| s.iter().filter(move |w| w.failed[m]))
                .count();
            MethodResult {
                name: name.clone(),
                mean_error_deg: mu,
                std_error_deg: var.sqrt(),
                median_error_deg: median(per_traj.iter().copied()),
                rotating_mean_error_deg: any_rotating.then(|| mean(rotating.iter().copied())),
                rotating_median_error_deg: any_rotating.then(|| median(rotating.iter().copied())),
                us_per_1000_vectors: percentile(&times, 0.5),
                us_per_1000_vectors_p10: percentile(&times, 0.1),
                us_per_1000_vectors_p90: percentile(&times, 0.9),
                failed_windows,
            }
        })
        .collect();
    let windows = results.iter().map(|(_, s, _)| s.len()).sum();
    let rotating_trajectories = flights.iter().filter(|f| f.rotating).count();
    let example = results.iter().find_map(|(_, _, e)| e.clone());
    BenchFoeReport {
        trajectories: options.trajectories,
        seed: options.seed,
        camera: options.camera,
        width_px: camera.width_px,
        height_px: camera.height_px,
        max_vectors: options.max_vectors,
        attitude_link: options.attitude_link,
        rotating_trajectories,
        methods,
        windows,
        per_trajectory: results.into_iter().map(|(t, _, _)| t).collect(),
        example,
    }
}

impl BenchFoeReport {
    /// The Table-I-like text table.
    pub fn table(&self) -> String {
        let mut s = format!(
            "FOE benchmark: {} trajectories, {} windows, seed {}, {} ({} x {} px)\n",
            self.trajectories, self.windows, self.seed, self.camera, self.width_px, self.height_px
        );
        s += &format!(
            "body rates over {} ({}); {} rotating flights\n",
            self.attitude_link,
            self.attitude_link.describe(),
            self.rotating_trajectories
        );
        s += &format!(
            "{:<20} {:>22} {:>30} {:>7}\n",
            "method", "course error (deg)", "us per 1000 vectors (p10-p90)", "failed"
        );
        for m in &self.methods {
            s += &format!(
                "{:<20} {:>12.2} +- {:<6.2} {:>12.1} ({:.1}-{:.1}) {:>7}\n",
                m.name,
                m.mean_error_deg,
                m.std_error_deg,
                m.us_per_1000_vectors,
                m.us_per_1000_vectors_p10,
                m.us_per_1000_vectors_p90,
                m.failed_windows
            );
        }
        s += &format!(
            "{:<20} {:>12} {:>24}\n",
            "method", "median (deg)", "rotating: mean / median"
        );
        for m in &self.methods {
            let rotating = match (m.rotating_mean_error_deg, m.rotating_median_error_deg) {
                (Some(mean), Some(median)) => format!("{mean:.2} / {median:.2}"),
                _ => "-".to_string(),
            };
            s += &format!(
                "{:<20} {:>12.2} {:>24}\n",
                m.name, m.median_error_deg, rotating
            );
        }
        s
    }
}
