//! The distance every DBSCAN variant measures with, in a module of its own so that the
//! reference and the two grids share it without depending on one another.

/// Squared distance, in this order of operations everywhere: the grids must decide
/// "within eps" exactly as the reference does.
#[inline]
pub(super) fn dist2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let (dx, dy, dz) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    dx * dx + dy * dy + dz * dz
}
