//! `kind = "sim"`: generated approaches to a pole, played in real time on the daemon
//! clock. The camera for bench tests without hardware; `faithd run` takes it only
//! with `--simulated-camera`.

use std::sync::mpsc::TrySendError;
use std::time::Duration;

use serde::{Deserialize, Serialize};

use crate::source::SourceIo;
use faithd_core::camera::CameraIntrinsics;
use faithd_core::event::Event;
use faithd_core::synth::{LoomingEdges, looming_edge_events};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimSource {
    /// Daemon time of the first approach, and the period between approaches.
    pub first_approach_us: u64,
    pub repeat_us: u64,
    /// Seed of the generated events.
    pub seed: u64,
}

impl Default for SimSource {
    fn default() -> Self {
        Self {
            first_approach_us: 1_000_000,
            repeat_us: 5_000_000,
            seed: 1,
        }
    }
}

/// Batches are handed over this often.
const BATCH_PERIOD: Duration = Duration::from_millis(2);

/// Runs the sim source on the calling thread until the run stops or the receiver is
/// gone.
pub fn run_sim(config: SimSource, camera: CameraIntrinsics, io: SourceIo) {
    let SourceIo {
        clock,
        batches,
        stop,
    } = io;
    let mut scene = LoomingEdges::pole_ahead((128.0, 86.0));
    scene.duration_s = 0.8;
    scene.noise_rate_hz = 0.5;
    scene.jitter_us = 100.0;
    let approach = looming_edge_events(&camera, &scene, config.seed);
    let approach_us = (scene.duration_s * 1e6) as i64;
    let repeat_us = i64::try_from(config.repeat_us)
        .unwrap_or(i64::MAX)
        .max(approach_us + 1);
    tracing::info!(
        events = approach.len(),
        first_us = config.first_approach_us,
        repeat_us,
        "sim camera: approaches to a pole"
    );
    let mut start_us = i64::try_from(config.first_approach_us).unwrap_or(i64::MAX);
    let mut next = 0usize;
    let mut dropped = 0u64;
    let mut drop_log = crate::logging::Throttle::new(5_000_000);
    while !stop.wait_timeout(BATCH_PERIOD) {
        let now_us = clock.now_us();
        let mut batch = Vec::new();
        while now_us >= start_us {
            let due = approach[next..].partition_point(|e| e.t_us + start_us <= now_us);
            batch.extend(approach[next..next + due].iter().map(|e| Event {
                t_us: e.t_us + start_us,
                ..*e
            }));
            next += due;
            if next < approach.len() {
                break;
            }
            next = 0;
            start_us += repeat_us;
        }
        // An empty batch still says "the camera is alive".
        match batches.try_send(batch) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) => {
                dropped += 1;
                drop_log.event(clock.now_us(), |since| {
                    tracing::warn!(
                        dropped,
                        since_last_line = since,
                        "pipeline not keeping up: event batch dropped"
                    )
                });
            }
            Err(TrySendError::Disconnected(_)) => return,
        }
    }
}
