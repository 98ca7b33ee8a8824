//! A scene seen from one camera pose: what every ray of a render shares, worked out
//! once per render instead of once per pixel.
//!
//! [`View::shade`] returns the same bits as [`Scene::shade`] for the same ray: the
//! published `faithd bench foe` figures depend on the exact events, so no f64
//! operation that reaches a result is reordered or replaced. What changes is what is
//! not computed, or computed once:
//! - the ray-independent part of each test (`min - o`, a pole's constant term) is
//!   subtracted once per render ([`Prepared`], [`PreparedNode`]);
//! - a box the ray provably misses is not tested ([`PixelRect`]);
//! - a room's exit is found without branches (its three divisions are independent
//!   and pipeline well: ordering them by cross-multiplication instead, with a
//!   division only for near-ties, was measured slower, and so was it for blocks);
//! - only the nearest hit is shaded (its texture coordinates, incidence, footprint),
//!   and the texture asks only for what its result depends on
//!   ([`crate::world::texture::Surface`]), keeping its last lattice hashes
//!   ([`LatticeMemo`]).
//!
//! Tried and not kept: per 8x8 tile lists of the BVH leaves a tile can see, tested
//! without the inner nodes (the same result, as a leaf inside a failed box fails
//! too): faster in the kitchen, slower in the other scenes.

use nalgebra::{Matrix3, Vector3};

use faithd_core::camera::CameraIntrinsics;

use super::{NodeKind, STACK_DEPTH, Scene, Shape, face_uv, pole_normal, room_exit};
use crate::world::texture::{LatticeMemo, Surface};

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

impl RoomFromInside {
    /// `room_exit`, without branches: the three divisions are independent (and
    /// pipelined), the smallest is picked with the generic code's ties (lowest axis).
    #[inline]
    fn exit(&self, d: &Vector3<f64>) -> Option<(f64, usize)> {
        let t = |k: usize| {
            let n = if d[k] > 0.0 {
                self.to_max[k]
            } else {
                self.to_min[k]
            };
            if d[k].abs() < 1e-12 {
                f64::INFINITY
            } else {
                n / d[k]
            }
        };
        let (tx, ty, tz) = (t(0), t(1), t(2));
        let (mut t_exit, mut axis) = (tx, 0);
        if ty < t_exit {
            t_exit = ty;
            axis = 1;
        }
        if tz < t_exit {
            t_exit = tz;
            axis = 2;
        }
        if !(t_exit.is_finite() && t_exit > 0.0) {
            return None;
        }
        Some((t_exit, axis))
    }
}

/// The nearest hit of a ray so far, before any shading: small enough to stay in
/// registers (a pole's hit point is recomputed for shading, the same expression).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Candidate {
    /// Infinite while nothing is hit: every hit's distance is finite, so "nearer
    /// than the best" is `t < best.t` as `Scene::cast`'s `is_none_or` has it.
    t: f64,
    solid: u32,
    /// The axis of the face's normal, or [`ON_POLE`].
    axis: u8,
}

const ON_POLE: u8 = 3;

impl Candidate {
    const NONE: Candidate = Candidate {
        t: f64::INFINITY,
        solid: u32::MAX,
        axis: 0,
    };
}

/// A solid seen from the camera: what its test subtracts from the ray's origin is
/// subtracted once per render (the same f64 operations, so the same bits).
#[derive(Clone, Copy, Debug)]
enum Prepared {
    /// A room with the camera strictly inside.
    RoomInside(RoomFromInside),
    /// A room the camera is not inside: the generic test.
    RoomOutside {
        min: Vector3<f64>,
        max: Vector3<f64>,
    },
    /// A block, as `min - o` and `max - o`.
    Block {
        to_min: Vector3<f64>,
        to_max: Vector3<f64>,
    },
    /// A pole, with `o - axis` (x, y) and the constant term of its quadratic.
    Pole {
        ox: f64,
        oy: f64,
        c: f64,
        z_top: f64,
    },
}

/// A BVH node seen from the camera.
#[derive(Clone, Copy, Debug)]
struct PreparedNode {
    /// The pixels whose rays can enter the box.
    rect: PixelRect,
    to_min: Vector3<f64>,
    to_max: Vector3<f64>,
    kind: NodeKind,
}

