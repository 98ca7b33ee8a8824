//! Closed-loop flights: the real daemon (`daemon::serve` with its link, pipeline,
//! commander, safety gate and MSP stream, MAVLink and MSP bytes through the real
//! codecs) flying a simulated quadrotor at poles, against a simulated iNav on
//! simulated UARTs, with a simulated event camera rendering the true path.
//!
//! Everything runs in simulated time: one single-threaded tokio runtime whose clock
//! is paused and advanced by the simulation, so a flight takes what its work costs
//! on this machine, not its length, and the same flight is the same on every run and
//! every machine. The pipeline's compute is charged in simulated time from a model
//! of it ([`crate::cycle::compute`]), scaled to the board faithd is meant to fly on.
//! `faithd demo` flies one; `faithd sim` flies the paper's experiment.

pub mod autopilot;
pub mod calibrate;
pub mod camera;
pub mod experiment;
pub mod film;
pub mod physics;
pub mod plot;
pub mod straight;
pub mod uart;

use std::sync::Arc;

use serde::Serialize;
use tokio::sync::mpsc;

use crate::cycle::compute::ComputeCharge;
pub use camera::CameraKind;
use faithd_daemon::clock::DaemonClock;
use faithd_daemon::command::{MspSink, Sink};
use faithd_daemon::config::FaithdConfig;
use faithd_daemon::cycle::CycleReport;
use faithd_daemon::daemon::{self, Ended, Execution, Hooks, Observation};
use faithd_daemon::transport::Address;
pub use faithd_sim::world::SceneKind;
use physics::{PathPoint, Shared, VEHICLE_RADIUS_M};

/// Unix time a simulated flight calls its start: fixed, so that nothing in a
/// flight depends on when it was flown.
const SIMULATED_START_UNIX_US: i64 = 1_700_000_000_000_000;

/// One flight to fly.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FlightSpec {
    /// Poles (x, y), metres; the first is the one the course is laid against.
    pub poles: Vec<(f64, f64)>,
    /// Where the straight path passes the first pole: + to its right, metres.
    pub lateral_offset_m: f64,
    /// Course relative to the arena's axis, degrees.
    pub heading_deg: f64,
    pub speed_m_s: f64,
    /// Distance along the course from the start to abeam the first pole.
    pub start_distance_m: f64,
    /// Surface texture contrast (1 = the arena's, lower = poorly textured).
    pub contrast: f64,
    /// Background-activity noise, events per pixel per second.
    pub noise_rate_hz: f64,
    /// The daemon and iNav run this long before the flight starts, the vehicle
    /// waiting at its start: faithd is a service that runs from boot, so on a real
    /// approach its link is up, iNav's once-a-second HEARTBEAT has come and the MSP
    /// stream is warm. Flight times (`decision_s`, the path) count from the end of it.
    pub lead_in_s: f64,
    /// The pilot puts the switch in AUTO at `auto_at_s`; false keeps it in MANUAL.
    pub pilot_auto: bool,
    pub auto_at_s: f64,
    pub max_time_s: f64,
    pub seed: u64,
    /// The room the poles stand in (the ray-traced camera; the line camera always
    /// draws the arena).
    pub scene: SceneKind,
    pub camera: CameraKind,
}

impl Default for FlightSpec {
    fn default() -> Self {
        Self {
            poles: vec![(0.0, 0.0)],
            lateral_offset_m: 0.0,
            heading_deg: 0.0,
            speed_m_s: 2.0,
            start_distance_m: 5.5,
            contrast: 1.0,
            noise_rate_hz: 0.5,
            lead_in_s: 1.5,
            pilot_auto: true,
            auto_at_s: 0.5,
            max_time_s: 8.0,
            seed: 1,
            scene: SceneKind::Arena,
            camera: CameraKind::Dvs,
        }
    }
}

impl FlightSpec {
    /// Pole radius plus vehicle half-span: closer than this, flying straight hits.
    pub fn contact_distance_m() -> f64 {
        0.25 + VEHICLE_RADIUS_M
    }

    /// Where the flight ends: 1 m past the pole the course is laid against. Flying
    /// on (to past a second pole) would take the vehicle to within a second of the
    /// back wall, where rolling is the right call and not a false avoidance.
    pub fn end_x_m(&self) -> f64 {
        self.poles[0].0 + 1.0
    }

    /// True time to contact with the first pole from `x_m` along the arena's axis,
    /// seconds (negative once past it).
    pub fn true_ttc_s(&self, x_m: f64) -> f64 {
        ((self.poles[0].0 - x_m) - Self::contact_distance_m()) / self.speed_m_s
    }

    /// Whether flying straight on would hit the first pole.
    pub fn is_collision_course(&self) -> bool {
        self.lateral_offset_m.abs() < Self::contact_distance_m()
    }
}

