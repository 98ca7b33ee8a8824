//! The ground station link (`[ground]`, off by default): one task that owns a second
//! MAVLink port, to a ground station over the board's WiFi (UDP) or a telemetry
//! radio (serial), so the person watching the flight sees what faithd does and why.
//!
//! What goes to the ground, all with faithd's own ids (the vehicle's system id,
//! component 191):
//! - faithd's HEARTBEAT, as an onboard controller;
//! - a STATUSTEXT on every change of the safety gate and on every roll
//!   (`faithd: roll right, obstacle TTC 1.1 s`, `faithd: gate closed: switch MANUAL`);
//! - NAMED_VALUE_FLOAT a few times a second: the FOE, the obstacle's TTC, the event
//!   rate and the cycle time, to plot in the ground station's MAVLink inspector;
//! - and every frame the autopilot sends, as it came off the wire, so one link shows
//!   both.
//!
//! What comes back goes nowhere by default: nothing from the ground reaches the
//! autopilot unless `forward_to_autopilot` says so, and even then no stick input
//! (RC_CHANNELS_OVERRIDE, MANUAL_CONTROL) unless `forward_rc_override` says so too.
//!
//! The ground link is a bystander: no other task ever waits for it. The link and the
//! commander hand it frames and notices through bounded queues with `try_send`; what
//! does not fit (a dead ground station, a radio slower than the autopilot's
//! telemetry) is dropped and counted, and the count goes to the journal. It is not
//! supervised by the watchdog either: a stuck ground link must not restart the
//! flight daemon (and every write in it gives up after 250 ms, every open after
//! 500 ms, as on the other ports).

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use mavlink::dialects::common::{MavMessage, MavSeverity, NAMED_VALUE_FLOAT_DATA, STATUSTEXT_DATA};
use mavlink::{AsyncMavlinkReader, MAVLinkMessageRaw, MavHeader, MavlinkVersion, Message as _};
use serde::{Deserialize, Serialize};
use tokio::sync::{mpsc, watch};

use super::MavlinkConfig;
use crate::clock::DaemonClock;
use crate::transport::{self, Address, BoxedTransport, Endpoint};
use faithd_core::decide::RollDirection;
use faithd_core::invalid::{Invalid, check};
use faithd_core::pipeline::PipelineTelemetry;
use faithd_core::safety::gate::{Blocker, FailsafeSource, GateState, PipelineProblem};

/// `[ground]`: where the ground station is and what may cross between it and the
/// autopilot.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GroundConfig {
    /// Off unless asked for: a flight needs no ground station.
    pub enabled: bool,
    /// The ground station: `udpout:GROUND_IP:14550` (QGroundControl and Mission
    /// Planner listen on UDP 14550 and answer whoever sends to them), `udp:BIND:PORT`
    /// (wait for a station to send first, then keep to it), or `serial:/dev/ttyS2` (a
    /// telemetry radio). Needed when `enabled`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub endpoint: Option<Address>,
    /// Serial baud rate (SiK telemetry radios default to 57600).
    pub baud: u32,
    /// Period of faithd's HEARTBEAT to the ground.
    pub heartbeat_period_us: i64,
    /// Period of the NAMED_VALUE_FLOAT values (250 ms: 4 Hz).
    pub telemetry_period_us: i64,
    /// Forward every frame from the autopilot's port to the ground. A ground station
    /// shows a vehicle only once it hears its autopilot, so this is what puts faithd's
    /// messages on its screen; turn it off on a radio too slow to carry both.
    pub forward_from_autopilot: bool,
    /// Forward frames from the ground station to the autopilot (commands, mission,
    /// parameters), except stick input. Off: the ground station only watches.
    pub forward_to_autopilot: bool,
    /// With `forward_to_autopilot`, also forward stick input (RC_CHANNELS_OVERRIDE and
    /// MANUAL_CONTROL): a joystick on the ground station would then fly the vehicle
    /// beside the pilot's radio and faithd's roll.
    pub forward_rc_override: bool,
}

impl Default for GroundConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            endpoint: None,
            baud: 57_600,
            heartbeat_period_us: 1_000_000,
            telemetry_period_us: 250_000,
            forward_from_autopilot: true,
            forward_to_autopilot: false,
            forward_rc_override: false,
        }
    }
}

impl GroundConfig {
    /// The port to the ground station, when the link is on.
    pub fn port(&self) -> Option<Endpoint> {
        let address = self.endpoint.clone().filter(|_| self.enabled)?;
        Some(Endpoint::new(address, self.baud))
    }

