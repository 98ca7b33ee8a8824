//! The commander's rules: what the roll channel holds at every moment, and why.
//!
//! One step takes everything the daemon knows (the vehicle, the pipeline, the
//! command path to the autopilot, the newest roll decision, the newest value the
//! autopilot reports using on roll) and the time, and returns the gate, the value the roll channel must
//! hold, and every change, each named. The rules it keeps:
//!
//! - a roll decision is acted on only while it is fresh (two pipeline periods);
//! - a roll starts only through an open gate, and is cut the moment the gate closes;
//! - a roll that iNav does not report using within `confirm_within_us` is a fault,
//!   latched (the gate stays closed) until the pilot takes the switch out of AUTO;
//! - between rolls, and whenever anything fails, the roll channel holds iNav's
//!   centre.
//!
//! Pure, like [`super::gate`]: the daemon's async task only moves values in and out.

use serde::Serialize;

use super::confirm::{RollConfirm, Verdict};
use super::gate::{
    self, Blocker, CommandPathStatus, GateConfig, GateState, PipelineStatus, RouteWords,
};
use super::manoeuvre::{Manoeuvre, ManoeuvreConfig, RollRequest, Transition};
use super::rc::NEUTRAL_US;
use super::vehicle::VehicleState;
use crate::decide::RollDirection;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CommanderConfig {
    pub gate: GateConfig,
    pub manoeuvre: ManoeuvreConfig,
    /// What the autopilot reports using for each roll: the route works it out from
    /// the autopilot's own calibration (iNav scales roll by its `rxrange`).
    pub reported_roll: ReportedRoll,
    /// A roll iNav does not report using within this is a fault.
    pub confirm_within_us: i64,
    /// A roll decision older than this is stale and not acted on.
    pub decision_fresh_us: i64,
}

/// The value the autopilot reports using while it takes a roll left or right: what
/// faithd commands, unless the autopilot's calibration of the channel moves it. The
/// roll check compares reports with these, not with the commanded values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReportedRoll {
    pub left_us: u16,
    pub right_us: u16,
}

impl ReportedRoll {
    /// An autopilot that uses the values as commanded.
    pub fn as_commanded(manoeuvre: &ManoeuvreConfig) -> Self {
        Self {
            left_us: manoeuvre.roll_value_us(RollDirection::Left),
            right_us: manoeuvre.roll_value_us(RollDirection::Right),
        }
    }

    /// The value reported during a roll in `direction`.
    pub fn for_direction(self, direction: RollDirection) -> u16 {
        match direction {
            RollDirection::Left => self.left_us,
            RollDirection::Right => self.right_us,
        }
    }
}

/// What the route to the autopilot last reported, as the commander reads it: the
/// command path's state and the newest roll value the autopilot reports using.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RouteStatus {
    pub path: CommandPathStatus,
    pub last_report: Option<RollReport>,
}

impl RouteStatus {
    /// A route that has read nothing yet.
    pub const fn unchecked(words: &'static RouteWords) -> Self {
        Self {
            path: CommandPathStatus::unchecked(words),
            last_report: None,
        }
    }
}

/// The pipeline asked for a roll at `t_us`; `last_event_us` is the newest event of
/// the window that decided it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RollCall {
    pub t_us: i64,
    pub request: RollRequest,
    pub last_event_us: i64,
}

/// The roll channel's value the autopilot reported using (iNav: MSP_RC), read at
/// daemon time `t_us`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RollReport {
    pub t_us: i64,
    pub roll_us: u16,
}

/// What the daemon knows at a step.
#[derive(Clone, Copy, Debug)]
pub struct Inputs<'a> {
    pub vehicle: &'a VehicleState,
    pub pipeline: &'a PipelineStatus,
    /// The route's state; its `roll_not_in_effect` is ignored (the commander keeps
    /// that latch itself).
    pub path: &'a CommandPathStatus,
    /// The newest roll call, when it is new since the last step.
    pub call: Option<RollCall>,
    /// The newest report, when it is new since the last step.
    pub report: Option<RollReport>,
}

/// A change the journal, the ground station or a harness hears of.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Event {
    /// The gate opened, or closed, or closed for another kind of reason.
    GateChanged {
        gate: GateState,
        was_open: Option<bool>,
    },
    RollStarted {
        direction: RollDirection,
        /// The value iNav uses during the roll.
        value_us: u16,
        duration_us: i64,
        /// The newest event of the deciding window, and of the first window of the
        /// unbroken run of roll calls that led to it (earlier when the gate held the
        /// roll back).
        last_event_us: i64,
        first_call_event_us: i64,
    },
    RollCompleted,
    RollCut {
        because: Blocker,
    },
    /// iNav reported using the roll `after_us` after it started.
    RollConfirmed {
        roll_us: u16,
        after_us: i64,
    },
    /// iNav has not used the roll for longer than the bound: latched fault.
    RollNotInEffect {
        commanded_us: u16,
        reported_us: Option<u16>,
        waited_us: i64,
    },
    /// The pilot took the switch out of AUTO: the latched fault is cleared.
    FaultCleared,
}

