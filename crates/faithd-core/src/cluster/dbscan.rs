//! DBSCAN (Ester 1996) with a uniform grid index.
//!
//! Cells have side eps, so every neighbour of a point lies in its own cell or one of
//! the 26 around it. Points are sorted by cell once per call and cells are found by
//! binary search, which needs no bound on the (unbounded) TTC axis and no hashing.

use serde::{Deserialize, Serialize};

use crate::invalid::{Invalid, check, positive};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DbscanConfig {
    /// Neighbourhood radius in feature units (the paper's 0.2).
    pub eps: f64,
    /// Points (the point itself included, scikit-learn's convention) an
    /// eps-neighbourhood needs for its centre to be a core point (the paper's 20).
    pub min_points: usize,
}

impl Default for DbscanConfig {
    fn default() -> Self {
        Self {
            eps: 0.2,
            min_points: 20,
        }
    }
}

impl DbscanConfig {
    /// `[pipeline.cluster]`: DBSCAN's radius and density.
    pub fn validate(&self) -> Result<(), Invalid> {
        positive(self.eps, "pipeline.cluster.eps")?;
        check(self.min_points >= 1, "pipeline.cluster.min_points", || {
            "must be at least 1".into()
        })?;
        Ok(())
    }
}

type CellKey = (i32, i32, i32);

/// DBSCAN with reusable buffers: no allocation per call once warmed up.
///
/// Two observations keep dense windows cheap without changing a single label: the
/// core test only needs to count up to min_points, and a cluster's expansion only
/// needs to look at cells that still hold unlabelled points.
pub struct Dbscan {
    config: DbscanConfig,
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

impl Dbscan {
    pub fn new(config: DbscanConfig) -> Self {
        Self {
            config,
            entries: Vec::new(),
            sorted: Vec::new(),
            cells: Vec::new(),
            adjacent_range: Vec::new(),
            adjacent: Vec::new(),
            cell_of_point: Vec::new(),
            unlabelled: Vec::new(),
            visited: Vec::new(),
            stack: Vec::new(),
        }
    }

    /// Grid cell of a point; `None` only for a non-finite coordinate.
    ///
    /// Cells are a hair wider than eps so that rounding in the division can never put
    /// two points within eps of each other two cells apart. Coordinates beyond the i32
    /// range are clamped: that can only merge far-apart cells, never split neighbours,
    /// so the labels still equal the brute-force reference.
    fn cell_of(&self, p: &[f64; 3]) -> Option<CellKey> {
        let side = self.config.eps.max(f64::MIN_POSITIVE) * (1.0 + 1e-9);
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
        let eps2 = self.config.eps * self.config.eps;
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
        let eps2 = self.config.eps * self.config.eps;
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

    /// Clusters `points`; `labels[i]` becomes the cluster of point i (numbered 0.. in
    /// order of discovery) or `None` for noise. Returns the number of clusters.
    /// Points with a non-finite coordinate are noise.
    pub fn run(&mut self, points: &[[f64; 3]], labels: &mut Vec<Option<u32>>) -> usize {
        let n = points.len();
        labels.clear();
        labels.resize(n, None);
        self.visited.clear();
        self.visited.resize(n, false);
        self.build_index(points);
        let min_points = self.config.min_points.max(1);
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

fn dist2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let (dx, dy, dz) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    dx * dx + dy * dy + dz * dz
}

/// The textbook O(n^2) algorithm with the same visiting order: the reference that the
/// grid version must match label for label.
#[doc(hidden)]
pub fn dbscan_brute_force(points: &[[f64; 3]], config: &DbscanConfig) -> Vec<Option<u32>> {
    let n = points.len();
    let finite = |p: &[f64; 3]| p.iter().all(|v| v.is_finite());
    let eps2 = config.eps * config.eps;
    let region = |i: usize| -> Vec<usize> {
        if !finite(&points[i]) {
            return Vec::new();
        }
        (0..n)
            .filter(|&j| finite(&points[j]) && dist2(&points[i], &points[j]) <= eps2)
            .collect()
    };
    let mut labels = vec![None; n];
    let mut visited = vec![false; n];
    let mut clusters = 0;
    for i in 0..n {
        if visited[i] {
            continue;
        }
        visited[i] = true;
        let seeds = region(i);
        if seeds.len() < config.min_points.max(1) {
            continue;
        }
        labels[i] = Some(clusters);
        let mut queue = seeds;
        while let Some(q) = queue.pop() {
            if labels[q].is_none() {
                labels[q] = Some(clusters);
            }
            if visited[q] {
                continue;
            }
            visited[q] = true;
            let more = region(q);
            if more.len() >= config.min_points.max(1) {
                queue.extend(more);
            }
        }
        clusters += 1;
    }
    labels
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn blob(cx: f64, cy: f64, cz: f64, n: usize, spread: f64) -> Vec<[f64; 3]> {
        (0..n)
            .map(|i| {
                let a = i as f64 * 2.399;
                let r = spread * ((i % 7) as f64 / 7.0);
                [
                    cx + r * a.cos(),
                    cy + r * a.sin(),
                    cz + r * 0.5 * (a * 0.7).sin(),
                ]
            })
            .collect()
    }

    #[test]
    fn two_blobs_and_noise() {
        let mut pts = blob(0.2, 0.2, 0.0, 30, 0.05);
        pts.extend(blob(0.8, 0.7, 1.0, 25, 0.05));
        pts.push([5.0, 5.0, 5.0]);
        pts.push([f64::NAN, 0.2, 0.0]);
        let mut labels = Vec::new();
        let n = Dbscan::new(DbscanConfig::default()).run(&pts, &mut labels);
        assert_eq!(n, 2);
        assert!(labels[..30].iter().all(|l| *l == Some(0)));
        assert!(labels[30..55].iter().all(|l| *l == Some(1)));
        assert_eq!(labels[55], None);
        assert_eq!(labels[56], None);
        assert_eq!(labels, dbscan_brute_force(&pts, &DbscanConfig::default()));
    }

    #[test]
    fn far_away_points_cluster_as_in_the_reference() {
        let config = DbscanConfig {
            eps: 0.2,
            min_points: 2,
        };
        let pts = [[1e12, 0.0, 0.0], [1e12, 0.0, 0.0], [-1e12, 5.0, 0.0]];
        let mut labels = Vec::new();
        Dbscan::new(config).run(&pts, &mut labels);
        assert_eq!(labels, vec![Some(0), Some(0), None]);
        assert_eq!(labels, dbscan_brute_force(&pts, &config));
    }

    #[test]
    fn min_points_counts_the_point_itself() {
        let config = DbscanConfig {
            eps: 0.2,
            min_points: 3,
        };
        let three = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0]];
        let mut labels = Vec::new();
        assert_eq!(Dbscan::new(config).run(&three, &mut labels), 1);
        assert_eq!(Dbscan::new(config).run(&three[..2], &mut labels), 0);
        assert_eq!(labels, vec![None, None]);
        assert_eq!(Dbscan::new(config).run(&[], &mut labels), 0);
        assert!(labels.is_empty());
    }

