//! The strip under the picture: the whole flight from left to right, filled in as
//! the video plays. One lane shows the safety gate (green open, red closed), one
//! the roll (orange while iNav rolls, or, when a recording does not say, for as
//! long as the pipeline asked), one a tick for every window that called for a
//! roll. A person sees where in the flight the frame is and what led to the roll.
//!
//! The strip keeps its own pixels and paints only each new window's columns, so a
//! long recording costs the same per frame as a short one.

use plotters::prelude::*;

use super::canvas::{self, Canvas};
use super::frame::Frame;
use super::{DrawResult, drawn};
use faithd_core::decide::Action;

/// The flight's first and last window ends, microseconds: the bar's ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TimeSpan {
    pub start_us: i64,
    pub end_us: i64,
}

impl TimeSpan {
    pub fn duration_s(&self) -> f64 {
        (self.end_us - self.start_us) as f64 * 1e-6
    }
}

pub const HEIGHT: u32 = 84;
/// Room for the lanes' names on the left.
const LEFT: i64 = 96;
const RIGHT: i64 = 24;
/// Lanes: rows of the strip (top inclusive, bottom exclusive).
const GATE_ROWS: (i64, i64) = (10, 26);
const ROLL_ROWS: (i64, i64) = (30, 46);
const CALL_ROWS: (i64, i64) = (50, 56);
const AXIS_ROW: i64 = 60;

pub struct TimeBar {
    strip: Canvas,
    span: TimeSpan,
    /// The column up to which the gate and roll lanes are painted.
    painted_x: Option<i64>,
    /// A roll the pipeline asked for runs this long (recordings without iNav's roll).
    asked_until_us: i64,
}

impl TimeBar {
    pub fn new(width: u32, span: TimeSpan) -> Result<Self, super::VideoError> {
        // Its labels are drawn now, with the bundled font.
        faithd_sim::bench::plot::use_bundled_font();
        let mut strip = Canvas::new(width, HEIGHT);
        strip.fill(
            (0, 0),
            (i64::from(width), i64::from(HEIGHT)),
            canvas::PANEL_BACKGROUND,
        );
        let mut bar = Self {
            strip,
            span,
            painted_x: None,
            asked_until_us: i64::MIN,
        };
        for rows in [GATE_ROWS, ROLL_ROWS, CALL_ROWS] {
            bar.paint(rows, LEFT, bar.right(), canvas::LANE);
        }
        bar.draw_axis()?;
        Ok(bar)
    }

    fn right(&self) -> i64 {
        i64::from(self.strip.width) - RIGHT
    }

    /// The column of time `t_us`.
    pub fn x(&self, t_us: i64) -> i64 {
        let span_us = (self.span.end_us - self.span.start_us).max(1) as f64;
        let f = ((t_us - self.span.start_us) as f64 / span_us).clamp(0.0, 1.0);
        LEFT + (f * (self.right() - LEFT) as f64).round() as i64
    }

    fn paint(&mut self, (top, bottom): (i64, i64), x0: i64, x1: i64, colour: RGBColor) {
        self.strip.fill((x0, top), (x1, bottom), colour);
    }

    /// Paints the lanes up to `frame`'s window.
    pub fn advance(&mut self, frame: &Frame) {
        let x1 = self.x(frame.t_us) + 1;
        let x0 = self.painted_x.unwrap_or(x1 - 1);
        let gate = match frame.gate {
            Some(g) if g.is_open() => canvas::GATE_OPEN,
            Some(_) => canvas::GATE_CLOSED,
            None => canvas::GATE_UNKNOWN,
        };
        self.paint(GATE_ROWS, x0, x1, gate);
        match frame.inav_roll {
            Some(roll) if roll.direction.is_some() => self.paint(ROLL_ROWS, x0, x1, canvas::ROLL),
            Some(_) => {}
            None => self.mark_asked_roll(frame),
        }
        if matches!(frame.decision.action, Action::Roll { .. }) {
            let x = self.x(frame.t_us);
            self.paint(CALL_ROWS, x, x + 2, canvas::ROLL);
        }
        self.painted_x = Some(x1);
    }

