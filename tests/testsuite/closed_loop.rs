//! Closed loop, end to end, in simulated time: the daemon's own `serve()` (link,
//! pipeline, commander, safety gate, MSP stream) with MAVLink and MSP bytes on
//! simulated UARTs to a simulated iNav, a simulated quadrotor, and the ray-traced
//! DVS camera rendering its true path.

use faithd::closed_loop::{CameraKind, FlightOutcome, FlightSpec, FlyOptions, SceneKind, fly};
use faithd::cycle::compute::ComputeCharge;

fn collision_course() -> FlightSpec {
    FlightSpec {
        lateral_offset_m: 0.1,
        seed: 3,
        ..Default::default()
    }
}

/// The outcome as `faithd sim --json` would publish it.
fn json(o: &FlightOutcome) -> String {
    serde_json::to_string(o).unwrap()
}

#[test]
fn a_collision_course_is_avoided() {
    let _cpu = crate::common::cpu::heavy();
    let o = fly(&collision_course(), &FlyOptions::default()).unwrap();
    assert!(o.collision_course);
    assert!(o.rolled, "no roll on a collision course");
    assert!(!o.collided, "hit the pole: clearance {}", o.min_clearance_m);
    let ttc = o.ttc_at_decision_s.unwrap();
    assert!((0.8..2.5).contains(&ttc), "rolled at true TTC {ttc}");
    // Pipeline compute, the commander's tick, the MSP frame on a 115200 baud UART
    // and iNav's next loop: milliseconds, in simulated time.
    let latency = o.latency_ms.unwrap();
    assert!((1.0..30.0).contains(&latency), "latency {latency} ms");
    assert!(o.latency_from_first_call_ms.unwrap() >= latency);
    assert!(o.events > 100_000, "the camera fired {} events", o.events);
    assert!(o.pipeline.cycles > 250, "{:?}", o.pipeline);
    assert_eq!(o.pipeline.overruns, 0, "{:?}", o.pipeline);
}

#[test]
fn a_near_pass_is_left_alone() {
    let _cpu = crate::common::cpu::heavy();
    let o = fly(
        &FlightSpec {
            lateral_offset_m: -0.9,
            seed: 4,
            ..Default::default()
        },
        &FlyOptions::default(),
    )
    .unwrap();
    assert!(!o.collision_course);
    assert!(!o.rolled, "rolled on a near pass: {:?}", o.decision);
    assert!(!o.collided);
    // Flying straight, the gap is the course offset less pole radius and half-span.
    assert!(
        (o.min_clearance_m - 0.5).abs() < 0.02,
        "{}",
        o.min_clearance_m
    );
}

#[test]
fn with_the_switch_in_manual_the_vehicle_hits_the_pole() {
    let _cpu = crate::common::cpu::heavy();
    let o = fly(
        &FlightSpec {
            pilot_auto: false,
            camera: CameraKind::Line,
            ..collision_course()
        },
        &FlyOptions::default(),
    )
    .unwrap();
    assert!(!o.rolled);
    assert!(
        o.collided,
        "the pilot kept MANUAL: faithd must not have steered"
    );
    assert!(o.path.iter().all(|p| p.roll_us == 1500));
}

/// The same flight twice, the second with both cores kept busy beside it: the
/// outcome is the same to the last byte (simulated time, the modelled compute, one
/// thread per flight).
#[test]
fn a_flight_is_the_same_on_every_run_and_under_any_load() {
    let _cpu = crate::common::cpu::heavy();
    let spec = FlightSpec {
        scene: SceneKind::Kitchen,
        ..collision_course()
    };
    let options = FlyOptions::default();
    let first = json(&fly(&spec, &options).unwrap());
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let hogs: Vec<_> = (0..2)
        .map(|_| {
            let stop = stop.clone();
            std::thread::spawn(move || {
                let mut x = 0u64;
                while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                    x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
                }
            })
        })
        .collect();
    let second = json(&fly(&spec, &options).unwrap());
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    for h in hogs {
        h.join().unwrap();
    }
    assert_eq!(first, second);
}

