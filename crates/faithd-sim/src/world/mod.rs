//! The built-in event-camera simulator: a DVS240 flying through textured 3D scenes.
//!
//! What ESIM did for the paper's benchmark, with no ROS, GPU or download: a pinhole
//! camera moves along a trajectory, the scene is ray-cast at a fixed rate, and every
//! pixel's log intensity, interpolated linearly between renders, fires events at
//! contrast-threshold crossings (with threshold mismatch, refractory period,
//! background noise and timestamp jitter). An IMU stream with noise and bias and the
//! ground-truth FOE come with the events. Everything is seeded.

pub mod attitude_link;
pub mod dvs;
pub mod line_camera;
pub mod quad;
pub mod quad_x;
pub mod scene;
pub mod scenes;
pub mod texture;
pub mod trajectory;

pub use attitude_link::AttitudeLink;
pub use dvs::{DvsConfig, EventCamera, render_interval_us};
pub use scene::Scene;
pub use scenes::SceneKind;
pub use trajectory::{Trajectory, VehicleState};

use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};

use faithd_core::attitude::AttitudeSample;
use faithd_core::camera::{CameraIntrinsics, Mounting};
use faithd_core::event::Event;

/// The gyro of the simulated autopilot.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ImuConfig {
    pub rate_hz: f64,
    /// White noise on each body rate, rad/s.
    pub gyro_noise_rad_s: f64,
    /// Constant bias per axis drawn from +-this, rad/s.
    pub gyro_bias_rad_s: f64,
}

impl Default for ImuConfig {
    fn default() -> Self {
        Self {
            rate_hz: 100.0,
            gyro_noise_rad_s: 0.01,
            gyro_bias_rad_s: 0.005,
        }
    }
}

/// Ground truth at one render instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Truth {
    pub t_us: i64,
    pub foe_px: Option<(f64, f64)>,
}

/// One simulated flight: everything the pipeline sees, and the truth.
pub struct SimRun {
    pub events: Vec<Event>,
    pub attitude: Vec<AttitudeSample>,
    pub truth: Vec<Truth>,
}

impl SimRun {
    /// The true FOE nearest in time to `t_us`.
    pub fn truth_at(&self, t_us: i64) -> Option<(f64, f64)> {
        let i = self.truth.partition_point(|t| t.t_us < t_us);
        let candidates = [i.checked_sub(1), Some(i)];
        candidates
            .into_iter()
            .flatten()
            .filter_map(|k| self.truth.get(k))
            .min_by_key(|t| (t.t_us - t_us).abs())
            .and_then(|t| t.foe_px)
    }
}

/// Flies `trajectory` through `scene` for `duration_s`.
pub fn simulate(
    scene: &Scene,
    trajectory: &Trajectory,
    camera: CameraIntrinsics,
    dvs: DvsConfig,
    imu: ImuConfig,
    duration_s: f64,
    seed: u64,
) -> SimRun {
    let mounting = Mounting::forward();
    let mut cam = EventCamera::new(camera, mounting, dvs, seed);
    let mut events = Vec::new();
    let mut truth = Vec::new();
    let step_us = (1e6 / dvs.render_rate_hz.max(1.0)).round().max(1.0) as i64;
    let end_us = (duration_s * 1e6) as i64;
    let mut t_us = 0;
    while t_us <= end_us {
        let state = trajectory.state(t_us as f64 * 1e-6);
        cam.advance(scene, &state, t_us, &mut events);
        truth.push(Truth {
            t_us,
            foe_px: state.true_foe_px(&camera, &mounting),
        });
        t_us += step_us;
    }
    let attitude = imu_samples(trajectory, imu, end_us, seed ^ 0x1bad_b002);
    SimRun {
        events,
        attitude,
        truth,
    }
}

/// Attitude reports with gyro noise and bias, as the autopilot would send them.
pub fn imu_samples(
    trajectory: &Trajectory,
    imu: ImuConfig,
    end_us: i64,
    seed: u64,
) -> Vec<AttitudeSample> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let noise = Normal::new(0.0, imu.gyro_noise_rad_s.max(0.0)).expect("finite");
    let b = imu.gyro_bias_rad_s.abs();
    let bias: [f64; 3] = if b > 0.0 {
        [
            rng.random_range(-b..=b),
            rng.random_range(-b..=b),
            rng.random_range(-b..=b),
        ]
    } else {
        [0.0; 3]
    };
    let step_us = (1e6 / imu.rate_hz.max(1.0)).round() as i64;
    let mut out = Vec::new();
    let mut t_us = 0;
    while t_us <= end_us {
        let mut s = trajectory.state(t_us as f64 * 1e-6).attitude_sample(t_us);
        s.roll_rate_rad_s += bias[0] + noise.sample(&mut rng);
        s.pitch_rate_rad_s += bias[1] + noise.sample(&mut rng);
        s.yaw_rate_rad_s += bias[2] + noise.sample(&mut rng);
        out.push(s);
        t_us += step_us;
    }
    out
}
