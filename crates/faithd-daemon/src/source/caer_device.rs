//! The iniVation cameras faithd drives through libcaer (`[source] device`): the
//! libcaer device type each is opened as, the sizes it comes in, what faithd sets
//! itself once it streams, and the (module, parameter) addresses a
//! `source.caer_settings` entry may write.
//!
//! The addresses are libcaer 3.x's public headers (3.3.9): `devices/device.h` and
//! `devices/usb.h` for the host side, `devices/davis.h` for the DAVIS240 and DAVIS346,
//! `devices/dvxplorer.h` for the DVXplorer family. Read-only addresses (sizes,
//! orientation, `HAS_*` feature tests, statistics, system information) are not
//! writable, so an entry naming one is refused before the camera is opened.

use std::ops::RangeInclusive;

use serde::{Deserialize, Serialize};

use faithd_core::invalid::Invalid;
use libcaer_sys as caer;

/// One libcaer configuration write: (module, parameter, value).
pub type Setting = (i8, u8, u32);

/// A DVS resolution in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SensorSize {
    pub width_px: u16,
    pub height_px: u16,
}

impl std::fmt::Display for SensorSize {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{} px", self.width_px, self.height_px)
    }
}

/// The camera on USB, as `[source] device` names it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CaerDevice {
    /// DAVIS240 (the paper's DVS240): 240 x 180, `CAER_DEVICE_DAVIS`.
    #[default]
    Davis240,
    /// DAVIS346: 346 x 260, `CAER_DEVICE_DAVIS`, its own bias addresses.
    Davis346,
    /// DVXplorer, DVXplorer Micro (640 x 480) and DVXplorer Lite (320 x 240),
    /// `CAER_DEVICE_DVXPLORER`, its own configuration modules.
    Dvxplorer,
}

/// Host-side addresses every libcaer USB device takes (`devices/usb.h` line 21,
/// `devices/device.h` lines 43-117): USB buffers, the data exchange's buffer size and
/// producers, the container's packet size, the log level. The blocking flag and the
/// container interval are faithd's own ([`CaerDevice::owned`]).
const HOST: [(i8, &[RangeInclusive<u8>]); 4] = [
    (-1, &[0..=1]),
    (-2, &[0..=0, 2..=3]),
    (-3, &[0..=0]),
    (-4, &[0..=0]),
];

/// The DAVIS modules' writable addresses (`devices/davis.h`): MUX 0, DVS 1 (run,
/// stall, external AER, the pixel, background-activity, ROI, skip and polarity
/// filters), APS 2, IMU 3, external input 4, USB 9; module 5 (biases and chip
/// configuration) differs between the chips and is added per device.
const DAVIS: [(i8, &[RangeInclusive<u8>]); 6] = [
    (0, &[0..=5]),
    (
        1,
        &[
            3..=5,
            11..=26,
            31..=34,
            41..=44,
            51..=52,
            61..=63,
            100..=100,
        ],
    ),
    (2, &[4..=5, 7..=13, 100..=102]),
    (3, &[2..=7, 9..=10]),
    (4, &[0..=5, 11..=16]),
    (9, &[0..=1]),
];

/// DAVIS240 biases and chip configuration (`devices/davis.h` lines 1280-1329):
/// DIFFBN = 0 ... SSN = 21, DIGITALMUX0 = 128 ... GLOBAL_SHUTTER = 142.
const DAVIS240_BIAS: (i8, &[RangeInclusive<u8>]) = (5, &[0..=21, 128..=142]);

/// DAVIS346 biases and chip configuration (`devices/davis.h` lines 1343-1396 and
/// `DAVIS346_CONFIG_CHIP_TESTADC`): APSOVERFLOWLEVEL = 0 ... ADCTESTVOLTAGE = 4,
/// LOCALBUFBN = 8 ... IFTHRBN = 27, BIASBUFFER = 34, SSP = 35, SSN = 36; chip 128-138,
/// 140-144.
const DAVIS346_BIAS: (i8, &[RangeInclusive<u8>]) =
    (5, &[0..=4, 8..=27, 34..=36, 128..=138, 140..=144]);

