//! Pinhole intrinsics of the event camera, and the body-to-camera mounting.

use crate::math;
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::invalid::{Invalid, check, positive};

/// Pinhole model of the sensor in pixels.
///
/// Derotation needs it to turn body rates into image motion, and the FOE needs it to
/// turn an image point into a course angle. Defaults are a DVS240 (240x180, 18.5 um
/// pixels) behind a 4.5 mm lens, as on the paper's vehicle; calibrate and override.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraIntrinsics {
    pub width_px: u16,
    pub height_px: u16,
    pub fx_px: f64,
    pub fy_px: f64,
    pub cx_px: f64,
    pub cy_px: f64,
}

impl Default for CameraIntrinsics {
    fn default() -> Self {
        Self::dvs240()
    }
}

impl CameraIntrinsics {
    /// The sensor size bounds the per-pixel buffers; the principal point lies on it.
    pub fn validate(&self) -> Result<(), Invalid> {
        let cam = self;
        check(
            (8..=2048).contains(&cam.width_px) && (8..=2048).contains(&cam.height_px),
            "pipeline.camera.width_px",
            || {
                format!(
                    "sensor must be 8x8 to 2048x2048 px (event surfaces are allocated per pixel), got {}x{}",
                    cam.width_px, cam.height_px
                )
            },
        )?;
        positive(cam.fx_px, "pipeline.camera.fx_px")?;
        positive(cam.fy_px, "pipeline.camera.fy_px")?;
        check(
            cam.cx_px.is_finite() && (0.0..f64::from(cam.width_px)).contains(&cam.cx_px),
            "pipeline.camera.cx_px",
            || {
                format!(
                    "must lie on the sensor (0..{}), got {}",
                    cam.width_px, cam.cx_px
                )
            },
        )?;
        check(
            cam.cy_px.is_finite() && (0.0..f64::from(cam.height_px)).contains(&cam.cy_px),
            "pipeline.camera.cy_px",
            || {
                format!(
                    "must lie on the sensor (0..{}), got {}",
                    cam.height_px, cam.cy_px
                )
            },
        )?;
        Ok(())
    }
}

impl CameraIntrinsics {
    /// DVS240 with a lens giving about 64 x 50 degrees of field of view.
    pub fn dvs240() -> Self {
        Self {
            width_px: 240,
            height_px: 180,
            fx_px: 195.0,
            fy_px: 195.0,
            cx_px: 119.5,
            cy_px: 89.5,
        }
    }

    /// Image point (pixels) to normalised image plane coordinates (x/z, y/z).
    pub fn normalise(&self, x_px: f64, y_px: f64) -> (f64, f64) {
        (
            (x_px - self.cx_px) / self.fx_px,
            (y_px - self.cy_px) / self.fy_px,
        )
    }

    /// Normalised image plane coordinates back to pixels.
    pub fn to_pixels(&self, x_n: f64, y_n: f64) -> (f64, f64) {
        (x_n * self.fx_px + self.cx_px, y_n * self.fy_px + self.cy_px)
    }

    /// Unit viewing ray of a pixel, in camera axes (x right, y down, z forward).
    pub fn ray(&self, x_px: f64, y_px: f64) -> Vector3<f64> {
        let (x_n, y_n) = self.normalise(x_px, y_px);
        Vector3::new(x_n, y_n, 1.0).normalize()
    }

    /// Projects a direction in camera axes to pixels; `None` when it points behind.
    pub fn project(&self, dir_cam: &Vector3<f64>) -> Option<(f64, f64)> {
        if dir_cam.z <= 1e-12 {
            return None;
        }
        Some(self.to_pixels(dir_cam.x / dir_cam.z, dir_cam.y / dir_cam.z))
    }

    /// Angle in degrees between the viewing rays of two pixels; the paper's course error.
    pub fn angle_between_deg(&self, a_px: (f64, f64), b_px: (f64, f64)) -> f64 {
        let dot = self.ray(a_px.0, a_px.1).dot(&self.ray(b_px.0, b_px.1));
        math::acos(dot.clamp(-1.0, 1.0)).to_degrees()
    }

    /// True when the pixel coordinate lies on the sensor.
    pub fn contains(&self, x_px: f64, y_px: f64) -> bool {
        x_px >= -0.5
            && y_px >= -0.5
            && x_px <= f64::from(self.width_px) - 0.5
            && y_px <= f64::from(self.height_px) - 0.5
    }

    pub fn pixel_count(&self) -> usize {
        usize::from(self.width_px) * usize::from(self.height_px)
    }
}

/// How the camera sits on the airframe.
///
/// MAVLink body rates are in FRD body axes (x forward, y right, z down); the optic-flow
/// equations want them in camera axes (x right, y down, z forward). A forward-looking
/// camera is the default; a tilted or rolled mount changes this matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mounting {
    pub body_to_camera: Matrix3<f64>,
}

impl Default for Mounting {
    fn default() -> Self {
        Self::forward()
    }
}

impl Mounting {
    /// Camera looking along the body x axis, image x to the right wing, image y down.
    pub fn forward() -> Self {
        #[rustfmt::skip]
        let body_to_camera = Matrix3::new(
            0.0, 1.0, 0.0,
            0.0, 0.0, 1.0,
            1.0, 0.0, 0.0,
        );
        Self { body_to_camera }
    }

    /// Forward camera pitched up by `pitch_up_deg` (a common FPV camera tilt).
    pub fn forward_pitched_up(pitch_up_deg: f64) -> Self {
        let th = pitch_up_deg.to_radians();
        // Rotation of the camera about the body y axis: the optical axis tilts up.
        #[rustfmt::skip]
        let tilt = Matrix3::new(
            math::cos(th), 0.0, -math::sin(th),
            0.0,      1.0,  0.0,
            math::sin(th), 0.0,  math::cos(th),
        );
        Self {
            body_to_camera: Self::forward().body_to_camera * tilt,
        }
    }

    /// Body angular rate (FRD, rad/s) expressed in camera axes.
    pub fn rates_in_camera(&self, body_rates_rad_s: Vector3<f64>) -> Vector3<f64> {
        self.body_to_camera * body_rates_rad_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forward_mount_maps_yaw_to_camera_y() {
        let m = Mounting::forward();
        let w = m.rates_in_camera(Vector3::new(0.0, 0.0, 1.0));
        assert_eq!(w, Vector3::new(0.0, 1.0, 0.0));
        let w = m.rates_in_camera(Vector3::new(1.0, 0.0, 0.0));
        assert_eq!(w, Vector3::new(0.0, 0.0, 1.0));
    }

    #[test]
    fn pitched_mount_sees_forward_above_centre() {
        let cam = CameraIntrinsics::dvs240();
        let m = Mounting::forward_pitched_up(10.0);
        let fwd_cam = m.body_to_camera * Vector3::new(1.0, 0.0, 0.0);
        let (x, y) = cam.project(&fwd_cam).unwrap();
        assert!((x - cam.cx_px).abs() < 1e-9);
        // Camera tilted up: the direction of travel appears below the image centre.
        assert!(y > cam.cy_px, "y {y}");
    }

    #[test]
    fn angle_between_principal_point_and_edge() {
        let cam = CameraIntrinsics::dvs240();
        let a = cam.angle_between_deg((cam.cx_px, cam.cy_px), (cam.cx_px + cam.fx_px, cam.cy_px));
        assert!((a - 45.0).abs() < 1e-9);
    }
}
