//! `faithd bench pipeline`: the whole pipeline, window after window as the daemon's
//! pipeline thread runs it ([`Cycle`], load shedding included), on a stream of a
//! chosen event rate: what each stage costs per window, how many events per second
//! one core gets through, how often the cycle sheds load, and the process's peak
//! memory.
//!
//! The streams are generated (`faithd_core::synth::looming_edges`: a pole ahead of a
//! wall, both covered with random straight edges, with background noise), with as
//! many edges as it takes to reach the rate, or read from a recording.

use std::sync::Mutex;
use std::time::Instant;

use serde::Serialize;

use faithd_core::attitude::{AttitudeLog, AttitudeSample};
use faithd_core::camera::CameraIntrinsics;
use faithd_core::event::Event;
use faithd_core::pipeline::PipelineConfig;
use faithd_core::synth::{Layer, LoomingEdges, looming_edge_events_seen_by};
use faithd_daemon::clock::WallStageClock;
use faithd_daemon::cycle::{Cycle, DaemonConfig, WindowOutcome};

/// One stream's figures. Key names are published (`--json`): add, never rename.
#[derive(Clone, Debug, Serialize)]
pub struct RateReport {
    /// The stream's events per second, as generated or recorded.
    pub events_per_s: f64,
    pub windows: usize,
    pub events_per_window_p50: f64,
    pub events_per_window_p99: f64,
    /// Events per window that reached the flow (median), and the windows that had
    /// more than the event cap in force (`pipeline.flow.max_events_per_window`, or
    /// less under load shedding) and kept evenly spaced runs of them.
    pub flow_events_per_window_p50: f64,
    pub capped_windows: usize,
    /// Median per window of what the stages got to work on: the flow's new vectors,
    /// the vectors the FOE took (tight ones of the history) and DBSCAN's points. A
    /// stage's low cost means little when it had nothing to do.
    pub new_vectors_p50: f64,
    pub foe_vectors_p50: f64,
    pub clustered_p50: f64,
    /// Per stage (flow, derotation, FOE, TTC, clustering, decision) and the whole
    /// window: p50 and p99 microseconds of this machine's wall clock.
    pub stages_us: Vec<StageFigures>,
    pub window_us_p50: f64,
    pub window_us_p99: f64,
    /// Events the pipeline got through per second of its own compute.
    pub throughput_events_per_s: f64,
    /// Windows over `daemon.budget_us` (compute times `cpu_scale`), and run shed.
    pub overruns: usize,
    pub shed_windows: usize,
    pub max_load_level: u32,
    /// Microseconds (p50, p99; this machine) the pipeline thread took to take a
    /// window's events from the camera's batch into its own buffer: memory traffic
    /// outside the window's compute, done while it waits for the period's end (16
    /// bytes an event: 26 MB a window at 165 Mev/s).
    pub take_us_p50: f64,
    pub take_us_p99: f64,
    /// Windows whose compute (times `cpu_scale`) ran past the period: in flight the
    /// next period would have been skipped, its events going to the window after.
    /// 0 means the pipeline kept up with the stream, window for window.
    pub late_windows: usize,
    /// The longest a window would have waited, microseconds, had the windows been
    /// queued back to back instead: 0 when every window ended within its period.
    pub backlog_us_max: i64,
    /// The process's peak resident memory during the run (VmHWM, reset before it),
    /// bytes: the pipeline's buffers, the process itself and the stream being read.
    pub peak_rss_bytes: Option<u64>,
    /// The stream's own size in memory, bytes, within that peak.
    pub stream_bytes: u64,
}

#[derive(Clone, Debug, Serialize)]
pub struct StageFigures {
    pub stage: &'static str,
    pub p50_us: f64,
    pub p99_us: f64,
}

/// A looming stream of about `events_per_s` for `seconds`, as `camera` sees it: the
/// looming scene of the flow benchmark (laid out for the DVS240 preset, scaled to
/// the camera's pixels) with its edges multiplied until the rate is reached.
pub fn generated_stream(
    camera: &CameraIntrinsics,
    events_per_s: f64,
    seconds: f64,
    seed: u64,
) -> Vec<Event> {
    let scene = |scale: f64| LoomingEdges {
        foe_px: (130.0, 85.0),
        layers: vec![
            Layer {
                tau0_s: seconds + 1.0,
                rect_px: Some((118.0, -1e4, 142.0, 1e4)),
                edges: (30.0 * scale).ceil() as usize,
            },
            Layer {
                tau0_s: seconds + 3.0,
                rect_px: None,
                edges: (60.0 * scale).ceil() as usize,
            },
        ],
        duration_s: seconds,
        jitter_us: 50.0,
        noise_rate_hz: 0.5,
    };
    let probe = looming_edge_events_seen_by(camera, &scene(1.0), seed);
    let probe_rate = probe.len() as f64 / seconds;
    drop(probe);
    let scale = (events_per_s / probe_rate.max(1.0)).max(0.01);
    looming_edge_events_seen_by(camera, &scene(scale), seed)
}

