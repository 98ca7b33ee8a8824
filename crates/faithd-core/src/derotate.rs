//! Derotation: remove the image motion caused by the vehicle's own rotation.
//!
//! Only translation carries the FOE. The rotational part of the flow at normalised
//! image point (x, y) for camera angular rate (wx, wy, wz) is (paper, eq. 3):
//! `u_R = x*y*wx - (1 + x^2)*wy + y*wz`, `v_R = (1 + y^2)*wx - x*y*wy - x*wz`.
//! A normal flow vector only measures the flow's component along its own direction,
//! so we subtract the rotational flow's component along that direction; subtracting
//! the whole rotational vector would add motion along the edge that was never seen.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::invalid::{Invalid, check};

use crate::attitude::{AttitudeSample, body_rates_at, mean_body_rates};
use crate::camera::{CameraIntrinsics, Mounting};
use crate::flow::FlowVector;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DerotationConfig {
    /// Turn derotation off only for a camera on a gimbal that cancels rotation.
    pub enabled: bool,
    /// Vectors whose derotated speed falls below this are dropped: what is left is
    /// sensor noise, and its direction says nothing about the FOE.
    pub min_speed_px_s: f64,
    /// Camera tilt above the body x axis, degrees (positive = looking up).
    pub camera_pitch_up_deg: f64,
    /// The longest a sample is held beyond the attitude's span to cover a window
    /// (the first sample after the window's oldest vector, the last before its end):
    /// past it the window is not derotated. 100 ms is `gate.attitude_stale_us`, two
    /// and a half periods of iNav's 25 Hz ATTITUDE. 0: any hold (faithd before window
    /// log 4 held the nearest sample however far it was).
    pub max_hold_us: i64,
}

impl Default for DerotationConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            min_speed_px_s: 2.0,
            camera_pitch_up_deg: 0.0,
            max_hold_us: 100_000,
        }
    }
}

impl DerotationConfig {
    /// `[pipeline.derotation]`.
    pub fn validate(&self) -> Result<(), Invalid> {
        let d = self;
        check(
            d.min_speed_px_s >= 0.0,
            "pipeline.derotation.min_speed_px_s",
            || format!("must not be negative, got {}", d.min_speed_px_s),
        )?;
        check(
            d.camera_pitch_up_deg.abs() <= 60.0,
            "pipeline.derotation.camera_pitch_up_deg",
            || format!("must be within +-60 degrees, got {}", d.camera_pitch_up_deg),
        )?;
        check(
            (0..=10_000_000).contains(&d.max_hold_us),
            "pipeline.derotation.max_hold_us",
            || format!("must be 0 (any hold) to 10 s, got {}", d.max_hold_us),
        )?;
        Ok(())
    }
}

/// What derotation did to a window's vectors.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DerotationStats {
    pub vectors_in: usize,
    pub dropped_slow: usize,
    pub state: DerotationState,
}

/// Whether a window's flow had its rotation taken out, and if not, why.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DerotationState {
    /// Attitude that covers the window was subtracted.
    Applied,
    /// Switched off in the configuration (a camera on a gimbal that cancels rotation).
    Off,
    /// No attitude sample at all.
    #[default]
    NoAttitude,
    /// Samples, but none within `max_hold_us` of one end of the window's span.
    NotCovered,
}

impl DerotationState {
    /// Whether the flow may be used for the FOE and decisions: derotated, or needing
    /// no derotation by the configuration's word. Rotating flow would poison both.
    pub fn usable(self) -> bool {
        matches!(self, DerotationState::Applied | DerotationState::Off)
    }

    pub fn name(self) -> &'static str {
        match self {
            DerotationState::Applied => "applied",
            DerotationState::Off => "off",
            DerotationState::NoAttitude => "no_attitude",
            DerotationState::NotCovered => "not_covered",
        }
    }
}

/// Rotational flow at a pixel for angular rates in camera axes, pixels per second.
pub fn rotational_flow_px_s(
    camera: &CameraIntrinsics,
    x_px: f64,
    y_px: f64,
    rates_cam_rad_s: &Vector3<f64>,
) -> (f64, f64) {
    let (x, y) = camera.normalise(x_px, y_px);
    let (wx, wy, wz) = (rates_cam_rad_s.x, rates_cam_rad_s.y, rates_cam_rad_s.z);
    let u = x * y * wx - (1.0 + x * x) * wy + y * wz;
    let v = (1.0 + y * y) * wx - x * y * wy - x * wz;
    (u * camera.fx_px, v * camera.fy_px)
}

/// Derotates flow vectors with the body rates averaged over the time each vector's plane
/// fit spans (`fit_span_rates`).
pub struct Derotator {
    camera: CameraIntrinsics,
    mounting: Mounting,
    config: DerotationConfig,
}

impl Derotator {
    pub fn new(camera: CameraIntrinsics, config: DerotationConfig) -> Self {
        Self {
            camera,
            mounting: Mounting::forward_pitched_up(config.camera_pitch_up_deg),
            config,
        }
    }

