//! A simulated iNav on two UARTs inside the process ([`super::uart`]): MAVLink
//! telemetry (ATTITUDE and RC_CHANNELS every 40 ms, iNav's fastest stream, SYS_STATUS
//! every 120 ms, HEARTBEAT every second, as the committed set-up has iNav send them)
//! and an MSP port that takes faithd's roll stream the way iNav's MSP RC override
//! does ([`faithd_inav::msp`]). Like iNav with a radio receiver, it ignores
//! RC_CHANNELS_OVERRIDE. Every byte goes through faithd's real MAVLink and MSP code,
//! in simulated time.

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use mavlink::dialects::common::*;
use tokio::io::{AsyncReadExt, AsyncWriteExt, DuplexStream, ReadHalf, WriteHalf};
use tokio::sync::mpsc;

use super::physics::Shared;
use super::uart;
use faithd_daemon::clock::DaemonClock;
use faithd_daemon::transport::InProcessPort;
use faithd_inav::mavlink::{self as inav_mavlink, encode};
use faithd_inav::msp::{InavMsp, Pilot, RollTarget, Setup};

/// The autopilot's boot clock runs on its own origin, as a real one does.
const BOOT_OFFSET_MS: i64 = 73_000;

/// Both UARTs run at iNav's default MAVLink and MSP speed.
pub const BAUD: u32 = 115_200;

/// The simulated iNav's two ports, for faithd's config.
pub struct SimulatedInav {
    pub mavlink: InProcessPort,
    pub msp: InProcessPort,
}

/// Starts the simulated iNav on the current (simulated-time) runtime.
pub fn start(shared: Arc<Shared>, clock: DaemonClock) -> SimulatedInav {
    let (mavlink, mavlink_sessions) = port("inav-mavlink");
    let (msp, msp_sessions) = port("inav-msp");
    tokio::spawn(run_mavlink(mavlink_sessions, shared.clone(), clock));
    tokio::spawn(run_msp(msp_sessions, shared, clock));
    SimulatedInav { mavlink, msp }
}

/// A port whose every open is a fresh UART session handed to the device's task.
fn port(name: &'static str) -> (InProcessPort, mpsc::UnboundedReceiver<DuplexStream>) {
    let (tx, rx) = mpsc::unbounded_channel();
    let port = InProcessPort::new(name, move || {
        let (faithd, device) = uart::pair(BAUD);
        tx.send(device).map_err(|_| {
            std::io::Error::new(
                std::io::ErrorKind::NotConnected,
                "the simulated iNav has stopped",
            )
        })?;
        Ok(Box::pin(faithd))
    });
    (port, rx)
}

/// One UART session, split so the device can write while it reads.
struct Session {
    rx: ReadHalf<DuplexStream>,
    tx: WriteHalf<DuplexStream>,
}

impl Session {
    fn new(stream: DuplexStream) -> Self {
        let (rx, tx) = tokio::io::split(stream);
        Self { rx, tx }
    }
}

/// Reads from the session if there is one; never resolves otherwise.
async fn read(session: &mut Option<Session>, buf: &mut [u8]) -> std::io::Result<usize> {
    match session {
        Some(s) => s.rx.read(buf).await,
        None => std::future::pending().await,
    }
}

async fn run_mavlink(
    mut sessions: mpsc::UnboundedReceiver<DuplexStream>,
    shared: Arc<Shared>,
    clock: DaemonClock,
) {
    let mut session: Option<Session> = None;
    let mut tick = tokio::time::interval(Duration::from_millis(40));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut n = 0u64;
    let mut seq = 0u8;
    let mut buf = vec![0u8; 1024];
    loop {
        tokio::select! {
            biased;
            opened = sessions.recv() => match opened {
                // A reopened port replaces the old session, as on a UART.
                Some(stream) => session = Some(Session::new(stream)),
                None => return,
            },
            _ = tick.tick() => {
                let mut out = Vec::new();
                let (attitude, roll_us, switch_us) = telemetry(&shared, &clock);
                for msg in [attitude, rc_channels(&clock, roll_us, switch_us)] {
                    encode(&mut out, &mut seq, &msg);
                }
                if n.is_multiple_of(3) {
                    encode(&mut out, &mut seq, &inav_mavlink::sys_status(true));
                }
                if n.is_multiple_of(25) {
                    encode(&mut out, &mut seq, &inav_mavlink::heartbeat(true, MavState::MAV_STATE_ACTIVE));
                }
                n += 1;
                if let Some(s) = &mut session
                    && s.tx.write_all(&out).await.is_err()
                {
                    session = None;
                }
            }
            // faithd's HEARTBEAT (and anything else it sends) is read and ignored.
            got = read(&mut session, &mut buf) => if matches!(got, Ok(0) | Err(_)) {
                session = None;
            },
        }
    }
}

/// The pilot's roll stick in the simulated flights: centred.
const PILOT_ROLL_US: u16 = 1500;

/// The pilot's receiver sends a frame every 7 ms (IBUS, the receiver of the SITL
/// experiment; rx/ibus.c). iNav recomputes the channels it flies with, the
/// override's among them, when such a frame has come in (rx/rx.c), so a roll waits
/// up to one frame there: on iNav's SITL the roll reached the mixer 8 ms later, on
/// average, than this model had it in use before it waited.
const RX_FRAME_US: i64 = 7_000;

