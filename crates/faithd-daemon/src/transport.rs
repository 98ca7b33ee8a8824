//! The ports faithd opens to reach the autopilot and the ground: a serial port on the
//! drone, TCP or UDP on the bench, an in-process port in the lab. Both MAVLink links
//! and the MSP stream open them, so they are a module of their own.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::pin::Pin;

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};

/// A byte stream to the autopilot.
pub trait Transport: AsyncRead + AsyncWrite + Send + Unpin {}
impl<T: AsyncRead + AsyncWrite + Send + Unpin> Transport for T {}

pub type BoxedTransport = Pin<Box<dyn Transport>>;

/// A write to a port that has not completed in this time is stuck (a UART with flow
/// control held off, a USB adapter wedged): at 115200 baud a 300-byte frame takes
/// 26 ms. The session ends and the port is reopened, instead of a task hanging with
/// the roll it holds.
pub const WRITE_TIMEOUT: std::time::Duration = std::time::Duration::from_millis(250);

/// Opening (or connecting) takes at most this; then it is tried again later.
pub const OPEN_TIMEOUT: std::time::Duration = std::time::Duration::from_millis(500);

/// Writes all of `bytes` and flushes, within [`WRITE_TIMEOUT`].
pub async fn write_bounded(
    writer: &mut (impl AsyncWrite + Unpin),
    bytes: &[u8],
) -> std::io::Result<()> {
    let write = async {
        writer.write_all(bytes).await?;
        writer.flush().await
    };
    tokio::time::timeout(WRITE_TIMEOUT, write)
        .await
        .unwrap_or_else(|_| {
            Err(std::io::Error::new(
                std::io::ErrorKind::TimedOut,
                format!(
                    "write not completed within {} ms",
                    WRITE_TIMEOUT.as_millis()
                ),
            ))
        })
}

/// Where a port is, as faithd.toml writes it: `serial:/dev/ttyAMA0`,
/// `tcp:127.0.0.1:5760`, `udp:0.0.0.0:14550`, `udp:0.0.0.0:14550@192.168.1.10:14550`
/// or `udpout:192.168.1.10:14550`; a bare absolute path is a serial device. Parsed
/// once, when the file is read: a config holds an address that can be opened.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum Address {
    /// A UART (or USB CDC) device.
    Serial(PathBuf),
    /// Connect to host:port (a simulator or a serial-to-TCP bridge).
    Tcp(String),
    /// Listen on an address. The peer is the configured one (`udp:BIND:PORT@PEER:PORT`),
    /// or the first sender; datagrams from anyone else are dropped, so one packet from
    /// another host cannot redirect faithd's traffic.
    UdpListen {
        bind: SocketAddr,
        peer: Option<SocketAddr>,
    },
    /// Send to a fixed peer from an ephemeral port; only that peer is heard.
    UdpOut(SocketAddr),
    /// A port inside this process: a simulated flight controller's UART. Never read
    /// from a file ([`Address::parse`] does not make one); a simulation builds it.
    InProcess(InProcessPort),
}

/// A simulated device's port: each open asks the simulation for a fresh byte
/// stream (as reopening a UART gives a fresh session), which is what lets the
/// daemon's own link and MSP stream run unchanged against a simulated iNav.
#[derive(Clone)]
pub struct InProcessPort {
    pub name: &'static str,
    connect: std::sync::Arc<dyn Fn() -> std::io::Result<BoxedTransport> + Send + Sync>,
}

impl InProcessPort {
    pub fn new(
        name: &'static str,
        connect: impl Fn() -> std::io::Result<BoxedTransport> + Send + Sync + 'static,
    ) -> Self {
        Self {
            name,
            connect: std::sync::Arc::new(connect),
        }
    }
}

impl std::fmt::Debug for InProcessPort {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "InProcessPort({})", self.name)
    }
}

/// The same port: the same simulation's connector.
impl PartialEq for InProcessPort {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.connect, &other.connect)
    }
}

