//! The pipeline in the lab: the daemon's own driver (`faithd_daemon::cycle::drive`)
//! paced by simulated time, each window's compute charged as the target board would
//! need it ([`compute`]), and `faithd bench pipeline` ([`bench`]).

pub mod bench;
pub mod compute;
mod simulated;

pub use simulated::{CycleReport, SimulatedPacing, SimulatedTaps, pipeline_task};
