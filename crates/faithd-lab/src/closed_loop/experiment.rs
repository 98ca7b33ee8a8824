//! `faithd sim`: the paper's onboard experiment (section IV) and more, in closed loop.
//!
//! The paper flew 25 runs at one 50 cm pole from 12 starting positions and headings,
//! 60% on collision courses and 40% near passes, and avoided 20 (80%). Here every run
//! draws its course offset, heading, speed, one or two poles, texture contrast and
//! sensor noise from the seed; 60% are collision courses.

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::Serialize;

use super::{FlightOutcome, FlightSpec, FlyOptions, fly};

/// Draws `runs` flights from `seed`.
pub fn plan(runs: usize, seed: u64) -> Vec<FlightSpec> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let contact = FlightSpec::contact_distance_m();
    (0..runs)
        .map(|i| {
            let collision = (i % 5) < 3;
            let side = if rng.random_range(0..2) == 0 {
                -1.0
            } else {
                1.0
            };
            let lateral_offset_m = if collision {
                side * rng.random_range(0.0..contact - 0.05)
            } else {
                side * rng.random_range(contact + 0.25..1.3)
            };
            let mut poles = vec![(0.0, 0.0)];
            if rng.random_range(0.0..1.0) < 0.3 {
                // A second pole beyond and to one side: scenery, not in the way.
                let s = if rng.random_range(0..2) == 0 {
                    -1.0
                } else {
                    1.0
                };
                poles.push((rng.random_range(1.5..3.0), s * rng.random_range(1.8..2.8)));
            }
            FlightSpec {
                poles,
                lateral_offset_m,
                heading_deg: rng.random_range(-10.0..10.0),
                speed_m_s: rng.random_range(1.5..2.5),
                start_distance_m: rng.random_range(5.0..6.0),
                contrast: rng.random_range(0.5..1.0),
                noise_rate_hz: rng.random_range(0.2..1.0),
                seed: seed.wrapping_mul(1000).wrapping_add(i as u64),
                ..Default::default()
            }
        })
        .collect()
}

/// Flies every spec, `threads` at a time, each flight on its own simulated-time
/// runtime; `done` hears each outcome as it lands (in any order). Outcomes come
/// back in spec order and do not depend on `threads`. Flight `filmed` (an index
/// into `specs`) keeps its frames for a video.
pub fn fly_all(
    specs: &[FlightSpec],
    options: &FlyOptions,
    threads: usize,
    filmed: Option<usize>,
    done: impl Fn(usize, &FlightOutcome) + Sync,
) -> Result<Vec<FlightOutcome>, String> {
    let next = std::sync::atomic::AtomicUsize::new(0);
    let slots: Vec<std::sync::Mutex<Option<FlightOutcome>>> =
        specs.iter().map(|_| std::sync::Mutex::new(None)).collect();
    let failure = std::sync::Mutex::new(None::<String>);
    std::thread::scope(|s| {
        for _ in 0..threads.clamp(1, specs.len().max(1)) {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    if i >= specs.len() || failure.lock().expect("failure lock").is_some() {
                        return;
                    }
                    let options = FlyOptions {
                        film: filmed == Some(i),
                        ..*options
                    };
                    match fly(&specs[i], &options) {
                        Ok(o) => {
                            done(i, &o);
                            *slots[i].lock().expect("slot lock") = Some(o);
                        }
                        Err(e) => {
                            *failure.lock().expect("failure lock") =
                                Some(format!("flight {} failed to run: {e}", i + 1));
                        }
                    }
                }
            });
        }
    });
    if let Some(why) = failure.into_inner().expect("failure lock") {
        return Err(why);
    }
    Ok(slots
        .into_iter()
        .map(|s| {
            s.into_inner()
                .expect("slot lock")
                .expect("every flight flown")
        })
        .collect())
}

/// The experiment's figures. Key names are published (docs/design.md, Commands): add,
/// never rename.
#[derive(Clone, Debug, Serialize)]
pub struct SimSummary {
    pub runs: usize,
    pub collision_courses: usize,
    /// Collision courses flown without contact.
    pub avoided: usize,
    pub near_passes: usize,
    /// Near passes on which faithd rolled anyway.
    pub false_avoidances: usize,
    /// avoided / collision_courses.
    pub success_rate: f64,
    /// Newest event of the deciding window to the roll in use at the autopilot.
    pub latency_ms_p50: f64,
    pub latency_ms_p99: f64,
    pub seed: u64,
    /// Near passes that touched the pole (a roll toward it would do that).
    pub near_pass_contacts: usize,
    /// True time to contact when the roll started, collision courses, median.
    pub ttc_at_decision_s_p50: f64,
    /// The same latency from the first roll call of the run that led to the roll:
    /// with the time the safety gate held the roll.
    pub latency_from_first_call_ms_p50: f64,
    pub latency_from_first_call_ms_p99: f64,
    /// The camera and the board: "dvs" or "line", the cpu scale, "model" or
    /// "measured" (a measured run is not repeatable).
    pub camera: super::CameraKind,
    pub cpu_scale: f64,
    pub compute: &'static str,
    /// The pipeline's cycles over all flights, as charged in simulated time.
    pub cycles: usize,
    pub cycle_ms_p50: f64,
    pub cycle_ms_p99: f64,
    pub overruns: usize,
    pub shed_cycles: usize,
    pub dropped_batches: u64,
    /// Seconds of flight simulated, and the events the camera fired in them.
    pub simulated_s: f64,
    pub events: u64,
}

