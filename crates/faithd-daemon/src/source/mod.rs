//! Where the daemon's events come from (`[source]`): the DVS240 through iniVation's
//! libcaer with the estimate of its clock against the daemon's, or the simulated
//! camera of the bench. Recorded files are read by `faithd_formats::events`.
//!
//! The daemon knows no camera: it calls [`start`] with `[source]` and runs what it
//! gets on a thread of its own with a [`SourceIo`]. A new camera family is one module
//! here (its library loading, size check, retry timing and messages), one arm of
//! [`SourceConfig`] and one arm of [`start`].

pub mod caer;
pub mod device_clock;
pub mod sim;

use std::sync::mpsc::SyncSender;

use serde::{Deserialize, Serialize};

use crate::clock::DaemonClock;
use crate::shutdown::Stop;
use faithd_core::camera::CameraIntrinsics;
use faithd_core::event::Event;
use faithd_core::invalid::{Invalid, check};
pub use sim::SimSource;

/// What a camera thread is handed: the daemon's clock, the pipeline's end of the
/// channel, and the run's stop, which it hears wherever it waits.
pub struct SourceIo {
    pub clock: DaemonClock,
    pub batches: SyncSender<Vec<Event>>,
    pub stop: Stop,
}

/// A started event source: runs on the calling thread until the run stops or the
/// pipeline hangs up (`Ok`), or until the camera contradicts the configuration.
pub type SourceFn = Box<dyn FnOnce(SourceIo) -> Result<(), Refusal> + Send>;

/// A source that cannot be used as configured: the key to change and why (the
/// daemon stops with status 2, and systemd does not restart it).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("`{key}`: {reason}")]
pub struct Refusal {
    pub key: &'static str,
    pub reason: String,
}

/// Why `faithd run` refuses a simulated camera without the command-line opt-in.
pub const SIM_SOURCE_REFUSED: &str = "is \"sim\": a simulated camera makes faithd roll the vehicle at imaginary poles about every 5 s; `faithd run` takes it only with --simulated-camera on its command line (bench and tests, never the service); set source.kind = \"caer\" for the DVS240";

/// Makes the configured source ready to run: loads its library and says which,
/// or refuses it with the key to change. `simulated_allowed` is `faithd run
/// --simulated-camera`: without it a simulated camera is refused, since a real
/// vehicle would roll at imaginary poles.
pub fn start(
    config: &SourceConfig,
    camera: CameraIntrinsics,
    simulated_allowed: bool,
) -> Result<SourceFn, Refusal> {
    match config.clone() {
        SourceConfig::Sim(_) if !simulated_allowed => Err(Refusal {
            key: "source.kind",
            reason: SIM_SOURCE_REFUSED.into(),
        }),
        SourceConfig::Sim(sim) => {
            tracing::warn!(
                "SIMULATED CAMERA (--simulated-camera): every roll faithd commands comes from generated events, not from the world; never fly like this"
            );
            Ok(Box::new(move |io| {
                sim::run_sim(sim, camera, io);
                Ok(())
            }))
        }
        SourceConfig::Caer(caer) => caer::prepare(caer, camera),
    }
}

/// Where events come from: `[source]`, a `kind` and that kind's own settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SourceConfig {
    /// The DVS240/DAVIS240 on USB through libcaer (opened at run time).
    Caer(CaerSource),
    /// Generated approaches to a pole, played in real time: the bench and tests only,
    /// and `faithd run` takes it only with `--simulated-camera`.
    Sim(SimSource),
}

