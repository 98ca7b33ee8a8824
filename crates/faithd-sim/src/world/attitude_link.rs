//! The body rates as the autopilot's link delivers them to derotation.
//!
//! The simulator's gyro ([`super::imu_samples`]) reports at 100 Hz with rates in
//! f64. faithd never gets that: iNav sends its filtered gyro, `gyro.gyroADCf`
//! (degrees per second, f32), over one of two links, each coarser in its own way.
//!
//! - MAVLink ATTITUDE (iNav's telemetry/mavlink.c): the rates as f32 degrees per
//!   second, one message every 40 ms with `mavlink_extra1_rate = 50`, since iNav's
//!   streams top out at 25 Hz whatever the setting (docs/inav.md, measured 24.6 Hz;
//!   faithd-daemon's `fc_check::mavlink_stream_period_us`).
//! - MSP_RAW_IMU, on the MSP-only link (faithd-daemon's `link/over_msp.rs`): int16
//!   whole degrees per second, iNav's sensors/gyro.c `gyroRateDps`,
//!   `lrintf(gyro.gyroADCf[axis])`, asked once every 40 ms (25 Hz: what a port that
//!   serves 100 commands a second can give the gyro at half its load, shared with
//!   the pilot's channels and iNav's status).
//!
//! Either way each sample keeps the time iNav read the gyro: the daemon stamps an
//! ATTITUDE with its `time_boot_ms` and an MSP reply with its arrival less its time
//! on the wire. What the bench asks is what the coarser rates cost the FOE, so
//! nothing else of the link (latency, lost replies) is modelled. The angles are left
//! as they are: derotation reads the rates alone.

use serde::{Deserialize, Serialize};

use faithd_core::attitude::AttitudeSample;

/// iNav's MAVLink ATTITUDE period at `mavlink_extra1_rate = 50`: 40 ms.
pub const MAVLINK_ATTITUDE_PERIOD_US: i64 = 40_000;
/// The MSP-only link asks for MSP_RAW_IMU every 40 ms.
pub const MSP_RAW_IMU_PERIOD_US: i64 = 40_000;

/// The link whose body rates derotate the flow (`bench foe --attitude-link`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AttitudeLink {
    /// The simulator's gyro as it is: 100 Hz, f64 rates. What every `bench foe`
    /// figure before this option was measured with.
    #[default]
    Imu,
    /// iNav's MAVLink ATTITUDE: 25 Hz, rates as f32 degrees per second.
    Mavlink,
    /// iNav's MSP_RAW_IMU: 25 Hz, rates in whole degrees per second.
    Msp,
}

impl AttitudeLink {
    pub const ALL: [AttitudeLink; 3] =
        [AttitudeLink::Imu, AttitudeLink::Mavlink, AttitudeLink::Msp];

