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
}
