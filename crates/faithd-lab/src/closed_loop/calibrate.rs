//! `faithd bench compute`: fits the model a simulated flight charges its pipeline
//! cycles from (`cycle::compute`) to this machine.
//!
//! The experiment's flights are flown straight (no daemon, no roll) on the chosen
//! camera; every window runs through the pipeline with its stages timed on the wall
//! clock, and each stage's time is fitted on its own counts. Run it on a quiet
//! machine: what else runs shows up as noise in the timings.

use serde::Serialize;

use super::FlightSpec;
use super::camera::FlightCamera;
use super::physics::{STEP_US, initial_quad};
use crate::cycle::compute::{self, ComputeModel, Stage, TERMS};
use faithd_core::pipeline::{Pipeline, PipelineConfig, StageTimings};
use faithd_daemon::clock::WallStageClock;
use faithd_daemon::cycle::Work;

/// Decision period, as the daemon runs it.
const WINDOW_US: i64 = 10_000;
/// Autopilot ATTITUDE period.
const ATTITUDE_US: i64 = 40_000;

/// Every window of `spec` flown straight to 1 m past its first pole: its counts and
/// its stages' measured times. Windows take the load-shedding levels 0 to 3 in turn
/// (halved fits, vectors and iterations, as `cycle::shed` sets them), so that each
/// cost is seen apart from the others: at full load FAITH's iterations never change,
/// and its per-vector cost could not be told from its per-iteration one.
pub fn measure(spec: &FlightSpec, config: &PipelineConfig) -> Vec<(Work, StageTimings)> {
    let mut quad = initial_quad(spec);
    let mut camera = FlightCamera::new(spec);
    let mut pipeline = Pipeline::new(*config);
    let mut clock = WallStageClock::new();
    let (mut pending, mut attitude) = (Vec::new(), Vec::new());
    let mut t_us: i64 = 1_000_000;
    camera.step(&quad.state(), t_us, &mut pending);
    pending.clear();
    let mut samples = Vec::new();
    while quad.position_m.x < spec.end_x_m() {
        t_us += STEP_US;
        quad.step(0.0, STEP_US as f64 * 1e-6);
        let state = quad.state();
        camera.step(&state, t_us, &mut pending);
        if t_us % ATTITUDE_US == 0 {
            attitude.push(state.attitude_sample(t_us));
        }
        if t_us % WINDOW_US != 0 {
            continue;
        }
        let level = (samples.len() % 4) as u32;
        let iterations = (config.faith.iterations >> level).max(1);
        pipeline.set_foe_iterations(iterations);
        pipeline.set_max_vectors(config.max_vectors >> level);
        pipeline.set_max_fits(config.flow.max_fits_per_window >> level);
        let take = faithd_core::window::events_until(&pending, t_us);
        let report = pipeline.process_window(&pending[..take], &attitude, t_us, &mut clock);
        samples.push((Work::of(&report, take, iterations), report.timings));
        pending.drain(..take);
    }
    samples
}

/// How well a model predicts measured windows.
#[derive(Clone, Debug, Serialize)]
pub struct FitReport {
    pub windows: usize,
    pub model: ComputeModel,
    /// Per term: its name and cost, nanoseconds.
    pub terms: Vec<(&'static str, f64)>,
    /// Measured and modelled mean window time, microseconds.
    pub measured_mean_us: f64,
    pub modelled_mean_us: f64,
    /// Per window |modelled - measured| / measured: median and 90th percentile.
    pub relative_error_p50: f64,
    pub relative_error_p90: f64,
    /// Per stage: measured and modelled mean, microseconds.
    pub stages: Vec<(Stage, f64, f64)>,
}

/// Judges `model` on `samples`.
pub fn judge(model: &ComputeModel, samples: &[(Work, StageTimings)]) -> FitReport {
    let n = samples.len().max(1) as f64;
    let mut errors: Vec<f64> = samples
        .iter()
        .filter(|(_, t)| t.total_ns() > 0)
        .map(|(w, t)| (model.cost_ns(w) - t.total_ns() as f64).abs() / t.total_ns() as f64)
        .collect();
    errors.sort_by(f64::total_cmp);
    let stages = Stage::ALL
        .iter()
        .map(|&s| {
            let measured = samples
                .iter()
                .map(|(_, t)| s.measured_ns(t) as f64)
                .sum::<f64>();
            let modelled = samples
                .iter()
                .map(|(w, _)| model.stage_ns(s, w))
                .sum::<f64>();
            (s, measured / n / 1e3, modelled / n / 1e3)
        })
        .collect();
    FitReport {
        windows: samples.len(),
        model: *model,
        terms: TERMS
            .iter()
            .zip(model.ns)
            .map(|((name, _), c)| (*name, c))
            .collect(),
        measured_mean_us: samples
            .iter()
            .map(|(_, t)| t.total_ns() as f64)
            .sum::<f64>()
            / n
            / 1e3,
        modelled_mean_us: samples.iter().map(|(w, _)| model.cost_ns(w)).sum::<f64>() / n / 1e3,
        relative_error_p50: super::experiment::percentile(&errors, 0.5),
        relative_error_p90: super::experiment::percentile(&errors, 0.9),
        stages,
    }
}

/// Fits the model to `samples` and judges it on them.
pub fn fit(samples: &[(Work, StageTimings)]) -> FitReport {
    judge(&compute::fit(samples), samples)
}
