//! Procedural surface textures: reflectance as a function of surface coordinates.
//!
//! Event cameras see only changes of log intensity, so what matters is the contrast and
//! the scale of the patterns. Each texture is a deterministic function of (u, v) in
//! metres, so the same scene renders the same at any time and from any pose.

/// The pattern family of a texture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pattern {
    /// Smooth multi-octave value noise (plaster, foam mats, cardboard).
    Noise,
    /// Parallel boards of random shade along u, with grain (wood, shelves).
    Planks,
    /// Square tiles of random shade with thin dark joints (floors, nets, kitchens).
    Tiles,
    /// Horizontal bands of random shade along v (striped poles, labels on boxes).
    Bands,
}

/// A texture: pattern, feature size and contrast around a base reflectance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Texture {
    pub pattern: Pattern,
    /// Size of one feature (noise cell, plank, tile, band), metres.
    pub scale_m: f64,
    /// Relative contrast 0..1: reflectance varies within base * (1 +- contrast).
    pub contrast: f64,
    /// Mean reflectance 0..1.
    pub base: f64,
    pub seed: u32,
}

impl Texture {
    pub fn new(pattern: Pattern, scale_m: f64, contrast: f64, base: f64, seed: u32) -> Self {
        Self {
            pattern,
            scale_m,
            contrast,
            base,
            seed,
        }
    }

    /// Reflectance at surface coordinates (u, v) in metres, in (0, 1], as seen by a
    /// pixel whose footprint on the surface is `footprint_m` wide.
    ///
    /// Features smaller than the footprint are faded to their mean instead of being
    /// point-sampled: point-sampled sub-pixel detail flickers from frame to frame and
    /// fires events that no real camera (whose pixels integrate light) would fire.
    pub fn reflectance(&self, u_m: f64, v_m: f64, footprint_m: f64) -> f64 {
        let (u, v) = (u_m / self.scale_m, v_m / self.scale_m);
        let f = footprint_m / self.scale_m;
        let p = match self.pattern {
            Pattern::Noise => {
                0.6 * fade(f) * value_noise(u, v, self.seed)
                    + 0.3 * fade(2.03 * f) * value_noise(2.03 * u, 2.03 * v, self.seed ^ 0x9e37)
                    + 0.1 * fade(4.1 * f) * value_noise(4.1 * u, 4.1 * v, self.seed ^ 0x7f4a)
            }
            Pattern::Planks => {
                let board = floor(u);
                let shade = lattice(board as i64, 0, self.seed);
                let grain = value_noise(u * 6.0, v * 0.4, self.seed ^ 0x51);
                let joint = if u - board < JOINT {
                    -fade(0.5 * f / JOINT)
                } else {
                    0.0
                };
                (fade(f) * (0.7 * shade + 0.25 * fade(6.0 * f) * grain) + joint).clamp(-1.0, 1.0)
            }
            Pattern::Tiles => {
                let (iu, iv) = (floor(u), floor(v));
                let shade = lattice(iu as i64, iv as i64, self.seed);
                let joint = u - iu < JOINT || v - iv < JOINT;
                if joint {
                    -fade(0.5 * f / JOINT)
                } else {
                    0.8 * fade(f) * shade
                }
            }
            Pattern::Bands => fade(f) * lattice(0, floor(v) as i64, self.seed),
        };
        (self.base * (1.0 + self.contrast * p)).clamp(0.01, 1.0)
    }
}

/// Width of plank and tile joints, in feature units.
const JOINT: f64 = 0.06;

/// A surface point as a render finds it, with what is dear to compute (the exact
/// footprint, the angle around a pole) computed only when a texture asks for it.
pub(crate) trait Surface {
    /// Surface coordinates, exactly as [`super::scene::Hit`] has them.
    fn u_m(&self) -> f64;
    fn v_m(&self) -> f64;
    /// The pixel's footprint, exactly as [`super::scene::Scene::shade`] computes it.
    fn footprint_m(&self) -> f64;
    /// `(num, den)` with `footprint_m()` within 1e-14 relative of `num / den`,
    /// computed without a division.
    fn footprint_ratio(&self) -> (f64, f64);
}

