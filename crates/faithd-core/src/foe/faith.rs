//! FAITH: fast iterative half-plane FOE estimation (the paper's Algorithm 1).
//!
//! Each iteration intersects the negative half-planes of two random flow vectors, keeps
//! adding random half-planes while they shrink that area, and scores the area's centre
//! by how many half-planes contain it. The best-scoring centre wins.
//!
//! Where faithd departs from the authors' code, and why:
//! - The centre is the polygon's area centroid, not its bounding-box centre: a thin
//!   sliver's box centre can lie outside the sliver (and outside the half-planes that
//!   made it).
//! - The search does not clamp to the image. Candidates come from a search box a little
//!   larger than the sensor; the winner is then refined over a box that reaches almost
//!   to 90 degrees off-axis. An FOE outside the view is reported as `Unbounded` with its
//!   side when the flow does not close the area, instead of being pinned to the border.
//! - Refinement: the final area is the intersection of *all* half-planes that agree with
//!   the best candidate (its inliers), whose centroid is a consensus estimate rather
//!   than the centre of the few half-planes one random draw happened to pick.
//! - A half-plane that would empty the area (an outlier disagreeing with it) is skipped
//!   rather than accepted as "smaller".
//! - Plateau centroid: with real normal flow, the number of half-planes containing a
//!   point is nearly flat over a wide region around the FOE (only the few vectors whose
//!   lines pass near the FOE tell those points apart), so the single best-scoring point
//!   wanders anywhere on that plateau. faithd reports the centroid of the plateau (the
//!   points within a small fraction of the best score), computed on a local grid with
//!   one pass per half-plane and grid row.
//! - Speeds: the half-planes use only the flow's directions, and the plateau leans to
//!   the side with fewer edges. `speed_fit` then places the FOE within a small grid
//!   around the plateau centroid by how well one time to contact per image patch
//!   explains the normal-flow speeds there. The `faithd bench foe` table of docs/performance.md
//!   gives what each of these steps is worth on the simulator.

use crate::math;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};

use crate::invalid::{Invalid, check, non_negative, positive};

use super::polygon::{ConvexPolygon, HalfPlane};
use super::speed_fit::{SpeedFit, SpeedFitConfig, UnitFlow};
use super::{FoeEstimate, FoeEstimator};
use crate::camera::CameraIntrinsics;
use crate::flow::FlowVector;

/// Tunables of FAITH. Defaults follow the paper where it is explicit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FaithConfig {
    /// RANSAC iterations. The paper's eq. 4 with p = 0.95, w = 0.75, n = 10 gives 52.
    pub iterations: u32,
    /// Upper bound on half-planes added in one iteration's shrinking loop, so a cycle's
    /// cost is bounded whatever the data.
    pub max_cuts_per_iteration: u32,
    /// Fewer usable vectors than this and no FOE is reported.
    pub min_vectors: usize,
    /// How far beyond the sensor border (pixels) candidate areas may reach.
    pub search_margin_px: f64,
    /// Radius (pixels, around the sensor) beyond which an area counts as unbounded.
    /// 20000 px at f = 195 px is 89.4 degrees off-axis.
    pub unbounded_margin_px: f64,
    /// A point within this distance (pixels) outside a half-plane still counts as in it.
    pub inlier_tolerance_px: f64,
    /// Refine the winner over all of its inlier half-planes (see the module docs).
    pub refine: bool,
    /// Report the bounding-box centre like the authors' code (for the benchmark only).
    pub bbox_centre: bool,
    /// Points whose support is within this fraction of the vectors of the best count as
    /// the plateau whose centroid is the FOE; 0 turns the plateau step off.
    pub plateau_fraction: f64,
    /// Half-size of the square grid searched for the plateau around the winner, pixels.
    pub plateau_radius_px: f64,
    /// Grid spacing of the plateau search, pixels.
    pub plateau_cell_px: f64,
    /// Half-size of the grid around the plateau centroid on which the speed fit places
    /// the FOE, pixels; 0 turns the speed fit off (see `speed_fit`).
    pub speed_radius_px: f64,
    /// Grid spacing of the speed fit, pixels.
    pub speed_step_px: f64,
    /// Side of the patches whose edges the speed fit gives one time to contact, pixels.
    pub speed_patch_px: f64,
    /// Speed fit: how far above the best residual a cell's may be and still count, as
    /// a fraction of the best's.
    pub speed_temperature: f64,
}

impl Default for FaithConfig {
    fn default() -> Self {
        Self {
            iterations: 52,
            max_cuts_per_iteration: 64,
            min_vectors: 10,
            search_margin_px: 20.0,
            unbounded_margin_px: 20_000.0,
            inlier_tolerance_px: 0.0,
            refine: true,
            bbox_centre: false,
            plateau_fraction: 0.01,
            plateau_radius_px: 64.0,
            plateau_cell_px: 4.0,
            speed_radius_px: 40.0,
            speed_step_px: 8.0,
            speed_patch_px: 20.0,
            speed_temperature: 0.3,
        }
    }
}

impl FaithConfig {
    /// `[pipeline.faith]`: iteration counts, margins and the speed fit's grid.
    pub fn validate(&self) -> Result<(), Invalid> {
        let fa = self;
        check(fa.iterations >= 1, "pipeline.faith.iterations", || {
            "must be at least 1".into()
        })?;
        check(fa.min_vectors >= 2, "pipeline.faith.min_vectors", || {
            "must be at least 2".into()
        })?;
        non_negative(fa.search_margin_px, "pipeline.faith.search_margin_px")?;
        check(
            fa.unbounded_margin_px.is_finite() && fa.unbounded_margin_px > fa.search_margin_px,
            "pipeline.faith.unbounded_margin_px",
            || "must be finite and larger than search_margin_px".into(),
        )?;
        non_negative(fa.inlier_tolerance_px, "pipeline.faith.inlier_tolerance_px")?;

        check(
            (0.0..1.0).contains(&fa.plateau_fraction),
            "pipeline.faith.plateau_fraction",
            || format!("must be 0 (off) to below 1, got {}", fa.plateau_fraction),
        )?;
        positive(fa.plateau_radius_px, "pipeline.faith.plateau_radius_px")?;
        positive(fa.plateau_cell_px, "pipeline.faith.plateau_cell_px")?;
        check(
            (0.0..=120.0).contains(&fa.speed_radius_px),
            "pipeline.faith.speed_radius_px",
            || format!("must be 0 (off) to 120 px, got {}", fa.speed_radius_px),
        )?;
        check(
            fa.speed_radius_px == 0.0
                || fa.speed_step_px >= 0.5 && fa.speed_step_px <= fa.speed_radius_px,
            "pipeline.faith.speed_step_px",
            || {
                format!(
                    "must be 0.5 px to speed_radius_px ({}), got {}",
                    fa.speed_radius_px, fa.speed_step_px
                )
            },
        )?;
        check(
            (4.0..=240.0).contains(&fa.speed_patch_px),
            "pipeline.faith.speed_patch_px",
            || format!("must be 4 to 240 px, got {}", fa.speed_patch_px),
        )?;
        check(
            fa.speed_temperature >= 0.0 && fa.speed_temperature.is_finite(),
            "pipeline.faith.speed_temperature",
            || {
                format!(
                    "must be a non-negative number (0: the best cell alone), got {}",
                    fa.speed_temperature
                )
            },
        )?;
        Ok(())
    }
}

