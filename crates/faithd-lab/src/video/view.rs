//! The camera's picture, scaled up: the window's events by polarity, the flow
//! history coloured by cluster with arrows on a sample of it, the obstacle's box,
//! and the FOE (a yellow cross) beside the true one (a green ring) when known.

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::canvas::{self, Canvas};
use super::frame::Frame;
use super::words;
use super::{DrawResult, drawn};
use faithd_core::decide::{Action, DecisionConfig, Reason, foe_region, not_in_the_way};
use faithd_core::event::Polarity;
use faithd_core::foe::FoeEstimate;
use faithd_core::pipeline::PipelineConfig;

/// At most this many flow arrows: more hide the picture they explain.
const MAX_ARROWS: usize = 300;
/// An arrow shows where its edge moves in this time, clamped to the lengths below:
/// normal flow ranges from a few px/s near the FOE to hundreds at the border.
const ARROW_SPAN_S: f64 = 0.1;
const ARROW_MIN_PX: f64 = 4.0;
const ARROW_MAX_PX: f64 = 10.0;

/// The camera's picture: the sensor's size, how much it is scaled up, and the
/// decision's margins (to draw where the FOE counts as in an obstacle's way).
#[derive(Clone, Copy, Debug)]
pub struct View {
    pub width_px: u16,
    pub height_px: u16,
    /// Frame pixels per sensor pixel.
    pub scale: u32,
    pub decision: DecisionConfig,
}

impl View {
    /// The picture of the pipeline `config` runs: 3 frame pixels a sensor pixel for
    /// the DVS240, fewer for larger sensors.
    pub fn of(config: &PipelineConfig) -> Self {
        let camera = &config.camera;
        View {
            width_px: camera.width_px,
            height_px: camera.height_px,
            scale: (720 / u32::from(camera.width_px.max(1))).clamp(1, 4),
            decision: config.decision,
        }
    }

    pub fn size(&self) -> (u32, u32) {
        (
            u32::from(self.width_px) * self.scale,
            u32::from(self.height_px) * self.scale,
        )
    }

    /// The frame pixel at the centre of sensor position (`x_px`, `y_px`).
    pub fn at(&self, x_px: f64, y_px: f64) -> (i32, i32) {
        let s = f64::from(self.scale);
        ((x_px * s + 0.5 * s) as i32, (y_px * s + 0.5 * s) as i32)
    }

    fn contains(&self, x_px: f64, y_px: f64) -> bool {
        (0.0..f64::from(self.width_px)).contains(&x_px)
            && (0.0..f64::from(self.height_px)).contains(&y_px)
    }
}

/// The background and the events: straight into the pixels (a window has thousands).
pub fn draw_events(canvas: &mut Canvas, frame: &Frame, view: &View) {
    let (w, h) = view.size();
    canvas.fill(
        (0, 0),
        (i64::from(w), i64::from(h)),
        canvas::VIEW_BACKGROUND,
    );
    let s = i64::from(view.scale);
    for e in &frame.events {
        if e.x_px >= view.width_px || e.y_px >= view.height_px {
            continue;
        }
        let colour = match e.polarity {
            Polarity::On => canvas::EVENT_ON,
            Polarity::Off => canvas::EVENT_OFF,
        };
        let (x, y) = (i64::from(e.x_px) * s, i64::from(e.y_px) * s);
        canvas.fill((x, y), (x + s, y + s), colour);
    }
}

/// Everything drawn over the events.
pub fn draw_overlays<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    frame: &Frame,
    view: &View,
) -> DrawResult {
    draw_flow(area, frame, view)?;
    draw_obstacle(area, frame, view)?;
    if let Some(truth_px) = frame.truth.and_then(|t| t.foe_px) {
        draw_true_foe(area, truth_px, view)?;
    }
    draw_foe(area, &frame.foe, view)
}

/// The colour of a vector in `cluster`: the obstacle's when it is the cluster the
/// decision was about, its own otherwise, grey in none.
fn cluster_colour(cluster: Option<u32>, obstacle: Option<(u32, RGBColor)>) -> RGBColor {
    match (cluster, obstacle) {
        (Some(id), Some((obstacle_id, colour))) if id == obstacle_id => colour,
        (Some(id), _) => canvas::CLUSTERS[id as usize % canvas::CLUSTERS.len()],
        (None, _) => canvas::UNCLUSTERED,
    }
}

