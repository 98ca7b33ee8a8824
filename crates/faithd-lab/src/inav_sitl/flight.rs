//! One flight of the closed-loop experiment with iNav's own flight controller in the
//! loop: iNav 9.1's SITL flies faithd-lab's quad-X ([`crate::realflight`]) through
//! its own mixer, PIDs and ANGLE mode; a scripted pilot on IBUS takes off, flies at
//! the pole with the pitch stick and puts the switch in AUTO; the real daemon
//! (`daemon::serve`) reads iNav on UART3 (its MAVLink, or with [`Link::Msp`] a second
//! MSP port) and streams its roll to iNav's MSP on UART4, as on the vehicle; the line
//! camera renders the true state in real time.
//!
//! Everything runs on the wall clock: iNav keeps its own, the physics server holds
//! each answer until the wall clock reaches the physics (so iNav's 1 kHz loop is
//! real time), and the line camera costs little enough to keep up on two cores.
//! What is measured is what iNav did: the roll at its mixer (its motors, as the
//! physics server saw them), the roll channel it reported (MSP_RC on its own port)
//! and the bank the vehicle reached under its controller.

use std::net::{IpAddr, Ipv4Addr};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::TrySendError;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde::Serialize;

use super::course::Course;
use super::monitor::{self, MODE_ANGLE, Monitor};
use super::pilot::{Phase, Pilot, Sticks};
use super::process::{
    self, Sitl, SitlError, UART_CLI, UART_MAVLINK, UART_MONITOR, UART_MSP_FAITHD,
};
use super::radio::{AUTO_US, CH_PITCH, CH_ROLL, CH_SWITCH, CH_THROTTLE, MANUAL_US, Radio};
use super::stalls::{Spans, StallFigures};
use crate::closed_loop::camera::{arena, optics};
use crate::closed_loop::physics::clearance_m;
use crate::closed_loop::{CameraKind, FlightSpec};
use crate::realflight::{Server, World};
use faithd_core::decide::{Action, RollDirection};
use faithd_daemon::clock::DaemonClock;
use faithd_daemon::command::{MspSink, Sink};
use faithd_daemon::config::FaithdConfig;
use faithd_daemon::daemon::{self, Ended, Execution, Hooks, Observation};
use faithd_daemon::link::TelemetryConfig;
use faithd_daemon::link::over_msp::MspTelemetryConfig;
use faithd_daemon::transport::Address;
use faithd_sim::world::line_camera::LineCamera;
use faithd_sim::world::quad_x::{QuadX, QuadXConfig};

/// iNav's set-up for these flights, applied in this order and saved: the pilot's
/// vehicle (IBUS receiver, ARM, ANGLE), faithd's committed script (what a person
/// pastes on the real board), then the simulated airframe (quad-X mixer, fake GPS).
const PILOT_CLI: &str = include_str!("../../../../tests/inav/pilot.cli");
const FAITHD_CLI: &str = include_str!("../../../../hil/inav/faithd.cli");
const FAITHD_MSP_CLI: &str = include_str!("../../../../hil/inav/faithd-msp.cli");
const QUAD_CLI: &str = include_str!("../../../../tests/inav/quad_rf.cli");

/// How faithd reads iNav in a flight: the vehicle's two ways of wiring it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Link {
    /// iNav's MAVLink telemetry on UART3 (hil/inav/faithd.cli): the default.
    #[default]
    Mavlink,
    /// A second MSP port on UART3 (hil/inav/faithd-msp.cli), no MAVLink at all, as
    /// on the iNav 10 boards without it (`[telemetry] kind = "msp"`).
    Msp,
}

impl Link {
    /// faithd's committed script for this link, and the lines that go with it on
    /// SITL: iNav allows three MSP ports (msp/msp_serial.h MAX_MSP_PORT_COUNT; a save
    /// with more resets every port, io/serial.c isSerialConfigValid), and SITL's
    /// UART1 and UART2 are both MSP, so with faithd's two UART2 gives its up.
    fn cli_lines(self) -> Vec<String> {
        match self {
            Link::Mavlink => process::script_lines(FAITHD_CLI),
            Link::Msp => {
                let mut lines = process::script_lines(FAITHD_MSP_CLI);
                lines.push("serial 1 0 115200 115200 115200 115200".into());
                lines
            }
        }
    }

