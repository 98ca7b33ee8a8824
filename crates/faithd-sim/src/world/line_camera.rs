//! A fast analytic event camera for closed-loop flights: the scene is a set of
//! straight edges in 3D (pole silhouettes and bands, wall stripes), each with a
//! brighter and a darker side. Between two poses every pixel centre that an edge
//! sweeps over fires one event, timed where the edge crossed it and signed by the
//! brightness change. Fast enough to run in real time beside the daemon, which the
//! ray-traced [`super::dvs::EventCamera`] is not on a small computer.

use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

use super::trajectory::VehicleState;
use faithd_core::camera::{CameraIntrinsics, Mounting};
use faithd_core::event::{Event, Polarity};

/// A vertical pole standing on the floor (z = 0, NED: z down).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoleSpec {
    pub x_m: f64,
    pub y_m: f64,
    pub radius_m: f64,
    pub height_m: f64,
}

/// An arena: walls at `x = back_wall_x_m` and `y = +-side_wall_y_m`, poles, and how
/// strongly the surfaces are textured (1 = the arena's contrast, 0.3 = poorly lit).
#[derive(Clone, Debug, PartialEq)]
pub struct ArenaSpec {
    pub poles: Vec<PoleSpec>,
    pub back_wall_x_m: f64,
    pub side_wall_y_m: f64,
    pub ceiling_m: f64,
    pub contrast: f64,
}

impl ArenaSpec {
    pub fn with_poles(poles: &[(f64, f64)]) -> Self {
        Self {
            poles: poles
                .iter()
                .map(|&(x_m, y_m)| PoleSpec {
                    x_m,
                    y_m,
                    radius_m: 0.25,
                    height_m: 3.0,
                })
                .collect(),
            back_wall_x_m: 6.0,
            side_wall_y_m: 4.0,
            ceiling_m: 3.0,
            contrast: 1.0,
        }
    }
}

/// An edge: points `a`, `b` (world); log intensity on the left and right of a->b
/// as seen in the image.
#[derive(Clone, Copy, Debug)]
struct Edge3 {
    a: Vector3<f64>,
    b: Vector3<f64>,
    /// Log intensity on the side the image normal points to, and on the other.
    log_pos: f64,
    log_neg: f64,
    /// Index of the pole this edge belongs to (pole edges are never occluded by it).
    pole: Option<usize>,
}

/// An edge projected at one instant.
#[derive(Clone, Copy, Debug)]
struct Edge2 {
    a: (f64, f64),
    dir: (f64, f64),
    len: f64,
}

impl Edge2 {
    fn normal(&self) -> (f64, f64) {
        (-self.dir.1, self.dir.0)
    }
    fn signed(&self, p: (f64, f64)) -> f64 {
        let n = self.normal();
        n.0 * (p.0 - self.a.0) + n.1 * (p.1 - self.a.1)
    }
    fn along(&self, p: (f64, f64)) -> f64 {
        self.dir.0 * (p.0 - self.a.0) + self.dir.1 * (p.1 - self.a.1)
    }
}

pub struct LineCamera {
    camera: CameraIntrinsics,
    mounting: Mounting,
    arena: ArenaSpec,
    rng: Pcg64Mcg,
    /// Background-activity noise, events per pixel per second.
    pub noise_rate_hz: f64,
    last: Option<VehicleState>,
    last_t_us: i64,
}

impl LineCamera {
    pub fn new(camera: CameraIntrinsics, mounting: Mounting, arena: ArenaSpec, seed: u64) -> Self {
        Self {
            camera,
            mounting,
            arena,
            rng: Pcg64Mcg::seed_from_u64(seed),
            noise_rate_hz: 0.5,
            last: None,
            last_t_us: 0,
        }
    }

    /// Advances to `state` at `t_us`, appending the events since the last call,
    /// time-ordered. The first call only sets the starting pose.
    pub fn advance(&mut self, state: &VehicleState, t_us: i64, out: &mut Vec<Event>) {
        let Some(prev) = self.last.replace(*state) else {
            self.last_t_us = t_us;
            return;
        };
        let t0_us = self.last_t_us;
        self.last_t_us = t_us;
        if t_us <= t0_us {
            return;
        }
        let start = out.len();
        let edges = self.edges(&prev, state);
        let occluders1 = self.pole_boxes(state);
        for (e0, e1, edge) in &edges {
            self.sweep(e0, e1, edge, &occluders1, t0_us, t_us, out);
        }
        self.add_noise(t0_us, t_us, out);
        out[start..].sort_by_key(|e| (e.t_us, e.y_px, e.x_px));
    }

