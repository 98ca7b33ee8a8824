//! Does the flight controller's set-up let faithd's roll route work?
//!
//! iNav decides on its own whether an MSP roll override is applied, when, and for
//! how long it outlives faithd. Every fact below was read from iNav 9.1's source and
//! measured on its SITL build (docs/inav.md); a set-up that is known to
//! fail is refused with the iNav CLI line that fixes it, before the gate can open.
//! `read` talks MSP; `evaluate` is pure and unit-tested.

use std::time::Duration;

use super::rxrange::RxRange;
use super::{CommandConfig, FIRST_AUX_CHANNEL};
use faithd_core::safety::gate::GateConfig;
use faithd_core::safety::rc::NEUTRAL_US;

use super::msp_port::{self, MspError, MspPort};

/// iNav's mode ids (fc/fc_msp_box.c, permanent ids).
const MODE_ARM: u8 = 0;
const MODE_ANGLE: u8 = 1;
const MODE_FAILSAFE: u8 = 27;
const MODE_MSP_RC_OVERRIDE: u8 = 50;
/// fc/runtime_config.h: ARMED in MSP2_INAV_STATUS's arming flags.
const ARMING_FLAG_ARMED: u32 = 1 << 2;
/// iNav's telemetry task ticks at 50 Hz (telemetry/mavlink.c, TELEMETRY_MAVLINK_MAXRATE).
const MAVLINK_TICK_US: i64 = 20_000;
/// rx/rx.h and flight/failsafe.h: PERIOD_RXDATA_RECOVERY and PERIOD_RXDATA_FAILURE.
const RXDATA_PERIOD_US: i64 = 200_000;
/// rx/msp.c: iNav notices that MSP frames stopped this long after the last one
/// (`rxSignalTimeout = DELAY_5_HZ`), and only then starts its failure period.
const MSP_SIGNAL_TIMEOUT_US: i64 = 200_000;
/// receiver_type's table in fc/settings.yaml.
const RECEIVER_TYPES: [&str; 4] = ["NONE", "SERIAL", "MSP", "SIM (SITL)"];
/// serial_rx's table in fc/settings.yaml.
const SERIAL_RX: [&str; 15] = [
    "SPEK1024",
    "SPEK2048",
    "SBUS",
    "SUMD",
    "IBUS",
    "JETIEXBUS",
    "CRSF",
    "FPORT",
    "SBUS_FAST",
    "FPORT2",
    "SRXL2",
    "GHST",
    "MAVLINK",
    "FBUS",
    "SBUS2",
];

/// One mode slot of iNav's `aux` table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ModeRange {
    pub slot: usize,
    pub mode_id: u8,
    /// 0 = AUX1 = channel 5.
    pub aux_index: u8,
    pub start_step: u8,
    pub end_step: u8,
}

impl ModeRange {
    /// A range is in use when it is not empty (rc_modes.h, IS_RANGE_USABLE).
    pub fn usable(&self) -> bool {
        self.start_step < self.end_step
    }

    pub fn channel(&self) -> u8 {
        self.aux_index.saturating_add(FIRST_AUX_CHANNEL)
    }

    /// Lowest channel value that activates the mode (900 + 25 per step).
    pub fn low_us(&self) -> u16 {
        900 + 25 * u16::from(self.start_step)
    }

    /// Highest channel value that activates it: iNav's upper bound is exclusive.
    pub fn high_us(&self) -> u16 {
        900 + 25 * u16::from(self.end_step) - 1
    }
}

/// What faithd reads from the flight controller.
#[derive(Clone, Debug, PartialEq)]
pub struct FcSettings {
    pub variant: String,
    pub version: (u8, u8, u8),
    pub receiver_type: u8,
    pub serialrx_provider: u8,
    pub msp_override_channels: u32,
    pub failsafe_delay_ds: u8,
    pub failsafe_recovery_delay_ds: u8,
    /// iNav's MAVLink settings; `None` when the build has none (iNav after 9.1 on
    /// boards with 512 KB of flash or less).
    pub mavlink: Option<MavlinkSettings>,
    /// Radio channel (0-based) feeding iNav's roll, pitch, yaw, throttle.
    pub rcmap: [u8; 4],
    pub modes: Vec<ModeRange>,
    /// MSP_BOXIDS: the modes this build offers, in the order of the status bits.
    pub box_ids: Vec<u8>,
    /// `rxrange` of roll, read in iNav's CLI (no MSP command reports it); `None`
    /// when not read (the daemon never enters the CLI: leaving it reboots iNav).
    pub roll_rxrange: Option<(u16, u16)>,
}

/// iNav's MAVLink telemetry settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MavlinkSettings {
    pub extra1_rate: u8,
    pub rc_chan_rate: u8,
    /// SYS_STATUS, whose RC receiver bit says the pilot's radio is lost.
    pub ext_status_rate: u8,
    pub sysid: u8,
    /// MAVLink version iNav speaks (1 sends RC_CHANNELS_RAW, which faithd does not read).
    pub version: u8,
}

/// Where MSP2_INAV_STATUS keeps the bits faithd reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StatusBits {
    /// Bit of the FAILSAFE mode, when the build reports it.
    pub failsafe: Option<u8>,
    /// Bit of the MSP RC OVERRIDE mode.
    pub msp_override: u8,
    /// Bit of ANGLE, when the build offers it (without it ANGLE reads off).
    pub angle: Option<u8>,
}

/// What MSP2_INAV_STATUS says, as faithd reads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StatusFlags {
    pub armed: bool,
    pub failsafe: bool,
    pub override_on: bool,
    pub angle: bool,
}

impl StatusBits {
    /// Reads an MSP2_INAV_STATUS reply; `None` when it is too short to hold the mode
    /// bits.
    pub fn decode(&self, payload: &[u8]) -> Option<StatusFlags> {
        let flags = u32::from_le_bytes(payload.get(9..13)?.try_into().ok()?);
        let modes = payload.get(13..)?;
        let bit = |i: u8| {
            modes
                .get(usize::from(i / 8))
                .map(|b| b & (1 << (i % 8)) != 0)
        };
        let optional = |i: Option<u8>| match i {
            Some(i) => bit(i),
            None => Some(false),
        };
        Some(StatusFlags {
            armed: flags & ARMING_FLAG_ARMED != 0,
            failsafe: optional(self.failsafe)?,
            override_on: bit(self.msp_override)?,
            angle: optional(self.angle)?,
        })
    }
}

/// What the check needs from faithd's own configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Expectations {
    pub switch_channel: u8,
    pub auto_min_us: u16,
    pub auto_max_us: u16,
    pub attitude_stale_us: i64,
    pub rc_stale_us: i64,
    pub autopilot_system_id: u8,
    /// iNav's `rxrange` for roll as faithd.toml says it is.
    pub roll_rxrange: RxRange,
    /// The longest iNav may keep faithd's last value after faithd stops.
    pub max_hold_after_stop_us: i64,
    /// faithd reads the autopilot over a second MSP port (`[telemetry] kind =
    /// "msp"`): iNav's MAVLink settings do not matter.
    pub telemetry_over_msp: bool,
}

