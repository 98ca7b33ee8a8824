//! The flow vector: what every stage after the camera works on.

use crate::math;

/// A normal optic flow vector: image motion across a local edge, in pixels per second.
///
/// Only the component normal to the edge is observable (the aperture problem), so
/// (`u_px_s`, `v_px_s`) points across the edge. Its origin is the event that produced it.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct FlowVector {
    pub t_us: i64,
    pub x_px: f64,
    pub y_px: f64,
    pub u_px_s: f64,
    pub v_px_s: f64,
    /// The event's neighbourhood also holds a plane without the stale pixels (see
    /// `FlowConfig::tight_residual_us`): its direction can be trusted for the FOE.
    pub tight: bool,
    /// Mean age of the points the plane was fitted to, relative to `t_us`, in
    /// microseconds (0 when unknown). The flow is the edge's motion averaged over
    /// those points' times, which are centred this long before the event: near the
    /// FOE, where edges are slow, tens of milliseconds. Derotation subtracts the
    /// rotation of that same span.
    pub fit_age_us: f32,
}

impl FlowVector {
    pub fn new(t_us: i64, x_px: f64, y_px: f64, u_px_s: f64, v_px_s: f64) -> Self {
        Self {
            t_us,
            x_px,
            y_px,
            u_px_s,
            v_px_s,
            tight: true,
            fit_age_us: 0.0,
        }
    }

    pub fn speed_px_s(&self) -> f64 {
        math::hypot(self.u_px_s, self.v_px_s)
    }

    /// Unit direction of the flow, or `None` for a zero vector.
    pub fn direction(&self) -> Option<(f64, f64)> {
        let s = self.speed_px_s();
        (s > 0.0 && s.is_finite()).then(|| (self.u_px_s / s, self.v_px_s / s))
    }
}