/// Runs `events` through the daemon's cycle, one window per `daemon.period_us`,
/// shedding load when a window's compute times `cpu_scale` overruns the budget.
///
/// Every window gets its own period's events, whatever the one before cost: that
/// measures what each window costs. What a late window would have done in flight is
/// counted instead (`late_windows`, `backlog_us_max`): the daemon never queues
/// windows, it skips the periods a late one overran (`Cycle::next_period`).
pub fn run(
    events: &[Event],
    pipeline: PipelineConfig,
    daemon: DaemonConfig,
    cpu_scale: f64,
) -> RateReport {
    let (Some(first), Some(last)) = (events.first(), events.last()) else {
        return Tally::default().report(events, daemon.period_us);
    };
    reset_peak_rss();
    let (start_us, end_us) = (first.t_us, last.t_us);
    let attitude = Mutex::new(level_flight(start_us, end_us + daemon.period_us));
    let mut cycle = Cycle::new(pipeline, daemon, start_us);
    let mut clock = WallStageClock::new();
    let mut tally = Tally::default();
    let mut next = 0;
    let mut window_end_us = start_us + daemon.period_us;
    while window_end_us <= end_us + daemon.period_us {
        let end = next + events[next..].partition_point(|e| e.t_us <= window_end_us);
        let batch = events[next..end].to_vec();
        let taking = Instant::now();
        cycle.take(batch, window_end_us, None);
        tally.takes.push(taking.elapsed().as_secs_f64() * 1e6);
        let outcome = cycle.run_window(window_end_us, &attitude, &mut clock, false);
        let charged_us = (outcome.measured_ns as f64 / 1e3 * cpu_scale).round() as i64;
        tally.window(end - next, &outcome, charged_us, &daemon);
        if cycle.load_level() > 0 {
            tally.shed += 1;
        }
        cycle.account(charged_us, window_end_us);
        tally.max_level = tally.max_level.max(cycle.load_level());
        next = end;
        window_end_us += daemon.period_us;
    }
    tally.report(events, end_us - start_us)
}

/// Stage names in the order of `Tally::per_stage`.
const STAGES: [&str; 6] = ["flow", "derotation", "foe", "ttc", "clustering", "decision"];

/// The windows' figures as they come.
#[derive(Default)]
struct Tally {
    per_stage: [Vec<f64>; 6],
    totals: Vec<f64>,
    /// Microseconds the pipeline thread took to take each window's events.
    takes: Vec<f64>,
    /// Events of each window that reached the flow, and windows over the event cap.
    kept: Vec<f64>,
    capped: usize,
    sizes: Vec<f64>,
    /// New vectors, FOE vectors, clustered points.
    work: [Vec<f64>; 3],
    overruns: usize,
    shed: usize,
    max_level: u32,
    late: usize,
    backlog_us: i64,
    backlog_us_max: i64,
}

impl Tally {
    /// One window of `events` events that cost `charged_us`.
    fn window(
        &mut self,
        events: usize,
        outcome: &WindowOutcome,
        charged_us: i64,
        daemon: &DaemonConfig,
    ) {
        self.sizes.push(events as f64);
        let w = outcome.work;
        self.kept.push((w.events - w.skipped) as f64);
        if w.skipped > 0 {
            self.capped += 1;
        }
        for (list, count) in self
            .work
            .iter_mut()
            .zip([w.new_vectors, w.foe_vectors, w.clustered])
        {
            list.push(count as f64);
        }
        let t = outcome.timings;
        let stage_ns = [
            t.flow_ns,
            t.derotate_ns,
            t.foe_ns,
            t.ttc_ns,
            t.cluster_ns,
            t.decide_ns,
        ];
        for (list, ns) in self.per_stage.iter_mut().zip(stage_ns) {
            list.push(ns as f64 / 1e3);
        }
        self.totals.push(outcome.measured_ns as f64 / 1e3);
        if charged_us > daemon.budget_us {
            self.overruns += 1;
        }
        if charged_us > daemon.period_us {
            self.late += 1;
        }
        // Lindley's recursion: the wait of the next window were they queued.
        self.backlog_us = (self.backlog_us + charged_us - daemon.period_us).max(0);
        self.backlog_us_max = self.backlog_us_max.max(self.backlog_us);
    }

