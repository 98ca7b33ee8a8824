//! The two numbers of radio control: which channel, and where its stick is. Each is
//! a type that holds only what iNav can take, so a bad value is refused when
//! faithd.toml is read, with its key, and never reaches the gate or the wire.

use serde::{Deserialize, Serialize};

/// An RC channel as MAVLink's RC_CHANNELS numbers them: 1 to 18.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(try_from = "u8", into = "u8")]
pub struct RcChannel(u8);

impl RcChannel {
    /// RC_CHANNELS carries 18 channels; iNav's MSP RC override reaches the same.
    pub const MAX: u8 = 18;

    /// `None` outside 1..=18.
    pub const fn new(channel: u8) -> Option<Self> {
        if channel >= 1 && channel <= Self::MAX {
            Some(Self(channel))
        } else {
            None
        }
    }

    /// For constants: `const { RcChannel::constant(6) }` fails to compile outside
    /// 1..=18.
    pub const fn constant(channel: u8) -> Self {
        match Self::new(channel) {
            Some(c) => c,
            None => panic!("RC channel outside 1..=18"),
        }
    }

    /// The channel number, 1-based as pilots and iNav's CLI count.
    pub const fn get(self) -> u8 {
        self.0
    }
}

impl TryFrom<u8> for RcChannel {
    type Error = String;

    fn try_from(channel: u8) -> Result<Self, String> {
        Self::new(channel).ok_or_else(|| {
            format!(
                "must be an RC channel 1 to {}, got {channel}",
                RcChannel::MAX
            )
        })
    }
}

impl From<RcChannel> for u8 {
    fn from(channel: RcChannel) -> u8 {
        channel.0
    }
}

impl std::fmt::Display for RcChannel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// A stick position as a pulse width, microseconds: what iNav takes as a valid
/// pulse, 750 to 2250 (`PWM_PULSE_MIN` and `PWM_PULSE_MAX` in iNav's rx.h).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(try_from = "u16", into = "u16")]
pub struct PwmUs(u16);

impl PwmUs {
    pub const MIN: u16 = 750;
    pub const MAX: u16 = 2250;

    /// `None` outside 750..=2250.
    pub const fn new(us: u16) -> Option<Self> {
        if us >= Self::MIN && us <= Self::MAX {
            Some(Self(us))
        } else {
            None
        }
    }

    /// For constants: `const { PwmUs::constant(1500) }` fails to compile outside
    /// 750..=2250.
    pub const fn constant(us: u16) -> Self {
        match Self::new(us) {
            Some(p) => p,
            None => panic!("pulse width outside 750..=2250 us"),
        }
    }

    pub const fn us(self) -> u16 {
        self.0
    }
}

impl TryFrom<u16> for PwmUs {
    type Error = String;

    fn try_from(us: u16) -> Result<Self, String> {
        Self::new(us).ok_or_else(|| {
            format!(
                "must be a pulse width iNav accepts, {} to {} us, got {us}",
                PwmUs::MIN,
                PwmUs::MAX
            )
        })
    }
}

impl From<PwmUs> for u16 {
    fn from(pwm: PwmUs) -> u16 {
        pwm.0
    }
}

impl std::fmt::Display for PwmUs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} us", self.0)
    }
}

/// iNav's stick centre (fc/fc_core.c, `PWM_RANGE_MIDDLE`): the roll value that
/// commands no bank in ANGLE mode and no rate outside it.
pub const NEUTRAL_US: u16 = 1500;

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_what_inav_takes_is_held() {
        assert_eq!(RcChannel::new(0), None);
        assert_eq!(RcChannel::new(1).map(RcChannel::get), Some(1));
        assert_eq!(RcChannel::new(18).map(RcChannel::get), Some(18));
        assert_eq!(RcChannel::new(19), None);
        assert_eq!(PwmUs::new(749), None);
        assert_eq!(PwmUs::new(1500).map(PwmUs::us), Some(1500));
        assert_eq!(PwmUs::new(2251), None);
    }

    #[test]
    fn deserialising_refuses_with_the_range() {
        let err = serde_json::from_str::<RcChannel>("19").unwrap_err();
        assert!(err.to_string().contains("1 to 18, got 19"), "{err}");
        let err = serde_json::from_str::<PwmUs>("3000").unwrap_err();
        assert!(
            err.to_string().contains("750 to 2250 us, got 3000"),
            "{err}"
        );
        assert_eq!(serde_json::to_string(&PwmUs::new(1500)).unwrap(), "1500");
    }

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
}
