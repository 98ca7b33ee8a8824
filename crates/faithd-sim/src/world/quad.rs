//! A quadrotor flying straight at constant speed and height whose lateral motion
//! answers the roll stick, as a small drone in iNav's ANGLE mode does: the stick sets
//! a bank angle (up to `max_bank_deg`), the attitude follows with a first-order lag,
//! the bank tilts the thrust sideways (g tan(bank)), and air drag opposes the
//! lateral speed. Pure: stepped with an explicit time step.

use nalgebra::{Rotation3, Vector3};

use super::trajectory::VehicleState;

const G_M_S2: f64 = 9.81;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadConfig {
    /// Forward speed along the heading, m/s.
    pub speed_m_s: f64,
    /// Bank angle at full stick (iNav's max_angle_inclination_rll), degrees.
    pub max_bank_deg: f64,
    /// Time constant of the attitude response to the stick, seconds.
    pub bank_lag_s: f64,
    /// Linear drag on lateral speed, 1/s.
    pub drag_per_s: f64,
}

impl Default for QuadConfig {
    fn default() -> Self {
        Self {
            speed_m_s: 2.0,
            max_bank_deg: 30.0,
            bank_lag_s: 0.15,
            drag_per_s: 1.0,
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
        }
    }

    /// Advances by `dt_s` with the roll stick at `roll_us` (1500 = centre).
    pub fn step(&mut self, roll_us: u16, dt_s: f64) {
        let c = &self.config;
        let stick = ((f64::from(roll_us) - 1500.0) / 500.0).clamp(-1.0, 1.0);
        let target = stick * c.max_bank_deg.to_radians();
        let alpha = (dt_s / c.bank_lag_s.max(1e-3)).min(1.0);
        let new_bank = self.bank_rad + alpha * (target - self.bank_rad);
        self.bank_rate_rad_s = (new_bank - self.bank_rad) / dt_s;
        self.bank_rad = new_bank;
        let accel = G_M_S2 * self.bank_rad.tan() - c.drag_per_s * self.lateral_m_s;
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
            q.step(1500, 0.001);
        }
        assert!((q.position_m.x - 2.0).abs() < 1e-9);
        assert_eq!(q.position_m.y, 0.0);
    }

    #[test]
    fn right_stick_banks_with_lag_and_moves_right() {
        let mut q = Quad::new(QuadConfig::default(), Vector3::zeros(), 0.0);
        for _ in 0..150 {
            q.step(1800, 0.001);
        }
        // After one time constant the bank is ~63% of the 18 degrees commanded.
        let bank_deg = q.bank_rad.to_degrees();
        assert!((10.5..12.5).contains(&bank_deg), "{bank_deg}");
        for _ in 150..1500 {
            q.step(1800, 0.001);
        }
        // 1.5 s of roll: a lateral displacement of over a metre, to the right (+y).
        assert!(q.position_m.y > 1.0, "{}", q.position_m.y);
        assert!(q.state().body_rates_rad_s.x.abs() < 0.05, "settled bank");
    }
}
