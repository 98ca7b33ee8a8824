//! The scripted pilot: what a person does with the sticks in ANGLE mode to fly a
//! course at a pole, looking at the true state as a person looks at the drone.
//! Throttle holds the height, the pitch stick holds the speed along the course, the
//! roll stick keeps the course line until the switch goes to AUTO (then iNav takes
//! roll from faithd alone, msp_override_channels = 1), yaw stays centred (iNav holds
//! the heading). Updated every 10 ms, as a hand is slower than the radio.

use super::course::{Course, HEIGHT_M};
use crate::closed_loop::FlightSpec;
use faithd_inav::msp::{Setup, rc_command};
use faithd_sim::world::quad_x::{G_M_S2, QuadX, QuadXConfig};

/// Stick update period, seconds.
const DT_S: f64 = 0.01;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Take-off and hover at the cruise height over the take-off point.
    Climb,
    /// Along the course at the spec's speed.
    Cruise,
}

/// The sticks and the switch, microseconds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sticks {
    pub throttle_us: u16,
    pub pitch_us: u16,
    pub roll_us: u16,
    pub auto: bool,
}

pub struct Pilot {
    spec: FlightSpec,
    course: Course,
    pub phase: Phase,
    height_integral: f64,
    speed_integral: f64,
    /// Daemon time the hover has been steady since.
    steady_since_us: Option<i64>,
    /// Daemon time the vehicle reached the model's start point at speed.
    pub start_us: Option<i64>,
    /// Where the pitch stick sits at the cruise speed: a pilot knows roughly how
    /// far forward to hold it (the nose down enough that the thrust's push matches
    /// the drag, through iNav's expo).
    cruise_stick_us: f64,
}

impl Pilot {
    pub fn new(spec: &FlightSpec, course: Course) -> Self {
        Self {
            spec: spec.clone(),
            course,
            phase: Phase::Climb,
            height_integral: 0.0,
            speed_integral: 0.0,
            steady_since_us: None,
            start_us: None,
            cruise_stick_us: cruise_stick_us(spec.speed_m_s),
        }
    }

    pub fn step(&mut self, quad: &QuadX, now_us: i64) -> Sticks {
        let throttle_us = self.throttle(quad);
        let (pitch_us, roll_us) = match self.phase {
            Phase::Climb => {
                self.climb_done(quad, now_us);
                (1500, self.keep_line(quad))
            }
            Phase::Cruise => {
                if self.start_us.is_none()
                    && self.course.to_go_m(&quad.position_m) <= self.spec.start_distance_m
                {
                    self.start_us = Some(now_us);
                }
                let roll_us = if self.auto(now_us) {
                    1500
                } else {
                    self.keep_line(quad)
                };
                (self.pitch(quad), roll_us)
            }
        };
        Sticks {
            throttle_us,
            pitch_us,
            roll_us,
            auto: self.auto(now_us),
        }
    }

    fn auto(&self, now_us: i64) -> bool {
        self.spec.pilot_auto
            && self
                .start_us
                .is_some_and(|t0| (now_us - t0) as f64 * 1e-6 >= self.spec.auto_at_s)
    }

    /// Height by throttle: hover is near mid-stick on this airframe.
    fn throttle(&mut self, quad: &QuadX) -> u16 {
        let height_m = -quad.position_m.z;
        let climb_m_s = -quad.velocity_m_s.z;
        let error_m = HEIGHT_M - height_m;
        self.height_integral = (self.height_integral + error_m * DT_S).clamp(-5.0, 5.0);
        let throttle = 1500.0 + 120.0 * error_m + 40.0 * self.height_integral - 150.0 * climb_m_s;
        throttle.clamp(1150.0, 1850.0) as u16
    }

    /// Hovering steady at the height for a second: off along the course.
    fn climb_done(&mut self, quad: &QuadX, now_us: i64) {
        let steady = (-quad.position_m.z - HEIGHT_M).abs() < 0.15 && quad.velocity_m_s.norm() < 0.3;
        match (steady, self.steady_since_us) {
            (true, None) => self.steady_since_us = Some(now_us),
            (false, _) => self.steady_since_us = None,
            (true, Some(t)) if now_us - t > 1_000_000 => self.phase = Phase::Cruise,
            _ => {}
        }
    }

    /// Speed along the course by pitch (stick forward, above 1500, is nose down).
    fn pitch(&mut self, quad: &QuadX) -> u16 {
        let speed_m_s = quad.velocity_m_s.dot(&self.course.forward);
        let error = self.spec.speed_m_s - speed_m_s;
        // The hand settles the speed it holds only once near it (no wind-up while
        // it accelerates from the hover).
        if error.abs() < 0.3 {
            self.speed_integral = (self.speed_integral + error * DT_S).clamp(-3.0, 3.0);
        }
        let pitch = 1500.0 + self.cruise_stick_us + 100.0 * error + 80.0 * self.speed_integral;
        pitch.clamp(1250.0, 1750.0) as u16
    }

    /// The course line by roll (right stick moves right).
    fn keep_line(&self, quad: &QuadX) -> u16 {
        let off_m = self.course.off_track_m(&quad.position_m);
        let drift_m_s = quad.velocity_m_s.dot(&self.course.right);
        let roll = 1500.0 - 100.0 * off_m - 120.0 * drift_m_s;
        roll.clamp(1400.0, 1600.0) as u16
    }
}

/// The pitch stick (us from centre) whose angle in iNav's ANGLE mode holds
/// `speed_m_s` against the quad-X's drag, through iNav's stick chain
/// (`faithd_inav::msp::rc_command`; the pitch axis has the roll's defaults).
fn cruise_stick_us(speed_m_s: f64) -> f64 {
    let quad = QuadXConfig::default();
    let drag_m_s2 = quad.rotor_drag_per_s * speed_m_s
        + quad.drag_n_per_m2_s2 * speed_m_s * speed_m_s / quad.mass_kg;
    let pitch_deg = (drag_m_s2 / G_M_S2).atan().to_degrees();
    let setup = Setup::default();
    let max_deg = f64::from(setup.max_angle_inclination_rll_ddeg) / 10.0;
    (0..=500u16)
        .find(|d| rc_command(&setup, 1500 + d) / 500.0 * max_deg >= pitch_deg)
        .map_or(500.0, f64::from)
}
