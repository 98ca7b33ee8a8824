//! The few libcaer functions faithd needs, declared from libcaer's public headers
//! (`libcaer/devices/device.h`, `devices/usb.h`, `devices/davis.h`, `events/packetContainer.h`,
//! `events/common.h`, `events/polarity.h`, libcaer 3.x).
//!
//! Only functions the shared library exports are loaded by name ([`LOADED_SYMBOLS`]).
//! The event-packet container's functions are `static inline` in
//! `events/packetContainer.h` in every libcaer since 2.5.0, so the library does not
//! export them ([`INLINE_IN_LIBCAER`]); faithd reads the container through its
//! documented layout instead ([`Container`]).
//!
//! Event packets are read through their documented memory layout (the same layout
//! AEDAT 3.1 files store): a 28-byte little-endian header followed by `eventCapacity`
//! events of `eventSize` bytes; a polarity event is a `u32` data word (bit 0 valid,
//! bit 1 polarity, bits 2..16 y, bits 17..31 x) and an `i32` timestamp.
// The crate is libcaer's foreign-function interface: its calls, and the packet
// memory libcaer lays out, are `unsafe` by nature (each block says why it holds).
#![allow(unsafe_code)]
#![allow(non_camel_case_types, non_snake_case)]

use std::ffi::{c_char, c_void};

/// The run-time loader libcaer is opened with, for tests that open other C libraries
/// the same way (the mock's script, a program built against libcaer's headers).
pub use libloading;

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

/// DAVIS cameras over USB, FX2 and FX3 boards alike (the DAVIS240, which the DVS240
/// is, and the DAVIS346): `devices/davis.h` line 36.
pub const CAER_DEVICE_DAVIS: u16 = 4;
pub const CAER_DEVICE_DVS128: u16 = 0;
/// The DVXplorer family (DVXplorer, Lite, Micro): `devices/dvxplorer.h` line 24 (not 6,
/// which is `CAER_DEVICE_DAVIS_RPI`: `devices/davis.h` line 40).
pub const CAER_DEVICE_DVXPLORER: u16 = 8;
/// `caer_dvx_info.chipID` of a DVXplorer (640x480) and of a DVXplorer Lite
/// (320x240): `devices/dvxplorer.h` lines 30 and 35.
pub const DVXPLORER_CHIP_ID: i16 = 20;
pub const DVXPLORER_LITE_CHIP_ID: i16 = 19;
/// `caerDeviceDiscover`'s "every device type" (`devices/device_discover.h` line 54).
pub const CAER_DEVICE_DISCOVER_ALL: i16 = -1;

pub const CAER_HOST_CONFIG_DATAEXCHANGE: i8 = -2;
pub const CAER_HOST_CONFIG_DATAEXCHANGE_BLOCKING: u8 = 1;
pub const CAER_HOST_CONFIG_PACKETS: i8 = -3;
pub const CAER_HOST_CONFIG_PACKETS_MAX_CONTAINER_INTERVAL: u8 = 1;

/// Event types (`events/common.h`, `enum caer_default_event_types`); a DAVIS container
/// holds one packet of each in the slot of the same number, or NULL there.
pub const SPECIAL_EVENT: i16 = 0;
/// Event type of polarity (DVS) packets.
pub const POLARITY_EVENT: i16 = 1;
pub const FRAME_EVENT: i16 = 2;
pub const IMU6_EVENT: i16 = 3;
pub const PACKET_HEADER_BYTES: usize = 28;

/// DAVIS module and parameter addresses (`devices/davis.h`, libcaer 3.x): the run
/// flags of the APS (frames) and the IMU, which `caerDeviceDataStart` turns on and
/// faithd turns off again, as it uses neither.
pub const DAVIS_CONFIG_APS: i8 = 2;
pub const DAVIS_CONFIG_APS_RUN: u8 = 4;
pub const DAVIS_CONFIG_IMU: i8 = 3;
pub const DAVIS_CONFIG_IMU_RUN_ACCELEROMETER: u8 = 2;
pub const DAVIS_CONFIG_IMU_RUN_GYROSCOPE: u8 = 3;
pub const DAVIS_CONFIG_IMU_RUN_TEMPERATURE: u8 = 4;
/// The chip's bias generator (`DAVIS_CONFIG_BIAS`); on a DAVIS240 parameters 0 to 19
/// are coarse/fine current biases (`DAVIS240_CONFIG_BIAS_DIFFBN` = 0, `_ONBN` = 1,
/// `_OFFBN` = 2, ...), 20 and 21 shifted-source biases.
pub const DAVIS_CONFIG_BIAS: i8 = 5;

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

