//! A scene seen from one camera pose: what every ray of a render shares, worked out
//! once per render instead of once per pixel.
//!
//! [`View::shade`] returns the same bits as [`Scene::shade`] for the same ray: the
//! published `faithd bench foe` figures depend on the exact events, so no f64
//! operation that reaches a result is reordered or replaced. What changes is what is
//! not computed:
//! - a box the ray provably misses is not tested ([`PixelRect`]);
//! - of a room's or a block's distances along three axes, only the one that is the
//!   answer is divided out: the others are ordered by cross-multiplication
//!   ([`quotient_lt`]), exact except in near-ties, which take the divisions;
//! - only the nearest hit is shaded (its texture coordinates, incidence, footprint),
//!   and the texture asks only for what its result depends on
//!   ([`crate::world::texture::Surface`]).

use nalgebra::{Matrix3, Vector3};

use faithd_core::camera::CameraIntrinsics;

use super::{
    NodeKind, STACK_DEPTH, Scene, Shape, face_uv, pole_entry, pole_normal, room_exit, slab_hit,
};
use crate::world::texture::Surface;

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

/// Products closer than this (relative) are ordered by the divisions themselves.
const TIE_REL: f64 = 1e-12;
/// Below this a product may have lost bits to underflow (or be zero): divide.
const TINY: f64 = 1e-250;

/// Whether `na / da < nb / db` as f64 divisions round them (`da`, `db` non-zero).
///
/// `na / da = (na sgn da) / |da|`, so the quotients are ordered as the products
/// `na sgn(da) |db|` and `nb sgn(db) |da|`. Each product is within 2^-53 relative of
/// its exact value and so is each rounded quotient: where the products differ by more
/// than 1e-12 relative the rounded quotients are strictly ordered the same way.
/// Closer (and for zero or tiny products) the divisions decide, as the generic code.
#[inline]
fn quotient_lt(na: f64, da: f64, nb: f64, db: f64) -> bool {
    let x = (na * db.abs()).copysign(na * da);
    let y = (nb * da.abs()).copysign(nb * db);
    let (ax, ay) = (x.abs(), y.abs());
    if ax.min(ay) > TINY {
        let gap = TIE_REL * ax.max(ay);
        if x < y - gap {
            return true;
        }
        if x > y + gap {
            return false;
        }
    }
    na / da < nb / db
}

/// A room the camera is inside, with the signed distances from the camera to its
/// walls along each axis (`min - o`, `max - o`: the same subtractions the generic
/// intersection makes per ray).
#[derive(Clone, Copy, Debug)]
struct RoomFromInside {
    to_min: Vector3<f64>,
    to_max: Vector3<f64>,
}

