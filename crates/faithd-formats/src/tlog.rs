//! MAVLink telemetry logs in the `.tlog` format ground stations write (QGroundControl,
//! Mission Planner, MAVProxy, pymavlink): each record is an 8-byte big-endian
//! timestamp (microseconds since the Unix epoch) followed by one raw MAVLink frame.
//!
//! The reader streams: it never holds more than one frame (at most 280 bytes), and a
//! damaged record is reported with its byte offset rather than skipped silently.

use std::io::{Read, Write};

use mavlink::dialects::common::MavMessage;
use mavlink::{MavHeader, MavlinkVersion};

#[derive(Debug, thiserror::Error)]
pub enum TlogError {
    #[error("tlog I/O error at byte {offset}: {source}")]
    Io { offset: u64, source: std::io::Error },
    #[error("tlog record at byte {offset}: {what}")]
    Damaged { offset: u64, what: String },
}

/// One record: its timestamp, and the frame's header and message when faithd's
/// dialect (common) knows the message; `None` for other dialects' messages.
#[derive(Clone, Debug, PartialEq)]
pub struct TlogRecord {
    pub t_unix_us: u64,
    pub offset: u64,
    pub header: MavHeader,
    pub message: Option<MavMessage>,
}

/// Appends one .tlog record to `out`: the big-endian Unix time in microseconds, then
/// the message as a MAVLink 2 frame. One buffer per record lets a writer put it on
/// disk in one piece, or not at all.
pub fn encode_record(
    out: &mut Vec<u8>,
    t_unix_us: u64,
    header: MavHeader,
    msg: &MavMessage,
) -> std::io::Result<()> {
    out.extend_from_slice(&t_unix_us.to_be_bytes());
    mavlink::write_versioned_msg(out, MavlinkVersion::V2, header, msg)
        .map(|_| ())
        .map_err(|e| std::io::Error::other(e.to_string()))
}

pub struct TlogWriter<W: Write> {
    out: W,
    frame: Vec<u8>,
}

impl<W: Write> TlogWriter<W> {
    pub fn new(out: W) -> Self {
        Self {
            out,
            frame: Vec::with_capacity(300),
        }
    }

    /// Appends one message as a MAVLink 2 frame stamped `t_unix_us`.
    pub fn write(
        &mut self,
        t_unix_us: u64,
        header: MavHeader,
        msg: &MavMessage,
    ) -> std::io::Result<()> {
        self.frame.clear();
        encode_record(&mut self.frame, t_unix_us, header, msg)?;
        self.out.write_all(&self.frame)
    }

    pub fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }

    pub fn into_inner(self) -> W {
        self.out
    }
}

pub struct TlogReader<R: Read> {
    input: R,
    offset: u64,
    frame: [u8; 300],
}

impl<R: Read> TlogReader<R> {
    pub fn new(input: R) -> Self {
        Self {
            input,
            offset: 0,
            frame: [0; 300],
        }
    }

    /// Reads exactly `n` bytes into the frame buffer at `at`; `Ok(false)` on a clean
    /// end of file before the first byte.
    fn fill(&mut self, at: usize, n: usize, record: u64, eof_ok: bool) -> Result<bool, TlogError> {
        let mut got = 0;
        while got < n {
            match self.input.read(&mut self.frame[at + got..at + n]) {
                Ok(0) if got == 0 && eof_ok => return Ok(false),
                Ok(0) => {
                    return Err(TlogError::Damaged {
                        offset: record,
                        what: format!(
                            "truncated: file ends {} bytes into the record",
                            self.offset - record + got as u64
                        ),
                    });
                }
                Ok(k) => got += k,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(source) => {
                    return Err(TlogError::Io {
                        offset: self.offset + got as u64,
                        source,
                    });
                }
            }
        }
        self.offset += n as u64;
        Ok(true)
    }