/// The scene from one camera position and attitude.
pub(crate) struct View<'a> {
    scene: &'a Scene,
    origin: Vector3<f64>,
    pixel_rad: f64,
    /// Per solid.
    solids: Vec<Prepared>,
    /// Per BVH node.
    nodes: Vec<PreparedNode>,
    /// The last texture lattice hash (renders go along rows).
    memo: LatticeMemo,
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
        let o = origin;
        let solids = self
            .solids
            .iter()
            .map(|solid| match solid.shape {
                Shape::Room { min, max } => {
                    let (to_min, to_max) = (min - o, max - o);
                    if (0..3).all(|k| to_min[k] < 0.0 && to_max[k] > 0.0) {
                        Prepared::RoomInside(RoomFromInside { to_min, to_max })
                    } else {
                        Prepared::RoomOutside { min, max }
                    }
                }
                Shape::Block { min, max } => Prepared::Block {
                    to_min: min - o,
                    to_max: max - o,
                },
                Shape::Pole {
                    x,
                    y,
                    radius,
                    z_top,
                } => {
                    let (ox, oy) = (o.x - x, o.y - y);
                    Prepared::Pole {
                        ox,
                        oy,
                        c: ox * ox + oy * oy - radius * radius,
                        z_top,
                    }
                }
            })
            .collect();
        let nodes = self
            .nodes
            .iter()
            .map(|node| PreparedNode {
                rect: project_box(&node.min, &node.max, origin, world_to_camera, camera),
                to_min: node.min - o,
                to_max: node.max - o,
                kind: node.kind,
            })
            .collect();
        View {
            scene: self,
            origin: *origin,
            pixel_rad: 1.0 / camera.fx_px,
            solids,
            nodes,
            memo: LatticeMemo::new(),
        }
    }
}

/// `block_entry` with `min - o` and `max - o` given. `o < min` iff `min - o > 0`:
/// the difference of two distinct doubles is never rounded to zero.
fn block_entry_from(
    d: &Vector3<f64>,
    to_min: &Vector3<f64>,
    to_max: &Vector3<f64>,
) -> Option<(f64, usize)> {
    let (mut t_near, mut t_far, mut axis) = (f64::NEG_INFINITY, f64::INFINITY, 0);
    for k in 0..3 {
        if d[k].abs() < 1e-12 {
            if to_min[k] > 0.0 || to_max[k] < 0.0 {
                return None;
            }
            continue;
        }
        let (mut t0, mut t1) = (to_min[k] / d[k], to_max[k] / d[k]);
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        if t0 > t_near {
            t_near = t0;
            axis = k;
        }
        t_far = t_far.min(t1);
    }
    if t_near > t_far || t_near <= 1e-9 {
        return None;
    }
    Some((t_near, axis))
}

/// `pole_entry` with the ray-independent terms given.
fn pole_entry_from(
    o: &Vector3<f64>,
    d: &Vector3<f64>,
    ox: f64,
    oy: f64,
    c: f64,
    z_top: f64,
) -> Option<(f64, Vector3<f64>)> {
    let a = d.x * d.x + d.y * d.y;
    if a < 1e-12 {
        return None;
    }
    let b = 2.0 * (ox * d.x + oy * d.y);
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return None;
    }
    let t = (-b - disc.sqrt()) / (2.0 * a);
    if t <= 1e-9 {
        return None;
    }
    let p = o + d * t;
    if p.z < z_top || p.z > 0.0 {
        return None;
    }
    Some((t, p))
}

