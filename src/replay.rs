//! `faithd replay`: recorded events (and attitude) through the same pipeline, one
//! line per decision window. Deterministic: a recording replays to identical output.
//!
//! Attitude comes from a `.tlog` (ATTITUDE messages, stamped with the autopilot's
//! `time_boot_ms` plus `attitude_offset_us`) or from the `imu.txt` beside a text
//! dataset (`t ax ay az gx gy gz`, seconds and rad/s in the camera's axes: x right,
//! y down, z forward, so body roll rate = gz, pitch rate = gx, yaw rate = gy). Without
//! either, derotation is switched off and every line says so.

use std::io::{BufRead, Write};
use std::path::Path;

use serde::Serialize;

use crate::attitude::AttitudeSample;
use crate::decide::Decision;
use crate::event::Event;
use crate::foe::FoeEstimate;
use crate::link::tlog::{TlogError, TlogReader};
use crate::pipeline::{NoClock, Pipeline, PipelineConfig};
use crate::source::{SourceError, open_events};

#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error("{path}: {source}")]
    Events { path: String, source: SourceError },
    #[error("{path}: {source}")]
    Tlog { path: String, source: TlogError },
    #[error("{path}: cannot read: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}, line {line}: {what}")]
    Imu {
        path: String,
        line: usize,
        what: String,
    },
    #[error("cannot write the output: {0}")]
    Output(std::io::Error),
}

pub enum AttitudeInput<'a> {
    None,
    Tlog { path: &'a Path, offset_us: i64 },
    Imu(&'a Path),
}

/// One decision window, as printed.
#[derive(Debug, Serialize)]
pub struct WindowLine {
    pub t_us: i64,
    pub events: usize,
    /// `{"x_px", "y_px"}`, `{"unbounded": side}` or null.
    pub foe: serde_json::Value,
    pub vectors: usize,
    pub clusters: usize,
    pub derotated: bool,
    pub decision: Decision,
}

fn foe_json(foe: &FoeEstimate) -> serde_json::Value {
    match foe {
        FoeEstimate::Point { x_px, y_px, .. } => serde_json::json!({"x_px": x_px, "y_px": y_px}),
        FoeEstimate::Unbounded { side, .. } => {
            serde_json::json!({"unbounded": format!("{side:?}").to_lowercase()})
        }
        FoeEstimate::Insufficient { .. } => serde_json::Value::Null,
    }
}

/// ATTITUDE samples of a .tlog, on the autopilot's boot clock plus `offset_us`.
pub fn attitude_from_tlog(path: &Path, offset_us: i64) -> Result<Vec<AttitudeSample>, ReplayError> {
    let file = std::fs::File::open(path).map_err(|source| ReplayError::Io {
        path: path.display().to_string(),
        source,
    })?;
    let mut reader = TlogReader::new(std::io::BufReader::new(file));
    let mut out = Vec::new();
    while let Some(rec) = reader.next_record().map_err(|source| ReplayError::Tlog {
        path: path.display().to_string(),
        source,
    })? {
        if let Some(mavlink::dialects::common::MavMessage::ATTITUDE(a)) = rec.message {
            let t_us = i64::from(a.time_boot_ms) * 1000 + offset_us;
            out.push(crate::link::telemetry::attitude_sample(t_us, &a));
        }
    }
    out.sort_by_key(|s| s.t_us);
    Ok(out)
}

/// Body rates from a dataset's imu.txt (gyro in camera axes).
pub fn attitude_from_imu_txt(path: &Path) -> Result<Vec<AttitudeSample>, ReplayError> {
    let p = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|source| ReplayError::Io {
        path: p.clone(),
        source,
    })?;
    let mut out = Vec::new();
    for (i, line) in std::io::BufReader::new(file).lines().enumerate() {
        let line = line.map_err(|source| ReplayError::Io {
            path: p.clone(),
            source,
        })?;
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let v: Vec<f64> = line
            .split_whitespace()
            .map(str::parse::<f64>)
            .collect::<Result<_, _>>()
            .map_err(|e| ReplayError::Imu {
                path: p.clone(),
                line: i + 1,
                what: format!("not a number: {e}"),
            })?;
        if v.len() != 7 || v.iter().any(|x| !x.is_finite()) {
            return Err(ReplayError::Imu {
                path: p.clone(),
                line: i + 1,
                what: format!(
                    "expected 7 finite numbers (t ax ay az gx gy gz), got {}",
                    v.len()
                ),
            });
        }
        out.push(AttitudeSample {
            t_us: (v[0] * 1e6).round() as i64,
            roll_rate_rad_s: v[6],
            pitch_rate_rad_s: v[4],
            yaw_rate_rad_s: v[5],
            ..Default::default()
        });
    }
    out.sort_by_key(|s| s.t_us);
    Ok(out)
}

/// Replays `events_path`, writing one line per `window_us` window to `out`.
pub fn replay(
    events_path: &Path,
    attitude: AttitudeInput<'_>,
    mut config: PipelineConfig,
    window_us: i64,
    json: bool,
    out: &mut dyn Write,
) -> Result<usize, ReplayError> {
    let samples = match attitude {
        AttitudeInput::None => Vec::new(),
        AttitudeInput::Tlog { path, offset_us } => attitude_from_tlog(path, offset_us)?,
        AttitudeInput::Imu(path) => attitude_from_imu_txt(path)?,
    };
    if samples.is_empty() {
        config.derotation.enabled = false;
    }
    let events_err = |source| ReplayError::Events {
        path: events_path.display().to_string(),
        source,
    };
    let mut reader = open_events(events_path).map_err(events_err)?;
    let mut pipeline = Pipeline::new(config);
    let mut pending: Vec<Event> = Vec::new();
    let mut batch = Vec::new();
    let mut window_end_us: Option<i64> = None;
    let mut windows = 0;
    let mut more = true;
    while more || !pending.is_empty() {
        if more {
            more = reader.next_batch(&mut batch).map_err(events_err)?;
            pending.extend_from_slice(&batch);
        }
        let Some(first) = pending.first() else {
            continue;
        };
        let first_us = first.t_us;
        let end = *window_end_us.get_or_insert(first_us + window_us);

        if first_us >= end + 1_000_000 {
            // A gap of over a second (recording paused): skip it rather than print
            // a line for every empty window.
            window_end_us = Some(first_us + window_us);
            continue;
        }
        // Process every window whose end the data has passed (or all, at the end).
        loop {
            let end_us = window_end_us.expect("set above");
            let data_passed = pending.last().is_some_and(|e| e.t_us >= end_us);
            // Wait for more data unless it already passed the window end or has ended.
            if pending.is_empty() || (!data_passed && more) {
                break;
            }
            let take = pending.partition_point(|e| e.t_us < end_us);
            let report = pipeline.process_window(&pending[..take], &samples, end_us, &mut NoClock);
            let line = WindowLine {
                t_us: end_us,
                events: take,
                foe: foe_json(&report.foe),
                vectors: report.vectors.len(),
                clusters: report.clusters.len(),
                derotated: report.derotation.applied,
                decision: report.decision,
            };
            pending.drain(..take);
            windows += 1;
            window_end_us = Some(end_us + window_us);
            if json {
                serde_json::to_writer(&mut *out, &line)
                    .map_err(|e| ReplayError::Output(e.into()))?;
                writeln!(out).map_err(ReplayError::Output)?;
            } else {
                writeln!(
                    out,
                    "{:>12} us  {:>6} events  {}",
                    line.t_us, line.events, line.decision
                )
                .map_err(ReplayError::Output)?;
            }
        }
    }
    Ok(windows)
}
