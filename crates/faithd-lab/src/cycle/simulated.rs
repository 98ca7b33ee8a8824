//! The pipeline as a task in simulated time: the daemon's own driver
//! (`faithd_daemon::cycle::drive`, the one that flies) paced by the simulation's
//! paused clock. Each window's compute is done at once (simulated time stands still
//! meanwhile) and then charged: the task sleeps the time the target board would have
//! needed ([`ComputeCharge`]) before the window's decision and health leave, and that
//! time decides overruns and load shedding as it would on the board.

use std::sync::mpsc::{Receiver, TryRecvError};
use std::time::Duration;

use tokio::sync::mpsc::UnboundedSender;

use super::compute::ComputeCharge;
use faithd_core::event::Event;
use faithd_core::pipeline::PipelineConfig;
use faithd_daemon::clock::DaemonClock;
use faithd_daemon::cycle::{Cycle, CycleIo, DaemonConfig, Pacing, WindowOutcome, drive};
use faithd_daemon::daemon::PipelineTaskFn;

pub use faithd_daemon::cycle::CycleReport;

/// What a simulated flight's harness hears from the pipeline.
#[derive(Default)]
pub struct SimulatedTaps {
    /// Every cycle's charged time, for the simulation's figures.
    pub cycles: Option<UnboundedSender<CycleReport>>,
    /// Every window as a video frame.
    pub frames: Option<UnboundedSender<crate::video::Frame>>,
}

/// Simulated time: the camera's batches taken at each period's end, a window's
/// compute charged and waited out.
pub struct SimulatedPacing {
    clock: DaemonClock,
    charge: ComputeCharge,
    cycles: Option<UnboundedSender<CycleReport>>,
}

impl Pacing for SimulatedPacing {
    async fn wait_until(
        &mut self,
        until_us: i64,
        events: &mut Receiver<Vec<Event>>,
        take: &mut (dyn FnMut(Vec<Event>, i64) + Send),
    ) -> bool {
        sleep_until_us(&self.clock, until_us).await;
        // Every batch the camera has delivered by now.
        loop {
            match events.try_recv() {
                Ok(batch) => take(batch, self.clock.now_us()),
                Err(TryRecvError::Empty) => return true,
                Err(TryRecvError::Disconnected) => return false,
            }
        }
    }

    async fn computed(&mut self, started_us: i64, outcome: &WindowOutcome) -> i64 {
        let charged_us = self.charge.charge_us(&outcome.work, outcome.measured_ns);
        // The board is busy this long; events keep arriving meanwhile.
        sleep_until_us(&self.clock, started_us + charged_us).await;
        charged_us
    }

    fn cycled(&mut self, cycle: CycleReport) {
        if let Some(tx) = &self.cycles {
            let _ = tx.send(cycle);
        }
    }
}

/// The pipeline task of a simulated flight, for `daemon::Execution::Tasks`: the
/// daemon's driver with [`SimulatedPacing`], every window handed to `taps`.
pub fn pipeline_task(charge: ComputeCharge, taps: SimulatedTaps) -> PipelineTaskFn {
    Box::new(
        move |pipeline_config: PipelineConfig,
              config: DaemonConfig,
              clock: DaemonClock,
              io: CycleIo| {
            Box::pin(async move {
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
                let mut pacing = SimulatedPacing {
                    clock,
                    charge,
                    cycles: taps.cycles,
                };
                drive(cycle, clock, io, &mut pacing).await;
            })
        },
    )
}

async fn sleep_until_us(clock: &DaemonClock, t_us: i64) {
    let now_us = clock.now_us();
    if t_us > now_us {
        tokio::time::sleep(Duration::from_micros((t_us - now_us) as u64)).await;
    }
}
