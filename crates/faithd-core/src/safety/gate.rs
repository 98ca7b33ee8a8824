//! The pilot's safety gate: may faithd command the vehicle right now?
//!
//! The rule of docs/design.md, checked in a fixed order so the log always names the
//! same first reason for the same situation: the link is up, the pilot's switch is in
//! AUTO, the vehicle is armed, RC, heartbeat and attitude data are fresh, and the
//! pipeline is healthy. Pure: the caller passes the time.

use serde::{Deserialize, Serialize};

use super::rc::{PwmUs, RcChannel};
use super::vehicle::VehicleState;
use crate::invalid::{Invalid, check};

/// iNav's first AUX channel: its modes (MSP RC OVERRIDE among them) bind to AUX.
pub const FIRST_AUX_CHANNEL: u8 = 5;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GateConfig {
    /// RC channel (1-based, as numbered in iNav's RC_CHANNELS) carrying the pilot's
    /// manual/auto switch.
    pub switch_channel: RcChannel,
    /// The switch is in AUTO while its value lies in this range.
    pub auto_min_us: PwmUs,
    pub auto_max_us: PwmUs,
    /// RC_CHANNELS older than this closes the gate.
    pub rc_stale_us: i64,
    /// SYS_STATUS (the pilot's radio health) older than this closes the gate.
    pub radio_stale_us: i64,
    /// ATTITUDE older than this closes the gate (derotation needs it).
    pub attitude_stale_us: i64,
    /// HEARTBEAT older than this closes the gate (armed state unknown).
    pub heartbeat_stale_us: i64,
    /// A pipeline that has not finished a cycle for this long is unhealthy.
    pub pipeline_stale_us: i64,
    /// The flight controller's status (read over MSP every send period) older than
    /// this closes the gate.
    pub fc_status_stale_us: i64,
}

impl Default for GateConfig {
    fn default() -> Self {
        Self {
            switch_channel: const { RcChannel::constant(6) },
            auto_min_us: const { PwmUs::constant(1700) },
            auto_max_us: const { PwmUs::constant(2100) },
            rc_stale_us: 300_000,
            radio_stale_us: 300_000,
            attitude_stale_us: 100_000,
            heartbeat_stale_us: 2_500_000,
            pipeline_stale_us: 100_000,
            fc_status_stale_us: 250_000,
        }
    }
}

impl GateConfig {
    /// `[gate]`: the switch on an AUX channel, an AUTO range that leaves the pilot a
    /// MANUAL end, and staleness limits between 1 ms and 10 s.
    pub fn validate(&self) -> Result<(), Invalid> {
        let g = self;
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
        )?;
        let (min, max) = (g.auto_min_us.us(), g.auto_max_us.us());
        check(
            min <= max && min >= 800 && max <= 2200,
            "gate.auto_min_us",
            || format!("AUTO range {min}..{max} must lie in 800..2200 with min <= max"),
        )?;
        // A switch has an end that means MANUAL: a range over both ends of the travel
        // (1000 and 2000, give or take 100) would leave the pilot no way back.
        check(min > 1100 || max < 1900, "gate.auto_max_us", || {
            format!(
                "AUTO range {min}..{max} covers the whole stick travel: the pilot could never switch to MANUAL"
            )
        })?;
        for (v, key) in [
            (g.rc_stale_us, "gate.rc_stale_us"),
            (g.radio_stale_us, "gate.radio_stale_us"),
            (g.attitude_stale_us, "gate.attitude_stale_us"),
            (g.heartbeat_stale_us, "gate.heartbeat_stale_us"),
            (g.pipeline_stale_us, "gate.pipeline_stale_us"),
            (g.fc_status_stale_us, "gate.fc_status_stale_us"),
        ] {
            check((1000..=10_000_000).contains(&v), key, || {
                format!("must be 1 ms to 10 s, got {v}")
            })?;
        }
        Ok(())
    }
}

/// What the pipeline thread last reported about itself.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PipelineStatus {
    /// Daemon time of the last finished cycle; `None` before the first.
    pub last_cycle_us: Option<i64>,
    /// Why the last cycle cannot be trusted, if it cannot.
    pub problem: Option<PipelineProblem>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PipelineProblem {
    /// The event source has delivered nothing for too long (camera gone).
    NoEvents,
    /// No attitude samples cover the window: flow cannot be derotated.
    NoAttitude,
}

