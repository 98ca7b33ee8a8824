//! `faithd demo`: the pipeline on a generated approach to a pole, with a summary.
//!
//! Until the closed-loop simulator and the MAVLink side exist, the demo flies open
//! loop: a vehicle heading at a pole in front of a wall, events from the looming-edges
//! generator, every window through the real pipeline, and the first roll decision
//! reported against the known truth.

use serde::Serialize;

use faithd_core::attitude::AttitudeSample;
use faithd_core::camera::CameraIntrinsics;
use faithd_core::decide::{Action, Decision};
use faithd_core::pipeline::{Pipeline, PipelineConfig, StageClock};
use faithd_core::synth::{LoomingEdges, looming_edge_events};

/// What a person wants to know after the demo flight.
#[derive(Clone, Debug, Serialize)]
pub struct DemoSummary {
    pub events: usize,
    pub windows: usize,
    pub true_foe_px: (f64, f64),
    pub pole_ttc_at_start_s: f64,
    /// The first roll command, if any.
    pub first_roll: Option<Decision>,
    /// True TTC of the pole when the roll was decided, seconds.
    pub true_ttc_at_roll_s: Option<f64>,
    /// Distance between estimated and true FOE at the roll, pixels.
    pub foe_error_px_at_roll: Option<f64>,
    pub mean_window_us: f64,
    pub max_window_us: f64,
    /// Mean time per stage: flow, derotation, FOE, TTC, clustering, decision (us).
    pub mean_stage_us: [f64; 6],
}

/// Runs the demo flight; `clock` times the pipeline (the CLI passes a real clock).
pub fn run(seed: u64, window_us: i64, clock: &mut dyn StageClock) -> DemoSummary {
    let cam = CameraIntrinsics::dvs240();
    let foe = (128.0, 86.0);
    let mut scene = LoomingEdges::pole_ahead(foe);
    scene.duration_s = 0.8;
    scene.noise_rate_hz = 0.5;
    scene.jitter_us = 100.0;
    let pole_ttc_s = scene.layers[0].tau0_s;
    let events = looming_edge_events(&cam, &scene, seed);
    let attitude: Vec<_> = (0..=100)
        .map(|i| AttitudeSample {
            t_us: i * 10_000,
            ..Default::default()
        })
        .collect();
    let mut pipeline = Pipeline::new(PipelineConfig {
        seed,
        ..Default::default()
    });
    let mut summary = DemoSummary {
        events: events.len(),
        windows: 0,
        true_foe_px: foe,
        pole_ttc_at_start_s: pole_ttc_s,
        first_roll: None,
        true_ttc_at_roll_s: None,
        foe_error_px_at_roll: None,
        mean_window_us: 0.0,
        max_window_us: 0.0,
        mean_stage_us: [0.0; 6],
    };
    let mut total_ns = 0u64;
    let mut start = 0;
    let mut window_end_us = window_us;
    let last_us = events.last().map_or(0, |e| e.t_us);
    while window_end_us <= last_us + window_us {
        let stop = start + faithd_core::window::events_until(&events[start..], window_end_us);
        let report = pipeline.process_window(&events[start..stop], &attitude, window_end_us, clock);
        start = stop;
        summary.windows += 1;
        let t = report.timings;
        for (acc, ns) in summary.mean_stage_us.iter_mut().zip([
            t.flow_ns,
            t.derotate_ns,
            t.foe_ns,
            t.ttc_ns,
            t.cluster_ns,
            t.decide_ns,
        ]) {
            *acc += ns as f64 / 1e3;
        }
        let ns = t.total_ns();
        total_ns += ns;
        summary.max_window_us = summary.max_window_us.max(ns as f64 / 1e3);
        let d = report.decision;
        tracing::debug!(t_us = d.t_us, "{d}");
        if summary.first_roll.is_none() && matches!(d.action, Action::Roll { .. }) {
            summary.true_ttc_at_roll_s = Some(pole_ttc_s - d.t_us as f64 * 1e-6);
            summary.foe_error_px_at_roll = d.foe_px.map(|(x, y)| (x - foe.0).hypot(y - foe.1));
            summary.first_roll = Some(d);
        }
        window_end_us += window_us;
    }
    let windows = summary.windows.max(1) as f64;
    summary.mean_window_us = total_ns as f64 / 1e3 / windows;
    for v in &mut summary.mean_stage_us {
        *v /= windows;
    }
    summary
}
