//! AEDAT 4.0, the format of iniVation's DV software and dv-processing.
//!
//! Layout (iniVation's "AEDAT 4.0 file format" page and the dv-processing schemas
//! `IOHeader.fbs`, `events.fbs`, `FileDataTable.fbs`):
//!
//! - `#!AER-DAT4.0\r\n` (14 bytes);
//! - an `i32` size and that many bytes of `IOHeader` flatbuffer: `compression`
//!   (`NONE`, `LZ4`, `LZ4_HIGH`, `ZSTD`, `ZSTD_HIGH`), `dataTablePosition` (file offset
//!   of the packet index, `-1` if absent) and `infoNode`, an XML list of streams;
//! - packets: `i32` stream id, `i32` body size, then the body, compressed on its own,
//!   which decompresses to a size-prefixed flatbuffer; for `EVTS` streams an
//!   `EventPacket` whose vector holds 16-byte `Event` structs (`i64` timestamp in us,
//!   `i16` x, `i16` y, `bool` polarity, padding);
//! - at `dataTablePosition`, a size-prefixed `FileDataTable` indexing every packet.
//!
//! The reader streams packets in file order and stops at the data table. The writer
//! ([`Aedat4Writer`]) produces files dv-processing opens (checked by
//! `tests/aedat4_interop.rs`), and is what faithd records flights with.

mod compression;
mod flatbuf;
mod info;
mod reader;
mod writer;

pub use info::StreamInfo;
pub use reader::Aedat4Reader;
pub use writer::{Aedat4Config, Aedat4Writer};

/// The `IOHeader` compression types, numbered as in `IOHeader.fbs`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compression {
    None = 0,
    Lz4 = 1,
    Lz4High = 2,
    Zstd = 3,
    ZstdHigh = 4,
}

impl Compression {
    pub const ALL: [Compression; 5] = [
        Compression::None,
        Compression::Lz4,
        Compression::Lz4High,
        Compression::Zstd,
        Compression::ZstdHigh,
    ];

    pub fn from_i32(value: i32) -> Option<Compression> {
        Compression::ALL.into_iter().find(|c| *c as i32 == value)
    }

    /// The name DV uses in the `infoNode` (`compression` attribute).
    pub fn name(self) -> &'static str {
        match self {
            Compression::None => "NONE",
            Compression::Lz4 => "LZ4",
            Compression::Lz4High => "LZ4_HIGH",
            Compression::Zstd => "ZSTD",
            Compression::ZstdHigh => "ZSTD_HIGH",
        }
    }
}

/// The version line every AEDAT 4 file starts with.
pub const MAGIC: &[u8; 14] = b"#!AER-DAT4.0\r\n";
/// Largest `IOHeader` accepted; real ones are a few kilobytes of XML.
pub const MAX_HEADER_BYTES: u64 = 16 * 1024 * 1024;
/// Largest packet body accepted, compressed or not; DV writes packets of a few
/// thousand events (tens of kilobytes).
pub const MAX_PACKET_BYTES: u64 = 64 * 1024 * 1024;