    /// `[ground]`: an endpoint when enabled, periods a link can keep, and stick input
    /// only where something is forwarded at all.
    pub fn validate(&self) -> Result<(), Invalid> {
        let g = self;
        check(
            !g.enabled || g.endpoint.is_some(),
            "ground.endpoint",
            || {
                "is needed with ground.enabled = true: \"udpout:GROUND_IP:14550\" (WiFi) or \"serial:/dev/ttyS2\" (a telemetry radio)".into()
            },
        )?;
        check(g.baud >= 1200, "ground.baud", || {
            format!("must be a serial baud rate, got {}", g.baud)
        })?;
        check(
            (100_000..=10_000_000).contains(&g.heartbeat_period_us),
            "ground.heartbeat_period_us",
            || format!("must be 100 ms to 10 s, got {}", g.heartbeat_period_us),
        )?;
        check(
            (50_000..=10_000_000).contains(&g.telemetry_period_us),
            "ground.telemetry_period_us",
            || {
                format!(
                    "must be 50 ms to 10 s (20 Hz at most), got {}",
                    g.telemetry_period_us
                )
            },
        )?;
        check(
            !g.forward_rc_override || g.forward_to_autopilot,
            "ground.forward_rc_override",
            || {
                "needs ground.forward_to_autopilot = true: nothing from the ground reaches the autopilot without it".into()
            },
        )
    }
}

/// Frames from the autopilot waiting for the ground: about half a second of iNav's
/// telemetry. More means the ground link is slower than the autopilot, or down.
const FRAMES_QUEUE: usize = 64;
/// STATUSTEXT waiting for the ground.
const NOTICES_QUEUE: usize = 16;
/// Frames from the ground waiting for the autopilot's port.
const UPLINK_QUEUE: usize = 16;
/// Drops are reported at most this often.
const REPORT_PERIOD: Duration = Duration::from_secs(5);

/// RC_CHANNELS_OVERRIDE and MANUAL_CONTROL: stick input, kept from the autopilot
/// unless `forward_rc_override`.
const STICK_INPUT_IDS: [u32; 2] = [70, 69];

/// RADIO_STATUS: a telemetry radio's buffer report. iNav paces its whole MAVLink
/// telemetry on the first one it hears (telemetry/mavlink.c), and could then starve
/// faithd's gate of ATTITUDE and RC_CHANNELS: never forwarded.
const RADIO_STATUS_ID: u32 = 109;

/// One MAVLink frame exactly as it was on the wire (its sender's ids and sequence
/// number, its checksum and any signature): forwarded unchanged, so the ground
/// station sees the autopilot as if it were wired to it, and the autopilot sees the
/// ground station's own frames.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RawFrame {
    bytes: Vec<u8>,
    header: MavHeader,
    message_id: u32,
}

impl RawFrame {
    pub fn new(raw: &MAVLinkMessageRaw) -> Self {
        let bytes = match raw {
            MAVLinkMessageRaw::V1(f) => f.raw_bytes().to_vec(),
            MAVLinkMessageRaw::V2(f) => f.raw_bytes().to_vec(),
        };
        Self {
            bytes,
            header: header_of(raw),
            message_id: raw.message_id(),
        }
    }

    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    pub fn header(&self) -> MavHeader {
        self.header
    }

    pub fn message_id(&self) -> u32 {
        self.message_id
    }

    /// The message, for the flight recording.
    pub fn decode(&self) -> Option<MavMessage> {
        let mut reader = mavlink::MavlinkReader::new(&self.bytes[..]);
        reader.read_any_message::<MavMessage>().ok().map(|(_, m)| m)
    }
}

/// The header a raw frame carries.
pub fn header_of(raw: &MAVLinkMessageRaw) -> MavHeader {
    MavHeader {
        system_id: raw.system_id(),
        component_id: raw.component_id(),
        sequence: raw.sequence(),
    }
}

/// Something a person on the ground should read, from the commander.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Notice {
    /// The gate's state changed: it opened, closed, or closed for another reason.
    /// `was_open` is the state before (`None` at the first evaluation).
    Gate {
        gate: GateState,
        was_open: Option<bool>,
    },
    /// A roll began, away from an obstacle whose mean TTC was `ttc_s`.
    Roll {
        direction: RollDirection,
        ttc_s: Option<f64>,
    },
}

/// Longest STATUSTEXT a single frame carries (longer ones need chunks, which not
/// every ground station joins).
pub const STATUSTEXT_MAX_CHARS: usize = 50;

impl Notice {
    /// The text and its severity, chosen for what ground stations do with it.
    /// QGroundControl lists every STATUSTEXT, reads aloud those of NOTICE (5) or
    /// higher, and pops ERROR (3) and higher up as a critical message (its
    /// `Vehicle::_handleTextMessage` and `StatusTextHandler`); Mission Planner shows
    /// the latest on its HUD and all in its Messages tab. So a roll is a WARNING (read
    /// aloud, flagged, not an error: faithd working as designed), the gate opening or
    /// closing a NOTICE (read aloud, so the pilot hears the switch take effect), and
    /// a new reason while it stays closed (the start-up sequence: link, RC, HEARTBEAT,
    /// the MSP stream warming up) INFO: listed, silent.
    pub fn statustext(&self) -> (MavSeverity, String) {
        let (severity, text) = match *self {
            Notice::Roll { direction, ttc_s } => {
                let side = match direction {
                    RollDirection::Left => "left",
                    RollDirection::Right => "right",
                };
                let text = match ttc_s.filter(|t| t.is_finite()) {
                    Some(t) => format!("faithd: roll {side}, obstacle TTC {t:.1} s"),
                    None => format!("faithd: roll {side}"),
                };
                (MavSeverity::MAV_SEVERITY_WARNING, text)
            }
            Notice::Gate {
                gate: GateState::Open,
                ..
            } => (MavSeverity::MAV_SEVERITY_NOTICE, "faithd: gate open".into()),
            Notice::Gate {
                gate: GateState::Closed(blocker),
                was_open,
            } => {
                let severity = if was_open == Some(false) {
                    MavSeverity::MAV_SEVERITY_INFO
                } else {
                    MavSeverity::MAV_SEVERITY_NOTICE
                };
                (
                    severity,
                    format!("faithd: gate closed: {}", short_reason(&blocker)),
                )
            }
        };
        (severity, fit(text, STATUSTEXT_MAX_CHARS))
    }
}

