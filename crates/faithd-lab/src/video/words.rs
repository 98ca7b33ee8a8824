//! What a frame says in words: the decision, its reason, the heading and the gate,
//! each short enough to read in a second beside a moving picture. The log line
//! (`Decision`'s `Display`) has every number; these have the ones that explain.

use faithd_core::decide::{Action, Decision, NotInTheWay, Reason, RollDirection};
use faithd_core::foe::FoeEstimate;
use faithd_core::safety::gate::GateState;

use super::frame::InavRoll;

/// The decision in two or three words: `HOLD`, `ROLL RIGHT 1.5 s`.
pub fn headline(decision: &Decision) -> String {
    match decision.action {
        Action::Hold => "HOLD".into(),
        Action::Roll {
            direction,
            duration_us,
        } => format!(
            "ROLL {} {:.1} s",
            direction_word(direction).to_uppercase(),
            duration_us as f64 * 1e-6
        ),
    }
}

/// Why, in plain words with the numbers that decided it.
pub fn reason(reason: &Reason) -> String {
    match *reason {
        Reason::NoAttitude => {
            "no attitude from iNav: the flow is not derotated, not trusted".into()
        }
        Reason::TooFewVectors { vectors, needed } => {
            format!("too little flow: {vectors} vectors, {needed} needed")
        }
        Reason::NoFoe => "no heading: the FOE could not be estimated".into(),
        Reason::FoeOutsideView => "heading outside the view".into(),
        Reason::WeakFoe { support, vectors } => {
            format!("heading uncertain: the FOE fits {support} of {vectors} vectors")
        }
        Reason::NoClusters => "no obstacle: no cluster in the flow".into(),
        Reason::ObstacleNotAhead => {
            "nothing in the way: no obstacle-like cluster around the FOE".into()
        }
        Reason::ObstacleFar { ttc_s, threshold_s } => {
            format!("obstacle ahead, {ttc_s:.2} s away: not yet under {threshold_s:.2} s")
        }
        Reason::ObstacleAhead { ttc_s, threshold_s } => {
            format!("obstacle ahead, {ttc_s:.2} s away: under {threshold_s:.2} s")
        }
        Reason::Unconfirmed {
            ttc_s,
            windows,
            needed,
        } => {
            format!("obstacle ahead, {ttc_s:.2} s away: confirming ({windows} of {needed} windows)")
        }
    }
}

/// Where the pipeline thinks the vehicle is heading.
pub fn heading(foe: &FoeEstimate) -> String {
    match *foe {
        FoeEstimate::Point {
            x_px,
            y_px,
            support,
        } => format!("FOE ({x_px:.0}, {y_px:.0}) px, fits {support} vectors"),
        FoeEstimate::Unbounded { side, .. } => format!("FOE beyond the {} edge", side.name()),
        FoeEstimate::Insufficient { vectors } => format!("no FOE ({vectors} usable vectors)"),
    }
}

/// The safety gate: open, or closed and why; or that the source did not record it.
pub fn gate(gate: Option<&GateState>) -> (GateWord, String) {
    match gate {
        Some(GateState::Open) => (GateWord::Open, "faithd may roll".into()),
        Some(GateState::Closed(blocker)) => (GateWord::Closed, blocker.to_string()),
        None => (
            GateWord::Unknown,
            "recordings hold no gate; the daemon's journal logs its every change".into(),
        ),
    }
}

/// The three states the panel and the time bar colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GateWord {
    Open,
    Closed,
    Unknown,
}

impl GateWord {
    pub fn label(self) -> &'static str {
        match self {
            GateWord::Open => "OPEN",
            GateWord::Closed => "CLOSED",
            GateWord::Unknown => "not recorded",
        }
    }
}

/// The roll iNav uses.
pub fn inav_roll(roll: Option<&InavRoll>) -> String {
    match roll {
        Some(InavRoll {
            value_us,
            direction: Some(d),
        }) => format!("rolling {} (stick {value_us} us)", direction_word(*d)),
        Some(InavRoll {
            value_us,
            direction: None,
        }) => format!("centre (stick {value_us} us)"),
        None => "not in this recording".into(),
    }
}

/// Why the nearest cluster is not the obstacle, as its label says it.
pub fn not_in_the_way(why: NotInTheWay) -> &'static str {
    match why {
        NotInTheWay::TooWide => "too wide for an obstacle",
        NotInTheWay::TooFlat => "too flat for an obstacle",
        NotInTheWay::Passing => "already passing",
        NotInTheWay::FoeOutside => "FOE outside its reach",
        NotInTheWay::ExpandsBeside => "expands beside: passing by",
    }
}

pub fn direction_word(direction: RollDirection) -> &'static str {
    match direction {
        RollDirection::Left => "left",
        RollDirection::Right => "right",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faithd_core::safety::gate::Blocker;

    fn decision(action: Action, reason: Reason) -> Decision {
        Decision {
            t_us: 0,
            action,
            reason,
            foe_px: None,
            vectors: 0,
            clusters: 0,
            obstacle: None,
            escape: None,
        }
    }

    #[test]
    fn a_roll_reads_as_its_direction_length_and_reason() {
        let d = decision(
            Action::Roll {
                direction: RollDirection::Right,
                duration_us: 1_500_000,
            },
            Reason::ObstacleAhead {
                ttc_s: 1.084,
                threshold_s: 1.85,
            },
        );
        assert_eq!(headline(&d), "ROLL RIGHT 1.5 s");
        assert_eq!(
            reason(&d.reason),
            "obstacle ahead, 1.08 s away: under 1.85 s"
        );
    }

    #[test]
    fn a_closed_gate_names_its_blocker_and_a_replay_says_it_has_none() {
        let closed = GateState::Closed(Blocker::SwitchNotAuto { value_us: 1000 });
        assert_eq!(
            gate(Some(&closed)),
            (
                GateWord::Closed,
                "pilot switch not in AUTO (1000 us)".to_string()
            )
        );
        assert_eq!(gate(None).0, GateWord::Unknown);
    }
}
