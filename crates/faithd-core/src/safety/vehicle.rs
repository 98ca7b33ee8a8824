//! What the daemon knows about the vehicle, as of the last messages received.
//!
//! Filled by the MAVLink adapter, read by the safety gate. Every field carries the
//! daemon time it was received at, so staleness is a subtraction.

/// The autopilot's last HEARTBEAT.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Heartbeat {
    pub t_us: i64,
    /// MAV_MODE_FLAG_SAFETY_ARMED of base_mode.
    pub armed: bool,
    /// The autopilot's flight mode number (iNav maps its modes to ArduPilot's).
    pub custom_mode: u32,
    /// HEARTBEAT system_status (MAV_STATE): iNav says CRITICAL while its failsafe
    /// is active (telemetry/mavlink.c).
    pub system_status: u8,
}

/// MAV_STATE values that mean the autopilot is in trouble: CRITICAL (iNav: failsafe
/// active), EMERGENCY, POWEROFF, FLIGHT_TERMINATION.
const MAV_STATE_CRITICAL: u8 = 5;

impl Heartbeat {
    /// The autopilot reports a failsafe or worse: faithd has no business rolling.
    pub fn in_failsafe(&self) -> bool {
        self.system_status >= MAV_STATE_CRITICAL
    }
}

/// The pilot's radio as the autopilot judges it (SYS_STATUS, the RC receiver's
/// health bit: iNav clears it the moment frames stop, before its failsafe starts).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadioHealth {
    pub t_us: i64,
    pub healthy: bool,
}

/// The autopilot's last RC_CHANNELS: what the pilot's radio says.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RcChannels {
    pub t_us: i64,
    /// Channels the autopilot reports as present (chancount).
    pub count: u8,
    /// chan1_raw .. chan18_raw, microseconds.
    pub values_us: [u16; 18],
}

impl RcChannels {
    /// Value of a 1-based channel, `None` when the autopilot does not report it
    /// (beyond chancount, or the MAVLink "unused" value 65535).
    pub fn channel_us(&self, channel: u8) -> Option<u16> {
        if channel == 0 || channel > self.count {
            return None;
        }
        let v = *self.values_us.get(usize::from(channel) - 1)?;
        (v != u16::MAX).then_some(v)
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VehicleState {
    /// The transport to the autopilot is open.
    pub link_up: bool,
    pub heartbeat: Option<Heartbeat>,
    pub rc: Option<RcChannels>,
    /// Daemon time of the last ATTITUDE (the samples themselves go to the pipeline).
    pub last_attitude_us: Option<i64>,
    /// The pilot's receiver, when the autopilot reports it (SYS_STATUS).
    pub radio: Option<RadioHealth>,
}

impl VehicleState {
    /// Forgets everything received: after a reconnect nothing old may open the gate.
    pub fn link_lost(&mut self) {
        *self = VehicleState::default();
    }
}
