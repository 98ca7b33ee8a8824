//! `faithd demo --open-loop`: the pipeline alone, open loop, on generated events of
//! an approach to a pole, its stages timed on this machine's clock.

use std::fmt::Write;
use std::time::Instant;

use faithd_core::pipeline::StageClock;
use faithd_sim::demo::{self, DemoSummary};

/// The open-loop demo once run.
pub struct OpenLoopDemo {
    pub summary: DemoSummary,
    /// The decision period, microseconds.
    pub window_us: i64,
}

/// Runs the open-loop demo for `seed`, one window per `window_us`.
pub fn run(seed: u64, window_us: i64) -> OpenLoopDemo {
    let summary = demo::run(seed, window_us, &mut MonotonicClock(Instant::now()));
    OpenLoopDemo { summary, window_us }
}

impl OpenLoopDemo {
    pub fn json(&self) -> String {
        serde_json::to_string(&self.summary).expect("summary serialises")
    }

    /// The run in lines of text: the approach, the first decision, the stages' cost.
    pub fn report(&self) -> String {
        let summary = &self.summary;
        let mut text = String::new();
        let mut line = |s: String| writeln!(text, "{s}").expect("a String takes text");
        line("faithd demo: open-loop approach to a pole (generated events, real pipeline)".into());
        line(format!(
            "  events {}, windows {} of {} ms",
            summary.events,
            summary.windows,
            self.window_us / 1000
        ));
        line(format!(
            "  true FOE ({:.0}, {:.0}) px, pole TTC {:.2} s at start",
            summary.true_foe_px.0, summary.true_foe_px.1, summary.pole_ttc_at_start_s
        ));
        match &summary.first_roll {
            Some(d) => {
                line(format!(
                    "  first decision to avoid at t = {:.0} ms: {d}",
                    d.t_us as f64 / 1e3
                ));
                line(format!(
                    "  true pole TTC then {:.2} s; FOE error {:.1} px",
                    summary.true_ttc_at_roll_s.unwrap_or(f64::NAN),
                    summary.foe_error_px_at_roll.unwrap_or(f64::NAN)
                ));
            }
            None => {
                line("  no avoidance decided (the pole was never judged close and ahead)".into())
            }
        }
        line(format!(
            "  pipeline time per window: mean {:.0} us, max {:.0} us",
            summary.mean_window_us, summary.max_window_us
        ));
        let s = summary.mean_stage_us;
        line(format!(
            "  per stage (mean us): flow {:.0}, derotation {:.0}, FOE {:.0}, TTC {:.0}, clustering {:.0}, decision {:.0}",
            s[0], s[1], s[2], s[3], s[4], s[5]
        ));
        text
    }
}

/// The process's monotonic clock, for stage timings.
struct MonotonicClock(Instant);

impl StageClock for MonotonicClock {
    fn now_ns(&mut self) -> u64 {
        self.0.elapsed().as_nanos() as u64
    }
}
