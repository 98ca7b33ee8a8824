//! NESW vector counting (Huang 2018). Placeholder until implemented.
use super::{FoeEstimate, FoeEstimator};
use crate::camera::CameraIntrinsics;
use crate::flow::FlowVector;

pub struct Nesw {
    _camera: CameraIntrinsics,
}
impl Nesw {
    pub fn new(camera: CameraIntrinsics) -> Self {
        Self { _camera: camera }
    }
}
impl FoeEstimator for Nesw {
    fn name(&self) -> &'static str {
        "nesw"
    }
    fn estimate(&mut self, flow: &[FlowVector], _seed: u64) -> FoeEstimate {
        FoeEstimate::Insufficient {
            vectors: flow.len(),
        }
    }
}
