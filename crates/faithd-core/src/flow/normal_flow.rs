//! The per-event flow estimator: surface update, neighbourhood, plane fit, checks.

use serde::{Deserialize, Serialize};

use crate::invalid::{Invalid, check, positive};

use super::tiles::Tiles;
use super::vector::FlowVector;
use crate::camera::CameraIntrinsics;
use crate::event::Event;

/// Largest neighbourhood radius: 11x11 pixels, what the point buffers hold.
pub const MAX_RADIUS_PX: u16 = 5;
pub(super) const MAX_POINTS: usize = ((2 * MAX_RADIUS_PX as usize) + 1).pow(2);

/// Events of a capped window tested against the surface to size its fit cap.
const FIT_CAP_SAMPLE: usize = 1024;
/// Sampled passes below which a window does not update the share of passes that mark.
const FIT_CAP_MIN_PASSES: u64 = 32;

/// Tunables of the normal flow stage.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FlowConfig {
    /// Neighbourhood half-size: 2 gives the 5x5 patch of Benosman 2014. At most 5.
    pub radius_px: u16,
    /// Only neighbours that fired within this time before the event are fitted. Longer
    /// windows keep slow edges (near the FOE, where the flow is slowest) but make their
    /// flow lag behind a changing course; 150 ms gave the lowest FOE error on the
    /// simulator (mean 6.5 degrees against 8.3 at 300 ms and 8.5 at 50 ms, 24 flights).
    pub window_us: i64,
    /// A pixel firing again within this time of its previous same-polarity event is
    /// ignored: one edge makes bursts of events per pixel, and only the first is on
    /// the moving front; where edges follow each other closely, the next one's
    /// neighbourhood also holds the previous one's pixels, and the two make one plane
    /// that is neither. 200 ms, chosen by measurement (docs/tuning.md): the median
    /// speed error against the known motion of the generated dense pole falls from
    /// 66 % at 20 ms (5.7 % at 100 ms, 4.2 % at 150 ms) to 3.8 %, on the looming pole
    /// from 3.0 to 3.0 % and on ray-traced flights from 2.9-3.3 to 2.8-3.1 %; FAITH's
    /// error on `faithd bench foe` falls from 3.80 / 4.11 / 4.24 to 3.68 / 3.98 / 4.18
    /// degrees (seeds 1-3), and the flow runs 1.3 to 2.4 times as fast. (1 ms before
    /// issue 20's first change, then 20 ms.)
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
        }
    }
}

impl FlowConfig {
    /// `[pipeline.flow]`: radius, fit sizes and speed limits that the fit can honour.
    pub fn validate(&self) -> Result<(), Invalid> {
        let f = self;
        check(
            (1..=super::MAX_RADIUS_PX).contains(&f.radius_px),
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
            f.min_speed_px_s < f.max_speed_px_s,
            "pipeline.flow.max_speed_px_s",
            || "must exceed min_speed_px_s".into(),
        )?;
        Ok(())
    }
}

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
}

/// Streaming normal flow: feed events in time order, collect vectors.
///
/// With more than one thread (`with_threads`) the sensor is split into as many
/// vertical tiles, and a window of at least `parallel_min_events` events runs each
/// tile on its own thread (see `tiles.rs`). The vectors, their order and the counters
/// are the same to the bit whatever the number of threads.
pub struct NormalFlow {
    config: FlowConfig,
    tiles: Tiles,
    /// Of the last capped `process_window` with enough sampled passes: how many of its
    /// events the sample said would pass the refractory filter, and how many did.
    last_window: Option<(u64, u64)>,
}

impl NormalFlow {
    /// Flow on the calling thread alone.
    pub fn new(camera: &CameraIntrinsics, config: FlowConfig) -> Self {
        Self::with_threads(camera, config, 1)
    }

    /// Flow on up to `threads` threads (the calling one included) for large windows;
    /// 1 is `new`. A sensor narrower than 11 pixels per thread gets fewer.
    pub fn with_threads(camera: &CameraIntrinsics, config: FlowConfig, threads: usize) -> Self {
        Self {
            tiles: Tiles::new(camera.width_px, camera.height_px, config.radius_px, threads),
            config,
            last_window: None,
        }
    }

