//! Streaming AEDAT 4 reader: one batch per event packet.

use std::io::Read;

use super::compression::decompress;
use super::flatbuf::{self, FlatError};
use super::info::{StreamInfo, parse_streams};
use super::{Compression, MAGIC, MAX_HEADER_BYTES, MAX_PACKET_BYTES};
use crate::events::counted::CountedReader;
use crate::events::{EventReader, Format, SourceError};
use faithd_core::event::Event;

/// Reads the polarity events of every `EVTS` stream of an AEDAT 4 file, skipping the
/// packets of other streams (frames, IMU, triggers) by their size.
pub struct Aedat4Reader<R> {
    input: CountedReader<R>,
    compression: Compression,
    /// File offset where packets end (the data table), if the header gives one.
    packets_end_bytes: Option<u64>,
    streams: Vec<StreamInfo>,
    event_stream_ids: Vec<i32>,
    raw: Vec<u8>,
    decoded: Vec<u8>,
}

impl<R: Read> Aedat4Reader<R> {
    /// Reads the version line and the `IOHeader`.
    pub fn new(input: R) -> Result<Self, SourceError> {
        let mut input = CountedReader::new(input);
        input.expect_magic(MAGIC, "#!AER-DAT4.0\\r\\n")?;
        let size_at_bytes = input.offset_bytes();
        let mut size = [0u8; 4];
        input.read_exact(&mut size, "IOHeader size")?;
        let size_bytes = i32::from_le_bytes(size);
        if size_bytes < 8 {
            return Err(SourceError::invalid(
                "IOHeader size",
                size_at_bytes,
                format!("{size_bytes} bytes is too small for a flatbuffer"),
            ));
        }
        if size_bytes as u64 > MAX_HEADER_BYTES {
            return Err(SourceError::TooLarge {
                field: "IOHeader size",
                offset_bytes: size_at_bytes,
                value: size_bytes as u64,
                limit: MAX_HEADER_BYTES,
            });
        }
        let header_at_bytes = input.offset_bytes();
        let mut header = Vec::new();
        input.read_into(size_bytes as u64, &mut header, "IOHeader")?;
        let fields = flatbuf::read_io_header(&header)
            .map_err(|e| flat_error("IOHeader", header_at_bytes, e))?;
        let compression = Compression::from_i32(fields.compression).ok_or_else(|| {
            SourceError::invalid(
                "IOHeader compression",
                header_at_bytes,
                format!("unknown compression type {}", fields.compression),
            )
        })?;
        let streams = parse_streams(&fields.info_node);
        let event_stream_ids: Vec<i32> = streams
            .iter()
            .filter(|s| s.type_identifier == "EVTS")
            .map(|s| s.id)
            .collect();
        if event_stream_ids.is_empty() {
            return Err(SourceError::invalid(
                "IOHeader infoNode",
                header_at_bytes,
                "no event (EVTS) stream declared",
            ));
        }
        Ok(Self {
            input,
            compression,
            packets_end_bytes: u64::try_from(fields.data_table_position).ok(),
            streams,
            event_stream_ids,
            raw: Vec::new(),
            decoded: Vec::new(),
        })
    }

    /// The streams the header declares, of every type.
    pub fn streams(&self) -> &[StreamInfo] {
        &self.streams
    }

    /// The compression the header declares for every packet.
    pub fn compression(&self) -> Compression {
        self.compression
    }
}

/// Maps an error inside a flatbuffer that starts at `buffer_at_bytes` in the file.
fn flat_error(field: &'static str, buffer_at_bytes: u64, error: FlatError) -> SourceError {
    SourceError::invalid(field, buffer_at_bytes + error.at as u64, error.reason)
}

impl<R: Read> EventReader for Aedat4Reader<R> {
    fn next_batch(&mut self, out: &mut Vec<Event>) -> Result<bool, SourceError> {
        out.clear();
        loop {
            let packet_at_bytes = self.input.offset_bytes();
            if self
                .packets_end_bytes
                .is_some_and(|end| packet_at_bytes >= end)
            {
                return Ok(false);
            }
            let mut packet_header = [0u8; 8];
            if !self
                .input
                .read_exact_or_eof(&mut packet_header, "packet header")?
            {
                return Ok(false);
            }
            let stream_id = i32::from_le_bytes(packet_header[0..4].try_into().expect("4 bytes"));
            let size_bytes = i32::from_le_bytes(packet_header[4..8].try_into().expect("4 bytes"));
            if size_bytes < 0 {
                return Err(SourceError::invalid(
                    "packet size",
                    packet_at_bytes + 4,
                    format!("negative size {size_bytes}"),
                ));
            }
            if size_bytes as u64 > MAX_PACKET_BYTES {
                return Err(SourceError::TooLarge {
                    field: "packet size",
                    offset_bytes: packet_at_bytes + 4,
                    value: size_bytes as u64,
                    limit: MAX_PACKET_BYTES,
                });
            }
            if !self.event_stream_ids.contains(&stream_id) {
                self.input.skip(size_bytes as u64, "packet body")?;
                continue;
            }
            let body_at_bytes = self.input.offset_bytes();
            self.input
                .read_into(size_bytes as u64, &mut self.raw, "event packet body")?;
            let flat = if self.compression == Compression::None {
                &self.raw
            } else {
                decompress(
                    self.compression,
                    &self.raw,
                    &mut self.decoded,
                    MAX_PACKET_BYTES,
                )
                .map_err(|reason| {
                    SourceError::invalid("compressed event packet", body_at_bytes, reason)
                })?;
                &self.decoded
            };
            // Offsets in errors count from the start of the size-prefixed buffer.
            let parsed = flatbuf::unprefix(flat).and_then(|buf| {
                flatbuf::read_event_packet(buf, out).map_err(|mut error| {
                    error.at += 4;
                    error
                })
            });
            if let Err(error) = parsed {
                out.clear();
                return Err(if self.compression == Compression::None {
                    SourceError::invalid(
                        "EventPacket",
                        body_at_bytes + error.at as u64,
                        error.reason,
                    )
                } else {
                    SourceError::invalid(
                        "EventPacket",
                        body_at_bytes,
                        format!(
                            "{} at byte {} of the decompressed packet",
                            error.reason, error.at
                        ),
                    )
                });
            }
            return Ok(true);
        }
    }

    fn format(&self) -> Format {
        Format::Aedat4
    }
}