impl Expectations {
    /// From the gate's settings, the command path's and the autopilot's MAVLink
    /// system id.
    pub fn new(gate: &GateConfig, command: &CommandConfig, autopilot_system_id: u8) -> Self {
        Self {
            switch_channel: gate.switch_channel.get(),
            auto_min_us: gate.auto_min_us.us(),
            auto_max_us: gate.auto_max_us.us(),
            attitude_stale_us: gate.attitude_stale_us,
            rc_stale_us: gate.rc_stale_us,
            autopilot_system_id,
            roll_rxrange: command.roll_rxrange_us,
            max_hold_after_stop_us: command.max_hold_after_stop_us,
            telemetry_over_msp: false,
        }
    }

    /// The same, for a faithd that reads the autopilot over MSP (`over_msp`).
    pub fn with_telemetry_over_msp(self, over_msp: bool) -> Self {
        Self {
            telemetry_over_msp: over_msp,
            ..self
        }
    }
}

/// One line of the report.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckItem {
    pub what: &'static str,
    /// What the flight controller has, in its own terms.
    pub found: String,
    /// Why that fails, when it does.
    pub problem: Option<String>,
    /// The iNav CLI line(s) that fix it.
    pub fix: Option<String>,
}

/// Figures of a set-up that passed, which the roll stream and the gate use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RouteFacts {
    /// Index in MSP_SET_RAW_RC of the radio channel that feeds iNav's roll.
    pub roll_frame_index: usize,
    /// The radio channel (0-based) feeding iNav's roll, pitch, yaw and throttle.
    pub rcmap: [u8; 4],
    /// Fresh frames iNav needs before it applies the override (its own failsafe
    /// recovery: 200 ms + failsafe_recovery_delay).
    pub warmup_us: i64,
    /// How long iNav keeps faithd's last value after frames stop (200 ms until it
    /// notices, then 200 ms + failsafe_delay): the bound on a roll outliving a killed
    /// faithd.
    pub hold_after_stop_us: i64,
    /// Worst period of ATTITUDE and RC_CHANNELS at the configured rates (0 when
    /// faithd reads them over MSP, or the build has no MAVLink).
    pub attitude_period_us: i64,
    pub rc_period_us: i64,
    /// How to read iNav's status (armed, failsafe, override mode) over MSP.
    pub status_bits: StatusBits,
}

#[derive(Clone, Debug, PartialEq)]
pub struct FcReport {
    pub items: Vec<CheckItem>,
    /// `Some` only when every item passed.
    pub route: Option<RouteFacts>,
}

impl FcReport {
    pub fn problems(&self) -> impl Iterator<Item = &CheckItem> {
        self.items.iter().filter(|i| i.problem.is_some())
    }

    /// One line naming every problem and its fix, for the journal.
    pub fn summary(&self) -> String {
        self.problems()
            .map(|i| {
                format!(
                    "{}: {} ({}){}",
                    i.what,
                    i.problem.as_deref().unwrap_or(""),
                    i.found,
                    i.fix
                        .as_deref()
                        .map(|f| format!("; fix: {f}"))
                        .unwrap_or_default()
                )
            })
            .collect::<Vec<_>>()
            .join("; ")
    }
}

/// Period of a MAVLink stream at iNav rate setting `rate`: its scheduler re-arms a
/// stream every 50 / rate ticks and counts one more tick before it fires again, so
/// 50 gives 40 ms (25 Hz), 25 gives 60 ms, 10 gives 120 ms. `None` when off.
pub fn mavlink_stream_period_us(rate: u8) -> Option<i64> {
    (rate > 0).then(|| (50 / i64::from(rate.min(50)) + 1) * MAVLINK_TICK_US)
}

/// One check of the set-up: pure, one report line.
type Check = fn(&FcSettings, &Expectations) -> CheckItem;

/// The checks of the pilot's side and the route, in the order the report lists them;
/// the telemetry's come after the first six ([`telemetry_checks`]).
const CHECKS: [Check; 10] = [
    check_firmware,
    check_receiver,
    check_override_channels,
    check_override_mode,
    check_arm_switch,
    check_angle,
    check_override_in_build,
    check_channel_map,
    check_failsafe_delays,
    check_roll_calibration,
];

/// One check of iNav's MAVLink telemetry.
type MavlinkCheck = fn(&MavlinkSettings, &Expectations) -> CheckItem;

const MAVLINK_CHECKS: [MavlinkCheck; 5] = [
    check_attitude_rate,
    check_rc_rate,
    check_sys_status_rate,
    check_system_id,
    check_mavlink_version,
];

/// Judges the set-up: every check in [`CHECKS`] and the telemetry's, and the
/// route's figures when all pass. Pure.
pub fn evaluate(s: &FcSettings, want: &Expectations) -> FcReport {
    let mut items: Vec<CheckItem> = CHECKS.iter().map(|check| check(s, want)).collect();
    let after_angle = items.len() - 4;
    items.splice(after_angle..after_angle, telemetry_checks(s, want));
    let passed = items.iter().all(|i| i.problem.is_none());
    FcReport {
        route: route_facts(s).filter(|_| passed),
        items,
    }
}

/// The figures the stream and the gate use, when this build offers the override.
fn route_facts(s: &FcSettings) -> Option<RouteFacts> {
    let status_bits = status_bits(&s.box_ids)?;
    Some(RouteFacts {
        roll_frame_index: usize::from(s.rcmap[0]),
        rcmap: s.rcmap,
        warmup_us: warmup_us(s),
        hold_after_stop_us: hold_after_stop_us(s),
        attitude_period_us: s
            .mavlink
            .and_then(|m| mavlink_stream_period_us(m.extra1_rate))
            .unwrap_or(0),
        rc_period_us: s
            .mavlink
            .and_then(|m| mavlink_stream_period_us(m.rc_chan_rate))
            .unwrap_or(0),
        status_bits,
    })
}

/// The bit of mode `id` in MSP2_INAV_STATUS: its position among the build's box ids.
fn mode_bit(s: &FcSettings, id: u8) -> Option<u8> {
    box_bit(&s.box_ids, id)
}

fn box_bit(box_ids: &[u8], id: u8) -> Option<u8> {
    box_ids
        .iter()
        .position(|b| *b == id)
        .and_then(|i| u8::try_from(i).ok())
}

/// Where MSP2_INAV_STATUS keeps the bits faithd reads, from MSP_BOXIDS; `None` when
/// the build has no MSP RC OVERRIDE mode.
pub fn status_bits(box_ids: &[u8]) -> Option<StatusBits> {
    Some(StatusBits {
        failsafe: box_bit(box_ids, MODE_FAILSAFE),
        msp_override: box_bit(box_ids, MODE_MSP_RC_OVERRIDE)?,
        angle: box_bit(box_ids, MODE_ANGLE),
    })
}

