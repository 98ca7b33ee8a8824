//! `--video FILE` on `replay`, `demo` and `sim`. The arguments are in every build,
//! so that the flight build, which has no video, can say so; the film itself
//! (`faithd::video`) is in the workstation build (feature `sim`).

use std::path::PathBuf;

use clap::Args;
use faithd_core::pipeline::PipelineConfig;

use crate::Failure;

#[derive(Args, Clone, Debug)]
pub struct VideoArgs {
    /// Write the flight as a video, one frame per decision window: FILE.mp4 (through
    /// ffmpeg, which must be installed), FILE.gif (animated GIF), or a directory or
    /// NAME.png (numbered PNG frames). Workstation builds only: the flight build
    /// refuses it.
    #[arg(long, value_name = "FILE")]
    pub video: Option<PathBuf>,
    /// How fast the video plays, as a fraction of real time: 0.25 shows a second of
    /// flight in four seconds, every 10 ms window a frame at 25 frames a second.
    /// Faster than 30 frames a second, windows are left out of the picture (never
    /// out of the time bar).
    #[arg(long, default_value_t = 0.25, value_parser = parse_speed, value_name = "FRACTION")]
    pub video_speed: f64,
}

/// `--video-speed`: 0.01 to 100 times real time.
fn parse_speed(text: &str) -> Result<f64, String> {
    let speed: f64 = text
        .parse()
        .map_err(|_| format!("`{text}` is not a number"))?;
    if (0.01..=100.0).contains(&speed) {
        Ok(speed)
    } else {
        Err(format!(
            "must be 0.01 to 100 (times real time), got {speed}"
        ))
    }
}

#[cfg(not(feature = "sim"))]
pub use flight_build::ReplayFilm;

#[cfg(feature = "sim")]
pub use workstation::{ReplayFilm, check_output, write_flight};

/// What a replay's video is of (the flight build, which draws none, reads none of it).
#[cfg_attr(not(feature = "sim"), allow(dead_code))]
pub enum ReplaySource<'a> {
    /// A recording cut into windows `window_us` long.
    Events {
        events: &'a std::path::Path,
        pipeline: &'a PipelineConfig,
        window_us: i64,
    },
    /// A daemon recording replayed as its window log says.
    WindowLog {
        events: &'a std::path::Path,
        log: &'a std::path::Path,
        /// The settings of `--config`, when given (else the log's).
        pipeline: Option<&'a PipelineConfig>,
    },
}

#[cfg(not(feature = "sim"))]
mod flight_build {
    use super::{ReplaySource, VideoArgs};
    use crate::Failure;
    use faithd_core::event::Event;
    use faithd_core::pipeline::WindowReport;

    /// The flight build draws nothing: `--video` is refused, with where to get it.
    pub struct ReplayFilm;

    impl ReplayFilm {
        pub fn start(args: &VideoArgs, _: ReplaySource<'_>) -> Result<Self, Failure> {
            match &args.video {
                Some(path) => Err(Failure::refused(format!(
                    "--video {}: this faithd is the flight build, which draws no video; replay the same files with a workstation build (`cargo run --release -- replay ... --video FILE`, default features)",
                    path.display()
                ))),
                None => Ok(Self),
            }
        }

        pub fn watch(&mut self, _: &[Event], _: &WindowReport<'_>) -> Result<(), String> {
            Ok(())
        }

        pub fn finish(self) -> Result<(), Failure> {
            Ok(())
        }
    }
}

#[cfg(feature = "sim")]
mod workstation {
    use std::io::IsTerminal;
    use std::time::Instant;

    use super::{ReplaySource, VideoArgs};
    use crate::Failure;
    use faithd::closed_loop::film::FilmedFlight;
    use faithd::video::{Film, Frame, TimeSpan, VideoSpec, View};
    use faithd_core::event::Event;
    use faithd_core::pipeline::PipelineConfig;
    use faithd_core::pipeline::WindowReport;

    /// A video being written, with a progress bar on a terminal.
    pub struct Filming {
        film: Film,
        progress: indicatif::ProgressBar,
        started: Instant,
    }

