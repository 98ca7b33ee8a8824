//! The simulated world and board of closed-loop flights: the camera, the room, and
//! what a pipeline cycle costs in simulated time.

use std::fmt;

use crate::closed_loop::{CameraKind, FlightSpec, FlyOptions, SceneKind};
use crate::cycle::compute::ComputeCharge;

/// The room the poles stand in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scene {
    One(SceneKind),
    /// The four scenes in turn, flight by flight.
    Mixed,
}

/// What a pipeline cycle costs in simulated time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compute {
    /// The calibrated model of this machine: the same on every run.
    Model,
    /// The time measured now: follows the load.
    Measured,
}

/// Where and on what the flights fly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct World {
    pub camera: CameraKind,
    pub scene: Scene,
    pub compute: Compute,
    /// How much slower than this machine the board computes.
    pub cpu_scale: f64,
}

impl World {
    /// How to fly in this world (without a film).
    pub fn options(&self) -> FlyOptions {
        FlyOptions {
            compute: match self.compute {
                Compute::Model => ComputeCharge::modelled(self.cpu_scale),
                Compute::Measured => ComputeCharge::Measured {
                    cpu_scale: self.cpu_scale,
                },
            },
            film: false,
        }
    }

    /// Sets the camera and scene of flight `index`.
    pub fn apply(&self, index: usize, spec: &mut FlightSpec) {
        spec.camera = self.camera;
        spec.scene = match self.scene {
            Scene::One(kind) => kind,
            Scene::Mixed => SceneKind::ALL[index % SceneKind::ALL.len()],
        };
    }
}

/// The world in words, as the runs' logs and reports name it.
impl fmt::Display for World {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let camera = match self.camera {
            CameraKind::Dvs => "ray-traced DVS",
            CameraKind::Line => "analytic line",
        };
        let room = match (self.camera, self.scene) {
            (CameraKind::Line, _) => "",
            (_, Scene::One(SceneKind::Arena)) => " in the arena",
            (_, Scene::One(SceneKind::Kitchen)) => " in the kitchen",
            (_, Scene::One(SceneKind::Shelves)) => " among shelves",
            (_, Scene::One(SceneKind::Warehouse)) => " in the warehouse",
            (_, Scene::Mixed) => " in the four scenes in turn",
        };
        let compute = match self.compute {
            Compute::Model => "modelled",
            Compute::Measured => "measured",
        };
        write!(
            f,
            "{camera} camera{room}, compute {compute} at cpu scale {}",
            self.cpu_scale
        )
    }
}