impl FaithConfig {
    /// The algorithm as the paper and the authors' code run it: 100 iterations, areas
    /// clamped to the image, bounding-box centre, no refinement. Kept for comparison.
    pub fn paper() -> Self {
        Self {
            iterations: 100,
            search_margin_px: 0.0,
            refine: false,
            bbox_centre: true,
            plateau_fraction: 0.0,
            speed_radius_px: 0.0,
            ..Self::default()
        }
    }

    /// Directions only: faithd's FAITH without the speed fit (for the benchmark).
    pub fn directions_only() -> Self {
        Self {
            speed_radius_px: 0.0,
            ..Self::default()
        }
    }

    fn speed_fit(&self) -> SpeedFitConfig {
        SpeedFitConfig {
            radius_px: self.speed_radius_px,
            step_px: self.speed_step_px,
            patch_px: self.speed_patch_px,
            temperature: self.speed_temperature,
        }
    }
}

/// The four sides of the sensor rectangle grown by `margin_px`, as half-planes.
fn sensor_box_sides(max_x_px: f64, max_y_px: f64, margin_px: f64) -> [HalfPlane; 4] {
    let side = |nx, ny, c| HalfPlane { nx, ny, c };
    [
        side(-1.0, 0.0, margin_px),
        side(0.0, -1.0, margin_px),
        side(1.0, 0.0, max_x_px + margin_px),
        side(0.0, 1.0, max_y_px + margin_px),
    ]
}

/// A boundary's crossing column in the plateau grid's rows, `x + j step` cells in row
/// `j`, in 32.32 fixed point: a row's column is then an add and a shift, where a
/// floating-point floor with its clamps took three times the instructions (the
/// plateau's updates are FAITH's largest part). The rows a line crosses are placed
/// within 2^-32 cells.
#[derive(Clone, Copy)]
struct FixedLine {
    x: i64,
    step: i64,
}

/// Largest |crossing| and |slope| a `FixedLine` holds, in cells: with at most 512 rows
/// (`plateau_centroid`'s bound) the sum stays far inside an i64 of 32.32. Nearly
/// horizontal boundaries go beyond it, and are placed in floating point.
const FIXED_MAX_CELLS: f64 = 1_048_576.0;

impl FixedLine {
    fn new(x: f64, step: f64) -> Option<Self> {
        let fits = |v: f64| v.abs() <= FIXED_MAX_CELLS;
        let fixed = |v: f64| (v * 4_294_967_296.0) as i64;
        (fits(x) && fits(step)).then(|| Self {
            x: fixed(x),
            step: fixed(step),
        })
    }

    fn at(&self, row: i64) -> i64 {
        self.x + row * self.step
    }
}

/// Adds `delta` to row `j`'s slot `column(j)` in every row of the plateau grid, unless
/// the line is clamped to one edge in its first and last rows (and so in all); true
/// when it was added.
fn add_line(
    grid: &mut [i32],
    stride: usize,
    side: usize,
    delta: i32,
    column: impl Fn(i64) -> usize,
) -> bool {
    let (first, last) = (column(0), column(side as i64 - 1));
    if first == last && (first == 0 || first == side) {
        return false;
    }
    for (j, row) in grid.chunks_exact_mut(stride).enumerate() {
        row[column(j as i64)] += delta;
    }
    true
}

/// The square grid on which `Faith::plateau_centroid` counts violated half-planes:
/// `side` cells a row and a column, `cell_px` apart, the first at `(x0_px, y0_px)`.
///
/// Its counts are row-major difference arrays: each row holds `side` cells, a sentinel
/// slot that collects updates past the last cell, and a whole-row counter.
#[derive(Clone, Copy)]
struct PlateauGrid {
    x0_px: f64,
    y0_px: f64,
    cell_px: f64,
    side: usize,
}

impl PlateauGrid {
    /// Slots per row: the cells, the sentinel and the whole-row counter.
    fn stride(&self) -> usize {
        self.side + 2
    }

    /// Slot of the counter added to every cell of its row.
    fn whole_row(&self) -> usize {
        self.side + 1
    }

    /// Centroid of the cells whose count is at most `most`; `None` when there are none.
    fn centroid_within(&self, cells: &[i32], most: i32) -> Option<(f64, f64)> {
        let (mut sx, mut sy, mut n) = (0usize, 0usize, 0usize);
        for (j, row) in cells.chunks_exact(self.stride()).enumerate() {
            for (i, &count) in row[..self.side].iter().enumerate() {
                if count <= most {
                    sx += i;
                    sy += j;
                    n += 1;
                }
            }
        }
        (n > 0).then(|| {
            (
                self.x0_px + self.cell_px * sx as f64 / n as f64,
                self.y0_px + self.cell_px * sy as f64 / n as f64,
            )
        })
    }
}

// The two `add_*_lines` go line by line, each over all rows: consecutive updates then go
// to different rows, where row by row many lines clamp to the same slot and their
// increments would wait on one another. A line's column is monotonic in the row, so
// when its first and last rows agree on "no cell violated" or "every cell violated", so
// do all rows between: such a line adds the same to every cell, which moves neither the
// plateau nor its centroid, and is left out.
//
// Lines beyond `FixedLine`'s range are placed in floating point, where the clamp keeps
// the truncating cast a floor (a libm floor call would cost more than the rest).

/// Adds the boundaries violated right of their crossing: from floor(x) + 1 on, clamped
/// to the row's slots.
fn add_rightward_lines(cells: &mut [i32], side: usize, lines: &[(f64, f64)]) {
    let stride = side + 2;
    let side_i64 = side as i64;
    let top = side as f64 + 1.0;
    for &(x, step) in lines {
        if let Some(line) = FixedLine::new(x, step) {
            let column = |j: i64| ((line.at(j) >> 32) + 1).clamp(0, side_i64) as usize;
            add_line(cells, stride, side, 1, column);
        } else {
            let column = |j: i64| {
                let v = (x + j as f64 * step).clamp(-1.0, top) + 1.0;
                (v as usize).min(side)
            };
            add_line(cells, stride, side, 1, column);
        }
    }
}

