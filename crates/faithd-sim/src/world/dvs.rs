//! The event camera: renders log intensity along the trajectory and emits events at
//! contrast-threshold crossings, interpolated in time between rendered samples.

use nalgebra::{Matrix3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal, Poisson};
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};

use super::scene::Scene;
use super::trajectory::VehicleState;
use faithd_core::camera::{CameraIntrinsics, Mounting};
use faithd_core::event::{Event, Polarity};

/// Sensor imperfections, with defaults near a DVS240's datasheet and ESIM's practice.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DvsConfig {
    /// Mean log-intensity change that fires an event.
    pub contrast_threshold: f64,
    /// Per-pixel standard deviation of the threshold (fixed-pattern mismatch).
    pub threshold_mismatch: f64,
    /// A pixel cannot fire again within this time, microseconds.
    pub refractory_us: i64,
    /// Background-activity noise, events per pixel per second.
    pub noise_rate_hz: f64,
    /// Standard deviation of timestamp jitter, microseconds.
    pub jitter_us: f64,
    /// Rendering rate; crossings between two renders are interpolated linearly.
    pub render_rate_hz: f64,
}

impl Default for DvsConfig {
    fn default() -> Self {
        Self {
            contrast_threshold: 0.2,
            threshold_mismatch: 0.02,
            refractory_us: 200,
            noise_rate_hz: 0.1,
            jitter_us: 50.0,
            render_rate_hz: 1000.0,
        }
    }
}

/// Per-pixel state of the emulated sensor.
pub struct EventCamera {
    camera: CameraIntrinsics,
    mounting: Mounting,
    config: DvsConfig,
    rng: Pcg64Mcg,
    /// Viewing ray per pixel, in body axes.
    rays_body: Vec<Vector3<f64>>,
    threshold_on: Vec<f32>,
    threshold_off: Vec<f32>,
    reference: Vec<f32>,
    last_event_us: Vec<i64>,
    last_log: Vec<f32>,
    current_log: Vec<f32>,
    /// Depth of the last render per pixel, metres (for plots and checks).
    depth_m: Vec<f32>,
    /// Reflectance of the last render per pixel, whose logarithm is `last_log`.
    reflectance_seen: Vec<f64>,
    last_t_us: Option<i64>,
}

impl EventCamera {
    pub fn new(camera: CameraIntrinsics, mounting: Mounting, config: DvsConfig, seed: u64) -> Self {
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let n = camera.pixel_count();
        let camera_to_body: Matrix3<f64> = mounting.body_to_camera.transpose();
        let mut rays_body = Vec::with_capacity(n);
        for y in 0..camera.height_px {
            for x in 0..camera.width_px {
                let (xn, yn) = camera.normalise(f64::from(x), f64::from(y));
                rays_body.push(camera_to_body * Vector3::new(xn, yn, 1.0));
            }
        }
        let mismatch = Normal::new(0.0, config.threshold_mismatch.max(0.0)).expect("finite");
        let c = config.contrast_threshold;
        let draw = |rng: &mut Pcg64Mcg| (c + mismatch.sample(rng)).max(0.25 * c) as f32;
        let threshold_on = (0..n).map(|_| draw(&mut rng)).collect();
        let threshold_off = (0..n).map(|_| draw(&mut rng)).collect();
        Self {
            camera,
            mounting,
            config,
            rng,
            rays_body,
            threshold_on,
            threshold_off,
            reference: vec![0.0; n],
            last_event_us: vec![i64::MIN / 2; n],
            last_log: vec![0.0; n],
            current_log: vec![0.0; n],
            depth_m: vec![0.0; n],
            reflectance_seen: vec![f64::NAN; n],
            last_t_us: None,
        }
    }

    pub fn camera(&self) -> &CameraIntrinsics {
        &self.camera
    }

    pub fn mounting(&self) -> &Mounting {
        &self.mounting
    }

    pub fn config(&self) -> &DvsConfig {
        &self.config
    }

    /// Depth per pixel of the last render, metres, row-major.
    pub fn depth_m(&self) -> &[f32] {
        &self.depth_m
    }

    /// Log intensity per pixel of the last render, row-major: what the events are
    /// fired from (for checks that a faster renderer sees the same image).
    pub fn log_intensity(&self) -> &[f32] {
        &self.last_log
    }

