//! The per-event work of the flow: surface update, neighbourhood, plane fits, checks.
//!
//! One `Engine` is a surface of active events with the scratch space and counters that
//! go with it: what one thread needs to run the flow over a tile of the sensor.

use super::config::{FlowConfig, MAX_POINTS, MAX_RADIUS_PX};
use super::plane_fit::Plane;
use super::stats::FlowStats;
use super::surface::{ActiveEventSurface, NEVER_US};
use super::vector::FlowVector;
use crate::event::Event;
use crate::math;

/// Points of one neighbourhood: `(dx_px, dy_px, dt_us)` relative to the event.
type Point = (f64, f64, f64);

/// Size of the point buffers: a power of two of at least `MAX_POINTS`. Indices below
/// `MAX_POINTS` are masked with `BUF_POINTS - 1`, which leaves them unchanged and shows
/// the compiler they are in bounds.
const BUF_POINTS: usize = 128;
const _: () = assert!(BUF_POINTS.is_power_of_two() && BUF_POINTS >= MAX_POINTS);

/// Windows up to this long let the coordinates of a neighbourhood be summed as
/// integers: every partial sum of at most `MAX_POINTS` times within the window is
/// below 2^53 in magnitude, so the floating-point sum the plane fit adds up is exact
/// and equals the integer sum (the pixel offsets are small integers anyway).
const EXACT_SUM_WINDOW_US: i64 = (1 << 53) / MAX_POINTS as i64;

/// A point's pixel offsets packed in one integer, `(dx + 8) + (dy + 8) << 32`: sums of
/// up to `MAX_POINTS` of them hold the sums of both offsets (plus 8 per point) without
/// carrying from one half into the other.
type PackedOffsets = i64;
const OFFSET_BIAS: i64 = 8;
const _: () = assert!(MAX_POINTS as i64 * (2 * OFFSET_BIAS) < 1 << 31);

/// The sums of a packed offsets sum's `points` points, as the plane fit takes them.
fn unpack_offset_sums(packed: PackedOffsets, points: usize) -> (f64, f64) {
    let bias = OFFSET_BIAS * points as i64;
    (
        ((packed & 0xffff_ffff) - bias) as f64,
        ((packed >> 32) - bias) as f64,
    )
}

/// Scratch space of one event's fit, reused from event to event: a neighbourhood's
/// points, and the subset a refit or the tight check works on.
struct Scratch {
    points: [Point; BUF_POINTS],
    subset: [Point; BUF_POINTS],
}

impl Scratch {
    fn new() -> Box<Self> {
        Box::new(Self {
            points: [(0.0, 0.0, 0.0); BUF_POINTS],
            subset: [(0.0, 0.0, 0.0); BUF_POINTS],
        })
    }
}

/// Whether an event is among the one in `one_in` that a capped window fits: by a hash
/// of the event, not its place in the window, so the choice is the same whichever
/// tile or thread handles it, and spread evenly over the sensor and the window. Only
/// events that pass the refractory filter are asked: at a high event rate most do
/// not, and a cap that counted them would spend its fits on events never fitted.
#[inline(always)]
pub(super) fn chosen_for_fit(e: &Event, one_in: u32) -> bool {
    let key = u64::from(e.x_px) | u64::from(e.y_px) << 16 | (e.t_us as u64) << 32;
    let hash = key.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 32;
    // hash / 2^32 < 1 / one_in, without a division.
    (hash * u64::from(one_in)) >> 32 == 0
}

/// What an event did to the surface.
pub(super) enum Mark {
    OutOfView,
    Refractory,
    /// It is now the pixel's latest event (x, y in pixels).
    Marked(usize, usize),
}

/// The surface of active events with the scratch space and counters that go with it:
/// everything one thread needs to run the flow.
pub(super) struct Engine {
    pub surface: ActiveEventSurface,
    scratch: Box<Scratch>,
    pub stats: FlowStats,
}

impl Engine {
    pub fn new(width_px: u16, height_px: u16) -> Self {
        Self {
            surface: ActiveEventSurface::new(width_px, height_px),
            scratch: Scratch::new(),
            stats: FlowStats::default(),
        }
    }

