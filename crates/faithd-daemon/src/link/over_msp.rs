//! The autopilot's telemetry over MSP, for flight controllers that have no MAVLink
//! (iNav after 9.1 on F411 and F722 boards, target/common.h): a UART of its own,
//! beside the command port, asked in turn for the gyro, the pilot's channels, the
//! arming and mode flags and the attitude.
//!
//! Why a second port: iNav serves one MSP command per port every 10 ms
//! (fc/fc_tasks.c TASK_SERIAL; msp/msp_serial.c), faithd uses at most half of that,
//! and on the command port the roll frame already takes every other slot and the
//! roll's confirmation and iNav's status the rest. The gyro alone, at the 25 Hz that
//! derotation gets here, would need all of them.
//!
//! What is read becomes the MAVLink messages that carry the same facts from iNav's
//! MAVLink telemetry (ATTITUDE, RC_CHANNELS, HEARTBEAT, SYS_STATUS), stamped at the
//! time iNav read them, and goes through the same path: the gate, derotation, the
//! recording and its replay see one kind of input whichever link the board has.
//! Two things differ, and docs/inav.md says so: the gyro comes in whole degrees per
//! second at 25 Hz (MAVLink: float at 25 Hz, `mavlink_extra1_rate = 50`), and iNav
//! reports nothing over MSP about its receiver before its own failsafe, so the
//! pilot's radio reads lost only from iNav's FAILSAFE mode on.

use std::time::Duration;

use mavlink::MavHeader;
use mavlink::dialects::common::{
    ATTITUDE_DATA, HEARTBEAT_DATA, MavAutopilot, MavMessage, MavModeFlag, MavState,
    MavSysStatusSensor, MavType, RC_CHANNELS_DATA, SYS_STATUS_DATA,
};
use serde::{Deserialize, Serialize};

use super::clock_sync::ClockSync;
use super::{CLOCK_SYNC_WINDOW, LinkOutputs, VehicleState};
use crate::clock::DaemonClock;
use crate::command::fc_check::{self, StatusBits, StatusFlags};
use crate::command::msp;
use crate::command::msp_port::{self, MspError, MspPort};
use crate::supervise::Heartbeat;
use crate::transport::{Address, Endpoint};
use faithd_core::invalid::{Invalid, check};

/// MSP_RAW_IMU: accelerometer, gyro (int16 whole degrees per second, `gyroRateDps`,
/// sensors/gyro.c) and magnetometer, three axes each (fc/fc_msp.c).
pub const MSP_RAW_IMU: u16 = 102;
/// MSP_ATTITUDE: roll and pitch in decidegrees, yaw in degrees (fc/fc_msp.c).
pub const MSP_ATTITUDE: u16 = 108;

/// `[telemetry] kind = "msp"`: the UART to iNav's second MSP port.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MspTelemetryConfig {
    pub endpoint: Address,
    pub baud: u32,
}

impl Default for MspTelemetryConfig {
    fn default() -> Self {
        Self {
            endpoint: Address::Serial("/dev/ttyAMA2".into()),
            baud: 115_200,
        }
    }
}

impl MspTelemetryConfig {
    pub fn port(&self) -> Endpoint {
        Endpoint::new(self.endpoint.clone(), self.baud)
    }

    pub fn validate(&self) -> Result<(), Invalid> {
        check(self.baud >= 1200, "telemetry.baud", || {
            format!("must be a serial baud rate, got {}", self.baud)
        })
    }
}

/// What one slot asks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ask {
    Imu,
    Rc,
    Status,
    Attitude,
}

impl Ask {
    fn command(self) -> u16 {
        match self {
            Ask::Imu => MSP_RAW_IMU,
            Ask::Rc => msp_port::MSP_RC,
            Ask::Status => msp_port::MSP2_INAV_STATUS,
            Ask::Attitude => MSP_ATTITUDE,
        }
    }
}

/// One request per 20 ms slot, in this order: the gyro every 40 ms (derotation;
/// `gate.attitude_stale_us` is 100 ms), the pilot's channels every 80 ms
/// (`gate.rc_stale_us` 300 ms), arming, failsafe and modes every 120 ms
/// (`gate.radio_stale_us` 300 ms), the angles every 240 ms (recorded, not used by
/// derotation).
const SCHEDULE: [Ask; 12] = [
    Ask::Imu,
    Ask::Rc,
    Ask::Imu,
    Ask::Status,
    Ask::Imu,
    Ask::Rc,
    Ask::Imu,
    Ask::Attitude,
    Ask::Imu,
    Ask::Rc,
    Ask::Imu,
    Ask::Status,
];

