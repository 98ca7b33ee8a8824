//! iNav's own flight controller in the loop: a RealFlight-protocol physics server for
//! iNav SITL's `--sim=rf`. SITL sends its motor outputs and takes back the state of
//! `faithd_sim::world::quad_x`'s quadrotor, so iNav's mixer, PIDs, ANGLE mode, rate
//! limits and failsafe fly it ([`wire`]: the exchange as iNav's source writes and reads
//! it; [`server`]: the TCP server, in real time).

pub mod server;
pub mod wire;

pub use server::{Server, World};
