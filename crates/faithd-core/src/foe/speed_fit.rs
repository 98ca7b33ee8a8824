//! Speed fit: where inside FAITH's answer the FOE lies, told by how fast edges move.
//!
//! FAITH reads only the direction of each normal-flow vector. Its plateau (the points
//! that violate the fewest half-planes) is wide wherever few edges run radially to the
//! FOE, and it leans to the side with fewer edges: the boundaries of the denser side
//! crowd closer to the FOE. On the simulator, the plateau centroid sits a few pixels
//! above the true FOE when a textured floor fills the lower half of the view.
//!
//! The speeds carry what the directions do not. For a translating camera, an edge at
//! `p` with unit normal `n` moves at `s = n . (p - F) / tau`, where `tau` is the time to
//! contact of the surface there. Neighbouring edges mostly share a surface and so a
//! `tau`: in each square patch of `patch_px`, the times to contact the vectors imply
//! for a candidate `F`, `h_i = n_i . (p_i - F) / s_i`, should agree. A patch's best
//! common inverse time to contact `a >= 0` leaves the relative residual
//! `sum (1 - a h_i)^2`; relative, because a plane fit's speed error grows with the
//! speed. `J(F)` sums the patches' residuals.
//!
//! `J` is evaluated on a grid around FAITH's estimate, and the answer is the grid's
//! mean weighted by `exp(-(J - J_min) / (temperature J_min))`, not the argmin:
//! neighbouring vectors come from overlapping plane fits, so their errors are strongly
//! correlated and `J` is far flatter in truth than its number of terms suggests; its
//! argmin jumps between the few cells the noise favours. The grid is FAITH's answer
//! with its uncertainty: the fit places the FOE within it, it does not replace it.
//!
//! Per patch, `sum h_i` is linear and `sum h_i^2` quadratic in `F`, with coefficients
//! that are sums over the patch's vectors. The vectors are read once; a grid cell then
//! costs one evaluation per occupied patch, whatever the number of vectors.

use crate::flow::FlowVector;

/// Tunables of the speed fit (keys of `[pipeline.faith]`, prefixed `speed_`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedFitConfig {
    /// Half-size of the square grid searched around FAITH's estimate, pixels; 0 turns
    /// the fit off.
    pub radius_px: f64,
    /// Grid spacing, pixels.
    pub step_px: f64,
    /// Side of the patches whose edges share one time to contact, pixels.
    pub patch_px: f64,
    /// How far above the best fit's residual a cell's may be and still count, as a
    /// fraction of the best's.
    pub temperature: f64,
}

impl Default for SpeedFitConfig {
    fn default() -> Self {
        Self {
            radius_px: 40.0,
            step_px: 8.0,
            patch_px: 20.0,
            temperature: 0.3,
        }
    }
}

/// Sums over one patch's vectors of `h = alpha - beta . F` and `h^2`, as polynomial
/// coefficients in `F`.
#[derive(Clone, Copy, Debug, Default)]
struct PatchSums {
    count: f64,
    alpha: f64,
    beta_x: f64,
    beta_y: f64,
    alpha2: f64,
    alpha_beta_x: f64,
    alpha_beta_y: f64,
    beta_xx: f64,
    beta_xy: f64,
    beta_yy: f64,
}

impl PatchSums {
    /// Adds a vector at `(x, y)` with unit normal `(nx, ny)` and speed `s`.
    fn add(&mut self, x: f64, y: f64, nx: f64, ny: f64, s: f64) {
        let inv_s = 1.0 / s;
        let (alpha, bx, by) = ((nx * x + ny * y) * inv_s, nx * inv_s, ny * inv_s);
        self.count += 1.0;
        self.alpha += alpha;
        self.beta_x += bx;
        self.beta_y += by;
        self.alpha2 += alpha * alpha;
        self.alpha_beta_x += alpha * bx;
        self.alpha_beta_y += alpha * by;
        self.beta_xx += bx * bx;
        self.beta_xy += bx * by;
        self.beta_yy += by * by;
    }

