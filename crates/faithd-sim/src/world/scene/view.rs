//! A scene seen from one camera pose: what every ray of a render shares, worked out
//! once per render instead of once per pixel.
//!
//! [`View::shade`] returns the same bits as [`Scene::shade`] for the same ray: the
//! published `faithd bench foe` figures depend on the exact events, so no f64
//! operation that reaches a result is reordered or replaced. What changes is what is
//! not computed: a box the ray provably misses is not tested, and of a room's three
//! exit distances only the nearest is divided out.

use nalgebra::{Matrix3, Vector3};

use faithd_core::camera::CameraIntrinsics;

use super::{Hit, NodeKind, STACK_DEPTH, Scene, Shape, face_hit, slab_hit};

/// Corners nearer the camera plane than this give no pixel bounds (their projection
/// is unbounded or behind): the node is then tested by every ray.
const NEAR_M: f64 = 0.05;

/// Pixels added around a box's projected corners. A ray outside misses the box by at
/// least this angle (10 mrad at the DVS240's 195 px focal length), which no rounding
/// in the slab test (relative 1e-16) can bridge.
const MARGIN_PX: f64 = 2.0;

/// Pixels whose rays may enter a box, inclusive bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
struct PixelRect {
    x0: i32,
    x1: i32,
    y0: i32,
    y1: i32,
}

impl PixelRect {
    const EVERY: PixelRect = PixelRect {
        x0: i32::MIN,
        x1: i32::MAX,
        y0: i32::MIN,
        y1: i32::MAX,
    };

    fn contains(&self, x_px: i32, y_px: i32) -> bool {
        x_px >= self.x0 && x_px <= self.x1 && y_px >= self.y0 && y_px <= self.y1
    }
}

/// A room the camera is inside, with the signed distances from the camera to its
/// walls along each axis (`min - o`, `max - o`: the same subtractions the generic
/// intersection makes per ray).
#[derive(Clone, Copy, Debug)]
struct RoomFromInside {
    to_min: Vector3<f64>,
    to_max: Vector3<f64>,
}

/// Products closer than this (relative) are compared by the exact divisions.
const TIE_REL: f64 = 1e-12;
/// Below this a product may have lost bits to underflow: compare exactly.
const TINY: f64 = 1e-250;

impl RoomFromInside {
    /// The first wall the ray leaves through, as `Shape::Room`'s intersection finds
    /// it, but with one division instead of three.
    ///
    /// The wall along axis k is reached at `t_k = n_k / d_k` (both of one sign, the
    /// camera being inside), so `t_a < t_b` iff `|n_a| |d_b| < |n_b| |d_a|`. Where
    /// the two products differ by more than 1e-12 relative, the rounded quotients are
    /// ordered the same way (each is within 2^-53 of its exact value); closer than
    /// that, the quotients are computed and compared as the generic code does.
    fn exit(&self, o: &Vector3<f64>, d: &Vector3<f64>, norm: f64) -> Option<Hit> {
        let mut best: Option<(usize, f64)> = None;
        for k in 0..3 {
            if d[k].abs() < 1e-12 {
                continue;
            }
            let n = if d[k] > 0.0 {
                self.to_max[k]
            } else {
                self.to_min[k]
            };
            let nearer = match best {
                None => true,
                Some((b, nb)) => {
                    let lhs = n.abs() * d[b].abs();
                    let rhs = nb.abs() * d[k].abs();
                    if lhs.min(rhs) < TINY {
                        n / d[k] < nb / d[b]
                    } else if lhs < rhs * (1.0 - TIE_REL) {
                        true
                    } else if rhs < lhs * (1.0 - TIE_REL) {
                        false
                    } else {
                        n / d[k] < nb / d[b]
                    }
                }
            };
            if nearer {
                best = Some((k, n));
            }
        }
        let (axis, n) = best?;
        let t_exit = n / d[axis];
        if !(t_exit.is_finite() && t_exit > 0.0) {
            return None;
        }
        Some(face_hit(o, d, norm, t_exit, axis))
    }
}

/// The scene from one camera position and attitude.
pub(crate) struct View<'a> {
    scene: &'a Scene,
    origin: Vector3<f64>,
    pixel_rad: f64,
    /// Per solid of `scene.always`: the room, when the camera is strictly inside it
    /// (else the generic intersection is used).
    rooms: Vec<Option<RoomFromInside>>,
    /// Per BVH node: the pixels whose rays can enter its box.
    node_px: Vec<PixelRect>,
}

impl Scene {
    /// Prepares a render from `origin` with a camera whose axes are
    /// `world_to_camera * (p - origin)`; `camera` maps its rays to pixels.
    pub(crate) fn view(
        &self,
        origin: &Vector3<f64>,
        world_to_camera: &Matrix3<f64>,
        camera: &CameraIntrinsics,
    ) -> View<'_> {
        let rooms = self
            .always
            .iter()
            .map(|&i| match self.solids[i].shape {
                Shape::Room { min, max } => {
                    let to_min = min - origin;
                    let to_max = max - origin;
                    let inside = (0..3).all(|k| to_min[k] < 0.0 && to_max[k] > 0.0);
                    inside.then_some(RoomFromInside { to_min, to_max })
                }
                _ => None,
            })
            .collect();
        let node_px = self
            .nodes
            .iter()
            .map(|node| project_box(&node.min, &node.max, origin, world_to_camera, camera))
            .collect();
        View {
            scene: self,
            origin: *origin,
            pixel_rad: 1.0 / camera.fx_px,
            rooms,
            node_px,
        }
    }
}