/// Adds the boundaries violated left of their crossing: the whole row minus the cells
/// from ceil(x) on, clamped to the row's slots. Returns how many whole rows that adds
/// to every row, for the caller to add once.
fn add_leftward_lines(cells: &mut [i32], side: usize, lines: &[(f64, f64)]) -> i32 {
    let stride = side + 2;
    let side_i64 = side as i64;
    let top = side as f64 + 1.0;
    let mut whole = 0;
    for &(x, step) in lines {
        // ceil(v) = -floor(-v), and = K - floor(K - v) for K = side + 1 >= v >= 0.
        let added = if let Some(line) = FixedLine::new(x, step) {
            let column = |j: i64| (-((-line.at(j)) >> 32)).clamp(0, side_i64) as usize;
            add_line(cells, stride, side, -1, column)
        } else {
            let column = |j: i64| {
                let v = (x + j as f64 * step).clamp(0.0, top);
                (side + 1 - ((top - v) as usize)).min(side)
            };
            add_line(cells, stride, side, -1, column)
        };
        whole += i32::from(added);
    }
    whole
}

/// Turns each row's difference array into counts, starting from its whole-row
/// counter, and returns the least count.
fn integrate_rows(cells: &mut [i32], side: usize) -> i32 {
    let stride = side + 2;
    let whole_row = side + 1;
    let mut least = i32::MAX;
    for row in cells.chunks_exact_mut(stride) {
        let mut acc = row[whole_row];
        for cell in &mut row[..side] {
            acc += *cell;
            *cell = acc;
            least = least.min(acc);
        }
    }
    least
}

/// Boundaries sampled for the coarse plateau pass: enough to place the plateau.
const COARSE_LINES: usize = 256;

/// The FAITH estimator with its reusable buffers.
pub struct Faith {
    camera: CameraIntrinsics,
    config: FaithConfig,
    /// Half-planes of the current window as structure of arrays in f32, so the score
    /// loop (the hot spot: iterations x vectors) runs four lanes wide. Single precision
    /// is ample: 240 px in f32 is exact to 2e-5 px.
    nx: Vec<f32>,
    ny: Vec<f32>,
    c: Vec<f32>,
    /// `c` plus the inlier tolerance, as the score compares with it.
    c_tol: Vec<f32>,
    /// Excess of every half-plane at one point, and of a block of them at another.
    excess_buffer: Vec<f64>,
    excess_block: Vec<f64>,
    area: ConvexPolygon,
    cut: ConvexPolygon,
    scratch: ConvexPolygon,
    /// Violation counts of the plateau grid, one row per grid row plus a spare column
    /// for the difference-array form.
    grid: Vec<i32>,
    /// Boundaries crossing the plateau grid, as (crossing column, change per row).
    rightward: Vec<(f64, f64)>,
    leftward: Vec<(f64, f64)>,
    /// Each boundary's distance from the plateau grid's centre.
    line_distance: Vec<f32>,
    /// The usable vectors of the window, normalised once for the half-planes and the
    /// speed fit.
    unit: UnitFlow,
    speed_fit: SpeedFit,
    /// The far-field check's candidates: (support, ray angle, off-axis degrees).
    far_candidates: Vec<(usize, f64, f64)>,
}

impl Faith {
    pub fn new(camera: CameraIntrinsics, config: FaithConfig) -> Self {
        Self {
            camera,
            config,
            nx: Vec::new(),
            ny: Vec::new(),
            c: Vec::new(),
            c_tol: Vec::new(),
            excess_buffer: Vec::new(),
            excess_block: Vec::new(),
            area: ConvexPolygon::with_capacity(64),
            cut: ConvexPolygon::with_capacity(64),
            scratch: ConvexPolygon::with_capacity(64),
            grid: Vec::new(),
            rightward: Vec::new(),
            leftward: Vec::new(),
            line_distance: Vec::new(),
            unit: UnitFlow::default(),
            speed_fit: SpeedFit::new(),
            far_candidates: Vec::new(),
        }
    }

    pub fn config(&self) -> &FaithConfig {
        &self.config
    }

    /// Room for windows of up to `vectors` vectors (and the largest plateau grid),
    /// so that a steady stream of windows allocates nothing.
    pub fn reserve(&mut self, vectors: usize) {
        for v in [&mut self.nx, &mut self.ny, &mut self.c, &mut self.c_tol] {
            v.reserve(vectors.saturating_sub(v.len()));
        }
        for v in [&mut self.excess_buffer, &mut self.excess_block] {
            v.reserve(vectors.saturating_sub(v.len()));
        }
        for v in [&mut self.rightward, &mut self.leftward] {
            v.reserve(vectors.saturating_sub(v.len()));
        }
        self.line_distance
            .reserve(vectors.saturating_sub(self.line_distance.len()));
        self.grid
            .reserve((512 * 514usize).saturating_sub(self.grid.len()));
        self.unit.reserve(vectors);
        self.speed_fit.reserve(vectors);
        let probes = FAR_PROBE_TURNS_DEG.len() * (FAR_PROBE_MAX_DEG / FAR_PROBE_STEP_DEG) as usize;
        self.far_candidates
            .reserve(probes.saturating_sub(self.far_candidates.len()));
    }

    /// Sets the iteration count; the daemon lowers it to shed load under a tight budget.
    pub fn set_iterations(&mut self, iterations: u32) {
        self.config.iterations = iterations;
    }

    /// The half-planes behind the usable vectors (`HalfPlane::behind`, whose tests and
    /// arithmetic `UnitFlow::load` shares), in single precision.
    fn load_half_planes(&mut self, flow: &[FlowVector]) {
        self.unit.load(flow);
        let u = &self.unit;
        let n = u.len();
        let (ux, uy, unx, uny) = (&u.x_px[..n], &u.y_px[..n], &u.nx[..n], &u.ny[..n]);
        let tol = self.config.inlier_tolerance_px as f32;
        for v in [&mut self.nx, &mut self.ny, &mut self.c, &mut self.c_tol] {
            v.clear();
            v.resize(n, 0.0);
        }
        let (nx, ny) = (&mut self.nx[..n], &mut self.ny[..n]);
        let (c, c_tol) = (&mut self.c[..n], &mut self.c_tol[..n]);
        // Indexed over slices of one length, so the loop vectorises.
        for i in 0..n {
            nx[i] = unx[i] as f32;
            ny[i] = uny[i] as f32;
            c[i] = (unx[i] * ux[i] + uny[i] * uy[i]) as f32;
            c_tol[i] = c[i] + tol;
        }
    }

    fn half_plane(&self, i: usize) -> HalfPlane {
        HalfPlane {
            nx: f64::from(self.nx[i]),
            ny: f64::from(self.ny[i]),
            c: f64::from(self.c[i]),
        }
    }

    /// Number of half-planes containing the point: the iteration score.
    fn score(&self, x: f64, y: f64) -> usize {
        self.score_above(x, y, 0)
    }

