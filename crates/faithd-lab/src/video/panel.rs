//! The text beside the picture, top to bottom in the order a person asks: when is
//! this, what did faithd decide and why, where is it heading, may it act (the
//! gate), is iNav rolling.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::TextStyle;

use super::canvas;
use super::frame::Frame;
use super::time_bar::TimeSpan;
use super::words::{self, GateWord};
use super::{DrawResult, drawn};
use faithd_core::decide::Action;

pub const WIDTH: u32 = 420;
const MARGIN: i32 = 16;
const SECTION_GAP: i32 = 14;

/// Draws on `area`, which is the panel (its origin at the panel's top left).
pub struct Panel<'a, DB: DrawingBackend> {
    area: &'a DrawingArea<DB, Shift>,
    y: i32,
}

impl<'a, DB: DrawingBackend> Panel<'a, DB> {
    pub fn new(area: &'a DrawingArea<DB, Shift>) -> Self {
        Self { area, y: MARGIN }
    }

    fn style(size: u32, colour: &RGBColor) -> TextStyle<'static> {
        ("sans-serif", size).into_font().color(colour)
    }

    /// One line, or as many as `text` needs at the panel's width.
    fn text(&mut self, text: &str, size: u32, colour: &RGBColor) -> DrawResult {
        let style = Self::style(size, colour);
        let max_width = WIDTH - 2 * MARGIN as u32;
        let mut line = String::new();
        for word in text.split(' ') {
            let candidate = if line.is_empty() {
                word.to_string()
            } else {
                format!("{line} {word}")
            };
            let (w, _) = self
                .area
                .estimate_text_size(&candidate, &style)
                .map_err(drawn)?;
            if w > max_width && !line.is_empty() {
                self.line(&line, size, &style)?;
                line = word.to_string();
            } else {
                line = candidate;
            }
        }
        self.line(&line, size, &style)
    }

    fn line(&mut self, text: &str, size: u32, style: &TextStyle<'_>) -> DrawResult {
        self.area
            .draw(&Text::new(
                text.to_string(),
                (MARGIN, self.y),
                style.clone(),
            ))
            .map_err(drawn)?;
        self.y += (size as f64 * 1.3) as i32;
        Ok(())
    }

    fn heading(&mut self, text: &str) -> DrawResult {
        self.y += SECTION_GAP;
        self.text(text, 14, &canvas::DIM_TEXT)
    }

    /// Everything for one frame.
    pub fn draw(&mut self, frame: &Frame, title: &str, span: &TimeSpan) -> DrawResult {
        self.text(title, 15, &canvas::DIM_TEXT)?;
        let t_s = (frame.t_us - span.start_us) as f64 * 1e-6;
        self.text(
            &format!("t = {t_s:.2} s of {:.2} s", span.duration_s()),
            20,
            &canvas::TEXT,
        )?;

        self.heading("DECISION")?;
        let rolling = matches!(frame.decision.action, Action::Roll { .. });
        let colour = if rolling { canvas::ROLL } else { canvas::TEXT };
        self.text(&words::headline(&frame.decision), 32, &colour)?;
        self.text(&words::reason(&frame.decision.reason), 17, &canvas::TEXT)?;

        self.heading("HEADING AND FLOW")?;
        self.text(&words::heading(&frame.foe), 17, &canvas::TEXT)?;
        if let Some(truth) = frame.truth {
            let line = match (truth.foe_px, frame.foe.point()) {
                (Some((tx, ty)), Some((x, y))) => format!(
                    "true FOE ({tx:.0}, {ty:.0}) px: {:.0} px off",
                    (x - tx).hypot(y - ty)
                ),
                (Some((tx, ty)), None) => format!("true FOE ({tx:.0}, {ty:.0}) px"),
                (None, _) => "true FOE behind the camera".into(),
            };
            self.text(&line, 17, &canvas::FOE_TRUE)?;
            self.text(
                &format!("true time to contact {:.2} s", truth.ttc_s),
                17,
                &canvas::FOE_TRUE,
            )?;
        }
        self.text(
            &format!(
                "{} events, {} vectors, {} clusters{}",
                frame.events.len(),
                frame.vectors.len(),
                frame.clusters.len(),
                if frame.derotated {
                    ""
                } else {
                    ", not derotated"
                }
            ),
            15,
            &canvas::DIM_TEXT,
        )?;

        self.heading("SAFETY GATE")?;
        let (word, why) = words::gate(frame.gate.as_ref());
        let colour = match word {
            GateWord::Open => canvas::GATE_OPEN,
            GateWord::Closed => canvas::GATE_CLOSED,
            GateWord::Unknown => canvas::DIM_TEXT,
        };
        self.text(word.label(), 24, &colour)?;
        self.text(&why, 16, &canvas::TEXT)?;

        self.heading("ROLL ON iNAV")?;
        let roll_colour = match frame.inav_roll {
            Some(r) if r.direction.is_some() => canvas::ROLL,
            Some(_) => canvas::TEXT,
            None => canvas::DIM_TEXT,
        };
        self.text(
            &words::inav_roll(frame.inav_roll.as_ref()),
            17,
            &roll_colour,
        )
    }
}
