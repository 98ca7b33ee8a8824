//! The pilot's safety gate: may faithd command the vehicle right now?
//!
//! The rule of docs/design.md, checked in a fixed order so the log always names the
//! same first reason for the same situation: the link is up, the pilot's switch is in
//! AUTO, the vehicle is armed, RC, heartbeat and attitude data are fresh, and the
//! pipeline is healthy. Pure: the caller passes the time.
//!
//! The command path (the route that carries the roll to the autopilot) comes in as a
//! [`CommandPathStatus`] that names no autopilot's transport: a set-up accepted or
//! not, an override active, a stabilised mode, a time from which the autopilot takes
//! the roll. The route says how its autopilot words each of these in the journal
//! ([`RouteWords`]), so a user still reads "iNav's MSP RC OVERRIDE mode" while the
//! gate knows only "the override".

use serde::{Deserialize, Serialize};

use super::rc::{PwmUs, RcChannel};
use super::vehicle::VehicleState;
use crate::invalid::{Invalid, check};

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
    /// The autopilot's own status (read by the route to it, e.g. iNav's over MSP)
    /// older than this closes the gate. The key keeps its published name.
    #[serde(rename = "fc_status_stale_us")]
    pub autopilot_status_stale_us: i64,
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
            autopilot_status_stale_us: 250_000,
        }
    }
}

impl GateConfig {
    /// `[gate]`: an AUTO range that leaves the pilot a MANUAL end, and staleness
    /// limits between 1 ms and 10 s. Which channels may carry the switch is the
    /// route's to say (iNav binds its modes to AUX channels only).
    pub fn validate(&self) -> Result<(), Invalid> {
        let g = self;
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
            (g.autopilot_status_stale_us, "gate.fc_status_stale_us"),
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

/// The autopilot's own state as the route reads it (iNav: MSP2_INAV_STATUS at every
/// send period, faster than MAVLink's 1 Hz HEARTBEAT): whether it would take
/// faithd's roll now, and whether a roll there means a bank.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AutopilotStatus {
    /// Daemon time of the read: the gate judges its freshness.
    pub t_us: i64,
    pub armed: bool,
    /// The autopilot's own failsafe (radio lost, or the pilot's failsafe switch).
    pub failsafe: bool,
    /// The autopilot's override of the pilot's roll is active (iNav: its MSP RC
    /// OVERRIDE mode, on only with the pilot's switch in AUTO).
    pub override_active: bool,
    /// The autopilot stabilises attitude, so a roll input commands a bank (iNav:
    /// ANGLE mode). Without it a roll input commands a rotation rate, and 1.5 s of a
    /// deflected stick rolls the vehicle over.
    pub stabilised: bool,
}

/// How a route words the command path's blockers in the journal. The gate only
/// carries the words; every route (the MSP stream to iNav today) has one table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RouteWords {
    pub setup_refused: &'static str,
    pub setup_changed: &'static str,
    pub not_streaming: &'static str,
    pub no_status: &'static str,
    /// Followed by the age: "(N ms)".
    pub status_stale: &'static str,
    /// In "the autopilot is in failsafe (...)".
    pub failsafe: &'static str,
    pub override_inactive: &'static str,
    pub stabilised_mode_off: &'static str,
    /// Followed by the time left: "(N ms to go)".
    pub warming_up: &'static str,
}

/// What the roll command path (the route to the autopilot) last reported.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CommandPathStatus {
    /// The autopilot's set-up was read and refused (the journal has why).
    pub setup_refused: bool,
    /// The set-up changed in flight (the journal has what): faithd stopped
    /// commanding until it is read and judged again.
    pub setup_changed: bool,
    /// Daemon time from which the autopilot takes the route's roll: the route
    /// started plus the autopilot's own recovery delay. `None` while the route is
    /// down or unchecked.
    pub ready_at_us: Option<i64>,
    /// A roll did not take effect on the autopilot; held until the pilot takes the
    /// switch out of AUTO.
    pub roll_not_in_effect: bool,
    /// The autopilot's last status; `None` before the first.
    pub autopilot: Option<AutopilotStatus>,
    /// The route's words for the blockers above.
    pub words: &'static RouteWords,
}