    /// The score of `(x, y)` if it is above `beat`; otherwise some number not above
    /// `beat`: the count stops once the half-planes left could no longer lift it past.
    /// With `beat` 0 the count is always complete.
    fn score_above(&self, x: f64, y: f64, beat: usize) -> usize {
        /// Half-planes counted between checks: long enough to run vectorised.
        const CHUNK: usize = 128;
        let n = self.nx.len();
        let (nx, ny, c) = (&self.nx[..n], &self.ny[..n], &self.c_tol[..n]);
        let (x, y) = (x as f32, y as f32);
        let mut count = 0;
        let mut start = 0;
        while start < n {
            let end = (start + CHUNK).min(n);
            // Branch-free so it vectorises.
            let mut inside = 0u32;
            for i in start..end {
                inside += u32::from(nx[i] * x + ny[i] * y <= c[i]);
            }
            count += inside as usize;
            start = end;
            if count + (n - start) <= beat {
                return count + (n - start);
            }
        }
        count
    }

    fn set_box(&mut self, margin_px: f64) {
        let (w, h) = self.sensor_max_px();
        self.area
            .set_rectangle(-margin_px, -margin_px, w + margin_px, h + margin_px);
    }

    /// Cuts `self.area` by half-plane `i`; returns false (area unchanged) when the cut
    /// would empty it.
    fn cut_area(&mut self, i: usize) -> bool {
        let h = self.half_plane(i);
        self.area.clip_into(&h, &mut self.cut);
        if self.cut.is_empty() {
            return false;
        }
        std::mem::swap(&mut self.area, &mut self.cut);
        true
    }

    fn centre(&self, poly: &ConvexPolygon) -> Option<(f64, f64)> {
        if self.config.bbox_centre {
            poly.bbox_centre()
        } else {
            poly.centroid()
        }
    }

    /// One RANSAC iteration: the paper's inner loop. Leaves the area in `self.area`.
    fn grow_candidate(&mut self, rng: &mut Pcg64Mcg) -> Option<(f64, f64)> {
        let n = self.nx.len();
        let i = rng.random_range(0..n);
        let mut j = rng.random_range(0..n - 1);
        if j >= i {
            j += 1;
        }
        self.set_box(self.config.search_margin_px);
        if !self.cut_area(i) || !self.cut_area(j) {
            return None;
        }
        let mut area_px2 = self.area.area();
        for _ in 0..self.config.max_cuts_per_iteration {
            let k = rng.random_range(0..n);
            let h = self.half_plane(k);
            // A half-plane holding the whole area leaves it as it is: the area test
            // below would stop here, so stop without clipping.
            if self.area.inside(&h) {
                break;
            }
            self.area.clip_into(&h, &mut self.cut);
            let new_area_px2 = self.cut.area();
            if self.cut.is_empty() || new_area_px2 >= area_px2 * (1.0 - 1e-12) {
                break;
            }
            std::mem::swap(&mut self.area, &mut self.cut);
            area_px2 = new_area_px2;
        }
        self.centre(&self.area)
    }

    /// Intersects every half-plane that contains `(x, y)` (the winner's inliers).
    fn refine_over_inliers(&mut self, x: f64, y: f64) {
        let c_tol = self.config.inlier_tolerance_px;
        self.set_box(self.config.unbounded_margin_px);
        let n = self.nx.len();
        // Every half-plane's excess at the winner, once, in a loop that vectorises.
        let mut at_winner = std::mem::take(&mut self.excess_buffer);
        self.excess_at(x, y, 0..n, &mut at_winner);
        // Cut first with the inliers whose boundary passes closest to the winner: they
        // shrink the area at once, after which almost every other half-plane contains
        // the whole area and is dismissed by a bounding-circle test in O(1).
        const FIRST_CUTS: usize = 16;
        let mut closest = [(f64::INFINITY, 0usize); FIRST_CUTS];
        for (i, &e) in at_winner.iter().enumerate() {
            if e <= c_tol && -e < closest[FIRST_CUTS - 1].0 {
                // Inserted in order, after any equal one (a sort of the 16 per
                // insertion cost several microseconds on a window of 2000 vectors).
                let mut k = FIRST_CUTS - 1;
                while k > 0 && closest[k - 1].0 > -e {
                    closest[k] = closest[k - 1];
                    k -= 1;
                }
                closest[k] = (-e, i);
            }
        }
        for &(d, i) in &closest {
            if d.is_finite() {
                self.cut_area_with_tolerance(i, c_tol);
            }
        }
        // The circle test a block at a time (vectorised), until a cut moves the circle:
        // then again from the next half-plane, with the new circle.
        const BLOCK: usize = 64;
        let mut at_centre = std::mem::take(&mut self.excess_block);
        let (mut cx, mut cy, mut radius) = self.area_circle();
        let mut start = 0;
        while start < n {
            let end = (start + BLOCK).min(n);
            self.excess_at(cx, cy, start..end, &mut at_centre);
            let mut next = end;
            for i in start..end {
                if at_winner[i] > c_tol || at_centre[i - start] + radius <= c_tol {
                    continue;
                }
                if self.cut_area_with_tolerance(i, c_tol) {
                    (cx, cy, radius) = self.area_circle();
                    next = i + 1;
                    break;
                }
            }
            start = next;
        }
        self.excess_buffer = at_winner;
        self.excess_block = at_centre;
    }

    /// `HalfPlane::excess` at `(x, y)` of the half-planes `range`, into `out`.
    fn excess_at(&self, x: f64, y: f64, range: std::ops::Range<usize>, out: &mut Vec<f64>) {
        out.clear();
        let (nx, ny, c) = (
            &self.nx[range.clone()],
            &self.ny[range.clone()],
            &self.c[range],
        );
        out.extend(
            nx.iter()
                .zip(ny)
                .zip(c)
                .map(|((&nx, &ny), &c)| f64::from(nx) * x + f64::from(ny) * y - f64::from(c)),
        );
    }

    /// Cuts the area by half-plane `i` widened by `tol`; true when the area changed.
    fn cut_area_with_tolerance(&mut self, i: usize, tol: f64) -> bool {
        let h = self.half_plane(i);
        let h = HalfPlane { c: h.c + tol, ..h };
        if self.area.inside(&h) {
            return false;
        }
        self.area.clip_into(&h, &mut self.cut);
        if self.cut.is_empty() {
            return false;
        }
        std::mem::swap(&mut self.area, &mut self.cut);
        true
    }

    /// A circle around the area: vertex mean and the largest distance to it.
    fn area_circle(&self) -> (f64, f64, f64) {
        let v = self.area.vertices();
        let n = v.len().max(1) as f64;
        let (sx, sy) = v.iter().fold((0.0, 0.0), |(a, b), &(x, y)| (a + x, b + y));
        let (cx, cy) = (sx / n, sy / n);
        let r2 = v
            .iter()
            .map(|&(x, y)| (x - cx) * (x - cx) + (y - cy) * (y - cy))
            .fold(0.0, f64::max);
        (cx, cy, r2.sqrt() * (1.0 + 1e-9))
    }

