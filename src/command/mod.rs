//! How a roll reaches the flight controller, and whether it can.
//!
//! One route flies: iNav's MSP RC override, streamed on a UART of its own
//! ([`stream`]), after the flight controller's set-up has been read and judged
//! ([`fc_check`]). RC_CHANNELS_OVERRIDE over MAVLink does not work beside a pilot's
//! radio (iNav reads it only when MAVLink *is* the receiver, and then the pilot's
//! and faithd's frames take turns per channel, with no release), so
//! `sink = "mavlink"` is refused with that reason.

pub mod fc_check;
pub mod msp;
pub mod msp_port;
pub mod stream;

use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SinkKind {
    /// Refused: kept so that an old config gets the reason, not "unknown variant".
    Mavlink,
    #[default]
    Msp,
}

/// Why `sink = "mavlink"` is refused, measured on iNav 9.1 SITL.
pub const MAVLINK_SINK_REFUSED: &str = "is refused: iNav ignores RC_CHANNELS_OVERRIDE unless MAVLink is its receiver, and then the pilot's and faithd's frames take turns on the roll channel (the roll was in effect in 37-62% of samples) and 0/65535 cannot release it; use sink = \"msp\" (README, Setting up iNav)";

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CommandConfig {
    /// "msp": iNav's MSP RC override on a UART of its own (the only route that flies).
    pub sink: SinkKind,
    /// UART of the MSP stream and its baud rate.
    pub msp_endpoint: String,
    pub msp_baud: u32,
    /// A roll that iNav does not report using (MSP_RC) within this is a fault: the
    /// journal says so and the gate closes until the pilot leaves AUTO.
    pub confirm_within_us: i64,
    /// Replies from the flight controller (set-up reads, MSP_RC) must come within this.
    pub msp_timeout_us: i64,
    /// Extra wait after iNav's own override recovery delay before the gate may open.
    pub warmup_margin_us: i64,
}

impl Default for CommandConfig {
    fn default() -> Self {
        Self {
            sink: SinkKind::Msp,
            msp_endpoint: "serial:/dev/ttyAMA1".into(),
            msp_baud: 115_200,
            confirm_within_us: 200_000,
            msp_timeout_us: 500_000,
            warmup_margin_us: 100_000,
        }
    }
}
