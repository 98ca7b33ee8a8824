//! Flight videos (`--video FILE` on `faithd replay`, `demo` and `sim`): every
//! decision window as one frame a person can read in a few seconds. The picture is
//! the camera's, scaled up, with the flow, the clusters, the obstacle's box and the
//! FOE (and the true FOE when the source knows it); beside it the decision and its
//! reason, the safety gate and the roll on iNav; under it the flight on a time bar.
//!
//! A replay and a simulated flight fill the same [`Frame`]; a [`Film`] draws each
//! ([`render`]) and writes it ([`output`]: MP4 through ffmpeg, an animated GIF or
//! PNG frames) at a pace a person can follow ([`pace`]).
//!
//! Workstation only (feature `sim`): it draws with plotters and its font, which the
//! flight build leaves out.

pub mod frame;
pub mod canvas;
pub mod view;
pub mod legend;
pub mod panel;
pub mod time_bar;
pub mod words;
pub mod render;
pub mod pace;
pub mod output;

use std::path::{Path, PathBuf};

pub use frame::{Frame, FrameVector, InavRoll, Truth};
pub use pace::{DEFAULT_SPEED, Pace};
pub use time_bar::TimeSpan;
pub use view::View;

#[derive(Debug, thiserror::Error)]
pub enum VideoError {
    #[error(
        "{path}: a video ends in .mp4 (through ffmpeg), .gif (animated GIF) or .png (numbered PNG frames beside it), or is a directory (PNG frames in it)"
    )]
    UnknownKind { path: String },
    #[error(
        "{path}: writing MP4 needs ffmpeg, and there is none on PATH: install it (`apt install ffmpeg`), or ask for an animated GIF (a path ending in .gif) or PNG frames (a directory)"
    )]
    NoFfmpeg { path: String },
    #[error("{path}: {what}")]
    Ffmpeg { path: String, what: String },
    #[error("cannot write {path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("cannot encode {path}: {what}")]
    Encode { path: String, what: String },
    #[error("cannot draw a frame: {0}")]
    Draw(String),
}

/// What plotters' drawing calls come back with, as a video error.
pub type DrawResult = Result<(), VideoError>;

pub fn drawn(e: impl std::fmt::Display) -> VideoError {
    VideoError::Draw(e.to_string())
}

/// What to write: `--video FILE` and `--video-speed`.
#[derive(Clone, Debug, PartialEq)]
pub struct VideoSpec {
    pub path: PathBuf,
    /// Fraction of real time the video plays at.
    pub speed: f64,
}

/// A video being written: windows go in in order, frames come out at the pace.
pub struct Film {
    renderer: render::Renderer,
    output: output::Output,
    pace: Pace,
    path: PathBuf,
    windows: usize,
    frames: usize,
}

/// What was written.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmSummary {
    pub path: PathBuf,
    pub frames: usize,
    pub windows: usize,
    pub fps: f64,
    pub width: u32,
    pub height: u32,
}

impl Film {
    /// Opens the video for a flight of windows `period_us` apart over `span`,
    /// titled `title`. Fails before drawing anything when the file cannot be
    /// written (no ffmpeg for MP4, an unknown kind, no such directory).
    pub fn create(
        spec: &VideoSpec,
        view: View,
        title: String,
        span: TimeSpan,
        period_us: i64,
    ) -> Result<Self, VideoError> {
        let pace = Pace::new(period_us, spec.speed);
        let renderer = render::Renderer::new(view, title, span)?;
        let output = output::Output::create(&spec.path, renderer.size(), &pace)?;
        Ok(Self {
            renderer,
            output,
            pace,
            path: spec.path.clone(),
            windows: 0,
            frames: 0,
        })
    }

    /// Takes the next window; draws and writes it when the pace says so.
    pub fn add(&mut self, frame: &Frame) -> Result<(), VideoError> {
        self.renderer.advance(frame);
        let drawn = self.windows.is_multiple_of(self.pace.every);
        self.windows += 1;
        if drawn {
            let canvas = self.renderer.draw(frame)?;
            self.output.write(canvas)?;
            self.frames += 1;
        }
        Ok(())
    }

    /// Frames the video will hold for `windows` windows.
    pub fn frames_for(&self, windows: usize) -> usize {
        windows.div_ceil(self.pace.every)
    }

    pub fn finish(self) -> Result<FilmSummary, VideoError> {
        let (width, height) = self.renderer.size();
        self.output.finish()?;
        Ok(FilmSummary {
            path: self.path,
            frames: self.frames,
            windows: self.windows,
            fps: self.pace.fps,
            width,
            height,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Windows taken so far.
    pub fn windows(&self) -> usize {
        self.windows
    }
}