    /// The scene's edges at both poses. Pole silhouettes depend on the viewpoint, so
    /// each pose gets its own; the lists are built in the same order, edge for edge.
    fn edges(
        &self,
        s0: &VehicleState,
        s1: &VehicleState,
    ) -> Vec<(Option<Edge2>, Option<Edge2>, Edge3)> {
        let then = self.world_edges(s0);
        let now = self.world_edges(s1);
        let paired = then.len() == now.len();
        now.iter()
            .enumerate()
            .map(|(k, e)| {
                let e_then = if paired { &then[k] } else { e };
                (self.project(e_then, s0), self.project(e, s1), *e)
            })
            .collect()
    }

    fn world_edges(&self, s: &VehicleState) -> Vec<Edge3> {
        let a = &self.arena;
        let k = a.contrast.clamp(0.05, 1.0);
        let bright = (0.6f64).ln();
        let dark = (0.6 - 0.45 * k).max(0.02).ln();
        let mut edges = Vec::new();
        let z_floor = 0.0;
        let z_top = -a.ceiling_m;
        // Back wall: vertical stripes every 0.4 m, horizontal every 0.5 m.
        let mut y = -a.side_wall_y_m + 0.4;
        let mut flip = false;
        while y < a.side_wall_y_m {
            let (p, n) = if flip { (bright, dark) } else { (dark, bright) };
            edges.push(Edge3 {
                a: Vector3::new(a.back_wall_x_m, y, z_floor),
                b: Vector3::new(a.back_wall_x_m, y, z_top),
                log_pos: p,
                log_neg: n,
                pole: None,
            });
            flip = !flip;
            y += 0.4;
        }
        let mut z = -0.5;
        while z > z_top {
            edges.push(Edge3 {
                a: Vector3::new(a.back_wall_x_m, -a.side_wall_y_m, z),
                b: Vector3::new(a.back_wall_x_m, a.side_wall_y_m, z),
                log_pos: bright,
                log_neg: (0.6 - 0.25 * k).ln(),
                pole: None,
            });
            z -= 0.5;
        }
        // Side walls: vertical stripes every 0.5 m along x.
        for side in [-1.0, 1.0] {
            let mut x = -8.0;
            let mut flip = false;
            while x < a.back_wall_x_m {
                let (p, n) = if flip { (bright, dark) } else { (dark, bright) };
                edges.push(Edge3 {
                    a: Vector3::new(x, side * a.side_wall_y_m, z_floor),
                    b: Vector3::new(x, side * a.side_wall_y_m, z_top),
                    log_pos: p,
                    log_neg: n,
                    pole: None,
                });
                flip = !flip;
                x += 0.5;
            }
        }
        // Poles: two silhouettes against the wall and bands every 0.25 m.
        let pole_dark = (0.15f64).ln();
        let pole_light = (0.15 + 0.6 * k).ln();
        for (i, p) in a.poles.iter().enumerate() {
            let to_pole = Vector3::new(p.x_m - s.position_m.x, p.y_m - s.position_m.y, 0.0);
            let d = to_pole.norm();
            if d <= p.radius_m {
                continue;
            }
            let w = Vector3::new(-to_pole.y, to_pole.x, 0.0) / d * p.radius_m;
            let c = Vector3::new(p.x_m, p.y_m, 0.0);
            let (l, r) = (c - w, c + w);
            let top = -p.height_m;
            for (q, sign) in [(l, 1.0), (r, -1.0)] {
                let (lp, ln) = if sign > 0.0 {
                    (pole_dark, bright)
                } else {
                    (bright, pole_dark)
                };
                edges.push(Edge3 {
                    a: Vector3::new(q.x, q.y, z_floor),
                    b: Vector3::new(q.x, q.y, top),
                    log_pos: lp,
                    log_neg: ln,
                    pole: Some(i),
                });
            }
            let mut z = -0.25;
            let mut flip = false;
            while z > top {
                let (lp, ln) = if flip {
                    (pole_dark, pole_light)
                } else {
                    (pole_light, pole_dark)
                };
                edges.push(Edge3 {
                    a: Vector3::new(l.x, l.y, z),
                    b: Vector3::new(r.x, r.y, z),
                    log_pos: lp,
                    log_neg: ln,
                    pole: Some(i),
                });
                flip = !flip;
                z -= 0.25;
            }
        }
        edges
    }

