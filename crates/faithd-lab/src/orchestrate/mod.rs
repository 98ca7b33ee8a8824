//! The lab's runs as the command line orders them (`faithd demo`, `faithd sim`,
//! `faithd bench`): each plans its flights or streams in the world asked for, flies
//! or runs them, draws their figures and renders its report as text or JSON. The
//! command line parses the arguments, calls one of these and prints what it returns;
//! progress comes back through callbacks, one line per flight, stream or trajectory.

pub mod bench_compute; // `bench compute`: the compute model fitted to this machine
pub mod bench_foe; // `bench foe`: Table I of the paper, and its figures
pub mod bench_pipeline; // `bench pipeline`: the pipeline's cost at given event rates
pub mod demo; // `demo`: one closed-loop flight at a pole
pub mod error; // what refused a run, or made it fail
pub mod flight_line; // one closed-loop flight in one line of the log
pub mod open_loop; // `demo --open-loop`: the pipeline alone on generated events
pub mod plan; // the experiment's flights in a world, and how many fly at once
pub mod sim; // `sim`: the closed-loop experiment
pub mod sitl; // `sim --autopilot inav-sitl`: the experiment with iNav's SITL flying
pub mod straight; // `sim --straight`: the experiment's flights flown straight
pub mod world; // the simulated world and board the flights fly in