/// The flight controller's own state, read over the MSP stream (MSP2_INAV_STATUS)
/// at every send period: faster than MAVLink's 1 Hz HEARTBEAT, and it says whether
/// iNav's MSP RC OVERRIDE mode is on, i.e. whether iNav would take faithd's roll.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FcStatus {
    pub t_us: i64,
    pub armed: bool,
    /// iNav's FAILSAFE flight mode (radio lost, or the pilot's failsafe switch).
    pub failsafe: bool,
    /// iNav's MSP RC OVERRIDE mode (on only with the pilot's switch in AUTO).
    pub override_on: bool,
    /// iNav flies in ANGLE mode (fc/fc_core.c sets the flight mode; MSP2_INAV_STATUS
    /// reports it, fc/fc_msp_box.c). Outside it the roll stick commands a rotation
    /// rate (flight/pid.c): 1.5 s of a deflected stick rolls the vehicle over.
    pub angle: bool,
}

/// What the roll command path (the MSP stream to iNav) last reported.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CommandPathStatus {
    /// The flight controller's set-up was read and refused (the journal has why).
    pub setup_refused: bool,
    /// The set-up changed in flight (the journal has what): faithd stopped
    /// streaming until it is read and judged again.
    pub setup_changed: bool,
    /// Daemon time from which iNav applies the stream: the stream started plus
    /// iNav's own recovery delay. `None` while the port is closed or unchecked.
    pub ready_at_us: Option<i64>,
    /// A roll did not take effect on the flight controller; held until the pilot
    /// takes the switch out of AUTO.
    pub roll_not_in_effect: bool,
    /// The flight controller's last status reply; `None` before the first.
    pub fc: Option<FcStatus>,
}

/// The first condition that keeps the gate closed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Blocker {
    LinkDown,
    NoRc,
    RcStale {
        age_us: i64,
    },
    /// The switch channel is missing from RC_CHANNELS (fewer channels reported).
    SwitchMissing {
        channel: u8,
    },
    SwitchNotAuto {
        value_us: u16,
    },
    /// The autopilot's receiver reports the pilot's radio lost (SYS_STATUS).
    RadioLost,
    NoHeartbeat,
    HeartbeatStale {
        age_us: i64,
    },
    Disarmed,
    /// The autopilot is in failsafe: HEARTBEAT system_status, or iNav's FAILSAFE mode.
    AutopilotFailsafe {
        source: FailsafeSource,
    },
    NoAttitude,
    AttitudeStale {
        age_us: i64,
    },
    PipelineNotRunning,
    PipelineStale {
        age_us: i64,
    },
    PipelineUnhealthy {
        problem: PipelineProblem,
    },
    FcSetupRefused,
    FcSetupChanged,
    CommandPortDown,
    NoFcStatus,
    FcStatusStale {
        age_us: i64,
    },
    /// iNav reports its MSP RC OVERRIDE mode off: it would not take faithd's roll.
    OverrideModeOff,
    /// iNav is not in ANGLE mode: a roll stick would command a rate, not a bank.
    AngleModeOff,
    /// No SYS_STATUS has said whether the pilot's radio reaches the autopilot.
    NoRadioStatus,
    /// SYS_STATUS stopped: the radio's last known health is too old to trust.
    RadioStatusStale {
        age_us: i64,
    },
    OverrideWarmingUp {
        remaining_us: i64,
    },
    RollNotInEffect,
}

