//! Vector intersections with RANSAC (Buczko 2017).
//!
//! Two random flow vectors, extended to lines, meet at a candidate FOE; the candidate
//! scores the vectors whose direction points away from it within an angle. The best
//! candidate is refined by least squares over its inliers (the point closest to all
//! their lines). It treats normal flow as if it were full flow, which is why it is the
//! least accurate method of Table I; unlike the half-plane methods it can place the
//! FOE outside the view.

use crate::math;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};

use super::{FoeEstimate, FoeEstimator};
use crate::camera::CameraIntrinsics;
use crate::flow::FlowVector;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VecIntersectionsConfig {
    /// RANSAC iterations (as many as FAITH's, for a fair comparison).
    pub iterations: u32,
    /// A vector is an inlier when it points away from the candidate within this angle.
    pub inlier_angle_deg: f64,
    /// Estimates farther than this beyond the sensor border are reported as unbounded.
    pub max_outside_px: f64,
}

impl Default for VecIntersectionsConfig {
    fn default() -> Self {
        Self {
            iterations: 52,
            inlier_angle_deg: 10.0,
            max_outside_px: 2400.0,
        }
    }
}

pub struct VecIntersections {
    camera: CameraIntrinsics,
    config: VecIntersectionsConfig,
    /// Usable vectors: origin and unit direction.
    lines: Vec<(f64, f64, f64, f64)>,
}

impl VecIntersections {
    pub fn new(camera: CameraIntrinsics, config: VecIntersectionsConfig) -> Self {
        Self {
            camera,
            config,
            lines: Vec::new(),
        }
    }

    fn is_inlier(&self, line: &(f64, f64, f64, f64), x: f64, y: f64, cos_max: f64) -> bool {
        let (px, py, dx, dy) = *line;
        let (rx, ry) = (px - x, py - y);
        let r = (rx * rx + ry * ry).sqrt();
        r > 0.0 && (rx * dx + ry * dy) >= cos_max * r
    }

    fn score(&self, x: f64, y: f64, cos_max: f64) -> usize {
        self.lines
            .iter()
            .filter(|l| self.is_inlier(l, x, y, cos_max))
            .count()
    }

    /// Least-squares point nearest to the inlier lines of `(x, y)`.
    fn refine(&self, x: f64, y: f64, cos_max: f64) -> Option<(f64, f64)> {
        // Minimise sum of squared distances to lines: sum (I - d d^T) (q - p) = 0.
        let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for l in self
            .lines
            .iter()
            .filter(|l| self.is_inlier(l, x, y, cos_max))
        {
            let (px, py, dx, dy) = *l;
            let (m11, m12, m22) = (1.0 - dx * dx, -dx * dy, 1.0 - dy * dy);
            a11 += m11;
            a12 += m12;
            a22 += m22;
            b1 += m11 * px + m12 * py;
            b2 += m12 * px + m22 * py;
        }
        let det = a11 * a22 - a12 * a12;
        if det.abs() < 1e-9 * (a11 + a22).powi(2).max(1e-12) {
            return None;
        }
        Some(((b1 * a22 - b2 * a12) / det, (a11 * b2 - a12 * b1) / det))
    }
}