/// The pixels a box can cover, or every pixel when a corner is not well in front.
fn project_box(
    min: &Vector3<f64>,
    max: &Vector3<f64>,
    origin: &Vector3<f64>,
    world_to_camera: &Matrix3<f64>,
    camera: &CameraIntrinsics,
) -> PixelRect {
    let (mut x_lo, mut x_hi, mut y_lo, mut y_hi) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for corner in 0..8 {
        let p = Vector3::new(
            if corner & 1 == 0 { min.x } else { max.x },
            if corner & 2 == 0 { min.y } else { max.y },
            if corner & 4 == 0 { min.z } else { max.z },
        );
        let c = world_to_camera * (p - origin);
        // Also NaN (a non-finite pose).
        if c.z.is_nan() || c.z < NEAR_M {
            return PixelRect::EVERY;
        }
        let (x_px, y_px) = camera.to_pixels(c.x / c.z, c.y / c.z);
        x_lo = x_lo.min(x_px);
        x_hi = x_hi.max(x_px);
        y_lo = y_lo.min(y_px);
        y_hi = y_hi.max(y_px);
    }
    if !(x_lo.is_finite() && x_hi.is_finite() && y_lo.is_finite() && y_hi.is_finite()) {
        return PixelRect::EVERY;
    }
    // Far outside the sensor the exact bound does not matter; keep it in i32.
    let lim = 1e6;
    let px = |v: f64| v.clamp(-lim, lim) as i32;
    PixelRect {
        x0: px((x_lo - MARGIN_PX).floor()),
        x1: px((x_hi + MARGIN_PX).ceil()),
        y0: px((y_lo - MARGIN_PX).floor()),
        y1: px((y_hi + MARGIN_PX).ceil()),
    }
}

impl View<'_> {
    /// [`Scene::cast`] for the ray of pixel (`x_px`, `y_px`), whose direction is `dir`
    /// and `norm` its length.
    fn cast(&self, dir: &Vector3<f64>, norm: f64, x_px: i32, y_px: i32) -> Option<Hit> {
        let scene = self.scene;
        let origin = &self.origin;
        let mut best: Option<Hit> = None;
        for (&i, room) in scene.always.iter().zip(&self.rooms) {
            let hit = match room {
                Some(room) => room.exit(origin, dir, norm),
                None => scene.solids[i].shape.intersect_with_norm(origin, dir, norm),
            };
            if let Some(h) = hit
                && best.is_none_or(|b| h.t < b.t)
            {
                best = Some(Hit { solid: i, ..h });
            }
        }
        // The box of the root bounds every other solid.
        if scene.nodes.is_empty() || !self.node_px[0].contains(x_px, y_px) {
            return best;
        }
        let inv = Vector3::new(1.0 / dir.x, 1.0 / dir.y, 1.0 / dir.z);
        let mut stack = [0u32; STACK_DEPTH];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let index = stack[top] as usize;
            // A box whose pixels exclude this one fails the slab test below anyway.
            if !self.node_px[index].contains(x_px, y_px) {
                continue;
            }
            let node = &scene.nodes[index];
            let limit = best.map_or(f64::INFINITY, |b| b.t);
            if !slab_hit(origin, &inv, &node.min, &node.max, limit) {
                continue;
            }
            match node.kind {
                NodeKind::Leaf { first, count } => {
                    for &i in &scene.order[first..first + count] {
                        if let Some(h) =
                            scene.solids[i].shape.intersect_with_norm(origin, dir, norm)
                            && best.is_none_or(|b| h.t < b.t)
                        {
                            best = Some(Hit { solid: i, ..h });
                        }
                    }
                }
                NodeKind::Inner { left, right } => {
                    if top + 2 <= stack.len() {
                        stack[top] = right as u32;
                        stack[top + 1] = left as u32;
                        top += 2;
                    }
                }
            }
        }
        best
    }

    /// [`Scene::shade`] (same bits) for the ray `dir` of pixel (`x_px`, `y_px`).
    pub(crate) fn shade(&self, dir: &Vector3<f64>, x_px: i32, y_px: i32) -> (f64, f64) {
        let norm = dir.norm();
        match self.cast(dir, norm, x_px, y_px) {
            Some(h) => {
                let dist_m = h.t * norm;
                let footprint_m = dist_m * self.pixel_rad / h.cos_incidence.max(0.05);
                let texture = &self.scene.solids[h.solid].texture;
                (texture.reflectance(h.u_m, h.v_m, footprint_m), dist_m)
            }
            None => (0.05, f64::INFINITY),
        }
    }
}