    /// The surface update every event makes: a pixel in view, not within the
    /// refractory time of its previous same-polarity event, takes the event's time.
    #[inline(always)]
    pub fn mark(&mut self, e: &Event, refractory_us: i64) -> Mark {
        let mark = self.test_mark(e, refractory_us);
        if let Mark::Marked(x, y) = mark {
            self.surface.set(x, y, e.polarity, e.t_us);
        }
        mark
    }

    /// Whether `e` would mark its pixel were it processed now. Reads only.
    #[inline(always)]
    pub fn would_mark(&self, e: &Event, refractory_us: i64) -> bool {
        matches!(self.test_mark(e, refractory_us), Mark::Marked(..))
    }

    /// What `mark` would do with `e`, without doing it.
    #[inline(always)]
    fn test_mark(&self, e: &Event, refractory_us: i64) -> Mark {
        let (x, y) = (usize::from(e.x_px), usize::from(e.y_px));
        if x >= self.surface.width_px() || y >= self.surface.height_px() {
            return Mark::OutOfView;
        }
        let previous_us = self.surface.get(x, y, e.polarity);
        if previous_us != NEVER_US && e.t_us.saturating_sub(previous_us) < refractory_us {
            return Mark::Refractory;
        }
        Mark::Marked(x, y)
    }

    /// Events counted so far that passed the refractory filter (in view, marking their
    /// pixel), whether fitted or not: with the sampled estimate of a window, the share
    /// of passes that mark, which sizes the fit cap of the next (`process_window`).
    pub fn marked(&self) -> u64 {
        self.stats.events - self.stats.out_of_view - self.stats.refractory
    }

    /// One event: update the surface, then, if it marked its pixel and is among the
    /// one in `fit_one_in` chosen (`chosen_for_fit`), try a plane fit around it. An
    /// event not fitted still marks its pixel, for its neighbours' fits.
    #[inline(always)]
    pub fn process_event(
        &mut self,
        e: &Event,
        config: &FlowConfig,
        fit_one_in: u32,
    ) -> Option<FlowVector> {
        // Four copies, so that an uncapped window's events carry no test of the cap.
        match (config.window_us <= EXACT_SUM_WINDOW_US, fit_one_in > 1) {
            (true, false) => self.process_event_with::<true, false>(e, config, 1),
            (true, true) => self.process_event_with::<true, true>(e, config, fit_one_in),
            (false, false) => self.process_event_with::<false, false>(e, config, 1),
            (false, true) => self.process_event_with::<false, true>(e, config, fit_one_in),
        }
    }

