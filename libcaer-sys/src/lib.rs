//! The few libcaer functions faithd needs, declared from libcaer's public headers
//! (`libcaer/devices/device.h`, `devices/usb.h`, `devices/davis.h`, `events/packetContainer.h`,
//! `events/common.h`, `events/polarity.h`, libcaer 3.x).
//!
//! Event packets are read through their documented memory layout (the same layout
//! AEDAT 3.1 files store): a 28-byte little-endian header followed by `eventCapacity`
//! events of `eventSize` bytes; a polarity event is a `u32` data word (bit 0 valid,
//! bit 1 polarity, bits 2..16 y, bits 17..31 x) and an `i32` timestamp.

#![allow(non_camel_case_types, non_snake_case)]

use std::ffi::{c_char, c_void};

#[repr(C)]
pub struct caer_device_handle {
    _private: [u8; 0],
}
pub type caerDeviceHandle = *mut caer_device_handle;

#[repr(C)]
pub struct caer_event_packet_container {
    _private: [u8; 0],
}
pub type caerEventPacketContainer = *mut caer_event_packet_container;

/// Pointer to an event packet: header then events.
pub type caerEventPacketHeader = *mut u8;

/// DAVIS cameras over USB (DAVIS240, which the DVS240 is).
pub const CAER_DEVICE_DAVIS: u16 = 4;
pub const CAER_DEVICE_DVS128: u16 = 0;

pub const CAER_HOST_CONFIG_DATAEXCHANGE: i8 = -2;
pub const CAER_HOST_CONFIG_DATAEXCHANGE_BLOCKING: u8 = 1;
pub const CAER_HOST_CONFIG_PACKETS: i8 = -3;
pub const CAER_HOST_CONFIG_PACKETS_MAX_CONTAINER_INTERVAL: u8 = 1;

/// Event type of polarity (DVS) packets.
pub const POLARITY_EVENT: i16 = 1;
pub const PACKET_HEADER_BYTES: usize = 28;

pub type NotifyFn = Option<unsafe extern "C" fn(ptr: *mut c_void)>;

/// `struct caer_davis_info` of libcaer 3.x (`libcaer/devices/davis.h`), field for field,
/// as `caerDavisInfoGet` returns it **by value**.
///
/// Why this and not another way to learn the sensor size: libcaer 3 has no generic
/// `caerDeviceInfoGet`; every device family has its own `caer<Family>InfoGet` returning
/// its struct by value, and `caerDavisInfoGet` is the documented way to read the DVS
/// size (the raw `DAVIS_CONFIG_DVS_SIZE_COLUMNS`/`_ROWS` parameters are marked
/// internal and ignore the X/Y swap that `dvsSizeX/Y` already apply). A struct
/// returned by value is as stable as its layout, so the layout is pinned below: the
/// sizes and offsets of the fields faithd reads are checked at compile time on 64-bit
/// targets, where a struct this size is returned through a caller-allocated buffer
/// (x86-64 SysV and AArch64 alike), exactly what `extern "C"` does with this type.
/// The two C enums (`apsColorFilter`, `imuType`) are plain `i32` here so that an
/// unknown value from a newer libcaer is a number, not undefined behaviour.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct caer_davis_info {
    pub deviceID: i16,
    pub deviceSerialNumber: [c_char; 9],
    pub deviceUSBBusNumber: u8,
    pub deviceUSBDeviceAddress: u8,
    /// Valid only while the device is open; faithd does not read it.
    pub deviceString: *mut c_char,
    pub firmwareVersion: i16,
    pub logicVersion: i16,
    pub chipID: i16,
    pub deviceIsMaster: bool,
    pub muxHasStatistics: bool,
    pub dvsSizeX: i16,
    pub dvsSizeY: i16,
    pub dvsHasPixelFilter: bool,
    pub dvsHasBackgroundActivityFilter: bool,
    pub dvsHasROIFilter: bool,
    pub dvsHasSkipFilter: bool,
    pub dvsHasPolarityFilter: bool,
    pub dvsHasStatistics: bool,
    pub apsSizeX: i16,
    pub apsSizeY: i16,
    /// `enum caer_frame_event_color_filter`.
    pub apsColorFilter: i32,
    pub apsHasGlobalShutter: bool,
    /// `enum caer_imu_types`.
    pub imuType: i32,
    pub extInputHasGenerator: bool,
}

#[cfg(target_pointer_width = "64")]
const _: () = {
    use std::mem::{offset_of, size_of};
    assert!(size_of::<caer_davis_info>() == 64);
    assert!(offset_of!(caer_davis_info, deviceString) == 16);
    assert!(offset_of!(caer_davis_info, chipID) == 28);
    assert!(offset_of!(caer_davis_info, dvsSizeX) == 32);
    assert!(offset_of!(caer_davis_info, dvsSizeY) == 34);
    assert!(offset_of!(caer_davis_info, apsColorFilter) == 48);
    assert!(offset_of!(caer_davis_info, imuType) == 56);
};

