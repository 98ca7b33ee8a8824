//! A tap on the wire between faithd and one of SITL's MSP UARTs: a TCP relay that
//! hands every byte on as it comes and notes each MSP frame that crossed, with its
//! time and direction. What a port carried is then read off the wire, not taken from
//! faithd's own account.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use faithd_inav::frame::Decoder;

use super::sitl::unix_us;

/// One MSP frame on the wire: when it was complete (Unix us), whether faithd sent it
/// (a request) or iNav did (a reply), and its command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crossed {
    pub t_us: i64,
    pub to_inav: bool,
    pub command: u16,
}

pub struct Wiretap {
    /// Where faithd connects instead of SITL's port.
    pub endpoint: String,
    pub crossed: Arc<Mutex<Vec<Crossed>>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Wiretap {
    /// A relay to `127.0.0.1:port`; each connection faithd opens gets one to SITL.
    pub fn to(port: u16) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        listener.set_nonblocking(true).unwrap();
        let endpoint = format!("tcp:{}", listener.local_addr().unwrap());
        let crossed = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (crossed, stop) = (crossed.clone(), stop.clone());
            std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    match listener.accept() {
                        Ok((faithd, _)) => relay(faithd, port, &crossed, &stop),
                        Err(_) => std::thread::sleep(Duration::from_millis(5)),
                    }
                }
            })
        };
        Wiretap {
            endpoint,
            crossed,
            stop,
            thread: Some(thread),
        }
    }

    /// faithd's requests, by time.
    pub fn requests(&self) -> Vec<Crossed> {
        let crossed = self.crossed.lock().unwrap();
        crossed.iter().filter(|c| c.to_inav).copied().collect()
    }

    /// The most requests in any one second, and the most requests waiting for their
    /// reply at once.
    pub fn busiest(&self) -> (usize, usize) {
        let crossed = self.crossed.lock().unwrap().clone();
        let requests: Vec<i64> = crossed
            .iter()
            .filter(|c| c.to_inav)
            .map(|c| c.t_us)
            .collect();
        let per_second = (0..requests.len())
            .map(|i| {
                requests[i..]
                    .iter()
                    .take_while(|t| **t < requests[i] + 1_000_000)
                    .count()
            })
            .max()
            .unwrap_or(0);
        let mut waiting = 0usize;
        let mut most_waiting = 0;
        for c in &crossed {
            if c.to_inav {
                waiting += 1;
            } else {
                waiting = waiting.saturating_sub(1);
            }
            most_waiting = most_waiting.max(waiting);
        }
        (per_second, most_waiting)
    }
}

impl Drop for Wiretap {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Relays one connection both ways until either side closes.
fn relay(faithd: TcpStream, port: u16, crossed: &Arc<Mutex<Vec<Crossed>>>, stop: &Arc<AtomicBool>) {
    let Ok(inav) = TcpStream::connect(("127.0.0.1", port)) else {
        return;
    };
    for s in [&faithd, &inav] {
        s.set_nodelay(true).unwrap();
        s.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
    }
    let (f2, i2) = (faithd.try_clone().unwrap(), inav.try_clone().unwrap());
    let (c2, s2) = (crossed.clone(), stop.clone());
    let back = std::thread::spawn(move || pump(i2, f2, false, &c2, &s2));
    pump(faithd, inav, true, crossed, stop);
    let _ = back.join();
}

/// Copies `from` to `to`, noting each complete MSP frame before it is handed on: a
/// frame noted after the write can be noted after the answer it caused (a reply
/// handed to faithd, the pump descheduled, faithd's next request noted first), and
/// the wire would seem to hold two requests at once. Noted first, the record keeps
/// the order in which the frames crossed.
fn pump(
    mut from: TcpStream,
    mut to: TcpStream,
    to_inav: bool,
    crossed: &Arc<Mutex<Vec<Crossed>>>,
    stop: &Arc<AtomicBool>,
) {
    let mut decoder = Decoder::default();
    let mut buf = [0u8; 1024];
    while !stop.load(Ordering::Relaxed) {
        match from.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => {
                let mut frames = Vec::new();
                decoder.push(&buf[..n], &mut frames);
                let t_us = unix_us();
                crossed
                    .lock()
                    .unwrap()
                    .extend(frames.iter().map(|f| Crossed {
                        t_us,
                        to_inav,
                        command: f.command,
                    }));
                if to.write_all(&buf[..n]).is_err() {
                    break;
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(_) => break,
        }
    }
    let _ = to.shutdown(std::net::Shutdown::Both);
}
