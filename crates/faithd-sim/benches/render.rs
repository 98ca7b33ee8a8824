//! One `EventCamera::advance` (a 240x180 ray-cast render and its events) per scene.
//!
//! `cargo bench -p faithd-sim --bench render`. The closed loop and `bench foe` render
//! at 1 kHz, so a render's cost decides how many flights fit in an hour.
//!
//! Each scene is flown straight at 2 m/s from mid-room toward its far end (the arena's
//! pole, the kitchen's table, the shelves' end rack, the warehouse's pallets). Only the
//! renders are timed: every 100 renders the camera starts afresh at the flight's
//! start (its untimed warm-up render sets the reference image), so every timed render
//! sees the same stretch of flight, whatever number of iterations criterion picks.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use faithd_core::camera::{CameraIntrinsics, Mounting};
use faithd_sim::world::{DvsConfig, EventCamera, SceneKind, Trajectory};

/// Renders per fresh camera: 0.2 m of flight at 2 m/s and 1 kHz.
const RENDERS_PER_FLIGHT: u64 = 100;
const STEP_US: i64 = 1000;

fn bench_render(c: &mut Criterion) {
    let intrinsics = CameraIntrinsics::dvs240();
    let mut group = c.benchmark_group("render");
    group.sample_size(30);
    group.measurement_time(Duration::from_secs(10));
    for kind in SceneKind::ALL {
        let scene = kind.build(1);
        let flight = Trajectory::straight([-1.0, 0.1, -1.2], 0.0, 0.0, 2.0);
        group.bench_function(kind.name(), |b| {
            b.iter_custom(|iters| {
                let mut events = Vec::new();
                let mut elapsed = Duration::ZERO;
                let mut camera = None;
                for i in 0..iters {
                    let k = (i % RENDERS_PER_FLIGHT) as i64 + 1;
                    if k == 1 {
                        let mut fresh = EventCamera::new(
                            intrinsics,
                            Mounting::forward(),
                            DvsConfig::default(),
                            7,
                        );
                        fresh.advance(&scene, &flight.state(0.0), 0, &mut events);
                        camera = Some(fresh);
                    }
                    let camera = camera.as_mut().expect("set at k == 1");
                    let t_us = k * STEP_US;
                    let state = flight.state(t_us as f64 * 1e-6);
                    events.clear();
                    let started = Instant::now();
                    camera.advance(black_box(&scene), black_box(&state), t_us, &mut events);
                    elapsed += started.elapsed();
                    black_box(&events);
                }
                elapsed
            })
        });
    }
    // The bound an adaptive render rate is chosen from: a pass over the depth map.
    let scene = SceneKind::Arena.build(1);
    let flight = Trajectory::straight([-1.0, 0.1, -1.2], 0.0, 0.0, 2.0);
    let mut camera = EventCamera::new(intrinsics, Mounting::forward(), DvsConfig::default(), 7);
    let state = flight.state(0.05);
    camera.advance(&scene, &state, 0, &mut Vec::new());
    group.bench_function("speed_bound_arena", |b| {
        b.iter(|| black_box(camera.max_image_speed_px_s(black_box(&state))))
    });
    group.finish();
}

criterion_group!(benches, bench_render);
criterion_main!(benches);
