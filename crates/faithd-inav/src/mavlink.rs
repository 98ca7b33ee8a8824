//! iNav's MAVLink telemetry as faithd meets it, built in one place for every simulated
//! iNav: the closed loop's (`super::autopilot`) and the test suite's mock on a
//! pseudo-terminal. Shapes follow iNav 9.1's telemetry/mavlink.c: HEARTBEAT of a
//! quadrotor (CRITICAL in failsafe), RC_CHANNELS in the order iNav reports them
//! (roll, pitch, throttle, yaw, then the AUX channels), SYS_STATUS with the RC
//! receiver's health.

use mavlink::dialects::common::*;
use mavlink::{MavHeader, MavlinkVersion};

/// HEARTBEAT: armed or not, and iNav's state (`MAV_STATE_CRITICAL` in failsafe).
pub fn heartbeat(armed: bool, system_status: MavState) -> MavMessage {
    let mut base_mode = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
    if armed {
        base_mode |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
    }
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_QUADROTOR,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode,
        system_status,
        mavlink_version: 3,
    })
}

/// RC_CHANNELS: the first eight channels iNav uses, in its report order.
pub fn rc_channels(boot_ms: u32, channels_us: [u16; 8], rssi: u8) -> MavMessage {
    let [c1, c2, c3, c4, c5, c6, c7, c8] = channels_us;
    MavMessage::RC_CHANNELS(RC_CHANNELS_DATA {
        time_boot_ms: boot_ms,
        chan1_raw: c1,
        chan2_raw: c2,
        chan3_raw: c3,
        chan4_raw: c4,
        chan5_raw: c5,
        chan6_raw: c6,
        chan7_raw: c7,
        chan8_raw: c8,
        chancount: 8,
        rssi,
        ..Default::default()
    })
}

/// SYS_STATUS: the RC receiver present and enabled, healthy or not (the pilot's radio
/// lost), beside a healthy gyro.
pub fn sys_status(radio_healthy: bool) -> MavMessage {
    let rc = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_RC_RECEIVER;
    let gyro = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO;
    MavMessage::SYS_STATUS(SYS_STATUS_DATA {
        onboard_control_sensors_present: rc | gyro,
        onboard_control_sensors_enabled: rc | gyro,
        onboard_control_sensors_health: if radio_healthy { rc | gyro } else { gyro },
        ..Default::default()
    })
}

/// Appends `msg` as a MAVLink 2 frame from iNav (system 1, component 1) and advances
/// the sequence number.
pub fn encode(out: &mut Vec<u8>, sequence: &mut u8, msg: &MavMessage) {
    let header = MavHeader {
        system_id: 1,
        component_id: 1,
        sequence: *sequence,
    };
    *sequence = sequence.wrapping_add(1);
    // Writing to a Vec cannot fail.
    let _ = mavlink::write_versioned_msg(out, MavlinkVersion::V2, header, msg);
}
