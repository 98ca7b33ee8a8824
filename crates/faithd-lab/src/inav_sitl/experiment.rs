//! The closed-loop experiment with iNav's SITL in the loop, and beside each flight
//! the deterministic model's (`closed_loop::fly`, the line camera) on the same spec:
//! where the two differ is what the model has to learn from iNav.

use std::path::Path;

use serde::Serialize;

use super::flight::{self, Link, SitlOutcome};
use super::process::SitlError;
use crate::closed_loop::experiment::percentile;
use crate::closed_loop::{self, CameraKind, FlightOutcome, FlightSpec, FlyOptions};
use faithd_core::decide::{Action, RollDirection};

/// The experiment's flights: `closed_loop::experiment::plan` (60 % collision courses,
/// a second pole in 30 %), on the line camera, which keeps up in real time.
pub fn plan(runs: usize, seed: u64) -> Vec<FlightSpec> {
    closed_loop::experiment::plan(runs, seed)
        .into_iter()
        .map(|spec| FlightSpec {
            camera: CameraKind::Line,
            ..spec
        })
        .collect()
}

/// What one roll did, measured the same way on iNav and on the model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct RollFigures {
    pub collision_course: bool,
    pub collided: bool,
    pub rolled: bool,
    /// Newest event of the deciding window -> the roll in use at the autopilot, ms.
    pub in_effect_ms: Option<f64>,
    /// The same event -> 5 degrees of bank the roll's way, ms.
    pub bank_5_deg_ms: Option<f64>,
    /// The same event -> 90 % of the roll's peak bank, ms.
    pub bank_90_ms: Option<f64>,
    pub peak_bank_deg: Option<f64>,
    pub height_change_m: Option<f64>,
    pub max_tilt_deg: f64,
    pub min_clearance_m: f64,
}

impl RollFigures {
    pub fn of_sitl(o: &SitlOutcome) -> Self {
        Self {
            collision_course: o.collision_course,
            collided: o.collided,
            rolled: o.rolled,
            in_effect_ms: o.in_effect_ms,
            bank_5_deg_ms: o.bank_5_deg_ms,
            bank_90_ms: o.bank_90_ms,
            peak_bank_deg: o.peak_bank_deg,
            height_change_m: o.height_change_m,
            max_tilt_deg: o.max_tilt_deg,
            min_clearance_m: o.min_clearance_m,
        }
    }

    /// The model's flight, from its path (every 10 ms) and its latencies.
    pub fn of_model(o: &FlightOutcome) -> Self {
        let mut f = Self {
            collision_course: o.collision_course,
            collided: o.collided,
            rolled: o.rolled,
            in_effect_ms: o.latency_ms,
            // The model flies at a constant height.
            height_change_m: o.rolled.then_some(0.0),
            max_tilt_deg: o.path.iter().map(|p| p.bank_deg.abs()).fold(0.0, f64::max),
            min_clearance_m: o.min_clearance_m,
            ..Self::default()
        };
        let (Some(event_s), Some(decision_s), Some(decision)) =
            (o.event_s, o.decision_s, o.decision)
        else {
            return f;
        };
        let sign = match decision.action {
            Action::Roll {
                direction: RollDirection::Left,
                ..
            } => -1.0,
            _ => 1.0,
        };
        let roll: Vec<_> = o
            .path
            .iter()
            .filter(|p| p.t_s >= decision_s && p.t_s <= decision_s + 2.0)
            .collect();
        if roll.is_empty() {
            return f;
        }
        let peak = roll
            .iter()
            .map(|p| p.bank_deg * sign)
            .fold(f64::MIN, f64::max);
        let after_event = |t_s: f64| (t_s - event_s) * 1e3;
        f.peak_bank_deg = Some(peak);
        f.bank_5_deg_ms = roll
            .iter()
            .find(|p| p.bank_deg * sign >= 5.0)
            .map(|p| after_event(p.t_s));
        f.bank_90_ms = roll
            .iter()
            .find(|p| p.bank_deg * sign >= 0.9 * peak)
            .map(|p| after_event(p.t_s));
        f
    }
}

