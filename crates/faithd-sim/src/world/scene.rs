//! 3D scenes made of boxes and vertical cylinders, in world axes x forward (north),
//! y right (east), z down, metres. The floor is at z = 0.

use nalgebra::Vector3;

use super::texture::Texture;

mod view;

/// One solid of the scene.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// The room the vehicle flies in, seen from inside (walls, floor, ceiling).
    Room {
        min: Vector3<f64>,
        max: Vector3<f64>,
    },
    /// A solid box seen from outside (cabinets, shelves, pallets).
    Block {
        min: Vector3<f64>,
        max: Vector3<f64>,
    },
    /// A vertical cylinder (poles), from `z_top` (negative, up) down to the floor.
    Pole {
        x: f64,
        y: f64,
        radius: f64,
        z_top: f64,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Solid {
    pub shape: Shape,
    pub texture: Texture,
}

/// A named scene, with a bounding-volume hierarchy over its solids so that a ray
/// tests a handful of boxes instead of every shelf in the room.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub name: &'static str,
    pub solids: Vec<Solid>,
    /// Solids that bound everything (rooms): tested by every ray.
    always: Vec<usize>,
    nodes: Vec<Node>,
    order: Vec<usize>,
}

#[derive(Clone, Debug, PartialEq)]
struct Node {
    min: Vector3<f64>,
    max: Vector3<f64>,
    /// Leaf: range into `order`; inner: `left` child index, right = left + 1... stored
    /// explicitly for clarity.
    kind: NodeKind,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum NodeKind {
    Leaf { first: usize, count: usize },
    Inner { left: usize, right: usize },
}

const LEAF_SIZE: usize = 4;

/// Capacity of the traversal stack; children beyond it are not visited (never reached:
/// a tree of 2^60 leaves would be needed).
const STACK_DEPTH: usize = 64;

/// The nearest surface along a ray: distance, texture coordinates and the cosine of
/// the incidence angle (1 = face-on), which sets how large a pixel's footprint is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f64,
    pub u_m: f64,
    pub v_m: f64,
    pub cos_incidence: f64,
    pub solid: usize,
}

impl Scene {
    pub fn new(name: &'static str, solids: Vec<Solid>) -> Self {
        let mut always = Vec::new();
        let mut order = Vec::new();
        for (i, s) in solids.iter().enumerate() {
            match s.shape.bounds() {
                Some(_) => order.push(i),
                None => always.push(i),
            }
        }
        let mut scene = Self {
            name,
            solids,
            always,
            nodes: Vec::new(),
            order,
        };
        if !scene.order.is_empty() {
            let n = scene.order.len();
            scene.build(0, n);
        }
        scene
    }

    /// Builds the subtree over `order[first..first + count]`; returns its node index.
    fn build(&mut self, first: usize, count: usize) -> usize {
        let bounds = |i: usize| self.solids[i].shape.bounds().expect("bounded solid");
        let (mut min, mut max) = bounds(self.order[first]);
        for &i in &self.order[first..first + count] {
            let (a, b) = bounds(i);
            min = min.inf(&a);
            max = max.sup(&b);
        }
        let index = self.nodes.len();
        self.nodes.push(Node {
            min,
            max,
            kind: NodeKind::Leaf { first, count },
        });
        if count <= LEAF_SIZE {
            return index;
        }
        let extent = max - min;
        let axis = extent.imax();
        let solids = &self.solids;
        self.order[first..first + count].sort_by(|&a, &b| {
            let ca = solids[a]
                .shape
                .bounds()
                .map_or(0.0, |(lo, hi)| lo[axis] + hi[axis]);
            let cb = solids[b]
                .shape
                .bounds()
                .map_or(0.0, |(lo, hi)| lo[axis] + hi[axis]);
            ca.total_cmp(&cb)
        });
        let half = count / 2;
        let left = self.build(first, half);
        let right = self.build(first + half, count - half);
        self.nodes[index].kind = NodeKind::Inner { left, right };
        index
    }

