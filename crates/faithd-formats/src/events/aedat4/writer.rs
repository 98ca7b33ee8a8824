//! AEDAT 4 writer: the format faithd records flights in, readable by DV and
//! dv-processing.

use std::io::{Seek, Write};

use super::compression::compress;
use super::flatbuf::{self, DataTableEntry};
use super::info::event_stream_xml;
use super::{Compression, MAGIC};
use crate::events::SourceError;
use faithd_core::event::Event;

/// What the header of a new recording says.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Aedat4Config {
    pub width_px: u16,
    pub height_px: u16,
    pub compression: Compression,
    /// Camera name stored as the stream's `source` (e.g. `DVS240`).
    pub source: String,
}

impl Default for Aedat4Config {
    fn default() -> Self {
        Self {
            width_px: 240,
            height_px: 180,
            compression: Compression::Lz4,
            source: "DVS240".to_string(),
        }
    }
}

/// Largest packet written; bigger batches are split so readers never meet a packet
/// near [`super::MAX_PACKET_BYTES`].
const MAX_WRITE_PACKET_EVENTS: usize = 64 * 1024;

/// Writes one event stream (id 0) as AEDAT 4.0.
///
/// Each [`write_events`](Self::write_events) call becomes one packet (or several if
/// large), written through at once, so a recording cut short by a crash keeps every
/// packet written so far: its header then says `dataTablePosition = -1` and readers
/// walk the packets. [`finish`](Self::finish) appends the packet index and fills in its
/// position in the header, which is why the output must be seekable.
pub struct Aedat4Writer<W: Write + Seek> {
    output: W,
    config: Aedat4Config,
    written_bytes: u64,
    // Where the IO header starts: the index position is patched there once the index is written again.
    #[allow(dead_code)]
    header_at_bytes: u64,
    last_t_us: Option<i64>,
    table: Vec<DataTableEntry>,
    flat: Vec<u8>,
    packed: Vec<u8>,
}

impl<W: Write + Seek> Aedat4Writer<W> {
    pub fn new(mut output: W, config: Aedat4Config) -> Result<Self, SourceError> {
        if config.width_px > i16::MAX as u16 || config.height_px > i16::MAX as u16 {
            return Err(SourceError::Unrepresentable {
                what: "AEDAT 4.0 resolution",
                reason: format!(
                    "{}x{} beyond 16-bit signed coordinates",
                    config.width_px, config.height_px
                ),
            });
        }
        let xml = event_stream_xml(
            config.compression,
            config.width_px,
            config.height_px,
            &config.source,
        );
        let mut bytes = MAGIC.to_vec();
        let header_at_bytes = bytes.len() as u64;
        flatbuf::write_io_header(&mut bytes, config.compression as i32, -1, &xml);
        output
            .write_all(&bytes)
            .map_err(|e| SourceError::write_io(e, 0))?;
        Ok(Self {
            output,
            config,
            written_bytes: bytes.len() as u64,
            header_at_bytes,
            last_t_us: None,
            table: Vec::new(),
            flat: Vec::new(),
            packed: Vec::new(),
        })
    }

    /// Appends events as packets. Times must not decrease (within and across calls)
    /// and pixels must lie on the sensor declared in the header, as DV requires.
    pub fn write_events(&mut self, events: &[Event]) -> Result<(), SourceError> {
        let mut last_t_us = self.last_t_us;
        for event in events {
            if last_t_us.is_some_and(|last| event.t_us < last) {
                return Err(SourceError::Unrepresentable {
                    what: "AEDAT 4.0 event",
                    reason: format!(
                        "time {} us goes back from {} us",
                        event.t_us,
                        last_t_us.unwrap_or_default()
                    ),
                });
            }
            if event.x_px >= self.config.width_px || event.y_px >= self.config.height_px {
                return Err(SourceError::Unrepresentable {
                    what: "AEDAT 4.0 event",
                    reason: format!(
                        "pixel ({}, {}) outside the {}x{} sensor",
                        event.x_px, event.y_px, self.config.width_px, self.config.height_px
                    ),
                });
            }
            last_t_us = Some(event.t_us);
        }
        for packet in events.chunks(MAX_WRITE_PACKET_EVENTS) {
            self.write_packet(packet)?;
        }
        self.last_t_us = last_t_us;
        Ok(())
    }

    fn write_packet(&mut self, events: &[Event]) -> Result<(), SourceError> {
        let (Some(first), Some(last)) = (events.first(), events.last()) else {
            return Ok(());
        };
        self.flat.clear();
        flatbuf::write_event_packet(&mut self.flat, events);
        compress(self.config.compression, &self.flat, &mut self.packed)
            .map_err(|e| SourceError::write_io(e, self.written_bytes))?;
        let body_bytes =
            i32::try_from(self.packed.len()).map_err(|_| SourceError::Unrepresentable {
                what: "AEDAT 4.0 packet",
                reason: format!("{} bytes exceed the 32-bit size field", self.packed.len()),
            })?;
        // Header and body leave in one write: a process killed between two writes
        // would leave a header without its body.
        let mut packet_header = [0u8; 8];
        packet_header[4..].copy_from_slice(&body_bytes.to_le_bytes());
        self.packed.splice(0..0, packet_header);
        self.output
            .write_all(&self.packed)
            .map_err(|e| SourceError::write_io(e, self.written_bytes))?;
        self.packed.drain(..8);
        self.table.push(DataTableEntry {
            body_at_bytes: (self.written_bytes + 8) as i64,
            stream_id: 0,
            body_bytes,
            elements: events.len() as i64,
            first_t_us: first.t_us,
            last_t_us: last.t_us,
        });
        self.written_bytes += 8 + self.packed.len() as u64;
        Ok(())
    }

    /// Bytes of whole packets (and the header) written so far: where the output
    /// should be cut back to when a write fails halfway through a packet.
    pub fn written_bytes(&self) -> u64 {
        self.written_bytes
    }

    /// The output, for a caller that has to repair it after a failed write.
    pub fn get_mut(&mut self) -> &mut W {
        &mut self.output
    }

    /// Flushes and hands back the output positioned at its end.
    ///
    /// The packet index (data table) is not written: dv-processing 2.0.4 spun forever
    /// reading the index this writer produced (found by tests/aedat4_interop.rs), while
    /// it reads files without one (`dataTablePosition = -1`) by walking the packets, as
    /// faithd does. Until the index is understood, recordings carry none.
    pub fn finish(mut self) -> Result<W, SourceError> {
        let at = self.written_bytes;
        self.output
            .flush()
            .map_err(|e| SourceError::write_io(e, at))?;
        Ok(self.output)
    }
}
