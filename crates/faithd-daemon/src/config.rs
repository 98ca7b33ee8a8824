//! faithd.toml, read into types that hold only usable values.
//!
//! A config mistake on a drone is found on the bench, not in the air. Parsing does
//! most of the work: RC channels, pulse widths and endpoints have types of their own,
//! and the command sink and the event source are tagged by `kind`, each with its own
//! keys. Each section then checks its ranges next to its definition (`validate`),
//! and this module the few rules that relate sections. Unknown keys, wrong types and
//! values out of range are all refused with the dotted key and the reason.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::command::CommandConfig;
use crate::cycle::DaemonConfig;
use crate::link::ground::GroundConfig;
use crate::link::{MavlinkConfig, TelemetryConfig};
use crate::record::RecordConfig;
use crate::source::SourceConfig;
use crate::transport::Endpoint;
use faithd_core::invalid::check;
use faithd_core::osd::OsdConfig;
use faithd_core::pipeline::PipelineConfig;
use faithd_core::safety::gate::GateConfig;
use faithd_core::safety::manoeuvre::ManoeuvreConfig;

/// The whole file.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FaithdConfig {
    pub pipeline: PipelineConfig,
    /// Where the autopilot is read: iNav's MAVLink on `[mavlink]` (the default), or
    /// a second MSP port for the boards without MAVLink.
    pub telemetry: TelemetryConfig,
    pub mavlink: MavlinkConfig,
    pub gate: GateConfig,
    pub manoeuvre: ManoeuvreConfig,
    pub command: CommandConfig,
    pub daemon: DaemonConfig,
    pub source: SourceConfig,
    pub record: RecordConfig,
    pub ground: GroundConfig,
    /// faithd's state in the pilot's goggles (iNav's global variables).
    pub osd: OsdConfig,
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
        key: String,
        reason: String,
    },
}

pub use faithd_core::invalid::Invalid;

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

    /// Parses faithd.toml into types that hold only usable values (RC channels,
    /// pulse widths, endpoints, the command sink and the event source with their own
    /// fields), then runs the checks that relate one value to another. Either way a
    /// refusal names the dotted key.
    pub fn parse(text: &str) -> Result<Self, ParseError> {
        let document =
            toml::Deserializer::parse(text).map_err(|e| ParseError::Toml(e.to_string()))?;
        let config: FaithdConfig = serde_path_to_error::deserialize(document).map_err(|e| {
            let key = e.path().to_string();
            let error = e.into_inner();
            match key.as_str() {
                // Not under any key (a missing table, say): toml's own message.
                "." | "" => ParseError::Toml(error.to_string()),
                _ => {
                    let mut reason = error.message().to_owned();
                    if let Some(hint) = moved_key(&key, &reason) {
                        reason.push_str("; ");
                        reason.push_str(hint);
                    }
                    ParseError::Invalid(Invalid { key, reason })
                }
            }
        })?;
        config.validate().map_err(ParseError::Invalid)?;
        Ok(config)
    }

    /// The checks that relate values to each other (orderings, budgets, one port
    /// against another) and the ranges each section checks beside its definition.
    pub fn validate(&self) -> Result<(), Invalid> {
        self.pipeline.validate()?;
        self.mavlink.validate()?;
        self.command.validate()?;
        validate_safety(self)?;
        self.daemon.validate()?;
        self.source.validate()?;
        validate_camera_size(self)?;
        self.record.validate()?;
        self.ground.validate()?;
        self.osd.validate()?;
        if let TelemetryConfig::Msp(t) = &self.telemetry {
            t.validate()?;
        }
        let telemetry_key = self.telemetry_key();
        check(
            self.command.msp_port().address != self.autopilot_port().address,
            "command.sink.endpoint",
            || {
                format!(
                    "must be a different port from {telemetry_key}: iNav serves one MSP command per port every 10 ms and the roll stream uses half of that"
                )
            },
        )?;
        check(
            !(self.telemetry.is_msp() && self.ground.forward_to_autopilot),
            "ground.forward_to_autopilot",
            || {
                "needs MAVLink to the autopilot: with [telemetry] kind = \"msp\" there is none"
                    .into()
            },
        )?;
        let ground = self.ground.endpoint.as_ref();
        check(
            ground.is_none_or(|g| {
                *g != self.autopilot_port().address && *g != self.command.msp_port().address
            }),
            "ground.endpoint",
            || format!("must be a port of its own, not {telemetry_key} or command.sink.endpoint"),
        )
    }

    /// The port the autopilot's telemetry comes in on.
    pub fn autopilot_port(&self) -> Endpoint {
        match &self.telemetry {
            TelemetryConfig::Mavlink => self.mavlink.port(),
            TelemetryConfig::Msp(t) => t.port(),
        }
    }

    /// The key naming that port.
    fn telemetry_key(&self) -> &'static str {
        match self.telemetry {
            TelemetryConfig::Mavlink => "mavlink.endpoint",
            TelemetryConfig::Msp(_) => "telemetry.endpoint",
        }
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

