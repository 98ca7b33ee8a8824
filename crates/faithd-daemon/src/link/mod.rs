//! The MAVLink link to the autopilot: one task that owns the transport, keeps it
//! open (reconnecting with backoff when the port vanishes), turns what arrives into
//! vehicle state and attitude samples, sends faithd's own HEARTBEAT, and writes what
//! the commander hands it. Nothing here waits for the pipeline, nor for the ground
//! station link ([`ground`]), which it hands every frame it reads.

pub mod clock_sync;
pub mod ground;
pub mod late_attitude;
pub mod over_msp;
pub mod telemetry;

use std::sync::{Arc, Mutex};
use std::time::Duration;

use mavlink::dialects::common::{
    HEARTBEAT_DATA, MavAutopilot, MavMessage, MavModeFlag, MavState, MavType,
};
use mavlink::{AsyncMavlinkReader, MavHeader, MavlinkVersion, Message as _};
use serde::{Deserialize, Serialize};
use tokio::sync::{mpsc, watch};

use crate::clock::DaemonClock;
use crate::supervise::Heartbeat;
use crate::transport::{self, Address, BoxedTransport, Endpoint};
use clock_sync::ClockSync;
use faithd_core::attitude::AttitudeLog;
use faithd_core::invalid::{Invalid, check};
use faithd_core::safety::vehicle::VehicleState;
use ground::{GroundFeed, RawFrame};
use telemetry::Update;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MavlinkConfig {
    /// `serial:/dev/ttyAMA0`, `tcp:HOST:PORT`, `udp:BIND:PORT` or `udpout:HOST:PORT`.
    pub endpoint: Address,
    /// Serial baud rate (iNav's MAVLink port default is 115200).
    pub baud: u32,
    /// faithd's own system id: the autopilot's, as a component of the same vehicle.
    pub system_id: u8,
    /// faithd's component id (191 = MAV_COMP_ID_ONBOARD_COMPUTER).
    pub component_id: u8,
    /// Messages from other systems (a ground station on the same radio) are ignored.
    pub autopilot_system_id: u8,
    /// ...and from other components of the autopilot's system (a camera, a gimbal,
    /// another companion): only the autopilot's own frames move the gate.
    pub autopilot_component_id: u8,
    /// Period of faithd's HEARTBEAT.
    pub heartbeat_period_us: i64,
    /// First and longest wait before reopening a lost port.
    pub reconnect_min_us: i64,
    pub reconnect_max_us: i64,
    /// No valid frame for this long and the port is closed and reopened: a USB
    /// adapter that vanished does not always report an error, it just goes quiet.
    pub silence_timeout_us: i64,
}

impl Default for MavlinkConfig {
    fn default() -> Self {
        Self {
            endpoint: Address::Serial("/dev/ttyAMA0".into()),
            baud: 115_200,
            system_id: 1,
            component_id: 191,
            autopilot_system_id: 1,
            autopilot_component_id: 1,
            heartbeat_period_us: 1_000_000,
            reconnect_min_us: 100_000,
            reconnect_max_us: 2_000_000,
            silence_timeout_us: 1_500_000,
        }
    }
}

impl MavlinkConfig {
    /// The port to the autopilot.
    pub fn port(&self) -> Endpoint {
        Endpoint::new(self.endpoint.clone(), self.baud)
    }

