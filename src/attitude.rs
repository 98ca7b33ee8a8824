//! Autopilot attitude samples and their alignment to event time.

use nalgebra::Vector3;

/// One ATTITUDE report of the autopilot, stamped in the event camera's time base.
///
/// Angles and rates follow MAVLink: FRD body axes, radians and radians per second.
/// Aligning the autopilot clock to the camera clock is the adapters' job; the core
/// only ever sees camera time.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct AttitudeSample {
    pub t_us: i64,
    pub roll_rad: f64,
    pub pitch_rad: f64,
    pub yaw_rad: f64,
    pub roll_rate_rad_s: f64,
    pub pitch_rate_rad_s: f64,
    pub yaw_rate_rad_s: f64,
}

impl AttitudeSample {
    pub fn body_rates_rad_s(&self) -> Vector3<f64> {
        Vector3::new(
            self.roll_rate_rad_s,
            self.pitch_rate_rad_s,
            self.yaw_rate_rad_s,
        )
    }
}

/// Body rates at `t_us`, linearly interpolated between the samples around it.
///
/// `samples` must be sorted by time. Outside the covered span the nearest sample is
/// held (the autopilot reports at 50 Hz or more, so a hold is at most one period).
/// Returns `None` when there are no samples at all: derotation then cannot run and the
/// caller must say so rather than assume the vehicle is not rotating.
pub fn body_rates_at(samples: &[AttitudeSample], t_us: i64) -> Option<Vector3<f64>> {
    let first = samples.first()?;
    let last = samples.last()?;
    if t_us <= first.t_us {
        return Some(first.body_rates_rad_s());
    }
    if t_us >= last.t_us {
        return Some(last.body_rates_rad_s());
    }
    let after = samples.partition_point(|s| s.t_us <= t_us);
    let (a, b) = (&samples[after - 1], &samples[after]);
    let span_us = (b.t_us - a.t_us) as f64;
    let w = if span_us > 0.0 {
        (t_us - a.t_us) as f64 / span_us
    } else {
        0.0
    };
    Some(a.body_rates_rad_s() * (1.0 - w) + b.body_rates_rad_s() * w)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t_us: i64, yaw_rate: f64) -> AttitudeSample {
        AttitudeSample {
            t_us,
            yaw_rate_rad_s: yaw_rate,
            ..Default::default()
        }
    }

    #[test]
    fn interpolates_between_samples_and_holds_at_ends() {
        let s = [sample(0, 0.0), sample(1000, 1.0), sample(3000, -1.0)];
        assert_eq!(body_rates_at(&s, 500).unwrap().z, 0.5);
        assert_eq!(body_rates_at(&s, 2000).unwrap().z, 0.0);
        assert_eq!(body_rates_at(&s, -10).unwrap().z, 0.0);
        assert_eq!(body_rates_at(&s, 9000).unwrap().z, -1.0);
        assert!(body_rates_at(&[], 0).is_none());
    }
}
