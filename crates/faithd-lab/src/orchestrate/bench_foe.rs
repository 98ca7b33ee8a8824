//! `faithd bench foe`: Table I of the paper, all four FOE methods on simulated
//! flights, and its figures.

use std::path::Path;
use std::time::Instant;

use super::error::RunError;
use faithd_sim::bench::foe::{self, BenchFoeOptions, BenchFoeReport};
use faithd_sim::bench::plot;

/// Runs the benchmark; `done` hears each trajectory's line as it lands.
pub fn run(options: &BenchFoeOptions, done: impl Fn(String) + Sync) -> BenchFoeReport {
    let started = Instant::now();
    let trajectories = options.trajectories;
    foe::run(options, &|finished, t| {
        done(format!(
            "[{finished}/{trajectories}] {:<9} course {:>6.1} deg{}{}: {} events, {:.0} vectors/window, {:.1} s",
            t.scene.name(),
            t.course_deg,
            if t.sway { ", sway" } else { "" },
            if t.rotating { ", rotating" } else { "" },
            t.events,
            t.mean_vectors,
            started.elapsed().as_secs_f64()
        ))
    })
}

/// Draws the report's figures into `dir` (foe_errors.png, and foe_frame.png when
/// the report has an example frame); `written` hears each file once it is.
pub fn write_figures(
    report: &BenchFoeReport,
    dir: &Path,
    mut written: impl FnMut(&Path),
) -> Result<(), RunError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| RunError::Failed(format!("cannot create {}: {e}", dir.display())))?;
    let errors = dir.join("foe_errors.png");
    plot::plot_errors(report, &errors).map_err(|e| RunError::Failed(e.to_string()))?;
    written(&errors);
    if let Some(frame) = &report.example {
        let path = dir.join("foe_frame.png");
        plot::plot_frame(frame, &path).map_err(|e| RunError::Failed(e.to_string()))?;
        written(&path);
    }
    Ok(())
}