    /// `[mavlink]`: ids, periods and timeouts the link can keep.
    pub fn validate(&self) -> Result<(), Invalid> {
        let m = self;
        check(m.baud >= 1200, "mavlink.baud", || {
            format!("must be a serial baud rate, got {}", m.baud)
        })?;
        check(m.system_id >= 1, "mavlink.system_id", || {
            "must be 1 to 255".into()
        })?;
        check(m.component_id >= 1, "mavlink.component_id", || {
            "must be 1 to 255".into()
        })?;
        check(
            m.autopilot_system_id >= 1,
            "mavlink.autopilot_system_id",
            || "must be 1 to 255".into(),
        )?;
        check(
            m.autopilot_component_id >= 1,
            "mavlink.autopilot_component_id",
            || "must be 1 to 255 (iNav's is 1, MAV_COMP_ID_AUTOPILOT1)".into(),
        )?;
        check(
            (10_000..=10_000_000).contains(&m.heartbeat_period_us),
            "mavlink.heartbeat_period_us",
            || format!("must be 10 ms to 10 s, got {}", m.heartbeat_period_us),
        )?;
        check(
            m.reconnect_min_us >= 1000 && m.reconnect_min_us <= m.reconnect_max_us,
            "mavlink.reconnect_min_us",
            || "must be at least 1 ms and at most reconnect_max_us".into(),
        )?;
        check(
            m.reconnect_max_us <= 60_000_000,
            "mavlink.reconnect_max_us",
            || format!("must be at most 60 s, got {}", m.reconnect_max_us),
        )?;
        check(
            (100_000..=60_000_000).contains(&m.silence_timeout_us),
            "mavlink.silence_timeout_us",
            || format!("must be 100 ms to 60 s, got {}", m.silence_timeout_us),
        )?;
        Ok(())
    }
}

/// Where faithd reads the autopilot: `[telemetry]`, a `kind` and its own settings.
///
/// iNav after 9.1 compiles MAVLink only on boards with more than 512 KB of flash
/// (target/common.h, iNav PR #11868): on F411 and F722 flight controllers faithd reads
/// the same facts over a second MSP port ([`over_msp`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TelemetryConfig {
    /// iNav's MAVLink telemetry on `[mavlink]`'s port.
    #[default]
    Mavlink,
    /// iNav's MSP on a UART of its own, beside the command port.
    Msp(over_msp::MspTelemetryConfig),
}

impl TelemetryConfig {
    pub fn is_msp(&self) -> bool {
        matches!(self, TelemetryConfig::Msp(_))
    }
}

/// ATTITUDE messages the clock offset is estimated over (five seconds at 50 Hz); the
/// replay of a recorded flight uses the same.
pub const CLOCK_SYNC_WINDOW: usize = 250;

/// What the link task publishes.
#[derive(Clone)]
pub struct LinkOutputs {
    pub vehicle: watch::Sender<VehicleState>,
    pub attitude: Arc<Mutex<AttitudeLog>>,
    /// Set by the test hook [`late_attitude`]: samples go here instead, and reach
    /// `attitude` late.
    pub late_attitude: Option<late_attitude::LateSender>,
    /// Every frame in and out goes to the flight recording.
    pub recorder: Option<crate::record::Recorder>,
    /// Every frame read goes to the ground station too, when there is one.
    pub ground: GroundFeed,
}

/// What the link writes to the autopilot besides its HEARTBEAT.
pub struct ToAutopilot {
    /// Messages of faithd's own, sent with its ids.
    pub own: mpsc::Receiver<MavMessage>,
    /// Frames from the ground station, written as received; only with
    /// `ground.forward_to_autopilot`. Served after what the autopilot sends, so a
    /// busy ground station cannot starve faithd's reading of the autopilot.
    pub from_ground: Option<mpsc::Receiver<RawFrame>>,
}

/// Records a frame in or out, stamped with the daemon-clock time `t_us` it was
/// handled at (in Unix time; see [`DaemonClock::unix_us`]).
pub(crate) fn record(
    outputs: &LinkOutputs,
    clock: &DaemonClock,
    t_us: i64,
    header: MavHeader,
    msg: &MavMessage,
) {
    if let Some(r) = &outputs.recorder {
        let t_unix_us = clock.unix_us(t_us);
        r.send(crate::record::Item::Mavlink(Box::new(
            crate::record::MavlinkRecord {
                t_unix_us,
                header,
                msg: msg.clone(),
            },
        )));
    }
}