    /// `process_event`, with the sums of coordinates added as integers when
    /// `INTEGER_SUMS` (see `EXACT_SUM_WINDOW_US`), and one in `fit_one_in` of the
    /// events fitted when `CAPPED`.
    ///
    /// The arithmetic is that of `fit_plane` on the points the original per-event code
    /// gathered, in their order, so the vectors are the same to the bit; what changed
    /// is what is not computed. The coordinate sums are added while gathering, and the
    /// initial fit's residuals are computed once for its sum of squares, the outlier
    /// rejection and the tight check together. The tight plane is fitted only for an
    /// event that yields a vector, and not at all when its points are those of the
    /// initial fit or of the refit (the same points in the same order give the same
    /// plane). A fit's RMS and gradient error are computed only when they are checked.
    /// Whether a pixel is recent or a point kept depends on the data, so those loops
    /// have no branch on it: mispredicted, such branches cost more than the fits.
    #[inline(always)]
    fn process_event_with<const INTEGER_SUMS: bool, const CAPPED: bool>(
        &mut self,
        e: &Event,
        config: &FlowConfig,
        fit_one_in: u32,
    ) -> Option<FlowVector> {
        self.stats.events += 1;
        let (x, y) = match self.mark(e, config.refractory_us) {
            Mark::OutOfView => {
                self.stats.out_of_view += 1;
                return None;
            }
            Mark::Refractory => {
                self.stats.refractory += 1;
                return None;
            }
            Mark::Marked(x, y) => (x, y),
        };
        if CAPPED && !chosen_for_fit(e, fit_one_in) {
            self.stats.not_fitted += 1;
            return None;
        }
        let Self {
            surface,
            scratch,
            stats,
        } = self;
        let Scratch { points, subset } = &mut **scratch;

        let (n, sums) = gather::<INTEGER_SUMS>(surface, e, x, y, config, points);
        if n < config.min_points {
            stats.too_few_points += 1;
            return None;
        }
        let points = &points[..n];
        let Some(initial) = Plane::through(points, sums) else {
            stats.bad_fit += 1;
            return None;
        };
        let Rejection { ss, kept, near } = reject_outliers(&initial, points, subset, config);
        let (fit, fit_ss, fit_time_sum_us) = if kept < n {
            if kept < config.min_points {
                stats.too_few_points += 1;
                return None;
            }
            let kept_points = &subset[..kept];
            // `fit_plane`'s own sums. (Masked sums in the rejection pass became a
            // mispredicted branch there; integer copies of the points cost more.)
            let (mut kx, mut ky, mut kt) = (0.0, 0.0, 0.0);
            for &(x, y, t) in kept_points {
                kx += x;
                ky += y;
                kt += t;
            }
            let Some(refit) = Plane::through(kept_points, (kx, ky, kt)) else {
                stats.bad_fit += 1;
                return None;
            };
            (refit, refit.residual_squares(kept_points), kt)
        } else {
            (initial, ss, sums.2)
        };
        if fit.rms_us(fit_ss) > config.max_rms_us
            || fit.gradient_rel_error(fit_ss) > config.max_gradient_rel_error
        {
            stats.bad_fit += 1;
            return None;
        }
        let Some((u, v)) = fit.normal_flow_px_s() else {
            stats.bad_fit += 1;
            return None;
        };
        let speed = math::hypot(u, v);
        if !(speed >= config.min_speed_px_s && speed <= config.max_speed_px_s) {
            stats.speed_rejected += 1;
            return None;
        }
        let tight = config.tight_residual_us <= 0.0 || {
            let holds = |plane: &Plane, ss: f64| {
                plane.rms_us(ss) <= config.max_rms_us
                    && plane.gradient_rel_error(ss) <= config.max_gradient_rel_error
                    && plane.normal_flow_px_s().is_some()
            };
            if near == n {
                holds(&initial, ss)
            } else if near == kept {
                // Nested sets of one size: the refit's points.
                holds(&fit, fit_ss)
            } else if near < config.min_points {
                false
            } else {
                // Rare: a vector whose tight set is neither fit's set. Masked sums
                // (see `masked`) in point order, as `fit_plane` adds them.
                let (mut sx, mut sy, mut st) = (0.0, 0.0, 0.0);
                let mut m = 0;
                for &p in points {
                    let take = initial.residual_us(p).abs() <= config.tight_residual_us;
                    subset[m & (BUF_POINTS - 1)] = p;
                    m += usize::from(take);
                    sx += masked(p.0, take);
                    sy += masked(p.1, take);
                    st += masked(p.2, take);
                }
                let near_points = &subset[..m];
                Plane::through(near_points, (sx, sy, st))
                    .is_some_and(|t| holds(&t, t.residual_squares(near_points)))
            }
        };
        stats.vectors += 1;
        if !tight {
            stats.not_tight += 1;
        }
        Some(FlowVector {
            tight,
            fit_age_us: (-fit_time_sum_us / fit.points() as f64) as f32,
            ..FlowVector::new(e.t_us, x as f64, y as f64, u, v)
        })
    }
}

/// What the initial fit's residuals tell.
struct Rejection {
    /// Sum of the squared residuals.
    ss: f64,
    /// Points within `outlier_residual_us`, now at the front of the subset.
    kept: usize,
    /// Points within `tight_residual_us`.
    near: usize,
}

/// The initial fit's residuals, computed once for its sum of squares, one round of
/// outlier rejection (stale or early pixels off the plane) and the size of the tight
/// check's set.
///
/// Not inlined: in the event's code the compiler spilled the sum of squares to memory
/// in this loop, which made it twice as slow.
#[inline(never)]
fn reject_outliers(
    initial: &Plane,
    points: &[Point],
    subset: &mut [Point; BUF_POINTS],
    config: &FlowConfig,
) -> Rejection {
    let (outlier_us, tight_us) = (config.outlier_residual_us, config.tight_residual_us);
    let mut ss = 0.0;
    let (mut kept, mut near) = (0, 0);
    for &p in points {
        let r = initial.residual_us(p);
        ss += r * r;
        near += usize::from(r.abs() <= tight_us);
        subset[kept & (BUF_POINTS - 1)] = p;
        kept += usize::from(r.abs() <= outlier_us);
    }
    Rejection { ss, kept, near }
}

