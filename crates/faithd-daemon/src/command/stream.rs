//! The roll stream: MSP_SET_RAW_RC to iNav for as long as its MSP port is open.
//!
//! iNav's MSP RC override has a failsafe of its own: it applies frames only after
//! 200 ms + failsafe_recovery_delay of them, and keeps the last value for 400 ms +
//! failsafe_delay after they stop (rx/msp.c, rx/msp_override.c; 0.70-0.74 s and
//! 0.89-0.94 s measured on SITL with the defaults). A sender that is silent between
//! rolls loses half of every 1.5 s roll that way. So faithd streams from the moment
//! the port is open and checked: iNav's centre while idle, the roll during a
//! manoeuvre. In AUTO iNav therefore holds roll at centre between manoeuvres; in
//! MANUAL its override mode is off and the pilot's stick is all it uses.
//!
//! The port carries what a flight controller can serve: one command per 20 ms slot
//! ([`super::msp_port`]), each answered before the next is written. The roll frame
//! goes first whenever the held value changed and at least every
//! `manoeuvre.resend_period_us`; the other slots ask MSP_RC (the roll iNav really
//! uses, for the commander's check) and MSP2_INAV_STATUS (armed, failsafe, ANGLE, the
//! override mode) in turn, and every 400 ms one request of the set-up check again: a
//! set-up changed in flight (from a configurator on another port) stops the stream
//! and closes the gate with what changed.
//!
//! Whatever the commander does, the stream holds a roll no longer than a roll lasts
//! plus a margin ([`StreamSettings::hold_bound`]), then reverts to the centre.

use std::time::Duration;

use tokio::sync::{mpsc, oneshot, watch};

use super::fc_check::{self, Expectations, FcSettings, RouteFacts};
use super::msp;
use super::msp_port::{self, MspError, MspPort};
use super::rxrange::RxRange;
use crate::clock::DaemonClock;
use crate::supervise::Heartbeat;
use crate::transport::Endpoint;
use faithd_core::osd::{GvarWriter, OsdConfig, PilotView};
use faithd_core::safety::commander::{RollReport, RouteStatus};
use faithd_core::safety::gate::{AutopilotStatus, RouteWords};
use faithd_core::safety::rc::NEUTRAL_US;

/// The stream's knobs, from the config.
#[derive(Clone, Copy, Debug)]
pub struct StreamSettings {
    /// The roll frame goes out at least this often.
    pub roll_period: Duration,
    /// Replies (set-up reads, MSP_RC) must come within this.
    pub reply_timeout: Duration,
    /// Wait beyond iNav's recovery delay before the gate may open.
    pub warmup_margin_us: i64,
    pub reconnect_min: Duration,
    pub reconnect_max: Duration,
    /// How long a refused set-up waits before it is read again.
    pub recheck: Duration,
    pub expect: Expectations,
    /// iNav's calibration of roll: values are aimed through it.
    pub roll_rxrange: RxRange,
    /// A value other than the centre held longer than this is dropped by the stream.
    pub hold_bound: Duration,
    /// faithd's state for the pilot's OSD, in iNav's global variables.
    pub osd: OsdConfig,
}

/// Asks the stream to end with the stick centre: `repeats` frames one period apart;
/// the answer is how many went out, or why none could.
pub struct StopRequest {
    pub repeats: u32,
    pub done: oneshot::Sender<Result<u32, ReleaseError>>,
}

/// Why the centre did not (all) reach iNav's MSP port.
#[derive(Debug, thiserror::Error)]
pub enum ReleaseError {
    /// The stream was not streaming: nothing of faithd's for iNav to hold.
    #[error("the MSP port is not open")]
    NotOpen,
    /// Asked while it read the set-up, before its first frame: nothing of faithd's
    /// for iNav to hold.
    #[error("the stream had not started: it was reading the flight controller's set-up")]
    NotStarted,
    #[error("cannot open {endpoint}: {source}")]
    Open {
        endpoint: String,
        source: std::io::Error,
    },
    #[error("{written} of {repeats} written, then: {source}")]
    Write {
        written: u32,
        repeats: u32,
        source: std::io::Error,
    },
}

/// The commander's side of the stream.
pub struct StreamHandle {
    /// The roll value iNav should use (the centre when idle).
    pub held: watch::Sender<u16>,
    /// What the gate and the commander read: the set-up judged, the stream ready
    /// (from when iNav applies it), iNav's status (armed, failsafe, ANGLE, the
    /// override mode) and the roll iNav reports using.
    pub status: watch::Receiver<RouteStatus>,
    /// The route as the last check found it, for a release written from outside.
    pub facts: watch::Receiver<Option<RouteFacts>>,
    pub stop: mpsc::Sender<StopRequest>,
}