pub fn summarise(outcomes: &[FlightOutcome], seed: u64, options: &FlyOptions) -> SimSummary {
    let courses: Vec<_> = outcomes.iter().filter(|o| o.collision_course).collect();
    let near: Vec<_> = outcomes.iter().filter(|o| !o.collision_course).collect();
    let avoided = courses.iter().filter(|o| !o.collided).count();
    let sorted = |values: Vec<f64>| {
        let mut v = values;
        v.sort_by(f64::total_cmp);
        v
    };
    let latencies = sorted(outcomes.iter().filter_map(|o| o.latency_ms).collect());
    let from_first = sorted(
        outcomes
            .iter()
            .filter_map(|o| o.latency_from_first_call_ms)
            .collect(),
    );
    let ttcs = sorted(courses.iter().filter_map(|o| o.ttc_at_decision_s).collect());
    // Cycle percentiles over flights: the median of the flights' medians, the
    // highest of their p99s.
    let cycle_p50 = sorted(outcomes.iter().map(|o| o.pipeline.charged_us_p50).collect());
    let sum = |f: fn(&FlightOutcome) -> usize| outcomes.iter().map(f).sum::<usize>();
    SimSummary {
        runs: outcomes.len(),
        collision_courses: courses.len(),
        avoided,
        near_passes: near.len(),
        false_avoidances: near.iter().filter(|o| o.rolled).count(),
        success_rate: if courses.is_empty() {
            0.0
        } else {
            avoided as f64 / courses.len() as f64
        },
        latency_ms_p50: percentile(&latencies, 0.5),
        latency_ms_p99: percentile(&latencies, 0.99),
        seed,
        near_pass_contacts: near.iter().filter(|o| o.collided).count(),
        ttc_at_decision_s_p50: percentile(&ttcs, 0.5),
        latency_from_first_call_ms_p50: percentile(&from_first, 0.5),
        latency_from_first_call_ms_p99: percentile(&from_first, 0.99),
        camera: outcomes
            .first()
            .map_or_else(Default::default, |o| o.spec.camera),
        cpu_scale: options.compute.cpu_scale(),
        compute: match options.compute {
            crate::cycle::compute::ComputeCharge::Model { .. } => "model",
            crate::cycle::compute::ComputeCharge::Measured { .. } => "measured",
        },
        cycles: sum(|o| o.pipeline.cycles),
        cycle_ms_p50: percentile(&cycle_p50, 0.5) / 1e3,
        cycle_ms_p99: outcomes
            .iter()
            .map(|o| o.pipeline.charged_us_p99)
            .fold(f64::NAN, f64::max)
            / 1e3,
        overruns: sum(|o| o.pipeline.overruns),
        shed_cycles: sum(|o| o.pipeline.shed_cycles),
        dropped_batches: outcomes.iter().map(|o| o.pipeline.dropped_batches).sum(),
        simulated_s: outcomes
            .iter()
            .map(|o| o.path.last().map_or(0.0, |p| p.t_s))
            .sum(),
        events: outcomes.iter().map(|o| o.events).sum(),
    }
}

/// Nearest-rank percentile of sorted values; NaN for none.
pub fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let rank = (q * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plan_is_deterministic_and_sixty_percent_collision_courses() {
        let a = plan(100, 7);
        assert_eq!(a, plan(100, 7));
        let courses = a.iter().filter(|s| s.is_collision_course()).count();
        assert_eq!(courses, 60);
        assert!(
            a.iter()
                .filter(|s| !s.is_collision_course())
                .all(|s| s.lateral_offset_m.abs() > 0.6)
        );
    }

    #[test]
    fn percentiles_by_nearest_rank() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 0.5), 50.0);
        assert_eq!(percentile(&v, 0.99), 99.0);
        assert!(percentile(&[], 0.5).is_nan());
    }
}
