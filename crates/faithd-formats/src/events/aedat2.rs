//! AEDAT 2.0, the jAER format: `#` header lines, then big-endian 8-byte records of a
//! 32-bit address and a 32-bit timestamp in microseconds.
//!
//! Address layout of the DAVIS240 (jAER's `DavisBaseCamera` extractor, and iniVation's
//! "AEDAT 2.0" documentation): bit 31 set marks an APS (frame) sample, bit 10 set an
//! IMU or external sample; both are skipped. For DVS events `y` is bits 22..=30, `x`
//! bits 12..=21 and the polarity bit 11 (1 = on).
//!
//! Orientation: jAER puts the origin at the bottom-left corner (row 0 is the bottom of
//! the image), while libcaer, DV (AEDAT 3/4) and faithd's camera model count rows from
//! the top. The DAVIS240 address carries the sensor's row counted from the bottom, so
//! by default this reader flips it, `y = height - 1 - raw_y`, and the writer flips it
//! back; `x` is not mirrored (jAER's DAVIS extractor uses the column as is; the
//! mirrored `x` seen in some scripts belongs to the older DVS128 layout). An event
//! recorded in AEDAT 2 and in AEDAT 3/4 by the same camera therefore lands on the same
//! pixel. [`Aedat2Layout::flip_y`] turns the flip off for files made by tools that
//! wrote top-left rows.
//!
//! Timestamps are 32-bit and wrap after about 71 minutes; the reader unwraps them into
//! the 64-bit time base, assuming no gap longer than half a wrap between records.

use std::io::{Read, Write};

use super::counted::{CountedReader, read_hash_header};
use super::{AEDAT2_MAGIC, EventReader, Format, SourceError};
use faithd_core::event::{Event, Polarity};

const APS_FLAG: u32 = 1 << 31;
const IMU_FLAG: u32 = 1 << 10;
const Y_SHIFT: u32 = 22;
const Y_MASK: u32 = 0x1FF;
const X_SHIFT: u32 = 12;
const X_MASK: u32 = 0x3FF;
const POLARITY_BIT: u32 = 1 << 11;
const RECORD_BYTES: usize = 8;
/// jAER's last header line. With it the header's end is known; without it (older or
/// hand-made files) header lines are told from records by being text, which a record
/// can mimic: a DVS address starting 0x23 0x0A reads as the line "#\n".
const END_OF_HEADER: &[u8] = b"#End Of ASCII Header";
/// Records read per batch.
const BATCH_RECORDS: usize = 4096;

/// Sensor geometry used to flip rows between jAER's bottom-left origin and faithd's
/// top-left one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Aedat2Layout {
    pub width_px: u16,
    pub height_px: u16,
    /// Flip rows (`y = height - 1 - raw`), right for files recorded by jAER.
    pub flip_y: bool,
}

impl Aedat2Layout {
    /// The DAVIS240 (240 x 180) as jAER records it.
    pub const DAVIS240: Aedat2Layout = Aedat2Layout {
        width_px: 240,
        height_px: 180,
        flip_y: true,
    };
}

impl Default for Aedat2Layout {
    fn default() -> Self {
        Self::DAVIS240
    }
}

/// Streaming reader of AEDAT 2.0 files.
pub struct Aedat2Reader<R> {
    input: CountedReader<R>,
    layout: Aedat2Layout,
    records: Vec<u8>,
    /// Raw timestamp of the previous record and how many wraps came before it.
    last_raw_t_us: Option<u32>,
    wraps: i64,
}

impl<R: Read> Aedat2Reader<R> {
    /// Reads the header of a DAVIS240 recording.
    pub fn new(input: R) -> Result<Self, SourceError> {
        Self::with_layout(input, Aedat2Layout::DAVIS240)
    }

    pub fn with_layout(input: R, layout: Aedat2Layout) -> Result<Self, SourceError> {
        let mut input = CountedReader::new(input);
        input.expect_magic(AEDAT2_MAGIC, "#!AER-DAT2.0")?;
        let mut rest_of_line = Vec::new();
        input.read_line(&mut rest_of_line, 4096, "header line")?;
        read_hash_header(&mut input, Some(END_OF_HEADER))?;
        Ok(Self {
            input,
            layout,
            records: vec![0; BATCH_RECORDS * RECORD_BYTES],
            last_raw_t_us: None,
            wraps: 0,
        })
    }

    fn unwrap_time(&mut self, raw_t_us: u32) -> i64 {
        if let Some(last) = self.last_raw_t_us {
            if raw_t_us < last && last - raw_t_us > 1 << 31 {
                self.wraps += 1;
            } else if raw_t_us > last && raw_t_us - last > 1 << 31 && self.wraps > 0 {
                // A record slightly older than one just past the wrap.
                return (self.wraps - 1) * (1i64 << 32) + i64::from(raw_t_us);
            }
        }
        self.last_raw_t_us = Some(raw_t_us);
        self.wraps * (1i64 << 32) + i64::from(raw_t_us)
    }
}

