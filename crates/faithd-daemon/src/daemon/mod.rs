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

use crate::actuator::{self, PilotView, RouteStatus};
use crate::clock::DaemonClock;
use crate::config::FaithdConfig;
use crate::link::ground::{self, GroundFeed, Notice};
use crate::link::{self, LinkOutputs, TelemetryConfig, ToAutopilot, over_msp};
use crate::shutdown::Shutdown;
use crate::source::{self, SourceIo};
use crate::transport::Endpoint;
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
pub use crate::source::SIM_SOURCE_REFUSED;

/// Runs the daemon until SIGINT, SIGTERM or SIGHUP.
pub fn run(config: FaithdConfig, options: RunOptions) -> Result<(), DaemonError> {
    link::late_attitude::delay_from_env().map_err(|reason| DaemonError::Config {
        key: link::late_attitude::VARIABLE,
        reason,
    })?;
    let endpoint = config.autopilot_port();
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
    let source = source::start(
        &config.source,
        config.pipeline.camera,
        options.simulated_camera,
    )
    .map_err(|source::Refusal { key, reason }| DaemonError::Config { key, reason })?;
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
    // Every task and thread has ended (or was named as stuck): nothing to wait for.
    runtime.shutdown_timeout(Duration::from_millis(200));
    match ended {
        Ended::Requested("SIGHUP") => Err(DaemonError::Hangup),
        Ended::Requested(_) => Ok(()),
        Ended::Fault(why) => Err(DaemonError::Fault(why)),
        Ended::Refused { key, reason } => Err(DaemonError::Config { key, reason }),
    }
}

/// Runs an event source on its own thread (the camera's work, from [`source::start`]).
pub use crate::source::SourceFn;

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
/// ([`supervise`]), after releasing the roll either way and then stopping every task
/// and thread it started through one [`Shutdown`].
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
    let stop = Shutdown::new();
    let mut tasks = Tasks::default();
    let recorder = record::start(&config.record, &window_log_header(&config, clock));
    let mut supervisor = supervise::Supervisor::new(clock);
    let links = start_links(
        &config,
        endpoint,
        clock,
        &recorder,
        &mut supervisor,
        &stop,
        &mut tasks,
    );
    let (pipeline, batches, cycle_io) = pipeline_channels(&links, &recorder, &stop);
    let workers = start_workers(
        execution,
        &config,
        clock,
        (batches, cycle_io),
        &stop,
        &faults,
    );
    let (view, view_rx) = watch::channel(PilotView::default());
    let actuator = actuator::start(
        &config,
        msp_endpoint.clone(),
        clock,
        supervisor.register("MSP roll stream"),
        view_rx,
    );
    let commander_beat = supervisor.register("commander");
    tasks.spawn("journal", &stop, report_dropped_log_lines());
    tasks.spawn(
        "systemd notifier",
        &stop,
        systemd_notifier(
            clock,
            links.vehicle_rx.clone(),
            pipeline.status_rx.clone(),
            config.gate.pipeline_stale_us,
            supervisor,
            faults.clone(),
        ),
    );
    let (held, stream_rx) = (actuator.held(), actuator.status());
    // The commander is a task of its own: a panic in it ends that task alone, and
    // the wait below then releases the roll like any other fault.
    let commander_stop = stop.handle();
    let task = commander_task(
        commander_config(&config),
        clock,
        CommanderInputs {
            vehicle_rx: links.vehicle_rx.clone(),
            status_rx: pipeline.status_rx,
            decision_rx: pipeline.decision_rx,
            stream_rx: stream_rx.clone(),
            observer,
            heartbeat: commander_beat,
            ground: links.ground_feed.clone(),
            telemetry_rx: links.telemetry.subscribe(),
        },
        Outputs { held, view },
    );
    let mut commander = tokio::spawn(async move {
        commander_stop.until(task).await;
    });
    let ended = wait_for_the_end(&mut commander, shutdown, &faults).await;
    // Whatever state the manoeuvre was in, the pilot gets the roll channel back: the
    // centre, `release_repeats` times, each frame flushed, before faithd exits.
    actuator.release_on_exit().await;
    stop.request();
    tasks.push("commander", commander);
    if let Some(r) = &recorder {
        r.finish().await;
    }
    stop_all(stop, tasks, workers).await;
    tracing::info!("faithd stopped");
    ended
}

