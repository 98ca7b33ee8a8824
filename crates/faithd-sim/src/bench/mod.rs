//! The `bench` commands: experiments on the built-in simulator that anyone can rerun.

pub mod foe;
pub mod plot;
