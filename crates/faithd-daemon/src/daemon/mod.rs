//! `faithd run`: the flight daemon. Wires the adapters to the core:
//!
//! ```text
//! event source thread --batches--> pipeline thread --roll decisions--> commander task
//!                                        ^   (status)                     |   ^
//!              link task --attitude------'        vehicle state ----------'   |
//!                 ^  \---------------------------------------------------------'
//!                                                     MSP roll stream <---'
//!                                                   (to iNav's MSP port; MSP_RC back)
//! ```
//!
//! The commander evaluates the safety gate whenever anything it depends on changes
//! and at every send period, so a closing gate releases the roll within one period.
//! It sets the value the MSP stream holds (the centre, or the roll) and compares it
//! with the roll channel iNav reports using: a roll that does not show is a fault.
//! systemd hears READY once the autopilot link is up and the pipeline has run, and
//! the watchdog is fed only while the pipeline keeps finishing cycles.

use std::sync::mpsc::SyncSender;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::sync::{mpsc, watch};

use crate::actuator::{self, RouteStatus};
use crate::clock::DaemonClock;
use crate::config::FaithdConfig;
use crate::link::endpoint::Endpoint;
use crate::link::ground::{self, GroundFeed, Notice};
use crate::link::{self, LinkOutputs, ToAutopilot};
use crate::source::{self, sim};
use crate::{cycle, record, supervise};
use faithd_core::attitude::AttitudeLog;
use faithd_core::decide::Action;
use faithd_core::event::Event;
use faithd_core::pipeline::PipelineTelemetry;
use faithd_core::safety::commander::{
    Commander, CommanderConfig, Event as CommanderEvent, Inputs, RollCall, RollReport,
};
use faithd_core::safety::gate::{GateState, PipelineStatus};
use faithd_core::safety::manoeuvre::RollRequest;
use faithd_core::safety::vehicle::VehicleState;

#[derive(Debug, thiserror::Error)]
pub enum DaemonError {
    #[error("`{key}`: {reason}")]
    Config { key: &'static str, reason: String },
    #[error("cannot start the runtime: {0}")]
    Runtime(std::io::Error),
    /// A task panicked or ended: faithd released the roll and stopped, for systemd
    /// to restart it.
    #[error("stopped on a fault: {0}")]
    Fault(String),
    /// SIGHUP: nobody asked faithd to stop for good (systemd stops it with SIGTERM),
    /// so it exits non-zero and `Restart=on-failure` starts it again.
    #[error(
        "stopped by SIGHUP after releasing the roll; exiting non-zero so that systemd restarts faithd"
    )]
    Hangup,
}

/// How [`serve`] ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Ended {
    /// Asked to stop (a signal, or the harness).
    Requested(&'static str),
    /// A task panicked, ended or could not go on.
    Fault(String),
    /// What the daemon found contradicts its configuration (exit 2, no restart).
    Refused { key: &'static str, reason: String },
}

/// What a person asked for on the command line of `faithd run`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RunOptions {
    /// `--simulated-camera`: let `source.kind = "sim"` command rolls. Without it a
    /// simulated source is refused: a real vehicle would roll at imaginary poles.
    pub simulated_camera: bool,
}

/// Why `faithd run` refuses a simulated camera without the command-line opt-in.
pub const SIM_SOURCE_REFUSED: &str = "is \"sim\": a simulated camera makes faithd roll the vehicle at imaginary poles about every 5 s; `faithd run` takes it only with --simulated-camera on its command line (bench and tests, never the service); set source.kind = \"caer\" for the DVS240";

