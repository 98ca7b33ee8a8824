//! Where an obstacle expands from, measured on the obstacle's own flow.
//!
//! An object at one depth, seen from a translating camera, moves in the image as
//! `(p - F) / tau`; an edge's normal flow is the part of that along its normal `n`:
//! `speed = (nx (x - x_foe) + ny (y - y_foe)) / tau`. On vertical edges that is the
//! horizontal expansion about the FOE's column. A pole the vehicle will pass beside
//! has both its edges moving the same way, so the column it expands about lies
//! outside it; a pole it will hit expands about a column inside it (or, if it only
//! clips it, just beside it). This is evidence the global FOE estimate cannot give:
//! when FAITH's FOE lands on a pole that is passing by, the pole's own flow still
//! says where it expands from.
//!
//! The column and `tau` are fitted by least squares; the FOE's row is FAITH's, as
//! the vertical position of a heading matters far less here than its column. The
//! term in `ny (y - y_foe)` is kept: an edge slanted 25 degrees low on a tall pole
//! moves mostly with the pole's vertical growth, and leaving that out made one such
//! edge (all the vectors a 200 ms refractory flow kept on the pole in some windows)
//! read as a pole sliding sideways. Only normals within 25 degrees of horizontal
//! count: the fit measures the column, which the others say little about.

use crate::flow::FlowVector;

/// A vector counts if its normal is at least this horizontal (cos of 25 degrees):
/// a slanted edge's horizontal flow mixes in the vertical expansion. At cos 45
/// degrees, slanted texture on an obstacle dead ahead biased the fit enough to veto
/// it (tests/pipeline.rs, roll_goes_toward_the_farther_side).
const MIN_HORIZONTAL_NORMAL: f64 = 0.9;
/// Fewer counted vectors than this and nothing is fitted.
const MIN_VECTORS: usize = 12;

/// How an obstacle's own flow expands: `u = (x - centre_x_px) / ttc_s` on a vertical
/// edge.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Expansion {
    /// The column it expands about: where the vehicle is heading, seen from it.
    pub centre_x_px: f64,
    /// Its time to contact from its growth alone (width over rate of widening),
    /// which needs no FOE column: a wrongly placed FOE cannot make it short.
    pub ttc_s: f64,
}

