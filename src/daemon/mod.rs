//! `faithd run`: the flight daemon. Wires the adapters to the core:
//!
//! ```text
//! event source thread --batches--> pipeline thread --roll decisions--> commander task
//!                                        ^   (status)                     |   ^
//!              link task --attitude------'        vehicle state ----------'   |
//!                 ^  \---------------------------------------------------------'
//!                 '------ RC_CHANNELS_OVERRIDE (or the MSP sink) <-- commands
//! ```
//!
//! The commander evaluates the safety gate whenever anything it depends on changes
//! and at every send period, so a closing gate releases the roll within one period.
//! systemd hears READY once the autopilot link is up and the pipeline has run, and
//! the watchdog is fed only while the pipeline keeps finishing cycles.

pub mod clock;
pub mod cycle;
pub mod record;
pub mod shed;
pub mod source;

use std::sync::mpsc::SyncSender;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde::{Deserialize, Serialize};
use tokio::sync::{mpsc, watch};

use crate::command::{self, SinkKind};
use crate::config::FaithdConfig;
use crate::decide::Action;
use crate::event::Event;
use crate::link::endpoint::Endpoint;
use crate::link::{self, AttitudeLog, LinkOutputs};
use crate::safety::gate::{self, GateState, PipelineStatus};
use crate::safety::manoeuvre::{Command, Commander, RollRequest, Transition};
use crate::safety::vehicle::VehicleState;
use clock::DaemonClock;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DaemonConfig {
    /// Pipeline cycle period (10 ms = 100 decisions per second).
    pub period_us: i64,
    /// A cycle longer than this is an overrun: the next cycles shed load.
    pub budget_us: i64,
    /// Load shedding never goes below these.
    pub shed_min_vectors: usize,
    pub shed_min_iterations: u32,
    /// No event batch for this long: the camera is gone, the pipeline unhealthy.
    pub event_stale_us: i64,
}

