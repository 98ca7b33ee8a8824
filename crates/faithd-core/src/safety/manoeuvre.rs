//! The avoidance manoeuvre as a state machine: idle, rolling, releasing, cooling down.
//!
//! The commander is stepped by the daemon at every send period and whenever the gate
//! or a decision changes; each step returns at most one command for the sink. It
//! never commands while the gate is closed, releases the roll channel the moment
//! the gate closes mid-roll, re-sends the roll every `resend_period_us` so the
//! autopilot does not time it out, and ends every roll with an explicit release.
//! Pure: time comes in as an argument.

use serde::{Deserialize, Serialize};

use super::gate::GateState;
use super::rc::{PwmUs, RcChannel};
use crate::decide::RollDirection;
use crate::invalid::{Invalid, check};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ManoeuvreConfig {
    /// RC channel (1-based, iNav's order; AETR puts roll on 1) the roll is sent on.
    pub roll_channel: RcChannel,
    /// Stick centre.
    pub neutral_us: PwmUs,
    /// Roll stick deflection from centre, microseconds (300 is 60% of full stick;
    /// in iNav's ANGLE mode that is 60% of max_angle_inclination_rll).
    pub deflection_us: u16,
    /// True when a positive deflection rolls left (a reversed channel).
    pub reversed: bool,
    /// Re-send period of the override while rolling, microseconds.
    pub resend_period_us: i64,
    /// How many times the release is sent (one per resend period), so that one lost
    /// frame cannot leave the stick deflected.
    pub release_repeats: u32,
    /// No new roll for this long after a roll ends or is cut.
    pub cooldown_us: i64,
}

impl Default for ManoeuvreConfig {
    fn default() -> Self {
        Self {
            roll_channel: const { RcChannel::constant(1) },
            neutral_us: const { PwmUs::constant(1500) },
            deflection_us: 300,
            reversed: false,
            resend_period_us: 20_000,
            release_repeats: 3,
            cooldown_us: 1_000_000,
        }
    }
}

impl ManoeuvreConfig {
    /// `[manoeuvre]`: roll on iNav's channel 1, a deflection that keeps the stick in
    /// 1000..2000, resend and release counts the stream can keep.
    pub fn validate(&self) -> Result<(), Invalid> {
        let m = self;
        check(m.roll_channel.get() == 1, "manoeuvre.roll_channel", || {
            format!(
                "must be 1: iNav's roll is its channel 1 whatever the radio's order (faithd reads iNav's channel map), got {}",
                m.roll_channel
            )
        })?;
        let neutral_us = m.neutral_us.us();
        check(
            (1000..=2000).contains(&neutral_us),
            "manoeuvre.neutral_us",
            || format!("must be 1000..2000, got {neutral_us}"),
        )?;
        check(
            (1..=500).contains(&m.deflection_us)
                && neutral_us - m.deflection_us >= 1000
                && neutral_us + m.deflection_us <= 2000,
            "manoeuvre.deflection_us",
            || {
                format!(
                    "must be 1..500 and keep the stick within 1000..2000, got {}",
                    m.deflection_us
                )
            },
        )?;
        check(
            (5_000..=500_000).contains(&m.resend_period_us),
            "manoeuvre.resend_period_us",
            || format!("must be 5 to 500 ms, got {}", m.resend_period_us),
        )?;
        check(
            (1..=50).contains(&m.release_repeats),
            "manoeuvre.release_repeats",
            || format!("must be 1 to 50, got {}", m.release_repeats),
        )?;
        check(
            (0..=60_000_000).contains(&m.cooldown_us),
            "manoeuvre.cooldown_us",
            || format!("must be 0 to 60 s, got {}", m.cooldown_us),
        )
    }
}

/// What the sink must put on the wire now.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Command {
    /// Hold the roll channel at this value.
    Roll { channel: u8, value_us: u16 },
    /// Give the roll channel back to the pilot.
    Release { channel: u8 },
}

/// Why the commander changed state: one log line each.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Transition {
    Started {
        direction: RollDirection,
        duration_us: i64,
    },
    Completed,
    /// The gate closed mid-roll.
    Cut,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum State {
    Idle,
    Rolling {
        value_us: u16,
        end_us: i64,
        next_send_us: i64,
    },
    Releasing {
        remaining: u32,
        next_send_us: i64,
    },
}

