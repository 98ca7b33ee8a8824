//! DBSCAN on a sparse grid (cells of side eps, sorted and binary-searched): the
//! fallback for inputs the dense grid (`dense_grid.rs`) declines.
//!
//! It needs no bound on the coordinates: far-apart points cost nothing, and coordinates
//! beyond the i32 range of cells are clamped. The pipeline's features never come here
//! (x and y span 0..1, and a z-score of n values stays within sqrt(n)); points spread
//! over more than a million cells, or an eps beyond 1e+-150, do.
//!
//! This is the algorithm faithd used for every input before the dense grid: Ester's
//! expansion with a stack, the core test counting only up to min_points, and an
//! expansion that only looks at cells still holding unlabelled points.

use super::geometry::dist2;

type CellKey = (i32, i32, i32);

/// The sparse grid with reusable buffers: no allocation per call once warmed up.
#[derive(Default)]
pub(super) struct SortedGrid {
    eps: f64,
    /// (cell, point index), sorted.
    entries: Vec<(CellKey, u32)>,
    /// Coordinates in cell order, so a cell's points are scanned contiguously.
    sorted: Vec<[f64; 3]>,
    /// Distinct cells with their range in `entries`.
    cells: Vec<(CellKey, u32, u32)>,
    /// For each cell, the range of its neighbour cells (itself included) in `adjacent`.
    adjacent_range: Vec<(u32, u32)>,
    adjacent: Vec<u32>,
    /// Cell of each point (by point index); u32::MAX for a non-finite point.
    cell_of_point: Vec<u32>,
    /// Points of each cell still without a label.
    unlabelled: Vec<u32>,
    visited: Vec<bool>,
    stack: Vec<u32>,
}

impl SortedGrid {
    /// Grid cell of a point; `None` only for a non-finite coordinate.
    ///
    /// Cells are a hair wider than eps so that rounding in the division can never put
    /// two points within eps of each other two cells apart. Coordinates beyond the i32
    /// range are clamped: that can only merge far-apart cells, never split neighbours,
    /// so the labels still equal the brute-force reference.
    fn cell_of(&self, p: &[f64; 3]) -> Option<CellKey> {
        let side = self.eps.max(f64::MIN_POSITIVE) * (1.0 + 1e-9);
        let k = |v: f64| {
            v.is_finite()
                .then(|| (v / side).floor().clamp(-1e9, 1e9) as i32)
        };
        Some((k(p[0])?, k(p[1])?, k(p[2])?))
    }

    fn build_index(&mut self, points: &[[f64; 3]]) {
        self.entries.clear();
        for (i, p) in points.iter().enumerate() {
            if let Some(key) = self.cell_of(p) {
                self.entries.push((key, i as u32));
            }
        }
        self.entries.sort_unstable();
        self.sorted.clear();
        self.sorted
            .extend(self.entries.iter().map(|&(_, i)| points[i as usize]));
        self.cell_of_point.clear();
        self.cell_of_point.resize(points.len(), u32::MAX);
        self.cells.clear();
        let mut start = 0;
        while start < self.entries.len() {
            let key = self.entries[start].0;
            let mut end = start + 1;
            while end < self.entries.len() && self.entries[end].0 == key {
                end += 1;
            }
            for &(_, i) in &self.entries[start..end] {
                self.cell_of_point[i as usize] = self.cells.len() as u32;
            }
            self.cells.push((key, start as u32, end as u32));
            start = end;
        }
        self.unlabelled.clear();
        self.unlabelled
            .extend(self.cells.iter().map(|&(_, s, e)| e - s));
        self.adjacent.clear();
        self.adjacent_range.clear();
        for c in 0..self.cells.len() {
            let (cx, cy, cz) = self.cells[c].0;
            let first = self.adjacent.len() as u32;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let key = (cx + dx, cy + dy, cz + dz);
                        if let Ok(n) = self.cells.binary_search_by(|cell| cell.0.cmp(&key)) {
                            self.adjacent.push(n as u32);
                        }
                    }
                }
            }
            self.adjacent_range
                .push((first, self.adjacent.len() as u32));
        }
    }

    /// Is point `i` a core point? Counts neighbours (itself included) up to min_points.
    fn is_core(&self, points: &[[f64; 3]], i: usize, min_points: usize) -> bool {
        let cell = self.cell_of_point[i];
        if cell == u32::MAX {
            return false;
        }
        let p = &points[i];
        let eps2 = self.eps * self.eps;
        let (a, b) = self.adjacent_range[cell as usize];
        let mut count = 0;
        for &n in &self.adjacent[a as usize..b as usize] {
            let (_, start, end) = self.cells[n as usize];
            for q in &self.sorted[start as usize..end as usize] {
                count += usize::from(dist2(p, q) <= eps2);
            }
            if count >= min_points {
                return true;
            }
        }
        false
    }

    /// Gives every unlabelled point within eps of core point `i` the label `id`, and
    /// queues those not yet visited (a visited one was found not to be core).
    fn claim(&mut self, points: &[[f64; 3]], i: usize, labels: &mut [Option<u32>], id: u32) {
        let cell = self.cell_of_point[i];
        let p = &points[i];
        let eps2 = self.eps * self.eps;
        let (a, b) = self.adjacent_range[cell as usize];
        for k in a..b {
            let n = self.adjacent[k as usize] as usize;
            if self.unlabelled[n] == 0 {
                continue;
            }
            let (_, start, end) = self.cells[n];
            for e in start as usize..end as usize {
                let r = self.entries[e].1 as usize;
                if labels[r].is_none() && dist2(p, &self.sorted[e]) <= eps2 {
                    labels[r] = Some(id);
                    self.unlabelled[n] -= 1;
                    if !self.visited[r] {
                        self.stack.push(r as u32);
                    }
                }
            }
        }
    }

    /// Clusters `points` into `labels` (already `None`, one per point); returns the
    /// number of clusters.
    pub(super) fn run(
        &mut self,
        points: &[[f64; 3]],
        eps: f64,
        min_points: usize,
        labels: &mut [Option<u32>],
    ) -> usize {
        self.eps = eps;
        let n = points.len();
        self.visited.clear();
        self.visited.resize(n, false);
        self.build_index(points);
        let mut clusters = 0u32;
        for i in 0..n {
            if self.visited[i] {
                continue;
            }
            self.visited[i] = true;
            if !self.is_core(points, i, min_points) {
                continue;
            }
            let id = clusters;
            clusters += 1;
            if labels[i].is_none() {
                labels[i] = Some(id);
                self.unlabelled[self.cell_of_point[i] as usize] -= 1;
            }
            self.stack.clear();
            self.claim(points, i, labels, id);
            while let Some(q) = self.stack.pop() {
                let q = q as usize;
                if self.visited[q] {
                    continue;
                }
                self.visited[q] = true;
                if self.is_core(points, q, min_points) {
                    self.claim(points, q, labels, id);
                }
            }
        }
        clusters as usize
    }
}
