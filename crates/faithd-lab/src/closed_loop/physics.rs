//! The simulated world, stepped every millisecond of simulated time: the vehicle
//! banks toward what the simulated iNav's ANGLE makes of the roll it uses, the camera renders events along
//! the true path, the pilot's switch goes to AUTO on time, and the flight ends past
//! the first pole or on contact.

use std::sync::atomic::{AtomicBool, AtomicI64, AtomicU16, AtomicU64, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use nalgebra::Vector3;
use serde::Serialize;

use super::FlightSpec;
use super::camera::{FlightCamera, arena};
use faithd_core::event::Event;
use faithd_daemon::clock::DaemonClock;
use faithd_sim::world::line_camera::ArenaSpec;
use faithd_sim::world::quad::{Quad, QuadConfig};
use faithd_sim::world::trajectory::VehicleState;

/// Half the span of the vehicle: contact when its centre comes this close to a pole's surface.
pub const VEHICLE_RADIUS_M: f64 = 0.15;

/// Physics and camera step.
pub const STEP_US: i64 = 1000;

/// State shared by the world and the simulated autopilot.
pub struct Shared {
    pub roll_us: AtomicU16,
    /// The bank iNav's ANGLE aims at for that roll, radians (`f64` bits): what
    /// the physics flies toward.
    pub bank_target_rad: AtomicU64,
    pub switch_auto: AtomicBool,
    pub state: Mutex<VehicleState>,
    /// Daemon time the first deflected roll was in use at the autopilot; `i64::MIN`
    /// until then.
    pub first_roll_rx_us: AtomicI64,
    /// Camera batches the pipeline's queue had no room for.
    pub dropped_batches: AtomicU64,
    pub done: tokio::sync::Notify,
    pub log: Mutex<Option<FlightLog>>,
}

#[derive(Clone, Copy, Debug, Serialize)]
pub struct PathPoint {
    pub t_s: f64,
    pub x_m: f64,
    pub y_m: f64,
    pub bank_deg: f64,
    pub roll_us: u16,
    /// Where the vehicle is heading in the camera's picture, pixels (`None`: behind
    /// it): what the pipeline's FOE estimates.
    pub true_foe_px: Option<(f64, f64)>,
}

#[derive(Clone, Debug, Default)]
pub struct FlightLog {
    pub path: Vec<PathPoint>,
    pub collided: bool,
    /// Smallest distance between the vehicle's edge and a pole's surface.
    pub min_clearance_m: f64,
    /// Events the camera fired.
    pub events: u64,
}

impl Shared {
    pub fn new(initial: VehicleState) -> Self {
        Self {
            roll_us: AtomicU16::new(1500),
            bank_target_rad: AtomicU64::new(0f64.to_bits()),
            switch_auto: AtomicBool::new(false),
            state: Mutex::new(initial),
            first_roll_rx_us: AtomicI64::new(i64::MIN),
            dropped_batches: AtomicU64::new(0),
            done: tokio::sync::Notify::new(),
            log: Mutex::new(None),
        }
    }
}

pub fn initial_quad(spec: &FlightSpec) -> Quad {
    let heading = spec.heading_deg.to_radians();
    // Start so that the straight path passes the first pole at the lateral offset.
    let pole = spec.poles[0];
    let back_m = spec.start_distance_m;
    let (s, c) = heading.sin_cos();
    let right = Vector3::new(-s, c, 0.0);
    let forward = Vector3::new(c, s, 0.0);
    let at_pole = Vector3::new(pole.0, pole.1, -1.0) + right * spec.lateral_offset_m;
    let start = at_pole - forward * back_m;
    Quad::new(
        QuadConfig {
            speed_m_s: spec.speed_m_s,
            ..Default::default()
        },
        start,
        heading,
    )
}

/// Smallest gap between the vehicle's edge at `position_m` and a pole's surface;
/// negative on contact.
pub fn clearance_m(arena: &ArenaSpec, position_m: &Vector3<f64>) -> f64 {
    arena
        .poles
        .iter()
        .map(|p| (position_m.x - p.x_m).hypot(position_m.y - p.y_m) - p.radius_m - VEHICLE_RADIUS_M)
        .fold(f64::INFINITY, f64::min)
}

/// The world as a task in simulated time; runs until the flight ends, then
/// signals `done`.
pub async fn run(
    spec: FlightSpec,
    shared: Arc<Shared>,
    clock: DaemonClock,
    batches: SyncSender<Vec<Event>>,
) {
    // Waiting at the start while the daemon boots: nothing moves, nothing fires.
    tokio::time::sleep(Duration::from_micros((spec.lead_in_s * 1e6) as u64)).await;
    let mut quad = initial_quad(&spec);
    let arena = arena(&spec);
    let mut camera = FlightCamera::new(&spec);
    let (intrinsics, mounting) = super::camera::optics();
    let mut log = FlightLog {
        min_clearance_m: f64::INFINITY,
        ..Default::default()
    };
    let start_us = clock.now_us();
    let mut t_us = start_us;
    let mut first = Vec::new();
    camera.step(&quad.state(), t_us, &mut first);
    let end_x_m = spec.end_x_m();
    let mut tick = tokio::time::interval_at(
        tokio::time::Instant::now() + Duration::from_micros(STEP_US as u64),
        Duration::from_micros(STEP_US as u64),
    );
    loop {
        tick.tick().await;
        t_us += STEP_US;
        let roll_us = shared.roll_us.load(Ordering::Relaxed);
        let target_rad = f64::from_bits(shared.bank_target_rad.load(Ordering::Relaxed));
        quad.step(target_rad, STEP_US as f64 * 1e-6);
        let state = quad.state();
        let mut batch = Vec::new();
        camera.step(&state, t_us, &mut batch);
        log.events += batch.len() as u64;
        *shared.state.lock().expect("state lock") = state;
        let elapsed_s = (t_us - start_us) as f64 * 1e-6;
        if elapsed_s >= spec.auto_at_s && spec.pilot_auto {
            shared.switch_auto.store(true, Ordering::Relaxed);
        }
        let clearance = clearance_m(&arena, &quad.position_m);
        log.min_clearance_m = log.min_clearance_m.min(clearance);
        if (t_us - start_us) % 10_000 == 0 {
            log.path.push(PathPoint {
                t_s: elapsed_s,
                x_m: quad.position_m.x,
                y_m: quad.position_m.y,
                bank_deg: quad.bank_rad.to_degrees(),
                roll_us,
                true_foe_px: state.true_foe_px(&intrinsics, &mounting),
            });
        }
        if !batch.is_empty() {
            match batches.try_send(batch) {
                Ok(()) => {}
                Err(TrySendError::Full(_)) => {
                    shared.dropped_batches.fetch_add(1, Ordering::Relaxed);
                }
                // The pipeline has stopped: the daemon is ending.
                Err(TrySendError::Disconnected(_)) => return,
            }
        }
        let ended = clearance < 0.0 || quad.position_m.x > end_x_m || elapsed_s > spec.max_time_s;
        if ended {
            log.collided = clearance < 0.0;
            *shared.log.lock().expect("log lock") = Some(log);
            shared.done.notify_one();
            return;
        }
    }
}
