//! Time to contact per flow vector, from the FOE.
//!
//! For translational flow `u = (p - foe) * W/Z`, so `tau = Z/W = |p - foe| / |u|`
//! (paper appendix). A normal flow vector only carries the part of `u` along its
//! direction `n`, whose size is `((p - foe) . n) * W/Z`; the matching distance is the
//! projection `(p - foe) . n`, which is what faithd divides by. Using `|p - foe|` with
//! normal flow (as the appendix does for full flow) overestimates TTC on every edge
//! that is not radial.

use serde::{Deserialize, Serialize};

use crate::invalid::{Invalid, positive};

use crate::flow::FlowVector;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TtcConfig {
    /// TTCs above this are clipped to it, seconds: far background would otherwise
    /// dominate the mean and variance used to normalise TTC for clustering.
    pub max_ttc_s: f64,
}

impl Default for TtcConfig {
    fn default() -> Self {
        Self { max_ttc_s: 10.0 }
    }
}

impl TtcConfig {
    /// `[pipeline.ttc]`.
    pub fn validate(&self) -> Result<(), Invalid> {
        positive(self.max_ttc_s, "pipeline.ttc.max_ttc_s")?;
        Ok(())
    }
}

/// TTC of one vector in seconds, or `None` when the vector points towards the FOE
/// (it then contradicts the FOE and is an outlier for this window).
pub fn ttc_s(f: &FlowVector, foe_px: (f64, f64), config: &TtcConfig) -> Option<f64> {
    let (nx, ny) = f.direction()?;
    let along_px = (f.x_px - foe_px.0) * nx + (f.y_px - foe_px.1) * ny;
    if along_px.is_nan() || along_px <= 0.0 {
        return None;
    }
    Some((along_px / f.speed_px_s()).min(config.max_ttc_s))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radial_flow_gives_distance_over_speed() {
        let cfg = TtcConfig::default();
        let f = FlowVector::new(0, 110.0, 50.0, 20.0, 0.0);
        assert!((ttc_s(&f, (100.0, 50.0), &cfg).unwrap() - 0.5).abs() < 1e-12);
    }

    #[test]
    fn normal_flow_uses_the_projected_distance() {
        // True flow (p - foe) / 2 s = (5, 5) px/s at (110, 60); the edge normal is x.
        let f = FlowVector::new(0, 110.0, 60.0, 5.0, 0.0);
        assert!((ttc_s(&f, (100.0, 50.0), &TtcConfig::default()).unwrap() - 2.0).abs() < 1e-12);
    }

    #[test]
    fn towards_the_foe_is_none_and_far_is_clipped() {
        let cfg = TtcConfig { max_ttc_s: 3.0 };
        assert!(
            ttc_s(
                &FlowVector::new(0, 90.0, 50.0, 10.0, 0.0),
                (100.0, 50.0),
                &cfg
            )
            .is_none()
        );
        assert_eq!(
            ttc_s(
                &FlowVector::new(0, 200.0, 50.0, 1.0, 0.0),
                (100.0, 50.0),
                &cfg
            ),
            Some(3.0)
        );
    }
}
