//! AEDAT 3.1, the cAER / libcaer format: `#` header lines closed by `#!END-HEADER`,
//! then packets of one event type each.
//!
//! A packet is a 28-byte little-endian header (`eventType i16, eventSource i16,
//! eventSize i32, eventTSOffset i32, eventTSOverflow i32, eventCapacity i32,
//! eventNumber i32, eventValid i32`) followed by `eventCapacity * eventSize` bytes.
//! Polarity packets (type 1) hold 8-byte events: a `u32` with bit 0 valid, bit 1
//! polarity, `y` in bits 2..=16 and `x` in bits 17..=31, then an `i32` timestamp whose
//! full value is `(eventTSOverflow << 31) | timestamp` microseconds. Packets of other
//! types (special, frame, IMU) are skipped by their size. Rows count from the top, as
//! in faithd.

use std::io::{Read, Write};

use super::counted::{CountedReader, read_hash_header};
use super::{AEDAT3_MAGIC, EventReader, Format, SourceError};
use faithd_core::event::{Event, Polarity};

const HEADER_BYTES: usize = 28;
const POLARITY_EVENT_TYPE: i16 = 1;
const POLARITY_EVENT_BYTES: usize = 8;
/// Largest packet body accepted; libcaer packets are a few hundred kilobytes.
pub const MAX_PACKET_BYTES: u64 = 64 * 1024 * 1024;
/// Events per packet written by [`Aedat3Writer`].
const WRITE_PACKET_EVENTS: usize = 4096;

/// Streaming reader of AEDAT 3.1 files; one batch per polarity packet.
pub struct Aedat3Reader<R> {
    input: CountedReader<R>,
    body: Vec<u8>,
}

impl<R: Read> Aedat3Reader<R> {
    pub fn new(input: R) -> Result<Self, SourceError> {
        let mut input = CountedReader::new(input);
        input.expect_magic(AEDAT3_MAGIC, "#!AER-DAT3.1")?;
        let mut rest_of_line = Vec::new();
        input.read_line(&mut rest_of_line, 4096, "header line")?;
        if !read_hash_header(&mut input, Some(b"#!END-HEADER"))? {
            return Err(SourceError::invalid(
                "AEDAT 3.1 header",
                input.offset_bytes(),
                "no #!END-HEADER line before the first non-# byte",
            ));
        }
        Ok(Self {
            input,
            body: Vec::new(),
        })
    }
}

/// The fields of a packet header faithd uses.
struct PacketHeader {
    event_type: i16,
    event_size_bytes: i32,
    ts_offset_bytes: i32,
    ts_overflow: i32,
    capacity: i32,
    number: i32,
}

impl PacketHeader {
    fn parse(bytes: &[u8; HEADER_BYTES]) -> Self {
        let i32_at = |at: usize| {
            i32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
        };
        Self {
            event_type: i16::from_le_bytes([bytes[0], bytes[1]]),
            event_size_bytes: i32_at(4),
            ts_offset_bytes: i32_at(8),
            ts_overflow: i32_at(12),
            capacity: i32_at(16),
            number: i32_at(20),
        }
    }
}

impl<R: Read> EventReader for Aedat3Reader<R> {
    fn next_batch(&mut self, out: &mut Vec<Event>) -> Result<bool, SourceError> {
        out.clear();
        let header_at_bytes = self.input.offset_bytes();
        let mut header_bytes = [0u8; HEADER_BYTES];
        if !self
            .input
            .read_exact_or_eof(&mut header_bytes, "AEDAT 3.1 packet header")?
        {
            return Ok(false);
        }
        let header = PacketHeader::parse(&header_bytes);
        let field_at = |field_offset: u64| header_at_bytes + field_offset;
        if header.event_size_bytes < 0 {
            return Err(SourceError::invalid(
                "eventSize",
                field_at(4),
                format!("negative size {}", header.event_size_bytes),
            ));
        }
        if header.capacity < 0 {
            return Err(SourceError::invalid(
                "eventCapacity",
                field_at(16),
                format!("negative capacity {}", header.capacity),
            ));
        }
        if header.number < 0 || header.number > header.capacity {
            return Err(SourceError::invalid(
                "eventNumber",
                field_at(20),
                format!(
                    "{} is outside 0..={} (eventCapacity)",
                    header.number, header.capacity
                ),
            ));
        }
        if header.ts_overflow < 0 {
            return Err(SourceError::invalid(
                "eventTSOverflow",
                field_at(12),
                format!("negative overflow count {}", header.ts_overflow),
            ));
        }
        let body_bytes = header.capacity as u64 * header.event_size_bytes as u64;
        if body_bytes > MAX_PACKET_BYTES {
            return Err(SourceError::TooLarge {
                field: "eventCapacity * eventSize",
                offset_bytes: field_at(4),
                value: body_bytes,
                limit: MAX_PACKET_BYTES,
            });
        }
        if header.event_type != POLARITY_EVENT_TYPE {
            self.input.skip(body_bytes, "AEDAT 3.1 packet body")?;
            return Ok(true);
        }
        if header.event_size_bytes as usize != POLARITY_EVENT_BYTES || header.ts_offset_bytes != 4 {
            return Err(SourceError::invalid(
                "polarity packet header",
                field_at(4),
                format!(
                    "eventSize {} and eventTSOffset {}, expected 8 and 4",
                    header.event_size_bytes, header.ts_offset_bytes
                ),
            ));
        }
        let body_at_bytes = self.input.offset_bytes();
        self.input
            .read_into(body_bytes, &mut self.body, "AEDAT 3.1 polarity packet body")?;
        let overflow_us = i64::from(header.ts_overflow) << 31;
        for (i, raw) in self
            .body
            .chunks_exact(POLARITY_EVENT_BYTES)
            .take(header.number as usize)
            .enumerate()
        {
            let data = u32::from_le_bytes([raw[0], raw[1], raw[2], raw[3]]);
            let t_us = i32::from_le_bytes([raw[4], raw[5], raw[6], raw[7]]);
            if data & 1 == 0 {
                continue;
            }
            if t_us < 0 {
                return Err(SourceError::invalid(
                    "polarity event timestamp",
                    body_at_bytes + (i * POLARITY_EVENT_BYTES) as u64 + 4,
                    format!("negative timestamp {t_us}"),
                ));
            }
            let y_px = ((data >> 2) & 0x7FFF) as u16;
            let x_px = ((data >> 17) & 0x7FFF) as u16;
            let polarity = Polarity::from_bool(data & 2 != 0);
            out.push(Event::new(
                overflow_us | i64::from(t_us),
                x_px,
                y_px,
                polarity,
            ));
        }
        Ok(true)
    }