    /// Centroid of the points (on a grid around `(cx, cy)`) whose violation count is
    /// within `slack` of the least; `None` when the grid is degenerate.
    ///
    /// Each half-plane's boundary crosses a grid row once, so its violated cells in that
    /// row are a prefix or a suffix: one difference-array update per row instead of one
    /// test per cell. Half-planes whose line misses the grid are constant over it and
    /// skipped.
    fn plateau_centroid(
        &mut self,
        cx: f64,
        cy: f64,
        radius_px: f64,
        cell_px: f64,
        slack: i32,
        line_stride: usize,
    ) -> Option<(f64, f64)> {
        let side = (2.0 * radius_px / cell_px).floor() as usize + 1;
        if !(2..=512).contains(&side) {
            return None;
        }
        let grid = PlateauGrid {
            x0_px: cx - radius_px,
            y0_px: cy - radius_px,
            cell_px,
            side,
        };
        self.grid.clear();
        self.grid.resize(side * grid.stride(), 0);
        self.measure_line_distances(cx, cy);
        let reach_px = radius_px * std::f64::consts::SQRT_2 + cell_px;
        self.collect_crossing_lines(&grid, reach_px, line_stride);
        let cells = &mut self.grid[..side * grid.stride()];
        add_rightward_lines(cells, side, &self.rightward);
        let whole = add_leftward_lines(cells, side, &self.leftward);
        for row in cells.chunks_exact_mut(grid.stride()) {
            row[grid.whole_row()] += whole;
        }
        let least = integrate_rows(cells, side);
        grid.centroid_within(cells, least + slack)
    }

    /// Each boundary's distance from `(cx, cy)` into `line_distance`, in single
    /// precision and a loop that vectorises: most boundaries miss the plateau grid, and
    /// this is the cheap test that skips them.
    fn measure_line_distances(&mut self, cx: f64, cy: f64) {
        let n = self.nx.len();
        let tol = self.config.inlier_tolerance_px;
        let (cx32, cy32, tol32) = (cx as f32, cy as f32, tol as f32);
        let (nx32, ny32, c32) = (&self.nx[..n], &self.ny[..n], &self.c[..n]);
        self.line_distance.clear();
        self.line_distance.resize(n, 0.0);
        let distance = &mut self.line_distance[..n];
        for i in 0..n {
            distance[i] = (nx32[i] * cx32 + ny32[i] * cy32 - (c32[i] + tol32)).abs();
        }
    }

    /// Sorts every `line_stride`-th boundary within `reach_px` of the grid's centre by
    /// the side its half-plane is violated on, as (crossing column at row 0, change per
    /// row) in cells, into `rightward` and `leftward`. A horizontal boundary leaves each
    /// row wholly in or out, so it is counted at once in the rows' whole-row slots.
    ///
    /// A boundary farther than `reach_px` is constant over the grid (the reach clears it
    /// by a cell), so the single-precision distance cannot wrongly drop one that matters.
    fn collect_crossing_lines(&mut self, grid: &PlateauGrid, reach_px: f64, line_stride: usize) {
        let PlateauGrid {
            x0_px: x0,
            y0_px: y0,
            cell_px,
            side,
        } = *grid;
        let (stride, whole_row) = (grid.stride(), grid.whole_row());
        let tol = self.config.inlier_tolerance_px;
        let per_cell = 1.0 / cell_px;
        self.rightward.clear();
        self.leftward.clear();
        let reach32 = reach_px as f32;
        for k in (0..self.nx.len()).step_by(line_stride.max(1)) {
            if self.line_distance[k] > reach32 {
                continue;
            }
            let HalfPlane { nx, ny, c } = self.half_plane(k);
            let c = c + tol;
            if nx.abs() < 1e-9 {
                for j in 0..side {
                    if ny * (y0 + j as f64 * cell_px) > c {
                        self.grid[j * stride + whole_row] += 1;
                    }
                }
                continue;
            }
            // One division where three were: they are most of this loop's cost.
            let inv_nx = 1.0 / nx;
            let x_cross = ((c - ny * y0) * inv_nx - x0) * per_cell;
            let step = -ny * inv_nx;
            if nx > 0.0 {
                self.rightward.push((x_cross, step));
            } else {
                self.leftward.push((x_cross, step));
            }
        }
    }

    /// Largest pixel coordinates of the sensor.
    fn sensor_max_px(&self) -> (f64, f64) {
        (
            f64::from(self.camera.width_px) - 1.0,
            f64::from(self.camera.height_px) - 1.0,
        )
    }

    /// Does the current area meet the sensor rectangle? (Uses the scratch polygons.)
    fn area_overlaps_view(&mut self) -> bool {
        let (w, h) = self.sensor_max_px();
        self.cut.copy_from(&self.area);
        for half in sensor_box_sides(w, h, 0.0) {
            self.cut.clip_into(&half, &mut self.scratch);
            std::mem::swap(&mut self.cut, &mut self.scratch);
        }
        !self.cut.is_empty()
    }

    /// Does the area reach the far box, i.e. is the true intersection unbounded?
    fn reaches_far_box(&self, poly: &ConvexPolygon) -> bool {
        let m = self.config.unbounded_margin_px;
        let (w, h) = self.sensor_max_px();
        let edge_tol = 1e-6 * m.max(1.0);
        poly.vertices().iter().any(|&(x, y)| {
            x <= -m + edge_tol
                || y <= -m + edge_tol
                || x >= w + m - edge_tol
                || y >= h + m - edge_tol
        })
    }
}

