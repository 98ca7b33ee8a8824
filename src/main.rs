//! The `faithd` command: one binary for the daemon, the tools and the experiments.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use faithd::config::FaithdConfig;
use faithd::pipeline::StageClock;

/// The process's monotonic clock, for stage timings.
struct MonotonicClock(std::time::Instant);

impl StageClock for MonotonicClock {
    fn now_ns(&mut self) -> u64 {
        self.0.elapsed().as_nanos() as u64
    }
}

fn demo(seed: u64, window_us: i64, json: bool) -> ExitCode {
    if window_us <= 0 {
        eprintln!("error: --window-us must be positive, got {window_us}");
        return ExitCode::from(2);
    }
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
        return ExitCode::SUCCESS;
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
    ExitCode::SUCCESS
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
    /// Fly the built-in demo: a generated approach to a pole through the real pipeline.
    Demo {
        /// Seed of the scene and of FAITH's draws.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Decision period, microseconds.
        #[arg(long, default_value_t = 10_000)]
        window_us: i64,
        /// Print the summary as one JSON object.
        #[arg(long)]
        json: bool,
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
    },
    /// Validate a config file: prints `ok` or the key and the reason it is refused.
    CheckConfig {
        /// Path to faithd.toml.
        path: PathBuf,
    },
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Table I of the paper: all four FOE methods on simulated flights.
    Foe {
        /// Number of simulated trajectories.
        #[arg(long, default_value_t = 100)]
        trajectories: usize,
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
    },
}

fn bench_foe(
    trajectories: usize,
    seed: u64,
    json: bool,
    threads: Option<usize>,
    plot_dir: &std::path::Path,
    rotation: bool,
) -> ExitCode {
    if trajectories == 0 {
        eprintln!("error: --trajectories must be at least 1");
        return ExitCode::from(2);
    }
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
        return ExitCode::from(1);
    }
    ExitCode::SUCCESS
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

fn run(path: &std::path::Path) -> ExitCode {
    let config = match FaithdConfig::load(path) {
        Ok(c) => c,
        Err(e) => {
            tracing::error!("refusing to start: {e}");
            return ExitCode::from(2);
        }
    };
    match faithd::daemon::run(config) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            tracing::error!("{e}");
            ExitCode::FAILURE
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    match cli.command {
        Command::Demo {
            seed,
            window_us,
            json,
        } => demo(seed, window_us, json),
        Command::Bench {
            what:
                BenchCommand::Foe {
                    trajectories,
                    seed,
                    json,
                    threads,
                    plot_dir,
                    rotation,
                },
        } => bench_foe(trajectories, seed, json, threads, &plot_dir, rotation),
        Command::Run { config } => run(&config),
        Command::CheckConfig { path } => match FaithdConfig::load(&path) {
            Ok(_) => {
                println!("{}: ok", path.display());
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(2)
            }
        },
    }
}
