//! iNav 10's bank-angle command beside faithd's stick route, measured on iNav itself.
//!
//! iNav 10 (maintenance-10.x) takes a bank angle over MSP:
//! MSP2_INAV_FLIGHT_AXIS_ANGLE_OVERRIDE (0x2216; u8 axis mask, 1 = roll, then i16
//! roll, pitch, yaw in decidegrees). What this experiment relies on, in iNav 10.x's
//! `src/main/`:
//! - fc/fc_msp.c:2648-2660: the command, a payload of exactly 7 bytes, only with
//!   USE_RX_MSP and USE_MSP_RC_OVERRIDE;
//! - rx/msp_override.c:286-301: every message stamps `lastAxisOverrideAt`, clamps roll
//!   to `max_angle_inclination_rll` and replaces the mask (mask 0 ends it);
//! - rx/msp_override.c:142-167: in effect only while the MSP RC OVERRIDE mode is on
//!   and the MSP override is out of failsafe (so MSP_SET_RAW_RC frames must keep
//!   coming), and cleared once no message came for 200 ms + failsafe_delay x 100 ms;
//! - programming/logic_condition.c:1215-1226 and 1243-1255, flight/pid.c:1307-1321:
//!   an axis with the override active runs iNav's level controller on the target,
//!   whatever the flight mode (ACRO too; MANUAL bypasses the PIDs).
//!
//! The experiment flies the lab's quad-X on iNav's SITL (the RealFlight server, a
//! scripted hand on IBUS holding 2 m) and plays each route from a harness sender on
//! SITL's UART4, the port faithd's roll stream uses, at faithd's pace: one command
//! per 20 ms slot at most, MSP_SET_RAW_RC every 40 ms. The stick route sends the roll
//! in MSP_SET_RAW_RC (1800/1200 us, faithd's 300 us); the bank-angle route keeps
//! MSP_SET_RAW_RC at the centre and sends 0x2216 with the bank the stick route
//! reaches (147 decidegrees) in the other slots, then mask 0. Each roll lasts 1.5 s,
//! as faithd's. Measured on iNav: the bank of the physics' true attitude and iNav's
//! motors, as [`super::flight`] measures the stick route in the closed loop.
//!
//! A lab experiment, not a faithd route: it decides whether one is worth building.

use std::io::{Read, Write};
use std::net::{IpAddr, TcpStream};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use nalgebra::Vector3;
use serde::Serialize;

use super::experiment::Spread;
use super::flight::{ROLL_MIX_IN_EFFECT, next_sim_ip};
use super::monitor::{self, MODE_ANGLE, Monitor};
use super::msp_client::{MspClient, read_timed_out};
use super::process::{self, Sitl, SitlError, UART_CLI, UART_MSP_FAITHD};
use super::radio::{AUTO_US, CH_PITCH, CH_ROLL, CH_SWITCH, CH_THROTTLE, MANUAL_US, Radio};
use crate::realflight::{Server, World};
use faithd_daemon::command::msp::{self, Decoder, MSP_SET_RAW_RC};
use faithd_sim::world::quad_x::{QuadX, QuadXConfig};

/// iNav 10's bank-angle command (msp/msp_protocol_v2_inav.h:138).
pub const MSP2_INAV_FLIGHT_AXIS_ANGLE_OVERRIDE: u16 = 0x2216;
/// MSP_API_VERSION: iNav 10.x answers 2.6, 9.1 answers 2.5 (msp/msp_protocol.h:62).
const MSP_API_VERSION: u16 = 1;

/// The bank the stick route reaches in iNav's ANGLE with its defaults (14.68 degrees
/// over the closed loop's rolls, `measured::PEAK_BANK_DEG`), the bank-angle route's
/// target, decidegrees.
pub const TARGET_DDEG: i16 = 147;
/// faithd's roll stick: 300 us from the centre.
const STICK_US: u16 = 300;
const CENTRE_US: u16 = 1500;
/// faithd's roll: 1.5 s.
const ROLL: Duration = Duration::from_millis(1500);
/// One command a slot at most: iNav serves one per port every 10 ms, faithd half.
const SLOT: Duration = Duration::from_millis(20);
/// MSP_SET_RAW_RC's period, and the bank-angle command's while it rolls.
const PERIOD: Duration = Duration::from_millis(40);
/// Where the sender is killed in a roll.
const KILLED_AFTER: Duration = Duration::from_millis(750);
/// The stick route outside ANGLE commands a roll rate: stopped at this bank.
const ACRO_STOP_DEG: f64 = 30.0;

/// ANGLE moves to its own switch (AUX3) so that the hand can fly without it:
/// tests/inav/pilot.cli puts it on the ARM switch.
const CH_ANGLE: usize = 7;
const ANGLE_ON_US: u16 = 1900;
const ANGLE_OFF_US: u16 = 1000;
/// The hand's roll stick while the route rolls: a hair off centre, so that MSP_RC
/// shows whose roll iNav uses (1500 = the sender's), with no bank worth the name.
const HAND_ROLL_US: u16 = 1490;
const HOVER_M: f64 = 2.0;

/// iNav's set-up: the pilot's vehicle, faithd's script (UART4 MSP, roll alone
/// overridden while the switch is in AUTO), the airframe, then ANGLE on AUX3.
const PILOT_CLI: &str = include_str!("../../../../tests/inav/pilot.cli");
const FAITHD_CLI: &str = include_str!("../../../../hil/inav/faithd.cli");
const QUAD_CLI: &str = include_str!("../../../../tests/inav/quad_rf.cli");
const ANGLE_ON_AUX3: &str = "aux 1 1 2 1700 2100";

