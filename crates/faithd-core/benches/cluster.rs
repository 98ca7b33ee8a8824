//! DBSCAN on feature vectors shaped like the pipeline's (x, y in 0..1, TTC z-score).
//!
//! `cargo bench --bench cluster`. Two inputs:
//! - `looming_pole`: the features of the busiest window of the pipeline itself, run on
//!   the generated approach to a pole in front of a wall (`synth::LoomingEdges`), with
//!   sensor noise: what DBSCAN sees in flight.
//! - `synthetic_N`: N points of a few dense groups at different TTC (a pole, a closer
//!   object, a far wall) over a sparse background, from a fixed generator, at the
//!   sizes the pipeline's `max_vectors` allows (3000 by default).

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use faithd_core::attitude::AttitudeSample;
use faithd_core::camera::CameraIntrinsics;
use faithd_core::cluster::{Dbscan, DbscanConfig, cluster_features};
use faithd_core::pipeline::{NoClock, Pipeline, PipelineConfig};
use faithd_core::synth::{LoomingEdges, looming_edge_events, pipeline_shaped_features};

const WINDOW_US: i64 = 10_000;

/// Features of the window with the most clustered vectors in a generated approach.
fn looming_pole_features() -> Vec<[f64; 3]> {
    let cam = CameraIntrinsics::dvs240();
    let mut scene = LoomingEdges::pole_ahead((130.0, 85.0));
    scene.noise_rate_hz = 0.5;
    scene.jitter_us = 50.0;
    let events = looming_edge_events(&cam, &scene, 1);
    let mut pipeline = Pipeline::new(PipelineConfig {
        camera: cam,
        ..PipelineConfig::default()
    });
    let end_us = events.last().map_or(0, |e| e.t_us);
    let mut best = Vec::new();
    let mut start = 0;
    let mut window_end_us = WINDOW_US;
    while window_end_us <= end_us {
        let stop = start + faithd_core::window::events_until(&events[start..], window_end_us);
        let attitude = [
            AttitudeSample {
                t_us: window_end_us - 2 * WINDOW_US,
                ..Default::default()
            },
            AttitudeSample {
                t_us: window_end_us + WINDOW_US,
                ..Default::default()
            },
        ];
        let report =
            pipeline.process_window(&events[start..stop], &attitude, window_end_us, &mut NoClock);
        let (xy_px, ttc_s): (Vec<_>, Vec<_>) = report
            .vectors
            .iter()
            .zip(report.ttc_s)
            .filter(|(_, t)| t.is_finite())
            .map(|(v, &t)| ((v.x_px, v.y_px), t))
            .unzip();
        if xy_px.len() > best.len() {
            cluster_features(&xy_px, &ttc_s, cam.width_px, cam.height_px, &mut best);
        }
        start = stop;
        window_end_us += WINDOW_US;
    }
    best
}

fn bench_dbscan(c: &mut Criterion) {
    let mut group = c.benchmark_group("dbscan");
    let mut dbscan = Dbscan::new(DbscanConfig::default());
    let mut labels = Vec::new();
    let pole = looming_pole_features();
    group.throughput(Throughput::Elements(pole.len() as u64));
    group.bench_function(BenchmarkId::new("looming_pole", pole.len()), |b| {
        b.iter(|| black_box(dbscan.run(black_box(&pole), &mut labels)))
    });
    for n in [1000, 3000, 6000] {
        let points = pipeline_shaped_features(n, 0x5eed);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(BenchmarkId::new("synthetic", n), |b| {
            b.iter(|| black_box(dbscan.run(black_box(&points), &mut labels)))
        });
    }
    group.finish();
}

criterion_group!(benches, bench_dbscan);
criterion_main!(benches);
