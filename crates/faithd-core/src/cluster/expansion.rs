//! Where an obstacle expands from, measured on the obstacle's own flow.
//!
//! An object at one depth, seen from a translating camera, moves in the image as
//! `u = (x - x_foe) / tau`: the horizontal flow of its vertical edges is a straight
//! line in `x` that crosses zero at the FOE's column. A pole the vehicle will pass
//! beside has both its edges moving the same way, so that line crosses zero outside
//! it; a pole it will hit expands about a column inside it (or, if it only clips it,
//! just beside it). This is evidence the global FOE estimate cannot give: when
//! FAITH's FOE lands on a pole that is passing by, the pole's own flow still says
//! where it expands from.
//!
//! Only near-vertical edges count, and the fit uses the horizontal part of their
//! normal flow. The exact model of a slanted edge's normal flow adds a term in
//! `(y - y_foe) * ny`; on a tall pole the error of the measured normal direction times
//! that lever arm outweighed what it recovers (in `faithd sim --straight`, seeds 1-8,
//! the exact model rolled in time on 443 of 480 collision courses, this one on 473).

use crate::flow::FlowVector;

/// A vector counts if its normal is at least this horizontal (cos of 25 degrees):
/// a slanted edge's horizontal flow mixes in the vertical expansion. At cos 45
/// degrees, slanted texture on an obstacle dead ahead biased the fit enough to veto
/// it (tests/pipeline.rs, roll_goes_toward_the_farther_side).
const MIN_HORIZONTAL_NORMAL: f64 = 0.9;
/// Fewer counted vectors than this and nothing is fitted.
const MIN_VECTORS: usize = 12;

/// How an obstacle's own flow expands: `u = (x - centre_x_px) / ttc_s`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Expansion {
    /// The column it expands about: where the vehicle is heading, seen from it.
    pub centre_x_px: f64,
    /// Its time to contact from its growth alone (width over rate of widening),
    /// which needs no FOE: a wrongly placed FOE cannot make it short.
    pub ttc_s: f64,
}

/// How `vectors` expand (`u = a * (x - x0)` by least squares, `a > 0`), or `None`
/// when they are too few, span too few columns, or do not expand.
///
/// The caller passes every vector inside an obstacle's box, not only those DBSCAN put
/// in its cluster: with the FOE misplaced, a pole's two edges get very different TTCs
/// and land in different clusters, and one edge alone shows no expansion.
pub fn expansion<'a>(vectors: impl IntoIterator<Item = &'a FlowVector>) -> Option<Expansion> {
    let (mut n, mut sx, mut su, mut sxx, mut sxu) = (0usize, 0.0, 0.0, 0.0, 0.0);
    for v in vectors {
        let Some((nx, _)) = v.direction() else {
            continue;
        };
        if nx.abs() < MIN_HORIZONTAL_NORMAL {
            continue;
        }
        n += 1;
        sx += v.x_px;
        su += v.u_px_s;
        sxx += v.x_px * v.x_px;
        sxu += v.x_px * v.u_px_s;
    }
    if n < MIN_VECTORS {
        return None;
    }
    let nf = n as f64;
    let (mean_x, mean_u) = (sx / nf, su / nf);
    let var_x = sxx / nf - mean_x * mean_x;
    // Vectors along one column give no slope.
    if var_x < 1.0 {
        return None;
    }
    let slope = (sxu / nf - mean_x * mean_u) / var_x;
    if slope <= 0.0 {
        return None;
    }
    Some(Expansion {
        centre_x_px: mean_x - mean_u / slope,
        ttc_s: 1.0 / slope,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

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
            let e = expansion(&vectors).unwrap();
            assert!((e.centre_x_px - foe_x).abs() < 1e-6, "{e:?} vs {foe_x}");
            assert!((e.ttc_s - 1.5).abs() < 1e-9, "{e:?}");
        }
    }

    #[test]
    fn too_few_flat_or_receding_vectors_say_nothing() {
        let vectors = pole(110.0, 100.0, 130.0, 1.5);
        assert_eq!(expansion(&vectors[..5]), None);
        let column = pole(110.0, 120.0, 120.0, 1.5);
        assert_eq!(expansion(&column), None);
        let receding = pole(110.0, 100.0, 130.0, -1.5);
        assert_eq!(expansion(&receding), None);
        // Vertical normals (horizontal edges) are left out.
        let horizontal: Vec<_> = vectors
            .iter()
            .map(|v| FlowVector::new(0, v.x_px, v.y_px, 1.0, 50.0))
            .collect();
        assert_eq!(expansion(&horizontal), None);
    }
}
