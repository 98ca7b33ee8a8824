//! The experiment's flights laid out in a world, and how many fly at once.

use super::world::World;
use crate::closed_loop::{FlightSpec, experiment};

/// The experiment's `runs` flights for `seed`, each with its camera and scene.
pub fn flights(runs: usize, seed: u64, world: &World) -> Vec<FlightSpec> {
    let mut specs = experiment::plan(runs, seed);
    for (i, spec) in specs.iter_mut().enumerate() {
        world.apply(i, spec);
    }
    specs
}

/// Flights flown at once: `asked`, or one per core.
pub fn threads(asked: Option<usize>) -> usize {
    asked.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}