    /// Where the harness reads what iNav uses: UART2, or UART1 when UART2 is no
    /// longer MSP (the board's USB port is the third there).
    pub fn monitor_uart(self) -> u16 {
        match self {
            Link::Mavlink => UART_MONITOR,
            Link::Msp => UART_CLI,
        }
    }

    /// In a line of text.
    pub fn describe(self) -> &'static str {
        match self {
            Link::Mavlink => "MAVLink telemetry",
            Link::Msp => "MSP-only link",
        }
    }
}

/// RealFlight's address for the next flight's SITL (its port is fixed at 18083 in
/// iNav 9.1's realFlight.c, `--simport` notwithstanding), a fresh loopback address
/// for every flight: iNav opens a connection per exchange, a thousand a second, and
/// the server closes each first, so a flight leaves some 20,000 connections in
/// TIME_WAIT on its address for a minute; the next flight's SITL never calls into
/// them. 253 addresses in turn come back to the first after more than an hour.
pub fn next_sim_ip() -> Ipv4Addr {
    static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed) % 253;
    Ipv4Addr::new(127, 0, 1, 2 + n as u8)
}

/// The roll is in effect at iNav's mixer once its left and right motors' commands
/// (0..1 each, summed per side) differ this much the roll's way: in the steady
/// cruise before a roll they are equal (the simulation has no wind).
pub const ROLL_MIX_IN_EFFECT: f64 = 0.05;

/// What iNav's SITL did in one flight.
#[derive(Clone, Debug, Serialize)]
pub struct SitlOutcome {
    pub spec: FlightSpec,
    pub collision_course: bool,
    pub collided: bool,
    /// faithd started a roll.
    pub rolled: bool,
    pub min_clearance_m: f64,
    /// Flight time of the roll decision, seconds (from the model's start point).
    pub decision_s: Option<f64>,
    /// From the newest event of the deciding window to the roll at iNav's mixer
    /// (its left and right motors [`ROLL_MIX_IN_EFFECT`] apart the roll's way),
    /// milliseconds.
    pub in_effect_ms: Option<f64>,
    /// The same to the first MSP_RC in which iNav reported the roll (its port is
    /// read every 10-20 ms, each sample stamped when it was asked for).
    pub msp_rc_ms: Option<f64>,
    /// The largest left-right motor difference in the second before the roll: how
    /// far below [`ROLL_MIX_IN_EFFECT`] the steady cruise stays.
    pub mix_before_roll: Option<f64>,
    /// From the same event to 5 degrees of bank the roll's way, milliseconds.
    pub bank_5_deg_ms: Option<f64>,
    /// From the same event to 90 % of the roll's peak bank, milliseconds.
    pub bank_90_ms: Option<f64>,
    /// The largest bank the roll's way within 2 s of its start, degrees.
    pub peak_bank_deg: Option<f64>,
    /// Largest height change within 2 s of the roll's start, metres.
    pub height_change_m: Option<f64>,
    /// Largest tilt of the whole flight after take-off, degrees (90 = flipped).
    pub max_tilt_deg: f64,
    /// The speed along the course when the flight started, m/s.
    pub speed_at_start_m_s: f64,
    /// Fresh SITLs started because one ended by itself while starting.
    pub sitl_restarts: u32,
    /// RealFlight exchanges answered.
    pub exchanges: u64,
    /// Where iNav's loop stalled, and what that could have changed.
    pub stalls: StallFigures,
    /// From the newest event of the deciding window to faithd's roll: its pipeline
    /// and gate on this machine, ms.
    pub decision_ms: Option<f64>,
    pub path: Vec<SitlPathPoint>,
}

#[derive(Clone, Copy, Debug, Serialize)]
pub struct SitlPathPoint {
    pub t_s: f64,
    pub x_m: f64,
    pub y_m: f64,
    pub height_m: f64,
    pub bank_deg: f64,
    /// Nose up positive.
    pub pitch_deg: f64,
    pub tilt_deg: f64,
    /// Speed along the course, m/s.
    pub speed_m_s: f64,
    /// The roll channel iNav used last (MSP_RC).
    pub roll_us: u16,
}

