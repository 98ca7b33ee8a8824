//! The pipeline as a task in simulated time: the same [`Cycle`] as the flight
//! thread, on the simulation's paused clock. Each window's compute is done at once
//! (simulated time stands still meanwhile) and then charged: the task sleeps the
//! time the target board would have needed ([`ComputeCharge`]) before the window's
//! decision and health leave, and that time decides overruns and load shedding as
//! it would on the board.

use std::sync::mpsc::TryRecvError;
use std::time::Duration;

use tokio::sync::mpsc::UnboundedSender;

use super::compute::ComputeCharge;
use super::{Cycle, CycleIo, DaemonConfig};
use crate::clock::{DaemonClock, WallStageClock};
use faithd_core::pipeline::PipelineConfig;

/// What a simulated flight's harness hears from the pipeline.
#[derive(Default)]
pub struct SimulatedTaps {
    /// Every cycle's charged time, for the simulation's figures.
    pub cycles: Option<UnboundedSender<CycleReport>>,
    /// Every window as a video frame.
    pub frames: Option<UnboundedSender<crate::video::Frame>>,
}

/// Runs until the simulated camera hangs up or `io.stop` is set, telling `taps`.
pub async fn run_simulated(
    pipeline_config: PipelineConfig,
    config: DaemonConfig,
    clock: DaemonClock,
    io: CycleIo,
    charge: ComputeCharge,
    taps: SimulatedTaps,
) {
    debug_assert!(
        clock.is_simulated(),
        "a simulated pipeline needs the simulated clock"
    );
    let mut cycle = Cycle::new(pipeline_config, config, clock.now_us());
    if let Some(frames) = taps.frames {
        cycle.tap_windows(Box::new(move |events, report| {
            let _ = frames.send(crate::video::Frame::of_window(events, report));
        }));
    }
    let report = taps.cycles;
    let mut stage_clock = WallStageClock::new();
    let recording = io.outputs.recorder.is_some();
    let mut next_us = clock.now_us() + config.period_us;
    loop {
        if io.stop.load(std::sync::atomic::Ordering::Acquire) {
            return;
        }
        sleep_until_us(&clock, next_us).await;
        // Every batch the camera has delivered by now.
        loop {
            match io.events.try_recv() {
                Ok(batch) => cycle.take(batch, clock.now_us(), io.outputs.recorder.as_ref()),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => {
                    tracing::debug!("simulated camera ended; pipeline task stops");
                    return;
                }
            }
        }
        let started_us = clock.now_us();
        let outcome = cycle.run_window(started_us, &io.attitude, &mut stage_clock, recording);
        let charged_us = charge.charge_us(&outcome.work, outcome.measured_ns);
        // The board is busy this long; events keep arriving meanwhile.
        sleep_until_us(&clock, started_us + charged_us).await;
        let work = outcome.work;
        cycle.publish(outcome, &io.outputs);
        // The board's time, not the timer's (tokio's fire on whole milliseconds).
        let now_us = clock.now_us();
        cycle.account(charged_us, now_us);
        cycle.report_telemetry(&io.outputs);
        if let Some(tx) = &report {
            let _ = tx.send(CycleReport {
                started_us,
                charged_us,
                work,
                load_level: cycle.load_level(),
            });
        }
        next_us = cycle.next_period(next_us, now_us);
    }
}

/// One simulated cycle, as charged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CycleReport {
    pub started_us: i64,
    pub charged_us: i64,
    pub work: super::Work,
    /// The load level after the cycle (0 = full load).
    pub load_level: u32,
}

async fn sleep_until_us(clock: &DaemonClock, t_us: i64) {
    let now_us = clock.now_us();
    if t_us > now_us {
        tokio::time::sleep(Duration::from_micros((t_us - now_us) as u64)).await;
    }
}
