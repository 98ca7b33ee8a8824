//! The flight commands: `run` (the daemon), `replay`, `check-config` and `check-fc`.

use std::path::{Path, PathBuf};

use clap::Args;

use faithd::config::FaithdConfig;

use crate::Failure;
use crate::video::{ReplayFilm, ReplaySource, VideoArgs, replay_failure};

/// `faithd replay`: a recording through the pipeline, or a daemon recording checked
/// window by window against its flight (`--windows`).
#[derive(Args)]
pub struct ReplayArgs {
    /// Event file: AEDAT 4.0, 3.1, 2.0 or the datasets' text format.
    #[arg(long)]
    events: PathBuf,
    /// Attitude from a MAVLink telemetry log (ATTITUDE messages).
    #[arg(long, conflicts_with = "imu")]
    mavlink: Option<PathBuf>,
    /// Added to the attitude's times (ATTITUDE's time_boot_ms, imu.txt's t), in us,
    /// to reach the events' clock.
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
    #[command(flatten)]
    video: VideoArgs,
}

/// `faithd run`.
#[derive(Args)]
pub struct RunArgs {
    /// Path to faithd.toml.
    #[arg(long, default_value = "/etc/faithd/faithd.toml")]
    config: PathBuf,
    /// Accept `source.kind = "sim"`: rolls commanded from a simulated camera.
    /// For the bench and tests only; the service never passes it.
    #[arg(long)]
    simulated_camera: bool,
}

/// `faithd check-fc`.
#[derive(Args)]
pub struct CheckFcArgs {
    /// Path to faithd.toml.
    #[arg(long)]
    config: PathBuf,
    /// One JSON object instead of the table.
    #[arg(long)]
    json: bool,
    /// Do not read iNav's rxrange. It is read in iNav's CLI (no MSP command reports
    /// it), which iNav leaves only by rebooting: without this flag a disarmed flight
    /// controller reboots at the end of the check.
    #[arg(long)]
    no_cli: bool,
}

/// `faithd replay`: a daemon recording checked against its flight (`--windows`), or
/// any recording through the pipeline.
pub fn replay(args: &ReplayArgs) -> Result<(), Failure> {
    match &args.windows {
        Some(log) => replay_window_log(args, log),
        None => replay_events(args),
    }
}

fn replay_events(args: &ReplayArgs) -> Result<(), Failure> {
    use faithd::replay::AttitudeInput;
    let config = load_optional(args.config.as_deref())?.unwrap_or_default();
    // The command line and the config checks both keep this positive.
    let window_us = args.window_us.unwrap_or(config.daemon.period_us);
    let mut film = ReplayFilm::start(
        &args.video,
        ReplaySource::Events {
            events: &args.events,
            pipeline: &config.pipeline,
            window_us,
        },
    )?;
    let attitude = match (&args.mavlink, &args.imu) {
        (Some(path), _) => AttitudeInput::Tlog {
            path,
            offset_us: args.attitude_offset_us,
        },
        (None, Some(path)) => AttitudeInput::Imu {
            path,
            offset_us: args.attitude_offset_us,
        },
        (None, None) => {
            eprintln!("note: no --mavlink or --imu: derotation is off for this replay");
            AttitudeInput::None
        }
    };
    let spinner = replay_spinner(args);
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let result = faithd::replay::replay(
        &args.events,
        attitude,
        config.pipeline,
        window_us,
        args.json,
        &mut out,
        &mut |events, report| {
            spinner.inc(1);
            film.watch(events, report)
        },
    );
    let _ = std::io::Write::flush(&mut out);
    spinner.finish_and_clear();
    let summary = result.map_err(replay_failure)?;
    note_coverage(&summary);
    film.finish()
}

/// Says on standard error how much of the replay the attitude covered, and which
/// windows ran without derotation (at most a few runs, then how many more).
fn note_coverage(summary: &faithd::replay::ReplaySummary) {
    let Some(covers) = summary.attitude_covers else {
        return;
    };
    let missed: usize = summary.not_derotated.iter().map(|run| run.2).sum();
    if missed == 0 {
        return;
    }
    eprintln!(
        "note: the attitude covers {:.1} % of the events' span: {missed} of {} windows ran without derotation",
        covers * 100.0,
        summary.windows
    );
    const SHOWN: usize = 5;
    for &(first_us, last_us, windows) in summary.not_derotated.iter().take(SHOWN) {
        eprintln!("note:   {windows} windows from {first_us} us to {last_us} us");
    }
    if summary.not_derotated.len() > SHOWN {
        eprintln!(
            "note:   and {} more runs",
            summary.not_derotated.len() - SHOWN
        );
    }
}

/// How far a long replay has got, on standard error when it is a terminal. Hidden
/// when the windows' lines go to the terminal too (they would tear it) and when a
/// video is written (its own bar counts the frames); a pipe never sees it.
fn replay_spinner(args: &ReplayArgs) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if std::io::stdout().is_terminal() || args.video.video.is_some() {
        return indicatif::ProgressBar::hidden();
    }
    let spinner = indicatif::ProgressBar::new_spinner();
    spinner.set_style(
        indicatif::ProgressStyle::with_template("{spinner} {pos} windows replayed, {elapsed}")
            .expect("progress template"),
    );
    spinner.enable_steady_tick(std::time::Duration::from_millis(200));
    spinner
}