/// Fresh frames iNav needs before it applies the override.
fn warmup_us(s: &FcSettings) -> i64 {
    RXDATA_PERIOD_US + i64::from(s.failsafe_recovery_delay_ds) * 100_000
}

/// How long iNav keeps faithd's last value after frames stop.
fn hold_after_stop_us(s: &FcSettings) -> i64 {
    MSP_SIGNAL_TIMEOUT_US + RXDATA_PERIOD_US + i64::from(s.failsafe_delay_ds) * 100_000
}

/// A report line.
fn item(
    what: &'static str,
    found: String,
    problem: Option<String>,
    fix: Option<String>,
) -> CheckItem {
    CheckItem {
        what,
        found,
        problem,
        fix,
    }
}

/// The usable ranges of mode `id`.
fn ranges_of(s: &FcSettings, id: u8) -> Vec<&ModeRange> {
    s.modes
        .iter()
        .filter(|m| m.usable() && m.mode_id == id)
        .collect()
}

/// "slot N on channel C at LOW..HIGH us", for each range.
fn describe(ms: &[&ModeRange]) -> String {
    ms.iter()
        .map(|m| {
            format!(
                "slot {} on channel {} at {}..{} us",
                m.slot,
                m.channel(),
                m.low_us(),
                m.high_us()
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The first mode slot not in use, where a fix puts a missing range.
fn free_slot(s: &FcSettings) -> usize {
    s.modes
        .iter()
        .find(|m| !m.usable())
        .map_or(s.modes.len(), |m| m.slot)
}

fn check_firmware(s: &FcSettings, _: &Expectations) -> CheckItem {
    item(
        "firmware",
        format!(
            "{} {}.{}.{}",
            s.variant, s.version.0, s.version.1, s.version.2
        ),
        (s.variant != "INAV").then(|| "faithd's roll route is made for iNav".into()),
        None,
    )
}

/// A receiver that is not MSP (iNav applies the override only then), and a real one.
fn check_receiver(s: &FcSettings, _: &Expectations) -> CheckItem {
    let receiver = RECEIVER_TYPES
        .get(usize::from(s.receiver_type))
        .copied()
        .unwrap_or("unknown");
    let provider = SERIAL_RX
        .get(usize::from(s.serialrx_provider))
        .copied()
        .unwrap_or("unknown");
    let (problem, fix) = match receiver {
        "MSP" => (
            Some("iNav applies MSP RC override only when its receiver is not MSP (rx/rx.c); with an MSP receiver faithd's frame would replace the pilot's whole frame: throttle, arm and the switch".to_string()),
            Some(format!("set receiver_type = SERIAL (serialrx_provider is {provider}: set it to your radio's protocol if that is not it)")),
        ),
        "NONE" => (
            Some("no receiver: the pilot's radio must reach iNav for the switch to work".to_string()),
            Some(format!("set receiver_type = SERIAL (serialrx_provider is {provider}: set it to your radio's protocol if that is not it)")),
        ),
        "SERIAL" | "SIM (SITL)" => (None, None),
        _ => (Some("unknown receiver type".to_string()), None),
    };
    let found = if receiver == "SERIAL" {
        format!("receiver_type = SERIAL, serialrx_provider = {provider}")
    } else {
        format!("receiver_type = {receiver}")
    };
    item("pilot's receiver", found, problem, fix)
}

fn check_override_channels(s: &FcSettings, _: &Expectations) -> CheckItem {
    item(
        "override channels",
        format!("msp_override_channels = {}", s.msp_override_channels),
        (s.msp_override_channels != 1).then(|| {
            "must be 1: roll alone (iNav's channel 1); any other bit lets faithd's frame drive another channel, and 0 lets it drive none".into()
        }),
        (s.msp_override_channels != 1).then(|| "set msp_override_channels = 1".into()),
    )
}

/// The MSP RC OVERRIDE mode on the pilot's switch, within AUTO and nowhere else.
fn check_override_mode(s: &FcSettings, want: &Expectations) -> CheckItem {
    let switch_aux = want.switch_channel.saturating_sub(FIRST_AUX_CHANNEL);
    let overrides = ranges_of(s, MODE_MSP_RC_OVERRIDE);
    let stray = overrides.iter().find(|m| {
        m.channel() != want.switch_channel
            || m.low_us() < want.auto_min_us
            || m.high_us() > want.auto_max_us
    });
    let problem = if want.switch_channel < FIRST_AUX_CHANNEL {
        Some(format!(
            "faithd's switch (gate.switch_channel = {}) must be an AUX channel (5 or above)",
            want.switch_channel
        ))
    } else if overrides.is_empty() {
        Some("the MSP RC OVERRIDE mode is not on the pilot's switch: iNav would never apply faithd's roll".into())
    } else {
        stray.map(|m| {
            format!(
                "MSP RC OVERRIDE is active on channel {} at {}..{} us, outside faithd's AUTO (channel {} at {}..{} us): iNav would apply faithd's frames with the switch in MANUAL",
                m.channel(),
                m.low_us(),
                m.high_us(),
                want.switch_channel,
                want.auto_min_us,
                want.auto_max_us
            )
        })
    };
    // A stray range is rewritten in its own slot; a missing one takes a free slot.
    let slot = stray.map_or_else(|| free_slot(s), |m| m.slot);
    let fix = problem.as_ref().map(|_| {
        format!(
            "aux {slot} {MODE_MSP_RC_OVERRIDE} {switch_aux} {} {}",
            want.auto_min_us, want.auto_max_us
        )
    });
    let found = if overrides.is_empty() {
        "MSP RC OVERRIDE not set".into()
    } else {
        format!("MSP RC OVERRIDE: {}", describe(&overrides))
    };
    item("override mode", found, problem, fix)
}

/// ARM on a switch of its own: on faithd's, MANUAL would disarm.
fn check_arm_switch(s: &FcSettings, want: &Expectations) -> CheckItem {
    let arms = ranges_of(s, MODE_ARM);
    let arm_on_switch = arms.iter().find(|m| m.channel() == want.switch_channel);
    item(
        "arm switch",
        if arms.is_empty() {
            "ARM not on a switch".into()
        } else {
            format!("ARM: {}", describe(&arms))
        },
        arm_on_switch.map(|m| {
            format!(
                "ARM shares channel {} with faithd's AUTO switch: flipping to MANUAL to take control back would disarm (or AUTO would arm)",
                m.channel()
            )
        }),
        arm_on_switch.map(|m| format!("aux {} 0 <other aux channel> 1700 2100 (ARM on a switch of its own)", m.slot)),
    )
}

/// ANGLE whenever faithd may roll: a roll stick outside ANGLE (and HORIZON) is a
/// rotation rate in iNav (flight/pid.c), so 1.5 s of it rolls the vehicle over.
/// faithd rolls only in AUTO and armed: ANGLE must be on over the whole AUTO range of
/// the switch, or over the whole range of the ARM switch.
fn check_angle(s: &FcSettings, want: &Expectations) -> CheckItem {
    let angles = ranges_of(s, MODE_ANGLE);
    let covers = |outer: &ModeRange, inner: &ModeRange| {
        outer.channel() == inner.channel()
            && outer.low_us() <= inner.low_us()
            && outer.high_us() >= inner.high_us()
    };
    let covered_by_angle = |m: &&ModeRange| angles.iter().any(|a| covers(a, m));
    let overrides = ranges_of(s, MODE_MSP_RC_OVERRIDE);
    let arms = ranges_of(s, MODE_ARM);
    let on_auto = !overrides.is_empty() && overrides.iter().all(covered_by_angle);
    let on_arm = !arms.is_empty() && arms.iter().all(covered_by_angle);
    let found = if angles.is_empty() {
        "ANGLE not on a switch".to_string()
    } else {
        format!("ANGLE: {}", describe(&angles))
    };
    let safe = on_auto || on_arm;
    item(
        "ANGLE on AUTO",
        found,
        (!safe).then(|| {
            format!(
                "the switch can be in AUTO (channel {} at {}..{} us) without ANGLE: there iNav takes a roll stick as a rotation rate, and a 1.5 s roll turns the vehicle over",
                want.switch_channel, want.auto_min_us, want.auto_max_us
            )
        }),
        (!safe).then(|| {
            format!(
                "aux {} {MODE_ANGLE} {} {} {}",
                free_slot(s),
                want.switch_channel.saturating_sub(FIRST_AUX_CHANNEL),
                want.auto_min_us,
                want.auto_max_us
            )
        }),
    )
}

/// A MAVLink stream at iNav rate setting `rate` fits within `stale_us` (faithd's
/// `key`), with one scheduler tick of jitter to spare: found, problem, fix.
fn rate_item(
    rate: u8,
    stale_us: i64,
    key: &str,
    setting: &str,
) -> (String, Option<String>, Option<String>) {
    let period = mavlink_stream_period_us(rate);
    let found = match period {
        Some(p) => format!("{setting} = {rate}: one every {} ms", p / 1000),
        None => format!("{setting} = 0: not sent"),
    };
    // One more scheduler tick of jitter must still fit in the staleness limit.
    let too_slow = period.is_none_or(|p| p + MAVLINK_TICK_US > stale_us);
    let problem = too_slow.then(|| {
        format!(
            "faithd's {key} is {} ms: the stream must arrive at least one 20 ms tick sooner, or the gate closes between messages",
            stale_us / 1000
        )
    });
    (
        found,
        problem,
        too_slow.then(|| format!("set {setting} = 50")),
    )
}

/// Over MSP the telemetry is faithd's to ask, and iNav's MAVLink does not matter;
/// over MAVLink the build must have it, at the rates the gate needs.
fn telemetry_checks(s: &FcSettings, want: &Expectations) -> Vec<CheckItem> {
    if want.telemetry_over_msp {
        return vec![item(
            "telemetry",
            "read over MSP on a port of its own (telemetry.endpoint): the gyro every 40 ms, the channels every 80 ms, the status every 120 ms".into(),
            None,
            None,
        )];
    }
    let Some(m) = &s.mavlink else {
        return vec![item(
            "telemetry",
            "this build has no MAVLink (iNav after 9.1 on a board with 512 KB of flash or less)".into(),
            Some("faithd is set to read iNav's MAVLink telemetry ([telemetry] kind = \"mavlink\")".into()),
            Some("in faithd.toml: [telemetry] kind = \"msp\" with the endpoint of a second MSP port (hil/inav/faithd-msp.cli sets one up)".into()),
        )];
    };
    MAVLINK_CHECKS.iter().map(|check| check(m, want)).collect()
}

fn check_attitude_rate(s: &MavlinkSettings, want: &Expectations) -> CheckItem {
    let (found, problem, fix) = rate_item(
        s.extra1_rate,
        want.attitude_stale_us,
        "gate.attitude_stale_us",
        "mavlink_extra1_rate",
    );
    item("ATTITUDE rate", found, problem, fix)
}

fn check_rc_rate(s: &MavlinkSettings, want: &Expectations) -> CheckItem {
    let (found, problem, fix) = rate_item(
        s.rc_chan_rate,
        want.rc_stale_us,
        "gate.rc_stale_us",
        "mavlink_rc_chan_rate",
    );
    item("RC_CHANNELS rate", found, problem, fix)
}

/// SYS_STATUS as often as RC_CHANNELS must be fresh: it says the radio is lost.
fn check_sys_status_rate(s: &MavlinkSettings, want: &Expectations) -> CheckItem {
    let status_period = mavlink_stream_period_us(s.ext_status_rate);
    let status_slow = status_period.is_none_or(|p| p + MAVLINK_TICK_US > want.rc_stale_us);
    item(
        "SYS_STATUS rate",
        match status_period {
            Some(p) => format!(
                "mavlink_ext_status_rate = {}: one every {} ms",
                s.ext_status_rate,
                p / 1000
            ),
            None => "mavlink_ext_status_rate = 0: not sent".into(),
        },
        status_slow.then(|| {
            format!(
                "SYS_STATUS tells faithd that the pilot's radio is lost (iNav's failsafe starts only failsafe_delay later); it must come at least as often as gate.rc_stale_us ({} ms)",
                want.rc_stale_us / 1000
            )
        }),
        status_slow.then(|| "set mavlink_ext_status_rate = 10".into()),
    )
}

fn check_system_id(s: &MavlinkSettings, want: &Expectations) -> CheckItem {
    let sysid_wrong = s.sysid != want.autopilot_system_id;
    item(
        "MAVLink system id",
        format!("mavlink_sysid = {}", s.sysid),
        sysid_wrong.then(|| {
            format!(
                "faithd listens to system {} (mavlink.autopilot_system_id)",
                want.autopilot_system_id
            )
        }),
        sysid_wrong.then(|| {
            format!(
                "set mavlink_sysid = {} (or change mavlink.autopilot_system_id)",
                want.autopilot_system_id
            )
        }),
    )
}

fn check_mavlink_version(s: &MavlinkSettings, _: &Expectations) -> CheckItem {
    let v1 = s.version != 2;
    item(
        "MAVLink version",
        format!("mavlink_version = {}", s.version),
        v1.then(|| "faithd reads RC_CHANNELS, which iNav sends only with MAVLink 2 (version 1 sends RC_CHANNELS_RAW)".into()),
        v1.then(|| "set mavlink_version = 2".into()),
    )
}

fn check_override_in_build(s: &FcSettings, _: &Expectations) -> CheckItem {
    let override_bit = mode_bit(s, MODE_MSP_RC_OVERRIDE);
    item(
        "override in this build",
        match override_bit {
            Some(_) => "MSP RC OVERRIDE offered".into(),
            None => "MSP RC OVERRIDE not offered".into(),
        },
        override_bit.is_none().then(|| {
            "this iNav build lacks USE_MSP_RC_OVERRIDE: it cannot take faithd's roll".into()
        }),
        override_bit
            .is_none()
            .then(|| "flash an iNav build with USE_MSP_RC_OVERRIDE (most targets have it)".into()),
    )
}

fn check_channel_map(s: &FcSettings, _: &Expectations) -> CheckItem {
    let roll_frame_index = usize::from(s.rcmap[0]);
    item(
        "channel map",
        format!("roll from radio channel {}", roll_frame_index + 1),
        (roll_frame_index > 3)
            .then(|| "roll must come from one of the first four radio channels".into()),
        None,
    )
}

/// iNav's hold of faithd's last value after a crash within faithd.toml's bound.
fn check_failsafe_delays(s: &FcSettings, want: &Expectations) -> CheckItem {
    let warmup_us = warmup_us(s);
    let hold_after_stop_us = hold_after_stop_us(s);
    let hold_too_long = hold_after_stop_us > want.max_hold_after_stop_us;
    // The largest failsafe_delay (tenths of a second) within the bound.
    let delay_fits_ds =
        (want.max_hold_after_stop_us - MSP_SIGNAL_TIMEOUT_US - RXDATA_PERIOD_US).max(0) / 100_000;
    item(
        "failsafe delays",
        format!(
            "failsafe_recovery_delay = {}, failsafe_delay = {}: iNav applies the override after {} ms of frames and keeps faithd's last value {} ms after they stop (200 ms to notice, 200 ms + failsafe_delay to give it up)",
            s.failsafe_recovery_delay_ds,
            s.failsafe_delay_ds,
            warmup_us / 1000,
            hold_after_stop_us / 1000
        ),
        hold_too_long.then(|| {
            format!(
                "after a crash iNav would keep faithd's last roll for {} ms, longer than command.max_hold_after_stop_us ({} ms)",
                hold_after_stop_us / 1000,
                want.max_hold_after_stop_us / 1000
            )
        }),
        hold_too_long.then(|| format!("set failsafe_delay = {}", delay_fits_ds.min(5))),
    )
}

/// iNav's `rxrange` of roll as faithd.toml says it is, and one faithd can aim
/// through (when it was read: no MSP command reports it).
fn check_roll_calibration(s: &FcSettings, want: &Expectations) -> CheckItem {
    let Some((min_us, max_us)) = s.roll_rxrange else {
        return item(
            "roll calibration",
            format!(
                "rxrange not read (no MSP command reports it): faithd aims its roll through command.roll_rxrange_us = [{}, {}], which `faithd check-fc` verifies",
                want.roll_rxrange.min_us(),
                want.roll_rxrange.max_us()
            ),
            None,
            None,
        );
    };
    let found = format!("rxrange 0 {min_us} {max_us}");
    let range = RxRange::new(min_us, max_us);
    let aimable = range.is_some_and(|r| {
        [NEUTRAL_US, NEUTRAL_US - 500, NEUTRAL_US + 500]
            .iter()
            .all(|v| r.aim(*v).is_some())
    });
    let problem = if !aimable {
        Some(format!(
            "iNav scales roll from {min_us}..{max_us} to 1000..2000: faithd cannot make it use the centre and a full roll through that"
        ))
    } else if range != Some(want.roll_rxrange) {
        Some(format!(
            "faithd aims its roll through command.roll_rxrange_us = [{}, {}]: iNav would use other values than faithd commands (1800 would arrive as {}) and the roll check would fail",
            want.roll_rxrange.min_us(),
            want.roll_rxrange.max_us(),
            range.map_or(0, |r| r
                .scale(want.roll_rxrange.aim(1800).map_or(1800, |a| a.0)))
        ))
    } else {
        None
    };
    let fix = problem.as_ref().map(|_| {
        if aimable {
            format!("in faithd.toml: [command] roll_rxrange_us = [{min_us}, {max_us}]")
        } else {
            "calibrate the radio's roll again (`rxrange 0 1000 2000` is iNav's default)".into()
        }
    });
    item("roll calibration", found, problem, fix)
}

/// One request of the set-up check, repeated in flight by the roll stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Recheck {
    OverrideChannels,
    ChannelMap,
    ModeRanges,
}

/// What the stream reads again in flight, one request at a time: iNav reads these on
/// every frame, and another MSP port (a configurator, a script) can change them. The
/// override mask twice as often: a channel added to it takes faithd's frame at once.
pub const RECHECKS: [Recheck; 4] = [
    Recheck::OverrideChannels,
    Recheck::ChannelMap,
    Recheck::OverrideChannels,
    Recheck::ModeRanges,
];

impl Recheck {
    pub fn command(self) -> u16 {
        match self {
            Recheck::OverrideChannels => msp_port::MSP2_COMMON_SETTING,
            Recheck::ChannelMap => msp_port::MSP_RX_MAP,
            Recheck::ModeRanges => msp_port::MSP_MODE_RANGES,
        }
    }

    pub fn request(self) -> Vec<u8> {
        match self {
            Recheck::OverrideChannels => {
                super::msp::encode_request(self.command(), b"msp_override_channels\0")
            }
            _ => super::msp::encode_request(self.command(), &[]),
        }
    }

    /// What changed since `checked`, in iNav's terms; `None` when nothing did.
    pub fn changed(self, checked: &FcSettings, reply: &[u8]) -> Option<String> {
        match self {
            Recheck::OverrideChannels => {
                let now = msp_port::le_unsigned(reply);
                (now != checked.msp_override_channels).then(|| {
                    format!(
                        "msp_override_channels is now {now}, was {}",
                        checked.msp_override_channels
                    )
                })
            }
            Recheck::ChannelMap => {
                let now: Vec<u8> = reply.iter().take(4).copied().collect();
                (now != checked.rcmap)
                    .then(|| format!("the channel map is now {now:?}, was {:?}", checked.rcmap))
            }
            Recheck::ModeRanges => {
                let now = mode_ranges(reply);
                let was: Vec<&ModeRange> = checked.modes.iter().filter(|m| m.usable()).collect();
                let is: Vec<&ModeRange> = now.iter().filter(|m| m.usable()).collect();
                (is != was).then(|| "the mode ranges (aux) changed".to_string())
            }
        }
    }
}

/// MSP_MODE_RANGES: (mode id, aux index, start step, end step) per slot.
fn mode_ranges(reply: &[u8]) -> Vec<ModeRange> {
    reply
        .chunks_exact(4)
        .enumerate()
        .map(|(slot, m)| ModeRange {
            slot,
            mode_id: m[0],
            aux_index: m[1],
            start_step: m[2],
            end_step: m[3],
        })
        .collect()
}

/// Reads every setting the check needs over an open MSP port.
pub async fn read(port: &mut MspPort, timeout: Duration) -> Result<FcSettings, MspError> {
    let variant = port.request(msp_port::MSP_FC_VARIANT, &[], timeout).await?;
    let version = port.request(msp_port::MSP_FC_VERSION, &[], timeout).await?;
    let byte = |v: &[u8], i: usize| v.get(i).copied().unwrap_or(0);
    let mut setting = async |name: &str| port.setting(name, timeout).await;
    let receiver_type = setting("receiver_type").await? as u8;
    let serialrx_provider = setting("serialrx_provider").await? as u8;
    let msp_override_channels = setting("msp_override_channels").await?;
    let failsafe_delay_ds = setting("failsafe_delay").await? as u8;
    let failsafe_recovery_delay_ds = setting("failsafe_recovery_delay").await? as u8;
    let mavlink = read_mavlink(port, timeout).await?;
    let map = port.request(msp_port::MSP_RX_MAP, &[], timeout).await?;
    let ranges = port
        .request(msp_port::MSP_MODE_RANGES, &[], timeout)
        .await?;
    let box_ids = port.request(msp_port::MSP_BOXIDS, &[], timeout).await?;
    Ok(FcSettings {
        variant: String::from_utf8_lossy(&variant[..variant.len().min(4)]).into_owned(),
        version: (byte(&version, 0), byte(&version, 1), byte(&version, 2)),
        receiver_type,
        serialrx_provider,
        msp_override_channels,
        failsafe_delay_ds,
        failsafe_recovery_delay_ds,
        mavlink,
        rcmap: [byte(&map, 0), byte(&map, 1), byte(&map, 2), byte(&map, 3)],
        modes: mode_ranges(&ranges),
        box_ids,
        roll_rxrange: None,
    })
}

/// iNav's MAVLink settings, or `None` when the build refuses the first (it has no
/// MAVLink: settings that are not compiled in are unknown to MSP2_COMMON_SETTING).
async fn read_mavlink(
    port: &mut MspPort,
    timeout: Duration,
) -> Result<Option<MavlinkSettings>, MspError> {
    let extra1_rate = match port.setting("mavlink_extra1_rate", timeout).await {
        Ok(v) => v as u8,
        Err(MspError::Refused { .. }) => return Ok(None),
        Err(e) => return Err(e),
    };
    let mut setting = async |name: &str| port.setting(name, timeout).await.map(|v| v as u8);
    Ok(Some(MavlinkSettings {
        extra1_rate,
        rc_chan_rate: setting("mavlink_rc_chan_rate").await?,
        ext_status_rate: setting("mavlink_ext_status_rate").await?,
        sysid: setting("mavlink_sysid").await?,
        version: setting("mavlink_version").await?,
    }))
}

/// Why `faithd check-fc` could not judge the set-up.
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    #[error("{0}")]
    Runtime(std::io::Error),
    #[error("{endpoint} did not open within 3 s")]
    OpenTimeout { endpoint: String },
    #[error("{endpoint}: {source}")]
    Open {
        endpoint: String,
        source: std::io::Error,
    },
    #[error(transparent)]
    Msp(#[from] MspError),
    #[error(transparent)]
    Cli(#[from] CliError),
}

/// Why `rxrange` could not be read in iNav's CLI.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    #[error("iNav's CLI: {0}")]
    Io(#[from] std::io::Error),
    #[error("iNav's CLI: {0}")]
    Msp(#[from] MspError),
    #[error("iNav did not enter its CLI after `#` (it answered {banner:?}): is the vehicle armed?")]
    NoCli { banner: String },
    #[error("iNav's CLI printed no `rxrange 0` line: {text:?}")]
    NoRxRange { text: String },
}

/// `faithd check-fc`: opens `command.sink.endpoint`, reads and judges the set-up.
/// With `read_rxrange`, a disarmed flight controller's `rxrange` is read in its CLI
/// too, which iNav leaves only by rebooting.
pub fn check_over_msp(
    command: &CommandConfig,
    expect: &Expectations,
    read_rxrange: bool,
) -> Result<FcReport, CheckError> {
    let endpoint = command.msp_port();
    let timeout = Duration::from_micros(command.msp_timeout_us.max(1) as u64);
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(CheckError::Runtime)?;
    runtime.block_on(async {
        let transport = tokio::time::timeout(Duration::from_secs(3), endpoint.open())
            .await
            .map_err(|_| CheckError::OpenTimeout {
                endpoint: endpoint.to_string(),
            })?
            .map_err(|source| CheckError::Open {
                endpoint: endpoint.to_string(),
                source,
            })?;
        let mut port = MspPort::new(transport);
        let mut settings = read(&mut port, timeout).await?;
        if !read_rxrange {
            return Ok(evaluate(&settings, expect));
        }
        let status = port
            .request(msp_port::MSP2_INAV_STATUS, &[], timeout)
            .await?;
        let armed = status
            .get(9..13)
            .is_some_and(|f| u32::from_le_bytes([f[0], f[1], f[2], f[3]]) & ARMING_FLAG_ARMED != 0);
        if armed {
            let mut report = evaluate(&settings, expect);
            report.route = None;
            for i in report.items.iter_mut().filter(|i| i.what == "roll calibration") {
                i.problem = Some("not read: the vehicle is armed, and iNav's CLI, the only place rxrange can be read, reboots the flight controller when it is left".into());
                i.fix = Some("disarm, then run `faithd check-fc` again".into());
            }
            return Ok(report);
        }
        settings.roll_rxrange = Some(read_roll_rxrange(&mut port).await?);
        Ok(evaluate(&settings, expect))
    })
}

/// `faithd check-fc` with `[telemetry] kind = "msp"`: whether iNav answers MSP on
/// the telemetry port (asked before the command port's check, which may reboot it).
pub fn probe_msp_telemetry(endpoint: &crate::transport::Endpoint, timeout: Duration) -> CheckItem {
    let asked = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| e.to_string())
        .and_then(|runtime| {
            runtime.block_on(async {
                let transport = tokio::time::timeout(Duration::from_secs(3), endpoint.open())
                    .await
                    .map_err(|_| "did not open within 3 s".to_string())?
                    .map_err(|e| e.to_string())?;
                let mut port = MspPort::new(transport);
                let variant = port
                    .request(msp_port::MSP_FC_VARIANT, &[], timeout)
                    .await
                    .map_err(|e| e.to_string())?;
                Ok(String::from_utf8_lossy(&variant[..variant.len().min(4)]).into_owned())
            })
        });
    match asked {
        Ok(variant) if variant == "INAV" => item(
            "telemetry port",
            format!("iNav answers MSP on {endpoint}"),
            None,
            None,
        ),
        Ok(other) => item(
            "telemetry port",
            format!("{other:?} answers MSP on {endpoint}"),
            Some("faithd reads iNav only".into()),
            None,
        ),
        Err(why) => item(
            "telemetry port",
            format!("no MSP reply on {endpoint}: {why}"),
            Some("faithd reads the autopilot there ([telemetry] kind = \"msp\")".into()),
            Some("serial N 1 115200 115200 115200 115200 for the UART wired to telemetry.endpoint (N its index: function 1 is MSP), or fix telemetry.endpoint in faithd.toml".into()),
        ),
    }
}

/// Reads `rxrange` of roll in iNav's CLI (fc/cli.c `cliRxRange` prints
/// `rxrange <channel> <min> <max>` for the four flight channels), then leaves it with
/// `exit`, which reboots the flight controller.
async fn read_roll_rxrange(port: &mut MspPort) -> Result<(u16, u16), CliError> {
    port.send_text(b"#").await?;
    let banner = port
        .read_text(Duration::from_secs(2), |t| {
            t.contains("CLI") && t.ends_with("# ")
        })
        .await?;
    if !banner.contains("CLI") {
        return Err(CliError::NoCli { banner });
    }
    port.send_text(b"rxrange\r\n").await?;
    let text = port
        .read_text(Duration::from_secs(2), |t| {
            t.contains("rxrange 3 ") && t.trim_end().ends_with('#')
        })
        .await?;
    let _ = port.send_text(b"exit\r\n").await;
    let _ = port
        .read_text(Duration::from_millis(500), |t| t.contains("Leaving CLI"))
        .await;
    parse_rxrange(&text, 0).ok_or(CliError::NoRxRange { text })
}

/// The `rxrange <channel> <min> <max>` line of `channel` in iNav's CLI output.
fn parse_rxrange(text: &str, channel: u8) -> Option<(u16, u16)> {
    text.lines().find_map(|line| {
        let mut words = line.split_whitespace();
        (words.next()? == "rxrange" && words.next()?.parse::<u8>().ok()? == channel)
            .then_some(())?;
        Some((words.next()?.parse().ok()?, words.next()?.parse().ok()?))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The committed CLI script's set-up (hil/inav/faithd.cli).
    pub fn good() -> FcSettings {
        let mut modes: Vec<ModeRange> = (0..40)
            .map(|slot| ModeRange {
                slot,
                mode_id: 0,
                aux_index: 0,
                start_step: 0,
                end_step: 0,
            })
            .collect();
        // aux 0 0 0 1700 2100 (ARM on channel 5), aux 1 1 0 1700 2100 (ANGLE with
        // it), aux 2 50 1 1700 2100 (channel 6).
        modes[0] = ModeRange {
            slot: 0,
            mode_id: MODE_ARM,
            aux_index: 0,
            start_step: 32,
            end_step: 48,
        };
        modes[1] = ModeRange {
            slot: 1,
            mode_id: MODE_ANGLE,
            aux_index: 0,
            start_step: 32,
            end_step: 48,
        };
        modes[2] = ModeRange {
            slot: 2,
            mode_id: MODE_MSP_RC_OVERRIDE,
            aux_index: 1,
            start_step: 32,
            end_step: 48,
        };
        FcSettings {
            variant: "INAV".into(),
            version: (9, 1, 0),
            receiver_type: 1,
            serialrx_provider: 4,
            msp_override_channels: 1,
            failsafe_delay_ds: 5,
            failsafe_recovery_delay_ds: 5,
            mavlink: Some(MavlinkSettings {
                extra1_rate: 50,
                rc_chan_rate: 50,
                ext_status_rate: 10,
                sysid: 1,
                version: 2,
            }),
            rcmap: [0, 1, 3, 2],
            modes,
            // As iNav 9.1's SITL build lists them (MSP_BOXIDS).
            box_ids: vec![
                0, 51, 61, 1, 2, 35, 5, 8, 6, 7, 32, 46, 3, 13, 60, 19, 27, 39, 40, 41, 42, 43, 44,
                50, 62, 63, 65, 66, 67,
            ],
            roll_rxrange: Some((1000, 2000)),
        }
    }

    fn want() -> Expectations {
        Expectations::new(&GateConfig::default(), &CommandConfig::default(), 1)
    }

    #[test]
    fn the_committed_set_up_passes_with_inav_timings() {
        let report = evaluate(&good(), &want());
        assert_eq!(report.problems().count(), 0, "{}", report.summary());
        let route = report.route.unwrap();
        assert_eq!(route.warmup_us, 700_000);
        // 200 ms before iNav notices, then 200 ms + failsafe_delay (measured on SITL:
        // 0.89-0.94 s).
        assert_eq!(route.hold_after_stop_us, 900_000);
        assert_eq!(route.attitude_period_us, 40_000);
        assert_eq!(route.roll_frame_index, 0);
        assert_eq!(
            route.status_bits,
            StatusBits {
                failsafe: Some(16),
                msp_override: 23,
                angle: Some(3),
            }
        );
    }

    #[test]
    fn status_bits_read_armed_failsafe_and_override() {
        let bits = StatusBits {
            failsafe: Some(16),
            msp_override: 23,
            angle: Some(3),
        };
        let flags = |armed, failsafe, override_on, angle| {
            Some(StatusFlags {
                armed,
                failsafe,
                override_on,
                angle,
            })
        };
        // cycle time .. profile (9 bytes), arming flags, then the mode bits.
        let mut payload = vec![0u8; 9];
        payload.extend_from_slice(&(ARMING_FLAG_ARMED | 1 << 3).to_le_bytes());
        // bit 16 (failsafe) and bit 23 (override) are both in the third byte.
        payload.extend_from_slice(&[0b0000_1001, 0, 0b1000_0001, 0, 0, 0, 0, 0]);
        assert_eq!(bits.decode(&payload), flags(true, true, true, true));
        payload[13] = 0b0000_0001;
        payload[15] = 0;
        payload[16] = 0;
        payload[9] = 0;
        assert_eq!(bits.decode(&payload), flags(false, false, false, false));
        assert_eq!(bits.decode(&payload[..14]), None, "too short");
    }

    #[test]
    fn stream_periods_match_what_inav_sends() {
        // Measured on SITL: 50 -> 24.6 Hz, 25 -> 16.4 Hz, 10 -> about 8 Hz, 5 -> 4.5 Hz.
        assert_eq!(mavlink_stream_period_us(50), Some(40_000));
        assert_eq!(mavlink_stream_period_us(100), Some(40_000));
        assert_eq!(mavlink_stream_period_us(25), Some(60_000));
        assert_eq!(mavlink_stream_period_us(10), Some(120_000));
        assert_eq!(mavlink_stream_period_us(5), Some(220_000));
        assert_eq!(mavlink_stream_period_us(0), None);
    }

    fn refused(settings: FcSettings, what: &str, fix: &str) {
        let report = evaluate(&settings, &want());
        assert!(report.route.is_none(), "{what} should refuse");
        let item = report
            .problems()
            .find(|i| i.what == what)
            .unwrap_or_else(|| panic!("no problem with {what}: {}", report.summary()));
        assert!(
            item.fix.as_deref().unwrap_or("").contains(fix),
            "{what}: fix {:?} lacks {fix}",
            item.fix
        );
    }

    /// iNav 10 on an F411 or F722 has no MAVLink: the MAVLink link is refused with
    /// the fix in faithd.toml, the MSP-only link passes without any MAVLink setting.
    #[test]
    fn a_build_without_mavlink_passes_only_with_the_telemetry_over_msp() {
        let mut s = good();
        s.mavlink = None;
        refused(s.clone(), "telemetry", "[telemetry] kind = \"msp\"");
        let report = evaluate(&s, &want().with_telemetry_over_msp(true));
        assert_eq!(report.problems().count(), 0, "{}", report.summary());
        assert!(report.items.iter().all(|i| !i.what.starts_with("MAVLink")));
        // Over MSP, iNav's MAVLink settings do not matter even where it has them.
        let mut s = good();
        s.mavlink.as_mut().unwrap().extra1_rate = 0;
        let report = evaluate(&s, &want().with_telemetry_over_msp(true));
        assert!(report.route.is_some(), "{}", report.summary());
    }

    #[test]
    fn each_known_failure_is_refused_with_its_cli_fix() {
        let mut s = good();
        s.receiver_type = 2;
        refused(s, "pilot's receiver", "set receiver_type = SERIAL");
        let mut s = good();
        s.msp_override_channels = 0b1001;
        refused(s, "override channels", "set msp_override_channels = 1");
        let mut s = good();
        s.modes[2].end_step = 0;
        refused(s, "override mode", "aux 2 50 1 1700 2100");
        let mut s = good();
        s.modes[2].start_step = 20; // active from 1400 us: in MANUAL too
        refused(s, "override mode", "aux 2 50 1 1700 2100");
        let mut s = good();
        s.modes[2].aux_index = 2;
        refused(s, "override mode", "aux 2 50 1 1700 2100");
        let mut s = good();
        s.modes[0].aux_index = 1;
        refused(s, "arm switch", "aux 0 0");
        let mut s = good();
        s.mavlink.as_mut().unwrap().extra1_rate = 10;
        refused(s, "ATTITUDE rate", "set mavlink_extra1_rate = 50");
        let mut s = good();
        s.mavlink.as_mut().unwrap().rc_chan_rate = 0;
        refused(s, "RC_CHANNELS rate", "set mavlink_rc_chan_rate = 50");
        let mut s = good();
        s.mavlink.as_mut().unwrap().ext_status_rate = 2; // iNav's default
        refused(s, "SYS_STATUS rate", "set mavlink_ext_status_rate = 10");
        let mut s = good();
        s.mavlink.as_mut().unwrap().sysid = 7;
        refused(s, "MAVLink system id", "set mavlink_sysid = 1");
        let mut s = good();
        s.mavlink.as_mut().unwrap().version = 1;
        refused(s, "MAVLink version", "set mavlink_version = 2");
        let mut s = good();
        s.box_ids.retain(|b| *b != MODE_MSP_RC_OVERRIDE);
        refused(s, "override in this build", "USE_MSP_RC_OVERRIDE");
        // ANGLE on another switch: AUTO can be on without it.
        let mut s = good();
        s.modes[1].aux_index = 2;
        refused(s, "ANGLE on AUTO", "aux 3 1 1 1700 2100");
        let mut s = good();
        s.modes[1].end_step = 0;
        refused(s, "ANGLE on AUTO", "aux 1 1 1 1700 2100");
        // failsafe_delay 10: iNav would hold faithd's roll 1.4 s after a crash.
        let mut s = good();
        s.failsafe_delay_ds = 10;
        refused(s, "failsafe delays", "set failsafe_delay = 5");
        // A calibrated receiver that faithd.toml does not know of.
        let mut s = good();
        s.roll_rxrange = Some((988, 2012));
        refused(s, "roll calibration", "roll_rxrange_us = [988, 2012]");
        let mut s = good();
        // Three microseconds wide: iNav's values jump by 333 us, 1500 cannot be hit.
        s.roll_rxrange = Some((1500, 1503));
        refused(s, "roll calibration", "calibrate");
    }

    #[test]
    fn angle_on_the_auto_switch_itself_passes_too() {
        let mut s = good();
        s.modes[1] = ModeRange {
            slot: 1,
            mode_id: MODE_ANGLE,
            aux_index: 1,
            start_step: 30,
            end_step: 48,
        };
        let report = evaluate(&s, &want());
        assert!(report.route.is_some(), "{}", report.summary());
        // Covering only part of AUTO is not enough.
        s.modes[1].start_step = 34;
        assert!(evaluate(&s, &want()).route.is_none());
    }

    #[test]
    fn a_known_calibration_passes_and_an_unread_one_is_named() {
        let mut s = good();
        s.roll_rxrange = Some((988, 2012));
        let command = CommandConfig {
            roll_rxrange_us: RxRange::new(988, 2012).unwrap(),
            ..CommandConfig::default()
        };
        let want = Expectations::new(&GateConfig::default(), &command, 1);
        assert!(evaluate(&s, &want).route.is_some());
        s.roll_rxrange = None;
        let report = evaluate(&s, &want);
        assert!(report.route.is_some());
        let item = report
            .items
            .iter()
            .find(|i| i.what == "roll calibration")
            .unwrap();
        assert!(item.found.contains("not read"), "{}", item.found);
    }

    #[test]
    fn rxrange_is_read_from_inavs_cli_output() {
        let text = "rxrange\r\nrxrange 0 988 2012\r\nrxrange 1 1000 2000\r\n\r\n# ";
        assert_eq!(parse_rxrange(text, 0), Some((988, 2012)));
        assert_eq!(parse_rxrange(text, 1), Some((1000, 2000)));
        assert_eq!(parse_rxrange(text, 2), None);
        assert_eq!(parse_rxrange("rxrange 0 x 2000", 0), None);
    }

    #[test]
    fn a_recheck_names_what_changed_in_flight() {
        let s = good();
        let mask = |v: u32| v.to_le_bytes().to_vec();
        assert_eq!(Recheck::OverrideChannels.changed(&s, &mask(1)), None);
        let what = Recheck::OverrideChannels.changed(&s, &mask(9)).unwrap();
        assert!(
            what.contains("msp_override_channels is now 9, was 1"),
            "{what}"
        );
        assert!(Recheck::ChannelMap.changed(&s, &[0, 1, 3, 2]).is_none());
        assert!(Recheck::ChannelMap.changed(&s, &[1, 0, 3, 2]).is_some());
        let mut ranges: Vec<u8> = s
            .modes
            .iter()
            .flat_map(|m| [m.mode_id, m.aux_index, m.start_step, m.end_step])
            .collect();
        assert!(Recheck::ModeRanges.changed(&s, &ranges).is_none());
        ranges[4 * 2 + 1] = 3; // the override moved to another channel
        assert!(Recheck::ModeRanges.changed(&s, &ranges).is_some());
    }

    #[test]
    fn a_remapped_radio_moves_the_roll_slot() {
        let mut s = good();
        s.rcmap = [1, 2, 3, 0]; // TAER-style radio: roll on radio channel 2
        let route = evaluate(&s, &want()).route.unwrap();
        assert_eq!(route.roll_frame_index, 1);
    }
}