/// What a simulated flight's pipeline cost, as charged in simulated time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct CycleFigures {
    pub cycles: usize,
    /// Cycles whose charged time exceeded `daemon.budget_us`.
    pub overruns: usize,
    /// Cycles run with load shed (fewer vectors and iterations).
    pub shed_cycles: usize,
    pub max_load_level: u32,
    pub charged_us_p50: f64,
    pub charged_us_p99: f64,
    pub charged_us_max: f64,
    /// Camera batches dropped because the pipeline's queue was full.
    pub dropped_batches: u64,
}

/// How to fly: what a cycle's compute costs in simulated time, and whether to keep
/// the flight's frames for a video.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FlyOptions {
    pub compute: ComputeCharge,
    /// Keep every window as a video frame ([`FlightOutcome::film`]).
    #[serde(skip)]
    pub film: bool,
}

impl Default for FlyOptions {
    fn default() -> Self {
        Self {
            compute: ComputeCharge::modelled(1.0),
            film: false,
        }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct FlightOutcome {
    pub spec: FlightSpec,
    pub collision_course: bool,
    pub collided: bool,
    /// faithd started a roll.
    pub rolled: bool,
    /// Smallest gap between the vehicle's edge and a pole's surface, metres.
    pub min_clearance_m: f64,
    /// Flight time of the roll decision, seconds.
    pub decision_s: Option<f64>,
    /// True time to contact with the first pole when the roll started, seconds.
    pub ttc_at_decision_s: Option<f64>,
    /// From the newest event of the deciding window to the first roll frame's arrival
    /// at the autopilot, milliseconds.
    pub latency_ms: Option<f64>,
    /// The same from the newest event of the first window of the unbroken run of
    /// roll calls that led to the roll: includes the time the safety gate held it
    /// (the switch not yet in AUTO, the MSP stream not yet warm).
    pub latency_from_first_call_ms: Option<f64>,
    /// Flight time of the newest event of the deciding window, and of the roll's
    /// arrival at the autopilot, seconds (to line the path up with the latencies).
    #[serde(skip)]
    pub event_s: Option<f64>,
    #[serde(skip)]
    pub roll_in_use_s: Option<f64>,
    /// Simulated time the daemon's compute cost, and what it shed.
    pub pipeline: CycleFigures,
    /// Events the camera fired.
    pub events: u64,
    /// The decision that started the roll, with its evidence.
    pub decision: Option<faithd_core::decide::Decision>,
    pub path: Vec<PathPoint>,
    /// The flight's frames, when [`FlyOptions::film`] asked for them.
    #[serde(skip)]
    pub film: Option<film::FilmedFlight>,
}

/// Flies one flight end to end in simulated time. Fails when the daemon ended on a
/// fault (a panic in one of its tasks): that is a defect, never an outcome.
pub fn fly(spec: &FlightSpec, options: &FlyOptions) -> std::io::Result<FlightOutcome> {
    fly_with(spec, options, faithd_daemon::supervise::Faults::new())
}

/// [`fly`], with the flight's faults in a handle of the caller's: a fault reported
/// on it, or a panic on the flight's thread, ends this flight alone.
pub fn fly_with(
    spec: &FlightSpec,
    options: &FlyOptions,
    faults: faithd_daemon::supervise::Faults,
) -> std::io::Result<FlightOutcome> {
    // One thread and a paused clock that advances only when every task waits: the
    // flight's order of events is fixed by its inputs, never by the machine.
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .start_paused(true)
        .build()?;
    let _run = faults.enter();
    runtime.block_on(fly_simulated(spec, options, faults))
}

async fn fly_simulated(
    spec: &FlightSpec,
    options: &FlyOptions,
    faults: faithd_daemon::supervise::Faults,
) -> std::io::Result<FlightOutcome> {
    let clock = DaemonClock::simulated(SIMULATED_START_UNIX_US);
    let shared = Arc::new(Shared::new(physics::initial_quad(spec).state()));
    let inav = autopilot::start(shared.clone(), clock);

    let mut config = FaithdConfig::default();
    config.mavlink.endpoint = Address::InProcess(inav.mavlink);
    config.command.sink = Sink::Msp(MspSink {
        endpoint: Address::InProcess(inav.msp),
        ..MspSink::default()
    });
    // Simulated flights are not recorded.
    config.record.enabled = false;
    let endpoint = config.mavlink.port();
    let msp_endpoint = config.command.msp_port();
    let budget_us = config.daemon.budget_us;
    let (manoeuvre, period_us, pipeline_config) =
        (config.manoeuvre, config.daemon.period_us, config.pipeline);
    let (obs_tx, mut obs_rx) = mpsc::unbounded_channel();
    let (cycles_tx, mut cycles_rx) = mpsc::unbounded_channel();
    let (frames_tx, mut frames_rx) = mpsc::unbounded_channel();
    let world_spec = spec.clone();
    let world_shared = shared.clone();
    let hooks = Hooks {
        clock,
        execution: Execution::Tasks {
            source: Box::new(move |clock, batches| {
                Box::pin(physics::run(world_spec, world_shared, clock, batches))
            }),
            pipeline: crate::cycle::pipeline_task(
                options.compute,
                crate::cycle::SimulatedTaps {
                    cycles: Some(cycles_tx),
                    frames: options.film.then_some(frames_tx),
                },
            ),
        },
        observer: Some(Box::new(move |o| {
            let _ = obs_tx.send(o);
        })),
        faults,
    };
    let start_us = clock.now_us() + (spec.lead_in_s * 1e6) as i64;
    let done = shared.clone();
    let ended = daemon::serve(config, endpoint, msp_endpoint, hooks, async move {
        done.done.notified().await;
        "the flight ended"
    })
    .await;
    if let Ended::Fault(why) | Ended::Refused { reason: why, .. } = ended {
        return Err(std::io::Error::other(format!(
            "the daemon stopped on a fault: {why}"
        )));
    }

    let log = shared
        .log
        .lock()
        .expect("log lock")
        .take()
        .unwrap_or_default();
    let mut started = None;
    let mut gates = Vec::new();
    while let Ok(observation) = obs_rx.try_recv() {
        match observation {
            Observation::ManoeuvreStarted {
                last_event_us,
                first_call_event_us,
                started_us,
                decision,
            } => {
                started.get_or_insert((last_event_us, first_call_event_us, started_us, decision));
            }
            Observation::Gate { t_us, gate } => gates.push((t_us, gate)),
        }
    }
    let decision = started.map(|(_, _, _, d)| d);
    let started = started.map(|(last, first, at, _)| (last, first, at));
    let first_rx = shared
        .first_roll_rx_us
        .load(std::sync::atomic::Ordering::Relaxed);
    let decision_s = started.map(|(_, _, s)| (s - start_us) as f64 * 1e-6);
    let ttc_at_decision_s = decision_s.and_then(|t| {
        let p = log
            .path
            .iter()
            .min_by(|a, b| (a.t_s - t).abs().total_cmp(&(b.t_s - t).abs()))?;
        Some(spec.true_ttc_s(p.x_m))
    });
    let rx_after = |event_us: i64| (first_rx - event_us) as f64 / 1e3;
    let received = started.filter(|_| first_rx != i64::MIN);
    let mut reports = Vec::new();
    while let Ok(r) = cycles_rx.try_recv() {
        reports.push(r);
    }
    let film = options.film.then(|| {
        let mut windows = Vec::new();
        while let Ok(frame) = frames_rx.try_recv() {
            windows.push(frame);
        }
        film::assemble(
            windows,
            &film::WorldRecord {
                start_us,
                path: &log.path,
                gates: &gates,
                spec,
                manoeuvre: &manoeuvre,
                period_us,
                pipeline: &pipeline_config,
            },
        )
    });
    let mut pipeline = cycle_figures(&reports, budget_us);
    pipeline.dropped_batches = shared
        .dropped_batches
        .load(std::sync::atomic::Ordering::Relaxed);
    Ok(FlightOutcome {
        spec: spec.clone(),
        collision_course: spec.is_collision_course(),
        collided: log.collided,
        rolled: started.is_some(),
        min_clearance_m: log.min_clearance_m,
        decision_s,
        ttc_at_decision_s,
        latency_ms: received.map(|(last, _, _)| rx_after(last)),
        latency_from_first_call_ms: received.map(|(_, first, _)| rx_after(first)),
        event_s: started.map(|(last, _, _)| (last - start_us) as f64 * 1e-6),
        roll_in_use_s: received.map(|_| (first_rx - start_us) as f64 * 1e-6),
        pipeline,
        events: log.events,
        decision,
        path: log.path,
        film,
    })
}

/// The charged cycle times of a flight, summed up.
fn cycle_figures(reports: &[CycleReport], budget_us: i64) -> CycleFigures {
    let mut charged: Vec<f64> = reports.iter().map(|r| r.charged_us as f64).collect();
    charged.sort_by(f64::total_cmp);
    let pick = |q: f64| experiment::percentile(&charged, q);
    CycleFigures {
        cycles: reports.len(),
        overruns: reports.iter().filter(|r| r.charged_us > budget_us).count(),
        shed_cycles: reports.iter().filter(|r| r.load_level > 0).count(),
        max_load_level: reports.iter().map(|r| r.load_level).max().unwrap_or(0),
        charged_us_p50: pick(0.5),
        charged_us_p99: pick(0.99),
        charged_us_max: charged.last().copied().unwrap_or(f64::NAN),
        dropped_batches: 0,
    }
}
