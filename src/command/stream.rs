//! The roll stream: MSP_SET_RAW_RC to iNav for as long as its MSP port is open.
//!
//! iNav's MSP RC override has a failsafe of its own: it applies frames only after
//! 200 ms + failsafe_recovery_delay of them, and keeps the last value for 200 ms +
//! failsafe_delay after they stop (rx/msp_override.c; 0.70-0.74 s and 0.89-0.90 s
//! measured on SITL with the defaults). A sender that is silent between rolls loses
//! half of every 1.5 s roll that way. So faithd streams from the moment the port is
//! open and checked: the stick centre while idle, the roll during a manoeuvre. In
//! AUTO iNav therefore holds roll at centre between manoeuvres; in MANUAL its
//! override mode is off and the pilot's stick is all it uses.
//!
//! Every period the stream also asks MSP_RC, the channel values iNav really uses:
//! the commander compares the roll channel with what it commanded.

use std::time::Duration;

use tokio::io::AsyncReadExt;
use tokio::sync::{mpsc, oneshot, watch};

use super::fc_check::{self, Expectations, RouteFacts};
use super::msp;
use super::msp_port::{self, MspPort};
use crate::clock::DaemonClock;
use crate::link::endpoint::Endpoint;
use crate::supervise::Heartbeat;

/// The stream's knobs, from the config.
#[derive(Clone, Copy, Debug)]
pub struct StreamSettings {
    pub neutral_us: u16,
    pub period: Duration,
    /// Replies (set-up reads, MSP_RC) must come within this.
    pub reply_timeout: Duration,
    /// Wait beyond iNav's recovery delay before the gate may open.
    pub warmup_margin_us: i64,
    pub reconnect_min: Duration,
    pub reconnect_max: Duration,
    /// How long a refused set-up waits before it is read again.
    pub recheck: Duration,
    pub expect: Expectations,
}

/// iNav's roll channel value, as MSP_RC reported it at daemon time `t_us`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RollReport {
    pub t_us: i64,
    pub roll_us: u16,
}

/// What the stream publishes for the gate and the commander.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StreamStatus {
    pub setup_refused: bool,
    /// From this daemon time on iNav applies the stream; `None` while not streaming.
    pub ready_at_us: Option<i64>,
    pub facts: Option<RouteFacts>,
    pub last_report: Option<RollReport>,
    /// iNav's own state (armed, failsafe, override mode), read every period.
    pub fc: Option<faithd_core::safety::gate::FcStatus>,
}

/// Asks the stream to end with the stick centre: `repeats` frames one period apart,
/// each flushed; the answer is how many went out, or why none could.
pub struct StopRequest {
    pub repeats: u32,
    pub done: oneshot::Sender<Result<u32, String>>,
}

/// The commander's side of the stream.
pub struct StreamHandle {
    /// The roll value the stream holds (the centre when idle).
    pub held: watch::Sender<u16>,
    pub status: watch::Receiver<StreamStatus>,
    pub stop: mpsc::Sender<StopRequest>,
}

/// Starts the stream task.
pub fn spawn(
    endpoint: Endpoint,
    settings: StreamSettings,
    clock: DaemonClock,
    heartbeat: Heartbeat,
) -> StreamHandle {
    let (held, held_rx) = watch::channel(settings.neutral_us);
    let (status_tx, status) = watch::channel(StreamStatus::default());
    let (stop, stop_rx) = mpsc::channel(1);
    let channels = Channels {
        held: held_rx,
        status: status_tx,
        stop: stop_rx,
        heartbeat,
    };
    tokio::spawn(run(endpoint, settings, clock, channels));
    StreamHandle { held, status, stop }
}

/// The stream task's ends of its channels, and its heartbeat.
struct Channels {
    held: watch::Receiver<u16>,
    status: watch::Sender<StreamStatus>,
    stop: mpsc::Receiver<StopRequest>,
    heartbeat: Heartbeat,
}

/// Writes the release from outside the stream, on a port opened afresh: for when the
/// stream task is gone (it panicked) and the daemon is stopping.
pub async fn release_directly(
    endpoint: &Endpoint,
    facts: RouteFacts,
    neutral_us: u16,
    repeats: u32,
) -> Result<u32, String> {
    let transport = endpoint
        .open()
        .await
        .map_err(|e| format!("cannot open {endpoint}: {e}"))?;
    let mut port = MspPort::new(transport);
    let centre = raw_rc_frame(facts.roll_frame_index, neutral_us, neutral_us);
    release(&mut port, &centre, repeats, Duration::from_millis(20)).await
}