/// Runs the daemon until SIGINT, SIGTERM or SIGHUP.
pub fn run(config: FaithdConfig, options: RunOptions) -> Result<(), DaemonError> {
    if matches!(config.source, source::SourceConfig::Sim(_)) && !options.simulated_camera {
        return Err(DaemonError::Config {
            key: "source.kind",
            reason: SIM_SOURCE_REFUSED.into(),
        });
    }
    let endpoint = config.mavlink.port();
    let msp_endpoint = config.command.msp_port();
    supervise::install_panic_hook();
    // This run's faults: a panic on a runtime worker (a task), on the camera or the
    // pipeline thread, or a refusal of the camera, ends this run and releases the roll.
    let faults = supervise::Faults::new();
    let runtime = faults.runtime().map_err(DaemonError::Runtime)?;
    // Caught before anything else starts: a stop that arrives while the camera opens
    // (a slow board widens that moment) ends in the release too, not in the default
    // action's exit.
    let signals = ShutdownSignals::install(&runtime).map_err(DaemonError::Runtime)?;
    let clock = DaemonClock::start();
    let camera = config.pipeline.camera;
    let source: SourceFn = match config.source.clone() {
        source::SourceConfig::Sim(sim) => {
            tracing::warn!(
                "SIMULATED CAMERA (--simulated-camera): every roll faithd commands comes from generated events, not from the world; never fly like this"
            );
            Box::new(move |clock, batches| sim::run_sim(sim, camera, clock, batches))
        }
        source::SourceConfig::Caer(caer) => {
            let path = (!caer.libcaer_path.is_empty()).then_some(caer.libcaer_path.as_str());
            let lib = libcaer_sys::Libcaer::load(path).map_err(|e| DaemonError::Config {
                key: "source.libcaer_path",
                reason: format!(
                    "{e}; install iniVation's libcaer 3 (it is not in Debian: see docs/camera.md) or name its file here"
                ),
            })?;
            tracing::info!(library = %lib.path, "libcaer loaded");
            let sensor = crate::source::caer::SensorSize {
                width_px: camera.width_px,
                height_px: camera.height_px,
            };
            let faults = faults.clone();
            Box::new(move |clock, batches| {
                if let Err(e) = crate::source::caer::run(
                    &lib,
                    caer.caer_settings,
                    sensor,
                    clock,
                    batches,
                    Duration::from_secs(2),
                ) {
                    faults.report(supervise::Fault::Refused {
                        key: e.key(),
                        reason: e.to_string(),
                    });
                }
            })
        }
    };
    let hooks = Hooks {
        clock,
        execution: Execution::Threads { source },
        observer: None,
        faults,
    };
    let ended = runtime.block_on(serve(
        config,
        endpoint,
        msp_endpoint,
        hooks,
        signals.first(),
    ));
    // Threads still blocked in a device or a disk are not waited for.
    runtime.shutdown_timeout(Duration::from_millis(200));
    match ended {
        Ended::Requested("SIGHUP") => Err(DaemonError::Hangup),
        Ended::Requested(_) => Ok(()),
        Ended::Fault(why) => Err(DaemonError::Fault(why)),
        Ended::Refused { key, reason } => Err(DaemonError::Config { key, reason }),
    }
}

/// Runs an event source on its own thread until the pipeline hangs up.
pub type SourceFn = Box<dyn FnOnce(DaemonClock, SyncSender<Vec<Event>>) + Send>;

/// An event source as a task on the caller's runtime (a simulated world stepping in
/// simulated time): it sends the camera's batches until the pipeline hangs up.
pub type SourceTaskFn = Box<
    dyn FnOnce(
            DaemonClock,
            SyncSender<Vec<Event>>,
        ) -> std::pin::Pin<Box<dyn std::future::Future<Output = ()> + Send>>
        + Send,
>;

/// The pipeline as a task on the caller's runtime: `cycle::drive` with the caller's
/// pacing (the lab's: simulated time and charged compute).
pub type PipelineTaskFn = Box<
    dyn FnOnce(
            faithd_core::pipeline::PipelineConfig,
            cycle::DaemonConfig,
            DaemonClock,
            cycle::CycleIo,
        ) -> std::pin::Pin<Box<dyn std::future::Future<Output = ()> + Send>>
        + Send,
>;

/// How the camera and the pipeline run beside the tokio tasks.
pub enum Execution {
    /// Flight (and real-time harnesses): the camera and the pipeline on threads of
    /// their own, on the wall clock.
    Threads { source: SourceFn },
    /// The camera and the pipeline as tasks on the same runtime as the link, the
    /// commander and the MSP stream: in a simulated flight, a single-threaded runtime
    /// whose clock is paused and advanced by the simulation, the pipeline the same
    /// driver as in flight, paced by the lab. Same input, same flight.
    Tasks {
        source: SourceTaskFn,
        pipeline: PipelineTaskFn,
    },
}

