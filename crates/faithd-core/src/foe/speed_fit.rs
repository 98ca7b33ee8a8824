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
use crate::math;

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
    /// Adds a vector at `(x, y)` with unit normal `(nx, ny)` and speed `1 / inv_s`.
    fn add(&mut self, x: f64, y: f64, nx: f64, ny: f64, inv_s: f64) {
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
        let (sum_h, sum_h2) = self.sums_at(fx, fy);
        if sum_h <= 0.0 || sum_h2 <= 0.0 {
            // The patch contracts about this FOE: a = 0 explains none of it.
            return self.count;
        }
        (self.count - sum_h * sum_h / sum_h2).max(0.0)
    }

    /// `sum h` and `sum h^2` for an FOE at `(fx, fy)`.
    fn sums_at(&self, fx: f64, fy: f64) -> (f64, f64) {
        let sum_h = self.alpha - self.beta_x * fx - self.beta_y * fy;
        let sum_h2 = self.alpha2 - 2.0 * (self.alpha_beta_x * fx + self.alpha_beta_y * fy)
            + self.beta_xx * fx * fx
            + 2.0 * self.beta_xy * fx * fy
            + self.beta_yy * fy * fy;
        (sum_h, sum_h2)
    }

    /// `sum h beta`: half the gradient of `sum h^2`, negated, at `(fx, fy)`.
    fn h_beta_at(&self, fx: f64, fy: f64) -> (f64, f64) {
        (
            self.alpha_beta_x - self.beta_xx * fx - self.beta_xy * fy,
            self.alpha_beta_y - self.beta_xy * fx - self.beta_yy * fy,
        )
    }
}

/// Patches `CentredPatches` handles at once: two vectors of four lanes.
const LANES: usize = 8;

/// The occupied patches' sums as polynomials in the offset `(dx, dy)` of the FOE
/// from a grid's centre, in single precision, one array per sum (padded with empty
/// patches to a whole number of `LANES`).
///
/// About the centre the terms are as small as the residuals they make: around the
/// origin, `sum h^2` would be the small difference of terms a hundred times larger,
/// and single precision could not hold it. Single precision runs four lanes wide,
/// and its division (the grid's cost) is several times cheaper; `J` then carries a
/// relative error near 1e-6, where the weights `exp(-(J - J_min) / (temperature
/// J_min))` tell apart cells whose `J` differ by percents.
#[derive(Debug, Default)]
struct CentredPatches {
    count: Vec<f32>,
    /// `sum h` and `sum h^2` at the centre.
    h: Vec<f32>,
    h2: Vec<f32>,
    /// Minus the gradient of `sum h`, and the terms of that of `sum h^2`.
    beta_x: Vec<f32>,
    beta_y: Vec<f32>,
    h_beta_x: Vec<f32>,
    h_beta_y: Vec<f32>,
    beta_xx: Vec<f32>,
    beta_xy: Vec<f32>,
    beta_yy: Vec<f32>,
    /// Along the grid row `set_row` chose: `sum h = h0 - beta_x dx` and
    /// `sum h^2 = (beta_xx dx + q1) dx + q0`.
    h0: Vec<f32>,
    q0: Vec<f32>,
    q1: Vec<f32>,
}

impl CentredPatches {
    /// Takes `patches` about `(cx, cy)`.
    fn load(&mut self, patches: &[PatchSums], cx: f64, cy: f64) {
        for v in self.arrays_mut() {
            v.clear();
        }
        for p in patches {
            let (h, h2) = p.sums_at(cx, cy);
            let (h_beta_x, h_beta_y) = p.h_beta_at(cx, cy);
            self.count.push(p.count as f32);
            self.h.push(h as f32);
            self.h2.push(h2 as f32);
            self.beta_x.push(p.beta_x as f32);
            self.beta_y.push(p.beta_y as f32);
            self.h_beta_x.push(h_beta_x as f32);
            self.h_beta_y.push(h_beta_y as f32);
            self.beta_xx.push(p.beta_xx as f32);
            self.beta_xy.push(p.beta_xy as f32);
            self.beta_yy.push(p.beta_yy as f32);
        }
        // Empty patches: `sum h` 0 fits no inverse time to contact, and a count of 0
        // adds nothing.
        let padded = patches.len().next_multiple_of(LANES);
        for v in self.arrays_mut() {
            v.resize(padded, 0.0);
        }
    }

    fn arrays_mut(&mut self) -> [&mut Vec<f32>; 13] {
        [
            &mut self.count,
            &mut self.h,
            &mut self.h2,
            &mut self.beta_x,
            &mut self.beta_y,
            &mut self.h_beta_x,
            &mut self.h_beta_y,
            &mut self.beta_xx,
            &mut self.beta_xy,
            &mut self.beta_yy,
            &mut self.h0,
            &mut self.q0,
            &mut self.q1,
        ]
    }