/// Requests a second per kind at [`SCHEDULE`]'s pace, for the docs and the tests.
pub fn requests_per_s() -> [(u16, f64); 4] {
    let slot_s = msp_port::MSP_SLOT_US as f64 / 1e6;
    let per_s = |a: Ask| {
        SCHEDULE.iter().filter(|s| **s == a).count() as f64 / (SCHEDULE.len() as f64 * slot_s)
    };
    [Ask::Imu, Ask::Rc, Ask::Status, Ask::Attitude].map(|a| (a.command(), per_s(a)))
}

/// The link's timing, from `[mavlink]` (reconnects) and `[command]` (replies).
#[derive(Clone, Copy, Debug)]
pub struct MspLinkTiming {
    pub reply_timeout: Duration,
    pub reconnect_min: Duration,
    pub reconnect_max: Duration,
    /// The ids the messages are recorded with: the autopilot's own.
    pub autopilot_system_id: u8,
    pub autopilot_component_id: u8,
}

/// Runs forever: open, serve, and on any failure wait and reopen.
pub async fn run(
    endpoint: Endpoint,
    timing: MspLinkTiming,
    clock: DaemonClock,
    outputs: LinkOutputs,
    heartbeat: Heartbeat,
) {
    let mut backoff = timing.reconnect_min;
    loop {
        heartbeat.beat();
        match endpoint.open().await {
            Ok(transport) => {
                tracing::info!(%endpoint, "autopilot telemetry over MSP up");
                backoff = timing.reconnect_min;
                outputs.vehicle.send_modify(|v| v.link_up = true);
                let mut port = MspPort::new(transport);
                let why = serve(&mut port, &endpoint, &timing, &clock, &outputs, &heartbeat).await;
                outputs.vehicle.send_modify(VehicleState::link_lost);
                outputs.attitude.lock().expect("attitude log lock").clear();
                tracing::warn!(%endpoint, "autopilot telemetry over MSP lost: {why}; reopening");
            }
            Err(e) => tracing::warn!(
                %endpoint,
                "cannot open the MSP telemetry port: {e}; retry in {} ms",
                backoff.as_millis()
            ),
        }
        heartbeat.sleep(backoff).await;
        backoff = (backoff * 2).min(timing.reconnect_max);
    }
}

/// Reads the build's mode order, then asks [`SCHEDULE`] round and round until the
/// port fails or a reply does not come; returns why.
async fn serve(
    port: &mut MspPort,
    endpoint: &Endpoint,
    timing: &MspLinkTiming,
    clock: &DaemonClock,
    outputs: &LinkOutputs,
    heartbeat: &Heartbeat,
) -> String {
    let box_ids = match port
        .request(msp_port::MSP_BOXIDS, &[], timing.reply_timeout)
        .await
    {
        Ok(ids) => ids,
        Err(e) => return format!("reading the build's flight modes: {e}"),
    };
    let Some(bits) = fc_check::status_bits(&box_ids) else {
        return "this build has no MSP RC OVERRIDE mode (MSP_BOXIDS): faithd cannot read its status".into();
    };
    let mut reader = Reader::new(bits, timing);
    let mut refusals = 0u64;
    for ask in SCHEDULE.iter().cycle() {
        heartbeat.beat();
        let command = ask.command();
        if let Err(e) = port.send(&msp::encode_request(command, &[])).await {
            return format!("write failed: {e}");
        }
        let payload = match port.reply(command, timing.reply_timeout).await {
            Ok(payload) => payload,
            Err(MspError::Refused { command }) => {
                refusals += 1;
                if refusals.is_power_of_two() {
                    tracing::error!(%endpoint, command, refusals, "the flight controller refused an MSP telemetry request");
                }
                continue;
            }
            Err(e) => return e.to_string(),
        };
        let stamp_us = reply_stamp_us(clock.now_us(), payload.len(), endpoint.baud);
        for msg in reader.read(*ask, &payload, stamp_us) {
            super::record(outputs, clock, stamp_us, reader.header(), &msg);
            super::receive(&msg, stamp_us, &mut reader.sync, outputs);
        }
    }
    unreachable!("the schedule cycles forever")
}