impl<R: Read> EventReader for Aedat2Reader<R> {
    fn next_batch(&mut self, out: &mut Vec<Event>) -> Result<bool, SourceError> {
        out.clear();
        let mut records = std::mem::take(&mut self.records);
        let batch_start_bytes = self.input.offset_bytes();
        let mut filled = 0;
        let result = (|| {
            for chunk in records.chunks_exact_mut(RECORD_BYTES) {
                if !self.input.read_exact_or_eof(chunk, "AEDAT 2.0 record")? {
                    break;
                }
                filled += 1;
            }
            for (i, record) in records[..filled * RECORD_BYTES]
                .chunks_exact(RECORD_BYTES)
                .enumerate()
            {
                let address = u32::from_be_bytes([record[0], record[1], record[2], record[3]]);
                let raw_t_us = u32::from_be_bytes([record[4], record[5], record[6], record[7]]);
                let t_us = self.unwrap_time(raw_t_us);
                if address & (APS_FLAG | IMU_FLAG) != 0 {
                    continue;
                }
                let raw_x = (address >> X_SHIFT) & X_MASK;
                let raw_y = (address >> Y_SHIFT) & Y_MASK;
                let offset_bytes = batch_start_bytes + (i * RECORD_BYTES) as u64;
                if raw_x >= u32::from(self.layout.width_px)
                    || raw_y >= u32::from(self.layout.height_px)
                {
                    return Err(SourceError::invalid(
                        "AEDAT 2.0 address",
                        offset_bytes,
                        format!(
                            "pixel ({raw_x}, {raw_y}) outside the {}x{} sensor (address {address:#010x})",
                            self.layout.width_px, self.layout.height_px
                        ),
                    ));
                }
                let y_px = if self.layout.flip_y {
                    self.layout.height_px - 1 - raw_y as u16
                } else {
                    raw_y as u16
                };
                let polarity = Polarity::from_bool(address & POLARITY_BIT != 0);
                out.push(Event::new(t_us, raw_x as u16, y_px, polarity));
            }
            Ok(())
        })();
        self.records = records;
        result?;
        Ok(filled > 0)
    }

    fn format(&self) -> Format {
        Format::Aedat2
    }
}

/// Writes DAVIS240-layout AEDAT 2.0 files that jAER opens, for tests and exports.
pub struct Aedat2Writer<W: Write> {
    output: W,
    layout: Aedat2Layout,
    written_bytes: u64,
    buffer: Vec<u8>,
}

impl<W: Write> Aedat2Writer<W> {
    pub fn new(output: W) -> Result<Self, SourceError> {
        Self::with_layout(output, Aedat2Layout::DAVIS240)
    }

    pub fn with_layout(mut output: W, layout: Aedat2Layout) -> Result<Self, SourceError> {
        let header = b"#!AER-DAT2.0\r\n\
# This is a raw AE data file created by faithd\r\n\
# Data format is int32 address, int32 timestamp (8 bytes total), repeated for each event\r\n\
# Timestamps tick is 1 us\r\n\
#End Of ASCII Header\r\n";
        output
            .write_all(header)
            .map_err(|e| SourceError::write_io(e, 0))?;
        Ok(Self {
            output,
            layout,
            written_bytes: header.len() as u64,
            buffer: Vec::new(),
        })
    }

    /// Appends events. Times must be non-negative; they are stored modulo 2^32 as the
    /// format has 32 bits, and the reader unwraps them again.
    pub fn write_events(&mut self, events: &[Event]) -> Result<(), SourceError> {
        self.buffer.clear();
        for event in events {
            if event.t_us < 0 {
                return Err(SourceError::Unrepresentable {
                    what: "AEDAT 2.0 event",
                    reason: format!("negative time {} us", event.t_us),
                });
            }
            if event.x_px >= self.layout.width_px || event.y_px >= self.layout.height_px {
                return Err(SourceError::Unrepresentable {
                    what: "AEDAT 2.0 event",
                    reason: format!(
                        "pixel ({}, {}) outside the {}x{} sensor",
                        event.x_px, event.y_px, self.layout.width_px, self.layout.height_px
                    ),
                });
            }
            let raw_y = if self.layout.flip_y {
                self.layout.height_px - 1 - event.y_px
            } else {
                event.y_px
            };
            let mut address = (u32::from(raw_y) << Y_SHIFT) | (u32::from(event.x_px) << X_SHIFT);
            if event.polarity == Polarity::On {
                address |= POLARITY_BIT;
            }
            self.buffer.extend_from_slice(&address.to_be_bytes());
            self.buffer
                .extend_from_slice(&((event.t_us as u64 & 0xFFFF_FFFF) as u32).to_be_bytes());
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