/// The DVXplorer's writable addresses (`devices/dvxplorer.h` lines 43-614): MUX 0,
/// DVS 1 (run), IMU 3, external input 4, USB 9, and the sensor's own modules: DVS chip
/// 20 (mode, ON/OFF only, subsampling, area blocking, timings), cropper 21, activity
/// decision 22 (the sensor's event-rate control), biases 23.
const DVXPLORER: [(i8, &[RangeInclusive<u8>]); 9] = [
    (0, &[0..=5]),
    (1, &[3..=3]),
    (3, &[2..=10]),
    (4, &[0..=5, 11..=16]),
    (9, &[0..=1]),
    (20, &[0..=46]),
    (21, &[0..=4]),
    (22, &[0..=5]),
    (23, &[0..=10, 20..=20]),
];

/// Addresses faithd writes itself, and why an entry must not undo them.
const OWNED: [((i8, u8), &str); 6] = [
    (
        (-2, 1),
        "is CAER_HOST_CONFIG_DATAEXCHANGE_BLOCKING, which faithd sets itself (off, so that the camera thread hears a stop)",
    ),
    (
        (-3, 1),
        "is CAER_HOST_CONFIG_PACKETS_MAX_CONTAINER_INTERVAL, which faithd sets itself (1 ms, so that events reach the pipeline within a millisecond, not libcaer's default 10)",
    ),
    (
        (2, 4),
        "is DAVIS_CONFIG_APS_RUN: faithd turns the APS off, as it discards frames",
    ),
    (
        (3, 2),
        "is the IMU's RUN_ACCELEROMETER: faithd turns the IMU off, as it discards IMU samples",
    ),
    (
        (3, 3),
        "is the IMU's RUN_GYROSCOPE: faithd turns the IMU off, as it discards IMU samples",
    ),
    (
        (3, 4),
        "is the IMU's RUN_TEMPERATURE: faithd turns the IMU off, as it discards IMU samples",
    ),
];

/// libcaer's container interval, in us, that faithd asks for: containers are handed
/// over at least every millisecond, so the freshest events of a 10 ms window are not
/// held back for up to libcaer's default 10 ms (`src/container_generation.h`, 10000;
/// measured on libcaer 3.3.15: 9.2 ms mean span).
pub const CONTAINER_INTERVAL_US: u32 = 1000;