/// A size libcaer reported, or `None` for its all-zeros failure (or a negative one).
fn positive_size(x: i16, y: i16) -> Option<(u16, u16)> {
    let x = u16::try_from(x).ok().filter(|&x| x > 0)?;
    let y = u16::try_from(y).ok().filter(|&y| y > 0)?;
    Some((x, y))
}

impl caer_davis_info {
    /// The DVS resolution (x, y) in pixels, or `None` when libcaer could not tell:
    /// `caerDavisInfoGet` returns all zeros on failure.
    pub fn dvs_size_px(&self) -> Option<(u16, u16)> {
        positive_size(self.dvsSizeX, self.dvsSizeY)
    }
}

/// `struct caer_dvx_info` of libcaer 3.x (`libcaer/devices/dvxplorer.h` lines 643-676),
/// field for field, as `caerDVXplorerInfoGet` (line 688) returns it by value: the
/// DVXplorer family's counterpart of [`caer_davis_info`], its layout pinned the same
/// way (its first fields, up to `dvsSizeY`, lie at the same offsets as the DAVIS
/// one's).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct caer_dvx_info {
    pub deviceID: i16,
    pub deviceSerialNumber: [c_char; 9],
    pub deviceUSBBusNumber: u8,
    pub deviceUSBDeviceAddress: u8,
    /// Valid only while the device is open.
    pub deviceString: *mut c_char,
    pub firmwareVersion: i16,
    pub logicVersion: i16,
    pub chipID: i16,
    pub deviceIsMaster: bool,
    pub muxHasStatistics: bool,
    pub dvsSizeX: i16,
    pub dvsSizeY: i16,
    pub dvsHasStatistics: bool,
    /// `enum caer_imu_types`.
    pub imuType: i32,
    pub extInputHasGenerator: bool,
}

#[cfg(target_pointer_width = "64")]
const _: () = {
    use std::mem::{offset_of, size_of};
    assert!(size_of::<caer_dvx_info>() == 48);
    assert!(offset_of!(caer_dvx_info, deviceString) == 16);
    assert!(offset_of!(caer_dvx_info, chipID) == 28);
    assert!(offset_of!(caer_dvx_info, dvsSizeX) == 32);
    assert!(offset_of!(caer_dvx_info, dvsSizeY) == 34);
    assert!(offset_of!(caer_dvx_info, imuType) == 40);
};

impl caer_dvx_info {
    /// The DVS resolution (x, y) in pixels, or `None` when libcaer could not tell
    /// (all zeros, as `caerDavisInfoGet` on failure).
    pub fn dvs_size_px(&self) -> Option<(u16, u16)> {
        positive_size(self.dvsSizeX, self.dvsSizeY)
    }
}

/// The head of libcaer 3.x's `struct caer_device_discovery_result`
/// (`devices/device_discover.h` lines 29-42): the device type and the two error flags
/// `usbDeviceFind` (`src/usb_utils.c`, 3.3.9) sets: `deviceErrorOpen` when
/// `libusb_open` failed (no permission), or reading its serial number or logic
/// version did; `deviceErrorVersion` when its firmware (`bcdDevice`) or logic version
/// is not the one libcaer requires. The union of per-family infos follows at
/// [`DISCOVERY_INFO_OFFSET`]; faithd reads the DAVIS and DVXplorer ones.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct caer_device_discovery_head {
    pub deviceType: u16,
    pub deviceErrorOpen: bool,
    pub deviceErrorVersion: bool,
}

/// Where the info union starts: aligned to its pointer members (`char *deviceString`).
pub const DISCOVERY_INFO_OFFSET: usize = std::mem::align_of::<*const c_char>();
/// Size of one discovery result on 64-bit targets: the head, then the union, as large
/// as its largest member, `struct caer_edvs_info` (96 bytes: `devices/edvs.h`, its
/// 64-byte `serialPortName` and the baud rate): `sizeof` is 104 compiled against
/// libcaer 3.3.9's headers. The first entry, all a single camera gives, is read the
/// same at any stride (the USB stand-in's tests read it through libcaer 3.3.15).
#[cfg(target_pointer_width = "64")]
pub const DISCOVERY_RESULT_BYTES: usize = 8 + 96;

/// The library names tried, in order, when no path is configured: libcaer 3's
/// soname, then the development symlink.
pub const DEFAULT_NAMES: [&str; 2] = ["libcaer.so.3", "libcaer.so"];

/// Why libcaer could not be used.
#[derive(Debug)]
pub enum LoadError {
    /// No library under any of the names tried (the loader's messages, joined), or no
    /// file at the path given.
    NotFound(String),
    /// The path names a directory, or a file the loader cannot load.
    NotALibrary(String),
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
            LoadError::NotALibrary(why) => f.write_str(why),
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

