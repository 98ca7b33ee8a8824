//! Convex polygons cut by half-planes: the exact geometry under FAITH.
//!
//! The FOE area of one RANSAC iteration is the intersection of a few negative
//! half-planes. Keeping it as an explicit convex polygon (rather than a pixel mask or a
//! bounding box) makes its area and centroid exact and costs a few vertices per cut.

use crate::math;

/// The closed half-plane `{ q : nx * q.x + ny * q.y <= c }`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfPlane {
    pub nx: f64,
    pub ny: f64,
    pub c: f64,
}

impl HalfPlane {
    /// The negative half-plane of a flow vector: the side of the line through its origin,
    /// orthogonal to it, that the vector points away from. `None` for a zero or
    /// non-finite vector, which says nothing about the FOE.
    pub fn behind(x_px: f64, y_px: f64, u: f64, v: f64) -> Option<Self> {
        // sqrt rather than hypot: flow speeds never approach overflow, and hypot is a
        // slow library call on the hot path (one per vector per window).
        let len = (u * u + v * v).sqrt();
        if !(len > 0.0 && len.is_finite() && x_px.is_finite() && y_px.is_finite()) {
            return None;
        }
        let inv_len = 1.0 / len;
        let (nx, ny) = (u * inv_len, v * inv_len);
        Some(Self {
            nx,
            ny,
            c: nx * x_px + ny * y_px,
        })
    }

    /// Signed distance of a point beyond the boundary (positive = outside).
    pub fn excess(&self, x: f64, y: f64) -> f64 {
        self.nx * x + self.ny * y - self.c
    }

    pub fn contains(&self, x: f64, y: f64) -> bool {
        self.excess(x, y) <= 0.0
    }
}

/// A convex polygon as its vertex list in order (either winding).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ConvexPolygon {
    vertices: Vec<(f64, f64)>,
}