/// How the roll reaches iNav.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Route {
    /// faithd's route today: MSP_SET_RAW_RC's roll at 1800/1200 us.
    Stick,
    /// iNav 10's MSP2_INAV_FLIGHT_AXIS_ANGLE_OVERRIDE at the stick route's bank.
    BankAngle,
}

/// What a roll is put through.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Trial {
    /// In ANGLE, the whole 1.5 s.
    Angle,
    /// Without ANGLE (ACRO): the stick route is stopped at [`ACRO_STOP_DEG`].
    Acro,
    /// In ANGLE, the sender killed [`KILLED_AFTER`] into the roll: nothing more sent.
    Killed,
}

/// One roll, as iNav flew it. Times are from the first command of the roll written
/// to UART4 (the kill's from the last command written).
#[derive(Clone, Debug, Serialize)]
pub struct TrialOutcome {
    pub route: Route,
    pub trial: Trial,
    /// +1 right, -1 left.
    pub direction: f64,
    /// ANGLE was on (MSP2_INAV_STATUS) all through the roll.
    pub angle_mode: bool,
    /// To iNav's left and right motors [`ROLL_MIX_IN_EFFECT`] apart the roll's way.
    pub to_mixer_ms: Option<f64>,
    pub to_5_deg_ms: Option<f64>,
    /// To 90 % of the target (14.7 degrees).
    pub to_90_ms: Option<f64>,
    /// The largest bank the roll's way while it was commanded, degrees.
    pub peak_deg: f64,
    /// The bank over the whole command, mean; over its last 0.5 s (settled), mean
    /// and least. Only for a command of the whole 1.5 s.
    pub mean_deg: Option<f64>,
    pub settled_mean_deg: Option<f64>,
    pub settled_min_deg: Option<f64>,
    /// How long the roll was commanded, ms (less than 1.5 s when stopped).
    pub commanded_ms: f64,
    /// The stick route in ACRO: mean roll rate from 5 to 25 degrees, deg/s.
    pub roll_rate_deg_s: Option<f64>,
    /// The bank 0.5 s after the command ended (in ACRO: still without ANGLE).
    pub bank_after_end_deg: Option<f64>,
    /// From the end of the command (the centre, or mask 0) to iNav's mixer rolling
    /// back (its motors [`ROLL_MIX_IN_EFFECT`] apart the other way), and to under 5
    /// degrees.
    pub end_to_mixer_back_ms: Option<f64>,
    pub end_to_level_ms: Option<f64>,
    /// Killed: from the last command written to iNav's mixer rolling back, to the
    /// bank falling under 90 % of what it was then, and to under 5 degrees.
    pub kill_to_mixer_back_ms: Option<f64>,
    pub kill_to_falling_ms: Option<f64>,
    pub kill_to_level_ms: Option<f64>,
    /// The largest roll stick iNav reported using during the roll (MSP_RC), us from
    /// the centre.
    pub stick_seen_us: u16,
    /// Commands written to UART4 a second: in the roll (all, MSP_SET_RAW_RC, 0x2216)
    /// and in the second before it.
    pub per_s_in_roll: Option<f64>,
    pub rc_per_s_in_roll: Option<f64>,
    pub bank_per_s_in_roll: Option<f64>,
    pub per_s_before: f64,
    /// Commands iNav refused (an MSP error reply) in the trial.
    pub refused: usize,
}

/// The experiment's trials and the SITL's figures.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// MSP_API_VERSION of the SITL flown (major, minor).
    pub msp_api: (u8, u8),
    pub trials: Vec<TrialOutcome>,
    pub exchanges: u64,
    pub late_exchanges: u64,
}

/// Flies the trials on iNav's SITL at `exe` (a 10.x build): `angle_rolls` rolls in
/// ANGLE per route (alternately right and left), then one without ANGLE and one with
/// the sender killed per route. `done` hears each trial.
pub fn run(
    exe: &Path,
    angle_rolls: usize,
    done: impl Fn(&TrialOutcome),
) -> Result<Report, SitlError> {
    let mut rig = Rig::boot(exe)?;
    let msp_api = rig.msp_api()?;
    if msp_api < (2, 6) {
        return Err(SitlError::Other(format!(
            "{}: MSP API {}.{}, iNav 9's; the bank-angle command is iNav 10's (MSP API 2.6)",
            exe.display(),
            msp_api.0,
            msp_api.1
        )));
    }
    rig.take_off()?;
    let mut plan = Vec::new();
    for i in 0..angle_rolls {
        let direction = if i % 2 == 0 { 1.0 } else { -1.0 };
        plan.push((Route::Stick, Trial::Angle, direction));
        plan.push((Route::BankAngle, Trial::Angle, direction));
    }
    for trial in [Trial::Acro, Trial::Killed] {
        for direction in [1.0, -1.0] {
            plan.push((Route::Stick, trial, direction));
            plan.push((Route::BankAngle, trial, -direction));
        }
    }
    let mut trials = Vec::new();
    for (route, trial, direction) in plan {
        let outcome = rig.fly(route, trial, direction)?;
        done(&outcome);
        trials.push(outcome);
    }
    Ok(Report {
        msp_api,
        trials,
        exchanges: rig.world.counters.exchanges.load(Ordering::Relaxed),
        late_exchanges: rig.world.counters.late_exchanges.load(Ordering::Relaxed),
    })
}

/// The vehicle: SITL flying the quad-X, the radio, the hand, the monitor, the sender.
struct Rig {
    world: Arc<World>,
    radio: Arc<Radio>,
    monitor: Monitor,
    hand: Hand,
    sender: Option<Sender>,
    // Dropped last: the threads above use their ports.
    sitl: Sitl,
    _server: Server,
}