/// The outcome of a step.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    pub gate: GateState,
    /// The value the roll channel must hold now, as iNav should use it.
    pub held_us: u16,
    pub events: Vec<Event>,
}

#[derive(Clone, Debug)]
pub struct Commander {
    config: CommanderConfig,
    manoeuvre: Manoeuvre,
    confirm: RollConfirm,
    /// A roll did not take effect: the gate stays closed until the switch leaves AUTO.
    fault_latched: bool,
    call: Option<RollCall>,
    first_call_event_us: Option<i64>,
    last_gate: Option<GateState>,
}

impl Commander {
    pub fn new(config: CommanderConfig) -> Self {
        Self {
            config,
            manoeuvre: Manoeuvre::new(config.manoeuvre),
            confirm: RollConfirm::new(config.confirm_within_us),
            fault_latched: false,
            call: None,
            first_call_event_us: None,
            last_gate: None,
        }
    }

    pub fn is_rolling(&self) -> bool {
        self.manoeuvre.is_rolling()
    }

    /// Advances to `now_us`.
    pub fn step(&mut self, now_us: i64, inputs: Inputs<'_>) -> Step {
        let mut events = Vec::new();
        if let Some(report) = inputs.report
            && let Verdict::Confirmed { after_us } =
                self.confirm.report(report.roll_us, report.t_us)
        {
            events.push(Event::RollConfirmed {
                roll_us: report.roll_us,
                after_us,
            });
        }
        if let Verdict::NotInEffect {
            commanded_us,
            reported_us,
            waited_us,
        } = self.confirm.check(now_us)
        {
            self.fault_latched = true;
            self.confirm.stop();
            events.push(Event::RollNotInEffect {
                commanded_us,
                reported_us,
                waited_us,
            });
        }

        let path = CommandPathStatus {
            roll_not_in_effect: self.fault_latched,
            ..*inputs.path
        };
        let gate = gate::evaluate(
            &self.config.gate,
            inputs.vehicle,
            inputs.pipeline,
            &path,
            now_us,
        );
        if self.fault_latched && matches!(gate, GateState::Closed(Blocker::SwitchNotAuto { .. })) {
            self.fault_latched = false;
            events.push(Event::FaultCleared);
        }
        if self.kind_changed(gate) {
            events.push(Event::GateChanged {
                gate,
                was_open: self.last_gate.map(|g| g.is_open()),
            });
        }
        self.last_gate = Some(gate);

        if inputs.call.is_some() {
            self.call = inputs.call;
        }
        let fresh = self
            .call
            .filter(|c| now_us - c.t_us <= self.config.decision_fresh_us);
        self.first_call_event_us =
            fresh.and(self.first_call_event_us.or(fresh.map(|c| c.last_event_us)));

        match self
            .manoeuvre
            .step(now_us, gate.is_open(), fresh.map(|c| c.request))
        {
            Some(Transition::Started {
                direction,
                value_us,
                duration_us,
            }) => {
                let call = fresh.expect("a roll starts only from a fresh call");
                events.push(Event::RollStarted {
                    direction,
                    value_us,
                    duration_us,
                    last_event_us: call.last_event_us,
                    first_call_event_us: self.first_call_event_us.unwrap_or(call.last_event_us),
                });
                self.call = None;
                self.first_call_event_us = None;
                let used_us = self.config.reported_roll.for_direction(direction);
                self.confirm.start(used_us, now_us);
            }
            Some(Transition::Completed) => {
                self.confirm.stop();
                events.push(Event::RollCompleted);
            }
            Some(Transition::Cut) => {
                self.confirm.stop();
                let because = match gate {
                    GateState::Closed(b) => b,
                    GateState::Open => unreachable!("a roll is cut only by a closed gate"),
                };
                events.push(Event::RollCut { because });
            }
            None => {}
        }
        Step {
            gate,
            held_us: if self.manoeuvre.is_rolling() {
                self.manoeuvre.held_us()
            } else {
                NEUTRAL_US
            },
            events,
        }
    }