    fn to_camera(&self, s: &VehicleState, p: &Vector3<f64>) -> Vector3<f64> {
        let body = s.attitude.inverse() * (p - s.position_m);
        self.mounting.body_to_camera * body
    }

    /// Projects an edge, clipped to the space in front of the camera.
    fn project(&self, e: &Edge3, s: &VehicleState) -> Option<Edge2> {
        const NEAR_M: f64 = 0.05;
        let mut a = self.to_camera(s, &e.a);
        let mut b = self.to_camera(s, &e.b);
        if a.z < NEAR_M && b.z < NEAR_M {
            return None;
        }
        if a.z < NEAR_M {
            a = b + (a - b) * ((b.z - NEAR_M) / (b.z - a.z));
        } else if b.z < NEAR_M {
            b = a + (b - a) * ((a.z - NEAR_M) / (a.z - b.z));
        }
        let c = &self.camera;
        let pa = (c.fx_px * a.x / a.z + c.cx_px, c.fy_px * a.y / a.z + c.cy_px);
        let pb = (c.fx_px * b.x / b.z + c.cx_px, c.fy_px * b.y / b.z + c.cy_px);
        let (dx, dy) = (pb.0 - pa.0, pb.1 - pa.1);
        let len = dx.hypot(dy);
        if !(len.is_finite() && len > 1e-9) {
            return None;
        }
        Some(Edge2 {
            a: pa,
            dir: (dx / len, dy / len),
            len,
        })
    }

    /// Image boxes (x0, x1, y0, y1) of the poles at a pose: wall edges behind them
    /// are hidden.
    fn pole_boxes(&self, s: &VehicleState) -> Vec<(usize, f64, f64, f64, f64)> {
        let mut boxes = Vec::new();
        for e in self.world_edges(s).iter().filter(|e| e.pole.is_some()) {
            let Some(p) = self.project(e, s) else {
                continue;
            };
            let b = (p.a.0 + p.dir.0 * p.len, p.a.1 + p.dir.1 * p.len);
            let i = e.pole.expect("filtered");
            let (x0, x1) = (p.a.0.min(b.0), p.a.0.max(b.0));
            let (y0, y1) = (p.a.1.min(b.1), p.a.1.max(b.1));
            match boxes
                .iter_mut()
                .find(|bx: &&mut (usize, f64, f64, f64, f64)| bx.0 == i)
            {
                Some(bx) => {
                    bx.1 = bx.1.min(x0);
                    bx.2 = bx.2.max(x1);
                    bx.3 = bx.3.min(y0);
                    bx.4 = bx.4.max(y1);
                }
                None => boxes.push((i, x0, x1, y0, y1)),
            }
        }
        boxes
    }

