//! The key to the picture's marks, in a strip under it: each mark drawn as in the
//! picture, with a few words.

use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::canvas;
use super::{DrawResult, drawn};

pub const HEIGHT: u32 = 56;

/// Draws the key on `area` (the strip); the true FOE's mark only when the source
/// knows it.
pub fn draw<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, truth: bool) -> DrawResult {
    let rows: [&[(i32, Swatch, &str)]; 2] = [
        &[
            (10, Swatch::Square(canvas::EVENT_ON), "ON events"),
            (120, Swatch::Square(canvas::EVENT_OFF), "OFF events"),
            (240, Swatch::Cross(canvas::FOE_ESTIMATED), "FOE (faithd)"),
            (
                370,
                if truth {
                    Swatch::Ring(canvas::FOE_TRUE)
                } else {
                    Swatch::None
                },
                if truth { "true FOE" } else { "" },
            ),
            (470, Swatch::Flow, "flow by cluster (grey: none)"),
        ],
        &[
            (10, Swatch::Box(canvas::ROLL), "obstacle: rolls"),
            (150, Swatch::Box(canvas::OBSTACLE_HELD), "obstacle: holds"),
            (
                300,
                Swatch::Dashed(canvas::OBSTACLE_HELD),
                "the FOE in here puts it in the way",
            ),
        ],
    ];
    let style = ("sans-serif", 15).into_font().color(&canvas::DIM_TEXT);
    for (row, items) in rows.iter().enumerate() {
        let y = 6 + 24 * row as i32;
        for &(x, swatch, label) in items.iter() {
            swatch.draw(area, (x + 9, y + 9))?;
            area.draw(&Text::new(label, (x + 26, y), style.clone()))
                .map_err(drawn)?;
        }
    }
    Ok(())
}

/// A mark, the same shape as in the picture.
#[derive(Clone, Copy)]
enum Swatch {
    Square(RGBColor),
    Cross(RGBColor),
    Ring(RGBColor),
    Box(RGBColor),
    Dashed(RGBColor),
    /// A cluster's dots with an arrow.
    Flow,
    None,
}

impl Swatch {
    fn draw<DB: DrawingBackend>(
        self,
        area: &DrawingArea<DB, Shift>,
        (x, y): (i32, i32),
    ) -> DrawResult {
        let outline = |c: RGBColor, dashed: bool| {
            let corners = vec![
                (x - 9, y - 6),
                (x + 9, y - 6),
                (x + 9, y + 6),
                (x - 9, y + 6),
                (x - 9, y - 6),
            ];
            if dashed {
                area.draw(&DashedPathElement::new(corners, 3, 3, c.stroke_width(1)))
            } else {
                area.draw(&PathElement::new(corners, c.stroke_width(2)))
            }
        };
        match self {
            Swatch::Square(c) => area.draw(&Rectangle::new(
                [(x - 5, y - 5), (x + 5, y + 5)],
                c.filled(),
            )),
            Swatch::Cross(c) => {
                let style = c.stroke_width(3);
                area.draw(&PathElement::new(vec![(x - 8, y), (x + 8, y)], style))
                    .and_then(|_| area.draw(&PathElement::new(vec![(x, y - 8), (x, y + 8)], style)))
            }
            Swatch::Ring(c) => area.draw(&Circle::new((x, y), 7, c.stroke_width(3))),
            Swatch::Box(c) => outline(c, false),
            Swatch::Dashed(c) => outline(c, true),
            Swatch::Flow => {
                for (dx, c) in [
                    (-8, canvas::CLUSTERS[0]),
                    (-2, canvas::CLUSTERS[1]),
                    (4, canvas::UNCLUSTERED),
                ] {
                    area.draw(&Rectangle::new(
                        [(x + dx - 1, y + 3), (x + dx + 1, y + 5)],
                        c.filled(),
                    ))
                    .map_err(drawn)?;
                }
                let style = canvas::ARROW.stroke_width(1);
                area.draw(&PathElement::new(
                    vec![(x - 8, y - 1), (x + 8, y - 1)],
                    style,
                ))
                .map_err(drawn)?;
                area.draw(&PathElement::new(
                    vec![(x + 4, y - 4), (x + 8, y - 1), (x + 4, y + 2)],
                    style,
                ))
            }
            Swatch::None => Ok(()),
        }
        .map_err(drawn)
    }
}
