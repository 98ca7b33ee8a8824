//! MSP v2 framing for iNav's MSP RC override (MSP_SET_RAW_RC).
//!
//! Frame: `$X<`, flag (u8), command (u16 LE), payload size (u16 LE), payload, and
//! a CRC-8/DVB-S2 over everything from the flag to the end of the payload.

/// iNav's MSP_SET_RAW_RC: channel values, u16 LE each, in iNav's channel order.
pub const MSP_SET_RAW_RC: u16 = 200;

/// CRC-8 with polynomial 0xD5 (DVB-S2), as MSP v2 uses.
pub fn crc8_dvb_s2(crc: u8, byte: u8) -> u8 {
    let mut crc = crc ^ byte;
    for _ in 0..8 {
        crc = if crc & 0x80 != 0 {
            (crc << 1) ^ 0xD5
        } else {
            crc << 1
        };
    }
    crc
}

/// One request frame from the companion to the flight controller.
pub fn encode_request(command: u16, payload: &[u8]) -> Vec<u8> {
    let size = u16::try_from(payload.len()).expect("MSP payloads are small");
    let mut frame = Vec::with_capacity(9 + payload.len());
    frame.extend_from_slice(b"$X<");
    frame.push(0);
    frame.extend_from_slice(&command.to_le_bytes());
    frame.extend_from_slice(&size.to_le_bytes());
    frame.extend_from_slice(payload);
    let crc = frame[3..].iter().fold(0, |c, &b| crc8_dvb_s2(c, b));
    frame.push(crc);
    frame
}

/// MSP_SET_RAW_RC carrying `channels_us` (index 0 is channel 1).
pub fn set_raw_rc(channels_us: &[u16]) -> Vec<u8> {
    let payload: Vec<u8> = channels_us.iter().flat_map(|v| v.to_le_bytes()).collect();
    encode_request(MSP_SET_RAW_RC, &payload)
}

/// A decoded MSP v2 frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Frame {
    /// `<` request, `>` reply, `!` error reply.
    pub direction: u8,
    pub command: u16,
    pub payload: Vec<u8>,
}

/// Incremental MSP v2 decoder: feed bytes, get whole frames; garbage and frames
/// with a bad checksum are skipped.
#[derive(Debug, Default)]
pub struct Decoder {
    buffer: Vec<u8>,
    /// Frames dropped for a bad checksum.
    pub bad_crc: u64,
}

impl Decoder {
    /// Largest payload accepted; iNav's own buffers are smaller.
    const MAX_PAYLOAD: usize = 1024;

    pub fn push(&mut self, bytes: &[u8], frames: &mut Vec<Frame>) {
        self.buffer.extend_from_slice(bytes);
        loop {
            let Some(start) = self.buffer.windows(2).position(|w| w == b"$X") else {
                let keep = usize::from(self.buffer.last() == Some(&b'$'));
                self.buffer.drain(..self.buffer.len() - keep);
                return;
            };
            self.buffer.drain(..start);
            if self.buffer.len() < 8 {
                return;
            }
            let size = usize::from(u16::from_le_bytes([self.buffer[6], self.buffer[7]]));
            if size > Self::MAX_PAYLOAD || !b"<>!".contains(&self.buffer[2]) {
                self.buffer.drain(..2);
                continue;
            }
            let total = 8 + size + 1;
            if self.buffer.len() < total {
                return;
            }
            let crc = self.buffer[3..total - 1]
                .iter()
                .fold(0, |c, &b| crc8_dvb_s2(c, b));
            if crc == self.buffer[total - 1] {
                frames.push(Frame {
                    direction: self.buffer[2],
                    command: u16::from_le_bytes([self.buffer[4], self.buffer[5]]),
                    payload: self.buffer[8..8 + size].to_vec(),
                });
                self.buffer.drain(..total);
            } else {
                self.bad_crc += 1;
                self.buffer.drain(..2);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_matches_the_dvb_s2_check_value() {
        // CRC-8/DVB-S2 of "123456789" is 0xBC.
        let crc = b"123456789".iter().fold(0, |c, &b| crc8_dvb_s2(c, b));
        assert_eq!(crc, 0xBC);
    }

    #[test]
    fn round_trips_through_garbage_and_split_reads() {
        let frame = set_raw_rc(&[1800, 1500, 1000, 1500]);
        assert_eq!(&frame[..3], b"$X<");
        assert_eq!(u16::from_le_bytes([frame[4], frame[5]]), MSP_SET_RAW_RC);
        assert_eq!(u16::from_le_bytes([frame[6], frame[7]]), 8);
        let mut corrupt = frame.clone();
        *corrupt.last_mut().unwrap() ^= 0xFF;
        let mut stream = b"\x00$$X junk".to_vec();
        stream.extend_from_slice(&corrupt);
        stream.extend_from_slice(&frame);
        let mut d = Decoder::default();
        let mut frames = Vec::new();
        for chunk in stream.chunks(3) {
            d.push(chunk, &mut frames);
        }
        assert_eq!(frames.len(), 1);
        assert_eq!(d.bad_crc, 1);
        assert_eq!(
            frames[0].payload,
            [1800u16, 1500, 1000, 1500]
                .iter()
                .flat_map(|v| v.to_le_bytes())
                .collect::<Vec<_>>()
        );
    }
}
