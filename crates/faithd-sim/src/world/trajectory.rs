//! Vehicle trajectories: straight or swaying flights, with optional rotation.

use nalgebra::{Rotation3, Vector3};

use faithd_core::attitude::AttitudeSample;
use faithd_core::camera::{CameraIntrinsics, Mounting};

/// A flight through a scene, in world axes (x forward, y right, z down).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Trajectory {
    pub start_m: [f64; 3],
    /// Body yaw at t = 0, degrees (0 = along world x).
    pub heading_deg: f64,
    /// Direction of travel relative to the heading, degrees to the right: the course
    /// angle that puts the FOE left or right of the image centre.
    pub course_deg: f64,
    /// Direction of travel above the horizontal, degrees.
    pub climb_deg: f64,
    pub speed_m_s: f64,
    /// Amplitude of a sideways velocity oscillation, m/s (0 = straight flight).
    pub sway_m_s: f64,
    pub sway_hz: f64,
    /// Amplitude and frequency of a yaw oscillation (rotation for derotation to undo).
    pub yaw_amp_deg: f64,
    pub yaw_hz: f64,
    /// Amplitude and frequency of a pitch oscillation.
    pub pitch_amp_deg: f64,
    pub pitch_hz: f64,
}

impl Trajectory {
    /// A level straight flight from `start_m` at `speed_m_s`.
    pub fn straight(start_m: [f64; 3], heading_deg: f64, course_deg: f64, speed_m_s: f64) -> Self {
        Self {
            start_m,
            heading_deg,
            course_deg,
            climb_deg: 0.0,
            speed_m_s,
            sway_m_s: 0.0,
            sway_hz: 0.0,
            yaw_amp_deg: 0.0,
            yaw_hz: 0.0,
            pitch_amp_deg: 0.0,
            pitch_hz: 0.0,
        }
    }
}

/// Where the vehicle is and how it moves at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VehicleState {
    pub t_s: f64,
    pub position_m: Vector3<f64>,
    pub velocity_m_s: Vector3<f64>,
    /// Body to world rotation.
    pub attitude: Rotation3<f64>,
    /// FRD body rates, rad/s.
    pub body_rates_rad_s: Vector3<f64>,
}

impl VehicleState {
    /// The true FOE in pixels: the velocity direction projected into the camera.
    /// `None` when the vehicle moves away from where the camera looks (or hovers).
    pub fn true_foe_px(
        &self,
        camera: &CameraIntrinsics,
        mounting: &Mounting,
    ) -> Option<(f64, f64)> {
        let v_body = self.attitude.inverse() * self.velocity_m_s;
        camera.project(&(mounting.body_to_camera * v_body))
    }

    /// Yaw, pitch, roll in radians (ZYX convention, as MAVLink ATTITUDE).
    pub fn euler_rad(&self) -> (f64, f64, f64) {
        let (roll, pitch, yaw) = self.attitude.euler_angles();
        (yaw, pitch, roll)
    }

    pub fn attitude_sample(&self, t_us: i64) -> AttitudeSample {
        let (yaw, pitch, roll) = self.euler_rad();
        AttitudeSample {
            t_us,
            roll_rad: roll,
            pitch_rad: pitch,
            yaw_rad: yaw,
            roll_rate_rad_s: self.body_rates_rad_s.x,
            pitch_rate_rad_s: self.body_rates_rad_s.y,
            yaw_rate_rad_s: self.body_rates_rad_s.z,
        }
    }
}