    pub fn config(&self) -> &FlowConfig {
        &self.config
    }

    /// Threads a large window runs on.
    pub fn threads(&self) -> usize {
        self.tiles.count()
    }

    /// Windows with at least this many events run on threads; smaller ones on the
    /// calling thread, where starting threads would cost more than they save.
    pub fn parallel_min_events(&self) -> usize {
        self.tiles.parallel_min_events
    }

    pub fn set_parallel_min_events(&mut self, events: usize) {
        self.tiles.parallel_min_events = events;
    }

    /// Counters since the last `take_stats`.
    pub fn take_stats(&mut self) -> FlowStats {
        self.tiles.take_stats()
    }

    /// Forgets the surface, e.g. after the camera reconnected.
    pub fn reset(&mut self) {
        self.tiles.clear();
        self.last_window = None;
    }

    /// Processes events in order, appending one vector per event that yields a good fit.
    pub fn process(&mut self, events: &[Event], out: &mut Vec<FlowVector>) {
        self.tiles.run(events, 1, &self.config, out);
    }

    /// Processes one window's events with about `max_fits` plane fits at most: one in
    /// k of the events that pass the refractory filter is fitted (chosen by a hash of
    /// the event), and every event updates the surface. The same events give the same
    /// vectors.
    ///
    /// k is sized before the window from how many of its events will pass the filter:
    /// at a high event rate most events are refractory, and a cap counting them would
    /// fit a few of those that pass and see next to nothing (at 8 Mev/s on the
    /// generated streams, one vector a window). That count is estimated from a sample
    /// of the window's events tested against the surface as it stands
    /// (`FIT_CAP_SAMPLE` of them), scaled by the share of such passes that held in the
    /// window before: a pixel firing twice in one window passes the test both times,
    /// but marks only once. The share of the window before alone is not enough: 200 ms
    /// after a burst of edges, the pixels it marked come out of their refractory
    /// period together, and a window sized by the quiet one before it fitted 30 times
    /// the cap (2.4 ms of flow at 12 Mev/s, an overrun on the Atom).
    pub fn process_window(&mut self, events: &[Event], max_fits: usize, out: &mut Vec<FlowVector>) {
        let max_fits = max_fits.max(1) as u64;
        if events.len() as u64 <= max_fits {
            // Every event may be fitted, whatever passes; the share of passes that
            // mark is left as the last busy window measured it.
            self.tiles.run(events, 1, &self.config, out);
            return;
        }
        let stride = events.len().div_ceil(FIT_CAP_SAMPLE);
        let (passing, looked) =
            self.tiles
                .sample_would_mark(events, stride, self.config.refractory_us);
        let would_mark = (events.len() as u64).saturating_mul(passing) / looked.max(1);
        let marks_per_pass = match self.last_window {
            Some((would_before, marked_before)) if would_before > 0 => {
                (marked_before as f64 / would_before as f64).clamp(1.0 / 64.0, 1.0)
            }
            _ => 1.0,
        };
        let expected_marked = (would_mark as f64 * marks_per_pass).ceil() as u64;
        let fit_one_in = expected_marked
            .div_ceil(max_fits)
            .clamp(1, u64::from(u32::MAX)) as u32;
        let marked_before = self.tiles.marked();
        self.tiles.run(events, fit_one_in, &self.config, out);
        let marked = self.tiles.marked().saturating_sub(marked_before);
        // A window where too few sampled events passed says little about the share:
        // keep the one before.
        if passing >= FIT_CAP_MIN_PASSES {
            self.last_window = Some((would_mark, marked));
        }
    }