/// MSP_SET_RAW_RC: the four flight channels at the centre, `roll_us` in the slot of
/// the radio channel that feeds iNav's roll. iNav needs all four valid to trust the
/// frame, and takes from it only the channels in msp_override_channels (roll alone,
/// as `faithd check-fc` verified).
pub fn raw_rc_frame(roll_frame_index: usize, roll_us: u16, neutral_us: u16) -> Vec<u8> {
    let mut channels = [neutral_us; 4];
    channels[roll_frame_index.min(3)] = roll_us;
    msp::set_raw_rc(&channels)
}

async fn run(endpoint: Endpoint, settings: StreamSettings, clock: DaemonClock, channels: Channels) {
    let mut channels = channels;
    let mut backoff = settings.reconnect_min;
    loop {
        channels.heartbeat.beat();
        let opened = tokio::select! {
            biased;
            o = endpoint.open() => o,
            Some(req) = channels.stop.recv() => {
                let _ = req.done.send(Err("the MSP port is not open".into()));
                return;
            }
        };
        let wait = match opened {
            Err(e) => {
                tracing::warn!(%endpoint, "cannot open the MSP command port: {e}; retry in {} ms", backoff.as_millis());
                backoff
            }
            Ok(transport) => {
                backoff = settings.reconnect_min;
                let mut port = MspPort::new(transport);
                match check(&mut port, &settings).await {
                    Err(why) => {
                        tracing::warn!(%endpoint, "cannot read the flight controller's set-up: {why}");
                        backoff
                    }
                    Ok(Err(summary)) => {
                        channels.status.send_modify(|s| s.setup_refused = true);
                        tracing::error!(%endpoint, "flight controller set-up refused, faithd will not command: {summary}");
                        settings.recheck
                    }
                    Ok(Ok(facts)) => {
                        let why = serve(&mut port, facts, &settings, &clock, &mut channels).await;
                        channels.status.send_modify(|s| {
                            s.ready_at_us = None;
                            s.last_report = None;
                            s.fc = None;
                        });
                        match why {
                            Ended::Stopped => return,
                            Ended::Failed(why) => {
                                tracing::warn!(%endpoint, "MSP command port lost: {why}; reopening")
                            }
                        }
                        backoff
                    }
                }
            }
        };
        tokio::select! {
            biased;
            _ = channels.heartbeat.sleep(wait) => {}
            Some(req) = channels.stop.recv() => {
                let _ = req.done.send(Err("the MSP port is not open".into()));
                return;
            }
        }
        backoff = (backoff * 2).min(settings.reconnect_max);
    }
}

/// Reads and judges the set-up; `Ok(Err(summary))` when it is refused.
async fn check(
    port: &mut MspPort,
    settings: &StreamSettings,
) -> Result<Result<RouteFacts, String>, String> {
    let fc = fc_check::read(port, settings.reply_timeout)
        .await
        .map_err(|e| e.to_string())?;
    let report = fc_check::evaluate(&fc, &settings.expect);
    Ok(match report.route {
        Some(facts) => {
            for item in &report.items {
                tracing::info!("flight controller {}: {}", item.what, item.found);
            }
            Ok(facts)
        }
        None => Err(report.summary()),
    })
}

enum Ended {
    Stopped,
    Failed(String),
}

