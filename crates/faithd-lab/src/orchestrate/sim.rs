//! `faithd sim`: the closed-loop experiment, many flights of the daemon against the
//! model of iNav, with success and false-avoidance rates and latencies.

use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

use super::error::RunError;
use super::flight_line::flight_line;
use super::plan;
use super::world::World;
use crate::closed_loop::experiment::{self, SimSummary};
use crate::closed_loop::film::FilmedFlight;
use crate::closed_loop::{FlightOutcome, FlightSpec, plot};
use faithd_sim::bench::plot::PlotError;

/// The experiment, planned.
pub struct Sim {
    pub runs: usize,
    pub seed: u64,
    pub world: World,
    /// Flights flown at once.
    pub threads: usize,
    /// The flight (an index) that keeps its frames for a video.
    pub filmed: Option<usize>,
    specs: Vec<FlightSpec>,
}

/// The experiment once flown.
pub struct SimRun {
    sim: Sim,
    outcomes: Vec<FlightOutcome>,
    summary: SimSummary,
    wall_s: f64,
}

impl Sim {
    /// `runs` flights for `seed` in `world`, `threads` at a time (one per core
    /// when `None`).
    pub fn new(runs: usize, seed: u64, world: World, threads: Option<usize>) -> Self {
        Self {
            runs,
            seed,
            world,
            threads: plan::threads(threads),
            filmed: None,
            specs: plan::flights(runs, seed, &world),
        }
    }

    /// What is about to fly, in one line.
    pub fn intro(&self) -> String {
        format!(
            "faithd sim: {} closed-loop flights, seed {}, {}; {} at a time",
            self.runs, self.seed, self.world, self.threads
        )
    }

    /// Flies every flight; `done` hears each one's line as it lands.
    pub fn fly(self, done: impl Fn(String) + Sync) -> Result<SimRun, RunError> {
        let options = self.world.options();
        let started = Instant::now();
        let specs = &self.specs;
        let outcomes = experiment::fly_all(specs, &options, self.threads, self.filmed, |i, o| {
            done(flight_line(i, self.runs, &specs[i], o))
        })
        .map_err(RunError::Failed)?;
        let summary = experiment::summarise(&outcomes, self.seed, &options);
        Ok(SimRun {
            sim: self,
            outcomes,
            summary,
            wall_s: started.elapsed().as_secs_f64(),
        })
    }
}

impl SimRun {
    /// How long the flights took, simulated and on the wall clock.
    pub fn timing(&self) -> String {
        format!(
            "{} flights ({:.0} s of flight) in {:.0} s on {} threads",
            self.sim.runs, self.summary.simulated_s, self.wall_s, self.sim.threads
        )
    }

    /// Draws each flight's closest approach against its course offset at `path`.
    pub fn plot(&self, path: &Path) -> Result<(), PlotError> {
        if let Some(dir) = path.parent() {
            let _ = std::fs::create_dir_all(dir);
        }
        plot::plot_outcomes(&self.outcomes, path)
    }

    /// The filmed flight's frames, with the video's title (once; `None` when no
    /// flight was filmed).
    pub fn take_film(&mut self) -> Option<(FilmedFlight, String)> {
        let i = self.sim.filmed?;
        let o = &mut self.outcomes[i];
        let title = format!(
            "faithd sim, seed {}: flight {} of {} ({}, {}, {:+.2} m off the pole)",
            self.sim.seed,
            i + 1,
            self.sim.runs,
            if o.collision_course {
                "collision course"
            } else {
                "near pass"
            },
            o.spec.scene.name(),
            o.spec.lateral_offset_m
        );
        let film = o.film.take().expect("the filmed flight keeps its frames");
        Some((film, title))
    }

    pub fn json(&self) -> String {
        serde_json::to_string(&self.summary).expect("summary serialises")
    }

    /// The experiment's figures in lines of text.
    pub fn report(&self) -> String {
        let s = &self.summary;
        let mut text = String::new();
        let mut line = |l: String| writeln!(text, "{l}").expect("a String takes text");
        line(format!(
            "faithd sim: {} closed-loop flights, seed {}, {}",
            s.runs, s.seed, self.sim.world
        ));
        line(format!(
            "  collision courses {}: avoided {} ({:.1}%)",
            s.collision_courses,
            s.avoided,
            100.0 * s.success_rate
        ));
        line(format!(
            "  near passes {}: false avoidances {} ({:.1}%), contacts {}",
            s.near_passes,
            s.false_avoidances,
            100.0 * s.false_avoidances as f64 / s.near_passes.max(1) as f64,
            s.near_pass_contacts
        ));
        line(format!(
            "  deciding event to roll in use at the autopilot: p50 {:.1} ms, p99 {:.1} ms; from the first call (with the gate's hold): p50 {:.1} ms, p99 {:.1} ms",
            s.latency_ms_p50,
            s.latency_ms_p99,
            s.latency_from_first_call_ms_p50,
            s.latency_from_first_call_ms_p99
        ));
        line(format!(
            "  true TTC at the roll (median): {:.2} s",
            s.ttc_at_decision_s_p50
        ));
        line(format!(
            "  pipeline cycles {}: {:.2} ms median, {:.2} ms p99; {} over budget, {} with load shed",
            s.cycles, s.cycle_ms_p50, s.cycle_ms_p99, s.overruns, s.shed_cycles
        ));
        text
    }
}