    /// The name `--attitude-link` takes and reports print.
    pub fn name(self) -> &'static str {
        match self {
            AttitudeLink::Imu => "imu",
            AttitudeLink::Mavlink => "mavlink",
            AttitudeLink::Msp => "msp",
        }
    }

    /// What the link delivers, for a report's header.
    pub fn describe(self) -> &'static str {
        match self {
            AttitudeLink::Imu => "the simulator's gyro, 100 Hz, f64 rad/s",
            AttitudeLink::Mavlink => "iNav's ATTITUDE, 25 Hz, f32 deg/s",
            AttitudeLink::Msp => "iNav's MSP_RAW_IMU, 25 Hz, whole deg/s",
        }
    }

    /// Time between the link's samples; `None` keeps every sample of the gyro.
    pub fn period_us(self) -> Option<i64> {
        match self {
            AttitudeLink::Imu => None,
            AttitudeLink::Mavlink => Some(MAVLINK_ATTITUDE_PERIOD_US),
            AttitudeLink::Msp => Some(MSP_RAW_IMU_PERIOD_US),
        }
    }

    /// One body rate (rad/s) as derotation reads it off the link, rad/s.
    ///
    /// iNav's body frame is forward-left-up (pitch and yaw negated against
    /// derotation's forward-right-down), and both roundings below are odd
    /// functions, so rounding here in forward-right-down gives what rounding in
    /// iNav's frame and negating gives.
    pub fn rate_rad_s(self, rate_rad_s: f64) -> f64 {
        let deg_s = rate_rad_s.to_degrees() as f32;
        match self {
            AttitudeLink::Imu => rate_rad_s,
            // gyroADCf as it is, an f32; the daemon widens it to f64
            // (`telemetry::attitude_sample`).
            AttitudeLink::Mavlink => f64::from(deg_s).to_radians(),
            // lrintf in the default rounding mode: to the nearest, ties to even
            // (2.5 -> 2), not lroundf's ties away from zero. The gyro's full scale,
            // 2000 deg/s, fits int16.
            AttitudeLink::Msp => f64::from(deg_s.round_ties_even()).to_radians(),
        }
    }

    /// The samples derotation gets over this link from the gyro's `samples`
    /// (sorted by time): one every [`Self::period_us`] from the first on, its time
    /// kept, its rates through [`Self::rate_rad_s`].
    pub fn deliver(self, samples: &[AttitudeSample]) -> Vec<AttitudeSample> {
        let Some(period_us) = self.period_us() else {
            return samples.to_vec();
        };
        let mut next_us = i64::MIN;
        samples
            .iter()
            .filter(|s| {
                let due = s.t_us >= next_us;
                if due {
                    next_us = s.t_us + period_us;
                }
                due
            })
            .map(|s| AttitudeSample {
                roll_rate_rad_s: self.rate_rad_s(s.roll_rate_rad_s),
                pitch_rate_rad_s: self.rate_rad_s(s.pitch_rate_rad_s),
                yaw_rate_rad_s: self.rate_rad_s(s.yaw_rate_rad_s),
                ..*s
            })
            .collect()
    }
}

impl std::fmt::Display for AttitudeLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A link name there is none of; says which names there are.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownAttitudeLink(pub String);

impl std::fmt::Display for UnknownAttitudeLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<&str> = AttitudeLink::ALL.iter().map(|l| l.name()).collect();
        write!(
            f,
            "no attitude link `{}`: the links are {}",
            self.0,
            names.join(", ")
        )
    }
}

impl std::error::Error for UnknownAttitudeLink {}

