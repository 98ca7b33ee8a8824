//! DBSCAN (Ester 1996) with a uniform grid index.
//!
//! Two grids give the same labels as the textbook algorithm: a dense one with cells of
//! eps / sqrt(3) (`dense_grid.rs`, every input of the pipeline) and a sparse one with
//! cells of eps (`sorted_grid.rs`, for points spread too widely for a dense array).

use serde::{Deserialize, Serialize};

use super::dense_grid::DenseGrid;
use super::geometry::dist2;
use super::sorted_grid::SortedGrid;

use crate::invalid::{Invalid, check, positive};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DbscanConfig {
    /// Neighbourhood radius in feature units (the paper's 0.2; faithd's 0.15, below).
    pub eps: f64,
    /// Points (the point itself included, scikit-learn's convention) an
    /// eps-neighbourhood needs for its centre to be a core point (the paper's 20).
    pub min_points: usize,
}

/// eps 0.15, not the paper's 0.2: on the ray-traced camera's textured rooms a pole
/// within two seconds merged with the floor and the walls into one cluster wider
/// than any obstacle at 0.2, and was then never rolled on (`faithd sim --straight`,
/// seeds 1-5: 99 of 120 collision courses in time with the earlier rule, 113 with
/// 0.15 and the other changes of docs/tuning.md; 0.12 and 0.1 rolled on 17 and 15
/// of 48 near passes).
impl Default for DbscanConfig {
    fn default() -> Self {
        Self {
            eps: 0.15,
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

/// DBSCAN with reusable buffers: no allocation per call once warmed up.
///
/// The labels are exactly those of Ester's expansion in point order
/// ([`dbscan_brute_force`]); see `dense_grid.rs` for how they are found without it.
pub struct Dbscan {
    config: DbscanConfig,
    dense: DenseGrid,
    /// For inputs the dense grid declines (points spread over millions of cells).
    sparse: SortedGrid,
}

impl Dbscan {
    pub fn new(config: DbscanConfig) -> Self {
        Self::with_capacity(config, 0)
    }

    /// Ready for up to `points` points without allocating on the dense grid (the
    /// pipeline's `max_vectors`): only a spread over more grid cells than before grows
    /// its buffers, and the sparse grid, for inputs spread over millions of cells,
    /// sizes itself as it goes.
    pub fn with_capacity(config: DbscanConfig, points: usize) -> Self {
        Self {
            config,
            dense: DenseGrid::with_capacity(points, config.min_points.max(1)),
            sparse: SortedGrid::default(),
        }
    }

    /// Clusters `points`; `labels[i]` becomes the cluster of point i (numbered 0.. in
    /// order of discovery) or `None` for noise. Returns the number of clusters.
    /// Points with a non-finite coordinate are noise.
    pub fn run(&mut self, points: &[[f64; 3]], labels: &mut Vec<Option<u32>>) -> usize {
        labels.clear();
        labels.resize(points.len(), None);
        let (eps, min_points) = (self.config.eps, self.config.min_points.max(1));
        match self.dense.run(points, eps, min_points, labels) {
            Some(clusters) => clusters,
            None => self.sparse.run(points, eps, min_points, labels),
        }
    }
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
    use crate::cluster::dense_grid::DenseGrid;
    use crate::math;
    use proptest::prelude::*;

    fn blob(cx: f64, cy: f64, cz: f64, n: usize, spread: f64) -> Vec<[f64; 3]> {
        (0..n)
            .map(|i| {
                let a = i as f64 * 2.399;
                let r = spread * ((i % 7) as f64 / 7.0);
                [
                    cx + r * math::cos(a),
                    cy + r * math::sin(a),
                    cz + r * 0.5 * math::sin(a * 0.7),
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

    /// Runs the dense grid alone; `None` when it declines the input.
    fn dense_only(pts: &[[f64; 3]], config: &DbscanConfig) -> Option<Vec<Option<u32>>> {
        let mut labels = vec![None; pts.len()];
        DenseGrid::default()
            .run(pts, config.eps, config.min_points.max(1), &mut labels)
            .map(|_| labels)
    }

    #[test]
    fn pipeline_shaped_features_match_brute_force() {
        for (n, seed, eps, min_points) in [
            (3000, 1, 0.2, 20),
            (2000, 2, 0.2, 20),
            (1500, 3, 0.1, 8),
            (1500, 4, 0.35, 40),
            (800, 5, 0.2, 1),
        ] {
            let pts = crate::synth::pipeline_shaped_features(n, seed);
            let config = DbscanConfig { eps, min_points };
            let reference = dbscan_brute_force(&pts, &config);
            assert_eq!(
                dense_only(&pts, &config).as_ref(),
                Some(&reference),
                "{n} {seed}"
            );
            let mut labels = Vec::new();
            let clusters = Dbscan::new(config).run(&pts, &mut labels);
            assert_eq!(labels, reference);
            let most = reference
                .iter()
                .flatten()
                .max()
                .map_or(0, |&c| c as usize + 1);
            assert_eq!(clusters, most);
        }
    }

    /// Wide inputs go to the sparse grid (and still match); a few far layers do not.
    #[test]
    fn wide_inputs_fall_back_to_the_sparse_grid() {
        let config = DbscanConfig::default();
        let mut pts = crate::synth::pipeline_shaped_features(300, 7);
        // A far point: TTC z-scores of a few outliers reach hundreds of eps, which the
        // compression of empty layers absorbs.
        pts.push([0.5, 0.5, 5000.0]);
        pts.extend((0..25).map(|k| [0.5, 0.5, 5000.0 + 0.001 * f64::from(k)]));
        let reference = dbscan_brute_force(&pts, &config);
        assert_eq!(dense_only(&pts, &config).as_ref(), Some(&reference));
        // Beyond a million cells along an axis: declined, and the facade still matches.
        pts.push([1e7, 0.0, 0.0]);
        let reference = dbscan_brute_force(&pts, &config);
        assert_eq!(dense_only(&pts, &config), None);
        let mut labels = Vec::new();
        Dbscan::new(config).run(&pts, &mut labels);
        assert_eq!(labels, reference);
        // An eps whose square leaves the normal range is declined too.
        let tiny = DbscanConfig {
            eps: 1e-200,
            min_points: 2,
        };
        let same = [[1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [1.0, 2.0, 3.5]];
        assert_eq!(dense_only(&same, &tiny), None);
        Dbscan::new(tiny).run(&same, &mut labels);
        assert_eq!(labels, dbscan_brute_force(&same, &tiny));
        assert_eq!(labels, vec![Some(0), Some(0), None]);
    }

    #[test]
    fn non_finite_points_are_noise_in_the_dense_grid() {
        let config = DbscanConfig {
            eps: 0.2,
            min_points: 3,
        };
        let mut pts = crate::synth::pipeline_shaped_features(200, 8);
        pts[3] = [f64::NAN, 0.1, 0.1];
        pts[50] = [0.1, f64::INFINITY, 0.1];
        pts[77] = [0.1, 0.1, f64::NEG_INFINITY];
        let reference = dbscan_brute_force(&pts, &config);
        assert_eq!(dense_only(&pts, &config).as_ref(), Some(&reference));
        let all_nan = vec![[f64::NAN; 3]; 5];
        assert_eq!(dense_only(&all_nan, &config), Some(vec![None; 5]));
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

        /// Clustered points (dense blobs, duplicates, thin sheets) where cells fill up,
        /// through the dense grid alone.
        #[test]
        fn dense_grid_matches_brute_force_on_clustered_points(
            blobs in prop::collection::vec(
                ((0.0..1.0f64, 0.0..1.0f64, -2.0..2.0f64), 0.0..0.3f64, 1usize..120),
                1..6,
            ),
            seed in 0u64..1000,
            eps in 0.05..0.4f64,
            min_points in 1usize..30,
        ) {
            let mut s = seed;
            let mut rnd = move || {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            };
            let mut pts = Vec::new();
            for ((x, y, z), spread, count) in blobs {
                for k in 0..count {
                    // Every seventh point repeats the last one; every fifth is flat in z.
                    let p = if k % 7 == 6 && !pts.is_empty() {
                        pts[pts.len() - 1]
                    } else {
                        let dz = if k % 5 == 0 { 0.0 } else { spread * rnd() };
                        [x + spread * rnd(), y + spread * rnd(), z + dz]
                    };
                    pts.push(p);
                }
            }
            let config = DbscanConfig { eps, min_points };
            let reference = dbscan_brute_force(&pts, &config);
            prop_assert_eq!(dense_only(&pts, &config), Some(reference));
        }
    }
}
