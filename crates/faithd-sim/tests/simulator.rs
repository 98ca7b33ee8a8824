//! The event-camera simulator against closed-form expectations.

use faithd_core::camera::{CameraIntrinsics, Mounting};
use faithd_core::event::Polarity;
use faithd_sim::world::scene::{Scene, Shape, Solid};
use faithd_sim::world::texture::{Pattern, Texture};
use faithd_sim::world::{DvsConfig, EventCamera, ImuConfig, Trajectory, simulate};
use nalgebra::Vector3;

fn flat(reflectance: f64) -> Texture {
    Texture::new(Pattern::Noise, 1.0, 0.0, reflectance, 0)
}

/// A wall 3 m ahead: dark left half, bright right half, with the step at y = 0.
fn step_wall() -> Scene {
    Scene::new(
        "step",
        vec![
            Solid {
                shape: Shape::Block {
                    min: Vector3::new(3.0, -50.0, -50.0),
                    max: Vector3::new(3.1, 0.0, 50.0),
                },
                texture: flat(0.2),
            },
            Solid {
                shape: Shape::Block {
                    min: Vector3::new(3.0, 0.0, -50.0),
                    max: Vector3::new(3.1, 50.0, 50.0),
                },
                texture: flat(0.8),
            },
        ],
    )
}

fn ideal_sensor() -> DvsConfig {
    DvsConfig {
        contrast_threshold: 0.2,
        threshold_mismatch: 0.0,
        refractory_us: 0,
        noise_rate_hz: 0.0,
        jitter_us: 0.0,
        render_rate_hz: 1000.0,
    }
}

#[test]
fn a_moving_edge_fires_along_the_edge_with_the_expected_count_and_sign() {
    let cam = CameraIntrinsics::dvs240();
    // Sliding right at 0.5 m/s past the wall: the edge moves left at f * V / Z px/s.
    let trajectory = Trajectory::straight([0.0, -0.6, -1.2], 0.0, 90.0, 0.5);
    let duration_s = 0.4;
    let run = simulate(
        &step_wall(),
        &trajectory,
        cam,
        ideal_sensor(),
        ImuConfig::default(),
        duration_s,
        1,
    );
    let speed_px_s = cam.fx_px * 0.5 / 3.0;
    assert!(!run.events.is_empty());
    // Bright moves in from the right: only ON events, ln(0.8 / 0.2) / 0.2 = 6.9 -> 6 per pixel.
    assert!(run.events.iter().all(|e| e.polarity == Polarity::On));
    let mut per_pixel = std::collections::HashMap::new();
    for e in &run.events {
        *per_pixel.entry((e.x_px, e.y_px)).or_insert(0) += 1;
    }
    let sixes = per_pixel.values().filter(|&&n| n == 6).count();
    assert!(
        sixes * 100 >= per_pixel.len() * 95,
        "{sixes} of {} pixels fired 6 times",
        per_pixel.len()
    );
    // Every event sits on the edge's predicted column at its time (within 1.5 px).
    let x_at = |t_us: i64| {
        let y_cam = -0.6 + 0.5 * t_us as f64 * 1e-6;
        cam.cx_px + cam.fx_px * (0.0 - y_cam) / 3.0
    };
    for e in &run.events {
        let dx = f64::from(e.x_px) - x_at(e.t_us);
        assert!(
            dx.abs() < 1.5,
            "event at x {} t {} us, edge at {:.1}",
            e.x_px,
            e.t_us,
            x_at(e.t_us)
        );
    }
    // And the edge advances at the predicted speed: columns crossed in the run.
    let rows = usize::from(cam.height_px);
    let columns_crossed = per_pixel.len() as f64 / rows as f64;
    let expected = speed_px_s * duration_s;
    assert!(
        (columns_crossed - expected).abs() < 1.5,
        "{columns_crossed} vs {expected}"
    );
}

#[test]
fn events_are_time_ordered_and_a_static_camera_sees_only_noise() {
    let cam = CameraIntrinsics::dvs240();
    let still = Trajectory::straight([0.0, -0.6, -1.2], 0.0, 0.0, 0.0);
    let noisy = DvsConfig {
        noise_rate_hz: 1.0,
        ..ideal_sensor()
    };
    let run = simulate(
        &step_wall(),
        &still,
        cam,
        noisy,
        ImuConfig::default(),
        0.5,
        2,
    );
    assert!(run.events.windows(2).all(|w| w[0].t_us <= w[1].t_us));
    // 1 event per pixel per second over 0.5 s: about 21600 events, Poisson.
    let expected = cam.pixel_count() as f64 * 0.5;
    let n = run.events.len() as f64;
    assert!(
        (n - expected).abs() < 5.0 * expected.sqrt(),
        "{n} events, expected {expected}"
    );
}

