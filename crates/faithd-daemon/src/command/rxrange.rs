//! iNav's calibration of a flight channel (`rxrange`), which the MSP route aims its
//! roll through. An iNav particular: the core's commander hears only what the
//! autopilot reports using for each roll ([`RxRange::reported_roll`]).

use serde::{Deserialize, Serialize};

use faithd_core::safety::commander::ReportedRoll;
use faithd_core::safety::manoeuvre::ManoeuvreConfig;
use faithd_core::safety::rc::PwmUs;

/// The calibration iNav applies to a flight channel (`rxrange <channel> <min> <max>`
/// in its CLI): every value on roll, pitch, yaw and throttle, the MSP RC override's
/// included, is scaled from `min..max` to 1000..2000 before use (rx/msp_override.c,
/// `mspOverrideCalculateChannels`; common/maths.c, `scaleRange`, integer division),
/// then clamped to 750..2250. faithd aims its frames through it so that iNav uses
/// the microseconds meant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "[u16; 2]", into = "[u16; 2]")]
pub struct RxRange {
    min_us: u16,
    max_us: u16,
}

impl RxRange {
    /// iNav's default range (rx/rx.c, `PWM_RANGE_MIN`..`PWM_RANGE_MAX`): no scaling.
    pub const DEFAULT: RxRange = RxRange {
        min_us: 1000,
        max_us: 2000,
    };

    /// `None` unless 750 <= min < max <= 2250 (iNav's CLI takes min = max, and then
    /// divides by zero on every frame).
    pub const fn new(min_us: u16, max_us: u16) -> Option<Self> {
        if min_us >= PwmUs::MIN && max_us <= PwmUs::MAX && min_us < max_us {
            Some(Self { min_us, max_us })
        } else {
            None
        }
    }

    pub const fn min_us(self) -> u16 {
        self.min_us
    }

    pub const fn max_us(self) -> u16 {
        self.max_us
    }

    /// The value iNav uses when `sent_us` arrives (0 is "no value" and passes as is).
    pub fn scale(self, sent_us: u16) -> u16 {
        if sent_us == 0 {
            return 0;
        }
        let a = 1000 * (i64::from(sent_us) - i64::from(self.min_us));
        let b = i64::from(self.max_us) - i64::from(self.min_us);
        // C's `/` truncates toward zero, as Rust's does on i64.
        let scaled = a / b + 1000;
        scaled.clamp(i64::from(PwmUs::MIN), i64::from(PwmUs::MAX)) as u16
    }

    /// The value to send so that iNav uses `wanted_us`, or the nearest it can be
    /// made to use (a range narrower than 1000 us skips values): `(sent, used)`.
    /// `None` when nothing iNav takes lands within 1 us of it.
    pub fn aim(self, wanted_us: u16) -> Option<(u16, u16)> {
        (PwmUs::MIN..=PwmUs::MAX)
            .map(|sent| (sent, self.scale(sent)))
            .min_by_key(|&(sent, used)| (used.abs_diff(wanted_us), sent.abs_diff(wanted_us)))
            .filter(|&(_, used)| used.abs_diff(wanted_us) <= 1)
    }
}

impl Default for RxRange {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl TryFrom<[u16; 2]> for RxRange {
    type Error = String;

    fn try_from([min_us, max_us]: [u16; 2]) -> Result<Self, String> {
        Self::new(min_us, max_us).ok_or_else(|| {
            format!(
                "must be [min, max] with {} <= min < max <= {} (iNav's `rxrange 0 min max`), got [{min_us}, {max_us}]",
                PwmUs::MIN,
                PwmUs::MAX
            )
        })
    }
}

impl From<RxRange> for [u16; 2] {
    fn from(r: RxRange) -> [u16; 2] {
        [r.min_us, r.max_us]
    }
}

impl std::fmt::Display for RxRange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}..{} us", self.min_us, self.max_us)
    }
}

impl RxRange {
    /// What iNav reports using (MSP_RC) for faithd's left and right rolls, each
    /// aimed through this range: the commander's roll check expects these.
    pub fn reported_roll(self, manoeuvre: &ManoeuvreConfig) -> ReportedRoll {
        let used = |wanted_us: u16| self.aim(wanted_us).map_or(wanted_us, |(_, used)| used);
        let commanded = ReportedRoll::as_commanded(manoeuvre);
        ReportedRoll {
            left_us: used(commanded.left_us),
            right_us: used(commanded.right_us),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rxrange_scales_as_inav_does_and_aims_through_it() {
        let default = RxRange::DEFAULT;
        assert_eq!(default.scale(1800), 1800);
        assert_eq!(default.aim(1800), Some((1800, 1800)));
        // The measurement on iNav: `rxrange 0 988 2012` turns 1800 into 1792.
        let wide = RxRange::new(988, 2012).unwrap();
        assert_eq!(wide.scale(1800), 1792);
        assert_eq!(wide.scale(1500), 1500);
        let (sent, used) = wide.aim(1800).unwrap();
        assert_eq!((wide.scale(sent), used), (1800, 1800));
        assert_eq!(sent, 1808);
        // An asymmetric range moves the centre: 1500 is no longer sent as 1500.
        let shifted = RxRange::new(1000, 2040).unwrap();
        assert_eq!(shifted.scale(1500), 1480);
        assert_eq!(
            shifted.aim(1500).map(|(s, u)| (shifted.scale(s), u)),
            Some((1500, 1500))
        );
        // Narrower than 1000 us: every sent step is 1.25 used steps; the nearest lands.
        let narrow = RxRange::new(1100, 1900).unwrap();
        let (sent, used) = narrow.aim(1801).unwrap();
        assert_eq!(narrow.scale(sent), used);
        assert!(used.abs_diff(1801) <= 1);
        // Truncation toward zero below min (C's division), then the clamp.
        assert_eq!(wide.scale(750), 1000 - 232);
        assert_eq!(RxRange::new(2000, 2250).unwrap().scale(750), 750);
        assert_eq!(default.scale(0), 0);
        assert_eq!(RxRange::new(1500, 1500), None);
        let err = serde_json::from_str::<RxRange>("[2000, 1000]").unwrap_err();
        assert!(err.to_string().contains("min < max"), "{err}");
    }

    #[test]
    fn the_roll_check_expects_the_roll_as_it_lands_through_rxrange() {
        let manoeuvre = ManoeuvreConfig::default();
        let narrow = RxRange::new(1100, 1900).unwrap();
        let (_, used) = narrow.aim(1800).unwrap();
        assert_eq!(narrow.reported_roll(&manoeuvre).right_us, used);
        assert_eq!(
            RxRange::DEFAULT.reported_roll(&manoeuvre),
            ReportedRoll::as_commanded(&manoeuvre)
        );
    }
}