/// The messages a reply to `command` makes on a fresh link (for the fuzzer: any
/// bytes give messages or none, never a panic).
pub fn messages(bits: StatusBits, command: u16, payload: &[u8], stamp_us: i64) -> Vec<MavMessage> {
    let Some(ask) = SCHEDULE.iter().find(|a| a.command() == command) else {
        return Vec::new();
    };
    let timing = MspLinkTiming {
        reply_timeout: Duration::ZERO,
        reconnect_min: Duration::ZERO,
        reconnect_max: Duration::ZERO,
        autopilot_system_id: 1,
        autopilot_component_id: 1,
    };
    let mut reader = Reader::new(bits, &timing);
    reader.read(Ask::Attitude, payload, stamp_us);
    reader.read(*ask, payload, stamp_us)
}

/// When iNav read what a reply of `payload_bytes` carries, received whole at
/// `rx_us`: before it, by the reply's time on the wire (10 bits a byte), to the
/// millisecond that MAVLink's `time_boot_ms` carries too.
pub fn reply_stamp_us(rx_us: i64, payload_bytes: usize, baud: u32) -> i64 {
    let frame_bytes = (9 + payload_bytes) as i64;
    let wire_us = frame_bytes * 10 * 1_000_000 / i64::from(baud.max(1));
    (rx_us - wire_us).div_euclid(1000) * 1000
}

/// Turns MSP replies into the MAVLink messages iNav's telemetry would carry.
struct Reader {
    bits: StatusBits,
    /// The newest MSP_ATTITUDE: roll and pitch in decidegrees, yaw in degrees.
    angles: Option<[i16; 3]>,
    sync: ClockSync,
    header: MavHeader,
}

impl Reader {
    fn new(bits: StatusBits, timing: &MspLinkTiming) -> Self {
        Self {
            bits,
            angles: None,
            sync: ClockSync::new(CLOCK_SYNC_WINDOW),
            header: MavHeader {
                system_id: u32::from(timing.autopilot_system_id),
                component_id: timing.autopilot_component_id,
                sequence: 0,
            },
        }
    }

    /// The header of the next message (its sequence counts the messages made).
    fn header(&mut self) -> MavHeader {
        let header = self.header;
        self.header.sequence = header.sequence.wrapping_add(1);
        header
    }

    /// The messages a reply to `ask` makes; none for a reply too short to be iNav's
    /// (said in the journal) and for the angles alone, which ride on the next gyro.
    fn read(&mut self, ask: Ask, payload: &[u8], stamp_us: i64) -> Vec<MavMessage> {
        let time_boot_ms = (stamp_us / 1000) as u32;
        let made = match ask {
            Ask::Imu => gyro_dps(payload).map(|g| vec![attitude(time_boot_ms, self.angles, g)]),
            Ask::Rc => Some(vec![rc_channels(time_boot_ms, payload)]),
            Ask::Status => self
                .bits
                .decode(payload)
                .map(|flags| vec![heartbeat(flags), sys_status(flags)]),
            Ask::Attitude => {
                self.angles = angles(payload);
                self.angles.map(|_| Vec::new())
            }
        };
        made.unwrap_or_else(|| {
            tracing::warn!(
                command = ask.command(),
                bytes = payload.len(),
                "MSP telemetry reply too short; ignored"
            );
            Vec::new()
        })
    }
}

fn i16_at(payload: &[u8], index: usize) -> Option<i16> {
    let at = 2 * index;
    Some(i16::from_le_bytes(
        payload.get(at..at + 2)?.try_into().ok()?,
    ))
}

/// MSP_RAW_IMU's gyro: the 4th to 6th int16.
fn gyro_dps(payload: &[u8]) -> Option<[i16; 3]> {
    Some([
        i16_at(payload, 3)?,
        i16_at(payload, 4)?,
        i16_at(payload, 5)?,
    ])
}

/// MSP_ATTITUDE: roll, pitch (decidegrees), yaw (degrees).
fn angles(payload: &[u8]) -> Option<[i16; 3]> {
    Some([
        i16_at(payload, 0)?,
        i16_at(payload, 1)?,
        i16_at(payload, 2)?,
    ])
}