/// How iNav over MSP is worded in the journal when it keeps the gate closed.
pub static INAV_MSP_WORDS: RouteWords = RouteWords {
    setup_refused: "flight controller set-up refused (see `faithd check-fc`)",
    setup_changed: "the flight controller's set-up changed in flight (the journal says what): faithd reads it again before it commands",
    not_streaming: "MSP command port not streaming",
    no_status: "no status from the flight controller over MSP yet",
    status_stale: "flight controller status over MSP stale",
    failsafe: "iNav's FAILSAFE mode",
    override_inactive: "iNav reports its MSP RC OVERRIDE mode off: it would not take faithd's roll",
    stabilised_mode_off: "iNav is not in ANGLE mode: a roll stick would command a rotation rate, not a bank (put ANGLE on the AUTO switch: `faithd check-fc`)",
    warming_up: "iNav applies the MSP override only after its recovery delay",
};

/// MSP2_INAV_SET_GVAR (iNav 9.0 and later, fc/fc_msp.c): a u8 index and an int32.
pub const MSP2_INAV_SET_GVAR: u16 = 0x2214;

/// Starts the stream task; with `[osd] enabled`, it writes `view` into iNav's
/// global variables in the slots the roll frame leaves free.
pub fn spawn(
    endpoint: Endpoint,
    settings: StreamSettings,
    clock: DaemonClock,
    heartbeat: Heartbeat,
    view: watch::Receiver<PilotView>,
) -> StreamHandle {
    let (held, held_rx) = watch::channel(NEUTRAL_US);
    let (status_tx, status) = watch::channel(RouteStatus::unchecked(&INAV_MSP_WORDS));
    let (facts_tx, facts) = watch::channel(None);
    let (stop, stop_rx) = mpsc::channel(1);
    let channels = Channels {
        held: held_rx,
        status: status_tx,
        facts: facts_tx,
        stop: stop_rx,
        heartbeat,
        osd: settings.osd.enabled.then(|| Osd {
            writer: GvarWriter::new(&settings.osd),
            view,
        }),
    };
    tokio::spawn(run(endpoint, settings, clock, channels));
    StreamHandle {
        held,
        status,
        facts,
        stop,
    }
}

/// The stream task's ends of its channels, and its heartbeat.
struct Channels {
    held: watch::Receiver<u16>,
    status: watch::Sender<RouteStatus>,
    facts: watch::Sender<Option<RouteFacts>>,
    stop: mpsc::Receiver<StopRequest>,
    heartbeat: Heartbeat,
    osd: Option<Osd>,
}

/// What the pilot's OSD is to show, and which variable is written next.
struct Osd {
    writer: GvarWriter,
    view: watch::Receiver<PilotView>,
}

impl Osd {
    fn next(&mut self, now_us: i64) -> Option<(u8, i32)> {
        let view = *self.view.borrow();
        self.writer.next(&view, now_us)
    }
}

/// Writes the release from outside the stream, on a port opened afresh: for when the
/// stream task is gone (it panicked) and the daemon is stopping.
pub async fn release_directly(
    endpoint: &Endpoint,
    facts: RouteFacts,
    roll_rxrange: RxRange,
    repeats: u32,
    period: Duration,
) -> Result<u32, ReleaseError> {
    let transport = endpoint.open().await.map_err(|source| ReleaseError::Open {
        endpoint: endpoint.to_string(),
        source,
    })?;
    let mut port = MspPort::new(transport);
    let centre = raw_rc_frame(facts.rcmap, NEUTRAL_US, roll_rxrange, &[]);
    release(&mut port, &centre, repeats, period).await
}

