//! The few libcaer functions faithd needs, declared from libcaer's public headers
//! (`libcaer/devices/device.h`, `devices/usb.h`, `events/packetContainer.h`,
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
