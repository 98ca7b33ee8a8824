//! Request and reply over iNav's MSP port: the flight-controller check reads its
//! settings this way, and the roll stream reads back MSP_RC (what iNav uses).

use std::time::Duration;

use tokio::io::{AsyncReadExt, ReadHalf, WriteHalf};

use super::msp::{self, Decoder, Frame};
use crate::link::endpoint::BoxedTransport;

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
    pub rx: ReadHalf<BoxedTransport>,
    pub tx: WriteHalf<BoxedTransport>,
    pub decoder: Decoder,
    frames: Vec<Frame>,
}

impl MspPort {
    pub fn new(transport: BoxedTransport) -> Self {
        let (rx, tx) = tokio::io::split(transport);
        Self {
            rx,
            tx,
            decoder: Decoder::default(),
            frames: Vec::new(),
        }
    }

    /// Writes one frame and flushes it: a write that returns has left faithd. A
    /// write stuck for [`crate::link::endpoint::WRITE_TIMEOUT`] fails.
    pub async fn write(&mut self, frame: &[u8]) -> std::io::Result<()> {
        crate::link::endpoint::write_bounded(&mut self.tx, frame).await
    }

    /// Sends `command` and waits for its reply, skipping replies to other commands
    /// (acknowledgements of MSP_SET_RAW_RC, a late reply to an earlier request).
    pub async fn request(
        &mut self,
        command: u16,
        payload: &[u8],
        timeout: Duration,
    ) -> Result<Vec<u8>, MspError> {
        self.write(&msp::encode_request(command, payload)).await?;
        let deadline = tokio::time::Instant::now() + timeout;
        let mut buf = [0u8; 512];
        loop {
            if let Some(i) = self.frames.iter().position(|f| f.command == command) {
                let frame = self.frames.remove(i);
                self.frames.clear();
                return match frame.direction {
                    b'!' => Err(MspError::Refused { command }),
                    _ => Ok(frame.payload),
                };
            }
            self.frames.clear();
            let read = tokio::time::timeout_at(deadline, self.rx.read(&mut buf)).await;
            match read {
                Err(_) => {
                    return Err(MspError::Timeout {
                        command,
                        timeout_ms: timeout.as_millis(),
                    });
                }
                Ok(Ok(0)) => return Err(MspError::Closed),
                Ok(Ok(n)) => self.decoder.push(&buf[..n], &mut self.frames),
                Ok(Err(e)) => return Err(e.into()),
            }
        }
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
