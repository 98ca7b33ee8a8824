//! Exact DBSCAN on a dense grid of cells a hair under eps / sqrt(3) wide.
//!
//! Ester's expansion gives every label by a rule that needs no expansion order:
//! - a core point (at least min_points points within eps, itself included) belongs to
//!   the connected component of the graph "core points within eps of each other";
//! - components are numbered in the order of their lowest point index (the loop over
//!   points starts a cluster at the first core point it has not yet reached);
//! - a border point (not core, within eps of a core point) takes the lowest number
//!   among the components of the core points within eps of it (clusters are expanded
//!   one after the other, and the first to reach a point keeps it);
//! - anything else is noise.
//!
//! This module computes exactly that, with cells small enough that any two points of
//! one cell are within eps (the diagonal is under eps, by a margin far above
//! rounding) and large enough that a neighbour is at most two cells away per axis:
//! - a cell with min_points points is core throughout, with no distance computed;
//! - all core points of a cell are in one component, so components are found over
//!   cells (union-find), testing a pair of neighbouring cells only while they are still
//!   apart, and stopping at the first pair of points within eps;
//! - a point that is not core has walked every cell in its reach to learn so, and
//!   keeps the list of the points within eps it found there (fewer than min_points):
//!   as a border point it takes the lowest cluster among the core ones of that list,
//!   with no second search; the points of a cell with fewer than min_points points in
//!   the 125 cells around are not tested, and look for a core point within eps only
//!   when a cell in reach has one;
//! - a point only looks at the cells whose box comes within eps of it (about a third
//!   of the 125 around it), and up to four consecutive points of one row of the grid
//!   share that walk.
//!
//! The grid is a dense array: the cell coordinates of each axis are compressed (a run
//! of empty layers becomes at most two, which keeps every "at most two apart"
//! relation), the grid is padded by two cells on every side so that every neighbour
//! offset is in bounds, and x runs fastest, so a row of five neighbour cells
//! (dx = -2..=2) holds one contiguous run of the points sorted by cell, and one
//! contiguous run of the occupied cells numbered in grid order.
//!
//! Points spread over more than a million cells along an axis (or over too many cells
//! in all), or an eps whose square would leave the normal f64 range, are declined
//! (`None`) and clustered by the sparse grid instead.

use std::ops::Range;

use super::geometry::dist2;

/// No cell, point or cluster.
const NONE: u32 = u32::MAX;
/// Widest extent, in cells, accepted along one axis: keeps the rounding of a point's
/// place in the grid below 1e-9 cells.
const MAX_AXIS_CELLS: f64 = 1_048_576.0;
/// Cell side over eps: under 1 / sqrt(3) (by 1e-6) so a cell's diagonal is under eps.
const SIDE_PER_EPS: f64 = 0.577_349_7;
/// Padding (in cells) on each side of every axis: the reach of a neighbour.
const PAD: u32 = 2;
/// (eps in cells)^2 = 1 / SIDE_PER_EPS^2 = 3.0000055, plus a margin far above the
/// rounding of a point's place in its cell: a cell whose box is farther from a point
/// than this holds no point within eps of it.
const REACH2_CELLS: f64 = 3.0001;

/// A row of neighbour cells along x (dx = -2..=2): the dense index of its middle cell
/// relative to the centre cell, and its offsets in y and z (-2..=2).
#[derive(Clone, Copy, Debug)]
struct Row {
    middle: isize,
    dy: i8,
    dz: i8,
}

/// Squared distances in cells, along one axis, from a point at `frac` (0..1) of its
/// cell to the cells at offsets -2..=2.
fn gaps2(frac: f64) -> [f64; 5] {
    let g = [1.0 + frac, frac, 0.0, 1.0 - frac, 2.0 - frac];
    g.map(|g| g * g)
}

/// The cells of a row (offsets lo..=hi of -2..=2) whose boxes come within
/// `sqrt(rest2)` cells along x of a point whose x gaps are `gx2`.
fn x_span(gx2: &[f64; 5], rest2: f64) -> (isize, isize) {
    let lo = -isize::from(gx2[0] <= rest2) - isize::from(gx2[1] <= rest2);
    let hi = isize::from(gx2[3] <= rest2) + isize::from(gx2[4] <= rest2);
    (lo, hi)
}

