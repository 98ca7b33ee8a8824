//! The simulation commands (feature `sim`): `demo`, `sim` and `bench`, on the
//! built-in simulator. The flight build has none of them.

use std::path::{Path, PathBuf};

use clap::Args;

use faithd::config::FaithdConfig;
use faithd_core::pipeline::StageClock;

use crate::Failure;

/// `faithd demo`: the closed loop by default, or the pipeline alone (`--open-loop`).
#[derive(Args)]
pub struct DemoArgs {
    /// Seed of the scene and of FAITH's draws.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Where the course passes the pole: metres right (+) or left (-) of its centre.
    #[arg(long, default_value_t = 0.1, allow_negative_numbers = true)]
    offset_m: f64,
    /// Keep the pilot's switch in MANUAL: faithd must not act (the vehicle hits).
    #[arg(long, conflicts_with = "open_loop")]
    manual: bool,
    /// Print the outcome as one JSON object.
    #[arg(long)]
    json: bool,
    /// Where to draw the trajectory.
    #[arg(long, default_value = "out/demo/flight.png")]
    plot: PathBuf,
    /// Instead: the pipeline alone, open loop, on generated events (stage timings).
    /// The closed loop's course, switch and plot do not apply to it.
    #[arg(long, conflicts_with_all = ["offset_m", "manual", "plot"])]
    open_loop: bool,
    /// Open loop only: decision period, microseconds.
    #[arg(long, default_value_t = 10_000, requires = "open_loop",
          value_parser = clap::value_parser!(i64).range(1_000..=1_000_000))]
    window_us: i64,
}

/// `faithd sim`.
#[derive(Args)]
pub struct SimArgs {
    #[arg(long, default_value_t = 100)]
    runs: usize,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
    /// Fly the same flights straight, without the daemon and faster than real
    /// time, and report where the decision rule would have rolled (a proxy for
    /// tuning it over many seeds; see faithd::closed_loop::straight).
    #[arg(long)]
    straight: bool,
    /// With --straight: the pipeline settings to judge (`[pipeline]` of a
    /// faithd.toml); the defaults otherwise.
    #[arg(long, requires = "straight")]
    config: Option<PathBuf>,
}

/// `faithd bench foe`.
#[derive(Args)]
pub struct BenchFoeArgs {
    /// Number of simulated trajectories.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..))]
    trajectories: u32,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Directory for the figures (foe_errors.png, foe_frame.png).
    #[arg(long, default_value = "out/bench-foe")]
    plot_dir: PathBuf,
    /// Also fly every third trajectory with body rotation (exercises derotation).
    #[arg(long)]
    rotation: bool,
}

/// `faithd demo`: the closed loop, or the pipeline alone with `--open-loop`.
pub fn demo(args: &DemoArgs) -> Result<(), Failure> {
    if args.open_loop {
        open_loop_demo(args.seed, args.window_us, args.json)
    } else {
        closed_loop_demo(args)
    }
}

/// `faithd sim`: the closed-loop experiment, or its straight-flight proxy.
pub fn sim(args: &SimArgs) -> Result<(), Failure> {
    if args.straight {
        sim_straight(args.runs, args.seed, args.config.as_deref(), args.json)
    } else {
        sim_closed_loop(args.runs, args.seed, args.json)
    }
}

fn closed_loop_demo(args: &DemoArgs) -> Result<(), Failure> {
    let (seed, offset_m, manual, json) = (args.seed, args.offset_m, args.manual, args.json);
    let plot = args.plot.as_path();
    let spec = faithd::closed_loop::FlightSpec {
        lateral_offset_m: offset_m,
        pilot_auto: !manual,
        seed,
        ..Default::default()
    };
    eprintln!(
        "faithd demo: the daemon flies a simulated quadrotor at a pole ({} m/s, course {:+.2} m from its centre), simulated iNav over MAVLink on loopback UDP; switch {}",
        spec.speed_m_s,
        spec.lateral_offset_m,
        if manual {
            "stays in MANUAL"
        } else {
            "to AUTO at 0.5 s"
        }
    );
    let outcome = faithd::closed_loop::fly(&spec)
        .map_err(|e| Failure::failed(format!("cannot fly the demo: {e}")))?;
    if let Some(dir) = plot.parent() {
        let _ = std::fs::create_dir_all(dir);
    }
    let plotted = faithd::closed_loop::plot::plot_flight(&outcome, plot);
    if json {
        let mut value = serde_json::to_value(&outcome).expect("outcome serialises");
        value.as_object_mut().map(|o| o.remove("path"));
        println!("{value}");
    } else {
        println!("faithd demo: closed-loop flight at a pole");
        println!(
            "  course: {} ({:+.2} m from the pole's centre; contact below {:.2} m)",
            if outcome.collision_course {
                "collision"
            } else {
                "near pass"
            },
            spec.lateral_offset_m,
            faithd::closed_loop::FlightSpec::contact_distance_m()
        );
        match (outcome.decision_s, outcome.ttc_at_decision_s) {
            (Some(t), Some(ttc)) => println!(
                "  roll decided at {t:.2} s of flight, true time to contact then {ttc:.2} s; first roll frame at the autopilot {:.1} ms after the deciding event",
                outcome.latency_ms.unwrap_or(f64::NAN)
            ),
            _ => println!("  no roll commanded"),
        }
        println!(
            "  result: {}, closest gap between vehicle and pole {:.2} m",
            if outcome.collided {
                "HIT the pole"
            } else {
                "no contact"
            },
            outcome.min_clearance_m
        );
        match &plotted {
            Ok(()) => println!("  trajectory: {}", plot.display()),
            Err(e) => println!("  trajectory not drawn: {e}"),
        }
    }
    Ok(())
}

