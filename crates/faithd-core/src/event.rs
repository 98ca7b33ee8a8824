//! DVS events: the camera's only output and the pipeline's first input.

/// Brightness change sign reported by the sensor for one pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Polarity {
    /// Log intensity fell by at least the contrast threshold.
    Off = 0,
    /// Log intensity rose by at least the contrast threshold.
    On = 1,
}

impl Polarity {
    /// Index into per-polarity tables (surfaces of active events).
    pub fn index(self) -> usize {
        self as usize
    }

    /// Maps the `0`/`1` or `false`/`true` conventions of event files.
    pub fn from_bool(on: bool) -> Self {
        if on { Polarity::On } else { Polarity::Off }
    }
}

/// One address-event: a pixel whose log intensity crossed the contrast threshold.
///
/// The timestamp is the sensor's, in microseconds; every later stage keeps that time
/// base so a recorded flight replays to the same decisions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Event {
    /// Microseconds; a usable time lies within +-[`Event::MAX_ABS_T_US`].
    pub t_us: i64,
    pub x_px: u16,
    pub y_px: u16,
    pub polarity: Polarity,
}

impl Event {
    /// 2^53 us, about 285 years: any clock a recording can carry, with room to add
    /// windows and histories without overflow. A time beyond it is damage.
    pub const MAX_ABS_T_US: i64 = 1 << 53;

    pub fn new(t_us: i64, x_px: u16, y_px: u16, polarity: Polarity) -> Self {
        Self {
            t_us,
            x_px,
            y_px,
            polarity,
        }
    }
}
