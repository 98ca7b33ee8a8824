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
        normal_flow_px_s(self.a_us_per_px, self.b_us_per_px)
    }
}

/// Fits a plane to `(dx_px, dy_px, dt_us)` points by least squares.
///
/// `None` when the points do not determine a plane (fewer than three, or collinear
/// in the image, which a single row of pixels along an edge would be).
pub fn fit_plane(points: &[(f64, f64, f64)]) -> Option<PlaneFit> {
    let (mut sx, mut sy, mut st) = (0.0, 0.0, 0.0);
    for &(x, y, t) in points {
        sx += x;
        sy += y;
        st += t;
    }
    let plane = Plane::through(points, (sx, sy, st))?;
    Some(plane.fit(plane.residual_squares(points)))
}

/// The least-squares plane of `fit_plane` before its residuals are known: the flow
/// stage takes the fit in these steps so that it can reuse sums it already has and
/// skip what a rejected fit never needs. The steps keep the operations, and their
/// order, of the one-piece fit they were split from (issue 20), so every fit has the
/// same bits as before.
#[derive(Clone, Copy, Debug)]
pub(super) struct Plane {
    pub a_us_per_px: f64,
    pub b_us_per_px: f64,
    pub c_us: f64,
    sxx: f64,
    syy: f64,
    det: f64,
    points: usize,
}

impl Plane {
    /// The plane through `points`, given the sums of their coordinates in point order
    /// (`sum.0` of the x, and so on; sums added in another order may round
    /// differently).
    #[inline(always)]
    pub fn through(points: &[(f64, f64, f64)], sum: (f64, f64, f64)) -> Option<Plane> {
        let n = points.len();
        if n < 3 {
            return None;
        }
        let nf = n as f64;
        // Centre the data so the 2x2 system for (a, b) is well conditioned.
        let (mx, my, mt) = (sum.0 / nf, sum.1 / nf, sum.2 / nf);
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
        Some(Plane {
            a_us_per_px: a,
            b_us_per_px: b,
            c_us: c,
            sxx,
            syy,
            det,
            points: n,
        })
    }

    /// Points the plane was fitted to.
    #[inline(always)]
    pub fn points(&self) -> usize {
        self.points
    }

    /// How far a point's time lies from the plane, microseconds.
    #[inline(always)]
    pub fn residual_us(&self, (x, y, t): (f64, f64, f64)) -> f64 {
        t - (self.a_us_per_px * x + self.b_us_per_px * y + self.c_us)
    }

    /// Sum of the squared residuals of `points`, in point order.
    #[inline(always)]
    pub fn residual_squares(&self, points: &[(f64, f64, f64)]) -> f64 {
        let mut ss = 0.0;
        for &p in points {
            let r = self.residual_us(p);
            ss += r * r;
        }
        ss
    }

    /// Root mean square residual, given the sum of squared residuals.
    #[inline(always)]
    pub fn rms_us(&self, ss: f64) -> f64 {
        (ss / self.points as f64).sqrt()
    }

    /// `PlaneFit::gradient_rel_error`, given the sum of squared residuals.
    #[inline(always)]
    pub fn gradient_rel_error(&self, ss: f64) -> f64 {
        let (a, b) = (self.a_us_per_px, self.b_us_per_px);
        let nf = self.points as f64;
        // Least-squares covariance of (a, b): sigma^2 * inverse of the centred scatter.
        let sigma2 = if self.points > 3 {
            ss / (nf - 3.0)
        } else {
            0.0
        };
        let var_ab = sigma2 * (self.sxx + self.syy) / self.det;
        let grad = (a * a + b * b).sqrt();
        if grad > 0.0 {
            var_ab.sqrt() / grad
        } else {
            f64::INFINITY
        }
    }

    /// `PlaneFit::normal_flow_px_s` of this plane.
    #[inline(always)]
    pub fn normal_flow_px_s(&self) -> Option<(f64, f64)> {
        normal_flow_px_s(self.a_us_per_px, self.b_us_per_px)
    }

    /// The whole fit, given the sum of squared residuals.
    pub fn fit(&self, ss: f64) -> PlaneFit {
        PlaneFit {
            a_us_per_px: self.a_us_per_px,
            b_us_per_px: self.b_us_per_px,
            c_us: self.c_us,
            rms_us: self.rms_us(ss),
            points: self.points,
            gradient_rel_error: self.gradient_rel_error(ss),
        }
    }
}

/// Normal flow in pixels per second from a time gradient in microseconds per pixel.
#[inline(always)]
fn normal_flow_px_s(a_us_per_px: f64, b_us_per_px: f64) -> Option<(f64, f64)> {
    let g2 = a_us_per_px * a_us_per_px + b_us_per_px * b_us_per_px;
    if !(g2 > 0.0 && g2.is_finite()) {
        return None;
    }
    Some((1e6 * a_us_per_px / g2, 1e6 * b_us_per_px / g2))
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