/// MSP_SET_RAW_RC: in the slot of the radio channel that feeds iNav's roll, the value
/// that iNav, after scaling it by `rxrange`, uses as `roll_us`; in every other slot
/// what iNav last reported using on that channel (`in_use`, MSP_RC in iNav's order:
/// roll, pitch, yaw, throttle, AUX...), the centre before the first report.
///
/// iNav takes from the frame only the channels in msp_override_channels (roll alone,
/// as `faithd check-fc` verified), but it reads that mask on every frame
/// (rx/msp_override.c, mspOverrideChannels), and a channel added to it from another
/// port takes the frame's value at once, with no per-channel way to decline: a 0 or
/// an invalid value makes iNav hold the last valid one (msp_override.c, the
/// MAX_INVALID_RX_PULSE hold), a channel left out of the frame reads 0. So the other
/// channels carry the pilot's own values, as iNav used them a report ago: until
/// faithd notices the change and stops, a throttle added to the mask keeps the
/// pilot's throttle instead of jumping to mid-stick, an ARM channel stays armed.
pub fn raw_rc_frame(
    rcmap: [u8; 4],
    roll_us: u16,
    roll_rxrange: RxRange,
    in_use: &[u16],
) -> Vec<u8> {
    let mut channels = vec![NEUTRAL_US; in_use.len().max(4)];
    for (i, &radio) in rcmap.iter().enumerate() {
        if let (Some(slot), Some(&v)) = (channels.get_mut(usize::from(radio)), in_use.get(i)) {
            *slot = v;
        }
    }
    for (slot, &v) in channels.iter_mut().zip(in_use).skip(4) {
        *slot = v;
    }
    channels[usize::from(rcmap[0]).min(3)] =
        roll_rxrange.aim(roll_us).map_or(roll_us, |(sent, _)| sent);
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
                let _ = req.done.send(Err(ReleaseError::NotOpen));
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
                // The set-up takes a few hundred milliseconds to read: a stop meanwhile
                // finds no frame of faithd's on iNav and ends the task at once.
                let checked = tokio::select! {
                    biased;
                    Some(req) = channels.stop.recv() => {
                        let _ = req.done.send(Err(ReleaseError::NotStarted));
                        return;
                    }
                    checked = check(&mut port, &settings) => checked,
                };
                match checked {
                    Err(why) => {
                        tracing::warn!(%endpoint, "cannot read the flight controller's set-up: {why}");
                        backoff
                    }
                    Ok(Checked::Refused(summary)) => {
                        channels.status.send_modify(|s| s.path.setup_refused = true);
                        tracing::error!(%endpoint, "flight controller set-up refused, faithd will not command: {summary}");
                        settings.recheck
                    }
                    Ok(Checked::Accepted(fc, facts)) => {
                        let why =
                            serve(&mut port, &fc, facts, &settings, &clock, &mut channels).await;
                        channels.status.send_modify(|s| {
                            s.path.ready_at_us = None;
                            s.path.autopilot = None;
                            s.last_report = None;
                        });
                        match why {
                            Ended::Stopped => return,
                            Ended::SetupChanged(what) => {
                                channels.status.send_modify(|s| s.path.setup_changed = true);
                                tracing::error!(%endpoint, "the flight controller's set-up changed in flight ({what}): faithd stopped streaming and closes the gate until the set-up is checked again");
                                Duration::ZERO
                            }
                            Ended::Failed(why) => {
                                tracing::warn!(%endpoint, "MSP command port lost: {why}; reopening");
                                backoff
                            }
                        }
                    }
                }
            }
        };
        tokio::select! {
            biased;
            _ = channels.heartbeat.sleep(wait) => {}
            Some(req) = channels.stop.recv() => {
                let _ = req.done.send(Err(ReleaseError::NotOpen));
                return;
            }
        }
        backoff = (backoff * 2).min(settings.reconnect_max);
    }
}

/// The set-up as judged on an open port.
enum Checked {
    /// Accepted: what was read, and the route it gives.
    Accepted(FcSettings, RouteFacts),
    /// Refused, with the check's summary for the journal.
    Refused(String),
}

/// Reads and judges the set-up; an error when it could not be read at all.
async fn check(port: &mut MspPort, settings: &StreamSettings) -> Result<Checked, MspError> {
    let fc = fc_check::read(port, settings.reply_timeout).await?;
    let report = fc_check::evaluate(&fc, &settings.expect);
    Ok(match report.route {
        Some(facts) => {
            for item in &report.items {
                tracing::info!("flight controller {}: {}", item.what, item.found);
            }
            Checked::Accepted(fc, facts)
        }
        None => Checked::Refused(report.summary()),
    })
}

enum Ended {
    Stopped,
    SetupChanged(String),
    Failed(String),
}

/// What the stream asks in the slots the roll frame leaves free.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ask {
    Rc,
    Status,
    Recheck(fc_check::Recheck),
    /// One of faithd's variables for the pilot's OSD: iNav's index, the value.
    Gvar(u8, i32),
}

/// MSP_RC and MSP2_INAV_STATUS in turn; two of every [`RECHECK_EVERY`] asks (MSP_RC's
/// turns) the next part of the set-up check instead, and two others (MSP2_INAV_STATUS's)
/// a variable for the OSD when one is due (five a second at most). MSP_RC and the
/// status each still come at least every 160 ms.
struct Rotation {
    n: usize,
    recheck: usize,
}

/// Ten asks take 400 ms with the roll frame in every other slot: a recheck every
/// 200 ms, the override mask ([`fc_check::RECHECKS`]) every 400 ms.
const RECHECK_EVERY: usize = 10;

impl Rotation {
    fn next(&mut self, osd: Option<&mut Osd>, now_us: i64) -> Ask {
        self.n += 1;
        if matches!(self.n % RECHECK_EVERY, 0 | 4) {
            self.recheck += 1;
            return Ask::Recheck(fc_check::RECHECKS[self.recheck % fc_check::RECHECKS.len()]);
        }
        if self.n.is_multiple_of(2) {
            return Ask::Rc;
        }
        let osd_turn = matches!(self.n % RECHECK_EVERY, 3 | 7);
        match osd.filter(|_| osd_turn).and_then(|o| o.next(now_us)) {
            Some((index, value)) => Ask::Gvar(index, value),
            None => Ask::Status,
        }
    }
}

/// The value streamed, and how long it has been other than the centre.
struct Held {
    wanted_us: u16,
    raised_at: Option<tokio::time::Instant>,
    /// The bound ran out: the stream sends the centre until the commander does too.
    reverted: bool,
}

impl Held {
    /// The commander asked for `wanted_us`.
    fn set(&mut self, wanted_us: u16) {
        if wanted_us == self.wanted_us {
            return;
        }
        self.wanted_us = wanted_us;
        self.reverted = false;
        self.raised_at = (wanted_us != NEUTRAL_US).then(tokio::time::Instant::now);
    }

