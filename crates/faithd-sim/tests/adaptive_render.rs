//! Adaptive render timing: the image-speed bound holds against the real motion of
//! scene points, and a flight rendered only as often as the image needs gives the
//! events a 1 kHz flight gives.

use faithd_core::camera::{CameraIntrinsics, Mounting};
use faithd_core::event::{Event, Polarity};
use faithd_sim::world::{
    DvsConfig, EventCamera, Scene, SceneKind, Trajectory, VehicleState, render_interval_us,
};
use nalgebra::{Rotation3, Vector3};

const POLE_X_M: f64 = 3.0;

fn camera(seed: u64) -> EventCamera {
    camera_with(DvsConfig::default(), seed)
}

fn camera_with(config: DvsConfig, seed: u64) -> EventCamera {
    EventCamera::new(
        CameraIntrinsics::dvs240(),
        Mounting::forward(),
        config,
        seed,
    )
}

/// Where `p` appears in the image of a camera in `state`, pixels (even off the
/// sensor); `None` behind the camera.
fn project(cam: &EventCamera, state: &VehicleState, p: &Vector3<f64>) -> Option<(f64, f64)> {
    let in_body = state.attitude.inverse() * (p - state.position_m);
    cam.camera()
        .project(&(cam.mounting().body_to_camera * in_body))
}

/// The scene point each pixel sees from `state` (row-major), as the renderer casts.
fn scene_points(
    cam: &EventCamera,
    scene: &Scene,
    state: &VehicleState,
) -> Vec<Option<Vector3<f64>>> {
    let intrinsics = cam.camera();
    let camera_to_body = cam.mounting().body_to_camera.transpose();
    let r = state.attitude.matrix();
    let mut points = Vec::with_capacity(intrinsics.pixel_count());
    for y in 0..intrinsics.height_px {
        for x in 0..intrinsics.width_px {
            let (xn, yn) = intrinsics.normalise(f64::from(x), f64::from(y));
            let dir = r * (camera_to_body * Vector3::new(xn, yn, 1.0));
            points.push(
                scene
                    .cast(&state.position_m, &dir)
                    .map(|h| state.position_m + dir * h.t),
            );
        }
    }
    points
}

/// The fastest image motion of any scene point seen from `now`, px/s, measured as the
/// displacement between its projections 0.5 ms before and after (a central
/// difference over 1 ms), and the speed of the nearest point.
fn measured_speeds_px_s(
    cam: &EventCamera,
    scene: &Scene,
    before: &VehicleState,
    now: &VehicleState,
    after: &VehicleState,
) -> (f64, f64) {
    let span_s = after.t_s - before.t_s;
    let mut fastest: f64 = 0.0;
    let mut nearest = (f64::INFINITY, 0.0);
    for p in scene_points(cam, scene, now).into_iter().flatten() {
        let (Some(a), Some(b)) = (project(cam, before, &p), project(cam, after, &p)) else {
            continue;
        };
        let speed = (b.0 - a.0).hypot(b.1 - a.1) / span_s;
        fastest = fastest.max(speed);
        let distance_m = (p - now.position_m).norm();
        if distance_m < nearest.0 {
            nearest = (distance_m, speed);
        }
    }
    (fastest, nearest.1)
}

#[test]
fn render_interval_is_the_time_to_move_the_allowed_displacement() {
    // 0.5 px at 250 px/s: 2 ms.
    assert_eq!(render_interval_us(250.0, 0.5, 1000, 5000), 2000);
    // Rounded down: 0.5 px at 300 px/s is 1666.67 us.
    assert_eq!(render_interval_us(300.0, 0.5, 1000, 5000), 1666);
    assert_eq!(render_interval_us(5000.0, 0.5, 1000, 5000), 1000);
    assert_eq!(render_interval_us(1.0, 0.5, 1000, 5000), 5000);
    assert_eq!(render_interval_us(0.0, 0.5, 1000, 5000), 5000);
    assert_eq!(render_interval_us(f64::INFINITY, 0.5, 1000, 5000), 1000);
    assert_eq!(render_interval_us(f64::NAN, 0.5, 1000, 5000), 1000);
}