/// The cluster the decision was about, and its colour: orange when it rolls,
/// white when it holds.
fn obstacle(frame: &Frame) -> Option<(u32, RGBColor)> {
    let o = frame.decision.obstacle?;
    let colour = if matches!(frame.decision.action, Action::Roll { .. }) {
        canvas::ROLL
    } else {
        canvas::OBSTACLE_HELD
    };
    Some((o.id, colour))
}

/// A dot on every vector of the history (its cluster's colour), and an arrow on an
/// even sample of them.
fn draw_flow<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    frame: &Frame,
    view: &View,
) -> DrawResult {
    let obstacle = obstacle(frame);
    for v in &frame.vectors {
        let (x, y) = view.at(f64::from(v.x_px), f64::from(v.y_px));
        let colour = cluster_colour(v.cluster, obstacle);
        area.draw(&Rectangle::new(
            [(x - 1, y - 1), (x + 1, y + 1)],
            colour.filled(),
        ))
        .map_err(drawn)?;
    }
    let step = frame.vectors.len().div_ceil(MAX_ARROWS).max(1);
    let s = f64::from(view.scale);
    let style = canvas::ARROW.mix(0.85).stroke_width(1);
    for v in frame.vectors.iter().step_by(step) {
        let (u, w) = (f64::from(v.u_px_s), f64::from(v.v_px_s));
        let speed = u.hypot(w);
        if !(speed > 0.0 && speed.is_finite()) {
            continue;
        }
        let length_px = (speed * ARROW_SPAN_S).clamp(ARROW_MIN_PX, ARROW_MAX_PX) * s;
        let (dx, dy) = (u / speed, w / speed);
        let from = view.at(f64::from(v.x_px), f64::from(v.y_px));
        let tip = (
            from.0 + (dx * length_px) as i32,
            from.1 + (dy * length_px) as i32,
        );
        let head = 0.35 * length_px;
        let barb = |side: f64| {
            let (bx, by) = (-dx * 0.87 - side * dy * 0.5, -dy * 0.87 + side * dx * 0.5);
            (tip.0 + (bx * head) as i32, tip.1 + (by * head) as i32)
        };
        area.draw(&PathElement::new(vec![from, tip], style))
            .map_err(drawn)?;
        area.draw(&PathElement::new(vec![barb(1.0), tip, barb(-1.0)], style))
            .map_err(drawn)?;
    }
    Ok(())
}

/// The cluster the decision was about: its box (thick when it is ahead, thin when
/// the FOE is outside its reach), and dashed around it where the FOE counts as in
/// its way (the decision's margins), labelled with its time to contact.
fn draw_obstacle<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    frame: &Frame,
    view: &View,
) -> DrawResult {
    let (Some(o), Some((_, colour))) = (frame.decision.obstacle, obstacle(frame)) else {
        return Ok(());
    };
    let ahead = !matches!(frame.decision.reason, Reason::ObstacleNotAhead);
    let s = view.scale as i32;
    let corners = |x0: f64, y0: f64, x1: f64, y1: f64| {
        let (a, b) = (view.at(x0, y0), view.at(x1, y1));
        ((a.0 - s, a.1 - s), (b.0 + s, b.1 + s))
    };
    let region = foe_region(&o, &frame.clusters, &view.decision);
    let (r0, r1) = corners(
        region.min_x_px,
        region.min_y_px,
        region.max_x_px,
        region.max_y_px,
    );
    let outline = vec![
        (r0.0, r0.1),
        (r1.0, r0.1),
        (r1.0, r1.1),
        (r0.0, r1.1),
        (r0.0, r0.1),
    ];
    area.draw(&DashedPathElement::new(
        outline,
        6,
        6,
        colour.stroke_width(1),
    ))
    .map_err(drawn)?;
    let (b0, b1) = corners(o.min_x_px, o.min_y_px, o.max_x_px, o.max_y_px);
    let width = if ahead { 3 } else { 1 };
    area.draw(&Rectangle::new([b0, b1], colour.stroke_width(width)))
        .map_err(drawn)?;
    let label = if ahead {
        format!("obstacle {:.2} s", o.mean_ttc_s)
    } else {
        let why = frame.decision.foe_px.and_then(|foe_px| {
            let width_px = f64::from(view.width_px);
            not_in_the_way(&o, &frame.clusters, &view.decision, width_px, foe_px)
        });
        format!(
            "nearest {:.2} s: {}",
            o.mean_ttc_s,
            why.map_or("not in the way", words::not_in_the_way)
        )
    };
    let (view_w, view_h) = view.size();
    // Above the box, else below it, else inside its top; never off the picture.
    let at_y = if b0.1 >= 26 {
        b0.1 - 24
    } else if b1.1 + 26 <= view_h as i32 {
        b1.1 + 6
    } else {
        b0.1.max(0) + 6
    };
    let at = (b0.0.clamp(4, view_w as i32 - 230), at_y);
    let style = ("sans-serif", 18).into_font().color(&colour);
    let (w, h) = area.estimate_text_size(&label, &style).map_err(drawn)?;
    area.draw(&Rectangle::new(
        [
            (at.0 - 3, at.1 - 2),
            (at.0 + w as i32 + 3, at.1 + h as i32 + 2),
        ],
        canvas::VIEW_BACKGROUND.mix(0.75).filled(),
    ))
    .map_err(drawn)?;
    area.draw(&Text::new(label, at, style)).map_err(drawn)
}

