//! MSP v2 framing as iNav writes and reads it (msp/msp_serial.c, `mspSerialEncode`;
//! CRC-8/DVB-S2 from the flag to the end of the payload): `$X`, a direction (`<` to
//! the flight controller, `>` a reply, `!` an error reply), flag, command (u16 LE),
//! size (u16 LE), payload, CRC.

/// CRC-8, polynomial 0xD5 (DVB-S2), as iNav's common/crc.c computes it.
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

/// One MSP v2 frame in `direction`.
pub fn encode(direction: u8, command: u16, payload: &[u8]) -> Vec<u8> {
    let mut f = vec![b'$', b'X', direction, 0];
    f.extend_from_slice(&command.to_le_bytes());
    f.extend_from_slice(&(payload.len() as u16).to_le_bytes());
    f.extend_from_slice(payload);
    let crc = f[3..].iter().fold(0, |c, &b| crc8_dvb_s2(c, b));
    f.push(crc);
    f
}

/// A request to the flight controller.
pub fn request(command: u16, payload: &[u8]) -> Vec<u8> {
    encode(b'<', command, payload)
}

/// A decoded frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Frame {
    pub direction: u8,
    pub command: u16,
    pub payload: Vec<u8>,
}

/// Whole frames out of a byte stream; anything that is not one is skipped.
#[derive(Debug, Default)]
pub struct Decoder {
    buffer: Vec<u8>,
}

impl Decoder {
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
            let total = 9 + size;
            if size > 4096 || !b"<>!".contains(&self.buffer[2]) {
                self.buffer.drain(..2);
                continue;
            }
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
                self.buffer.drain(..2);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_and_a_round_trip() {
        assert_eq!(b"123456789".iter().fold(0, |c, &b| crc8_dvb_s2(c, b)), 0xBC);
        let mut stream = b"junk$".to_vec();
        stream.extend(request(105, &[]));
        stream.extend(encode(b'>', 200, &[1, 2]));
        let mut frames = Vec::new();
        let mut d = Decoder::default();
        for chunk in stream.chunks(3) {
            d.push(chunk, &mut frames);
        }
        assert_eq!(frames.len(), 2);
        assert_eq!((frames[1].direction, frames[1].command), (b'>', 200));
        assert_eq!(frames[1].payload, vec![1, 2]);
    }
}