/// What differs between the service and an in-process harness (`faithd demo`,
/// `faithd sim`): the clock, the camera and the pipeline's execution, and who
/// watches the manoeuvres.
pub struct Hooks {
    pub clock: DaemonClock,
    pub execution: Execution,
    pub observer: Option<Observer>,
    /// This run's faults: the first one reported ends the run (`serve` releases the
    /// roll and returns it). The caller enters it on its own runtime's threads.
    pub faults: supervise::Faults,
}

/// Called by the commander with every [`Observation`]: on the commander's own task,
/// so a harness can measure it (or, in a test, make it fail).
pub type Observer = Box<dyn FnMut(Observation) + Send>;

/// Something a harness may want to measure. A few per flight, so a large variant
/// costs nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
#[allow(clippy::large_enum_variant)]
pub enum Observation {
    /// A roll began; `last_event_us` is the newest event of the deciding window,
    /// `first_call_event_us` that of the first window of the unbroken run of roll
    /// calls that led to it (earlier when the gate held the roll).
    ManoeuvreStarted {
        last_event_us: i64,
        first_call_event_us: i64,
        started_us: i64,
        decision: faithd_core::decide::Decision,
    },
    /// The safety gate changed (open, closed, or closed for another reason or
    /// count): a flight's video shows it.
    Gate { t_us: i64, gate: GateState },
}