/// The pipeline's FOE: a yellow cross with a dark edge; an arrow at the border when
/// it lies beyond the view.
fn draw_foe<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    foe: &FoeEstimate,
    view: &View,
) -> DrawResult {
    match *foe {
        FoeEstimate::Point { x_px, y_px, .. } => {
            let (x, y) = view.at(x_px, y_px);
            let arm = 16;
            for (colour, width) in [(BLACK, 7), (canvas::FOE_ESTIMATED, 3)] {
                let style = colour.stroke_width(width);
                area.draw(&PathElement::new(vec![(x - arm, y), (x + arm, y)], style))
                    .map_err(drawn)?;
                area.draw(&PathElement::new(vec![(x, y - arm), (x, y + arm)], style))
                    .map_err(drawn)?;
            }
            Ok(())
        }
        FoeEstimate::Unbounded { dx, dy, side, .. } => {
            let (w, h) = view.size();
            let (cx, cy) = (f64::from(w) / 2.0, f64::from(h) / 2.0);
            // Where the ray from the centre leaves the view, a little inside.
            let reach = ((cx - 20.0) / dx.abs().max(1e-9)).min((cy - 20.0) / dy.abs().max(1e-9));
            let tip = ((cx + dx * reach) as i32, (cy + dy * reach) as i32);
            let tail = (
                (cx + dx * (reach - 50.0)) as i32,
                (cy + dy * (reach - 50.0)) as i32,
            );
            let style = canvas::FOE_ESTIMATED.stroke_width(4);
            area.draw(&PathElement::new(vec![tail, tip], style))
                .map_err(drawn)?;
            area.draw(&Circle::new(tip, 6, canvas::FOE_ESTIMATED.filled()))
                .map_err(drawn)?;
            let label = format!("FOE beyond the {} edge", side.name());
            let font = ("sans-serif", 17).into_font().color(&canvas::FOE_ESTIMATED);
            let at = (
                tail.0.clamp(10, w as i32 - 200),
                tail.1.clamp(10, h as i32 - 30),
            );
            area.draw(&Text::new(label, at, font)).map_err(drawn)
        }
        FoeEstimate::Insufficient { .. } => Ok(()),
    }
}

/// The true FOE: a green ring, at the border (smaller) when it lies beyond the view.
fn draw_true_foe<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    (x_px, y_px): (f64, f64),
    view: &View,
) -> DrawResult {
    let inside = view.contains(x_px, y_px);
    let clamped = (
        x_px.clamp(3.0, f64::from(view.width_px) - 4.0),
        y_px.clamp(3.0, f64::from(view.height_px) - 4.0),
    );
    let centre = view.at(clamped.0, clamped.1);
    let radius = if inside { 13 } else { 8 };
    area.draw(&Circle::new(centre, radius, BLACK.stroke_width(6)))
        .map_err(drawn)?;
    area.draw(&Circle::new(
        centre,
        radius,
        canvas::FOE_TRUE.stroke_width(3),
    ))
    .map_err(drawn)
}
