//! The camera of a simulated flight: the ray-traced DVS simulator of `bench foe`
//! (the realistic one: textured scenes, threshold mismatch, refractory period,
//! noise), or the analytic line camera (pole silhouettes and wall stripes, much
//! cheaper, for quick runs).

use serde::Serialize;

use super::FlightSpec;
use faithd_core::camera::{CameraIntrinsics, Mounting};
use faithd_core::event::Event;
use faithd_sim::world::line_camera::{ArenaSpec, LineCamera};
use faithd_sim::world::scenes::with_poles;
use faithd_sim::world::{DvsConfig, EventCamera, Scene, VehicleState, render_interval_us};

/// Every simulated flight's camera: a DVS240 looking straight ahead. The true FOE
/// of the flight's video is projected through the same.
pub fn optics() -> (CameraIntrinsics, Mounting) {
    (CameraIntrinsics::dvs240(), Mounting::forward())
}

/// Which camera renders a flight.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CameraKind {
    /// The ray-traced DVS simulator, in the flight's scene.
    #[default]
    Dvs,
    /// The analytic line camera (the arena only).
    Line,
}

/// A flight's camera, stepped along the vehicle's true path.
pub enum FlightCamera {
    Line(Box<LineCamera>),
    Dvs(Box<DvsView>),
}

/// The ray-traced camera and the scene it flies through.
pub struct DvsView {
    scene: Scene,
    camera: EventCamera,
    /// When the next render is due (the adaptive rate below).
    next_render_us: Option<i64>,
}

/// The ray-traced camera renders as often as the image moves (as ESIM does): the
/// next render comes when the fastest pixel has moved this far, at most 1 kHz (the
/// rate `bench foe` renders at throughout) and at least every 3 ms. Crossings
/// between renders are interpolated linearly, right while an edge moves under a
/// pixel; the events of an interval reach the daemon at its end, as a USB camera
/// delivers them in packets a few milliseconds apart.
const RENDER_MAX_DISPLACEMENT_PX: f64 = 0.5;
const RENDER_MIN_INTERVAL_US: i64 = 1000;
const RENDER_MAX_INTERVAL_US: i64 = 3000;

impl FlightCamera {
    pub fn new(spec: &FlightSpec) -> Self {
        match spec.camera {
            CameraKind::Line => {
                let mut arena = arena(spec);
                arena.contrast = spec.contrast;
                let (intrinsics, mounting) = optics();
                let mut camera = LineCamera::new(intrinsics, mounting, arena, spec.seed);
                camera.noise_rate_hz = spec.noise_rate_hz;
                FlightCamera::Line(Box::new(camera))
            }
            CameraKind::Dvs => {
                let mut scene = with_poles(spec.scene, spec.seed, &spec.poles);
                for solid in &mut scene.solids {
                    solid.texture.contrast *= spec.contrast;
                }
                let dvs = DvsConfig {
                    noise_rate_hz: spec.noise_rate_hz,
                    ..DvsConfig::default()
                };
                let (intrinsics, mounting) = optics();
                let camera = EventCamera::new(intrinsics, mounting, dvs, spec.seed);
                FlightCamera::Dvs(Box::new(DvsView {
                    scene,
                    camera,
                    next_render_us: None,
                }))
            }
        }
    }

    /// Moves the camera to `state` at `t_us` (called every physics step); appends the
    /// events it has fired since the last call, time-ordered.
    pub fn step(&mut self, state: &VehicleState, t_us: i64, out: &mut Vec<Event>) {
        match self {
            FlightCamera::Line(c) => c.advance(state, t_us, out),
            FlightCamera::Dvs(v) => {
                if v.next_render_us.is_some_and(|due| t_us < due) {
                    return;
                }
                v.camera.advance(&v.scene, state, t_us, out);
                let speed_px_s = v.camera.max_image_speed_px_s(state);
                let interval_us = render_interval_us(
                    speed_px_s,
                    RENDER_MAX_DISPLACEMENT_PX,
                    RENDER_MIN_INTERVAL_US,
                    RENDER_MAX_INTERVAL_US,
                );
                // On the physics' millisecond steps.
                v.next_render_us = Some(t_us + interval_us / 1000 * 1000);
            }
        }
    }
}

/// The poles of a flight (contact is judged against these), as the line camera
/// draws them.
pub fn arena(spec: &FlightSpec) -> ArenaSpec {
    ArenaSpec::with_poles(&spec.poles)
}