impl CommandPathStatus {
    /// A route that has read nothing yet.
    pub const fn unchecked(words: &'static RouteWords) -> Self {
        Self {
            setup_refused: false,
            setup_changed: false,
            ready_at_us: None,
            roll_not_in_effect: false,
            autopilot: None,
            words,
        }
    }
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
    /// The autopilot is in failsafe: HEARTBEAT system_status, or its own status.
    AutopilotFailsafe {
        source: FailsafeSource,
        #[serde(skip)]
        says: &'static str,
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
    /// The route read the autopilot's set-up and refused it.
    SetupRefused {
        #[serde(skip)]
        says: &'static str,
    },
    /// The autopilot's set-up changed in flight: read and judged again first.
    SetupChanged {
        #[serde(skip)]
        says: &'static str,
    },
    /// The route to the autopilot is not carrying the roll.
    CommandPortDown {
        #[serde(skip)]
        says: &'static str,
    },
    NoAutopilotStatus {
        #[serde(skip)]
        says: &'static str,
    },
    AutopilotStatusStale {
        age_us: i64,
        #[serde(skip)]
        says: &'static str,
    },
    /// The autopilot reports its override off: it would not take faithd's roll.
    OverrideInactive {
        #[serde(skip)]
        says: &'static str,
    },
    /// The autopilot does not stabilise attitude: a roll would command a rate.
    StabilisedModeOff {
        #[serde(skip)]
        says: &'static str,
    },
    /// No SYS_STATUS has said whether the pilot's radio reaches the autopilot.
    NoRadioStatus,
    /// SYS_STATUS stopped: the radio's last known health is too old to trust.
    RadioStatusStale {
        age_us: i64,
    },
    OverrideWarmingUp {
        remaining_us: i64,
        #[serde(skip)]
        says: &'static str,
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
            Blocker::AutopilotFailsafe { says, .. } => {
                write!(f, "the autopilot is in failsafe ({says})")
            }
            Blocker::NoAutopilotStatus { says }
            | Blocker::OverrideInactive { says }
            | Blocker::StabilisedModeOff { says }
            | Blocker::SetupRefused { says }
            | Blocker::SetupChanged { says }
            | Blocker::CommandPortDown { says } => f.write_str(says),
            Blocker::AutopilotStatusStale { age_us, says } => {
                write!(f, "{says} ({} ms)", age_us / 1000)
            }
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
            Blocker::OverrideWarmingUp { remaining_us, says } => {
                write!(f, "{says} ({} ms to go)", remaining_us / 1000)
            }
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
    /// The route's read of the autopilot's status (iNav: its FAILSAFE flight mode).
    AutopilotStatus,
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

/// Why a HEARTBEAT says failsafe: MAVLink's words, the link being MAVLink's.
const HEARTBEAT_FAILSAFE: &str = "HEARTBEAT system_status CRITICAL or worse";

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
    let words = command.words;
    if command.setup_refused {
        return Some(Blocker::SetupRefused {
            says: words.setup_refused,
        });
    }
    if command.setup_changed {
        return Some(Blocker::SetupChanged {
            says: words.setup_changed,
        });
    }
    let Some(ready_at_us) = command.ready_at_us else {
        return Some(Blocker::CommandPortDown {
            says: words.not_streaming,
        });
    };
    let Some(ap) = &command.autopilot else {
        return Some(Blocker::NoAutopilotStatus {
            says: words.no_status,
        });
    };
    let age_us = now_us - ap.t_us;
    if age_us > config.autopilot_status_stale_us {
        return Some(Blocker::AutopilotStatusStale {
            age_us,
            says: words.status_stale,
        });
    }
    if ap.failsafe {
        return Some(Blocker::AutopilotFailsafe {
            source: FailsafeSource::AutopilotStatus,
            says: words.failsafe,
        });
    }
    if !ap.armed {
        return Some(Blocker::Disarmed);
    }
    if !ap.stabilised {
        return Some(Blocker::StabilisedModeOff {
            says: words.stabilised_mode_off,
        });
    }
    if !ap.override_active {
        return Some(Blocker::OverrideInactive {
            says: words.override_inactive,
        });
    }
    if now_us < ready_at_us {
        return Some(Blocker::OverrideWarmingUp {
            remaining_us: ready_at_us - now_us,
            says: words.warming_up,
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
            says: HEARTBEAT_FAILSAFE,
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
    use super::test_words::WORDS;
    use super::*;
    use crate::safety::vehicle::{Heartbeat, RadioHealth, RcChannels};

    const NOW: i64 = 10_000_000;
    const AP_OK: AutopilotStatus = AutopilotStatus {
        t_us: NOW - 10_000,
        armed: true,
        failsafe: false,
        override_active: true,
        stabilised: true,
    };
    const READY: CommandPathStatus = CommandPathStatus {
        setup_refused: false,
        setup_changed: false,
        ready_at_us: Some(0),
        roll_not_in_effect: false,
        autopilot: Some(AP_OK),
        words: &WORDS,
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
                "setup_refused",
            ),
            (
                CommandPathStatus {
                    setup_changed: true,
                    ..READY
                },
                "setup_changed",
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
            (
                CommandPathStatus {
                    autopilot: None,
                    ..READY
                },
                "no_autopilot_status",
            ),
            (
                CommandPathStatus {
                    autopilot: Some(AutopilotStatus {
                        t_us: now - 300_000,
                        ..AP_OK
                    }),
                    ..READY
                },
                "autopilot_status_stale",
            ),
            (
                CommandPathStatus {
                    autopilot: Some(AutopilotStatus {
                        failsafe: true,
                        ..AP_OK
                    }),
                    ..READY
                },
                "autopilot_failsafe",
            ),
            (
                CommandPathStatus {
                    autopilot: Some(AutopilotStatus {
                        armed: false,
                        ..AP_OK
                    }),
                    ..READY
                },
                "disarmed",
            ),
            (
                CommandPathStatus {
                    autopilot: Some(AutopilotStatus {
                        override_active: false,
                        ..AP_OK
                    }),
                    ..READY
                },
                "override_inactive",
            ),
            (
                CommandPathStatus {
                    autopilot: Some(AutopilotStatus {
                        stabilised: false,
                        ..AP_OK
                    }),
                    ..READY
                },
                "stabilised_mode_off",
            ),
        ];
        for (path, kind) in cases {
            let state = evaluate(&cfg, &v, &p, &path, now);
            assert_eq!(serde_json::to_value(state).unwrap()["kind"], kind);
        }
        // The journal reads the route's words, with the age or the time left.
        let texts: Vec<String> = cases
            .iter()
            .map(|(path, _)| match evaluate(&cfg, &v, &p, path, now) {
                GateState::Closed(b) => b.to_string(),
                GateState::Open => String::new(),
            })
            .collect();
        assert_eq!(texts[0], "set-up refused");
        assert_eq!(texts[3], "warming up (300 ms to go)");
        assert_eq!(texts[6], "status stale (300 ms)");
        assert_eq!(texts[7], "the autopilot is in failsafe (its failsafe)");
        assert_eq!(texts[10], "not stabilised");
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

/// A route's words for the tests of the gate and the commander.
#[cfg(test)]
pub(crate) mod test_words {
    use super::RouteWords;

    pub(crate) const WORDS: RouteWords = RouteWords {
        setup_refused: "set-up refused",
        setup_changed: "set-up changed",
        not_streaming: "not streaming",
        no_status: "no status",
        status_stale: "status stale",
        failsafe: "its failsafe",
        override_inactive: "override off",
        stabilised_mode_off: "not stabilised",
        warming_up: "warming up",
    };
}
