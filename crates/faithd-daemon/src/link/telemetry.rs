//! Turns the autopilot's MAVLink messages into vehicle state and attitude samples.

use mavlink::dialects::common::{ATTITUDE_DATA, MavMessage, MavModeFlag, MavSysStatusSensor};

use super::clock_sync::ClockSync;
use faithd_core::attitude::AttitudeSample;
use faithd_core::safety::vehicle::{Heartbeat, RadioHealth, RcChannels, VehicleState};

/// What one received message changed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Update {
    Heartbeat,
    Rc,
    /// SYS_STATUS with the pilot's receiver in it.
    Radio,
    Attitude(AttitudeSample),
    /// Not a message faithd uses.
    Ignored,
}

/// An ATTITUDE message from iNav as a core sample stamped `t_us`.
///
/// The angles are MAVLink's (radians; iNav 9.1 src/main/telemetry/mavlink.c:723-728
/// negates its own pitch to give MAVLink's nose-up positive). The rates are not:
/// mavlink.c:729-734 sends `gyro.gyroADCf` as they are, which is degrees per second
/// (src/main/sensors/gyro.c:420 converts it to radians only for the IMU) in iNav's
/// body frame, forward-left-up (flight/imu.c:624-626), where a positive pitch rate
/// lowers the nose and a positive yaw rate turns it left. Derotation wants radians
/// per second about forward-right-down: roll as sent, pitch and yaw negated. Read
/// as MAVLink's radians, a 38 deg/s roll was a 38 rad/s one (seen on iNav's SITL
/// flying the lab's quad-X: the FOE 115 px off and no roll on a collision course).
pub fn attitude_sample(t_us: i64, a: &ATTITUDE_DATA) -> AttitudeSample {
    let rate_rad_s = |deg_s: f32| f64::from(deg_s).to_radians();
    AttitudeSample {
        t_us,
        roll_rad: f64::from(a.roll),
        pitch_rad: f64::from(a.pitch),
        yaw_rad: f64::from(a.yaw),
        roll_rate_rad_s: rate_rad_s(a.rollspeed),
        pitch_rate_rad_s: -rate_rad_s(a.pitchspeed),
        yaw_rate_rad_s: -rate_rad_s(a.yawspeed),
    }
}

