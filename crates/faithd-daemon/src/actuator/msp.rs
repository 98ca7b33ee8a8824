//! The MSP route: iNav's MSP RC override, streamed by [`crate::command::stream`]
//! after [`crate::command::fc_check`] judged the set-up. What is iNav's here and
//! nowhere above the seam: the stream's timings from faithd.toml, the roll aimed
//! through `rxrange` (and what iNav therefore reports using), and the release
//! written from outside the stream when its task is gone.

use std::time::Duration;

use tokio::sync::{mpsc, oneshot, watch};

use super::RouteStatus;
use crate::clock::DaemonClock;
use crate::command::fc_check::{Expectations, RouteFacts};
use crate::command::rxrange::RxRange;
use crate::command::stream::{self, ReleaseError, StopRequest, StreamHandle, StreamSettings};
use crate::config::FaithdConfig;
use crate::supervise::Heartbeat;
use crate::transport::Endpoint;
use faithd_core::osd::PilotView;

/// How much longer than a roll lasts the stream holds it before it reverts to the
/// centre on its own: the commander releases within a few milliseconds of the end.
pub const HOLD_MARGIN_US: i64 = 250_000;

/// What the MSP route keeps for its release.
pub struct MspRoute {
    stop: mpsc::Sender<StopRequest>,
    facts: watch::Receiver<Option<RouteFacts>>,
    endpoint: Endpoint,
    roll_rxrange: RxRange,
    release_repeats: u32,
    /// One roll frame period: the release's frames go out this far apart.
    period: Duration,
}

/// Starts the stream task on `endpoint`.
pub(super) fn start(
    config: &FaithdConfig,
    endpoint: Endpoint,
    clock: DaemonClock,
    heartbeat: Heartbeat,
    view: watch::Receiver<PilotView>,
) -> (watch::Sender<u16>, watch::Receiver<RouteStatus>, MspRoute) {
    let settings = stream_settings(config);
    let StreamHandle {
        held,
        status,
        facts,
        stop,
    } = stream::spawn(endpoint.clone(), settings, clock, heartbeat, view);
    let route = MspRoute {
        stop,
        facts,
        endpoint,
        roll_rxrange: config.command.roll_rxrange_us,
        release_repeats: config.manoeuvre.release_repeats,
        period: Duration::from_micros(config.manoeuvre.resend_period_us.max(1) as u64),
    };
    (held, status, route)
}

/// The stream's knobs, from faithd.toml.
pub fn stream_settings(config: &FaithdConfig) -> StreamSettings {
    let us = |v: i64| Duration::from_micros(v.max(1) as u64);
    StreamSettings {
        roll_period: us(config.manoeuvre.resend_period_us),
        reply_timeout: us(config.command.msp_timeout_us),
        warmup_margin_us: config.command.warmup_margin_us,
        reconnect_min: us(config.mavlink.reconnect_min_us),
        reconnect_max: us(config.mavlink.reconnect_max_us),
        recheck: Duration::from_secs(5),
        expect: Expectations::new(
            &config.gate,
            &config.command,
            config.mavlink.autopilot_system_id,
        )
        .with_telemetry_over_msp(config.telemetry.is_msp()),
        roll_rxrange: config.command.roll_rxrange_us,
        hold_bound: us(config.pipeline.decision.roll_duration_us + HOLD_MARGIN_US),
        osd: config.osd,
    }
}

/// Why the stream did not write the release itself.
enum NotReleased {
    /// The stream is alive and not streaming: nothing of faithd's for iNav to hold.
    NothingHeld(ReleaseError),
    /// The stream task is gone or stuck: the release is written from outside.
    StreamGone(&'static str),
}

impl MspRoute {
    /// Ends the stream with the centre and says in the journal what reached the
    /// wire. When the stream task is gone (it panicked) or does not answer, the port
    /// is opened afresh and the centre written from here.
    pub async fn release_on_exit(&self, status: &watch::Receiver<RouteStatus>) {
        let streaming = status.borrow().path.ready_at_us.is_some();
        let facts = *self.facts.borrow();
        let why = match self.ask_the_stream().await {
            Ok(n) => {
                tracing::info!("roll channel released: {n} centre frames written to iNav");
                return;
            }
            // The stream is alive and not streaming (the port is down, or the set-up
            // was refused or changed): iNav has no frame of faithd's to hold, and a
            // frame written now could land on a set-up faithd refused.
            Err(NotReleased::NothingHeld(why)) => {
                tracing::info!("roll channel: nothing to release ({why})");
                return;
            }
            Err(NotReleased::StreamGone(why)) => why,
        };
        let Some(facts) = facts.filter(|_| streaming) else {
            tracing::info!("roll channel: nothing to release ({why}; faithd was not streaming)");
            return;
        };
        tracing::error!(
            "roll channel release through the stream failed ({why}): writing it directly"
        );
        match stream::release_directly(
            &self.endpoint,
            facts,
            self.roll_rxrange,
            self.release_repeats,
            self.period,
        )
        .await
        {
            Ok(n) => tracing::info!("roll channel released: {n} centre frames written to iNav"),
            Err(e) => tracing::error!(
                "roll channel release not written ({e}): iNav keeps faithd's last value until its MSP override times out"
            ),
        }
    }

    /// Asks the stream task to release; how many centre frames it wrote.
    async fn ask_the_stream(&self) -> Result<u32, NotReleased> {
        let (done, answer) = oneshot::channel();
        let request = StopRequest {
            repeats: self.release_repeats,
            done,
        };
        if self.stop.try_send(request).is_err() {
            return Err(NotReleased::StreamGone("the MSP stream task has ended"));
        }
        match tokio::time::timeout(Duration::from_secs(1), answer).await {
            Ok(Ok(Ok(n))) => Ok(n),
            Ok(Ok(Err(why))) => Err(NotReleased::NothingHeld(why)),
            Ok(Err(_)) => Err(NotReleased::StreamGone("the MSP stream task has ended")),
            Err(_) => Err(NotReleased::StreamGone(
                "the MSP stream did not answer within 1 s",
            )),
        }
    }
}
