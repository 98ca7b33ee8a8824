//! NESW vector counting (Huang 2018): the FOE column is where flow turns from
//! pointing left to pointing right, the FOE row where it turns from up to down.
//!
//! For a candidate column x, count the vectors left of x that point left plus the
//! vectors right of x that point right; the FOE column maximises that count (likewise
//! rows with v). Cumulative counts over the sensor's columns and rows make it
//! O(N + width + height). It cannot see beyond the image: a best column on the border
//! is reported as `Unbounded` on that side.

use super::{FoeEstimate, FoeEstimator, Side};
use crate::camera::CameraIntrinsics;
use crate::flow::FlowVector;

/// Below this many usable vectors the counts are not worth a guess.
pub const NESW_MIN_VECTORS: usize = 10;

pub struct Nesw {
    camera: CameraIntrinsics,
    /// Per column: vectors pointing left, vectors pointing right (then per row).
    left: Vec<u32>,
    right: Vec<u32>,
    up: Vec<u32>,
    down: Vec<u32>,
}

impl Nesw {
    pub fn new(camera: CameraIntrinsics) -> Self {
        let (w, h) = (usize::from(camera.width_px), usize::from(camera.height_px));
        Self {
            camera,
            left: vec![0; w],
            right: vec![0; w],
            up: vec![0; h],
            down: vec![0; h],
        }
    }
}

/// The best split position along one axis: maximises (negatives before) + (positives
/// after). Returns the middle of the best plateau and whether it touches a border.
fn best_split(neg: &[u32], pos: &[u32]) -> Option<(f64, Option<bool>)> {
    let n = neg.len();
    if n == 0 {
        return None;
    }
    let total_pos: u32 = pos.iter().sum();
    // Candidate k sits at coordinate k: vectors at < k are "before", at > k "after".
    let (mut neg_before, mut pos_upto) = (0u32, 0u32);
    let mut best = 0u32;
    let (mut first, mut last) = (0usize, 0usize);
    for k in 0..n {
        let pos_after = total_pos - pos_upto - pos[k];
        let score = neg_before + pos_after;
        if score > best {
            best = score;
            first = k;
            last = k;
        } else if score == best && last + 1 == k {
            last = k;
        }
        neg_before += neg[k];
        pos_upto += pos[k];
    }
    let border = if first == 0 {
        Some(false)
    } else if last == n - 1 {
        Some(true)
    } else {
        None
    };
    Some(((first + last) as f64 * 0.5, border))
}

impl FoeEstimator for Nesw {
    fn name(&self) -> &'static str {
        "nesw"
    }

    fn estimate(&mut self, flow: &[FlowVector], _seed: u64) -> FoeEstimate {
        for v in [
            &mut self.left,
            &mut self.right,
            &mut self.up,
            &mut self.down,
        ] {
            v.fill(0);
        }
        let (w, h) = (self.left.len(), self.up.len());
        let mut used = 0;
        for f in flow {
            let (x, y) = (f.x_px.round(), f.y_px.round());
            if !(f.u_px_s.is_finite() && f.v_px_s.is_finite() && x >= 0.0 && y >= 0.0) {
                continue;
            }
            let (xi, yi) = (x as usize, y as usize);
            if xi >= w || yi >= h {
                continue;
            }
            used += 1;
            if f.u_px_s < 0.0 {
                self.left[xi] += 1;
            } else if f.u_px_s > 0.0 {
                self.right[xi] += 1;
            }
            if f.v_px_s < 0.0 {
                self.up[yi] += 1;
            } else if f.v_px_s > 0.0 {
                self.down[yi] += 1;
            }
        }
        if used < NESW_MIN_VECTORS {
            return FoeEstimate::Insufficient { vectors: used };
        }
        let (Some((x, x_border)), Some((y, y_border))) = (
            best_split(&self.left, &self.right),
            best_split(&self.up, &self.down),
        ) else {
            return FoeEstimate::Insufficient { vectors: used };
        };
        let support = flow
            .iter()
            .filter(|f| (f.x_px - x) * f.u_px_s + (f.y_px - y) * f.v_px_s > 0.0)
            .count();
        let side = match (x_border, y_border) {
            (Some(false), _) => Some(Side::Left),
            (Some(true), _) => Some(Side::Right),
            (None, Some(false)) => Some(Side::Above),
            (None, Some(true)) => Some(Side::Below),
            (None, None) => None,
        };
        FoeEstimate::point_or_beyond(&self.camera, x, y, side, support)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math;
    use crate::synth::{FlowFieldSpec, radial_normal_flow};

    fn error_px(spec: FlowFieldSpec, seed: u64) -> f64 {
        let cam = CameraIntrinsics::dvs240();
        let flow = radial_normal_flow(&cam, &spec, seed);
        let (x, y) = Nesw::new(cam).estimate(&flow, 0).point().expect("a point");
        math::hypot(x - spec.foe_px.0, y - spec.foe_px.1)
    }

    #[test]
    fn finds_the_foe_of_radial_flow() {
        // Counting is robust but coarse: over five fields the mean error measured
        // 2-8 px clean and 6-14 px with 5 degree noise and 20 % outliers.
        for foe in [(120.0, 90.0), (60.0, 40.0), (200.0, 150.0)] {
            let clean = FlowFieldSpec::clean(foe, 1000);
            let dirty = FlowFieldSpec {
                angle_noise_deg: 5.0,
                outlier_fraction: 0.2,
                ..clean
            };
            let mean = |spec| (0..5).map(|s| error_px(spec, s)).sum::<f64>() / 5.0;
            let (c, d) = (mean(clean), mean(dirty));
            assert!(c < 12.0 && d < 20.0, "{foe:?}: clean {c} dirty {d}");
        }
    }

    #[test]
    fn foe_beyond_the_left_border_is_unbounded_left() {
        let cam = CameraIntrinsics::dvs240();
        let flow = radial_normal_flow(&cam, &FlowFieldSpec::clean((-300.0, 90.0), 800), 3);
        match Nesw::new(cam).estimate(&flow, 0) {
            FoeEstimate::Unbounded { side, .. } => assert_eq!(side, Side::Left),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn degenerate_input_is_insufficient() {
        let cam = CameraIntrinsics::dvs240();
        let mut nesw = Nesw::new(cam);
        assert_eq!(
            nesw.estimate(&[], 0),
            FoeEstimate::Insufficient { vectors: 0 }
        );
        let bad = vec![FlowVector::new(0, f64::NAN, 1.0, 1.0, 1.0); 50];
        assert_eq!(
            nesw.estimate(&bad, 0),
            FoeEstimate::Insufficient { vectors: 0 }
        );
        let outside = vec![FlowVector::new(0, 500.0, 1.0, 1.0, 1.0); 50];
        assert_eq!(
            nesw.estimate(&outside, 0),
            FoeEstimate::Insufficient { vectors: 0 }
        );
    }
}