impl Default for SourceConfig {
    fn default() -> Self {
        SourceConfig::Caer(CaerSource::default())
    }
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CaerSource {
    /// Where libcaer is; empty = the system loader's search for libcaer.so.3.
    pub libcaer_path: String,
    /// libcaer settings applied once the camera streams (after libcaer's defaults and
    /// `caerDeviceDataStart`), as [module, parameter, value] (biases and filters; see
    /// libcaer's devices/davis.h for the addresses). One that libcaer refuses stops
    /// the daemon with a configuration error naming it.
    pub caer_settings: Vec<(i8, u8, u32)>,
}

/// Settings faithd makes itself, which an entry of `caer_settings` must not undo:
/// non-blocking data exchange (the camera thread waits on the run's stop between
/// reads, never inside libcaer, so that it hears a stop) and the APS and IMU off
/// (faithd discards frames and IMU samples).
const OWNED_BY_FAITHD: [((i8, u8), &str); 5] = [
    (
        (-2, 1),
        "is CAER_HOST_CONFIG_DATAEXCHANGE_BLOCKING, which faithd sets itself (off, so that the camera thread hears a stop)",
    ),
    (
        (2, 4),
        "is DAVIS_CONFIG_APS_RUN: faithd turns the APS off, as it discards frames",
    ),
    (
        (3, 2),
        "is DAVIS_CONFIG_IMU_RUN_ACCELEROMETER: faithd turns the IMU off, as it discards IMU samples",
    ),
    (
        (3, 3),
        "is DAVIS_CONFIG_IMU_RUN_GYROSCOPE: faithd turns the IMU off, as it discards IMU samples",
    ),
    (
        (3, 4),
        "is DAVIS_CONFIG_IMU_RUN_TEMPERATURE: faithd turns the IMU off, as it discards IMU samples",
    ),
];

impl CaerSource {
    /// Refuses an entry that would undo what faithd sets itself; what the camera
    /// takes is for libcaer to say when it opens it.
    pub fn validate(&self) -> Result<(), Invalid> {
        for (index, &(module, param, value)) in self.caer_settings.iter().enumerate() {
            if let Some((_, why)) = OWNED_BY_FAITHD
                .iter()
                .find(|(address, _)| *address == (module, param))
            {
                return Err(Invalid {
                    key: format!("source.caer_settings[{index}]"),
                    reason: format!("[{module}, {param}, {value}] {why}; remove the entry"),
                });
            }
        }
        Ok(())
    }
}

impl SourceConfig {
    /// `[source]`: a simulated camera repeats its approach at most once a second.
    pub fn validate(&self) -> Result<(), Invalid> {
        match self {
            SourceConfig::Caer(caer) => caer.validate(),
            SourceConfig::Sim(sim) => check(sim.repeat_us >= 1_000_000, "source.repeat_us", || {
                format!("must be at least 1 s, got {}", sim.repeat_us)
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_setting_that_undoes_what_faithd_sets_itself_is_refused_by_its_index() {
        let caer = |caer_settings| {
            SourceConfig::Caer(CaerSource {
                libcaer_path: String::new(),
                caer_settings,
            })
        };
        assert_eq!(caer(vec![(5, 1, 24575), (5, 2, 16399)]).validate(), Ok(()));
        let err = caer(vec![(5, 1, 24575), (2, 4, 1)]).validate().unwrap_err();
        assert_eq!(err.key, "source.caer_settings[1]");
        assert!(err.reason.contains("DAVIS_CONFIG_APS_RUN"), "{err}");
        let err = caer(vec![(-2, 1, 0)]).validate().unwrap_err();
        assert_eq!(err.key, "source.caer_settings[0]");
    }

    /// The example faithd.toml gives is what it says: libcaer's own DAVIS240 defaults
    /// for OnBn and OffBn, coarse/fine encoded, accepted by the checks.
    #[test]
    fn the_shipped_bias_example_is_libcaers_davis240_defaults_encoded() {
        use libcaer_sys::CoarseFineBias;
        let shipped = include_str!("../../../../config/faithd.toml");
        let example = shipped
            .lines()
            .find_map(|l| l.strip_prefix("#   caer_settings = "))
            .expect("the example in config/faithd.toml");
        #[derive(Deserialize)]
        struct Example {
            caer_settings: Vec<(i8, u8, u32)>,
        }
        let parsed: Example = toml::from_str(&format!("caer_settings = {example}")).unwrap();
        assert_eq!(
            parsed.caer_settings,
            [
                (5, 1, CoarseFineBias::n_type(5, 255).encode()),
                (5, 2, CoarseFineBias::n_type(4, 0).encode()),
            ]
        );
        let caer = CaerSource {
            libcaer_path: String::new(),
            caer_settings: parsed.caer_settings,
        };
        assert_eq!(caer.validate(), Ok(()));
    }
}
