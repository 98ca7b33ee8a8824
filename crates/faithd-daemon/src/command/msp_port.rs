//! Request and reply over iNav's MSP port: the flight-controller check reads its
//! settings this way, and the roll stream reads back MSP_RC (what iNav uses).
//!
//! Every command faithd writes here waits for its slot: one command per
//! [`MSP_SLOT_US`], half of what iNav's 100 Hz serial task serves on a port
//! (fc/fc_tasks.c; msp/msp_serial.c answers one command per run). A sender that
//! outruns the port fills its 256-byte receive ring, and the ring loses bytes
//! (drivers/serial_uart.h); the callers keep one request outstanding at a time.

use std::time::Duration;

use tokio::io::{AsyncReadExt, ReadHalf, WriteHalf};

use super::msp::{self, Decoder, Frame};
use crate::transport::BoxedTransport;

/// iNav's serial task runs at 100 Hz and serves one MSP command per port per run
/// (fc/fc_tasks.c TASK_SERIAL; msp/msp_serial.c "process one command at a time"):
/// faithd sends one command per slot of this length, half of what the port serves.
pub const MSP_SLOT_US: i64 = 20_000;

/// iNav drops the MSP override's signal when no frame came for this long (rx/msp.c,
/// `rxSignalTimeout = DELAY_5_HZ`).
pub const INAV_MSP_SIGNAL_TIMEOUT_US: i64 = 200_000;

/// MSP_FC_VARIANT: four ASCII letters, "INAV" on iNav.
pub const MSP_FC_VARIANT: u16 = 2;
/// MSP_FC_VERSION: major, minor, patch.
pub const MSP_FC_VERSION: u16 = 3;
/// MSP_MODE_RANGES: per mode slot (permanent id, aux channel index, start step, end step).
pub const MSP_MODE_RANGES: u16 = 34;
/// MSP_RX_MAP: which radio channel feeds roll, pitch, yaw and throttle.
pub const MSP_RX_MAP: u16 = 64;
/// MSP_RC: the channel values iNav uses, after its receiver, failsafe and MSP override.
pub const MSP_RC: u16 = 105;
/// MSP_BOXIDS: the permanent ids of the flight modes this build offers, in the order
/// of MSP2_INAV_STATUS's mode bits.
pub const MSP_BOXIDS: u16 = 119;
/// MSP2_COMMON_SETTING: the raw value of a setting, looked up by its CLI name.
pub const MSP2_COMMON_SETTING: u16 = 0x1003;
/// MSP2_INAV_STATUS: arming flags and the flight modes active (fc/fc_msp.c).
pub const MSP2_INAV_STATUS: u16 = 0x2000;

/// Why a request got no usable answer.
#[derive(Debug, thiserror::Error)]
pub enum MspError {
    #[error("MSP port: {0}")]
    Io(#[from] std::io::Error),
    #[error("no reply to MSP command {command} within {timeout_ms} ms")]
    Timeout { command: u16, timeout_ms: u128 },
    #[error("the flight controller refused MSP command {command} (unknown command or setting)")]
    Refused { command: u16 },
    #[error("the MSP port closed")]
    Closed,
}

/// One MSP port, split so that the roll stream can write while it reads replies.
pub struct MspPort {
    rx: ReadHalf<BoxedTransport>,
    tx: WriteHalf<BoxedTransport>,
    decoder: Decoder,
    /// Frames decoded and not yet taken, oldest first.
    frames: std::collections::VecDeque<Frame>,
    /// The earliest time the next command may be written.
    next_slot: tokio::time::Instant,
    /// The command written whose reply has not been read yet.
    pending: Option<u16>,
}

impl MspPort {
    pub fn new(transport: BoxedTransport) -> Self {
        let (rx, tx) = tokio::io::split(transport);
        Self {
            rx,
            tx,
            decoder: Decoder::default(),
            frames: Default::default(),
            next_slot: tokio::time::Instant::now(),
            pending: None,
        }
    }

    /// Frames dropped for a bad checksum so far.
    pub fn bad_crc(&self) -> u64 {
        self.decoder.bad_crc
    }

    /// The earliest time the next command may be written.
    pub fn next_slot(&self) -> tokio::time::Instant {
        self.next_slot
    }

    /// Writes one command in its slot and flushes it: a write that returns has left
    /// faithd. A write stuck for [`crate::transport::WRITE_TIMEOUT`] fails.
    /// Returns the time the slot began.
    pub async fn send(&mut self, frame: &[u8]) -> std::io::Result<tokio::time::Instant> {
        // One request outstanding: a reply not read yet (a stop came while it was
        // awaited) is given one more slot before the next command goes anyway.
        if let Some(command) = self.pending {
            let slot = Duration::from_micros(MSP_SLOT_US as u64);
            let _ = self.reply(command, slot).await;
        }
        tokio::time::sleep_until(self.next_slot).await;
        let at = tokio::time::Instant::now();
        self.next_slot = at + Duration::from_micros(MSP_SLOT_US as u64);
        self.pending = frame_command(frame);
        crate::transport::write_bounded(&mut self.tx, frame).await?;
        Ok(at)
    }