/// Applies `msg`, received at daemon time `rx_us`, to `state`.
pub fn apply(
    state: &mut VehicleState,
    sync: &mut ClockSync,
    msg: &MavMessage,
    rx_us: i64,
) -> Update {
    match msg {
        MavMessage::HEARTBEAT(hb) => {
            state.heartbeat = Some(Heartbeat {
                t_us: rx_us,
                armed: hb
                    .base_mode
                    .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED),
                custom_mode: hb.custom_mode,
                system_status: hb.system_status as u8,
            });
            Update::Heartbeat
        }
        MavMessage::SYS_STATUS(st) => {
            let rc = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_RC_RECEIVER;
            if !st.onboard_control_sensors_present.contains(rc) {
                return Update::Ignored;
            }
            state.radio = Some(RadioHealth {
                t_us: rx_us,
                healthy: st.onboard_control_sensors_health.contains(rc),
            });
            Update::Radio
        }
        MavMessage::RC_CHANNELS(rc) => {
            state.rc = Some(RcChannels {
                t_us: rx_us,
                count: rc.chancount.min(18),
                values_us: [
                    rc.chan1_raw,
                    rc.chan2_raw,
                    rc.chan3_raw,
                    rc.chan4_raw,
                    rc.chan5_raw,
                    rc.chan6_raw,
                    rc.chan7_raw,
                    rc.chan8_raw,
                    rc.chan9_raw,
                    rc.chan10_raw,
                    rc.chan11_raw,
                    rc.chan12_raw,
                    rc.chan13_raw,
                    rc.chan14_raw,
                    rc.chan15_raw,
                    rc.chan16_raw,
                    rc.chan17_raw,
                    rc.chan18_raw,
                ],
            });
            Update::Rc
        }
        MavMessage::ATTITUDE(a) => {
            let values = [
                a.roll,
                a.pitch,
                a.yaw,
                a.rollspeed,
                a.pitchspeed,
                a.yawspeed,
            ];
            if values.iter().any(|v| !v.is_finite()) {
                // A corrupt sample must not reach derotation; freshness is not renewed.
                return Update::Ignored;
            }
            let t_us = sync.observe(i64::from(a.time_boot_ms) * 1000, rx_us);
            state.last_attitude_us = Some(rx_us);
            Update::Attitude(attitude_sample(t_us, a))
        }
        _ => Update::Ignored,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::common::{HEARTBEAT_DATA, RC_CHANNELS_DATA};

    /// What iNav's SITL sent while the lab's quad-X rolled left at about 38 deg/s and
    /// lowered its nose at about 11 deg/s: rates in degrees per second, pitch positive
    /// nose down. Derotation gets radians per second, nose up positive.
    #[test]
    fn inavs_rates_in_degrees_about_forward_left_up_become_radians_about_frd() {
        let a = ATTITUDE_DATA {
            time_boot_ms: 13_240,
            roll: -0.091,
            pitch: -0.066,
            yaw: 0.079,
            rollspeed: -38.488,
            pitchspeed: 11.509,
            yawspeed: 4.0,
        };
        let s = attitude_sample(7, &a);
        assert!((s.roll_rate_rad_s - (-38.488f64).to_radians()).abs() < 1e-6);
        assert!((s.pitch_rate_rad_s - (-11.509f64).to_radians()).abs() < 1e-6);
        assert!((s.yaw_rate_rad_s - (-4.0f64).to_radians()).abs() < 1e-6);
        // The angles are MAVLink's already.
        assert_eq!(s.roll_rad, f64::from(a.roll));
        assert_eq!(s.pitch_rad, f64::from(a.pitch));
    }

    #[test]
    fn heartbeat_armed_flag_and_rc_count() {
        let mut state = VehicleState::default();
        let mut sync = ClockSync::new(10);
        let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            base_mode: MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED,
            custom_mode: 2,
            system_status: mavlink::dialects::common::MavState::MAV_STATE_CRITICAL,
            ..Default::default()
        });
        assert_eq!(apply(&mut state, &mut sync, &hb, 5), Update::Heartbeat);
        let h = state.heartbeat.unwrap();
        assert!(h.armed);
        assert!(h.in_failsafe(), "iNav's failsafe is MAV_STATE_CRITICAL");
        assert_eq!((h.t_us, h.custom_mode), (5, 2));
        let rc = MavMessage::RC_CHANNELS(RC_CHANNELS_DATA {
            chancount: 6,
            chan6_raw: 1900,
            chan7_raw: 1000,
            ..Default::default()
        });
        apply(&mut state, &mut sync, &rc, 7);
        let rc = state.rc.unwrap();
        assert_eq!(rc.channel_us(6), Some(1900));
        assert_eq!(rc.channel_us(7), None, "beyond chancount");
        assert_eq!(rc.channel_us(0), None);
    }

    #[test]
    fn sys_status_reports_the_pilots_receiver() {
        use mavlink::dialects::common::SYS_STATUS_DATA;
        let mut state = VehicleState::default();
        let mut sync = ClockSync::new(10);
        let rc = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_RC_RECEIVER;
        let gyro = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO;
        let lost = MavMessage::SYS_STATUS(SYS_STATUS_DATA {
            onboard_control_sensors_present: rc | gyro,
            onboard_control_sensors_health: gyro,
            ..Default::default()
        });
        assert_eq!(apply(&mut state, &mut sync, &lost, 3), Update::Radio);
        assert_eq!(
            state.radio,
            Some(RadioHealth {
                t_us: 3,
                healthy: false
            })
        );
        let no_receiver = MavMessage::SYS_STATUS(SYS_STATUS_DATA {
            onboard_control_sensors_present: gyro,
            ..Default::default()
        });
        assert_eq!(
            apply(&mut state, &mut sync, &no_receiver, 4),
            Update::Ignored
        );
    }

    #[test]
    fn corrupt_attitude_is_ignored_and_does_not_refresh() {
        let mut state = VehicleState::default();
        let mut sync = ClockSync::new(10);
        let bad = MavMessage::ATTITUDE(ATTITUDE_DATA {
            rollspeed: f32::NAN,
            ..Default::default()
        });
        assert_eq!(apply(&mut state, &mut sync, &bad, 9), Update::Ignored);
        assert_eq!(state.last_attitude_us, None);
        let good = MavMessage::ATTITUDE(ATTITUDE_DATA {
            time_boot_ms: 100,
            // iNav's degrees per second, nose left positive.
            yawspeed: 30.0,
            ..Default::default()
        });
        let Update::Attitude(s) = apply(&mut state, &mut sync, &good, 1_100_000) else {
            panic!()
        };
        assert_eq!(s.t_us, 1_100_000);
        assert!((s.yaw_rate_rad_s + 30f64.to_radians()).abs() < 1e-9);
    }
}