impl Rig {
    fn boot(exe: &Path) -> Result<Self, SitlError> {
        let mut lines = process::script_lines(PILOT_CLI);
        lines.extend(process::script_lines(FAITHD_CLI));
        lines.extend(process::script_lines(QUAD_CLI));
        lines.push(ANGLE_ON_AUX3.into());
        let mut tries = 0;
        let (server, sitl) = loop {
            let world = World::new(QuadX::on_ground(
                QuadXConfig::default(),
                Vector3::zeros(),
                0.0,
            ));
            let sim_ip = next_sim_ip();
            let server = Server::start(IpAddr::V4(sim_ip), world).map_err(|e| {
                SitlError::Other(format!("cannot bind RealFlight's {sim_ip}:18083: {e}"))
            })?;
            let booted = Sitl::start(
                exe,
                &[
                    "--sim=rf".into(),
                    format!("--simip={sim_ip}"),
                    "--chanmap=M01-01,M02-02,M03-03,M04-04".into(),
                ],
            )
            .and_then(|sitl| sitl.cli_save(&lines).map(|()| sitl));
            match booted {
                Ok(sitl) => break (server, sitl),
                Err(SitlError::Crashed { status, .. }) if tries < 3 => {
                    tries += 1;
                    tracing::warn!(%status, "SITL ended by itself while it started; a fresh one");
                }
                Err(e) => return Err(e),
            }
        };
        let world = server.world.clone();
        let radio = Arc::new(Radio::start(&sitl)?);
        radio.set(CH_ANGLE, ANGLE_ON_US);
        let monitor = Monitor::start(&sitl)?;
        let hand = Hand::start(world.clone(), radio.clone());
        Ok(Self {
            world,
            radio,
            monitor,
            hand,
            sender: None,
            sitl,
            _server: server,
        })
    }

    /// MSP_API_VERSION on UART1: (major, minor).
    fn msp_api(&self) -> Result<(u8, u8), SitlError> {
        let mut client = MspClient::connect(self.sitl.port(UART_CLI))
            .map_err(|e| SitlError::Other(format!("UART1: {e}")))?;
        let v = client
            .request(MSP_API_VERSION, &[])
            .map_err(|e| SitlError::Other(format!("MSP_API_VERSION: {e}")))?;
        match v[..] {
            [_, major, minor, ..] => Ok((major, minor)),
            _ => Err(SitlError::Other(format!("MSP_API_VERSION: {v:?}"))),
        }
    }

    /// Arms in ANGLE, climbs to 2 m and starts the sender.
    fn take_off(&mut self) -> Result<(), SitlError> {
        monitor::arm(&self.radio, &self.monitor, &self.sitl)?;
        self.hand.flying.store(true, Ordering::Relaxed);
        self.sender = Some(Sender::start(&self.sitl, self.radio.clone())?);
        self.steady(Duration::from_secs(25))
            .map_err(|e| SitlError::Other(format!("take-off: {e}")))
    }

