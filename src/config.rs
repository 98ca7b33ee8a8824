//! faithd.toml: loading and validation.
//!
//! A config mistake on a drone is found on the bench, not in the air: unknown keys,
//! wrong types and out-of-range values are all refused with the key and the reason.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::command::CommandConfig;
use crate::daemon::DaemonConfig;
use crate::daemon::record::RecordConfig;
use crate::daemon::source::SourceConfig;
use crate::link::MavlinkConfig;
use crate::link::endpoint::Endpoint;
use faithd_core::pipeline::PipelineConfig;
use faithd_core::safety::gate::GateConfig;
use faithd_core::safety::manoeuvre::ManoeuvreConfig;

/// The whole file.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FaithdConfig {
    pub pipeline: PipelineConfig,
    pub mavlink: MavlinkConfig,
    pub gate: GateConfig,
    pub manoeuvre: ManoeuvreConfig,
    pub command: CommandConfig,
    pub daemon: DaemonConfig,
    pub source: SourceConfig,
    pub record: RecordConfig,
}

#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("cannot read {path}: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: `{key}` {reason}")]
    Invalid {
        path: PathBuf,
        key: &'static str,
        reason: String,
    },
}

/// A value that failed validation: the dotted key and what is wrong with it.
#[derive(Debug, Clone, PartialEq)]
pub struct Invalid {
    pub key: &'static str,
    pub reason: String,
}

impl FaithdConfig {
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.to_owned(),
            source,
        })?;
        Self::parse(&text).map_err(|e| match e {
            ParseError::Toml(message) => ConfigError::Parse {
                path: path.to_owned(),
                message,
            },
            ParseError::Invalid(Invalid { key, reason }) => ConfigError::Invalid {
                path: path.to_owned(),
                key,
                reason,
            },
        })
    }

    pub fn parse(text: &str) -> Result<Self, ParseError> {
        let config: FaithdConfig =
            toml::from_str(text).map_err(|e| ParseError::Toml(e.to_string()))?;
        config.validate().map_err(ParseError::Invalid)?;
        Ok(config)
    }

    /// Checks every value a type cannot express (ranges, orderings, finiteness).
    pub fn validate(&self) -> Result<(), Invalid> {
        validate_pipeline(&self.pipeline)?;
        validate_links(self)?;
        validate_safety(self)?;
        validate_daemon(self)
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum ParseError {
    Toml(String),
    Invalid(Invalid),
}

impl std::fmt::Display for ParseError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParseError::Toml(m) => write!(f, "{m}"),
            ParseError::Invalid(Invalid { key, reason }) => write!(f, "`{key}` {reason}"),
        }
    }
}

fn check(ok: bool, key: &'static str, reason: impl FnOnce() -> String) -> Result<(), Invalid> {
    if ok {
        Ok(())
    } else {
        Err(Invalid {
            key,
            reason: reason(),
        })
    }
}

fn positive(v: f64, key: &'static str) -> Result<(), Invalid> {
    check(v.is_finite() && v > 0.0, key, || {
        format!("must be a positive number, got {v}")
    })
}

fn non_negative(v: f64, key: &'static str) -> Result<(), Invalid> {
    check(v.is_finite() && v >= 0.0, key, || {
        format!("must be a non-negative number, got {v}")
    })
}

