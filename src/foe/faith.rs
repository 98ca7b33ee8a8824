//! FAITH (placeholder, being written).
use super::{FoeEstimate, FoeEstimator};
use crate::camera::CameraIntrinsics;
use crate::flow::FlowVector;

#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FaithConfig {}

pub struct Faith {
    _camera: CameraIntrinsics,
}
impl Faith {
    pub fn new(camera: CameraIntrinsics, _config: FaithConfig) -> Self {
        Self { _camera: camera }
    }
}
impl FoeEstimator for Faith {
    fn name(&self) -> &'static str {
        "faith"
    }
    fn estimate(&mut self, flow: &[FlowVector], _seed: u64) -> FoeEstimate {
        FoeEstimate::Insufficient { vectors: flow.len() }
    }
}