/// The window log's header: what a replay needs to know about this run.
fn window_log_header(
    config: &FaithdConfig,
    clock: DaemonClock,
) -> faithd_formats::window_log::WindowLogHeader {
    faithd_formats::window_log::WindowLogHeader {
        faithd_window_log: faithd_formats::window_log::WINDOW_LOG_VERSION,
        faithd_version: env!("CARGO_PKG_VERSION").into(),
        clock_start_unix_us: clock.start_unix_us(),
        own_system_id: config.mavlink.system_id,
        own_component_id: config.mavlink.component_id,
        autopilot_system_id: config.mavlink.autopilot_system_id,
        autopilot_component_id: Some(config.mavlink.autopilot_component_id),
        clock_sync_window: link::CLOCK_SYNC_WINDOW,
        pipeline: config.pipeline,
    }
}

/// What the links to the autopilot (and the ground station) hand the daemon.
struct Links {
    vehicle_rx: watch::Receiver<VehicleState>,
    attitude: Arc<Mutex<AttitudeLog>>,
    /// The pipeline's running totals, which the ground station plots.
    telemetry: watch::Sender<PipelineTelemetry>,
    ground_feed: GroundFeed,
    /// faithd sends only its own HEARTBEAT on the MAVLink link: nothing else queues,
    /// but the queue stays open for the run.
    _to_autopilot: mpsc::Sender<mavlink::dialects::common::MavMessage>,
}

/// Starts the MAVLink link and, when configured, the ground station's: bystanders
/// fed through queues that never make the link or the commander wait.
fn start_links(
    config: &FaithdConfig,
    endpoint: Endpoint,
    clock: DaemonClock,
    recorder: &Option<record::Recorder>,
    supervisor: &mut supervise::Supervisor,
    stop: &Shutdown,
    tasks: &mut Tasks,
) -> Links {
    let (vehicle_tx, vehicle_rx) = watch::channel(VehicleState::default());
    let attitude = Arc::new(Mutex::new(AttitudeLog::default()));
    let (to_autopilot, own) = mpsc::channel(1);
    let (telemetry, telemetry_rx) = watch::channel(PipelineTelemetry::default());
    let (ground_feed, from_ground) = match config.ground.port() {
        Some(port) => {
            let (feed, io, from_ground) = ground::queues(&config.ground, telemetry_rx);
            tracing::info!(ground = %port, "ground station link configured");
            let (ground, mavlink) = (config.ground.clone(), config.mavlink.clone());
            let task = ground::run(ground, mavlink, port, clock, io);
            tasks.spawn("ground station link", stop, task);
            (feed, from_ground)
        }
        None => (GroundFeed::default(), None),
    };
    // Checked by `run` before anything started.
    let late_attitude = link::late_attitude::delay_from_env()
        .ok()
        .flatten()
        .map(|delay| link::late_attitude::start(delay, attitude.clone()));
    let outputs = LinkOutputs {
        vehicle: vehicle_tx,
        attitude: attitude.clone(),
        late_attitude,
        recorder: recorder.clone(),
        ground: ground_feed.clone(),
    };
    let beat = supervisor.register("autopilot link");
    match &config.telemetry {
        TelemetryConfig::Mavlink => {
            let to = ToAutopilot { own, from_ground };
            let task = link::run(config.mavlink.clone(), endpoint, clock, outputs, to, beat);
            tasks.spawn("autopilot link", stop, task);
        }
        TelemetryConfig::Msp(_) => {
            let task = over_msp::run(endpoint, msp_link_timing(config), clock, outputs, beat);
            tasks.spawn("autopilot link", stop, task);
        }
    }
    Links {
        vehicle_rx,
        attitude,
        telemetry,
        ground_feed,
        _to_autopilot: to_autopilot,
    }
}

