//! The few libcaer functions faithd needs, declared from libcaer's public headers
//! (`libcaer/devices/device.h`, `devices/usb.h`, `events/packetContainer.h`,
//! `events/common.h`, `events/polarity.h`, libcaer 3.x).
//!
//! Event packets are read through their documented memory layout (the same layout
//! AEDAT 3.1 files store): a 28-byte little-endian header followed by `eventCapacity`
//! events of `eventSize` bytes; a polarity event is a `u32` data word (bit 0 valid,
//! bit 1 polarity, bits 2..16 y, bits 17..31 x) and an `i32` timestamp.

#![allow(non_camel_case_types)]

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

unsafe extern "C" {
    pub fn caerDeviceOpen(
        device_id: u16,
        device_type: u16,
        bus_number_restrict: u8,
        dev_address_restrict: u8,
        serial_number_restrict: *const c_char,
    ) -> caerDeviceHandle;
    pub fn caerDeviceClose(handle: *mut caerDeviceHandle) -> bool;
    pub fn caerDeviceSendDefaultConfig(handle: caerDeviceHandle) -> bool;
    pub fn caerDeviceConfigSet(
        handle: caerDeviceHandle,
        mod_addr: i8,
        param_addr: u8,
        param: u32,
    ) -> bool;
    pub fn caerDeviceDataStart(
        handle: caerDeviceHandle,
        data_notify_increase: NotifyFn,
        data_notify_decrease: NotifyFn,
        data_notify_user_ptr: *mut c_void,
        data_shutdown_notify: NotifyFn,
        data_shutdown_user_ptr: *mut c_void,
    ) -> bool;
    pub fn caerDeviceDataStop(handle: caerDeviceHandle) -> bool;
    pub fn caerDeviceDataGet(handle: caerDeviceHandle) -> caerEventPacketContainer;
    pub fn caerEventPacketContainerFree(container: caerEventPacketContainer);
    pub fn caerEventPacketContainerGetEventPacketsNumber(
        container: caerEventPacketContainer,
    ) -> i32;
    pub fn caerEventPacketContainerGetEventPacket(
        container: caerEventPacketContainer,
        n: i32,
    ) -> caerEventPacketHeader;
}

/// The mock's script controls (only with the `mock` feature).
#[cfg(feature = "mock")]
pub mod mock {
    unsafe extern "C" {
        /// Containers served before the device "vanishes", and how many opens fail
        /// after that before it "returns". Resets the counters.
        pub fn caer_mock_script(containers_before_disconnect: i32, failed_opens_after: i32);
        /// Opens attempted so far (successful or not).
        pub fn caer_mock_open_attempts() -> i32;
        /// Last value set for (module, parameter), or -1.
        pub fn caer_mock_config_value(mod_addr: i8, param_addr: u8) -> i64;
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
