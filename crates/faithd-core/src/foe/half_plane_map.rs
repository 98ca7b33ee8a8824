//! The half-plane probability map (Clady 2014): every pixel counts the negative
//! half-planes it lies in; the FOE is the centroid of the most-voted pixels.
//!
//! Kept deliberately in its published form, one test per pixel per vector
//! (O(N x pixels)), because it is the baseline whose cost Table I measures.

use serde::{Deserialize, Serialize};

use super::{FoeEstimate, FoeEstimator, Side};
use crate::camera::CameraIntrinsics;
use crate::flow::FlowVector;

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HalfPlaneMapConfig {}

pub struct HalfPlaneMap {
    camera: CameraIntrinsics,
    votes: Vec<u32>,
}

impl HalfPlaneMap {
    pub fn new(camera: CameraIntrinsics, _config: HalfPlaneMapConfig) -> Self {
        Self {
            camera,
            votes: vec![0; camera.pixel_count()],
        }
    }
}

impl FoeEstimator for HalfPlaneMap {
    fn name(&self) -> &'static str {
        "half_planes"
    }

    fn estimate(&mut self, flow: &[FlowVector], _seed: u64) -> FoeEstimate {
        self.votes.fill(0);
        let w = usize::from(self.camera.width_px);
        let mut used = 0;
        for f in flow {
            let Some((nx, ny)) = f.direction() else {
                continue;
            };
            if !(f.x_px.is_finite() && f.y_px.is_finite()) {
                continue;
            }
            used += 1;
            let c = nx * f.x_px + ny * f.y_px;
            for (i, vote) in self.votes.iter_mut().enumerate() {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                *vote += u32::from(nx * x + ny * y <= c);
            }
        }
        if used < 10 {
            return FoeEstimate::Insufficient { vectors: used };
        }
        let best = self.votes.iter().copied().max().unwrap_or(0);
        let (mut sx, mut sy, mut n) = (0.0, 0.0, 0usize);
        for (i, &v) in self.votes.iter().enumerate() {
            if v == best {
                sx += (i % w) as f64;
                sy += (i / w) as f64;
                n += 1;
            }
        }
        let (x, y) = (sx / n as f64, sy / n as f64);
        let support = best as usize;
        // The best region hugging the border means the map could not close it.
        let (maxx, maxy) = (
            f64::from(self.camera.width_px) - 1.0,
            f64::from(self.camera.height_px) - 1.0,
        );
        let side = if x < 1.0 {
            Some(Side::Left)
        } else if x > maxx - 1.0 {
            Some(Side::Right)
        } else if y < 1.0 {
            Some(Side::Above)
        } else if y > maxy - 1.0 {
            Some(Side::Below)
        } else {
            None
        };
        FoeEstimate::point_or_beyond(&self.camera, x, y, side, support)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math;
    use crate::synth::{FlowFieldSpec, radial_normal_flow};

    #[test]
    fn finds_the_foe_of_noisy_normal_flow() {
        let cam = CameraIntrinsics::dvs240();
        for foe in [(120.0, 90.0), (50.0, 140.0)] {
            let spec = FlowFieldSpec {
                angle_noise_deg: 5.0,
                outlier_fraction: 0.1,
                ..FlowFieldSpec::clean(foe, 400)
            };
            let flow = radial_normal_flow(&cam, &spec, 1);
            let (x, y) = HalfPlaneMap::new(cam, HalfPlaneMapConfig::default())
                .estimate(&flow, 0)
                .point()
                .expect("a point");
            assert!(math::hypot(x - foe.0, y - foe.1) < 10.0, "{foe:?}: {x} {y}");
        }
    }

    #[test]
    fn foe_outside_is_reported_on_its_side() {
        let cam = CameraIntrinsics::dvs240();
        let flow = radial_normal_flow(&cam, &FlowFieldSpec::clean((120.0, 400.0), 300), 2);
        match HalfPlaneMap::new(cam, HalfPlaneMapConfig::default()).estimate(&flow, 0) {
            FoeEstimate::Unbounded { side, .. } => assert_eq!(side, Side::Below),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn degenerate_input_is_insufficient() {
        let cam = CameraIntrinsics::dvs240();
        let mut map = HalfPlaneMap::new(cam, HalfPlaneMapConfig::default());
        assert_eq!(
            map.estimate(&[], 0),
            FoeEstimate::Insufficient { vectors: 0 }
        );
    }
}
