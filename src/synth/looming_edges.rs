//! Events of straight edges expanding from an FOE (being written).
pub struct LoomingEdges;
pub fn looming_edge_events() {}