impl CaerDevice {
    /// As the configuration names it.
    pub fn key(self) -> &'static str {
        match self {
            CaerDevice::Davis240 => "davis240",
            CaerDevice::Davis346 => "davis346",
            CaerDevice::Dvxplorer => "dvxplorer",
        }
    }

    /// The libcaer device type `caerDeviceOpen` and `caerDeviceDiscover` take.
    pub fn libcaer_type(self) -> u16 {
        match self {
            CaerDevice::Davis240 | CaerDevice::Davis346 => caer::CAER_DEVICE_DAVIS,
            CaerDevice::Dvxplorer => caer::CAER_DEVICE_DVXPLORER,
        }
    }

    /// The DVS sizes this family comes in.
    pub fn sizes(self) -> &'static [SensorSize] {
        const fn px(width_px: u16, height_px: u16) -> SensorSize {
            SensorSize {
                width_px,
                height_px,
            }
        }
        const DAVIS240: [SensorSize; 1] = [px(240, 180)];
        const DAVIS346: [SensorSize; 1] = [px(346, 260)];
        const DVXPLORER: [SensorSize; 2] = [px(640, 480), px(320, 240)];
        match self {
            CaerDevice::Davis240 => &DAVIS240,
            CaerDevice::Davis346 => &DAVIS346,
            CaerDevice::Dvxplorer => &DVXPLORER,
        }
    }

    /// What faithd writes after `caerDeviceDataStart`, which turned them on: the APS
    /// (a DAVIS's frames) and the IMU's three run flags. Their packets would take USB
    /// bandwidth and the camera thread's time for nothing, as faithd reads only
    /// polarity events. The IMU's addresses are the same on both families
    /// (`DAVIS_CONFIG_IMU` / `DVX_IMU` = 3, run flags 2-4).
    pub fn own_settings(self) -> &'static [Setting] {
        const IMU_OFF: [Setting; 3] = [
            (
                caer::DAVIS_CONFIG_IMU,
                caer::DAVIS_CONFIG_IMU_RUN_ACCELEROMETER,
                0,
            ),
            (
                caer::DAVIS_CONFIG_IMU,
                caer::DAVIS_CONFIG_IMU_RUN_GYROSCOPE,
                0,
            ),
            (
                caer::DAVIS_CONFIG_IMU,
                caer::DAVIS_CONFIG_IMU_RUN_TEMPERATURE,
                0,
            ),
        ];
        const DAVIS_OFF: [Setting; 4] = [
            (caer::DAVIS_CONFIG_APS, caer::DAVIS_CONFIG_APS_RUN, 0),
            IMU_OFF[0],
            IMU_OFF[1],
            IMU_OFF[2],
        ];
        match self {
            CaerDevice::Davis240 | CaerDevice::Davis346 => &DAVIS_OFF,
            CaerDevice::Dvxplorer => &IMU_OFF,
        }
    }

    /// Whether this camera has a writable (module, parameter) there.
    pub fn takes(self, (module, param): (i8, u8)) -> bool {
        let modules: Vec<(i8, &[RangeInclusive<u8>])> = match self {
            CaerDevice::Davis240 => [&HOST[..], &DAVIS[..], &[DAVIS240_BIAS]].concat(),
            CaerDevice::Davis346 => [&HOST[..], &DAVIS[..], &[DAVIS346_BIAS]].concat(),
            CaerDevice::Dvxplorer => [&HOST[..], &DVXPLORER[..]].concat(),
        };
        modules
            .iter()
            .filter(|(m, _)| *m == module)
            .any(|(_, ranges)| ranges.iter().any(|r| r.contains(&param)))
    }

    /// Refuses an entry that would undo what faithd sets itself, or that names an
    /// address this camera does not have; the value is for libcaer to take or refuse
    /// when it applies it.
    pub fn validate(self, settings: &[Setting]) -> Result<(), Invalid> {
        for (index, &(module, param, value)) in settings.iter().enumerate() {
            let key = format!("source.caer_settings[{index}]");
            if let Some((_, why)) = OWNED.iter().find(|(at, _)| *at == (module, param)) {
                return Err(Invalid {
                    key,
                    reason: format!("[{module}, {param}, {value}] {why}; remove the entry"),
                });
            }
            if !self.takes((module, param)) {
                return Err(Invalid {
                    key,
                    reason: format!(
                        "[{module}, {param}, {value}]: a {} has no writable ({module}, {param}); addresses are in libcaer's {} (source.device = \"{}\")",
                        self.name(),
                        self.header(),
                        self.key()
                    ),
                });
            }
        }
        Ok(())
    }

    /// The camera's name, for messages.
    pub fn name(self) -> &'static str {
        match self {
            CaerDevice::Davis240 => "DAVIS240",
            CaerDevice::Davis346 => "DAVIS346",
            CaerDevice::Dvxplorer => "DVXplorer",
        }
    }

    /// libcaer's header holding its addresses.
    fn header(self) -> &'static str {
        match self {
            CaerDevice::Davis240 | CaerDevice::Davis346 => "devices/davis.h",
            CaerDevice::Dvxplorer => "devices/dvxplorer.h",
        }
    }
}