/// The daemon proper; returns when `shutdown` completes or a fault is reported
/// ([`supervise`]), after releasing the roll either way.
pub async fn serve(
    config: FaithdConfig,
    endpoint: Endpoint,
    msp_endpoint: Endpoint,
    hooks: Hooks,
    shutdown: impl std::future::Future<Output = &'static str>,
) -> Ended {
    let Hooks {
        clock,
        execution,
        observer,
        faults,
    } = hooks;
    tracing::info!(
        version = env!("CARGO_PKG_VERSION"),
        %endpoint,
        msp = %msp_endpoint,
        period_us = config.daemon.period_us,
        "faithd starting"
    );

    let window_log_header = faithd_formats::window_log::WindowLogHeader {
        faithd_window_log: faithd_formats::window_log::WINDOW_LOG_VERSION,
        faithd_version: env!("CARGO_PKG_VERSION").into(),
        clock_start_unix_us: clock.start_unix_us(),
        own_system_id: config.mavlink.system_id,
        own_component_id: config.mavlink.component_id,
        autopilot_system_id: config.mavlink.autopilot_system_id,
        autopilot_component_id: Some(config.mavlink.autopilot_component_id),
        clock_sync_window: link::CLOCK_SYNC_WINDOW,
        pipeline: config.pipeline,
    };
    let recorder = record::start(&config.record, &window_log_header);
    let mut supervisor = supervise::Supervisor::new(clock);
    let (vehicle_tx, vehicle_rx) = watch::channel(VehicleState::default());
    let attitude = Arc::new(Mutex::new(AttitudeLog::default()));
    // faithd sends only its own HEARTBEAT on the MAVLink link; nothing else queues.
    let (_mav_out_tx, mav_out_rx) = mpsc::channel(1);
    let (telemetry_tx, telemetry_rx) = watch::channel(PipelineTelemetry::default());
    // The ground station link, when configured: a bystander fed through queues that
    // never make the link or the commander wait.
    let (ground_feed, from_ground, ground_task) = match config.ground.port() {
        Some(port) => {
            let (feed, io, from_ground) = ground::queues(&config.ground, telemetry_rx);
            tracing::info!(ground = %port, "ground station link configured");
            let task = tokio::spawn(ground::run(
                config.ground.clone(),
                config.mavlink.clone(),
                port,
                clock,
                io,
            ));
            (feed, from_ground, Some(task))
        }
        None => (GroundFeed::default(), None, None),
    };
    let link_task = tokio::spawn(link::run(
        config.mavlink.clone(),
        endpoint,
        clock,
        LinkOutputs {
            vehicle: vehicle_tx,
            attitude: attitude.clone(),
            recorder: recorder.clone(),
            ground: ground_feed.clone(),
        },
        ToAutopilot {
            own: mav_out_rx,
            from_ground,
        },
        supervisor.register("autopilot link"),
    ));

    let (status_tx, status_rx) = watch::channel(PipelineStatus::default());
    let (decision_tx, decision_rx) = watch::channel(None);
    let (batch_tx, batch_rx) = std::sync::mpsc::sync_channel(256);
    let (pipeline_config, daemon_config) = (config.pipeline, config.daemon);
    let stop_pipeline = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let cycle_io = cycle::CycleIo {
        events: batch_rx,
        attitude,
        outputs: cycle::CycleOutputs {
            status: status_tx,
            decisions: decision_tx,
            telemetry: telemetry_tx,
            recorder: recorder.clone(),
        },
        stop: stop_pipeline.clone(),
    };
    let workers = match execution {
        Execution::Threads { source } => {
            let source_faults = faults.clone();
            let source_thread = std::thread::Builder::new()
                .name("faithd-source".into())
                .spawn(move || {
                    let _run = source_faults.enter();
                    source(clock, batch_tx)
                })
                .expect("spawn source thread");
            let pipeline_faults = faults.clone();
            let pipeline_thread = std::thread::Builder::new()
                .name("faithd-pipeline".into())
                .spawn(move || {
                    let _run = pipeline_faults.enter();
                    cycle::run(pipeline_config, daemon_config, clock, cycle_io)
                })
                .expect("spawn pipeline thread");
            Workers::Threads([("pipeline", pipeline_thread), ("camera", source_thread)])
        }
        Execution::Tasks { source, pipeline } => {
            let world = tokio::spawn(source(clock, batch_tx));
            let pipeline = tokio::spawn(pipeline(pipeline_config, daemon_config, clock, cycle_io));
            Workers::Tasks([pipeline, world])
        }
    };

    let actuator = actuator::start(
        &config,
        msp_endpoint.clone(),
        clock,
        supervisor.register("MSP roll stream"),
    );
    let commander_beat = supervisor.register("commander");
    let log_task = tokio::spawn(report_dropped_log_lines());

    let notifier_task = tokio::spawn(systemd_notifier(
        clock,
        vehicle_rx.clone(),
        status_rx.clone(),
        config.gate.pipeline_stale_us,
        supervisor,
        faults.clone(),
    ));
    // The commander is a task of its own: a panic in it ends that task alone, and
    // the select below then releases the roll like any other fault.
    let (held, stream_rx) = (actuator.held(), actuator.status());
    let mut commander = tokio::spawn(commander_task(
        commander_config(&config),
        clock,
        CommanderInputs {
            vehicle_rx,
            status_rx,
            decision_rx,
            stream_rx: stream_rx.clone(),
            observer,
            heartbeat: commander_beat,
            ground: ground_feed,
        },
        held,
    ));
    // Every select in the daemon is biased: branches are polled in the order
    // written, so a simulated flight (one thread, simulated time) takes the same
    // path on every run. Rare events come first, so a busy stream cannot starve them.
    let mut commander_done = false;
    let ended = tokio::select! {
        biased;
        ended = &mut commander => {
            commander_done = true;
            Ended::Fault(match ended {
                Err(e) if e.is_panic() => "the commander panicked".into(),
                _ => "the commander ended".into(),
            })
        }
        why = shutdown => {
            tracing::info!("shutdown requested ({why})");
            Ended::Requested(why)
        }
        fault = faults.wait() => match fault {
            supervise::Fault::Crash(why) => {
                tracing::error!("{why}: releasing the roll and stopping (systemd restarts faithd)");
                Ended::Fault(why)
            }
            supervise::Fault::Refused { key, reason } => {
                tracing::error!("`{key}`: {reason}: releasing the roll and stopping");
                Ended::Refused { key, reason }
            }
        }
    };
    // Whatever state the manoeuvre was in, the pilot gets the roll channel back: the
    // centre, `release_repeats` times, each frame flushed, before faithd exits.
    actuator.release_on_exit().await;
    if !commander_done {
        commander.abort();
        let _ = commander.await;
    }
    if let Some(r) = &recorder {
        r.finish().await;
    }
    // Every task and thread is ended and joined before `serve` returns: the
    // background tasks are cancelled, the pipeline is told to stop, and the camera
    // thread ends when the pipeline's end of its channel is gone.
    for task in [link_task, log_task, notifier_task]
        .into_iter()
        .chain(ground_task)
    {
        task.abort();
        let _ = task.await;
    }
    stop_pipeline.store(true, std::sync::atomic::Ordering::Release);
    workers.join().await;
    tracing::info!("faithd stopped");
    ended
}

