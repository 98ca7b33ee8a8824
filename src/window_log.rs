//! The window log: one JSON line per pipeline window of a flight, beside its event and
//! MAVLink recordings (`flight-<time>-001.windows.jsonl`).
//!
//! The events and the .tlog hold what came in; the window log holds what the daemon
//! made of it and the few things a replay cannot know from the data alone: where each
//! window ended on the daemon clock, how many events it took (events still in flight
//! at a window's end go to the next one), the load-shedding settings in force, the
//! pipeline configuration, and the Unix time of the daemon clock's zero (which puts
//! every .tlog frame back on the daemon clock). With it `faithd replay --windows`
//! recomputes every window of a flight and checks it against what was decided live.
//!
//! The first line is a [`WindowLogHeader`]; every other line a [`WindowLogLine`].

use serde::{Deserialize, Serialize};

use crate::pipeline::{PipelineConfig, WindowReport};
use crate::replay::WindowLine;

/// Format version, bumped on any change a reader must know about.
pub const WINDOW_LOG_VERSION: u32 = 1;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WindowLogHeader {
    pub faithd_window_log: u32,
    pub faithd_version: String,
    /// Unix time (us) of the daemon clock's zero; .tlog stamps minus this are
    /// daemon-clock times.
    pub clock_start_unix_us: i64,
    /// Frames from this system and component in the .tlog are faithd's own (outgoing).
    pub own_system_id: u8,
    pub own_component_id: u8,
    /// Only this system's frames were taken as the autopilot's.
    pub autopilot_system_id: u8,
    /// ATTITUDE messages the clock-offset estimate runs over.
    pub clock_sync_window: usize,
    pub pipeline: PipelineConfig,
}

/// One window as the daemon ran it.
#[derive(Debug, Serialize)]
pub struct WindowLogLine<'a> {
    #[serde(flatten)]
    pub line: &'a WindowLine,
    /// Load-shedding settings in force for this window.
    pub max_vectors: usize,
    pub foe_iterations: u32,
}

/// What a replay needs from a recorded line to rerun its window; the rest of the line
/// is kept as JSON to compare against.
#[derive(Clone, Debug, Deserialize)]
pub struct RecordedWindow {
    pub t_us: i64,
    pub events: usize,
    pub max_vectors: usize,
    pub foe_iterations: u32,
}

impl WindowLine {
    /// The printed form of one window's report.
    pub fn from_report(t_us: i64, events: usize, report: &WindowReport<'_>) -> Self {
        WindowLine {
            t_us,
            events,
            foe: crate::replay::foe_json(&report.foe),
            vectors: report.vectors.len(),
            clusters: report.clusters.len(),
            derotated: report.derotation.applied,
            decision: report.decision,
        }
    }
}

/// The fields of a window line that a replay must reproduce exactly.
pub const COMPARED_FIELDS: [&str; 7] = [
    "t_us",
    "events",
    "foe",
    "vectors",
    "clusters",
    "derotated",
    "decision",
];

/// Why a replayed window differs from the recorded one (`None`: identical).
pub fn difference(recorded: &serde_json::Value, replayed: &serde_json::Value) -> Option<String> {
    COMPARED_FIELDS.iter().find_map(|field| {
        let (a, b) = (recorded.get(field), replayed.get(field));
        (a != b).then(|| {
            let show = |v: Option<&serde_json::Value>| v.map_or("absent".into(), |v| v.to_string());
            format!("{field}: recorded {}, replayed {}", show(a), show(b))
        })
    })
}