#[test]
fn same_seed_same_events_and_imu() {
    let cam = CameraIntrinsics::dvs240();
    let scene = faithd_sim::world::SceneKind::Kitchen.build(4);
    let mut t = Trajectory::straight([-4.0, 0.2, -1.2], 3.0, -12.0, 1.5);
    t.yaw_amp_deg = 2.0;
    t.yaw_hz = 1.0;
    let a = simulate(
        &scene,
        &t,
        cam,
        DvsConfig::default(),
        ImuConfig::default(),
        0.1,
        9,
    );
    let b = simulate(
        &scene,
        &t,
        cam,
        DvsConfig::default(),
        ImuConfig::default(),
        0.1,
        9,
    );
    assert_eq!(a.events, b.events);
    assert_eq!(a.attitude, b.attitude);
    let c = simulate(
        &scene,
        &t,
        cam,
        DvsConfig::default(),
        ImuConfig::default(),
        0.1,
        10,
    );
    assert_ne!(a.events, c.events);
}

#[test]
fn the_event_camera_can_be_stepped_for_closed_loop_use() {
    let cam = CameraIntrinsics::dvs240();
    let scene = step_wall();
    let trajectory = Trajectory::straight([0.0, -0.6, -1.2], 0.0, 90.0, 0.5);
    let mut camera = EventCamera::new(cam, Mounting::forward(), ideal_sensor(), 1);
    let mut stepped = Vec::new();
    for k in 0..=100 {
        let t_us = k * 1000;
        camera.advance(
            &scene,
            &trajectory.state(t_us as f64 * 1e-6),
            t_us,
            &mut stepped,
        );
    }
    let whole = simulate(
        &scene,
        &trajectory,
        cam,
        ideal_sensor(),
        ImuConfig::default(),
        0.1,
        1,
    );
    assert_eq!(stepped, whole.events);
}

#[test]
fn a_small_foe_benchmark_is_deterministic_and_ranks_faith_first() {
    use faithd_sim::bench::foe::{BenchFoeOptions, run};
    let options = BenchFoeOptions {
        trajectories: 4,
        seed: 5,
        duration_s: 0.3,
        windows: 2,
        threads: 2,
        ..Default::default()
    };
    let a = run(&options, &|_, _| {});
    let b = run(
        &BenchFoeOptions {
            threads: 1,
            ..options.clone()
        },
        &|_, _| {},
    );
    // Bit patterns, so a trajectory with no usable window (NaN) compares equal too.
    let errors = |r: &faithd_sim::bench::foe::BenchFoeReport| {
        r.per_trajectory
            .iter()
            .map(|t| t.mean_error_deg.iter().map(|e| e.to_bits()).collect())
            .collect::<Vec<Vec<u64>>>()
    };
    assert_eq!(
        errors(&a),
        errors(&b),
        "same seed, any thread count, same errors"
    );
    let names: Vec<&str> = a.methods.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(
        &names[..4],
        ["faith", "half_planes", "nesw", "vec_intersections"]
    );
    let faith = &a.methods[0];
    assert!(faith.mean_error_deg.is_finite());
    for other in &a.methods[1..4] {
        assert!(
            faith.mean_error_deg < other.mean_error_deg,
            "{faith:?} vs {other:?}"
        );
    }
    // The figures render from the report.
    let dir = std::env::temp_dir().join(format!("faithd-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    faithd_sim::bench::plot::plot_errors(&a, &dir.join("e.png")).unwrap();
    faithd_sim::bench::plot::plot_frame(a.example.as_ref().unwrap(), &dir.join("f.png")).unwrap();
    assert!(std::fs::metadata(dir.join("f.png")).unwrap().len() > 10_000);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The link's rates are the ones derotation gets: the same rotating flight, its
/// rates rounded to whole degrees per second at 25 Hz, gives FAITH other errors.
#[test]
fn the_benchs_attitude_link_reaches_derotation() {
    use faithd_sim::bench::foe::{BenchFoeOptions, run};
    use faithd_sim::world::AttitudeLink;
    let options = BenchFoeOptions {
        trajectories: 3,
        seed: 5,
        duration_s: 0.3,
        windows: 2,
        threads: 2,
        variants: Vec::new(),
        rotation: true,
        ..Default::default()
    };
    let over = |attitude_link| {
        run(
            &BenchFoeOptions {
                attitude_link,
                ..options.clone()
            },
            &|_, _| {},
        )
    };
    let (imu, msp) = (over(AttitudeLink::Imu), over(AttitudeLink::Msp));
    assert_eq!(
        (imu.attitude_link, msp.attitude_link),
        (AttitudeLink::Imu, AttitudeLink::Msp)
    );
    assert_eq!(msp.rotating_trajectories, 1);
    let rotating = |r: &faithd_sim::bench::foe::BenchFoeReport| {
        let t = &r.per_trajectory[2];
        assert!(t.rotating);
        t.mean_error_deg[0]
    };
    assert!(rotating(&msp).is_finite());
    assert_ne!(rotating(&imu), rotating(&msp));
    assert_eq!(
        msp.methods[0].rotating_mean_error_deg,
        Some(rotating(&msp)),
        "one rotating flight: its error is the mean"
    );
}