impl FoeEstimator for Faith {
    fn name(&self) -> &'static str {
        "faith"
    }

    fn estimate(&mut self, flow: &[FlowVector], seed: u64) -> FoeEstimate {
        self.load_half_planes(flow);
        let n = self.nx.len();
        if n < self.config.min_vectors.max(2) {
            return FoeEstimate::Insufficient { vectors: n };
        }
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let mut best: Option<(usize, (f64, f64))> = None;
        for _ in 0..self.config.iterations.max(1) {
            let Some((x, y)) = self.grow_candidate(&mut rng) else {
                continue;
            };
            let score = self.score_above(x, y, best.map_or(0, |(s, _)| s));
            if best.is_none_or(|(s, _)| score > s) {
                best = Some((score, (x, y)));
            }
        }
        let Some((mut support, (mut x, mut y))) = best else {
            return FoeEstimate::Insufficient { vectors: n };
        };
        if self.config.refine {
            self.refine_over_inliers(x, y);
            if !self.area_overlaps_view() {
                // The agreeing half-planes exclude the whole view: the FOE is outside.
                let (ox, oy) = self.area.centroid().unwrap_or((x, y));
                if self.reaches_far_box(&self.area) {
                    return self.unbounded(ox, oy, support);
                }
                let support = self.score(ox, oy);
                if let Some(beyond) = self.look_beyond(ox, oy, support) {
                    return beyond;
                }
                return FoeEstimate::Point {
                    x_px: ox,
                    y_px: oy,
                    support,
                };
            }
            // The data allow an FOE in view: prefer it, as the vehicle flies at what it
            // sees. Its estimate is the consensus area within the search box.
            let margin = self.config.search_margin_px;
            let (w, h) = self.sensor_max_px();
            for half in sensor_box_sides(w, h, margin) {
                self.area.clip_into(&half, &mut self.cut);
                if !self.cut.is_empty() {
                    std::mem::swap(&mut self.area, &mut self.cut);
                }
            }
            if let Some((rx, ry)) = self.centre(&self.area) {
                let refined_support = self.score(rx, ry);
                if refined_support >= support {
                    (x, y, support) = (rx, ry, refined_support);
                }
            }
        }
        let mut moved = false;
        if self.config.plateau_fraction > 0.0 {
            let slack = (self.config.plateau_fraction * n as f64).ceil() as i32;
            // A coarse pass over a sample of the boundaries finds the plateau; a fine
            // pass over all of them around its centre measures it.
            let (r, cell) = (self.config.plateau_radius_px, self.config.plateau_cell_px);
            let stride = n.div_ceil(COARSE_LINES);
            let coarse_slack = (slack / stride as i32).max(1);
            for (radius_px, cell_px, slack, stride) in [
                (r, 2.0 * cell, coarse_slack, stride),
                (0.375 * r, cell, slack, 1),
            ] {
                if let Some(p) = self.plateau_centroid(x, y, radius_px, cell_px, slack, stride) {
                    (x, y) = p;
                }
            }
            moved = true;
        }
        let sensor_px = (self.camera.width_px, self.camera.height_px);
        let speed_config = self.config.speed_fit();
        if let Some(p) = self
            .speed_fit
            .refine_unit(&self.unit, (x, y), sensor_px, &speed_config)
        {
            (x, y) = p;
            moved = true;
        }
        if moved {
            // One scoring pass for wherever the plateau and speed steps left the FOE.
            support = self.score(x, y);
        }
        if let Some(beyond) = self.look_beyond(x, y, support) {
            return beyond;
        }
        FoeEstimate::Point {
            x_px: x,
            y_px: y,
            support,
        }
    }
}

/// Off-axis angles the far-field check looks at beyond an estimate outside the view:
/// every 2.5 degrees out to this.
const FAR_PROBE_MAX_DEG: f64 = 87.5;
const FAR_PROBE_STEP_DEG: f64 = 2.5;
/// ...along the estimate's direction from the principal point and these turns of it.
const FAR_PROBE_TURNS_DEG: [f64; 5] = [0.0, -6.0, 6.0, -12.0, 12.0];

impl Faith {
    /// An estimate outside the view is checked against the far field along its ray.
    ///
    /// With outliers among the vectors, a few of them close the region the others
    /// leave open toward an FOE far off axis, and the search settles just past the
    /// border (an FOE 63 to 80 degrees off axis came back 17 to 36 px past it, 29 to
    /// 53 degrees off). Every inlier's half-plane holds the far FOE; seen from a
    /// point near the border, the edges' lines fan out and many exclude it. So the
    /// points further out along the same ray (and rays turned 6 and 12 degrees either
    /// way) are scored, and `far_verdict` weighs them against the estimate.
    ///
    /// Only with the speed fit on: one of the two tests needs its patches, and the
    /// configurations without it (`directions_only`, `paper`) are the benchmark's
    /// references for what each step is worth, kept as they were. An estimate inside
    /// the view is never looked at, so it keeps every bit.
    fn look_beyond(&mut self, x: f64, y: f64, support: usize) -> Option<FoeEstimate> {
        let (w, h) = self.sensor_max_px();
        let speed_config = self.config.speed_fit();
        if (0.0..=w).contains(&x) && (0.0..=h).contains(&y) || speed_config.radius_px <= 0.0 {
            return None;
        }
        let (xn, yn) = self.camera.normalise(x, y);
        let r = math::hypot(xn, yn);
        if r <= 0.0 {
            return None;
        }
        let sensor_px = (self.camera.width_px, self.camera.height_px);
        self.speed_fit
            .load_patches(&self.unit, sensor_px, speed_config.patch_px);
        let start_deg = math::atan(r).to_degrees();
        let heading = math::atan2(yn, xn);
        // Candidates along the estimate's ray and rays either side of it (an estimate
        // past the border is off in direction too), out to nearly 90 degrees. The
        // buffer is kept between windows: the steady state allocates nothing.
        let mut candidates = std::mem::take(&mut self.far_candidates);
        candidates.clear();
        for turn_deg in FAR_PROBE_TURNS_DEG {
            let phi = heading + turn_deg.to_radians();
            let mut deg = start_deg + FAR_PROBE_STEP_DEG;
            while deg <= FAR_PROBE_MAX_DEG + 1e-9 {
                let (px, py) = self.off_axis_px(phi, deg);
                candidates.push((self.score(px, py), phi, deg));
                deg += FAR_PROBE_STEP_DEG;
            }
        }
        let verdict = self.far_verdict(&candidates, (x, y), support);
        self.far_candidates = candidates;
        verdict
    }

    /// The pixel `deg` degrees off axis in the direction `phi` (radians) from the
    /// principal point.
    fn off_axis_px(&self, phi: f64, deg: f64) -> (f64, f64) {
        let t = math::tan(deg.to_radians());
        self.camera
            .to_pixels(math::cos(phi) * t, math::sin(phi) * t)
    }

