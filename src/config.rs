//! faithd.toml: loading and validation.
//!
//! A config mistake on a drone is found on the bench, not in the air: unknown keys,
//! wrong types and out-of-range values are all refused with the key and the reason.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::pipeline::PipelineConfig;

/// The whole file. Sections for the links and the daemon join as they are built.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FaithdConfig {
    pub pipeline: PipelineConfig,
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
        validate_pipeline(&self.pipeline)
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

fn validate_pipeline(p: &PipelineConfig) -> Result<(), Invalid> {
    let cam = &p.camera;
    check(
        cam.width_px >= 8 && cam.height_px >= 8,
        "pipeline.camera.width_px",
        || {
            format!(
                "sensor must be at least 8x8 px, got {}x{}",
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
    check(p.history_us > 0, "pipeline.history_us", || {
        format!("must be positive, got {}", p.history_us)
    })?;
    check(p.max_vectors >= 1, "pipeline.max_vectors", || {
        "must be at least 1".into()
    })?;

    let f = &p.flow;
    check(
        (1..=crate::flow::MAX_RADIUS_PX).contains(&f.radius_px),
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
    check(
        fa.search_margin_px >= 0.0 && fa.search_margin_px.is_finite(),
        "pipeline.faith.search_margin_px",
        || format!("must be a non-negative number, got {}", fa.search_margin_px),
    )?;
    check(
        fa.unbounded_margin_px.is_finite() && fa.unbounded_margin_px > fa.search_margin_px,
        "pipeline.faith.unbounded_margin_px",
        || "must be finite and larger than search_margin_px".into(),
    )?;
    check(
        fa.inlier_tolerance_px >= 0.0 && fa.inlier_tolerance_px.is_finite(),
        "pipeline.faith.inlier_tolerance_px",
        || {
            format!(
                "must be a non-negative number, got {}",
                fa.inlier_tolerance_px
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
    check(
        de.box_margin_x_px >= 0.0 && de.box_margin_x_px.is_finite(),
        "pipeline.decision.box_margin_x_px",
        || format!("must be a non-negative number, got {}", de.box_margin_x_px),
    )?;
    check(
        de.box_margin_y_px >= 0.0 && de.box_margin_y_px.is_finite(),
        "pipeline.decision.box_margin_y_px",
        || format!("must be a non-negative number, got {}", de.box_margin_y_px),
    )?;
    check(
        (0.0..=1.0).contains(&de.min_foe_support),
        "pipeline.decision.min_foe_support",
        || format!("must be a fraction 0..1, got {}", de.min_foe_support),
    )?;
    Ok(())
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
                "[pipeline.faith]\niterations = 0\n",
                "pipeline.faith.iterations",
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
                "[pipeline.flow]\nmin_speed_px_s = 9000.0\n",
                "pipeline.flow.max_speed_px_s",
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
