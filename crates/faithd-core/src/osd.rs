//! faithd's state in the pilot's goggles: three iNav global variables that the
//! flight controller's OSD shows (custom OSD elements, io/osd/custom_elements.h):
//! the gate (1 open, 2 and up a short reason code it is closed for), the roll (-1
//! left, 0 none, 1 right) and the nearest obstacle's time to contact in tenths of a
//! second (0 none). The gate is never 0: iNav starts its variables at 0
//! (programming/global_variables.c, gvInit), so 0 means faithd has written nothing
//! since the flight controller booted, and the OSD shows nothing of faithd.
//!
//! The pilot flies with goggles and no ground station: a code is what fits in a
//! corner of the OSD, and docs/inav.md lists what each means. Pure: the caller
//! gives the time and writes the variable the [`GvarWriter`] picks.

use serde::{Deserialize, Serialize};

use crate::invalid::{Invalid, check};
use crate::safety::gate::{Blocker, GateState};
use crate::safety::rc::NEUTRAL_US;

/// iNav's global variables (programming/global_variables.h, MAX_GLOBAL_VARIABLES).
pub const INAV_GLOBAL_VARIABLES: u8 = 8;
/// The variables faithd writes: gate, roll, time to contact.
pub const VARIABLES: usize = 3;
/// The longest time to contact shown, tenths of a second: beyond it nothing is near.
pub const MAX_TTC_DS: i32 = 99;

/// `[osd]`: whether faithd writes its state into iNav's global variables, and which.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OsdConfig {
    /// Off unless asked: the variables may hold the pilot's own logic.
    pub enabled: bool,
    /// The first of the three variables (gate, roll, time to contact).
    pub first_gvar: u8,
    /// Each variable is written again at least this often (iNav forgets them when it
    /// reboots).
    pub refresh_us: i64,
}

impl Default for OsdConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            first_gvar: 5,
            refresh_us: 2_000_000,
        }
    }
}

impl OsdConfig {
    pub fn validate(&self) -> Result<(), Invalid> {
        let last = INAV_GLOBAL_VARIABLES - VARIABLES as u8;
        check(self.first_gvar <= last, "osd.first_gvar", || {
            format!(
                "must be 0 to {last}: faithd writes {VARIABLES} of iNav's {INAV_GLOBAL_VARIABLES} global variables from it, got {}",
                self.first_gvar
            )
        })?;
        check(
            (200_000..=60_000_000).contains(&self.refresh_us),
            "osd.refresh_us",
            || format!("must be 0.2 s to 60 s, got {}", self.refresh_us),
        )
    }
}

/// The gate's code on the OSD: 1 open, else why it is closed, grouped by what the
/// pilot can do about it (docs/inav.md has the table).
pub fn gate_code(gate: &GateState) -> i32 {
    let GateState::Closed(blocker) = gate else {
        return GATE_OPEN;
    };
    match blocker {
        Blocker::SwitchNotAuto { .. } | Blocker::SwitchMissing { .. } => 2,
        Blocker::Disarmed => 3,
        Blocker::AutopilotFailsafe { .. } | Blocker::RadioLost => 4,
        Blocker::LinkDown
        | Blocker::NoRc
        | Blocker::RcStale { .. }
        | Blocker::NoHeartbeat
        | Blocker::HeartbeatStale { .. }
        | Blocker::NoAttitude
        | Blocker::AttitudeStale { .. }
        | Blocker::NoRadioStatus
        | Blocker::RadioStatusStale { .. } => 5,
        Blocker::PipelineNotRunning
        | Blocker::PipelineStale { .. }
        | Blocker::PipelineUnhealthy { .. } => 6,
        Blocker::SetupRefused { .. } | Blocker::SetupChanged { .. } => 7,
        Blocker::StabilisedModeOff { .. } => 8,
        Blocker::OverrideInactive { .. } => 9,
        Blocker::CommandPortDown { .. }
        | Blocker::NoAutopilotStatus { .. }
        | Blocker::AutopilotStatusStale { .. }
        | Blocker::OverrideWarmingUp { .. } => 10,
        Blocker::RollNotInEffect => 11,
    }
}

/// The gate variable while faithd may roll.
pub const GATE_OPEN: i32 = 1;

/// What the goggles show, as the variables' values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PilotView {
    pub gate: i32,
    pub roll: i32,
    pub ttc_ds: i32,
}

/// Before the first look at the gate: closed, nothing heard from the autopilot.
impl Default for PilotView {
    fn default() -> Self {
        Self::new(&GateState::Closed(Blocker::LinkDown), NEUTRAL_US, None)
    }
}