/// Flies `spec` with iNav's SITL at `exe` in the loop, faithd reading iNav over
/// `link`. The spec's camera must be the line camera: the flight runs in real time,
/// and the ray-traced one cannot keep up beside SITL on two cores.
pub fn fly(spec: &FlightSpec, exe: &Path, link: Link) -> Result<SitlOutcome, SitlError> {
    if spec.camera != CameraKind::Line {
        return Err(SitlError::Other(format!(
            "camera {:?}: a flight with iNav's SITL runs in real time on the line camera only",
            spec.camera
        )));
    }
    let course = Course::of(spec);
    let mut restarts = 0;
    let (server, sitl) = loop {
        match boot(spec, &course, exe, link) {
            Ok(booted) => break booted,
            Err(SitlError::Crashed { status, log }) if restarts < MAX_RESTARTS => {
                restarts += 1;
                tracing::warn!(
                    %status,
                    restarts,
                    "SITL ended by itself while it started, before anything flew; starting a fresh one. Its log:\n{log}"
                );
            }
            Err(e) => return Err(e),
        }
    };
    let world = server.world.clone();
    let radio = Radio::start(&sitl)?;
    let monitor = Monitor::start_on(&sitl, link.monitor_uart())?;
    let daemon = Daemon::start(spec, &sitl, link, world.clone())?;
    monitor::arm(&radio, &monitor, &sitl)?;
    if !monitor.latest().is_some_and(|s| s.mode(MODE_ANGLE)) {
        return Err(SitlError::Other(
            "armed without ANGLE: tests/inav/pilot.cli puts ANGLE on the ARM switch".into(),
        ));
    }
    let flown = fly_course(spec, &course, &world, &radio, &monitor, &daemon.clock);
    radio.set(CH_THROTTLE, 1000);
    radio.set(CH_SWITCH, MANUAL_US);
    let observations = daemon.stop()?;
    let flown =
        flown.map_err(|why| SitlError::Other(format!("{why}; SITL log:\n{}", sitl.log())))?;
    let mut outcome = measure(spec, flown, &observations, &monitor, &world);
    outcome.sitl_restarts = restarts;
    Ok(outcome)
}

/// Fresh SITLs a flight may start after one that ended by itself while starting.
const MAX_RESTARTS: u32 = 3;

/// The quad-X on the ground at the take-off point, its RealFlight server, and SITL
/// flying it with the set-up for `link` saved (iNav reboots to take it).
fn boot(
    spec: &FlightSpec,
    course: &Course,
    exe: &Path,
    link: Link,
) -> Result<(Server, Sitl), SitlError> {
    let world = World::new(QuadX::on_ground(
        QuadXConfig::default(),
        course.takeoff_m(spec),
        spec.heading_deg.to_radians(),
    ));
    let sim_ip = next_sim_ip();
    let server = Server::start(IpAddr::V4(sim_ip), world)
        .map_err(|e| SitlError::Other(format!("cannot bind RealFlight's {sim_ip}:18083: {e}")))?;
    let sitl = Sitl::start(
        exe,
        &[
            "--sim=rf".into(),
            format!("--simip={sim_ip}"),
            "--chanmap=M01-01,M02-02,M03-03,M04-04".into(),
        ],
    )?;
    let mut lines = process::script_lines(PILOT_CLI);
    lines.extend(link.cli_lines());
    lines.extend(process::script_lines(QUAD_CLI));
    sitl.cli_save(&lines)?;
    Ok((server, sitl))
}

/// The flight as the pilot flew it.
struct Flown {
    clock: DaemonClock,
    /// One moment on both clocks: the wall's and the daemon's.
    base: (Instant, i64),
    /// Daemon time of the flight's start (the model's start point reached).
    start_us: i64,
    path: Vec<(i64, SitlPathPoint)>,
    collided: bool,
    min_clearance_m: f64,
    max_tilt_deg: f64,
    speed_at_start_m_s: f64,
}

impl Flown {
    fn instant_of(&self, t_us: i64) -> Instant {
        let (at, base_us) = self.base;
        if t_us >= base_us {
            at + Duration::from_micros((t_us - base_us) as u64)
        } else {
            at - Duration::from_micros((base_us - t_us) as u64)
        }
    }

    fn daemon_us(&self, at: Instant) -> i64 {
        let (base, base_us) = self.base;
        match at.checked_duration_since(base) {
            Some(d) => base_us + d.as_micros() as i64,
            None => base_us - base.duration_since(at).as_micros() as i64,
        }
    }
}

