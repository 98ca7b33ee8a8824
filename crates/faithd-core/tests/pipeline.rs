//! The whole core on generated event streams with known answers.

use faithd_core::attitude::AttitudeSample;
use faithd_core::camera::CameraIntrinsics;
use faithd_core::decide::{Action, Reason, RollDirection};
use faithd_core::event::Event;
use faithd_core::flow::{FlowConfig, NormalFlow};
use faithd_core::foe::FoeEstimate;
use faithd_core::math;
use faithd_core::pipeline::{NoClock, Pipeline, PipelineConfig, StageClock};
use faithd_core::synth::{Layer, LoomingEdges, looming_edge_events};

const WINDOW_US: i64 = 10_000;

/// A still vehicle's attitude stream at 100 Hz over the run.
fn level_attitude(duration_us: i64) -> Vec<AttitudeSample> {
    (0..=duration_us / 10_000)
        .map(|i| AttitudeSample {
            t_us: i * 10_000,
            ..Default::default()
        })
        .collect()
}

/// Splits events into consecutive windows and runs them all, collecting what `f` takes.
fn run_windows<T>(
    pipeline: &mut Pipeline,
    events: &[Event],
    attitude: &[AttitudeSample],
    clock: &mut dyn StageClock,
    mut f: impl FnMut(&faithd_core::pipeline::WindowReport<'_>) -> T,
) -> Vec<T> {
    let end_us = events.last().map_or(0, |e| e.t_us) + 1;
    let mut out = Vec::new();
    let mut start = 0;
    let mut window_end_us = WINDOW_US;
    while window_end_us <= end_us + WINDOW_US {
        let stop = start + faithd_core::window::events_until(&events[start..], window_end_us);
        let att: Vec<_> = attitude
            .iter()
            .copied()
            .filter(|a| {
                a.t_us >= window_end_us - 2 * WINDOW_US && a.t_us <= window_end_us + WINDOW_US
            })
            .collect();
        let report = pipeline.process_window(&events[start..stop], &att, window_end_us, clock);
        out.push(f(&report));
        start = stop;
        window_end_us += WINDOW_US;
    }
    out
}

#[test]
fn flow_of_looming_edges_matches_the_closed_form() {
    let cam = CameraIntrinsics::dvs240();
    let scene = LoomingEdges {
        foe_px: (110.0, 95.0),
        layers: vec![Layer {
            tau0_s: 2.0,
            rect_px: None,
            edges: 40,
        }],
        duration_s: 0.6,
        jitter_us: 0.0,
        noise_rate_hz: 0.0,
    };
    let events = looming_edge_events(&cam, &scene, 3);
    let mut flow = NormalFlow::new(&cam, FlowConfig::default());
    let mut vectors = Vec::new();
    flow.process(&events, &mut vectors);
    assert!(vectors.len() > 2_000, "{} vectors", vectors.len());
    let (mut away, mut ttc_ok, mut checked) = (0, 0, 0);
    let mut ttc_rel_errors = Vec::new();
    for v in &vectors {
        let (rx, ry) = (v.x_px - 110.0, v.y_px - 95.0);
        if math::hypot(rx, ry) < 15.0 {
            continue; // near the FOE the flow is a few px/s and poorly conditioned
        }
        checked += 1;
        let along = rx * v.u_px_s + ry * v.v_px_s;
        if along > 0.0 {
            away += 1;
        }
        let ttc = faithd_core::ttc::ttc_at_s(v, (110.0, 95.0), v.t_us, &Default::default());
        let truth_s = 2.0 - v.t_us as f64 * 1e-6;
        if ttc.is_some_and(|t| (t - truth_s).abs() < 0.15 * truth_s) {
            ttc_ok += 1;
        }
        ttc_rel_errors.extend(ttc.map(|t| (t - truth_s).abs() / truth_s));
    }
    let away_frac = away as f64 / checked as f64;
    let ttc_frac = ttc_ok as f64 / checked as f64;
    // Up to 5 % go astray where a patch mixes the events of two crossing edges.
    assert!(away_frac > 0.93, "only {away_frac} point away from the FOE");
    assert!(ttc_frac > 0.8, "only {ttc_frac} have TTC within 15 %");
    // The fit's lag taken off, the median error is 0.3 % (3.8 % without: the distance
    // over a speed measured 20 to 60 ms earlier).
    ttc_rel_errors.sort_by(f64::total_cmp);
    let median = ttc_rel_errors[ttc_rel_errors.len() / 2];
    assert!(median < 0.01, "median TTC error {median}");
}

#[test]
fn pole_ahead_is_avoided_toward_open_space() {
    let cam = CameraIntrinsics::dvs240();
    let foe = (130.0, 85.0);
    let scene = LoomingEdges::pole_ahead(foe);
    let events = looming_edge_events(&cam, &scene, 7);
    let attitude = level_attitude(600_000);
    let mut pipeline = Pipeline::new(PipelineConfig::default());
    let decisions = run_windows(&mut pipeline, &events, &attitude, &mut NoClock, |r| {
        (r.decision, r.foe)
    });
    let rolls: Vec<_> = decisions
        .iter()
        .filter(|(d, _)| matches!(d.action, Action::Roll { .. }))
        .collect();
    // Windows that see the pole ahead and close, rolling or confirming that they do.
    let calls = decisions
        .iter()
        .filter(|(d, _)| {
            matches!(
                d.reason,
                Reason::ObstacleAhead { .. } | Reason::Unconfirmed { .. }
            )
        })
        .count();
    assert!(
        calls * 2 > decisions.len() && !rolls.is_empty(),
        "only {} of {} windows called for a roll: {:#?}",
        calls,
        decisions.len(),
        decisions
            .iter()
            .map(|(d, _)| d.to_string())
            .collect::<Vec<_>>()
    );
    let foe_errors: Vec<f64> = rolls
        .iter()
        .map(|(_, est)| {
            let (x, y) = est.point().unwrap();
            math::hypot(x - foe.0, y - foe.1)
        })
        .collect();
    let mean_error = foe_errors.iter().sum::<f64>() / foe_errors.len() as f64;
    // Measured: mean 12.6 px (3.7 degrees), worst 19.7 px. The pole is 24 px wide at
    // the start and grows; what matters is that the FOE lands on it.
    assert!(foe_errors.iter().all(|&e| e < 25.0), "{foe_errors:?}");
    assert!(mean_error < 16.0, "{foe_errors:?}");
    let mut ttc_rel_errors = Vec::new();
    for (d, _) in &rolls {
        let Reason::ObstacleAhead { ttc_s, .. } = d.reason else {
            panic!("{d}")
        };
        // The pole's true TTC runs from 1.2 s down to 0.7 s over the run.
        let truth_s = 1.2 - d.t_us as f64 * 1e-6;
        ttc_rel_errors.push((ttc_s - truth_s).abs() / truth_s);
        assert!(d.obstacle.is_some(), "{d}");
    }
    // The first roll is the one that acts (the manoeuvre then runs its 1.5 s).
    // Measured: 2.0 % (at a true TTC of 1.07 s).
    assert!(ttc_rel_errors[0] < 0.05, "{ttc_rel_errors:?}");
    ttc_rel_errors.sort_by(f64::total_cmp);
    let median = ttc_rel_errors[ttc_rel_errors.len() / 2];
    // Measured: 10.8 %. The rolls go on to the end of the run (true TTC 0.7 s); up
    // to a true TTC of 0.87 s they are within 4.6 %, after that the pole, 40 to 60
    // px wide, is split into pieces by DBSCAN, and the piece the rule takes is the
    // one at the FOE, whose flow is the slowest and its TTC the least certain (6 to
    // 42 % off). Before the obstacle's expansion kept the term of slanted edges, the
    // rule called the roll only up to a true TTC of 0.87 s, and this median was 3.8 %.
    assert!(
        median < 0.15,
        "median TTC error {median}: {ttc_rel_errors:?}"
    );
}

#[test]
fn pole_beside_the_course_is_left_alone() {
    let cam = CameraIntrinsics::dvs240();
    let foe = (60.0, 85.0);
    let mut scene = LoomingEdges::pole_ahead(foe);
    // Pole 70 px right of the course: a near pass.
    scene.layers[0].rect_px = Some((foe.0 + 60.0, -1e4, foe.0 + 84.0, 1e4));
    let events = looming_edge_events(&cam, &scene, 8);
    let attitude = level_attitude(600_000);
    let mut pipeline = Pipeline::new(PipelineConfig::default());
    let decisions = run_windows(&mut pipeline, &events, &attitude, &mut NoClock, |r| {
        r.decision
    });
    let rolls = decisions
        .iter()
        .filter(|d| matches!(d.action, Action::Roll { .. }))
        .count();
    assert_eq!(
        rolls,
        0,
        "{:#?}",
        decisions.iter().map(|d| d.to_string()).collect::<Vec<_>>()
    );
    assert!(
        decisions
            .iter()
            .any(|d| d.reason == Reason::ObstacleNotAhead)
    );
}

#[test]
fn roll_goes_toward_the_farther_side() {
    let cam = CameraIntrinsics::dvs240();
    // FOE on the pole; a near wall fills the left third, far background elsewhere.
    let foe = (120.0, 85.0);
    let mut scene = LoomingEdges::pole_ahead(foe);
    scene.layers.push(Layer {
        tau0_s: 2.5,
        rect_px: Some((-1e4, -1e4, 60.0, 1e4)),
        edges: 40,
    });
    scene.layers[1].tau0_s = 8.0;
    let events = looming_edge_events(&cam, &scene, 9);
    let attitude = level_attitude(600_000);
    let mut pipeline = Pipeline::new(PipelineConfig::default());
    let decisions = run_windows(&mut pipeline, &events, &attitude, &mut NoClock, |r| {
        r.decision
    });
    let dirs: Vec<_> = decisions
        .iter()
        .filter_map(|d| match d.action {
            Action::Roll { direction, .. } => Some(direction),
            Action::Hold => None,
        })
        .collect();
    assert!(!dirs.is_empty());
    let right = dirs.iter().filter(|&&d| d == RollDirection::Right).count();
    // The first windows see the wall before the far background has formed a cluster;
    // once both sides are seen the rolls go right.
    assert!(
        right * 4 >= dirs.len() * 3,
        "{right} of {} rolls go right",
        dirs.len()
    );
}

#[test]
fn no_attitude_means_no_roll() {
    let cam = CameraIntrinsics::dvs240();
    let events = looming_edge_events(&cam, &LoomingEdges::pole_ahead((130.0, 85.0)), 7);
    let mut pipeline = Pipeline::new(PipelineConfig::default());
    let decisions = run_windows(&mut pipeline, &events, &[], &mut NoClock, |r| r.decision);
    assert!(
        decisions
            .iter()
            .all(|d| d.action == Action::Hold && d.reason == Reason::NoAttitude)
    );
}

#[test]
fn same_input_same_output_bit_for_bit() {
    let cam = CameraIntrinsics::dvs240();
    let mut scene = LoomingEdges::pole_ahead((100.0, 70.0));
    scene.noise_rate_hz = 1.0;
    scene.jitter_us = 100.0;
    let events = looming_edge_events(&cam, &scene, 21);
    let attitude = level_attitude(600_000);
    let render = |r: &faithd_core::pipeline::WindowReport<'_>| {
        format!(
            "{:?}|{:?}|{:?}|{:?}|{:?}",
            r.foe, r.ttc_s, r.labels, r.clusters, r.decision
        )
    };
    let a = run_windows(
        &mut Pipeline::new(PipelineConfig::default()),
        &events,
        &attitude,
        &mut NoClock,
        render,
    );
    let b = run_windows(
        &mut Pipeline::new(PipelineConfig::default()),
        &events,
        &attitude,
        &mut NoClock,
        render,
    );
    assert_eq!(a, b);
    // A different seed changes RANSAC's draws (proving the seed is used) ...
    let other = PipelineConfig {
        seed: 99,
        ..Default::default()
    };
    let c = run_windows(
        &mut Pipeline::new(other),
        &events,
        &attitude,
        &mut NoClock,
        |r| r.foe,
    );
    let a_foe = run_windows(
        &mut Pipeline::new(PipelineConfig::default()),
        &events,
        &attitude,
        &mut NoClock,
        |r| r.foe,
    );
    assert_ne!(c, a_foe);
    // ... but not the answer: both seeds agree on the FOE within a few pixels.
    for (x, y) in c.iter().zip(&a_foe) {
        if let (
            FoeEstimate::Point {
                x_px: x1, y_px: y1, ..
            },
            FoeEstimate::Point {
                x_px: x2, y_px: y2, ..
            },
        ) = (x, y)
        {
            assert!(math::hypot(x1 - x2, y1 - y2) < 10.0);
        }
    }
}

/// A clock that advances 1 us per reading, to check the timings come from it.
struct TickClock(u64);

impl StageClock for TickClock {
    fn now_ns(&mut self) -> u64 {
        self.0 += 1_000;
        self.0
    }
}

#[test]
fn stage_timings_come_from_the_callers_clock() {
    let cam = CameraIntrinsics::dvs240();
    let events = looming_edge_events(&cam, &LoomingEdges::pole_ahead((130.0, 85.0)), 7);
    let attitude = level_attitude(600_000);
    let mut pipeline = Pipeline::new(PipelineConfig::default());
    let timings = run_windows(
        &mut pipeline,
        &events[..5000],
        &attitude,
        &mut TickClock(0),
        |r| r.timings,
    );
    for t in timings {
        assert_eq!(t.flow_ns, 1_000);
        assert_eq!(t.total_ns(), 6_000);
    }
}
