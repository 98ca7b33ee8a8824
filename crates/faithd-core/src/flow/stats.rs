//! What the normal flow stage did with a window's events, in a module of its own: the
//! estimator, its tiles and the per-tile engine all count into it.

use serde::Serialize;

/// Counters of what happened to the events of a window, for logs and health checks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct FlowStats {
    pub events: u64,
    pub out_of_view: u64,
    pub refractory: u64,
    pub too_few_points: u64,
    pub bad_fit: u64,
    /// Vectors (among `vectors`) whose neighbourhood has no tight plane (see
    /// `tight_residual_us`): kept for TTC, left out of the FOE.
    pub not_tight: u64,
    pub speed_rejected: u64,
    pub vectors: u64,
    /// Events that only updated the surface (in view, not refractory): the window
    /// had more events than fits.
    pub not_fitted: u64,
    /// Events of the window left out before the flow (not counted in `events`): it
    /// had more than `max_events_per_window`.
    pub skipped: u64,
}
