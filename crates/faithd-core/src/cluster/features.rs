//! The clustering space of the paper: position normalised to 0..1, TTC as a z-score.

/// Writes one `[x, y, ttc]` feature per vector into `out`.
///
/// Positions are divided by the sensor size so both axes span 0..1; TTC becomes
/// `(ttc - mean) / std` so eps means the same whatever the speed of flight. When all
/// TTCs are equal (std 0) the TTC coordinate is 0: the clusters then come from
/// position alone, which is all the data can tell.
pub fn cluster_features(
    xy_px: &[(f64, f64)],
    ttc_s: &[f64],
    width_px: u16,
    height_px: u16,
    out: &mut Vec<[f64; 3]>,
) {
    out.clear();
    let n = xy_px.len().min(ttc_s.len());
    if n == 0 {
        return;
    }
    let mean = ttc_s[..n].iter().sum::<f64>() / n as f64;
    let var = ttc_s[..n]
        .iter()
        .map(|t| (t - mean) * (t - mean))
        .sum::<f64>()
        / n as f64;
    let std = var.sqrt();
    let (sx, sy) = (
        1.0 / (f64::from(width_px) - 1.0).max(1.0),
        1.0 / (f64::from(height_px) - 1.0).max(1.0),
    );
    out.extend(xy_px[..n].iter().zip(&ttc_s[..n]).map(|(&(x, y), &t)| {
        let z = if std > 0.0 { (t - mean) / std } else { 0.0 };
        [x * sx, y * sy, z]
    }));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalises_position_and_ttc() {
        let mut out = Vec::new();
        cluster_features(
            &[(0.0, 0.0), (239.0, 179.0)],
            &[1.0, 3.0],
            240,
            180,
            &mut out,
        );
        let expect = [[0.0, 0.0, -1.0], [1.0, 1.0, 1.0]];
        for (got, want) in out.iter().zip(&expect) {
            for k in 0..3 {
                assert!((got[k] - want[k]).abs() < 1e-12, "{got:?}");
            }
        }
        cluster_features(
            &[(10.0, 10.0), (20.0, 20.0)],
            &[2.0, 2.0],
            240,
            180,
            &mut out,
        );
        assert_eq!(out[0][2], 0.0);
        cluster_features(&[], &[], 240, 180, &mut out);
        assert!(out.is_empty());
    }
}