/// Keys that faithd read flat before the typed config, and where they went: a config
/// written for it is refused with the new place of the key, not just "unknown field".
const MOVED_KEYS: [(&str, &str, &str); 5] = [
    (
        "command",
        "msp_endpoint",
        "it is now `endpoint` under [command.sink] (kind = \"msp\")",
    ),
    (
        "command",
        "msp_baud",
        "it is now `baud` under [command.sink] (kind = \"msp\")",
    ),
    (
        "source",
        "sim_first_approach_us",
        "it is now `first_approach_us` (with kind = \"sim\")",
    ),
    (
        "source",
        "sim_repeat_us",
        "it is now `repeat_us` (with kind = \"sim\")",
    ),
    (
        "source",
        "sim_seed",
        "it is now `seed` (with kind = \"sim\")",
    ),
];

/// Where a key the parse refused has moved, or why it was removed, if it is one
/// that did.
fn moved_key(key: &str, reason: &str) -> Option<&'static str> {
    if key == "command.sink" && reason.starts_with("invalid type: string") {
        return Some("the sink is now a table: [command.sink] with kind = \"msp\"");
    }
    let removed = faithd_core::safety::manoeuvre::REMOVED_KEYS
        .iter()
        .find(|(old, _)| {
            key.starts_with("manoeuvre") && reason.contains(&format!("unknown field `{old}`"))
        });
    if let Some((_, why)) = removed {
        return Some(why);
    }
    MOVED_KEYS.iter().find_map(|&(section, old, hint)| {
        let named = key.starts_with(section) && reason.contains(&format!("unknown field `{old}`"));
        named.then_some(hint)
    })
}

/// What one section cannot check alone: what the route to the autopilot asks of the
/// switch and the roll, the gate's staleness against the daemon's period, and the
/// roll channel against the switch.
/// `pipeline.camera` must be a size the configured camera comes in: the camera
/// thread would refuse it at the first open, in flight, otherwise.
fn validate_camera_size(c: &FaithdConfig) -> Result<(), Invalid> {
    let SourceConfig::Caer(caer) = &c.source else {
        return Ok(());
    };
    let cam = &c.pipeline.camera;
    let sizes = caer.device.sizes();
    check(
        sizes
            .iter()
            .any(|s| (s.width_px, s.height_px) == (cam.width_px, cam.height_px)),
        "pipeline.camera.width_px",
        || {
            let sizes: Vec<String> = sizes.iter().map(|s| s.to_string()).collect();
            format!(
                "is {}x{} px, but a {} (source.device = \"{}\") is {}: set pipeline.camera (and its intrinsics) for it",
                cam.width_px,
                cam.height_px,
                caer.device.name(),
                caer.device.key(),
                sizes.join(" or ")
            )
        },
    )
}

