//! What iNav's own flight controller did in the closed-loop experiment, and how
//! close faithd's model of it must stay.
//!
//! Measured with `faithd sim --autopilot inav-sitl --runs 60 --seed 1` against iNav
//! 9.1's SITL built with the board's serial timing (docs/simulation.md has the whole
//! table). Two tests hold the two sides to these figures: with `INAV_SITL` set, the
//! SITL test flies a handful of the flights and checks iNav still does this; in CI,
//! the closed-loop test flies the model and checks it still predicts it. When iNav's
//! behaviour or the airframe changes, the SITL test fails first, and these figures
//! are measured again.

/// A figure iNav gave, and how far the model may stray from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bound {
    pub inav: f64,
    pub tolerance: f64,
}

impl Bound {
    pub fn holds(&self, value: f64) -> bool {
        (value - self.inav).abs() <= self.tolerance
    }
}

/// The bank iNav's ANGLE mode reached on faithd's 300 us roll, degrees (the 36
/// rolls of the experiment: 14.58-14.71, p50 14.68; iNav aims at 14.85; the model
/// reaches 14.74).
pub const PEAK_BANK_DEG: Bound = Bound {
    inav: 14.68,
    tolerance: 0.5,
};

/// From the roll at iNav's mixer to 5 degrees of bank, ms (p50 over the rolls:
/// 144, all within 140-151; the model 147).
pub const MIXER_TO_5_DEG_MS: Bound = Bound {
    inav: 144.0,
    tolerance: 15.0,
};

/// From the roll at iNav's mixer to 90 % of the peak bank, ms (p50: 713, all
/// within 706-721; the model 697).
pub const MIXER_TO_90_PERCENT_MS: Bound = Bound {
    inav: 713.0,
    tolerance: 30.0,
};

/// From the newest event of the deciding window to the roll at iNav's mixer, ms
/// (p50: 40, p99 72, over 17-72): faithd's pipeline in real time, its MSP stream's
/// 20 ms slots on iNav's 10 ms serial task, and iNav's receiver frame. The model
/// gives 24 (p99 37): 16 ms early at the median, not yet explained; the bound
/// holds it there, so that a model drifting further from iNav fails.
pub const EVENT_TO_MIXER_MS: Bound = Bound {
    inav: 40.0,
    tolerance: 20.0,
};

/// The medians of some rolls' timings, as the bounds above read them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RollTimings {
    pub event_to_mixer_ms: f64,
    pub mixer_to_5_deg_ms: f64,
    pub mixer_to_90_percent_ms: f64,
}

impl RollTimings {
    /// From rolls that each reached 90 % of their peak (iNav's, or the model's with
    /// its roll in use for the mixer).
    pub fn of(rolls: &[super::experiment::RollFigures]) -> Self {
        let p50 = |f: fn(&super::experiment::RollFigures) -> Option<f64>| {
            super::experiment::Spread::of(rolls.iter().filter_map(f)).p50
        };
        Self {
            event_to_mixer_ms: p50(|r| r.in_effect_ms),
            mixer_to_5_deg_ms: p50(|r| Some(r.bank_5_deg_ms? - r.in_effect_ms?)),
            mixer_to_90_percent_ms: p50(|r| Some(r.bank_90_ms? - r.in_effect_ms?)),
        }
    }

    /// The first timing outside its bound, named.
    pub fn check(&self) -> Result<(), String> {
        for (name, bound, value) in [
            ("event to mixer", EVENT_TO_MIXER_MS, self.event_to_mixer_ms),
            (
                "mixer to 5 degrees",
                MIXER_TO_5_DEG_MS,
                self.mixer_to_5_deg_ms,
            ),
            (
                "mixer to 90 %",
                MIXER_TO_90_PERCENT_MS,
                self.mixer_to_90_percent_ms,
            ),
        ] {
            if !bound.holds(value) {
                return Err(format!("{name}: {value:.0} ms, iNav {bound:?}"));
            }
        }
        Ok(())
    }
}