        /// Every symbol faithd loads from libcaer, by name: all of them functions that
        /// libcaer 3.x's shared library exports (checked against the real library by
        /// `tests/testsuite/libcaer_real.rs` when `LIBCAER_PATH` names one).
        pub const LOADED_SYMBOLS: &[&str] = &[$(stringify!($name)),*];

        impl Libcaer {
            /// Opens the library at `path` (a path, or a name for the loader to find).
            pub fn load_from(path: &str) -> Result<Self, LoadError> {
                let library = open_library(path)?;
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
    // Required, not optional: every libcaer since 1.0 exports it, and faithd must not
    // stream from a camera whose size it could not check (a DAVIS346 read as a 240x180
    // would be silently cropped).
    caerDavisInfoGet: fn(handle: caerDeviceHandle) -> caer_davis_info;
    // The DVXplorer family's info (libcaer 3.0 and later).
    caerDVXplorerInfoGet: fn(handle: caerDeviceHandle) -> caer_dvx_info;
    // Tells why no camera opened: none on USB, or one that could not be opened or
    // has the wrong firmware (`devices/device_discover.h` line 67). The results are
    // calloc'ed by libcaer and freed with `free`.
    caerDeviceDiscover: fn(device_type: i16, results: *mut *mut c_void) -> isize;
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

/// Opens a library file, telling a missing file, a directory and a file that is not
/// a shared library for this machine apart (the loader says "cannot open" to all).
/// A bare name (no `/`) is the loader's search, and failing it is `NotFound`.
fn open_library(path: &str) -> Result<libloading::Library, LoadError> {
    if path.contains('/') {
        match std::fs::metadata(path) {
            Err(e) => return Err(LoadError::NotFound(format!("{path}: {e}"))),
            Ok(m) if m.is_dir() => {
                return Err(LoadError::NotALibrary(format!("{path} is a directory")));
            }
            Ok(_) => {}
        }
    }
    // SAFETY: loading runs the library's initialisers; libcaer's are plain.
    unsafe { libloading::Library::new(path) }.map_err(|e| {
        if path.contains('/') {
            LoadError::NotALibrary(format!(
                "{path} is not a shared library for this machine: {e}"
            ))
        } else {
            LoadError::NotFound(format!("{path}: {e}"))
        }
    })
}

/// One camera `caerDeviceDiscover` found, and whether libcaer could use it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Discovered {
    pub device_type: u16,
    /// `libusb_open` failed (no permission on the device node), or reading its serial
    /// number or logic version did.
    pub error_open: bool,
    /// Its firmware or logic is not the version this libcaer requires.
    pub error_version: bool,
    pub firmware_version: i16,
    pub logic_version: i16,
    /// 0 when the device could not be opened.
    pub chip_id: i16,
    pub usb_bus: u8,
    pub usb_address: u8,
}

impl Libcaer {
    /// Every camera of `device_type` on USB, as `caerDeviceDiscover` reports them
    /// (it opens each briefly, but claims none), or `None` when libusb failed.
    /// Reads the fields the DAVIS and DVXplorer infos share at the same offsets
    /// (serial, bus, address, firmware, logic, chip: `caer_davis_info`,
    /// `caer_dvx_info`); an entry of another type is skipped.
    pub fn discover(&self, device_type: u16) -> Option<Vec<Discovered>> {
        let mut results: *mut c_void = std::ptr::null_mut();
        let wanted = i16::try_from(device_type).ok()?;
        // SAFETY: libcaer writes a calloc'ed array (or NULL) to `results`.
        let count = unsafe { (self.caerDeviceDiscover)(wanted, &mut results) };
        if count < 0 {
            return None;
        }
        let mut found = Vec::new();
        for i in 0..count as usize {
            // SAFETY: `count` results of DISCOVERY_RESULT_BYTES each (libcaer 3.x's
            // struct); the head is at the start, the info at its offset, and both
            // info structs share these fields' offsets.
            let entry = unsafe { results.cast::<u8>().add(i * DISCOVERY_RESULT_BYTES) };
            // SAFETY: as above; read unaligned, as nothing promises more.
            let head = unsafe { entry.cast::<caer_device_discovery_head>().read_unaligned() };
            if head.deviceType != device_type {
                continue;
            }
            // SAFETY: as above: a DAVIS or DVXplorer info begins the union.
            let info = unsafe {
                entry
                    .add(DISCOVERY_INFO_OFFSET)
                    .cast::<caer_dvx_info>()
                    .read_unaligned()
            };
            found.push(Discovered {
                device_type,
                error_open: head.deviceErrorOpen,
                error_version: head.deviceErrorVersion,
                firmware_version: info.firmwareVersion,
                logic_version: info.logicVersion,
                chip_id: info.chipID,
                usb_bus: info.deviceUSBBusNumber,
                usb_address: info.deviceUSBDeviceAddress,
            });
        }
        // SAFETY: libcaer allocated the array with calloc; free(NULL) is a no-op.
        unsafe { free(results) };
        Some(found)
    }
}

/// Whether the library at `path` exports `symbol` (what `dlsym` finds): how a libcaer
/// build is checked against [`LOADED_SYMBOLS`] and [`INLINE_IN_LIBCAER`].
pub fn exports(path: &str, symbol: &str) -> Result<bool, LoadError> {
    let library = open_library(path)?;
    // SAFETY: the symbol is looked up, never called.
    let found = unsafe { library.get::<*const c_void>(symbol.as_bytes()) }.is_ok();
    Ok(found)
}

/// A coarse/fine current bias of a DAVIS chip, as libcaer 3.x's
/// `struct caer_bias_coarsefine` (`devices/davis.h`) describes it; [`encode`] gives
/// the value `caerDeviceConfigSet` takes for it, laid out as libcaer's
/// `caerBiasCoarseFineGenerate` (`src/davis.c`, 3.3.9) lays it out. Biases are written
/// through this encoding, never as plain numbers: a raw `1` is a P-type cascode bias
/// at zero current.
///
/// [`encode`]: CoarseFineBias::encode
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CoarseFineBias {
    /// 0 to 7: the current range (11 pA upward).
    pub coarse: u8,
    /// 0 to 255: the fraction of the coarse current, in 255ths.
    pub fine: u8,
    pub enabled: bool,
    /// N-type (true) or P-type transistor.
    pub sex_n: bool,
    /// Normal (true) or cascode.
    pub type_normal: bool,
    /// Normal (true) or low current level.
    pub current_level_normal: bool,
}

impl CoarseFineBias {
    /// An enabled, normal, normal-level N-type bias (libcaer's `CF_N_TYPE`).
    pub const fn n_type(coarse: u8, fine: u8) -> Self {
        Self {
            coarse,
            fine,
            enabled: true,
            sex_n: true,
            type_normal: true,
            current_level_normal: true,
        }
    }