    #[test]
    fn border_point_joins_the_first_cluster_that_reaches_it() {
        let config = DbscanConfig {
            eps: 0.16,
            min_points: 4,
        };
        // Two dense groups and one point between them that is not core itself.
        let pts = [
            [0.0, 0.0, 0.0],
            [0.05, 0.0, 0.0],
            [0.1, 0.0, 0.0],
            [0.15, 0.0, 0.0],
            [0.3, 0.0, 0.0], // border: 3 points within eps, reachable from both groups
            [0.45, 0.0, 0.0],
            [0.5, 0.0, 0.0],
            [0.55, 0.0, 0.0],
            [0.6, 0.0, 0.0],
        ];
        let mut labels = Vec::new();
        assert_eq!(Dbscan::new(config).run(&pts, &mut labels), 2);
        assert_eq!(labels[4], Some(0));
        assert_eq!(labels[5], Some(1));
        assert_eq!(labels, dbscan_brute_force(&pts, &config));
    }

    #[test]
    fn five_thousand_points_match_brute_force() {
        let mut pts = Vec::new();
        let mut s = 12345u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for k in 0..5000 {
            let (cx, cy, cz) = match k % 4 {
                0 => (0.2, 0.3, -1.0),
                1 => (0.7, 0.6, 0.5),
                2 => (0.5, 0.5, 2.0),
                _ => (rnd(), rnd(), rnd() * 6.0 - 3.0),
            };
            pts.push([cx + 0.1 * rnd(), cy + 0.1 * rnd(), cz + 0.3 * rnd()]);
        }
        let mut labels = Vec::new();
        Dbscan::new(DbscanConfig::default()).run(&pts, &mut labels);
        assert_eq!(labels, dbscan_brute_force(&pts, &DbscanConfig::default()));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Points on a lattice put many pairs at exactly eps and on cell boundaries,
        /// where a grid and the brute-force reference are most likely to disagree.
        #[test]
        fn grid_matches_brute_force_on_a_lattice(
            pts in prop::collection::vec((0i32..20, 0i32..20, -20i32..20), 0..300),
            step in prop::sample::select(vec![0.05f64, 0.1, 0.2]),
            min_points in 1usize..12,
        ) {
            let pts: Vec<[f64; 3]> = pts
                .into_iter()
                .map(|(a, b, c)| [f64::from(a) * step, f64::from(b) * step, f64::from(c) * step])
                .collect();
            let config = DbscanConfig { eps: 0.2, min_points };
            let mut labels = Vec::new();
            Dbscan::new(config).run(&pts, &mut labels);
            prop_assert_eq!(labels, dbscan_brute_force(&pts, &config));
        }

        #[test]
        fn grid_matches_brute_force(
            pts in prop::collection::vec((0.0..1.0f64, 0.0..1.0f64, -2.0..2.0f64), 0..300),
            eps in 0.05..0.4f64,
            min_points in 1usize..25,
        ) {
            let pts: Vec<[f64; 3]> = pts.into_iter().map(|(a, b, c)| [a, b, c]).collect();
            let config = DbscanConfig { eps, min_points };
            let mut labels = Vec::new();
            Dbscan::new(config).run(&pts, &mut labels);
            prop_assert_eq!(labels, dbscan_brute_force(&pts, &config));
        }
    }
}