/// One flight on iNav and on the model.
#[derive(Clone, Debug, Serialize)]
pub struct Compared {
    pub spec: FlightSpec,
    pub inav: RollFigures,
    pub model: RollFigures,
    /// The iNav flight's extra figures (speed at the start, MSP_RC's view of the
    /// roll, the mixer before it, RealFlight exchanges).
    pub speed_at_start_m_s: f64,
    pub msp_rc_ms: Option<f64>,
    pub mix_before_roll: Option<f64>,
    pub sitl_restarts: u32,
    pub exchanges: u64,
    /// Where iNav's loop stalled ([`super::stalls`]).
    pub stalls: super::stalls::StallFigures,
    /// From the deciding event to faithd's roll on this machine, ms.
    pub decision_ms: Option<f64>,
    /// The iNav flight's path, every 10 ms from the model's start point.
    pub path: Vec<super::flight::SitlPathPoint>,
}

/// Flies every spec on iNav (in real time, one after the other, faithd reading it
/// over `link`) and on the model; `done` hears each as it lands.
pub fn fly_all(
    specs: &[FlightSpec],
    exe: &Path,
    link: Link,
    done: impl Fn(usize, &Compared),
) -> Result<Vec<Compared>, SitlError> {
    let mut all = Vec::with_capacity(specs.len());
    for (i, spec) in specs.iter().enumerate() {
        let inav = flight::fly(spec, exe, link)
            .map_err(|e| SitlError::Other(format!("flight {} on iNav: {e}", i + 1)))?;
        let model = closed_loop::fly(spec, &FlyOptions::default())
            .map_err(|e| SitlError::Other(format!("flight {} on the model: {e}", i + 1)))?;
        let compared = Compared {
            spec: spec.clone(),
            inav: RollFigures::of_sitl(&inav),
            model: RollFigures::of_model(&model),
            speed_at_start_m_s: inav.speed_at_start_m_s,
            msp_rc_ms: inav.msp_rc_ms,
            mix_before_roll: inav.mix_before_roll,
            sitl_restarts: inav.sitl_restarts,
            exchanges: inav.exchanges,
            stalls: inav.stalls,
            decision_ms: inav.decision_ms,
            path: inav.path,
        };
        done(i, &compared);
        all.push(compared);
    }
    Ok(all)
}

/// p50 and p99 of some figures.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Spread {
    pub count: usize,
    pub p50: f64,
    pub p99: f64,
    pub min: f64,
    pub max: f64,
}

impl Spread {
    pub fn of(values: impl Iterator<Item = f64>) -> Self {
        let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
        v.sort_by(f64::total_cmp);
        Self {
            count: v.len(),
            p50: percentile(&v, 0.5),
            p99: percentile(&v, 0.99),
            min: v.first().copied().unwrap_or(f64::NAN),
            max: v.last().copied().unwrap_or(f64::NAN),
        }
    }
}

/// One side's figures over the experiment.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Figures {
    pub runs: usize,
    pub collision_courses: usize,
    pub avoided: usize,
    pub near_passes: usize,
    pub false_avoidances: usize,
    /// Flights whose tilt reached 90 degrees.
    pub flips: usize,
    pub max_height_change_m: f64,
    pub peak_bank_deg: Spread,
    pub in_effect_ms: Spread,
    pub bank_5_deg_ms: Spread,
    pub bank_90_ms: Spread,
}

impl Figures {
    pub fn of(flights: &[RollFigures]) -> Self {
        let courses = flights.iter().filter(|f| f.collision_course);
        let near = flights.iter().filter(|f| !f.collision_course);
        Self {
            runs: flights.len(),
            collision_courses: courses.clone().count(),
            avoided: courses.filter(|f| !f.collided).count(),
            near_passes: near.clone().count(),
            false_avoidances: near.filter(|f| f.rolled).count(),
            flips: flights.iter().filter(|f| f.max_tilt_deg >= 90.0).count(),
            max_height_change_m: flights
                .iter()
                .filter_map(|f| f.height_change_m)
                .fold(0.0, f64::max),
            peak_bank_deg: Spread::of(flights.iter().filter_map(|f| f.peak_bank_deg)),
            in_effect_ms: Spread::of(flights.iter().filter_map(|f| f.in_effect_ms)),
            bank_5_deg_ms: Spread::of(flights.iter().filter_map(|f| f.bank_5_deg_ms)),
            bank_90_ms: Spread::of(flights.iter().filter_map(|f| f.bank_90_ms)),
        }
    }
}

