//! Time to contact per flow vector, from the FOE.
//!
//! For translational flow `u = (p - foe) * W/Z`, so `tau = Z/W = |p - foe| / |u|`
//! (paper appendix). A normal flow vector only carries the part of `u` along its
//! direction `n`, whose size is `((p - foe) . n) * W/Z`; the matching distance is the
//! projection `(p - foe) . n`, which is what faithd divides by. Using `|p - foe|` with
//! normal flow (as the appendix does for full flow) overestimates TTC on every edge
//! that is not radial.
//!
//! That ratio is the TTC of the vector's own moment, and of the moment its speed was
//! measured, neither of which is the decision's. Two corrections bring it to the end of
//! the window (`ttc_at_s`); without them the obstacle's TTC on the generated pole
//! approach was 7 % too long at the median, and the rule rolled that much later:
//! - A plane fit's speed is the edge's speed at the mean time of its points,
//!   `FlowVector::fit_age_us` (`a`) before the event, while `(p - foe) . n` is the
//!   distance at the event. A looming surface's edges move at `d / T`, with `d` growing
//!   as `1 / T`, so the ratio is `q = d(t) / s(t - a) = (T + a)^2 / T`, about `T + 2a`:
//!   near the FOE, where fits span 30 to 60 ms, 60 to 120 ms too long. `T` is the root
//!   of `T^2 - (q - 2a) T + a^2 = 0`.
//! - The history holds vectors up to `history_us` old, and each is that much closer to
//!   contact by the end of the window.

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

/// TTC at `now_us` from one vector, in seconds (see the module's notes), or `None`
/// when the vector points towards the FOE (it then contradicts the FOE and is an
/// outlier for this window). At least 0: a vector whose extrapolation has passed
/// contact says the surface is there now.
pub fn ttc_at_s(
    f: &FlowVector,
    foe_px: (f64, f64),
    now_us: i64,
    config: &TtcConfig,
) -> Option<f64> {
    let (nx, ny) = f.direction()?;
    let along_px = (f.x_px - foe_px.0) * nx + (f.y_px - foe_px.1) * ny;
    if along_px.is_nan() || along_px <= 0.0 {
        return None;
    }
    let ratio_s = along_px / f.speed_px_s();
    if ratio_s >= config.max_ttc_s {
        return Some(config.max_ttc_s);
    }
    let age_s = (now_us - f.t_us) as f64 * 1e-6;
    Some((at_event_s(ratio_s, f64::from(f.fit_age_us) * 1e-6) - age_s).clamp(0.0, config.max_ttc_s))
}

/// The TTC at the event from the ratio `q` of its distance to a speed measured
/// `fit_age_s` earlier: the larger root of `T^2 - (q - 2a) T + a^2 = 0`. A ratio under
/// `4a` has no root (the fit is too old for the model); it then gives `q / 4`, where
/// the root meets it.
fn at_event_s(ratio_s: f64, fit_age_s: f64) -> f64 {
    let (q, a) = (ratio_s, fit_age_s.max(0.0));
    if q <= 4.0 * a {
        return q / 4.0;
    }
    0.5 * ((q - 2.0 * a) + (q * q - 4.0 * a * q).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radial_flow_gives_distance_over_speed() {
        let cfg = TtcConfig::default();
        let f = FlowVector::new(0, 110.0, 50.0, 20.0, 0.0);
        assert!((ttc_at_s(&f, (100.0, 50.0), 0, &cfg).unwrap() - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_fits_lag_and_the_vectors_age_are_taken_off() {
        // A surface 1 s from contact at t = 0.1 s, seen by an edge 20 px from the FOE
        // there: its speed 40 ms earlier (T = 1.04 s, distance 20 / 1.04 * 1.0 px) was
        // 20 / 1.04^2 px/s.
        let speed_px_s = 20.0 / (1.04 * 1.04);
        let f = FlowVector {
            fit_age_us: 40_000.0,
            ..FlowVector::new(100_000, 120.0, 50.0, speed_px_s, 0.0)
        };
        let cfg = TtcConfig::default();
        let at_event = ttc_at_s(&f, (100.0, 50.0), 100_000, &cfg).unwrap();
        assert!((at_event - 1.0).abs() < 1e-9, "{at_event}");
        // The distance over the speed alone would say 1.0816 s.
        let later = ttc_at_s(&f, (100.0, 50.0), 130_000, &cfg).unwrap();
        assert!((later - 0.97).abs() < 1e-9, "{later}");
        // Far past its time, a vector says contact, not a negative time.
        assert_eq!(ttc_at_s(&f, (100.0, 50.0), 2_000_000, &cfg), Some(0.0));
    }

    #[test]
    fn normal_flow_uses_the_projected_distance() {
        // True flow (p - foe) / 2 s = (5, 5) px/s at (110, 60); the edge normal is x.
        let f = FlowVector::new(0, 110.0, 60.0, 5.0, 0.0);
        let ttc = ttc_at_s(&f, (100.0, 50.0), 0, &TtcConfig::default()).unwrap();
        assert!((ttc - 2.0).abs() < 1e-12);
    }

    #[test]
    fn towards_the_foe_is_none_and_far_is_clipped() {
        let cfg = TtcConfig { max_ttc_s: 3.0 };
        assert!(
            ttc_at_s(
                &FlowVector::new(0, 90.0, 50.0, 10.0, 0.0),
                (100.0, 50.0),
                0,
                &cfg
            )
            .is_none()
        );
        assert_eq!(
            ttc_at_s(
                &FlowVector::new(0, 200.0, 50.0, 1.0, 0.0),
                (100.0, 50.0),
                0,
                &cfg
            ),
            Some(3.0)
        );
    }
}
