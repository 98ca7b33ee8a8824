//! Normal flow of a camera translating towards a fronto-parallel scene.

use crate::math;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64Mcg;

use crate::camera::CameraIntrinsics;
use crate::flow::FlowVector;

/// What to generate: where the FOE is, how many vectors, and how dirty they are.
#[derive(Clone, Copy, Debug)]
pub struct FlowFieldSpec {
    /// True focus of expansion in pixels (may lie outside the sensor).
    pub foe_px: (f64, f64),
    /// Inverse time to contact W/Z in 1/s shared by all points (one depth plane).
    pub divergence_per_s: f64,
    pub vectors: usize,
    /// Standard deviation of the direction error of each normal flow vector, degrees.
    pub angle_noise_deg: f64,
    /// Relative standard deviation of the speed (0.1 = 10 %).
    pub speed_noise_rel: f64,
    /// Fraction of vectors replaced by random ones (outliers), 0..1.
    pub outlier_fraction: f64,
}

impl FlowFieldSpec {
    pub fn clean(foe_px: (f64, f64), vectors: usize) -> Self {
        Self {
            foe_px,
            divergence_per_s: 1.0,
            vectors,
            angle_noise_deg: 0.0,
            speed_noise_rel: 0.0,
            outlier_fraction: 0.0,
        }
    }
}

/// Normal flow at random pixels over random edge orientations.
///
/// The true flow at `p` is `(p - foe) * W/Z`; an edge of random orientation only shows
/// its projection on the edge normal, which is what event-based normal flow measures.
/// Vectors whose normal flow would be nearly zero (edge aligned with the radial
/// direction) are redrawn, as a real flow estimator would not report them either.
pub fn radial_normal_flow(
    camera: &CameraIntrinsics,
    spec: &FlowFieldSpec,
    seed: u64,
) -> Vec<FlowVector> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let angle_noise =
        Normal::new(0.0, spec.angle_noise_deg.to_radians().max(0.0)).expect("finite angle noise");
    let speed_noise = Normal::new(1.0, spec.speed_noise_rel.max(0.0)).expect("finite speed noise");
    let w = f64::from(camera.width_px);
    let h = f64::from(camera.height_px);
    let mut out = Vec::with_capacity(spec.vectors);
    let mut t_us = 0i64;
    while out.len() < spec.vectors {
        let x = rng.random_range(0.0..w - 1.0);
        let y = rng.random_range(0.0..h - 1.0);
        t_us += 10;
        if rng.random_bool(spec.outlier_fraction.clamp(0.0, 1.0)) {
            let dir = rng.random_range(0.0..std::f64::consts::TAU);
            let speed = rng.random_range(5.0..200.0);
            out.push(FlowVector::new(
                t_us,
                x,
                y,
                speed * math::cos(dir),
                speed * math::sin(dir),
            ));
            continue;
        }
        let (tx, ty) = (
            (x - spec.foe_px.0) * spec.divergence_per_s,
            (y - spec.foe_px.1) * spec.divergence_per_s,
        );
        let normal_angle = rng.random_range(0.0..std::f64::consts::TAU);
        let (nx, ny) = (math::cos(normal_angle), math::sin(normal_angle));
        let along = tx * nx + ty * ny;
        // Skip edges that hide nearly all of the motion; orient the normal with the flow.
        if along.abs() < 0.3 * math::hypot(tx, ty) || along.abs() < 1e-6 {
            continue;
        }
        let (nx, ny, mag) = if along < 0.0 {
            (-nx, -ny, -along)
        } else {
            (nx, ny, along)
        };
        let dth = angle_noise.sample(&mut rng);
        let (c, s) = (math::cos(dth), math::sin(dth));
        let mag = mag * speed_noise.sample(&mut rng).max(0.05);
        let (ux, uy) = (c * nx - s * ny, s * nx + c * ny);
        out.push(FlowVector::new(t_us, x, y, mag * ux, mag * uy));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clean_vectors_point_away_from_foe() {
        let cam = CameraIntrinsics::dvs240();
        let spec = FlowFieldSpec::clean((100.0, 80.0), 500);
        let flow = radial_normal_flow(&cam, &spec, 1);
        assert_eq!(flow.len(), 500);
        for f in &flow {
            let away = (f.x_px - 100.0) * f.u_px_s + (f.y_px - 80.0) * f.v_px_s;
            assert!(away > 0.0);
        }
    }

    #[test]
    fn same_seed_same_field() {
        let cam = CameraIntrinsics::dvs240();
        let mut spec = FlowFieldSpec::clean((10.0, 20.0), 100);
        spec.angle_noise_deg = 5.0;
        spec.outlier_fraction = 0.2;
        assert_eq!(
            radial_normal_flow(&cam, &spec, 7),
            radial_normal_flow(&cam, &spec, 7)
        );
    }
}