impl std::fmt::Display for Blocker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Blocker::LinkDown => write!(f, "autopilot link down"),
            Blocker::NoRc => write!(f, "no RC_CHANNELS received yet"),
            Blocker::RcStale { age_us } => write!(f, "RC_CHANNELS stale ({} ms)", age_us / 1000),
            Blocker::SwitchMissing { channel } => {
                write!(f, "switch channel {channel} not in RC_CHANNELS")
            }
            Blocker::SwitchNotAuto { value_us } => {
                write!(f, "pilot switch not in AUTO ({value_us} us)")
            }
            Blocker::RadioLost => write!(
                f,
                "the autopilot reports the pilot's radio lost (SYS_STATUS RC receiver unhealthy)"
            ),
            Blocker::AutopilotFailsafe { source } => match source {
                FailsafeSource::Heartbeat => write!(
                    f,
                    "the autopilot is in failsafe (HEARTBEAT system_status CRITICAL or worse)"
                ),
                FailsafeSource::FcStatus => {
                    write!(f, "the autopilot is in failsafe (iNav's FAILSAFE mode)")
                }
            },
            Blocker::NoFcStatus => write!(f, "no status from the flight controller over MSP yet"),
            Blocker::FcStatusStale { age_us } => write!(
                f,
                "flight controller status over MSP stale ({} ms)",
                age_us / 1000
            ),
            Blocker::OverrideModeOff => write!(
                f,
                "iNav reports its MSP RC OVERRIDE mode off: it would not take faithd's roll"
            ),
            Blocker::AngleModeOff => write!(
                f,
                "iNav is not in ANGLE mode: a roll stick would command a rotation rate, not a bank (put ANGLE on the AUTO switch: `faithd check-fc`)"
            ),
            Blocker::NoRadioStatus => write!(
                f,
                "no SYS_STATUS received yet: the pilot's radio health is unknown"
            ),
            Blocker::RadioStatusStale { age_us } => write!(
                f,
                "SYS_STATUS stale ({} ms): the pilot's radio health is unknown",
                age_us / 1000
            ),
            Blocker::NoHeartbeat => write!(f, "no HEARTBEAT received yet"),
            Blocker::HeartbeatStale { age_us } => {
                write!(f, "HEARTBEAT stale ({} ms)", age_us / 1000)
            }
            Blocker::Disarmed => write!(f, "vehicle disarmed"),
            Blocker::NoAttitude => write!(f, "no ATTITUDE received yet"),
            Blocker::AttitudeStale { age_us } => {
                write!(f, "ATTITUDE stale ({} ms)", age_us / 1000)
            }
            Blocker::PipelineNotRunning => write!(f, "pipeline has not run yet"),
            Blocker::PipelineStale { age_us } => {
                write!(
                    f,
                    "pipeline stalled ({} ms since last cycle)",
                    age_us / 1000
                )
            }
            Blocker::PipelineUnhealthy { problem } => write!(f, "pipeline unhealthy: {problem:?}"),
            Blocker::FcSetupRefused => {
                write!(
                    f,
                    "flight controller set-up refused (see `faithd check-fc`)"
                )
            }
            Blocker::FcSetupChanged => write!(
                f,
                "the flight controller's set-up changed in flight (the journal says what): faithd reads it again before it commands"
            ),
            Blocker::CommandPortDown => write!(f, "MSP command port not streaming"),
            Blocker::OverrideWarmingUp { remaining_us } => write!(
                f,
                "iNav applies the MSP override only after its recovery delay ({} ms to go)",
                remaining_us / 1000
            ),
            Blocker::RollNotInEffect => write!(
                f,
                "the last roll did not take effect on the flight controller (switch to MANUAL and back once fixed)"
            ),
        }
    }
}

/// Which report said the autopilot is in failsafe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FailsafeSource {
    /// MAVLink HEARTBEAT system_status CRITICAL or worse.
    Heartbeat,
    /// MSP2_INAV_STATUS: the FAILSAFE flight mode.
    FcStatus,
}

/// Open, or closed with the first reason.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "state")]
pub enum GateState {
    Open,
    Closed(Blocker),
}

impl GateState {
    pub fn is_open(&self) -> bool {
        matches!(self, GateState::Open)
    }
}

/// Evaluates the gate at `now_us` (daemon time).
pub fn evaluate(
    config: &GateConfig,
    vehicle: &VehicleState,
    pipeline: &PipelineStatus,
    command: &CommandPathStatus,
    now_us: i64,
) -> GateState {
    match first_blocker(config, vehicle, pipeline, now_us)
        .or_else(|| command_blocker(config, command, now_us))
    {
        Some(b) => GateState::Closed(b),
        None => GateState::Open,
    }
}

/// The command path comes last: its blockers matter only once the vehicle and the
/// pipeline would allow a roll.
fn command_blocker(
    config: &GateConfig,
    command: &CommandPathStatus,
    now_us: i64,
) -> Option<Blocker> {
    if command.setup_refused {
        return Some(Blocker::FcSetupRefused);
    }
    if command.setup_changed {
        return Some(Blocker::FcSetupChanged);
    }
    let Some(ready_at_us) = command.ready_at_us else {
        return Some(Blocker::CommandPortDown);
    };
    let Some(fc) = &command.fc else {
        return Some(Blocker::NoFcStatus);
    };
    let age_us = now_us - fc.t_us;
    if age_us > config.fc_status_stale_us {
        return Some(Blocker::FcStatusStale { age_us });
    }
    if fc.failsafe {
        return Some(Blocker::AutopilotFailsafe {
            source: FailsafeSource::FcStatus,
        });
    }
    if !fc.armed {
        return Some(Blocker::Disarmed);
    }
    if !fc.angle {
        return Some(Blocker::AngleModeOff);
    }
    if !fc.override_on {
        return Some(Blocker::OverrideModeOff);
    }
    if now_us < ready_at_us {
        return Some(Blocker::OverrideWarmingUp {
            remaining_us: ready_at_us - now_us,
        });
    }
    if command.roll_not_in_effect {
        return Some(Blocker::RollNotInEffect);
    }
    None
}