/// The experiment, iNav beside the model.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub seed: u64,
    /// How faithd read iNav in every flight.
    pub link: Link,
    pub inav: Figures,
    pub model: Figures,
    /// Flights where iNav and the model came out the same (rolled or not, hit or not).
    pub same_outcome: usize,
    pub late_exchanges: u64,
    /// The longest stall of iNav's loop in any flight, ms.
    pub worst_stall_ms: f64,
    /// Rolls with a stall in their span ([`super::stalls`]).
    pub disturbed_rolls: usize,
    pub exchanges: u64,
    /// SITLs that ended by themselves while starting, and were started afresh.
    pub sitl_restarts: u32,
}

pub fn report(flights: &[Compared], seed: u64, link: Link) -> Report {
    let inav: Vec<_> = flights.iter().map(|c| c.inav).collect();
    let model: Vec<_> = flights.iter().map(|c| c.model).collect();
    Report {
        seed,
        link,
        inav: Figures::of(&inav),
        model: Figures::of(&model),
        same_outcome: flights
            .iter()
            .filter(|c| c.inav.rolled == c.model.rolled && c.inav.collided == c.model.collided)
            .count(),
        late_exchanges: flights.iter().map(|c| c.stalls.late_exchanges).sum(),
        worst_stall_ms: flights
            .iter()
            .map(|c| c.stalls.worst_ms)
            .fold(0.0, f64::max),
        disturbed_rolls: flights.iter().filter(|c| c.stalls.disturbs_roll()).count(),
        exchanges: flights.iter().map(|c| c.exchanges).sum(),
        sitl_restarts: flights.iter().map(|c| c.sitl_restarts).sum(),
    }
}

impl Report {
    /// The two columns as a Markdown table.
    pub fn table(&self) -> String {
        let spread = |s: &Spread, unit: &str| {
            if s.count == 0 {
                "-".to_string()
            } else {
                format!("{:.0} / {:.0} {unit}", s.p50, s.p99)
            }
        };
        let (a, b) = (&self.inav, &self.model);
        let rows = [
            (
                "collision courses avoided".to_string(),
                format!("{} / {}", a.avoided, a.collision_courses),
                format!("{} / {}", b.avoided, b.collision_courses),
            ),
            (
                "false avoidances".into(),
                format!("{} / {}", a.false_avoidances, a.near_passes),
                format!("{} / {}", b.false_avoidances, b.near_passes),
            ),
            ("flips".into(), a.flips.to_string(), b.flips.to_string()),
            (
                "largest height change in a roll".into(),
                format!("{:.2} m", a.max_height_change_m),
                format!("{:.2} m", b.max_height_change_m),
            ),
            (
                "peak bank per roll (p50, min-max)".into(),
                format!(
                    "{:.1} deg ({:.1}-{:.1})",
                    a.peak_bank_deg.p50, a.peak_bank_deg.min, a.peak_bank_deg.max
                ),
                format!(
                    "{:.1} deg ({:.1}-{:.1})",
                    b.peak_bank_deg.p50, b.peak_bank_deg.min, b.peak_bank_deg.max
                ),
            ),
            (
                "event -> roll in effect (p50 / p99)".into(),
                spread(&a.in_effect_ms, "ms"),
                spread(&b.in_effect_ms, "ms"),
            ),
            (
                "event -> 5 deg of bank".into(),
                spread(&a.bank_5_deg_ms, "ms"),
                spread(&b.bank_5_deg_ms, "ms"),
            ),
            (
                "event -> 90 % of the peak bank".into(),
                spread(&a.bank_90_ms, "ms"),
                spread(&b.bank_90_ms, "ms"),
            ),
        ];
        let mut out = format!(
            "| | iNav SITL, {} | faithd's model |\n| --- | --- | --- |\n",
            self.link.describe()
        );
        for (what, x, y) in rows {
            out.push_str(&format!("| {what} | {x} | {y} |\n"));
        }
        out.push_str(&format!(
            "\n{} of {} flights came out the same on both; RealFlight: {} exchanges, {} late \
             (the longest stall of iNav's loop {:.0} ms; {} rolls disturbed by one); \
             {} SITLs ended by themselves while starting and were started afresh.\n",
            self.same_outcome,
            a.runs,
            self.exchanges,
            self.late_exchanges,
            self.worst_stall_ms,
            self.disturbed_rolls,
            self.sitl_restarts
        ));
        out
    }
}
