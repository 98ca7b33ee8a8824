//! One avoidance roll as a state machine: idle, rolling, cooling down.
//!
//! A roll starts only through an open gate and outside the cool-down, lasts its
//! duration, and ends the moment the gate closes. Its output is the value the roll
//! channel must hold now: iNav's centre, or the centre plus or minus the deflection.
//! Pure: time comes in as an argument. [`super::commander`] wraps it with the rules
//! around it (the gate, fresh decisions, the roll check).

use serde::{Deserialize, Serialize};

use super::rc::{NEUTRAL_US, RcChannel};
use crate::decide::RollDirection;
use crate::invalid::{Invalid, check};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ManoeuvreConfig {
    /// RC channel (1-based, iNav's order; AETR puts roll on 1) the roll is sent on.
    pub roll_channel: RcChannel,
    /// Roll stick deflection from iNav's centre (1500), microseconds (300 is 60% of
    /// full stick; in iNav's ANGLE mode that is 60% of max_angle_inclination_rll).
    pub deflection_us: u16,
    /// How often the route re-sends the held roll (the centre while idle), so that
    /// the autopilot does not time the override out. What periods a route can keep
    /// is the route's to check (iNav's MSP stream: whole MSP slots, under half of
    /// iNav's signal timeout).
    pub resend_period_us: i64,
    /// How many times the centre is written when faithd stops, one period apart, so
    /// that one lost frame cannot leave the stick deflected.
    pub release_repeats: u32,
    /// No new roll for this long after a roll ends or is cut.
    pub cooldown_us: i64,
}

impl Default for ManoeuvreConfig {
    fn default() -> Self {
        Self {
            roll_channel: const { RcChannel::constant(1) },
            deflection_us: 300,
            // Two of the MSP stream's 20 ms slots: the roll frame every other slot.
            resend_period_us: 40_000,
            release_repeats: 3,
            cooldown_us: 1_000_000,
        }
    }
}

/// Keys `[manoeuvre]` once had, and why they are refused now: a config that still
/// sets them is told the reason, not "unknown field".
pub const REMOVED_KEYS: [(&str, &str); 2] = [
    (
        "neutral_us",
        "it was removed: iNav's stick centre is always 1500 (fc/fc_core.c), and any other centre is a standing bank while the switch is in AUTO",
    ),
    (
        "reversed",
        "it was removed: iNav has no RC reversal (a value above 1500 always rolls right), so a reversed roll would only mirror every roll toward the obstacle",
    ),
];

impl ManoeuvreConfig {
    /// `[manoeuvre]`: roll on iNav's channel 1, a deflection that keeps the stick in
    /// 1000..2000, release and cool-down counts the route can keep. The re-send
    /// period is checked by the route that keeps it.
    pub fn validate(&self) -> Result<(), Invalid> {
        let m = self;
        check(m.roll_channel.get() == 1, "manoeuvre.roll_channel", || {
            format!(
                "must be 1: iNav's roll is its channel 1 whatever the radio's order (faithd reads iNav's channel map), got {}",
                m.roll_channel
            )
        })?;
        check(
            (1..=500).contains(&m.deflection_us),
            "manoeuvre.deflection_us",
            || {
                format!(
                    "must be 1..500 (the stick stays within 1000..2000 about iNav's centre 1500), got {}",
                    m.deflection_us
                )
            },
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

    /// The roll channel's value for a roll in `direction` (iNav: above 1500 rolls
    /// right).
    pub fn roll_value_us(&self, direction: RollDirection) -> u16 {
        match direction {
            RollDirection::Right => NEUTRAL_US + self.deflection_us,
            RollDirection::Left => NEUTRAL_US - self.deflection_us,
        }
    }
}

/// A roll the pipeline asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RollRequest {
    pub direction: RollDirection,
    pub duration_us: i64,
}

/// Why the manoeuvre changed state: one log line each.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Transition {
    Started {
        direction: RollDirection,
        value_us: u16,
        duration_us: i64,
    },
    Completed,
    /// The gate closed mid-roll.
    Cut,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum State {
    Idle,
    Rolling { value_us: u16, end_us: i64 },
}

/// The roll in progress, if any, and the cool-down after it.
#[derive(Clone, Debug)]
pub struct Manoeuvre {
    config: ManoeuvreConfig,
    state: State,
    cooldown_until_us: i64,
}

impl Manoeuvre {
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