    /// What the far field says of an estimate outside the view, from the scored
    /// candidates beyond it: `Unbounded`, a point further out, or nothing to change.
    ///
    /// The estimate moves only on evidence that it is not where the flow converges:
    /// - the directions: points further out hold clearly more half-planes than the
    ///   estimate (by more than 1.5 times the plateau's slack), so the estimate sits
    ///   on an area that a few outliers closed; or
    /// - the speeds: the half-planes are as many out to the last angle as anywhere
    ///   (within the slack of the best) and the speeds fit there no worse than at
    ///   the estimate.
    ///
    /// An FOE just inside or past the border (where the simulator's flights at 30
    /// degrees put it) shows neither: too few vectors lie beyond it for the support to
    /// drop further out, but it does not rise either (at most 2 half-planes on
    /// `bench foe` seed 1, against a slack of 6 to 24), and its speeds, which grow
    /// with the distance from it, fit a far FOE worse (by 11 % and more at the last
    /// angle). An FOE far off axis among 15 % outliers gains 3 to 97 half-planes
    /// further out, and where it gains little its speeds fit the far points 2 to 5 %
    /// better. The margin of 1.5 slacks rather than one: a rotating flight of seed 3
    /// (465 vectors, FOE in view 19 px from the border) gained 6 against a slack of
    /// 5, and moving it doubled its error; at 1000 vectors it costs one of 150
    /// synthetic far fields (70 degrees off axis, toward a corner).
    ///
    /// When the support keeps within the slack of the best out to the last angle
    /// along some ray, the FOE is reported as `Unbounded` toward the far point there
    /// whose speeds fit best; otherwise (with a clear gain) as the point of the
    /// plateau whose speeds fit best.
    fn far_verdict(
        &self,
        candidates: &[(usize, f64, f64)],
        estimate: (f64, f64),
        support: usize,
    ) -> Option<FoeEstimate> {
        let n = self.nx.len();
        let slack = (self.config.plateau_fraction * n as f64).ceil() as usize;
        let top = candidates
            .iter()
            .map(|c| c.0)
            .max()
            .unwrap_or(0)
            .max(support);
        let gain = 2 * (top - support) > 3 * slack;
        let own_cost = self.speed_fit.cost(estimate.0, estimate.1);
        let cost_at = |&(score, phi, deg): &(usize, f64, f64)| {
            let (px, py) = self.off_axis_px(phi, deg);
            (self.speed_fit.cost(px, py), score, px, py)
        };
        let far_deg = candidates.iter().map(|c| c.2).fold(0.0, f64::max);
        let unbounded = candidates
            .iter()
            .filter(|c| c.2 == far_deg && c.0 + slack >= top)
            .map(cost_at)
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .filter(|&(cost, ..)| gain || cost <= own_cost);
        if let Some((_, score, px, py)) = unbounded {
            return Some(self.unbounded(px, py, score.max(support)));
        }
        if !gain {
            return None;
        }
        let (_, score, px, py) = candidates
            .iter()
            .filter(|c| c.0 + slack >= top)
            .map(cost_at)
            .min_by(|a, b| a.0.total_cmp(&b.0))?;
        Some(FoeEstimate::Point {
            x_px: px,
            y_px: py,
            support: score,
        })
    }

