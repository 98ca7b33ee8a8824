//! Normal flow throughput on generated looming scenes: events per second.
//!
//! `cargo bench --bench flow`; criterion prints the throughput in elements (events)/s.
//! `looming_pole_scene` is the pole of `tests/pipeline.rs` with noise (67k events in
//! 0.5 s); `dense_pole_scene` is the same flight past five times the edges (about 5
//! times the events in the same time, a DVS240 near its peak rate), where the
//! surface is busier and more neighbourhoods hold enough points for a fit.

use std::hint::black_box;

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

fn bench_flow(c: &mut Criterion) {
    let cam = CameraIntrinsics::dvs240();
    let mut group = c.benchmark_group("normal_flow");
    for (name, edges_factor) in [("looming_pole_scene", 1), ("dense_pole_scene", 5)] {
        let events = scene(edges_factor);
        group.throughput(Throughput::Elements(events.len() as u64));
        let mut out = Vec::with_capacity(events.len());
        group.bench_function(name, |b| {
            b.iter(|| {
                let mut flow = NormalFlow::new(&cam, FlowConfig::default());
                out.clear();
                flow.process(black_box(&events), &mut out);
                black_box(out.len())
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_flow);
criterion_main!(benches);
