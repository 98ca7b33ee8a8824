//! The simulation commands (feature `sim`): `demo`, `sim` and `bench`, on the
//! built-in simulator. The flight build has none of them. Each parses its arguments,
//! calls the lab (`faithd::orchestrate`) and prints what it returns.

mod bench; // `bench foe`, `bench pipeline`, `bench compute`
mod demo; // `demo`, closed loop or open loop
mod sim; // `sim`: the experiment on the model, straight, or with iNav's SITL
mod world; // the simulated world and board, as arguments

pub use bench::{
    BenchComputeArgs, BenchFoeArgs, BenchPipelineArgs, bench_compute, bench_foe, bench_pipeline,
};
pub use demo::{DemoArgs, demo};
pub use sim::{SimArgs, sim};
