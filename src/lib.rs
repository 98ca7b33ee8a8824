//! faithd as one crate for the command line and the integration tests: the flight
//! daemon (`faithd-daemon`) and, with the `sim` feature, the lab (`faithd-lab`), under
//! the paths they have always had. The flight build (`--no-default-features`) holds
//! the daemon alone.

pub use faithd_daemon::*;

#[cfg(feature = "sim")]
pub use faithd_lab::{closed_loop, inav_sitl, orchestrate, realflight, video};

/// The pipeline's driver (`faithd-daemon`), and with the lab its charged compute and
/// the `bench pipeline` runner.
pub mod cycle {
    pub use faithd_daemon::cycle::*;
    #[cfg(feature = "sim")]
    pub use faithd_lab::cycle::{bench, compute};
}