#[test]
fn speed_bound_holds_and_is_not_loose_flying_at_a_pole() {
    let scene = SceneKind::Arena.build(2);
    // Toward the pole, a little off its centre line; 1.6 m to 0.7 m from its surface.
    let flight = Trajectory::straight([POLE_X_M - 1.85, 0.3, -1.2], 0.0, 0.0, 2.0);
    for t_s in [0.0, 0.2, 0.45] {
        let mut cam = camera(1);
        let now = flight.state(t_s);
        cam.advance(&scene, &now, 0, &mut Vec::new());
        let bound = cam.max_image_speed_px_s(&now);
        let (fastest, nearest) = measured_speeds_px_s(
            &cam,
            &scene,
            &flight.state(t_s - 0.0005),
            &now,
            &flight.state(t_s + 0.0005),
        );
        println!(
            "t {t_s} s: bound {bound:.1} px/s, fastest {fastest:.1}, nearest point {nearest:.1}"
        );
        assert!(
            bound >= fastest,
            "t {t_s}: bound {bound} < measured {fastest}"
        );
        assert!(
            bound <= 3.0 * fastest,
            "t {t_s}: bound {bound} more than 3x the fastest point's {fastest}"
        );
    }
}

#[test]
fn speed_bound_holds_and_is_not_loose_when_only_turning() {
    let scene = SceneKind::Kitchen.build(3);
    let attitude = Rotation3::from_euler_angles(0.05, -0.1, 0.3);
    for rates in [
        Vector3::new(0.0, 0.0, 2.0),
        Vector3::new(0.0, 1.0, 0.0),
        Vector3::new(1.5, 0.0, 0.0),
        Vector3::new(0.7, -0.4, 1.1),
    ] {
        // Body rates turn the body frame: attitude(t) = attitude(0) exp(t [w]x).
        let state = |t_s: f64| VehicleState {
            t_s,
            position_m: Vector3::new(0.0, 0.5, -1.3),
            velocity_m_s: Vector3::zeros(),
            attitude: attitude * Rotation3::new(rates * t_s),
            body_rates_rad_s: rates,
        };
        let mut cam = camera(2);
        cam.advance(&scene, &state(0.0), 0, &mut Vec::new());
        let bound = cam.max_image_speed_px_s(&state(0.0));
        let (fastest, _) =
            measured_speeds_px_s(&cam, &scene, &state(-0.0005), &state(0.0), &state(0.0005));
        println!("rates {rates:?}: bound {bound:.1} px/s, fastest {fastest:.1}");
        assert!(
            bound >= fastest,
            "{rates:?}: bound {bound} < measured {fastest}"
        );
        assert!(
            bound <= 3.0 * fastest,
            "{rates:?}: bound {bound}, measured {fastest}"
        );
    }
}

/// Flies `flight` for `duration_s`, rendering every `step_us`, or adaptively (`None`)
/// with at most 0.5 px of image motion per render and 1 to 5 ms between renders.
/// Returns the events and the render times.
fn fly(
    scene: &Scene,
    config: DvsConfig,
    flight: &Trajectory,
    duration_s: f64,
    step_us: Option<i64>,
) -> (Vec<Event>, Vec<i64>) {
    let mut cam = camera_with(config, 9);
    let mut events = Vec::new();
    let end_us = (duration_s * 1e6) as i64;
    let mut t_us = 0;
    let mut renders = Vec::new();
    loop {
        let state = flight.state(t_us as f64 * 1e-6);
        cam.advance(scene, &state, t_us, &mut events);
        renders.push(t_us);
        if t_us >= end_us {
            break;
        }
        let dt_us = step_us.unwrap_or_else(|| {
            render_interval_us(cam.max_image_speed_px_s(&state), 0.5, 1000, 5000)
        });
        t_us = (t_us + dt_us).min(end_us);
    }
    (events, renders)
}

/// The approach to the arena's pole, head on at 2 m/s from 5.5 m to 0.4 m of its
/// centre (where a 15 cm vehicle touches it).
fn approach() -> (Trajectory, f64) {
    let start_m = 5.5;
    let end_m = 0.4;
    (
        Trajectory::straight([POLE_X_M - start_m, 0.0, -1.0], 0.0, 0.0, 2.0),
        (start_m - end_m) / 2.0,
    )
}

/// Pearson correlation.
fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let cov: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f64 = a.iter().map(|x| (x - ma).powi(2)).sum();
    let vb: f64 = b.iter().map(|y| (y - mb).powi(2)).sum();
    cov / (va * vb).sqrt()
}

/// Events per 10 ms window, and per 30x30 px cell of the sensor.
fn histograms(events: &[Event], windows: usize) -> (Vec<f64>, Vec<f64>) {
    let mut per_window = vec![0.0; windows];
    let mut per_cell = vec![0.0; 8 * 6];
    for e in events {
        per_window[((e.t_us - 1) / 10_000).clamp(0, windows as i64 - 1) as usize] += 1.0;
        per_cell[usize::from(e.y_px / 30) * 8 + usize::from(e.x_px / 30)] += 1.0;
    }
    (per_window, per_cell)
}

fn on_share(events: &[Event]) -> f64 {
    events.iter().filter(|e| e.polarity == Polarity::On).count() as f64 / events.len() as f64
}