fn sim_closed_loop(runs: usize, seed: u64, json: bool) -> Result<(), Failure> {
    use faithd::closed_loop::experiment;
    let specs = experiment::plan(runs, seed);
    let mut outcomes = Vec::with_capacity(runs);
    for (i, spec) in specs.iter().enumerate() {
        match faithd::closed_loop::fly(spec) {
            Ok(o) => {
                eprintln!(
                    "[{}/{}] {} offset {:+.2} m, heading {:+.1} deg, {:.1} m/s: {}{}{}",
                    i + 1,
                    runs,
                    if o.collision_course {
                        "collision course"
                    } else {
                        "near pass       "
                    },
                    spec.lateral_offset_m,
                    spec.heading_deg,
                    spec.speed_m_s,
                    if o.collided { "HIT" } else { "clear" },
                    match (o.rolled, roll_ttc_s(&o)) {
                        (true, Some((measured, truth))) => format!(
                            ", rolled at {:.2} s of flight, TTC {measured:.2} s measured, {truth:.2} s true",
                            o.decision_s.unwrap_or(f64::NAN)
                        ),
                        (true, None) => ", rolled".into(),
                        (false, _) => String::new(),
                    },
                    match o.latency_ms {
                        Some(ms) =>
                            format!(", first roll frame {ms:.1} ms after the deciding event"),
                        None => String::new(),
                    }
                );
                if let (false, Some(d)) = (o.collision_course, &o.decision) {
                    eprintln!("    rolled on a near pass: {d}");
                }
                outcomes.push(o);
            }
            Err(e) => {
                return Err(Failure::failed(format!(
                    "flight {} failed to run: {e}",
                    i + 1
                )));
            }
        }
    }
    let summary = experiment::summarise(&outcomes, seed);
    if json {
        println!(
            "{}",
            serde_json::to_string(&summary).expect("summary serialises")
        );
    } else {
        println!(
            "faithd sim: {} closed-loop flights, seed {}",
            summary.runs, summary.seed
        );
        println!(
            "  collision courses {}: avoided {} ({:.1}%)",
            summary.collision_courses,
            summary.avoided,
            100.0 * summary.success_rate
        );
        println!(
            "  near passes {}: false avoidances {} ({:.1}%), contacts {}",
            summary.near_passes,
            summary.false_avoidances,
            100.0 * summary.false_avoidances as f64 / summary.near_passes.max(1) as f64,
            summary.near_pass_contacts
        );
        println!(
            "  latency, deciding event to first roll frame: p50 {:.1} ms, p99 {:.1} ms",
            summary.latency_ms_p50, summary.latency_ms_p99
        );
        println!(
            "  true TTC at the roll (median): {:.2} s",
            summary.ttc_at_decision_s_p50
        );
    }
    Ok(())
}

fn sim_straight(runs: usize, seed: u64, config: Option<&Path>, json: bool) -> Result<(), Failure> {
    use faithd::closed_loop::{experiment, straight};
    let config = match config.map(FaithdConfig::load).transpose() {
        Ok(c) => c.unwrap_or_default().pipeline,
        Err(e) => {
            return Err(Failure::refused(e));
        }
    };
    let specs = experiment::plan(runs, seed);
    let outcomes = straight::fly_all(&specs, &config, 2);
    for (i, o) in outcomes.iter().enumerate() {
        let what = match (&o.roll, o.collision_course) {
            (None, true) => "collision course: NO ROLL".to_string(),
            (Some(r), true) if !o.avoided() => {
                format!(
                    "collision course: LATE, rolled at true TTC {:.2} s: {}",
                    r.true_ttc_s, r.decision
                )
            }
            (Some(r), false) => {
                format!(
                    "near pass: rolled at true TTC {:.2} s: {}",
                    r.true_ttc_s, r.decision
                )
            }
            _ => continue,
        };
        eprintln!(
            "[{}] offset {:+.2} m: {what}",
            i + 1,
            o.spec.lateral_offset_m
        );
    }
    let s = straight::summarise(&outcomes, seed);
    if json {
        println!("{}", serde_json::to_string(&s).expect("summary serialises"));
    } else {
        println!("faithd sim --straight: {} flights, seed {}", s.runs, s.seed);
        println!(
            "  collision courses {}: rolled in time {}, late {}, no roll {}",
            s.collision_courses, s.avoided, s.late, s.no_roll
        );
        println!(
            "  near passes {}: false avoidances {} ({:.1}%)",
            s.near_passes,
            s.false_avoidances,
            100.0 * s.false_avoidances as f64 / s.near_passes.max(1) as f64
        );
    }
    Ok(())
}