/// The camera and the pipeline: threads in flight, tasks in a simulated flight.
enum Workers {
    Threads([(&'static str, std::thread::JoinHandle<()>); 2]),
    Tasks([tokio::task::JoinHandle<()>; 2]),
}

impl Workers {
    /// Waits for the camera and the pipeline to end (the pipeline was told to stop;
    /// the camera ends when the pipeline's end of its channel is gone). A thread
    /// still blocked in a device after 1 s is named and not waited for.
    async fn join(self) {
        match self {
            Workers::Threads(threads) => {
                let deadline = tokio::time::Instant::now() + Duration::from_secs(1);
                while threads.iter().any(|(_, t)| !t.is_finished())
                    && tokio::time::Instant::now() < deadline
                {
                    tokio::time::sleep(Duration::from_millis(5)).await;
                }
                for (name, thread) in threads {
                    if thread.is_finished() {
                        let _ = thread.join();
                    } else {
                        tracing::warn!(
                            "the {name} thread did not end within 1 s (blocked in a device?); not waited for"
                        );
                    }
                }
            }
            Workers::Tasks(tasks) => {
                for task in tasks {
                    task.abort();
                    let _ = task.await;
                }
            }
        }
    }
}

/// What the commander listens to, and its heartbeat.
struct CommanderInputs {
    vehicle_rx: watch::Receiver<VehicleState>,
    status_rx: watch::Receiver<PipelineStatus>,
    decision_rx: watch::Receiver<Option<cycle::RollDecision>>,
    stream_rx: watch::Receiver<RouteStatus>,
    observer: Option<Observer>,
    heartbeat: supervise::Heartbeat,
    /// Gate changes and rolls, for the ground station (a no-op without one).
    ground: GroundFeed,
}

/// The commander's configuration, from faithd.toml.
fn commander_config(config: &FaithdConfig) -> CommanderConfig {
    CommanderConfig {
        gate: config.gate,
        manoeuvre: config.manoeuvre,
        reported_roll: actuator::reported_roll(config),
        confirm_within_us: config.command.confirm_within_us,
        decision_fresh_us: 2 * config.daemon.period_us.max(1),
    }
}

/// The commander as a task: it moves values between the channels and the pure
/// [`Commander`], which makes every decision, and says in the journal what each step
/// changed. Woken four times per roll frame period (and at every input change), so
/// a staleness limit is acted on within a few milliseconds.
async fn commander_task(
    rules: CommanderConfig,
    clock: DaemonClock,
    inputs: CommanderInputs,
    held: watch::Sender<u16>,
) {
    let CommanderInputs {
        mut vehicle_rx,
        mut status_rx,
        mut decision_rx,
        mut stream_rx,
        mut observer,
        heartbeat,
        ground,
    } = inputs;
    let mut commander = Commander::new(rules);
    let period = Duration::from_micros((rules.manoeuvre.resend_period_us / 4).max(1000) as u64);
    let mut tick = tokio::time::interval(period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut last_report: Option<RollReport> = None;
    let mut last_observed_gate: Option<GateState> = None;
    // The decision behind the newest roll call, for the observer and the ground.
    let mut newest: Option<cycle::RollDecision> = None;
    loop {
        let mut call = None;
        tokio::select! {
            biased;
            _ = tick.tick() => {}
            Ok(()) = vehicle_rx.changed() => {}
            Ok(()) = status_rx.changed() => {}
            Ok(()) = stream_rx.changed() => {}
            Ok(()) = decision_rx.changed() => {
                let decided = *decision_rx.borrow_and_update();
                if let Some(d) = decided
                    && let Action::Roll { direction, duration_us } = d.decision.action
                {
                    tracing::debug!("roll requested: {}", d.decision);
                    call = Some(RollCall {
                        t_us: d.decision.t_us,
                        request: RollRequest { direction, duration_us },
                        last_event_us: d.last_event_us,
                    });
                    newest = Some(d);
                }
            }
        }
        heartbeat.beat();
        let now_us = clock.now_us();
        let vehicle = *vehicle_rx.borrow_and_update();
        let pipeline = *status_rx.borrow_and_update();
        let streamed = *stream_rx.borrow_and_update();
        let report = streamed.last_report.filter(|r| Some(*r) != last_report);
        last_report = streamed.last_report.or(last_report);
        let path = streamed.path;
        let step = commander.step(
            now_us,
            Inputs {
                vehicle: &vehicle,
                pipeline: &pipeline,
                path: &path,
                call,
                report,
            },
        );
        held.send_if_modified(|v| std::mem::replace(v, step.held_us) != step.held_us);
        if last_observed_gate != Some(step.gate) {
            if let Some(observe) = observer.as_mut() {
                observe(Observation::Gate {
                    t_us: now_us,
                    gate: step.gate,
                });
            }
            last_observed_gate = Some(step.gate);
        }
        for event in step.events {
            tell(
                &event,
                now_us,
                &clock,
                newest.as_ref(),
                &ground,
                observer.as_mut(),
            );
        }
    }
}

/// One change of the commander in the journal, to the ground station and to a
/// harness that watches.
fn tell(
    event: &CommanderEvent,
    now_us: i64,
    clock: &DaemonClock,
    decision: Option<&cycle::RollDecision>,
    ground: &GroundFeed,
    observer: Option<&mut Observer>,
) {
    let unix_us = clock.unix_us(now_us);
    match *event {
        CommanderEvent::GateChanged { gate, was_open } => {
            match gate {
                GateState::Open => tracing::info!("safety gate open: faithd may command roll"),
                GateState::Closed(b) => tracing::info!("safety gate closed: {b}"),
            }
            ground.notify(Notice::Gate { gate, was_open });
        }
        CommanderEvent::RollStarted {
            direction,
            value_us,
            duration_us,
            last_event_us,
            first_call_event_us,
        } => {
            if let (Some(observe), Some(d)) = (observer, decision) {
                observe(Observation::ManoeuvreStarted {
                    last_event_us,
                    first_call_event_us,
                    started_us: now_us,
                    decision: d.decision,
                });
            }
            ground.notify(Notice::Roll {
                direction,
                ttc_s: decision
                    .and_then(|d| d.decision.obstacle)
                    .map(|o| o.mean_ttc_s),
            });
            // The Unix time lets a bench or a test line the decision up with what the
            // flight controller reports.
            tracing::info!(
                ?direction,
                roll_us = value_us,
                duration_ms = duration_us / 1000,
                unix_us,
                "manoeuvre started: roll {direction:?}"
            )
        }
        CommanderEvent::RollCompleted => {
            tracing::info!(unix_us, "manoeuvre completed: roll released")
        }
        CommanderEvent::RollCut { because } => {
            tracing::warn!(unix_us, "manoeuvre cut: roll released because {because}")
        }
        CommanderEvent::RollConfirmed { roll_us, after_us } => tracing::info!(
            roll_us,
            "roll in effect on the flight controller {} ms after it was commanded",
            after_us / 1000
        ),
        CommanderEvent::RollNotInEffect {
            commanded_us,
            reported_us,
            waited_us,
        } => tracing::error!(
            commanded_us,
            ?reported_us,
            "roll not in effect on the flight controller: commanded {commanded_us} us on roll, iNav reports {} for {} ms; closing the gate until the switch leaves AUTO",
            reported_us.map_or("nothing".into(), |v| format!("{v} us")),
            waited_us / 1000
        ),
        CommanderEvent::FaultCleared => {
            tracing::info!("switch out of AUTO: the roll fault is cleared")
        }
    }
}

/// READY once the link is up and the pipeline has run; WATCHDOG while the pipeline
/// keeps finishing cycles and every supervised task keeps beating.
async fn systemd_notifier(
    clock: DaemonClock,
    mut vehicle_rx: watch::Receiver<VehicleState>,
    status_rx: watch::Receiver<PipelineStatus>,
    pipeline_stale_us: i64,
    supervisor: supervise::Supervisor,
    faults: supervise::Faults,
) {
    loop {
        let up = vehicle_rx.borrow().link_up && status_rx.borrow().last_cycle_us.is_some();
        if up {
            break;
        }
        tokio::select! {
            biased;
            changed = vehicle_rx.changed() => if changed.is_err() {
                faults.report(supervise::Fault::Crash(
                    "the autopilot link task ended before READY".into(),
                ));
                return;
            },
            _ = tokio::time::sleep(Duration::from_millis(20)) => {}
        }
    }
    let _ = sd_notify::notify(&[sd_notify::NotifyState::Ready]);
    tracing::info!("ready: autopilot link up, pipeline running");
    let Some(watchdog) = sd_notify::watchdog_enabled() else {
        return;
    };
    let mut tick = tokio::time::interval(watchdog / 2);
    let mut withheld_for: Option<String> = None;
    loop {
        tick.tick().await;
        let now_us = clock.now_us();
        let stalled = match (status_rx.borrow().last_cycle_us, supervisor.stalled(now_us)) {
            (_, Some((task, age_us))) => Some(format!(
                "{task} has not shown life for {} ms",
                age_us / 1000
            )),
            (Some(t), None) if now_us - t <= pipeline_stale_us => None,
            _ => Some("pipeline stalled".into()),
        };
        match stalled {
            None => {
                let _ = sd_notify::notify(&[sd_notify::NotifyState::Watchdog]);
                if withheld_for.take().is_some() {
                    tracing::info!("all tasks alive again: watchdog fed");
                }
            }
            Some(why) => {
                if withheld_for.as_deref() != Some(why.as_str()) {
                    tracing::error!("{why}: withholding the watchdog (systemd restarts faithd)");
                }
                withheld_for = Some(why);
            }
        }
    }
}

/// Says how many journal lines were dropped while the journal was behind, once it
/// keeps up again (the count itself is a line that may be dropped, so it repeats).
async fn report_dropped_log_lines() {
    let mut reported = crate::logging::dropped_lines();
    let mut tick = tokio::time::interval(Duration::from_secs(5));
    loop {
        tick.tick().await;
        let dropped = crate::logging::dropped_lines();
        if dropped != reported {
            tracing::warn!(
                dropped_lines = dropped - reported,
                total = dropped,
                "the journal fell behind: log lines dropped"
            );
            reported = dropped;
        }
    }
}

/// SIGTERM (systemd stop), SIGINT (Ctrl-C) and SIGHUP (the terminal went away),
/// caught from the moment they are installed: every one ends in the release, never in
/// an exit without it.
struct ShutdownSignals {
    term: tokio::signal::unix::Signal,
    int: tokio::signal::unix::Signal,
    hup: tokio::signal::unix::Signal,
}

impl ShutdownSignals {
    /// Installs the handlers on `runtime`'s signal driver.
    fn install(runtime: &tokio::runtime::Runtime) -> std::io::Result<Self> {
        use tokio::signal::unix::{SignalKind, signal};
        let _entered = runtime.enter();
        Ok(Self {
            term: signal(SignalKind::terminate())?,
            int: signal(SignalKind::interrupt())?,
            hup: signal(SignalKind::hangup())?,
        })
    }

    /// The first of them to arrive, by name.
    async fn first(mut self) -> &'static str {
        tokio::select! {
            _ = self.term.recv() => "SIGTERM",
            _ = self.int.recv() => "SIGINT",
            _ = self.hup.recv() => "SIGHUP",
        }
    }
}
