//! faithd's simulator and experiments: everything the workstation needs and the
//! flight binary does not link (the `sim` feature of the `faithd` package).

pub mod world; // a DVS240 on a quadrotor flying through textured 3D scenes
pub mod demo; // the open-loop demo on looming edges
pub mod bench; // the FOE benchmark over simulated flights, and its plots