    /// One event: update the surface, then try a plane fit around it.
    pub fn process_event(&mut self, e: &Event) -> Option<FlowVector> {
        self.tiles.step(e, 1, &self.config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::event::Polarity;
    use crate::math;

    /// A straight edge sweeping across the sensor at constant velocity.
    fn sweep(speed_px_s: f64, angle_deg: f64) -> Vec<Event> {
        let (nx, ny) = (
            math::cos(angle_deg.to_radians()),
            math::sin(angle_deg.to_radians()),
        );
        let mut events = Vec::new();
        for y in 0..180u16 {
            for x in 0..240u16 {
                // Distance of the pixel along the edge normal, from a line through (0, 0).
                let d = f64::from(x) * nx + f64::from(y) * ny + 300.0;
                let t_us = (d / speed_px_s * 1e6) as i64;
                events.push(Event::new(t_us, x, y, Polarity::On));
            }
        }
        events.sort_by_key(|e| e.t_us);
        events
    }

    #[test]
    fn straight_edge_gives_its_velocity() {
        let cam = CameraIntrinsics::dvs240();
        for (speed, angle) in [(50.0, 0.0), (200.0, 30.0), (20.0, 135.0), (400.0, -100.0)] {
            let mut flow = NormalFlow::new(&cam, FlowConfig::default());
            let mut out = Vec::new();
            flow.process(&sweep(speed, angle), &mut out);
            assert!(out.len() > 20_000, "only {} vectors", out.len());
            let (mut su, mut sv) = (0.0, 0.0);
            for f in &out {
                su += f.u_px_s;
                sv += f.v_px_s;
            }
            let (mu, mv) = (su / out.len() as f64, sv / out.len() as f64);
            let (eu, ev) = (
                speed * math::cos(angle.to_radians()),
                speed * math::sin(angle.to_radians()),
            );
            let err = math::hypot(mu - eu, mv - ev) / speed;
            assert!(
                err < 0.05,
                "speed {speed} angle {angle}: mean ({mu}, {mv}) vs ({eu}, {ev})"
            );
        }
    }

    /// A slow edge following a fast one over the same pixels: ahead of the slow front
    /// the neighbourhood still holds the fast edge's times, young enough for the fit
    /// window. The vectors whose fit leans on them must be the ones not marked tight.
    #[test]
    fn vectors_leaning_on_stale_pixels_are_not_tight() {
        let cam = CameraIntrinsics::dvs240();
        let mut events = Vec::new();
        for y in 40..120u16 {
            for x in 40..56u16 {
                let dx = i64::from(x - 40);
                // Fast edge at 400 px/s, then the slow one at 100 px/s, both moving right.
                events.push(Event::new(1_000_000 + dx * 2_500, x, y, Polarity::On));
                events.push(Event::new(
                    1_040_000 + dx * 10_000 + i64::from(y % 3) * 700,
                    x,
                    y,
                    Polarity::On,
                ));
            }
        }
        events.sort_by_key(|e| e.t_us);
        // The slow edge follows 40 to 80 ms behind: within the default refractory period
        // its pixels would not fire again at all. A shorter one lets them, as an edge
        // more than 200 ms behind would.
        let config = FlowConfig {
            refractory_us: 20_000,
            ..FlowConfig::default()
        };
        let mut flow = NormalFlow::new(&cam, config);
        let mut out = Vec::new();
        flow.process(&events, &mut out);
        // The slow edge's vectors: direction error against +x, tight or not.
        let slow: Vec<_> = out.iter().filter(|v| v.t_us >= 1_045_000).collect();
        let angle_deg = |v: &&FlowVector| math::atan2(v.v_px_s, v.u_px_s).to_degrees().abs();
        let mean = |vs: Vec<f64>| vs.iter().sum::<f64>() / vs.len().max(1) as f64;
        let tight: Vec<f64> = slow.iter().filter(|v| v.tight).map(angle_deg).collect();
        let loose: Vec<f64> = slow.iter().filter(|v| !v.tight).map(angle_deg).collect();
        let speed_error =
            |vs: &[&&FlowVector]| mean(vs.iter().map(|v| (v.speed_px_s() - 100.0).abs()).collect());
        // Measured: 157 tight with speed error 5 px/s, 469 not tight pointing backwards
        // (mean 178 degrees off) with speed error 56 px/s.
        let tight_refs: Vec<_> = slow.iter().filter(|v| v.tight).collect();
        let loose_refs: Vec<_> = slow.iter().filter(|v| !v.tight).collect();
        assert!(
            tight.len() > 50 && loose.len() > 100,
            "{} / {}",
            tight.len(),
            loose.len()
        );
        assert!(mean(loose) > 120.0, "the leaning fits point backwards");
        assert!(
            speed_error(&tight_refs) * 5.0 < speed_error(&loose_refs),
            "{} vs {}",
            speed_error(&tight_refs),
            speed_error(&loose_refs)
        );
    }

    #[test]
    fn refractory_and_out_of_view_events_are_counted_not_used() {
        let cam = CameraIntrinsics::dvs240();
        let mut flow = NormalFlow::new(&cam, FlowConfig::default());
        let mut out = Vec::new();
        let events = [
            Event::new(0, 10, 10, Polarity::On),
            Event::new(100, 10, 10, Polarity::On),
            Event::new(200, 10, 10, Polarity::Off),
            Event::new(300, 240, 10, Polarity::On),
            Event::new(300, 10, 180, Polarity::On),
        ];
        flow.process(&events, &mut out);
        let stats = flow.take_stats();
        assert_eq!(stats.events, 5);
        assert_eq!(stats.refractory, 1);
        assert_eq!(stats.out_of_view, 2);
        assert!(out.is_empty());
    }

    #[test]
    fn random_noise_yields_few_vectors() {
        use rand::{RngExt, SeedableRng};
        let cam = CameraIntrinsics::dvs240();
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        let events: Vec<_> = (0..50_000)
            .map(|i| {
                Event::new(
                    i * 20,
                    rng.random_range(0..240),
                    rng.random_range(0..180),
                    Polarity::from_bool(rng.random_bool(0.5)),
                )
            })
            .collect();
        let mut flow = NormalFlow::new(&cam, FlowConfig::default());
        let mut out = Vec::new();
        flow.process(&events, &mut out);
        // 50k uniform events over 1 s: a pixel's neighbourhood rarely holds 8 recent ones.
        assert!(out.len() < 2_500, "{} vectors from noise", out.len());
    }

    /// Every pixel of the sensor once, in `window_us` from `start_us`.
    fn every_pixel(start_us: i64, window_us: i64) -> Vec<Event> {
        let pixels = 240 * 180;
        (0..pixels)
            .map(|i| {
                let t_us = start_us + (i as i64 * window_us) / pixels as i64;
                Event::new(t_us, (i % 240) as u16, (i / 240) as u16, Polarity::On)
            })
            .collect()
    }

    /// Plane fits a window tried: events that marked their pixel and were chosen.
    fn fits(stats: &FlowStats) -> u64 {
        stats.events - stats.out_of_view - stats.refractory - stats.not_fitted
    }

    /// 200 ms after a burst, its pixels leave their refractory period together. The
    /// windows between passed next to nothing, so a cap sized by the window before
    /// would fit every event of that one (43,200 fits for a cap of 1000).
    #[test]
    fn fit_cap_holds_when_a_burst_leaves_its_refractory_period() {
        let cam = CameraIntrinsics::dvs240();
        let config = FlowConfig::default();
        let mut flow = NormalFlow::new(&cam, config);
        let mut out = Vec::new();
        let window_us = 10_000;
        let mut per_window = Vec::new();
        for w in 0..25 {
            out.clear();
            flow.process_window(&every_pixel(w * window_us, window_us), 1_000, &mut out);
            per_window.push(flow.take_stats());
        }
        let refractory_windows = (config.refractory_us / window_us) as usize;
        // The quiet windows: every event refractory.
        for stats in &per_window[1..refractory_windows] {
            assert_eq!(stats.refractory, stats.events);
        }
        for (w, stats) in per_window.iter().enumerate() {
            let marked = stats.events - stats.refractory;
            let fits = fits(stats);
            assert!(fits <= 1_500, "window {w}: {fits} fits of {marked} marked");
        }
        // Both bursts marked every pixel and were fitted near the cap.
        for w in [0, refractory_windows] {
            let stats = &per_window[w];
            assert_eq!(stats.events - stats.refractory, 43_200, "window {w}");
            assert!(fits(stats) >= 800, "window {w}: {} fits", fits(stats));
        }
    }
}
