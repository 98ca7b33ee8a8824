//! The actuator seam: the one interface through which the daemon reaches the
//! autopilot's roll, whatever the route.
//!
//! The daemon starts a route ([`start`]), sets the value it holds
//! ([`Actuator::held`]: the centre, or a roll), reads its autopilot-neutral status
//! ([`Actuator::status`]: the core's [`RouteStatus`], which the gate and the commander
//! take as they are), and has it release the roll on the way out
//! ([`Actuator::release_on_exit`]). Nothing outside this module names a route.
//!
//! One route flies today: iNav's MSP RC override ([`msp`], on the wire of
//! [`crate::command`]). A second route (MAVLink to ArduPilot or PX4, iNav 10's
//! flight-axis override, ...) is one module beside `msp.rs` here, with its own
//! `start` returning the held value's watch and a [`RouteStatus`] watch and its own
//! release, plus one arm: a `[command.sink] kind` in [`crate::command::Sink`] (with
//! its checks in `CommandConfig::validate_route`) and a [`Route`] variant matched
//! in [`start`] and [`Actuator::release_on_exit`].

pub mod msp;

use tokio::sync::watch;

use crate::clock::DaemonClock;
use crate::command::Sink;
use crate::config::FaithdConfig;
use crate::supervise::Heartbeat;
use crate::transport::Endpoint;
pub use faithd_core::osd::PilotView;
pub use faithd_core::safety::commander::{ReportedRoll, RouteStatus};

/// A started route to the autopilot, as the daemon holds it.
pub struct Actuator {
    /// The roll value the autopilot should use (its centre when idle): the
    /// commander sets it, the route carries it.
    held: watch::Sender<u16>,
    status: watch::Receiver<RouteStatus>,
    route: Route,
}

/// The routes faithd can fly, each with what it needs to release the roll.
enum Route {
    Msp(msp::MspRoute),
}

/// Starts the route `[command.sink]` names, on `endpoint` (the caller's: a serial
/// port in flight, an in-process UART in the lab); `heartbeat` is the route task's
/// beat for the watchdog; `view` what the pilot's OSD is to show of faithd.
pub fn start(
    config: &FaithdConfig,
    endpoint: Endpoint,
    clock: DaemonClock,
    heartbeat: Heartbeat,
    view: watch::Receiver<PilotView>,
) -> Actuator {
    match &config.command.sink {
        Sink::Msp(_) => {
            let (held, status, route) = msp::start(config, endpoint, clock, heartbeat, view);
            Actuator {
                held,
                status,
                route: Route::Msp(route),
            }
        }
    }
}

/// What the autopilot on the configured route reports using for each roll, for the
/// commander's roll check (iNav: the roll as it lands through its `rxrange`).
pub fn reported_roll(config: &FaithdConfig) -> ReportedRoll {
    match &config.command.sink {
        Sink::Msp(_) => config
            .command
            .roll_rxrange_us
            .reported_roll(&config.manoeuvre),
    }
}

impl Actuator {
    /// The watch the commander sets: the roll value the autopilot should use.
    pub fn held(&self) -> watch::Sender<u16> {
        self.held.clone()
    }

    /// The route's autopilot-neutral status, for the gate and the commander.
    pub fn status(&self) -> watch::Receiver<RouteStatus> {
        self.status.clone()
    }

    /// Ends the route with the roll at the centre and says in the journal what
    /// reached the wire; when the route's task is gone, the release is written from
    /// here.
    pub async fn release_on_exit(&self) {
        match &self.route {
            Route::Msp(route) => route.release_on_exit(&self.status).await,
        }
    }
}