    #[allow(clippy::too_many_arguments)]
    fn sweep(
        &mut self,
        e0: &Option<Edge2>,
        e1: &Option<Edge2>,
        edge: &Edge3,
        occluders: &[(usize, f64, f64, f64, f64)],
        t0_us: i64,
        t1_us: i64,
        out: &mut Vec<Event>,
    ) {
        let (Some(e0), Some(e1)) = (e0, e1) else {
            return;
        };
        let pts = [
            e0.a,
            (e0.a.0 + e0.dir.0 * e0.len, e0.a.1 + e0.dir.1 * e0.len),
            e1.a,
            (e1.a.0 + e1.dir.0 * e1.len, e1.a.1 + e1.dir.1 * e1.len),
        ];
        let w = f64::from(self.camera.width_px);
        let h = f64::from(self.camera.height_px);
        let x0 = pts
            .iter()
            .map(|p| p.0)
            .fold(f64::INFINITY, f64::min)
            .floor()
            .max(0.0);
        let x1 = pts
            .iter()
            .map(|p| p.0)
            .fold(f64::NEG_INFINITY, f64::max)
            .ceil()
            .min(w - 1.0);
        let y0 = pts
            .iter()
            .map(|p| p.1)
            .fold(f64::INFINITY, f64::min)
            .floor()
            .max(0.0);
        let y1 = pts
            .iter()
            .map(|p| p.1)
            .fold(f64::NEG_INFINITY, f64::max)
            .ceil()
            .min(h - 1.0);
        if x0 > x1 || y0 > y1 {
            return;
        }
        // An edge jumping across most of the image in one step (passing the camera)
        // is not a motion the sensor would see as a sweep.
        if (x1 - x0) * (y1 - y0) > 0.5 * w * h {
            return;
        }
        let span = (t1_us - t0_us) as f64;
        for yi in y0 as i64..=y1 as i64 {
            for xi in x0 as i64..=x1 as i64 {
                let p = (xi as f64, yi as f64);
                let (s0, s1) = (e0.signed(p), e1.signed(p));
                if (s0 < 0.0) == (s1 < 0.0) {
                    continue;
                }
                let u = e1.along(p);
                if !(0.0..=e1.len).contains(&u) {
                    continue;
                }
                let hidden = occluders.iter().any(|&(i, bx0, bx1, by0, by1)| {
                    edge.pole != Some(i) && p.0 >= bx0 && p.0 <= bx1 && p.1 >= by0 && p.1 <= by1
                });
                if hidden {
                    continue;
                }
                let before = if s0 >= 0.0 {
                    edge.log_pos
                } else {
                    edge.log_neg
                };
                let after = if s1 >= 0.0 {
                    edge.log_pos
                } else {
                    edge.log_neg
                };
                if (after - before).abs() < 0.15 {
                    continue;
                }
                let f = s0 / (s0 - s1);
                let t = (t0_us as f64 + f * span).round() as i64;
                out.push(Event::new(
                    t.clamp(t0_us + 1, t1_us),
                    xi as u16,
                    yi as u16,
                    Polarity::from_bool(after > before),
                ));
            }
        }
    }

    fn add_noise(&mut self, t0_us: i64, t1_us: i64, out: &mut Vec<Event>) {
        let n_px = self.camera.pixel_count() as f64;
        let expected = self.noise_rate_hz * n_px * (t1_us - t0_us) as f64 * 1e-6;
        let mut n = expected.floor() as usize;
        if self.rng.random_range(0.0..1.0) < expected.fract() {
            n += 1;
        }
        for _ in 0..n {
            out.push(Event::new(
                self.rng.random_range(t0_us + 1..=t1_us),
                self.rng.random_range(0..self.camera.width_px),
                self.rng.random_range(0..self.camera.height_px),
                Polarity::from_bool(self.rng.random_range(0..2) == 1),
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::quad::{Quad, QuadConfig};

    #[test]
    fn approaching_a_pole_makes_it_loom_with_events_on_both_silhouettes() {
        let cam = CameraIntrinsics::dvs240();
        let mut lc = LineCamera::new(
            cam,
            Mounting::forward(),
            ArenaSpec::with_poles(&[(0.0, 0.0)]),
            1,
        );
        lc.noise_rate_hz = 0.0;
        let mut q = Quad::new(QuadConfig::default(), Vector3::new(-3.0, 0.0, -1.0), 0.0);
        let mut events = Vec::new();
        lc.advance(&q.state(), 0, &mut events);
        for step in 1..=500 {
            q.step(0.0, 0.001);
            lc.advance(&q.state(), step * 1000, &mut events);
        }
        assert!(events.windows(2).all(|w| w[0].t_us <= w[1].t_us));
        // The pole is centred: its silhouettes move outwards, left edge left, right
        // edge right, so events appear on both sides of the image centre.
        let near_centre = |e: &&Event| (e.x_px as f64 - 119.5).abs() < 40.0;
        let left = events
            .iter()
            .filter(near_centre)
            .filter(|e| e.x_px < 119)
            .count();
        let right = events
            .iter()
            .filter(near_centre)
            .filter(|e| e.x_px > 120)
            .count();
        assert!(left > 500 && right > 500, "left {left}, right {right}");
    }
}
