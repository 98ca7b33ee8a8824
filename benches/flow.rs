//! Normal flow throughput on a generated looming scene: events per second per core.
//!
//! `cargo bench --bench flow`; criterion prints the throughput in elements (events)/s.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use faithd_core::camera::CameraIntrinsics;
use faithd_core::flow::{FlowConfig, NormalFlow};
use faithd_core::synth::{LoomingEdges, looming_edge_events};

fn bench_flow(c: &mut Criterion) {
    let cam = CameraIntrinsics::dvs240();
    let mut scene = LoomingEdges::pole_ahead((130.0, 85.0));
    scene.noise_rate_hz = 0.5;
    scene.jitter_us = 50.0;
    let events = looming_edge_events(&cam, &scene, 1);
    let mut group = c.benchmark_group("normal_flow");
    group.throughput(Throughput::Elements(events.len() as u64));
    let mut out = Vec::with_capacity(events.len());
    group.bench_function("looming_pole_scene", |b| {
        b.iter(|| {
            let mut flow = NormalFlow::new(&cam, FlowConfig::default());
            out.clear();
            flow.process(black_box(&events), &mut out);
            black_box(out.len())
        })
    });
    group.finish();
}

criterion_group!(benches, bench_flow);
criterion_main!(benches);