    /// Bit 0 enabled, 1 N-type, 2 normal type, 3 normal current level, 4..11 fine,
    /// 12..14 coarse.
    pub const fn encode(self) -> u32 {
        (self.enabled as u32)
            | (self.sex_n as u32) << 1
            | (self.type_normal as u32) << 2
            | (self.current_level_normal as u32) << 3
            | (self.fine as u32) << 4
            | ((self.coarse & 0x07) as u32) << 12
    }
}

/// The functions libcaer 3.x defines `static inline` in `events/packetContainer.h`
/// (every libcaer since 2.5.0) and so does not export: loading one by name fails
/// with the real library. faithd needs three of them and implements them on
/// [`Container`] from the header's documented layout.
pub const INLINE_IN_LIBCAER: [&str; 3] = [
    "caerEventPacketContainerFree",
    "caerEventPacketContainerGetEventPacketsNumber",
    "caerEventPacketContainerGetEventPacket",
];

/// Byte offset of `int32_t eventPacketsNumber` in libcaer 3.x's packed
/// `struct caer_event_packet_container` (after `int64_t lowestEventTimestamp`,
/// `int64_t highestEventTimestamp`, `int32_t eventsNumber`, `int32_t eventsValidNumber`).
pub const CONTAINER_PACKETS_NUMBER_OFFSET: usize = 24;
/// Byte offset of the container's array of packet pointers: right after the count,
/// so unaligned on 64-bit targets (the struct is packed).
pub const CONTAINER_PACKETS_OFFSET: usize = 28;

unsafe extern "C" {
    /// The C library's `free`: libcaer allocates containers and packets with `calloc`
    /// and its own (inline) `caerEventPacketContainerFree` releases them with `free`,
    /// in the caller's process, which is the allocator faithd must hand them back to.
    fn free(ptr: *mut c_void);
}

/// One event-packet container from `caerDeviceDataGet`, owned: dropping it frees the
/// container and its packets as libcaer's `caerEventPacketContainerFree` does.
///
/// Follows libcaer 3.x's `include/libcaer/events/packetContainer.h` (3.3.9): the
/// struct is packed, the count is read at [`CONTAINER_PACKETS_NUMBER_OFFSET`] and
/// packet `n`'s pointer at [`CONTAINER_PACKETS_OFFSET`] + n * pointer size, both
/// unaligned; a slot may be NULL (a DAVIS container has four, one per event type).
pub struct Container {
    raw: std::ptr::NonNull<u8>,
}

// SAFETY: the container is plain heap memory handed over by libcaer; no thread of
// libcaer touches it after DataGet returned it.
unsafe impl Send for Container {}

impl Container {
    /// Takes ownership of what `caerDeviceDataGet` returned (`None` for NULL).
    ///
    /// # Safety
    /// `raw` must be NULL or a container allocated the way libcaer allocates them
    /// (calloc'ed container and packets), owned by no one else.
    pub unsafe fn from_raw(raw: caerEventPacketContainer) -> Option<Self> {
        std::ptr::NonNull::new(raw.cast::<u8>()).map(|raw| Self { raw })
    }