    /// The value to send now; reverts (once, with a journal line) past the bound.
    fn value_us(&mut self, bound: Duration) -> u16 {
        if let Some(raised_at) = self.raised_at
            && !self.reverted
            && raised_at.elapsed() > bound
        {
            self.reverted = true;
            tracing::error!(
                held_us = self.wanted_us,
                bound_ms = bound.as_millis(),
                "roll {} us held for longer than a roll lasts: the stream reverts to the centre on its own",
                self.wanted_us
            );
        }
        if self.reverted {
            NEUTRAL_US
        } else {
            self.wanted_us
        }
    }
}

/// What a slot is for, once it comes.
enum Slot {
    /// Write this: the roll frame (`None`) with `value_us`, or a request.
    Due { ask: Option<Ask>, value_us: u16 },
    /// The commander changed the value while a request waited: look again.
    Changed,
    /// The daemon asked the stream to release and end.
    Stop(StopRequest),
}

/// The stream on an open, checked port: the slots, the value and the rotation.
struct Serving<'a> {
    port: &'a mut MspPort,
    checked: &'a FcSettings,
    facts: RouteFacts,
    settings: &'a StreamSettings,
    clock: &'a DaemonClock,
    wanted: Held,
    rotation: Rotation,
    sent_us: Option<u16>,
    last_roll_frame: tokio::time::Instant,
    refusals: u64,
    /// The channels iNav last reported using (MSP_RC, iNav's order).
    in_use_us: Vec<u16>,
}

/// Streams until the port fails, the set-up changes or the daemon asks to stop: in
/// each slot the roll frame when due, else the next request, and its reply read.
async fn serve(
    port: &mut MspPort,
    checked: &FcSettings,
    facts: RouteFacts,
    settings: &StreamSettings,
    clock: &DaemonClock,
    channels: &mut Channels,
) -> Ended {
    let mut serving = Serving::begin(port, checked, facts, settings, clock, channels);
    loop {
        channels.heartbeat.beat();
        let (ask, value_us) = match serving.wait_for_slot(channels).await {
            Slot::Due { ask, value_us } => (ask, value_us),
            Slot::Changed => continue,
            Slot::Stop(req) => return serving.release_and_end(req).await,
        };
        let payload = match serving.exchange(channels, ask, value_us).await {
            Ok(Some(payload)) => payload,
            Ok(None) => continue,
            Err(ended) => return ended,
        };
        if let Some(ended) = serving.take_reply(&channels.status, ask, &payload) {
            return ended;
        }
    }
}

impl<'a> Serving<'a> {
    /// Starts at the centre, whatever was held before the port went away: that is
    /// the release a restarted or reconnected faithd owes the pilot. Publishes the
    /// route and from when iNav applies it.
    fn begin(
        port: &'a mut MspPort,
        checked: &'a FcSettings,
        facts: RouteFacts,
        settings: &'a StreamSettings,
        clock: &'a DaemonClock,
        channels: &mut Channels,
    ) -> Self {
        channels.held.mark_unchanged();
        if let Some(osd) = channels.osd.as_mut() {
            osd.writer.forget();
        }
        let started_us = clock.now_us();
        let ready_at_us = started_us + facts.warmup_us + settings.warmup_margin_us;
        channels.facts.send_replace(Some(facts));
        channels.status.send_modify(|s| {
            s.path.setup_refused = false;
            s.path.setup_changed = false;
            s.path.ready_at_us = Some(ready_at_us);
        });
        tracing::info!(
            warmup_ms = (ready_at_us - started_us) / 1000,
            "MSP roll stream started at the stick centre"
        );
        Self {
            port,
            checked,
            facts,
            settings,
            clock,
            wanted: Held {
                wanted_us: NEUTRAL_US,
                raised_at: None,
                reverted: false,
            },
            rotation: Rotation { n: 0, recheck: 0 },
            sent_us: None,
            last_roll_frame: tokio::time::Instant::now(),
            refusals: 0,
            in_use_us: Vec::new(),
        }
    }

    /// The roll frame with `roll_us`, aimed through iNav's `rxrange`.
    fn frame(&self, roll_us: u16) -> Vec<u8> {
        raw_rc_frame(
            self.facts.rcmap,
            roll_us,
            self.settings.roll_rxrange,
            &self.in_use_us,
        )
    }

