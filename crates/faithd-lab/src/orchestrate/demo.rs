//! `faithd demo`: the daemon flies a simulated quadrotor at a pole against a
//! simulated iNav, in simulated time, and the flight is drawn and reported.

use std::fmt::Write;
use std::path::PathBuf;
use std::time::Instant;

use super::error::RunError;
use super::world::World;
use crate::closed_loop::film::FilmedFlight;
use crate::closed_loop::{self, FlightOutcome, FlightSpec, FlyOptions, plot};
use faithd_sim::bench::plot::PlotError;

/// The demo's flight, as asked.
#[derive(Clone, Debug)]
pub struct Demo {
    pub spec: FlightSpec,
    pub world: World,
    /// The pilot's switch stays in MANUAL: faithd must not act.
    pub manual: bool,
    /// Where to draw the trajectory.
    pub plot: PathBuf,
    /// Keep the flight's frames for a video.
    pub film: bool,
}

/// The demo once flown.
pub struct DemoFlight {
    demo: Demo,
    outcome: FlightOutcome,
    wall_s: f64,
    plotted: Result<(), PlotError>,
}

impl Demo {
    /// The flight past the pole at `offset_m` from its centre, seed `seed`.
    pub fn new(seed: u64, offset_m: f64, manual: bool, world: World, plot: PathBuf) -> Self {
        let mut spec = FlightSpec {
            lateral_offset_m: offset_m,
            pilot_auto: !manual,
            seed,
            ..Default::default()
        };
        world.apply(0, &mut spec);
        Self {
            spec,
            world,
            manual,
            plot,
            film: false,
        }
    }

    /// What is about to fly, in one line.
    pub fn intro(&self) -> String {
        format!(
            "faithd demo: the daemon flies a simulated quadrotor at a pole ({} m/s, course {:+.2} m from its centre) against a simulated iNav (MAVLink and MSP on simulated UARTs), in simulated time; {}; switch {}",
            self.spec.speed_m_s,
            self.spec.lateral_offset_m,
            self.world,
            if self.manual {
                "stays in MANUAL"
            } else {
                "to AUTO at 0.5 s"
            }
        )
    }

    /// Flies the demo and draws its trajectory (a drawing that fails is reported,
    /// not an error).
    pub fn fly(self) -> Result<DemoFlight, RunError> {
        let options = FlyOptions {
            film: self.film,
            ..self.world.options()
        };
        let started = Instant::now();
        let outcome = closed_loop::fly(&self.spec, &options)
            .map_err(|e| RunError::Failed(format!("cannot fly the demo: {e}")))?;
        let wall_s = started.elapsed().as_secs_f64();
        if let Some(dir) = self.plot.parent() {
            let _ = std::fs::create_dir_all(dir);
        }
        let plotted = plot::plot_flight(&outcome, &self.plot);
        Ok(DemoFlight {
            demo: self,
            outcome,
            wall_s,
            plotted,
        })
    }
}

impl DemoFlight {
    /// The outcome as one JSON object, without the path.
    pub fn json(&self) -> String {
        let mut value = serde_json::to_value(&self.outcome).expect("outcome serialises");
        value.as_object_mut().map(|o| o.remove("path"));
        value.to_string()
    }

    /// The outcome in lines of text.
    pub fn report(&self) -> String {
        let (o, spec) = (&self.outcome, &self.demo.spec);
        let mut text = String::new();
        let mut line = |s: String| writeln!(text, "{s}").expect("a String takes text");
        line("faithd demo: closed-loop flight at a pole".into());
        line(format!(
            "  course: {} ({:+.2} m from the pole's centre; contact below {:.2} m)",
            if o.collision_course {
                "collision"
            } else {
                "near pass"
            },
            spec.lateral_offset_m,
            FlightSpec::contact_distance_m()
        ));
        line(match (o.decision_s, o.ttc_at_decision_s) {
            (Some(t), Some(ttc)) => format!(
                "  roll decided at {t:.2} s of flight, true time to contact then {ttc:.2} s; roll in use at the autopilot {:.1} ms after the deciding event",
                o.latency_ms.unwrap_or(f64::NAN)
            ),
            _ => "  no roll commanded".into(),
        });
        let p = &o.pipeline;
        line(format!(
            "  pipeline: {} cycles, {:.2} ms median ({:.2} ms p99) at cpu scale {}; {} over budget, {} with load shed",
            p.cycles,
            p.charged_us_p50 / 1e3,
            p.charged_us_p99 / 1e3,
            self.demo.world.cpu_scale,
            p.overruns,
            p.shed_cycles
        ));
        line(format!(
            "  {} events; {:.2} s of flight simulated in {:.1} s",
            o.events,
            o.path.last().map_or(0.0, |p| p.t_s),
            self.wall_s
        ));
        line(format!(
            "  result: {}, closest gap between vehicle and pole {:.2} m",
            if o.collided {
                "HIT the pole"
            } else {
                "no contact"
            },
            o.min_clearance_m
        ));
        line(match &self.plotted {
            Ok(()) => format!("  trajectory: {}", self.demo.plot.display()),
            Err(e) => format!("  trajectory not drawn: {e}"),
        });
        text
    }

    /// The flight's frames for its video, with the video's title (once; `None`
    /// when the demo was not filmed).
    pub fn take_film(&mut self) -> Option<(FilmedFlight, String)> {
        let film = self.outcome.film.take()?;
        let title = format!(
            "faithd demo: {} ({:+.2} m off the pole), seed {}",
            if self.outcome.collision_course {
                "collision course"
            } else {
                "near pass"
            },
            self.demo.spec.lateral_offset_m,
            self.demo.spec.seed
        );
        Some((film, title))
    }
}
