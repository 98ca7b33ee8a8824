//! Where the frames go, chosen by the path: `.mp4` through ffmpeg (Debian's, when
//! installed: faithd carries no video codec of its own), `.gif` an animated GIF, a
//! directory (or a path ending in `/`) or a `.png` name PNG frames, numbered.
//! Asking for MP4 without ffmpeg is refused, never quietly turned into something
//! else.

use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};

use super::VideoError;
use super::canvas::{self, Canvas};
use super::pace::Pace;

/// What a path asks for.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum VideoKind {
    Mp4,
    Gif,
    /// PNG files `<stem>-00001.png`, ... beside a `.png` name, or `frame-00001.png`,
    /// ... in a directory.
    PngFrames {
        dir: PathBuf,
        stem: String,
    },
}

impl VideoKind {
    pub fn of(path: &Path) -> Result<Self, VideoError> {
        let text = path.to_string_lossy();
        let extension = path.extension().map(|e| e.to_string_lossy().to_lowercase());
        if text.ends_with('/') || path.is_dir() {
            return Ok(VideoKind::PngFrames {
                dir: path.to_path_buf(),
                stem: "frame".into(),
            });
        }
        match extension.as_deref() {
            Some("mp4") => Ok(VideoKind::Mp4),
            Some("gif") => Ok(VideoKind::Gif),
            Some("png") => Ok(VideoKind::PngFrames {
                dir: path
                    .parent()
                    .filter(|p| !p.as_os_str().is_empty())
                    .map_or_else(|| PathBuf::from("."), Path::to_path_buf),
                stem: path
                    .file_stem()
                    .map_or_else(|| "frame".into(), |s| s.to_string_lossy().into_owned()),
            }),
            _ => Err(VideoError::UnknownKind {
                path: path.display().to_string(),
            }),
        }
    }
}

/// Whether a video can be written at `path` as far as can be told before the
/// first frame: a kind faithd writes, and ffmpeg for MP4. For the commands that
/// fly before they draw.
pub fn check(path: &Path) -> Result<(), VideoError> {
    match VideoKind::of(path)? {
        VideoKind::Mp4 if find_on_path("ffmpeg").is_none() => Err(VideoError::NoFfmpeg {
            path: path.display().to_string(),
        }),
        _ => Ok(()),
    }
}

/// An open video.
pub enum Output {
    Mp4(Ffmpeg),
    Gif(GifFile),
    Png(PngFrames),
}

impl Output {
    /// Opens `path` for frames of `size` at `pace`; fails before any frame is drawn
    /// when it cannot be written (no ffmpeg, no such directory).
    pub fn create(path: &Path, size: (u32, u32), pace: &Pace) -> Result<Self, VideoError> {
        Ok(match VideoKind::of(path)? {
            VideoKind::Mp4 => Output::Mp4(Ffmpeg::start(path, size, pace)?),
            VideoKind::Gif => Output::Gif(GifFile::create(path, size, *pace)?),
            VideoKind::PngFrames { dir, stem } => Output::Png(PngFrames::create(dir, stem)?),
        })
    }

    pub fn write(&mut self, frame: &Canvas) -> Result<(), VideoError> {
        match self {
            Output::Mp4(f) => f.write(frame),
            Output::Gif(g) => g.write(frame),
            Output::Png(p) => p.write(frame),
        }
    }

    /// Closes the video; for MP4, waits for ffmpeg and checks that it succeeded.
    pub fn finish(self) -> Result<(), VideoError> {
        match self {
            Output::Mp4(f) => f.finish(),
            Output::Gif(g) => g.finish(),
            Output::Png(_) => Ok(()),
        }
    }
}

fn io_error(path: &Path) -> impl Fn(std::io::Error) -> VideoError + '_ {
    move |source| VideoError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// Raw RGB frames piped into ffmpeg, which writes H.264 (or its default MP4 codec)
/// in 4:2:0, the colour format every player takes.
pub struct Ffmpeg {
    path: PathBuf,
    child: Child,
    stdin: Option<ChildStdin>,
    /// ffmpeg's complaints, read on a thread so that a full pipe cannot stall it.
    stderr: Option<std::thread::JoinHandle<String>>,
}

