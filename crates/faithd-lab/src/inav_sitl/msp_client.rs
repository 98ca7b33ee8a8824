//! The harness's own MSP v2 client on SITL's MSP UARTs: the commands it asks, and
//! reads that may run into the socket's timeout (the process, its CLI and the monitor
//! all read so).

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use faithd_daemon::command::msp::{self, Decoder, Frame};

/// MSP commands the harness uses.
pub const MSP_RC: u16 = 105;
pub const MSP2_INAV_STATUS: u16 = 0x2000;
pub const MSP_BOXIDS: u16 = 119;

/// A blocking MSP v2 client for the harness's own ports.
pub struct MspClient {
    stream: TcpStream,
    decoder: Decoder,
    frames: Vec<Frame>,
}

impl MspClient {
    pub fn connect(port: u16) -> std::io::Result<Self> {
        let stream = TcpStream::connect(("127.0.0.1", port))?;
        stream.set_nodelay(true)?;
        stream.set_read_timeout(Some(Duration::from_millis(20)))?;
        Ok(Self {
            stream,
            decoder: Decoder::default(),
            frames: Vec::new(),
        })
    }

    /// Sends `command` and waits up to 500 ms for its reply.
    pub fn request(&mut self, command: u16, payload: &[u8]) -> std::io::Result<Vec<u8>> {
        self.stream
            .write_all(&msp::encode_request(command, payload))?;
        let deadline = Instant::now() + Duration::from_millis(500);
        let mut buf = [0u8; 1024];
        while Instant::now() < deadline {
            if let Some(i) = self.frames.iter().position(|f| f.command == command) {
                let f = self.frames.remove(i);
                self.frames.clear();
                return match f.direction {
                    b'>' => Ok(f.payload),
                    _ => Err(std::io::Error::other(format!("MSP {command} refused"))),
                };
            }
            match self.stream.read(&mut buf) {
                Ok(0) => return Err(std::io::ErrorKind::UnexpectedEof.into()),
                Ok(n) => self.decoder.push(&buf[..n], &mut self.frames),
                Err(e) if read_timed_out(&e) => {}
                Err(e) => return Err(e),
            }
        }
        Err(std::io::ErrorKind::TimedOut.into())
    }
}

/// A read that ran into the socket's read timeout (nothing came): not an error here.
pub fn read_timed_out(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
    )
}