    /// Open against closed, or closed for another kind of reason (not merely an age
    /// that grew).
    fn kind_changed(&self, gate: GateState) -> bool {
        match (self.last_gate, gate) {
            (None, _) => true,
            (Some(GateState::Closed(a)), GateState::Closed(b)) => {
                std::mem::discriminant(&a) != std::mem::discriminant(&b)
            }
            (Some(a), b) => a.is_open() != b.is_open(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::safety::gate::AutopilotStatus;
    use crate::safety::gate::test_words::WORDS;
    use crate::safety::vehicle::{Heartbeat, RadioHealth, RcChannels};

    const PERIOD_US: i64 = 10_000;

    fn config() -> CommanderConfig {
        CommanderConfig {
            gate: GateConfig::default(),
            manoeuvre: ManoeuvreConfig::default(),
            reported_roll: ReportedRoll::as_commanded(&ManoeuvreConfig::default()),
            confirm_within_us: 200_000,
            decision_fresh_us: 2 * PERIOD_US,
        }
    }

    /// A vehicle with every input fresh at `now_us` and the switch at `switch_us`.
    struct World {
        switch_us: u16,
    }

    impl World {
        fn inputs(&self, now_us: i64) -> (VehicleState, PipelineStatus, CommandPathStatus) {
            let mut channels = [1500u16; 18];
            channels[5] = self.switch_us;
            let vehicle = VehicleState {
                link_up: true,
                heartbeat: Some(Heartbeat {
                    t_us: now_us,
                    armed: true,
                    custom_mode: 0,
                    system_status: 4,
                }),
                rc: Some(RcChannels {
                    t_us: now_us,
                    count: 8,
                    values_us: channels,
                }),
                last_attitude_us: Some(now_us),
                radio: Some(RadioHealth {
                    t_us: now_us,
                    healthy: true,
                }),
            };
            let pipeline = PipelineStatus {
                last_cycle_us: Some(now_us),
                problem: None,
            };
            let path = CommandPathStatus {
                setup_refused: false,
                setup_changed: false,
                ready_at_us: Some(0),
                roll_not_in_effect: false,
                autopilot: Some(AutopilotStatus {
                    t_us: now_us,
                    armed: true,
                    failsafe: false,
                    override_active: self.switch_us >= 1700,
                    stabilised: true,
                }),
                words: &WORDS,
            };
            (vehicle, pipeline, path)
        }
    }

    fn call(t_us: i64) -> RollCall {
        RollCall {
            t_us,
            request: RollRequest {
                direction: RollDirection::Right,
                duration_us: 1_500_000,
            },
            last_event_us: t_us - 3_000,
        }
    }

    fn step(
        c: &mut Commander,
        world: &World,
        now_us: i64,
        call: Option<RollCall>,
        report: Option<u16>,
    ) -> Step {
        let (v, p, path) = world.inputs(now_us);
        c.step(
            now_us,
            Inputs {
                vehicle: &v,
                pipeline: &p,
                path: &path,
                call,
                report: report.map(|roll_us| RollReport {
                    t_us: now_us,
                    roll_us,
                }),
            },
        )
    }

    #[test]
    fn a_fresh_call_rolls_for_its_duration_and_is_confirmed() {
        let mut c = Commander::new(config());
        let auto = World { switch_us: 1900 };
        let first = step(&mut c, &auto, 0, None, None);
        assert!(first.gate.is_open(), "{first:?}");
        assert_eq!(first.held_us, 1500);
        let s = step(&mut c, &auto, 10_000, Some(call(10_000)), None);
        assert_eq!(s.held_us, 1800);
        assert!(matches!(
            s.events[..],
            [Event::RollStarted {
                value_us: 1800,
                last_event_us: 7_000,
                first_call_event_us: 7_000,
                ..
            }]
        ));
        let s = step(&mut c, &auto, 50_000, None, Some(1800));
        assert_eq!(
            s.events,
            vec![Event::RollConfirmed {
                roll_us: 1800,
                after_us: 40_000
            }]
        );
        for t in (60_000..1_510_000).step_by(20_000) {
            let s = step(&mut c, &auto, t, None, Some(1800));
            assert_eq!(s.held_us, 1800, "{t}");
            assert!(s.events.is_empty(), "{t}: {:?}", s.events);
        }
        let s = step(&mut c, &auto, 1_510_000, None, Some(1800));
        assert_eq!(s.held_us, 1500);
        assert_eq!(s.events, vec![Event::RollCompleted]);
    }

    #[test]
    fn a_stale_call_is_never_acted_on() {
        let mut c = Commander::new(config());
        let auto = World { switch_us: 1900 };
        step(&mut c, &auto, 0, None, None);
        // Decided at 0, seen only 2 periods + 1 us later (the gate was just closed).
        let s = step(&mut c, &auto, 2 * PERIOD_US + 1, Some(call(0)), None);
        assert_eq!(s.held_us, 1500);
        assert!(s.events.is_empty(), "{:?}", s.events);
        // Within two periods it is acted on.
        let mut c = Commander::new(config());
        step(&mut c, &auto, 0, None, None);
        let s = step(&mut c, &auto, 2 * PERIOD_US, Some(call(0)), None);
        assert_eq!(s.held_us, 1800);
    }

    #[test]
    fn a_roll_held_back_names_the_first_call_of_its_run() {
        let mut c = Commander::new(config());
        let manual = World { switch_us: 1000 };
        let auto = World { switch_us: 1900 };
        step(&mut c, &manual, 0, Some(call(0)), None);
        step(&mut c, &manual, 10_000, Some(call(10_000)), None);
        let s = step(&mut c, &auto, 20_000, Some(call(20_000)), None);
        assert!(
            matches!(
                s.events[..],
                [
                    Event::GateChanged { .. },
                    Event::RollStarted {
                        last_event_us: 17_000,
                        first_call_event_us: -3_000,
                        ..
                    }
                ]
            ),
            "{:?}",
            s.events
        );
    }

    #[test]
    fn a_roll_not_in_effect_latches_the_gate_shut_until_the_switch_leaves_auto() {
        let mut c = Commander::new(config());
        let auto = World { switch_us: 1900 };
        let manual = World { switch_us: 1000 };
        step(&mut c, &auto, 0, Some(call(0)), None);
        let s = step(&mut c, &auto, 200_000, None, Some(1500));
        assert_eq!(s.held_us, 1800, "within the bound");
        let s = step(&mut c, &auto, 200_001, None, Some(1500));
        assert_eq!(s.held_us, 1500, "released at once");
        assert_eq!(
            s.events,
            vec![
                Event::RollNotInEffect {
                    commanded_us: 1800,
                    reported_us: Some(1500),
                    waited_us: 200_001
                },
                Event::GateChanged {
                    gate: GateState::Closed(Blocker::RollNotInEffect),
                    was_open: Some(true)
                },
                Event::RollCut {
                    because: Blocker::RollNotInEffect
                }
            ]
        );
        // Latched: a fresh call in AUTO, long after, starts nothing.
        let s = step(&mut c, &auto, 5_000_000, Some(call(5_000_000)), None);
        assert_eq!(s.held_us, 1500);
        assert_eq!(s.gate, GateState::Closed(Blocker::RollNotInEffect));
        // MANUAL clears it; back in AUTO a roll may start again.
        let s = step(&mut c, &manual, 5_010_000, None, None);
        assert!(s.events.contains(&Event::FaultCleared), "{:?}", s.events);
        step(&mut c, &auto, 5_020_000, None, None);
        let s = step(&mut c, &auto, 5_030_000, Some(call(5_030_000)), None);
        assert_eq!(s.held_us, 1800);
    }

    #[test]
    fn a_closing_gate_releases_in_the_same_step() {
        let mut c = Commander::new(config());
        let auto = World { switch_us: 1900 };
        let manual = World { switch_us: 1000 };
        step(&mut c, &auto, 0, Some(call(0)), None);
        let s = step(&mut c, &manual, 300_000, None, Some(1800));
        assert_eq!(s.held_us, 1500);
        assert!(matches!(
            s.events.last(),
            Some(Event::RollCut {
                because: Blocker::SwitchNotAuto { value_us: 1000 }
            })
        ));
    }

    #[test]
    fn the_check_expects_the_roll_as_the_route_says_it_lands() {
        // An autopilot whose calibration makes faithd's 1800 read back as 1799.
        let used = 1799;
        let mut c = Commander::new(CommanderConfig {
            reported_roll: ReportedRoll {
                left_us: 1201,
                right_us: used,
            },
            ..config()
        });
        let auto = World { switch_us: 1900 };
        step(&mut c, &auto, 0, Some(call(0)), None);
        let s = step(&mut c, &auto, 30_000, None, Some(1800));
        assert!(
            !matches!(s.events[..], [Event::RollConfirmed { .. }]),
            "the commanded value is not what this autopilot reports: {:?}",
            s.events
        );
        let s = step(&mut c, &auto, 40_000, None, Some(used));
        assert!(
            matches!(s.events[..], [Event::RollConfirmed { .. }]),
            "{:?}",
            s.events
        );
    }
}