    /// The next frame from the flight controller. Cancel-safe: a frame decoded and
    /// not returned stays for the next call.
    pub async fn next_frame(&mut self) -> Result<Frame, MspError> {
        let mut buf = [0u8; 512];
        loop {
            if let Some(frame) = self.frames.pop_front() {
                return Ok(frame);
            }
            let n = self.rx.read(&mut buf).await?;
            if n == 0 {
                return Err(MspError::Closed);
            }
            let mut decoded = Vec::new();
            self.decoder.push(&buf[..n], &mut decoded);
            self.frames.extend(decoded);
        }
    }

    /// Waits for the reply to `command`, skipping replies to other commands (a late
    /// reply to an earlier request). Replies iNav refused (`!`) are an error.
    pub async fn reply(&mut self, command: u16, timeout: Duration) -> Result<Vec<u8>, MspError> {
        let got = self.wait_for_reply(command, timeout).await;
        // Answered, refused or given up on: the next command does not wait for it
        // again. (A wait cancelled half-way leaves it pending.)
        self.pending = None;
        got
    }

    async fn wait_for_reply(
        &mut self,
        command: u16,
        timeout: Duration,
    ) -> Result<Vec<u8>, MspError> {
        let deadline = tokio::time::Instant::now() + timeout;
        loop {
            let frame = tokio::time::timeout_at(deadline, self.next_frame())
                .await
                .map_err(|_| MspError::Timeout {
                    command,
                    timeout_ms: timeout.as_millis(),
                })??;
            if frame.command != command || frame.direction == b'<' {
                continue;
            }
            return match frame.direction {
                b'!' => Err(MspError::Refused { command }),
                _ => Ok(frame.payload),
            };
        }
    }

    /// Sends `command` in its slot and waits for its reply: one request outstanding.
    pub async fn request(
        &mut self,
        command: u16,
        payload: &[u8],
        timeout: Duration,
    ) -> Result<Vec<u8>, MspError> {
        self.send(&msp::encode_request(command, payload)).await?;
        self.reply(command, timeout).await
    }

    /// Writes raw bytes (iNav's CLI is not MSP) in a slot of their own.
    pub async fn send_text(&mut self, text: &[u8]) -> std::io::Result<()> {
        self.send(text).await.map(|_| ())
    }

    /// Reads raw bytes until `until` says the text is complete, or `timeout` passes.
    pub async fn read_text(
        &mut self,
        timeout: Duration,
        until: impl Fn(&str) -> bool,
    ) -> Result<String, MspError> {
        let deadline = tokio::time::Instant::now() + timeout;
        let mut text = Vec::new();
        let mut buf = [0u8; 512];
        while !until(&String::from_utf8_lossy(&text)) {
            match tokio::time::timeout_at(deadline, self.rx.read(&mut buf)).await {
                Err(_) => break,
                Ok(Ok(0)) => break,
                Ok(Ok(n)) => text.extend_from_slice(&buf[..n]),
                Ok(Err(e)) => return Err(e.into()),
            }
        }
        Ok(String::from_utf8_lossy(&text).into_owned())
    }

    /// Reads one setting by its iNav CLI name, as an unsigned number (settings are
    /// 1, 2 or 4 bytes, little endian).
    pub async fn setting(&mut self, name: &str, timeout: Duration) -> Result<u32, MspError> {
        let mut payload = name.as_bytes().to_vec();
        payload.push(0);
        let value = self.request(MSP2_COMMON_SETTING, &payload, timeout).await?;
        Ok(le_unsigned(&value))
    }
}

/// The command of an MSP v2 request frame (`None` for raw text: iNav's CLI).
fn frame_command(frame: &[u8]) -> Option<u16> {
    (frame.len() >= 9 && frame.starts_with(b"$X<"))
        .then(|| u16::from_le_bytes([frame[4], frame[5]]))
}

/// Little-endian unsigned value of up to four bytes.
pub fn le_unsigned(bytes: &[u8]) -> u32 {
    bytes
        .iter()
        .take(4)
        .enumerate()
        .fold(0, |v, (i, b)| v | u32::from(*b) << (8 * i))
}

/// The u16 channel values of an MSP_RC reply (index 0 is iNav's roll).
pub fn rc_values(payload: &[u8]) -> impl Iterator<Item = u16> + '_ {
    payload
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn little_endian_values() {
        assert_eq!(le_unsigned(&[1]), 1);
        assert_eq!(le_unsigned(&[0x34, 0x12]), 0x1234);
        assert_eq!(le_unsigned(&[1, 0, 0, 0x80]), 0x8000_0001);
        assert_eq!(le_unsigned(&[]), 0);
        let rc: Vec<u16> = rc_values(&[0xDC, 0x05, 0x08, 0x07, 9]).collect();
        assert_eq!(rc, vec![1500, 1800]);
    }
}