impl Eq for InProcessPort {}

impl Address {
    pub fn parse(text: &str) -> Result<Self, String> {
        let (scheme, rest) = match text.split_once(':') {
            Some((s, r)) if ["serial", "tcp", "udp", "udpout"].contains(&s) => (s, r),
            _ if text.starts_with('/') => ("serial", text),
            _ => {
                return Err(format!(
                    "`{text}` is not serial:PATH, tcp:HOST:PORT, udp:ADDR:PORT[@PEER:PORT] or udpout:ADDR:PORT"
                ));
            }
        };
        let addr = |r: &str| {
            r.parse::<SocketAddr>()
                .map_err(|e| format!("`{r}` is not an IP address and port: {e}"))
        };
        match scheme {
            "serial" if rest.starts_with('/') => Ok(Address::Serial(PathBuf::from(rest))),
            "serial" => Err(format!("serial device `{rest}` must be an absolute path")),
            "tcp"
                if rest
                    .rsplit_once(':')
                    .is_some_and(|(_, p)| p.parse::<u16>().is_ok()) =>
            {
                Ok(Address::Tcp(rest.to_owned()))
            }
            "tcp" => Err(format!("`{rest}` is not HOST:PORT")),
            "udp" => match rest.split_once('@') {
                Some((bind, peer)) => Ok(Address::UdpListen {
                    bind: addr(bind)?,
                    peer: Some(addr(peer)?),
                }),
                None => Ok(Address::UdpListen {
                    bind: addr(rest)?,
                    peer: None,
                }),
            },
            _ => addr(rest).map(Address::UdpOut),
        }
    }
}

impl TryFrom<String> for Address {
    type Error = String;

    fn try_from(text: String) -> Result<Self, String> {
        Address::parse(&text)
    }
}

impl From<Address> for String {
    fn from(address: Address) -> String {
        address.to_string()
    }
}

/// The form faithd.toml writes, which [`Address::parse`] reads back.
impl std::fmt::Display for Address {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Address::Serial(path) => write!(f, "serial:{}", path.display()),
            Address::Tcp(a) => write!(f, "tcp:{a}"),
            Address::UdpListen { bind, peer: None } => write!(f, "udp:{bind}"),
            Address::UdpListen {
                bind,
                peer: Some(p),
            } => write!(f, "udp:{bind}@{p}"),
            Address::UdpOut(a) => write!(f, "udpout:{a}"),
            Address::InProcess(p) => write!(f, "inprocess:{}", p.name),
        }
    }
}

/// A port to open: its address and, for a serial device, the baud rate.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Endpoint {
    pub address: Address,
    pub baud: u32,
}

impl Endpoint {
    pub fn new(address: Address, baud: u32) -> Self {
        Self { address, baud }
    }

    /// Opens the endpoint within [`OPEN_TIMEOUT`].
    ///
    /// A serial port starts empty: what the kernel queued before faithd opened it
    /// (telemetry from before a reconnect) is discarded, since arriving now it would
    /// pass for fresh and could open the safety gate on a vehicle state that is gone.
    pub async fn open(&self) -> std::io::Result<BoxedTransport> {
        tokio::time::timeout(OPEN_TIMEOUT, self.open_unbounded())
            .await
            .unwrap_or_else(|_| {
                Err(std::io::Error::new(
                    std::io::ErrorKind::TimedOut,
                    format!("not open within {} ms", OPEN_TIMEOUT.as_millis()),
                ))
            })
    }