impl FoeEstimator for VecIntersections {
    fn name(&self) -> &'static str {
        "vec_intersections"
    }

    fn estimate(&mut self, flow: &[FlowVector], seed: u64) -> FoeEstimate {
        self.lines.clear();
        self.lines.extend(flow.iter().filter_map(|f| {
            let (dx, dy) = f.direction()?;
            (f.x_px.is_finite() && f.y_px.is_finite()).then_some((f.x_px, f.y_px, dx, dy))
        }));
        let n = self.lines.len();
        if n < 10 {
            return FoeEstimate::Insufficient { vectors: n };
        }
        let cos_max = math::cos(self.config.inlier_angle_deg.to_radians());
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let mut best: Option<(usize, f64, f64)> = None;
        for _ in 0..self.config.iterations.max(1) {
            let i = rng.random_range(0..n);
            let mut j = rng.random_range(0..n - 1);
            if j >= i {
                j += 1;
            }
            let (p1x, p1y, d1x, d1y) = self.lines[i];
            let (p2x, p2y, d2x, d2y) = self.lines[j];
            let cross = d1x * d2y - d1y * d2x;
            if cross.abs() < 1e-6 {
                continue; // parallel lines never meet
            }
            let s = ((p2x - p1x) * d2y - (p2y - p1y) * d2x) / cross;
            let (x, y) = (p1x + s * d1x, p1y + s * d1y);
            let score = self.score(x, y, cos_max);
            if best.is_none_or(|(b, _, _)| score > b) {
                best = Some((score, x, y));
            }
        }
        let Some((mut support, mut x, mut y)) = best else {
            return FoeEstimate::Insufficient { vectors: n };
        };
        if let Some((rx, ry)) = self.refine(x, y, cos_max) {
            let refined = self.score(rx, ry, cos_max);
            if refined >= support {
                (x, y, support) = (rx, ry, refined);
            }
        }
        let (w, h) = (
            f64::from(self.camera.width_px),
            f64::from(self.camera.height_px),
        );
        let m = self.config.max_outside_px;
        if x < -m || y < -m || x > w + m || y > h + m {
            return FoeEstimate::unbounded_towards(&self.camera, x, y, None, support);
        }
        FoeEstimate::Point {
            x_px: x,
            y_px: y,
            support,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::foe::Side;
    use crate::synth::{FlowFieldSpec, radial_normal_flow};

    /// Full (not normal) radial flow with direction noise.
    fn full_flow(foe: (f64, f64), n: usize, noise_deg: f64, seed: u64) -> Vec<FlowVector> {
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        (0..n)
            .map(|i| {
                let (x, y) = (rng.random_range(0.0..239.0), rng.random_range(0.0..179.0));
                let a = math::atan2(y - foe.1, x - foe.0)
                    + rng.random_range(-noise_deg..=noise_deg).to_radians();
                let speed = math::hypot(x - foe.0, y - foe.1) * 0.5;
                FlowVector::new(i as i64, x, y, speed * math::cos(a), speed * math::sin(a))
            })
            .collect()
    }

    #[test]
    fn finds_the_foe_of_full_radial_flow() {
        let cam = CameraIntrinsics::dvs240();
        for foe in [(120.0, 90.0), (40.0, 150.0), (-60.0, 90.0)] {
            let flow = full_flow(foe, 800, 3.0, 1);
            let est =
                VecIntersections::new(cam, VecIntersectionsConfig::default()).estimate(&flow, 5);
            let (x, y) = est.point().expect("a point");
            assert!(math::hypot(x - foe.0, y - foe.1) < 3.0, "{foe:?}: {x} {y}");
        }
    }

    #[test]
    fn far_outside_is_unbounded_and_normal_flow_does_not_panic() {
        let cam = CameraIntrinsics::dvs240();
        let flow = full_flow((-5000.0, 90.0), 500, 0.5, 2);
        match VecIntersections::new(cam, VecIntersectionsConfig::default()).estimate(&flow, 1) {
            FoeEstimate::Unbounded { side, .. } => assert_eq!(side, Side::Left),
            other => panic!("{other:?}"),
        }
        let normal = radial_normal_flow(&cam, &FlowFieldSpec::clean((100.0, 80.0), 500), 3);
        let est =
            VecIntersections::new(cam, VecIntersectionsConfig::default()).estimate(&normal, 1);
        assert!(
            est.point()
                .is_some_and(|(x, y)| x.is_finite() && y.is_finite())
        );
    }

    #[test]
    fn degenerate_input_is_insufficient_and_seeded() {
        let cam = CameraIntrinsics::dvs240();
        let mut vi = VecIntersections::new(cam, VecIntersectionsConfig::default());
        assert_eq!(
            vi.estimate(&[], 1),
            FoeEstimate::Insufficient { vectors: 0 }
        );
        let flow = full_flow((100.0, 100.0), 300, 10.0, 4);
        assert_eq!(vi.estimate(&flow, 9), vi.estimate(&flow, 9));
    }
}