/// The daemon's checks of a pipeline configuration (also applied to the one a window
/// log carries, before a replay allocates anything for it).
pub fn validate_pipeline(p: &PipelineConfig) -> Result<(), Invalid> {
    let cam = &p.camera;
    check(
        (8..=2048).contains(&cam.width_px) && (8..=2048).contains(&cam.height_px),
        "pipeline.camera.width_px",
        || {
            format!(
                "sensor must be 8x8 to 2048x2048 px (event surfaces are allocated per pixel), got {}x{}",
                cam.width_px, cam.height_px
            )
        },
    )?;
    positive(cam.fx_px, "pipeline.camera.fx_px")?;
    positive(cam.fy_px, "pipeline.camera.fy_px")?;
    check(
        cam.cx_px.is_finite() && (0.0..f64::from(cam.width_px)).contains(&cam.cx_px),
        "pipeline.camera.cx_px",
        || {
            format!(
                "must lie on the sensor (0..{}), got {}",
                cam.width_px, cam.cx_px
            )
        },
    )?;
    check(
        cam.cy_px.is_finite() && (0.0..f64::from(cam.height_px)).contains(&cam.cy_px),
        "pipeline.camera.cy_px",
        || {
            format!(
                "must lie on the sensor (0..{}), got {}",
                cam.height_px, cam.cy_px
            )
        },
    )?;
    check(
        (1..=10_000_000).contains(&p.history_us),
        "pipeline.history_us",
        || format!("must be 1 us to 10 s, got {}", p.history_us),
    )?;
    check(
        (1..=100_000).contains(&p.max_vectors),
        "pipeline.max_vectors",
        || {
            format!(
                "must be 1 to 100000 (buffers are sized from it), got {}",
                p.max_vectors
            )
        },
    )?;
    check(
        (1..=100).contains(&p.foe_smoothing_windows),
        "pipeline.foe_smoothing_windows",
        || format!("must be 1 to 100, got {}", p.foe_smoothing_windows),
    )?;

    let f = &p.flow;
    check(
        (1..=faithd_core::flow::MAX_RADIUS_PX).contains(&f.radius_px),
        "pipeline.flow.radius_px",
        || format!("must be 1 to 5, got {}", f.radius_px),
    )?;
    check(f.window_us > 0, "pipeline.flow.window_us", || {
        format!("must be positive, got {}", f.window_us)
    })?;
    check(f.refractory_us >= 0, "pipeline.flow.refractory_us", || {
        format!("must not be negative, got {}", f.refractory_us)
    })?;
    let patch = (2 * usize::from(f.radius_px) + 1).pow(2);
    check(
        (3..=patch).contains(&f.min_points),
        "pipeline.flow.min_points",
        || {
            format!(
                "must be 3 to {patch} for radius {}, got {}",
                f.radius_px, f.min_points
            )
        },
    )?;
    positive(f.outlier_residual_us, "pipeline.flow.outlier_residual_us")?;
    positive(f.max_rms_us, "pipeline.flow.max_rms_us")?;
    positive(f.min_speed_px_s, "pipeline.flow.min_speed_px_s")?;
    positive(f.max_speed_px_s, "pipeline.flow.max_speed_px_s")?;
    check(
        f.min_speed_px_s < f.max_speed_px_s,
        "pipeline.flow.max_speed_px_s",
        || "must exceed min_speed_px_s".into(),
    )?;

    let d = &p.derotation;
    check(
        d.min_speed_px_s >= 0.0,
        "pipeline.derotation.min_speed_px_s",
        || format!("must not be negative, got {}", d.min_speed_px_s),
    )?;
    check(
        d.camera_pitch_up_deg.abs() <= 60.0,
        "pipeline.derotation.camera_pitch_up_deg",
        || format!("must be within +-60 degrees, got {}", d.camera_pitch_up_deg),
    )?;

    let fa = &p.faith;
    check(fa.iterations >= 1, "pipeline.faith.iterations", || {
        "must be at least 1".into()
    })?;
    check(fa.min_vectors >= 2, "pipeline.faith.min_vectors", || {
        "must be at least 2".into()
    })?;
    non_negative(fa.search_margin_px, "pipeline.faith.search_margin_px")?;
    check(
        fa.unbounded_margin_px.is_finite() && fa.unbounded_margin_px > fa.search_margin_px,
        "pipeline.faith.unbounded_margin_px",
        || "must be finite and larger than search_margin_px".into(),
    )?;
    non_negative(fa.inlier_tolerance_px, "pipeline.faith.inlier_tolerance_px")?;

    check(
        (0.0..1.0).contains(&fa.plateau_fraction),
        "pipeline.faith.plateau_fraction",
        || format!("must be 0 (off) to below 1, got {}", fa.plateau_fraction),
    )?;
    positive(fa.plateau_radius_px, "pipeline.faith.plateau_radius_px")?;
    positive(fa.plateau_cell_px, "pipeline.faith.plateau_cell_px")?;
    check(
        (0.0..=120.0).contains(&fa.speed_radius_px),
        "pipeline.faith.speed_radius_px",
        || format!("must be 0 (off) to 120 px, got {}", fa.speed_radius_px),
    )?;
    check(
        fa.speed_radius_px == 0.0
            || fa.speed_step_px >= 0.5 && fa.speed_step_px <= fa.speed_radius_px,
        "pipeline.faith.speed_step_px",
        || {
            format!(
                "must be 0.5 px to speed_radius_px ({}), got {}",
                fa.speed_radius_px, fa.speed_step_px
            )
        },
    )?;
    check(
        (4.0..=240.0).contains(&fa.speed_patch_px),
        "pipeline.faith.speed_patch_px",
        || format!("must be 4 to 240 px, got {}", fa.speed_patch_px),
    )?;
    check(
        fa.speed_temperature >= 0.0 && fa.speed_temperature.is_finite(),
        "pipeline.faith.speed_temperature",
        || {
            format!(
                "must be a non-negative number (0: the best cell alone), got {}",
                fa.speed_temperature
            )
        },
    )?;

    positive(p.ttc.max_ttc_s, "pipeline.ttc.max_ttc_s")?;
    positive(p.cluster.eps, "pipeline.cluster.eps")?;
    check(
        p.cluster.min_points >= 1,
        "pipeline.cluster.min_points",
        || "must be at least 1".into(),
    )?;

    let de = &p.decision;
    positive(de.ttc_threshold_s, "pipeline.decision.ttc_threshold_s")?;
    check(
        (1..=10_000_000).contains(&de.roll_duration_us),
        "pipeline.decision.roll_duration_us",
        || format!("must be 1 us to 10 s, got {}", de.roll_duration_us),
    )?;
    non_negative(de.box_margin_x_px, "pipeline.decision.box_margin_x_px")?;
    non_negative(de.box_margin_y_px, "pipeline.decision.box_margin_y_px")?;
    check(
        (0.0..=1.0).contains(&de.min_foe_support),
        "pipeline.decision.min_foe_support",
        || format!("must be a fraction 0..1, got {}", de.min_foe_support),
    )?;
    check(
        (1..=64).contains(&de.confirm_windows),
        "pipeline.decision.confirm_windows",
        || format!("must be 1 to 64, got {}", de.confirm_windows),
    )?;
    check(
        (de.confirm_windows..=64).contains(&de.confirm_span_windows),
        "pipeline.decision.confirm_span_windows",
        || {
            format!(
                "must be confirm_windows ({}) to 64, got {}",
                de.confirm_windows, de.confirm_span_windows
            )
        },
    )?;
    check(
        de.max_obstacle_width > 0.0 && de.max_obstacle_width <= 1.0,
        "pipeline.decision.max_obstacle_width",
        || {
            format!(
                "must be a fraction in (0, 1], got {}",
                de.max_obstacle_width
            )
        },
    )?;
    non_negative(
        de.min_obstacle_height_px,
        "pipeline.decision.min_obstacle_height_px",
    )?;
    check(
        de.min_ttc_s >= 0.0 && de.min_ttc_s < de.ttc_threshold_s,
        "pipeline.decision.min_ttc_s",
        || {
            format!(
                "must be 0 or more and below ttc_threshold_s, got {}",
                de.min_ttc_s
            )
        },
    )?;
    Ok(())
}

