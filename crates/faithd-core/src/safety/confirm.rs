//! Did the roll take effect on the flight controller?
//!
//! A frame on the wire proves nothing: iNav may ignore it (wrong receiver set-up,
//! the override mode off, its own failsafe holding another value). The monitor
//! compares the roll channel iNav reports using (MSP_RC) with what faithd commands,
//! and calls a roll that does not show within a bound a fault, never a success.
//! Pure: reports and time come in as arguments.

/// What the monitor concluded at a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Nothing commanded, or the roll is showing.
    Fine,
    /// The roll showed for the first time this manoeuvre, `after_us` after it started.
    Confirmed { after_us: i64 },
    /// The roll has not been in effect for longer than the bound.
    NotInEffect {
        commanded_us: u16,
        /// The last value iNav reported, if any report arrived.
        reported_us: Option<u16>,
        waited_us: i64,
    },
}

/// A roll is judged on what iNav reports: one that a report contradicts (iNav uses
/// another value) for longer than the bound is a fault. With no report at all, the
/// gate closes first on the stale port (the reports and iNav's status come over the
/// same MSP port); a roll that stays blind for twice the bound is a fault too.
#[derive(Clone, Debug)]
pub struct RollConfirm {
    bound_us: i64,
    /// The commanded value, when it started, when iNav last reported it, and
    /// whether it has shown at all.
    roll: Option<Active>,
    last_report_us: Option<u16>,
}

#[derive(Clone, Copy, Debug)]
struct Active {
    value_us: u16,
    started_us: i64,
    last_match_us: i64,
    /// The newest report read during this roll, whatever it said.
    last_report_t_us: Option<i64>,
    confirmed: bool,
}

impl RollConfirm {
    pub fn new(bound_us: i64) -> Self {
        Self {
            bound_us,
            roll: None,
            last_report_us: None,
        }
    }

    /// A roll to `value_us` begins at `now_us`.
    pub fn start(&mut self, value_us: u16, now_us: i64) {
        self.roll = Some(Active {
            value_us,
            started_us: now_us,
            last_match_us: now_us,
            last_report_t_us: None,
            confirmed: false,
        });
    }

    /// The roll ended or was cut: nothing more to confirm.
    pub fn stop(&mut self) {
        self.roll = None;
    }

    /// iNav reported using `value_us` on the roll channel, read at `t_us`.
    pub fn report(&mut self, value_us: u16, t_us: i64) -> Verdict {
        self.last_report_us = Some(value_us);
        let Some(roll) = self.roll.as_mut() else {
            return Verdict::Fine;
        };
        if t_us < roll.started_us {
            return Verdict::Fine;
        }
        roll.last_report_t_us = Some(roll.last_report_t_us.map_or(t_us, |t| t.max(t_us)));
        if value_us != roll.value_us {
            return Verdict::Fine;
        }
        roll.last_match_us = roll.last_match_us.max(t_us);
        if roll.confirmed {
            return Verdict::Fine;
        }
        roll.confirmed = true;
        Verdict::Confirmed {
            after_us: t_us - roll.started_us,
        }
    }

    /// At `now_us`: has a report contradicted the roll for longer than the bound,
    /// or has the roll gone unreported for twice that?
    pub fn check(&self, now_us: i64) -> Verdict {
        let Some(r) = self.roll else {
            return Verdict::Fine;
        };
        let waited_us = now_us - r.last_match_us;
        let contradicted = r.last_report_t_us.is_some_and(|t| t > r.last_match_us);
        if (contradicted && waited_us > self.bound_us) || waited_us > 2 * self.bound_us {
            Verdict::NotInEffect {
                commanded_us: r.value_us,
                reported_us: self.last_report_us,
                waited_us,
            }
        } else {
            Verdict::Fine
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_roll_that_shows_in_time_is_confirmed_once() {
        let mut c = RollConfirm::new(200_000);
        c.start(1800, 1_000_000);
        assert_eq!(c.report(1500, 1_010_000), Verdict::Fine);
        assert_eq!(
            c.report(1800, 1_040_000),
            Verdict::Confirmed { after_us: 40_000 }
        );
        assert_eq!(c.report(1800, 1_060_000), Verdict::Fine);
        assert_eq!(c.check(1_250_000), Verdict::Fine);
    }

    #[test]
    fn a_roll_that_never_shows_is_a_fault_after_the_bound() {
        let mut c = RollConfirm::new(200_000);
        c.start(1800, 0);
        for t in (0..=200_000).step_by(20_000) {
            c.report(1500, t);
            assert_eq!(c.check(t), Verdict::Fine, "{t}");
        }
        assert_eq!(
            c.check(200_001),
            Verdict::NotInEffect {
                commanded_us: 1800,
                reported_us: Some(1500),
                waited_us: 200_001
            }
        );
    }

    #[test]
    fn a_roll_lost_mid_way_is_a_fault_too() {
        let mut c = RollConfirm::new(100_000);
        c.start(1200, 0);
        c.report(1200, 30_000);
        c.report(1500, 60_000);
        assert_eq!(c.check(130_000), Verdict::Fine);
        assert!(matches!(c.check(130_001), Verdict::NotInEffect { .. }));
        c.stop();
        assert_eq!(
            c.check(1_000_000),
            Verdict::Fine,
            "nothing after the roll ends"
        );
    }

    #[test]
    fn no_report_at_all_is_a_fault_after_twice_the_bound() {
        let mut c = RollConfirm::new(100_000);
        c.start(1800, 0);
        assert_eq!(
            c.check(150_000),
            Verdict::Fine,
            "the stale port closes the gate first"
        );
        assert_eq!(
            c.check(200_001),
            Verdict::NotInEffect {
                commanded_us: 1800,
                reported_us: None,
                waited_us: 200_001
            }
        );
    }

    #[test]
    fn reports_that_stop_after_a_match_are_not_yet_a_contradiction() {
        let mut c = RollConfirm::new(200_000);
        c.start(1800, 0);
        c.report(1800, 20_000);
        // The port stalls: no report for 300 ms. The gate (iNav's status is stale
        // after 250 ms) cuts the roll; the check does not call iNav wrong.
        assert_eq!(c.check(320_000), Verdict::Fine);
        assert!(matches!(c.check(420_001), Verdict::NotInEffect { .. }));
    }
}