    /// Waits for the next slot. The roll frame is due when the value changed, or
    /// when the next slot comes a period after the last roll frame: the roll frame
    /// and the requests then take turns. A stop wins over the slot, and a new value
    /// takes the slot from a request (the roll frame is always first in line).
    async fn wait_for_slot(&mut self, channels: &mut Channels) -> Slot {
        if channels.held.has_changed().unwrap_or(false) {
            self.wanted.set(*channels.held.borrow_and_update());
        }
        let value_us = self.wanted.value_us(self.settings.hold_bound);
        let roll_due = self.sent_us != Some(value_us)
            || self.port.next_slot() >= self.last_roll_frame + self.settings.roll_period;
        let ask = if roll_due {
            None
        } else {
            let now_us = self.clock.now_us();
            Some(self.rotation.next(channels.osd.as_mut(), now_us))
        };
        tokio::select! {
            biased;
            Some(req) = channels.stop.recv() => Slot::Stop(req),
            Ok(()) = channels.held.changed(), if ask.is_some() => {
                self.wanted.set(*channels.held.borrow_and_update());
                Slot::Changed
            }
            _ = tokio::time::sleep_until(self.port.next_slot()) => Slot::Due { ask, value_us },
        }
    }

    /// Writes the slot's command and reads its reply: `Ok(None)` when iNav refused
    /// it (counted, and said in the journal at powers of two), `Err` when the
    /// stream ends here.
    async fn exchange(
        &mut self,
        channels: &mut Channels,
        ask: Option<Ask>,
        value_us: u16,
    ) -> Result<Option<Vec<u8>>, Ended> {
        let (command, bytes) = match ask {
            None => (msp::MSP_SET_RAW_RC, self.frame(value_us)),
            Some(Ask::Rc) => (msp_port::MSP_RC, msp::encode_request(msp_port::MSP_RC, &[])),
            Some(Ask::Status) => (
                msp_port::MSP2_INAV_STATUS,
                msp::encode_request(msp_port::MSP2_INAV_STATUS, &[]),
            ),
            Some(Ask::Recheck(r)) => (r.command(), r.request()),
            Some(Ask::Gvar(index, value)) => {
                let mut payload = vec![index];
                payload.extend_from_slice(&value.to_le_bytes());
                (
                    MSP2_INAV_SET_GVAR,
                    msp::encode_request(MSP2_INAV_SET_GVAR, &payload),
                )
            }
        };
        let slot_at = match self.port.send(&bytes).await {
            Ok(at) => at,
            Err(e) => return Err(Ended::Failed(format!("write failed: {e}"))),
        };
        if ask.is_none() {
            self.sent_us = Some(value_us);
            self.last_roll_frame = slot_at;
        }
        let timeout = self.settings.reply_timeout;
        let reply = tokio::select! {
            biased;
            Some(req) = channels.stop.recv() => return Err(self.release_and_end(req).await),
            reply = self.port.reply(command, timeout) => reply,
        };
        match reply {
            Ok(payload) => Ok(Some(payload)),
            Err(MspError::Refused { command }) => {
                self.refusals += 1;
                if self.refusals.is_power_of_two() {
                    tracing::error!(
                        command,
                        refusals = self.refusals,
                        "the flight controller refused an MSP command"
                    );
                }
                Ok(None)
            }
            Err(e) => Err(Ended::Failed(e.to_string())),
        }
    }

    /// Hands a reply on: the roll iNav uses to the commander, iNav's status to the
    /// gate, a set-up read again to the check (a change ends the stream).
    fn take_reply(
        &mut self,
        status: &watch::Sender<RouteStatus>,
        ask: Option<Ask>,
        payload: &[u8],
    ) -> Option<Ended> {
        match ask {
            None | Some(Ask::Gvar(..)) => {}
            Some(Ask::Rc) => {
                self.in_use_us = msp_port::rc_values(payload).collect();
                if let Some(roll_us) = msp_port::rc_values(payload).next() {
                    let report = RollReport {
                        t_us: self.clock.now_us(),
                        roll_us,
                    };
                    status.send_modify(|s| s.last_report = Some(report));
                }
            }
            Some(Ask::Status) => match self.facts.status_bits.decode(payload) {
                Some(bits) => publish_autopilot_status(
                    status,
                    AutopilotStatus {
                        t_us: self.clock.now_us(),
                        armed: bits.armed,
                        failsafe: bits.failsafe,
                        override_active: bits.override_on,
                        stabilised: bits.angle,
                    },
                ),
                None => tracing::warn!(
                    bytes = payload.len(),
                    "MSP2_INAV_STATUS reply too short; ignored"
                ),
            },
            Some(Ask::Recheck(r)) => {
                return r.changed(self.checked, payload).map(Ended::SetupChanged);
            }
        }
        None
    }

    /// Writes the centre as the daemon asked and answers how many went out.
    /// With the OSD on, the gate's variable then goes to 0 (one more slot), which the
    /// goggles show as nothing of faithd: a stopped faithd does not leave `FAITH OPEN`
    /// on the screen.
    async fn release_and_end(&mut self, req: StopRequest) -> Ended {
        let centre = self.frame(NEUTRAL_US);
        let sent = release(self.port, &centre, req.repeats, self.settings.roll_period).await;
        // Before the answer: the daemon exits once it has it.
        if self.settings.osd.enabled && sent.is_ok() {
            let mut payload = vec![self.settings.osd.first_gvar];
            payload.extend_from_slice(&0i32.to_le_bytes());
            let slot = Duration::from_micros(msp_port::MSP_SLOT_US as u64);
            if self
                .port
                .send(&msp::encode_request(MSP2_INAV_SET_GVAR, &payload))
                .await
                .is_ok()
            {
                let _ = self.port.reply(MSP2_INAV_SET_GVAR, slot).await;
            }
        }
        let _ = req.done.send(sent);
        Ended::Stopped
    }
}

