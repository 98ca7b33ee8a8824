//! The `faithd` command: one binary for the daemon, the tools and the experiments.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};

use faithd::config::FaithdConfig;
use faithd::pipeline::StageClock;

/// The process's monotonic clock, for stage timings.
struct MonotonicClock(std::time::Instant);

impl StageClock for MonotonicClock {
    fn now_ns(&mut self) -> u64 {
        self.0.elapsed().as_nanos() as u64
    }
}

fn closed_loop_demo(args: &DemoArgs) -> ExitCode {
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
    let outcome = match faithd::closed_loop::fly(&spec) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: cannot fly the demo: {e}");
            return Exit::Failed.into();
        }
    };
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
    Exit::Ok.into()
}

fn sim(runs: usize, seed: u64, json: bool) -> ExitCode {
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
                eprintln!("error: flight {} failed to run: {e}", i + 1);
                return Exit::Failed.into();
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
    Exit::Ok.into()
}

fn sim_straight(runs: usize, seed: u64, config: Option<&std::path::Path>, json: bool) -> ExitCode {
    use faithd::closed_loop::{experiment, straight};
    let config = match config.map(FaithdConfig::load).transpose() {
        Ok(c) => c.unwrap_or_default().pipeline,
        Err(e) => {
            eprintln!("error: {e}");
            return Exit::Refused.into();
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
    Exit::Ok.into()
}

fn demo(seed: u64, window_us: i64, json: bool) -> ExitCode {
    let summary = faithd::demo::run(
        seed,
        window_us,
        &mut MonotonicClock(std::time::Instant::now()),
    );
    if json {
        println!(
            "{}",
            serde_json::to_string(&summary).expect("summary serialises")
        );
        return Exit::Ok.into();
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
    Exit::Ok.into()
}

/// faithd's exit statuses (docs/design.md, Commands): scripts and the systemd unit
/// read them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Exit {
    Ok = 0,
    /// Could not do the job: a fault, a task that ended, an I/O error on output.
    Failed = 1,
    /// Refused: bad configuration or input, a missing library, a camera that does
    /// not match the configuration. The unit does not restart on it.
    Refused = 2,
    /// A replay whose windows decide otherwise than the flight did.
    Differs = 3,
}

impl From<Exit> for ExitCode {
    fn from(exit: Exit) -> Self {
        ExitCode::from(exit as u8)
    }
}

#[derive(Parser)]
#[command(
    name = "faithd",
    version,
    about = "Event-camera obstacle avoidance for small drones"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The main job, no hardware: the daemon flies a simulated quadrotor at a pole
    /// against a simulated iNav over MAVLink, in closed loop and real time.
    Demo(DemoArgs),
    /// The closed-loop avoidance experiment: many flights, success and false-avoidance rates.
    Sim {
        #[arg(long, default_value_t = 100)]
        runs: usize,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
        /// Fly the same flights straight, without the daemon and faster than real
        /// time, and report where the decision rule would have rolled (a proxy for
        /// tuning it over many seeds; see closed_loop::straight).
        #[arg(long)]
        straight: bool,
        /// With --straight: the pipeline settings to judge (`[pipeline]` of a
        /// faithd.toml); the defaults otherwise.
        #[arg(long, requires = "straight")]
        config: Option<std::path::PathBuf>,
    },
    /// Experiments on the built-in simulator.
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
    /// The flight daemon: camera, pipeline, safety gate and MAVLink to the autopilot.
    Run {
        /// Path to faithd.toml.
        #[arg(long, default_value = "/etc/faithd/faithd.toml")]
        config: PathBuf,
        /// Accept `source.kind = "sim"`: rolls commanded from a simulated camera.
        /// For the bench and tests only; the service never passes it.
        #[arg(long)]
        simulated_camera: bool,
    },
    /// Recorded events (and attitude) through the same pipeline: one line per window.
    Replay(ReplayArgs),
    /// Validate a config file: prints `ok` or the key and the reason it is refused.
    CheckConfig {
        /// Path to faithd.toml.
        path: PathBuf,
    },
    /// Read the flight controller's set-up over its MSP port (`command.msp_endpoint`)
    /// and say whether faithd's roll route can work, naming the iNav CLI line that
    /// fixes each problem. Exit 0 when it can, 2 when it is refused, 1 when the flight
    /// controller cannot be read. `faithd run` does the same check before its gate
    /// can open.
    CheckFc {
        /// Path to faithd.toml.
        #[arg(long)]
        config: PathBuf,
        /// One JSON object instead of the table.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Table I of the paper: all four FOE methods on simulated flights.
    Foe(BenchFoeArgs),
}

/// `faithd demo`: the closed loop by default, or the pipeline alone (`--open-loop`).
#[derive(Args)]
struct DemoArgs {
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

/// `faithd replay`: a recording through the pipeline, or a daemon recording checked
/// window by window against its flight (`--windows`).
#[derive(Args)]
struct ReplayArgs {
    /// Event file: AEDAT 4.0, 3.1, 2.0 or the datasets' text format.
    #[arg(long)]
    events: PathBuf,
    /// Attitude from a MAVLink telemetry log (ATTITUDE messages).
    #[arg(long, conflicts_with = "imu")]
    mavlink: Option<PathBuf>,
    /// Added to ATTITUDE's time_boot_ms (in us) to reach the events' clock.
    #[arg(long, default_value_t = 0, allow_negative_numbers = true)]
    attitude_offset_us: i64,
    /// Attitude from a text dataset's imu.txt.
    #[arg(long)]
    imu: Option<PathBuf>,
    /// Pipeline settings (default: the built-in defaults).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Window (decision period), microseconds; default daemon.period_us.
    #[arg(long, value_parser = clap::value_parser!(i64).range(1..))]
    window_us: Option<i64>,
    /// The window log of a daemon recording (`*.windows.jsonl`): replay its windows
    /// exactly as the daemon ran them (window ends, event counts, load shedding,
    /// logged pipeline settings unless --config), put the .tlog on the daemon clock
    /// by itself, and check every window against the live decision (exit 3 if any
    /// differs).
    #[arg(long, conflicts_with_all = ["imu", "window_us", "attitude_offset_us"])]
    windows: Option<PathBuf>,
    /// One JSON object per window.
    #[arg(long)]
    json: bool,
}

/// `faithd bench foe`.
#[derive(Args)]
struct BenchFoeArgs {
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

fn bench_foe(args: &BenchFoeArgs) -> ExitCode {
    let (trajectories, seed, json) = (args.trajectories as usize, args.seed, args.json);
    let (threads, plot_dir, rotation) = (args.threads, args.plot_dir.as_path(), args.rotation);
    let mut options = faithd::bench::foe::BenchFoeOptions {
        trajectories,
        seed,
        rotation,
        ..Default::default()
    };
    if let Some(t) = threads {
        options.threads = t.max(1);
    }
    let started = std::time::Instant::now();
    let report = faithd::bench::foe::run(&options, &|done, t| {
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
    if let Err(e) = write_bench_figures(&report, plot_dir) {
        eprintln!("error: {e}");
        return Exit::Failed.into();
    }
    Exit::Ok.into()
}

fn write_bench_figures(
    report: &faithd::bench::foe::BenchFoeReport,
    dir: &std::path::Path,
) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let errors = dir.join("foe_errors.png");
    faithd::bench::plot::plot_errors(report, &errors).map_err(|e| e.to_string())?;
    eprintln!("wrote {}", errors.display());
    if let Some(frame) = &report.example {
        let path = dir.join("foe_frame.png");
        faithd::bench::plot::plot_frame(frame, &path).map_err(|e| e.to_string())?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// The TTC the roll was decided on and the true one at that moment.
fn roll_ttc_s(o: &faithd::closed_loop::FlightOutcome) -> Option<(f64, f64)> {
    let measured = match o.decision?.reason {
        faithd::decide::Reason::ObstacleAhead { ttc_s, .. } => ttc_s,
        _ => return None,
    };
    Some((measured, o.ttc_at_decision_s?))
}

fn replay(args: &ReplayArgs) -> ExitCode {
    let (events, mavlink, imu) = (
        args.events.as_path(),
        args.mavlink.as_deref(),
        args.imu.as_deref(),
    );
    let (attitude_offset_us, config, window_us, json) = (
        args.attitude_offset_us,
        args.config.as_deref(),
        args.window_us,
        args.json,
    );
    use faithd::replay::AttitudeInput;
    let config = match config.map(FaithdConfig::load).transpose() {
        Ok(c) => c.unwrap_or_default(),
        Err(e) => {
            eprintln!("error: {e}");
            return Exit::Refused.into();
        }
    };
    // The command line and the config checks both keep this positive.
    let window_us = window_us.unwrap_or(config.daemon.period_us);
    let attitude = match (mavlink, imu) {
        (Some(path), _) => AttitudeInput::Tlog {
            path,
            offset_us: attitude_offset_us,
        },
        (None, Some(path)) => AttitudeInput::Imu(path),
        (None, None) => {
            eprintln!("note: no --mavlink or --imu: derotation is off for this replay");
            AttitudeInput::None
        }
    };
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    match faithd::replay::replay(events, attitude, config.pipeline, window_us, json, &mut out) {
        Ok(_) => Exit::Ok.into(),
        Err(e) => {
            let _ = std::io::Write::flush(&mut out);
            eprintln!("error: {e}");
            Exit::Refused.into()
        }
    }
}

fn replay_window_log(args: &ReplayArgs, log: &std::path::Path) -> ExitCode {
    let (events, mavlink) = (args.events.as_path(), args.mavlink.as_deref());
    let (config, json) = (args.config.as_deref(), args.json);
    let pipeline = match config.map(FaithdConfig::load).transpose() {
        Ok(c) => c.map(|c| c.pipeline),
        Err(e) => {
            eprintln!("error: {e}");
            return Exit::Refused.into();
        }
    };
    if mavlink.is_none() {
        eprintln!("note: no --mavlink: replaying without the recorded attitude");
    }
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let result = faithd::replay::replay_window_log(events, mavlink, log, pipeline, json, &mut out);
    let _ = std::io::Write::flush(&mut out);
    match result {
        Ok(r) if r.differing == 0 => {
            eprintln!(
                "replayed {} windows: every one as decided in flight",
                r.windows
            );
            Exit::Ok.into()
        }
        Ok(r) => {
            let (t_us, why) = r.first_difference.unwrap_or_default();
            eprintln!(
                "replayed {} windows: {} differ from the flight; the first at {t_us} us ({why})",
                r.windows, r.differing
            );
            Exit::Differs.into()
        }
        Err(e) => {
            eprintln!("error: {e}");
            Exit::Refused.into()
        }
    }
}

fn run(path: &std::path::Path, options: faithd::daemon::RunOptions) -> ExitCode {
    let config = match FaithdConfig::load(path) {
        Ok(c) => c,
        Err(e) => {
            tracing::error!("refusing to start: {e}");
            return Exit::Refused.into();
        }
    };
    match faithd::daemon::run(config, options) {
        Ok(()) => Exit::Ok.into(),
        Err(e @ faithd::daemon::DaemonError::Config { .. }) => {
            tracing::error!("refusing to start: {e}");
            Exit::Refused.into()
        }
        Err(e) => {
            tracing::error!("{e}");
            Exit::Failed.into()
        }
    }
}

fn check_fc(path: &std::path::Path, json: bool) -> ExitCode {
    use faithd::command::fc_check;
    let config = match FaithdConfig::load(path) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            return Exit::Refused.into();
        }
    };
    let report = match fc_check::check_over_msp(&config) {
        Ok(r) => r,
        Err(e) => {
            eprintln!(
                "error: cannot read the flight controller on {}: {e}",
                config.command.msp_endpoint
            );
            return Exit::Failed.into();
        }
    };
    if json {
        let items: Vec<_> = report
            .items
            .iter()
            .map(|i| {
                serde_json::json!({
                    "check": i.what, "found": i.found, "ok": i.problem.is_none(),
                    "problem": i.problem, "fix": i.fix,
                })
            })
            .collect();
        let route = report.route.map(|r| {
            serde_json::json!({
                "warmup_us": r.warmup_us,
                "hold_after_stop_us": r.hold_after_stop_us,
                "attitude_period_us": r.attitude_period_us,
                "rc_period_us": r.rc_period_us,
                "roll_frame_index": r.roll_frame_index,
            })
        });
        println!(
            "{}",
            serde_json::json!({"ok": report.route.is_some(), "checks": items, "route": route})
        );
    } else {
        for i in &report.items {
            match &i.problem {
                None => println!("ok    {}: {}", i.what, i.found),
                Some(p) => {
                    println!("FAIL  {}: {}: {p}", i.what, i.found);
                    if let Some(fix) = &i.fix {
                        println!("      fix (iNav CLI): {fix}");
                    }
                }
            }
        }
        match report.route {
            Some(_) => println!("flight controller set-up: ok for faithd's roll route"),
            None => println!("flight controller set-up: refused; faithd will not command"),
        }
    }
    if report.route.is_some() {
        Exit::Ok.into()
    } else {
        Exit::Refused.into()
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // The experiment flies the daemon a hundred times: only its warnings, by default.
    let default_filter = match cli.command {
        Command::Sim { .. } => "warn",
        // The demo shows the daemon's gate and manoeuvre lines, not every decision.
        Command::Demo(_) => "info,faithd::daemon::cycle=warn",
        _ => "info",
    };
    let _log = faithd::logging::init(default_filter);
    match cli.command {
        Command::Demo(args) => {
            if args.open_loop {
                demo(args.seed, args.window_us, args.json)
            } else {
                closed_loop_demo(&args)
            }
        }
        Command::Sim {
            runs,
            seed,
            json,
            straight: false,
            ..
        } => sim(runs, seed, json),
        Command::Sim {
            runs,
            seed,
            json,
            straight: true,
            config,
        } => sim_straight(runs, seed, config.as_deref(), json),
        Command::Bench {
            what: BenchCommand::Foe(args),
        } => bench_foe(&args),
        Command::Run {
            config,
            simulated_camera,
        } => run(&config, faithd::daemon::RunOptions { simulated_camera }),
        Command::Replay(args) => match &args.windows {
            Some(log) => replay_window_log(&args, log),
            None => replay(&args),
        },
        Command::CheckFc { config, json } => check_fc(&config, json),
        Command::CheckConfig { path } => match FaithdConfig::load(&path) {
            Ok(_) => {
                println!("{}: ok", path.display());
                Exit::Ok.into()
            }
            Err(e) => {
                eprintln!("error: {e}");
                Exit::Refused.into()
            }
        },
    }
}