    /// The translational normal flow of one vector, or `None` when nothing is left.
    pub fn derotate(&self, f: &FlowVector, body_rates_rad_s: Vector3<f64>) -> Option<FlowVector> {
        let (nx, ny) = f.direction()?;
        let rates_cam = self.mounting.rates_in_camera(body_rates_rad_s);
        let (ur, vr) = rotational_flow_px_s(&self.camera, f.x_px, f.y_px, &rates_cam);
        let speed = f.speed_px_s() - (ur * nx + vr * ny);
        if !speed.is_finite() || speed.abs() < self.config.min_speed_px_s {
            return None;
        }
        Some(FlowVector {
            u_px_s: speed * nx,
            v_px_s: speed * ny,
            ..*f
        })
    }

    /// Derotates `flow`, the vectors of the window that ends at `window_end_us`, in
    /// place, keeping the vectors that survive, in order. Without attitude that covers
    /// the window it leaves them as they are and says why.
    pub fn derotate_all(
        &self,
        flow: &mut Vec<FlowVector>,
        attitude: &[AttitudeSample],
        window_end_us: i64,
    ) -> DerotationStats {
        let vectors_in = flow.len();
        let state = self.coverage(flow, attitude, window_end_us);
        if state != DerotationState::Applied {
            return DerotationStats {
                vectors_in,
                dropped_slow: 0,
                state,
            };
        }
        flow.retain_mut(|f| {
            let rates = fit_span_rates(attitude, f).unwrap_or_else(Vector3::zeros);
            match self.derotate(f, rates) {
                Some(d) => {
                    *f = d;
                    true
                }
                None => false,
            }
        });
        DerotationStats {
            vectors_in,
            dropped_slow: vectors_in - flow.len(),
            state,
        }
    }

    /// Whether `attitude` covers the window: a sample no later than `max_hold_us`
    /// after its oldest vector (or its end, without vectors), and one no earlier than
    /// `max_hold_us` before its end. A sample held further would stand for rotation
    /// nobody measured: a log on another clock, or a link that went quiet.
    fn coverage(
        &self,
        flow: &[FlowVector],
        attitude: &[AttitudeSample],
        window_end_us: i64,
    ) -> DerotationState {
        if !self.config.enabled {
            return DerotationState::Off;
        }
        let (Some(first), Some(last)) = (attitude.first(), attitude.last()) else {
            return DerotationState::NoAttitude;
        };
        let hold_us = self.config.max_hold_us;
        if hold_us == 0 {
            return DerotationState::Applied;
        }
        let oldest_us = flow.iter().map(|f| f.t_us).min().unwrap_or(window_end_us);
        if first.t_us > oldest_us.saturating_add(hold_us)
            || last.t_us < window_end_us.saturating_sub(hold_us)
        {
            return DerotationState::NotCovered;
        }
        DerotationState::Applied
    }
}