    /// `caerEventPacketContainerGetEventPacketsNumber`: the number of slots (never
    /// negative here, whatever the memory says).
    pub fn packets_number(&self) -> i32 {
        // SAFETY: the count lies within the container's fixed part, which every
        // container has.
        let n = unsafe {
            self.raw
                .as_ptr()
                .add(CONTAINER_PACKETS_NUMBER_OFFSET)
                .cast::<i32>()
                .read_unaligned()
        };
        n.max(0)
    }

    /// `caerEventPacketContainerGetEventPacket`: packet `n`, or `None` when the slot
    /// is NULL or `n` is out of range.
    pub fn packet(&self, n: i32) -> Option<caerEventPacketHeader> {
        if n < 0 || n >= self.packets_number() {
            return None;
        }
        let offset = CONTAINER_PACKETS_OFFSET + n as usize * std::mem::size_of::<*mut u8>();
        // SAFETY: slot `n` exists (checked above); the array is unaligned.
        let packet = unsafe {
            self.raw
                .as_ptr()
                .add(offset)
                .cast::<caerEventPacketHeader>()
                .read_unaligned()
        };
        (!packet.is_null()).then_some(packet)
    }

    /// The non-NULL packets, in slot order.
    pub fn packets(&self) -> impl Iterator<Item = caerEventPacketHeader> + '_ {
        (0..self.packets_number()).filter_map(|n| self.packet(n))
    }

    /// Hands the container back without freeing it.
    pub fn into_raw(self) -> caerEventPacketContainer {
        let raw = self.raw.as_ptr().cast();
        std::mem::forget(self);
        raw
    }
}

impl Drop for Container {
    /// `caerEventPacketContainerFree`: every non-NULL packet, then the container.
    fn drop(&mut self) {
        // SAFETY: `from_raw`'s contract: calloc'ed by libcaer, owned by us alone.
        unsafe {
            for packet in self.packets() {
                free(packet.cast());
            }
            free(self.raw.as_ptr().cast());
        }
    }
}

/// The C test doubles, built as shared libraries for tests: the mock of libcaer
/// (`mock/caer_mock.c`: the same functions over a scripted stream, loaded exactly as
/// libcaer is) and the USB stand-in under the real libcaer ([`mock::USB_STANDIN`]).
#[cfg(feature = "mock")]
pub mod mock {
    use super::caerEventPacketContainer;

    /// Path of the mock library built by this crate's build script.
    pub const LIBRARY: &str = concat!(env!("OUT_DIR"), "/libcaer_mock.so");

    /// Path of the USB stand-in built by this crate's build script
    /// (`usb_standin/usb_standin.c`): libusb-1.0's functions over a pretend camera
    /// (DAVIS240, DAVIS346, DVXplorer), for running iniVation's real libcaer without
    /// one. Preload it (`LD_PRELOAD`) into the process that loads libcaer, and choose
    /// the camera, its scene and its faults with the `USB_STANDIN_*` variables the
    /// file's head describes.
    pub const USB_STANDIN: &str = concat!(env!("OUT_DIR"), "/libusb_standin.so");

    /// `caer_mock_fail` flags: what the device refuses.
    pub const FAIL_DEFAULT_CONFIG: i32 = 1;
    pub const FAIL_DATA_START: i32 = 2;
    /// `caerDavisInfoGet` returns all zeros (no DVS size).
    pub const FAIL_INFO: i32 = 4;

    /// `caer_mock_unusable` causes, as `caerDeviceDiscover` and `caerDeviceOpen` show
    /// them: no permission on the device node, firmware too old, claimed by another
    /// program.
    pub const UNUSABLE_PERMISSION: i32 = 1;
    pub const UNUSABLE_VERSION: i32 = 2;
    pub const UNUSABLE_BUSY: i32 = 3;

    /// Containers still handed out after the device went away (they were in
    /// libcaer's ring buffer), before DataGet returns NULL: the mock's
    /// `QUEUED_AFTER_UNPLUG`.
    pub const QUEUED_AFTER_UNPLUG: usize = 2;

