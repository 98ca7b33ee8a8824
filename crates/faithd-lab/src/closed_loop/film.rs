//! A simulated flight on film: the daemon's own windows, as its pipeline computed
//! them, joined with what the simulation knows at each window's time and no
//! recording holds: the commander's safety gate, the roll iNav uses, the true
//! heading and time to contact.

use faithd_core::pipeline::PipelineConfig;
use faithd_core::safety::gate::GateState;
use faithd_core::safety::manoeuvre::ManoeuvreConfig;

use super::FlightSpec;
use super::physics::PathPoint;
use crate::video::{Frame, InavRoll, TimeSpan, Truth};
use faithd_core::decide::RollDirection;

/// The frames of one flight, from the start of the flight (the daemon's lead-in,
/// with the vehicle waiting and the camera dark, is left out) to its end.
#[derive(Clone, Debug)]
pub struct FilmedFlight {
    pub frames: Vec<Frame>,
    pub span: TimeSpan,
    /// The pipeline's period: windows are this far apart.
    pub period_us: i64,
    /// The settings the daemon's pipeline flew with.
    pub pipeline: PipelineConfig,
}

/// What the flight's world recorded, on the daemon clock.
pub struct WorldRecord<'a> {
    /// The daemon time the vehicle set off; the path's times count from it.
    pub start_us: i64,
    pub path: &'a [PathPoint],
    /// Every change of the commander's gate, in order.
    pub gates: &'a [(i64, GateState)],
    pub spec: &'a FlightSpec,
    pub manoeuvre: &'a ManoeuvreConfig,
    pub period_us: i64,
    pub pipeline: &'a PipelineConfig,
}

/// Joins the pipeline's windows with the world's record of the same moments.
pub fn assemble(windows: Vec<Frame>, world: &WorldRecord<'_>) -> FilmedFlight {
    let end_us = world
        .path
        .last()
        .map_or(world.start_us, |p| world.start_us + (p.t_s * 1e6) as i64);
    let frames = windows
        .into_iter()
        .filter(|f| (world.start_us..=end_us).contains(&f.t_us))
        .map(|mut frame| {
            frame.gate = gate_at(world.gates, frame.t_us);
            if let Some(p) = path_at(world.path, frame.t_us - world.start_us) {
                frame.inav_roll = Some(inav_roll(p.roll_us));
                frame.truth = Some(Truth {
                    foe_px: p.true_foe_px,
                    ttc_s: world.spec.true_ttc_s(p.x_m),
                });
            }
            frame
        })
        .collect();
    FilmedFlight {
        frames,
        span: TimeSpan {
            start_us: world.start_us,
            end_us,
        },
        period_us: world.period_us,
        pipeline: *world.pipeline,
    }
}

/// The gate as it stood at `t_us`: the last change at or before it.
fn gate_at(gates: &[(i64, GateState)], t_us: i64) -> Option<GateState> {
    let after = gates.partition_point(|(t, _)| *t <= t_us);
    after.checked_sub(1).map(|i| gates[i].1)
}

/// The path's last point at or before `flight_us` into the flight.
fn path_at(path: &[PathPoint], flight_us: i64) -> Option<&PathPoint> {
    let after = path.partition_point(|p| (p.t_s * 1e6).round() as i64 <= flight_us);
    after.checked_sub(1).map(|i| &path[i])
}

/// Which way iNav's roll value `value_us` rolls: above its centre, right.
fn inav_roll(value_us: u16) -> InavRoll {
    let neutral_us = faithd_core::safety::rc::NEUTRAL_US;
    let sense = if value_us > neutral_us {
        RollDirection::Right
    } else {
        RollDirection::Left
    };
    let direction = (value_us != neutral_us).then_some(sense);
    InavRoll {
        value_us,
        direction,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faithd_core::safety::gate::Blocker;

    #[test]
    fn a_window_sees_the_gate_as_it_last_changed() {
        let closed = GateState::Closed(Blocker::NoHeartbeat);
        let gates = [(100, closed), (300, GateState::Open)];
        assert_eq!(gate_at(&gates, 50), None);
        assert_eq!(gate_at(&gates, 100), Some(closed));
        assert_eq!(gate_at(&gates, 299), Some(closed));
        assert_eq!(gate_at(&gates, 300), Some(GateState::Open));
    }

    #[test]
    fn the_roll_value_reads_as_a_direction_about_inavs_centre() {
        assert_eq!(inav_roll(1500).direction, None);
        assert_eq!(inav_roll(1800).direction, Some(RollDirection::Right));
        assert_eq!(inav_roll(1200).direction, Some(RollDirection::Left));
    }
}