impl ConvexPolygon {
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            vertices: Vec::with_capacity(capacity),
        }
    }

    /// Axis-aligned rectangle from (x0, y0) to (x1, y1).
    pub fn rectangle(x0: f64, y0: f64, x1: f64, y1: f64) -> Self {
        let mut p = Self::with_capacity(16);
        p.set_rectangle(x0, y0, x1, y1);
        p
    }

    /// Overwrites this polygon with a rectangle, keeping its allocation.
    pub fn set_rectangle(&mut self, x0: f64, y0: f64, x1: f64, y1: f64) {
        self.vertices.clear();
        self.vertices
            .extend_from_slice(&[(x0, y0), (x1, y0), (x1, y1), (x0, y1)]);
    }

    pub fn vertices(&self) -> &[(f64, f64)] {
        &self.vertices
    }

    /// Fewer than three vertices: the intersection is empty (or degenerate).
    pub fn is_empty(&self) -> bool {
        self.vertices.len() < 3
    }

    pub fn copy_from(&mut self, other: &ConvexPolygon) {
        self.vertices.clear();
        self.vertices.extend_from_slice(&other.vertices);
    }

    /// Writes `self ∩ half` into `out` (one Sutherland-Hodgman pass; convexity is kept).
    pub fn clip_into(&self, half: &HalfPlane, out: &mut ConvexPolygon) {
        out.vertices.clear();
        let n = self.vertices.len();
        if n < 3 {
            return;
        }
        // Each vertex's excess once (the same value for both edges it ends), and the
        // next vertex without a `%`: an integer division per edge cost as much as the
        // rest of the pass.
        let first = self.vertices[0];
        let first_excess = half.excess(first.0, first.1);
        let (mut a, mut da) = (first, first_excess);
        for i in 0..n {
            let (b, db) = if i + 1 == n {
                (first, first_excess)
            } else {
                let b = self.vertices[i + 1];
                (b, half.excess(b.0, b.1))
            };
            if da <= 0.0 {
                out.vertices.push(a);
            }
            if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
                let s = da / (da - db);
                out.vertices
                    .push((a.0 + (b.0 - a.0) * s, a.1 + (b.1 - a.1) * s));
            }
            (a, da) = (b, db);
        }
        if out.vertices.len() < 3 {
            out.vertices.clear();
        }
    }

    /// True when every vertex satisfies the half-plane, so a cut would change nothing.
    pub fn inside(&self, half: &HalfPlane) -> bool {
        self.vertices.iter().all(|&(x, y)| half.excess(x, y) <= 0.0)
    }

    /// Area by the shoelace formula (always non-negative).
    pub fn area(&self) -> f64 {
        self.signed_area2().abs() * 0.5
    }

    fn signed_area2(&self) -> f64 {
        let n = self.vertices.len();
        if n < 3 {
            return 0.0;
        }
        // Relative to the first vertex, to keep precision on far-away polygons.
        let (ox, oy) = self.vertices[0];
        let mut acc = 0.0;
        for i in 1..n - 1 {
            let (ax, ay) = (self.vertices[i].0 - ox, self.vertices[i].1 - oy);
            let (bx, by) = (self.vertices[i + 1].0 - ox, self.vertices[i + 1].1 - oy);
            acc += ax * by - bx * ay;
        }
        acc
    }

    /// Area centroid; the vertex mean for a degenerate (zero-area) polygon.
    pub fn centroid(&self) -> Option<(f64, f64)> {
        let n = self.vertices.len();
        if n == 0 {
            return None;
        }
        let (ox, oy) = self.vertices[0];
        let a2 = self.signed_area2();
        if a2.abs() <= 1e-12 {
            let (sx, sy) = self
                .vertices
                .iter()
                .fold((0.0, 0.0), |(sx, sy), &(x, y)| (sx + x, sy + y));
            return Some((sx / n as f64, sy / n as f64));
        }
        let (mut cx, mut cy) = (0.0, 0.0);
        for i in 1..n - 1 {
            let (ax, ay) = (self.vertices[i].0 - ox, self.vertices[i].1 - oy);
            let (bx, by) = (self.vertices[i + 1].0 - ox, self.vertices[i + 1].1 - oy);
            let cross = ax * by - bx * ay;
            cx += (ax + bx) * cross;
            cy += (ay + by) * cross;
        }
        Some((ox + cx / (3.0 * a2), oy + cy / (3.0 * a2)))
    }

    /// Centre of the axis-aligned bounding box: what the authors' code reports as FOE.
    pub fn bbox_centre(&self) -> Option<(f64, f64)> {
        let first = *self.vertices.first()?;
        let (mut x0, mut y0, mut x1, mut y1) = (first.0, first.1, first.0, first.1);
        for &(x, y) in &self.vertices {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        Some(((x0 + x1) * 0.5, (y0 + y1) * 0.5))
    }

    /// Point-in-polygon for a convex polygon, with a tolerance in the polygon's units.
    pub fn contains(&self, x: f64, y: f64, tol: f64) -> bool {
        let n = self.vertices.len();
        if n < 3 {
            return false;
        }
        let orientation = self.signed_area2().signum();
        (0..n).all(|i| {
            let a = self.vertices[i];
            let b = self.vertices[(i + 1) % n];
            let (ex, ey) = (b.0 - a.0, b.1 - a.1);
            let len = math::hypot(ex, ey);
            if len == 0.0 {
                return true;
            }
            let cross = (ex * (y - a.1) - ey * (x - a.0)) * orientation / len;
            cross >= -tol
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn clipping_a_square_in_half() {
        let sq = ConvexPolygon::rectangle(0.0, 0.0, 2.0, 2.0);
        let mut out = ConvexPolygon::default();
        // x <= 1
        sq.clip_into(
            &HalfPlane {
                nx: 1.0,
                ny: 0.0,
                c: 1.0,
            },
            &mut out,
        );
        assert!((out.area() - 2.0).abs() < 1e-12);
        let (cx, cy) = out.centroid().unwrap();
        assert!((cx - 0.5).abs() < 1e-12 && (cy - 1.0).abs() < 1e-12);
    }

    #[test]
    fn disjoint_half_plane_empties_polygon() {
        let sq = ConvexPolygon::rectangle(0.0, 0.0, 1.0, 1.0);
        let mut out = ConvexPolygon::default();
        sq.clip_into(
            &HalfPlane {
                nx: 1.0,
                ny: 0.0,
                c: -5.0,
            },
            &mut out,
        );
        assert!(out.is_empty());
        assert_eq!(out.area(), 0.0);
    }

    #[test]
    fn behind_a_flow_vector_is_the_side_it_points_away_from() {
        let h = HalfPlane::behind(10.0, 10.0, 1.0, 0.0).unwrap();
        assert!(h.contains(5.0, 100.0));
        assert!(!h.contains(11.0, 10.0));
        assert!(HalfPlane::behind(0.0, 0.0, 0.0, 0.0).is_none());
        assert!(HalfPlane::behind(0.0, 0.0, f64::NAN, 1.0).is_none());
    }

    #[test]
    fn triangle_centroid_differs_from_box_centre() {
        let tri = ConvexPolygon {
            vertices: vec![(0.0, 0.0), (3.0, 0.0), (0.0, 3.0)],
        };
        assert_eq!(tri.centroid(), Some((1.0, 1.0)));
        assert_eq!(tri.bbox_centre(), Some((1.5, 1.5)));
    }

    fn half_planes() -> impl Strategy<Value = Vec<(f64, f64, f64)>> {
        prop::collection::vec(
            (0.0..std::f64::consts::TAU, -50.0..50.0f64, 0.0..1.0f64),
            1..12,
        )
    }

    proptest! {
        /// A point inside every half-plane (and the start box) is inside the clipped
        /// polygon; one outside any of them is not.
        #[test]
        fn clipped_polygon_is_the_intersection(
            planes in half_planes(),
            px in -90.0..90.0f64,
            py in -90.0..90.0f64,
        ) {
            let mut poly = ConvexPolygon::rectangle(-100.0, -100.0, 100.0, 100.0);
            let mut tmp = ConvexPolygon::default();
            let mut hs = Vec::new();
            for (angle, offset, _) in planes {
                let h = HalfPlane { nx: math::cos(angle), ny: math::sin(angle), c: offset };
                poly.clip_into(&h, &mut tmp);
                std::mem::swap(&mut poly, &mut tmp);
                hs.push(h);
            }
            let margin = 1e-7;
            let inside_all = hs.iter().all(|h| h.excess(px, py) <= -margin);
            let outside_one = hs.iter().any(|h| h.excess(px, py) > margin);
            if inside_all {
                prop_assert!(poly.contains(px, py, 1e-6));
            }
            if outside_one {
                prop_assert!(!poly.contains(px, py, -1e-9) || poly.is_empty());
            }
            if !poly.is_empty() {
                // The centroid of a non-empty convex polygon lies inside it.
                let (cx, cy) = poly.centroid().unwrap();
                prop_assert!(poly.contains(cx, cy, 1e-6));
                for h in &hs {
                    prop_assert!(h.excess(cx, cy) <= 1e-6);
                }
            }
        }

        /// Cutting never grows the area.
        #[test]
        fn clipping_never_grows_area(planes in half_planes()) {
            let mut poly = ConvexPolygon::rectangle(-100.0, -100.0, 100.0, 100.0);
            let mut tmp = ConvexPolygon::default();
            for (angle, offset, _) in planes {
                let before = poly.area();
                poly.clip_into(&HalfPlane { nx: math::cos(angle), ny: math::sin(angle), c: offset }, &mut tmp);
                std::mem::swap(&mut poly, &mut tmp);
                prop_assert!(poly.area() <= before * (1.0 + 1e-12) + 1e-9);
            }
        }
    }
}
