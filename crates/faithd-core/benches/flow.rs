//! Normal flow throughput on generated looming scenes: events per second.
//!
//! `cargo bench --bench flow`; criterion prints the throughput in elements (events)/s.
//! `looming_pole_scene` is the pole of `tests/pipeline.rs` with noise (67k events in
//! 0.5 s); `dense_pole_scene` is the same flight past five times the edges (290k
//! events), where the surface is busier and more neighbourhoods hold enough points
//! for a fit. Both run on one thread and, as `..._2_threads`, on two (one window of the
//! whole stream, above `parallel_min_events`). `peak_windows` feeds the dense scene
//! as the daemon would at a DVS240's peak rate of 12 million events per second: 10 ms
//! windows of 120k events, at most 2000 fits each (the default cap), so that mostly
//! surface updates are measured.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use faithd_core::camera::CameraIntrinsics;
use faithd_core::event::Event;
use faithd_core::flow::{FlowConfig, NormalFlow};
use faithd_core::synth::{LoomingEdges, looming_edge_events};

fn scene(edges_factor: usize) -> Vec<Event> {
    let cam = CameraIntrinsics::dvs240();
    let mut scene = LoomingEdges::pole_ahead((130.0, 85.0));
    scene.noise_rate_hz = 0.5;
    scene.jitter_us = 50.0;
    for layer in &mut scene.layers {
        layer.edges *= edges_factor;
    }
    looming_edge_events(&cam, &scene, 1)
}

/// Events per window at 12 million events per second and 100 windows per second.
const PEAK_WINDOW_EVENTS: usize = 120_000;

fn bench_flow(c: &mut Criterion) {
    let cam = CameraIntrinsics::dvs240();
    let config = FlowConfig::default();
    let mut group = c.benchmark_group("normal_flow");
    let looming = scene(1);
    let dense = scene(5);
    for (name, events, threads, window) in [
        ("looming_pole_scene", &looming, 1, None),
        ("dense_pole_scene", &dense, 1, None),
        ("looming_pole_scene_2_threads", &looming, 2, None),
        ("dense_pole_scene_2_threads", &dense, 2, None),
        ("peak_windows", &dense, 1, Some(PEAK_WINDOW_EVENTS)),
        (
            "peak_windows_2_threads",
            &dense,
            2,
            Some(PEAK_WINDOW_EVENTS),
        ),
    ] {
        group.throughput(Throughput::Elements(events.len() as u64));
        let mut out = Vec::with_capacity(events.len());
        // One flow for all runs, reset between them outside the timing, as the daemon
        // keeps its flow: a fresh one would time the growth of the tiles' buffers
        // and, on two tiles, 1.4 MB of surfaces to get from the system (0.3 ms). The
        // `before` baseline made a flow inside each run (then 6 us, 0.04 % of it).
        let mut flow = NormalFlow::with_threads(&cam, config, threads);
        group.bench_function(name, |b| {
            b.iter_custom(|runs| {
                let mut total = Duration::ZERO;
                for _ in 0..runs {
                    flow.reset();
                    out.clear();
                    let start = Instant::now();
                    match window {
                        None => flow.process(black_box(events), &mut out),
                        Some(size) => {
                            for w in events.chunks(size) {
                                flow.process_window(
                                    black_box(w),
                                    config.max_fits_per_window,
                                    &mut out,
                                );
                            }
                        }
                    }
                    black_box(out.len());
                    total += start.elapsed();
                }
                total
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_flow);
criterion_main!(benches);