/// How `vectors` expand about a column (the FOE at row `foe_y_px`), or `None` when
/// they are too few, span too few columns, or do not expand.
///
/// The caller passes every vector inside an obstacle's box, not only those DBSCAN put
/// in its cluster: with the FOE misplaced, a pole's two edges get very different TTCs
/// and land in different clusters, and one edge alone shows no expansion.
pub fn expansion<'a>(
    vectors: impl IntoIterator<Item = &'a FlowVector>,
    foe_y_px: f64,
) -> Option<Expansion> {
    // speed = a * p + c * q with p = nx (x - x_ref) + ny (y - foe_y), q = nx,
    // a = 1 / tau and c = (x_ref - centre_x) / tau. Columns are taken from the first
    // counted vector's, so the sums do not cancel.
    let mut x_ref = None;
    let mut n = 0usize;
    let (mut spp, mut spq, mut sqq, mut sps, mut sqs) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let (mut sx, mut sxx) = (0.0, 0.0);
    for v in vectors {
        let Some((nx, ny)) = v.direction() else {
            continue;
        };
        if nx.abs() < MIN_HORIZONTAL_NORMAL {
            continue;
        }
        let x_ref = *x_ref.get_or_insert(v.x_px);
        let speed = v.u_px_s * nx + v.v_px_s * ny;
        let dx = v.x_px - x_ref;
        let p = nx * dx + ny * (v.y_px - foe_y_px);
        n += 1;
        spp += p * p;
        spq += p * nx;
        sqq += nx * nx;
        sps += p * speed;
        sqs += nx * speed;
        sx += dx;
        sxx += dx * dx;
    }
    let x_ref = x_ref?;
    if n < MIN_VECTORS {
        return None;
    }
    // Vectors along one column give no slope.
    let nf = n as f64;
    if sxx / nf - (sx / nf) * (sx / nf) < 1.0 {
        return None;
    }
    let det = spp * sqq - spq * spq;
    if det <= 1e-9 * spp * sqq {
        return None;
    }
    let a = (sps * sqq - sqs * spq) / det;
    let c = (sqs * spp - sps * spq) / det;
    if a <= 0.0 {
        return None;
    }
    Some(Expansion {
        centre_x_px: x_ref - c / a,
        ttc_s: 1.0 / a,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math;

    /// Vertical-edge vectors of a pole between `x0` and `x1` at time to contact
    /// `tau_s`, FOE at column `foe_x`.
    fn pole(foe_x: f64, x0: f64, x1: f64, tau_s: f64) -> Vec<FlowVector> {
        let mut out = Vec::new();
        for k in 0..40 {
            let x = x0 + (x1 - x0) * f64::from(k % 10) / 9.0;
            let y = 40.0 + f64::from(k);
            out.push(FlowVector::new(0, x, y, (x - foe_x) / tau_s, 0.0));
        }
        out
    }

    #[test]
    fn a_pole_expands_from_the_foe_column() {
        for foe_x in [60.0, 100.0, 118.0, 180.0] {
            let vectors = pole(foe_x, 100.0, 130.0, 1.5);
            let e = expansion(&vectors, 80.0).unwrap();
            assert!((e.centre_x_px - foe_x).abs() < 1e-6, "{e:?} vs {foe_x}");
            assert!((e.ttc_s - 1.5).abs() < 1e-9, "{e:?}");
        }
    }

    #[test]
    fn too_few_flat_or_receding_vectors_say_nothing() {
        let vectors = pole(110.0, 100.0, 130.0, 1.5);
        assert_eq!(expansion(&vectors[..5], 80.0), None);
        let column = pole(110.0, 120.0, 120.0, 1.5);
        assert_eq!(expansion(&column, 80.0), None);
        let receding = pole(110.0, 100.0, 130.0, -1.5);
        assert_eq!(expansion(&receding, 80.0), None);
        // Vertical normals (horizontal edges) are left out.
        let horizontal: Vec<_> = vectors
            .iter()
            .map(|v| FlowVector::new(0, v.x_px, v.y_px, 1.0, 50.0))
            .collect();
        assert_eq!(expansion(&horizontal, 80.0), None);
    }

    /// A slanted edge low on a tall pole: its normal flow is mostly the pole's
    /// vertical growth. Fitted as horizontal expansion alone, it read as a pole
    /// sliding sideways (what a 200 ms refractory flow kept of the daemon's simulated
    /// pole in some windows: one such edge, every vector moving left).
    #[test]
    fn a_slanted_edge_low_on_a_pole_expands_from_the_foe_column() {
        let (foe_x, foe_y, tau_s) = (128.0, 86.0, 0.84);
        let normal_deg: f64 = 155.0;
        let (nx, ny) = (
            math::cos(normal_deg.to_radians()),
            math::sin(normal_deg.to_radians()),
        );
        let vectors: Vec<FlowVector> = (0..30)
            .map(|k| {
                let (x, y) = (112.0 + f64::from(k), 120.0 + 2.0 * f64::from(k));
                let speed = (nx * (x - foe_x) + ny * (y - foe_y)) / tau_s;
                FlowVector::new(0, x, y, speed * nx, speed * ny)
            })
            .collect();
        assert!(vectors.iter().all(|v| v.u_px_s < 0.0), "all move left");
        let e = expansion(&vectors, foe_y).unwrap();
        assert!((e.centre_x_px - foe_x).abs() < 1e-6, "{e:?}");
        assert!((e.ttc_s - tau_s).abs() < 1e-9, "{e:?}");
    }
}
