//! The simulated world and board of closed-loop flights, as `demo`, `sim` and
//! `bench compute` take them.

use clap::Args;

use faithd::closed_loop::{CameraKind, SceneKind};
use faithd::orchestrate::world::{self, World};

/// The simulated world and board of a closed-loop flight.
#[derive(Args)]
pub struct WorldArgs {
    /// The camera: the ray-traced DVS simulator (realistic) or the analytic line
    /// camera (pole silhouettes and stripes; fast).
    #[arg(long, value_enum, default_value_t = Camera::Dvs)]
    camera: Camera,
    /// The room the poles stand in (the DVS camera; the line camera draws the arena).
    #[arg(long, value_enum, default_value_t = Scene::Arena)]
    scene: Scene,
    /// How much slower than this machine the board computes: 1 is this machine,
    /// `atom` the paper's Intel Atom x5-Z8350 (see docs/tuning.md).
    #[arg(long, default_value = "1", value_parser = parse_cpu_scale)]
    cpu_scale: f64,
    /// What a pipeline cycle costs in simulated time: the calibrated model of this
    /// machine (the same on every run) or the time measured now (follows the load).
    #[arg(long, value_enum, default_value_t = Compute::Model)]
    compute: Compute,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Camera {
    Dvs,
    Line,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Scene {
    Arena,
    Kitchen,
    Shelves,
    Warehouse,
    /// The four in turn, flight by flight (`faithd sim`).
    Mixed,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Compute {
    Model,
    Measured,
}

/// `--cpu-scale`: a factor of 0.01 to 100, or `atom`.
pub fn parse_cpu_scale(text: &str) -> Result<f64, String> {
    if text.eq_ignore_ascii_case("atom") {
        return Ok(faithd::cycle::compute::ATOM_X5_Z8350_SCALE);
    }
    let scale: f64 = text
        .parse()
        .map_err(|_| format!("`{text}` is neither a number nor `atom`"))?;
    if (0.01..=100.0).contains(&scale) {
        Ok(scale)
    } else {
        Err(format!("must be 0.01 to 100, got {scale}"))
    }
}

impl WorldArgs {
    /// The world the lab flies in.
    pub fn world(&self) -> World {
        World {
            camera: match self.camera {
                Camera::Dvs => CameraKind::Dvs,
                Camera::Line => CameraKind::Line,
            },
            scene: match self.scene {
                Scene::Arena => world::Scene::One(SceneKind::Arena),
                Scene::Kitchen => world::Scene::One(SceneKind::Kitchen),
                Scene::Shelves => world::Scene::One(SceneKind::Shelves),
                Scene::Warehouse => world::Scene::One(SceneKind::Warehouse),
                Scene::Mixed => world::Scene::Mixed,
            },
            compute: match self.compute {
                Compute::Model => world::Compute::Model,
                Compute::Measured => world::Compute::Measured,
            },
            cpu_scale: self.cpu_scale,
        }
    }
}
