//! How a roll reaches the flight controller, and whether it can.
//!
//! One route flies: iNav's MSP RC override, streamed on a UART of its own
//! ([`stream`]), after the flight controller's set-up has been read and judged
//! ([`fc_check`]). RC_CHANNELS_OVERRIDE over MAVLink does not work beside a pilot's
//! radio (iNav reads it only when MAVLink *is* the receiver, and then the pilot's
//! and faithd's frames take turns per channel, with no release), so
//! `[command.sink] kind = "mavlink"` is refused with that reason.

pub mod fc_check;
pub mod msp;
pub mod msp_port;
pub mod rxrange;
pub mod stream;

use serde::{Deserialize, Serialize};

use crate::transport::{Address, Endpoint};
use faithd_core::invalid::{Invalid, check};
use faithd_core::safety::gate::GateConfig;
use faithd_core::safety::manoeuvre::ManoeuvreConfig;
use faithd_core::safety::rc::{NEUTRAL_US, RcChannel};
use msp_port::{INAV_MSP_SIGNAL_TIMEOUT_US, MSP_SLOT_US};
use rxrange::RxRange;

/// iNav's first AUX channel: its modes (MSP RC OVERRIDE among them) bind to AUX.
pub const FIRST_AUX_CHANNEL: u8 = 5;

/// Why `kind = "mavlink"` is refused, as measured on iNav 9.1 SITL (docs/inav.md has
/// the figures).
pub const MAVLINK_SINK_REFUSED: &str = "is refused: iNav ignores RC_CHANNELS_OVERRIDE unless MAVLink is its receiver, and then the pilot's and faithd's frames take turns on the roll channel and 0/65535 cannot release it; use kind = \"msp\" (docs/inav.md)";

/// How rolls reach iNav: `[command.sink]`, a `kind` and that kind's own settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "SinkTable", into = "SinkTable")]
pub enum Sink {
    /// iNav's MSP RC override on a UART of its own (the only route that flies).
    Msp(MspSink),
}

impl Default for Sink {
    fn default() -> Self {
        Sink::Msp(MspSink::default())
    }
}

/// `kind = "msp"`: the UART to iNav's MSP port.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MspSink {
    pub endpoint: Address,
    pub baud: u32,
}

impl Default for MspSink {
    fn default() -> Self {
        Self {
            endpoint: Address::Serial("/dev/ttyAMA1".into()),
            baud: 115_200,
        }
    }
}

/// `[command.sink]` as written. A MAVLink sink is read only to be refused with the
/// reason (an old config gets that, not "unknown variant"); [`Sink`] cannot hold one.
#[derive(Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
enum SinkTable {
    Msp(MspSink),
    Mavlink {},
}

impl TryFrom<SinkTable> for Sink {
    type Error = String;

    fn try_from(table: SinkTable) -> Result<Self, String> {
        match table {
            SinkTable::Msp(msp) => Ok(Sink::Msp(msp)),
            SinkTable::Mavlink {} => Err(format!("kind \"mavlink\" {MAVLINK_SINK_REFUSED}")),
        }
    }
}