fn validate_links(c: &FaithdConfig) -> Result<(), Invalid> {
    let m = &c.mavlink;
    Endpoint::parse(&m.endpoint, m.baud).map_err(|reason| Invalid {
        key: "mavlink.endpoint",
        reason,
    })?;
    check(m.baud >= 1200, "mavlink.baud", || {
        format!("must be a serial baud rate, got {}", m.baud)
    })?;
    check(m.system_id >= 1, "mavlink.system_id", || {
        "must be 1 to 255".into()
    })?;
    check(m.component_id >= 1, "mavlink.component_id", || {
        "must be 1 to 255".into()
    })?;
    check(
        m.autopilot_system_id >= 1,
        "mavlink.autopilot_system_id",
        || "must be 1 to 255".into(),
    )?;
    check(
        m.autopilot_component_id >= 1,
        "mavlink.autopilot_component_id",
        || "must be 1 to 255 (iNav's is 1, MAV_COMP_ID_AUTOPILOT1)".into(),
    )?;
    check(
        (10_000..=10_000_000).contains(&m.heartbeat_period_us),
        "mavlink.heartbeat_period_us",
        || format!("must be 10 ms to 10 s, got {}", m.heartbeat_period_us),
    )?;
    check(
        m.reconnect_min_us >= 1000 && m.reconnect_min_us <= m.reconnect_max_us,
        "mavlink.reconnect_min_us",
        || "must be at least 1 ms and at most reconnect_max_us".into(),
    )?;
    check(
        m.reconnect_max_us <= 60_000_000,
        "mavlink.reconnect_max_us",
        || format!("must be at most 60 s, got {}", m.reconnect_max_us),
    )?;
    check(
        (100_000..=60_000_000).contains(&m.silence_timeout_us),
        "mavlink.silence_timeout_us",
        || format!("must be 100 ms to 60 s, got {}", m.silence_timeout_us),
    )?;
    let cmd = &c.command;
    check(
        cmd.sink != crate::command::SinkKind::Mavlink,
        "command.sink",
        || format!("\"mavlink\" {}", crate::command::MAVLINK_SINK_REFUSED),
    )?;
    Endpoint::parse(&cmd.msp_endpoint, cmd.msp_baud).map_err(|reason| Invalid {
        key: "command.msp_endpoint",
        reason,
    })?;
    check(
        cmd.msp_endpoint != m.endpoint,
        "command.msp_endpoint",
        || "must be a different port from mavlink.endpoint".into(),
    )?;
    check(
        (20_000..=1_000_000).contains(&cmd.confirm_within_us),
        "command.confirm_within_us",
        || format!("must be 20 ms to 1 s, got {}", cmd.confirm_within_us),
    )?;
    check(
        (10_000..=5_000_000).contains(&cmd.msp_timeout_us),
        "command.msp_timeout_us",
        || format!("must be 10 ms to 5 s, got {}", cmd.msp_timeout_us),
    )?;
    check(
        (0..=5_000_000).contains(&cmd.warmup_margin_us),
        "command.warmup_margin_us",
        || format!("must be 0 to 5 s, got {}", cmd.warmup_margin_us),
    )
}