    async fn open_unbounded(&self) -> std::io::Result<BoxedTransport> {
        match &self.address {
            Address::Serial(path) => {
                use tokio_serial::SerialPort;
                let path = path.to_string_lossy();
                let port = tokio_serial::SerialStream::open(&tokio_serial::new(path, self.baud))?;
                port.clear(tokio_serial::ClearBuffer::Input)?;
                Ok(Box::pin(port))
            }
            Address::Tcp(addr) => {
                let stream = tokio::net::TcpStream::connect(addr).await?;
                stream.set_nodelay(true)?;
                Ok(Box::pin(stream))
            }
            Address::UdpListen { bind, peer } => udp_stream(*bind, *peer).await,
            Address::UdpOut(peer) => {
                let any: SocketAddr = if peer.is_ipv4() {
                    "0.0.0.0:0".parse().expect("literal address")
                } else {
                    "[::]:0".parse().expect("literal address")
                };
                udp_stream(any, Some(*peer)).await
            }
            Address::InProcess(port) => (port.connect)(),
        }
    }
}

impl std::fmt::Display for Endpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.address {
            Address::Serial(path) => {
                write!(f, "serial {} at {} baud", path.display(), self.baud)
            }
            Address::Tcp(a) => write!(f, "tcp {a}"),
            Address::UdpListen { bind, peer: None } => {
                write!(f, "udp listening on {bind}, locked to the first peer")
            }
            Address::UdpListen {
                bind,
                peer: Some(p),
            } => write!(f, "udp listening on {bind}, peer {p}"),
            Address::UdpOut(a) => write!(f, "udp to {a}"),
            Address::InProcess(p) => write!(f, "in-process port {} (simulated)", p.name),
        }
    }
}

