//! faithd's integration tests, one test binary (as cargo's own `tests/testsuite`):
//! the real `faithd` binary and `daemon::serve` against a mock iNav on
//! pseudo-terminals, iNav's own firmware (SITL, when `INAV_SITL` names one), the C
//! mock of libcaer and the real one (`LIBCAER_PATH`; on a pretend USB camera, the
//! stand-in, in `caer_usb`), pymavlink and dv-processing as peers, the unit, the package's manual pages, and with the `sim` feature the lab
//! (closed loop, `faithd sim`, videos). Support by concern in [`common`]. The other
//! crates test themselves: `cargo test -p faithd-core` (and formats, sim, daemon, inav,
//! lab).

mod common;

mod architectures;
mod caer_mock;
mod caer_usb;
#[cfg(feature = "sim")]
mod closed_loop;
mod daemon;
mod faults;
mod ground_station;
#[cfg(feature = "sim")]
mod inav_flight;
mod inav_sitl;
mod libcaer_real;
mod manual;
mod msp_only_link;
mod pymavlink_peer;
mod real_events;
mod recording_faults;
mod replay;
mod replay_late;
mod replay_trust;
#[cfg(feature = "sim")]
mod sim_cli;
mod soak;
mod systemd;
#[cfg(feature = "sim")]
mod video;
mod workspace;