fn validate_safety(c: &FaithdConfig) -> Result<(), Invalid> {
    let g = &c.gate;
    check(
        (5..=18).contains(&g.switch_channel),
        "gate.switch_channel",
        || {
            format!(
                "must be an AUX channel 5 to 18 (iNav binds its MSP RC OVERRIDE mode to AUX channels), got {}",
                g.switch_channel
            )
        },
    )?;
    check(
        g.auto_min_us <= g.auto_max_us && g.auto_min_us >= 800 && g.auto_max_us <= 2200,
        "gate.auto_min_us",
        || {
            format!(
                "AUTO range {}..{} must lie in 800..2200 with min <= max",
                g.auto_min_us, g.auto_max_us
            )
        },
    )?;
    // A switch has an end that means MANUAL: a range over both ends of the travel
    // (1000 and 2000, give or take 100) would leave the pilot no way back.
    check(
        g.auto_min_us > 1100 || g.auto_max_us < 1900,
        "gate.auto_max_us",
        || {
            format!(
                "AUTO range {}..{} covers the whole stick travel: the pilot could never switch to MANUAL",
                g.auto_min_us, g.auto_max_us
            )
        },
    )?;
    check(
        g.pipeline_stale_us >= 2 * c.daemon.period_us,
        "gate.pipeline_stale_us",
        || {
            format!(
                "{} us is less than two pipeline periods (daemon.period_us = {}): the gate would never open",
                g.pipeline_stale_us, c.daemon.period_us
            )
        },
    )?;
    for (v, key) in [
        (g.rc_stale_us, "gate.rc_stale_us"),
        (g.attitude_stale_us, "gate.attitude_stale_us"),
        (g.heartbeat_stale_us, "gate.heartbeat_stale_us"),
        (g.pipeline_stale_us, "gate.pipeline_stale_us"),
        (g.fc_status_stale_us, "gate.fc_status_stale_us"),
    ] {
        check((1000..=10_000_000).contains(&v), key, || {
            format!("must be 1 ms to 10 s, got {v}")
        })?;
    }
    let m = &c.manoeuvre;
    check(m.roll_channel == 1, "manoeuvre.roll_channel", || {
        format!(
            "must be 1: iNav's roll is its channel 1 whatever the radio's order (faithd reads iNav's channel map), got {}",
            m.roll_channel
        )
    })?;
    check(
        m.roll_channel != g.switch_channel,
        "manoeuvre.roll_channel",
        || "must not be the pilot's switch channel".into(),
    )?;
    check(
        (1000..=2000).contains(&m.neutral_us),
        "manoeuvre.neutral_us",
        || format!("must be 1000..2000, got {}", m.neutral_us),
    )?;
    check(
        (1..=500).contains(&m.deflection_us)
            && m.neutral_us - m.deflection_us >= 1000
            && m.neutral_us + m.deflection_us <= 2000,
        "manoeuvre.deflection_us",
        || {
            format!(
                "must be 1..500 and keep the stick within 1000..2000, got {}",
                m.deflection_us
            )
        },
    )?;
    check(
        (5_000..=500_000).contains(&m.resend_period_us),
        "manoeuvre.resend_period_us",
        || format!("must be 5 to 500 ms, got {}", m.resend_period_us),
    )?;
    check(
        (1..=50).contains(&m.release_repeats),
        "manoeuvre.release_repeats",
        || format!("must be 1 to 50, got {}", m.release_repeats),
    )?;
    check(
        (0..=60_000_000).contains(&m.cooldown_us),
        "manoeuvre.cooldown_us",
        || format!("must be 0 to 60 s, got {}", m.cooldown_us),
    )
}

