//! A quadrotor flying straight at constant speed and height whose lateral motion
//! answers a bank target as iNav's ANGLE mode makes a small drone answer it (the
//! target is iNav's, from the roll stick: `faithd_inav::msp::InavMsp::roll_target`):
//! the bank follows through the rate loop and the angle loop (two first-order lags
//! fitted to iNav 9.1's SITL flying faithd-lab's quad-X), the bank
//! tilts the thrust sideways (g tan(bank)), and the quad-X's rotor and air drag
//! oppose the lateral speed.
//! Pure: stepped with an explicit time step.

use nalgebra::{Rotation3, Vector3};

use super::trajectory::VehicleState;

const G_M_S2: f64 = 9.81;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadConfig {
    /// Forward speed along the heading, m/s.
    pub speed_m_s: f64,
    /// Time constant of the bank toward its target. iNav's ANGLE asks a rate of
    /// mc_p_level / 6.56 per second of angle error (flight/pid.c:702, pid.h:46: 20
    /// gives 3.05/s, 0.33 s); iNav's SITL flying the quad-X follows 0.30 s.
    pub bank_lag_s: f64,
    /// The rate loop and the motors before the bank follows: 0.02 s, fitted with
    /// `bank_lag_s` to SITL (5 degrees after 150 ms, 90 % after 720 ms, on iNav's
    /// 14.85 degree target for +300 us).
    pub rate_lag_s: f64,
    /// Rotor drag on the lateral speed, 1/s, and air drag per metre of the
    /// airspeed times the lateral speed: those of the quad-X iNav's SITL flies
    /// (`quad_x::QuadXConfig`: 0.3/s, and 0.03 N/(m/s)^2 on 0.6 kg).
    pub rotor_drag_per_s: f64,
    pub air_drag_per_m: f64,
}

impl Default for QuadConfig {
    fn default() -> Self {
        Self {
            speed_m_s: 2.0,
            bank_lag_s: 0.30,
            rate_lag_s: 0.02,
            rotor_drag_per_s: 0.3,
            air_drag_per_m: 0.05,
        }
    }
}

/// Lateral state in the frame of the initial course: x ahead, y to the right, z down.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quad {
    pub config: QuadConfig,
    pub t_s: f64,
    /// Position, metres (world NED, x north).
    pub position_m: Vector3<f64>,
    /// Heading, radians from north.
    pub heading_rad: f64,
    /// Speed to the right of the heading, m/s.
    pub lateral_m_s: f64,
    pub bank_rad: f64,
    pub bank_rate_rad_s: f64,
    /// The rate loop's stage: where the bank is being driven, radians.
    pub driven_rad: f64,
}

impl Quad {
    pub fn new(config: QuadConfig, position_m: Vector3<f64>, heading_rad: f64) -> Self {
        Self {
            config,
            t_s: 0.0,
            position_m,
            heading_rad,
            lateral_m_s: 0.0,
            bank_rad: 0.0,
            bank_rate_rad_s: 0.0,
            driven_rad: 0.0,
        }
    }

    /// Advances by `dt_s` toward a bank of `target_rad` (right positive).
    pub fn step(&mut self, target_rad: f64, dt_s: f64) {
        let c = &self.config;
        let target = target_rad;
        let rate_alpha = (dt_s / c.rate_lag_s.max(1e-3)).min(1.0);
        self.driven_rad += rate_alpha * (target - self.driven_rad);
        let alpha = (dt_s / c.bank_lag_s.max(1e-3)).min(1.0);
        let new_bank = self.bank_rad + alpha * (self.driven_rad - self.bank_rad);
        self.bank_rate_rad_s = (new_bank - self.bank_rad) / dt_s;
        self.bank_rad = new_bank;
        let airspeed_m_s = c.speed_m_s.hypot(self.lateral_m_s);
        let drag_per_s = c.rotor_drag_per_s + c.air_drag_per_m * airspeed_m_s;
        let accel = G_M_S2 * self.bank_rad.tan() - drag_per_s * self.lateral_m_s;
        self.lateral_m_s += accel * dt_s;
        let (s, co) = self.heading_rad.sin_cos();
        let forward = Vector3::new(co, s, 0.0);
        let right = Vector3::new(-s, co, 0.0);
        self.position_m += (forward * c.speed_m_s + right * self.lateral_m_s) * dt_s;
        self.t_s += dt_s;
    }

    /// The state the camera and the autopilot's ATTITUDE report see.
    pub fn state(&self) -> VehicleState {
        let (s, co) = self.heading_rad.sin_cos();
        let velocity = Vector3::new(co, s, 0.0) * self.config.speed_m_s
            + Vector3::new(-s, co, 0.0) * self.lateral_m_s;
        VehicleState {
            t_s: self.t_s,
            position_m: self.position_m,
            velocity_m_s: velocity,
            attitude: Rotation3::from_euler_angles(self.bank_rad, 0.0, self.heading_rad),
            body_rates_rad_s: Vector3::new(self.bank_rate_rad_s, 0.0, 0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centred_stick_flies_straight() {
        let mut q = Quad::new(QuadConfig::default(), Vector3::zeros(), 0.0);
        for _ in 0..1000 {
            q.step(0.0, 0.001);
        }
        assert!((q.position_m.x - 2.0).abs() < 1e-9);
        assert_eq!(q.position_m.y, 0.0);
    }

    #[test]
    fn a_bank_target_is_reached_as_inav_reached_it_and_moves_right() {
        let mut q = Quad::new(QuadConfig::default(), Vector3::zeros(), 0.0);
        let mut banks = Vec::new();
        // iNav's target for faithd's 300 us (faithd_inav::msp::rc_command).
        let target_rad = 14.85f64.to_radians();
        for _ in 0..1500 {
            q.step(target_rad, 0.001);
            banks.push(q.bank_rad.to_degrees());
        }
        // iNav's SITL on the quad-X, from the roll at its mixer: 5 degrees after
        // 140-151 ms, 90 % of the peak the roll reached after 706-721 ms.
        let ms_to = |deg: f64| banks.iter().position(|b| *b >= deg).unwrap() + 1;
        let peak = banks.iter().copied().fold(0.0, f64::max);
        assert!((130..=165).contains(&ms_to(5.0)), "{}", ms_to(5.0));
        let to_90 = ms_to(0.9 * peak);
        assert!((680..=740).contains(&to_90), "{to_90}");
        // 1.5 s of roll: most of a metre to the right (+y).
        assert!(q.position_m.y > 0.6, "{}", q.position_m.y);
        assert!(q.state().body_rates_rad_s.x.abs() < 0.05, "settled bank");
    }
}