/// `value` where `keep`, else +0 or -0: adding either zero to a sum that is not -0 (a
/// sum started at +0 never is) leaves the sum's bits as they are, so a masked sum over
/// all points equals the sum over the kept ones in their order.
#[inline(always)]
fn masked(value: f64, keep: bool) -> f64 {
    value * f64::from(u8::from(keep))
}

/// Recent same-polarity neighbours of an event at (x, y) as (dx, dy, dt) relative to
/// it, row by row, and the sums of their coordinates in that order.
///
/// Every pixel of the patch is written to the buffer and counted only when it is
/// recent. With `INTEGER_SUMS` the sums are added as integers (exact, see
/// `EXACT_SUM_WINDOW_US`); else in floating point in point order, with a zero for the
/// other pixels (see `masked`).
#[inline(always)]
fn gather<const INTEGER_SUMS: bool>(
    surface: &ActiveEventSurface,
    e: &Event,
    x: usize,
    y: usize,
    config: &FlowConfig,
    points: &mut [Point; BUF_POINTS],
) -> (usize, (f64, f64, f64)) {
    let r = usize::from(config.radius_px.min(MAX_RADIUS_PX));
    let (w, h) = (surface.width_px(), surface.height_px());
    let (x0, x1) = (x.saturating_sub(r), (x + r).min(w - 1));
    let (y0, y1) = (y.saturating_sub(r), (y + r).min(h - 1));
    // A pixel is recent when it has fired (not `NEVER_US`, which is `i64::MIN`) and
    // `0 <= t_us.saturating_sub(t) <= window_us`: when `t` lies in `oldest_us..=t_us`.
    // One unsigned comparison tests that (offsets from `oldest_us` that wrap are huge).
    // A window of `i64::MAX` takes every earlier time, however far the saturated age.
    let t_us = e.t_us;
    let oldest_us = if config.window_us == i64::MAX {
        NEVER_US + 1
    } else {
        t_us.saturating_sub(config.window_us).max(NEVER_US + 1)
    };
    let span_us = if config.window_us < 0 || t_us < oldest_us {
        None
    } else {
        Some(t_us.wrapping_sub(oldest_us) as u64)
    };
    let Some(span_us) = span_us else {
        return (0, (0.0, 0.0, 0.0));
    };
    let plane = surface.plane(e.polarity);
    let (xf, yf) = (x as f64, y as f64);
    let mut n = 0;
    let (mut sxy, mut st) = (0, 0);
    let (mut sxf, mut syf, mut stf) = (0.0, 0.0, 0.0);
    for ny in y0..=y1 {
        let row = &plane[ny * w + x0..=ny * w + x1];
        let dy = ny as f64 - yf;
        // dx and the packed offsets step by one along the row.
        let mut dx = x0 as f64 - xf;
        let xy0: PackedOffsets =
            (x0 as i64 - x as i64 + OFFSET_BIAS) + ((ny as i64 - y as i64 + OFFSET_BIAS) << 32);
        for (xy, &t) in (xy0..).zip(row) {
            let recent = (t.wrapping_sub(oldest_us) as u64) <= span_us;
            // `wrapping_sub` is what `-` does in a release build; a recent pixel's
            // difference never wraps.
            let dt = t.wrapping_sub(t_us);
            let dtf = dt as f64;
            let slot = n & (BUF_POINTS - 1);
            points[slot] = (dx, dy, dtf);
            if INTEGER_SUMS {
                let mask = -i64::from(recent);
                sxy += xy & mask;
                st += dt & mask;
            } else {
                sxf += masked(dx, recent);
                syf += masked(dy, recent);
                stf += masked(dtf, recent);
            }
            n += usize::from(recent);
            dx += 1.0;
        }
    }
    if INTEGER_SUMS {
        let (sx, sy) = unpack_offset_sums(sxy, n);
        (n, (sx, sy, st as f64))
    } else {
        (n, (sxf, syf, stf))
    }
}
