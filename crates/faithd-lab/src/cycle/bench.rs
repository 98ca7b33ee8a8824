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

use serde::Serialize;

use faithd_core::attitude::{AttitudeLog, AttitudeSample};
use faithd_core::camera::CameraIntrinsics;
use faithd_core::event::Event;
use faithd_core::pipeline::PipelineConfig;
use faithd_core::synth::{Layer, LoomingEdges, looming_edge_events};
use faithd_daemon::clock::WallStageClock;
use faithd_daemon::cycle::{Cycle, DaemonConfig};

/// One stream's figures. Key names are published (`--json`): add, never rename.
#[derive(Clone, Debug, Serialize)]
pub struct RateReport {
    /// The stream's events per second, as generated or recorded.
    pub events_per_s: f64,
    pub windows: usize,
    pub events_per_window_p50: f64,
    pub events_per_window_p99: f64,
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

/// A looming stream of about `events_per_s` for `seconds`: the looming scene of the
/// flow benchmark with its edges multiplied until the rate is reached.
pub fn generated_stream(events_per_s: f64, seconds: f64, seed: u64) -> Vec<Event> {
    let cam = CameraIntrinsics::dvs240();
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
    let probe = looming_edge_events(&cam, &scene(1.0), seed);
    let probe_rate = probe.len() as f64 / seconds;
    let scale = (events_per_s / probe_rate.max(1.0)).max(0.01);
    looming_edge_events(&cam, &scene(scale), seed)
}

/// Runs `events` through the daemon's cycle, one window per `daemon.period_us`,
/// shedding load when a window's compute times `cpu_scale` overruns the budget.
pub fn run(
    events: &[Event],
    pipeline: PipelineConfig,
    daemon: DaemonConfig,
    cpu_scale: f64,
) -> RateReport {
    let (Some(first), Some(last)) = (events.first(), events.last()) else {
        return empty_report();
    };
    reset_peak_rss();
    let (start_us, end_us) = (first.t_us, last.t_us);
    let attitude = Mutex::new(level_flight(start_us, end_us + daemon.period_us));
    let mut cycle = Cycle::new(pipeline, daemon, start_us);
    let mut clock = WallStageClock::new();
    let mut next = 0;
    let mut window_end_us = start_us + daemon.period_us;
    let (mut per_stage, mut totals, mut sizes) = (vec![Vec::new(); 6], Vec::new(), Vec::new());
    let (mut overruns, mut shed, mut max_level) = (0, 0, 0);
    let mut events_done = 0usize;
    let mut work: [Vec<f64>; 3] = Default::default();
    while window_end_us <= end_us + daemon.period_us {
        let end = next + events[next..].partition_point(|e| e.t_us <= window_end_us);
        cycle.take(events[next..end].to_vec(), window_end_us, None);
        sizes.push((end - next) as f64);
        events_done += end - next;
        next = end;
        let outcome = cycle.run_window(window_end_us, &attitude, &mut clock, false);
        let w = outcome.work;
        for (list, count) in work
            .iter_mut()
            .zip([w.new_vectors, w.foe_vectors, w.clustered])
        {
            list.push(count as f64);
        }
        let t = outcome.timings;
        for (k, ns) in [
            t.flow_ns,
            t.derotate_ns,
            t.foe_ns,
            t.ttc_ns,
            t.cluster_ns,
            t.decide_ns,
        ]
        .into_iter()
        .enumerate()
        {
            per_stage[k].push(ns as f64 / 1e3);
        }
        let total_us = outcome.measured_ns as f64 / 1e3;
        totals.push(total_us);
        let charged_us = (total_us * cpu_scale).round() as i64;
        if charged_us > daemon.budget_us {
            overruns += 1;
        }
        if cycle.load_level() > 0 {
            shed += 1;
        }
        cycle.account(charged_us, window_end_us);
        max_level = max_level.max(cycle.load_level());
        window_end_us += daemon.period_us;
    }
    let compute_s = totals.iter().sum::<f64>() / 1e6;
    let names = ["flow", "derotation", "foe", "ttc", "clustering", "decision"];
    let stages_us = names
        .iter()
        .zip(per_stage)
        .map(|(stage, mut v)| {
            v.sort_by(f64::total_cmp);
            StageFigures {
                stage,
                p50_us: quantile(&v, 0.5),
                p99_us: quantile(&v, 0.99),
            }
        })
        .collect();
    totals.sort_by(f64::total_cmp);
    sizes.sort_by(f64::total_cmp);
    let [new_vectors_p50, foe_vectors_p50, clustered_p50] = work.map(|mut v| {
        v.sort_by(f64::total_cmp);
        quantile(&v, 0.5)
    });
    RateReport {
        events_per_s: events.len() as f64 / ((end_us - start_us).max(1) as f64 * 1e-6),
        windows: totals.len(),
        events_per_window_p50: quantile(&sizes, 0.5),
        events_per_window_p99: quantile(&sizes, 0.99),
        new_vectors_p50,
        foe_vectors_p50,
        clustered_p50,
        stages_us,
        window_us_p50: quantile(&totals, 0.5),
        window_us_p99: quantile(&totals, 0.99),
        throughput_events_per_s: events_done as f64 / compute_s.max(1e-9),
        overruns,
        shed_windows: shed,
        max_load_level: max_level,
        peak_rss_bytes: peak_rss_bytes(),
        stream_bytes: std::mem::size_of_val(events) as u64,
    }
}

fn empty_report() -> RateReport {
    RateReport {
        events_per_s: 0.0,
        windows: 0,
        events_per_window_p50: 0.0,
        events_per_window_p99: 0.0,
        new_vectors_p50: 0.0,
        foe_vectors_p50: 0.0,
        clustered_p50: 0.0,
        stages_us: Vec::new(),
        window_us_p50: 0.0,
        window_us_p99: 0.0,
        throughput_events_per_s: 0.0,
        overruns: 0,
        shed_windows: 0,
        max_load_level: 0,
        peak_rss_bytes: peak_rss_bytes(),
        stream_bytes: 0,
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
        let events = generated_stream(500_000.0, 0.2, 1);
        let rate = events.len() as f64 / 0.2;
        assert!((350_000.0..700_000.0).contains(&rate), "{rate}");
        assert!(events.windows(2).all(|w| w[0].t_us <= w[1].t_us));
    }

    #[test]
    fn a_run_reports_every_window_and_sheds_on_a_slow_board() {
        let events = generated_stream(500_000.0, 0.2, 1);
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
        assert!(here.peak_rss_bytes.is_some());
    }
}
