//! How iNav's loop stalled in one flight, and whether a stall could have changed what
//! the flight shows.
//!
//! On a loaded machine SITL waits for a core, and its 1 kHz loop comes to the physics
//! server late. The server catches up 20 ms of physics with iNav's last motors; beyond
//! that the exchange is late ([`Stall`]) and the vehicle stands still for the rest,
//! while the wall clock, faithd and its camera go on. What a stall can change, and the
//! bound each check keeps:
//!
//! - **The roll's timings and bank.** A stall between the deciding event and the end of
//!   the roll's measurement (2 s after it began) lengthens every figure after it by up
//!   to its own length, and a late exchange is a stall of more than 20 ms: more than the
//!   tightest timing tolerance (15 ms, [`super::measured`]). Such a roll is *disturbed*:
//!   its figures are reported and left out of the bounds on iNav's figures.
//! - **The clearance.** While the vehicle stood still, faithd's pipeline did not: a roll
//!   that took effect after a stall had that much more time. Had the vehicle flown on,
//!   the same manoeuvre would have started at most `stalled time x speed` further along
//!   the course, and the pass moves no further than the manoeuvre does: an avoidance
//!   counts when its clearance is larger than that ([`StallFigures::clearance_gift_m`]).
//!   Every stall from the start of the course to the roll at the mixer counts, the
//!   conservative choice.
//!
//! Nothing here bounds how often iNav stalls: that is the machine's load, not faithd.

use std::time::Instant;

use serde::Serialize;

use crate::realflight::server::Stall;

/// One flight's stalls, as the checks read them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StallFigures {
    /// Exchanges iNav came to late over the whole flight, take-off included.
    pub late_exchanges: u64,
    /// The longest and the summed stall of those, ms.
    pub worst_ms: f64,
    pub total_ms: f64,
    /// Stalled time from the start of the course to the roll at iNav's mixer (to the
    /// end of the flight when nothing rolled), ms.
    pub before_mixer_ms: f64,
    /// Late exchanges in the roll's span: the deciding event to 2 s after the roll.
    pub in_roll: u64,
    /// The fastest the vehicle flew along the course before the roll took effect, m/s.
    pub approach_speed_m_s: f64,
}

/// Where in the flight the checks look, on the wall clock.
#[derive(Clone, Copy, Debug)]
pub struct Spans {
    /// The start of the course (the model's start point reached).
    pub course_start: Instant,
    /// The roll at iNav's mixer, when there was one.
    pub mixer: Option<Instant>,
    /// The deciding event to the end of the roll's measurement.
    pub roll: Option<(Instant, Instant)>,
    pub approach_speed_m_s: f64,
}

impl StallFigures {
    pub fn of(stalls: &[Stall], spans: Spans) -> Self {
        let within = |s: &Stall, from: Instant, to: Option<Instant>| {
            s.at >= from && to.is_none_or(|to| s.at <= to)
        };
        Self {
            late_exchanges: stalls.len() as u64,
            worst_ms: stalls.iter().map(|s| s.stalled_ms).fold(0.0, f64::max),
            // Folded from +0.0: an empty f64 sum is -0.0, printed "-0 ms".
            total_ms: stalls.iter().fold(0.0, |sum, s| sum + s.stalled_ms),
            before_mixer_ms: stalls
                .iter()
                .filter(|s| within(s, spans.course_start, spans.mixer))
                .fold(0.0, |sum, s| sum + s.stalled_ms),
            in_roll: spans.roll.map_or(0, |(from, to)| {
                stalls.iter().filter(|s| within(s, from, Some(to))).count() as u64
            }),
            approach_speed_m_s: spans.approach_speed_m_s,
        }
    }

    /// A stall in the roll's span: its timings and bank say more about the machine
    /// than about iNav.
    pub fn disturbs_roll(&self) -> bool {
        self.in_roll > 0
    }

    /// The most clearance the stalls before the roll could have given faithd, metres.
    pub fn clearance_gift_m(&self) -> f64 {
        self.before_mixer_ms / 1e3 * self.approach_speed_m_s.abs()
    }

    /// Why an avoidance with `min_clearance_m` may be the stalls' doing, if it may (a
    /// collision is one whatever stalled: a stall only gives faithd time).
    pub fn doubts_avoidance(&self, min_clearance_m: f64) -> Option<String> {
        let gift_m = self.clearance_gift_m();
        (self.before_mixer_ms > 0.0 && min_clearance_m <= gift_m).then(|| {
            format!(
                "iNav's loop stalled {:.0} ms before the roll took effect: at {:.2} m/s the \
                 vehicle stood still for up to {gift_m:.2} m of the course while faithd ran, \
                 and the pass cleared by {min_clearance_m:.2} m; the machine is too loaded \
                 for this flight to show the avoidance",
                self.before_mixer_ms, self.approach_speed_m_s
            )
        })
    }

    /// In a line of text.
    pub fn describe(&self) -> String {
        format!(
            "{} late exchanges (worst {:.0} ms, {:.0} ms in all; {:.0} ms before the roll \
             took effect, {} in the roll)",
            self.late_exchanges, self.worst_ms, self.total_ms, self.before_mixer_ms, self.in_roll
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn at(base: Instant, ms: u64) -> Instant {
        base + Duration::from_millis(ms)
    }

    #[test]
    fn stalls_count_where_they_fall() {
        let t0 = Instant::now();
        let stalls = [
            // Take-off, before the course.
            Stall {
                at: t0,
                stalled_ms: 90.0,
            },
            // On the approach.
            Stall {
                at: at(t0, 1_000),
                stalled_ms: 30.0,
            },
            // In the roll, after the mixer.
            Stall {
                at: at(t0, 3_100),
                stalled_ms: 25.0,
            },
        ];
        let spans = Spans {
            course_start: at(t0, 500),
            mixer: Some(at(t0, 3_000)),
            roll: Some((at(t0, 2_950), at(t0, 5_000))),
            approach_speed_m_s: 3.0,
        };
        let f = StallFigures::of(&stalls, spans);
        assert_eq!(f.late_exchanges, 3);
        assert_eq!(f.worst_ms, 90.0);
        assert_eq!(f.total_ms, 145.0);
        assert_eq!(f.before_mixer_ms, 30.0);
        assert_eq!(f.in_roll, 1);
        assert!(f.disturbs_roll());
        assert!((f.clearance_gift_m() - 0.09).abs() < 1e-12);
        assert!(f.doubts_avoidance(1.1).is_none());
        let why = f.doubts_avoidance(0.05).unwrap();
        assert!(why.contains("30 ms") && why.contains("0.09 m"), "{why}");
    }

    #[test]
    fn a_flight_without_stalls_is_undisturbed_and_trusted() {
        let t0 = Instant::now();
        let f = StallFigures::of(
            &[],
            Spans {
                course_start: t0,
                mixer: None,
                roll: None,
                approach_speed_m_s: 3.0,
            },
        );
        assert!(!f.disturbs_roll());
        assert_eq!(f.clearance_gift_m(), 0.0);
        assert_eq!(
            f.describe(),
            "0 late exchanges (worst 0 ms, 0 ms in all; 0 ms before the roll took effect, 0 in the roll)"
        );
        assert!(f.doubts_avoidance(0.01).is_none());
    }
}
