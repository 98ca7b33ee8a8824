//! PNG figures of a benchmark run: the error and time per method (the paper's Fig. 6)
//! and one example frame (events, flow, true and estimated FOE).

use std::path::Path;
use std::sync::Once;

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

use super::foe::{BenchFoeReport, ExampleFrame};
use faithd_core::event::Polarity;
use faithd_core::foe::FoeEstimate;

/// DejaVu Sans, shipped so that figures render the same on a machine with no fonts.
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

#[derive(Debug, thiserror::Error)]
#[error("cannot draw {path}: {message}")]
pub struct PlotError {
    pub path: String,
    pub message: String,
}

pub fn fail(path: &Path) -> impl Fn(String) -> PlotError + '_ {
    move |message| PlotError {
        path: path.display().to_string(),
        message,
    }
}

pub fn use_bundled_font() {
    static REGISTER: Once = Once::new();
    REGISTER.call_once(|| {
        // The bytes are a valid TrueType font compiled into the binary.
        let _ = register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

const METHOD_COLOURS: [RGBColor; 6] = [
    RGBColor(200, 30, 30),
    RGBColor(30, 100, 200),
    RGBColor(230, 150, 20),
    RGBColor(40, 160, 60),
    RGBColor(140, 60, 170),
    RGBColor(90, 90, 90),
];

/// Mean course error (with one standard deviation) and median time per 1000 vectors
/// (log scale) for every method.
pub fn plot_errors(report: &BenchFoeReport, path: &Path) -> Result<(), PlotError> {
    use_bundled_font();
    let err = fail(path);
    // 700 px a panel leaves each of six method names its own room under its bar.
    let root = BitMapBackend::new(path, (1400, 480)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
    let (left, right) = root.split_horizontally(700);
    let n = report.methods.len();
    let names: Vec<String> = report.methods.iter().map(|m| m.name.clone()).collect();
    let label = |x: &f64| {
        let i = x.round() as usize;
        if (x - x.round()).abs() < 1e-6 && i < n {
            names[i].clone()
        } else {
            String::new()
        }
    };
    let max_err = report
        .methods
        .iter()
        .map(|m| m.mean_error_deg + m.std_error_deg)
        .fold(1.0, f64::max);
    let mut chart = ChartBuilder::on(&left)
        .caption(
            format!("Course error, {} trajectories", report.trajectories),
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(60)
        .y_label_area_size(50)
        .build_cartesian_2d(-0.5..(n as f64 - 0.5), 0.0..max_err * 1.1)
        .map_err(|e| err(e.to_string()))?;
    chart
        .configure_mesh()
        .x_labels(n)
        .x_label_formatter(&label)
        .x_label_style(("sans-serif", 11))
        .y_desc("error (deg)")
        .disable_x_mesh()
        .draw()
        .map_err(|e| err(e.to_string()))?;
    let bars: Vec<_> = report
        .methods
        .iter()
        .map(|m| {
            let lo = (m.mean_error_deg - m.std_error_deg).max(0.0);
            (m.mean_error_deg, lo, m.mean_error_deg + m.std_error_deg)
        })
        .collect();
    draw_bars(&mut chart, &bars, 0.0).map_err(&err)?;

    let max_us = report
        .methods
        .iter()
        .map(|m| m.us_per_1000_vectors_p90)
        .fold(10.0, f64::max);
    let mut chart = ChartBuilder::on(&right)
        .caption("Time per 1000 vectors", ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(60)
        .y_label_area_size(60)
        .build_cartesian_2d(-0.5..(n as f64 - 0.5), (1.0..max_us * 3.0).log_scale())
        .map_err(|e| err(e.to_string()))?;
    chart
        .configure_mesh()
        .x_labels(n)
        .x_label_formatter(&label)
        .x_label_style(("sans-serif", 11))
        .y_desc("microseconds (log)")
        .disable_x_mesh()
        .draw()
        .map_err(|e| err(e.to_string()))?;
    let bars: Vec<_> = report
        .methods
        .iter()
        .map(|m| {
            (
                m.us_per_1000_vectors.max(1.0),
                m.us_per_1000_vectors_p10.max(1.0),
                m.us_per_1000_vectors_p90.max(1.0),
            )
        })
        .collect();
    draw_bars(&mut chart, &bars, 1.0).map_err(&err)?;
    root.present().map_err(|e| err(e.to_string()))
}

/// One coloured bar per method from `base` to its value, with a whisker from `lo` to
/// `hi`; bars sit at x = 0, 1, 2, ...
fn draw_bars<Y>(
    chart: &mut ChartContext<'_, BitMapBackend<'_>, Cartesian2d<RangedCoordf64, Y>>,
    bars: &[(f64, f64, f64)],
    base: f64,
) -> Result<(), String>
where
    Y: Ranged<ValueType = f64>,
{
    for (i, &(value, lo, hi)) in bars.iter().enumerate() {
        let x = i as f64;
        let colour = METHOD_COLOURS[i % METHOD_COLOURS.len()];
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(x - 0.35, base), (x + 0.35, value)],
                colour.filled(),
            )))
            .map_err(|e| e.to_string())?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(x, lo), (x, hi)],
                BLACK.stroke_width(2),
            )))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// One evaluation window: its events, its (derotated) flow, the true FOE and every