/// Number of points of the slices within `eps2` (squared) of `p`. Branch-free so it
/// vectorises; the distance is computed as `dist2` computes it, bit for bit.
fn count_within(xs: &[f64], ys: &[f64], zs: &[f64], p: [f64; 3], eps2: f64) -> usize {
    let n = xs.len();
    let (ys, zs) = (&ys[..n], &zs[..n]);
    let mut count = 0usize;
    for k in 0..n {
        count += usize::from(dist2(&p, &[xs[k], ys[k], zs[k]]) <= eps2);
    }
    count
}

/// Points whose core tests share one walk over the cells around theirs: consecutive
/// points of one row of the grid, at most `GROUP_SPAN_CELLS` cells apart.
const GROUP: usize = 4;
/// How far apart (in cells along x) the first and last cell of a group may be.
const GROUP_SPAN_CELLS: usize = 2;

/// Points of one row of the grid whose core tests share a walk.
#[derive(Default)]
struct Group {
    len: usize,
    /// Sorted position, dense cell, and the count at which the test may stop.
    pos: [usize; GROUP],
    cell: [usize; GROUP],
    limit: [usize; GROUP],
}

/// What `assign_cells` found.
enum Cells {
    NoneFinite,
    /// Some axis spans more than `MAX_AXIS_CELLS`.
    TooWide,
    /// Padded dimensions of the compressed grid.
    Grid([u32; 3]),
}

/// The dense grid with reusable buffers: no allocation per call once warmed up.
#[derive(Default)]
pub(super) struct DenseGrid {
    /// Per point, per axis: its cell coordinate (raw, then compressed and padded), and
    /// where in that cell it lies (0..1).
    axis: [Vec<u32>; 3],
    frac: [Vec<f64>; 3],
    /// Per point: its cell (dense index), `NONE` for a point with a non-finite
    /// coordinate.
    cell_of_point: Vec<u32>,
    /// Per point: core or not.
    core_point: Vec<bool>,
    /// Axis compression: raw coordinate (or rank of a distinct one) to compressed.
    remap: Vec<u32>,
    distinct: Vec<u32>,
    /// `starts[c + 1]` is the first sorted point of dense cell `c`, for `c` up to the
    /// volume (then the number of points): see `sort_by_cell`.
    starts: Vec<u32>,
    /// Number of occupied cells before each dense cell: the occupied cell number of an
    /// occupied cell, and the range of occupied cells of any run of dense cells.
    occupied_before: Vec<u32>,
    /// Occupied cells in dense order, as dense indices.
    cells: Vec<u32>,
    /// Per occupied cell: how many of its points are core (they come first).
    core_count: Vec<u32>,
    /// Per occupied cell: union-find parent, and the cluster number of a core cell
    /// (NONE otherwise).
    parent: Vec<u32>,
    /// Per dense cell: a root its cell once had while joining (see
    /// `join_core_cells`), then its cluster number; NONE for a cell without core
    /// points.
    marks: Vec<u32>,
    cluster: Vec<u32>,
    /// Points sorted by cell, as structure of arrays so distance loops vectorise.
    xs: Vec<f64>,
    ys: Vec<f64>,
    zs: Vec<f64>,
    /// Where in its cell each sorted point lies, per axis (0..1).
    fracs: Vec<[f64; 3]>,
    /// Original index of each sorted point.
    index: Vec<u32>,
    /// The 25 rows around a cell, nearest first, and the 12 with a positive offset
    /// (the forward half, for pairs of cells taken once).
    rows: Vec<Row>,
    forward_rows: Vec<Row>,
    /// Per point that is not core: (original index, range in `neighbours`).
    non_core: Vec<(u32, u32, u32)>,
    /// Original indices of the points within eps of each point that is not core.
    neighbours: Vec<u32>,
    /// Occupied cells with fewer than min_points points in reach.
    lonely_cells: Vec<u32>,
    /// Scratch hit lists of the points of a core test, as sorted positions.
    hits: [Vec<u32>; GROUP],
}

