//! `faithd sim --autopilot inav-sitl`: the experiment with iNav's own flight
//! controller (its SITL build) flying the quad-X in real time, one flight after the
//! other, each also flown on the model.

use std::path::PathBuf;
use std::time::Instant;

use super::error::RunError;
use crate::inav_sitl::experiment::{self, Compared, Report};
use crate::inav_sitl::flight::Link;

/// The experiment with iNav's SITL, as asked.
pub struct SitlSim {
    pub runs: usize,
    pub seed: u64,
    /// iNav's SITL executable (9.1, or 10.x built from maintenance-10.x).
    pub exe: PathBuf,
    /// How faithd reads iNav: its MAVLink, or a second MSP port.
    pub link: Link,
}

/// The experiment once flown.
pub struct SitlRun {
    sim: SitlSim,
    flights: Vec<Compared>,
    report: Report,
    wall_s: f64,
}

impl SitlSim {
    /// What is about to fly, in one line.
    pub fn intro(&self) -> String {
        format!(
            "faithd sim: {} flights with iNav's SITL ({}) flying the quad-X in real time, faithd on its {}, seed {}, line camera; each also flown on the model",
            self.runs,
            self.exe.display(),
            self.link.describe(),
            self.seed
        )
    }

    /// Flies every flight on iNav and on the model; `done` hears each one's line
    /// as it lands.
    pub fn fly(self, done: impl Fn(String)) -> Result<SitlRun, RunError> {
        let specs = experiment::plan(self.runs, self.seed);
        let started = Instant::now();
        let flights = experiment::fly_all(&specs, &self.exe, self.link, |i, c| {
            done(flight_line(i, self.runs, c))
        })
        .map_err(|e| RunError::Failed(e.to_string()))?;
        let report = experiment::report(&flights, self.seed, self.link);
        Ok(SitlRun {
            sim: self,
            flights,
            report,
            wall_s: started.elapsed().as_secs_f64(),
        })
    }
}

impl SitlRun {
    /// The report and every flight as one JSON object.
    pub fn json(&self) -> String {
        serde_json::json!({"report": self.report, "flights": self.flights}).to_string()
    }

    /// A heading line and the report's table, iNav beside the model.
    pub fn report(&self) -> String {
        format!(
            "faithd sim --autopilot inav-sitl --link {}: {} flights, seed {}, {:.0} s\n\n{}",
            match self.sim.link {
                Link::Mavlink => "mavlink",
                Link::Msp => "msp",
            },
            self.sim.runs,
            self.sim.seed,
            self.wall_s,
            self.report.table()
        )
    }
}

/// Flight `i` of `runs` on iNav and on the model, in one line.
fn flight_line(i: usize, runs: usize, c: &Compared) -> String {
    format!(
        "  flight {}/{runs}: {} {:+.2} m at {:.2} m/s (iNav's vehicle at {:.2}); iNav: {}{}, bank {}, in effect {}; model: {}{}",
        i + 1,
        if c.inav.collision_course {
            "collision"
        } else {
            "near pass"
        },
        c.spec.lateral_offset_m,
        c.spec.speed_m_s,
        c.speed_at_start_m_s,
        if c.inav.rolled { "rolled" } else { "no roll" },
        if c.inav.collided { ", HIT" } else { "" },
        c.inav
            .peak_bank_deg
            .map_or("-".into(), |b| format!("{b:.1} deg")),
        c.inav
            .in_effect_ms
            .map_or("-".into(), |t| format!("{t:.0} ms")),
        if c.model.rolled { "rolled" } else { "no roll" },
        if c.model.collided { ", HIT" } else { "" },
    )
}
