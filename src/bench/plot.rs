//! The error-against-time plot of a bench: MSE against seconds on log-log axes, one line (with
//! markers) per integrator through the medians over runs at each curve point, drawn with
//! plotters' SVG backend. Text is left to the viewer's fonts (SVG `<text>`), so no font files
//! are needed.

use super::run::IntegratorRuns;
use crate::error::{Error, Result};
use crate::metrics::median;
use plotters::prelude::*;
use std::path::Path;

/// The plotted points of one integrator: (median seconds, median MSE) per curve index, over
/// the runs that have that point; points with MSE <= 0 cannot go on a log axis and are left
/// out.
pub fn median_curve(ir: &IntegratorRuns) -> Vec<(f64, f64)> {
    let len = ir.runs.iter().map(|r| r.curve.len()).max().unwrap_or(0);
    (0..len)
        .filter_map(|k| {
            let pts: Vec<_> = ir.runs.iter().filter_map(|r| r.curve.get(k)).collect();
            let t = median(&pts.iter().map(|q| q.seconds).collect::<Vec<_>>());
            let mse = median(&pts.iter().map(|q| q.error.mse).collect::<Vec<_>>());
            (t > 0.0 && mse > 0.0 && mse.is_finite()).then_some((t, mse))
        })
        .collect()
}

/// Draw the plot as SVG text.
pub fn svg(title: &str, all: &[IntegratorRuns]) -> Result<String> {
    let curves: Vec<(String, Vec<(f64, f64)>)> = all
        .iter()
        .map(|ir| (ir.name.clone(), median_curve(ir)))
        .collect();
    let pts = curves.iter().flat_map(|(_, c)| c.iter().copied());
    let (mut t0, mut t1, mut e0, mut e1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (t, e) in pts {
        (t0, t1, e0, e1) = (t0.min(t), t1.max(t), e0.min(e), e1.max(e));
    }
    if t0 > t1 {
        // Nothing to plot (every error was zero): an empty frame.
        (t0, t1, e0, e1) = (0.1, 1.0, 0.1, 1.0);
    }
    // Pad by a factor on both log axes so lines do not sit on the frame.
    let (t0, t1, e0, e1) = (t0 / 1.3, t1 * 1.3, e0 / 1.5, e1 * 1.5);
    let mut text = String::new();
    draw(&mut text, title, &curves, (t0, t1, e0, e1))
        .map_err(|e| Error::new(format!("cannot draw the error plot: {e}")))?;
    Ok(text)
}

fn draw(
    out: &mut String,
    title: &str,
    curves: &[(String, Vec<(f64, f64)>)],
    (t0, t1, e0, e1): (f64, f64, f64, f64),
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    let root = SVGBackend::with_string(out, (720, 460)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (t0..t1).log_scale().with_key_points(key_points_125(t0, t1)),
            (e0..e1).log_scale().with_key_points(key_points_125(e0, e1)),
        )?;
    chart
        .configure_mesh()
        .x_desc("seconds")
        .y_desc("MSE")
        .x_label_formatter(&|x| format!("{}", round3(*x)))
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .draw()?;
    for (i, (name, pts)) in curves.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), colour.stroke_width(2)))?
            .label(name.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    root.present()?;
    Ok(())
}

/// 1, 2 and 5 times the powers of ten in [lo, hi]: the labelled points of a log axis.
pub fn key_points_125(lo: f64, hi: f64) -> Vec<f64> {
    let mut points = Vec::new();
    let mut p = 10f64.powf(lo.log10().floor());
    while p <= hi {
        for m in [1.0, 2.0, 5.0] {
            let v = round3(m * p);
            if v >= lo && v <= hi {
                points.push(v);
            }
        }
        p *= 10.0;
    }
    points
}

/// `v` rounded to 3 significant digits (so 0.2 prints as 0.2, not 0.20000000000000004).
fn round3(v: f64) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let p = 10f64.powf(v.abs().log10().floor() - 2.0);
    (v / p).round() * p
}

/// Write the plot to `path` (atomically).
pub fn write_svg(path: &Path, title: &str, all: &[IntegratorRuns]) -> Result<()> {
    super::report::write_text(path, &svg(title, all)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_points_are_1_2_5_decades() {
        assert_eq!(key_points_125(0.08, 2.5), [0.1, 0.2, 0.5, 1.0, 2.0]);
        assert_eq!(key_points_125(3e-4, 1.5e-3), [5e-4, 1e-3]);
    }
}
