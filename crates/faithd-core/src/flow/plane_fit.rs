//! Least-squares plane through local event timestamps.

/// A fitted local plane `dt = a*dx + b*dy + c` around an event, in microseconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneFit {
    /// Time gradient along x, microseconds per pixel.
    pub a_us_per_px: f64,
    /// Time gradient along y, microseconds per pixel.
    pub b_us_per_px: f64,
    pub c_us: f64,
    /// Root mean square residual of the points used, microseconds.
    pub rms_us: f64,
    pub points: usize,
    /// Standard error of the gradient (a, b) over its norm: how well the points pin the
    /// edge's speed. Near-flat or scattered patches give values near or above 1.
    pub gradient_rel_error: f64,
}

impl PlaneFit {
    /// Normal flow in pixels per second: the gradient divided by its squared norm.
    pub fn normal_flow_px_s(&self) -> Option<(f64, f64)> {
        let g2 = self.a_us_per_px * self.a_us_per_px + self.b_us_per_px * self.b_us_per_px;
        if !(g2 > 0.0 && g2.is_finite()) {
            return None;
        }
        Some((1e6 * self.a_us_per_px / g2, 1e6 * self.b_us_per_px / g2))
    }
}

/// Fits a plane to `(dx_px, dy_px, dt_us)` points by least squares.
///
/// `None` when the points do not determine a plane (fewer than three, or collinear
/// in the image, which a single row of pixels along an edge would be).
pub fn fit_plane(points: &[(f64, f64, f64)]) -> Option<PlaneFit> {
    let n = points.len();
    if n < 3 {
        return None;
    }
    let nf = n as f64;
    // Centre the data so the 2x2 system for (a, b) is well conditioned.
    let (mut mx, mut my, mut mt) = (0.0, 0.0, 0.0);
    for &(x, y, t) in points {
        mx += x;
        my += y;
        mt += t;
    }
    mx /= nf;
    my /= nf;
    mt /= nf;
    let (mut sxx, mut sxy, mut syy, mut sxt, mut syt) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(x, y, t) in points {
        let (dx, dy, dt) = (x - mx, y - my, t - mt);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
        sxt += dx * dt;
        syt += dy * dt;
    }
    let det = sxx * syy - sxy * sxy;
    // Collinear pixels: the spread across the line is zero.
    if det <= 1e-9 * (sxx + syy).powi(2).max(1e-12) {
        return None;
    }
    let a = (sxt * syy - syt * sxy) / det;
    let b = (syt * sxx - sxt * sxy) / det;
    let c = mt - a * mx - b * my;
    let mut ss = 0.0;
    for &(x, y, t) in points {
        let r = t - (a * x + b * y + c);
        ss += r * r;
    }
    // Least-squares covariance of (a, b): sigma^2 * inverse of the centred scatter.
    let sigma2 = if n > 3 { ss / (nf - 3.0) } else { 0.0 };
    let var_ab = sigma2 * (sxx + syy) / det;
    let grad = (a * a + b * b).sqrt();
    let gradient_rel_error = if grad > 0.0 {
        var_ab.sqrt() / grad
    } else {
        f64::INFINITY
    };
    Some(PlaneFit {
        a_us_per_px: a,
        b_us_per_px: b,
        c_us: c,
        rms_us: (ss / nf).sqrt(),
        points: n,
        gradient_rel_error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_an_exact_plane() {
        let mut pts = Vec::new();
        for y in -2..=2 {
            for x in -2..=2 {
                let (x, y) = (f64::from(x), f64::from(y));
                pts.push((x, y, 100.0 * x - 50.0 * y + 7.0));
            }
        }
        let fit = fit_plane(&pts).unwrap();
        assert!((fit.a_us_per_px - 100.0).abs() < 1e-9);
        assert!((fit.b_us_per_px + 50.0).abs() < 1e-9);
        assert!((fit.c_us - 7.0).abs() < 1e-9);
        assert!(fit.rms_us < 1e-9);
    }

    #[test]
    fn edge_moving_right_at_100_px_s() {
        // 10 ms per pixel along x, constant along y.
        let pts: Vec<_> = (-2..=2)
            .flat_map(|y| {
                (-2..=0).map(move |x| (f64::from(x), f64::from(y), 10_000.0 * f64::from(x)))
            })
            .collect();
        let (u, v) = fit_plane(&pts).unwrap().normal_flow_px_s().unwrap();
        assert!((u - 100.0).abs() < 1e-6 && v.abs() < 1e-6, "{u} {v}");
    }

    #[test]
    fn collinear_points_do_not_fit() {
        let pts: Vec<_> = (0..5).map(|i| (f64::from(i), 0.0, f64::from(i))).collect();
        assert!(fit_plane(&pts).is_none());
        assert!(fit_plane(&pts[..2]).is_none());
    }
}
