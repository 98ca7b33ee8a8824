//! Normal optic flow from events.

mod vector;

pub use vector::FlowVector;