    /// Waits until the vehicle hovers level and still at 2 m for half a second.
    fn steady(&self, timeout: Duration) -> Result<(), String> {
        let deadline = Instant::now() + timeout;
        let mut since = None;
        while Instant::now() < deadline {
            let quad = self.world.quad();
            let (bank, pitch, _) = quad.euler_rad();
            let v = quad.velocity_m_s;
            let ok = (-quad.position_m.z - HOVER_M).abs() < 0.25
                && v.x.hypot(v.y) < 0.25
                && bank.to_degrees().abs() < 1.5
                && pitch.to_degrees().abs() < 3.0;
            if quad.tilt_rad().to_degrees() > 60.0 {
                return Err(format!("lost control: {quad:?}"));
            }
            match (ok, since) {
                (true, None) => since = Some(Instant::now()),
                (false, _) => since = None,
                (true, Some(t)) if Instant::now() - t > Duration::from_millis(500) => {
                    return Ok(());
                }
                _ => {}
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        Err(format!(
            "not steady in {timeout:?}: {:?}",
            self.world.quad()
        ))
    }

    /// One roll by `route` put through `trial`, from a steady hover.
    fn fly(
        &mut self,
        route: Route,
        trial: Trial,
        direction: f64,
    ) -> Result<TrialOutcome, SitlError> {
        let fail = |why: String| SitlError::Other(format!("{route:?} {trial:?}: {why}"));
        // The hand steadies the vehicle in MANUAL; the sender streams the centre.
        self.radio.set(CH_SWITCH, MANUAL_US);
        self.radio.set(CH_ANGLE, ANGLE_ON_US);
        self.hand.set(true, true);
        if self.sender.as_ref().is_none_or(Sender::is_dead) {
            self.sender = Some(Sender::start(&self.sitl, self.radio.clone())?);
        }
        self.steady(Duration::from_secs(20)).map_err(fail)?;
        // AUTO: iNav takes roll from UART4 once MSP_RC shows the sender's centre.
        self.hand.set(false, true);
        self.radio.set(CH_SWITCH, AUTO_US);
        std::thread::sleep(Duration::from_millis(100));
        self.monitor
            .wait_until(Duration::from_secs(3), |s| s.roll() == CENTRE_US)
            .ok_or_else(|| fail("iNav never took the sender's roll".into()))?;
        std::thread::sleep(Duration::from_millis(300));
        if trial == Trial::Acro {
            self.hand.set(false, false);
            self.radio.set(CH_ANGLE, ANGLE_OFF_US);
            self.monitor
                .wait_until(Duration::from_secs(2), |s| !s.mode(MODE_ANGLE))
                .ok_or_else(|| fail("ANGLE did not go off".into()))?;
            std::thread::sleep(Duration::from_millis(200));
        }
        let sender = self.sender.as_ref().expect("the sender runs");
        let rolling = if route == Route::Stick {
            Wanted {
                roll_us: (f64::from(CENTRE_US) + direction * f64::from(STICK_US)) as u16,
                bank_ddeg: None,
            }
        } else {
            Wanted {
                roll_us: CENTRE_US,
                bank_ddeg: Some((direction * f64::from(TARGET_DDEG)) as i16),
            }
        };
        let requested = Instant::now();
        sender.want(rolling);
        let mut path: Vec<(Instant, f64)> = Vec::with_capacity(3000);
        let mut ended: Option<Instant> = None;
        let mut killed = false;
        let mut angle_back: Option<Instant> = None;
        let total = match trial {
            Trial::Angle | Trial::Acro => ROLL + Duration::from_millis(1500),
            Trial::Killed => KILLED_AFTER + Duration::from_millis(2500),
        };
        while requested.elapsed() < total {
            let quad = self.world.quad();
            let bank_deg = quad.euler_rad().0.to_degrees();
            let now = Instant::now();
            path.push((now, bank_deg));
            if quad.tilt_rad().to_degrees() > 75.0 {
                return Err(fail(format!("lost control: {quad:?}")));
            }
            let elapsed = requested.elapsed();
            match trial {
                Trial::Killed if !killed && elapsed >= KILLED_AFTER => {
                    if let Some(sender) = self.sender.as_mut() {
                        sender.kill();
                    }
                    killed = true;
                }
                Trial::Killed => {}
                _ if ended.is_none()
                    && (elapsed >= ROLL
                        || (trial == Trial::Acro
                            && route == Route::Stick
                            && bank_deg * direction >= ACRO_STOP_DEG)) =>
                {
                    ended = Some(now);
                    self.sender.as_ref().expect("the sender runs").want(Wanted {
                        roll_us: CENTRE_US,
                        bank_ddeg: None,
                    });
                }
                _ => {}
            }
            // Without ANGLE nothing levels the vehicle after the command: the hand
            // puts ANGLE back 0.6 s after it ended.
            if trial == Trial::Acro
                && angle_back.is_none()
                && ended.is_some_and(|t| now - t >= Duration::from_millis(600))
            {
                self.radio.set(CH_ANGLE, ANGLE_ON_US);
                angle_back = Some(now);
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        self.radio.set(CH_ANGLE, ANGLE_ON_US);
        self.radio.set(CH_SWITCH, MANUAL_US);
        self.hand.set(true, true);
        let sent = self.sender.as_ref().expect("the sender runs").log();
        let unix_offset_us = super::clock::unix_us() - requested.elapsed().as_micros() as i64;
        let flown = Flown {
            route,
            trial,
            direction,
            requested,
            unix_at_request_us: unix_offset_us,
            sent: &sent,
            path: &path,
        };
        Ok(flown.measure(&self.world, &self.monitor))
    }
}

/// What the sender is to put on the port.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Wanted {
    /// MSP_SET_RAW_RC's roll.
    roll_us: u16,
    /// The bank-angle command's roll, or none (mask 0 once, then nothing).
    bank_ddeg: Option<i16>,
}

/// One command written to UART4.
#[derive(Clone, Copy, Debug)]
struct Sent {
    at: Instant,
    command: u16,
    /// MSP_SET_RAW_RC's roll; the bank-angle command's mask.
    roll_us: u16,
    mask: u8,
    /// iNav answered with an MSP error.
    refused: bool,
}

/// The harness's sender on UART4, at faithd's pace: a 20 ms slot, one command in a
/// slot at most; MSP_SET_RAW_RC at least every 40 ms; a change goes out in the next
/// slot; the bank-angle command, while one is wanted, every 40 ms in the slots
/// MSP_SET_RAW_RC leaves. Each reply is read before the next slot.
struct Sender {
    wanted: Arc<Mutex<Wanted>>,
    sent: Arc<Mutex<Vec<Sent>>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Sender {
    fn start(sitl: &Sitl, radio: Arc<Radio>) -> Result<Self, SitlError> {
        let deadline = Instant::now() + Duration::from_secs(5);
        let mut stream = loop {
            match TcpStream::connect(("127.0.0.1", sitl.port(UART_MSP_FAITHD))) {
                Ok(s) => break s,
                Err(e) if Instant::now() > deadline => {
                    return Err(SitlError::Other(format!("UART4: {e}")));
                }
                Err(_) => std::thread::sleep(Duration::from_millis(50)),
            }
        };
        stream
            .set_nodelay(true)
            .and_then(|()| stream.set_read_timeout(Some(Duration::from_millis(2))))
            .map_err(|e| SitlError::Other(format!("UART4: {e}")))?;
        let wanted = Arc::new(Mutex::new(Wanted {
            roll_us: CENTRE_US,
            bank_ddeg: None,
        }));
        let sent = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (wanted, sent, stop) = (wanted.clone(), sent.clone(), stop.clone());
            std::thread::spawn(move || {
                let mut decoder = Decoder::default();
                let mut frames = Vec::new();
                let mut buf = [0u8; 512];
                let mut sent_roll_us = None;
                let mut sent_bank = None;
                let (mut last_rc, mut last_bank): (Option<Instant>, Option<Instant>) = (None, None);
                let mut next = Instant::now();
                while !stop.load(Ordering::Relaxed) {
                    let want = *wanted.lock().expect("wanted lock");
                    let now = Instant::now();
                    // A slot's worth of slack: the slots drift by a millisecond.
                    let due = |last: Option<Instant>| {
                        last.is_none_or(|t| now + Duration::from_millis(2) >= t + PERIOD)
                    };
                    let bank = if sent_roll_us != Some(want.roll_us) {
                        Some(false)
                    } else if sent_bank != Some(want.bank_ddeg) {
                        Some(true)
                    } else if due(last_rc) {
                        Some(false)
                    } else if want.bank_ddeg.is_some() && due(last_bank) {
                        Some(true)
                    } else {
                        None
                    };
                    if let Some(bank) = bank {
                        let (command, bytes, roll_us, mask) = if bank {
                            let mask = u8::from(want.bank_ddeg.is_some());
                            let mut payload = vec![mask];
                            payload.extend_from_slice(&want.bank_ddeg.unwrap_or(0).to_le_bytes());
                            payload.extend_from_slice(&[0, 0, 0, 0]);
                            let bytes =
                                msp::encode_request(MSP2_INAV_FLIGHT_AXIS_ANGLE_OVERRIDE, &payload);
                            (MSP2_INAV_FLIGHT_AXIS_ANGLE_OVERRIDE, bytes, CENTRE_US, mask)
                        } else {
                            // The pilot's channels with faithd's roll, as faithd sends them.
                            let mut channels = radio.channels();
                            channels[CH_ROLL - 1] = want.roll_us;
                            (MSP_SET_RAW_RC, msp::set_raw_rc(&channels), want.roll_us, 0)
                        };
                        if stream.write_all(&bytes).is_err() {
                            return;
                        }
                        let at = Instant::now();
                        if bank {
                            sent_bank = Some(want.bank_ddeg);
                            last_bank = Some(at);
                        } else {
                            sent_roll_us = Some(want.roll_us);
                            last_rc = Some(at);
                        }
                        let refused = read_reply(
                            &mut stream,
                            &mut decoder,
                            &mut frames,
                            &mut buf,
                            command,
                            at + Duration::from_millis(15),
                        );
                        sent.lock().expect("sent lock").push(Sent {
                            at,
                            command,
                            roll_us,
                            mask,
                            refused,
                        });
                    }
                    next += SLOT;
                    match next.checked_duration_since(Instant::now()) {
                        Some(wait) => std::thread::sleep(wait),
                        None => next = Instant::now(),
                    }
                }
            })
        };
        Ok(Self {
            wanted,
            sent,
            stop,
            thread: Some(thread),
        })
    }

    fn want(&self, wanted: Wanted) {
        *self.wanted.lock().expect("wanted lock") = wanted;
    }

    /// Everything written so far.
    fn log(&self) -> Vec<Sent> {
        self.sent.lock().expect("sent lock").clone()
    }

    /// Stops at once, as a crashed companion does: nothing more is written, the
    /// port is closed.
    fn kill(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }

    fn is_dead(&self) -> bool {
        self.thread.is_none()
    }
}

impl Drop for Sender {
    fn drop(&mut self) {
        self.kill();
    }
}

/// Reads until `command`'s reply or `deadline`: whether iNav refused it.
fn read_reply(
    stream: &mut TcpStream,
    decoder: &mut Decoder,
    frames: &mut Vec<msp::Frame>,
    buf: &mut [u8],
    command: u16,
    deadline: Instant,
) -> bool {
    while Instant::now() < deadline {
        if let Some(f) = frames.iter().find(|f| f.command == command) {
            let refused = f.direction == b'!';
            frames.clear();
            return refused;
        }
        match stream.read(buf) {
            Ok(0) => return false,
            Ok(n) => decoder.push(&buf[..n], frames),
            Err(e) if read_timed_out(&e) => {}
            Err(_) => return false,
        }
    }
    false
}

/// The scripted pilot's hands, every 10 ms: the throttle holds 2 m; with `hold_roll`
/// and `hold_pitch` the sticks bring the vehicle to rest over the take-off point
/// (in ANGLE); without, the roll stick rests at [`HAND_ROLL_US`] and pitch at the
/// centre.
struct Hand {
    hold_roll: Arc<AtomicBool>,
    hold_pitch: Arc<AtomicBool>,
    flying: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Hand {
    fn start(world: Arc<World>, radio: Arc<Radio>) -> Self {
        let hold_roll = Arc::new(AtomicBool::new(true));
        let hold_pitch = Arc::new(AtomicBool::new(true));
        let flying = Arc::new(AtomicBool::new(false));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (hold_roll, hold_pitch, flying, stop) = (
                hold_roll.clone(),
                hold_pitch.clone(),
                flying.clone(),
                stop.clone(),
            );
            std::thread::spawn(move || {
                let mut integral = 0.0;
                while !stop.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(10));
                    if !flying.load(Ordering::Relaxed) {
                        continue;
                    }
                    let quad = world.quad();
                    let height_m = -quad.position_m.z;
                    let error_m = HOVER_M - height_m;
                    integral = (integral + error_m * 0.01).clamp(-5.0, 5.0);
                    let throttle =
                        1500.0 + 120.0 * error_m + 40.0 * integral + 150.0 * quad.velocity_m_s.z;
                    radio.set(CH_THROTTLE, throttle.clamp(1150.0, 1850.0) as u16);
                    let yaw = quad.euler_rad().2;
                    let forward = Vector3::new(yaw.cos(), yaw.sin(), 0.0);
                    let right = Vector3::new(-yaw.sin(), yaw.cos(), 0.0);
                    let stick = |along: &Vector3<f64>| {
                        let v = quad.velocity_m_s.dot(along);
                        let p = quad.position_m.dot(along);
                        (1500.0 - 150.0 * v - 40.0 * p).clamp(1300.0, 1700.0) as u16
                    };
                    radio.set(
                        CH_PITCH,
                        if hold_pitch.load(Ordering::Relaxed) {
                            stick(&forward)
                        } else {
                            CENTRE_US
                        },
                    );
                    radio.set(
                        CH_ROLL,
                        if hold_roll.load(Ordering::Relaxed) {
                            stick(&right)
                        } else {
                            HAND_ROLL_US
                        },
                    );
                }
            })
        };
        Self {
            hold_roll,
            hold_pitch,
            flying,
            stop,
            thread: Some(thread),
        }
    }

    fn set(&self, hold_roll: bool, hold_pitch: bool) {
        self.hold_roll.store(hold_roll, Ordering::Relaxed);
        self.hold_pitch.store(hold_pitch, Ordering::Relaxed);
    }
}

impl Drop for Hand {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// One trial as recorded: the sender's log and the bank every 2 ms.
struct Flown<'a> {
    route: Route,
    trial: Trial,
    direction: f64,
    requested: Instant,
    /// The Unix time of `requested` (iNav's samples are stamped in Unix time).
    unix_at_request_us: i64,
    sent: &'a [Sent],
    path: &'a [(Instant, f64)],
}

impl Flown<'_> {
    fn is_roll(&self, s: &Sent) -> bool {
        match self.route {
            Route::Stick => s.command == MSP_SET_RAW_RC && s.roll_us != CENTRE_US,
            Route::BankAngle => s.command == MSP2_INAV_FLIGHT_AXIS_ANGLE_OVERRIDE && s.mask != 0,
        }
    }

