//! Event sources for the daemon. `sim` plays generated approaches to a pole in
//! real time on the daemon clock: the camera for bench tests and demos without
//! hardware. (Live cameras and recorded files join here.)

use std::sync::mpsc::{SyncSender, TrySendError};
use std::time::Duration;

use serde::{Deserialize, Serialize};

use super::clock::DaemonClock;
use faithd_core::camera::CameraIntrinsics;
use faithd_core::event::Event;
use faithd_core::synth::{LoomingEdges, looming_edge_events};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SourceKind {
    /// The DVS240/DAVIS240 on USB through libcaer (opened at run time).
    #[default]
    Caer,
    /// Generated approaches to a pole, played in real time: the bench and tests only,
    /// and `faithd run` takes it only with `--simulated-camera`.
    Sim,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SourceConfig {
    pub kind: SourceKind,
    /// caer: where libcaer is; empty = the system loader's search for libcaer.so.3.
    pub libcaer_path: String,
    /// caer: libcaer settings applied after its defaults, as [module, parameter,
    /// value] (biases and filters; see libcaer's davis.h for the addresses).
    pub caer_settings: Vec<(i8, u8, u32)>,
    /// sim: daemon time of the first approach, and the period between approaches.
    pub sim_first_approach_us: i64,
    pub sim_repeat_us: i64,
    /// sim: seed of the generated events.
    pub sim_seed: u64,
}

impl Default for SourceConfig {
    fn default() -> Self {
        Self {
            kind: SourceKind::Caer,
            libcaer_path: String::new(),
            caer_settings: Vec::new(),
            sim_first_approach_us: 1_000_000,
            sim_repeat_us: 5_000_000,
            sim_seed: 1,
        }
    }
}

/// Batches are handed over this often.
const BATCH_PERIOD: Duration = Duration::from_millis(2);

/// Runs the sim source on the calling thread until the receiver is gone.
pub fn run_sim(
    config: SourceConfig,
    camera: CameraIntrinsics,
    clock: DaemonClock,
    batches: SyncSender<Vec<Event>>,
) {
    let mut scene = LoomingEdges::pole_ahead((128.0, 86.0));
    scene.duration_s = 0.8;
    scene.noise_rate_hz = 0.5;
    scene.jitter_us = 100.0;
    let approach = looming_edge_events(&camera, &scene, config.sim_seed);
    let approach_us = (scene.duration_s * 1e6) as i64;
    let repeat_us = config.sim_repeat_us.max(approach_us + 1);
    tracing::info!(
        events = approach.len(),
        first_us = config.sim_first_approach_us,
        repeat_us,
        "sim camera: approaches to a pole"
    );
    let mut start_us = config.sim_first_approach_us;
    let mut next = 0usize;
    let mut dropped = 0u64;
    let mut drop_log = super::cycle::Throttle::new(5_000_000);
    loop {
        std::thread::sleep(BATCH_PERIOD);
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
