//! A whole frame: the camera's picture on the left with the key to its marks
//! under it, the panel of words on the right, the time bar across the bottom.

use plotters::prelude::*;

use super::canvas::{self, Canvas};
use super::frame::Frame;
use super::legend;
use super::panel::{self, Panel};
use super::time_bar::{self, TimeBar, TimeSpan};
use super::view::{self, View};
use super::{VideoError, drawn};

pub struct Renderer {
    view: View,
    title: String,
    span: TimeSpan,
    bar: TimeBar,
    canvas: Canvas,
}

impl Renderer {
    pub fn new(view: View, title: String, span: TimeSpan) -> Result<Self, VideoError> {
        // The same DejaVu Sans as the figures, compiled in: no font on the machine
        // is needed.
        faithd_sim::bench::plot::use_bundled_font();
        let (view_w, view_h) = view.size();
        // Even sides: the video encoders' 4:2:0 colour needs them.
        let width = (view_w + panel::WIDTH).next_multiple_of(2);
        let height = ((view_h + legend::HEIGHT).max(MIN_PANEL_HEIGHT) + time_bar::HEIGHT)
            .next_multiple_of(2);
        Ok(Self {
            bar: TimeBar::new(width, span)?,
            canvas: Canvas::new(width, height),
            view,
            title,
            span,
        })
    }

    pub fn size(&self) -> (u32, u32) {
        (self.canvas.width, self.canvas.height)
    }

    /// Where the time bar's strip starts in the frame.
    pub fn time_bar_top(&self) -> u32 {
        self.canvas.height - time_bar::HEIGHT
    }

    pub fn view(&self) -> &View {
        &self.view
    }

    /// Takes a window into the time bar. Every window goes through here, also those
    /// the video's pace leaves undrawn, so that the bar misses none.
    pub fn advance(&mut self, frame: &Frame) {
        self.bar.advance(frame);
    }

    /// Draws `frame` (after [`Self::advance`]).
    pub fn draw(&mut self, frame: &Frame) -> Result<&Canvas, VideoError> {
        let (width, height) = self.size();
        let bar_top = self.time_bar_top();
        self.canvas.fill(
            (0, 0),
            (i64::from(width), i64::from(height)),
            canvas::PANEL_BACKGROUND,
        );
        view::draw_events(&mut self.canvas, frame, &self.view);
        self.canvas.blit(self.bar.strip(), (0, bar_top));

        let (view_w, view_h) = self.view.size();
        {
            let root = BitMapBackend::with_buffer(&mut self.canvas.rgb, (width, height))
                .into_drawing_area();
            let picture = root.clone().shrink((0, 0), (view_w, view_h));
            view::draw_overlays(&picture, frame, &self.view)?;
            let words = root.clone().shrink((view_w, 0), (width - view_w, bar_top));
            let mut panel = Panel::new(&words);
            panel.draw(frame, &self.title, &self.span)?;
            let key = root.clone().shrink((0, view_h), (view_w, legend::HEIGHT));
            legend::draw(&key, frame.truth.is_some())?;
            let bar = root.clone().shrink((0, bar_top), (width, time_bar::HEIGHT));
            self.bar.draw_marks(&bar, frame)?;
            root.present().map_err(drawn)?;
        }
        Ok(&self.canvas)
    }
}

/// The panel needs this much height whatever the camera's.
const MIN_PANEL_HEIGHT: u32 = 560;
