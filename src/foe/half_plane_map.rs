//! Half-plane probability map (Clady 2014). Placeholder until implemented.
use super::{FoeEstimate, FoeEstimator};
use crate::camera::CameraIntrinsics;
use crate::flow::FlowVector;

#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HalfPlaneMapConfig {}

pub struct HalfPlaneMap {
    _camera: CameraIntrinsics,
}
impl HalfPlaneMap {
    pub fn new(camera: CameraIntrinsics, _config: HalfPlaneMapConfig) -> Self {
        Self { _camera: camera }
    }
}
impl FoeEstimator for HalfPlaneMap {
    fn name(&self) -> &'static str {
        "half_planes"
    }
    fn estimate(&mut self, flow: &[FlowVector], _seed: u64) -> FoeEstimate {
        FoeEstimate::Insufficient {
            vectors: flow.len(),
        }
    }
}