    fn render(&mut self, scene: &Scene, state: &VehicleState) {
        let r = state.attitude.matrix();
        let world_to_camera = self.mounting.body_to_camera * r.transpose();
        let view = scene.view(&state.position_m, &world_to_camera, &self.camera);
        let w = i32::from(self.camera.width_px);
        // A pixel often sees exactly the reflectance its left neighbour saw (inside a
        // tile, a band, a board), or the one it saw in the last render: the logarithm
        // of an equal f64 is the same, so reuse it. `last_log` is still the last
        // render's image here (and `reflectance_seen` NaN before the first).
        let mut left_reflectance = f64::NAN;
        let mut left_log = 0.0f32;
        let (mut x_px, mut y_px) = (0, 0);
        for (i, ray_b) in self.rays_body.iter().enumerate() {
            let dir = r * ray_b;
            // Counted, not divided out of `i`: an integer division per pixel shows.
            let (reflectance, depth) = view.shade(&dir, x_px, y_px);
            x_px += 1;
            if x_px == w {
                x_px = 0;
                y_px += 1;
            }
            if reflectance != left_reflectance {
                left_reflectance = reflectance;
                left_log = if reflectance == self.reflectance_seen[i] {
                    self.last_log[i]
                } else {
                    reflectance.ln() as f32
                };
            }
            self.current_log[i] = left_log;
            self.reflectance_seen[i] = reflectance;
            self.depth_m[i] = depth as f32;
        }
    }

    /// Renders the state at `t_us` and appends the events since the previous render,
    /// time-ordered. The first call only sets the reference image.
    pub fn advance(
        &mut self,
        scene: &Scene,
        state: &VehicleState,
        t_us: i64,
        out: &mut Vec<Event>,
    ) {
        self.render(scene, state);
        let Some(t0_us) = self.last_t_us.filter(|&t0| t_us > t0) else {
            self.reference.copy_from_slice(&self.current_log);
            self.last_log.copy_from_slice(&self.current_log);
            self.last_t_us = Some(t_us);
            return;
        };
        let start = out.len();
        let span_us = (t_us - t0_us) as f64;
        let jitter = Normal::new(0.0, self.config.jitter_us.max(0.0)).expect("finite");
        let w = usize::from(self.camera.width_px);
        for i in 0..self.current_log.len() {
            let (l0, l1) = (self.last_log[i], self.current_log[i]);
            let dl = l1 - l0;
            if dl == 0.0 {
                continue;
            }
            loop {
                let (target, polarity) = if dl > 0.0 {
                    (self.reference[i] + self.threshold_on[i], Polarity::On)
                } else {
                    (self.reference[i] - self.threshold_off[i], Polarity::Off)
                };
                let frac = f64::from((target - l0) / dl);
                if !(0.0..=1.0).contains(&frac) {
                    break;
                }
                self.reference[i] = target;
                let t = t0_us as f64 + frac * span_us + jitter.sample(&mut self.rng);
                let t = (t.round() as i64).clamp(t0_us + 1, t_us);
                if t - self.last_event_us[i] < self.config.refractory_us {
                    continue;
                }
                self.last_event_us[i] = t;
                out.push(Event::new(t, (i % w) as u16, (i / w) as u16, polarity));
            }
        }
        self.add_noise(t0_us, t_us, out);
        out[start..].sort_by_key(|e| (e.t_us, e.y_px, e.x_px));
        std::mem::swap(&mut self.last_log, &mut self.current_log);
        self.last_t_us = Some(t_us);
    }

    fn add_noise(&mut self, t0_us: i64, t1_us: i64, out: &mut Vec<Event>) {
        let mean = self.config.noise_rate_hz
            * self.camera.pixel_count() as f64
            * (t1_us - t0_us) as f64
            * 1e-6;
        if mean <= 0.0 {
            return;
        }
        let count = Poisson::new(mean).map_or(0.0, |p| p.sample(&mut self.rng)) as usize;
        for _ in 0..count {
            out.push(Event::new(
                self.rng.random_range(t0_us + 1..=t1_us),
                self.rng.random_range(0..self.camera.width_px),
                self.rng.random_range(0..self.camera.height_px),
                Polarity::from_bool(self.rng.random_bool(0.5)),
            ));
        }
    }
}