    /// Sets the row's coefficients, `dy` from the centre.
    fn set_row(&mut self, dy: f32) {
        let n = self.count.len();
        let (h, h2, beta_y) = (&self.h[..n], &self.h2[..n], &self.beta_y[..n]);
        let (h_beta_x, h_beta_y) = (&self.h_beta_x[..n], &self.h_beta_y[..n]);
        let (beta_xy, beta_yy) = (&self.beta_xy[..n], &self.beta_yy[..n]);
        let (h0, q0, q1) = (&mut self.h0[..n], &mut self.q0[..n], &mut self.q1[..n]);
        for i in 0..n {
            h0[i] = h[i] - beta_y[i] * dy;
            q0[i] = h2[i] - 2.0 * h_beta_y[i] * dy + beta_yy[i] * dy * dy;
            q1[i] = 2.0 * (beta_xy[i] * dy - h_beta_x[i]);
        }
    }

    /// `J` at `dx` from the centre along the row `set_row` chose: the same as
    /// `PatchSums::residual` summed over the patches, without branches, in lanes
    /// over the patches.
    fn row_cost(&self, dx: f32) -> f32 {
        let n = self.count.len();
        let (count, beta_x, beta_xx) = (&self.count[..n], &self.beta_x[..n], &self.beta_xx[..n]);
        let (h0, q0, q1) = (&self.h0[..n], &self.q0[..n], &self.q1[..n]);
        let mut lanes = [0.0f32; LANES];
        let blocks = count
            .chunks_exact(LANES)
            .zip(beta_x.chunks_exact(LANES))
            .zip(beta_xx.chunks_exact(LANES))
            .zip(h0.chunks_exact(LANES))
            .zip(q0.chunks_exact(LANES).zip(q1.chunks_exact(LANES)));
        for ((((count, beta_x), beta_xx), h0), (q0, q1)) in blocks {
            for k in 0..LANES {
                let sum_h = h0[k] - beta_x[k] * dx;
                let sum_h2 = (beta_xx[k] * dx + q1[k]) * dx + q0[k];
                let ratio = sum_h * sum_h / sum_h2;
                // At most the count (Cauchy-Schwarz), but for rounding.
                let explained = if ratio < count[k] { ratio } else { count[k] };
                // `&`, not `&&`: both sides are cheap, and a select vectorises.
                let fits = (sum_h > 0.0) & (sum_h2 > 0.0);
                lanes[k] += count[k] - if fits { explained } else { 0.0 };
            }
        }
        lanes.iter().sum()
    }
}

/// The usable vectors of a window with their unit normals and speeds, worked out once
/// for both FAITH's half-planes and the speed fit (the same square root and
/// divisions either would do), as structure of arrays.
#[derive(Debug, Default)]
pub(crate) struct UnitFlow {
    pub x_px: Vec<f64>,
    pub y_px: Vec<f64>,
    pub nx: Vec<f64>,
    pub ny: Vec<f64>,
    /// One over the speed: the speed fit's terms are divided by it.
    pub inv_speed_s_per_px: Vec<f64>,
}

impl UnitFlow {
    /// Keeps the vectors with a finite origin and a finite, non-zero speed.
    pub fn load(&mut self, flow: &[FlowVector]) {
        self.x_px.clear();
        self.y_px.clear();
        self.nx.clear();
        self.ny.clear();
        self.inv_speed_s_per_px.clear();
        for f in flow {
            // sqrt rather than hypot: the flow is finite and far from overflow, and
            // hypot's care costs more than the rest of this loop.
            let speed = (f.u_px_s * f.u_px_s + f.v_px_s * f.v_px_s).sqrt();
            if !(speed > 0.0 && speed.is_finite() && f.x_px.is_finite() && f.y_px.is_finite()) {
                continue;
            }
            self.x_px.push(f.x_px);
            self.y_px.push(f.y_px);
            // One division for three quotients: divisions, not the rest, are what
            // this loop costs.
            let inv_speed = 1.0 / speed;
            self.nx.push(f.u_px_s * inv_speed);
            self.ny.push(f.v_px_s * inv_speed);
            self.inv_speed_s_per_px.push(inv_speed);
        }
    }

    pub fn len(&self) -> usize {
        self.x_px.len()
    }

    /// Room for `vectors` without growing.
    pub fn reserve(&mut self, vectors: usize) {
        for v in [
            &mut self.x_px,
            &mut self.y_px,
            &mut self.nx,
            &mut self.ny,
            &mut self.inv_speed_s_per_px,
        ] {
            v.reserve(vectors.saturating_sub(v.len()));
        }
    }
}

