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

/// Relative margin on the image-speed bound, see [`EventCamera::max_image_speed_px_s`].
const SPEED_MARGIN: f64 = 0.01;

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
    /// Depth of the last render per pixel, metres (for plots, checks and the
    /// image-speed bound).
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

    /// A bound on how fast any pixel's content moves across the image, px/s, for a
    /// vehicle in `state` seeing the scene of the last render (its depth map): what
    /// an adaptive render rate needs (ESIM renders more often when the image moves
    /// faster), see [`render_interval_us`].
    ///
    /// The motion field of a static point at normalised image position (x, y) and
    /// depth Z along the optical axis, for a camera moving at v and turning at w
    /// (both in camera axes), is a translational part `((x v_z - v_x) / Z,
    /// (y v_z - v_y) / Z)` plus a rotational part independent of depth (the one
    /// derotation removes, see `faithd_core::derotate`). The bound is the largest
    /// translational flow plus the largest rotational flow:
    /// - translation, per 4x4 block of pixels: the nearest depth in the block (every
    ///   pixel is read, so no thin pole between samples is missed), divided by the
    ///   largest ray length `sqrt(1 + x^2 + y^2)` in the block to get Z, and the
    ///   numerator at the block's corners (its length is convex in x and y);
    /// - rotation: each term at the sensor's largest |x| and |y|;
    /// - plus 1 % for the second-order change of the flow within a render interval.
    ///
    /// The bound is for the pose of the last render; before the first render it is
    /// infinite for a moving camera (depths are 0). Its cost is a pass over the depth map and a few
    /// flops per block: a few per cent of a render.
    pub fn max_image_speed_px_s(&self, state: &VehicleState) -> f64 {
        let world_to_camera = self.mounting.body_to_camera * state.attitude.matrix().transpose();
        let v = world_to_camera * state.velocity_m_s;
        let w = self.mounting.rates_in_camera(state.body_rates_rad_s);
        let cam = &self.camera;
        let (width, height) = (usize::from(cam.width_px), usize::from(cam.height_px));
        let (x_first, y_first) = cam.normalise(0.0, 0.0);
        let (x_last, y_last) = cam.normalise((width - 1) as f64, (height - 1) as f64);
        let (ax, ay) = (
            x_first.abs().max(x_last.abs()),
            y_first.abs().max(y_last.abs()),
        );
        let rot_u = ax * ay * w.x.abs() + (1.0 + ax * ax) * w.y.abs() + ay * w.z.abs();
        let rot_v = (1.0 + ay * ay) * w.x.abs() + ax * ay * w.y.abs() + ax * w.z.abs();
        let rotation_px_s = (cam.fx_px * rot_u).hypot(cam.fy_px * rot_v);

        // Over a block the translational flow's squared length is largest at an x
        // and a y extreme, each chosen apart: per block column and per block row.
        const BLOCK: usize = 4;
        // First and last pixel of each block along an axis of `count` pixels.
        let blocks = |count: usize| {
            (0..count.div_ceil(BLOCK)).map(move |b| (b * BLOCK, ((b + 1) * BLOCK).min(count) - 1))
        };
        let columns: Vec<(f64, f64)> = blocks(width)
            .map(|(first, last)| {
                let x = |px: usize| cam.normalise(px as f64, 0.0).0;
                let flow = |x: f64| (cam.fx_px * (x * v.z - v.x)).powi(2);
                let (xa, xb) = (x(first), x(last));
                (flow(xa).max(flow(xb)), xa.abs().max(xb.abs()).powi(2))
            })
            .collect();
        let rows: Vec<(f64, f64)> = blocks(height)
            .map(|(first, last)| {
                let y = |px: usize| cam.normalise(0.0, px as f64).1;
                let flow = |y: f64| (cam.fy_px * (y * v.z - v.y)).powi(2);
                let (ya, yb) = (y(first), y(last));
                (flow(ya).max(flow(yb)), ya.abs().max(yb.abs()).powi(2))
            })
            .collect();
        let mut nearest_m = vec![f32::INFINITY; columns.len()];
        // The largest (numerator / Z)^2 = numerator^2 (1 + x^2 + y^2) / depth^2.
        let mut translation_sq: f64 = 0.0;
        for (by, &(flow_y, y_sq)) in rows.iter().enumerate() {
            nearest_m.fill(f32::INFINITY);
            let last_row = ((by + 1) * BLOCK).min(height);
            for row in self.depth_m[by * BLOCK * width..last_row * width].chunks_exact(width) {
                for (nearest, block) in nearest_m.iter_mut().zip(row.chunks(BLOCK)) {
                    *nearest = block.iter().fold(*nearest, |a, &b| a.min(b));
                }
            }
            for (&depth_m, &(flow_x, x_sq)) in nearest_m.iter().zip(&columns) {
                let numerator_sq = flow_x + flow_y;
                if depth_m < f32::INFINITY && numerator_sq > 0.0 {
                    let depth_m = f64::from(depth_m);
                    translation_sq = translation_sq
                        .max(numerator_sq * (1.0 + x_sq + y_sq) / (depth_m * depth_m));
                }
            }
        }
        let translation_px_s = translation_sq.sqrt();
        // The motion field is the instantaneous speed; a point's displacement over a
        // millisecond differs from it to second order (a turning camera sweeps a
        // point along a curve), by a fraction of a per cent at these rates.
        (translation_px_s + rotation_px_s) * (1.0 + SPEED_MARGIN)
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
        let pixels = self
            .rays_body
            .iter()
            .zip(self.current_log.iter_mut())
            .zip(self.reflectance_seen.iter_mut())
            .zip(self.depth_m.iter_mut())
            .zip(&self.last_log);
        for ((((ray_b, log), seen), depth_m), last_log) in pixels {
            let dir = r * ray_b;
            // The pixel's coordinates, counted along (the view culls boxes by pixel).
            let (reflectance, depth) = view.shade(&dir, x_px, y_px);
            x_px += 1;
            if x_px == w {
                x_px = 0;
                y_px += 1;
            }
            if reflectance != left_reflectance {
                left_reflectance = reflectance;
                left_log = if reflectance == *seen {
                    *last_log
                } else {
                    reflectance.ln() as f32
                };
            }
            *log = left_log;
            *seen = reflectance;
            *depth_m = depth as f32;
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

/// The next render interval of an adaptive render rate: as long as it takes the
/// fastest pixel (`speed_px_s`, see [`EventCamera::max_image_speed_px_s`]) to move
/// `max_displacement_px`, within `min_us..=max_us`.
///
/// Crossings between renders are interpolated linearly, which is right while an edge
/// moves less than a pixel or so between them; a static image needs few renders and a
/// fast one many. Rounded down, so the displacement stays within the bound. An
/// unknown speed (NaN) gets the shortest interval, a still image the longest.
pub fn render_interval_us(
    speed_px_s: f64,
    max_displacement_px: f64,
    min_us: i64,
    max_us: i64,
) -> i64 {
    if speed_px_s.is_nan() {
        return min_us;
    }
    if speed_px_s <= 0.0 {
        return max_us;
    }
    let interval_us = (max_displacement_px / speed_px_s * 1e6).floor();
    // `as` saturates (an infinite interval becomes i64::MAX) before the clamp.
    (interval_us as i64).clamp(min_us, max_us)
}
