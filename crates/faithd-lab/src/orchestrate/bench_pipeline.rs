//! `faithd bench pipeline`: the whole pipeline on streams of given event rates (or
//! a recording): per-stage cost per window, throughput, load shedding and peak
//! memory.

use std::fmt::Write;
use std::path::PathBuf;

use super::error::RunError;
use crate::cycle::bench::{self, RateReport};
use faithd_core::camera::{CameraIntrinsics, CameraPreset};
use faithd_core::pipeline::PipelineConfig;
use faithd_daemon::cycle::DaemonConfig;

/// The streams to run through the pipeline.
pub enum Streams {
    /// A recording (AEDAT 2/3/4 or text), as recorded.
    Recording(PathBuf),
    /// Generated looming streams of these events per second, `seconds` long each.
    Generated { rates: Vec<f64>, seconds: f64 },
}

/// The bench once run.
pub struct PipelineBench {
    period_us: i64,
    budget_us: i64,
    cpu_scale: f64,
    camera: BenchCamera,
    reports: Vec<(String, RateReport)>,
}

/// The camera the streams are seen by: a preset's name, or `custom` for intrinsics
/// of a configuration that match none.
#[derive(Clone, Copy, Debug)]
pub struct BenchCamera {
    pub name: &'static str,
    pub intrinsics: CameraIntrinsics,
}

impl BenchCamera {
    /// `preset` when given, else the configuration's camera.
    pub fn resolve(preset: Option<CameraPreset>, configured: CameraIntrinsics) -> Self {
        let preset = preset.or_else(|| {
            CameraPreset::ALL
                .into_iter()
                .find(|p| p.intrinsics() == configured)
        });
        match preset {
            Some(p) => BenchCamera {
                name: p.name(),
                intrinsics: p.intrinsics(),
            },
            None => BenchCamera {
                name: "custom",
                intrinsics: configured,
            },
        }
    }
}

impl Streams {
    /// Each stream's name in the report.
    pub fn names(&self) -> Vec<String> {
        match self {
            Streams::Recording(path) => vec![path.display().to_string()],
            Streams::Generated { rates, .. } => rates
                .iter()
                .map(|r| format!("generated {:.1} Mev/s", r / 1e6))
                .collect(),
        }
    }
}

/// Runs every stream through the pipeline of `pipeline` and `daemon`, seen by
/// `camera` (which replaces `pipeline.camera`), load shed as at `cpu_scale`; `done`
/// hears each stream's end. Each stream is made (or read) just before its run and
/// dropped after it.
pub fn run(
    streams: &Streams,
    (mut pipeline, daemon): (PipelineConfig, DaemonConfig),
    camera: BenchCamera,
    cpu_scale: f64,
    mut done: impl FnMut(),
) -> Result<PipelineBench, RunError> {
    pipeline.camera = camera.intrinsics;
    pipeline
        .validate()
        .map_err(|e| RunError::Refused(e.to_string()))?;
    let mut reports = Vec::new();
    for (i, name) in streams.names().into_iter().enumerate() {
        let events = match streams {
            Streams::Recording(path) => faithd_formats::events::open_events(path)
                .and_then(|mut r| faithd_formats::events::read_all(r.as_mut()))
                .map_err(|e| RunError::Refused(format!("{}: {e}", path.display())))?,
            Streams::Generated { rates, seconds } => {
                bench::generated_stream(&camera.intrinsics, rates[i], *seconds, 1)
            }
        };
        reports.push((name, bench::run(&events, pipeline, daemon, cpu_scale)));
        done();
    }
    Ok(PipelineBench {
        period_us: daemon.period_us,
        budget_us: daemon.budget_us,
        cpu_scale,
        camera,
        reports,
    })
}

impl PipelineBench {
    pub fn json(&self) -> String {
        let rows: Vec<_> = self
            .reports
            .iter()
            .map(|(name, r)| serde_json::json!({ "stream": name, "report": r }))
            .collect();
        let cam = &self.camera.intrinsics;
        serde_json::json!({
            "cpu_scale": self.cpu_scale,
            "camera": self.camera.name,
            "width_px": cam.width_px,
            "height_px": cam.height_px,
            "period_us": self.period_us,
            "budget_us": self.budget_us,
            "streams": rows,
        })
        .to_string()
    }

    /// Each stream's figures in lines of text.
    pub fn report(&self) -> String {
        let mut text = String::new();
        let mut line = |l: String| writeln!(text, "{l}").expect("a String takes text");
        let cam = &self.camera.intrinsics;
        line(format!(
            "faithd bench pipeline: {} ({} x {} px), one window per {} ms within {} ms, load shed as at cpu scale {}",
            self.camera.name,
            cam.width_px,
            cam.height_px,
            self.period_us / 1000,
            self.budget_us / 1000,
            self.cpu_scale
        ));
        for (name, r) in &self.reports {
            stream_lines(name, r, &mut line);
        }
        text
    }
}

/// One stream's figures, line by line.
fn stream_lines(name: &str, r: &RateReport, line: &mut impl FnMut(String)) {
    line(format!(
        "  {name}: {:.2} Mev/s, {} windows of {:.0} events (p99 {:.0})",
        r.events_per_s / 1e6,
        r.windows,
        r.events_per_window_p50,
        r.events_per_window_p99
    ));
    line(format!(
        "    per window (p50): {:.0} events to the flow ({} windows over the event cap), {:.0} new vectors, {:.0} taken by the FOE, {:.0} clustered",
        r.flow_events_per_window_p50,
        r.capped_windows,
        r.new_vectors_p50,
        r.foe_vectors_p50,
        r.clustered_p50
    ));
    let stages: Vec<String> = r
        .stages_us
        .iter()
        .map(|s| format!("{} {:.0}/{:.0}", s.stage, s.p50_us, s.p99_us))
        .collect();
    line(format!("    us per window p50/p99: {}", stages.join(", ")));
    line(format!(
        "    whole window {:.0}/{:.0} us; {:.2} Mev/s per core of compute; {} over budget, {} shed (level up to {}); peak RSS {:.1} MB ({:.1} MB of it the stream)",
        r.window_us_p50,
        r.window_us_p99,
        r.throughput_events_per_s / 1e6,
        r.overruns,
        r.shed_windows,
        r.max_load_level,
        r.peak_rss_bytes.unwrap_or(0) as f64 / 1e6,
        r.stream_bytes as f64 / 1e6
    ));
    line(format!(
        "    kept up: {} windows past their period, largest backlog had they queued {} us; taking a window's events {:.0}/{:.0} us",
        r.late_windows, r.backlog_us_max, r.take_us_p50, r.take_us_p99
    ));
}