fn validate_record(c: &FaithdConfig) -> Result<(), Invalid> {
    const MIB: u64 = 1024 * 1024;
    let r = &c.record;
    if !r.enabled {
        return Ok(());
    }
    check(!r.dir.as_os_str().is_empty(), "record.dir", || {
        "must name a directory".into()
    })?;
    check(r.max_file_bytes >= MIB, "record.max_file_bytes", || {
        format!(
            "must be at least 1 MiB ({MIB}), got {}: smaller parts would open a file per batch",
            r.max_file_bytes
        )
    })?;
    // Three files are open at a time (events, MAVLink, windows), each up to a part:
    // one more part of room keeps the budget from deleting what is being written.
    check(
        r.max_total_bytes >= 4 * r.max_file_bytes,
        "record.max_total_bytes",
        || {
            format!(
                "must be at least four times record.max_file_bytes ({}), got {}: three files are written at once and the budget needs a part to spare",
                4 * r.max_file_bytes,
                r.max_total_bytes
            )
        },
    )?;
    check(
        (MIB..=1024 * MIB).contains(&r.max_queue_bytes),
        "record.max_queue_bytes",
        || {
            format!(
                "must be 1 MiB to 1 GiB, got {}: the queue is memory the daemon holds while the card is slow",
                r.max_queue_bytes
            )
        },
    )?;
    check(
        (10..=60_000).contains(&r.sync_interval_ms),
        "record.sync_interval_ms",
        || format!("must be 10 to 60000 ms, got {}", r.sync_interval_ms),
    )
}

