//! `faithd bench compute`: fits the model of the pipeline's compute time that
//! simulated flights charge (`sim --cpu-scale`) to this machine, and judges the
//! committed one on the same windows.

use std::fmt::Write;

use super::plan;
use super::world::World;
use crate::closed_loop::calibrate::{self, FitReport};
use crate::cycle::compute::ComputeModel;
use faithd_core::pipeline::PipelineConfig;

/// The fit once made.
pub struct ComputeBench {
    flights: usize,
    world: World,
    fitted: FitReport,
    committed: FitReport,
}

/// Measures the experiment's first `flights` flights for `seed` in `world`, flown
/// straight one at a time (the model stands for one core of this machine); `done`
/// hears each flight's end.
pub fn run(flights: usize, seed: u64, world: World, mut done: impl FnMut()) -> ComputeBench {
    let specs = plan::flights(flights, seed, &world);
    let config = PipelineConfig::default();
    let mut samples = Vec::new();
    for spec in &specs {
        samples.extend(calibrate::measure(spec, &config));
        done();
    }
    ComputeBench {
        flights: specs.len(),
        world,
        fitted: calibrate::fit(&samples),
        committed: calibrate::judge(&ComputeModel::CALIBRATED, &samples),
    }
}

impl ComputeBench {
    pub fn json(&self) -> String {
        serde_json::json!({ "fitted": self.fitted, "committed": self.committed }).to_string()
    }

    /// The fitted and committed models side by side, in lines of text.
    pub fn report(&self) -> String {
        let (fitted, committed) = (&self.fitted, &self.committed);
        let mut text = String::new();
        let mut line = |l: String| writeln!(text, "{l}").expect("a String takes text");
        line(format!(
            "faithd bench compute: {} windows of {} flights ({})",
            fitted.windows, self.flights, self.world
        ));
        line("  term                              fitted ns    committed ns".into());
        for ((name, c), (_, k)) in fitted.terms.iter().zip(&committed.terms) {
            line(format!("  {name:<32} {c:>10.3} {k:>14.3}"));
        }
        for (label, r) in [("fitted", fitted), ("committed", committed)] {
            line(format!(
                "  {label}: mean window {:.0} us measured, {:.0} us modelled; per-window error median {:.0}%, 90th percentile {:.0}%",
                r.measured_mean_us,
                r.modelled_mean_us,
                100.0 * r.relative_error_p50,
                100.0 * r.relative_error_p90
            ));
        }
        line("  per stage, mean us measured / fitted / committed:".into());
        for ((stage, measured, f), (_, _, k)) in fitted.stages.iter().zip(&committed.stages) {
            line(format!("    {stage:?}: {measured:.1} / {f:.1} / {k:.1}"));
        }
        line(format!(
            "  as code: ns: {:?}",
            fitted.model.ns.map(|c| (c * 1000.0).round() / 1000.0)
        ));
        text
    }
}
