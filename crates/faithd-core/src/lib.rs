//! faithd's core: events and attitude samples stamped in microseconds go in,
//! avoidance decisions and the roll manoeuvre come out.
//!
//! Nothing here reads a clock, touches a file or a socket, or draws an unseeded
//! random number, so any recorded flight replays to the same decisions bit for bit.
//! The crate's dependencies enforce it: no tokio, no MAVLink, no file formats.
//! Modules in the order an event travels (docs/design.md):
#![forbid(unsafe_code)]

pub mod event; // one DVS event: pixel, polarity, microseconds
pub mod camera; // intrinsics and the camera's mounting on the body
pub mod attitude; // body rates from the autopilot, and the recent log of them
pub mod window; // which events make up one pipeline window
pub mod flow; // normal optic flow from the events (local plane fits)
pub mod derotate; // the rotational part of the flow taken out
pub mod foe; // focus of expansion: FAITH and the baselines
pub mod ttc; // time to contact per flow vector
pub mod cluster; // DBSCAN over position and TTC: the obstacles
pub mod decide; // a roll left, right or nothing, and why
pub mod pipeline; // the stages above, in order, for one window
pub mod safety; // the pilot's gate and the timed roll manoeuvre
pub mod osd; // faithd's state as iNav global variables, for the pilot's goggles
pub mod invalid; // a setting that cannot be used: its key and why
pub mod math; // sin, hypot and the rest: the same bits on every architecture
pub mod synth; // analytic inputs with known answers, for tests and the sim source