fn validate_daemon(c: &FaithdConfig) -> Result<(), Invalid> {
    validate_record(c)?;
    let d = &c.daemon;
    check(
        (1000..=100_000).contains(&d.period_us),
        "daemon.period_us",
        || format!("must be 1 to 100 ms, got {}", d.period_us),
    )?;
    check(
        d.budget_us > 0 && d.budget_us <= d.period_us,
        "daemon.budget_us",
        || {
            format!(
                "must be positive and at most period_us, got {}",
                d.budget_us
            )
        },
    )?;
    check(d.shed_min_vectors >= 1, "daemon.shed_min_vectors", || {
        "must be at least 1".into()
    })?;
    check(
        d.shed_min_iterations >= 1,
        "daemon.shed_min_iterations",
        || "must be at least 1".into(),
    )?;
    check(
        (1000..=10_000_000).contains(&d.event_stale_us),
        "daemon.event_stale_us",
        || format!("must be 1 ms to 10 s, got {}", d.event_stale_us),
    )?;
    let s = &c.source;
    check(
        s.sim_first_approach_us >= 0,
        "source.sim_first_approach_us",
        || "must not be negative".into(),
    )?;
    check(s.sim_repeat_us >= 1_000_000, "source.sim_repeat_us", || {
        format!("must be at least 1 s, got {}", s.sim_repeat_us)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_file_is_all_defaults() {
        assert_eq!(FaithdConfig::parse("").unwrap(), FaithdConfig::default());
    }

    #[test]
    fn shipped_config_parses_and_equals_the_defaults() {
        let text = include_str!("../config/faithd.toml");
        assert_eq!(FaithdConfig::parse(text).unwrap(), FaithdConfig::default());
    }

    #[test]
    fn unknown_key_is_named() {
        let err = FaithdConfig::parse("[pipeline.faith]\niteratoins = 5\n").unwrap_err();
        assert!(err.to_string().contains("iteratoins"), "{err}");
    }

    #[test]
    fn wrong_type_is_named() {
        let err =
            FaithdConfig::parse("[pipeline.decision]\nttc_threshold_s = \"soon\"\n").unwrap_err();
        assert!(err.to_string().contains("ttc_threshold_s"), "{err}");
    }

    #[test]
    fn out_of_range_values_name_key_and_reason() {
        for (text, key) in [
            (
                "[pipeline.flow]\nradius_px = 9\n",
                "pipeline.flow.radius_px",
            ),
            ("[pipeline.cluster]\neps = -0.2\n", "pipeline.cluster.eps"),
            (
                "[pipeline.decision]\nconfirm_windows = 4\nconfirm_span_windows = 3\n",
                "pipeline.decision.confirm_span_windows",
            ),
            (
                "[pipeline.faith]\niterations = 0\n",
                "pipeline.faith.iterations",
            ),
            (
                "[pipeline.faith]\nspeed_radius_px = 40.0\nspeed_step_px = 0.0\n",
                "pipeline.faith.speed_step_px",
            ),
            (
                "[pipeline.faith]\nspeed_patch_px = 1.0\n",
                "pipeline.faith.speed_patch_px",
            ),
            (
                "[pipeline.faith]\nplateau_fraction = 1.5\n",
                "pipeline.faith.plateau_fraction",
            ),
            (
                "[pipeline.camera]\ncx_px = 500.0\n",
                "pipeline.camera.cx_px",
            ),
            (
                "[pipeline.decision]\nroll_duration_us = 0\n",
                "pipeline.decision.roll_duration_us",
            ),
            (
                "[pipeline.decision]\nmin_foe_support = 1.5\n",
                "pipeline.decision.min_foe_support",
            ),
            (
                "[pipeline.decision]\nbox_margin_x_px = -1.0\n",
                "pipeline.decision.box_margin_x_px",
            ),
            (
                "[pipeline.faith]\nsearch_margin_px = inf\n",
                "pipeline.faith.search_margin_px",
            ),
            (
                "[pipeline.flow]\nmin_speed_px_s = 9000.0\n",
                "pipeline.flow.max_speed_px_s",
            ),
            ("[mavlink]\nendpoint = \"COM3\"\n", "mavlink.endpoint"),
            ("[gate]\nswitch_channel = 0\n", "gate.switch_channel"),
            (
                "[gate]\nauto_min_us = 2000\nauto_max_us = 1700\n",
                "gate.auto_min_us",
            ),
            ("[gate]\nattitude_stale_us = 0\n", "gate.attitude_stale_us"),
            (
                "[gate]\nauto_min_us = 900\nauto_max_us = 2100\n",
                "gate.auto_max_us",
            ),
            (
                "[gate]\npipeline_stale_us = 15000\n",
                "gate.pipeline_stale_us",
            ),
            ("[record]\nmax_file_bytes = 0\n", "record.max_file_bytes"),
            (
                "[record]\nmax_file_bytes = 268435456\nmax_total_bytes = 805306368\n",
                "record.max_total_bytes",
            ),
            ("[record]\nmax_queue_bytes = 0\n", "record.max_queue_bytes"),
            (
                "[record]\nsync_interval_ms = 0\n",
                "record.sync_interval_ms",
            ),
            (
                "[gate]\nfc_status_stale_us = 0\n",
                "gate.fc_status_stale_us",
            ),
            (
                "[mavlink]\nautopilot_component_id = 0\n",
                "mavlink.autopilot_component_id",
            ),
            ("[manoeuvre]\nroll_channel = 6\n", "manoeuvre.roll_channel"),
            ("[command]\nsink = \"mavlink\"\n", "command.sink"),
            (
                "[command]\nconfirm_within_us = 5000000\n",
                "command.confirm_within_us",
            ),
            (
                "[manoeuvre]\ndeflection_us = 700\n",
                "manoeuvre.deflection_us",
            ),
            ("[daemon]\nbudget_us = 20000\n", "daemon.budget_us"),
            (
                "[command]\nsink = \"msp\"\nmsp_endpoint = \"serial:/dev/ttyAMA0\"\n",
                "command.msp_endpoint",
            ),
        ] {
            match FaithdConfig::parse(text) {
                Err(ParseError::Invalid(inv)) => assert_eq!(inv.key, key, "{text}"),
                other => panic!("{text}: expected invalid {key}, got {other:?}"),
            }
        }
    }

    #[test]
    fn load_reports_the_path() {
        let err = FaithdConfig::load(Path::new("/nonexistent/faithd.toml")).unwrap_err();
        assert!(err.to_string().contains("/nonexistent/faithd.toml"));
    }
}