    /// Without iNav's roll, the lane shows the roll as the pipeline asked for it:
    /// from a window that calls for one, for its duration (the daemon ignores calls
    /// while it rolls).
    fn mark_asked_roll(&mut self, frame: &Frame) {
        let Action::Roll { duration_us, .. } = frame.decision.action else {
            return;
        };
        if frame.t_us < self.asked_until_us {
            return;
        }
        self.asked_until_us = frame.t_us + duration_us;
        let (x0, x1) = (self.x(frame.t_us), self.x(self.asked_until_us));
        self.paint(ROLL_ROWS, x0, x1 + 1, canvas::ROLL);
    }

    pub fn strip(&self) -> &Canvas {
        &self.strip
    }

    /// Time ticks and their labels, once: whole seconds, or halves and fifths of
    /// them on short flights.
    fn draw_axis(&mut self) -> Result<(), super::VideoError> {
        let duration_s = self.span.duration_s().max(1e-3);
        let step_s = [
            0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 30.0, 60.0, 120.0, 300.0, 600.0,
        ]
        .into_iter()
        .find(|s| duration_s / s <= 12.0)
        .unwrap_or(1800.0);
        let ticks: Vec<(i64, f64)> = (0..)
            .map(|k| f64::from(k) * step_s)
            .take_while(|t| *t <= duration_s + 1e-9)
            .map(|t| (self.x(self.span.start_us + (t * 1e6) as i64), t))
            .collect();
        let (width, height) = (self.strip.width, self.strip.height);
        let area =
            BitMapBackend::with_buffer(&mut self.strip.rgb, (width, height)).into_drawing_area();
        let font = ("sans-serif", 15).into_font().color(&canvas::DIM_TEXT);
        for (x, t) in ticks {
            let x = x as i32;
            area.draw(&PathElement::new(
                vec![(x, AXIS_ROW as i32), (x, AXIS_ROW as i32 + 4)],
                canvas::DIM_TEXT.stroke_width(1),
            ))
            .map_err(drawn)?;
            let label = if step_s < 1.0 {
                format!("{t:.1} s")
            } else {
                format!("{t:.0} s")
            };
            area.draw(&Text::new(
                label,
                (x - 10, AXIS_ROW as i32 + 6),
                font.clone(),
            ))
            .map_err(drawn)?;
        }
        area.present().map_err(drawn)
    }

    /// Over the strip, once it is in the frame (`area` is the strip's place): the
    /// lanes' names, which say where the roll lane comes from, and the cursor at
    /// `frame`.
    pub fn draw_marks<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, plotters::coord::Shift>,
        frame: &Frame,
    ) -> DrawResult {
        let roll = if frame.inav_roll.is_some() {
            "iNav roll"
        } else {
            "roll asked"
        };
        for (name, (top, _)) in [
            ("gate", GATE_ROWS),
            (roll, ROLL_ROWS),
            ("roll calls", CALL_ROWS),
        ] {
            let size = if top == CALL_ROWS.0 { 12 } else { 15 };
            let style = ("sans-serif", size).into_font().color(&canvas::DIM_TEXT);
            area.draw(&Text::new(name, (8, top as i32 - 1), style))
                .map_err(drawn)?;
        }
        let x = self.x(frame.t_us) as i32;
        area.draw(&PathElement::new(
            vec![(x, GATE_ROWS.0 as i32 - 6), (x, CALL_ROWS.1 as i32 + 2)],
            canvas::TEXT.stroke_width(2),
        ))
        .map_err(drawn)
    }

    /// The frame pixel rows of the roll lane, for the tests.
    pub fn roll_rows() -> (i64, i64) {
        ROLL_ROWS
    }

    /// The same for the gate lane.
    pub fn gate_rows() -> (i64, i64) {
        GATE_ROWS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ends_of_the_flight_are_the_ends_of_the_bar() {
        let bar = TimeBar::new(
            1000,
            TimeSpan {
                start_us: 5_000_000,
                end_us: 7_000_000,
            },
        )
        .unwrap();
        assert_eq!(bar.x(5_000_000), LEFT);
        assert_eq!(bar.x(7_000_000), 1000 - RIGHT);
        assert_eq!(bar.x(6_000_000), (LEFT + 1000 - RIGHT) / 2);
        // Before and after the span: pinned to the ends, never off the strip.
        assert_eq!(bar.x(0), LEFT);
        assert_eq!(bar.x(i64::MAX / 2), 1000 - RIGHT);
    }
}