impl std::str::FromStr for AttitudeLink {
    type Err = UnknownAttitudeLink;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        AttitudeLink::ALL
            .into_iter()
            .find(|l| l.name().eq_ignore_ascii_case(text))
            .ok_or_else(|| UnknownAttitudeLink(text.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn deg_s(rate_rad_s: f64) -> f64 {
        rate_rad_s.to_degrees()
    }

    /// 100 Hz gyro samples over 0..=400 ms, a yaw of 12.6 deg/s and more.
    fn gyro_100_hz() -> Vec<AttitudeSample> {
        (0..=40)
            .map(|i| AttitudeSample {
                t_us: i * 10_000,
                roll_rad: 0.1,
                pitch_rad: -0.05,
                yaw_rad: 1.0,
                roll_rate_rad_s: (-0.4f64).to_radians(),
                pitch_rate_rad_s: (-2.5f64).to_radians(),
                yaw_rate_rad_s: (12.6f64 + i as f64).to_radians(),
            })
            .collect()
    }

    #[test]
    fn msp_gives_whole_degrees_per_second_rounded_as_lrintf() {
        let msp = |d: f64| deg_s(AttitudeLink::Msp.rate_rad_s(d.to_radians()));
        assert!((msp(12.6) - 13.0).abs() < 1e-9);
        assert!(
            (AttitudeLink::Msp.rate_rad_s(12.6f64.to_radians()) - 13f64.to_radians()).abs() < 1e-12
        );
        assert!((msp(-12.6) + 13.0).abs() < 1e-9);
        assert!((msp(12.4) - 12.0).abs() < 1e-9);
        assert_eq!(msp(0.4), 0.0, "a slow turn reads as none");
        // Ties to even, as lrintf in the default rounding mode.
        assert!((msp(2.5) - 2.0).abs() < 1e-9);
        assert!((msp(-2.5) + 2.0).abs() < 1e-9);
        assert!((msp(1.5) - 2.0).abs() < 1e-9);
    }

    #[test]
    fn mavlink_keeps_the_rate_to_f32_precision() {
        let r = AttitudeLink::Mavlink.rate_rad_s(12.6f64.to_radians());
        assert!((deg_s(r) - 12.6).abs() < 1e-5);
        assert_eq!(r, f64::from(12.6f32).to_radians());
        let x = 0.123_456_789_f64;
        assert_eq!(AttitudeLink::Imu.rate_rad_s(x), x);
    }

    #[test]
    fn both_links_deliver_one_sample_every_40_ms_at_the_time_the_gyro_was_read() {
        let gyro = gyro_100_hz();
        for link in [AttitudeLink::Mavlink, AttitudeLink::Msp] {
            let got = link.deliver(&gyro);
            let times: Vec<i64> = got.iter().map(|s| s.t_us).collect();
            assert_eq!(
                times,
                (0..=10).map(|i| i * 40_000).collect::<Vec<_>>(),
                "{link}"
            );
            assert!(got.windows(2).all(|w| w[1].t_us - w[0].t_us == 40_000));
            // The sample at 40 ms is the gyro's at 40 ms: yaw 16.6 deg/s.
            let yaw = deg_s(got[1].yaw_rate_rad_s);
            match link {
                AttitudeLink::Msp => assert!((yaw - 17.0).abs() < 1e-9, "{yaw}"),
                _ => assert!((yaw - 16.6).abs() < 1e-5, "{yaw}"),
            }
            // The angles pass as they are.
            assert_eq!((got[1].roll_rad, got[1].yaw_rad), (0.1, 1.0));
        }
        let msp = AttitudeLink::Msp.deliver(&gyro);
        assert_eq!(deg_s(msp[0].roll_rate_rad_s), 0.0);
        assert!((deg_s(msp[0].pitch_rate_rad_s) + 2.0).abs() < 1e-9);
        assert_eq!(
            AttitudeLink::Imu.deliver(&gyro),
            gyro,
            "every sample, as it is"
        );
    }

    #[test]
    fn a_late_sample_starts_the_next_period_from_its_own_time() {
        let times = [0, 10_000, 45_000, 80_000, 90_000, 130_000];
        let gyro: Vec<AttitudeSample> = times
            .iter()
            .map(|&t_us| AttitudeSample {
                t_us,
                ..Default::default()
            })
            .collect();
        let got: Vec<i64> = AttitudeLink::Msp
            .deliver(&gyro)
            .iter()
            .map(|s| s.t_us)
            .collect();
        assert_eq!(got, [0, 45_000, 90_000, 130_000]);
        assert!(AttitudeLink::Msp.deliver(&[]).is_empty());
    }

    #[test]
    fn the_links_go_by_name_and_a_wrong_one_is_refused_with_the_names() {
        for link in AttitudeLink::ALL {
            assert_eq!(link.name().parse::<AttitudeLink>(), Ok(link));
            assert_eq!(link.to_string(), link.name());
        }
        assert_eq!("MSP".parse::<AttitudeLink>(), Ok(AttitudeLink::Msp));
        let err = "crsf".parse::<AttitudeLink>().unwrap_err().to_string();
        assert_eq!(
            err,
            "no attitude link `crsf`: the links are imu, mavlink, msp"
        );
        assert_eq!(AttitudeLink::default(), AttitudeLink::Imu);
    }
}
