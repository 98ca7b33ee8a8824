//! `faithd sim --straight`: the experiment's flights flown straight, without the
//! daemon and faster than real time, to see where the decision rule would roll.
//!
//! The closed loop takes about 4 s of wall time per flight; this takes a few
//! milliseconds of camera per window, so 100 flights run in seconds and a rule can be
//! judged over many seeds. It is a proxy: no safety gate beyond the pilot's switch
//! time, no MAVLink, and the vehicle never rolls, so a collision course counts as
//! avoided when the first roll came at a true TTC of at least [`IN_TIME_S`] (the
//! closed loop clears the pole from there: iNav's 14.85 degrees of bank for faithd's
//! 300 us, reached as iNav's SITL reaches it, moves the vehicle the 0.4 m it needs
//! in about 0.83 s, and the roll is in effect at iNav some 50 ms after the event).

use serde::Serialize;

use super::FlightSpec;
use super::camera::{FlightCamera, arena};
use super::physics::{clearance_m, initial_quad};
use faithd_core::decide::{Action, Decision};
use faithd_core::pipeline::{NoClock, Pipeline, PipelineConfig};

/// A roll decided at a true TTC below this is too late to clear the pole.
pub const IN_TIME_S: f64 = 0.9;

/// Decision period, as the daemon's pipeline thread runs it.
const WINDOW_US: i64 = 10_000;
/// Autopilot ATTITUDE period.
const ATTITUDE_US: i64 = 20_000;
/// Physics and camera step.
const STEP_US: i64 = super::physics::STEP_US;

/// The first roll of a straight flight.
#[derive(Clone, Debug, Serialize)]
pub struct StraightRoll {
    /// Flight time of the deciding window, seconds.
    pub t_s: f64,
    /// True time to contact with the first pole then (negative: already passed).
    pub true_ttc_s: f64,
    pub decision: Decision,
}

#[derive(Clone, Debug, Serialize)]
pub struct StraightOutcome {
    pub spec: FlightSpec,
    pub collision_course: bool,
    pub roll: Option<StraightRoll>,
}

impl StraightOutcome {
    /// A collision course rolled on in time.
    pub fn avoided(&self) -> bool {
        self.collision_course
            && self
                .roll
                .as_ref()
                .is_some_and(|r| r.true_ttc_s >= IN_TIME_S)
    }
}

/// Flies `spec` straight to 1 m past its first pole (or contact) and returns the first
/// window, after the pilot's switch goes to AUTO, that decided to roll.
pub fn fly_straight(spec: &FlightSpec, config: &PipelineConfig) -> StraightOutcome {
    let mut quad = initial_quad(spec);
    let arena = arena(spec);
    let mut camera = FlightCamera::new(spec);
    let mut pipeline = Pipeline::new(*config);
    let (mut pending, mut attitude) = (Vec::new(), Vec::new());
    // Start the clock at 1 s so no timestamp is negative or zero.
    let start_us: i64 = 1_000_000;
    let auto_us = start_us + (spec.auto_at_s * 1e6) as i64;
    let mut t_us = start_us;
    camera.step(&quad.state(), t_us, &mut pending);
    pending.clear();
    let end_x_m = spec.end_x_m();
    let mut roll = None;
    while roll.is_none() {
        t_us += STEP_US;
        quad.step(0.0, STEP_US as f64 * 1e-6);
        let state = quad.state();
        camera.step(&state, t_us, &mut pending);
        if t_us % ATTITUDE_US == 0 {
            attitude.push(state.attitude_sample(t_us));
        }
        if clearance_m(&arena, &quad.position_m) < 0.0 || quad.position_m.x > end_x_m {
            break;
        }
        if t_us % WINDOW_US != 0 {
            continue;
        }
        let take = faithd_core::window::events_until(&pending, t_us);
        let decision = pipeline
            .process_window(&pending[..take], &attitude, t_us, &mut NoClock)
            .decision;
        pending.drain(..take);
        let gate_open = spec.pilot_auto && t_us >= auto_us;
        if gate_open && matches!(decision.action, Action::Roll { .. }) {
            roll = Some(StraightRoll {
                t_s: (t_us - start_us) as f64 * 1e-6,
                true_ttc_s: spec.true_ttc_s(quad.position_m.x),
                decision,
            });
        }
    }
    StraightOutcome {
        spec: spec.clone(),
        collision_course: spec.is_collision_course(),
        roll,
    }
}

/// Flies every spec on `threads` threads; outcomes in spec order.
pub fn fly_all(
    specs: &[FlightSpec],
    config: &PipelineConfig,
    threads: usize,
) -> Vec<StraightOutcome> {
    let threads = threads.max(1);
    let mut slots: Vec<Option<StraightOutcome>> = vec![None; specs.len()];
    std::thread::scope(|s| {
        let workers: Vec<_> = (0..threads)
            .map(|w| {
                s.spawn(move || {
                    (w..specs.len())
                        .step_by(threads)
                        .map(|i| (i, fly_straight(&specs[i], config)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for worker in workers {
            for (i, outcome) in worker.join().expect("straight flight thread") {
                slots[i] = Some(outcome);
            }
        }
    });
    slots
        .into_iter()
        .map(|o| o.expect("every flight flown"))
        .collect()
}

/// Figures of a straight-flight run.
#[derive(Clone, Debug, Serialize)]
pub struct StraightSummary {
    pub runs: usize,
    pub seed: u64,
    pub collision_courses: usize,
    /// Rolled at a true TTC of at least [`IN_TIME_S`].
    pub avoided: usize,
    /// Rolled, but later than that.
    pub late: usize,
    pub no_roll: usize,
    pub near_passes: usize,
    pub false_avoidances: usize,
}

pub fn summarise(outcomes: &[StraightOutcome], seed: u64) -> StraightSummary {
    let (collision, near): (Vec<_>, Vec<_>) = outcomes.iter().partition(|o| o.collision_course);
    let avoided = collision.iter().filter(|o| o.avoided()).count();
    let no_roll = collision.iter().filter(|o| o.roll.is_none()).count();
    StraightSummary {
        runs: outcomes.len(),
        seed,
        collision_courses: collision.len(),
        avoided,
        late: collision.len() - avoided - no_roll,
        no_roll,
        near_passes: near.len(),
        false_avoidances: near.iter().filter(|o| o.roll.is_some()).count(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straight_flights_roll_at_a_pole_ahead_and_not_at_one_passed_wide() {
        let config = PipelineConfig::default();
        let ahead = fly_straight(&FlightSpec::default(), &config);
        let roll = ahead.roll.as_ref().expect("rolled at the pole ahead");
        assert!(ahead.avoided(), "rolled too late: {:.2} s", roll.true_ttc_s);
        let wide = FlightSpec {
            lateral_offset_m: 1.2,
            ..FlightSpec::default()
        };
        let passed = fly_straight(&wide, &config);
        assert!(
            passed.roll.is_none(),
            "rolled on a wide pass: {:?}",
            passed.roll
        );
        let manual = FlightSpec {
            pilot_auto: false,
            ..FlightSpec::default()
        };
        assert!(fly_straight(&manual, &config).roll.is_none());
        let s = summarise(&[ahead, passed], 7);
        assert_eq!(
            (s.avoided, s.late, s.no_roll, s.false_avoidances),
            (1, 0, 0, 0)
        );
    }
}
