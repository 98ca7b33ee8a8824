//! The simulation commands (feature `sim`): `demo`, `sim` and `bench`, on the
//! built-in simulator. The flight build has none of them.

use std::path::{Path, PathBuf};

use clap::Args;

use faithd::config::FaithdConfig;
use faithd_core::pipeline::StageClock;

use crate::Failure;
use crate::video::{Filming, VideoArgs};

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

/// The simulated world and board of a closed-loop flight.
#[derive(Args)]
pub struct WorldArgs {
    /// The camera: the ray-traced DVS simulator (realistic) or the analytic line
    /// camera (pole silhouettes and stripes; fast).
    #[arg(long, value_enum, default_value_t = Camera::Dvs)]
    camera: Camera,
    /// The room the poles stand in (the DVS camera; the line camera draws the arena).
    #[arg(long, value_enum, default_value_t = Scene::Arena)]
    scene: Scene,
    /// How much slower than this machine the board computes: 1 is this machine,
    /// `atom` the paper's Intel Atom x5-Z8350 (see docs/tuning.md).
    #[arg(long, default_value = "1", value_parser = parse_cpu_scale)]
    cpu_scale: f64,
    /// What a pipeline cycle costs in simulated time: the calibrated model of this
    /// machine (the same on every run) or the time measured now (follows the load).
    #[arg(long, value_enum, default_value_t = Compute::Model)]
    compute: Compute,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Camera {
    Dvs,
    Line,
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

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Scene {
    Arena,
    Kitchen,
    Shelves,
    Warehouse,
    /// The four in turn, flight by flight (`faithd sim`).
    Mixed,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Compute {
    Model,
    Measured,
}

/// `--cpu-scale`: a factor of 0.01 to 100, or `atom`.
fn parse_cpu_scale(text: &str) -> Result<f64, String> {
    if text.eq_ignore_ascii_case("atom") {
        return Ok(faithd::cycle::compute::ATOM_X5_Z8350_SCALE);
    }
    let scale: f64 = text
        .parse()
        .map_err(|_| format!("`{text}` is neither a number nor `atom`"))?;
    if (0.01..=100.0).contains(&scale) {
        Ok(scale)
    } else {
        Err(format!("must be 0.01 to 100, got {scale}"))
    }
}

impl WorldArgs {
    fn options(&self) -> faithd::closed_loop::FlyOptions {
        use faithd::cycle::compute::ComputeCharge;
        faithd::closed_loop::FlyOptions {
            compute: match self.compute {
                Compute::Model => ComputeCharge::modelled(self.cpu_scale),
                Compute::Measured => ComputeCharge::Measured {
                    cpu_scale: self.cpu_scale,
                },
            },
            film: false,
        }
    }

    /// The camera and scene of flight `index`.
    fn apply(&self, index: usize, spec: &mut faithd::closed_loop::FlightSpec) {
        use faithd::closed_loop::{CameraKind, SceneKind};
        spec.camera = match self.camera {
            Camera::Dvs => CameraKind::Dvs,
            Camera::Line => CameraKind::Line,
        };
        spec.scene = match self.scene {
            Scene::Arena => SceneKind::Arena,
            Scene::Kitchen => SceneKind::Kitchen,
            Scene::Shelves => SceneKind::Shelves,
            Scene::Warehouse => SceneKind::Warehouse,
            Scene::Mixed => SceneKind::ALL[index % SceneKind::ALL.len()],
        };
    }

    fn describe(&self) -> String {
        format!(
            "{} camera{}, compute {} at cpu scale {}",
            match self.camera {
                Camera::Dvs => "ray-traced DVS",
                Camera::Line => "analytic line",
            },
            match (self.camera, self.scene) {
                (Camera::Line, _) => String::new(),
                (_, Scene::Arena) => " in the arena".into(),
                (_, Scene::Kitchen) => " in the kitchen".into(),
                (_, Scene::Shelves) => " among shelves".into(),
                (_, Scene::Warehouse) => " in the warehouse".into(),
                (_, Scene::Mixed) => " in the four scenes in turn".into(),
            },
            match self.compute {
                Compute::Model => "modelled",
                Compute::Measured => "measured",
            },
            self.cpu_scale
        )
    }
}

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
}

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
}

/// `faithd demo`: the closed loop, or the pipeline alone with `--open-loop`.
pub fn demo(args: &DemoArgs) -> Result<(), Failure> {
    if args.open_loop && args.video.video.is_some() {
        return Err(Failure::refused(
            "--video films the closed-loop flight; the open-loop demo has none",
        ));
    }
    if args.open_loop {
        open_loop_demo(args.seed, args.window_us, args.json)
    } else {
        closed_loop_demo(args)
    }
}

/// `faithd sim`: the closed-loop experiment, or its straight-flight proxy.
pub fn sim(args: &SimArgs) -> Result<(), Failure> {
    if args.straight && args.video.video.is_some() {
        return Err(Failure::refused(
            "--video films a closed-loop flight; --straight flies none",
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

fn closed_loop_demo(args: &DemoArgs) -> Result<(), Failure> {
    let (seed, offset_m, manual, json) = (args.seed, args.offset_m, args.manual, args.json);
    let plot = args.plot.as_path();
    let mut spec = faithd::closed_loop::FlightSpec {
        lateral_offset_m: offset_m,
        pilot_auto: !manual,
        seed,
        ..Default::default()
    };
    args.world.apply(0, &mut spec);
    eprintln!(
        "faithd demo: the daemon flies a simulated quadrotor at a pole ({} m/s, course {:+.2} m from its centre) against a simulated iNav (MAVLink and MSP on simulated UARTs), in simulated time; {}; switch {}",
        spec.speed_m_s,
        spec.lateral_offset_m,
        args.world.describe(),
        if manual {
            "stays in MANUAL"
        } else {
            "to AUTO at 0.5 s"
        }
    );
    check_video_output(&args.video)?;
    let options = faithd::closed_loop::FlyOptions {
        film: args.video.video.is_some(),
        ..args.world.options()
    };
    let started = std::time::Instant::now();
    let mut outcome = faithd::closed_loop::fly(&spec, &options)
        .map_err(|e| Failure::failed(format!("cannot fly the demo: {e}")))?;
    let wall_s = started.elapsed().as_secs_f64();
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
                "  roll decided at {t:.2} s of flight, true time to contact then {ttc:.2} s; roll in use at the autopilot {:.1} ms after the deciding event",
                outcome.latency_ms.unwrap_or(f64::NAN)
            ),
            _ => println!("  no roll commanded"),
        }
        let p = &outcome.pipeline;
        println!(
            "  pipeline: {} cycles, {:.2} ms median ({:.2} ms p99) at cpu scale {}; {} over budget, {} with load shed",
            p.cycles,
            p.charged_us_p50 / 1e3,
            p.charged_us_p99 / 1e3,
            args.world.cpu_scale,
            p.overruns,
            p.shed_cycles
        );
        println!(
            "  {} events; {:.2} s of flight simulated in {wall_s:.1} s",
            outcome.events,
            outcome.path.last().map_or(0.0, |p| p.t_s)
        );
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
    match outcome.film.take() {
        Some(film) => {
            let title = format!(
                "faithd demo: {} ({:+.2} m off the pole), seed {seed}",
                if outcome.collision_course {
                    "collision course"
                } else {
                    "near pass"
                },
                spec.lateral_offset_m
            );
            write_flight_video(&args.video, film, title)
        }
        None => Ok(()),
    }
}

/// Refuses a video that cannot be written before any flight is flown for it.
fn check_video_output(args: &VideoArgs) -> Result<(), Failure> {
    match &args.video {
        Some(path) => faithd::video::output::check(path)
            .map_err(|e| Failure::refused(format!("--video: {e}"))),
        None => Ok(()),
    }
}

/// Draws a simulated flight's frames into the video `args` asks for.
fn write_flight_video(
    args: &VideoArgs,
    film: faithd::closed_loop::film::FilmedFlight,
    title: String,
) -> Result<(), Failure> {
    let windows = (film.frames.len(), film.period_us);
    let Some(mut filming) = Filming::start(args, &film.pipeline, title, film.span, windows, true)?
    else {
        return Ok(());
    };
    for frame in &film.frames {
        filming.add(frame).map_err(Failure::failed)?;
    }
    filming.finish()
}

/// `faithd sim --autopilot inav-sitl`: the experiment with iNav's SITL in the loop,
/// in real time, one flight after the other, each beside the model's.
fn sim_inav_sitl(args: &SimArgs) -> Result<(), Failure> {
    use faithd::inav_sitl::experiment;
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
    let (runs, seed) = (args.runs, args.seed);
    let specs = experiment::plan(runs, seed);
    eprintln!(
        "faithd sim: {runs} flights with iNav's SITL ({}) flying the quad-X in real time, seed {seed}, line camera; each also flown on the model",
        exe.display()
    );
    let started = std::time::Instant::now();
    let flights = experiment::fly_all(&specs, exe, |i, c| {
        eprintln!(
            "  flight {}/{runs}: {} {:+.2} m at {:.2} m/s (iNav's vehicle at {:.2}); iNav: {}{}, bank {}, in effect {}; model: {}{}",
            i + 1,
            if c.inav.collision_course {
                "collision"
            } else {
                "near pass"
            },
            c.spec.lateral_offset_m,
            c.spec.speed_m_s,
            c.speed_at_start_m_s,
            if c.inav.rolled { "rolled" } else { "no roll" },
            if c.inav.collided { ", HIT" } else { "" },
            c.inav
                .peak_bank_deg
                .map_or("-".into(), |b| format!("{b:.1} deg")),
            c.inav
                .in_effect_ms
                .map_or("-".into(), |t| format!("{t:.0} ms")),
            if c.model.rolled { "rolled" } else { "no roll" },
            if c.model.collided { ", HIT" } else { "" },
        );
    })
    .map_err(|e| Failure::failed(e.to_string()))?;
    let report = experiment::report(&flights, seed);
    if args.json {
        println!(
            "{}",
            serde_json::json!({"report": report, "flights": flights})
        );
    } else {
        println!(
            "faithd sim --autopilot inav-sitl: {runs} flights, seed {seed}, {:.0} s\n",
            started.elapsed().as_secs_f64()
        );
        print!("{}", report.table());
    }
    Ok(())
}

fn sim_closed_loop(args: &SimArgs) -> Result<(), Failure> {
    use faithd::closed_loop::experiment;
    let (runs, seed) = (args.runs, args.seed);
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
    check_video_output(&args.video)?;
    let mut specs = experiment::plan(runs, seed);
    for (i, spec) in specs.iter_mut().enumerate() {
        args.world.apply(i, spec);
    }
    let threads = args.threads.map_or_else(
        || std::thread::available_parallelism().map_or(1, |n| n.get()),
        |t| t as usize,
    );
    eprintln!(
        "faithd sim: {runs} closed-loop flights, seed {seed}, {}; {threads} at a time",
        args.world.describe()
    );
    let options = args.world.options();
    let started = std::time::Instant::now();
    let progress = progress_bar(runs as u64, "flights");
    let mut outcomes = experiment::fly_all(&specs, &options, threads, filmed, |i, o| {
        let line = flight_line(i, runs, &specs[i], o);
        step(&progress, line);
    })
    .map_err(Failure::failed)?;
    progress.finish_and_clear();
    let summary = experiment::summarise(&outcomes, seed, &options);
    eprintln!(
        "{runs} flights ({:.0} s of flight) in {:.0} s on {threads} threads",
        summary.simulated_s,
        started.elapsed().as_secs_f64()
    );
    // The figures stand without the picture: a plot that cannot be written is
    // reported, and the run still gives its result.
    if let Some(dir) = args.plot.parent() {
        let _ = std::fs::create_dir_all(dir);
    }
    match faithd::closed_loop::plot::plot_outcomes(&outcomes, &args.plot) {
        Ok(()) => eprintln!("outcome plot: {}", args.plot.display()),
        Err(e) => eprintln!("warning: {e}"),
    }
    if let Some(i) = filmed {
        let o = &mut outcomes[i];
        let title = format!(
            "faithd sim, seed {seed}: flight {} of {runs} ({}, {}, {:+.2} m off the pole)",
            i + 1,
            if o.collision_course {
                "collision course"
            } else {
                "near pass"
            },
            o.spec.scene.name(),
            o.spec.lateral_offset_m
        );
        let film = o.film.take().expect("the filmed flight keeps its frames");
        write_flight_video(&args.video, film, title)?;
    }
    if args.json {
        println!(
            "{}",
            serde_json::to_string(&summary).expect("summary serialises")
        );
        return Ok(());
    }
    println!(
        "faithd sim: {} closed-loop flights, seed {}, {}",
        summary.runs,
        summary.seed,
        args.world.describe()
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
        "  deciding event to roll in use at the autopilot: p50 {:.1} ms, p99 {:.1} ms; from the first call (with the gate's hold): p50 {:.1} ms, p99 {:.1} ms",
        summary.latency_ms_p50,
        summary.latency_ms_p99,
        summary.latency_from_first_call_ms_p50,
        summary.latency_from_first_call_ms_p99
    );
    println!(
        "  true TTC at the roll (median): {:.2} s",
        summary.ttc_at_decision_s_p50
    );
    println!(
        "  pipeline cycles {}: {:.2} ms median, {:.2} ms p99; {} over budget, {} with load shed",
        summary.cycles,
        summary.cycle_ms_p50,
        summary.cycle_ms_p99,
        summary.overruns,
        summary.shed_cycles
    );
    Ok(())
}

/// One flight's line in the log of `faithd sim`.
fn flight_line(
    i: usize,
    runs: usize,
    spec: &faithd::closed_loop::FlightSpec,
    o: &faithd::closed_loop::FlightOutcome,
) -> String {
    let mut line = format!(
        "[{}/{}] {} {:<9} offset {:+.2} m, heading {:+.1} deg, {:.1} m/s: {}",
        i + 1,
        runs,
        if o.collision_course {
            "collision course"
        } else {
            "near pass       "
        },
        spec.scene.name(),
        spec.lateral_offset_m,
        spec.heading_deg,
        spec.speed_m_s,
        if o.collided { "HIT" } else { "clear" },
    );
    match (o.rolled, roll_ttc_s(o)) {
        (true, Some((measured, truth))) => {
            line += &format!(
                ", rolled at {:.2} s of flight, TTC {measured:.2} s measured, {truth:.2} s true",
                o.decision_s.unwrap_or(f64::NAN)
            )
        }
        (true, None) => line += ", rolled",
        (false, _) => {}
    }
    if let Some(ms) = o.latency_ms {
        line += &format!(", roll in use {ms:.1} ms after the deciding event");
    }
    if o.pipeline.overruns > 0 {
        line += &format!(", {} cycles over budget", o.pipeline.overruns);
    }
    if let (false, Some(d)) = (o.collision_course, &o.decision) {
        line += &format!("\n    rolled on a near pass: {d}");
    }
    line
}

/// One item done: its line above the bar on a terminal, or alone in a pipe.
fn step(progress: &indicatif::ProgressBar, line: String) {
    if progress.is_hidden() {
        eprintln!("{line}");
    } else {
        progress.println(line);
    }
    progress.inc(1);
}

/// A progress bar on standard error when it is a terminal; hidden (and silent) in
/// a pipe or a file.
pub fn progress_bar(len: u64, what: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "{{bar:40}} {{pos}}/{{len}} {what}, {{elapsed}} elapsed, about {{eta}} left"
        ))
        .expect("progress template"),
    );
    bar
}