/// A roll the pipeline asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RollRequest {
    pub direction: RollDirection,
    pub duration_us: i64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Step {
    pub command: Option<Command>,
    pub transition: Option<Transition>,
}

#[derive(Clone, Debug)]
pub struct Commander {
    config: ManoeuvreConfig,
    state: State,
    cooldown_until_us: i64,
}

impl Commander {
    pub fn new(config: ManoeuvreConfig) -> Self {
        Self {
            config,
            state: State::Idle,
            cooldown_until_us: i64::MIN,
        }
    }

    pub fn is_rolling(&self) -> bool {
        matches!(self.state, State::Rolling { .. })
    }

    /// Stick value for a roll in `direction`.
    pub fn roll_value_us(&self, direction: RollDirection) -> u16 {
        let c = &self.config;
        let right = matches!(direction, RollDirection::Right) != c.reversed;
        if right {
            c.neutral_us.us().saturating_add(c.deflection_us)
        } else {
            c.neutral_us.us().saturating_sub(c.deflection_us)
        }
    }

    /// Advances to `now_us`. `request` is the pipeline's newest roll decision, if any.
    pub fn step(&mut self, now_us: i64, gate: &GateState, request: Option<RollRequest>) -> Step {
        let channel = self.config.roll_channel.get();
        match self.state {
            State::Rolling { .. } if !gate.is_open() => {
                self.begin_release(now_us);
                Step {
                    command: Some(Command::Release { channel }),
                    transition: Some(Transition::Cut),
                }
            }
            State::Rolling { end_us, .. } if now_us >= end_us => {
                self.begin_release(now_us);
                Step {
                    command: Some(Command::Release { channel }),
                    transition: Some(Transition::Completed),
                }
            }
            State::Rolling {
                value_us,
                end_us,
                next_send_us,
            } => {
                if now_us < next_send_us {
                    return Step::default();
                }
                self.state = State::Rolling {
                    value_us,
                    end_us,
                    next_send_us: now_us + self.config.resend_period_us,
                };
                Step {
                    command: Some(Command::Roll { channel, value_us }),
                    transition: None,
                }
            }
            State::Releasing {
                remaining,
                next_send_us,
            } => {
                if now_us < next_send_us {
                    return Step::default();
                }
                self.state = if remaining <= 1 {
                    State::Idle
                } else {
                    State::Releasing {
                        remaining: remaining - 1,
                        next_send_us: now_us + self.config.resend_period_us,
                    }
                };
                Step {
                    command: Some(Command::Release { channel }),
                    transition: None,
                }
            }
            State::Idle => match request {
                Some(r) if gate.is_open() && now_us >= self.cooldown_until_us => {
                    let value_us = self.roll_value_us(r.direction);
                    self.state = State::Rolling {
                        value_us,
                        end_us: now_us + r.duration_us,
                        next_send_us: now_us + self.config.resend_period_us,
                    };
                    Step {
                        command: Some(Command::Roll { channel, value_us }),
                        transition: Some(Transition::Started {
                            direction: r.direction,
                            duration_us: r.duration_us,
                        }),
                    }
                }
                _ => Step::default(),
            },
        }
    }

