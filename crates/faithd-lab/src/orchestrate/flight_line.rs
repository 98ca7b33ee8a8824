//! One closed-loop flight in one line of `faithd sim`'s log.

use crate::closed_loop::{FlightOutcome, FlightSpec};
use faithd_core::decide::Reason;

/// Flight `i` of `runs`: its course, scene and result, the roll and its latency.
pub fn flight_line(i: usize, runs: usize, spec: &FlightSpec, o: &FlightOutcome) -> String {
    let mut line = format!(
        "[{}/{}] {} {:<9} offset {:+.2} m, heading {:+.1} deg, {:.1} m/s: {}",
        i + 1,
        runs,
        if o.collision_course {
            "collision course"
        } else {
            "near pass       "
        },
        spec.scene.name(),
        spec.lateral_offset_m,
        spec.heading_deg,
        spec.speed_m_s,
        if o.collided { "HIT" } else { "clear" },
    );
    match (o.rolled, roll_ttc_s(o)) {
        (true, Some((measured, truth))) => {
            line += &format!(
                ", rolled at {:.2} s of flight, TTC {measured:.2} s measured, {truth:.2} s true",
                o.decision_s.unwrap_or(f64::NAN)
            )
        }
        (true, None) => line += ", rolled",
        (false, _) => {}
    }
    if let Some(ms) = o.latency_ms {
        line += &format!(", roll in use {ms:.1} ms after the deciding event");
    }
    if o.pipeline.overruns > 0 {
        line += &format!(", {} cycles over budget", o.pipeline.overruns);
    }
    if let (false, Some(d)) = (o.collision_course, &o.decision) {
        line += &format!("\n    rolled on a near pass: {d}");
    }
    line
}

/// The TTC the roll was decided on and the true one at that moment.
fn roll_ttc_s(o: &FlightOutcome) -> Option<(f64, f64)> {
    let measured = match o.decision?.reason {
        Reason::ObstacleAhead { ttc_s, .. } => ttc_s,
        _ => return None,
    };
    Some((measured, o.ttc_at_decision_s?))
}
