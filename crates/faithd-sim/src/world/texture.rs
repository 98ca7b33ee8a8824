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
/// Truncation toward zero is exact below 2^52 (every such double's integer part is a
/// double); one less for a negative non-integer. `copysign` keeps `floor(-0.0)` at
/// -0.0 (the result otherwise always has the sign of `x`). NaN, infinities and
/// larger magnitudes (integers already) take `f64::floor`.
#[inline]
fn floor(x: f64) -> f64 {
    const TWO_52: f64 = 4_503_599_627_370_496.0;
    if x.abs() < TWO_52 {
        let t = x as i64 as f64;
        let r = if t > x { t - 1.0 } else { t };
        r.copysign(x)
    } else {
        x.floor()
    }
}

/// Hash of an integer lattice point to [-1, 1].
fn lattice(i: i64, j: i64, seed: u32) -> f64 {
    let mut h = (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
        ^ (j as u64).wrapping_mul(0xc2b2_ae3d_27d4_eb4f)
        ^ u64::from(seed).wrapping_mul(0x1656_67b1_9e37_79f9);
    h ^= h >> 33;
    h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^= h >> 33;
    (h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

/// Bilinear value noise with smoothstep weights, in [-1, 1].
fn value_noise(u: f64, v: f64, seed: u32) -> f64 {
    let (iu, iv) = (floor(u), floor(v));
    let (fu, fv) = (u - iu, v - iv);
    let (su, sv) = (fu * fu * (3.0 - 2.0 * fu), fv * fv * (3.0 - 2.0 * fv));
    let (i, j) = (iu as i64, iv as i64);
    let a = lattice(i, j, seed);
    let b = lattice(i + 1, j, seed);
    let c = lattice(i, j + 1, seed);
    let d = lattice(i + 1, j + 1, seed);
    let top = a + (b - a) * su;
    let bottom = c + (d - c) * su;
    top + (bottom - top) * sv
}

#[cfg(test)]
mod tests {
    use super::*;

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
