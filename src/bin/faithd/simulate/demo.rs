//! `faithd demo`: the daemon flying a simulated quadrotor at a pole (closed loop),
//! or the pipeline alone on generated events (`--open-loop`).

use std::path::PathBuf;

use clap::Args;

use faithd::orchestrate::{demo::Demo, open_loop};

use super::world::WorldArgs;
use crate::Failure;
use crate::video::{self, VideoArgs};

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
    #[command(flatten)]
    world: WorldArgs,
    #[command(flatten)]
    video: VideoArgs,
}

/// `faithd demo`: the closed loop, or the pipeline alone with `--open-loop`.
pub fn demo(args: &DemoArgs) -> Result<(), Failure> {
    if args.open_loop && args.video.video.is_some() {
        return Err(Failure::refused(
            "--video films the closed-loop flight; the open-loop demo has none",
        ));
    }
    if args.open_loop {
        open_loop_demo(args)
    } else {
        closed_loop_demo(args)
    }
}

fn closed_loop_demo(args: &DemoArgs) -> Result<(), Failure> {
    let mut demo = Demo::new(
        args.seed,
        args.offset_m,
        args.manual,
        args.world.world(),
        args.plot.clone(),
    );
    eprintln!("{}", demo.intro());
    video::check_output(&args.video)?;
    demo.film = args.video.video.is_some();
    let mut flight = demo.fly()?;
    if args.json {
        println!("{}", flight.json());
    } else {
        print!("{}", flight.report());
    }
    match flight.take_film() {
        Some((film, title)) => video::write_flight(&args.video, film, title),
        None => Ok(()),
    }
}

fn open_loop_demo(args: &DemoArgs) -> Result<(), Failure> {
    let demo = open_loop::run(args.seed, args.window_us);
    if args.json {
        println!("{}", demo.json());
    } else {
        print!("{}", demo.report());
    }
    Ok(())
}
