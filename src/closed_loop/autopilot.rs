//! A simulated iNav: MAVLink telemetry on a loopback UDP socket (HEARTBEAT, ATTITUDE
//! and RC_CHANNELS every 40 ms, iNav's fastest stream) and an MSP port on loopback
//! TCP that takes faithd's roll stream the way iNav's MSP RC override does
//! ([`super::inav_msp`]). Like iNav with a radio receiver, it ignores
//! RC_CHANNELS_OVERRIDE.

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use mavlink::dialects::common::*;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, UdpSocket};

use super::inav_mavlink::{self, encode};
use super::inav_msp::{FcView, InavMsp, Setup};
use super::physics::Shared;
use crate::clock::DaemonClock;

/// The autopilot's boot clock runs on its own origin, as a real one does.
const BOOT_OFFSET_MS: i64 = 73_000;

pub async fn run(socket: UdpSocket, shared: Arc<Shared>, clock: DaemonClock) {
    let mut peer: Option<SocketAddr> = None;
    let mut tick = tokio::time::interval(Duration::from_millis(40));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut n = 0u64;
    let mut seq = 0u8;
    let mut buf = vec![0u8; 4096];
    loop {
        tokio::select! {
            got = socket.recv_from(&mut buf) => {
                let Ok((len, from)) = got else { continue };
                let mut reader = mavlink::MavlinkReader::new(&buf[..len]);
                while let Ok((header, _)) = reader.read_any_message::<MavMessage>() {
                    if header.component_id == 191 {
                        peer = Some(from);
                    }
                }
            }
            _ = tick.tick() => {
                let Some(to) = peer else { continue };
                let mut out = Vec::new();
                let (attitude, roll_us, switch_us) = telemetry(&shared, &clock);
                for msg in [attitude, rc_channels(&clock, roll_us, switch_us)] {
                    encode(&mut out, &mut seq, &msg);
                }
                if n.is_multiple_of(25) {
                    encode(&mut out, &mut seq, &inav_mavlink::heartbeat(true, MavState::MAV_STATE_ACTIVE));
                }
                n += 1;
                let _ = socket.send_to(&out, to).await;
            }
        }
    }
}

/// The pilot's roll stick in the simulated flights: centred.
const PILOT_ROLL_US: u16 = 1500;

/// iNav's MSP port on a loopback TCP listener: one connection at a time (faithd
/// reopens after a loss), the roll iNav uses published to the physics every 5 ms.
pub async fn run_msp(listener: TcpListener, shared: Arc<Shared>, clock: DaemonClock) {
    let mut fc = InavMsp::new(Setup::default());
    loop {
        let Ok((mut stream, _)) = listener.accept().await else {
            return;
        };
        let _ = stream.set_nodelay(true);
        let mut tick = tokio::time::interval(Duration::from_millis(5));
        let mut buf = [0u8; 1024];
        loop {
            tokio::select! {
                got = stream.read(&mut buf) => {
                    let n = match got { Ok(0) | Err(_) => break, Ok(n) => n };
                    let now_us = clock.now_us();
                    let (_, roll_us, switch_us) = telemetry(&shared, &clock);
                    let rc = rc_in_use(roll_us, switch_us);
                    let out = fc.receive(&buf[..n], now_us, FcView::flying(rc));
                    if stream.write_all(&out).await.is_err() {
                        break;
                    }
                    publish_roll(&fc, &shared, &clock);
                }
                _ = tick.tick() => publish_roll(&fc, &shared, &clock),
            }
        }
    }
}

fn publish_roll(fc: &InavMsp, shared: &Shared, clock: &DaemonClock) {
    let now_us = clock.now_us();
    let switch_us = if shared.switch_auto.load(Ordering::Relaxed) {
        1900
    } else {
        1000
    };
    let roll_us = fc.roll_in_use(now_us, switch_us, PILOT_ROLL_US);
    shared.roll_us.store(roll_us, Ordering::Relaxed);
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
        rollspeed: rates.x as f32,
        pitchspeed: rates.y as f32,
        yawspeed: rates.z as f32,
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