    fn format(&self) -> Format {
        Format::Aedat3
    }
}

/// Writes AEDAT 3.1 files of polarity packets (source id 1), as libcaer would.
pub struct Aedat3Writer<W: Write> {
    output: W,
    written_bytes: u64,
    buffer: Vec<u8>,
}

impl<W: Write> Aedat3Writer<W> {
    pub fn new(mut output: W) -> Result<Self, SourceError> {
        let header = b"#!AER-DAT3.1\r\n\
#Format: RAW\r\n\
#Source 1: DVS240\r\n\
#Start-Time: written by faithd\r\n\
#!END-HEADER\r\n";
        output
            .write_all(header)
            .map_err(|e| SourceError::write_io(e, 0))?;
        Ok(Self {
            output,
            written_bytes: header.len() as u64,
            buffer: Vec::new(),
        })
    }

    /// Appends events as polarity packets. A packet holds events of one timestamp
    /// overflow epoch (2^31 us), so a new packet starts wherever the epoch changes.
    pub fn write_events(&mut self, events: &[Event]) -> Result<(), SourceError> {
        for event in events {
            if event.t_us < 0 {
                return Err(SourceError::Unrepresentable {
                    what: "AEDAT 3.1 event",
                    reason: format!("negative time {} us", event.t_us),
                });
            }
            if event.x_px > 0x7FFF || event.y_px > 0x7FFF {
                return Err(SourceError::Unrepresentable {
                    what: "AEDAT 3.1 event",
                    reason: format!("pixel ({}, {}) beyond 15 bits", event.x_px, event.y_px),
                });
            }
            if (event.t_us >> 31) > i64::from(i32::MAX) {
                return Err(SourceError::Unrepresentable {
                    what: "AEDAT 3.1 event",
                    reason: format!("time {} us beyond the 62-bit range", event.t_us),
                });
            }
        }
        let mut rest = events;
        while let Some(first) = rest.first() {
            let epoch = first.t_us >> 31;
            let len = rest
                .iter()
                .take(WRITE_PACKET_EVENTS)
                .take_while(|e| e.t_us >> 31 == epoch)
                .count();
            let (packet, tail) = rest.split_at(len);
            self.write_packet(epoch as i32, packet)?;
            rest = tail;
        }
        Ok(())
    }

    fn write_packet(&mut self, ts_overflow: i32, events: &[Event]) -> Result<(), SourceError> {
        let count = events.len() as i32;
        self.buffer.clear();
        self.buffer
            .extend_from_slice(&POLARITY_EVENT_TYPE.to_le_bytes());
        self.buffer.extend_from_slice(&1i16.to_le_bytes());
        for field in [8i32, 4, ts_overflow, count, count, count] {
            self.buffer.extend_from_slice(&field.to_le_bytes());
        }
        for event in events {
            let data = 1u32
                | (u32::from(event.polarity == Polarity::On) << 1)
                | (u32::from(event.y_px) << 2)
                | (u32::from(event.x_px) << 17);
            self.buffer.extend_from_slice(&data.to_le_bytes());
            let t_us = (event.t_us & 0x7FFF_FFFF) as i32;
            self.buffer.extend_from_slice(&t_us.to_le_bytes());
        }
        self.output
            .write_all(&self.buffer)
            .map_err(|e| SourceError::write_io(e, self.written_bytes))?;
        self.written_bytes += self.buffer.len() as u64;
        Ok(())
    }

    pub fn finish(mut self) -> Result<W, SourceError> {
        self.output
            .flush()
            .map_err(|e| SourceError::write_io(e, self.written_bytes))?;
        Ok(self.output)
    }
}