    /// `sum (1 - a h_i)^2` at the best `a >= 0` for an FOE at `(fx, fy)`.
    fn residual(&self, fx: f64, fy: f64) -> f64 {
        let sum_h = self.alpha - self.beta_x * fx - self.beta_y * fy;
        if sum_h <= 0.0 {
            // The patch contracts about this FOE: a = 0 explains none of it.
            return self.count;
        }
        let sum_h2 = self.alpha2 - 2.0 * (self.alpha_beta_x * fx + self.alpha_beta_y * fy)
            + self.beta_xx * fx * fx
            + 2.0 * self.beta_xy * fx * fy
            + self.beta_yy * fy * fy;
        if sum_h2 <= 0.0 {
            return self.count;
        }
        (self.count - sum_h * sum_h / sum_h2).max(0.0)
    }
}

/// Per-row coefficients of the occupied patches, as arrays so the cell loop runs
/// several patches per instruction: along a grid row (fixed `fy`), `sum h` is
/// `h0 - beta_x fx` and `sum h^2` is `(beta_xx fx + q1) fx + q0`.
#[derive(Debug, Default)]
struct RowTerms {
    count: Vec<f64>,
    beta_x: Vec<f64>,
    beta_xx: Vec<f64>,
    h0: Vec<f64>,
    q0: Vec<f64>,
    q1: Vec<f64>,
}

impl RowTerms {
    fn set_row(&mut self, patches: &[PatchSums], fy: f64) {
        self.count.clear();
        self.beta_x.clear();
        self.beta_xx.clear();
        self.h0.clear();
        self.q0.clear();
        self.q1.clear();
        for p in patches {
            self.count.push(p.count);
            self.beta_x.push(p.beta_x);
            self.beta_xx.push(p.beta_xx);
            self.h0.push(p.alpha - p.beta_y * fy);
            self.q0
                .push(p.alpha2 - 2.0 * p.alpha_beta_y * fy + p.beta_yy * fy * fy);
            self.q1.push(2.0 * (p.beta_xy * fy - p.alpha_beta_x));
        }
    }

    /// `J` at `(fx, fy)` for the row set last; the same as `PatchSums::residual`
    /// summed, written without branches.
    fn cost(&self, fx: f64) -> f64 {
        let n = self.count.len();
        let (count, beta_x, beta_xx) = (&self.count[..n], &self.beta_x[..n], &self.beta_xx[..n]);
        let (h0, q0, q1) = (&self.h0[..n], &self.q0[..n], &self.q1[..n]);
        let mut total = 0.0;
        for k in 0..n {
            let sum_h = h0[k] - beta_x[k] * fx;
            let sum_h2 = (beta_xx[k] * fx + q1[k]) * fx + q0[k];
            let explained = (sum_h * sum_h / sum_h2).min(count[k]);
            let fits = sum_h > 0.0 && sum_h2 > 0.0;
            total += count[k] - if fits { explained } else { 0.0 };
        }
        total
    }
}

/// The speed fit with its reusable buffers.
#[derive(Debug, Default)]
pub struct SpeedFit {
    patches: Vec<PatchSums>,
    occupied: Vec<PatchSums>,
    row: RowTerms,
    /// Grid cells as (x, y, J).
    cells: Vec<(f64, f64, f64)>,
}

impl SpeedFit {
    pub fn new() -> Self {
        Self::default()
    }

    /// The FOE placed by the speeds around `start`, or `None` when the vectors give no
    /// patch to fit (or the config turns the fit off).
    pub fn refine(
        &mut self,
        flow: &[FlowVector],
        start: (f64, f64),
        sensor_px: (u16, u16),
        config: &SpeedFitConfig,
    ) -> Option<(f64, f64)> {
        if config.radius_px <= 0.0 || config.step_px <= 0.0 || config.patch_px <= 0.0 {
            return None;
        }
        self.sum_patches(flow, sensor_px, config.patch_px);
        if self.occupied.is_empty() {
            return None;
        }
        self.evaluate_grid(start, config.radius_px, config.step_px);
        self.weighted_mean(config.temperature)
    }