/// The scripted pilot flies the course: take-off and hover, then at the pole with
/// the pitch stick, the switch in AUTO on time; ends 1 m past the pole, on contact,
/// on a flip or at the spec's time limit.
fn fly_course(
    spec: &FlightSpec,
    course: &Course,
    world: &World,
    radio: &Radio,
    monitor: &Monitor,
    clock: &DaemonClock,
) -> Result<Flown, String> {
    let mut pilot = Pilot::new(spec, *course);
    let arena = arena(spec);
    let started = Instant::now();
    let mut flown = Flown {
        clock: *clock,
        base: (Instant::now(), clock.now_us()),
        start_us: i64::MAX,
        path: Vec::new(),
        collided: false,
        min_clearance_m: f64::INFINITY,
        max_tilt_deg: 0.0,
        speed_at_start_m_s: f64::NAN,
    };
    let mut next = Instant::now();
    loop {
        let quad = world.quad();
        let now_us = clock.now_us();
        let Sticks {
            throttle_us,
            pitch_us,
            roll_us,
            auto,
        } = pilot.step(&quad, now_us);
        radio.set(CH_THROTTLE, throttle_us);
        radio.set(CH_PITCH, pitch_us);
        radio.set(CH_ROLL, roll_us);
        radio.set(CH_SWITCH, if auto { AUTO_US } else { MANUAL_US });
        let tilt_deg = quad.tilt_rad().to_degrees();
        let height_m = -quad.position_m.z;
        if pilot.phase != Phase::Climb {
            flown.max_tilt_deg = flown.max_tilt_deg.max(tilt_deg);
        }
        if tilt_deg > 90.0 {
            return Err(format!("the vehicle flipped: tilt {tilt_deg:.0} deg"));
        }
        if let Some(t0) = pilot.start_us {
            if flown.start_us == i64::MAX {
                flown.start_us = t0;
                flown.speed_at_start_m_s = quad.velocity_m_s.dot(&course.forward);
            }
            let clearance = clearance_m(&arena, &quad.position_m);
            flown.min_clearance_m = flown.min_clearance_m.min(clearance);
            let (bank_rad, pitch_rad, _) = quad.euler_rad();
            flown.path.push((
                now_us,
                SitlPathPoint {
                    t_s: (now_us - t0) as f64 * 1e-6,
                    x_m: quad.position_m.x,
                    y_m: quad.position_m.y,
                    height_m,
                    bank_deg: bank_rad.to_degrees(),
                    pitch_deg: pitch_rad.to_degrees(),
                    tilt_deg,
                    speed_m_s: quad.velocity_m_s.dot(&course.forward),
                    roll_us: monitor.latest().map_or(0, |s| s.roll()),
                },
            ));
            if clearance < 0.0 {
                flown.collided = true;
                return Ok(flown);
            }
            if course.to_go_m(&quad.position_m) < -1.0
                || (now_us - t0) as f64 * 1e-6 > spec.max_time_s
            {
                return Ok(flown);
            }
            if height_m < 0.2 {
                return Err(format!("the vehicle came down in flight: {quad:?}"));
            }
        } else if started.elapsed() > Duration::from_secs(25) {
            return Err(format!(
                "the pilot never reached the start ({:?}): {quad:?}",
                pilot.phase
            ));
        }
        next += Duration::from_millis(10);
        match next.checked_duration_since(Instant::now()) {
            Some(wait) => std::thread::sleep(wait),
            None => next = Instant::now(),
        }
    }
}

