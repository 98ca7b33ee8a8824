//! The live event camera: a DVS240 through iniVation's libcaer, and the estimate of
//! its clock against the daemon's. Recorded files are read by `faithd_formats::events`.

pub mod caer;
pub mod device_clock;