/// The speed fit with its reusable buffers.
#[derive(Debug, Default)]
pub struct SpeedFit {
    patches: Vec<PatchSums>,
    occupied: Vec<PatchSums>,
    /// The occupied patches about the grid's centre.
    centred: CentredPatches,
    /// The flow of `refine`, normalised.
    unit: UnitFlow,
    /// Grid cells as (x, y, J).
    cells: Vec<(f64, f64, f64)>,
}

impl SpeedFit {
    pub fn new() -> Self {
        Self::default()
    }

    /// Room for windows of up to `vectors` vectors, so that none allocates.
    pub fn reserve(&mut self, vectors: usize) {
        self.unit.reserve(vectors);
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
        let mut unit = std::mem::take(&mut self.unit);
        unit.load(flow);
        let foe = self.refine_unit(&unit, start, sensor_px, config);
        self.unit = unit;
        foe
    }

    /// `refine` on flow already normalised.
    pub(crate) fn refine_unit(
        &mut self,
        unit: &UnitFlow,
        start: (f64, f64),
        sensor_px: (u16, u16),
        config: &SpeedFitConfig,
    ) -> Option<(f64, f64)> {
        if config.radius_px <= 0.0 || config.step_px <= 0.0 || config.patch_px <= 0.0 {
            return None;
        }
        self.sum_patches(unit, sensor_px, config.patch_px);
        if self.occupied.is_empty() {
            return None;
        }
        self.evaluate_grid(start, config.radius_px, config.step_px);
        self.weighted_mean(config.temperature)
    }

    /// Sums the patches of `unit` for [`Self::cost`] (as `refine_unit` does first).
    pub(crate) fn load_patches(&mut self, unit: &UnitFlow, sensor_px: (u16, u16), patch_px: f64) {
        if patch_px > 0.0 {
            self.sum_patches(unit, sensor_px, patch_px);
        }
    }

    /// `J` at one candidate FOE: the sum of the patches' residuals.
    pub fn cost(&self, fx: f64, fy: f64) -> f64 {
        self.occupied.iter().map(|p| p.residual(fx, fy)).sum()
    }

    fn sum_patches(&mut self, unit: &UnitFlow, sensor_px: (u16, u16), patch_px: f64) {
        let cols = (f64::from(sensor_px.0) / patch_px).ceil().max(1.0) as usize;
        let rows = (f64::from(sensor_px.1) / patch_px).ceil().max(1.0) as usize;
        self.patches.clear();
        self.patches.resize(cols * rows, PatchSums::default());
        let n = unit.len();
        let (x, y) = (&unit.x_px[..n], &unit.y_px[..n]);
        let (nx, ny) = (&unit.nx[..n], &unit.ny[..n]);
        let inv_speed = &unit.inv_speed_s_per_px[..n];
        let per_patch = 1.0 / patch_px;
        for i in 0..n {
            // Casts saturate: a vector off the sensor lands in the border patch.
            let col = ((x[i] * per_patch) as usize).min(cols - 1);
            let row = ((y[i] * per_patch) as usize).min(rows - 1);
            self.patches[row * cols + col].add(x[i], y[i], nx[i], ny[i], inv_speed[i]);
        }
        self.occupied.clear();
        self.occupied
            .extend(self.patches.iter().filter(|p| p.count > 0.0));
    }

    fn evaluate_grid(&mut self, start: (f64, f64), radius_px: f64, step_px: f64) {
        let half = (radius_px / step_px).round() as i64;
        self.centred.load(&self.occupied, start.0, start.1);
        self.cells.clear();
        for j in -half..=half {
            let dy = j as f64 * step_px;
            self.centred.set_row(dy as f32);
            for i in -half..=half {
                let dx = i as f64 * step_px;
                let cost = self.centred.row_cost(dx as f32);
                self.cells
                    .push((start.0 + dx, start.1 + dy, f64::from(cost)));
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
            let w = math::exp(-(cost - least) / scale);
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
        let mut unit = UnitFlow::default();
        unit.load(&flow);
        fit.sum_patches(&unit, (cam.width_px, cam.height_px), patch_px);
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
            // About a centre 13 px off, as a grid cell around FAITH's answer sees it.
            let (cx, cy) = (fx - 13.0, fy + 13.0);
            let mut centred = CentredPatches::default();
            centred.load(&fit.occupied, cx, cy);
            centred.set_row((fy - cy) as f32);
            let by_row = f64::from(centred.row_cost((fx - cx) as f32));
            assert!(
                (by_row - fast).abs() <= 1e-5 * fast.max(1.0),
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
        let error_px = math::hypot(x - truth.0, y - truth.1);
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
            total_px += math::hypot(x - truth.0, y - truth.1);
        }
        let start_px = math::hypot(start.0 - truth.0, start.1 - truth.1);
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