    fn is_end(&self, s: &Sent) -> bool {
        match self.route {
            Route::Stick => s.command == MSP_SET_RAW_RC && s.roll_us == CENTRE_US,
            Route::BankAngle => s.command == MSP2_INAV_FLIGHT_AXIS_ANGLE_OVERRIDE && s.mask == 0,
        }
    }

    fn unix_us(&self, at: Instant) -> i64 {
        match at.checked_duration_since(self.requested) {
            Some(d) => self.unix_at_request_us + d.as_micros() as i64,
            None => self.unix_at_request_us - (self.requested - at).as_micros() as i64,
        }
    }

    /// The bank the roll's way from `from` on.
    fn banks_from(&self, from: Instant) -> impl Iterator<Item = (Instant, f64)> + '_ {
        self.path
            .iter()
            .filter(move |(t, _)| *t >= from)
            .map(|(t, b)| (*t, b * self.direction))
    }

    fn first_from(&self, from: Instant, pred: impl Fn(f64) -> bool) -> Option<f64> {
        self.banks_from(from)
            .find(|(_, b)| pred(*b))
            .map(|(t, _)| ms(from, t))
    }

    fn measure(&self, world: &World, monitor: &Monitor) -> TrialOutcome {
        let target_deg = f64::from(TARGET_DDEG) / 10.0;
        let last_at = self.path.last().map_or(self.requested, |(t, _)| *t);
        let t_cmd = self
            .sent
            .iter()
            .find(|s| s.at >= self.requested && self.is_roll(s))
            .map_or(self.requested, |s| s.at);
        let t_end = self
            .sent
            .iter()
            .find(|s| s.at > t_cmd && self.is_end(s))
            .map(|s| s.at);
        let t_kill = (self.trial == Trial::Killed)
            .then(|| self.sent.last().map(|s| s.at))
            .flatten();
        let until = t_kill.or(t_end).unwrap_or(last_at);
        let roll: Vec<(Instant, f64)> =
            self.banks_from(t_cmd).filter(|(t, _)| *t < until).collect();
        let peak_deg = roll.iter().map(|(_, b)| *b).fold(f64::MIN, f64::max);
        let t90 = roll
            .iter()
            .find(|(_, b)| *b >= 0.9 * target_deg)
            .map(|(t, _)| *t);
        let whole = until - t_cmd >= ROLL - Duration::from_millis(20);
        let mean =
            |v: &[f64]| (whole && !v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
        let all: Vec<f64> = roll.iter().map(|(_, b)| *b).collect();
        let settled: Vec<f64> = roll
            .iter()
            .filter(|(t, _)| until - *t <= Duration::from_millis(500))
            .map(|(_, b)| *b)
            .collect();
        let at = |t: Instant| self.banks_from(t).next().map(|(_, b)| b);
        let roll_rate_deg_s = (self.trial == Trial::Acro && self.route == Route::Stick)
            .then(|| {
                let t5 = roll.iter().find(|(_, b)| *b >= 5.0)?.0;
                let t25 = roll.iter().find(|(_, b)| *b >= 25.0)?.0;
                Some(20.0 / (t25 - t5).as_secs_f64())
            })
            .flatten();
        let bank_at_kill = t_kill.and_then(at);
        let mix = world.roll_mix.lock().unwrap_or_else(|e| e.into_inner());
        let mixer_back = |from: Instant| {
            mix.iter()
                .find(|(at, m)| *at >= from && m * self.direction < -ROLL_MIX_IN_EFFECT)
                .map(|(at, _)| ms(from, *at))
        };
        let to_mixer_ms = mix
            .iter()
            .find(|(at, m)| *at >= t_cmd && m * self.direction > ROLL_MIX_IN_EFFECT)
            .map(|(at, _)| ms(t_cmd, *at));
        let seen = monitor.between(self.unix_us(t_cmd), self.unix_us(until));
        let in_roll = |p: &dyn Fn(&Sent) -> bool| {
            let span_s = (until - t_cmd).as_secs_f64();
            (t_end.is_some() && span_s > 0.1).then(|| {
                let n = self
                    .sent
                    .iter()
                    .filter(|s| s.at >= t_cmd && s.at < until && p(s))
                    .count();
                n as f64 / span_s
            })
        };
        TrialOutcome {
            route: self.route,
            trial: self.trial,
            direction: self.direction,
            angle_mode: !seen.is_empty() && seen.iter().all(|s| s.mode(MODE_ANGLE)),
            to_mixer_ms,
            to_5_deg_ms: self.first_from(t_cmd, |b| b >= 5.0),
            to_90_ms: t90.map(|t| ms(t_cmd, t)),
            peak_deg,
            mean_deg: mean(&all),
            settled_mean_deg: mean(&settled),
            settled_min_deg: mean(&settled)
                .map(|_| settled.iter().copied().fold(f64::MAX, f64::min)),
            commanded_ms: ms(t_cmd, until),
            roll_rate_deg_s,
            bank_after_end_deg: t_end.and_then(|t| at(t + Duration::from_millis(500))),
            end_to_mixer_back_ms: t_end.and_then(mixer_back),
            end_to_level_ms: t_end.and_then(|t| self.first_from(t, |b| b < 5.0)),
            kill_to_mixer_back_ms: t_kill.and_then(mixer_back),
            kill_to_falling_ms: t_kill
                .zip(bank_at_kill)
                .and_then(|(t, b0)| self.first_from(t, |b| b < 0.9 * b0)),
            kill_to_level_ms: t_kill.and_then(|t| self.first_from(t, |b| b < 5.0)),
            stick_seen_us: seen
                .iter()
                .map(|s| s.roll().abs_diff(CENTRE_US))
                .max()
                .unwrap_or(0),
            per_s_in_roll: in_roll(&|_| true),
            rc_per_s_in_roll: in_roll(&|s| s.command == MSP_SET_RAW_RC),
            bank_per_s_in_roll: in_roll(&|s| s.command == MSP2_INAV_FLIGHT_AXIS_ANGLE_OVERRIDE),
            per_s_before: self
                .sent
                .iter()
                .filter(|s| s.at < t_cmd && t_cmd - s.at <= Duration::from_secs(1))
                .count() as f64,
            refused: self
                .sent
                .iter()
                .filter(|s| s.at + Duration::from_secs(1) >= self.requested && s.refused)
                .count(),
        }
    }
}