fn first_blocker(
    config: &GateConfig,
    vehicle: &VehicleState,
    pipeline: &PipelineStatus,
    now_us: i64,
) -> Option<Blocker> {
    if !vehicle.link_up {
        return Some(Blocker::LinkDown);
    }
    let Some(rc) = &vehicle.rc else {
        return Some(Blocker::NoRc);
    };
    let age_us = now_us - rc.t_us;
    if age_us > config.rc_stale_us {
        return Some(Blocker::RcStale { age_us });
    }
    let channel = config.switch_channel.get();
    let Some(value_us) = rc.channel_us(channel) else {
        return Some(Blocker::SwitchMissing { channel });
    };
    if !(config.auto_min_us.us()..=config.auto_max_us.us()).contains(&value_us) {
        return Some(Blocker::SwitchNotAuto { value_us });
    }
    let Some(radio) = &vehicle.radio else {
        return Some(Blocker::NoRadioStatus);
    };
    if !radio.healthy {
        return Some(Blocker::RadioLost);
    }
    let age_us = now_us - radio.t_us;
    if age_us > config.radio_stale_us {
        return Some(Blocker::RadioStatusStale { age_us });
    }
    let Some(hb) = &vehicle.heartbeat else {
        return Some(Blocker::NoHeartbeat);
    };
    let age_us = now_us - hb.t_us;
    if age_us > config.heartbeat_stale_us {
        return Some(Blocker::HeartbeatStale { age_us });
    }
    if !hb.armed {
        return Some(Blocker::Disarmed);
    }
    if hb.in_failsafe() {
        return Some(Blocker::AutopilotFailsafe {
            source: FailsafeSource::Heartbeat,
        });
    }
    let Some(att_us) = vehicle.last_attitude_us else {
        return Some(Blocker::NoAttitude);
    };
    let age_us = now_us - att_us;
    if age_us > config.attitude_stale_us {
        return Some(Blocker::AttitudeStale { age_us });
    }
    let Some(cycle_us) = pipeline.last_cycle_us else {
        return Some(Blocker::PipelineNotRunning);
    };
    let age_us = now_us - cycle_us;
    if age_us > config.pipeline_stale_us {
        return Some(Blocker::PipelineStale { age_us });
    }
    if let Some(problem) = pipeline.problem {
        return Some(Blocker::PipelineUnhealthy { problem });
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::safety::vehicle::{Heartbeat, RadioHealth, RcChannels};

    const NOW: i64 = 10_000_000;
    const FC_OK: FcStatus = FcStatus {
        t_us: NOW - 10_000,
        armed: true,
        failsafe: false,
        override_on: true,
        angle: true,
    };
    const READY: CommandPathStatus = CommandPathStatus {
        setup_refused: false,
        setup_changed: false,
        ready_at_us: Some(0),
        roll_not_in_effect: false,
        fc: Some(FC_OK),
    };

    #[test]
    fn the_command_path_closes_it_last_and_names_why() {
        let cfg = GateConfig::default();
        let now = NOW;
        let (v, p) = all_good(now);
        let cases = [
            (
                CommandPathStatus {
                    setup_refused: true,
                    ..READY
                },
                "fc_setup_refused",
            ),
            (
                CommandPathStatus {
                    setup_changed: true,
                    ..READY
                },
                "fc_setup_changed",
            ),
            (
                CommandPathStatus {
                    ready_at_us: None,
                    ..READY
                },
                "command_port_down",
            ),
            (
                CommandPathStatus {
                    ready_at_us: Some(now + 300_000),
                    ..READY
                },
                "override_warming_up",
            ),
            (
                CommandPathStatus {
                    roll_not_in_effect: true,
                    ..READY
                },
                "roll_not_in_effect",
            ),
            (CommandPathStatus { fc: None, ..READY }, "no_fc_status"),
            (
                CommandPathStatus {
                    fc: Some(FcStatus {
                        t_us: now - 300_000,
                        ..FC_OK
                    }),
                    ..READY
                },
                "fc_status_stale",
            ),
            (
                CommandPathStatus {
                    fc: Some(FcStatus {
                        failsafe: true,
                        ..FC_OK
                    }),
                    ..READY
                },
                "autopilot_failsafe",
            ),
            (
                CommandPathStatus {
                    fc: Some(FcStatus {
                        armed: false,
                        ..FC_OK
                    }),
                    ..READY
                },
                "disarmed",
            ),
            (
                CommandPathStatus {
                    fc: Some(FcStatus {
                        override_on: false,
                        ..FC_OK
                    }),
                    ..READY
                },
                "override_mode_off",
            ),
            (
                CommandPathStatus {
                    fc: Some(FcStatus {
                        angle: false,
                        ..FC_OK
                    }),
                    ..READY
                },
                "angle_mode_off",
            ),
        ];
        for (path, kind) in cases {
            let state = evaluate(&cfg, &v, &p, &path, now);
            assert_eq!(serde_json::to_value(state).unwrap()["kind"], kind);
        }
        let (mut manual, _) = all_good(now);
        manual.rc.as_mut().unwrap().values_us[5] = 1000;
        let state = evaluate(&cfg, &manual, &p, &cases[3].0, now);
        assert!(
            matches!(state, GateState::Closed(Blocker::SwitchNotAuto { .. })),
            "the switch is named before the command path: {state:?}"
        );
    }

    fn all_good(now_us: i64) -> (VehicleState, PipelineStatus) {
        let mut channels = [1500u16; 18];
        channels[5] = 1900;
        let vehicle = VehicleState {
            link_up: true,
            heartbeat: Some(Heartbeat {
                t_us: now_us - 500_000,
                armed: true,
                custom_mode: 0,
                system_status: 4,
            }),
            rc: Some(RcChannels {
                t_us: now_us - 50_000,
                count: 8,
                values_us: channels,
            }),
            last_attitude_us: Some(now_us - 20_000),
            radio: Some(RadioHealth {
                t_us: now_us - 60_000,
                healthy: true,
            }),
        };
        let pipeline = PipelineStatus {
            last_cycle_us: Some(now_us - 10_000),
            problem: None,
        };
        (vehicle, pipeline)
    }

    #[test]
    fn opens_only_when_everything_holds() {
        let cfg = GateConfig::default();
        let now = 10_000_000;
        let (v, p) = all_good(now);
        assert_eq!(evaluate(&cfg, &v, &p, &READY, now), GateState::Open);
    }

    #[test]
    fn each_condition_alone_closes_it() {
        let cfg = GateConfig::default();
        let now = NOW;
        type Breaker = fn(&mut VehicleState, &mut PipelineStatus);
        let cases: [(Breaker, &str); 16] = [
            (|v, _| v.link_up = false, "link_down"),
            (|v, _| v.rc = None, "no_rc"),
            (|v, _| v.rc.as_mut().unwrap().t_us -= 400_000, "rc_stale"),
            (|v, _| v.rc.as_mut().unwrap().count = 4, "switch_missing"),
            (
                |v, _| v.rc.as_mut().unwrap().values_us[5] = 1000,
                "switch_not_auto",
            ),
            (|v, _| v.heartbeat = None, "no_heartbeat"),
            (
                |v, _| v.heartbeat.as_mut().unwrap().t_us -= 3_000_000,
                "heartbeat_stale",
            ),
            (
                |v, _| v.heartbeat.as_mut().unwrap().armed = false,
                "disarmed",
            ),
            (
                |v, _| v.heartbeat.as_mut().unwrap().system_status = 5,
                "autopilot_failsafe",
            ),
            (
                |v, _| v.radio.as_mut().unwrap().healthy = false,
                "radio_lost",
            ),
            (|v, _| v.radio = None, "no_radio_status"),
            (
                |v, _| v.radio.as_mut().unwrap().t_us -= 400_000,
                "radio_status_stale",
            ),
            (|v, _| v.last_attitude_us = None, "no_attitude"),
            (
                |v, _| *v.last_attitude_us.as_mut().unwrap() -= 200_000,
                "attitude_stale",
            ),
            (|_, p| p.last_cycle_us = None, "pipeline_not_running"),
            (
                |_, p| p.problem = Some(PipelineProblem::NoEvents),
                "pipeline_unhealthy",
            ),
        ];
        for (breaker, kind) in cases {
            let (mut v, mut p) = all_good(now);
            breaker(&mut v, &mut p);
            let state = evaluate(&cfg, &v, &p, &READY, now);
            let json = serde_json::to_value(state).unwrap();
            assert_eq!(json["kind"], kind, "{state:?}");
        }
    }

    #[test]
    fn switch_range_is_inclusive() {
        let cfg = GateConfig::default();
        let now = NOW;
        for (value, open) in [(1699, false), (1700, true), (2100, true), (2101, false)] {
            let (mut v, p) = all_good(now);
            v.rc.as_mut().unwrap().values_us[5] = value;
            assert_eq!(
                evaluate(&cfg, &v, &p, &READY, now).is_open(),
                open,
                "{value}"
            );
        }
    }
}
