//! Focus-of-expansion estimators: where in the image the vehicle is heading.
//!
//! Under pure translation every flow vector points away from the FOE, so the FOE lies
//! in the negative half-plane behind each vector (Clady 2014). FAITH (the paper's
//! Algorithm 1) samples those half-planes RANSAC-style; the three baselines of the
//! paper's Table I are here too so the benchmark compares like with like.

pub mod faith;
pub mod half_plane_map;
pub mod nesw;
pub mod polygon;
pub mod speed_fit;
pub mod vec_intersections;

pub use faith::{Faith, FaithConfig};
pub use half_plane_map::{HalfPlaneMap, HalfPlaneMapConfig};
pub use nesw::Nesw;
pub use vec_intersections::{VecIntersections, VecIntersectionsConfig};

use crate::camera::CameraIntrinsics;
use crate::flow::FlowVector;
use crate::math;

/// Which image border the FOE lies beyond when it is outside the field of view.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    Left,
    Right,
    Above,
    Below,
}

impl Side {
    /// The dominant side of a direction given in image axes (x right, y down).
    pub fn of_direction(dx: f64, dy: f64) -> Side {
        if dx.abs() >= dy.abs() {
            if dx < 0.0 { Side::Left } else { Side::Right }
        } else if dy < 0.0 {
            Side::Above
        } else {
            Side::Below
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Side::Left => "left",
            Side::Right => "right",
            Side::Above => "above",
            Side::Below => "below",
        }
    }
}

/// What an estimator could say about the FOE for one window of flow.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FoeEstimate {
    /// A point in pixel coordinates (it may lie slightly outside the sensor).
    Point {
        x_px: f64,
        y_px: f64,
        /// Flow vectors consistent with this FOE (the RANSAC score).
        support: usize,
    },
    /// The flow does not bound the FOE: it lies beyond the image on `side`, in the
    /// direction (`dx`, `dy`) (unit, image axes) from the image centre.
    Unbounded {
        side: Side,
        dx: f64,
        dy: f64,
        support: usize,
    },
    /// Too few usable vectors to say anything.
    Insufficient { vectors: usize },
}

impl FoeEstimate {
    /// The FOE lies beyond the view, in the direction of `(x_px, y_px)` seen from the
    /// principal point; `side` is that direction's dominant side unless given.
    pub fn unbounded_towards(
        camera: &CameraIntrinsics,
        x_px: f64,
        y_px: f64,
        side: Option<Side>,
        support: usize,
    ) -> Self {
        let (dx, dy) = (x_px - camera.cx_px, y_px - camera.cy_px);
        let len = math::hypot(dx, dy).max(f64::MIN_POSITIVE);
        FoeEstimate::Unbounded {
            side: side.unwrap_or_else(|| Side::of_direction(dx, dy)),
            dx: dx / len,
            dy: dy / len,
            support,
        }
    }

    /// A point, or `Unbounded` toward it when the method found it on a border `side`.
    pub fn point_or_beyond(
        camera: &CameraIntrinsics,
        x_px: f64,
        y_px: f64,
        side: Option<Side>,
        support: usize,
    ) -> Self {
        match side {
            Some(side) => Self::unbounded_towards(camera, x_px, y_px, Some(side), support),
            None => FoeEstimate::Point {
                x_px,
                y_px,
                support,
            },
        }
    }

    pub fn point(&self) -> Option<(f64, f64)> {
        match *self {
            FoeEstimate::Point { x_px, y_px, .. } => Some((x_px, y_px)),
            _ => None,
        }
    }

    pub fn support(&self) -> usize {
        match *self {
            FoeEstimate::Point { support, .. } | FoeEstimate::Unbounded { support, .. } => support,
            FoeEstimate::Insufficient { .. } => 0,
        }
    }
}

/// One FOE method of the benchmark.
///
/// `seed` makes the randomised methods reproducible per window: the pipeline derives
/// it from its configured seed and the window time, so any window of a recorded flight
/// can be recomputed on its own. Deterministic methods ignore it.
pub trait FoeEstimator {
    /// Stable name used in benchmark tables and JSON (`faith`, `half_planes`, ...).
    fn name(&self) -> &'static str;

    fn estimate(&mut self, flow: &[FlowVector], seed: u64) -> FoeEstimate;
}

/// The four methods of Table I, selectable from config.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FoeMethod {
    Faith,
    HalfPlanes,
    Nesw,
    VecIntersections,
}

impl FoeMethod {
    pub const ALL: [FoeMethod; 4] = [
        FoeMethod::Faith,
        FoeMethod::HalfPlanes,
        FoeMethod::Nesw,
        FoeMethod::VecIntersections,
    ];

    pub fn name(self) -> &'static str {
        match self {
            FoeMethod::Faith => "faith",
            FoeMethod::HalfPlanes => "half_planes",
            FoeMethod::Nesw => "nesw",
            FoeMethod::VecIntersections => "vec_intersections",
        }
    }
}