/// The figures of one flight, from what iNav used and what the vehicle did.
fn measure(
    spec: &FlightSpec,
    flown: Flown,
    observations: &[Observation],
    monitor: &Monitor,
    world: &World,
) -> SitlOutcome {
    let started = observations.iter().find_map(|o| match o {
        Observation::ManoeuvreStarted {
            last_event_us,
            started_us,
            decision,
            ..
        } => Some((*last_event_us, *started_us, decision.action)),
        _ => None,
    });
    let mut outcome = SitlOutcome {
        spec: spec.clone(),
        collision_course: spec.is_collision_course(),
        collided: flown.collided,
        rolled: started.is_some(),
        min_clearance_m: flown.min_clearance_m,
        decision_s: None,
        in_effect_ms: None,
        msp_rc_ms: None,
        mix_before_roll: None,
        bank_5_deg_ms: None,
        bank_90_ms: None,
        peak_bank_deg: None,
        height_change_m: None,
        max_tilt_deg: flown.max_tilt_deg,
        speed_at_start_m_s: flown.speed_at_start_m_s,
        sitl_restarts: 0,
        exchanges: world.counters.exchanges.load(Ordering::Relaxed),
        stalls: StallFigures::default(),
        decision_ms: None,
        path: flown.path.iter().map(|(_, p)| *p).collect(),
    };
    let stalls = world
        .stalls
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .clone();
    let mut spans = Spans {
        course_start: flown.instant_of(flown.start_us),
        mixer: None,
        roll: None,
        approach_speed_m_s: fastest_m_s(&flown.path, i64::MAX),
    };
    let Some((event_us, started_us, action)) = started else {
        outcome.stalls = StallFigures::of(&stalls, spans);
        return outcome;
    };
    outcome.decision_ms = Some((started_us - event_us) as f64 / 1e3);
    let sign = match action {
        Action::Roll {
            direction: RollDirection::Left,
            ..
        } => -1.0,
        _ => 1.0,
    };
    outcome.decision_s = Some((started_us - flown.start_us) as f64 * 1e-6);
    let ms_after_event = |t_us: i64| (t_us - event_us) as f64 / 1e3;
    // iNav's samples are stamped in Unix time; the daemon's clock counts from its start.
    let to_daemon = |unix_us: i64| unix_us - flown.clock.start_unix_us();
    outcome.msp_rc_ms = monitor
        .between(flown.clock.unix_us(started_us) as i64, i64::MAX)
        .iter()
        .find(|s| (f64::from(s.roll()) - 1500.0) * sign > 100.0)
        .map(|s| ms_after_event(to_daemon(s.t_us)));
    let started_at = flown.instant_of(started_us);
    let mix = world.roll_mix.lock().unwrap_or_else(|e| e.into_inner());
    outcome.mix_before_roll = Some(
        mix.iter()
            .filter(|(at, _)| {
                *at < started_at && started_at.duration_since(*at).as_secs_f64() < 1.0
            })
            .map(|(_, m)| m.abs())
            .fold(0.0, f64::max),
    );
    let in_effect_at = mix
        .iter()
        .find(|(at, mix)| *at >= started_at && mix * sign > ROLL_MIX_IN_EFFECT)
        .map(|(at, _)| *at);
    outcome.in_effect_ms = in_effect_at.map(|at| ms_after_event(flown.daemon_us(at)));
    spans.mixer = in_effect_at;
    spans.roll = Some((
        flown.instant_of(event_us),
        flown.instant_of(started_us + 2_000_000),
    ));
    spans.approach_speed_m_s = fastest_m_s(
        &flown.path,
        in_effect_at.map_or(i64::MAX, |at| flown.daemon_us(at)),
    );
    outcome.stalls = StallFigures::of(&stalls, spans);
    let roll: Vec<&(i64, SitlPathPoint)> = flown
        .path
        .iter()
        .filter(|(t, _)| *t >= started_us && *t <= started_us + 2_000_000)
        .collect();
    let peak = roll
        .iter()
        .map(|(_, p)| p.bank_deg * sign)
        .fold(f64::MIN, f64::max);
    if roll.is_empty() {
        return outcome;
    }
    outcome.peak_bank_deg = Some(peak);
    outcome.bank_5_deg_ms = roll
        .iter()
        .find(|(_, p)| p.bank_deg * sign >= 5.0)
        .map(|(t, _)| ms_after_event(*t));
    outcome.bank_90_ms = roll
        .iter()
        .find(|(_, p)| p.bank_deg * sign >= 0.9 * peak)
        .map(|(t, _)| ms_after_event(*t));
    let h0 = roll[0].1.height_m;
    outcome.height_change_m = Some(
        roll.iter()
            .map(|(_, p)| (p.height_m - h0).abs())
            .fold(0.0, f64::max),
    );
    outcome
}

/// The fastest along the course in the path until daemon time `until_us`, m/s.
fn fastest_m_s(path: &[(i64, SitlPathPoint)], until_us: i64) -> f64 {
    path.iter()
        .take_while(|(t, _)| *t <= until_us)
        .map(|(_, p)| p.speed_m_s.abs())
        .fold(0.0, f64::max)
}

/// The real daemon, on a runtime of its own, with the line camera as its source.
struct Daemon {
    clock: DaemonClock,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    observations: Arc<Mutex<Vec<Observation>>>,
    thread: Option<std::thread::JoinHandle<Ended>>,
    camera_stop: Arc<AtomicBool>,
}