fn validate_safety(c: &FaithdConfig) -> Result<(), Invalid> {
    c.gate.validate()?;
    c.manoeuvre.validate()?;
    c.command.validate_route(&c.gate, &c.manoeuvre)?;
    let g = &c.gate;
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
    check(
        c.manoeuvre.roll_channel != g.switch_channel,
        "manoeuvre.roll_channel",
        || "must not be the pilot's switch channel".into(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_camera_is_taken_at_the_sizes_it_comes_in() {
        let at = |device: &str, w: u16, h: u16| {
            FaithdConfig::parse(&format!(
                "[pipeline.camera]\nwidth_px = {w}\nheight_px = {h}\ncx_px = {}\ncy_px = {}\n[source]\nkind = \"caer\"\ndevice = \"{device}\"\n",
                f64::from(w) / 2.0,
                f64::from(h) / 2.0
            ))
        };
        assert!(at("davis240", 240, 180).is_ok());
        assert!(at("davis346", 346, 260).is_ok());
        assert!(at("dvxplorer", 640, 480).is_ok());
        assert!(at("dvxplorer", 320, 240).is_ok());
        let err = at("davis346", 640, 480).unwrap_err().to_string();
        assert!(
            err.contains("a DAVIS346 (source.device = \"davis346\") is 346x260 px"),
            "{err}"
        );
        let err = at("davis640", 640, 480).unwrap_err().to_string();
        assert!(err.contains("unknown variant `davis640`"), "{err}");
    }

    #[test]
    fn empty_file_is_all_defaults() {
        assert_eq!(FaithdConfig::parse("").unwrap(), FaithdConfig::default());
    }

    #[test]
    fn shipped_config_parses_and_equals_the_defaults() {
        let text = include_str!("../../../config/faithd.toml");
        assert_eq!(FaithdConfig::parse(text).unwrap(), FaithdConfig::default());
    }

    #[test]
    fn the_msp_only_link_takes_a_port_of_its_own() {
        let config =
            FaithdConfig::parse("[telemetry]\nkind = \"msp\"\nendpoint = \"serial:/dev/ttyS5\"\n")
                .unwrap();
        assert!(config.telemetry.is_msp());
        assert_eq!(
            config.autopilot_port().to_string(),
            "serial /dev/ttyS5 at 115200 baud"
        );
        let same = FaithdConfig::parse(
            "[telemetry]\nkind = \"msp\"\nendpoint = \"serial:/dev/ttyAMA1\"\n",
        )
        .unwrap_err();
        assert!(
            same.to_string().contains("command.sink.endpoint")
                && same.to_string().contains("telemetry.endpoint"),
            "{same}"
        );
        let typo =
            FaithdConfig::parse("[telemetry]\nkind = \"msp\"\nendpiont = \"x\"\n").unwrap_err();
        assert!(typo.to_string().contains("endpiont"), "{typo}");
        let forward = FaithdConfig::parse(
            "[telemetry]\nkind = \"msp\"\n[ground]\nendpoint = \"udp:0.0.0.0:14550\"\nforward_to_autopilot = true\n",
        )
        .unwrap_err();
        assert!(
            forward.to_string().contains("ground.forward_to_autopilot"),
            "{forward}"
        );
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
            ("[command.sink]\nkind = \"mavlink\"\n", "command.sink"),
            ("[gate]\nswitch_channel = 19\n", "gate.switch_channel"),
            ("[gate]\nauto_max_us = 3000\n", "gate.auto_max_us"),
            ("[manoeuvre]\nneutral_us = 1500\n", "manoeuvre.neutral_us"),
            ("[manoeuvre]\nreversed = true\n", "manoeuvre.reversed"),
            (
                "[manoeuvre]\nresend_period_us = 20000\n",
                "manoeuvre.resend_period_us",
            ),
            (
                "[command]\nroll_rxrange_us = [1500, 1503]\n",
                "command.roll_rxrange_us",
            ),
            (
                "[command]\nroll_rxrange_us = [2000, 1000]\n",
                "command.roll_rxrange_us",
            ),
            (
                "[command]\nmax_hold_after_stop_us = 30000000\n",
                "command.max_hold_after_stop_us",
            ),
            (
                "[command.sink]\nkind = \"msp\"\nbaud = 9\n",
                "command.sink.baud",
            ),
            (
                "[source]\nkind = \"sim\"\nrepeat_us = 10\n",
                "source.repeat_us",
            ),
            ("[source]\nkind = \"camera\"\n", "source.kind"),
            (
                "[source]\nkind = \"caer\"\ndevice = \"dvxplorer\"\n",
                "pipeline.camera.width_px",
            ),
            (
                "[source]\nkind = \"caer\"\nreopen_min_us = 10\n",
                "source.reopen_min_us",
            ),
            (
                "[source]\nkind = \"caer\"\nreopen_max_us = 1000\n",
                "source.reopen_max_us",
            ),
            (
                "[source]\nkind = \"caer\"\ncaer_settings = [[23, 20, 2]]\n",
                "source.caer_settings[0]",
            ),
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
                "[command.sink]\nkind = \"msp\"\nendpoint = \"serial:/dev/ttyAMA0\"\n",
                "command.sink.endpoint",
            ),
            ("[ground]\nenabled = true\n", "ground.endpoint"),
            ("[ground]\nendpoint = \"nowhere\"\n", "ground.endpoint"),
            (
                "[ground]\nendpoint = \"serial:/dev/ttyAMA0\"\n",
                "ground.endpoint",
            ),
            (
                "[ground]\nendpoint = \"serial:/dev/ttyAMA1\"\n",
                "ground.endpoint",
            ),
            ("[ground]\nbaud = 0\n", "ground.baud"),
            (
                "[ground]\ntelemetry_period_us = 1000\n",
                "ground.telemetry_period_us",
            ),
            (
                "[ground]\nheartbeat_period_us = 0\n",
                "ground.heartbeat_period_us",
            ),
            (
                "[ground]\nforward_rc_override = true\n",
                "ground.forward_rc_override",
            ),
        ] {
            match FaithdConfig::parse(text) {
                Err(ParseError::Invalid(inv)) => assert_eq!(inv.key, key, "{text}"),
                other => panic!("{text}: expected invalid {key}, got {other:?}"),
            }
        }
    }

    #[test]
    fn each_kind_takes_only_its_own_keys() {
        let err = FaithdConfig::parse("[source]\nkind = \"sim\"\nlibcaer_path = \"/x\"\n")
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("`source`"), "{err}");
        assert!(err.contains("unknown field `libcaer_path`"), "{err}");
        let sim = FaithdConfig::parse("[source]\nkind = \"sim\"\nseed = 7\n").unwrap();
        assert!(matches!(
            sim.source,
            crate::source::SourceConfig::Sim(crate::source::SimSource { seed: 7, .. })
        ));
        let err = FaithdConfig::parse("[command.sink]\nkind = \"mavlink\"\n")
            .unwrap_err()
            .to_string();
        assert!(err.contains("RC_CHANNELS_OVERRIDE"), "{err}");
    }

    #[test]
    fn an_old_flat_layout_names_the_key_that_moved() {
        let err =
            FaithdConfig::parse("[command]\nmsp_endpoint = \"serial:/dev/ttyS1\"\n").unwrap_err();
        match err {
            ParseError::Invalid(inv) => {
                assert_eq!(inv.key, "command.msp_endpoint");
                assert!(inv.reason.contains("unknown field"), "{}", inv.reason);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn keys_inav_cannot_mean_are_refused_with_the_reason() {
        for (text, why) in [
            ("[manoeuvre]\nneutral_us = 1520\n", "always 1500"),
            ("[manoeuvre]\nreversed = false\n", "no RC reversal"),
        ] {
            let err = FaithdConfig::parse(text).unwrap_err().to_string();
            assert!(err.contains(why), "{text}: {err}");
        }
    }

    #[test]
    fn a_key_of_the_flat_layout_says_where_it_went() {
        for (text, moved_to) in [
            (
                "[command]\nmsp_endpoint = \"serial:/dev/ttyS1\"\n",
                "[command.sink]",
            ),
            ("[command]\nsink = \"msp\"\n", "[command.sink]"),
            ("[source]\nkind = \"sim\"\nsim_seed = 3\n", "`seed`"),
        ] {
            let err = FaithdConfig::parse(text).unwrap_err().to_string();
            assert!(err.contains(moved_to), "{text}: {err}");
        }
        let refused = FaithdConfig::parse("[command.sink]\nkind = \"mavlink\"\n")
            .unwrap_err()
            .to_string();
        assert!(!refused.contains("now a table"), "{refused}");
    }

    #[test]
    fn a_ground_link_parses_when_asked_for() {
        let config = FaithdConfig::parse(
            "[ground]\nenabled = true\nendpoint = \"udpout:192.168.4.2:14550\"\nforward_to_autopilot = true\n",
        )
        .unwrap();
        let port = config.ground.port().expect("a ground port");
        assert_eq!(port.address.to_string(), "udpout:192.168.4.2:14550");
        assert!(config.ground.forward_to_autopilot && !config.ground.forward_rc_override);
        // Written but off: no port.
        let off =
            FaithdConfig::parse("[ground]\nendpoint = \"udpout:192.168.4.2:14550\"\n").unwrap();
        assert!(off.ground.port().is_none());
    }

    #[test]
    fn load_reports_the_path() {
        let err = FaithdConfig::load(Path::new("/nonexistent/faithd.toml")).unwrap_err();
        assert!(err.to_string().contains("/nonexistent/faithd.toml"));
    }
}