/// The body rates to derotate `f` with: their mean over the time its plane fit spans,
/// `2 * fit_age_us` up to the event (centred on the fit's points), or the rates at the
/// event when the age is unknown.
///
/// A plane fit's flow is the edge's motion averaged over its points' times, tens of
/// milliseconds for the slow edges near the FOE, and the rotation in it is the mean
/// rotation of that span, not the rotation at the event. The mean also averages the
/// gyro's noise over the same span: on `faithd bench foe` (no rotation, so every bit
/// of derotation there is gyro noise and bias) FAITH's error fell from 3.85 to 3.80
/// degrees (seed 1) and 4.29 to 4.11 (seed 2). Half the span (the fit's mean time
/// alone) gave 3.89; the span to the oldest point 3.81 and 4.13.
fn fit_span_rates(attitude: &[AttitudeSample], f: &FlowVector) -> Option<Vector3<f64>> {
    let age_us = f64::from(f.fit_age_us);
    if age_us > 0.0 && age_us.is_finite() {
        let span_us = (2.0 * age_us).round() as i64;
        mean_body_rates(attitude, f.t_us.saturating_sub(span_us), f.t_us)
    } else {
        body_rates_at(attitude, f.t_us)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::{FlowFieldSpec, radial_normal_flow};

    #[test]
    fn yaw_right_moves_the_scene_left() {
        let cam = CameraIntrinsics::dvs240();
        let w = Mounting::forward().rates_in_camera(Vector3::new(0.0, 0.0, 0.5));
        let (u, v) = rotational_flow_px_s(&cam, cam.cx_px, cam.cy_px, &w);
        assert!((u + 0.5 * cam.fx_px).abs() < 1e-9 && v.abs() < 1e-9);
    }

    #[test]
    fn derotation_restores_the_translational_normal_flow() {
        let cam = CameraIntrinsics::dvs240();
        let der = Derotator::new(cam, DerotationConfig::default());
        let body_rates = Vector3::new(0.3, -0.2, 0.6);
        let rates_cam = Mounting::forward().rates_in_camera(body_rates);
        let spec = FlowFieldSpec::clean((100.0, 80.0), 300);
        let truth = radial_normal_flow(&cam, &spec, 4);
        let mut restored = 0;
        for t in &truth {
            // The camera sees translation + rotation, projected on the same edge normal.
            let (nx, ny) = t.direction().unwrap();
            let (ur, vr) = rotational_flow_px_s(&cam, t.x_px, t.y_px, &rates_cam);
            let seen = t.speed_px_s() + ur * nx + vr * ny;
            let observed = FlowVector::new(t.t_us, t.x_px, t.y_px, seen * nx, seen * ny);
            if let Some(d) = der.derotate(&observed, body_rates) {
                assert!((d.u_px_s - t.u_px_s).abs() < 1e-6 && (d.v_px_s - t.v_px_s).abs() < 1e-6);
                restored += 1;
            }
        }
        assert!(restored > 250, "{restored}");
    }

    /// A vector whose fit spans the last 40 ms loses the mean yaw of those 40 ms; one
    /// without a known age, the yaw at its instant.
    #[test]
    fn a_fit_is_derotated_with_the_rates_of_its_span() {
        let cam = CameraIntrinsics::dvs240();
        let der = Derotator::new(cam, DerotationConfig::default());
        // Yaw rate ramps from 0 at t = 0 to 1 rad/s at t = 100 ms.
        let yaw = |t_us: i64| AttitudeSample {
            t_us,
            yaw_rate_rad_s: t_us as f64 * 1e-5,
            ..Default::default()
        };
        let attitude = [yaw(0), yaw(100_000)];
        let aged = FlowVector {
            fit_age_us: 20_000.0,
            ..FlowVector::new(100_000, 60.0, 90.0, -400.0, 0.0)
        };
        let fresh = FlowVector::new(100_000, 60.0, 90.0, -400.0, 0.0);
        let mut flow = vec![aged, fresh];
        let stats = der.derotate_all(&mut flow, &attitude, 100_000);
        assert_eq!(stats.state, DerotationState::Applied);
        // The mean of the ramp over 60..100 ms is 0.8 rad/s; at 100 ms it is 1.
        let span = der.derotate(&aged, Vector3::new(0.0, 0.0, 0.8)).unwrap();
        let instant = der.derotate(&fresh, Vector3::new(0.0, 0.0, 1.0)).unwrap();
        assert!((flow[0].u_px_s - span.u_px_s).abs() < 1e-9, "{:?}", flow[0]);
        assert!(
            (flow[1].u_px_s - instant.u_px_s).abs() < 1e-9,
            "{:?}",
            flow[1]
        );
        assert!((span.u_px_s - instant.u_px_s).abs() > 10.0);
    }

    #[test]
    fn no_attitude_means_not_applied() {
        let cam = CameraIntrinsics::dvs240();
        let der = Derotator::new(cam, DerotationConfig::default());
        let mut flow = vec![FlowVector::new(0, 1.0, 1.0, 5.0, 0.0)];
        let stats = der.derotate_all(&mut flow, &[], 0);
        assert_eq!(stats.state, DerotationState::NoAttitude);
        assert!(!stats.state.usable());
        assert_eq!(flow.len(), 1);
    }

    /// Attitude on another clock, or one that stopped: the window is left rotating
    /// and says so, whatever the held sample would have subtracted.
    #[test]
    fn a_sample_held_beyond_max_hold_does_not_cover_the_window() {
        let cam = CameraIntrinsics::dvs240();
        let der = Derotator::new(cam, DerotationConfig::default());
        let yaw = |t_us: i64| AttitudeSample {
            t_us,
            yaw_rate_rad_s: 0.5,
            ..Default::default()
        };
        let vector = FlowVector::new(1_000_000, 60.0, 90.0, -400.0, 0.0);
        let state = |attitude: &[AttitudeSample]| {
            let mut flow = vec![vector];
            let stats = der.derotate_all(&mut flow, attitude, 1_005_000);
            (stats.state, flow[0] == vector)
        };
        let covering = [yaw(980_000), yaw(1_000_000)];
        assert_eq!(state(&covering), (DerotationState::Applied, false));
        let later = [yaw(1_000_000_000), yaw(1_000_020_000)];
        assert_eq!(state(&later), (DerotationState::NotCovered, true));
        let stopped = [yaw(800_000), yaw(900_000)];
        assert_eq!(state(&stopped), (DerotationState::NotCovered, true));
        // Within the hold at both ends.
        let edges = [yaw(1_090_000), yaw(1_095_000)];
        assert_eq!(state(&edges).0, DerotationState::Applied);

        let any_hold = Derotator::new(
            cam,
            DerotationConfig {
                max_hold_us: 0,
                ..DerotationConfig::default()
            },
        );
        let mut flow = vec![vector];
        let stats = any_hold.derotate_all(&mut flow, &later, 1_005_000);
        assert_eq!(stats.state, DerotationState::Applied);

        let off = Derotator::new(
            cam,
            DerotationConfig {
                enabled: false,
                ..DerotationConfig::default()
            },
        );
        let stats = off.derotate_all(&mut flow, &[], 1_005_000);
        assert_eq!(stats.state, DerotationState::Off);
        assert!(stats.state.usable());
    }
}