impl Daemon {
    fn start(
        spec: &FlightSpec,
        sitl: &Sitl,
        link: Link,
        world: Arc<World>,
    ) -> Result<Self, SitlError> {
        let mut config = FaithdConfig::default();
        let address = |uart| {
            Address::parse(&sitl.endpoint(uart))
                .map_err(|e| SitlError::Other(format!("UART{uart}: {e}")))
        };
        match link {
            Link::Mavlink => config.mavlink.endpoint = address(UART_MAVLINK)?,
            Link::Msp => {
                config.telemetry = TelemetryConfig::Msp(MspTelemetryConfig {
                    endpoint: address(UART_MAVLINK)?,
                    ..MspTelemetryConfig::default()
                })
            }
        }
        config.mavlink.reconnect_min_us = 50_000;
        config.mavlink.reconnect_max_us = 200_000;
        config.command.sink = Sink::Msp(MspSink {
            endpoint: address(UART_MSP_FAITHD)?,
            ..MspSink::default()
        });
        config.record.enabled = false;
        if let Some(dir) = std::env::var_os("FAITHD_SITL_RECORD") {
            config.record.enabled = true;
            config.record.dir = dir.into();
        }
        let clock = DaemonClock::start();
        let camera_stop = Arc::new(AtomicBool::new(false));
        let observations = Arc::new(Mutex::new(Vec::new()));
        let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
        let source = {
            let (spec, stop) = (spec.clone(), camera_stop.clone());
            Box::new(move |io: faithd_daemon::source::SourceIo| {
                line_camera(&spec, &world, io.clock, io.batches, &stop);
                Ok(())
            })
        };
        let observer = {
            let observations = observations.clone();
            Box::new(move |o| observations.lock().expect("observations lock").push(o))
        };
        let faults = faithd_daemon::supervise::Faults::new();
        let runtime = faults
            .runtime()
            .map_err(|e| SitlError::Other(format!("the daemon's runtime: {e}")))?;
        let endpoint = config.autopilot_port();
        let msp_endpoint = config.command.msp_port();
        let hooks = Hooks {
            clock,
            execution: Execution::Threads { source },
            observer: Some(observer),
            faults,
        };
        let thread = std::thread::spawn(move || {
            let ended = runtime.block_on(daemon::serve(
                config,
                endpoint,
                msp_endpoint,
                hooks,
                async move {
                    let _ = stop_rx.await;
                    "the flight ended"
                },
            ));
            runtime.shutdown_timeout(Duration::from_millis(200));
            ended
        });
        Ok(Self {
            clock,
            stop: Some(stop_tx),
            observations,
            thread: Some(thread),
            camera_stop,
        })
    }

    /// Stops the daemon; what it observed, or the fault it ended on.
    fn stop(mut self) -> Result<Vec<Observation>, SitlError> {
        self.camera_stop.store(true, Ordering::Relaxed);
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        let ended = self
            .thread
            .take()
            .map(|t| t.join())
            .unwrap_or(Ok(Ended::Requested("never started")));
        match ended {
            Ok(Ended::Requested(_)) => Ok(std::mem::take(
                &mut *self.observations.lock().expect("observations lock"),
            )),
            Ok(other) => Err(SitlError::Other(format!("faithd ended on {other:?}"))),
            Err(_) => Err(SitlError::Other("faithd's thread panicked".into())),
        }
    }
}

impl Drop for Daemon {
    fn drop(&mut self) {
        self.camera_stop.store(true, Ordering::Relaxed);
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The line camera on the vehicle's true state, every millisecond of wall time, its
/// events stamped on the daemon's clock as a USB camera's are once mapped.
fn line_camera(
    spec: &FlightSpec,
    world: &World,
    clock: DaemonClock,
    batches: std::sync::mpsc::SyncSender<Vec<faithd_core::event::Event>>,
    stop: &AtomicBool,
) {
    let mut arena = arena(spec);
    arena.contrast = spec.contrast;
    let (intrinsics, mounting) = optics();
    let mut camera = LineCamera::new(intrinsics, mounting, arena, spec.seed);
    camera.noise_rate_hz = spec.noise_rate_hz;
    let mut next = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        let state = world.quad().state();
        let mut batch = Vec::new();
        camera.advance(&state, clock.now_us(), &mut batch);
        if !batch.is_empty() {
            match batches.try_send(batch) {
                Ok(()) | Err(TrySendError::Full(_)) => {}
                Err(TrySendError::Disconnected(_)) => return,
            }
        }
        next += Duration::from_millis(1);
        match next.checked_duration_since(Instant::now()) {
            Some(wait) => std::thread::sleep(wait),
            None => next = Instant::now(),
        }
    }
}