impl Ffmpeg {
    fn start(path: &Path, (width, height): (u32, u32), pace: &Pace) -> Result<Self, VideoError> {
        let Some(ffmpeg) = find_on_path("ffmpeg") else {
            return Err(VideoError::NoFfmpeg {
                path: path.display().to_string(),
            });
        };
        let rate = format!("{}/1000", (pace.fps * 1000.0).round() as u64);
        let mut child = Command::new(ffmpeg)
            .args(["-hide_banner", "-loglevel", "error", "-nostdin", "-y"])
            .args(["-f", "rawvideo", "-pix_fmt", "rgb24"])
            .args(["-s", &format!("{width}x{height}"), "-r", &rate, "-i", "-"])
            .args(["-pix_fmt", "yuv420p", "-movflags", "+faststart"])
            .arg(path)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| VideoError::Ffmpeg {
                path: path.display().to_string(),
                what: format!("cannot start ffmpeg: {e}"),
            })?;
        let stdin = child.stdin.take();
        let stderr = child.stderr.take().map(|mut s| {
            std::thread::spawn(move || {
                let mut text = String::new();
                let _ = s.read_to_string(&mut text);
                text
            })
        });
        Ok(Self {
            path: path.to_path_buf(),
            child,
            stdin,
            stderr,
        })
    }

    fn write(&mut self, frame: &Canvas) -> Result<(), VideoError> {
        let stdin = self.stdin.as_mut().expect("open until finished");
        if let Err(e) = stdin.write_all(&frame.rgb) {
            // ffmpeg has gone: its own words say more than a broken pipe.
            return Err(self.failure(&format!("stopped taking frames ({e})")));
        }
        Ok(())
    }

    fn finish(mut self) -> Result<(), VideoError> {
        drop(self.stdin.take());
        let status = self.child.wait().map_err(|e| VideoError::Ffmpeg {
            path: self.path.display().to_string(),
            what: format!("cannot wait for ffmpeg: {e}"),
        })?;
        if status.success() {
            return Ok(());
        }
        Err(self.failure(&format!("ended with {status}")))
    }

    fn failure(&mut self, what: &str) -> VideoError {
        drop(self.stdin.take());
        let _ = self.child.wait();
        let said = self
            .stderr
            .take()
            .and_then(|t| t.join().ok())
            .unwrap_or_default();
        VideoError::Ffmpeg {
            path: self.path.display().to_string(),
            what: format!("ffmpeg {what}: {}", said.trim()),
        }
    }
}

/// The first executable file `name` in the directories of PATH.
fn find_on_path(name: &str) -> Option<PathBuf> {
    use std::os::unix::fs::PermissionsExt;
    std::env::split_paths(&std::env::var_os("PATH")?)
        .map(|dir| dir.join(name))
        .find(|p| {
            std::fs::metadata(p).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
        })
}

/// An animated GIF on one fixed palette: every colour a frame is drawn with, a
/// colour cube for what lies between (text edges), and greys. A fixed palette
/// costs a table look-up per pixel, where quantising each frame costs tens of
/// milliseconds, and the marks keep their exact colours.
pub struct GifFile {
    path: PathBuf,
    encoder: gif::Encoder<BufWriter<std::fs::File>>,
    palette: Palette,
    pace: Pace,
    frames: usize,
    indices: Vec<u8>,
}

impl GifFile {
    fn create(path: &Path, (width, height): (u32, u32), pace: Pace) -> Result<Self, VideoError> {
        let file = std::fs::File::create(path).map_err(io_error(path))?;
        let palette = Palette::new();
        let gif_error = |e: gif::EncodingError| VideoError::Encode {
            path: path.display().to_string(),
            what: e.to_string(),
        };
        let mut encoder = gif::Encoder::new(
            BufWriter::new(file),
            width as u16,
            height as u16,
            &palette.rgb,
        )
        .map_err(gif_error)?;
        encoder
            .set_repeat(gif::Repeat::Infinite)
            .map_err(gif_error)?;
        Ok(Self {
            path: path.to_path_buf(),
            encoder,
            palette,
            pace,
            frames: 0,
            indices: Vec::new(),
        })
    }

    fn write(&mut self, frame: &Canvas) -> Result<(), VideoError> {
        self.indices.clear();
        self.indices.extend(
            frame
                .rgb
                .chunks_exact(3)
                .map(|p| self.palette.index(p[0], p[1], p[2])),
        );
        let gif_frame = gif::Frame {
            width: frame.width as u16,
            height: frame.height as u16,
            delay: self.pace.delay_cs(self.frames),
            buffer: std::borrow::Cow::Borrowed(&self.indices),
            ..gif::Frame::default()
        };
        self.encoder
            .write_frame(&gif_frame)
            .map_err(|e| VideoError::Encode {
                path: self.path.display().to_string(),
                what: e.to_string(),
            })?;
        self.frames += 1;
        Ok(())
    }

    fn finish(self) -> Result<(), VideoError> {
        let path = self.path;
        let mut writer = self.encoder.into_inner().map_err(|e| VideoError::Encode {
            path: path.display().to_string(),
            what: e.to_string(),
        })?;
        writer.flush().map_err(io_error(&path))
    }
}

/// The GIF's 256 colours and the nearest of them for every colour at 5 bits a
/// channel.
struct Palette {
    rgb: Vec<u8>,
    nearest: Vec<u8>,
}

