//! `faithd bench`: experiments on the built-in simulator (the FOE methods, the
//! pipeline's cost, the compute model).

use std::path::PathBuf;

use clap::Args;

use faithd::config::FaithdConfig;
use faithd::orchestrate::bench_pipeline::{self, BenchCamera, Streams};
use faithd::orchestrate::{bench_compute, bench_foe};
use faithd_core::camera::CameraPreset;
use faithd_sim::world::AttitudeLink;

use super::world::{WorldArgs, parse_cpu_scale};
use crate::Failure;
use crate::progress::{progress_bar, step};

/// `faithd bench foe`.
#[derive(Args)]
pub struct BenchFoeArgs {
    /// Number of simulated trajectories.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..))]
    trajectories: u32,
    /// Seed of the trajectories, scenes and FAITH's draws.
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
    /// The camera flown (the same flights and scenes, rendered at its size; all
    /// with the DAVIS240's field of view): davis240, davis346, dvxplorer or
    /// dvxplorer-lite.
    #[arg(long, default_value = "davis240", value_parser = parse_camera)]
    camera: CameraPreset,
    /// Give the methods at most this many (newest) vectors of the history, as the
    /// pipeline's `max_vectors` does (default: the whole 50 ms history).
    #[arg(long, value_parser = clap::value_parser!(u32).range(50..))]
    max_vectors: Option<u32>,
    /// The link derotation's body rates come over: imu (the simulator's 100 Hz gyro
    /// as it is), mavlink (iNav's ATTITUDE: 25 Hz, f32 degrees per second) or msp
    /// (iNav's MSP_RAW_IMU: 25 Hz, whole degrees per second).
    #[arg(long, default_value = "imu", value_parser = parse_attitude_link)]
    attitude_link: AttitudeLink,
}

/// `faithd bench pipeline`.
#[derive(Args)]
pub struct BenchPipelineArgs {
    /// Event rates of the generated streams, events per second.
    #[arg(long = "events-per-s", value_delimiter = ',', default_values_t = [500_000.0, 2_000_000.0, 8_000_000.0])]
    rates: Vec<f64>,
    /// Length of each generated stream, seconds.
    #[arg(long, default_value_t = 1.0)]
    seconds: f64,
    /// Instead of generated streams: a recording (AEDAT 2/3/4 or text), as recorded.
    #[arg(long, conflicts_with = "rates")]
    events: Option<PathBuf>,
    /// Load shedding as on a board this much slower than this machine (`atom`: the
    /// paper's Intel Atom x5-Z8350).
    #[arg(long, default_value = "1", value_parser = parse_cpu_scale)]
    cpu_scale: f64,
    /// The pipeline settings (`[pipeline]` and `[daemon]` of a faithd.toml).
    #[arg(long)]
    config: Option<PathBuf>,
    /// The camera the streams are seen by (its size and intrinsics, all with the
    /// DAVIS240's field of view): davis240, davis346, dvxplorer or dvxplorer-lite.
    /// Default: the configuration's camera (a DAVIS240 without --config).
    #[arg(long, value_parser = parse_camera)]
    camera: Option<CameraPreset>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

/// `--camera`: a preset's name; a wrong one is refused with the names there are.
pub fn parse_camera(text: &str) -> Result<CameraPreset, String> {
    text.parse()
        .map_err(|e: faithd_core::camera::UnknownCamera| e.to_string())
}

/// `--attitude-link`: a link's name; a wrong one is refused with the names there are.
fn parse_attitude_link(text: &str) -> Result<AttitudeLink, String> {
    text.parse()
        .map_err(|e: faithd_sim::world::attitude_link::UnknownAttitudeLink| e.to_string())
}

/// `faithd bench compute`.
#[derive(Args)]
pub struct BenchComputeArgs {
    /// Flights of the experiment's plan to measure (flown straight).
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..))]
    flights: u32,
    /// Seed of the flights.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    world: WorldArgs,
}

pub fn bench_foe(args: &BenchFoeArgs) -> Result<(), Failure> {
    let mut options = faithd_sim::bench::foe::BenchFoeOptions {
        trajectories: args.trajectories as usize,
        seed: args.seed,
        rotation: args.rotation,
        camera: args.camera,
        max_vectors: args.max_vectors.map(|n| n as usize),
        attitude_link: args.attitude_link,
        ..Default::default()
    };
    if let Some(t) = args.threads {
        options.threads = t.max(1);
    }
    let progress = progress_bar(args.trajectories as u64, "trajectories");
    let report = bench_foe::run(&options, |line| step(&progress, line));
    progress.finish_and_clear();
    if args.json {
        println!(
            "{}",
            serde_json::to_string(&report).expect("report serialises")
        );
    } else {
        print!("{}", report.table());
    }
    bench_foe::write_figures(&report, &args.plot_dir, |path| {
        eprintln!("wrote {}", path.display())
    })?;
    Ok(())
}

pub fn bench_pipeline(args: &BenchPipelineArgs) -> Result<(), Failure> {
    let config = match args.config.as_deref().map(FaithdConfig::load).transpose() {
        Ok(c) => c.unwrap_or_default(),
        Err(e) => return Err(Failure::refused(e)),
    };
    if !(args.seconds > 0.0 && args.seconds <= 60.0) {
        return Err(Failure::refused(format!(
            "--seconds must be above 0 and at most 60, got {}",
            args.seconds
        )));
    }
    let streams = match &args.events {
        Some(path) => Streams::Recording(path.clone()),
        None => Streams::Generated {
            rates: args.rates.clone(),
            seconds: args.seconds,
        },
    };
    let progress = progress_bar(streams.names().len() as u64, "streams");
    let camera = BenchCamera::resolve(args.camera, config.pipeline.camera);
    let bench = bench_pipeline::run(
        &streams,
        (config.pipeline, config.daemon),
        camera,
        args.cpu_scale,
        || progress.inc(1),
    )?;
    progress.finish_and_clear();
    if args.json {
        println!("{}", bench.json());
    } else {
        print!("{}", bench.report());
    }
    Ok(())
}

pub fn bench_compute(args: &BenchComputeArgs) -> Result<(), Failure> {
    let progress = progress_bar(args.flights as u64, "flights");
    let bench = bench_compute::run(args.flights as usize, args.seed, args.world.world(), || {
        progress.inc(1)
    });
    progress.finish_and_clear();
    if args.json {
        println!("{}", bench.json());
    } else {
        print!("{}", bench.report());
    }
    Ok(())
}
