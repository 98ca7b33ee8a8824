//! `faithd sim --straight`: the experiment's flights flown straight, without the
//! daemon and faster than real time, and where the decision rule would have rolled
//! (a proxy for tuning it over many seeds; see [`crate::closed_loop::straight`]).

use std::fmt::Write;

use super::plan;
use super::world::World;
use crate::closed_loop::straight::{self, StraightOutcome, StraightSummary};
use faithd_core::pipeline::PipelineConfig;

/// The straight flights once flown.
pub struct StraightRun {
    outcomes: Vec<StraightOutcome>,
    summary: StraightSummary,
}

/// Flies the experiment's `runs` flights for `seed` in `world` straight, judged by
/// `config`, `threads` at a time (one per core when `None`).
pub fn fly(
    runs: usize,
    seed: u64,
    world: &World,
    config: &PipelineConfig,
    threads: Option<usize>,
) -> StraightRun {
    let specs = plan::flights(runs, seed, world);
    let outcomes = straight::fly_all(&specs, config, plan::threads(threads));
    let summary = straight::summarise(&outcomes, seed);
    StraightRun { outcomes, summary }
}

impl StraightRun {
    /// A line for each flight the rule got wrong or rolled on: a collision course
    /// with no roll or a late one, a near pass it rolled on.
    pub fn notable_flights(&self) -> Vec<String> {
        let mut lines = Vec::new();
        for (i, o) in self.outcomes.iter().enumerate() {
            let what = match (&o.roll, o.collision_course) {
                (None, true) => "collision course: NO ROLL".to_string(),
                (Some(r), true) if !o.avoided() => {
                    format!(
                        "collision course: LATE, rolled at true TTC {:.2} s: {}",
                        r.true_ttc_s, r.decision
                    )
                }
                (Some(r), false) => {
                    format!(
                        "near pass: rolled at true TTC {:.2} s: {}",
                        r.true_ttc_s, r.decision
                    )
                }
                _ => continue,
            };
            lines.push(format!(
                "[{}] offset {:+.2} m: {what}",
                i + 1,
                o.spec.lateral_offset_m
            ));
        }
        lines
    }

    pub fn json(&self) -> String {
        serde_json::to_string(&self.summary).expect("summary serialises")
    }

    /// The figures in lines of text.
    pub fn report(&self) -> String {
        let s = &self.summary;
        let mut text = String::new();
        let mut line = |l: String| writeln!(text, "{l}").expect("a String takes text");
        line(format!(
            "faithd sim --straight: {} flights, seed {}",
            s.runs, s.seed
        ));
        line(format!(
            "  collision courses {}: rolled in time {}, late {}, no roll {}",
            s.collision_courses, s.avoided, s.late, s.no_roll
        ));
        line(format!(
            "  near passes {}: false avoidances {} ({:.1}%)",
            s.near_passes,
            s.false_avoidances,
            100.0 * s.false_avoidances as f64 / s.near_passes.max(1) as f64
        ));
        text
    }
}