#[test]
fn adaptive_rendering_gives_the_events_of_rendering_at_1_khz() {
    let scene = SceneKind::Arena.build(4);
    let (flight, duration_s) = approach();
    // The last 1.2 s: from 2.8 m to 0.4 m, where the pole comes to fill the view and
    // the image moves fastest.
    let span_s = 1.2;
    let mut late = flight;
    late.start_m[0] += 2.0 * (duration_s - span_s);

    // An ideal sensor (no refractory period, no jitter): the same threshold
    // crossings, whether interpolated over 1 ms or over up to 5 ms, window by window
    // and over the sensor.
    let windows = (span_s * 100.0).round() as usize;
    let ideal = DvsConfig {
        refractory_us: 0,
        jitter_us: 0.0,
        ..DvsConfig::default()
    };
    let (fixed, _) = fly(&scene, ideal, &late, span_s, Some(1000));
    let (adaptive, _) = fly(&scene, ideal, &late, span_s, None);
    let ratio = adaptive.len() as f64 / fixed.len() as f64;
    let (time_a, space_a) = histograms(&fixed, windows);
    let (time_b, space_b) = histograms(&adaptive, windows);
    let moved = time_a
        .iter()
        .zip(&time_b)
        .map(|(a, b)| (a - b).abs())
        .sum::<f64>()
        / time_a.iter().sum::<f64>();
    let (r_time, r_space) = (
        correlation(&time_a, &time_b),
        correlation(&space_a, &space_b),
    );
    println!(
        "ideal sensor: 1 kHz {} events, adaptive {}; per 10 ms window {:.1} % of the events in other windows, correlation {r_time:.3}; per 30 px cell {r_space:.3}",
        fixed.len(),
        adaptive.len(),
        moved * 100.0
    );
    assert!((0.98..=1.02).contains(&ratio), "ideal sensor: {ratio}");
    assert!(moved < 0.1 && r_time > 0.98 && r_space > 0.99);

    // The default sensor. Its 200 us refractory period drops some of the crossings
    // of a point-sampled texture step, and more of them when the step is
    // interpolated over 1 ms than over a longer render interval: the adaptive flight
    // has more events (9 % here, up to a third in a window, more where steps are
    // strong), the same activity over time and much the same over the sensor.
    let (fixed, _) = fly(&scene, DvsConfig::default(), &late, span_s, Some(1000));
    let (adaptive, renders) = fly(&scene, DvsConfig::default(), &late, span_s, None);
    let mean_interval_ms = span_s * 1e3 / (renders.len() - 1) as f64;
    let ratio = adaptive.len() as f64 / fixed.len() as f64;
    let (time_a, space_a) = histograms(&fixed, windows);
    let (time_b, space_b) = histograms(&adaptive, windows);
    let (r_time, r_space) = (
        correlation(&time_a, &time_b),
        correlation(&space_a, &space_b),
    );
    let moved = time_a
        .iter()
        .zip(&time_b)
        .map(|(a, b)| (a - b).abs())
        .sum::<f64>()
        / time_a.iter().sum::<f64>();
    println!(
        "default sensor: 1 kHz {} events, adaptive {} ({} renders, mean interval {mean_interval_ms:.2} ms); per 10 ms window {:.1} % of the events in other windows, correlation {r_time:.3}; per 30 px cell {r_space:.3}",
        fixed.len(),
        adaptive.len(),
        renders.len(),
        moved * 100.0
    );
    assert!(mean_interval_ms > 1.5, "adaptive rendering saved little");
    assert!((0.9..=1.1).contains(&ratio), "event counts differ: {ratio}");
    assert!((on_share(&fixed) - on_share(&adaptive)).abs() < 0.03);
    assert!(r_time > 0.95 && r_space > 0.9, "{r_time} {r_space}");
}

/// The figure for docs/simulation.md: the mean render interval on the whole approach.
#[test]
fn adaptive_rendering_on_the_approach_to_a_pole() {
    let scene = SceneKind::Arena.build(1);
    let (flight, duration_s) = approach();
    let (_, renders) = fly(&scene, DvsConfig::default(), &flight, duration_s, None);
    let intervals: Vec<i64> = renders.windows(2).map(|w| w[1] - w[0]).collect();
    let mean_ms = intervals.iter().sum::<i64>() as f64 / intervals.len() as f64 / 1000.0;
    let at_min = intervals.iter().filter(|&&i| i == 1000).count();
    println!(
        "{:.2} s approach: {} renders (1 kHz: {}), mean interval {mean_ms:.2} ms, {at_min} at 1 ms",
        duration_s,
        renders.len(),
        (duration_s * 1000.0) as usize + 1
    );
    assert!(mean_ms > 2.0, "{mean_ms}");
}