    /// `caer_mock_count` subjects.
    pub const COUNT_STARTS: i32 = 0;
    pub const COUNT_STOPS: i32 = 1;
    pub const COUNT_CLOSES: i32 = 2;
    pub const COUNT_SHUTDOWN_CALLS: i32 = 3;

    macro_rules! script {
        ($($(#[$doc:meta])* $field:ident = $symbol:literal: fn($($arg:ident: $ty:ty),*) $(-> $ret:ty)?;)*) => {
            /// The mock's script controls, from the same loaded library (so the same
            /// state), as safe calls: each takes plain values and touches only the
            /// mock's own state.
            pub struct Script {
                $($field: unsafe extern "C" fn($($ty),*) $(-> $ret)?,)*
                _library: libloading::Library,
            }

            impl Script {
                pub fn load() -> Self {
                    // SAFETY: the mock's functions have exactly these C signatures.
                    unsafe {
                        let library = libloading::Library::new(LIBRARY).expect("the mock libcaer");
                        Self {
                            $($field: *library
                                .get(concat!($symbol, "\0").as_bytes())
                                .expect($symbol),)*
                            _library: library,
                        }
                    }
                }

                $(
                    $(#[$doc])*
                    pub fn $field(&self, $($arg: $ty),*) $(-> $ret)? {
                        // SAFETY: loaded with this signature from the library `self`
                        // keeps open; plain values in and out, no pointer kept.
                        unsafe { (self.$field)($($arg),*) }
                    }
                )*
            }
        };
    }

    script! {
        /// Containers served before the device "vanishes", and how many opens fail
        /// after that before it "returns". Resets every other control and counter.
        set = "caer_mock_script": fn(containers_before_disconnect: i32, failed_opens_after: i32);
        /// Opens attempted so far (successful or not).
        open_attempts = "caer_mock_open_attempts": fn() -> i32;
        /// Last value set for (module, parameter), or -1.
        config_value = "caer_mock_config_value": fn(module: i8, param: u8) -> i64;
        /// Whether the caller's last write of (module, parameter) came while the
        /// device was started (after a successful DataStart): 1, 0, or -1 when the
        /// caller never wrote it (DataStart's and DataStop's own writes do not count).
        config_written_while_started = "caer_mock_config_written_while_started": fn(module: i8, param: u8) -> i32;
        /// The DVS size `caerDavisInfoGet` reports (240x180 until set; `set` restores it).
        sensor = "caer_mock_sensor": fn(width_px: i16, height_px: i16);
        /// The camera's family: `CAER_DEVICE_DAVIS` (until set; `set` restores it) or
        /// `CAER_DEVICE_DVXPLORER`, which has its own info call and modules, no APS.
        device = "caer_mock_device": fn(device_type: u16);
        /// What makes the camera on USB unusable (`UNUSABLE_*`; 0 until set).
        unusable = "caer_mock_unusable": fn(why: i32);
        /// What the device refuses from now on: a sum of the `FAIL_*` flags.
        fail = "caer_mock_fail": fn(what: i32);
        /// After this many containers the scene goes dark for this long (us of device
        /// time): a blocking DataGet returns NULL after 1.11-1.22 s meanwhile.
        quiet = "caer_mock_quiet": fn(after_containers: i32, gap_us: i64);
        /// The device clock: it runs at `rate` times real time (1.02: 2 % fast) and each
        /// container arrives a uniform random `latency_min_us..=latency_max_us` after its
        /// newest event. Containers are paced in real time. `set` restores (1, 0, 0).
        clock = "caer_mock_clock": fn(rate: f64, latency_min_us: i32, latency_max_us: i32);
        /// CLOCK_MONOTONIC in microseconds (Rust's `Instant` on Linux).
        now_us = "caer_mock_now_us": fn() -> i64;
        /// The CLOCK_MONOTONIC time (us) at which the device clock of the current
        /// session read `device_us`: when an event stamped so really happened.
        true_host_us = "caer_mock_true_host_us": fn(device_us: i64) -> i64;
        /// How many DataStarts succeeded, DataStops, Closes, shutdown callbacks
        /// (`COUNT_*`).
        count = "caer_mock_count": fn(what: i32) -> i32;
        /// Packets of an event type handed out since `set`.
        packets_served = "caer_mock_packets_served": fn(event_type: i32) -> i32;
        /// Data container `k` as DataGet builds it, APS and IMU running: (k, first
        /// device time in us, edge column). Owned by the caller.
        container = "caer_mock_container": fn(k: i32, t0_us: i64, x: i32) -> caerEventPacketContainer;
        /// The container libcaer sends alone after a timestamp reset. Owned by the
        /// caller.
        timestamp_reset_container = "caer_mock_timestamp_reset_container": fn() -> caerEventPacketContainer;
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

/// Reads the valid polarity events of one packet, appending to `out`; `false` (and
/// nothing read) for a packet of another type or with an inconsistent header.
///
/// Follows libcaer 3.x's `events/common.h` (the packed 28-byte header: type at 0,
/// eventSize at 4, eventTSOffset at 8, eventTSOverflow at 12, eventCapacity at 16,
/// eventNumber at 20) and `events/polarity.h` (the data word, then the timestamp at
/// eventTSOffset; full time = overflow << 31 | timestamp). Only the first
/// `eventNumber` events are filled; the rest of the capacity is zeroed memory.
///
/// # Safety
/// `packet` must be NULL or point to a live libcaer event packet (header and
/// `eventCapacity` events).
pub unsafe fn read_polarity_packet(packet: caerEventPacketHeader, out: &mut Vec<Polarity>) -> bool {
    if packet.is_null() {
        return false;
    }
    // SAFETY: the header's 28 bytes are there (caller's contract); events are read
    // only below `eventNumber`, checked against the capacity first.
    let i32_at = |off: usize| unsafe { packet.add(off).cast::<i32>().read_unaligned() };
    // SAFETY: the type is the header's first two bytes (caller's contract).
    let event_type = unsafe { packet.cast::<i16>().read_unaligned() };
    if event_type != POLARITY_EVENT {
        return false;
    }
    let event_size = i32_at(4);
    let ts_offset = i32_at(8);
    let ts_overflow = i64::from(i32_at(12));
    let capacity = i32_at(16);
    let event_number = i32_at(20);
    if event_size < 8
        || !(0..=event_size - 4).contains(&ts_offset)
        || event_number < 0
        || event_number > capacity
    {
        return false;
    }
    let (event_size, ts_offset) = (event_size as usize, ts_offset as usize);
    out.reserve(event_number as usize);
    for k in 0..event_number as usize {
        let base = PACKET_HEADER_BYTES + k * event_size;
        let data = i32_at(base) as u32;
        if data & 1 == 0 {
            continue;
        }
        let ts = i64::from(i32_at(base + ts_offset));
        out.push(Polarity {
            t_us: (ts_overflow << 31) | ts,
            x: ((data >> 17) & 0x7FFF) as u16,
            y: ((data >> 2) & 0x7FFF) as u16,
            on: data & 2 != 0,
        });
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    unsafe extern "C" {
        fn calloc(count: usize, size: usize) -> *mut c_void;
    }

    /// A packet as libcaer's `caerEventPacketAllocate` makes one (calloc'ed, header
    /// filled in), with `events` (data word, timestamp) of 8 bytes each.
    fn packet(event_type: i16, capacity: i32, events: &[(u32, i32)]) -> *mut u8 {
        let bytes = PACKET_HEADER_BYTES + capacity as usize * 8;
        // SAFETY: a fresh zeroed allocation of `bytes`, written within it.
        unsafe {
            let p = calloc(1, bytes).cast::<u8>();
            let header: [i32; 6] = [8, 4, 0, capacity, events.len() as i32, events.len() as i32];
            p.cast::<i16>().write_unaligned(event_type);
            p.add(2).cast::<i16>().write_unaligned(1);
            for (k, v) in header.iter().enumerate() {
                p.add(4 + 4 * k).cast::<i32>().write_unaligned(*v);
            }
            for (k, &(data, ts)) in events.iter().enumerate() {
                let e = p.add(PACKET_HEADER_BYTES + 8 * k);
                e.cast::<u32>().write_unaligned(data);
                e.add(4).cast::<i32>().write_unaligned(ts);
            }
            p
        }
    }

    /// A container laid out as packetContainer.h lays it out: packed, the count at 24
    /// and the pointers from 28, unaligned.
    fn container(slots: &[*mut u8]) -> caerEventPacketContainer {
        let pointer = std::mem::size_of::<*mut u8>();
        // SAFETY: a fresh zeroed allocation, written within it.
        unsafe {
            let c = calloc(1, CONTAINER_PACKETS_OFFSET + std::mem::size_of_val(slots)).cast::<u8>();
            c.cast::<i64>().write_unaligned(-1);
            c.add(8).cast::<i64>().write_unaligned(-1);
            c.add(CONTAINER_PACKETS_NUMBER_OFFSET)
                .cast::<i32>()
                .write_unaligned(slots.len() as i32);
            for (n, &p) in slots.iter().enumerate() {
                c.add(CONTAINER_PACKETS_OFFSET + n * pointer)
                    .cast::<*mut u8>()
                    .write_unaligned(p);
            }
            c.cast()
        }
    }

    fn polarity_word(x: u32, y: u32, on: bool, valid: bool) -> u32 {
        x << 17 | y << 2 | u32::from(on) << 1 | u32::from(valid)
    }

    #[test]
    fn a_packed_container_gives_its_slots_and_skips_the_null_ones() {
        let polarity = packet(
            POLARITY_EVENT,
            16,
            &[
                (polarity_word(239, 179, true, true), 100),
                (polarity_word(5, 6, false, false), 101),
                (polarity_word(0, 1, false, true), 102),
            ],
        );
        let imu = packet(IMU6_EVENT, 4, &[(1, 150)]);
        let raw = container(&[std::ptr::null_mut(), polarity, std::ptr::null_mut(), imu]);
        // SAFETY: built as libcaer builds them, owned here.
        let c = unsafe { Container::from_raw(raw) }.unwrap();
        assert_eq!(c.packets_number(), 4);
        assert_eq!(c.packet(0), None);
        assert_eq!(c.packet(1), Some(polarity));
        assert_eq!(c.packet(3), Some(imu));
        assert_eq!(c.packet(4), None);
        assert_eq!(c.packet(-1), None);
        assert_eq!(c.packets().collect::<Vec<_>>(), [polarity, imu]);
        let mut out = Vec::new();
        for p in c.packets() {
            // SAFETY: live packets of a live container.
            unsafe { read_polarity_packet(p, &mut out) };
        }
        let expected = [
            Polarity {
                t_us: 100,
                x: 239,
                y: 179,
                on: true,
            },
            Polarity {
                t_us: 102,
                x: 0,
                y: 1,
                on: false,
            },
        ];
        assert_eq!(
            out, expected,
            "the invalid event and the IMU packet skipped"
        );
        // Dropped: both packets and the container go back to libc's free.
        drop(c);
        // SAFETY: NULL is no container.
        assert!(unsafe { Container::from_raw(std::ptr::null_mut()) }.is_none());
    }

    #[test]
    fn a_polarity_packet_claiming_more_events_than_its_capacity_is_not_read() {
        let p = packet(POLARITY_EVENT, 2, &[(polarity_word(1, 1, true, true), 7)]);
        // SAFETY: the header lies within the allocation.
        unsafe { p.add(20).cast::<i32>().write_unaligned(3) };
        let raw = container(&[p]);
        // SAFETY: built as libcaer builds them, owned here.
        let c = unsafe { Container::from_raw(raw) }.unwrap();
        let mut out = Vec::new();
        // SAFETY: a live packet.
        assert!(!unsafe { read_polarity_packet(c.packet(0).unwrap(), &mut out) });
        assert!(out.is_empty());
    }

    #[test]
    fn the_overflow_counter_extends_event_times_past_31_bits() {
        let p = packet(POLARITY_EVENT, 1, &[(polarity_word(1, 2, true, true), 5)]);
        // SAFETY: the header lies within the allocation.
        unsafe { p.add(12).cast::<i32>().write_unaligned(2) };
        // SAFETY: built as libcaer builds them, owned here.
        let c = unsafe { Container::from_raw(container(&[p])) }.unwrap();
        let mut out = Vec::new();
        // SAFETY: a live packet.
        unsafe { read_polarity_packet(c.packet(0).unwrap(), &mut out) };
        assert_eq!(out[0].t_us, (2 << 31) | 5);
    }

    #[test]
    fn no_inline_function_is_loaded_by_name() {
        for name in INLINE_IN_LIBCAER {
            assert!(!LOADED_SYMBOLS.contains(&name), "{name} is static inline");
        }
        assert!(
            LOADED_SYMBOLS
                .iter()
                .all(|s| !s.starts_with("caerEventPacket"))
        );
    }

    #[test]
    fn coarse_fine_biases_encode_as_libcaer_generates_them() {
        // libcaer 3.3.9's DAVIS240 defaults (src/davis_common.h) for DiffBn, OnBn, OffBn.
        assert_eq!(CoarseFineBias::n_type(4, 39).encode(), 17023);
        assert_eq!(CoarseFineBias::n_type(5, 255).encode(), 24575);
        assert_eq!(CoarseFineBias::n_type(4, 0).encode(), 16399);
        let raw_one = CoarseFineBias {
            coarse: 0,
            fine: 0,
            enabled: true,
            sex_n: false,
            type_normal: false,
            current_level_normal: false,
        };
        assert_eq!(
            raw_one.encode(),
            1,
            "what [5, 0, 1] wrote: P-type cascode, no current"
        );
    }
}