impl Default for DaemonConfig {
    fn default() -> Self {
        Self {
            period_us: 10_000,
            budget_us: 8_000,
            shed_min_vectors: 300,
            shed_min_iterations: 13,
            event_stale_us: 200_000,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum DaemonError {
    #[error("`{key}`: {reason}")]
    Config { key: &'static str, reason: String },
    #[error("cannot start the runtime: {0}")]
    Runtime(std::io::Error),
}

/// Runs the daemon until SIGINT or SIGTERM.
pub fn run(config: FaithdConfig) -> Result<(), DaemonError> {
    let endpoint =
        Endpoint::parse(&config.mavlink.endpoint, config.mavlink.baud).map_err(|reason| {
            DaemonError::Config {
                key: "mavlink.endpoint",
                reason,
            }
        })?;
    let msp_endpoint = match config.command.sink {
        SinkKind::Mavlink => None,
        SinkKind::Msp => Some(
            Endpoint::parse(&config.command.msp_endpoint, config.command.msp_baud).map_err(
                |reason| DaemonError::Config {
                    key: "command.msp_endpoint",
                    reason,
                },
            )?,
        ),
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(DaemonError::Runtime)?;
    let clock = DaemonClock::start();
    let (source_config, camera) = (config.source.clone(), config.pipeline.camera);
    let source: SourceFn = match source_config.kind {
        source::SourceKind::Sim => {
            Box::new(move |clock, batches| source::run_sim(source_config, camera, clock, batches))
        }
        #[cfg(feature = "caer")]
        source::SourceKind::Caer => Box::new(move |clock, batches| {
            crate::source::caer::run(
                source_config.caer_settings,
                clock,
                batches,
                Duration::from_secs(2),
            )
        }),
        #[cfg(not(feature = "caer"))]
        source::SourceKind::Caer => {
            return Err(DaemonError::Config {
                key: "source.kind",
                reason: "this faithd was built without libcaer (cargo build --features caer)"
                    .into(),
            });
        }
    };
    let hooks = Hooks {
        clock,
        source,
        observer: None,
    };
    runtime.block_on(serve(
        config,
        endpoint,
        msp_endpoint,
        hooks,
        shutdown_signal(),
    ));
    Ok(())
}

/// Runs an event source on its own thread until the pipeline hangs up.
pub type SourceFn = Box<dyn FnOnce(DaemonClock, SyncSender<Vec<Event>>) + Send>;

/// What differs between the service and an in-process harness (`faithd demo`,
/// `faithd sim`): the clock, the camera, and who watches the manoeuvres.
pub struct Hooks {
    pub clock: DaemonClock,
    pub source: SourceFn,
    pub observer: Option<mpsc::UnboundedSender<Observation>>,
}

/// Something a harness may want to measure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Observation {
    /// A roll began; `last_event_us` is the newest event of the deciding window.
    ManoeuvreStarted {
        last_event_us: i64,
        started_us: i64,
        decision: crate::decide::Decision,
    },
}

/// The daemon proper; returns when `shutdown` completes, after releasing the roll.
pub async fn serve(
    config: FaithdConfig,
    endpoint: Endpoint,
    msp_endpoint: Option<Endpoint>,
    hooks: Hooks,
    shutdown: impl std::future::Future<Output = ()>,
) {
    let Hooks {
        clock,
        source,
        observer,
    } = hooks;
    tracing::info!(
        version = env!("CARGO_PKG_VERSION"),
        %endpoint,
        sink = ?config.command.sink,
        period_us = config.daemon.period_us,
        "faithd starting"
    );

    let window_log_header = crate::window_log::WindowLogHeader {
        faithd_window_log: crate::window_log::WINDOW_LOG_VERSION,
        faithd_version: env!("CARGO_PKG_VERSION").into(),
        clock_start_unix_us: clock.start_unix_us(),
        own_system_id: config.mavlink.system_id,
        own_component_id: config.mavlink.component_id,
        autopilot_system_id: config.mavlink.autopilot_system_id,
        clock_sync_window: link::CLOCK_SYNC_WINDOW,
        pipeline: config.pipeline,
    };
    let recorder = record::start(&config.record, &window_log_header);
    let (vehicle_tx, vehicle_rx) = watch::channel(VehicleState::default());
    let attitude = Arc::new(Mutex::new(AttitudeLog::default()));
    let (mav_out_tx, mav_out_rx) = mpsc::channel(64);
    tokio::spawn(link::run(
        config.mavlink.clone(),
        endpoint,
        clock,
        LinkOutputs {
            vehicle: vehicle_tx,
            attitude: attitude.clone(),
            recorder: recorder.clone(),
        },
        mav_out_rx,
    ));

    let (status_tx, status_rx) = watch::channel(PipelineStatus::default());
    let (decision_tx, decision_rx) = mpsc::channel(4);
    let (batch_tx, batch_rx) = std::sync::mpsc::sync_channel(256);
    std::thread::Builder::new()
        .name("faithd-source".into())
        .spawn(move || source(clock, batch_tx))
        .expect("spawn source thread");
    let (pipeline_config, daemon_config) = (config.pipeline, config.daemon);
    let cycle_recorder = recorder.clone();
    std::thread::Builder::new()
        .name("faithd-pipeline".into())
        .spawn(move || {
            cycle::run(
                pipeline_config,
                daemon_config,
                clock,
                cycle::CycleIo {
                    events: batch_rx,
                    attitude,
                    status: status_tx,
                    decisions: decision_tx,
                    recorder: cycle_recorder,
                },
            )
        })
        .expect("spawn pipeline thread");

    let sink = match msp_endpoint {
        None => Sink::Mavlink(mav_out_tx),
        Some(ep) => {
            let (tx, rx) = mpsc::channel(64);
            tokio::spawn(command::run_msp(
                ep,
                rx,
                Duration::from_micros(config.mavlink.reconnect_min_us.max(1) as u64),
                Duration::from_micros(config.mavlink.reconnect_max_us.max(1) as u64),
            ));
            Sink::Msp(tx)
        }
    };

    tokio::spawn(systemd_notifier(
        clock,
        vehicle_rx.clone(),
        status_rx.clone(),
        config.gate.pipeline_stale_us,
    ));
    let commander = commander_task(
        &config,
        clock,
        vehicle_rx,
        status_rx,
        decision_rx,
        &sink,
        observer,
    );
    tokio::select! {
        _ = commander => {}
        _ = shutdown => tracing::info!("shutdown requested"),
    }
    // Whatever state the manoeuvre was in, the pilot gets the roll channel back.
    let release = Command::Release {
        channel: config.manoeuvre.roll_channel,
    };
    sink.send(release, &config).await;
    tokio::time::sleep(Duration::from_millis(50)).await;
    if let Some(r) = &recorder {
        r.finish();
    }
    tracing::info!("faithd stopped; roll channel released");
}

/// Where commands go.
enum Sink {
    Mavlink(mpsc::Sender<mavlink::dialects::common::MavMessage>),
    Msp(mpsc::Sender<Vec<u8>>),
}

impl Sink {
    async fn send(&self, cmd: Command, config: &FaithdConfig) {
        let release_us = config.command.release_us;
        let delivered = match self {
            Sink::Mavlink(tx) => tx
                .send(command::mavlink_override(
                    cmd,
                    release_us,
                    config.mavlink.autopilot_system_id,
                    1,
                ))
                .await
                .is_ok(),
            Sink::Msp(tx) => tx
                .send(command::msp_override(
                    cmd,
                    release_us,
                    config.manoeuvre.neutral_us,
                ))
                .await
                .is_ok(),
        };
        if !delivered {
            tracing::error!(?cmd, "command sink has stopped");
        }
    }
}

async fn commander_task(
    config: &FaithdConfig,
    clock: DaemonClock,
    mut vehicle_rx: watch::Receiver<VehicleState>,
    mut status_rx: watch::Receiver<PipelineStatus>,
    mut decision_rx: mpsc::Receiver<cycle::RollDecision>,
    sink: &Sink,
    observer: Option<mpsc::UnboundedSender<Observation>>,
) {
    let mut commander = Commander::new(config.manoeuvre);
    // Woken four times per send period (and at every input change), so a re-send or
    // a staleness limit is acted on at most a quarter period late.
    let period = Duration::from_micros((config.manoeuvre.resend_period_us / 4).max(1000) as u64);
    let mut tick = tokio::time::interval(period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut last_gate: Option<GateState> = None;
    let mut request: Option<(i64, RollRequest, i64, crate::decide::Decision)> = None;
    loop {
        tokio::select! {
            _ = tick.tick() => {}
            Ok(()) = vehicle_rx.changed() => {}
            Ok(()) = status_rx.changed() => {}
            Some(cycle::RollDecision { decision: d, last_event_us }) = decision_rx.recv() => {
                if let Action::Roll { direction, duration_us } = d.action {
                    request = Some((d.t_us, RollRequest { direction, duration_us }, last_event_us, d));
                    tracing::debug!("roll requested: {d}");
                }
            }
        }
        let now_us = clock.now_us();
        let vehicle = *vehicle_rx.borrow_and_update();
        let status = *status_rx.borrow_and_update();
        let gate = gate::evaluate(&config.gate, &vehicle, &status, now_us);
        if last_gate.map(|g| g.is_open()) != Some(gate.is_open())
            || matches!((last_gate, gate), (Some(GateState::Closed(a)), GateState::Closed(b)) if std::mem::discriminant(&a) != std::mem::discriminant(&b))
        {
            match gate {
                GateState::Open => tracing::info!("safety gate open: faithd may command roll"),
                GateState::Closed(b) => tracing::info!("safety gate closed: {b}"),
            }
            last_gate = Some(gate);
        }
        // A roll decision is acted on only while it is fresh.
        let fresh = request.filter(|(t, _, _, _)| now_us - t <= 2 * config.daemon.period_us.max(1));
        let step = commander.step(now_us, &gate, fresh.map(|(_, r, _, _)| r));
        if let Some(t) = step.transition {
            match t {
                Transition::Started {
                    direction,
                    duration_us,
                } => {
                    if let (Some(obs), Some((_, _, last_event_us, decision))) = (&observer, fresh) {
                        let _ = obs.send(Observation::ManoeuvreStarted {
                            last_event_us,
                            started_us: now_us,
                            decision,
                        });
                    }
                    request = None;
                    tracing::info!(
                        ?direction,
                        duration_ms = duration_us / 1000,
                        "manoeuvre started: roll {direction:?}"
                    )
                }
                Transition::Completed => tracing::info!("manoeuvre completed: roll released"),
                Transition::Cut => tracing::warn!(
                    "manoeuvre cut: roll released because {}",
                    match gate {
                        GateState::Closed(b) => b.to_string(),
                        GateState::Open => "?".into(),
                    }
                ),
            }
        }
        if let Some(cmd) = step.command {
            tracing::debug!(?cmd, "command");
            sink.send(cmd, config).await;
        }
    }
}

/// READY once the link is up and the pipeline has run; WATCHDOG while it keeps running.
async fn systemd_notifier(
    clock: DaemonClock,
    mut vehicle_rx: watch::Receiver<VehicleState>,
    status_rx: watch::Receiver<PipelineStatus>,
    pipeline_stale_us: i64,
) {
    loop {
        let up = vehicle_rx.borrow().link_up && status_rx.borrow().last_cycle_us.is_some();
        if up {
            break;
        }
        tokio::select! {
            _ = vehicle_rx.changed() => {}
            _ = tokio::time::sleep(Duration::from_millis(20)) => {}
        }
    }
    let _ = sd_notify::notify(&[sd_notify::NotifyState::Ready]);
    tracing::info!("ready: autopilot link up, pipeline running");
    let Some(watchdog) = sd_notify::watchdog_enabled() else {
        return;
    };
    let mut tick = tokio::time::interval(watchdog / 2);
    loop {
        tick.tick().await;
        let last = status_rx.borrow().last_cycle_us;
        match last {
            Some(t) if clock.now_us() - t <= pipeline_stale_us => {
                let _ = sd_notify::notify(&[sd_notify::NotifyState::Watchdog]);
            }
            _ => tracing::error!("pipeline stalled: withholding the watchdog"),
        }
    }
}

async fn shutdown_signal() {
    use tokio::signal::unix::{SignalKind, signal};
    let mut term = signal(SignalKind::terminate()).expect("SIGTERM handler");
    tokio::select! {
        _ = term.recv() => {}
        _ = tokio::signal::ctrl_c() => {}
    }
}