    /// The first release goes out now; the repeats follow one period apart.
    fn begin_release(&mut self, now_us: i64) {
        self.cooldown_until_us = now_us + self.config.cooldown_us;
        self.state = if self.config.release_repeats <= 1 {
            State::Idle
        } else {
            State::Releasing {
                remaining: self.config.release_repeats - 1,
                next_send_us: now_us + self.config.resend_period_us,
            }
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::safety::gate::Blocker;

    const OPEN: GateState = GateState::Open;
    const CLOSED: GateState = GateState::Closed(Blocker::SwitchNotAuto { value_us: 1000 });

    fn right(duration_us: i64) -> Option<RollRequest> {
        Some(RollRequest {
            direction: RollDirection::Right,
            duration_us,
        })
    }

    /// Steps every `dt_us` from `from_us` to `to_us`, collecting commands.
    fn run(
        c: &mut Commander,
        from_us: i64,
        to_us: i64,
        dt_us: i64,
        gate: impl Fn(i64) -> GateState,
        request: impl Fn(i64) -> Option<RollRequest>,
    ) -> Vec<(i64, Command)> {
        let mut out = Vec::new();
        let mut t = from_us;
        while t <= to_us {
            if let Some(cmd) = c.step(t, &gate(t), request(t)).command {
                out.push((t, cmd));
            }
            t += dt_us;
        }
        out
    }

    #[test]
    fn a_roll_lasts_its_duration_resent_every_period_then_released() {
        let cfg = ManoeuvreConfig::default();
        let mut c = Commander::new(cfg);
        let sent = run(
            &mut c,
            0,
            3_000_000,
            1_000,
            |_| OPEN,
            |t| right(1_500_000).filter(|_| t == 0),
        );
        let rolls: Vec<_> = sent
            .iter()
            .filter(|(_, c)| matches!(c, Command::Roll { .. }))
            .collect();
        assert_eq!(rolls.first().unwrap().0, 0);
        assert_eq!(rolls.last().unwrap().0, 1_480_000);
        assert_eq!(rolls.len(), 75, "one every 20 ms over 1.5 s");
        assert!(rolls.iter().all(|(_, c)| *c
            == Command::Roll {
                channel: 1,
                value_us: 1800
            }));
        let releases: Vec<_> = sent
            .iter()
            .filter(|(_, c)| matches!(c, Command::Release { .. }))
            .map(|(t, _)| *t)
            .collect();
        assert_eq!(releases, vec![1_500_000, 1_520_000, 1_540_000]);
    }

    #[test]
    fn closing_gate_mid_roll_releases_at_once_and_nothing_follows_until_it_reopens() {
        let mut c = Commander::new(ManoeuvreConfig {
            cooldown_us: 0,
            ..Default::default()
        });
        let gate = |t: i64| {
            if (500_000..900_000).contains(&t) {
                CLOSED
            } else {
                OPEN
            }
        };
        let sent = run(&mut c, 0, 2_000_000, 1_000, gate, |t| {
            right(1_500_000).filter(|_| t == 0 || t == 600_000)
        });
        let first_release = sent
            .iter()
            .find(|(_, c)| matches!(c, Command::Release { .. }))
            .unwrap();
        assert_eq!(
            first_release.0, 500_000,
            "released in the step the gate closed"
        );
        assert!(
            sent.iter()
                .filter(|(t, _)| (500_000..900_000).contains(t))
                .all(|(_, c)| matches!(c, Command::Release { .. })),
            "{sent:?}"
        );
        assert!(
            sent.iter().all(|(t, _)| *t < 900_000),
            "the request made while closed is not replayed later"
        );
    }

    #[test]
    fn closed_gate_never_commands_a_roll() {
        let mut c = Commander::new(ManoeuvreConfig::default());
        let sent = run(
            &mut c,
            0,
            1_000_000,
            1_000,
            |_| CLOSED,
            |_| right(1_500_000),
        );
        assert!(sent.is_empty(), "{sent:?}");
    }

    #[test]
    fn cooldown_blocks_the_next_roll() {
        let cfg = ManoeuvreConfig::default();
        let mut c = Commander::new(cfg);
        let sent = run(&mut c, 0, 4_000_000, 10_000, |_| OPEN, |_| right(500_000));
        let starts: Vec<_> = sent
            .windows(2)
            .filter(|w| {
                matches!(w[0].1, Command::Release { .. }) && matches!(w[1].1, Command::Roll { .. })
            })
            .map(|w| w[1].0)
            .collect();
        // Rolls end at 0.5 s and released; the next may start at 1.5 s.
        assert_eq!(starts[0], 1_500_000);
    }

    #[test]
    fn left_and_reversed() {
        let c = Commander::new(ManoeuvreConfig::default());
        assert_eq!(c.roll_value_us(RollDirection::Left), 1200);
        let c = Commander::new(ManoeuvreConfig {
            reversed: true,
            ..Default::default()
        });
        assert_eq!(c.roll_value_us(RollDirection::Left), 1800);
    }
}
