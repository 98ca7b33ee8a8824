//! Top view of a closed-loop flight: poles, the path, where faithd rolled.

use std::path::Path;

use plotters::prelude::*;

use super::FlightOutcome;
use faithd_sim::bench::plot::{PlotError, fail, use_bundled_font};

pub fn plot_flight(outcome: &FlightOutcome, path: &Path) -> Result<(), PlotError> {
    use_bundled_font();
    let err = fail(path);
    let root = BitMapBackend::new(path, (900, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
    let xs = outcome.path.iter().map(|p| p.x_m);
    let x0 = xs.clone().fold(f64::INFINITY, f64::min).min(-1.0) - 0.5;
    let x1 = xs.fold(f64::NEG_INFINITY, f64::max).max(1.0) + 0.5;
    let ys = outcome
        .path
        .iter()
        .map(|p| p.y_m)
        .chain(outcome.spec.poles.iter().map(|p| p.1));
    let (ymin, ymax) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
        (a.min(y), b.max(y))
    });
    let mid = 0.5 * (ymin + ymax);
    let half = (0.5 * (ymax - ymin) + 1.0).max(0.25 * (x1 - x0));
    let caption = format!(
        "{}: min clearance {:.2} m{}",
        if outcome.collided {
            "hit the pole"
        } else {
            "no contact"
        },
        outcome.min_clearance_m,
        match outcome.ttc_at_decision_s {
            Some(t) => format!(", rolled at true TTC {t:.2} s"),
            None => ", no roll".into(),
        }
    );
    let mut chart = ChartBuilder::on(&root)
        .caption(caption, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        // North (x) to the right, east (y) down the page: the pilot's view from above.
        .build_cartesian_2d(x0..x1, (mid + half)..(mid - half))
        .map_err(|e| err(e.to_string()))?;
    chart
        .configure_mesh()
        .x_desc("x, along the arena (m)")
        .y_desc("y, to the right (m)")
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|e| err(e.to_string()))?;
    for &(px, py) in &outcome.spec.poles {
        let ring: Vec<(f64, f64)> = (0..=48)
            .map(|k| {
                let a = k as f64 / 48.0 * std::f64::consts::TAU;
                (px + 0.25 * a.cos(), py + 0.25 * a.sin())
            })
            .collect();
        chart
            .draw_series(std::iter::once(Polygon::new(
                ring,
                RGBColor(90, 90, 90).filled(),
            )))
            .map_err(|e| err(e.to_string()))?;
    }
    chart
        .draw_series(LineSeries::new(
            outcome.path.iter().map(|p| (p.x_m, p.y_m)),
            RGBColor(30, 100, 200).stroke_width(2),
        ))
        .map_err(|e| err(e.to_string()))?
        .label("path")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(30, 100, 200)));
    chart
        .draw_series(
            outcome
                .path
                .iter()
                .filter(|p| p.roll_us != 1500)
                .map(|p| Circle::new((p.x_m, p.y_m), 3, RGBColor(220, 40, 40).filled())),
        )
        .map_err(|e| err(e.to_string()))?
        .label("roll commanded")
        .legend(|(x, y)| Circle::new((x + 10, y), 4, RGBColor(220, 40, 40).filled()));
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(|e| err(e.to_string()))?;
    root.present().map_err(|e| err(e.to_string()))
}

/// The experiment at a glance: each flight's closest approach to a pole against its
/// course's offset from the first pole's centre, coloured by whether faithd rolled.
/// Collision courses lie between the two dashed lines; a dot below zero gap is a hit.
/// Rolls belong inside the band and none outside it, so a false avoidance or a missed
/// roll stands out as a dot of the wrong colour on the wrong side.
pub fn plot_outcomes(outcomes: &[FlightOutcome], path: &Path) -> Result<(), PlotError> {
    use_bundled_font();
    let err = fail(path);
    let root = BitMapBackend::new(path, (900, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
    let contact_m = super::FlightSpec::contact_distance_m();
    let x_max = outcomes
        .iter()
        .map(|o| o.spec.lateral_offset_m.abs())
        .fold(contact_m, f64::max)
        + 0.1;
    let y_max = outcomes
        .iter()
        .map(|o| o.min_clearance_m)
        .filter(|m| m.is_finite())
        .fold(1.0, f64::max)
        + 0.1;
    let avoided = outcomes
        .iter()
        .filter(|o| o.collision_course && !o.collided)
        .count();
    let courses = outcomes.iter().filter(|o| o.collision_course).count();
    let false_rolls = outcomes
        .iter()
        .filter(|o| !o.collision_course && o.rolled)
        .count();
    let caption = format!(
        "{} flights: {avoided} of {courses} collision courses avoided, {false_rolls} of {} near passes rolled on",
        outcomes.len(),
        outcomes.len() - courses
    );
    let mut chart = ChartBuilder::on(&root)
        .caption(caption, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(-x_max..x_max, -0.2..y_max)
        .map_err(|e| err(e.to_string()))?;
    chart
        .configure_mesh()
        .x_desc("course offset from the pole's centre (m)")
        .y_desc("closest gap to a pole (m)")
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|e| err(e.to_string()))?;
    let grey = RGBColor(120, 120, 120);
    for x in [-contact_m, contact_m] {
        chart
            .draw_series(DashedLineSeries::new(
                [(x, -0.2), (x, y_max)],
                6,
                4,
                grey.stroke_width(1),
            ))
            .map_err(|e| err(e.to_string()))?;
    }
    chart
        .draw_series(LineSeries::new([(-x_max, 0.0), (x_max, 0.0)], BLACK))
        .map_err(|e| err(e.to_string()))?;
    let classes = [
        (true, false, "rolled", RGBColor(30, 100, 200)),
        (false, false, "no roll", RGBColor(150, 150, 150)),
        (true, true, "rolled, hit", RGBColor(220, 40, 40)),
        (false, true, "no roll, hit", RGBColor(120, 0, 0)),
    ];
    for (rolled, hit, label, colour) in classes {
        let dots: Vec<(f64, f64)> = outcomes
            .iter()
            .filter(|o| o.rolled == rolled && o.collided == hit)
            .map(|o| (o.spec.lateral_offset_m, o.min_clearance_m.max(-0.2)))
            .collect();
        if dots.is_empty() {
            continue;
        }
        chart
            .draw_series(dots.into_iter().map(|p| Circle::new(p, 4, colour.filled())))
            .map_err(|e| err(e.to_string()))?
            .label(label)
            .legend(move |(x, y)| Circle::new((x + 10, y), 4, colour.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(|e| err(e.to_string()))?;
    root.present().map_err(|e| err(e.to_string()))
}
