//! Where the daemon's events come from (`[source]`): an iniVation camera (DAVIS240,
//! DAVIS346, DVXplorer) through iniVation's libcaer with the estimate of its clock against the daemon's, or the simulated
//! camera of the bench. Recorded files are read by `faithd_formats::events`.
//!
//! The daemon knows no camera: it calls [`start`] with `[source]` and runs what it
//! gets on a thread of its own with a [`SourceIo`]. A new camera family is one module
//! here (its library loading, size check, retry timing and messages), one arm of
//! [`SourceConfig`] and one arm of [`start`].

pub mod caer;
pub mod caer_device;
pub mod device_clock;
pub mod sim;

use std::sync::mpsc::SyncSender;

use serde::{Deserialize, Serialize};

use crate::clock::DaemonClock;
use crate::shutdown::Stop;
pub use caer_device::CaerDevice;
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
pub const SIM_SOURCE_REFUSED: &str = "is \"sim\": a simulated camera makes faithd roll the vehicle at imaginary poles about every 5 s; `faithd run` takes it only with --simulated-camera on its command line (bench and tests, never the service); set source.kind = \"caer\" for the camera";

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

/// What `faithd check-config` checks beyond the file: that a configured
/// `source.libcaer_path` is a libcaer 3 faithd can load (a missing file, a directory
/// and a file that is not a library are refused, as `faithd run` would refuse them).
/// With no path it looks for the system's libcaer and returns a note when there is
/// none: the file is fine, but `faithd run` will refuse to start until it is
/// installed.
pub fn check_library(config: &SourceConfig) -> Result<Option<String>, Refusal> {
    let SourceConfig::Caer(caer) = config else {
        return Ok(None);
    };
    match caer::load(caer) {
        Ok(_) => Ok(None),
        Err(refusal) if caer.libcaer_path.is_empty() => Ok(Some(format!(
            "note: `{}`: {}; `faithd run` refuses to start until it is installed",
            refusal.key, refusal.reason
        ))),
        Err(refusal) => Err(refusal),
    }
}

/// Where events come from: `[source]`, a `kind` and that kind's own settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SourceConfig {
    /// An iniVation camera on USB through libcaer (opened at run time).
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

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CaerSource {
    /// Which camera: "davis240" (the default), "davis346" or "dvxplorer".
    pub device: CaerDevice,
    /// Where libcaer is; empty = the system loader's search for libcaer.so.3.
    pub libcaer_path: String,
    /// libcaer settings applied once the camera streams (after libcaer's defaults and
    /// `caerDeviceDataStart`), as [module, parameter, value] (biases, filters, the
    /// DVXplorer's cropper and event-rate control; the addresses are in libcaer's
    /// devices/davis.h or devices/dvxplorer.h). An address the camera does not have
    /// is refused by the checks; a value libcaer refuses stops the daemon with a
    /// configuration error naming it.
    pub caer_settings: Vec<(i8, u8, u32)>,
    /// The wait before opening the camera again after a failed open, doubled after
    /// every failure up to `reopen_max_us`; back to the first after a session ran.
    pub reopen_min_us: i64,
    pub reopen_max_us: i64,
}

impl Default for CaerSource {
    fn default() -> Self {
        let retry = caer::RetryTiming::DEFAULT;
        Self {
            device: CaerDevice::default(),
            libcaer_path: String::new(),
            caer_settings: Vec::new(),
            reopen_min_us: retry.first.as_micros() as i64,
            reopen_max_us: retry.longest.as_micros() as i64,
        }
    }
}

impl CaerSource {
    /// Refuses an entry that would undo what faithd sets itself or that names an
    /// address the camera does not have, and a reopen timing that would spin (under
    /// 1 ms) or never try again (over a minute).
    pub fn validate(&self) -> Result<(), Invalid> {
        self.device.validate(&self.caer_settings)?;
        check(
            (1_000..=60_000_000).contains(&self.reopen_min_us),
            "source.reopen_min_us",
            || format!("must be 1 ms to 60 s, got {} us", self.reopen_min_us),
        )?;
        check(
            (self.reopen_min_us..=60_000_000).contains(&self.reopen_max_us),
            "source.reopen_max_us",
            || {
                format!(
                    "must be reopen_min_us ({} us) to 60 s, got {} us",
                    self.reopen_min_us, self.reopen_max_us
                )
            },
        )
    }

    /// The reopen timing, as the camera thread takes it.
    pub fn retry(&self) -> caer::RetryTiming {
        caer::RetryTiming {
            first: std::time::Duration::from_micros(self.reopen_min_us.max(0) as u64),
            longest: std::time::Duration::from_micros(self.reopen_max_us.max(0) as u64),
        }
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
                caer_settings,
                ..CaerSource::default()
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
            caer_settings: parsed.caer_settings,
            ..CaerSource::default()
        };
        assert_eq!(caer.validate(), Ok(()));
    }
}