fn replay_window_log(args: &ReplayArgs, log: &Path) -> Result<(), Failure> {
    let pipeline = load_optional(args.config.as_deref())?.map(|c| c.pipeline);
    let mavlink = args.mavlink.as_deref();
    let mut film = ReplayFilm::start(
        &args.video,
        ReplaySource::WindowLog {
            events: &args.events,
            log,
            pipeline: pipeline.as_ref(),
        },
    )?;
    if mavlink.is_none() {
        eprintln!("note: no --mavlink: replaying without the recorded attitude");
    }
    let spinner = replay_spinner(args);
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let result = faithd::replay::replay_window_log(
        &args.events,
        mavlink,
        log,
        pipeline,
        args.json,
        &mut out,
        &mut |events, report| {
            spinner.inc(1);
            film.watch(events, report)
        },
    );
    let _ = std::io::Write::flush(&mut out);
    spinner.finish_and_clear();
    let r = result.map_err(replay_failure)?;
    film.finish()?;
    if r.late_windows > 0 {
        eprintln!(
            "{} windows ran in flight before attitude that had arrived reached the pipeline; each replayed with the samples it had",
            r.late_windows
        );
    }
    if r.differing == 0 {
        eprintln!(
            "replayed {} windows: every one as decided in flight",
            r.windows
        );
        return Ok(());
    }
    let (t_us, why) = r.first_difference.unwrap_or_default();
    Err(Failure::differs(format!(
        "replayed {} windows: {} differ from the flight; the first at {t_us} us ({why})",
        r.windows, r.differing
    )))
}

/// `faithd run`: the daemon until SIGTERM. Its errors go to the journal.
pub fn run(args: &RunArgs) -> Result<(), Failure> {
    let options = faithd::daemon::RunOptions {
        simulated_camera: args.simulated_camera,
    };
    let config = FaithdConfig::load(&args.config)
        .map_err(|e| Failure::refused(format!("refusing to start: {e}")))?;
    faithd::daemon::run(config, options).map_err(|e| match e {
        faithd::daemon::DaemonError::Config { .. } => {
            Failure::refused(format!("refusing to start: {e}"))
        }
        _ => Failure::failed(e),
    })
}

/// `faithd check-config`: `ok`, or the key and the reason it is refused.
pub fn check_config(path: &Path) -> Result<(), Failure> {
    let config = FaithdConfig::load(path).map_err(Failure::refused)?;
    let note = faithd::source::check_library(&config.source)
        .map_err(|e| Failure::refused(format!("{}: {e}", path.display())))?;
    if let Some(note) = note {
        eprintln!("{note}");
    }
    println!("{}: ok", path.display());
    Ok(())
}

/// `faithd check-fc`: the flight controller's set-up read over MSP, item by item.
pub fn check_fc(args: &CheckFcArgs) -> Result<(), Failure> {
    use faithd::command::fc_check;
    let config = FaithdConfig::load(&args.config).map_err(Failure::refused)?;
    let expect = fc_check::Expectations::new(
        &config.gate,
        &config.command,
        config.mavlink.autopilot_system_id,
    )
    .with_telemetry_over_msp(config.telemetry.is_msp());
    if !args.no_cli && !args.json {
        println!(
            "reading rxrange in iNav's CLI: the flight controller reboots when the check leaves it (--no-cli skips this)"
        );
    }
    let timeout = std::time::Duration::from_micros(config.command.msp_timeout_us.max(1) as u64);
    let telemetry = match &config.telemetry {
        faithd::link::TelemetryConfig::Msp(t) => {
            Some(fc_check::probe_msp_telemetry(&t.port(), timeout))
        }
        faithd::link::TelemetryConfig::Mavlink => None,
    };
    let mut report =
        fc_check::check_over_msp(&config.command, &expect, !args.no_cli).map_err(|e| {
            Failure::failed(format!(
                "cannot read the flight controller on {}: {e}",
                config.command.msp_port()
            ))
        })?;
    if let Some(item) = telemetry {
        if item.problem.is_some() {
            report.route = None;
        }
        report.items.push(item);
    }
    if args.json {
        print_fc_report_json(&report);
    } else {
        print_fc_report(&report);
    }
    match report.route {
        Some(_) => Ok(()),
        // The report above says why.
        None => Err(Failure::reported(crate::Exit::Refused)),
    }
}

fn print_fc_report(report: &faithd::command::fc_check::FcReport) {
    for i in &report.items {
        match &i.problem {
            None => println!("ok    {}: {}", i.what, i.found),
            Some(p) => {
                println!("FAIL  {}: {}: {p}", i.what, i.found);
                match i.fix.as_deref() {
                    Some(fix) if fix.starts_with("in faithd.toml") => println!("      fix {fix}"),
                    Some(fix) => println!("      fix (iNav CLI): {fix}"),
                    None => {}
                }
            }
        }
    }
    match report.route {
        Some(_) => println!("flight controller set-up: ok for faithd's roll route"),
        None => println!("flight controller set-up: refused; faithd will not command"),
    }
}

fn print_fc_report_json(report: &faithd::command::fc_check::FcReport) {
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
}

/// A config file when one is given: refused with its key and reason when bad.
fn load_optional(path: Option<&Path>) -> Result<Option<FaithdConfig>, Failure> {
    path.map(FaithdConfig::load)
        .transpose()
        .map_err(Failure::refused)
}