/// Margin (relative) by which a bound must clear a threshold to be trusted; the
/// bounds themselves are good to about 1e-15.
const CERTAIN_REL: f64 = 1e-12;

/// `f = footprint / scale` for the fall-off of features, exact only when needed: in
/// most pixels a feature is either plainly larger than four footprints (fade 1) or
/// plainly smaller than two (fade 0), and `fade` does not depend on the exact `f`.
struct LazyFootprint<'a, S> {
    surface: &'a S,
    scale_m: f64,
    num: f64,
    /// `num / den_lo <= 0.25` means `f <= 0.25`, certainly; `num / den_hi >= 0.5`,
    /// `f >= 0.5`.
    den_lo: f64,
    den_hi: f64,
    exact: std::cell::Cell<Option<f64>>,
}

impl<'a, S: Surface> LazyFootprint<'a, S> {
    fn new(surface: &'a S, scale_m: f64) -> Self {
        let (num, den) = surface.footprint_ratio();
        let den = den * scale_m;
        Self {
            surface,
            scale_m,
            num,
            // One multiplication each: a bound, so the order of rounding is free.
            den_lo: den * (0.25 * (1.0 - CERTAIN_REL)),
            den_hi: den * (0.5 * (1.0 + CERTAIN_REL)),
            exact: std::cell::Cell::new(None),
        }
    }

    /// The exact `f`, as [`Texture::reflectance`] computes it.
    fn f(&self) -> f64 {
        if let Some(f) = self.exact.get() {
            return f;
        }
        let f = self.surface.footprint_m() / self.scale_m;
        self.exact.set(Some(f));
        f
    }

    /// `fade(arg(f))` where `arg(f)` is about `gain * f`.
    fn fade(&self, gain: f64, arg: impl FnOnce(f64) -> f64) -> f64 {
        let a = gain * self.num;
        if a <= self.den_lo {
            1.0
        } else if a >= self.den_hi {
            0.0
        } else {
            fade(arg(self.f()))
        }
    }
}

/// `(floor(x), x - floor(x) < JOINT)` for `x = x_m / scale_m`, as the textures
/// compute them. (Multiplying by `1 / scale_m` where that provably gives the same
/// answers was tried: no faster than the division, which pipelines.)
fn cell(x_m: f64, scale_m: f64) -> (f64, bool) {
    let x = x_m / scale_m;
    let ix = floor(x);
    (ix, x - ix < JOINT)
}

