//! iNav's own flight controller in the closed loop: iNav 9.1's SITL (its path from
//! the user: the project carries no iNav code and no recipe that builds it) flying
//! faithd-lab's quad-X over its RealFlight interface, set up from the committed CLI
//! scripts, flown by a scripted pilot on IBUS, with the real daemon on its MAVLink
//! and MSP UARTs (`faithd sim --autopilot inav-sitl`).

pub mod clock; // the wall clock in Unix microseconds, the journal's time base
pub mod course; // where a flight goes: the course line and the height
pub mod experiment; // many flights, and the model's figures on the same flights
pub mod flight; // one flight: SITL, physics, pilot, faithd and the line camera
pub mod measured; // what iNav did in the experiment, and the bounds the model is held to
pub mod monitor; // what iNav uses, read back over MSP; arming
pub mod msp_client; // the harness's MSP client and the commands it asks
pub mod pilot; // the scripted pilot's hands
pub mod process; // the SITL process and its CLI
pub mod radio; // the pilot's IBUS receiver
pub mod stalls; // how iNav's loop stalled, and what a stall could have changed

pub use flight::{SitlOutcome, fly};
pub use process::{Sitl, SitlError};