/// Runs forever: open, serve, and on any failure wait and reopen.
pub async fn run(
    config: MavlinkConfig,
    endpoint: Endpoint,
    clock: DaemonClock,
    outputs: LinkOutputs,
    mut outgoing: ToAutopilot,
    heartbeat: Heartbeat,
) {
    let min = Duration::from_micros(config.reconnect_min_us.max(1) as u64);
    let max = Duration::from_micros(config.reconnect_max_us.max(1) as u64);
    let mut backoff = min;
    let mut sequence = 0u8;
    loop {
        heartbeat.beat();
        match endpoint.open().await {
            Ok(transport) => {
                tracing::info!(%endpoint, "autopilot link up");
                backoff = min;
                outputs.vehicle.send_modify(|v| v.link_up = true);
                let why = serve(
                    &config,
                    transport,
                    &clock,
                    &outputs,
                    &mut outgoing,
                    &mut sequence,
                    &heartbeat,
                )
                .await;
                outputs.vehicle.send_modify(VehicleState::link_lost);
                outputs.attitude.lock().expect("attitude log lock").clear();
                tracing::warn!(%endpoint, "autopilot link lost: {why}; reopening");
            }
            Err(e) => {
                tracing::warn!(%endpoint, "cannot open autopilot link: {e}; retry in {} ms", backoff.as_millis());
            }
        }
        // Commands queued while the link was down are stale: drop them.
        while outgoing.own.try_recv().is_ok() {}
        if let Some(rx) = &mut outgoing.from_ground {
            while rx.try_recv().is_ok() {}
        }
        heartbeat.sleep(backoff).await;
        backoff = (backoff * 2).min(max);
    }
}

/// Serves one open transport until it fails; returns why.
async fn serve(
    config: &MavlinkConfig,
    transport: BoxedTransport,
    clock: &DaemonClock,
    outputs: &LinkOutputs,
    outgoing: &mut ToAutopilot,
    sequence: &mut u8,
    alive: &Heartbeat,
) -> String {
    let (read_half, mut write_half) = tokio::io::split(transport);
    let mut reader = AsyncMavlinkReader::new(read_half);
    let mut sync = ClockSync::new(CLOCK_SYNC_WINDOW);
    let mut heartbeat = tokio::time::interval(Duration::from_micros(
        config.heartbeat_period_us.max(1000) as u64,
    ));
    heartbeat.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut skipped = 0u64;
    let mut foreign = 0u64;
    let silence = Duration::from_micros(config.silence_timeout_us.max(1000) as u64);
    let mut deadline = tokio::time::Instant::now() + silence;
    let mut beat = tokio::time::interval(crate::supervise::BEAT_PERIOD);
    loop {
        // Biased, timers first: a stream of frames cannot starve the heartbeat,
        // and the silence deadline is only judged once no frame is waiting.
        tokio::select! {
            biased;
            _ = beat.tick() => alive.beat(),
            _ = heartbeat.tick() => {
                if let Err(e) = send(config, clock, &mut write_half, sequence, &own_heartbeat(), outputs).await {
                    return format!("write failed: {e}");
                }
            }
            Some(msg) = outgoing.own.recv() => {
                if let Err(e) = send(config, clock, &mut write_half, sequence, &msg, outputs).await {
                    return format!("write failed: {e}");
                }
            }
            got = reader.read_any_raw_message::<MavMessage>() => match got {
                Ok(raw) => {
                    outputs.ground.forward(&raw);
                    let header = ground::header_of(&raw);
                    let msg = match MavMessage::parse(raw.version(), raw.message_id(), raw.payload()) {
                        Ok(msg) => msg,
                        Err(e) => {
                            skipped += 1;
                            tracing::debug!(skipped, "undecodable MAVLink frame skipped: {e}");
                            continue;
                        }
                    };
                    if !from_autopilot(config, &header) {
                        foreign += 1;
                        if foreign.is_power_of_two() {
                            tracing::warn!(
                                system_id = header.system_id,
                                component_id = header.component_id,
                                foreign,
                                "MAVLink frames from a sender other than the autopilot ignored"
                            );
                        }
                        continue;
                    }
                    deadline = tokio::time::Instant::now() + silence;
                    let rx_us = clock.now_us();
                    record(outputs, clock, rx_us, header, &msg);
                    receive(&msg, rx_us, &mut sync, outputs);
                }
                Err(mavlink::error::MessageReadError::Io(e)) => return format!("read failed: {e}"),
                Err(mavlink::error::MessageReadError::Parse(e)) => {
                    // A frame with a valid checksum faithd cannot decode (another
                    // dialect's message): skip it, count it.
                    skipped += 1;
                    tracing::debug!(skipped, "undecodable MAVLink frame skipped: {e}");
                }
            },
            _ = tokio::time::sleep_until(deadline) => {
                return format!("nothing from the autopilot for {} ms", silence.as_millis());
            }
            Some(frame) = recv_from_ground(&mut outgoing.from_ground) => {
                if let Some(msg) = frame.decode() {
                    record(outputs, clock, clock.now_us(), frame.header(), &msg);
                }
                if let Err(e) = transport::write_bounded(&mut write_half, frame.bytes()).await {
                    return format!("write failed: {e}");
                }
            }
        }
    }
}

