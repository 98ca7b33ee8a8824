//! A RealFlight server for iNav SITL (`--sim=rf`): the quad-X of
//! `faithd_sim::world::quad_x` flown by iNav's own motor outputs, in real time.
//!
//! iNav's SOAP thread calls ExchangeData back to back, and its main loop takes a new
//! gyro, accelerometer and attitude sample once per completed exchange
//! (src/main/fc/fc_core.c:951-961, realFlight.c:459-462): the server's pace is iNav's
//! sensor rate. This one steps the physics 1 ms per exchange and holds each answer
//! until the wall clock has caught up with the physics, so iNav sees a 1 kHz sensor
//! loop in real time; when iNav is late the physics catches up in 1 ms steps (at most
//! [`MAX_CATCH_UP_STEPS`] at once; beyond, the exchange is late: counted in
//! `Counters::late_exchanges`, its stall kept in `World::stalls`, and the physics clock
//! jumps to the wall clock, the vehicle standing still for the time skipped).
//!
//! SITL always calls port 18083 (realFlight.c:60, 473) on the address `--simip`
//! names, so two flights at once take two loopback addresses (127.0.0.2, 127.0.0.3...).

use std::io::{BufReader, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use faithd_sim::world::quad_x::QuadX;

use super::wire::{self, Call, Extras};

/// RealFlight's port, fixed in iNav SITL.
pub const REALFLIGHT_PORT: u16 = 18083;
/// Physics step per exchange.
pub const STEP: Duration = Duration::from_millis(1);
/// When iNav falls further behind than this many steps, the rest is skipped.
pub const MAX_CATCH_UP_STEPS: u32 = 20;

/// Which of iNav's output channels drive motors 1..4 (0-based): `--chanmap
/// M01-01,M02-02,M03-03,M04-04` puts motor n on channel n.
pub const MOTOR_CHANNELS: [usize; 4] = [0, 1, 2, 3];

/// An exchange iNav came to late: its loop had been away for `stalled_ms` of wall
/// time (the physics that far behind), more than the [`MAX_CATCH_UP_STEPS`] caught up.
#[derive(Clone, Copy, Debug)]
pub struct Stall {
    pub at: Instant,
    pub stalled_ms: f64,
}

#[derive(Debug, Default)]
pub struct Counters {
    pub exchanges: AtomicU64,
    /// Exchanges after which the physics was more than [`MAX_CATCH_UP_STEPS`] behind.
    pub late_exchanges: AtomicU64,
    /// Requests that could not be read (each answered with a SOAP fault).
    pub bad_requests: AtomicU64,
}

/// What the server and its readers (the camera, the pilot, the experiment) share.
pub struct World {
    pub quad: Mutex<QuadX>,
    /// iNav's last motor commands, 0..1.
    pub motors: Mutex<[f64; 4]>,
    pub extras: Mutex<Extras>,
    pub counters: Counters,
    /// iNav's roll at its mixer, every exchange: when it came, and the left motors'
    /// command minus the right ones' (positive rolls right). What iNav did with a
    /// roll stick shows here first, a millisecond after its PID loop ran.
    pub roll_mix: Mutex<Vec<(Instant, f64)>>,
    /// Every late exchange, in order.
    pub stalls: Mutex<Vec<Stall>>,
    /// The wall-clock instant of the physics' time zero.
    pub origin: Instant,
}

impl World {
    pub fn new(quad: QuadX) -> Arc<Self> {
        Arc::new(Self {
            quad: Mutex::new(quad),
            motors: Mutex::new([0.0; 4]),
            extras: Mutex::new(Extras::default()),
            counters: Counters::default(),
            roll_mix: Mutex::new(Vec::new()),
            stalls: Mutex::new(Vec::new()),
            origin: Instant::now(),
        })
    }

    /// The vehicle now (a copy).
    pub fn quad(&self) -> QuadX {
        self.quad.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }
}

pub struct Server {
    pub addr: SocketAddr,
    pub world: Arc<World>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Server {
    /// Listens on `ip`:18083 and serves iNav until dropped.
    pub fn start(ip: std::net::IpAddr, world: Arc<World>) -> std::io::Result<Self> {
        let listener = TcpListener::bind((ip, REALFLIGHT_PORT))?;
        let addr = listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (world, stop) = (world.clone(), stop.clone());
            std::thread::Builder::new()
                .name("realflight".into())
                .spawn(move || serve(listener, &world, &stop))?
        };
        Ok(Self {
            addr,
            world,
            stop,
            thread: Some(thread),
        })
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        // Wake the accept.
        let _ = TcpStream::connect_timeout(&self.addr, Duration::from_millis(100));
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn serve(listener: TcpListener, world: &World, stop: &AtomicBool) {
    for stream in listener.incoming() {
        if stop.load(Ordering::Relaxed) {
            return;
        }
        let Ok(stream) = stream else { continue };
        if let Err(e) = answer(stream, world) {
            tracing::debug!("realflight: a connection ended early: {e}");
        }
    }
}

/// One call on one connection, then the connection is closed: iNav reads the answer
/// until then (soap_client.c:162-204).
fn answer(stream: TcpStream, world: &World) -> std::io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_secs(1)))?;
    stream.set_nodelay(true)?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let reply = match wire::read_call(&mut reader) {
        Ok(Call::ExchangeData { channels }) => {
            let motors = MOTOR_CHANNELS.map(|c| channels[c]);
            let quad = exchange(world, motors);
            let extras = *world.extras.lock().unwrap_or_else(|e| e.into_inner());
            wire::exchange_reply(&quad, &extras)
        }
        Ok(call) => {
            tracing::debug!(?call, "realflight: call");
            wire::ack_reply(&call)
        }
        Err(wire::WireError::Truncated(0)) => {
            // Connected and gone without a byte: a SITL killed between flights.
            tracing::debug!("realflight: a connection closed before its request");
            return Ok(());
        }
        Err(e) => {
            world.counters.bad_requests.fetch_add(1, Ordering::Relaxed);
            tracing::warn!("realflight: a request could not be read: {e}");
            wire::fault_reply(&e)
        }
    };
    let mut stream = stream;
    stream.write_all(&reply)?;
    stream.shutdown(Shutdown::Both)
}