/// Why the gate is closed, in the 29 characters a STATUSTEXT leaves after
/// `faithd: gate closed: ` (the journal has the long form).
fn short_reason(blocker: &Blocker) -> String {
    match *blocker {
        Blocker::LinkDown => "autopilot link down".into(),
        Blocker::NoRc => "no RC_CHANNELS yet".into(),
        Blocker::RcStale { age_us } => format!("RC_CHANNELS stale {} ms", age_us / 1000),
        Blocker::SwitchMissing { channel } => format!("no switch channel {channel}"),
        Blocker::SwitchNotAuto { .. } => "switch MANUAL".into(),
        Blocker::RadioLost => "pilot's radio lost".into(),
        Blocker::NoRadioStatus => "no SYS_STATUS yet".into(),
        Blocker::RadioStatusStale { age_us } => format!("SYS_STATUS stale {} ms", age_us / 1000),
        Blocker::NoHeartbeat => "no HEARTBEAT yet".into(),
        Blocker::HeartbeatStale { age_us } => format!("HEARTBEAT stale {} ms", age_us / 1000),
        Blocker::Disarmed => "disarmed".into(),
        Blocker::AutopilotFailsafe {
            source: FailsafeSource::Heartbeat,
            ..
        } => "autopilot failsafe".into(),
        Blocker::AutopilotFailsafe {
            source: FailsafeSource::AutopilotStatus,
            ..
        } => "iNav FAILSAFE mode".into(),
        Blocker::NoAttitude => "no ATTITUDE yet".into(),
        Blocker::AttitudeStale { age_us } => format!("ATTITUDE stale {} ms", age_us / 1000),
        Blocker::PipelineNotRunning => "pipeline not running".into(),
        Blocker::PipelineStale { age_us } => format!("pipeline stalled {} ms", age_us / 1000),
        Blocker::PipelineUnhealthy {
            problem: PipelineProblem::NoEvents,
        } => "no events from camera".into(),
        Blocker::PipelineUnhealthy {
            problem: PipelineProblem::NoAttitude,
        } => "no attitude for the flow".into(),
        Blocker::SetupRefused { .. } => "FC set-up refused".into(),
        Blocker::SetupChanged { .. } => "FC set-up changed in flight".into(),
        Blocker::CommandPortDown { .. } => "MSP port down".into(),
        Blocker::NoAutopilotStatus { .. } => "no FC status yet".into(),
        Blocker::AutopilotStatusStale { age_us, .. } => {
            format!("FC status stale {} ms", age_us / 1000)
        }
        Blocker::OverrideInactive { .. } => "MSP RC OVERRIDE mode off".into(),
        Blocker::StabilisedModeOff { .. } => "iNav not in ANGLE".into(),
        Blocker::OverrideWarmingUp { .. } => "MSP stream warming up".into(),
        Blocker::RollNotInEffect => "roll not in effect on FC".into(),
    }
}

/// `text` cut to `max` bytes at a character boundary.
fn fit(mut text: String, max: usize) -> String {
    if text.len() > max {
        let mut end = max;
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        text.truncate(end);
    }
    text
}

/// What the ground link lost, by cause; reported in the journal while it grows.
#[derive(Debug, Default)]
pub struct Counters {
    /// Autopilot frames not forwarded: the queue was full (the ground link slower
    /// than the autopilot, or down), or they had waited through a reconnect.
    pub frames_dropped: AtomicU64,
    /// STATUSTEXT not sent: the queue was full.
    pub notices_dropped: AtomicU64,
    /// Ground frames for the autopilot dropped: its port's queue was full.
    pub uplink_dropped: AtomicU64,
    /// Ground frames kept from the autopilot by the configuration.
    pub uplink_refused: AtomicU64,
}

impl Counters {
    fn snapshot(&self) -> [u64; 4] {
        [
            &self.frames_dropped,
            &self.notices_dropped,
            &self.uplink_dropped,
            &self.uplink_refused,
        ]
        .map(|c| c.load(Ordering::Relaxed))
    }
}

/// What the other tasks hold of the ground link: every call returns at once. With
/// the link off ([`GroundFeed::default`]) every call does nothing.
#[derive(Clone, Debug, Default)]
pub struct GroundFeed {
    frames: Option<mpsc::Sender<RawFrame>>,
    notices: Option<mpsc::Sender<Notice>>,
    counters: Arc<Counters>,
}

