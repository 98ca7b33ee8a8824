//! Where the autopilot is: a serial port on the drone, TCP or UDP on the bench.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::pin::Pin;

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};

/// A byte stream to the autopilot.
pub trait Transport: AsyncRead + AsyncWrite + Send + Unpin {}
impl<T: AsyncRead + AsyncWrite + Send + Unpin> Transport for T {}

pub type BoxedTransport = Pin<Box<dyn Transport>>;

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Endpoint {
    /// A UART (or USB CDC) device, at a baud rate.
    Serial { path: PathBuf, baud: u32 },
    /// Connect to host:port (a simulator or a serial-to-TCP bridge).
    Tcp(String),
    /// Listen on an address; replies go to whoever sent last.
    UdpListen(SocketAddr),
    /// Send to a fixed peer from an ephemeral port.
    UdpOut(SocketAddr),
}

impl Endpoint {
    /// Parses `serial:/dev/ttyAMA0`, `tcp:127.0.0.1:5760`, `udp:0.0.0.0:14550` or
    /// `udpout:192.168.1.10:14550`; a bare path is a serial device.
    pub fn parse(text: &str, baud: u32) -> Result<Self, String> {
        let (scheme, rest) = match text.split_once(':') {
            Some((s, r)) if ["serial", "tcp", "udp", "udpout"].contains(&s) => (s, r),
            _ if text.starts_with('/') => ("serial", text),
            _ => {
                return Err(format!(
                    "`{text}` is not serial:PATH, tcp:HOST:PORT, udp:ADDR:PORT or udpout:ADDR:PORT"
                ));
            }
        };
        let addr = |r: &str| {
            r.parse::<SocketAddr>()
                .map_err(|e| format!("`{r}` is not an IP address and port: {e}"))
        };
        match scheme {
            "serial" if rest.starts_with('/') => Ok(Endpoint::Serial {
                path: PathBuf::from(rest),
                baud,
            }),
            "serial" => Err(format!("serial device `{rest}` must be an absolute path")),
            "tcp"
                if rest
                    .rsplit_once(':')
                    .is_some_and(|(_, p)| p.parse::<u16>().is_ok()) =>
            {
                Ok(Endpoint::Tcp(rest.to_owned()))
            }
            "tcp" => Err(format!("`{rest}` is not HOST:PORT")),
            "udp" => addr(rest).map(Endpoint::UdpListen),
            _ => addr(rest).map(Endpoint::UdpOut),
        }
    }

    pub async fn open(&self) -> std::io::Result<BoxedTransport> {
        match self {
            Endpoint::Serial { path, baud } => {
                let path = path.to_string_lossy();
                let port = tokio_serial::SerialStream::open(&tokio_serial::new(path, *baud))?;
                Ok(Box::pin(port))
            }
            Endpoint::Tcp(addr) => {
                let stream = tokio::net::TcpStream::connect(addr).await?;
                stream.set_nodelay(true)?;
                Ok(Box::pin(stream))
            }
            Endpoint::UdpListen(bind) => udp_stream(*bind, None).await,
            Endpoint::UdpOut(peer) => {
                let any: SocketAddr = if peer.is_ipv4() {
                    "0.0.0.0:0".parse().expect("literal address")
                } else {
                    "[::]:0".parse().expect("literal address")
                };
                udp_stream(any, Some(*peer)).await
            }
        }
    }
}

impl std::fmt::Display for Endpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Endpoint::Serial { path, baud } => {
                write!(f, "serial {} at {baud} baud", path.display())
            }
            Endpoint::Tcp(a) => write!(f, "tcp {a}"),
            Endpoint::UdpListen(a) => write!(f, "udp listening on {a}"),
            Endpoint::UdpOut(a) => write!(f, "udp to {a}"),
        }
    }
}

/// UDP carried as a byte stream: a pump task moves datagrams between the socket
/// and one end of an in-memory pipe, so the MAVLink session code is the same for
/// every transport. The pump ends when the session drops its end.
async fn udp_stream(bind: SocketAddr, peer: Option<SocketAddr>) -> std::io::Result<BoxedTransport> {
    let socket = tokio::net::UdpSocket::bind(bind).await?;
    let (ours, theirs) = tokio::io::duplex(64 * 1024);
    tokio::spawn(async move {
        let (mut from_session, mut to_session) = tokio::io::split(theirs);
        let mut peer = peer;
        let mut datagram = vec![0u8; 65_536];
        let mut outgoing = vec![0u8; 4096];
        loop {
            tokio::select! {
                got = socket.recv_from(&mut datagram) => {
                    let Ok((n, from)) = got else { break };
                    peer = Some(from);
                    if to_session.write_all(&datagram[..n]).await.is_err() {
                        break;
                    }
                }
                got = from_session.read(&mut outgoing) => {
                    let n = match got { Ok(0) | Err(_) => break, Ok(n) => n };
                    if let Some(p) = peer {
                        // A datagram that cannot be sent is lost, as UDP would lose it.
                        let _ = socket.send_to(&outgoing[..n], p).await;
                    }
                }
            }
        }
    });
    Ok(Box::pin(ours))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_form_and_names_the_problem() {
        assert_eq!(
            Endpoint::parse("serial:/dev/ttyAMA0", 115_200).unwrap(),
            Endpoint::Serial {
                path: "/dev/ttyAMA0".into(),
                baud: 115_200
            }
        );
        assert!(matches!(
            Endpoint::parse("/dev/ttyACM0", 57_600).unwrap(),
            Endpoint::Serial { baud: 57_600, .. }
        ));
        assert_eq!(
            Endpoint::parse("tcp:localhost:5760", 0).unwrap(),
            Endpoint::Tcp("localhost:5760".into())
        );
        assert!(matches!(
            Endpoint::parse("udp:0.0.0.0:14550", 0).unwrap(),
            Endpoint::UdpListen(_)
        ));
        assert!(matches!(
            Endpoint::parse("udpout:127.0.0.1:14550", 0).unwrap(),
            Endpoint::UdpOut(_)
        ));
        for bad in ["ttyS0", "serial:ttyS0", "tcp:host", "udp:nowhere", "ftp:x"] {
            let err = Endpoint::parse(bad, 0).unwrap_err();
            assert!(!err.is_empty(), "{bad}");
        }
    }
}