impl Trajectory {
    fn course_axes(&self) -> (Vector3<f64>, Vector3<f64>) {
        let az = (self.heading_deg + self.course_deg).to_radians();
        let el = self.climb_deg.to_radians();
        let dir = Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), -el.sin());
        let lateral = Vector3::new(-az.sin(), az.cos(), 0.0);
        (dir, lateral)
    }

    /// The state at time `t_s` from the start, in closed form.
    pub fn state(&self, t_s: f64) -> VehicleState {
        let tau = std::f64::consts::TAU;
        let (dir, lateral) = self.course_axes();
        let start = Vector3::from(self.start_m);
        let (sway_v, sway_p) = if self.sway_hz > 0.0 {
            let w = tau * self.sway_hz;
            (
                self.sway_m_s * (w * t_s).sin(),
                self.sway_m_s * (1.0 - (w * t_s).cos()) / w,
            )
        } else {
            (0.0, 0.0)
        };
        let position_m = start + dir * (self.speed_m_s * t_s) + lateral * sway_p;
        let velocity_m_s = dir * self.speed_m_s + lateral * sway_v;

        let (yaw_off, yaw_rate) = oscillation(self.yaw_amp_deg.to_radians(), self.yaw_hz, t_s);
        let (pitch, pitch_rate) = oscillation(self.pitch_amp_deg.to_radians(), self.pitch_hz, t_s);
        let yaw = self.heading_deg.to_radians() + yaw_off;
        let attitude = Rotation3::from_euler_angles(0.0, pitch, yaw);
        // ZYX Euler rates to FRD body rates, with zero roll.
        let body_rates_rad_s =
            Vector3::new(-yaw_rate * pitch.sin(), pitch_rate, yaw_rate * pitch.cos());
        VehicleState {
            t_s,
            position_m,
            velocity_m_s,
            attitude,
            body_rates_rad_s,
        }
    }
}

/// `amp * sin(2 pi f t)` and its derivative.
fn oscillation(amp: f64, hz: f64, t_s: f64) -> (f64, f64) {
    if hz <= 0.0 || amp == 0.0 {
        return (0.0, 0.0);
    }
    let w = std::f64::consts::TAU * hz;
    (amp * (w * t_s).sin(), amp * w * (w * t_s).cos())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn course_angle_puts_the_foe_at_that_angle() {
        let cam = CameraIntrinsics::dvs240();
        let m = Mounting::forward();
        for course in [-30.0f64, -10.0, 0.0, 20.0] {
            let s = Trajectory::straight([0.0, 0.0, -1.2], 15.0, course, 2.0).state(0.3);
            let (x, y) = s.true_foe_px(&cam, &m).unwrap();
            let expect_x = cam.cx_px + cam.fx_px * course.to_radians().tan();
            assert!(
                (x - expect_x).abs() < 1e-6 && (y - cam.cy_px).abs() < 1e-6,
                "{x} {y}"
            );
        }
    }

    #[test]
    fn ground_truth_foe_is_the_projected_velocity_under_rotation() {
        let cam = CameraIntrinsics::dvs240();
        let m = Mounting::forward();
        let mut t = Trajectory::straight([0.0, 0.0, -1.2], 0.0, 0.0, 2.0);
        t.yaw_amp_deg = 10.0;
        t.yaw_hz = 1.0;
        let s = t.state(0.25); // yaw at its +10 degree peak
        let (x, _) = s.true_foe_px(&cam, &m).unwrap();
        // Nose 10 degrees right of the course: the FOE appears 10 degrees left.
        let expect_x = cam.cx_px - cam.fx_px * 10f64.to_radians().tan();
        assert!((x - expect_x).abs() < 1e-6, "{x} vs {expect_x}");
        assert!(s.body_rates_rad_s.z.abs() < 1e-9);
        let s0 = t.state(0.0);
        assert!((s0.body_rates_rad_s.z - 10f64.to_radians() * std::f64::consts::TAU).abs() < 1e-9);
    }

    #[test]
    fn sway_moves_the_foe_during_the_run() {
        let cam = CameraIntrinsics::dvs240();
        let m = Mounting::forward();
        let mut t = Trajectory::straight([0.0, 0.0, -1.2], 0.0, 0.0, 2.0);
        t.sway_m_s = 0.6;
        t.sway_hz = 1.0;
        let a = t.state(0.0).true_foe_px(&cam, &m).unwrap();
        let b = t.state(0.25).true_foe_px(&cam, &m).unwrap();
        assert!((b.0 - a.0) > 40.0, "{a:?} {b:?}");
        // Position is the integral of velocity.
        let dt = 1e-4;
        let num = (t.state(0.3 + dt).position_m - t.state(0.3).position_m) / dt;
        assert!((num - t.state(0.3).velocity_m_s).norm() < 1e-3);
    }
}