impl From<Sink> for SinkTable {
    fn from(sink: Sink) -> Self {
        match sink {
            Sink::Msp(msp) => SinkTable::Msp(msp),
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CommandConfig {
    pub sink: Sink,
    /// A roll that iNav does not report using (MSP_RC) within this is a fault: the
    /// journal says so and the gate closes until the pilot leaves AUTO.
    pub confirm_within_us: i64,
    /// Replies from the flight controller (set-up reads, MSP_RC) must come within this.
    pub msp_timeout_us: i64,
    /// Extra wait after iNav's own override recovery delay before the gate may open.
    pub warmup_margin_us: i64,
    /// iNav's calibration of roll (`rxrange 0 MIN MAX` in its CLI): iNav scales every
    /// value on roll, faithd's included, from this range to 1000..2000. faithd aims
    /// its values through it; `faithd check-fc` reads iNav's and compares.
    pub roll_rxrange_us: RxRange,
    /// The longest iNav may keep faithd's last roll value after faithd stops (a
    /// crash, a kill): `faithd check-fc` and the daemon refuse a failsafe_delay that
    /// makes iNav's hold (0.4 s + failsafe_delay) longer.
    pub max_hold_after_stop_us: i64,
}

impl Default for CommandConfig {
    fn default() -> Self {
        Self {
            sink: Sink::default(),
            confirm_within_us: 200_000,
            msp_timeout_us: 500_000,
            warmup_margin_us: 100_000,
            roll_rxrange_us: RxRange::DEFAULT,
            max_hold_after_stop_us: 1_000_000,
        }
    }
}

impl CommandConfig {
    /// The port of the MSP stream.
    pub fn msp_port(&self) -> Endpoint {
        let Sink::Msp(msp) = &self.sink;
        Endpoint::new(msp.endpoint.clone(), msp.baud)
    }

    /// `[command]`: the sink's baud rate and the stream's timings.
    pub fn validate(&self) -> Result<(), Invalid> {
        let Sink::Msp(msp) = &self.sink;
        check(msp.baud >= 1200, "command.sink.baud", || {
            format!("must be a serial baud rate, got {}", msp.baud)
        })?;
        let cmd = self;
        check(
            (20_000..=1_000_000).contains(&cmd.confirm_within_us),
            "command.confirm_within_us",
            || format!("must be 20 ms to 1 s, got {}", cmd.confirm_within_us),
        )?;
        check(
            (10_000..=5_000_000).contains(&cmd.msp_timeout_us),
            "command.msp_timeout_us",
            || format!("must be 10 ms to 5 s, got {}", cmd.msp_timeout_us),
        )?;
        check(
            (0..=5_000_000).contains(&cmd.warmup_margin_us),
            "command.warmup_margin_us",
            || format!("must be 0 to 5 s, got {}", cmd.warmup_margin_us),
        )?;
        check(
            (400_000..=20_400_000).contains(&cmd.max_hold_after_stop_us),
            "command.max_hold_after_stop_us",
            || {
                format!(
                    "must be 0.4 s (iNav's hold with failsafe_delay = 0) to 20.4 s, got {}",
                    cmd.max_hold_after_stop_us
                )
            },
        )
    }

    /// What the route asks of the other sections: for iNav's MSP override, the
    /// pilot's switch on an AUX channel, a roll frame period the MSP slots carry and
    /// iNav does not time out, and a roll that lands through `rxrange`. A new route
    /// adds its own arm here.
    pub fn validate_route(
        &self,
        gate: &GateConfig,
        manoeuvre: &ManoeuvreConfig,
    ) -> Result<(), Invalid> {
        match &self.sink {
            Sink::Msp(_) => {
                validate_msp_switch(gate)?;
                validate_msp_period(manoeuvre)?;
                validate_msp_rxrange(self.roll_rxrange_us, manoeuvre)
            }
        }
    }
}

/// iNav binds its MSP RC OVERRIDE mode (and every mode) to AUX channels only.
fn validate_msp_switch(g: &GateConfig) -> Result<(), Invalid> {
    check(
        g.switch_channel.get() >= FIRST_AUX_CHANNEL,
        "gate.switch_channel",
        || {
            format!(
                "must be an AUX channel {FIRST_AUX_CHANNEL} to {} (iNav binds its MSP RC OVERRIDE mode to AUX channels), got {}",
                RcChannel::MAX,
                g.switch_channel
            )
        },
    )
}

/// The roll frame every other MSP slot at most, and often enough that iNav does not
/// drop the override between frames.
fn validate_msp_period(m: &ManoeuvreConfig) -> Result<(), Invalid> {
    let max_period_us = INAV_MSP_SIGNAL_TIMEOUT_US / 2;
    check(
        m.resend_period_us >= 2 * MSP_SLOT_US
            && m.resend_period_us <= max_period_us
            && m.resend_period_us % MSP_SLOT_US == 0,
        "manoeuvre.resend_period_us",
        || {
            format!(
                "must be a multiple of {} ms from {} to {} ms: iNav serves one MSP command per port every 10 ms and faithd uses at most half of that (one command per {} ms, the roll frame every other one at most), and iNav drops the override after {} ms without a frame; got {}",
                MSP_SLOT_US / 1000,
                2 * MSP_SLOT_US / 1000,
                max_period_us / 1000,
                MSP_SLOT_US / 1000,
                INAV_MSP_SIGNAL_TIMEOUT_US / 1000,
                m.resend_period_us
            )
        },
    )
}

/// Every value faithd sends on roll (the centre, left, right) lands through iNav's
/// `rxrange` within 1 us of what faithd means.
fn validate_msp_rxrange(range: RxRange, m: &ManoeuvreConfig) -> Result<(), Invalid> {
    for wanted_us in [
        NEUTRAL_US,
        NEUTRAL_US - m.deflection_us,
        NEUTRAL_US + m.deflection_us,
    ] {
        check(
            range.aim(wanted_us).is_some(),
            "command.roll_rxrange_us",
            || {
                format!(
                    "iNav scales roll from {range} to 1000..2000: no value faithd can send lands within 1 us of {wanted_us}"
                )
            },
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_roll_frame_period_fits_the_msp_budget_and_inavs_timeout() {
        for (period_us, ok) in [
            (20_000, false),
            (30_000, false),
            (40_000, true),
            (60_000, true),
            (100_000, true),
            (120_000, false),
        ] {
            let m = ManoeuvreConfig {
                resend_period_us: period_us,
                ..Default::default()
            };
            let route = CommandConfig::default().validate_route(&GateConfig::default(), &m);
            assert_eq!(route.is_ok(), ok, "{period_us}");
        }
    }
}