impl Texture {
    /// [`Texture::reflectance`] of a render's surface point, the same bits, doing
    /// only the work the result depends on.
    ///
    /// A term whose fade is certainly 0 is left out: it is +-0, and adding a zero
    /// leaves any non-zero sum as it is, while a sum of zeros (of either sign) gives
    /// `base * (1 + contrast * 0) = base` all the same.
    ///
    /// `memo` keeps the last lattice hashes: neighbouring pixels mostly see the same
    /// tile, band, board or noise cell.
    ///
    /// Inlined into the render loop: 7 % faster on the arena, 3 % slower on the
    /// shelves and the warehouse (inlining only the tiles and bands was in between).
    #[inline]
    pub(crate) fn reflectance_of(&self, s: &impl Surface, memo: &LatticeMemo) -> f64 {
        let lazy = LazyFootprint::new(s, self.scale_m);
        let p = match self.pattern {
            Pattern::Noise => {
                let w1 = lazy.fade(1.0, |f| f);
                let w2 = lazy.fade(2.03, |f| 2.03 * f);
                let w3 = lazy.fade(4.1, |f| 4.1 * f);
                if w1 == 0.0 && w2 == 0.0 && w3 == 0.0 {
                    0.0
                } else {
                    let (u, v) = (s.u_m() / self.scale_m, s.v_m() / self.scale_m);
                    // `1.0 * u` is `u`, bit for bit.
                    let term = |site: usize, weight: f64, w: f64, k: f64, seed: u32| {
                        if w == 0.0 {
                            0.0
                        } else {
                            weight * w * memo.value_noise(site, k * u, k * v, seed)
                        }
                    };
                    term(0, 0.6, w1, 1.0, self.seed)
                        + term(1, 0.3, w2, 2.03, self.seed ^ 0x9e37)
                        + term(2, 0.1, w3, 4.1, self.seed ^ 0x7f4a)
                }
            }
            Pattern::Planks => {
                let (board, in_joint) = cell(s.u_m(), self.scale_m);
                let joint = if in_joint {
                    -lazy.fade(0.5 / JOINT, |f| 0.5 * f / JOINT)
                } else {
                    0.0
                };
                let w1 = lazy.fade(1.0, |f| f);
                let body = if w1 == 0.0 {
                    0.0
                } else {
                    let shade = memo.lattice(board as i64, 0, self.seed);
                    let w6 = lazy.fade(6.0, |f| 6.0 * f);
                    let grain = if w6 == 0.0 {
                        0.0
                    } else {
                        let (u, v) = (s.u_m() / self.scale_m, s.v_m() / self.scale_m);
                        0.25 * w6 * memo.value_noise(3, u * 6.0, v * 0.4, self.seed ^ 0x51)
                    };
                    w1 * (0.7 * shade + grain)
                };
                (body + joint).clamp(-1.0, 1.0)
            }
            Pattern::Tiles => {
                let (iu, u_joint) = cell(s.u_m(), self.scale_m);
                let (iv, v_joint) = cell(s.v_m(), self.scale_m);
                if u_joint || v_joint {
                    -lazy.fade(0.5 / JOINT, |f| 0.5 * f / JOINT)
                } else {
                    let w = lazy.fade(1.0, |f| f);
                    if w == 0.0 {
                        0.0
                    } else {
                        0.8 * w * memo.lattice(iu as i64, iv as i64, self.seed)
                    }
                }
            }
            Pattern::Bands => {
                let w = lazy.fade(1.0, |f| f);
                if w == 0.0 {
                    0.0
                } else {
                    let (iv, _) = cell(s.v_m(), self.scale_m);
                    w * memo.lattice(0, iv as i64, self.seed)
                }
            }
        };
        (self.base * (1.0 + self.contrast * p)).clamp(0.01, 1.0)
    }
}

/// Contrast kept by a feature whose size is `1 / x` pixel footprints: full from four
/// pixels up, none at two or fewer. A DVS240's lens and its large, low-fill-factor
/// pixels pass little contrast near the sampling limit; without this fall-off,
/// point-sampled detail aliases into patterns that drift against the true motion and
/// fire events no real camera would (FAITH's mean error on a 24-trajectory `bench foe`
/// run: 24 degrees with no fall-off, 9.6 with it from two pixels, 8.3 from four).
fn fade(x: f64) -> f64 {
    (2.0 - 4.0 * x).clamp(0.0, 1.0)
}

/// `x.floor()`, exactly, without a call: the default x86-64 target has no SSE4.1
/// `roundsd`, so `f64::floor` is a libm call, and textures floor twice per pixel.
///
/// Below 2^52 in magnitude, adding and subtracting 2^52 (with the sign of `x`)
/// rounds `x` to an integer (the spacing of doubles there is 1), exactly; one less
/// where that rounded up. `copysign` keeps `floor(-0.0)` at -0.0 (the result otherwise
/// always has the sign of `x`). NaN, infinities and larger magnitudes (integers
/// already) take `f64::floor`. (An `as i64` round trip is exact too, but Rust's
/// saturating cast costs more instructions.)
#[inline]
fn floor(x: f64) -> f64 {
    const TWO_52: f64 = 4_503_599_627_370_496.0;
    if x.abs() < TWO_52 {
        let c = TWO_52.copysign(x);
        let t = (x + c) - c;
        let r = if t > x { t - 1.0 } else { t };
        r.copysign(x)
    } else {
        x.floor()
    }
}