/// The MSP telemetry link's timing: reconnects as `[mavlink]`'s, replies as the
/// command port's.
fn msp_link_timing(config: &FaithdConfig) -> over_msp::MspLinkTiming {
    let us = |v: i64| Duration::from_micros(v.max(1) as u64);
    over_msp::MspLinkTiming {
        reply_timeout: us(config.command.msp_timeout_us),
        reconnect_min: us(config.mavlink.reconnect_min_us),
        reconnect_max: us(config.mavlink.reconnect_max_us),
        autopilot_system_id: config.mavlink.autopilot_system_id,
        autopilot_component_id: config.mavlink.autopilot_component_id,
    }
}

/// The commander's ends of the pipeline's outputs.
struct PipelineEnds {
    status_rx: watch::Receiver<PipelineStatus>,
    decision_rx: watch::Receiver<Option<cycle::RollDecision>>,
}

/// The channels between the camera, the pipeline and the commander.
fn pipeline_channels(
    links: &Links,
    recorder: &Option<record::Recorder>,
    stop: &Shutdown,
) -> (PipelineEnds, SyncSender<Vec<Event>>, cycle::CycleIo) {
    let (status, status_rx) = watch::channel(PipelineStatus::default());
    let (decisions, decision_rx) = watch::channel(None);
    let (batches, events) = std::sync::mpsc::sync_channel(256);
    let cycle_io = cycle::CycleIo {
        events,
        attitude: links.attitude.clone(),
        outputs: cycle::CycleOutputs {
            status,
            decisions,
            telemetry: links.telemetry.clone(),
            recorder: recorder.clone(),
        },
        stop: stop.handle(),
    };
    let ends = PipelineEnds {
        status_rx,
        decision_rx,
    };
    (ends, batches, cycle_io)
}

/// Starts the camera and the pipeline: threads in flight, tasks in a simulated
/// flight. A camera that contradicts the configuration is reported as a refusal.
fn start_workers(
    execution: Execution,
    config: &FaithdConfig,
    clock: DaemonClock,
    (batches, cycle_io): (SyncSender<Vec<Event>>, cycle::CycleIo),
    stop: &Shutdown,
    faults: &supervise::Faults,
) -> Workers {
    let (pipeline_config, daemon_config) = (config.pipeline, config.daemon);
    match execution {
        Execution::Threads { source } => {
            let io = SourceIo {
                clock,
                batches,
                stop: stop.handle(),
            };
            let refusals = faults.clone();
            let camera = spawn_thread("faithd-source", faults, move || {
                if let Err(source::Refusal { key, reason }) = source(io) {
                    refusals.report(supervise::Fault::Refused { key, reason });
                }
            });
            let pipeline = spawn_thread("faithd-pipeline", faults, move || {
                cycle::run(pipeline_config, daemon_config, clock, cycle_io)
            });
            Workers::Threads([("pipeline", pipeline), ("camera", camera)])
        }
        Execution::Tasks { source, pipeline } => {
            let world_stop = stop.handle();
            let world = tokio::spawn(async move {
                world_stop.until(source(clock, batches)).await;
            });
            let pipeline = tokio::spawn(pipeline(pipeline_config, daemon_config, clock, cycle_io));
            Workers::Tasks([("pipeline", pipeline), ("camera", world)])
        }
    }
}

/// A named thread inside this run's faults: a panic on it ends the run.
fn spawn_thread(
    name: &str,
    faults: &supervise::Faults,
    work: impl FnOnce() + Send + 'static,
) -> std::thread::JoinHandle<()> {
    let faults = faults.clone();
    std::thread::Builder::new()
        .name(name.into())
        .spawn(move || {
            let _run = faults.enter();
            work()
        })
        .unwrap_or_else(|e| panic!("cannot start the {name} thread: {e}"))
}

/// Waits for what ends the run: the commander's end (a fault), the shutdown
/// request, or a fault reported by any part.
async fn wait_for_the_end(
    commander: &mut tokio::task::JoinHandle<()>,
    shutdown: impl std::future::Future<Output = &'static str>,
    faults: &supervise::Faults,
) -> Ended {
    // Every select in the daemon is biased: branches are polled in the order
    // written, so a simulated flight (one thread, simulated time) takes the same
    // path on every run. Rare events come first, so a busy stream cannot starve them.
    tokio::select! {
        biased;
        ended = commander => Ended::Fault(match ended {
            Err(e) if e.is_panic() => "the commander panicked".into(),
            _ => "the commander ended".into(),
        }),
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
    }
}