    /// The FOE lies beyond the view, in the direction of `(x, y)` from the centre.
    fn unbounded(&self, x: f64, y: f64, support: usize) -> FoeEstimate {
        FoeEstimate::unbounded_towards(&self.camera, x, y, None, support)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::foe::Side;
    use crate::synth::{FlowFieldSpec, radial_normal_flow};

    fn run(config: FaithConfig, spec: &FlowFieldSpec, seed: u64) -> FoeEstimate {
        let cam = CameraIntrinsics::dvs240();
        let flow = radial_normal_flow(&cam, spec, seed);
        Faith::new(cam, config).estimate(&flow, seed ^ 0xfa17)
    }

    /// Mean pixel error over several random fields.
    fn mean_error_px(config: FaithConfig, spec: FlowFieldSpec, trials: u64) -> f64 {
        let mut sum = 0.0;
        for seed in 0..trials {
            let est = run(config, &spec, seed);
            let (x, y) = est.point().unwrap_or_else(|| panic!("no point: {est:?}"));
            sum += math::hypot(x - spec.foe_px.0, y - spec.foe_px.1);
        }
        sum / trials as f64
    }

    fn noisy(foe: (f64, f64)) -> FlowFieldSpec {
        FlowFieldSpec {
            angle_noise_deg: 5.0,
            speed_noise_rel: 0.2,
            outlier_fraction: 0.15,
            ..FlowFieldSpec::clean(foe, 1000)
        }
    }

    #[test]
    fn finds_foe_of_clean_and_noisy_fields() {
        // Measured means over 10 fields: 1.3 px clean at the centre, 2.4 px noisy at
        // the centre, 3.8 px in a corner, about 10 px noisy at the border (where no
        // vector lies beyond the FOE to close the plateau). The bounds leave room for
        // the directions-only figures (2.0, 3.4, about 10).
        let clean = mean_error_px(
            FaithConfig::default(),
            FlowFieldSpec::clean((120.0, 90.0), 1000),
            10,
        );
        let centre = mean_error_px(FaithConfig::default(), noisy((120.0, 90.0)), 10);
        let corner = mean_error_px(FaithConfig::default(), noisy((30.0, 150.0)), 10);
        let border = mean_error_px(FaithConfig::default(), noisy((2.0, 90.0)), 10);
        assert!(clean < 5.0, "clean {clean}");
        assert!(centre < 7.0, "centre {centre}");
        assert!(corner < 15.0, "corner {corner}");
        assert!(border < 20.0, "border {border}");
    }

    /// The plateau's difference arrays, fixed-point rows and skipped lines give the
    /// centroid a cell-by-cell count of violated half-planes gives: over noisy
    /// fields, grids placed on and off the FOE, coarse and fine, with a slack of 0 to
    /// 40 (a shift of the crossing column by one cell fails this).
    #[test]
    fn plateau_centroid_equals_counting_every_cell() {
        let cam = CameraIntrinsics::dvs240();
        let mut faith = Faith::new(cam, FaithConfig::default());
        let tol = faith.config.inlier_tolerance_px;
        let mut checked = 0;
        for seed in 0..6u64 {
            let foe = (40.0 + 30.0 * seed as f64, 30.0 + 20.0 * seed as f64);
            let spec = FlowFieldSpec {
                outlier_fraction: 0.15,
                ..noisy(foe)
            };
            let flow = radial_normal_flow(&cam, &spec, seed);
            faith.load_half_planes(&flow);
            let n = faith.nx.len();
            for (centre, radius_px, cell_px) in [
                (foe, 64.0, 8.0),
                (foe, 24.0, 4.0),
                ((foe.0 + 17.3, foe.1 - 9.1), 24.0, 4.0),
                ((foe.0 - 40.7, foe.1 + 33.9), 30.0, 3.0),
            ] {
                for slack in [0, 10, 40] {
                    let got = faith
                        .plateau_centroid(centre.0, centre.1, radius_px, cell_px, slack, 1)
                        .unwrap();
                    let side = (2.0 * radius_px / cell_px).floor() as usize + 1;
                    let (x0, y0) = (centre.0 - radius_px, centre.1 - radius_px);
                    let counts: Vec<(usize, usize, usize)> = (0..side * side)
                        .map(|cell| {
                            let (i, j) = (cell % side, cell / side);
                            let (x, y) = (x0 + i as f64 * cell_px, y0 + j as f64 * cell_px);
                            let violated = (0..n)
                                .filter(|&k| faith.half_plane(k).excess(x, y) > tol)
                                .count();
                            (i, j, violated)
                        })
                        .collect();
                    let least = counts.iter().map(|c| c.2).min().unwrap();
                    let within: Vec<_> = counts
                        .iter()
                        .filter(|c| c.2 <= least + slack as usize)
                        .collect();
                    let mean = |f: fn(&&(usize, usize, usize)) -> usize| {
                        within.iter().map(f).sum::<usize>() as f64 / within.len() as f64
                    };
                    let want = (x0 + cell_px * mean(|c| c.0), y0 + cell_px * mean(|c| c.1));
                    assert!(
                        (got.0 - want.0).abs() < 1e-9 && (got.1 - want.1).abs() < 1e-9,
                        "seed {seed}, grid at {centre:?} r {radius_px} cell {cell_px}, \
                         slack {slack}: {got:?}, counting gives {want:?}"
                    );
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 72);
    }

    #[test]
    fn plateau_centroid_beats_the_papers_variant_on_noisy_flow() {
        let ours = mean_error_px(FaithConfig::directions_only(), noisy((120.0, 90.0)), 30);
        let paper = mean_error_px(FaithConfig::paper(), noisy((120.0, 90.0)), 30);
        let no_plateau = FaithConfig {
            plateau_fraction: 0.0,
            ..FaithConfig::directions_only()
        };
        let best_point = mean_error_px(no_plateau, noisy((120.0, 90.0)), 30);
        // Measured over 30 fields: 2.9 px against 4.6 (paper) and 5.7 (best point).
        assert!(ours * 1.2 < paper, "ours {ours} paper {paper}");
        assert!(
            ours * 1.5 < best_point,
            "ours {ours} best point {best_point}"
        );
    }

    #[test]
    fn speed_fit_beats_directions_alone_on_noisy_flow() {
        let with_speeds = mean_error_px(FaithConfig::default(), noisy((120.0, 90.0)), 30);
        let directions = mean_error_px(FaithConfig::directions_only(), noisy((120.0, 90.0)), 30);
        // Measured over 30 fields: 2.1 px against 2.9.
        assert!(
            with_speeds * 1.2 < directions,
            "with speeds {with_speeds} directions only {directions}"
        );
    }

    #[test]
    fn foe_outside_the_view_is_unbounded_with_its_side() {
        let cam = CameraIntrinsics::dvs240();
        for (foe, side) in [
            ((-400.0, 90.0), Side::Left),
            ((700.0, 60.0), Side::Right),
            ((120.0, -500.0), Side::Above),
        ] {
            let mut spec = FlowFieldSpec::clean(foe, 800);
            spec.angle_noise_deg = 2.0;
            let flow = radial_normal_flow(&cam, &spec, 3);
            match Faith::new(cam, FaithConfig::default()).estimate(&flow, 9) {
                FoeEstimate::Unbounded {
                    side: s, dx, dy, ..
                } => {
                    assert_eq!(s, side, "{foe:?}");
                    let (tx, ty) = (foe.0 - cam.cx_px, foe.1 - cam.cy_px);
                    let cos = (dx * tx + dy * ty) / math::hypot(tx, ty);
                    assert!(cos > 0.9, "direction off: {dx} {dy} for {foe:?}");
                }
                other => panic!("{foe:?}: expected unbounded, got {other:?}"),
            }
        }
    }

    /// With 15 % outliers a few of them close the area toward an FOE far off axis;
    /// the far-field check still finds it: `Unbounded` toward it, or a point within
    /// 10 degrees. Without the check every one of these came back as a point 17 to
    /// 36 px past the border, 26 to 54 degrees off (the 29 to 53).
    #[test]
    fn foe_far_off_axis_among_outliers_is_unbounded_toward_it() {
        let cam = CameraIntrinsics::dvs240();
        let (mut right, mut cases) = (0, 0);
        for off_axis_deg in [63.0f64, 70.0, 80.0] {
            for direction_deg in [0.0f64, 30.0, 90.0, 180.0, 270.0] {
                let r = cam.fx_px * math::tan(off_axis_deg.to_radians());
                let (c, s) = (
                    math::cos(direction_deg.to_radians()),
                    math::sin(direction_deg.to_radians()),
                );
                let foe = (cam.cx_px + r * c, cam.cy_px + r * s);
                for seed in 0..6 {
                    let est = run(FaithConfig::default(), &noisy(foe), seed);
                    cases += 1;
                    let ok = match est {
                        FoeEstimate::Unbounded { dx, dy, .. } => dx * c + dy * s > 0.9,
                        FoeEstimate::Point { x_px, y_px, .. } => {
                            cam.angle_between_deg((x_px, y_px), foe) < 10.0
                        }
                        FoeEstimate::Insufficient { .. } => false,
                    };
                    right += usize::from(ok);
                }
            }
        }
        // 90 of 90 when written (fields 0 to 9 with other draws: 149 of 150). A
        // first rule (`Unbounded` only when every point along a ray is on the
        // plateau and the speeds fit no worse) found 54: beyond the estimate the
        // support climbs over several steps before it levels off.
        assert!(right * 100 >= cases * 95, "{right} of {cases}");
    }

    #[test]
    fn foe_just_outside_the_view_but_bounded_is_a_point() {
        // A few pixels past the border the flow still closes the area.
        let spec = FlowFieldSpec::clean((-6.0, 90.0), 1000);
        let est = run(FaithConfig::default(), &spec, 4);
        let (x, y) = est.point().expect("a point");
        assert!(math::hypot(x + 6.0, y - 90.0) < 20.0, "{x} {y}");
    }

    #[test]
    fn too_few_or_degenerate_vectors_are_insufficient() {
        let cam = CameraIntrinsics::dvs240();
        let mut faith = Faith::new(cam, FaithConfig::default());
        assert_eq!(
            faith.estimate(&[], 1),
            FoeEstimate::Insufficient { vectors: 0 }
        );
        let zeros = vec![FlowVector::new(0, 10.0, 10.0, 0.0, 0.0); 100];
        assert_eq!(
            faith.estimate(&zeros, 1),
            FoeEstimate::Insufficient { vectors: 0 }
        );
        let nans = vec![FlowVector::new(0, f64::NAN, 10.0, 1.0, 0.0); 100];
        assert_eq!(
            faith.estimate(&nans, 1),
            FoeEstimate::Insufficient { vectors: 0 }
        );
    }

    #[test]
    fn same_seed_same_estimate_and_buffers_do_not_leak_between_calls() {
        let cam = CameraIntrinsics::dvs240();
        let mut spec = FlowFieldSpec::clean((80.0, 70.0), 600);
        spec.outlier_fraction = 0.3;
        let flow = radial_normal_flow(&cam, &spec, 11);
        let other = radial_normal_flow(&cam, &FlowFieldSpec::clean((10.0, 10.0), 300), 12);
        let mut a = Faith::new(cam, FaithConfig::default());
        let first = a.estimate(&flow, 5);
        a.estimate(&other, 6);
        assert_eq!(a.estimate(&flow, 5), first);
        assert_eq!(
            Faith::new(cam, FaithConfig::default()).estimate(&flow, 5),
            first
        );
    }
}