/// A board ten times slower than this machine overruns the 8 ms budget and sheds
/// load, as the daemon would on it; this machine does not.
#[test]
fn a_slow_board_overruns_and_sheds_load() {
    let _cpu = crate::common::cpu::heavy();
    let spec = FlightSpec {
        camera: CameraKind::Line,
        ..collision_course()
    };
    let here = fly(&spec, &FlyOptions::default()).unwrap();
    let slow = fly(
        &spec,
        &FlyOptions {
            compute: ComputeCharge::modelled(10.0),
            ..FlyOptions::default()
        },
    )
    .unwrap();
    assert_eq!(here.pipeline.overruns, 0, "{:?}", here.pipeline);
    assert!(slow.pipeline.overruns > 0, "{:?}", slow.pipeline);
    assert!(slow.pipeline.shed_cycles > 0, "{:?}", slow.pipeline);
    assert!(slow.pipeline.max_load_level >= 1);
    // Ten times the cost, less what the shed load saves.
    assert!(
        slow.pipeline.charged_us_p50 > 3.0 * here.pipeline.charged_us_p50,
        "{:?} vs {:?}",
        slow.pipeline,
        here.pipeline
    );
}

/// Charging the measured time instead of the model flies too (not repeatable).
#[test]
fn measured_compute_flies_too() {
    let _cpu = crate::common::cpu::heavy();
    let o = fly(
        &FlightSpec {
            camera: CameraKind::Line,
            ..collision_course()
        },
        &FlyOptions {
            compute: ComputeCharge::Measured { cpu_scale: 1.0 },
            ..FlyOptions::default()
        },
    )
    .unwrap();
    assert!(o.rolled && !o.collided);
    assert!(o.pipeline.charged_us_p50 > 1.0, "{:?}", o.pipeline);
}

/// Two flights in one process, as `faithd sim` flies them: a fault of one (a panic on
/// its thread, or a task reporting one) ends that flight and leaves the other alone.
#[test]
fn one_flights_fault_ends_that_flight_only() {
    let _cpu = crate::common::cpu::heavy();
    use faithd::supervise::{Fault, Faults};
    let options = FlyOptions::default();
    let faulty = Faults::new();
    let line = FlightSpec {
        camera: CameraKind::Line,
        ..collision_course()
    };
    let (spec_a, spec_b) = (line.clone(), line);
    let (a, b) = std::thread::scope(|s| {
        let handle = faulty.clone();
        let a = s.spawn(|| faithd::closed_loop::fly_with(&spec_a, &options, handle));
        let b = s.spawn(|| fly(&spec_b, &options));
        // Mid-flight for the first one (the daemon is up within milliseconds of
        // simulated time, and the flight lasts seconds of it).
        std::thread::sleep(std::time::Duration::from_millis(100));
        faulty.report(Fault::Crash("injected fault of flight A".into()));
        (a.join().unwrap(), b.join().unwrap())
    });
    let err = a.expect_err("flight A ends on its fault");
    assert!(
        err.to_string().contains("injected fault of flight A"),
        "{err}"
    );
    let b = b.expect("flight B flies on");
    assert!(b.rolled && !b.collided, "flight B: {}", json(&b));
}

/// What CI keeps of what iNav's SITL taught: the model's roll, end to end (faithd's
/// MSP stream into the model of iNav's port, the receiver frame, the ANGLE
/// response), stays within the stated bounds of what iNav's own controller did on
/// the same flights (`faithd::inav_sitl::measured`; the SITL side is
/// `inav_flight::faithd_avoids_the_pole_through_inavs_own_controller`).
#[test]
fn the_model_rolls_as_inavs_own_controller_did() {
    use faithd::inav_sitl::experiment::{RollFigures, plan};
    use faithd::inav_sitl::measured;
    let _cpu = crate::common::cpu::heavy();
    let rolls: Vec<RollFigures> = plan(5, 1)
        .iter()
        .filter(|s| s.is_collision_course())
        .map(|s| RollFigures::of_model(&fly(s, &FlyOptions::default()).unwrap()))
        .collect();
    assert_eq!(rolls.len(), 3);
    for r in &rolls {
        assert!(r.rolled && !r.collided, "{r:?}");
        let peak = r.peak_bank_deg.unwrap();
        assert!(
            measured::PEAK_BANK_DEG.holds(peak),
            "peak bank {peak}: {r:?}"
        );
    }
    let timings = measured::RollTimings::of(&rolls);
    println!("model: {timings:?}");
    if let Err(why) = timings.check() {
        panic!("model strays from what iNav did: {why}");
    }
}