impl caer_davis_info {
    /// The DVS resolution (x, y) in pixels, or `None` when libcaer could not tell:
    /// `caerDavisInfoGet` returns all zeros on failure.
    pub fn dvs_size_px(&self) -> Option<(u16, u16)> {
        let x = u16::try_from(self.dvsSizeX).ok().filter(|&x| x > 0)?;
        let y = u16::try_from(self.dvsSizeY).ok().filter(|&y| y > 0)?;
        Some((x, y))
    }
}

/// The library names tried, in order, when no path is configured: libcaer 3's
/// soname, then the development symlink.
pub const DEFAULT_NAMES: [&str; 2] = ["libcaer.so.3", "libcaer.so"];

/// Why libcaer could not be used.
#[derive(Debug)]
pub enum LoadError {
    /// No library under any of the names tried (the loader's messages, joined).
    NotFound(String),
    /// The library lacks a function faithd calls: not libcaer 3.
    MissingSymbol {
        library: String,
        symbol: &'static str,
    },
}

impl std::fmt::Display for LoadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LoadError::NotFound(why) => write!(f, "libcaer not found: {why}"),
            LoadError::MissingSymbol { library, symbol } => {
                write!(f, "{library} has no `{symbol}`: not libcaer 3.x")
            }
        }
    }
}

impl std::error::Error for LoadError {}

macro_rules! libcaer_functions {
    ($($name:ident: fn($($arg:ident: $ty:ty),*) $(-> $ret:ty)?;)*) => {
        /// libcaer, opened at run time: faithd is built and packaged without it and
        /// finds it where iniVation's packages install it. Every function pointer
        /// stays valid while the library is loaded, which is as long as this value
        /// lives.
        pub struct Libcaer {
            /// Where it was loaded from (for the journal).
            pub path: String,
            $(pub $name: unsafe extern "C" fn($($ty),*) $(-> $ret)?,)*
            _library: libloading::Library,
        }

        impl Libcaer {
            /// Opens the library at `path` (a path, or a name for the loader to find).
            pub fn load_from(path: &str) -> Result<Self, LoadError> {
                // SAFETY: loading runs the library's initialisers; libcaer's are plain.
                let library = unsafe { libloading::Library::new(path) }
                    .map_err(|e| LoadError::NotFound(format!("{path}: {e}")))?;
                $(
                    // SAFETY: the type is libcaer 3's declaration of the function; the
                    // pointer is used only while `_library` keeps it mapped.
                    let $name = unsafe {
                        *library
                            .get::<unsafe extern "C" fn($($ty),*) $(-> $ret)?>(
                                concat!(stringify!($name), "\0").as_bytes(),
                            )
                            .map_err(|_| LoadError::MissingSymbol {
                                library: path.to_string(),
                                symbol: stringify!($name),
                            })?
                    };
                )*
                Ok(Self { path: path.to_string(), $($name,)* _library: library })
            }
        }
    };
}

libcaer_functions! {
    caerDeviceOpen: fn(
        device_id: u16,
        device_type: u16,
        bus_number_restrict: u8,
        dev_address_restrict: u8,
        serial_number_restrict: *const c_char
    ) -> caerDeviceHandle;
    caerDeviceClose: fn(handle: *mut caerDeviceHandle) -> bool;
    caerDeviceSendDefaultConfig: fn(handle: caerDeviceHandle) -> bool;
    caerDeviceConfigSet: fn(handle: caerDeviceHandle, mod_addr: i8, param_addr: u8, param: u32) -> bool;
    caerDeviceDataStart: fn(
        handle: caerDeviceHandle,
        data_notify_increase: NotifyFn,
        data_notify_decrease: NotifyFn,
        data_notify_user_ptr: *mut c_void,
        data_shutdown_notify: NotifyFn,
        data_shutdown_user_ptr: *mut c_void
    ) -> bool;
    caerDeviceDataStop: fn(handle: caerDeviceHandle) -> bool;
    caerDeviceDataGet: fn(handle: caerDeviceHandle) -> caerEventPacketContainer;
    caerEventPacketContainerFree: fn(container: caerEventPacketContainer);
    caerEventPacketContainerGetEventPacketsNumber: fn(container: caerEventPacketContainer) -> i32;
    caerEventPacketContainerGetEventPacket: fn(container: caerEventPacketContainer, n: i32) -> caerEventPacketHeader;
    // Required, not optional: every libcaer since 1.0 exports it, and faithd must not
    // stream from a camera whose size it could not check (a DAVIS346 read as a 240x180
    // would be silently cropped).
    caerDavisInfoGet: fn(handle: caerDeviceHandle) -> caer_davis_info;
}

