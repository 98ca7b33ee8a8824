//! How fast the video plays. The daemon decides 100 times a second: one frame per
//! window at real time is too fast to follow, so the video plays slowed down
//! (`--video-speed`, a fraction of real time, 0.25 by default: a second of flight
//! lasts four). Above 30 frames a second, windows are left out of the picture (never
//! out of the time bar) rather than asking players for rates they drop.

/// The most frames a second a video asks for.
pub const MAX_FPS: f64 = 30.0;

/// The default speed: a quarter of real time, 25 frames a second at 100 windows a
/// second, every window drawn.
pub const DEFAULT_SPEED: f64 = 0.25;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pace {
    /// Every how many windows a frame is drawn.
    pub every: usize,
    /// Frames a second of video.
    pub fps: f64,
}

impl Pace {
    /// For windows `period_us` apart played at `speed` times real time.
    pub fn new(period_us: i64, speed: f64) -> Self {
        let windows_per_s = 1e6 / period_us.max(1) as f64;
        let wanted_fps = windows_per_s * speed;
        let every = (wanted_fps / MAX_FPS).ceil().max(1.0) as usize;
        Self {
            every,
            fps: wanted_fps / every as f64,
        }
    }

    /// The display time of frame `index` in hundredths of a second (a GIF's unit),
    /// rounded so that the frames' sum keeps to the video's clock.
    pub fn delay_cs(&self, index: usize) -> u16 {
        let at_cs = |i: usize| (i as f64 * 100.0 / self.fps).round() as i64;
        (at_cs(index + 1) - at_cs(index)).clamp(1, i64::from(u16::MAX)) as u16
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quarter_of_real_time_draws_every_window_at_25_frames_a_second() {
        let pace = Pace::new(10_000, DEFAULT_SPEED);
        assert_eq!(
            pace,
            Pace {
                every: 1,
                fps: 25.0
            }
        );
        assert!((0..10).all(|i| pace.delay_cs(i) == 4));
    }

    #[test]
    fn real_time_leaves_windows_out_to_keep_under_30_frames_a_second() {
        let pace = Pace::new(10_000, 1.0);
        assert_eq!(pace.every, 4);
        assert_eq!(pace.fps, 25.0);
    }

    #[test]
    fn delays_that_do_not_divide_keep_to_the_clock() {
        let pace = Pace::new(10_000, 0.3);
        let total: u32 = (0..30).map(|i| u32::from(pace.delay_cs(i))).sum();
        assert_eq!(total, 100, "30 frames at 30 fps are one second");
    }
}