    /// The value the roll channel holds now: the roll's, or iNav's centre.
    pub fn held_us(&self) -> u16 {
        match self.state {
            State::Rolling { value_us, .. } => value_us,
            State::Idle => NEUTRAL_US,
        }
    }

    /// Advances to `now_us` with the gate `open` or not; `request` is a fresh roll
    /// decision, if the pipeline has one.
    pub fn step(
        &mut self,
        now_us: i64,
        open: bool,
        request: Option<RollRequest>,
    ) -> Option<Transition> {
        match self.state {
            State::Rolling { .. } if !open => {
                self.end(now_us);
                Some(Transition::Cut)
            }
            State::Rolling { end_us, .. } if now_us >= end_us => {
                self.end(now_us);
                Some(Transition::Completed)
            }
            State::Rolling { .. } => None,
            State::Idle => {
                let r = request.filter(|_| open && now_us >= self.cooldown_until_us)?;
                let value_us = self.config.roll_value_us(r.direction);
                self.state = State::Rolling {
                    value_us,
                    end_us: now_us + r.duration_us,
                };
                Some(Transition::Started {
                    direction: r.direction,
                    value_us,
                    duration_us: r.duration_us,
                })
            }
        }
    }

    fn end(&mut self, now_us: i64) {
        self.cooldown_until_us = now_us + self.config.cooldown_us;
        self.state = State::Idle;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn right(duration_us: i64) -> Option<RollRequest> {
        Some(RollRequest {
            direction: RollDirection::Right,
            duration_us,
        })
    }

    #[test]
    fn a_roll_holds_its_value_for_its_duration_then_the_centre() {
        let mut m = Manoeuvre::new(ManoeuvreConfig::default());
        assert_eq!(m.held_us(), 1500);
        assert_eq!(
            m.step(0, true, right(1_500_000)),
            Some(Transition::Started {
                direction: RollDirection::Right,
                value_us: 1800,
                duration_us: 1_500_000
            })
        );
        assert_eq!(m.held_us(), 1800);
        assert_eq!(m.step(1_499_999, true, None), None);
        assert_eq!(m.held_us(), 1800);
        assert_eq!(m.step(1_500_000, true, None), Some(Transition::Completed));
        assert_eq!(m.held_us(), 1500);
    }

    #[test]
    fn a_closing_gate_cuts_the_roll_and_a_closed_one_starts_none() {
        let mut m = Manoeuvre::new(ManoeuvreConfig {
            cooldown_us: 0,
            ..Default::default()
        });
        assert_eq!(m.step(0, false, right(1_500_000)), None);
        assert_eq!(m.held_us(), 1500);
        m.step(10, true, right(1_500_000));
        assert_eq!(m.step(500_000, false, None), Some(Transition::Cut));
        assert_eq!(m.held_us(), 1500);
    }

    #[test]
    fn cooldown_blocks_the_next_roll() {
        let mut m = Manoeuvre::new(ManoeuvreConfig::default());
        m.step(0, true, right(500_000));
        m.step(500_000, true, right(500_000));
        assert!(!m.is_rolling());
        assert_eq!(m.step(1_499_999, true, right(500_000)), None);
        assert!(m.step(1_500_000, true, right(500_000)).is_some());
    }

    #[test]
    fn left_is_below_inavs_centre() {
        let c = ManoeuvreConfig::default();
        assert_eq!(c.roll_value_us(RollDirection::Left), 1200);
        assert_eq!(c.roll_value_us(RollDirection::Right), 1800);
    }
}