    impl Filming {
        /// Opens the video `args` asks for (`None` when none is): a flight over
        /// `span` of about `windows` windows `period_us` apart. `show_progress`
        /// false keeps the bar away from a terminal that takes other output.
        pub fn start(
            args: &VideoArgs,
            pipeline: &PipelineConfig,
            title: String,
            span: TimeSpan,
            (windows, period_us): (usize, i64),
            show_progress: bool,
        ) -> Result<Option<Self>, Failure> {
            let Some(path) = &args.video else {
                return Ok(None);
            };
            let spec = VideoSpec {
                path: path.clone(),
                speed: args.video_speed,
            };
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|e| {
                    Failure::refused(format!("--video: cannot create {}: {e}", dir.display()))
                })?;
            }
            let film = Film::create(&spec, View::of(pipeline), title, span, period_us)
                .map_err(|e| Failure::refused(format!("--video: {e}")))?;
            let progress = crate::progress::progress_bar(film.frames_for(windows) as u64, "frames");
            if !show_progress {
                progress.set_draw_target(indicatif::ProgressDrawTarget::hidden());
            }
            Ok(Some(Self {
                film,
                progress,
                started: Instant::now(),
            }))
        }

        pub fn add(&mut self, frame: &Frame) -> Result<(), String> {
            self.film.add(frame).map_err(|e| e.to_string())?;
            self.progress
                .set_position(self.film.frames_for(self.film.windows()) as u64);
            Ok(())
        }

        /// Closes the video and says what it holds and how fast it was drawn.
        pub fn finish(self) -> Result<(), Failure> {
            self.progress.finish_and_clear();
            let summary = self
                .film
                .finish()
                .map_err(|e| Failure::failed(format!("--video: {e}")))?;
            let wall_s = self.started.elapsed().as_secs_f64();
            eprintln!(
                "video: {} ({} frames of {}x{} at {:.1} frames a second, {} windows; written at {:.0} frames a second)",
                summary.path.display(),
                summary.frames,
                summary.width,
                summary.height,
                summary.fps,
                summary.windows,
                summary.frames as f64 / wall_s.max(1e-9)
            );
            Ok(())
        }
    }

    /// Refuses a video that cannot be written before any flight is flown for it.
    pub fn check_output(args: &VideoArgs) -> Result<(), Failure> {
        match &args.video {
            Some(path) => faithd::video::output::check(path)
                .map_err(|e| Failure::refused(format!("--video: {e}"))),
            None => Ok(()),
        }
    }

    /// Draws a simulated flight's frames into the video `args` asks for.
    pub fn write_flight(
        args: &VideoArgs,
        film: FilmedFlight,
        title: String,
    ) -> Result<(), Failure> {
        let windows = (film.frames.len(), film.period_us);
        let Some(mut filming) =
            Filming::start(args, &film.pipeline, title, film.span, windows, true)?
        else {
            return Ok(());
        };
        for frame in &film.frames {
            filming.add(frame).map_err(Failure::failed)?;
        }
        filming.finish()
    }

    /// A replay's film: every window the replay runs becomes a frame.
    pub struct ReplayFilm(Option<Filming>);

    impl ReplayFilm {
        pub fn start(args: &VideoArgs, source: ReplaySource<'_>) -> Result<Self, Failure> {
            if args.video.is_none() {
                return Ok(Self(None));
            }
            let refused = |e: faithd::replay::ReplayError| Failure::refused(e);
            let (pipeline, title, span, windows, period_us) = match source {
                ReplaySource::Events {
                    events,
                    pipeline,
                    window_us,
                } => {
                    let (first_us, last_us) = faithd::replay::events_span(events)
                        .map_err(refused)?
                        .unwrap_or((0, 0));
                    let span = TimeSpan {
                        start_us: first_us + window_us,
                        end_us: last_us + window_us,
                    };
                    let windows = ((last_us - first_us) / window_us.max(1) + 1) as usize;
                    (*pipeline, name_of(events), span, windows, window_us)
                }
                ReplaySource::WindowLog {
                    events,
                    log,
                    pipeline,
                } => {
                    let outline = faithd::replay::window_log_outline(log).map_err(refused)?;
                    let (first_us, last_us, windows) = outline.windows.unwrap_or((0, 0, 0));
                    let period_us = (last_us - first_us) / (windows.max(2) as i64 - 1);
                    let span = TimeSpan {
                        start_us: first_us,
                        end_us: last_us,
                    };
                    let title = format!("{}, windows as flown", name_of(events));
                    let pipeline = pipeline.copied().unwrap_or(outline.pipeline);
                    (pipeline, title, span, windows, period_us.max(1))
                }
            };
            let title = format!("faithd replay of {title}");
            // The replay prints its windows on standard output: a progress bar on
            // the same terminal would be torn by them.
            let show_progress = !std::io::stdout().is_terminal();
            Filming::start(
                args,
                &pipeline,
                title,
                span,
                (windows, period_us),
                show_progress,
            )
            .map(Self)
        }

        pub fn watch(&mut self, events: &[Event], report: &WindowReport<'_>) -> Result<(), String> {
            match &mut self.0 {
                Some(filming) => filming.add(&Frame::of_window(events, report)),
                None => Ok(()),
            }
        }

        pub fn finish(self) -> Result<(), Failure> {
            self.0.map_or(Ok(()), Filming::finish)
        }
    }

    fn name_of(path: &std::path::Path) -> String {
        path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        )
    }
}

/// A video's progress and errors belong to the command; failures writing it are
/// failures of the job (exit 1), not refusals of its input.
pub fn replay_failure(e: faithd::replay::ReplayError) -> Failure {
    match e {
        faithd::replay::ReplayError::Watch(why) => Failure::failed(format!("--video: {why}")),
        e => Failure::refused(e),
    }
}
