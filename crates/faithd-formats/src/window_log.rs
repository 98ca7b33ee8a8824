//! The window log: one JSON line per pipeline window of a flight, beside its event and
//! MAVLink recordings (`flight-<time>-001.windows.jsonl`).
//!
//! The events and the .tlog hold what came in; the window log holds what the daemon
//! made of it and the few things a replay cannot know from the data alone: where each
//! window ended on the daemon clock, how many events it took (events still in flight
//! at a window's end go to the next one), which attitude samples it was handed (a
//! sample reaches the pipeline a moment after its frame is recorded, and a window can
//! run inside that moment), the load-shedding settings in force, the pipeline
//! configuration, and the Unix time of the daemon clock's zero (which puts every .tlog
//! frame back on the daemon clock). With it `faithd replay --windows` feeds every
//! window exactly what it had in flight and checks it against what was decided live.
//!
//! The first line is a [`WindowLogHeader`]; every other line a [`WindowLogLine`].

use serde::{Deserialize, Serialize};

use faithd_core::attitude::AttitudeUsed;
use faithd_core::decide::Decision;
use faithd_core::derotate::{DerotationConfig, DerotationState};
use faithd_core::flow::FlowConfig;
use faithd_core::foe::{FaithConfig, FoeEstimate};
use faithd_core::pipeline::{PipelineConfig, WindowReport};

/// Format version, bumped on any change a reader must know about.
///
/// 2: FAITH's speed fit (`pipeline.faith.speed_*`). A version-1 header has no such
/// keys, and reading it with today's defaults would switch on a step its flight never
/// ran; [`WindowLogHeader::pipeline_as_run`] turns it off instead.
/// 3: the fit cap. 4: each window's `attitude` (the samples it was handed) and
/// derotation's `max_hold_us`; older flights held any sample.
pub const WINDOW_LOG_VERSION: u32 = 4;

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
    /// ...and only this component's (absent in logs written before faithd checked it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub autopilot_component_id: Option<u8>,
    /// ATTITUDE messages the clock-offset estimate runs over.
    pub clock_sync_window: usize,
    pub pipeline: PipelineConfig,
}

impl WindowLogHeader {
    /// The pipeline configuration the flight ran with, or why this faithd cannot
    /// read it.
    pub fn pipeline_as_run(&self) -> Result<PipelineConfig, String> {
        // Version 2 predates the fit cap: every event of a window was fitted.
        let uncapped = |p: PipelineConfig| PipelineConfig {
            flow: FlowConfig {
                max_fits_per_window: 1_000_000,
                ..p.flow
            },
            ..p
        };
        // Versions 1 to 3 held the nearest attitude sample however far it was.
        let any_hold = PipelineConfig {
            derotation: DerotationConfig {
                max_hold_us: 0,
                ..self.pipeline.derotation
            },
            ..self.pipeline
        };
        match self.faithd_window_log {
            WINDOW_LOG_VERSION => Ok(self.pipeline),
            3 => Ok(any_hold),
            2 => Ok(uncapped(any_hold)),
            // Version 1 also predates FAITH's speed fit.
            1 => Ok(uncapped(PipelineConfig {
                faith: FaithConfig {
                    speed_radius_px: 0.0,
                    ..self.pipeline.faith
                },
                ..any_hold
            })),
            v => Err(format!(
                "window log version {v} (this faithd reads 1 to {WINDOW_LOG_VERSION})"
            )),
        }
    }
}

/// One window as the daemon ran it.
#[derive(Debug, Serialize)]
pub struct WindowLogLine<'a> {
    #[serde(flatten)]
    pub line: &'a WindowLine,
    /// Load-shedding settings in force for this window.
    pub max_vectors: usize,
    pub foe_iterations: u32,
    pub max_fits: usize,
    pub max_events: usize,
    /// The attitude samples the window was handed.
    pub attitude: AttitudeUsed,
}