/// Applies iNav's motors, steps the physics and waits for the wall clock to reach it.
fn exchange(world: &World, motors: [f64; 4]) -> QuadX {
    *world.motors.lock().unwrap_or_else(|e| e.into_inner()) = motors;
    // iNav's Quad X: motors 3 and 4 on the left, 1 and 2 on the right.
    let left_minus_right = motors[2] + motors[3] - motors[0] - motors[1];
    world
        .roll_mix
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push((Instant::now(), left_minus_right));
    let elapsed = world.origin.elapsed();
    let mut quad = world.quad.lock().unwrap_or_else(|e| e.into_inner());
    let behind_s = elapsed.as_secs_f64() - quad.t_s;
    let steps = (behind_s / STEP.as_secs_f64()).floor().max(1.0);
    if steps > f64::from(MAX_CATCH_UP_STEPS) {
        world
            .counters
            .late_exchanges
            .fetch_add(1, Ordering::Relaxed);
        world
            .stalls
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(Stall {
                at: Instant::now(),
                stalled_ms: behind_s * 1e3,
            });
    }
    let steps = steps.min(f64::from(MAX_CATCH_UP_STEPS)) as u32;
    for _ in 0..steps {
        quad.step(motors, STEP.as_secs_f64());
    }
    if behind_s > f64::from(MAX_CATCH_UP_STEPS) * STEP.as_secs_f64() {
        // Skipped time: the physics clock jumps to the wall clock.
        quad.t_s = elapsed.as_secs_f64();
    }
    let answer = quad.clone();
    let due = world.origin + Duration::from_secs_f64(quad.t_s);
    drop(quad);
    world.counters.exchanges.fetch_add(1, Ordering::Relaxed);
    if let Some(wait) = due.checked_duration_since(Instant::now()) {
        std::thread::sleep(wait);
    }
    answer
}

#[cfg(test)]
mod tests {
    use super::*;
    use faithd_sim::world::quad_x::QuadXConfig;
    use nalgebra::Vector3;
    use std::io::Read;

