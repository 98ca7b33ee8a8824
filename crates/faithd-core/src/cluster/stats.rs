//! Per-cluster summaries: what the decision and the log need to know of a cluster.

use serde::Serialize;

#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ClusterStats {
    pub id: u32,
    pub count: usize,
    pub mean_ttc_s: f64,
    pub centroid_x_px: f64,
    pub centroid_y_px: f64,
    pub min_x_px: f64,
    pub max_x_px: f64,
    pub min_y_px: f64,
    pub max_y_px: f64,
    /// How the cluster's own flow expands, when measurable (see
    /// [`super::expansion`]); filled in by the pipeline.
    pub expansion: Option<super::Expansion>,
}

/// Fills `out` with one entry per cluster id present in `labels`, in id order.
pub fn cluster_stats(
    xy_px: &[(f64, f64)],
    ttc_s: &[f64],
    labels: &[Option<u32>],
    out: &mut Vec<ClusterStats>,
) {
    out.clear();
    for ((&(x, y), &t), label) in xy_px.iter().zip(ttc_s).zip(labels) {
        let Some(id) = *label else { continue };
        let id_usize = id as usize;
        while out.len() <= id_usize {
            out.push(ClusterStats {
                id: out.len() as u32,
                count: 0,
                mean_ttc_s: 0.0,
                centroid_x_px: 0.0,
                centroid_y_px: 0.0,
                min_x_px: f64::INFINITY,
                max_x_px: f64::NEG_INFINITY,
                min_y_px: f64::INFINITY,
                max_y_px: f64::NEG_INFINITY,
                expansion: None,
            });
        }
        let c = &mut out[id_usize];
        c.count += 1;
        c.mean_ttc_s += t;
        c.centroid_x_px += x;
        c.centroid_y_px += y;
        c.min_x_px = c.min_x_px.min(x);
        c.max_x_px = c.max_x_px.max(x);
        c.min_y_px = c.min_y_px.min(y);
        c.max_y_px = c.max_y_px.max(y);
    }
    out.retain(|c| c.count > 0);
    for c in out.iter_mut() {
        let n = c.count as f64;
        c.mean_ttc_s /= n;
        c.centroid_x_px /= n;
        c.centroid_y_px /= n;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summarises_each_cluster() {
        let xy = [(10.0, 20.0), (30.0, 40.0), (100.0, 100.0), (5.0, 5.0)];
        let ttc = [1.0, 2.0, 5.0, 9.0];
        let labels = [Some(0), Some(0), Some(1), None];
        let mut out = Vec::new();
        cluster_stats(&xy, &ttc, &labels, &mut out);
        assert_eq!(out.len(), 2);
        assert_eq!(out[0].count, 2);
        assert_eq!(out[0].mean_ttc_s, 1.5);
        assert_eq!((out[0].centroid_x_px, out[0].centroid_y_px), (20.0, 30.0));
        assert_eq!((out[0].min_x_px, out[0].max_x_px), (10.0, 30.0));
        assert_eq!(out[1].mean_ttc_s, 5.0);
    }
}