    /// `J` at one candidate FOE: the sum of the patches' residuals.
    pub fn cost(&self, fx: f64, fy: f64) -> f64 {
        self.occupied.iter().map(|p| p.residual(fx, fy)).sum()
    }

    fn sum_patches(&mut self, flow: &[FlowVector], sensor_px: (u16, u16), patch_px: f64) {
        let cols = (f64::from(sensor_px.0) / patch_px).ceil().max(1.0) as usize;
        let rows = (f64::from(sensor_px.1) / patch_px).ceil().max(1.0) as usize;
        self.patches.clear();
        self.patches.resize(cols * rows, PatchSums::default());
        for f in flow {
            // sqrt rather than hypot: the flow is finite and far from overflow, and
            // hypot's care costs more than the rest of this loop.
            let speed = (f.u_px_s * f.u_px_s + f.v_px_s * f.v_px_s).sqrt();
            if !(speed > 0.0 && speed.is_finite() && f.x_px.is_finite() && f.y_px.is_finite()) {
                continue;
            }
            let (nx, ny) = (f.u_px_s / speed, f.v_px_s / speed);
            // Casts saturate: a vector off the sensor lands in the border patch.
            let col = ((f.x_px / patch_px) as usize).min(cols - 1);
            let row = ((f.y_px / patch_px) as usize).min(rows - 1);
            self.patches[row * cols + col].add(f.x_px, f.y_px, nx, ny, speed);
        }
        self.occupied.clear();
        self.occupied
            .extend(self.patches.iter().filter(|p| p.count > 0.0));
    }

    fn evaluate_grid(&mut self, start: (f64, f64), radius_px: f64, step_px: f64) {
        let half = (radius_px / step_px).round() as i64;
        self.cells.clear();
        for j in -half..=half {
            let y = start.1 + j as f64 * step_px;
            self.row.set_row(&self.occupied, y);
            for i in -half..=half {
                let x = start.0 + i as f64 * step_px;
                self.cells.push((x, y, self.row.cost(x)));
            }
        }
    }