    /// One call as iNav makes it: a fresh connection, the request, the answer read
    /// until the server closes the connection (soap_client.c:162-204).
    fn call(addr: SocketAddr, action: &str, body: &str) -> String {
        let envelope = format!(
            "<?xml version=\"1.0\" encoding=\"utf-8\"?><soap:Envelope xmlns:soap=\"http://schemas.xmlsoap.org/soap/envelope/\"><soap:Body>{body}</soap:Body></soap:Envelope>"
        );
        let mut stream = TcpStream::connect(addr).unwrap();
        stream
            .set_read_timeout(Some(Duration::from_secs(1)))
            .unwrap();
        write!(
            stream,
            "POST / HTTP/1.1\r\nHost: {addr}\r\nContent-Type: text/xml; charset=utf-8\r\nSOAPAction: \"{action}\"\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{envelope}",
            envelope.len()
        )
        .unwrap();
        let mut answer = String::new();
        // Fails (times out) unless the server closes the connection.
        stream.read_to_string(&mut answer).unwrap();
        answer
    }

    fn exchange(addr: SocketAddr, motor: f64) -> String {
        let mut items = String::new();
        for i in 0..wire::CHANNELS {
            let v = if i < 4 { motor } else { 0.0 };
            items += &format!("<item>{v:.4}</item>");
        }
        call(
            addr,
            "ExchangeData",
            &format!(
                "<ExchangeData><pControlInputs><m-selectedChannels>4095</m-selectedChannels><m-channelValues-0to1>{items}</m-channelValues-0to1></pControlInputs></ExchangeData>"
            ),
        )
    }

    /// The quad-X on the ground, served on `ip` (a loopback address per test).
    fn grounded_quad_served_on(ip: &str) -> (Server, Arc<World>) {
        let world = World::new(QuadX::on_ground(
            QuadXConfig::default(),
            Vector3::zeros(),
            0.0,
        ));
        let server = Server::start(ip.parse().unwrap(), world.clone()).unwrap();
        (server, world)
    }

    #[test]
    fn inavs_motors_fly_the_quad_and_the_answers_keep_to_the_wall_clock() {
        let (server, world) = grounded_quad_served_on("127.0.0.3");
        let restore = call(
            server.addr,
            "RestoreOriginalControllerDevice",
            "<RestoreOriginalControllerDevice><a>1</a><b>2</b></RestoreOriginalControllerDevice>",
        );
        assert!(restore.starts_with("HTTP/1.1 200"), "{restore}");
        assert!(restore.contains("<soap:Body>"), "{restore}");

        let idle = exchange(server.addr, 0.08);
        assert!(
            idle.contains("<m-accelerationBodyAZ-MPS2>-9.80665"),
            "{idle}"
        );
        for _ in 0..300 {
            exchange(server.addr, 0.6);
            // An answer never runs ahead of the wall clock.
            assert!(world.quad().t_s <= world.origin.elapsed().as_secs_f64() + 1e-9);
        }
        let quad = world.quad();
        assert!(!quad.on_ground && quad.position_m.z < -0.05, "{quad:?}");
        assert_eq!(*world.motors.lock().unwrap(), [0.6; 4]);
        assert_eq!(world.counters.exchanges.load(Ordering::Relaxed), 301);

        let broken = call(server.addr, "ExchangeData", "<ExchangeData/>");
        assert!(broken.starts_with("HTTP/1.1 500"), "{broken}");
        assert!(broken.contains("m-channelValues-0to1"), "{broken}");
        assert_eq!(world.counters.bad_requests.load(Ordering::Relaxed), 1);
    }

    /// iNav away for 80 ms: the exchange after it is late, its stall is kept with how
    /// long iNav was away, and the vehicle stood still for what the catch-up skipped.
    #[test]
    fn an_exchange_after_a_stall_is_late_and_the_stall_is_kept() {
        let (server, world) = grounded_quad_served_on("127.0.0.4");
        for _ in 0..50 {
            exchange(server.addr, 0.6);
        }
        let before = world.quad().t_s;
        std::thread::sleep(Duration::from_millis(80));
        let away = Instant::now();
        exchange(server.addr, 0.6);
        let stalls = world.stalls.lock().unwrap().clone();
        assert!(!stalls.is_empty(), "no stall kept");
        let last = stalls.last().unwrap();
        assert!(last.at >= away, "{last:?}");
        assert!(last.stalled_ms >= 80.0, "{last:?}");
        assert_eq!(
            world.counters.late_exchanges.load(Ordering::Relaxed),
            stalls.len() as u64
        );
        // The physics clock is at the wall clock again, not 20 steps on.
        assert!(
            world.quad().t_s - before >= 0.080,
            "{}",
            world.quad().t_s - before
        );
    }
}