/// The last lattice point hashed and its value: a cache of a pure function, so it
/// changes no result. Starts holding the value of (0, 0, 0).
pub(crate) struct LatticeMemo {
    key: std::cell::Cell<(i64, i64, u32)>,
    value: std::cell::Cell<f64>,
    /// The last noise cell's corners, per call site of [`value_noise`] (the three
    /// octaves and the grain of planks): `(i, j, seed)` and the four values.
    cells: [std::cell::Cell<NoiseCell>; 4],
}

/// A noise cell, `(i, j, seed)`, and its corner values.
type NoiseCell = ((i64, i64, u32), [f64; 4]);

impl LatticeMemo {
    pub(crate) fn new() -> Self {
        Self {
            key: std::cell::Cell::new((0, 0, 0)),
            value: std::cell::Cell::new(lattice(0, 0, 0)),
            cells: std::array::from_fn(|_| {
                std::cell::Cell::new(((0, 0, 0), noise_corners(0, 0, 0)))
            }),
        }
    }

    /// `value_noise(u, v, seed)`, keeping the cell's corners in slot `site`.
    #[inline]
    fn value_noise(&self, site: usize, u: f64, v: f64, seed: u32) -> f64 {
        let (iu, iv) = (floor(u), floor(v));
        let key = (iu as i64, iv as i64, seed);
        let (cached, corners) = self.cells[site].get();
        let corners = if cached == key {
            corners
        } else {
            let corners = noise_corners(key.0, key.1, seed);
            self.cells[site].set((key, corners));
            corners
        };
        noise_blend(u - iu, v - iv, corners)
    }

    /// `lattice(i, j, seed)`.
    #[inline]
    fn lattice(&self, i: i64, j: i64, seed: u32) -> f64 {
        if self.key.get() == (i, j, seed) {
            return self.value.get();
        }
        let value = lattice(i, j, seed);
        self.key.set((i, j, seed));
        self.value.set(value);
        value
    }
}

/// Hash of an integer lattice point to [-1, 1].
fn lattice(i: i64, j: i64, seed: u32) -> f64 {
    lattice_mix(lattice_i(i) ^ lattice_j(j) ^ lattice_seed(seed))
}

/// The three terms of a lattice hash, apart so that the corners of a noise cell can
/// share them: `(i + 1) K = i K + K` in wrapping arithmetic.
const LATTICE_I: u64 = 0x9e37_79b9_7f4a_7c15;
const LATTICE_J: u64 = 0xc2b2_ae3d_27d4_eb4f;

fn lattice_i(i: i64) -> u64 {
    (i as u64).wrapping_mul(LATTICE_I)
}

fn lattice_j(j: i64) -> u64 {
    (j as u64).wrapping_mul(LATTICE_J)
}

fn lattice_seed(seed: u32) -> u64 {
    u64::from(seed).wrapping_mul(0x1656_67b1_9e37_79f9)
}