fn ms(from: Instant, to: Instant) -> f64 {
    to.saturating_duration_since(from).as_secs_f64() * 1e3
}

impl Report {
    /// The two routes side by side, as a Markdown table.
    pub fn table(&self) -> String {
        let of = |route: Route, trial: Trial| -> Vec<&TrialOutcome> {
            self.trials
                .iter()
                .filter(|t| t.route == route && t.trial == trial)
                .collect()
        };
        let cell =
            |route: Route, trial: Trial, f: &dyn Fn(&TrialOutcome) -> Option<f64>, unit: &str| {
                let values: Vec<f64> = of(route, trial).into_iter().filter_map(f).collect();
                let s = Spread::of(values.iter().copied());
                match s.count {
                    0 => "-".to_string(),
                    // Two rolls, one each way: both.
                    1 | 2 => {
                        let each: Vec<String> = values.iter().map(|v| format!("{v:.1}")).collect();
                        format!("{} {unit}", each.join(" / "))
                    }
                    _ => format!("{:.1} {unit} ({:.1}-{:.1})", s.p50, s.min, s.max),
                }
            };
        type Row<'a> = (
            &'a str,
            Trial,
            &'a dyn Fn(&TrialOutcome) -> Option<f64>,
            &'a str,
        );
        let rows: [Row; 21] = [
            (
                "ANGLE: command -> roll at the mixer",
                Trial::Angle,
                &|t| t.to_mixer_ms,
                "ms",
            ),
            (
                "ANGLE: command -> 5 deg of bank",
                Trial::Angle,
                &|t| t.to_5_deg_ms,
                "ms",
            ),
            (
                "ANGLE: command -> 90 % of 14.7 deg",
                Trial::Angle,
                &|t| t.to_90_ms,
                "ms",
            ),
            (
                "ANGLE: peak bank",
                Trial::Angle,
                &|t| Some(t.peak_deg),
                "deg",
            ),
            (
                "ANGLE: bank over the 1.5 s, mean",
                Trial::Angle,
                &|t| t.mean_deg,
                "deg",
            ),
            (
                "ANGLE: bank over the last 0.5 s, mean",
                Trial::Angle,
                &|t| t.settled_mean_deg,
                "deg",
            ),
            (
                "ANGLE: bank over the last 0.5 s, least",
                Trial::Angle,
                &|t| t.settled_min_deg,
                "deg",
            ),
            (
                "ANGLE: end of the command -> mixer rolls back",
                Trial::Angle,
                &|t| t.end_to_mixer_back_ms,
                "ms",
            ),
            (
                "ANGLE: end of the command -> under 5 deg",
                Trial::Angle,
                &|t| t.end_to_level_ms,
                "ms",
            ),
            (
                "ANGLE: roll stick iNav used (MSP_RC), off centre",
                Trial::Angle,
                &|t| Some(f64::from(t.stick_seen_us)),
                "us",
            ),
            (
                "ANGLE: commands a second on UART4 in the roll",
                Trial::Angle,
                &|t| t.per_s_in_roll,
                "/s",
            ),
            (
                "ANGLE: of which 0x2216",
                Trial::Angle,
                &|t| t.bank_per_s_in_roll,
                "/s",
            ),
            (
                "ANGLE: commands a second on UART4 before the roll",
                Trial::Angle,
                &|t| Some(t.per_s_before),
                "/s",
            ),
            (
                "no ANGLE (ACRO): command -> 5 deg of bank",
                Trial::Acro,
                &|t| t.to_5_deg_ms,
                "ms",
            ),
            (
                "no ANGLE (ACRO): peak bank while commanded",
                Trial::Acro,
                &|t| Some(t.peak_deg),
                "deg",
            ),
            (
                "no ANGLE (ACRO): commanded for",
                Trial::Acro,
                &|t| Some(t.commanded_ms),
                "ms",
            ),
            (
                "no ANGLE (ACRO): bank 0.5 s after the command ended",
                Trial::Acro,
                &|t| t.bank_after_end_deg,
                "deg",
            ),
            (
                "sender killed 0.75 s in: largest bank before",
                Trial::Killed,
                &|t| Some(t.peak_deg),
                "deg",
            ),
            (
                "sender killed: last command -> mixer rolls back",
                Trial::Killed,
                &|t| t.kill_to_mixer_back_ms,
                "ms",
            ),
            (
                "sender killed: last command -> bank falling (< 90 %)",
                Trial::Killed,
                &|t| t.kill_to_falling_ms,
                "ms",
            ),
            (
                "sender killed: last command -> under 5 deg",
                Trial::Killed,
                &|t| t.kill_to_level_ms,
                "ms",
            ),
        ];
        let mut out = format!(
            "{} rolls in ANGLE per route: median (least-most); two without ANGLE and two killed: each.\n\n\
             | | stick route (MSP_SET_RAW_RC 1800/1200) | bank-angle command (0x2216, 14.7 deg) |\n| --- | --- | --- |\n",
            self.trials
                .iter()
                .filter(|t| t.route == Route::Stick && t.trial == Trial::Angle)
                .count()
        );
        for (what, trial, f, unit) in rows {
            out.push_str(&format!(
                "| {what} | {} | {} |\n",
                cell(Route::Stick, trial, f, unit),
                cell(Route::BankAngle, trial, f, unit)
            ));
        }
        let acro_rate = of(Route::Stick, Trial::Acro)
            .iter()
            .filter_map(|t| t.roll_rate_deg_s)
            .map(|r| format!("{r:.0}"))
            .collect::<Vec<_>>()
            .join(", ");
        let refused: usize = self.trials.iter().map(|t| t.refused).sum();
        out.push_str(&format!(
            "\nMSP API {}.{}; the stick route without ANGLE rolled at {acro_rate} deg/s (stopped at {ACRO_STOP_DEG} deg); \
             {refused} commands refused in all; RealFlight: {} exchanges, {} late.\n",
            self.msp_api.0, self.msp_api.1, self.exchanges, self.late_exchanges
        ));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trial(route: Route, trial: Trial, to_mixer_ms: f64) -> TrialOutcome {
        TrialOutcome {
            route,
            trial,
            direction: 1.0,
            angle_mode: trial != Trial::Acro,
            to_mixer_ms: Some(to_mixer_ms),
            to_5_deg_ms: Some(150.0),
            to_90_ms: Some(745.0),
            peak_deg: 14.6,
            mean_deg: Some(11.4),
            settled_mean_deg: Some(14.3),
            settled_min_deg: Some(14.0),
            commanded_ms: 1500.0,
            roll_rate_deg_s: None,
            bank_after_end_deg: Some(3.0),
            end_to_mixer_back_ms: Some(10.0),
            end_to_level_ms: Some(345.0),
            kill_to_mixer_back_ms: None,
            kill_to_falling_ms: None,
            kill_to_level_ms: None,
            stick_seen_us: 0,
            per_s_in_roll: Some(25.0),
            rc_per_s_in_roll: Some(25.0),
            bank_per_s_in_roll: Some(0.0),
            per_s_before: 25.0,
            refused: 0,
        }
    }