/// `slab_hit` with `min - o` and `max - o` given.
fn slab_hit_from(
    inv: &Vector3<f64>,
    to_min: &Vector3<f64>,
    to_max: &Vector3<f64>,
    limit: f64,
) -> bool {
    let (mut t0, mut t1) = (0.0f64, limit);
    for k in 0..3 {
        let (a, b) = (to_min[k] * inv[k], to_max[k] * inv[k]);
        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
        // NaN (a ray parallel to a face, on it) keeps the range: be inclusive.
        if lo > t0 {
            t0 = lo;
        }
        if hi < t1 {
            t1 = hi;
        }
        if t0 > t1 {
            return false;
        }
    }
    true
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
    #[inline]
    fn consider(&self, i: usize, d: &Vector3<f64>, best: &mut Candidate) {
        let found = match self.solids[i] {
            Prepared::RoomInside(room) => room.exit(d),
            Prepared::RoomOutside { min, max } => room_exit(&self.origin, d, &min, &max),
            Prepared::Block { to_min, to_max } => block_entry_from(d, &to_min, &to_max),
            Prepared::Pole { ox, oy, c, z_top } => {
                pole_entry_from(&self.origin, d, ox, oy, c, z_top)
                    .map(|(t, _)| (t, usize::from(ON_POLE)))
            }
        };
        if let Some((t, axis)) = found
            && t < best.t
        {
            *best = Candidate {
                t,
                solid: i as u32,
                axis: axis as u8,
            };
        }
    }

    /// [`Scene::cast`] for the ray `dir` of pixel (`x_px`, `y_px`), unshaded.
    #[inline]
    fn cast(&self, dir: &Vector3<f64>, x_px: i32, y_px: i32) -> Candidate {
        let scene = self.scene;
        let mut best = Candidate::NONE;
        for &i in &scene.always {
            self.consider(i, dir, &mut best);
        }
        // The box of the root bounds every other solid.
        if self
            .nodes
            .first()
            .is_none_or(|root| !root.rect.contains(x_px, y_px))
        {
            return best;
        }
        let inv = Vector3::new(1.0 / dir.x, 1.0 / dir.y, 1.0 / dir.z);
        let mut stack = [0u32; STACK_DEPTH];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            // A box whose pixels exclude this one fails the slab test below anyway.
            if !node.rect.contains(x_px, y_px) {
                continue;
            }
            if !slab_hit_from(&inv, &node.to_min, &node.to_max, best.t) {
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
    #[inline]
    pub(crate) fn shade(&self, dir: &Vector3<f64>, x_px: i32, y_px: i32) -> (f64, f64) {
        let hit = self.cast(dir, x_px, y_px);
        if hit.solid == u32::MAX {
            return (0.05, f64::INFINITY);
        }
        let norm = dir.norm();
        let dist_m = hit.t * norm;
        let solid = &self.scene.solids[hit.solid as usize];
        // As `face_hit` and `pole_entry` compute it.
        let p = self.origin + dir * hit.t;
        let surface = match (hit.axis, &solid.shape) {
            (ON_POLE, &Shape::Pole { x, y, radius, .. }) => {
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
            (ON_POLE, _) => unreachable!("a pole hit is on a pole"),
            (axis, _) => {
                let axis = usize::from(axis);
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
        };
        (solid.texture.reflectance_of(&surface, &self.memo), dist_m)
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
    use super::super::{block_entry, pole_entry, slab_hit};
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
    fn branchless_room_exit_matches_the_generic_one() {
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

    /// Blocks, poles and BVH boxes tested with the origin subtracted once per
    /// render answer as the generic tests do.
    #[test]
    fn tests_prepared_per_render_match_the_generic_ones() {
        let (min, max) = (Vector3::new(1.0, -0.5, -2.0), Vector3::new(1.7, 0.4, 0.0));
        let around = (Vector3::new(-2.0, -3.0, -4.0), Vector3::new(4.0, 3.0, 1.0));
        let (px, py, radius, z_top) = (1.35, -0.05, 0.35, -2.0);
        let mut rng = Pcg64Mcg::seed_from_u64(10);
        let (mut blocks, mut poles, mut slabs) = (0, 0, 0);
        for (i, (o, d)) in tie_heavy_rays(400_000, 10, around, (min, max))
            .into_iter()
            .enumerate()
        {
            // Some origins exactly on a face plane (zero numerators), some of those
            // with the ray in that plane (a NaN in the slab test).
            let (o, d) = match i % 32 {
                3 => (Vector3::new(min.x, o.y, o.z), d),
                19 => (Vector3::new(min.x, o.y, o.z), Vector3::new(0.0, d.y, d.z)),
                _ => (o, d),
            };
            let (to_min, to_max) = (min - o, max - o);
            let generic = block_entry(&o, &d, &min, &max);
            blocks += usize::from(generic.is_some());
            assert_eq!(
                block_entry_from(&d, &to_min, &to_max),
                generic,
                "ray {i}: {o:?} {d:?}"
            );
            let (ox, oy) = (o.x - px, o.y - py);
            let c = ox * ox + oy * oy - radius * radius;
            let generic = pole_entry(&o, &d, px, py, radius, z_top);
            poles += usize::from(generic.is_some());
            assert_eq!(
                pole_entry_from(&o, &d, ox, oy, c, z_top),
                generic,
                "ray {i}"
            );
            let inv = Vector3::new(1.0 / d.x, 1.0 / d.y, 1.0 / d.z);
            let limit = rng.random_range(0.0..3.0);
            let generic = slab_hit(&o, &inv, &min, &max, limit);
            slabs += usize::from(generic);
            assert_eq!(
                slab_hit_from(&inv, &to_min, &to_max, limit),
                generic,
                "ray {i}"
            );
        }
        assert!(
            blocks > 100_000 && poles > 30_000 && slabs > 50_000,
            "{blocks} {poles} {slabs}"
        );
    }
}
