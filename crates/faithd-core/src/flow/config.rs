//! The normal flow stage's tunables and the bounds its buffers are sized by, apart from
//! the estimator so that the estimator, its tiles and the per-tile engine all read them
//! without depending on one another.

use serde::{Deserialize, Serialize};

use crate::invalid::{Invalid, check, positive};

/// Largest neighbourhood radius: 11x11 pixels, what the point buffers hold.
pub const MAX_RADIUS_PX: u16 = 5;
pub(super) const MAX_POINTS: usize = ((2 * MAX_RADIUS_PX as usize) + 1).pow(2);

/// Tunables of the normal flow stage.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FlowConfig {
    /// Neighbourhood half-size: 2 gives the 5x5 patch of Benosman 2014. At most 5.
    pub radius_px: u16,
    /// Only neighbours that fired within this time before the event are fitted. Longer
    /// windows keep slow edges (near the FOE, where the flow is slowest) but make their
    /// flow lag behind a changing course; 150 ms gave the lowest FOE error on the
    /// simulator (docs/tuning.md).
    pub window_us: i64,
    /// A pixel firing again within this time of its previous same-polarity event is
    /// ignored: one edge makes bursts of events per pixel, and only the first is on
    /// the moving front; where edges follow each other closely, the next one's
    /// neighbourhood also holds the previous one's pixels, and the two make one plane
    /// that is neither. 200 ms, chosen by measurement against the known motion of the
    /// generated and ray-traced scenes (docs/tuning.md, "Switched to 200 ms").
    pub refractory_us: i64,
    /// Points needed for a fit, the event itself included.
    pub min_points: usize,
    /// Points whose residual exceeds this are dropped and the plane refitted once.
    /// Left at 20 ms: tighter (7.5 ms) helps FAITH as much as `tight_residual_us` does,
    /// but biases the looming pole's speeds in `tests/pipeline.rs` (median TTC error
    /// 0.39 against 0.21).
    pub outlier_residual_us: f64,
    /// A vector goes to the FOE only if its neighbourhood also holds a good plane
    /// (within the RMS and gradient limits) through the points within this of the
    /// first fit (`FlowVector::tight`); its flow is still the `outlier_residual_us`
    /// refit, and TTC uses every vector. 0 turns the check off.
    ///
    /// The 150 ms window holds pixels that earlier edges left behind. Where they are
    /// many, the first fit leans on them, and the flow direction of the event is
    /// doubtful even when the refit looks clean: these vectors cost FAITH more than
    /// their number adds. Leaving them out brings FAITH's error on `faithd bench foe` (100
    /// flights) from 6.26 to 4.95 degrees (seed 1) and 6.51 to 5.40 (seed 2); 6 ms and
    /// 9 ms do about as well, 4 ms and 5 ms worse. Using the tight refit's flow instead
    /// selects about the same vectors for 0.1 degree more; dropping the vectors from TTC
    /// too, or a tighter `outlier_residual_us`, biases the looming speeds TTC depends on
    /// (median TTC error in `tests/pipeline.rs` 0.34 instead of 0.21).
    pub tight_residual_us: f64,
    /// Fits with a larger RMS residual after that are rejected.
    pub max_rms_us: f64,
    /// Fits whose gradient is this uncertain (standard error over norm) are rejected:
    /// their speed and direction are guesses, and as outliers they cost the FOE more
    /// than their number adds.
    pub max_gradient_rel_error: f64,
    /// Flow slower than this is rejected (nearly flat fits are noise).
    pub min_speed_px_s: f64,
    /// Flow faster than this is rejected (steep fits from simultaneous events).
    pub max_speed_px_s: f64,
    /// At most about this many events of a window get a plane fit; in a busier window
    /// one in k of the events that pass the refractory filter is fitted (k sized from
    /// a sample of the window, see `NormalFlow::process_window`) and the others only
    /// update the surface. Fits are the flow's cost, and an obstacle filling the
    /// view can bring 50 times a window's usual events: uncapped, that window would
    /// take tens of milliseconds exactly when the decision matters. The history keeps
    /// at most `pipeline.max_vectors` vectors anyway, so fitting them all would mostly
    /// push out older vectors. Load shedding lowers the cap further. 1000, not 2000:
    /// counted on the events that pass the refractory filter, 2000 fits made the
    /// closed loop on the Atom's factor overrun its budget 160 times and shed on a
    /// third of its cycles (seed 1; 30 and 3 % when the cap counted every event).
    pub max_fits_per_window: usize,
    /// At most this many events of a window reach the flow at all (surface updates
    /// and fits): a busier window keeps runs of consecutive events at evenly spaced
    /// places in it (`NormalFlow::process_window_within`), the others are left out
    /// and counted (`FlowStats::skipped`). Every event costs a look at the surface
    /// even when it is refractory, and at 640 x 480 that look misses the cache (10 to
    /// 20 ns on the development machine), so a DVXplorer at the 165 Mev/s it can
    /// deliver over USB (iniVation,
    /// <https://docs.inivation.com/hardware/current-products/dvxplorer.html>; 1.65
    /// million events a window) took 12.5 ms of flow per 10 ms window whatever the
    /// fits cost. 200,000 (20 Mev/s) keeps that window within 3 ms at the median here
    /// and binds on no DVS240 or DAVIS346 stream (both peak at 12 Mev/s, 120,000 a
    /// window); load shedding lowers it once the other limits are at their floors.
    /// The buffer of the kept events is sized from it. docs/performance.md, "At the
    /// sizes of the cameras on sale".
    pub max_events_per_window: usize,
}