impl GroundFeed {
    /// A frame from the autopilot's port, for the ground.
    pub fn forward(&self, raw: &MAVLinkMessageRaw) {
        if let Some(tx) = &self.frames
            && tx.try_send(RawFrame::new(raw)).is_err()
        {
            self.counters.frames_dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Something to tell the ground.
    pub fn notify(&self, notice: Notice) {
        if let Some(tx) = &self.notices
            && tx.try_send(notice).is_err()
        {
            self.counters
                .notices_dropped
                .fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// The ground task's side of the queues.
pub struct GroundIo {
    frames: mpsc::Receiver<RawFrame>,
    notices: mpsc::Receiver<Notice>,
    telemetry: watch::Receiver<PipelineTelemetry>,
    /// The autopilot link's queue for ground frames, when they may go there.
    to_autopilot: Option<mpsc::Sender<RawFrame>>,
    counters: Arc<Counters>,
}

/// The queues between the daemon's tasks and the ground link: the feed the link and
/// the commander hold, the ground task's ends, and the receiver the autopilot link
/// takes ground frames from (only with `forward_to_autopilot`).
pub fn queues(
    config: &GroundConfig,
    telemetry: watch::Receiver<PipelineTelemetry>,
) -> (GroundFeed, GroundIo, Option<mpsc::Receiver<RawFrame>>) {
    let (frames_tx, frames) = mpsc::channel(FRAMES_QUEUE);
    let (notices_tx, notices) = mpsc::channel(NOTICES_QUEUE);
    let (to_autopilot, uplink) = if config.forward_to_autopilot {
        let (tx, rx) = mpsc::channel(UPLINK_QUEUE);
        (Some(tx), Some(rx))
    } else {
        (None, None)
    };
    let counters = Arc::new(Counters::default());
    let feed = GroundFeed {
        frames: config.forward_from_autopilot.then_some(frames_tx),
        notices: Some(notices_tx),
        counters: counters.clone(),
    };
    let io = GroundIo {
        frames,
        notices,
        telemetry,
        to_autopilot,
        counters,
    };
    (feed, io, uplink)
}

/// Runs forever: open the ground port, serve it, and on any failure wait and reopen
/// (with the autopilot link's backoff).
pub async fn run(
    config: GroundConfig,
    mavlink: MavlinkConfig,
    endpoint: Endpoint,
    clock: DaemonClock,
    mut io: GroundIo,
) {
    let min = Duration::from_micros(mavlink.reconnect_min_us.max(1) as u64);
    let max = Duration::from_micros(mavlink.reconnect_max_us.max(1) as u64);
    let mut backoff = min;
    let mut sequence = 0u8;
    let mut reported = [0u64; 4];
    if config.forward_to_autopilot {
        tracing::warn!(
            rc_override = config.forward_rc_override,
            "frames from the ground station are forwarded to the autopilot (ground.forward_to_autopilot)"
        );
    }
    let mut reopened = false;
    loop {
        match endpoint.open().await {
            Ok(transport) => {
                tracing::info!(%endpoint, "ground station link up");
                backoff = min;
                // The autopilot's frames that waited through a reconnect are stale:
                // dropped, counted. Notices are kept: what happened while the link
                // was down is still news.
                if std::mem::replace(&mut reopened, true) {
                    drain_frames(&mut io);
                }
                let why = serve(
                    &config,
                    &mavlink,
                    transport,
                    &clock,
                    &mut io,
                    &mut sequence,
                    &mut reported,
                )
                .await;
                tracing::warn!(%endpoint, "ground station link lost: {why}; reopening");
            }
            Err(e) => {
                tracing::warn!(%endpoint, "cannot open ground station link: {e}; retry in {} ms", backoff.as_millis());
            }
        }
        tokio::time::sleep(backoff).await;
        backoff = (backoff * 2).min(max);
    }
}

fn drain_frames(io: &mut GroundIo) {
    let mut frames = 0;
    while io.frames.try_recv().is_ok() {
        frames += 1;
    }
    io.counters
        .frames_dropped
        .fetch_add(frames, Ordering::Relaxed);
}

/// The values plotted on the ground, as NAMED_VALUE_FLOAT names (10 characters at
/// most). A value the pipeline does not have (no FOE in the view, no obstacle, no
/// window in the period) is sent as NaN, so every name keeps its rate.
pub const VALUE_NAMES: [&str; 5] = ["foe_x_px", "foe_y_px", "ttc_s", "events_hz", "cycle_ms"];

/// The pipeline's totals at one look, and when.
#[derive(Clone, Copy)]
struct Look {
    t_us: i64,
    totals: PipelineTelemetry,
}

/// The values of [`VALUE_NAMES`] over the time between two looks.
fn values(before: &Look, now: &Look) -> [f32; 5] {
    let (b, n) = (&before.totals, &now.totals);
    let dt_us = now.t_us - before.t_us;
    let events_hz = if dt_us > 0 {
        n.events.saturating_sub(b.events) as f64 * 1e6 / dt_us as f64
    } else {
        f64::NAN
    };
    let windows = n.windows.saturating_sub(b.windows);
    let cycle_ms = if windows > 0 {
        (n.cycle_us_total - b.cycle_us_total) as f64 / windows as f64 / 1000.0
    } else {
        f64::NAN
    };
    let (foe_x_px, foe_y_px) = n.foe_px.unwrap_or((f64::NAN, f64::NAN));
    [
        foe_x_px,
        foe_y_px,
        n.obstacle_ttc_s.unwrap_or(f64::NAN),
        events_hz,
        cycle_ms,
    ]
    .map(|v| v as f32)
}

/// Serves one open ground port until it fails; returns why.
async fn serve(
    config: &GroundConfig,
    mavlink: &MavlinkConfig,
    transport: BoxedTransport,
    clock: &DaemonClock,
    io: &mut GroundIo,
    sequence: &mut u8,
    reported: &mut [u64; 4],
) -> String {
    let (read_half, mut write_half) = tokio::io::split(transport);
    let mut reader = AsyncMavlinkReader::new(read_half);
    let period = |us: i64| Duration::from_micros(us.max(1000) as u64);
    let mut heartbeat = tokio::time::interval(period(config.heartbeat_period_us));
    heartbeat.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut values_tick = tokio::time::interval(period(config.telemetry_period_us));
    values_tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut report = tokio::time::interval(REPORT_PERIOD);
    report.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut last = Look {
        t_us: clock.now_us(),
        totals: *io.telemetry.borrow(),
    };
    let mut own = Own {
        header: MavHeader {
            system_id: u32::from(mavlink.system_id),
            component_id: mavlink.component_id,
            sequence: 0,
        },
        sequence,
        buffer: Vec::with_capacity(512),
    };
    loop {
        // Biased, in order of what a person on the ground needs most: faithd's own
        // HEARTBEAT and notices first, the values, then the autopilot's stream, then
        // what the ground says.
        tokio::select! {
            biased;
            _ = heartbeat.tick() => {
                own.push(&super::own_heartbeat());
            }
            Some(notice) = io.notices.recv() => {
                let (severity, text) = notice.statustext();
                own.push(&MavMessage::STATUSTEXT(STATUSTEXT_DATA {
                    severity,
                    text: text.as_str().into(),
                    id: 0,
                    chunk_seq: 0,
                }));
            }
            _ = values_tick.tick() => {
                let now = Look { t_us: clock.now_us(), totals: *io.telemetry.borrow() };
                let time_boot_ms = (now.t_us / 1000).clamp(0, i64::from(u32::MAX)) as u32;
                for (name, value) in VALUE_NAMES.iter().zip(values(&last, &now)) {
                    own.push(&MavMessage::NAMED_VALUE_FLOAT(NAMED_VALUE_FLOAT_DATA {
                        time_boot_ms,
                        value,
                        name: (*name).into(),
                    }));
                }
                last = now;
            }
            Some(frame) = io.frames.recv() => {
                own.buffer.extend_from_slice(frame.bytes());
            }
            got = reader.read_any_raw_message::<MavMessage>() => match got {
                Ok(raw) => uplink(config, mavlink, &raw, io),
                Err(mavlink::error::MessageReadError::Io(e)) => return format!("read failed: {e}"),
                // A frame with a valid checksum faithd cannot decode: not for us.
                Err(mavlink::error::MessageReadError::Parse(_)) => {}
            },
            _ = report.tick() => report_losses(&io.counters, reported),
        }
        if !own.buffer.is_empty() {
            let written = transport::write_bounded(&mut write_half, &own.buffer).await;
            own.buffer.clear();
            if let Err(e) = written {
                return format!("write failed: {e}");
            }
        }
    }
}

/// faithd's own frames to the ground, encoded into one buffer with its ids and
/// sequence numbers.
struct Own<'a> {
    header: MavHeader,
    sequence: &'a mut u8,
    buffer: Vec<u8>,
}

impl Own<'_> {
    fn push(&mut self, msg: &MavMessage) {
        let header = MavHeader {
            sequence: *self.sequence,
            ..self.header
        };
        *self.sequence = self.sequence.wrapping_add(1);
        // Encoding into a Vec cannot fail on I/O; a message faithd builds always fits.
        if let Err(e) =
            mavlink::write_versioned_msg(&mut self.buffer, MavlinkVersion::V2, header, msg)
        {
            tracing::error!("cannot encode {} for the ground: {e}", msg.message_name());
        }
    }
}

/// A frame from the ground: to the autopilot's port if the configuration lets it
/// go there, else counted and (now and then) named in the journal.
fn uplink(config: &GroundConfig, mavlink: &MavlinkConfig, raw: &MAVLinkMessageRaw, io: &GroundIo) {
    let id = raw.message_id();
    let refused = match &io.to_autopilot {
        None => Some("ground.forward_to_autopilot = false"),
        Some(_) if STICK_INPUT_IDS.contains(&id) && !config.forward_rc_override => {
            Some("stick input, ground.forward_rc_override = false")
        }
        Some(_) if id == RADIO_STATUS_ID => Some(
            "RADIO_STATUS makes iNav pace its telemetry on the ground radio's buffer, which could starve faithd of ATTITUDE",
        ),
        // A frame that claims the vehicle's own system (the autopilot's, or faithd's)
        // is an echo or an impostor, never the ground station's.
        Some(_)
            if raw.system_id() == u32::from(mavlink.system_id)
                || raw.system_id() == u32::from(mavlink.autopilot_system_id) =>
        {
            Some("it claims the vehicle's own system id")
        }
        Some(_) => None,
    };
    match (refused, &io.to_autopilot) {
        (Some(why), _) => {
            let n = io.counters.uplink_refused.fetch_add(1, Ordering::Relaxed) + 1;
            if n.is_power_of_two() {
                let name =
                    MavMessage::default_message_from_id(id).map_or("?", |m| m.message_name());
                tracing::info!(
                    message_name = name,
                    message_id = id,
                    system_id = raw.system_id(),
                    component_id = raw.component_id(),
                    refused = n,
                    "frame from the ground station not forwarded to the autopilot ({why})"
                );
            }
        }
        (None, Some(tx)) => {
            if tx.try_send(RawFrame::new(raw)).is_err() {
                io.counters.uplink_dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
        (None, None) => {}
    }
}

fn report_losses(counters: &Counters, reported: &mut [u64; 4]) {
    let now = counters.snapshot();
    if now[..3] != reported[..3] {
        tracing::warn!(
            autopilot_frames = now[0] - reported[0],
            statustext = now[1] - reported[1],
            frames_for_the_autopilot = now[2] - reported[2],
            "ground station link behind: dropped (queue full: the ground link is slower than the autopilot, or down)"
        );
    }
    *reported = now;
}

#[cfg(test)]
mod tests {
    use super::*;
    use faithd_core::safety::gate::PipelineProblem;

    fn every_blocker() -> Vec<Blocker> {
        let age_us = 2_500_000;
        vec![
            Blocker::LinkDown,
            Blocker::NoRc,
            Blocker::RcStale { age_us },
            Blocker::SwitchMissing { channel: 18 },
            Blocker::SwitchNotAuto { value_us: 1000 },
            Blocker::RadioLost,
            Blocker::NoHeartbeat,
            Blocker::HeartbeatStale { age_us },
            Blocker::Disarmed,
            Blocker::AutopilotFailsafe {
                source: FailsafeSource::Heartbeat,
                says: "",
            },
            Blocker::AutopilotFailsafe {
                source: FailsafeSource::AutopilotStatus,
                says: "",
            },
            Blocker::NoAttitude,
            Blocker::AttitudeStale { age_us },
            Blocker::PipelineNotRunning,
            Blocker::PipelineStale { age_us },
            Blocker::PipelineUnhealthy {
                problem: PipelineProblem::NoEvents,
            },
            Blocker::PipelineUnhealthy {
                problem: PipelineProblem::NoAttitude,
            },
            Blocker::SetupRefused { says: "" },
            Blocker::CommandPortDown { says: "" },
            Blocker::NoAutopilotStatus { says: "" },
            Blocker::AutopilotStatusStale { age_us, says: "" },
            Blocker::OverrideInactive { says: "" },
            Blocker::OverrideWarmingUp {
                remaining_us: 300_000,
                says: "",
            },
            Blocker::RollNotInEffect,
        ]
    }

    #[test]
    fn every_reason_fits_one_statustext_whole() {
        for blocker in every_blocker() {
            let notice = Notice::Gate {
                gate: GateState::Closed(blocker),
                was_open: Some(true),
            };
            let (_, text) = notice.statustext();
            let whole = format!("faithd: gate closed: {}", short_reason(&blocker));
            assert_eq!(text, whole, "{blocker:?} was cut");
            assert!(text.len() <= STATUSTEXT_MAX_CHARS, "{text}");
        }
    }

    #[test]
    fn texts_and_severities_read_as_a_ground_station_shows_them() {
        let roll = Notice::Roll {
            direction: RollDirection::Right,
            ttc_s: Some(1.08),
        };
        assert_eq!(
            roll.statustext(),
            (
                MavSeverity::MAV_SEVERITY_WARNING,
                "faithd: roll right, obstacle TTC 1.1 s".into()
            )
        );
        let manual = GateState::Closed(Blocker::SwitchNotAuto { value_us: 1000 });
        assert_eq!(
            Notice::Gate {
                gate: manual,
                was_open: Some(true)
            }
            .statustext(),
            (
                MavSeverity::MAV_SEVERITY_NOTICE,
                "faithd: gate closed: switch MANUAL".into()
            )
        );
        // Another reason while it stays closed: listed, not read aloud.
        assert_eq!(
            Notice::Gate {
                gate: manual,
                was_open: Some(false)
            }
            .statustext()
            .0,
            MavSeverity::MAV_SEVERITY_INFO
        );
        assert_eq!(
            Notice::Gate {
                gate: GateState::Open,
                was_open: Some(false)
            }
            .statustext(),
            (MavSeverity::MAV_SEVERITY_NOTICE, "faithd: gate open".into())
        );
        let huge = Notice::Roll {
            direction: RollDirection::Left,
            ttc_s: Some(1e300),
        };
        assert!(huge.statustext().1.len() <= STATUSTEXT_MAX_CHARS);
        assert_eq!(fit("ab\u{e9}".into(), 3), "ab");
    }

    #[test]
    fn values_are_rates_and_means_between_two_looks() {
        let before = Look {
            t_us: 1_000_000,
            totals: PipelineTelemetry {
                windows: 100,
                events: 50_000,
                cycle_us_total: 200_000,
                ..Default::default()
            },
        };
        let now = Look {
            t_us: 1_250_000,
            totals: PipelineTelemetry {
                windows: 125,
                events: 100_000,
                cycle_us_total: 250_000,
                foe_px: Some((120.0, 90.0)),
                obstacle_ttc_s: Some(1.5),
            },
        };
        assert_eq!(values(&before, &now), [120.0, 90.0, 1.5, 200_000.0, 2.0]);
        let idle = values(
            &now,
            &Look {
                t_us: 1_500_000,
                ..now
            },
        );
        assert_eq!(idle[3], 0.0);
        assert!(idle[4].is_nan(), "no window: no cycle time");
        let empty = values(
            &before,
            &Look {
                t_us: 1_250_000,
                ..before
            },
        );
        assert!(empty[0].is_nan() && empty[2].is_nan());
        assert!(VALUE_NAMES.iter().all(|n| n.len() <= 10));
    }

    use crate::transport::InProcessPort;
    use mavlink::dialects::common::{
        ATTITUDE_DATA, COMMAND_LONG_DATA, MavCmd, RC_CHANNELS_OVERRIDE_DATA,
    };
    use std::sync::Mutex;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    /// A frame as the autopilot's port would deliver it.
    fn autopilot_frame(msg: &MavMessage, sequence: u8) -> MAVLinkMessageRaw {
        let mut raw = mavlink::MAVLinkV2MessageRaw::new();
        let header = MavHeader {
            system_id: 1,
            component_id: 1,
            sequence,
        };
        raw.serialize_message(header, msg);
        MAVLinkMessageRaw::V2(raw)
    }

    /// The ground task on an in-process port (one open only), in simulated time; the
    /// station's end, and the feed and counters.
    fn start(
        config: GroundConfig,
        buffer_bytes: usize,
    ) -> (
        tokio::io::DuplexStream,
        GroundFeed,
        watch::Sender<PipelineTelemetry>,
        Option<mpsc::Receiver<RawFrame>>,
    ) {
        let (station, faithd) = tokio::io::duplex(buffer_bytes);
        let once = Mutex::new(Some(faithd));
        let port = InProcessPort::new("ground station", move || {
            once.lock()
                .unwrap()
                .take()
                .map(|t| Box::pin(t) as BoxedTransport)
                .ok_or_else(|| std::io::Error::other("gone"))
        });
        let (telemetry_tx, telemetry_rx) = watch::channel(PipelineTelemetry::default());
        let (feed, io, uplink) = queues(&config, telemetry_rx);
        let clock = DaemonClock::simulated(0);
        let endpoint = Endpoint::new(Address::InProcess(port), 0);
        tokio::spawn(run(config, MavlinkConfig::default(), endpoint, clock, io));
        (station, feed, telemetry_tx, uplink)
    }

    fn frame_bytes(header: MavHeader, msg: &MavMessage) -> Vec<u8> {
        let mut bytes = Vec::new();
        mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, header, msg).unwrap();
        bytes
    }

    fn ground_station_header() -> MavHeader {
        MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: 0,
        }
    }

    fn stick_and_command() -> Vec<u8> {
        let mut bytes = frame_bytes(
            ground_station_header(),
            &MavMessage::RC_CHANNELS_OVERRIDE(RC_CHANNELS_OVERRIDE_DATA {
                chan1_raw: 1900,
                target_system: 1,
                target_component: 1,
                ..Default::default()
            }),
        );
        bytes.extend(frame_bytes(
            ground_station_header(),
            &MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
                command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                target_system: 1,
                target_component: 1,
                ..Default::default()
            }),
        ));
        bytes
    }

    #[tokio::test(start_paused = true)]
    async fn in_simulated_time_the_ground_hears_faithd_and_the_autopilot_and_nothing_goes_back() {
        let config = GroundConfig {
            enabled: true,
            ..GroundConfig::default()
        };
        let (mut station, feed, telemetry, uplink) = start(config, 64 * 1024);
        assert!(
            uplink.is_none(),
            "nothing from the ground reaches the autopilot"
        );
        let attitude = MavMessage::ATTITUDE(ATTITUDE_DATA {
            time_boot_ms: 7,
            rollspeed: 0.5,
            ..Default::default()
        });
        let raw = autopilot_frame(&attitude, 42);
        let as_sent = RawFrame::new(&raw).bytes().to_vec();
        tokio::time::sleep(Duration::from_millis(100)).await;
        telemetry.send_replace(PipelineTelemetry {
            windows: 10,
            events: 1000,
            cycle_us_total: 20_000,
            foe_px: Some((120.0, 90.0)),
            obstacle_ttc_s: Some(1.2),
        });
        feed.forward(&raw);
        feed.notify(Notice::Roll {
            direction: RollDirection::Left,
            ttc_s: Some(1.2),
        });
        station.write_all(&stick_and_command()).await.unwrap();
        tokio::time::sleep(Duration::from_millis(2_850)).await;
        let mut got = Vec::new();
        let mut buf = [0u8; 4096];
        while let Ok(Ok(n)) =
            tokio::time::timeout(Duration::from_micros(1), station.read(&mut buf)).await
        {
            got.extend_from_slice(&buf[..n]);
        }
        let mut reader = mavlink::MavlinkReader::new(&got[..]);
        let (mut heartbeats, mut texts, mut values, mut attitudes) = (0, Vec::new(), 0, 0);
        while let Ok((header, msg)) = reader.read_any_message::<MavMessage>() {
            match msg {
                MavMessage::HEARTBEAT(h) => {
                    assert_eq!((header.system_id, header.component_id), (1, 191));
                    assert_eq!(
                        h.mavtype,
                        mavlink::dialects::common::MavType::MAV_TYPE_ONBOARD_CONTROLLER
                    );
                    heartbeats += 1;
                }
                MavMessage::STATUSTEXT(t) => texts.push(t.text.to_str().unwrap().to_owned()),
                MavMessage::NAMED_VALUE_FLOAT(_) => values += 1,
                MavMessage::ATTITUDE(_) => {
                    assert_eq!(
                        (header.system_id, header.component_id, header.sequence),
                        (1, 1, 42)
                    );
                    attitudes += 1;
                }
                other => panic!("unexpected {other:?}"),
            }
        }
        assert!(
            got.windows(as_sent.len()).any(|w| w == as_sent),
            "the autopilot's frame reaches the ground byte for byte"
        );
        // 2.95 s of simulated time: HEARTBEAT at 0, 1, 2 s; values every 250 ms from 0.
        assert_eq!(heartbeats, 3);
        assert_eq!(values, 12 * VALUE_NAMES.len());
        assert_eq!(attitudes, 1);
        assert_eq!(texts, ["faithd: roll left, obstacle TTC 1.2 s"]);
        assert_eq!(feed.counters.uplink_refused.load(Ordering::Relaxed), 2);
    }

    #[tokio::test(start_paused = true)]
    async fn forwarding_up_keeps_stick_input_and_impostors_from_the_autopilot() {
        let config = GroundConfig {
            enabled: true,
            forward_to_autopilot: true,
            ..GroundConfig::default()
        };
        let (mut station, feed, _telemetry, uplink) = start(config, 64 * 1024);
        let mut uplink = uplink.expect("forwarding on");
        station.write_all(&stick_and_command()).await.unwrap();
        let impostor = MavHeader {
            system_id: 1,
            component_id: 1,
            sequence: 0,
        };
        station
            .write_all(&frame_bytes(
                impostor,
                &MavMessage::HEARTBEAT(Default::default()),
            ))
            .await
            .unwrap();
        // A SiK radio on the ground station's side reports its buffer.
        let radio = MavHeader {
            system_id: 51,
            component_id: 68,
            sequence: 0,
        };
        station
            .write_all(&frame_bytes(
                radio,
                &MavMessage::RADIO_STATUS(mavlink::dialects::common::RADIO_STATUS_DATA {
                    txbuf: 10,
                    ..Default::default()
                }),
            ))
            .await
            .unwrap();
        tokio::time::sleep(Duration::from_millis(500)).await;
        let forwarded = uplink.try_recv().expect("the command is forwarded");
        assert!(matches!(
            forwarded.decode(),
            Some(MavMessage::COMMAND_LONG(_))
        ));
        assert_eq!(forwarded.header().system_id, 255);
        assert!(uplink.try_recv().is_err(), "nothing else");
        assert_eq!(feed.counters.uplink_refused.load(Ordering::Relaxed), 3);
    }

    #[tokio::test(start_paused = true)]
    async fn a_ground_station_that_stops_reading_costs_frames_never_a_wait() {
        let config = GroundConfig {
            enabled: true,
            ..GroundConfig::default()
        };
        // A tiny pipe nobody reads: the ground link's writes stall, time out, and it
        // cannot reopen.
        let (_station, feed, _telemetry, _) = start(config, 256);
        let attitude = autopilot_frame(&MavMessage::ATTITUDE(Default::default()), 0);
        let started = std::time::Instant::now();
        for _ in 0..200 {
            tokio::time::sleep(Duration::from_millis(10)).await;
            for _ in 0..10 {
                feed.forward(&attitude);
                feed.notify(Notice::Gate {
                    gate: GateState::Open,
                    was_open: Some(false),
                });
            }
        }
        assert!(started.elapsed() < Duration::from_secs(5));
        let dropped = feed.counters.frames_dropped.load(Ordering::Relaxed);
        assert!(dropped >= 2000 - FRAMES_QUEUE as u64 - 100, "{dropped}");
        assert!(feed.counters.notices_dropped.load(Ordering::Relaxed) > 1000);
    }

    #[test]
    fn the_link_is_off_by_default_and_needs_an_endpoint_when_on() {
        let config = GroundConfig::default();
        assert!(!config.enabled && config.port().is_none());
        config.validate().unwrap();
        let on = GroundConfig {
            enabled: true,
            ..GroundConfig::default()
        };
        assert_eq!(on.validate().unwrap_err().key, "ground.endpoint");
        let rc = GroundConfig {
            forward_rc_override: true,
            ..GroundConfig::default()
        };
        assert_eq!(rc.validate().unwrap_err().key, "ground.forward_rc_override");
    }
}