    /// The report of a run over `events`, which spanned `span_us`.
    fn report(mut self, events: &[Event], span_us: i64) -> RateReport {
        let compute_s = self.totals.iter().sum::<f64>() / 1e6;
        let stages_us = STAGES
            .iter()
            .zip(self.per_stage)
            .map(|(stage, mut v)| {
                v.sort_by(f64::total_cmp);
                StageFigures {
                    stage,
                    p50_us: quantile(&v, 0.5),
                    p99_us: quantile(&v, 0.99),
                }
            })
            .collect();
        let events_done = self.sizes.iter().sum::<f64>();
        self.totals.sort_by(f64::total_cmp);
        self.sizes.sort_by(f64::total_cmp);
        self.takes.sort_by(f64::total_cmp);
        self.kept.sort_by(f64::total_cmp);
        let [new_vectors_p50, foe_vectors_p50, clustered_p50] = self.work.map(|mut v| {
            v.sort_by(f64::total_cmp);
            quantile(&v, 0.5)
        });
        RateReport {
            events_per_s: events.len() as f64 / (span_us.max(1) as f64 * 1e-6),
            windows: self.totals.len(),
            events_per_window_p50: quantile(&self.sizes, 0.5),
            events_per_window_p99: quantile(&self.sizes, 0.99),
            flow_events_per_window_p50: quantile(&self.kept, 0.5),
            capped_windows: self.capped,
            new_vectors_p50,
            foe_vectors_p50,
            clustered_p50,
            stages_us,
            window_us_p50: quantile(&self.totals, 0.5),
            window_us_p99: quantile(&self.totals, 0.99),
            throughput_events_per_s: if compute_s > 0.0 {
                events_done / compute_s
            } else {
                0.0
            },
            overruns: self.overruns,
            shed_windows: self.shed,
            max_load_level: self.max_level,
            take_us_p50: quantile(&self.takes, 0.5),
            take_us_p99: quantile(&self.takes, 0.99),
            late_windows: self.late,
            backlog_us_max: self.backlog_us_max,
            peak_rss_bytes: peak_rss_bytes(),
            stream_bytes: std::mem::size_of_val(events) as u64,
        }
    }
}

/// A level, unrotating vehicle's attitude every 20 ms: the streams have no rotation.
fn level_flight(start_us: i64, end_us: i64) -> AttitudeLog {
    let mut log = AttitudeLog::default();
    let mut t_us = start_us - 100_000;
    while t_us <= end_us + 100_000 {
        log.push(AttitudeSample {
            t_us,
            roll_rad: 0.0,
            pitch_rad: 0.0,
            yaw_rad: 0.0,
            roll_rate_rad_s: 0.0,
            pitch_rate_rad_s: 0.0,
            yaw_rate_rad_s: 0.0,
        });
        t_us += 20_000;
    }
    log
}

/// Nearest-rank quantile of sorted values; 0 for none.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let rank = (q * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// Starts VmHWM afresh from the current resident size (Linux: `clear_refs` 5), so
/// each stream's peak is its own and not the largest stream's generation.
fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// VmHWM of /proc/self/status, bytes; `None` where there is no such file.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_generated_stream_has_about_the_rate_asked_for() {
        let events = generated_stream(&CameraIntrinsics::dvs240(), 500_000.0, 0.2, 1);
        let rate = events.len() as f64 / 0.2;
        assert!((350_000.0..700_000.0).contains(&rate), "{rate}");
        assert!(events.windows(2).all(|w| w[0].t_us <= w[1].t_us));
    }

    #[test]
    fn a_run_reports_every_window_and_sheds_on_a_slow_board() {
        let events = generated_stream(&CameraIntrinsics::dvs240(), 500_000.0, 0.2, 1);
        let here = run(
            &events,
            PipelineConfig::default(),
            DaemonConfig::default(),
            1.0,
        );
        assert!(here.windows >= 20, "{here:?}");
        assert!(here.window_us_p50 > 0.0 && here.throughput_events_per_s > 0.0);
        assert_eq!(here.stages_us.len(), 6);
        // A board 10,000 times slower overruns every window and sheds to the floor.
        let slow = run(
            &events,
            PipelineConfig::default(),
            DaemonConfig::default(),
            1e4,
        );
        assert_eq!(slow.overruns, slow.windows);
        assert!(slow.max_load_level >= 3, "{slow:?}");
        // Every window ran past its period: in flight each would skip periods, and a
        // queue of them would only grow.
        assert_eq!(slow.late_windows, slow.windows);
        assert!(slow.backlog_us_max > 1_000_000, "{slow:?}");
        assert!(here.peak_rss_bytes.is_some());
    }
}