    /// The next record, `None` at the end of the file.
    pub fn next_record(&mut self) -> Result<Option<TlogRecord>, TlogError> {
        let record = self.offset;
        if !self.fill(0, 8, record, true)? {
            return Ok(None);
        }
        let t_unix_us = u64::from_be_bytes(self.frame[..8].try_into().expect("8 bytes"));
        self.fill(0, 2, record, false)?;
        let (header_len, payload_len) = match self.frame[0] {
            0xFD => (10, usize::from(self.frame[1])),
            0xFE => (6, usize::from(self.frame[1])),
            other => {
                return Err(TlogError::Damaged {
                    offset: record + 8,
                    what: format!(
                        "expected a MAVLink start byte (0xFD or 0xFE), found 0x{other:02X}"
                    ),
                });
            }
        };
        let v2 = self.frame[0] == 0xFD;
        // Header rest, payload, checksum; a signed MAVLink 2 frame adds 13 bytes.
        self.fill(2, header_len - 2, record, false)?;
        let signed = v2 && self.frame[2] & 0x01 != 0;
        let rest = payload_len + 2 + if signed { 13 } else { 0 };
        self.fill(header_len, rest, record, false)?;
        let frame = &self.frame[..header_len + rest];
        let mut reader = mavlink::MavlinkReader::new(frame);
        let (header, message) = match reader.read_any_message::<MavMessage>() {
            Ok((h, m)) => (h, Some(m)),
            Err(_) => {
                // A frame of another dialect (unknown id or CRC extra): kept, undecoded.
                let (sys, comp, seq) = if v2 {
                    (frame[5], frame[6], frame[4])
                } else {
                    (frame[3], frame[4], frame[2])
                };
                (
                    MavHeader {
                        system_id: u32::from(sys),
                        component_id: comp,
                        sequence: seq,
                    },
                    None,
                )
            }
        };
        Ok(Some(TlogRecord {
            t_unix_us,
            offset: record,
            header,
            message,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::common::ATTITUDE_DATA;

    fn attitude(ms: u32) -> MavMessage {
        MavMessage::ATTITUDE(ATTITUDE_DATA {
            time_boot_ms: ms,
            rollspeed: 0.25,
            ..Default::default()
        })
    }

    fn header(seq: u8) -> MavHeader {
        MavHeader {
            system_id: 1,
            component_id: 1,
            sequence: seq,
        }
    }

    #[test]
    fn round_trip() {
        let mut w = TlogWriter::new(Vec::new());
        for k in 0..50u8 {
            w.write(
                1_700_000_000_000_000 + u64::from(k) * 20_000,
                header(k),
                &attitude(u32::from(k) * 20),
            )
            .unwrap();
        }
        let bytes = w.into_inner();
        let mut r = TlogReader::new(&bytes[..]);
        let mut n = 0u8;
        while let Some(rec) = r.next_record().unwrap() {
            assert_eq!(rec.t_unix_us, 1_700_000_000_000_000 + u64::from(n) * 20_000);
            assert_eq!(rec.header, header(n));
            assert_eq!(rec.message, Some(attitude(u32::from(n) * 20)));
            n += 1;
        }
        assert_eq!(n, 50);
    }

    #[test]
    fn damage_is_reported_with_the_byte_offset() {
        let mut w = TlogWriter::new(Vec::new());
        w.write(1, header(0), &attitude(0)).unwrap();
        w.write(2, header(1), &attitude(20)).unwrap();
        let bytes = w.into_inner();
        let first_len = bytes.len() / 2;
        // Truncated second record.
        let mut r = TlogReader::new(&bytes[..bytes.len() - 3]);
        r.next_record().unwrap().unwrap();
        let err = r.next_record().unwrap_err().to_string();
        assert!(
            err.contains(&format!("byte {first_len}")) && err.contains("truncated"),
            "{err}"
        );
        // A bad start byte.
        let mut bad = bytes.clone();
        bad[first_len + 8] = 0x42;
        let mut r = TlogReader::new(&bad[..]);
        r.next_record().unwrap().unwrap();
        let err = r.next_record().unwrap_err().to_string();
        assert!(
            err.contains(&format!("byte {}", first_len + 8)) && err.contains("0x42"),
            "{err}"
        );
    }

    #[test]
    fn hostile_bytes_never_panic() {
        let mut seed = 0x1234_5678_9abc_def0u64;
        for len in 0..2000usize {
            let bytes: Vec<u8> = (0..len % 300)
                .map(|_| {
                    seed ^= seed << 13;
                    seed ^= seed >> 7;
                    seed ^= seed << 17;
                    if seed.is_multiple_of(7) {
                        0xFD
                    } else {
                        seed as u8
                    }
                })
                .collect();
            let mut r = TlogReader::new(&bytes[..]);
            while let Ok(Some(_)) = r.next_record() {}
        }
    }
}
