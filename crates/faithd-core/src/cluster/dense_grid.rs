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
//! - a border point tries the clusters around it lowest number first and stops at the
//!   first core point within eps;
//! - a point only looks at the cells whose box comes within eps of it (about a third
//!   of the 125 around it).
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

use super::dbscan::dist2;

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

/// Points whose core tests share one walk over the cells around theirs.
const GROUP: usize = 2;

/// For each point of `ps`, the number of points of the slices within `eps2` of it,
/// computed as `dist2` computes it; each point of the slices is loaded once for all.
fn count_within_group(
    xs: &[f64],
    ys: &[f64],
    zs: &[f64],
    ps: &[[f64; 3]; GROUP],
    eps2: f64,
) -> [usize; GROUP] {
    let n = xs.len();
    let (ys, zs) = (&ys[..n], &zs[..n]);
    let mut counts = [0usize; GROUP];
    for k in 0..n {
        let q = [xs[k], ys[k], zs[k]];
        for (count, p) in counts.iter_mut().zip(ps) {
            *count += usize::from(dist2(p, &q) <= eps2);
        }
    }
    counts
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
    /// Candidate clusters of a cell's border points: (cluster, occupied cell, offset).
    candidates: Vec<(u32, u32, [i8; 3])>,
}

impl DenseGrid {
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

    /// Squared gaps (in cells) from sorted point `pos` to the cells around it, per
    /// axis.
    fn gaps_of(&self, pos: usize) -> [[f64; 5]; 3] {
        self.fracs[pos].map(gaps2)
    }

    /// Marks core points and moves them to the front of their cell.
    fn find_core_points(&mut self, eps2: f64, min_points: usize) {
        let m = self.cells.len();
        self.core_count.clear();
        self.core_count.resize(m, 0);
        self.core_point.clear();
        self.core_point.resize(self.cell_of_point.len(), false);
        for k in 0..m {
            let c = self.cells[k] as usize;
            let (begin, end) = (self.first(c), self.first(c + 1));
            if end - begin >= min_points {
                // Every point of the cell is within eps of every other.
                for pos in begin..end {
                    self.core_point[self.index[pos] as usize] = true;
                }
                self.core_count[k] = (end - begin) as u32;
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
                continue;
            }
            let mut core = 0;
            for group in (begin..end).step_by(GROUP) {
                let group = group..(group + GROUP).min(end);
                for (pos, is_core) in group
                    .clone()
                    .zip(self.core_group(c, group, eps2, min_points))
                {
                    if is_core {
                        self.core_point[self.index[pos] as usize] = true;
                        core += 1;
                    }
                }
            }
            self.core_count[k] = core;
            if core > 0 && core < (end - begin) as u32 {
                self.core_first(begin, end);
            }
        }
    }

    /// Which of up to `GROUP` points of cell `c` (sorted positions `group`) are core.
    ///
    /// The points share the walk over the rows around the cell (nearest first, each
    /// row cut to the cells that come within eps of any of them, and scanned once for
    /// all of them), until each has its min_points.
    fn core_group(
        &self,
        c: usize,
        group: Range<usize>,
        eps2: f64,
        min_points: usize,
    ) -> [bool; GROUP] {
        // A NaN point (filling a short group) is within eps of nothing.
        let mut ps = [[f64::NAN; 3]; GROUP];
        let mut gaps = [[[0.0; 5]; 3]; GROUP];
        let mut counts = [min_points; GROUP];
        for (i, pos) in group.enumerate() {
            ps[i] = [self.xs[pos], self.ys[pos], self.zs[pos]];
            gaps[i] = self.gaps_of(pos);
            counts[i] = 0;
        }
        for r in &self.rows {
            let (mut lo, mut hi) = (isize::MAX, isize::MIN);
            for i in 0..GROUP {
                let [gx2, gy2, gz2] = &gaps[i];
                let rest2 = REACH2_CELLS - gy2[(r.dy + 2) as usize] - gz2[(r.dz + 2) as usize];
                if counts[i] < min_points && rest2 >= 0.0 {
                    let (l, h) = x_span(gx2, rest2);
                    (lo, hi) = (lo.min(l), hi.max(h));
                }
            }
            if lo > hi {
                continue;
            }
            let middle = c.wrapping_add_signed(r.middle);
            let points = self.first(middle.wrapping_add_signed(lo))
                ..self.first(middle.wrapping_add_signed(hi + 1));
            let found = count_within_group(
                &self.xs[points.clone()],
                &self.ys[points.clone()],
                &self.zs[points],
                &ps,
                eps2,
            );
            for i in 0..GROUP {
                counts[i] += found[i];
            }
            if counts.iter().all(|&n| n >= min_points) {
                break;
            }
        }
        counts.map(|n| n >= min_points)
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
    /// eps of it.
    fn label_border_points(&mut self, eps2: f64, labels: &mut [Option<u32>]) {
        let mut candidates = std::mem::take(&mut self.candidates);
        for k in 0..self.cells.len() {
            let c = self.cells[k] as usize;
            let (core_end, end) = (self.core_range(k).end, self.first(c + 1));
            if core_end == end {
                continue;
            }
            // The cell's own core points are within eps of all its points.
            let own = if self.core_count[k] > 0 {
                self.cluster[k]
            } else {
                NONE
            };
            candidates.clear();
            for row in &self.rows {
                let middle = c.wrapping_add_signed(row.middle);
                let run = &self.marks[middle - 2..middle + 3];
                // A cell without core points is NONE, never below `own`.
                if run.iter().fold(NONE, |a, &b| a.min(b)) >= own {
                    continue;
                }
                for (dx, &id) in (-2..=2).zip(run) {
                    if id < own {
                        let j = self.occupied_before[middle.wrapping_add_signed(dx as isize)];
                        candidates.push((id, j, [dx, row.dy, row.dz]));
                    }
                }
            }
            candidates.sort_unstable_by_key(|c| (c.0, c.1));
            for pos in core_end..end {
                let best = candidates
                    .iter()
                    .find(|&&(_, j, d)| self.touches(pos, j as usize, d, eps2))
                    .map_or(own, |&(id, _, _)| id);
                if best != NONE {
                    labels[self.index[pos] as usize] = Some(best);
                }
            }
        }
        self.candidates = candidates;
    }
}