impl Default for FlowConfig {
    fn default() -> Self {
        Self {
            radius_px: 2,
            window_us: 150_000,
            refractory_us: 200_000,
            min_points: 8,
            outlier_residual_us: 20_000.0,
            tight_residual_us: 7_500.0,
            max_rms_us: 10_000.0,
            max_gradient_rel_error: 0.25,
            min_speed_px_s: 2.0,
            max_speed_px_s: 5_000.0,
            max_fits_per_window: 1_000,
            max_events_per_window: 200_000,
        }
    }
}

impl FlowConfig {
    /// `[pipeline.flow]`: radius, fit sizes and speed limits that the fit can honour.
    pub fn validate(&self) -> Result<(), Invalid> {
        let f = self;
        check(
            (1..=MAX_RADIUS_PX).contains(&f.radius_px),
            "pipeline.flow.radius_px",
            || format!("must be 1 to 5, got {}", f.radius_px),
        )?;
        check(f.window_us > 0, "pipeline.flow.window_us", || {
            format!("must be positive, got {}", f.window_us)
        })?;
        check(f.refractory_us >= 0, "pipeline.flow.refractory_us", || {
            format!("must not be negative, got {}", f.refractory_us)
        })?;
        let patch = (2 * usize::from(f.radius_px) + 1).pow(2);
        check(
            (3..=patch).contains(&f.min_points),
            "pipeline.flow.min_points",
            || {
                format!(
                    "must be 3 to {patch} for radius {}, got {}",
                    f.radius_px, f.min_points
                )
            },
        )?;
        positive(f.outlier_residual_us, "pipeline.flow.outlier_residual_us")?;
        positive(f.max_rms_us, "pipeline.flow.max_rms_us")?;
        positive(f.min_speed_px_s, "pipeline.flow.min_speed_px_s")?;
        positive(f.max_speed_px_s, "pipeline.flow.max_speed_px_s")?;
        check(
            (1..=1_000_000).contains(&f.max_fits_per_window),
            "pipeline.flow.max_fits_per_window",
            || format!("must be 1 to 1000000, got {}", f.max_fits_per_window),
        )?;
        check(
            (1..=4_000_000).contains(&f.max_events_per_window),
            "pipeline.flow.max_events_per_window",
            || {
                format!(
                    "must be 1 to 4000000 (a buffer is sized from it), got {}",
                    f.max_events_per_window
                )
            },
        )?;
        check(
            f.min_speed_px_s < f.max_speed_px_s,
            "pipeline.flow.max_speed_px_s",
            || "must exceed min_speed_px_s".into(),
        )?;
        Ok(())
    }
}