impl RoomFromInside {
    /// `room_exit`, with one division instead of three.
    fn exit(&self, d: &Vector3<f64>) -> Option<(f64, usize)> {
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
            // The first axis always replaces the initial infinity (n / d is finite).
            let nearer = match best {
                None => true,
                Some((b, nb)) => quotient_lt(n, d[k], nb, d[b]),
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
        Some((t_exit, axis))
    }
}

/// `block_entry`, with one division instead of six (none for most misses).
///
/// Along an axis the generic code divides `min - o` and `max - o` by `d` and swaps
/// them into entry and exit; by the monotony of rounding the entry is `min - o`
/// divided for `d > 0`, `max - o` for `d < 0` (or an equal value).
fn block_entry_fast(
    o: &Vector3<f64>,
    d: &Vector3<f64>,
    min: &Vector3<f64>,
    max: &Vector3<f64>,
) -> Option<(f64, usize)> {
    // (numerator, denominator, axis) of the latest entry and of the earliest exit.
    let mut near: Option<(f64, f64, usize)> = None;
    let mut far: Option<(f64, f64)> = None;
    for k in 0..3 {
        let dk = d[k];
        if dk.abs() < 1e-12 {
            if o[k] < min[k] || o[k] > max[k] {
                return None;
            }
            continue;
        }
        let (lo, hi) = (min[k] - o[k], max[k] - o[k]);
        let (n_in, n_out) = if dk > 0.0 { (lo, hi) } else { (hi, lo) };
        match near {
            Some((n, dn, _)) if !quotient_lt(n, dn, n_in, dk) => {}
            _ => near = Some((n_in, dk, k)),
        }
        match far {
            Some((n, dn)) if !quotient_lt(n_out, dk, n, dn) => {}
            _ => far = Some((n_out, dk)),
        }
    }
    let ((n_near, d_near, axis), (n_far, d_far)) = (near?, far?);
    if quotient_lt(n_far, d_far, n_near, d_near) {
        return None;
    }
    let t_near = n_near / d_near;
    if t_near <= 1e-9 {
        return None;
    }
    Some((t_near, axis))
}

/// The nearest hit of a ray, before any shading.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Candidate {
    t: f64,
    solid: usize,
    kind: CandidateKind,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum CandidateKind {
    /// On a face of a room or a block whose normal is along `axis`.
    Face { axis: usize },
    /// On the side of a pole, at `p`.
    Pole { p: Vector3<f64> },
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
    /// The nearest hit of solid `i`, if nearer than `best` (ties keep `best`, as
    /// [`Scene::cast`] does).
    fn consider(&self, i: usize, d: &Vector3<f64>, best: &mut Option<Candidate>) {
        let o = &self.origin;
        let found = match self.scene.solids[i].shape {
            Shape::Room { min, max } => {
                room_exit(o, d, &min, &max).map(|(t, axis)| (t, CandidateKind::Face { axis }))
            }
            Shape::Block { min, max } => block_entry_fast(o, d, &min, &max)
                .map(|(t, axis)| (t, CandidateKind::Face { axis })),
            Shape::Pole {
                x,
                y,
                radius,
                z_top,
            } => pole_entry(o, d, x, y, radius, z_top).map(|(t, p)| (t, CandidateKind::Pole { p })),
        };
        if let Some((t, kind)) = found
            && best.is_none_or(|b| t < b.t)
        {
            *best = Some(Candidate { t, solid: i, kind });
        }
    }

    /// [`Scene::cast`] for the ray `dir` of pixel (`x_px`, `y_px`), unshaded.
    fn cast(&self, dir: &Vector3<f64>, x_px: i32, y_px: i32) -> Option<Candidate> {
        let scene = self.scene;
        let mut best: Option<Candidate> = None;
        for (&i, room) in scene.always.iter().zip(&self.rooms) {
            match room {
                Some(room) => {
                    if let Some((t, axis)) = room.exit(dir)
                        && best.is_none_or(|b| t < b.t)
                    {
                        best = Some(Candidate {
                            t,
                            solid: i,
                            kind: CandidateKind::Face { axis },
                        });
                    }
                }
                None => self.consider(i, dir, &mut best),
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
            if !slab_hit(&self.origin, &inv, &node.min, &node.max, limit) {
                continue;
            }
            match node.kind {
                NodeKind::Leaf { first, count } => {
                    for &i in &scene.order[first..first + count] {
                        self.consider(i, dir, &mut best);
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
        let Some(hit) = self.cast(dir, x_px, y_px) else {
            return (0.05, f64::INFINITY);
        };
        let norm = dir.norm();
        let dist_m = hit.t * norm;
        let solid = &self.scene.solids[hit.solid];
        let p = match hit.kind {
            CandidateKind::Face { .. } => self.origin + dir * hit.t,
            CandidateKind::Pole { p } => p,
        };
        let surface = match (hit.kind, &solid.shape) {
            (CandidateKind::Face { axis }, _) => {
                let (u_m, v_m) = face_uv(&p, axis);
                HitSurface {
                    u: SurfaceU::Known(u_m),
                    v_m,
                    dist_m,
                    pixel_rad: self.pixel_rad,
                    norm,
                    cos_num: dir[axis].abs(),
                }
            }
            (CandidateKind::Pole { .. }, &Shape::Pole { x, y, radius, .. }) => {
                let (nx, ny) = pole_normal(&p, x, y, radius);
                HitSurface {
                    u: SurfaceU::AroundPole { nx, ny, radius },
                    v_m: p.z,
                    dist_m,
                    pixel_rad: self.pixel_rad,
                    norm,
                    cos_num: (nx * dir.x + ny * dir.y).abs(),
                }
            }
            (CandidateKind::Pole { .. }, _) => unreachable!("a pole hit is on a pole"),
        };
        (solid.texture.reflectance_of(&surface), dist_m)
    }
}

/// The u coordinate of a hit: known, or the angle around a pole (an `atan2` that the
/// poles' banded textures never ask for).
#[derive(Clone, Copy, Debug)]
enum SurfaceU {
    Known(f64),
    AroundPole { nx: f64, ny: f64, radius: f64 },
}

/// A hit as the texture sees it. `Hit::cos_incidence` is `cos_num / norm`, and the
/// footprint is `dist_m * pixel_rad / cos_incidence.max(0.05)`, as in `Scene::shade`.
#[derive(Clone, Copy, Debug)]
struct HitSurface {
    u: SurfaceU,
    v_m: f64,
    dist_m: f64,
    pixel_rad: f64,
    norm: f64,
    cos_num: f64,
}

impl Surface for HitSurface {
    fn u_m(&self) -> f64 {
        match self.u {
            SurfaceU::Known(u_m) => u_m,
            SurfaceU::AroundPole { nx, ny, radius } => ny.atan2(nx) * radius,
        }
    }

    fn v_m(&self) -> f64 {
        self.v_m
    }

    fn footprint_m(&self) -> f64 {
        self.dist_m * self.pixel_rad / (self.cos_num / self.norm).max(0.05)
    }

    /// `dist pr / max(c / n, 0.05) = dist pr n / max(c, 0.05 n)`.
    fn footprint_ratio(&self) -> (f64, f64) {
        (
            self.dist_m * self.pixel_rad * self.norm,
            self.cos_num.max(0.05 * self.norm),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::super::block_entry;
    use super::*;
    use crate::world::SceneKind;
    use faithd_core::camera::Mounting;
    use nalgebra::Rotation3;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// Every pixel of random poses in every scene, plus rays along the axes and with
    /// zero components: the view's shading has the same bits as the scene's.
    #[test]
    fn view_shades_every_ray_with_the_same_bits_as_the_scene() {
        let camera = CameraIntrinsics::dvs240();
        let mounting = Mounting::forward();
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        for kind in SceneKind::ALL {
            for seed in 0..3 {
                let scene = kind.build(seed);
                for pose in 0..6 {
                    let origin = Vector3::new(
                        rng.random_range(-5.5..5.5),
                        rng.random_range(-3.0..3.0),
                        rng.random_range(-2.5..-0.3),
                    );
                    // Level, along and across the room, for the first poses.
                    let attitude = if pose < 2 {
                        Rotation3::from_euler_angles(
                            0.0,
                            0.0,
                            f64::from(pose) * std::f64::consts::FRAC_PI_2,
                        )
                    } else {
                        Rotation3::from_euler_angles(
                            rng.random_range(-0.6..0.6),
                            rng.random_range(-0.4..0.4),
                            rng.random_range(-3.2..3.2),
                        )
                    };
                    let r = attitude.matrix();
                    let world_to_camera = mounting.body_to_camera * r.transpose();
                    let view = scene.view(&origin, &world_to_camera, &camera);
                    let camera_to_body = mounting.body_to_camera.transpose();
                    let pixel_rad = 1.0 / camera.fx_px;
                    for y in 0..i32::from(camera.height_px) {
                        for x in 0..i32::from(camera.width_px) {
                            let (xn, yn) = camera.normalise(f64::from(x), f64::from(y));
                            let dir = r * (camera_to_body * Vector3::new(xn, yn, 1.0));
                            let (a, da) = scene.shade(&origin, &dir, pixel_rad);
                            let (b, db) = view.shade(&dir, x, y);
                            assert_eq!(
                                (a.to_bits(), da.to_bits()),
                                (b.to_bits(), db.to_bits()),
                                "{} pose {pose} pixel ({x}, {y})",
                                scene.name
                            );
                        }
                    }
                }
            }
        }
    }

    /// Rays from random points, half of them aimed at corners and edges, where the
    /// distances along two or three axes tie (in exact arithmetic, or nearly).
    fn tie_heavy_rays(
        n: usize,
        seed: u64,
        origins: (Vector3<f64>, Vector3<f64>),
        targets: (Vector3<f64>, Vector3<f64>),
    ) -> Vec<(Vector3<f64>, Vector3<f64>)> {
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let (lo, hi) = origins;
        let (min, max) = targets;
        (0..n)
            .map(|i| {
                let o = Vector3::new(
                    rng.random_range(lo.x..hi.x),
                    rng.random_range(lo.y..hi.y),
                    rng.random_range(lo.z..hi.z),
                );
                let d = if i % 2 == 0 {
                    let target = Vector3::new(
                        if rng.random_bool(0.5) { min.x } else { max.x },
                        if rng.random_bool(0.5) { min.y } else { max.y },
                        if rng.random_bool(0.5) { min.z } else { max.z },
                    );
                    let d = target - o;
                    match i % 8 {
                        0 => Vector3::new(d.x, d.y, 0.0),
                        2 => d * 0.3,
                        4 => Vector3::new(d.x, 1e-13, d.z),
                        _ => d,
                    }
                } else {
                    Vector3::new(
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                    )
                };
                (o, d)
            })
            .collect()
    }

    #[test]
    fn room_exit_with_one_division_matches_the_generic_one() {
        let (min, max) = (Vector3::new(-6.0, -4.0, -3.5), Vector3::new(6.0, 4.0, 0.0));
        let inside = (min + Vector3::repeat(0.01), max - Vector3::repeat(0.01));
        for (i, (o, d)) in tie_heavy_rays(200_000, 9, inside, (min, max))
            .into_iter()
            .enumerate()
        {
            let fast = RoomFromInside {
                to_min: min - o,
                to_max: max - o,
            }
            .exit(&d);
            assert_eq!(fast, room_exit(&o, &d, &min, &max), "ray {i}: {o:?} {d:?}");
        }
    }

    #[test]
    fn block_entry_with_one_division_matches_the_generic_one() {
        let (min, max) = (Vector3::new(1.0, -0.5, -2.0), Vector3::new(1.7, 0.4, 0.0));
        let around = (Vector3::new(-2.0, -3.0, -4.0), Vector3::new(4.0, 3.0, 1.0));
        let mut hits = 0;
        for (i, (o, d)) in tie_heavy_rays(400_000, 10, around, (min, max))
            .into_iter()
            .enumerate()
        {
            // Some origins exactly on a face plane (zero numerators).
            let o = if i % 16 == 3 {
                Vector3::new(min.x, o.y, o.z)
            } else {
                o
            };
            let generic = block_entry(&o, &d, &min, &max);
            hits += usize::from(generic.is_some());
            assert_eq!(
                block_entry_fast(&o, &d, &min, &max),
                generic,
                "ray {i}: {o:?} {d:?}"
            );
        }
        assert!(hits > 100_000, "{hits}");
    }

    #[test]
    fn quotient_order_matches_the_divisions() {
        let mut rng = Pcg64Mcg::seed_from_u64(12);
        for i in 0..500_000 {
            let na: f64 = rng.random_range(-10.0..10.0);
            let da: f64 = rng.random_range(-1.0..1.0);
            // Every fourth pair nearly tied, every eighth exactly.
            let (nb, db) = match i % 8 {
                0 => (na * 3.0, da * 3.0),
                2 | 4 => (na * (1.0 + 1e-13 * rng.random_range(-3.0..3.0)), da),
                6 => (0.0, da),
                _ => (rng.random_range(-10.0..10.0), rng.random_range(-1.0..1.0)),
            };
            assert_eq!(
                quotient_lt(na, da, nb, db),
                na / da < nb / db,
                "{na} / {da} vs {nb} / {db}"
            );
        }
    }
}