impl Palette {
    fn new() -> Self {
        let mut colours: Vec<(u8, u8, u8)> = [
            canvas::VIEW_BACKGROUND,
            canvas::PANEL_BACKGROUND,
            canvas::TEXT,
            canvas::DIM_TEXT,
            canvas::EVENT_ON,
            canvas::EVENT_OFF,
            canvas::UNCLUSTERED,
            canvas::ARROW,
            canvas::FOE_ESTIMATED,
            canvas::FOE_TRUE,
            canvas::ROLL,
            canvas::OBSTACLE_HELD,
            canvas::GATE_OPEN,
            canvas::GATE_CLOSED,
            canvas::GATE_UNKNOWN,
            canvas::LANE,
        ]
        .into_iter()
        .chain(canvas::CLUSTERS)
        .map(|c| (c.0, c.1, c.2))
        .collect();
        let level = |i: u8| i * 51;
        for r in 0..6 {
            for g in 0..6 {
                for b in 0..6 {
                    colours.push((level(r), level(g), level(b)));
                }
            }
        }
        // The rest: greys between the cube's, for text edges on the dark panels.
        let greys = 256usize.saturating_sub(colours.len());
        for k in 0..greys {
            let grey = (12 + 232 * k / greys.max(1)) as u8;
            colours.push((grey, grey, grey));
        }
        colours.truncate(256);
        let nearest = (0..32 * 32 * 32)
            .map(|i: usize| {
                let at = |shift: usize| (((i >> shift) & 31) * 8 + 4) as i32;
                let (r, g, b) = (at(10), at(5), at(0));
                colours
                    .iter()
                    .enumerate()
                    .min_by_key(|(_, c)| {
                        let d = |a: u8, b: i32| (i32::from(a) - b).pow(2);
                        d(c.0, r) + d(c.1, g) + d(c.2, b)
                    })
                    .map_or(0, |(k, _)| k as u8)
            })
            .collect();
        Self {
            rgb: colours.iter().flat_map(|c| [c.0, c.1, c.2]).collect(),
            nearest,
        }
    }

    fn index(&self, r: u8, g: u8, b: u8) -> u8 {
        let key = (usize::from(r >> 3) << 10) | (usize::from(g >> 3) << 5) | usize::from(b >> 3);
        self.nearest[key]
    }
}

/// One PNG file a frame, numbered from 1.
pub struct PngFrames {
    dir: PathBuf,
    stem: String,
    frames: usize,
}

impl PngFrames {
    fn create(dir: PathBuf, stem: String) -> Result<Self, VideoError> {
        std::fs::create_dir_all(&dir).map_err(io_error(&dir))?;
        Ok(Self {
            dir,
            stem,
            frames: 0,
        })
    }

    fn write(&mut self, frame: &Canvas) -> Result<(), VideoError> {
        self.frames += 1;
        let path = self
            .dir
            .join(format!("{}-{:05}.png", self.stem, self.frames));
        let file = std::fs::File::create(&path).map_err(io_error(&path))?;
        let mut encoder = png::Encoder::new(BufWriter::new(file), frame.width, frame.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_compression(png::Compression::Fast);
        let png_error = |e: png::EncodingError| VideoError::Encode {
            path: path.display().to_string(),
            what: e.to_string(),
        };
        let mut writer = encoder.write_header().map_err(png_error)?;
        writer.write_image_data(&frame.rgb).map_err(png_error)?;
        writer.finish().map_err(png_error)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_path_says_what_to_write() {
        assert_eq!(VideoKind::of(Path::new("f.MP4")).unwrap(), VideoKind::Mp4);
        assert_eq!(
            VideoKind::of(Path::new("out/f.gif")).unwrap(),
            VideoKind::Gif
        );
        assert_eq!(
            VideoKind::of(Path::new("out/flight.png")).unwrap(),
            VideoKind::PngFrames {
                dir: "out".into(),
                stem: "flight".into()
            }
        );
        assert_eq!(
            VideoKind::of(Path::new("out/frames/")).unwrap(),
            VideoKind::PngFrames {
                dir: "out/frames/".into(),
                stem: "frame".into()
            }
        );
        let err = VideoKind::of(Path::new("f.avi")).unwrap_err().to_string();
        assert!(err.contains(".mp4") && err.contains(".gif"), "{err}");
    }

    #[test]
    fn every_colour_of_the_drawing_is_its_own_in_the_gif() {
        let palette = Palette::new();
        for c in [
            canvas::FOE_ESTIMATED,
            canvas::FOE_TRUE,
            canvas::ROLL,
            canvas::GATE_OPEN,
            canvas::EVENT_ON,
            canvas::EVENT_OFF,
        ] {
            let i = usize::from(palette.index(c.0, c.1, c.2)) * 3;
            assert_eq!(&palette.rgb[i..i + 3], &[c.0, c.1, c.2], "{c:?}");
        }
    }

    #[test]
    fn mp4_without_ffmpeg_is_refused_with_what_to_do() {
        let err = VideoError::NoFfmpeg {
            path: "f.mp4".into(),
        }
        .to_string();
        assert!(
            err.contains("apt install ffmpeg") && err.contains(".gif"),
            "{err}"
        );
    }
}