/// iNav's MSP port (one session at a time: faithd reopens after a loss), run as a
/// flight controller runs it ([`faithd_inav::msp`]) every millisecond of simulated
/// time; the roll iNav uses goes to the physics at the pilot's next receiver frame.
async fn run_msp(
    mut sessions: mpsc::UnboundedReceiver<DuplexStream>,
    shared: Arc<Shared>,
    clock: DaemonClock,
) {
    let mut fc = InavMsp::new(Setup::default(), clock.now_us());
    let mut next_rx_frame_us = clock.now_us();
    let mut session: Option<Session> = None;
    let mut tick = tokio::time::interval(Duration::from_millis(1));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut buf = [0u8; 1024];
    loop {
        tokio::select! {
            biased;
            opened = sessions.recv() => match opened {
                Some(stream) => session = Some(Session::new(stream)),
                None => return,
            },
            _ = tick.tick() => {
                let now_us = clock.now_us();
                fc.set_pilot(pilot(&shared));
                fc.advance(now_us);
                let out = fc.take_output();
                if !out.is_empty()
                    && let Some(s) = &mut session
                    && s.tx.write_all(&out).await.is_err()
                {
                    session = None;
                }
                // iNav takes the override's channels when it processes the pilot's
                // next receiver frame (rx/rx.c), not the moment they arrive.
                if now_us >= next_rx_frame_us {
                    publish_roll(&fc, &shared, now_us);
                    next_rx_frame_us += RX_FRAME_US;
                }
            }
            got = read(&mut session, &mut buf) => {
                match got {
                    Ok(0) | Err(_) => session = None,
                    Ok(n) => {
                        fc.set_pilot(pilot(&shared));
                        fc.receive(&buf[..n], clock.now_us());
                    }
                }
            }
        }
    }
}

/// The pilot's side as iNav sees it: armed, in ANGLE, the switch where the flight
/// has it.
fn pilot(shared: &Shared) -> Pilot {
    let switch_us = if shared.switch_auto.load(Ordering::Relaxed) {
        1900
    } else {
        1000
    };
    Pilot::flying(rc_in_use(PILOT_ROLL_US, switch_us))
}

fn publish_roll(fc: &InavMsp, shared: &Shared, now_us: i64) {
    let roll_us = fc.roll_in_use();
    shared.roll_us.store(roll_us, Ordering::Relaxed);
    let target_rad = match fc.roll_target() {
        RollTarget::BankDeg(deg) => deg.to_radians(),
        // Outside ANGLE the stick is a rate: the bank it would reach by the next
        // receiver frame (the simulated pilot always flies in ANGLE).
        RollTarget::RateDegS(deg_s) => {
            f64::from_bits(shared.bank_target_rad.load(Ordering::Relaxed))
                + (deg_s * RX_FRAME_US as f64 * 1e-6).to_radians()
        }
    };
    shared
        .bank_target_rad
        .store(target_rad.to_bits(), Ordering::Relaxed);
    if roll_us != PILOT_ROLL_US {
        // The first moment iNav used a deflected roll after a manoeuvre started.
        let _ = shared.first_roll_rx_us.compare_exchange(
            i64::MIN,
            now_us,
            Ordering::Relaxed,
            Ordering::Relaxed,
        );
    }
}

/// The eight channels iNav reports using (MSP_RC and RC_CHANNELS alike).
fn rc_in_use(roll_us: u16, switch_us: u16) -> [u16; 8] {
    [roll_us, 1500, 1450, 1500, 1900, switch_us, 1000, 1000]
}

fn telemetry(shared: &Shared, clock: &DaemonClock) -> (MavMessage, u16, u16) {
    let state = *shared.state.lock().expect("state lock");
    let (yaw, pitch, roll) = state.euler_rad();
    let rates = state.body_rates_rad_s;
    let attitude = MavMessage::ATTITUDE(ATTITUDE_DATA {
        time_boot_ms: boot_ms(clock),
        roll: roll as f32,
        pitch: pitch as f32,
        yaw: yaw as f32,
        // As iNav sends them (telemetry/mavlink.c:729-734): its gyro in degrees per
        // second, about forward-left-up (flight/imu.c:624-626), not MAVLink's radians.
        rollspeed: rates.x.to_degrees() as f32,
        pitchspeed: -rates.y.to_degrees() as f32,
        yawspeed: -rates.z.to_degrees() as f32,
    });
    let switch_us = if shared.switch_auto.load(Ordering::Relaxed) {
        1900
    } else {
        1000
    };
    (attitude, shared.roll_us.load(Ordering::Relaxed), switch_us)
}

fn boot_ms(clock: &DaemonClock) -> u32 {
    (clock.now_us() / 1000 + BOOT_OFFSET_MS) as u32
}

fn rc_channels(clock: &DaemonClock, roll_us: u16, switch_us: u16) -> MavMessage {
    inav_mavlink::rc_channels(boot_ms(clock), rc_in_use(roll_us, switch_us), 255)
}