/// UDP carried as a byte stream: a pump task moves datagrams between the socket
/// and one end of an in-memory pipe, so the MAVLink session code is the same for
/// every transport. The socket is connected to its one peer (the configured one, or
/// the first sender), so the kernel drops datagrams from anybody else. The pump ends
/// when the session drops its end.
async fn udp_stream(bind: SocketAddr, peer: Option<SocketAddr>) -> std::io::Result<BoxedTransport> {
    let socket = tokio::net::UdpSocket::bind(bind).await?;
    if let Some(p) = peer {
        socket.connect(p).await?;
    }
    let (ours, theirs) = tokio::io::duplex(64 * 1024);
    tokio::spawn(async move {
        let (mut from_session, mut to_session) = tokio::io::split(theirs);
        let mut locked = peer.is_some();
        let mut datagram = vec![0u8; 65_536];
        let mut outgoing = vec![0u8; 4096];
        loop {
            tokio::select! {
                got = socket.recv_from(&mut datagram) => {
                    let (n, from) = match got {
                        Ok(got) => got,
                        // The peer's port is closed (ICMP): it may open later.
                        Err(e) if e.kind() == std::io::ErrorKind::ConnectionRefused => continue,
                        Err(_) => break,
                    };
                    if !locked {
                        if socket.connect(from).await.is_err() {
                            break;
                        }
                        tracing::info!(peer = %from, "UDP peer locked to the first sender");
                        locked = true;
                    }
                    if to_session.write_all(&datagram[..n]).await.is_err() {
                        break;
                    }
                }
                got = from_session.read(&mut outgoing) => {
                    let n = match got { Ok(0) | Err(_) => break, Ok(n) => n };
                    if locked {
                        // A datagram that cannot be sent is lost, as UDP would lose it.
                        let _ = socket.send(&outgoing[..n]).await;
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
            Address::parse("serial:/dev/ttyAMA0").unwrap(),
            Address::Serial("/dev/ttyAMA0".into())
        );
        assert_eq!(
            Address::parse("/dev/ttyACM0").unwrap(),
            Address::Serial("/dev/ttyACM0".into())
        );
        assert_eq!(
            Address::parse("tcp:localhost:5760").unwrap(),
            Address::Tcp("localhost:5760".into())
        );
        assert!(matches!(
            Address::parse("udp:0.0.0.0:14550").unwrap(),
            Address::UdpListen { peer: None, .. }
        ));
        assert_eq!(
            Address::parse("udp:127.0.0.1:14550@127.0.0.1:14551").unwrap(),
            Address::UdpListen {
                bind: "127.0.0.1:14550".parse().unwrap(),
                peer: Some("127.0.0.1:14551".parse().unwrap())
            }
        );
        assert!(matches!(
            Address::parse("udpout:127.0.0.1:14550").unwrap(),
            Address::UdpOut(_)
        ));
        for bad in [
            "ttyS0",
            "serial:ttyS0",
            "tcp:host",
            "udp:nowhere",
            "udp:0.0.0.0:1@nowhere",
            "ftp:x",
        ] {
            let err = Address::parse(bad).unwrap_err();
            assert!(!err.is_empty(), "{bad}");
        }
    }

    #[test]
    fn an_address_reads_back_as_written() {
        for text in [
            "serial:/dev/ttyAMA0",
            "tcp:localhost:5760",
            "udp:0.0.0.0:14550",
            "udp:127.0.0.1:14550@127.0.0.1:14551",
            "udpout:[::1]:14550",
        ] {
            let address = Address::parse(text).unwrap();
            assert_eq!(address.to_string(), text);
            assert_eq!(Address::parse(&address.to_string()).unwrap(), address);
        }
    }

    /// Reads what reaches the session within `ms`.
    async fn drain(t: &mut BoxedTransport, ms: u64) -> Vec<u8> {
        let mut got = Vec::new();
        let mut buf = [0u8; 256];
        while let Ok(Ok(n)) =
            tokio::time::timeout(Duration::from_millis(ms), t.read(&mut buf)).await
        {
            if n == 0 {
                break;
            }
            got.extend_from_slice(&buf[..n]);
        }
        got
    }

    use std::time::Duration;

    #[tokio::test]
    async fn udp_locks_to_its_first_peer_and_ignores_strangers() {
        let probe = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
        let bind = probe.local_addr().unwrap();
        drop(probe);
        let mut session = Endpoint::new(Address::UdpListen { bind, peer: None }, 0)
            .open()
            .await
            .unwrap();
        let autopilot = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
        let stranger = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
        autopilot
            .send_to(b"from the autopilot", bind)
            .await
            .unwrap();
        assert_eq!(drain(&mut session, 100).await, b"from the autopilot");
        stranger.send_to(b"redirect me", bind).await.unwrap();
        autopilot.send_to(b"again", bind).await.unwrap();
        assert_eq!(
            drain(&mut session, 100).await,
            b"again",
            "the stranger is not heard"
        );
        session.write_all(b"override").await.unwrap();
        let mut buf = [0u8; 64];
        let (n, _) = tokio::time::timeout(Duration::from_secs(1), autopilot.recv_from(&mut buf))
            .await
            .expect("the locked peer gets faithd's frames")
            .unwrap();
        assert_eq!(&buf[..n], b"override");
        let nothing =
            tokio::time::timeout(Duration::from_millis(100), stranger.recv_from(&mut buf)).await;
        assert!(nothing.is_err(), "nothing goes to the stranger");
    }

    #[tokio::test]
    async fn udpout_hears_only_its_peer() {
        let autopilot = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
        let stranger = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
        let mut session = Endpoint::new(Address::UdpOut(autopilot.local_addr().unwrap()), 0)
            .open()
            .await
            .unwrap();
        session.write_all(b"hello").await.unwrap();
        let mut buf = [0u8; 64];
        let (n, faithd) = autopilot.recv_from(&mut buf).await.unwrap();
        assert_eq!(&buf[..n], b"hello");
        stranger.send_to(b"redirect me", faithd).await.unwrap();
        autopilot.send_to(b"telemetry", faithd).await.unwrap();
        assert_eq!(drain(&mut session, 100).await, b"telemetry");
        session.write_all(b"override").await.unwrap();
        let (n, _) = autopilot.recv_from(&mut buf).await.unwrap();
        assert_eq!(&buf[..n], b"override");
        let nothing =
            tokio::time::timeout(Duration::from_millis(100), stranger.recv_from(&mut buf)).await;
        assert!(nothing.is_err(), "nothing goes to the stranger");
    }
}