impl DenseGrid {
    /// A grid whose buffers hold `points` points from the start: an input of up to
    /// that many allocates only when it spreads over more cells than any before (the
    /// buffers indexed by grid cell), whatever its layout otherwise.
    pub(super) fn with_capacity(points: usize, min_points: usize) -> Self {
        let mut grid = Self::default();
        for axis in &mut grid.axis {
            axis.reserve(points);
        }
        for frac in &mut grid.frac {
            frac.reserve(points);
        }
        grid.cell_of_point.reserve(points);
        grid.core_point.reserve(points);
        grid.distinct.reserve(points);
        grid.xs.reserve(points);
        grid.ys.reserve(points);
        grid.zs.reserve(points);
        grid.fracs.reserve(points);
        grid.index.reserve(points);
        grid.non_core.reserve(points);
        grid.neighbours
            .reserve(points.saturating_mul(min_points.saturating_sub(1)));
        for hits in &mut grid.hits {
            hits.reserve(points);
        }
        // At most one occupied cell per point.
        grid.cells.reserve(points);
        grid.core_count.reserve(points);
        grid.parent.reserve(points);
        grid.cluster.reserve(points);
        grid.lonely_cells.reserve(points);
        grid
    }

    /// Clusters `points` into `labels` (already `None`, one per point) and returns the
    /// number of clusters, or `None` (labels untouched) when the input is not for this
    /// grid.
    pub(super) fn run(
        &mut self,
        points: &[[f64; 3]],
        eps: f64,
        min_points: usize,
        labels: &mut [Option<u32>],
    ) -> Option<usize> {
        // eps^2 and the distances compared with it stay normal f64 numbers.
        if !(1e-150..=1e150).contains(&eps) {
            return None;
        }
        let n = points.len();
        if n >= NONE as usize {
            return None;
        }
        let inv_side = 1.0 / (eps * SIDE_PER_EPS);
        let dims = match self.assign_cells(points, inv_side) {
            Cells::NoneFinite => return Some(0),
            Cells::TooWide => return None,
            Cells::Grid(dims) => dims,
        };
        let volume = dims.iter().map(|&d| d as usize).product::<usize>();
        if volume > n.saturating_mul(64).saturating_add(262_144) {
            return None;
        }
        self.sort_by_cell(points, dims, volume);
        self.set_rows(dims);
        let eps2 = eps * eps;
        self.find_core_points(eps2, min_points);
        self.join_core_cells(eps2);
        let clusters = self.number_clusters(labels);
        self.label_border_points(eps2, labels);
        Some(clusters)
    }