    fn weighted_mean(&self, temperature: f64) -> Option<(f64, f64)> {
        let &(bx, by, least) = self
            .cells
            .iter()
            .filter(|c| c.2.is_finite())
            .min_by(|a, b| a.2.total_cmp(&b.2))?;
        let scale = temperature * least;
        if !(scale > 0.0 && scale.is_finite()) {
            // A perfect fit (or no temperature): the best cell alone.
            return Some((bx, by));
        }
        let (mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0);
        for &(x, y, cost) in &self.cells {
            let w = (-(cost - least) / scale).exp();
            if w.is_finite() {
                sw += w;
                sx += w * x;
                sy += w * y;
            }
        }
        Some((sx / sw, sy / sw))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::CameraIntrinsics;
    use crate::synth::{FlowFieldSpec, radial_normal_flow};

    /// The per-patch sums give the same `J` as summing over the vectors one by one.
    #[test]
    fn patch_sums_equal_the_direct_sum() {
        let cam = CameraIntrinsics::dvs240();
        let mut spec = FlowFieldSpec::clean((130.0, 70.0), 400);
        spec.speed_noise_rel = 0.2;
        spec.angle_noise_deg = 5.0;
        let flow = radial_normal_flow(&cam, &spec, 3);
        let mut fit = SpeedFit::new();
        let patch_px = 20.0;
        fit.sum_patches(&flow, (cam.width_px, cam.height_px), patch_px);
        for (fx, fy) in [(130.0, 70.0), (90.0, 100.0), (200.0, 10.0), (-50.0, 300.0)] {
            let mut by_patch: std::collections::HashMap<(usize, usize), Vec<f64>> =
                Default::default();
            for f in &flow {
                let (nx, ny) = f.direction().unwrap();
                let h = (nx * (f.x_px - fx) + ny * (f.y_px - fy)) / f.speed_px_s();
                let key = ((f.x_px / patch_px) as usize, (f.y_px / patch_px) as usize);
                by_patch.entry(key).or_default().push(h);
            }
            let direct: f64 = by_patch
                .values()
                .map(|hs| {
                    let a =
                        (hs.iter().sum::<f64>() / hs.iter().map(|h| h * h).sum::<f64>()).max(0.0);
                    hs.iter().map(|h| (1.0 - a * h).powi(2)).sum::<f64>()
                })
                .sum();
            let fast = fit.cost(fx, fy);
            fit.row.set_row(&fit.occupied, fy);
            let by_row = fit.row.cost(fx);
            assert!(
                (by_row - fast).abs() <= 1e-6 * fast.max(1.0),
                "at ({fx}, {fy}): row terms {by_row}, patch sums {fast}"
            );
            assert!(
                (direct - fast).abs() <= 1e-6 * direct.max(1.0),
                "at ({fx}, {fy}): direct {direct}, patch sums {fast}"
            );
        }
    }

    /// Exact speeds of one depth plane: the fit finds the FOE from a start 30 px off,
    /// with every edge direction consistent with both points.
    #[test]
    fn exact_speeds_place_the_foe() {
        let cam = CameraIntrinsics::dvs240();
        let truth = (150.0, 80.0);
        let flow = radial_normal_flow(&cam, &FlowFieldSpec::clean(truth, 600), 7);
        let config = SpeedFitConfig {
            step_px: 1.0,
            ..SpeedFitConfig::default()
        };
        let (x, y) = SpeedFit::new()
            .refine(
                &flow,
                (120.0, 100.0),
                (cam.width_px, cam.height_px),
                &config,
            )
            .unwrap();
        let error_px = (x - truth.0).hypot(y - truth.1);
        assert!(error_px < 1.0, "({x:.2}, {y:.2}) is {error_px:.2} px off");
    }

    /// Noisy speeds: the weighted mean is closer to the truth than the start, averaged
    /// over fields, and the fit is off for a zero radius.
    #[test]
    fn noisy_speeds_pull_towards_the_foe() {
        let cam = CameraIntrinsics::dvs240();
        let truth = (100.0, 95.0);
        let start = (112.0, 85.0);
        let mut spec = FlowFieldSpec::clean(truth, 800);
        spec.speed_noise_rel = 0.3;
        spec.angle_noise_deg = 8.0;
        let mut fit = SpeedFit::new();
        let sensor = (cam.width_px, cam.height_px);
        let mut total_px = 0.0;
        for seed in 0..10 {
            let flow = radial_normal_flow(&cam, &spec, seed);
            let (x, y) = fit
                .refine(&flow, start, sensor, &SpeedFitConfig::default())
                .unwrap();
            total_px += (x - truth.0).hypot(y - truth.1);
        }
        let start_px = (start.0 - truth.0).hypot(start.1 - truth.1);
        assert!(
            total_px / 10.0 < 0.5 * start_px,
            "mean error {:.2} px from a start {start_px:.2} px off",
            total_px / 10.0
        );
        let off = SpeedFitConfig {
            radius_px: 0.0,
            ..SpeedFitConfig::default()
        };
        let flow = radial_normal_flow(&cam, &spec, 0);
        assert_eq!(fit.refine(&flow, start, sensor, &off), None);
    }

    #[test]
    fn no_vectors_no_fit() {
        let mut fit = SpeedFit::new();
        let still = [FlowVector::new(0, 10.0, 10.0, 0.0, 0.0)];
        assert_eq!(
            fit.refine(&still, (50.0, 50.0), (240, 180), &SpeedFitConfig::default()),
            None
        );
    }
}