/// ATTITUDE as iNav's MAVLink telemetry makes it (telemetry/mavlink.c): the angles
/// in radians with pitch negated (nose up positive), the rates in degrees per second
/// as the gyro gives them, which [`super::telemetry::attitude_sample`] reads. Before
/// the first MSP_ATTITUDE the angles are level; derotation uses the rates alone.
fn attitude(time_boot_ms: u32, angles: Option<[i16; 3]>, gyro_dps: [i16; 3]) -> MavMessage {
    let [roll_ddeg, pitch_ddeg, yaw_deg] = angles.unwrap_or([0; 3]);
    let rad = |deg: f64| deg.to_radians() as f32;
    let yaw_rad = (f64::from(yaw_deg) + 180.0).rem_euclid(360.0) - 180.0;
    MavMessage::ATTITUDE(ATTITUDE_DATA {
        time_boot_ms,
        roll: rad(f64::from(roll_ddeg) / 10.0),
        pitch: rad(-f64::from(pitch_ddeg) / 10.0),
        yaw: rad(yaw_rad),
        rollspeed: f32::from(gyro_dps[0]),
        pitchspeed: f32::from(gyro_dps[1]),
        yawspeed: f32::from(gyro_dps[2]),
    })
}

/// RC_CHANNELS from MSP_RC: the channels iNav uses, as many as it has (at most the
/// 18 RC_CHANNELS carries), the rest unused (65535).
fn rc_channels(time_boot_ms: u32, payload: &[u8]) -> MavMessage {
    let mut values = [u16::MAX; 18];
    for (v, got) in values.iter_mut().zip(msp_port::rc_values(payload)) {
        *v = got;
    }
    let count = (payload.len() / 2).min(18) as u8;
    MavMessage::RC_CHANNELS(RC_CHANNELS_DATA {
        time_boot_ms,
        chancount: count,
        chan1_raw: values[0],
        chan2_raw: values[1],
        chan3_raw: values[2],
        chan4_raw: values[3],
        chan5_raw: values[4],
        chan6_raw: values[5],
        chan7_raw: values[6],
        chan8_raw: values[7],
        chan9_raw: values[8],
        chan10_raw: values[9],
        chan11_raw: values[10],
        chan12_raw: values[11],
        chan13_raw: values[12],
        chan14_raw: values[13],
        chan15_raw: values[14],
        chan16_raw: values[15],
        chan17_raw: values[16],
        chan18_raw: values[17],
        rssi: u8::MAX,
    })
}

/// HEARTBEAT from MSP2_INAV_STATUS: armed, and iNav's failsafe as MAV_STATE_CRITICAL
/// (what telemetry/mavlink.c says during it).
fn heartbeat(flags: StatusFlags) -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_GENERIC,
        autopilot: MavAutopilot::MAV_AUTOPILOT_GENERIC,
        base_mode: if flags.armed {
            MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED
        } else {
            MavModeFlag::empty()
        },
        system_status: if flags.failsafe {
            MavState::MAV_STATE_CRITICAL
        } else {
            MavState::MAV_STATE_ACTIVE
        },
        mavlink_version: 3,
    })
}

