//! Vector intersections with RANSAC (Buczko 2017). Placeholder until implemented.
use super::{FoeEstimate, FoeEstimator};
use crate::camera::CameraIntrinsics;
use crate::flow::FlowVector;

#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VecIntersectionsConfig {}

pub struct VecIntersections {
    _camera: CameraIntrinsics,
}
impl VecIntersections {
    pub fn new(camera: CameraIntrinsics, _config: VecIntersectionsConfig) -> Self {
        Self { _camera: camera }
    }
}
impl FoeEstimator for VecIntersections {
    fn name(&self) -> &'static str {
        "vec_intersections"
    }
    fn estimate(&mut self, flow: &[FlowVector], _seed: u64) -> FoeEstimate {
        FoeEstimate::Insufficient {
            vectors: flow.len(),
        }
    }
}