fn sim_straight(args: &SimArgs) -> Result<(), Failure> {
    use faithd::closed_loop::{experiment, straight};
    let (runs, seed, json) = (args.runs, args.seed, args.json);
    let config = match args.config.as_deref().map(FaithdConfig::load).transpose() {
        Ok(c) => c.unwrap_or_default().pipeline,
        Err(e) => {
            return Err(Failure::refused(e));
        }
    };
    let mut specs = experiment::plan(runs, seed);
    for (i, spec) in specs.iter_mut().enumerate() {
        args.world.apply(i, spec);
    }
    let threads = args.threads.map_or_else(
        || std::thread::available_parallelism().map_or(1, |n| n.get()),
        |t| t as usize,
    );
    let outcomes = straight::fly_all(&specs, &config, threads);
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
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

pub fn bench_pipeline(args: &BenchPipelineArgs) -> Result<(), Failure> {
    use faithd::cycle::bench;
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
    // Each stream is made (or read) just before its run and dropped after it.
    let streams: Vec<String> = match &args.events {
        Some(path) => vec![path.display().to_string()],
        None => args
            .rates
            .iter()
            .map(|r| format!("generated {:.1} Mev/s", r / 1e6))
            .collect(),
    };
    let progress = progress_bar(streams.len() as u64, "streams");
    let mut reports = Vec::new();
    for (i, name) in streams.iter().enumerate() {
        let events = match &args.events {
            Some(path) => faithd_formats::events::open_events(path)
                .and_then(|mut r| faithd_formats::events::read_all(r.as_mut()))
                .map_err(|e| Failure::refused(format!("{}: {e}", path.display())))?,
            None => bench::generated_stream(args.rates[i], args.seconds, 1),
        };
        let report = bench::run(&events, config.pipeline, config.daemon, args.cpu_scale);
        reports.push((name.clone(), report));
        progress.inc(1);
    }
    progress.finish_and_clear();
    if args.json {
        let rows: Vec<_> = reports
            .iter()
            .map(|(name, r)| serde_json::json!({ "stream": name, "report": r }))
            .collect();
        println!(
            "{}",
            serde_json::json!({ "cpu_scale": args.cpu_scale, "streams": rows })
        );
        return Ok(());
    }
    println!(
        "faithd bench pipeline: one window per {} ms, load shed as at cpu scale {}",
        config.daemon.period_us / 1000,
        args.cpu_scale
    );
    for (name, r) in &reports {
        println!(
            "  {name}: {:.2} Mev/s, {} windows of {:.0} events (p99 {:.0})",
            r.events_per_s / 1e6,
            r.windows,
            r.events_per_window_p50,
            r.events_per_window_p99
        );
        println!(
            "    per window (p50): {:.0} new vectors, {:.0} taken by the FOE, {:.0} clustered",
            r.new_vectors_p50, r.foe_vectors_p50, r.clustered_p50
        );
        let stages: Vec<String> = r
            .stages_us
            .iter()
            .map(|s| format!("{} {:.0}/{:.0}", s.stage, s.p50_us, s.p99_us))
            .collect();
        println!("    us per window p50/p99: {}", stages.join(", "));
        println!(
            "    whole window {:.0}/{:.0} us; {:.2} Mev/s per core of compute; {} over budget, {} shed (level up to {}); peak RSS {:.1} MB ({:.1} MB of it the stream)",
            r.window_us_p50,
            r.window_us_p99,
            r.throughput_events_per_s / 1e6,
            r.overruns,
            r.shed_windows,
            r.max_load_level,
            r.peak_rss_bytes.unwrap_or(0) as f64 / 1e6,
            r.stream_bytes as f64 / 1e6
        );
    }
    Ok(())
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

pub fn bench_compute(args: &BenchComputeArgs) -> Result<(), Failure> {
    use faithd::closed_loop::{calibrate, experiment};
    use faithd::cycle::compute::ComputeModel;
    let mut specs = experiment::plan(args.flights as usize, args.seed);
    for (i, spec) in specs.iter_mut().enumerate() {
        args.world.apply(i, spec);
    }
    let config = faithd_core::pipeline::PipelineConfig::default();
    let progress = progress_bar(specs.len() as u64, "flights");
    // One flight at a time: the model stands for one core of this machine.
    let mut samples = Vec::new();
    for spec in &specs {
        samples.extend(calibrate::measure(spec, &config));
        progress.inc(1);
    }
    progress.finish_and_clear();
    let fitted = calibrate::fit(&samples);
    let committed = calibrate::judge(&ComputeModel::CALIBRATED, &samples);
    if args.json {
        let both = serde_json::json!({ "fitted": fitted, "committed": committed });
        println!("{both}");
        return Ok(());
    }
    println!(
        "faithd bench compute: {} windows of {} flights ({})",
        fitted.windows,
        specs.len(),
        args.world.describe()
    );
    println!("  term                              fitted ns    committed ns");
    for ((name, c), (_, k)) in fitted.terms.iter().zip(&committed.terms) {
        println!("  {name:<32} {c:>10.3} {k:>14.3}");
    }
    for (label, r) in [("fitted", &fitted), ("committed", &committed)] {
        println!(
            "  {label}: mean window {:.0} us measured, {:.0} us modelled; per-window error median {:.0}%, 90th percentile {:.0}%",
            r.measured_mean_us,
            r.modelled_mean_us,
            100.0 * r.relative_error_p50,
            100.0 * r.relative_error_p90
        );
    }
    println!("  per stage, mean us measured / fitted / committed:");
    for ((stage, measured, f), (_, _, k)) in fitted.stages.iter().zip(&committed.stages) {
        println!("    {stage:?}: {measured:.1} / {f:.1} / {k:.1}");
    }
    println!(
        "  as code: ns: {:?}",
        fitted.model.ns.map(|c| (c * 1000.0).round() / 1000.0)
    );
    Ok(())
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
    let progress = progress_bar(trajectories as u64, "trajectories");
    let report = faithd_sim::bench::foe::run(&options, &|done, t| {
        let line = format!(
            "[{done}/{trajectories}] {:<9} course {:>6.1} deg{}{}: {} events, {:.0} vectors/window, {:.1} s",
            t.scene.name(),
            t.course_deg,
            if t.sway { ", sway" } else { "" },
            if t.rotating { ", rotating" } else { "" },
            t.events,
            t.mean_vectors,
            started.elapsed().as_secs_f64()
        );
        step(&progress, line);
    });
    progress.finish_and_clear();
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
