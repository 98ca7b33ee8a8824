//! The four benchmark scenes, in the spirit of the paper's ESIM scenes (Fig. 5):
//! a flying arena with poles, a kitchen, storage shelves and a poorly textured
//! warehouse. All are rooms 12 m long (x from -6 to 6) the vehicle crosses at 1.2 m.

use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;

use super::scene::{Scene, Shape, Solid};
use super::texture::{Pattern, Texture};

/// Which scene to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SceneKind {
    Arena,
    Kitchen,
    Shelves,
    Warehouse,
}

impl SceneKind {
    pub const ALL: [SceneKind; 4] = [
        SceneKind::Arena,
        SceneKind::Kitchen,
        SceneKind::Shelves,
        SceneKind::Warehouse,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SceneKind::Arena => "arena",
            SceneKind::Kitchen => "kitchen",
            SceneKind::Shelves => "shelves",
            SceneKind::Warehouse => "warehouse",
        }
    }

    /// Builds the scene; `seed` varies textures and clutter placement.
    pub fn build(self, seed: u64) -> Scene {
        match self {
            SceneKind::Arena => arena(&[(3.0, 0.0)], seed),
            SceneKind::Kitchen => kitchen(seed),
            SceneKind::Shelves => shelves(seed),
            SceneKind::Warehouse => warehouse(seed),
        }
    }
}

fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
    Vector3::new(x, y, z)
}

fn room(half_width_m: f64, height_m: f64, texture: Texture) -> Solid {
    Solid {
        shape: Shape::Room {
            min: v(-6.0, -half_width_m, -height_m),
            max: v(6.0, half_width_m, 0.0),
        },
        texture,
    }
}

fn block(min: Vector3<f64>, max: Vector3<f64>, texture: Texture) -> Solid {
    Solid {
        shape: Shape::Block { min, max },
        texture,
    }
}

/// The flying arena: netted walls, foam floor, 50 cm poles at the given (x, y).
pub fn arena(poles: &[(f64, f64)], seed: u64) -> Scene {
    let s = seed as u32;
    let mut solids = vec![room(
        5.0,
        4.0,
        Texture::new(Pattern::Tiles, 0.35, 0.6, 0.45, s),
    )];
    solids.extend(poles.iter().enumerate().map(|(i, &p)| pole(p, i, s)));
    Scene::new("arena", solids)
}

/// A 50 cm pole from the floor to 4 m, striped as the arena's are.
fn pole((x, y): (f64, f64), index: usize, seed: u32) -> Solid {
    Solid {
        shape: Shape::Pole {
            x,
            y,
            radius: 0.25,
            z_top: -4.0,
        },
        texture: Texture::new(Pattern::Bands, 0.12, 0.8, 0.6, seed ^ (17 + index as u32)),
    }
}

/// A scene of `kind` with 50 cm poles at (x, y): the closed loop's obstacles in any
/// of the four rooms (the arena gets these poles instead of its own).
pub fn with_poles(kind: SceneKind, seed: u64, poles: &[(f64, f64)]) -> Scene {
    if kind == SceneKind::Arena {
        return arena(poles, seed);
    }
    let scene = kind.build(seed);
    let mut solids = scene.solids;
    solids.extend(
        poles
            .iter()
            .enumerate()
            .map(|(i, &p)| pole(p, i, seed as u32)),
    );
    Scene::new(scene.name, solids)
}

/// A kitchen: tiled room, counters and cabinets of wood along the walls, a table.
fn kitchen(seed: u64) -> Scene {
    let s = seed as u32;
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x4b17);
    let mut solids = vec![room(
        3.5,
        2.8,
        Texture::new(Pattern::Tiles, 0.2, 0.5, 0.6, s),
    )];
    for side in [-1.0f64, 1.0] {
        let mut x = -6.0;
        while x < 6.0 {
            let len = rng.random_range(0.6..1.4);
            let depth = rng.random_range(0.5..0.7);
            let height = rng.random_range(0.8..2.2);
            let y0 = side * 3.5;
            let y1 = side * (3.5 - depth);
            solids.push(block(
                v(x, y0.min(y1), -height),
                v(x + len, y0.max(y1), 0.0),
                Texture::new(Pattern::Planks, 0.15, 0.5, 0.5, s ^ rng.random::<u32>()),
            ));
            x += len + rng.random_range(0.0..0.3);
        }
    }
    solids.push(block(
        v(4.0, -0.8, -0.75),
        v(5.2, 0.8, 0.0),
        Texture::new(Pattern::Noise, 0.1, 0.7, 0.5, s ^ 99),
    ));
    Scene::new("kitchen", solids)
}

/// Storage shelves: aisles of racks with boxes of varied labels.
fn shelves(seed: u64) -> Scene {
    let s = seed as u32;
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x5e1f);
    let mut solids = vec![room(
        4.0,
        3.5,
        Texture::new(Pattern::Noise, 0.5, 0.4, 0.5, s),
    )];
    for y_rack in [-3.0, 3.0] {
        for level in 0..4 {
            let z_bottom = -0.1 - 0.8 * f64::from(level);
            let mut x = -6.0;
            while x < 6.0 {
                let len = rng.random_range(0.3..0.8);
                let h = rng.random_range(0.3..0.7);
                solids.push(block(
                    v(x, y_rack - 0.4, z_bottom - h),
                    v(x + len, y_rack + 0.4, z_bottom),
                    Texture::new(
                        if rng.random_bool(0.5) {
                            Pattern::Bands
                        } else {
                            Pattern::Tiles
                        },
                        rng.random_range(0.05..0.2),
                        rng.random_range(0.3..0.9),
                        rng.random_range(0.3..0.8),
                        s ^ rng.random::<u32>(),
                    ),
                ));
                x += len + rng.random_range(0.02..0.2);
            }
        }
    }
    // A rack across the far end of the aisle.
    solids.push(block(
        v(5.0, -2.5, -2.5),
        v(5.6, 2.5, 0.0),
        Texture::new(Pattern::Planks, 0.25, 0.6, 0.5, s ^ 5),
    ));
    Scene::new("shelves", solids)
}

/// A wood warehouse: large, dim, low-contrast walls; a few pallet stacks.
fn warehouse(seed: u64) -> Scene {
    let s = seed as u32;
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x3a7e);
    let mut solids = vec![room(
        6.0,
        5.0,
        Texture::new(Pattern::Planks, 0.6, 0.15, 0.35, s),
    )];
    for _ in 0..6 {
        let (x, y): (f64, f64) = (rng.random_range(-2.0..5.0), rng.random_range(-5.0..5.0));
        if y.abs() < 1.0 && x < 3.0 {
            continue;
        }
        let h = rng.random_range(0.5..2.5);
        solids.push(block(
            v(x, y, -h),
            v(x + 1.2, y + 1.0, 0.0),
            Texture::new(Pattern::Planks, 0.12, 0.35, 0.4, s ^ rng.random::<u32>()),
        ));
    }
    Scene::new("warehouse", solids)
}
