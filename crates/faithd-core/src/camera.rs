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

    /// DAVIS346 (346 x 260, 18.5 um pixels) behind a lens giving the DVS240 preset's
    /// field of view (63.2 x 49.6 degrees: a 5.2 mm lens), so that a scene seen by
    /// both looks the same, only finer.
    pub fn davis346() -> Self {
        Self::with_dvs240_view(346, 260)
    }

    /// DVXplorer (640 x 480, 9 um pixels) behind a lens giving the DVS240 preset's
    /// field of view (63.2 x 49.6 degrees: a 4.7 mm lens).
    pub fn dvxplorer() -> Self {
        Self::with_dvs240_view(640, 480)
    }

    /// DVXplorer Lite (320 x 240) behind a lens giving the DVS240 preset's field of view.
    pub fn dvxplorer_lite() -> Self {
        Self::with_dvs240_view(320, 240)
    }

    /// A sensor of `width_px` x `height_px` seeing what the DVS240 preset sees: the
    /// focal length grows with the width (the DVS240's 195 px per 240 columns), the
    /// principal point sits at the centre. Every preset's aspect is within 0.2 % of
    /// the DVS240's 4:3, so the vertical field of view matches too.
    fn with_dvs240_view(width_px: u16, height_px: u16) -> Self {
        let reference = Self::dvs240();
        let f_px = reference.fx_px * f64::from(width_px) / f64::from(reference.width_px);
        Self {
            width_px,
            height_px,
            fx_px: f_px,
            fy_px: f_px,
            cx_px: (f64::from(width_px) - 1.0) / 2.0,
            cy_px: (f64::from(height_px) - 1.0) / 2.0,
        }
    }

    /// Pixels of this camera per pixel of the DVS240 preset at the centre of the view
    /// (the ratio of focal lengths): what a length tuned in DVS240 pixels becomes here.
    pub fn px_per_dvs240_px(&self) -> f64 {
        self.fx_px / Self::dvs240().fx_px
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

/// The iniVation cameras faithd has intrinsics for, by the names the command line
/// takes (`--camera`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CameraPreset {
    /// DAVIS240 (the DVS240 sensor, 240 x 180): what faithd has flown with.
    #[default]
    Davis240,
    Davis346,
    Dvxplorer,
    DvxplorerLite,
}

impl CameraPreset {
    pub const ALL: [CameraPreset; 4] = [
        CameraPreset::Davis240,
        CameraPreset::Davis346,
        CameraPreset::Dvxplorer,
        CameraPreset::DvxplorerLite,
    ];

    /// The name `--camera` takes and reports print.
    pub fn name(self) -> &'static str {
        match self {
            CameraPreset::Davis240 => "davis240",
            CameraPreset::Davis346 => "davis346",
            CameraPreset::Dvxplorer => "dvxplorer",
            CameraPreset::DvxplorerLite => "dvxplorer-lite",
        }
    }

    /// The preset's intrinsics, all with the DVS240 preset's field of view.
    pub fn intrinsics(self) -> CameraIntrinsics {
        match self {
            CameraPreset::Davis240 => CameraIntrinsics::dvs240(),
            CameraPreset::Davis346 => CameraIntrinsics::davis346(),
            CameraPreset::Dvxplorer => CameraIntrinsics::dvxplorer(),
            CameraPreset::DvxplorerLite => CameraIntrinsics::dvxplorer_lite(),
        }
    }
}

impl std::fmt::Display for CameraPreset {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A camera name no preset has; says which names there are.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownCamera(pub String);

impl std::fmt::Display for UnknownCamera {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<&str> = CameraPreset::ALL.iter().map(|c| c.name()).collect();
        write!(
            f,
            "no camera `{}`: the cameras are {}",
            self.0,
            names.join(", ")
        )
    }
}

impl std::error::Error for UnknownCamera {}

impl std::str::FromStr for CameraPreset {
    type Err = UnknownCamera;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        CameraPreset::ALL
            .into_iter()
            .find(|c| c.name().eq_ignore_ascii_case(text))
            .ok_or_else(|| UnknownCamera(text.to_string()))
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
    fn the_presets_see_the_dvs240s_field_of_view() {
        let half_fov_deg = |cam: &CameraIntrinsics| {
            let x = cam.angle_between_deg((cam.cx_px, cam.cy_px), (-0.5, cam.cy_px));
            let y = cam.angle_between_deg((cam.cx_px, cam.cy_px), (cam.cx_px, -0.5));
            (x, y)
        };
        let reference = half_fov_deg(&CameraIntrinsics::dvs240());
        for preset in CameraPreset::ALL {
            let cam = preset.intrinsics();
            cam.validate().unwrap();
            let (x, y) = half_fov_deg(&cam);
            assert!(
                (x - reference.0).abs() < 0.01,
                "{preset}: {x} vs {reference:?}"
            );
            assert!(
                (y - reference.1).abs() < 0.1,
                "{preset}: {y} vs {reference:?}"
            );
        }
        assert_eq!(
            CameraPreset::Davis240.intrinsics(),
            CameraIntrinsics::dvs240()
        );
        assert_eq!(CameraIntrinsics::dvs240().px_per_dvs240_px(), 1.0);
        let dvx = CameraIntrinsics::dvxplorer();
        assert_eq!((dvx.width_px, dvx.height_px, dvx.fx_px), (640, 480, 520.0));
    }

    #[test]
    fn camera_names_parse_and_a_wrong_one_names_the_right_ones() {
        for preset in CameraPreset::ALL {
            assert_eq!(preset.name().parse::<CameraPreset>(), Ok(preset));
        }
        let err = "dvs640".parse::<CameraPreset>().unwrap_err().to_string();
        assert_eq!(
            err,
            "no camera `dvs640`: the cameras are davis240, davis346, dvxplorer, dvxplorer-lite"
        );
    }

    #[test]
    fn angle_between_principal_point_and_edge() {
        let cam = CameraIntrinsics::dvs240();
        let a = cam.angle_between_deg((cam.cx_px, cam.cy_px), (cam.cx_px + cam.fx_px, cam.cy_px));
        assert!((a - 45.0).abs() < 1e-9);
    }
}