impl PilotView {
    /// From the gate, the roll value held (iNav's centre when none) and the nearest
    /// obstacle's time to contact.
    pub fn new(gate: &GateState, held_us: u16, ttc_s: Option<f64>) -> Self {
        Self {
            gate: gate_code(gate),
            roll: (i32::from(held_us) - i32::from(NEUTRAL_US)).signum(),
            ttc_ds: ttc_s
                .filter(|t| t.is_finite() && *t > 0.0)
                .map_or(0, |t| ((t * 10.0).round() as i32).clamp(1, MAX_TTC_DS)),
        }
    }

    pub fn values(&self) -> [i32; VARIABLES] {
        [self.gate, self.roll, self.ttc_ds]
    }
}

/// Picks the next variable to write: a changed one first (gate, roll, time to
/// contact, in that order), else the one written longest ago once it is due again.
#[derive(Clone, Debug)]
pub struct GvarWriter {
    first: u8,
    refresh_us: i64,
    shown: [Option<i32>; VARIABLES],
    written_at_us: [i64; VARIABLES],
}

impl GvarWriter {
    pub fn new(config: &OsdConfig) -> Self {
        Self {
            first: config.first_gvar,
            refresh_us: config.refresh_us,
            shown: [None; VARIABLES],
            written_at_us: [i64::MIN; VARIABLES],
        }
    }

    /// The variable (iNav's index) and value to write now, if any; taken as
    /// written.
    pub fn next(&mut self, view: &PilotView, now_us: i64) -> Option<(u8, i32)> {
        let values = view.values();
        let changed = (0..VARIABLES).find(|&i| self.shown[i] != Some(values[i]));
        let due = || {
            (0..VARIABLES)
                .min_by_key(|&i| self.written_at_us[i])
                .filter(|&i| now_us.saturating_sub(self.written_at_us[i]) >= self.refresh_us)
        };
        let i = changed.or_else(due)?;
        self.shown[i] = Some(values[i]);
        self.written_at_us[i] = now_us;
        Some((self.first + i as u8, values[i]))
    }

    /// The flight controller may have lost the values (a reconnect, a reboot):
    /// everything is written again.
    pub fn forget(&mut self) {
        self.shown = [None; VARIABLES];
        self.written_at_us = [i64::MIN; VARIABLES];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::safety::gate::PipelineProblem;

    #[test]
    fn the_view_names_the_gate_the_roll_and_the_nearest_obstacle() {
        let open = PilotView::new(&GateState::Open, 1800, Some(1.234));
        assert_eq!(open.values(), [1, 1, 12]);
        let manual = GateState::Closed(Blocker::SwitchNotAuto { value_us: 1000 });
        assert_eq!(PilotView::new(&manual, 1500, None).values(), [2, 0, 0]);
        let camera = GateState::Closed(Blocker::PipelineUnhealthy {
            problem: PipelineProblem::NoEvents,
        });
        assert_eq!(
            PilotView::new(&camera, 1200, Some(42.0)).values(),
            [6, -1, 99]
        );
        assert_eq!(
            PilotView::default().gate,
            5,
            "before the first look: no telemetry"
        );
        assert_eq!(PilotView::new(&GateState::Open, 1500, Some(0.01)).ttc_ds, 1);
    }

    #[test]
    fn a_change_is_written_first_and_everything_again_when_due() {
        let config = OsdConfig::default();
        let mut w = GvarWriter::new(&config);
        let mut view = PilotView::new(&GateState::Open, 1500, None);
        let first: Vec<_> = (0..3).map(|k| w.next(&view, k).unwrap()).collect();
        assert_eq!(first, vec![(5, 1), (6, 0), (7, 0)]);
        assert_eq!(w.next(&view, 100_000), None, "nothing changed, nothing due");
        view.roll = 1;
        assert_eq!(w.next(&view, 200_000), Some((6, 1)));
        assert_eq!(
            w.next(&view, 2_000_000),
            Some((5, 1)),
            "the oldest, when due"
        );
        assert_eq!(w.next(&view, 2_000_001), None, "the roll is due at 2.2 s");
        assert_eq!(w.next(&view, 2_000_002), Some((7, 0)));
        assert_eq!(w.next(&view, 2_200_000), Some((6, 1)));
        w.forget();
        assert_eq!(w.next(&view, 2_200_001), Some((5, 1)));
    }

    #[test]
    fn the_variables_fit_inavs_eight() {
        let ok = OsdConfig {
            first_gvar: 5,
            ..Default::default()
        };
        assert!(ok.validate().is_ok());
        let too_far = OsdConfig {
            first_gvar: 6,
            ..Default::default()
        };
        assert_eq!(too_far.validate().unwrap_err().key, "osd.first_gvar");
    }
}
