//! FOE methods on the same 1000 normal-flow vectors (the paper's "per 1000 vectors").
//!
//! `cargo bench --bench foe`. The paper reports FAITH at ~10 ms and the half-plane
//! probability map at ~370 ms per 1000 vectors (Table I).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use faithd_core::camera::CameraIntrinsics;
use faithd_core::foe::{
    Faith, FaithConfig, FoeEstimator, HalfPlaneMap, HalfPlaneMapConfig, Nesw, VecIntersections,
    VecIntersectionsConfig,
};
use faithd_core::synth::{FlowFieldSpec, radial_normal_flow};

fn thousand_vectors() -> Vec<faithd_core::flow::FlowVector> {
    let cam = CameraIntrinsics::dvs240();
    let spec = FlowFieldSpec {
        angle_noise_deg: 5.0,
        speed_noise_rel: 0.2,
        outlier_fraction: 0.1,
        ..FlowFieldSpec::clean((140.0, 80.0), 1000)
    };
    radial_normal_flow(&cam, &spec, 42)
}

fn bench_foe(c: &mut Criterion) {
    let cam = CameraIntrinsics::dvs240();
    let flow = thousand_vectors();
    let mut group = c.benchmark_group("foe_1000_vectors");
    let mut faith = Faith::new(cam, FaithConfig::default());
    group.bench_function("faith", |b| {
        b.iter(|| black_box(faith.estimate(black_box(&flow), 7)))
    });
    let mut faith_directions = Faith::new(cam, FaithConfig::directions_only());
    group.bench_function("faith_directions_only", |b| {
        b.iter(|| black_box(faith_directions.estimate(black_box(&flow), 7)))
    });
    let mut faith_paper = Faith::new(cam, FaithConfig::paper());
    group.bench_function("faith_paper_variant", |b| {
        b.iter(|| black_box(faith_paper.estimate(black_box(&flow), 7)))
    });
    let mut nesw = Nesw::new(cam);
    group.bench_function("nesw", |b| {
        b.iter(|| black_box(nesw.estimate(black_box(&flow), 7)))
    });
    let mut vi = VecIntersections::new(cam, VecIntersectionsConfig::default());
    group.bench_function("vec_intersections", |b| {
        b.iter(|| black_box(vi.estimate(black_box(&flow), 7)))
    });
    let mut map = HalfPlaneMap::new(cam, HalfPlaneMapConfig::default());
    group.sample_size(20);
    group.bench_function("half_planes", |b| {
        b.iter(|| black_box(map.estimate(black_box(&flow), 7)))
    });
    group.finish();
}

criterion_group!(benches, bench_foe);
criterion_main!(benches);
