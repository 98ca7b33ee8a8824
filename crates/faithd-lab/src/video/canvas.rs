//! The frame's pixels (RGB, 8 bits a channel, rows top to bottom) and the colours
//! every part of a frame draws with, named for what they mean so that the picture,
//! the legend and the tests agree.

use plotters::style::RGBColor;

/// Background of the camera view: near black, so that events and overlays stand out.
pub const VIEW_BACKGROUND: RGBColor = RGBColor(14, 14, 18);
/// Background of the text panel and the time bar.
pub const PANEL_BACKGROUND: RGBColor = RGBColor(34, 34, 42);
pub const TEXT: RGBColor = RGBColor(236, 236, 236);
pub const DIM_TEXT: RGBColor = RGBColor(150, 150, 162);

/// Events by polarity, muted: they are the backdrop the flow is computed from.
pub const EVENT_ON: RGBColor = RGBColor(120, 48, 48);
pub const EVENT_OFF: RGBColor = RGBColor(45, 68, 135);

/// Flow vectors in no cluster (noise, or no TTC).
pub const UNCLUSTERED: RGBColor = RGBColor(125, 125, 125);
/// Flow vectors by cluster, in turn: none of them the colour of an FOE, the
/// obstacle or a polarity.
pub const CLUSTERS: [RGBColor; 4] = [
    RGBColor(0, 205, 225),
    RGBColor(185, 125, 255),
    RGBColor(255, 125, 205),
    RGBColor(200, 200, 120),
];

/// Flow arrows (a sample of the vectors), over the vectors' coloured dots.
pub const ARROW: RGBColor = RGBColor(245, 245, 245);

/// The pipeline's FOE: a yellow cross.
pub const FOE_ESTIMATED: RGBColor = RGBColor(255, 225, 0);
/// The simulator's true FOE: a green ring.
pub const FOE_TRUE: RGBColor = RGBColor(0, 235, 110);

/// The obstacle's box when the decision is to roll, and the roll on the time bar.
pub const ROLL: RGBColor = RGBColor(255, 120, 0);
/// The obstacle's box when the decision holds (far, not ahead, unconfirmed).
pub const OBSTACLE_HELD: RGBColor = RGBColor(235, 235, 235);

/// The safety gate on the panel and the time bar.
pub const GATE_OPEN: RGBColor = RGBColor(40, 190, 80);
pub const GATE_CLOSED: RGBColor = RGBColor(200, 50, 50);
pub const GATE_UNKNOWN: RGBColor = RGBColor(80, 80, 90);
/// The time bar's lanes where nothing is marked yet.
pub const LANE: RGBColor = RGBColor(58, 58, 68);

/// An RGB image in memory: what the encoders take.
pub struct Canvas {
    pub width: u32,
    pub height: u32,
    /// `width * height * 3` bytes.
    pub rgb: Vec<u8>,
}

impl Canvas {
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            rgb: vec![0; width as usize * height as usize * 3],
        }
    }

    /// Fills the rectangle from (`x0`, `y0`) inclusive to (`x1`, `y1`) exclusive,
    /// clipped to the image.
    pub fn fill(&mut self, (x0, y0): (i64, i64), (x1, y1): (i64, i64), colour: RGBColor) {
        let (x0, x1) = (
            x0.max(0) as usize,
            x1.min(i64::from(self.width)).max(0) as usize,
        );
        let (y0, y1) = (
            y0.max(0) as usize,
            y1.min(i64::from(self.height)).max(0) as usize,
        );
        let stride = self.width as usize * 3;
        for y in y0..y1 {
            for px in self.rgb[y * stride + x0 * 3..y * stride + x1 * 3].chunks_exact_mut(3) {
                px.copy_from_slice(&[colour.0, colour.1, colour.2]);
            }
        }
    }

    /// Copies `src` (an image of `width` by `height`) with its top-left at (`x`, `y`).
    pub fn blit(&mut self, src: &Canvas, (x, y): (u32, u32)) {
        let stride = self.width as usize * 3;
        let row = src.width as usize * 3;
        for (r, line) in src.rgb.chunks_exact(row).enumerate() {
            let at = (y as usize + r) * stride + x as usize * 3;
            self.rgb[at..at + row].copy_from_slice(line);
        }
    }

    /// The colour at (`x`, `y`).
    pub fn pixel(&self, x: u32, y: u32) -> RGBColor {
        let i = (y as usize * self.width as usize + x as usize) * 3;
        RGBColor(self.rgb[i], self.rgb[i + 1], self.rgb[i + 2])
    }
}