async fn serve(
    port: &mut MspPort,
    facts: RouteFacts,
    settings: &StreamSettings,
    clock: &DaemonClock,
    channels: &mut Channels,
) -> Ended {
    let Channels {
        held,
        status,
        stop,
        heartbeat,
    } = channels;
    let neutral = settings.neutral_us;
    let frame = |roll_us| raw_rc_frame(facts.roll_frame_index, roll_us, neutral);
    let mut requests = msp::encode_request(msp_port::MSP_RC, &[]);
    requests.extend(msp::encode_request(msp_port::MSP2_INAV_STATUS, &[]));
    // Whatever was held before the port went away, the stream starts at the centre:
    // that is the release a restarted or reconnected faithd owes the pilot.
    held.mark_unchanged();
    let mut roll_us = neutral;
    if let Err(e) = port.write(&frame(roll_us)).await {
        return Ended::Failed(format!("write failed: {e}"));
    }
    let started_us = clock.now_us();
    let ready_at_us = started_us + facts.warmup_us + settings.warmup_margin_us;
    status.send_modify(|s| {
        s.setup_refused = false;
        s.facts = Some(facts);
        s.ready_at_us = Some(ready_at_us);
    });
    tracing::info!(
        warmup_ms = (ready_at_us - started_us) / 1000,
        "MSP roll stream started at the stick centre"
    );
    let mut tick = tokio::time::interval(settings.period);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut last_reply = tokio::time::Instant::now();
    let mut frames = Vec::new();
    let mut buf = [0u8; 512];
    let mut refusals = 0u64;
    loop {
        heartbeat.beat();
        // Biased (polled in this order, as everywhere in the daemon): the stop and the
        // send period come before the replies, which cannot starve them.
        tokio::select! {
            biased;
            Some(req) = stop.recv() => {
                let sent = release(port, &frame(neutral), req.repeats, settings.period).await;
                let _ = req.done.send(sent);
                return Ended::Stopped;
            }
            _ = tick.tick() => {
                if last_reply.elapsed() > settings.reply_timeout {
                    return Ended::Failed(format!(
                        "no MSP_RC reply for {} ms", last_reply.elapsed().as_millis()
                    ));
                }
                let mut out = frame(roll_us);
                out.extend_from_slice(&requests);
                if let Err(e) = port.write(&out).await {
                    return Ended::Failed(format!("write failed: {e}"));
                }
            }
            Ok(()) = held.changed() => {
                roll_us = *held.borrow_and_update();
                if let Err(e) = port.write(&frame(roll_us)).await {
                    return Ended::Failed(format!("write failed: {e}"));
                }
            }
            got = port.rx.read(&mut buf) => {
                let n = match got {
                    Ok(0) => return Ended::Failed("end of stream".into()),
                    Ok(n) => n,
                    Err(e) => return Ended::Failed(format!("read failed: {e}")),
                };
                port.decoder.push(&buf[..n], &mut frames);
                for f in frames.drain(..) {
                    if f.direction == b'!' {
                        refusals += 1;
                        if refusals.is_power_of_two() {
                            tracing::error!(command = f.command, refusals, "the flight controller refused an MSP command");
                        }
                    } else if f.command == msp_port::MSP_RC {
                        last_reply = tokio::time::Instant::now();
                        if let Some(roll) = msp_port::rc_values(&f.payload).next() {
                            let report = RollReport { t_us: clock.now_us(), roll_us: roll };
                            status.send_modify(|s| s.last_report = Some(report));
                        }
                    } else if f.command == msp_port::MSP2_INAV_STATUS {
                        match facts.status_bits.decode(&f.payload) {
                            Some((armed, failsafe, override_on)) => publish_fc_status(
                                status,
                                faithd_core::safety::gate::FcStatus {
                                    t_us: clock.now_us(),
                                    armed,
                                    failsafe,
                                    override_on,
                                },
                            ),
                            None => tracing::warn!(bytes = f.payload.len(), "MSP2_INAV_STATUS reply too short; ignored"),
                        }
                    }
                }
            }
        }
    }
}

/// Hands iNav's latest status to the gate, saying in the journal when it changed.
fn publish_fc_status(
    status: &watch::Sender<StreamStatus>,
    fc: faithd_core::safety::gate::FcStatus,
) {
    let flags = |f: &faithd_core::safety::gate::FcStatus| (f.armed, f.failsafe, f.override_on);
    status.send_modify(|s| {
        if s.fc.as_ref().map(flags) != Some(flags(&fc)) {
            tracing::info!(
                armed = fc.armed,
                failsafe = fc.failsafe,
                override_on = fc.override_on,
                "flight controller status"
            );
        }
        s.fc = Some(fc);
    });
}

/// Writes the centre `repeats` times, one period apart, each flushed.
async fn release(
    port: &mut MspPort,
    centre: &[u8],
    repeats: u32,
    period: Duration,
) -> Result<u32, String> {
    for n in 0..repeats.max(1) {
        if n > 0 {
            tokio::time::sleep(period).await;
        }
        port.write(centre)
            .await
            .map_err(|e| format!("{n} of {repeats} written, then: {e}"))?;
    }
    Ok(repeats.max(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_carries_the_roll_in_the_mapped_slot_and_the_centre_elsewhere() {
        let mut out = Vec::new();
        msp::Decoder::default().push(&raw_rc_frame(1, 1800, 1500), &mut out);
        let values: Vec<u16> = msp_port::rc_values(&out[0].payload).collect();
        assert_eq!(values, vec![1500, 1800, 1500, 1500]);
        assert_eq!(out[0].command, msp::MSP_SET_RAW_RC);
    }
}