    /// Three rolls give a median and a range, two give each value, none a dash.
    #[test]
    fn the_table_gives_medians_of_three_and_each_of_two() {
        let report = Report {
            msp_api: (2, 6),
            trials: vec![
                trial(Route::Stick, Trial::Angle, 14.0),
                trial(Route::Stick, Trial::Angle, 15.0),
                trial(Route::Stick, Trial::Angle, 16.0),
                trial(Route::BankAngle, Trial::Angle, 8.0),
                trial(Route::BankAngle, Trial::Angle, 9.0),
                trial(Route::Stick, Trial::Acro, 7.0),
                trial(Route::Stick, Trial::Acro, 9.0),
            ],
            exchanges: 10,
            late_exchanges: 0,
        };
        let table = report.table();
        assert!(table.starts_with("3 rolls in ANGLE per route"), "{table}");
        let row = |name: &str| {
            table
                .lines()
                .find(|l| l.starts_with(&format!("| {name} |")))
                .unwrap_or_else(|| panic!("no row {name}: {table}"))
                .to_string()
        };
        assert_eq!(
            row("ANGLE: command -> roll at the mixer"),
            "| ANGLE: command -> roll at the mixer | 15.0 ms (14.0-16.0) | 8.0 / 9.0 ms |"
        );
        assert!(row("sender killed: last command -> under 5 deg").ends_with("| - | - |"));
        assert!(table.contains("MSP API 2.6"), "{table}");
    }
}
