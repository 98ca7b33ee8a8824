//! Closed loop, end to end: the daemon's own tasks and safety gate, MAVLink bytes on
//! a loopback socket to a simulated iNav, a simulated quadrotor and camera.

use faithd::closed_loop::{FlightSpec, fly};

#[test]
fn a_collision_course_is_avoided() {
    let o = fly(&FlightSpec {
        lateral_offset_m: 0.1,
        seed: 3,
        ..Default::default()
    })
    .unwrap();
    assert!(o.collision_course);
    assert!(o.rolled, "no roll on a collision course");
    assert!(!o.collided, "hit the pole: clearance {}", o.min_clearance_m);
    let ttc = o.ttc_at_decision_s.unwrap();
    assert!((0.5..2.5).contains(&ttc), "rolled at true TTC {ttc}");
    let latency = o.latency_ms.unwrap();
    assert!(latency < 50.0, "latency {latency} ms");
}

#[test]
fn a_near_pass_is_left_alone() {
    let o = fly(&FlightSpec {
        lateral_offset_m: -0.9,
        seed: 4,
        ..Default::default()
    })
    .unwrap();
    assert!(!o.collision_course);
    assert!(!o.rolled, "rolled on a near pass");
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
    let o = fly(&FlightSpec {
        lateral_offset_m: 0.1,
        pilot_auto: false,
        seed: 3,
        ..Default::default()
    })
    .unwrap();
    assert!(!o.rolled);
    assert!(
        o.collided,
        "the pilot kept MANUAL: faithd must not have steered"
    );
    assert!(o.path.iter().all(|p| p.roll_us == 1500));
}
