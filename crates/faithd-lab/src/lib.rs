//! faithd's lab: the flight daemon (`faithd-daemon`) flying a simulated quadrotor
//! against faithd's model of iNav (`faithd-inav`) in simulated time, with the DVS
//! simulator (`faithd-sim`) as its camera; the pipeline's compute charged as the
//! target board would need it; flights as videos. Never in the flight build: the
//! binary links it only with the `sim` feature.

pub mod closed_loop; // the daemon flying a simulated quadrotor against a simulated iNav
pub mod cycle; // the pipeline in simulated time, its compute charged as on the board
pub mod inav_sitl; // iNav SITL flying the quad-X: faithd, a scripted pilot and the line camera in real time
pub mod orchestrate; // the lab's runs as the command line orders them: demo, sim and the benches
pub mod realflight; // iNav SITL's RealFlight interface: iNav's own controller flies a quad-X
pub mod video; // a flight as a video: every window's picture, decision, gate and roll
