//! Analytic inputs with known answers: flow fields and event streams generated from
//! closed-form motion, for tests, benchmarks and examples.
//!
//! These are not the camera simulator (that renders textured scenes); they are the
//! smallest inputs whose correct FOE, flow and TTC are known exactly.

pub mod cluster_features;
pub mod flow_field;
pub mod looming_edges;

pub use cluster_features::pipeline_shaped_features;
pub use flow_field::{FlowFieldSpec, radial_normal_flow};
pub use looming_edges::{Layer, LoomingEdges, looming_edge_events, looming_edge_events_seen_by};