    /// Cell coordinates of every point, compressed per axis, and the padded grid
    /// dimensions.
    fn assign_cells(&mut self, points: &[[f64; 3]], inv_side: f64) -> Cells {
        let n = points.len();
        self.cell_of_point.clear();
        self.cell_of_point.resize(n, NONE);
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        let mut finite = 0usize;
        for (i, p) in points.iter().enumerate() {
            if p.iter().all(|v| v.is_finite()) {
                finite += 1;
                // Any value but NONE marks a finite point until its cell is known.
                self.cell_of_point[i] = 0;
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        if finite == 0 {
            return Cells::NoneFinite;
        }
        let mut dims = [0u32; 3];
        for k in 0..3 {
            // NaN (an infinite extent) fails the comparison too.
            let extent_cells = (hi[k] - lo[k]) * inv_side;
            if extent_cells.is_nan() || extent_cells >= MAX_AXIS_CELLS {
                return Cells::TooWide;
            }
            let mut axis = std::mem::take(&mut self.axis[k]);
            axis.clear();
            self.frac[k].clear();
            for (p, &c) in points.iter().zip(&self.cell_of_point) {
                if c == NONE {
                    axis.push(NONE);
                    self.frac[k].push(0.0);
                } else {
                    // v - lo >= 0, so the truncating cast is a floor.
                    let a = (p[k] - lo[k]) * inv_side;
                    let cell = a as u32;
                    axis.push(cell);
                    self.frac[k].push(a - f64::from(cell));
                }
            }
            dims[k] = self.compress(&mut axis, n);
            self.axis[k] = axis;
        }
        Cells::Grid(dims)
    }

    /// Maps raw cell coordinates (NONE skipped) to compressed ones from `PAD` on: a run
    /// of g empty layers between occupied ones becomes min(g, 2), so layers one or two
    /// apart stay so and layers three or more apart stay at least three apart. Returns
    /// the padded dimension.
    fn compress(&mut self, axis: &mut [u32], n: usize) -> u32 {
        let extent = axis
            .iter()
            .filter(|&&a| a != NONE)
            .max()
            .map_or(0, |&a| a + 1);
        let mut next = PAD;
        if extent as usize <= 4 * n + 64 {
            // Mark occupied layers, then number them in one pass.
            self.remap.clear();
            self.remap.resize(extent as usize, NONE);
            for &a in axis.iter().filter(|&&a| a != NONE) {
                self.remap[a as usize] = 0;
            }
            let mut previous: Option<usize> = None;
            for (a, slot) in self.remap.iter_mut().enumerate() {
                if *slot == NONE {
                    continue;
                }
                if let Some(p) = previous {
                    next += (a - p).min(3) as u32;
                }
                *slot = next;
                previous = Some(a);
            }
            for a in axis.iter_mut().filter(|a| **a != NONE) {
                *a = self.remap[*a as usize];
            }
        } else {
            // Few points over a wide extent: number the distinct layers.
            self.distinct.clear();
            self.distinct
                .extend(axis.iter().copied().filter(|&a| a != NONE));
            self.distinct.sort_unstable();
            self.distinct.dedup();
            self.remap.clear();
            let mut previous: Option<u32> = None;
            for &a in &self.distinct {
                if let Some(p) = previous {
                    next += (a - p).min(3);
                }
                self.remap.push(next);
                previous = Some(a);
            }
            for a in axis.iter_mut().filter(|a| **a != NONE) {
                let rank = self.distinct.partition_point(|&d| d < *a);
                *a = self.remap[rank];
            }
        }
        next + PAD + 1
    }

    /// Counting sort of the points by dense cell (x fastest), into the sorted arrays.
    fn sort_by_cell(&mut self, points: &[[f64; 3]], dims: [u32; 3], volume: usize) {
        let (dx, dy) = (dims[0] as usize, dims[1] as usize);
        let [ax, ay, az] = &self.axis;
        for (i, cell) in self.cell_of_point.iter_mut().enumerate() {
            if *cell != NONE {
                *cell = (ax[i] as usize + dx * (ay[i] as usize + dy * az[i] as usize)) as u32;
            }
        }
        // Counts at c + 1, prefix sums (the end of each cell), then a backward pass
        // that decrements to the start of each cell, filling each cell in index order.
        self.starts.clear();
        self.starts.resize(volume + 2, 0);
        for &c in &self.cell_of_point {
            if c != NONE {
                self.starts[c as usize + 1] += 1;
            }
        }
        self.occupied_before.clear();
        self.occupied_before.reserve(volume + 1);
        let (mut total, mut occupied) = (0, 0);
        for s in &mut self.starts[1..volume + 1] {
            self.occupied_before.push(occupied);
            occupied += u32::from(*s > 0);
            total += *s;
            *s = total;
        }
        self.occupied_before.push(occupied);
        self.starts[volume + 1] = total;
        let total = total as usize;
        self.xs.resize(total, 0.0);
        self.ys.resize(total, 0.0);
        self.zs.resize(total, 0.0);
        self.index.resize(total, 0);
        self.fracs.resize(total, [0.0; 3]);
        for (i, &c) in self.cell_of_point.iter().enumerate().rev() {
            if c == NONE {
                continue;
            }
            let start = &mut self.starts[c as usize + 1];
            *start -= 1;
            let pos = *start as usize;
            let [x, y, z] = points[i];
            (self.xs[pos], self.ys[pos], self.zs[pos]) = (x, y, z);
            self.fracs[pos] = [self.frac[0][i], self.frac[1][i], self.frac[2][i]];
            self.index[pos] = i as u32;
        }
        self.cells.clear();
        let mut last = NONE;
        for &i in &self.index {
            let c = self.cell_of_point[i as usize];
            if c != last {
                self.cells.push(c);
                last = c;
            }
        }
    }

    /// First sorted point of dense cell `c` (the number of points for the volume).
    fn first(&self, c: usize) -> usize {
        self.starts[c + 1] as usize
    }

    /// The rows around a cell of a grid with these dimensions, nearest first.
    fn set_rows(&mut self, dims: [u32; 3]) {
        let (sy, sz) = (dims[0] as isize, dims[0] as isize * dims[1] as isize);
        let mut rows = [Row {
            middle: 0,
            dy: 0,
            dz: 0,
        }; 25];
        for (k, row) in rows.iter_mut().enumerate() {
            let (dy, dz) = (k as i8 % 5 - 2, k as i8 / 5 - 2);
            let middle = isize::from(dy) * sy + isize::from(dz) * sz;
            *row = Row { middle, dy, dz };
        }
        // Squared gap in whole cells (rows whose middle cells touch first), then
        // squared offset.
        let key = |r: &Row| {
            let gap = |v: i8| (v.abs() - 1).max(0).pow(2);
            (gap(r.dy) + gap(r.dz), r.dy * r.dy + r.dz * r.dz, r.middle)
        };
        rows.sort_unstable_by_key(key);
        self.rows.clear();
        self.rows.extend_from_slice(&rows);
        self.forward_rows.clear();
        self.forward_rows
            .extend(rows.iter().filter(|r| r.middle > 0));
    }

    /// Points of sorted range `range` within `eps2` of `p`.
    fn count_in(&self, range: Range<usize>, p: [f64; 3], eps2: f64) -> usize {
        count_within(
            &self.xs[range.clone()],
            &self.ys[range.clone()],
            &self.zs[range],
            p,
            eps2,
        )
    }

    /// For each point of `ps`, appends to its hit list (from its count on) the sorted
    /// positions in `range` of the points within `eps2` of it, computed as `dist2`
    /// computes it. Each point of the range is loaded once for all; the lists are
    /// written branch-free, so each must have room for every point walked.
    fn collect_within(
        &self,
        range: Range<usize>,
        ps: &[[f64; 3]; GROUP],
        eps2: f64,
        hits: &mut [&mut [u32]; GROUP],
        counts: &mut [usize; GROUP],
    ) {
        let base = range.start;
        let xs = &self.xs[range.clone()];
        let (ys, zs) = (&self.ys[range.clone()], &self.zs[range]);
        for (k, ((&x, &y), &z)) in xs.iter().zip(ys).zip(zs).enumerate() {
            let inside = ps.map(|p| dist2(&p, &[x, y, z]) <= eps2);
            for i in 0..GROUP {
                hits[i][counts[i]] = (base + k) as u32;
                counts[i] += usize::from(inside[i]);
            }
        }
    }

    /// Squared gaps (in cells) from sorted point `pos` to the cells around it, per
    /// axis.
    fn gaps_of(&self, pos: usize) -> [[f64; 5]; 3] {
        self.fracs[pos].map(gaps2)
    }

    /// Marks core points and moves them to the front of their cell; records, for every
    /// point that is not core, the points within eps of it (`non_core`, `neighbours`).
    fn find_core_points(&mut self, eps2: f64, min_points: usize) {
        let m = self.cells.len();
        self.core_point.clear();
        self.core_point.resize(self.cell_of_point.len(), false);
        self.non_core.clear();
        self.neighbours.clear();
        self.lonely_cells.clear();
        let mut hits = std::mem::take(&mut self.hits);
        // A hit list never holds more than every point.
        for list in &mut hits {
            if list.len() < self.index.len() {
                list.resize(self.index.len(), 0);
            }
        }
        let mut group = Group::default();
        for k in 0..m {
            let c = self.cells[k] as usize;
            let (begin, end) = (self.first(c), self.first(c + 1));
            if end - begin >= min_points {
                // Every point of the cell is within eps of every other.
                for pos in begin..end {
                    self.core_point[self.index[pos] as usize] = true;
                }
                continue;
            }
            // Points in the 125 cells around: an upper bound on any point's count.
            let reach: usize = self
                .rows
                .iter()
                .map(|r| {
                    let middle = c.wrapping_add_signed(r.middle);
                    self.first(middle + 3) - self.first(middle - 2)
                })
                .sum();
            if reach < min_points {
                // No point here can be core. Few are border points: only those with a
                // core cell in reach, and that is known only once every core point
                // is (`label_border_points`).
                self.lonely_cells.push(k as u32);
                continue;
            }
            for pos in begin..end {
                if group.len == GROUP || (group.len > 0 && c - group.cell[0] > GROUP_SPAN_CELLS) {
                    self.test_group(&group, eps2, min_points, &mut hits);
                    group.len = 0;
                }
                (group.pos[group.len], group.cell[group.len]) = (pos, c);
                group.limit[group.len] = min_points;
                group.len += 1;
            }
        }
        if group.len > 0 {
            self.test_group(&group, eps2, min_points, &mut hits);
        }
        self.hits = hits;
        self.core_count.clear();
        for k in 0..m {
            let c = self.cells[k] as usize;
            let (begin, end) = (self.first(c), self.first(c + 1));
            let core = (begin..end)
                .filter(|&pos| self.core_point[self.index[pos] as usize])
                .count();
            self.core_count.push(core as u32);
            if core > 0 && core < end - begin {
                self.core_first(begin, end);
            }
        }
    }

    /// Marks the core points of `group`, and lists the neighbours of the others.
    fn test_group(
        &mut self,
        group: &Group,
        eps2: f64,
        min_points: usize,
        hits: &mut [Vec<u32>; GROUP],
    ) {
        let counts = self.walk_group(group, eps2, hits);
        for i in 0..group.len {
            let point = self.index[group.pos[i]];
            if counts[i] >= min_points {
                self.core_point[point as usize] = true;
            } else {
                // A point short of min_points walked every cell in reach, so its list
                // is whole.
                let start = self.neighbours.len() as u32;
                for &q in &hits[i][..counts[i]] {
                    self.neighbours.push(self.index[q as usize]);
                }
                self.non_core
                    .push((point, start, self.neighbours.len() as u32));
            }
        }
    }

    /// How many points are within eps of each point of `group`, each counted until it
    /// reaches its limit; the sorted positions of those found are in `hits` (the first
    /// count of each list).
    ///
    /// The points share the walk over the rows around their cells (nearest first, each
    /// row cut to the cells that come within eps of any of them, and scanned once for
    /// all of them). Their cells lie in one row of the grid, so the union of their
    /// spans along a row is one run of cells.
    fn walk_group(&self, group: &Group, eps2: f64, hits: &mut [Vec<u32>; GROUP]) -> [usize; GROUP] {
        // A missing member is a NaN point, within eps of nothing, that needs nothing.
        let mut ps = [[f64::NAN; 3]; GROUP];
        let mut gaps = [[[0.0; 5]; 3]; GROUP];
        let mut shift = [0isize; GROUP];
        let mut limit = [0usize; GROUP];
        let base = group.cell[0];
        for i in 0..group.len {
            let pos = group.pos[i];
            ps[i] = [self.xs[pos], self.ys[pos], self.zs[pos]];
            gaps[i] = self.gaps_of(pos);
            shift[i] = (group.cell[i] - base) as isize;
            limit[i] = group.limit[i];
        }
        let mut counts = [0usize; GROUP];
        let mut lists = hits.each_mut().map(|list| list.as_mut_slice());
        for r in &self.rows {
            let (mut lo, mut hi) = (isize::MAX, isize::MIN);
            for i in 0..GROUP {
                let [gx2, gy2, gz2] = &gaps[i];
                let rest2 = REACH2_CELLS - gy2[(r.dy + 2) as usize] - gz2[(r.dz + 2) as usize];
                if counts[i] < limit[i] && rest2 >= 0.0 {
                    let (l, h) = x_span(gx2, rest2);
                    (lo, hi) = (lo.min(shift[i] + l), hi.max(shift[i] + h));
                }
            }
            if lo > hi {
                continue;
            }
            let middle = base.wrapping_add_signed(r.middle);
            let points = self.first(middle.wrapping_add_signed(lo))
                ..self.first(middle.wrapping_add_signed(hi + 1));
            self.collect_within(points, &ps, eps2, &mut lists, &mut counts);
            if (0..GROUP).all(|i| counts[i] >= limit[i]) {
                break;
            }
        }
        counts
    }

    /// Reorders the sorted points `begin..end` (one cell) so the core ones come first.
    fn core_first(&mut self, begin: usize, end: usize) {
        let (mut a, mut b) = (begin, end);
        loop {
            while a < b && self.core_point[self.index[a] as usize] {
                a += 1;
            }
            while a < b && !self.core_point[self.index[b - 1] as usize] {
                b -= 1;
            }
            if a + 1 >= b {
                return;
            }
            self.xs.swap(a, b - 1);
            self.ys.swap(a, b - 1);
            self.zs.swap(a, b - 1);
            self.fracs.swap(a, b - 1);
            self.index.swap(a, b - 1);
        }
    }

    /// Core points of occupied cell `k`, as a sorted range.
    fn core_range(&self, k: usize) -> Range<usize> {
        let begin = self.first(self.cells[k] as usize);
        begin..begin + self.core_count[k] as usize
    }

    /// Is sorted point `pos` within eps of a core point of occupied cell `j`, `d` cells
    /// away from its own? Cells whose box is out of reach are not scanned.
    fn touches(&self, pos: usize, j: usize, d: [i8; 3], eps2: f64) -> bool {
        let f = self.fracs[pos];
        let gap2 = |frac: f64, d: i8| {
            let g = [1.0 + frac, frac, 0.0, 1.0 - frac, 2.0 - frac][(d + 2) as usize];
            g * g
        };
        if gap2(f[0], d[0]) + gap2(f[1], d[1]) + gap2(f[2], d[2]) > REACH2_CELLS {
            return false;
        }
        let p = [self.xs[pos], self.ys[pos], self.zs[pos]];
        self.count_in(self.core_range(j), p, eps2) > 0
    }

    fn find(&mut self, mut k: usize) -> usize {
        while self.parent[k] as usize != k {
            let up = self.parent[self.parent[k] as usize];
            self.parent[k] = up;
            k = up as usize;
        }
        k
    }

    /// Union-find over the cells with core points, each pair of neighbouring cells
    /// taken once (the forward half of the rows, and the cells after the centre in its
    /// own row) and tested only while its cells are still apart.
    ///
    /// Two passes: the 13 nearest neighbours (offsets -1..=1 on every axis) of every
    /// cell first, then the rest. Nearly every cell joins its component through its
    /// nearest neighbours, so by the second pass most of the farther pairs, whose
    /// points are rarely within eps, are already together. `marks` holds, per dense
    /// cell, a root its cell had at some point (NONE for a cell without core points):
    /// sets only ever merge, so two cells that once had the same root are still
    /// together, and a run of neighbour cells all sharing the centre's root is passed
    /// over in one branch-free sweep.
    fn join_core_cells(&mut self, eps2: f64) {
        let m = self.cells.len();
        self.parent.clear();
        self.parent.extend(0..m as u32);
        let mut marks = std::mem::take(&mut self.marks);
        marks.clear();
        marks.resize(self.occupied_before.len(), NONE);
        for k in 0..m {
            if self.core_count[k] > 0 {
                marks[self.cells[k] as usize] = k as u32;
            }
        }
        let rows = std::mem::take(&mut self.forward_rows);
        let own_row = Row {
            middle: 0,
            dy: 0,
            dz: 0,
        };
        for near in [true, false] {
            for k in 0..m {
                if self.core_count[k] == 0 {
                    continue;
                }
                let c = self.cells[k] as usize;
                let mut mine = self.find(k) as u32;
                marks[c] = mine;
                for row in std::iter::once(&own_row).chain(&rows) {
                    let middle = c.wrapping_add_signed(row.middle);
                    let inner = row.dy.abs() <= 1 && row.dz.abs() <= 1;
                    let (from, to) = match (near, row.middle == 0) {
                        (true, true) => (c + 1, c + 2),
                        (true, false) if inner => (middle - 1, middle + 2),
                        (true, false) => continue,
                        (false, true) => (c + 1, c + 3),
                        (false, false) => (middle - 2, middle + 3),
                    };
                    if marks[from..to]
                        .iter()
                        .fold(true, |all, &r| all & (r == mine || r == NONE))
                    {
                        continue;
                    }
                    for other in from..to {
                        if marks[other] == NONE || marks[other] == mine {
                            continue;
                        }
                        let dx = other.wrapping_sub(middle) as isize as i8;
                        if !near && inner && dx.abs() <= 1 {
                            // Tested in the first pass.
                            continue;
                        }
                        let j = self.occupied_before[other] as usize;
                        let theirs = self.find(j) as u32;
                        marks[other] = theirs;
                        if theirs == mine {
                            continue;
                        }
                        let d = [dx, row.dy, row.dz];
                        if self.core_range(k).any(|pos| self.touches(pos, j, d, eps2)) {
                            // The lower root wins: any fixed rule would do.
                            let (lo, hi) = (mine.min(theirs), mine.max(theirs));
                            self.parent[hi as usize] = lo;
                            mine = lo;
                            (marks[c], marks[other]) = (lo, lo);
                        }
                    }
                }
            }
        }
        self.forward_rows = rows;
        self.marks = marks;
    }

    /// Numbers the components by their lowest core point and labels the core points.
    fn number_clusters(&mut self, labels: &mut [Option<u32>]) -> usize {
        let m = self.cells.len();
        self.cluster.clear();
        self.cluster.resize(m, NONE);
        let mut clusters = 0;
        for (i, label) in labels.iter_mut().enumerate() {
            if !self.core_point[i] {
                continue;
            }
            let cell = self.occupied_before[self.cell_of_point[i] as usize] as usize;
            let root = self.find(cell);
            if self.cluster[root] == NONE {
                self.cluster[root] = clusters;
                clusters += 1;
            }
            *label = Some(self.cluster[root]);
        }
        for k in 0..m {
            if self.core_count[k] > 0 {
                let root = self.find(k);
                self.cluster[k] = self.cluster[root];
                self.marks[self.cells[k] as usize] = self.cluster[k];
            }
        }
        clusters as usize
    }

    /// Gives each non-core point the lowest cluster number among the core points within
    /// eps of it: from its list (`find_core_points`), or for the points of cells too
    /// sparse to have been tested, by a walk when a core cell is in reach.
    fn label_border_points(&mut self, eps2: f64, labels: &mut [Option<u32>]) {
        for &(point, start, end) in &self.non_core {
            let best = self.neighbours[start as usize..end as usize]
                .iter()
                .filter(|&&q| self.core_point[q as usize])
                .filter_map(|&q| labels[q as usize])
                .min();
            if best.is_some() {
                labels[point as usize] = best;
            }
        }
        let mut hits = std::mem::take(&mut self.hits);
        for &k in &self.lonely_cells {
            let c = self.cells[k as usize] as usize;
            let core_in_reach = self.rows.iter().any(|row| {
                let middle = c.wrapping_add_signed(row.middle);
                self.marks[middle - 2..middle + 3]
                    .iter()
                    .any(|&m| m != NONE)
            });
            if !core_in_reach {
                continue;
            }
            let (begin, end) = (self.first(c), self.first(c + 1));
            for start in (begin..end).step_by(GROUP) {
                let mut group = Group::default();
                for pos in start..(start + GROUP).min(end) {
                    (group.pos[group.len], group.cell[group.len]) = (pos, c);
                    group.limit[group.len] = usize::MAX;
                    group.len += 1;
                }
                let counts = self.walk_group(&group, eps2, &mut hits);
                for i in 0..group.len {
                    let best = hits[i][..counts[i]]
                        .iter()
                        .map(|&q| self.index[q as usize] as usize)
                        .filter(|&q| self.core_point[q])
                        .filter_map(|q| labels[q])
                        .min();
                    if best.is_some() {
                        labels[self.index[group.pos[i]] as usize] = best;
                    }
                }
            }
        }
        self.hits = hits;
    }
}
