//! Where a flight with iNav's SITL goes: the course line at the pole and the height,
//! as the flight sets up the world and the pilot flies it.

use nalgebra::Vector3;

use crate::closed_loop::FlightSpec;

/// The vehicle takes off this far behind the point where the model's flight starts,
/// so that it has reached its cruise speed there (2 m/s takes the pilot about two
/// seconds and three metres).
pub const RUN_UP_M: f64 = 4.0;

/// Cruise height, metres (the model flies at 1 m).
pub const HEIGHT_M: f64 = 1.0;

/// The flight's course: the straight line through `spec`'s offset beside the first
/// pole, along its heading.
#[derive(Clone, Copy, Debug)]
pub struct Course {
    pub forward: Vector3<f64>,
    pub right: Vector3<f64>,
    /// Abeam the first pole, at the offset, on the ground.
    pub abeam_m: Vector3<f64>,
}

impl Course {
    pub fn of(spec: &FlightSpec) -> Self {
        let (s, c) = spec.heading_deg.to_radians().sin_cos();
        let forward = Vector3::new(c, s, 0.0);
        let right = Vector3::new(-s, c, 0.0);
        let pole = spec.poles[0];
        Self {
            forward,
            right,
            abeam_m: Vector3::new(pole.0, pole.1, 0.0) + right * spec.lateral_offset_m,
        }
    }

    /// Distance still to fly to abeam the pole (negative past it).
    pub fn to_go_m(&self, position_m: &Vector3<f64>) -> f64 {
        (self.abeam_m - position_m).dot(&self.forward)
    }

    /// How far right of the course line.
    pub fn off_track_m(&self, position_m: &Vector3<f64>) -> f64 {
        (position_m - self.abeam_m).dot(&self.right)
    }

    pub fn takeoff_m(&self, spec: &FlightSpec) -> Vector3<f64> {
        self.abeam_m - self.forward * (spec.start_distance_m + RUN_UP_M)
    }
}
