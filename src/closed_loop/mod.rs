//! Closed-loop flights: the real daemon (same tasks, same safety gate, same MAVLink
//! bytes over a loopback socket) flying a simulated quadrotor at poles, against a
//! simulated iNav, with a simulated event camera rendering the true path. Runs in
//! real time. `faithd demo` flies one; `faithd sim` flies the paper's experiment.

pub mod autopilot;
pub mod experiment;
pub mod inav_mavlink;
pub mod inav_msp;
pub mod physics;
pub mod plot;
pub mod straight;

use std::sync::Arc;

use serde::Serialize;
use tokio::sync::mpsc;

use crate::clock::DaemonClock;
use crate::command::{MspSink, Sink};
use crate::config::FaithdConfig;
use crate::daemon::{self, Hooks, Observation};
use crate::link::endpoint::Address;
use physics::{PathPoint, Shared, VEHICLE_RADIUS_M};

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
    /// The pilot puts the switch in AUTO at `auto_at_s`; false keeps it in MANUAL.
    pub pilot_auto: bool,
    pub auto_at_s: f64,
    pub max_time_s: f64,
    pub seed: u64,
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
            pilot_auto: true,
            auto_at_s: 0.5,
            max_time_s: 8.0,
            seed: 1,
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
    /// The decision that started the roll, with its evidence.
    pub decision: Option<faithd_core::decide::Decision>,
    pub path: Vec<PathPoint>,
}

/// Flies one flight end to end; blocks for its duration (real time).
pub fn fly(spec: &FlightSpec) -> std::io::Result<FlightOutcome> {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    runtime.block_on(fly_async(spec))
}

async fn fly_async(spec: &FlightSpec) -> std::io::Result<FlightOutcome> {
    let clock = DaemonClock::start();
    let socket = tokio::net::UdpSocket::bind("127.0.0.1:0").await?;
    let port = socket.local_addr()?.port();
    let shared = Arc::new(Shared::new(physics::initial_quad(spec).state()));
    tokio::spawn(autopilot::run(socket, shared.clone(), clock));
    let msp = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let msp_port = msp.local_addr()?.port();
    tokio::spawn(autopilot::run_msp(msp, shared.clone(), clock));

    let mut config = FaithdConfig::default();
    config.mavlink.endpoint = Address::UdpOut(([127, 0, 0, 1], port).into());
    config.command.sink = Sink::Msp(MspSink {
        endpoint: Address::Tcp(format!("127.0.0.1:{msp_port}")),
        ..MspSink::default()
    });
    // Simulated flights are not recorded.
    config.record.enabled = false;
    let endpoint = config.mavlink.port();
    let (obs_tx, mut obs_rx) = mpsc::unbounded_channel();
    let source_spec = spec.clone();
    let source_shared = shared.clone();
    let hooks = Hooks {
        clock,
        source: Box::new(move |clock, batches| {
            physics::run(source_spec, source_shared, clock, batches)
        }),
        observer: Some(obs_tx),
    };
    let start_us = clock.now_us();
    let done = shared.clone();
    let msp_endpoint = config.command.msp_port();
    daemon::serve(config, endpoint, msp_endpoint, hooks, async move {
        done.done.notified().await;
        "the flight ended"
    })
    .await;

    let log = shared
        .log
        .lock()
        .expect("log lock")
        .take()
        .unwrap_or_default();
    let mut decision = None;
    let started = obs_rx.try_recv().ok().map(|o| match o {
        Observation::ManoeuvreStarted {
            last_event_us,
            started_us,
            decision: d,
        } => {
            decision = Some(d);
            (last_event_us, started_us)
        }
    });
    let first_rx = shared
        .first_roll_rx_us
        .load(std::sync::atomic::Ordering::Relaxed);
    let decision_s = started.map(|(_, s)| (s - start_us) as f64 * 1e-6);
    let ttc_at_decision_s = decision_s.and_then(|t| {
        let p = log
            .path
            .iter()
            .min_by(|a, b| (a.t_s - t).abs().total_cmp(&(b.t_s - t).abs()))?;
        Some(spec.true_ttc_s(p.x_m))
    });
    let latency_ms = started
        .filter(|_| first_rx != i64::MIN)
        .map(|(last_event_us, _)| (first_rx - last_event_us) as f64 / 1e3);
    Ok(FlightOutcome {
        spec: spec.clone(),
        collision_course: spec.is_collision_course(),
        collided: log.collided,
        rolled: started.is_some(),
        min_clearance_m: log.min_clearance_m,
        decision_s,
        ttc_at_decision_s,
        latency_ms,
        decision,
        path: log.path,
    })
}