    /// Nearest hit of the ray `origin + t * dir`, t > 0.
    pub fn cast(&self, origin: &Vector3<f64>, dir: &Vector3<f64>) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let norm = dir.norm();
        let consider = |i: usize, best: &mut Option<Hit>| {
            if let Some(h) = self.solids[i].shape.intersect_with_norm(origin, dir, norm)
                && best.is_none_or(|b| h.t < b.t)
            {
                *best = Some(Hit { solid: i, ..h });
            }
        };
        for &i in &self.always {
            consider(i, &mut best);
        }
        if self.nodes.is_empty() {
            return best;
        }
        let inv = Vector3::new(1.0 / dir.x, 1.0 / dir.y, 1.0 / dir.z);
        // u32, not usize: a 512-byte stack was zeroed by a memset call on every ray.
        let mut stack = [0u32; STACK_DEPTH];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            let limit = best.map_or(f64::INFINITY, |b| b.t);
            if !slab_hit(origin, &inv, &node.min, &node.max, limit) {
                continue;
            }
            match node.kind {
                NodeKind::Leaf { first, count } => {
                    for &i in &self.order[first..first + count] {
                        consider(i, &mut best);
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

    /// Reflectance and distance seen along a ray whose pixel spans `pixel_rad`
    /// radians; a dim constant where nothing is hit.
    pub fn shade(&self, origin: &Vector3<f64>, dir: &Vector3<f64>, pixel_rad: f64) -> (f64, f64) {
        match self.cast(origin, dir) {
            Some(h) => {
                let dist_m = h.t * dir.norm();
                let footprint_m = dist_m * pixel_rad / h.cos_incidence.max(0.05);
                let texture = &self.solids[h.solid].texture;
                (texture.reflectance(h.u_m, h.v_m, footprint_m), dist_m)
            }
            None => (0.05, f64::INFINITY),
        }
    }
}

/// Surface coordinates on the face of a box whose normal is along `axis`.
fn face_uv(p: &Vector3<f64>, axis: usize) -> (f64, f64) {
    match axis {
        0 => (p.y, p.z),
        1 => (p.x, p.z),
        _ => (p.x, p.y),
    }
}

/// Does the ray enter the box before `limit`?
fn slab_hit(
    o: &Vector3<f64>,
    inv: &Vector3<f64>,
    min: &Vector3<f64>,
    max: &Vector3<f64>,
    limit: f64,
) -> bool {
    let (mut t0, mut t1) = (0.0f64, limit);
    for k in 0..3 {
        let (a, b) = ((min[k] - o[k]) * inv[k], (max[k] - o[k]) * inv[k]);
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

/// `norm` is `d.norm()`, passed in so that a ray computes it once for all its tests.
fn face_hit(o: &Vector3<f64>, d: &Vector3<f64>, norm: f64, t: f64, axis: usize) -> Hit {
    let p = o + d * t;
    let (u_m, v_m) = face_uv(&p, axis);
    Hit {
        t,
        u_m,
        v_m,
        cos_incidence: d[axis].abs() / norm,
        solid: 0,
    }
}

impl Shape {
    /// Axis-aligned bounds; `None` for a room, which encloses everything.
    pub fn bounds(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        match self {
            Shape::Room { .. } => None,
            Shape::Block { min, max } => Some((*min, *max)),
            Shape::Pole {
                x,
                y,
                radius,
                z_top,
            } => Some((
                Vector3::new(x - radius, y - radius, *z_top),
                Vector3::new(x + radius, y + radius, 0.0),
            )),
        }
    }

    /// Ray intersection (the `solid` index of the hit is left 0).
    pub fn intersect(&self, o: &Vector3<f64>, d: &Vector3<f64>) -> Option<Hit> {
        self.intersect_with_norm(o, d, d.norm())
    }

    /// [`Shape::intersect`] with `d.norm()` computed by the caller, once per ray.
    pub(crate) fn intersect_with_norm(
        &self,
        o: &Vector3<f64>,
        d: &Vector3<f64>,
        norm: f64,
    ) -> Option<Hit> {
        match self {
            Shape::Room { min, max } => {
                room_exit(o, d, min, max).map(|(t, axis)| face_hit(o, d, norm, t, axis))
            }
            Shape::Block { min, max } => {
                block_entry(o, d, min, max).map(|(t, axis)| face_hit(o, d, norm, t, axis))
            }
            &Shape::Pole {
                x,
                y,
                radius,
                z_top,
            } => pole_entry(o, d, x, y, radius, z_top).map(|(t, p)| {
                let (nx, ny) = pole_normal(&p, x, y, radius);
                let angle = ny.atan2(nx);
                Hit {
                    t,
                    u_m: angle * radius,
                    v_m: p.z,
                    cos_incidence: (nx * d.x + ny * d.y).abs() / norm,
                    solid: 0,
                }
            }),
        }
    }
}

/// Where a ray from inside a room leaves it: the distance (in units of `d`) and the
/// axis of the wall.
fn room_exit(
    o: &Vector3<f64>,
    d: &Vector3<f64>,
    min: &Vector3<f64>,
    max: &Vector3<f64>,
) -> Option<(f64, usize)> {
    let mut t_exit = f64::INFINITY;
    let mut axis = 0;
    for k in 0..3 {
        if d[k].abs() < 1e-12 {
            continue;
        }
        let bound = if d[k] > 0.0 { max[k] } else { min[k] };
        let t = (bound - o[k]) / d[k];
        if t < t_exit {
            t_exit = t;
            axis = k;
        }
    }
    if !(t_exit.is_finite() && t_exit > 0.0) {
        return None;
    }
    Some((t_exit, axis))
}

/// Where a ray enters a box from outside: the distance and the axis of the face.
fn block_entry(
    o: &Vector3<f64>,
    d: &Vector3<f64>,
    min: &Vector3<f64>,
    max: &Vector3<f64>,
) -> Option<(f64, usize)> {
    let (mut t_near, mut t_far, mut axis) = (f64::NEG_INFINITY, f64::INFINITY, 0);
    for k in 0..3 {
        if d[k].abs() < 1e-12 {
            if o[k] < min[k] || o[k] > max[k] {
                return None;
            }
            continue;
        }
        let (mut t0, mut t1) = ((min[k] - o[k]) / d[k], (max[k] - o[k]) / d[k]);
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

/// Where a ray meets the side of a vertical cylinder: the distance and the point.
fn pole_entry(
    o: &Vector3<f64>,
    d: &Vector3<f64>,
    x: f64,
    y: f64,
    radius: f64,
    z_top: f64,
) -> Option<(f64, Vector3<f64>)> {
    let (ox, oy) = (o.x - x, o.y - y);
    let a = d.x * d.x + d.y * d.y;
    if a < 1e-12 {
        return None;
    }
    let b = 2.0 * (ox * d.x + oy * d.y);
    let c = ox * ox + oy * oy - radius * radius;
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

/// The outward unit normal (x, y) of a pole's side at `p`.
fn pole_normal(p: &Vector3<f64>, x: f64, y: f64, radius: f64) -> (f64, f64) {
    ((p.x - x) / radius, (p.y - y) / radius)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::texture::Pattern;

    fn tex() -> Texture {
        Texture::new(Pattern::Noise, 0.2, 0.5, 0.5, 1)
    }

    #[test]
    fn hierarchy_finds_the_same_hits_as_testing_every_solid() {
        let scene = crate::world::SceneKind::Shelves.build(3);
        let o = Vector3::new(-4.0, 0.2, -1.2);
        for i in 0..2000 {
            let a = f64::from(i) * 0.0031;
            let d = Vector3::new(1.0, (a * 7.0).sin() * 1.5, (a * 3.0).cos() * 0.8);
            let brute = scene
                .solids
                .iter()
                .enumerate()
                .filter_map(|(k, s)| s.shape.intersect(&o, &d).map(|h| (h.t, k)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let fast = scene.cast(&o, &d).map(|h| (h.t, h.solid));
            assert_eq!(fast, brute, "ray {i}");
        }
    }

    #[test]
    fn rays_hit_the_nearest_solid() {
        let scene = Scene::new(
            "t",
            vec![
                Solid {
                    shape: Shape::Room {
                        min: Vector3::new(-10.0, -10.0, -4.0),
                        max: Vector3::new(10.0, 10.0, 0.0),
                    },
                    texture: tex(),
                },
                Solid {
                    shape: Shape::Pole {
                        x: 3.0,
                        y: 0.0,
                        radius: 0.25,
                        z_top: -4.0,
                    },
                    texture: tex(),
                },
                Solid {
                    shape: Shape::Block {
                        min: Vector3::new(5.0, 2.0, -1.0),
                        max: Vector3::new(6.0, 3.0, 0.0),
                    },
                    texture: tex(),
                },
            ],
        );
        let o = Vector3::new(0.0, 0.0, -1.0);
        let ahead = scene.cast(&o, &Vector3::new(1.0, 0.0, 0.0)).unwrap();
        assert_eq!(ahead.solid, 1);
        assert!((ahead.t - 2.75).abs() < 1e-9);
        let back = scene.cast(&o, &Vector3::new(-1.0, 0.0, 0.0)).unwrap();
        assert_eq!(back.solid, 0);
        assert!((back.t - 10.0).abs() < 1e-9);
        let down = scene.cast(&o, &Vector3::new(0.0, 0.0, 1.0)).unwrap();
        assert!((down.t - 1.0).abs() < 1e-9);
        let to_block = Vector3::new(5.5, 2.5, -0.5) - o;
        assert_eq!(scene.cast(&o, &to_block).unwrap().solid, 2);
    }
}