/// How long the tasks and threads have, once asked, to reach their safe states.
const STOP_WITHIN: Duration = Duration::from_secs(1);

/// Waits for every task and thread to have stopped (each dropped its [`Stop`]) and
/// joins them; one still running after [`STOP_WITHIN`] (a thread blocked in a
/// device) is named and not waited for.
async fn stop_all(stop: Shutdown, tasks: Tasks, workers: Workers) {
    let all_stopped = stop.stopped(STOP_WITHIN).await;
    for (name, task) in tasks.0 {
        if all_stopped || task.is_finished() {
            let _ = task.await;
        } else {
            tracing::warn!("the {name} task did not stop within 1 s; not waited for");
        }
    }
    workers.join(all_stopped).await;
}

/// The tasks of a run, by name, each ended by the run's stop.
#[derive(Default)]
struct Tasks(Vec<(&'static str, tokio::task::JoinHandle<()>)>);

impl Tasks {
    /// Spawns `work` until the run stops: these tasks hold nothing that needs more
    /// than dropping (a port closes, a timer ends), so where they wait is a safe
    /// place to end.
    fn spawn(
        &mut self,
        name: &'static str,
        stop: &Shutdown,
        work: impl std::future::Future<Output = ()> + Send + 'static,
    ) {
        let stop = stop.handle();
        let task = tokio::spawn(async move {
            stop.until(work).await;
        });
        self.0.push((name, task));
    }

    fn push(&mut self, name: &'static str, task: tokio::task::JoinHandle<()>) {
        self.0.push((name, task));
    }
}

/// The camera and the pipeline: threads in flight, tasks in a simulated flight.
enum Workers {
    Threads([(&'static str, std::thread::JoinHandle<()>); 2]),
    Tasks([(&'static str, tokio::task::JoinHandle<()>); 2]),
}

impl Workers {
    /// Joins the camera and the pipeline once they have stopped; one that has not
    /// (`all_stopped` false and still running) is named and not waited for.
    async fn join(self, all_stopped: bool) {
        match self {
            Workers::Threads(threads) => {
                for (name, thread) in threads {
                    if all_stopped || thread.is_finished() {
                        let _ = thread.join();
                    } else {
                        tracing::warn!(
                            "the {name} thread did not stop within 1 s (blocked in a device?); not waited for"
                        );
                    }
                }
            }
            Workers::Tasks(tasks) => {
                for (name, task) in tasks {
                    if all_stopped || task.is_finished() {
                        let _ = task.await;
                    } else {
                        tracing::warn!("the {name} task did not stop within 1 s; not waited for");
                    }
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
    /// The pipeline's newest estimates: the obstacle's time to contact.
    telemetry_rx: watch::Receiver<PipelineTelemetry>,
}

/// What the commander sets: the roll value held, and what the pilot's OSD shows.
struct Outputs {
    held: watch::Sender<u16>,
    view: watch::Sender<PilotView>,
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
    outputs: Outputs,
) {
    let Outputs { held, view } = outputs;
    let CommanderInputs {
        mut vehicle_rx,
        mut status_rx,
        mut decision_rx,
        mut stream_rx,
        mut observer,
        heartbeat,
        ground,
        telemetry_rx,
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
        let ttc_s = telemetry_rx.borrow().obstacle_ttc_s;
        let seen = PilotView::new(&step.gate, step.held_us, ttc_s);
        view.send_if_modified(|v| std::mem::replace(v, seen) != seen);
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

    /// The first of them to arrive, by name (biased as every select here: two signals
    /// pending at once are named in the same order on every run).
    async fn first(mut self) -> &'static str {
        tokio::select! {
            biased;
            _ = self.term.recv() => "SIGTERM",
            _ = self.int.recv() => "SIGINT",
            _ = self.hup.recv() => "SIGHUP",
        }
    }
}