/// SYS_STATUS with the receiver's health: over MSP, iNav says nothing of its
/// receiver before its failsafe, so the radio reads lost from the FAILSAFE mode on.
fn sys_status(flags: StatusFlags) -> MavMessage {
    let rc = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_RC_RECEIVER;
    MavMessage::SYS_STATUS(SYS_STATUS_DATA {
        onboard_control_sensors_present: rc,
        onboard_control_sensors_enabled: rc,
        onboard_control_sensors_health: if flags.failsafe {
            MavSysStatusSensor::empty()
        } else {
            rc
        },
        ..Default::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::telemetry::{self, Update};

    fn bits() -> StatusBits {
        StatusBits {
            failsafe: Some(2),
            msp_override: 1,
            angle: Some(0),
        }
    }

    fn timing() -> MspLinkTiming {
        MspLinkTiming {
            reply_timeout: Duration::from_millis(500),
            reconnect_min: Duration::from_millis(100),
            reconnect_max: Duration::from_secs(2),
            autopilot_system_id: 1,
            autopilot_component_id: 1,
        }
    }

    fn i16s(values: &[i16]) -> Vec<u8> {
        values.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    /// iNav's gyro over MSP is the same gyroADCf that its MAVLink ATTITUDE carries,
    /// rounded to whole degrees per second: derotation reads it the same way
    /// (forward-left-up in degrees, to forward-right-down in radians).
    #[test]
    fn the_gyro_becomes_the_rates_of_attitude_as_mavlink_would_carry_them() {
        let mut reader = Reader::new(bits(), &timing());
        assert!(
            reader
                .read(Ask::Attitude, &i16s(&[-91, 66, 350]), 1_000)
                .is_empty()
        );
        let imu = i16s(&[0, 0, 512, -38, 12, 4, 0, 0, 0]);
        let msgs = reader.read(Ask::Imu, &imu, 13_240_000);
        let [MavMessage::ATTITUDE(a)] = &msgs[..] else {
            panic!("{msgs:?}")
        };
        assert_eq!(a.time_boot_ms, 13_240);
        assert_eq!((a.rollspeed, a.pitchspeed, a.yawspeed), (-38.0, 12.0, 4.0));
        assert!((f64::from(a.roll) - (-9.1f64).to_radians()).abs() < 1e-6);
        assert!(
            (f64::from(a.pitch) - (-6.6f64).to_radians()).abs() < 1e-6,
            "nose up positive"
        );
        assert!(
            (f64::from(a.yaw) - (-10f64).to_radians()).abs() < 1e-6,
            "350 deg is -10"
        );
        let s = telemetry::attitude_sample(7, a);
        assert!((s.roll_rate_rad_s - (-38f64).to_radians()).abs() < 1e-9);
        assert!((s.pitch_rate_rad_s - (-12f64).to_radians()).abs() < 1e-9);
        assert!((s.yaw_rate_rad_s - (-4f64).to_radians()).abs() < 1e-9);
    }

    #[test]
    fn status_makes_a_heartbeat_and_the_radio_reads_lost_in_failsafe() {
        let mut reader = Reader::new(bits(), &timing());
        // cycle time .. profile (9 bytes), arming flags (ARMED), modes: ANGLE, override.
        let mut status = vec![0u8; 9];
        status.extend_from_slice(&(1u32 << 2).to_le_bytes());
        status.extend_from_slice(&[0b011, 0, 0, 0]);
        let mut state = VehicleState::default();
        let mut sync = ClockSync::new(10);
        for msg in reader.read(Ask::Status, &status, 5_000) {
            telemetry::apply(&mut state, &mut sync, &msg, 5_000);
        }
        let hb = state.heartbeat.expect("a heartbeat");
        assert!(hb.armed && !hb.in_failsafe());
        assert!(state.radio.unwrap().healthy);
        status[13] |= 0b100;
        for msg in reader.read(Ask::Status, &status, 6_000) {
            telemetry::apply(&mut state, &mut sync, &msg, 6_000);
        }
        assert!(state.heartbeat.unwrap().in_failsafe());
        assert!(!state.radio.unwrap().healthy);
        assert!(reader.read(Ask::Status, &status[..12], 7_000).is_empty());
    }

    #[test]
    fn the_pilots_channels_as_many_as_inav_has() {
        let mut reader = Reader::new(bits(), &timing());
        let rc: Vec<u8> = [1440u16, 1500, 1500, 1400, 1900, 1850]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let mut state = VehicleState::default();
        let mut sync = ClockSync::new(10);
        let msgs = reader.read(Ask::Rc, &rc, 9_000);
        assert_eq!(
            telemetry::apply(&mut state, &mut sync, &msgs[0], 9_000),
            Update::Rc
        );
        let rc = state.rc.unwrap();
        assert_eq!(rc.channel_us(6), Some(1850));
        assert_eq!(rc.channel_us(7), None);
    }

    #[test]
    fn a_reply_is_stamped_before_its_time_on_the_wire() {
        // MSP_RAW_IMU's 27 bytes take 2.34 ms at 115200 baud.
        assert_eq!(reply_stamp_us(100_000, 18, 115_200), 97_000);
        assert_eq!(reply_stamp_us(102_400, 18, 115_200), 100_000);
    }

    #[test]
    fn the_schedule_keeps_within_half_of_what_the_port_serves() {
        let rates = requests_per_s();
        let total: f64 = rates.iter().map(|(_, r)| r).sum();
        assert!((total - 50.0).abs() < 1e-9, "{total}");
        assert_eq!(rates[0], (MSP_RAW_IMU, 25.0));
    }
}