/// What a replay needs from a recorded line to rerun its window; the rest of the line
/// is kept as JSON to compare against.
#[derive(Clone, Debug, Deserialize)]
pub struct RecordedWindow {
    pub t_us: i64,
    pub events: usize,
    pub max_vectors: usize,
    pub foe_iterations: u32,
    /// The fit cap in force; absent from logs written before there was one (their
    /// windows fitted every event).
    #[serde(default)]
    pub max_fits: Option<usize>,
    /// The event cap in force; absent from logs written before there was one (no
    /// window of theirs held more events than the configuration's cap: their DVS240
    /// peaks at 120,000 a window).
    #[serde(default)]
    pub max_events: Option<usize>,
    /// The attitude samples the window was handed; absent from logs before version 4
    /// (their replay takes the samples whose frames were recorded before the window).
    #[serde(default)]
    pub attitude: Option<AttitudeUsed>,
}

/// One decision window, as printed.
#[derive(Debug, Serialize)]
pub struct WindowLine {
    pub t_us: i64,
    pub events: usize,
    /// `{"x_px", "y_px"}`, `{"unbounded": side, "dx", "dy", "angle_deg"}` or null.
    pub foe: serde_json::Value,
    pub vectors: usize,
    pub clusters: usize,
    /// Attitude that covers the window was subtracted from its flow.
    pub derotated: bool,
    /// Why or why not: `applied`, `off`, `no_attitude` or `not_covered`.
    pub derotation: &'static str,
    pub decision: Decision,
    /// Events left out before the flow: the window held more than its event cap
    /// (`pipeline.flow.max_events_per_window`, or less under load shedding).
    /// Printed only when some were.
    #[serde(skip_serializing_if = "is_zero")]
    pub skipped_events: u64,
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

pub fn foe_json(foe: &FoeEstimate) -> serde_json::Value {
    match foe {
        FoeEstimate::Point { x_px, y_px, .. } => serde_json::json!({"x_px": x_px, "y_px": y_px}),
        // The direction the estimate holds, beside the side it names: a unit ray from
        // the principal point in image axes (x right, y down), and its angle from +x
        // toward +y, so an off-view heading can be scored and plotted.
        FoeEstimate::Unbounded { side, dx, dy, .. } => serde_json::json!({
            "unbounded": side.name(),
            "dx": dx,
            "dy": dy,
            "angle_deg": dy.atan2(*dx).to_degrees(),
        }),
        FoeEstimate::Insufficient { .. } => serde_json::Value::Null,
    }
}

impl WindowLine {
    /// The printed form of one window's report.
    pub fn from_report(t_us: i64, events: usize, report: &WindowReport<'_>) -> Self {
        WindowLine {
            t_us,
            events,
            foe: foe_json(&report.foe),
            vectors: report.vectors.len(),
            clusters: report.clusters.len(),
            derotated: report.derotation.state == DerotationState::Applied,
            derotation: report.derotation.state.name(),
            decision: report.decision,
            skipped_events: report.flow_stats.skipped,
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

/// Why a replayed window differs from the recorded one (`None`: identical). Of the
/// FOE, the keys the flight recorded are compared: a log written before the
/// unbounded FOE's direction was added still compares on its side.
pub fn difference(recorded: &serde_json::Value, replayed: &serde_json::Value) -> Option<String> {
    COMPARED_FIELDS.iter().find_map(|field| {
        let (a, b) = (recorded.get(field), replayed.get(field));
        let same = match *field {
            "foe" => foe_holds(a, b),
            _ => a == b,
        };
        (!same).then(|| {
            let show = |v: Option<&serde_json::Value>| v.map_or("absent".into(), |v| v.to_string());
            format!("{field}: recorded {}, replayed {}", show(a), show(b))
        })
    })
}

/// Whether the replayed FOE says all that the recorded one does.
fn foe_holds(recorded: Option<&serde_json::Value>, replayed: Option<&serde_json::Value>) -> bool {
    match (recorded, replayed) {
        (Some(serde_json::Value::Object(a)), Some(serde_json::Value::Object(b))) => {
            a.iter().all(|(k, v)| b.get(k) == Some(v))
        }
        (a, b) => a == b,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(version: u32) -> WindowLogHeader {
        WindowLogHeader {
            faithd_window_log: version,
            faithd_version: "0.1.0".into(),
            clock_start_unix_us: 0,
            own_system_id: 1,
            own_component_id: 191,
            autopilot_system_id: 1,
            autopilot_component_id: Some(1),
            clock_sync_window: 50,
            pipeline: PipelineConfig::default(),
        }
    }

    #[test]
    fn a_version_1_log_replays_without_the_speed_fit_it_never_ran() {
        // A version-1 header as the daemon wrote it: no speed_* keys.
        let mut json = serde_json::to_value(header(1)).unwrap();
        let faith = json["pipeline"]["faith"].as_object_mut().unwrap();
        faith.retain(|k, _| !k.starts_with("speed_"));
        let old: WindowLogHeader = serde_json::from_value(json).unwrap();
        let config = old.pipeline_as_run().unwrap();
        assert_eq!(config.faith.speed_radius_px, 0.0);
        assert_eq!(
            config.faith.iterations,
            PipelineConfig::default().faith.iterations
        );

        let current = header(WINDOW_LOG_VERSION).pipeline_as_run().unwrap();
        assert_eq!(current, PipelineConfig::default());
        assert!(current.faith.speed_radius_px > 0.0);
    }

    #[test]
    fn logs_before_version_4_replay_with_any_hold_as_they_flew() {
        for version in 1..WINDOW_LOG_VERSION {
            let config = header(version).pipeline_as_run().unwrap();
            assert_eq!(config.derotation.max_hold_us, 0, "version {version}");
        }
        let current = header(WINDOW_LOG_VERSION).pipeline_as_run().unwrap();
        assert!(current.derotation.max_hold_us > 0);
    }

    /// An unbounded FOE recorded before its direction was logged compares on its
    /// side; one recorded with it, on the direction too.
    #[test]
    fn an_old_unbounded_foe_compares_on_the_keys_it_recorded() {
        let line = |foe: serde_json::Value| {
            let mut v = serde_json::json!({
                "t_us": 1, "events": 2, "vectors": 3, "clusters": 0,
                "derotated": true, "decision": {"kind": "hold"},
            });
            v["foe"] = foe;
            v
        };
        let replayed = line(serde_json::json!(
            {"unbounded": "below", "dx": 0.0, "dy": 1.0, "angle_deg": 90.0}
        ));
        let old = line(serde_json::json!({"unbounded": "below"}));
        assert_eq!(difference(&old, &replayed), None);
        let other_side = line(serde_json::json!({"unbounded": "left"}));
        assert!(difference(&other_side, &replayed).is_some());
        let other_ray = line(serde_json::json!(
            {"unbounded": "below", "dx": 0.6, "dy": 0.8, "angle_deg": 53.13}
        ));
        let why = difference(&other_ray, &replayed).unwrap();
        assert!(why.starts_with("foe:"), "{why}");
    }

    /// An FOE beyond the view keeps the direction the estimate holds, not only its
    /// side: 45 degrees of heading would otherwise be lost.
    #[test]
    fn an_unbounded_foe_is_printed_with_its_direction() {
        let foe = FoeEstimate::Unbounded {
            side: faithd_core::foe::Side::Below,
            dx: 0.6,
            dy: 0.8,
            support: 9,
        };
        let json = foe_json(&foe);
        assert_eq!(json["unbounded"], "below");
        assert_eq!(
            (json["dx"].as_f64(), json["dy"].as_f64()),
            (Some(0.6), Some(0.8))
        );
        let angle_deg = json["angle_deg"].as_f64().unwrap();
        assert!((angle_deg - 53.130_102).abs() < 1e-5, "{angle_deg}");
    }

    #[test]
    fn an_unknown_version_is_refused_with_its_number() {
        let err = header(WINDOW_LOG_VERSION + 1)
            .pipeline_as_run()
            .unwrap_err();
        assert!(
            err.contains(&format!("version {}", WINDOW_LOG_VERSION + 1)),
            "{err}"
        );
    }
}