fn open_loop_demo(seed: u64, window_us: i64, json: bool) -> Result<(), Failure> {
    let summary = faithd_sim::demo::run(
        seed,
        window_us,
        &mut MonotonicClock(std::time::Instant::now()),
    );
    if json {
        println!(
            "{}",
            serde_json::to_string(&summary).expect("summary serialises")
        );
        return Ok(());
    }
    println!("faithd demo: open-loop approach to a pole (generated events, real pipeline)");
    println!(
        "  events {}, windows {} of {} ms",
        summary.events,
        summary.windows,
        window_us / 1000
    );
    println!(
        "  true FOE ({:.0}, {:.0}) px, pole TTC {:.2} s at start",
        summary.true_foe_px.0, summary.true_foe_px.1, summary.pole_ttc_at_start_s
    );
    match &summary.first_roll {
        Some(d) => {
            println!(
                "  first decision to avoid at t = {:.0} ms: {d}",
                d.t_us as f64 / 1e3
            );
            println!(
                "  true pole TTC then {:.2} s; FOE error {:.1} px",
                summary.true_ttc_at_roll_s.unwrap_or(f64::NAN),
                summary.foe_error_px_at_roll.unwrap_or(f64::NAN)
            );
        }
        None => println!("  no avoidance decided (the pole was never judged close and ahead)"),
    }
    println!(
        "  pipeline time per window: mean {:.0} us, max {:.0} us",
        summary.mean_window_us, summary.max_window_us
    );
    let s = summary.mean_stage_us;
    println!(
        "  per stage (mean us): flow {:.0}, derotation {:.0}, FOE {:.0}, TTC {:.0}, clustering {:.0}, decision {:.0}",
        s[0], s[1], s[2], s[3], s[4], s[5]
    );
    Ok(())
}

/// The TTC the roll was decided on and the true one at that moment.
fn roll_ttc_s(o: &faithd::closed_loop::FlightOutcome) -> Option<(f64, f64)> {
    let measured = match o.decision?.reason {
        faithd_core::decide::Reason::ObstacleAhead { ttc_s, .. } => ttc_s,
        _ => return None,
    };
    Some((measured, o.ttc_at_decision_s?))
}

pub fn bench_foe(args: &BenchFoeArgs) -> Result<(), Failure> {
    let (trajectories, seed, json) = (args.trajectories as usize, args.seed, args.json);
    let (threads, plot_dir, rotation) = (args.threads, args.plot_dir.as_path(), args.rotation);
    let mut options = faithd_sim::bench::foe::BenchFoeOptions {
        trajectories,
        seed,
        rotation,
        ..Default::default()
    };
    if let Some(t) = threads {
        options.threads = t.max(1);
    }
    let started = std::time::Instant::now();
    let report = faithd_sim::bench::foe::run(&options, &|done, t| {
        eprintln!(
            "[{done}/{trajectories}] {:<9} course {:>6.1} deg{}{}: {} events, {:.0} vectors/window, {:.1} s",
            t.scene.name(),
            t.course_deg,
            if t.sway { ", sway" } else { "" },
            if t.rotating { ", rotating" } else { "" },
            t.events,
            t.mean_vectors,
            started.elapsed().as_secs_f64()
        );
    });
    if json {
        println!(
            "{}",
            serde_json::to_string(&report).expect("report serialises")
        );
    } else {
        print!("{}", report.table());
    }
    write_bench_figures(&report, plot_dir).map_err(Failure::failed)
}

fn write_bench_figures(
    report: &faithd_sim::bench::foe::BenchFoeReport,
    dir: &Path,
) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let errors = dir.join("foe_errors.png");
    faithd_sim::bench::plot::plot_errors(report, &errors).map_err(|e| e.to_string())?;
    eprintln!("wrote {}", errors.display());
    if let Some(frame) = &report.example {
        let path = dir.join("foe_frame.png");
        faithd_sim::bench::plot::plot_frame(frame, &path).map_err(|e| e.to_string())?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// The process's monotonic clock, for stage timings.
struct MonotonicClock(std::time::Instant);

impl StageClock for MonotonicClock {
    fn now_ns(&mut self) -> u64 {
        self.0.elapsed().as_nanos() as u64
    }
}
