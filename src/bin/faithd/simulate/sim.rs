//! `faithd sim`: the closed-loop experiment on faithd's model of iNav, its
//! straight-flight proxy (`--straight`), or with iNav's SITL flying (`--autopilot
//! inav-sitl`).

use std::path::PathBuf;

use clap::Args;

use faithd::config::FaithdConfig;
use faithd::inav_sitl::flight::Link;
use faithd::orchestrate::sim::Sim;
use faithd::orchestrate::sitl::SitlSim;
use faithd::orchestrate::straight;

use super::world::WorldArgs;
use crate::Failure;
use crate::progress::{progress_bar, step};
use crate::video::{self, VideoArgs};

/// `faithd sim`.
#[derive(Args)]
pub struct SimArgs {
    /// Flights to fly; 60 % of them on a collision course.
    #[arg(long, default_value_t = 100)]
    runs: usize,
    /// Seed of the flights' courses, scenes and FAITH's draws: the same seed gives
    /// the same result, byte for byte.
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
    /// Flights flown at once (default: one per core). The result does not depend
    /// on it.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=64))]
    threads: Option<u32>,
    /// Where to draw the outcome: each flight's closest approach against its
    /// course offset, coloured by whether faithd rolled (closed loop only).
    #[arg(
        long,
        default_value = "out/sim/outcome.png",
        conflicts_with = "straight"
    )]
    plot: PathBuf,
    #[command(flatten)]
    world: WorldArgs,
    #[command(flatten)]
    video: VideoArgs,
    /// Which flight `--video` films, counted from 1 as the log numbers them.
    #[arg(long, default_value_t = 1, requires = "video",
          value_parser = clap::value_parser!(u32).range(1..))]
    video_flight: u32,
    /// Who flies: faithd's model of iNav (deterministic; the default), or iNav's
    /// own flight controller through its SITL build, in real time (about 20 s a
    /// flight), beside the model on the same flights.
    #[arg(long, value_enum, default_value_t = Autopilot::Model)]
    autopilot: Autopilot,
    /// With --autopilot inav-sitl: iNav 9.1's SITL executable, built beside the
    /// project with the board's serial timing (docs/simulation.md).
    #[arg(long, env = "INAV_SITL")]
    inav_sitl: Option<PathBuf>,
    /// With --autopilot inav-sitl: how faithd reads iNav, its MAVLink telemetry
    /// (hil/inav/faithd.cli) or a second MSP port and no MAVLink at all
    /// (hil/inav/faithd-msp.cli, `[telemetry] kind = "msp"`).
    #[arg(long, value_enum, default_value_t = LinkArg::Mavlink)]
    link: LinkArg,
}

/// How faithd reads iNav in `faithd sim --autopilot inav-sitl`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum LinkArg {
    /// iNav's MAVLink telemetry on UART3.
    Mavlink,
    /// A second MSP port on UART3, as on the iNav 10 boards without MAVLink.
    Msp,
}

/// Who flies the vehicle in `faithd sim`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Autopilot {
    /// faithd's model of iNav in simulated time: deterministic, faster than real time.
    Model,
    /// iNav's own flight controller (its SITL build, `--inav-sitl`) flying the
    /// simulated quad-X in real time, each flight also flown on the model.
    InavSitl,
}

/// `faithd sim`: the closed-loop experiment, or its straight-flight proxy.
pub fn sim(args: &SimArgs) -> Result<(), Failure> {
    if args.straight && args.video.video.is_some() {
        return Err(Failure::refused(
            "--video films a closed-loop flight; --straight flies none",
        ));
    }
    if args.link != LinkArg::Mavlink && args.autopilot != Autopilot::InavSitl {
        return Err(Failure::refused(
            "--link chooses how faithd reads iNav's SITL: it needs --autopilot inav-sitl",
        ));
    }
    if args.autopilot == Autopilot::InavSitl {
        sim_inav_sitl(args)
    } else if args.straight {
        sim_straight(args)
    } else {
        sim_closed_loop(args)
    }
}

fn sim_closed_loop(args: &SimArgs) -> Result<(), Failure> {
    let runs = args.runs;
    let filmed = args
        .video
        .video
        .is_some()
        .then(|| args.video_flight as usize - 1);
    if filmed.is_some_and(|i| i >= runs) {
        return Err(Failure::refused(format!(
            "--video-flight {}: there are {runs} flights",
            args.video_flight
        )));
    }
    video::check_output(&args.video)?;
    let threads = args.threads.map(|t| t as usize);
    let mut sim = Sim::new(runs, args.seed, args.world.world(), threads);
    sim.filmed = filmed;
    eprintln!("{}", sim.intro());
    let progress = progress_bar(runs as u64, "flights");
    let mut run = sim.fly(|line| step(&progress, line))?;
    progress.finish_and_clear();
    eprintln!("{}", run.timing());
    // The figures stand without the picture: a plot that cannot be written is
    // reported, and the run still gives its result.
    match run.plot(&args.plot) {
        Ok(()) => eprintln!("outcome plot: {}", args.plot.display()),
        Err(e) => eprintln!("warning: {e}"),
    }
    if let Some((film, title)) = run.take_film() {
        video::write_flight(&args.video, film, title)?;
    }
    if args.json {
        println!("{}", run.json());
    } else {
        print!("{}", run.report());
    }
    Ok(())
}

fn sim_straight(args: &SimArgs) -> Result<(), Failure> {
    let config = match args.config.as_deref().map(FaithdConfig::load).transpose() {
        Ok(c) => c.unwrap_or_default().pipeline,
        Err(e) => return Err(Failure::refused(e)),
    };
    let threads = args.threads.map(|t| t as usize);
    let run = straight::fly(args.runs, args.seed, &args.world.world(), &config, threads);
    for line in run.notable_flights() {
        eprintln!("{line}");
    }
    if args.json {
        println!("{}", run.json());
    } else {
        print!("{}", run.report());
    }
    Ok(())
}

/// `faithd sim --autopilot inav-sitl`: the experiment with iNav's SITL in the loop,
/// in real time, one flight after the other, each beside the model's.
fn sim_inav_sitl(args: &SimArgs) -> Result<(), Failure> {
    let Some(exe) = args.inav_sitl.as_deref() else {
        return Err(Failure::refused(
            "--autopilot inav-sitl needs iNav 9.1's SITL: --inav-sitl PATH or INAV_SITL (built beside the project with the board's serial timing; docs/simulation.md)",
        ));
    };
    if !exe.is_file() {
        return Err(Failure::refused(format!(
            "--inav-sitl {}: no such file",
            exe.display()
        )));
    }
    if args.straight || args.video.video.is_some() {
        return Err(Failure::refused(
            "--autopilot inav-sitl flies the closed loop in real time, without --straight or --video",
        ));
    }
    let sim = SitlSim {
        runs: args.runs,
        seed: args.seed,
        exe: exe.to_path_buf(),
        link: match args.link {
            LinkArg::Mavlink => Link::Mavlink,
            LinkArg::Msp => Link::Msp,
        },
    };
    eprintln!("{}", sim.intro());
    let run = sim.fly(|line| eprintln!("{line}"))?;
    if args.json {
        println!("{}", run.json());
    } else {
        print!("{}", run.report());
    }
    Ok(())
}