/// Hands iNav's latest status to the gate, saying in the journal when it changed
/// (in iNav's terms: the override mode, ANGLE).
fn publish_autopilot_status(status: &watch::Sender<RouteStatus>, fc: AutopilotStatus) {
    let flags = |f: &AutopilotStatus| (f.armed, f.failsafe, f.override_active, f.stabilised);
    status.send_modify(|s| {
        if s.path.autopilot.as_ref().map(flags) != Some(flags(&fc)) {
            tracing::info!(
                armed = fc.armed,
                failsafe = fc.failsafe,
                override_on = fc.override_active,
                angle = fc.stabilised,
                "flight controller status"
            );
        }
        s.path.autopilot = Some(fc);
    });
}

/// Writes the centre `repeats` times, one period apart, each in its slot and
/// acknowledged (or given a period to be).
async fn release(
    port: &mut MspPort,
    centre: &[u8],
    repeats: u32,
    period: Duration,
) -> Result<u32, ReleaseError> {
    for n in 0..repeats.max(1) {
        if n > 0 {
            tokio::time::sleep(
                period.saturating_sub(Duration::from_micros(msp_port::MSP_SLOT_US as u64)),
            )
            .await;
        }
        port.send(centre)
            .await
            .map_err(|source| ReleaseError::Write {
                written: n,
                repeats,
                source,
            })?;
        let _ = port.reply(msp::MSP_SET_RAW_RC, period).await;
    }
    Ok(repeats.max(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_carries_the_roll_in_the_mapped_slot_and_the_centre_elsewhere() {
        let mut out = Vec::new();
        let rcmap = [1, 0, 3, 2];
        msp::Decoder::default().push(&raw_rc_frame(rcmap, 1800, RxRange::DEFAULT, &[]), &mut out);
        let values: Vec<u16> = msp_port::rc_values(&out[0].payload).collect();
        assert_eq!(values, vec![1500, 1800, 1500, 1500]);
        assert_eq!(out[0].command, msp::MSP_SET_RAW_RC);
    }

    /// What iNav reported using (its order: roll, pitch, yaw, throttle, AUX...) goes
    /// back in the radio's order, the roll aside: a channel added to iNav's override
    /// mask keeps the pilot's value.
    #[test]
    fn the_other_channels_carry_what_inav_uses_in_the_radios_order() {
        let mut out = Vec::new();
        // TAER: throttle on radio channel 1, roll on 2, pitch on 3, yaw on 4.
        let rcmap = [1, 2, 3, 0];
        let in_use = [1440, 1510, 1490, 1234, 1900, 1850];
        let frame = raw_rc_frame(rcmap, 1800, RxRange::DEFAULT, &in_use);
        msp::Decoder::default().push(&frame, &mut out);
        let values: Vec<u16> = msp_port::rc_values(&out[0].payload).collect();
        assert_eq!(values, vec![1234, 1800, 1510, 1490, 1900, 1850]);
    }

    #[test]
    fn frame_aims_the_roll_through_rxrange() {
        let mut out = Vec::new();
        let range = RxRange::new(988, 2012).unwrap();
        msp::Decoder::default().push(&raw_rc_frame([0, 1, 3, 2], 1800, range, &[]), &mut out);
        let values: Vec<u16> = msp_port::rc_values(&out[0].payload).collect();
        assert_eq!(range.scale(values[0]), 1800);
    }
}

/// The stream against faithd's model of iNav on a board, over a simulated UART, in
/// simulated time: what iNav uses, millisecond by millisecond.
#[cfg(test)]
mod on_the_board {
    use std::sync::{Arc, Mutex};

    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    use super::*;
    use crate::transport::{Address, InProcessPort};
    use faithd_inav::msp::{InavMsp, Pilot, PortLog, Setup};

    /// A change to make to iNav at its next millisecond.
    type Change = Box<dyn FnOnce(&mut InavMsp) + Send>;

    /// What iNav used on roll, by daemon time, and the port's log.
    #[derive(Default)]
    struct Seen {
        roll: Vec<(i64, u16)>,
        throttle: Vec<(i64, u16)>,
        port: PortLog,
        /// Changes to make to iNav at its next millisecond (a configurator, the pilot).
        pending: Vec<Change>,
    }

    /// iNav's MSP port as a task: the pilot in AUTO, armed, in ANGLE.
    fn inav(clock: DaemonClock) -> (Endpoint, Arc<Mutex<Seen>>) {
        let (tx, mut sessions) = mpsc::unbounded_channel();
        let port = InProcessPort::new("inav-msp", move || {
            let (faithd, device) = tokio::io::duplex(16 * 1024);
            tx.send(device)
                .map_err(|_| std::io::Error::other("iNav has stopped"))?;
            Ok(Box::pin(faithd))
        });
        let seen = Arc::new(Mutex::new(Seen::default()));
        let out = seen.clone();
        tokio::spawn(async move {
            let mut fc = InavMsp::new(Setup::default(), clock.now_us());
            fc.set_pilot(Pilot::flying([
                1440, 1500, 1500, 1400, 1900, 1900, 1000, 1000,
            ]));
            let device = sessions.recv().await.expect("faithd opens the port");
            let (mut rx, mut tx) = tokio::io::split(device);
            let mut tick = tokio::time::interval(Duration::from_millis(1));
            let mut buf = [0u8; 512];
            // iNav runs on when faithd closes the port.
            let mut open = true;
            loop {
                tokio::select! {
                    biased;
                    _ = tick.tick() => {
                        let pending = std::mem::take(&mut out.lock().unwrap().pending);
                        for change in pending {
                            change(&mut fc);
                        }
                        fc.advance(clock.now_us());
                        let replies = fc.take_output();
                        if open && !replies.is_empty() && tx.write_all(&replies).await.is_err() {
                            open = false;
                        }
                        let mut seen = out.lock().unwrap();
                        seen.roll.push((clock.now_us(), fc.roll_in_use()));
                        seen.throttle.push((clock.now_us(), fc.channels_in_use()[3]));
                        seen.port = fc.log.clone();
                    }
                    got = rx.read(&mut buf), if open => match got {
                        Ok(0) | Err(_) => open = false,
                        Ok(n) => fc.receive(&buf[..n], clock.now_us()),
                    },
                }
            }
        });
        (Endpoint::new(Address::InProcess(port), 115_200), seen)
    }

    /// No OSD: the view never changes.
    fn no_view() -> watch::Receiver<PilotView> {
        watch::channel(PilotView::default()).1
    }

    fn settings() -> StreamSettings {
        let config = crate::config::FaithdConfig::default();
        StreamSettings {
            roll_period: Duration::from_millis(40),
            reply_timeout: Duration::from_millis(500),
            warmup_margin_us: 100_000,
            reconnect_min: Duration::from_millis(100),
            reconnect_max: Duration::from_secs(1),
            recheck: Duration::from_secs(5),
            expect: Expectations::new(&config.gate, &config.command, 1),
            roll_rxrange: RxRange::DEFAULT,
            hold_bound: Duration::from_millis(1750),
            osd: OsdConfig::default(),
        }
    }

    /// A stop while the set-up is still being read (a few hundred milliseconds after
    /// every open) is answered at once: no frame of faithd's reached iNav, so there is
    /// nothing to release, and the task ends without finishing the read.
    #[tokio::test(start_paused = true)]
    async fn a_stop_while_the_set_up_is_read_is_answered_at_once_with_nothing_written() {
        let clock = DaemonClock::simulated(0);
        let (endpoint, seen) = inav(clock);
        let heartbeat = crate::supervise::Supervisor::new(clock).register("stream");
        let stream = spawn(endpoint, settings(), clock, heartbeat, no_view());
        tokio::time::sleep(Duration::from_millis(30)).await;
        assert!(
            !seen.lock().unwrap().port.arrived.is_empty(),
            "the set-up read has begun"
        );
        let asked_us = clock.now_us();
        let (done, answer) = oneshot::channel();
        stream
            .stop
            .send(StopRequest { repeats: 3, done })
            .await
            .unwrap();
        let answer = answer.await.expect("the stream answers");
        assert!(
            matches!(answer, Err(ReleaseError::NotStarted)),
            "{answer:?}"
        );
        assert!(clock.now_us() - asked_us < 5_000, "answered after the read");
        assert!(stream.status.borrow().path.ready_at_us.is_none());
        assert!(stream.stop.is_closed(), "the stream task has ended");
        let seen = seen.lock().unwrap();
        assert!(
            seen.port
                .arrived
                .iter()
                .all(|(_, command)| *command != msp::MSP_SET_RAW_RC),
            "no roll frame reached iNav"
        );
    }

    /// Throttle added to iNav's override mask from another port while the pilot lowers
    /// it: iNav keeps the pilot's throttle of a report ago (never faithd's centre)
    /// until faithd notices, stops, and iNav's override times out; then the pilot's
    /// live stick. faithd reads the mask every 400 ms: the bound is that, a reply, and
    /// iNav's hold (0.2 s to notice + 0.2 s + failsafe_delay 0.5 s).
    #[tokio::test(start_paused = true)]
    async fn a_channel_added_to_the_override_keeps_the_pilots_value_until_faithd_lets_go() {
        let clock = DaemonClock::simulated(0);
        let (endpoint, seen) = inav(clock);
        let heartbeat = crate::supervise::Supervisor::new(clock).register("stream");
        let stream = spawn(endpoint, settings(), clock, heartbeat, no_view());
        tokio::time::sleep(Duration::from_millis(2300)).await;
        let changed_us = clock.now_us();
        seen.lock()
            .unwrap()
            .pending
            .push(Box::new(|fc: &mut InavMsp| {
                fc.setup.msp_override_channels = 0b1001;
                fc.set_pilot(Pilot::flying([
                    1440, 1500, 1500, 1300, 1900, 1900, 1000, 1000,
                ]));
            }));
        tokio::time::sleep(Duration::from_secs(3)).await;
        assert!(
            stream.status.borrow().path.setup_changed || stream.status.borrow().path.setup_refused
        );
        let seen = seen.lock().unwrap();
        let after: Vec<(i64, u16)> = seen
            .throttle
            .iter()
            .filter(|(t, _)| *t > changed_us)
            .copied()
            .collect();
        assert!(
            after.iter().all(|(_, v)| *v == 1400 || *v == 1300),
            "throttle only ever the pilot's: {:?}",
            after
                .iter()
                .map(|(_, v)| v)
                .collect::<std::collections::BTreeSet<_>>()
        );
        assert_eq!(
            after[0].1, 1400,
            "the frame's throttle, the pilot's of a report ago"
        );
        let back_us = after
            .iter()
            .find(|(_, v)| *v == 1300)
            .expect("the pilot's throttle back")
            .0;
        let held_us = back_us - changed_us;
        eprintln!(
            "measured (model): throttle added to the override: the pilot's of a report ago for {held_us} us, then the pilot's live stick"
        );
        assert!(
            held_us <= 400_000 + 2 * 20_000 + 900_000 + 20_000,
            "faithd's frame held throttle {held_us} us after the change"
        );
        assert!(
            after
                .iter()
                .filter(|(t, _)| *t >= back_us)
                .all(|(_, v)| *v == 1300)
        );
    }

    #[tokio::test(start_paused = true)]
    async fn a_roll_held_past_its_bound_is_dropped_by_the_stream_itself() {
        let clock = DaemonClock::simulated(0);
        let (endpoint, seen) = inav(clock);
        let heartbeat = crate::supervise::Supervisor::new(clock).register("stream");
        let stream = spawn(endpoint, settings(), clock, heartbeat, no_view());
        tokio::time::sleep(Duration::from_secs(2)).await;
        // A commander that sets a roll and never takes it back (stuck, or wrong).
        let raised_us = clock.now_us();
        stream.held.send_replace(1800);
        tokio::time::sleep(Duration::from_secs(4)).await;
        let seen = seen.lock().unwrap();
        let rolled_at = seen
            .roll
            .iter()
            .find(|(t, v)| *t >= raised_us && *v == 1800)
            .map(|(t, _)| *t)
            .expect("iNav used the roll");
        let back_at = seen
            .roll
            .iter()
            .find(|(t, v)| *t > rolled_at && *v != 1800)
            .map(|(t, _)| *t)
            .expect("the stream gave the roll back");
        let held_us = back_at - raised_us;
        assert!(
            (1_750_000..=1_750_000 + 80_000).contains(&held_us),
            "the roll held {held_us} us against a bound of 1.75 s"
        );
        assert!(
            seen.roll
                .iter()
                .filter(|(t, _)| *t >= back_at)
                .all(|(_, v)| *v == 1500),
            "the centre, not the pilot's stick nor the roll, after the bound"
        );
    }

    #[tokio::test(start_paused = true)]
    async fn the_stream_fits_the_boards_serial_task_and_loses_nothing() {
        let clock = DaemonClock::simulated(0);
        let (endpoint, seen) = inav(clock);
        let heartbeat = crate::supervise::Supervisor::new(clock).register("stream");
        let stream = spawn(endpoint, settings(), clock, heartbeat, no_view());
        // Rolls and releases in quick succession: every change is a roll frame first.
        for k in 0..40u64 {
            tokio::time::sleep(Duration::from_millis(100 + 7 * k)).await;
            stream
                .held
                .send_replace(if k % 2 == 0 { 1800 } else { 1500 });
        }
        tokio::time::sleep(Duration::from_secs(1)).await;
        let seen = seen.lock().unwrap();
        let port = &seen.port;
        assert_eq!(port.bytes_lost, 0);
        let arrived: Vec<i64> = port.arrived.iter().map(|(t, _)| *t).collect();
        let span_us = arrived.last().unwrap() - arrived[0];
        let mean_per_s = (arrived.len() - 1) as f64 * 1e6 / span_us as f64;
        assert!(mean_per_s <= 50.0, "{mean_per_s:.2} commands a second");
        for (i, t0) in arrived.iter().enumerate() {
            // A slot every 20 ms; a frame's time on the wire moves its arrival by a
            // fraction of a millisecond, so one second can hold 51 arrivals.
            let in_second = arrived[i..]
                .iter()
                .take_while(|t| **t < t0 + 1_000_000)
                .count();
            assert!(
                in_second <= 51,
                "{in_second} commands in the second from {t0}"
            );
            let served = port.served.iter().filter(|(t, _)| t <= t0).count();
            assert!(
                i + 1 - served <= 1,
                "{} requests waiting at {t0}",
                i + 1 - served
            );
        }
        // Each change reached iNav within a slot, its serial task and the wire.
        assert!(arrived.len() > 400, "{}", arrived.len());
    }
}
