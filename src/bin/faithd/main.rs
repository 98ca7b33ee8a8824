//! The `faithd` command: one binary for the daemon, the tools and, with the `sim`
//! feature, the experiments. `main` parses the arguments once into one struct per
//! subcommand, runs it, and maps what went wrong to one of the exit statuses below.

mod docs;
mod flight;
#[cfg(feature = "sim")]
mod progress;
#[cfg(feature = "sim")]
mod simulate;
mod video;

use std::fmt::Display;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{CommandFactory, Parser, Subcommand};

/// What this build can do, for `faithd --version`: a bug report or a bench log then
/// says whether the simulation commands were there. The camera is always supported:
/// libcaer is loaded when `faithd run` opens the camera, not linked.
#[cfg(feature = "sim")]
macro_rules! build_features {
    () => {
        "features: camera (DVS240, DAVIS346, DVXplorer over libcaer, loaded at run time), sim (demo, sim, bench)"
    };
}
#[cfg(not(feature = "sim"))]
macro_rules! build_features {
    () => {
        "flight build; features: camera (DVS240, DAVIS346, DVXplorer over libcaer, loaded at run time); without: sim"
    };
}
const VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), " (", build_features!(), ")");

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

/// Why a command did not succeed: its exit status and why (none when the command's
/// own output already said it).
#[derive(Debug)]
struct Failure {
    exit: Exit,
    why: Option<String>,
}

impl Failure {
    fn failed(why: impl Display) -> Self {
        Self::with(Exit::Failed, why)
    }

    fn refused(why: impl Display) -> Self {
        Self::with(Exit::Refused, why)
    }

    fn differs(why: impl Display) -> Self {
        Self::with(Exit::Differs, why)
    }

    fn reported(exit: Exit) -> Self {
        Self { exit, why: None }
    }

    fn with(exit: Exit, why: impl Display) -> Self {
        Self {
            exit,
            why: Some(why.to_string()),
        }
    }
}

/// A lab run refused or failed, as the command line exits on it.
#[cfg(feature = "sim")]
impl From<faithd::orchestrate::error::RunError> for Failure {
    fn from(e: faithd::orchestrate::error::RunError) -> Self {
        use faithd::orchestrate::error::RunError;
        match e {
            RunError::Refused(why) => Self::refused(why),
            RunError::Failed(why) => Self::failed(why),
        }
    }
}

#[derive(Parser)]
#[command(
    name = "faithd",
    version = VERSION,
    about = "Event-camera obstacle avoidance for small drones"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The main job, no hardware: the daemon flies a simulated quadrotor at a pole
    /// against a simulated iNav (MAVLink and MSP), in closed loop and simulated time.
    #[cfg(feature = "sim")]
    Demo(simulate::DemoArgs),
    /// The closed-loop avoidance experiment: many flights, success and false-avoidance rates.
    #[cfg(feature = "sim")]
    Sim(simulate::SimArgs),
    /// Experiments on the built-in simulator.
    #[cfg(feature = "sim")]
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
    /// The flight daemon: camera, pipeline, safety gate, iNav's telemetry (MAVLink or
    /// MSP) and the roll over MSP.
    Run(flight::RunArgs),
    /// Recorded events (and attitude) through the same pipeline: one line per window.
    Replay(flight::ReplayArgs),
    /// Validate a config file: prints `ok` or the key and the reason it is refused.
    CheckConfig {
        /// Path to faithd.toml.
        path: PathBuf,
    },
    /// Read the flight controller's set-up over its MSP port (`command.sink.endpoint`)
    /// and say whether faithd's roll route can work, naming the iNav CLI line that
    /// fixes each problem. Exit 0 when it can, 2 when it is refused, 1 when the flight
    /// controller cannot be read. `faithd run` does the same check before its gate
    /// can open.
    CheckFc(flight::CheckFcArgs),
    /// Print a completion script for a shell (bash, zsh, fish, elvish, powershell),
    /// e.g. `faithd completions bash > /etc/bash_completion.d/faithd`.
    Completions { shell: clap_complete::Shell },
    /// Write a manual page per command into DIR (packaging; the .deb installs them).
    #[command(hide = true)]
    ManPages { dir: PathBuf },
}

#[cfg(feature = "sim")]
#[derive(Subcommand)]
enum BenchCommand {
    /// Table I of the paper: all four FOE methods on simulated flights.
    Foe(simulate::BenchFoeArgs),
    /// The whole pipeline at given event rates: per-stage cost per window, throughput,
    /// load shedding and peak memory.
    Pipeline(simulate::BenchPipelineArgs),
    /// Fit the model of the pipeline's compute time that simulated flights charge
    /// (`sim --cpu-scale`) to this machine, and show how well the committed one fits.
    Compute(simulate::BenchComputeArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let daemon = matches!(cli.command, Command::Run(_));
    let _log = faithd::logging::init(default_log_filter(&cli.command));
    let exit = match try_main(cli.command) {
        Ok(()) => Exit::Ok,
        Err(failure) => {
            // The daemon's story is in its log (the journal); the tools talk to a
            // terminal. A replay that differs is a finding, not an error.
            match (&failure.why, daemon, failure.exit) {
                (None, ..) => {}
                (Some(why), true, _) => tracing::error!("{why}"),
                (Some(why), false, Exit::Differs) => eprintln!("{why}"),
                (Some(why), false, _) => eprintln!("error: {why}"),
            }
            failure.exit
        }
    };
    ExitCode::from(exit as u8)
}

fn try_main(command: Command) -> Result<(), Failure> {
    match command {
        #[cfg(feature = "sim")]
        Command::Demo(args) => simulate::demo(&args),
        #[cfg(feature = "sim")]
        Command::Sim(args) => simulate::sim(&args),
        #[cfg(feature = "sim")]
        Command::Bench {
            what: BenchCommand::Foe(args),
        } => simulate::bench_foe(&args),
        #[cfg(feature = "sim")]
        Command::Bench {
            what: BenchCommand::Compute(args),
        } => simulate::bench_compute(&args),
        #[cfg(feature = "sim")]
        Command::Bench {
            what: BenchCommand::Pipeline(args),
        } => simulate::bench_pipeline(&args),
        Command::Run(args) => flight::run(&args),
        Command::Replay(args) => flight::replay(&args),
        Command::CheckConfig { path } => flight::check_config(&path),
        Command::CheckFc(args) => flight::check_fc(&args),
        Command::Completions { shell } => {
            docs::print_completions(Cli::command(), shell);
            Ok(())
        }
        Command::ManPages { dir } => {
            let pages = docs::write_man_pages(Cli::command(), &dir).map_err(|e| {
                Failure::failed(format!(
                    "cannot write the manual pages to {}: {e}",
                    dir.display()
                ))
            })?;
            println!("{} manual pages in {}", pages.len(), dir.display());
            Ok(())
        }
    }
}

/// What is logged unless RUST_LOG says otherwise.
fn default_log_filter(command: &Command) -> &'static str {
    match command {
        // The experiment flies the daemon a hundred times: only its warnings.
        #[cfg(feature = "sim")]
        Command::Sim(_) => "warn",
        // The demo shows the daemon's gate and manoeuvre lines, not every decision.
        #[cfg(feature = "sim")]
        Command::Demo(_) => "info,faithd_daemon::cycle=warn",
        _ => "info",
    }
}
