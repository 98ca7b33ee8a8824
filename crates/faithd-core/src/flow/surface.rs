//! The surface of active events: latest timestamp per pixel and polarity.

use crate::event::Polarity;

/// Marks a pixel that has never fired.
pub const NEVER_US: i64 = i64::MIN;

/// Latest event time per pixel and polarity, as one flat preallocated table.
pub struct ActiveEventSurface {
    width_px: usize,
    height_px: usize,
    t_us: Vec<i64>,
}

impl ActiveEventSurface {
    pub fn new(width_px: u16, height_px: u16) -> Self {
        let (w, h) = (usize::from(width_px), usize::from(height_px));
        Self {
            width_px: w,
            height_px: h,
            t_us: vec![NEVER_US; 2 * w * h],
        }
    }

    pub fn width_px(&self) -> usize {
        self.width_px
    }

    pub fn height_px(&self) -> usize {
        self.height_px
    }

    fn index(&self, x_px: usize, y_px: usize, polarity: Polarity) -> usize {
        (polarity.index() * self.height_px + y_px) * self.width_px + x_px
    }

    /// Latest time at a pixel; `x_px`, `y_px` must be on the sensor.
    pub fn get(&self, x_px: usize, y_px: usize, polarity: Polarity) -> i64 {
        self.t_us[self.index(x_px, y_px, polarity)]
    }

    /// The latest times of one polarity, row by row (`y_px * width_px + x_px`).
    pub fn plane(&self, polarity: Polarity) -> &[i64] {
        let size = self.width_px * self.height_px;
        &self.t_us[polarity.index() * size..(polarity.index() + 1) * size]
    }

    /// Stores a new time and returns the previous one.
    pub fn set(&mut self, x_px: usize, y_px: usize, polarity: Polarity, t_us: i64) -> i64 {
        let i = self.index(x_px, y_px, polarity);
        std::mem::replace(&mut self.t_us[i], t_us)
    }

    /// Copies one column, both polarities, from a surface of the same size.
    pub fn copy_column_from(&mut self, other: &Self, x_px: usize) {
        debug_assert_eq!(
            (self.width_px, self.height_px),
            (other.width_px, other.height_px)
        );
        for i in (x_px..self.t_us.len()).step_by(self.width_px) {
            self.t_us[i] = other.t_us[i];
        }
    }

    /// Forgets every event (a new flight, or a camera that reconnected).
    pub fn clear(&mut self) {
        self.t_us.fill(NEVER_US);
    }
}