/// method's estimate.
pub fn plot_frame(frame: &ExampleFrame, path: &Path) -> Result<(), PlotError> {
    use_bundled_font();
    let err = fail(path);
    let (w, h) = (f64::from(frame.width_px), f64::from(frame.height_px));
    let root = BitMapBackend::new(path, (980, 800)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "{} flight, course {:.1} deg: events, flow and FOE at {} ms",
                frame.scene,
                frame.course_deg,
                frame.t_us / 1000
            ),
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(30)
        .y_label_area_size(40)
        .build_cartesian_2d(0.0..w, h..0.0)
        .map_err(|e| err(e.to_string()))?;
    chart
        .configure_mesh()
        .disable_mesh()
        .draw()
        .map_err(|e| err(e.to_string()))?;
    let on = RGBColor(230, 120, 120);
    let off = RGBColor(120, 150, 230);
    chart
        .draw_series(frame.events.iter().map(|e| {
            let colour = if e.polarity == Polarity::On { on } else { off };
            Circle::new((f64::from(e.x_px), f64::from(e.y_px)), 1, colour.filled())
        }))
        .map_err(|e| err(e.to_string()))?;
    // Flow arrows, scaled to a readable length, every few vectors.
    let step = (frame.vectors.len() / 600).max(1);
    let scale_s = 0.15;
    chart
        .draw_series(frame.vectors.iter().step_by(step).map(|v| {
            PathElement::new(
                vec![
                    (v.x_px, v.y_px),
                    (v.x_px + v.u_px_s * scale_s, v.y_px + v.v_px_s * scale_s),
                ],
                BLACK.stroke_width(1),
            )
        }))
        .map_err(|e| err(e.to_string()))?;
    chart
        .draw_series(std::iter::once(Cross::new(
            frame.truth_px,
            12,
            GREEN.stroke_width(4),
        )))
        .map_err(|e| err(e.to_string()))?
        .label("true FOE")
        .legend(|(x, y)| Cross::new((x, y), 6, GREEN.stroke_width(3)));
    for (i, (name, estimate)) in frame.estimates.iter().enumerate() {
        let colour = METHOD_COLOURS[i % METHOD_COLOURS.len()];
        if let FoeEstimate::Point { x_px, y_px, .. } = *estimate {
            chart
                .draw_series(std::iter::once(Circle::new(
                    (x_px.clamp(0.0, w), y_px.clamp(0.0, h)),
                    7,
                    colour.stroke_width(3),
                )))
                .map_err(|e| err(e.to_string()))?
                .label(name.as_str())
                .legend(move |(x, y)| Circle::new((x, y), 5, colour.stroke_width(2)));
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(|e| err(e.to_string()))?;
    root.present().map_err(|e| err(e.to_string()))
}
