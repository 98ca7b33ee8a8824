//! The transcendental functions of the core, the same bits on every architecture and
//! every C library.
//!
//! `f64::hypot`, `sin` and the rest call the platform's C library, and its answers
//! are not the same everywhere: glibc 2.36's `hypot` differs in the last bit between
//! x86-64 and arm64 on 13 % of random inputs (its arm64 build fuses multiply-adds),
//! and glibc's versions differ among themselves (a Pi on Bullseye has 2.31, a laptop
//! 2.36). One bit is enough to carry a time to contact across a threshold, so a flight
//! recorded on the drone could replay to another decision on a laptop. These are the
//! `libm` crate's Rust ports of musl's functions: rustc neither fuses nor reorders
//! floating-point arithmetic, and their only hardware instructions (sqrt, fma,
//! rounding) are exact in IEEE 754, so the same input gives the same output wherever
//! faithd runs. `sqrt`, `abs`, `floor`, `mul_add` and the four operations are exact
//! already and stay as they are. `clippy.toml` beside this crate's manifest refuses
//! the platform's versions here.

/// Sine of `x` radians.
pub fn sin(x: f64) -> f64 {
    libm::sin(x)
}

/// Cosine of `x` radians.
pub fn cos(x: f64) -> f64 {
    libm::cos(x)
}

/// Tangent of `x` radians.
pub fn tan(x: f64) -> f64 {
    libm::tan(x)
}

/// Arc tangent of `x`, radians.
pub fn atan(x: f64) -> f64 {
    libm::atan(x)
}

/// The angle of the point (`x`, `y`) from the +x axis, radians in [-pi, pi].
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}

/// Arc cosine of `x`, radians in [0, pi].
pub fn acos(x: f64) -> f64 {
    libm::acos(x)
}

/// The length of (`x`, `y`), without overflow or underflow on the way.
pub fn hypot(x: f64, y: f64) -> f64 {
    libm::hypot(x, y)
}

/// e to the power `x`.
pub fn exp(x: f64) -> f64 {
    libm::exp(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values whose correctly rounded results are known exactly: the functions are
    /// wired to the right implementations and the argument order is right.
    #[test]
    fn exact_values_come_back_exactly() {
        assert_eq!(hypot(3.0, 4.0), 5.0);
        assert_eq!(hypot(-5.0, 12.0), 13.0);
        assert_eq!(atan2(1.0, 0.0), std::f64::consts::FRAC_PI_2);
        assert_eq!(atan2(0.0, -1.0), std::f64::consts::PI);
        assert_eq!(atan(1.0), std::f64::consts::FRAC_PI_4);
        assert_eq!(acos(-1.0), std::f64::consts::PI);
        assert_eq!(cos(0.0), 1.0);
        assert_eq!(sin(0.0), 0.0);
        assert_eq!(tan(0.0), 0.0);
        assert_eq!(exp(0.0), 1.0);
    }

    /// Within one unit in the last place of the platform's answer, over many inputs:
    /// the same functions, only the last bit may differ.
    #[test]
    fn agree_with_the_platform_within_an_ulp() {
        let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs();
        for i in 0..20_000 {
            let x = (f64::from(i) - 10_000.0) * 0.000_731;
            let y = (f64::from(i % 977) - 488.0) * 0.0113;
            #[allow(clippy::disallowed_methods)]
            let pairs = [
                (sin(x), x.sin()),
                (cos(x), x.cos()),
                (tan(x * 0.2), (x * 0.2).tan()),
                (atan(x), x.atan()),
                (atan2(y, x), y.atan2(x)),
                (acos(x / 8.0), (x / 8.0).acos()),
                (hypot(x, y), x.hypot(y)),
                (exp(x), x.exp()),
            ];
            for (k, (ours, platform)) in pairs.into_iter().enumerate() {
                assert!(
                    ulps(ours, platform) <= 1,
                    "function {k} at ({x}, {y}): {ours} vs {platform}"
                );
            }
        }
    }
}