/// The next frame from the ground station, or never without forwarding.
async fn recv_from_ground(from_ground: &mut Option<mpsc::Receiver<RawFrame>>) -> Option<RawFrame> {
    match from_ground {
        Some(rx) => rx.recv().await,
        None => std::future::pending().await,
    }
}

/// Only the autopilot (its system and component id) is believed.
fn from_autopilot(config: &MavlinkConfig, header: &MavHeader) -> bool {
    header.system_id == u32::from(config.autopilot_system_id)
        && header.component_id == config.autopilot_component_id
}

pub(crate) fn receive(msg: &MavMessage, rx_us: i64, sync: &mut ClockSync, outputs: &LinkOutputs) {
    let mut update = Update::Ignored;
    let mut before = None;
    outputs.vehicle.send_if_modified(|v| {
        before = v.heartbeat.map(|h| (h.armed, h.custom_mode));
        update = telemetry::apply(v, sync, msg, rx_us);
        !matches!(update, Update::Ignored)
    });
    if let Update::Heartbeat = update {
        let now = outputs
            .vehicle
            .borrow()
            .heartbeat
            .map(|h| (h.armed, h.custom_mode));
        if let Some((armed, mode)) = now.filter(|n| before != Some(*n)) {
            tracing::info!(armed, flight_mode = mode, "autopilot state");
        }
    }
    if let Update::Attitude(sample) = update {
        match &outputs.late_attitude {
            Some(late) => {
                let _ = late.send((tokio::time::Instant::now(), sample));
            }
            None => outputs
                .attitude
                .lock()
                .expect("attitude log lock")
                .push(sample),
        }
    }
}

async fn send(
    config: &MavlinkConfig,
    clock: &DaemonClock,
    writer: &mut (impl tokio::io::AsyncWrite + Unpin),
    sequence: &mut u8,
    msg: &MavMessage,
    outputs: &LinkOutputs,
) -> std::io::Result<()> {
    let header = MavHeader {
        system_id: u32::from(config.system_id),
        component_id: config.component_id,
        sequence: *sequence,
    };
    record(outputs, clock, clock.now_us(), header, msg);
    *sequence = sequence.wrapping_add(1);
    let mut frame = Vec::with_capacity(280);
    mavlink::write_versioned_msg(&mut frame, MavlinkVersion::V2, header, msg)
        .map_err(|e| std::io::Error::other(e.to_string()))?;
    transport::write_bounded(writer, &frame).await
}

/// faithd announces itself as an onboard controller, not an autopilot (to the
/// autopilot and to the ground station alike).
pub(crate) fn own_heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    })
}