/// The finaliser of a lattice hash, to [-1, 1].
fn lattice_mix(mut h: u64) -> f64 {
    h ^= h >> 33;
    h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^= h >> 33;
    // Below 2^53 either conversion is exact; x86-64 converts an i64 in one
    // instruction and a u64 in several.
    ((h >> 11) as i64) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

/// Bilinear value noise with smoothstep weights, in [-1, 1].
fn value_noise(u: f64, v: f64, seed: u32) -> f64 {
    let (iu, iv) = (floor(u), floor(v));
    let (i, j) = (iu as i64, iv as i64);
    noise_blend(u - iu, v - iv, noise_corners(i, j, seed))
}

/// The lattice values at the corners (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1).
fn noise_corners(i: i64, j: i64, seed: u32) -> [f64; 4] {
    let s = lattice_seed(seed);
    let (hi0, hj0) = (lattice_i(i), lattice_j(j));
    let (hi1, hj1) = (hi0.wrapping_add(LATTICE_I), hj0.wrapping_add(LATTICE_J));
    [
        lattice_mix(hi0 ^ hj0 ^ s),
        lattice_mix(hi1 ^ hj0 ^ s),
        lattice_mix(hi0 ^ hj1 ^ s),
        lattice_mix(hi1 ^ hj1 ^ s),
    ]
}

/// Bilinear interpolation with smoothstep weights at (fu, fv) in the cell.
fn noise_blend(fu: f64, fv: f64, [a, b, c, d]: [f64; 4]) -> f64 {
    let (su, sv) = (fu * fu * (3.0 - 2.0 * fu), fv * fv * (3.0 - 2.0 * fv));
    let top = a + (b - a) * su;
    let bottom = c + (d - c) * su;
    top + (bottom - top) * sv
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hash as first written, term by term.
    fn lattice_direct(i: i64, j: i64, seed: u32) -> f64 {
        let mut h = (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
            ^ (j as u64).wrapping_mul(0xc2b2_ae3d_27d4_eb4f)
            ^ u64::from(seed).wrapping_mul(0x1656_67b1_9e37_79f9);
        h ^= h >> 33;
        h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 33;
        (h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }

    #[test]
    fn lattice_corners_from_shared_terms_are_the_direct_hash() {
        for (i, j) in [
            (0, 0),
            (-1, 5),
            (i64::MAX, -3),
            (i64::MIN, i64::MAX),
            (123_456, -9),
        ] {
            for seed in [0, 7, u32::MAX] {
                for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (a, b) = (i.wrapping_add(di), j.wrapping_add(dj));
                    let shared = lattice_mix(
                        lattice_i(i).wrapping_add(LATTICE_I * di as u64)
                            ^ lattice_j(j).wrapping_add(LATTICE_J * dj as u64)
                            ^ lattice_seed(seed),
                    );
                    assert_eq!(shared.to_bits(), lattice_direct(a, b, seed).to_bits());
                    assert_eq!(lattice(a, b, seed).to_bits(), shared.to_bits());
                }
            }
        }
    }

    #[test]
    fn floor_matches_the_library_floor_bit_for_bit() {
        let mut specials = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            4_503_599_627_370_495.5,
            -4_503_599_627_370_495.5,
            4_503_599_627_370_496.0,
            -4_503_599_627_370_497.0,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1.0 - f64::EPSILON / 2.0,
            -(1.0 - f64::EPSILON / 2.0),
        ];
        let mut x = 1.234_567e-7_f64;
        while x < 1e18 {
            for v in [
                x,
                -x,
                x.next_up(),
                -x.next_up(),
                x.next_down(),
                -x.next_down(),
            ] {
                specials.push(v);
                specials.push(v.round());
                specials.push(v.round().next_up());
                specials.push(v.round().next_down());
            }
            x *= 1.37;
        }
        for v in specials {
            assert_eq!(floor(v).to_bits(), v.floor().to_bits(), "{v:e}");
        }
        assert!(floor(f64::NAN).is_nan());
    }

    /// A surface point with a footprint as `Scene::shade` computes it.
    struct Point {
        u_m: f64,
        v_m: f64,
        dist_m: f64,
        pixel_rad: f64,
        norm: f64,
        cos_num: f64,
    }

    impl Surface for Point {
        fn u_m(&self) -> f64 {
            self.u_m
        }
        fn v_m(&self) -> f64 {
            self.v_m
        }
        fn footprint_m(&self) -> f64 {
            self.dist_m * self.pixel_rad / (self.cos_num / self.norm).max(0.05)
        }
        fn footprint_ratio(&self) -> (f64, f64) {
            (
                self.dist_m * self.pixel_rad * self.norm,
                self.cos_num.max(0.05 * self.norm),
            )
        }
    }

    /// Footprints spread over every regime of every fade (1, linear, 0, and the
    /// boundaries between), coordinates on and off tile, plank and band edges.
    #[test]
    fn lazy_reflectance_has_the_same_bits_as_the_reference() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(4);
        let patterns = [
            Pattern::Noise,
            Pattern::Planks,
            Pattern::Tiles,
            Pattern::Bands,
        ];
        let mut checked = [0usize; 4];
        let memo = LatticeMemo::new();
        for i in 0..400_000 {
            let pattern = patterns[i % 4];
            let scale_m = [0.35, 0.12, 0.6, 0.05, 0.2][i % 5];
            let t = Texture::new(pattern, scale_m, 0.7, 0.5, 9 + (i % 3) as u32);
            let norm = rng.random_range(0.5..2.0);
            let cos_num = norm * rng.random_range(0.0..1.0f64).powi(3);
            let mut p = Point {
                u_m: rng.random_range(-8.0..8.0),
                v_m: rng.random_range(-4.0..1.0),
                dist_m: 0.0,
                pixel_rad: 1.0 / 195.0,
                norm,
                cos_num,
            };
            // Aim f (footprint / scale) at a fade boundary of some gain now and then.
            let gains = [1.0, 2.03, 4.1, 6.0, 0.5 / JOINT];
            let target_f = if i % 3 == 0 {
                let edge = [0.25, 0.5][i % 2] / gains[(i / 2) % gains.len()];
                edge * (1.0 + 1e-15 * rng.random_range(-4.0..4.0))
            } else {
                rng.random_range(0.0..1.5f64).powi(2)
            };
            // dist * pr / max(c / n, 0.05) / scale = f
            p.dist_m = target_f * scale_m * (p.cos_num / p.norm).max(0.05) / p.pixel_rad;
            // Coordinates on a feature edge or a joint's edge now and then.
            if i % 7 == 0 {
                let k = rng.random_range(-20..20) as f64;
                p.u_m = (k + [0.0, JOINT][i % 2]) * scale_m;
                p.v_m = (k + [JOINT, 0.0][i % 2]) * scale_m;
            }
            let reference = t.reflectance(p.u_m, p.v_m, p.footprint_m());
            assert_eq!(
                t.reflectance_of(&p, &memo).to_bits(),
                reference.to_bits(),
                "{pattern:?} scale {scale_m} at ({}, {}) footprint {}",
                p.u_m,
                p.v_m,
                p.footprint_m()
            );
            checked[i % 4] += 1;
        }
        assert!(checked.iter().all(|&c| c == 100_000));
    }

    #[test]
    fn reflectance_stays_in_range_and_is_deterministic() {
        for pattern in [
            Pattern::Noise,
            Pattern::Planks,
            Pattern::Tiles,
            Pattern::Bands,
        ] {
            let t = Texture::new(pattern, 0.3, 0.9, 0.5, 7);
            let mut lo: f64 = 1.0;
            let mut hi: f64 = 0.0;
            for i in 0..2000 {
                let (u, v) = (f64::from(i) * 0.0137 - 5.0, f64::from(i) * 0.0291 - 9.0);
                let r = t.reflectance(u, v, 0.0);
                assert!((0.01..=1.0).contains(&r));
                assert_eq!(r, t.reflectance(u, v, 0.0));
                lo = lo.min(r);
                hi = hi.max(r);
            }
            assert!(
                hi / lo > 1.5,
                "{pattern:?} has too little contrast: {lo}..{hi}"
            );
        }
    }

    #[test]
    fn features_smaller_than_the_footprint_fade_to_the_mean() {
        for pattern in [
            Pattern::Noise,
            Pattern::Planks,
            Pattern::Tiles,
            Pattern::Bands,
        ] {
            let t = Texture::new(pattern, 0.1, 0.9, 0.5, 3);
            for i in 0..200 {
                let r = t.reflectance(f64::from(i) * 0.013, f64::from(i) * 0.007, 1.0);
                assert!((r - 0.5).abs() < 1e-9, "{pattern:?}: {r}");
            }
        }
    }

    #[test]
    fn low_contrast_texture_varies_little() {
        let t = Texture::new(Pattern::Noise, 0.5, 0.05, 0.5, 1);
        for i in 0..500 {
            let r = t.reflectance(f64::from(i) * 0.05, 0.3, 0.0);
            assert!((0.47..=0.53).contains(&r), "{r}");
        }
    }
}