impl Libcaer {
    /// Opens `path` when given, otherwise the first of [`DEFAULT_NAMES`] the system
    /// loader finds.
    pub fn load(path: Option<&str>) -> Result<Self, LoadError> {
        if let Some(p) = path {
            return Self::load_from(p);
        }
        let mut why = Vec::new();
        for name in DEFAULT_NAMES {
            match Self::load_from(name) {
                Ok(lib) => return Ok(lib),
                Err(LoadError::NotFound(e)) => why.push(e),
                Err(e) => return Err(e),
            }
        }
        Err(LoadError::NotFound(why.join("; ")))
    }
}

/// The C mock of libcaer (`mock/caer_mock.c`), built as a shared library for tests:
/// the same functions over a scripted stream, loaded exactly as libcaer is.
#[cfg(feature = "mock")]
pub mod mock {
    /// Path of the mock library built by this crate's build script.
    pub const LIBRARY: &str = concat!(env!("OUT_DIR"), "/libcaer_mock.so");

    /// The mock's script controls, from the same loaded library (so the same state).
    pub struct Script {
        /// Containers served before the device "vanishes", and how many opens fail
        /// after that before it "returns". Resets the counters.
        pub set: unsafe extern "C" fn(containers_before_disconnect: i32, failed_opens_after: i32),
        /// Opens attempted so far (successful or not).
        pub open_attempts: unsafe extern "C" fn() -> i32,
        /// Last value set for (module, parameter), or -1.
        pub config_value: unsafe extern "C" fn(mod_addr: i8, param_addr: u8) -> i64,
        /// The DVS size `caerDavisInfoGet` reports (240x180 until set; `set` restores it).
        pub sensor: unsafe extern "C" fn(width_px: i16, height_px: i16),
        /// The device clock: it runs at `rate` times real time (1.02: 2 % fast) and each
        /// container arrives a uniform random `latency_min_us..=latency_max_us` after its
        /// newest event. Containers are paced in real time. `set` restores (1, 0, 0).
        pub clock: unsafe extern "C" fn(rate: f64, latency_min_us: i32, latency_max_us: i32),
        /// CLOCK_MONOTONIC in microseconds (Rust's `Instant` on Linux).
        pub now_us: unsafe extern "C" fn() -> i64,
        /// The CLOCK_MONOTONIC time (us) at which the device clock of the current
        /// session read `device_us`: when an event stamped so really happened.
        pub true_host_us: unsafe extern "C" fn(device_us: i64) -> i64,
        _library: libloading::Library,
    }

    impl Script {
        pub fn load() -> Self {
            // SAFETY: the mock's functions have exactly these C signatures.
            unsafe {
                let library = libloading::Library::new(LIBRARY).expect("the mock libcaer");
                Self {
                    set: *library
                        .get(b"caer_mock_script\0")
                        .expect("caer_mock_script"),
                    open_attempts: *library
                        .get(b"caer_mock_open_attempts\0")
                        .expect("caer_mock_open_attempts"),
                    config_value: *library
                        .get(b"caer_mock_config_value\0")
                        .expect("caer_mock_config_value"),
                    sensor: *library
                        .get(b"caer_mock_sensor\0")
                        .expect("caer_mock_sensor"),
                    clock: *library.get(b"caer_mock_clock\0").expect("caer_mock_clock"),
                    now_us: *library
                        .get(b"caer_mock_now_us\0")
                        .expect("caer_mock_now_us"),
                    true_host_us: *library
                        .get(b"caer_mock_true_host_us\0")
                        .expect("caer_mock_true_host_us"),
                    _library: library,
                }
            }
        }
    }
}

/// One polarity event read from a packet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Polarity {
    pub t_us: i64,
    pub x: u16,
    pub y: u16,
    pub on: bool,
}

/// Reads the valid polarity events of one packet, appending to `out`.
///
/// # Safety
/// `packet` must point to a live libcaer event packet (header and events).
pub unsafe fn read_polarity_packet(packet: caerEventPacketHeader, out: &mut Vec<Polarity>) -> bool {
    if packet.is_null() {
        return false;
    }
    let i32_at = |off: usize| unsafe { i32::from_le_bytes(*(packet.add(off) as *const [u8; 4])) };
    let event_type = unsafe { i16::from_le_bytes(*(packet as *const [u8; 2])) };
    if event_type != POLARITY_EVENT {
        return false;
    }
    let event_size = i32_at(4);
    let ts_overflow = i64::from(i32_at(12));
    let event_number = i32_at(20);
    if event_size < 8 || event_number < 0 {
        return false;
    }
    for k in 0..event_number as usize {
        let base = PACKET_HEADER_BYTES + k * event_size as usize;
        let data = i32_at(base) as u32;
        if data & 1 == 0 {
            continue;
        }
        let ts = i64::from(i32_at(base + 4));
        out.push(Polarity {
            t_us: (ts_overflow << 31) | ts,
            x: ((data >> 17) & 0x7FFF) as u16,
            y: ((data >> 2) & 0x7FFF) as u16,
            on: data & 2 != 0,
        });
    }
    true
}
