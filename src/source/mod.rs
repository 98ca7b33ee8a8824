//! Where the daemon's events come from (`[source]`): the DVS240 through iniVation's
//! libcaer with the estimate of its clock against the daemon's, or the simulated
//! camera of the bench. Recorded files are read by `faithd_formats::events`.

pub mod caer;
pub mod device_clock;
pub mod sim;

use serde::{Deserialize, Serialize};

use faithd_core::invalid::{Invalid, check};
pub use sim::SimSource;

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
    /// libcaer settings applied after its defaults, as [module, parameter, value]
    /// (biases and filters; see libcaer's davis.h for the addresses).
    pub caer_settings: Vec<(i8, u8, u32)>,
}

impl SourceConfig {
    /// `[source]`: a simulated camera repeats its approach at most once a second.
    pub fn validate(&self) -> Result<(), Invalid> {
        match self {
            SourceConfig::Caer(_) => Ok(()),
            SourceConfig::Sim(sim) => check(sim.repeat_us >= 1_000_000, "source.repeat_us", || {
                format!("must be at least 1 s, got {}", sim.repeat_us)
            }),
        }
    }
}
