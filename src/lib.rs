//! faithd: event-camera obstacle avoidance for small drones.
//!
//! The modules below the adapters form the pure core: events and attitude samples
//! stamped in microseconds go in, decisions come out. Nothing in the core reads a
//! clock, touches a file or a socket, or draws an unseeded random number, so any
//! recorded flight replays to the same decisions bit for bit.
//!
//! Data flow (docs/design.md): [`flow`] (normal flow from events) -> [`derotate`] ->
//! [`foe`] (FAITH and the baselines) -> [`ttc`] -> [`cluster`] (DBSCAN) -> [`decide`];
//! [`pipeline`] runs them in order for one window.

pub mod attitude;
pub mod bench;
pub mod camera;
pub mod closed_loop;
pub mod cluster;
pub mod command;
pub mod config;
pub mod daemon;
pub mod decide;
pub mod demo;
pub mod derotate;
pub mod event;
pub mod flow;
pub mod foe;
pub mod link;
pub mod logging;
pub mod pipeline;
pub mod replay;
pub mod safety;
pub mod sim;
pub mod source;
pub mod synth;
pub mod ttc;
pub mod window;
pub mod window_log;