/// The camera a libcaer chip identifier names (`devices/davis.h` lines 46-91,
/// `devices/dvxplorer.h` lines 30-35), for messages.
pub fn chip_name(device_type: u16, chip_id: i16) -> &'static str {
    match (device_type, chip_id) {
        (caer::CAER_DEVICE_DAVIS, 0..=2) => "DAVIS240",
        (caer::CAER_DEVICE_DAVIS, 3) => "DAVIS128",
        (caer::CAER_DEVICE_DAVIS, 4 | 5 | 9) => "DAVIS346",
        (caer::CAER_DEVICE_DAVIS, 6 | 7) => "DAVIS640",
        (caer::CAER_DEVICE_DAVIS, 8) => "DAVIS208",
        (caer::CAER_DEVICE_DVXPLORER, 20) => "DVXplorer",
        (caer::CAER_DEVICE_DVXPLORER, 19) => "DVXplorer Lite",
        (caer::CAER_DEVICE_DAVIS, _) => "DAVIS",
        _ => "DVXplorer",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_camera_takes_its_own_bias_addresses_and_not_the_others() {
        // DAVIS240 OFFBN (2) and DAVIS346 OFFBN (12); a DVXplorer's bias module is 23.
        assert!(CaerDevice::Davis240.takes((5, 2)));
        assert!(CaerDevice::Davis240.takes((5, 12)));
        assert!(!CaerDevice::Davis240.takes((5, 30)));
        assert!(CaerDevice::Davis346.takes((5, 36)));
        assert!(
            !CaerDevice::Davis346.takes((5, 5)),
            "346: 5-7 are not biases"
        );
        assert!(!CaerDevice::Davis346.takes((23, 9)));
        assert!(CaerDevice::Dvxplorer.takes((23, 9)));
        assert!(CaerDevice::Dvxplorer.takes((21, 0)), "the cropper");
        assert!(!CaerDevice::Dvxplorer.takes((5, 1)), "no DAVIS bias module");
        assert!(!CaerDevice::Dvxplorer.takes((2, 4)), "no APS");
    }

    #[test]
    fn an_entry_for_another_camera_is_refused_naming_the_header() {
        let err = CaerDevice::Dvxplorer
            .validate(&[(23, 20, 2), (5, 1, 24575)])
            .unwrap_err();
        assert_eq!(err.key, "source.caer_settings[1]");
        assert_eq!(
            err.reason,
            "[5, 1, 24575]: a DVXplorer has no writable (5, 1); addresses are in libcaer's devices/dvxplorer.h (source.device = \"dvxplorer\")"
        );
        let err = CaerDevice::Davis346.validate(&[(1, 0, 5)]).unwrap_err();
        assert!(
            err.reason.contains("a DAVIS346 has no writable (1, 0)"),
            "{}",
            err.reason
        );
    }

    #[test]
    fn what_faithd_sets_itself_is_refused_on_every_camera() {
        for device in [
            CaerDevice::Davis240,
            CaerDevice::Davis346,
            CaerDevice::Dvxplorer,
        ] {
            for address in [(-2, 1), (-3, 1), (3, 2), (3, 3), (3, 4)] {
                let err = device.validate(&[(address.0, address.1, 1)]).unwrap_err();
                assert!(err.reason.ends_with("remove the entry"), "{}", err.reason);
            }
        }
    }

    #[test]
    fn the_imu_is_turned_off_on_every_camera_and_the_aps_on_a_davis() {
        let off = |d: CaerDevice| {
            d.own_settings()
                .iter()
                .map(|s| (s.0, s.1))
                .collect::<Vec<_>>()
        };
        assert_eq!(off(CaerDevice::Dvxplorer), [(3, 2), (3, 3), (3, 4)]);
        assert_eq!(off(CaerDevice::Davis346), [(2, 4), (3, 2), (3, 3), (3, 4)]);
        for device in [
            CaerDevice::Davis240,
            CaerDevice::Davis346,
            CaerDevice::Dvxplorer,
        ] {
            for s in device.own_settings() {
                assert!(device.takes((s.0, s.1)) || OWNED.iter().any(|(a, _)| *a == (s.0, s.1)));
            }
        }
    }
}
