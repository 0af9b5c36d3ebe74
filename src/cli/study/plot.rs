//! The study's PNG plots: the error of one measure against wall time, log–log, every
//! successful run a hollow circle and the Pareto front (the runs no other run beats in both
//! time and error) filled and joined in red.
//!
//! plotters' bitmap backend draws the shapes; the tick labels and axis names use the pixel
//! font of `peridyn modulus` (no font file, no system library). Runs with zero error (the
//! reference run itself, or an exact match) have no place on a log axis and are not drawn.

use std::path::Path;

use plotters::prelude::*;

use crate::cli::modulus::glyphs;
use crate::cli::modulus::plot::{label, width, SCALE};

/// Image size in pixels.
const SIZE: (u32, u32) = (800, 600);

/// Indices of the Pareto front of `points` (wall time, error): the points for which no other
/// point has both a smaller-or-equal time and a smaller error, in order of time.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for k in order {
        if points[k].1 < best {
            best = points[k].1;
            front.push(k);
        }
    }
    front
}

/// Whole decades covering [min, max] of positive values, as (lowest, highest) exponents.
fn decades(values: impl Iterator<Item = f64>) -> (i32, i32) {
    let (min, max) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    let low = min.log10().floor() as i32;
    let high = (max.log10().ceil() as i32).max(low + 1);
    (low, high)
}

/// Writes the plot of `points` (wall time in s, error) to `path`. Returns the number of points
/// drawn; nothing is written when no point has a positive error and time.
pub fn error_against_time(path: &Path, points: &[(f64, f64)]) -> Result<usize, String> {
    let drawn: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(t, e)| *t > 0.0 && *e > 0.0 && t.is_finite() && e.is_finite())
        .collect();
    if drawn.is_empty() {
        return Ok(0);
    }
    let (x_low, x_high) = decades(drawn.iter().map(|p| p.0));
    let (y_low, y_high) = decades(drawn.iter().map(|p| p.1));
    let log = |(t, e): (f64, f64)| (t.log10(), e.log10());
    let root = BitMapBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let x_range = f64::from(x_low)..f64::from(x_high);
    let y_range = f64::from(y_low)..f64::from(y_high);
    let mut chart = ChartBuilder::on(&root)
        .margin(30)
        .x_label_area_size(50)
        .y_label_area_size(90)
        .build_cartesian_2d(x_range.clone(), y_range.clone())
        .map_err(|e| e.to_string())?;
    let grid = RGBColor(220, 220, 220);
    let lines = (x_low..=x_high)
        .map(|x| vec![(f64::from(x), y_range.start), (f64::from(x), y_range.end)])
        .chain(
            (y_low..=y_high)
                .map(|y| vec![(x_range.start, f64::from(y)), (x_range.end, f64::from(y))]),
        );
    chart
        .draw_series(lines.map(|points| PathElement::new(points, grid)))
        .map_err(|e| e.to_string())?;
    let frame = vec![
        (x_range.start, y_range.end),
        (x_range.start, y_range.start),
        (x_range.end, y_range.start),
        (x_range.end, y_range.end),
        (x_range.start, y_range.end),
    ];
    chart
        .draw_series(std::iter::once(PathElement::new(frame, BLACK)))
        .map_err(|e| e.to_string())?;
    let front = pareto_front(&drawn);
    let red = RGBColor(200, 30, 30);
    chart
        .draw_series(LineSeries::new(
            front.iter().map(|&k| log(drawn[k])),
            red.stroke_width(2),
        ))
        .map_err(|e| e.to_string())?;
    for (k, point) in drawn.iter().enumerate() {
        let style = if front.contains(&k) {
            red.filled()
        } else {
            RGBColor(90, 90, 90).stroke_width(2)
        };
        chart
            .draw_series(std::iter::once(Circle::new(log(*point), 6, style)))
            .map_err(|e| e.to_string())?;
    }
    let glyph_height = glyphs::HEIGHT * SCALE;
    for x in x_low..=x_high {
        let text = format!("1e{x}");
        let (px, py) = chart.backend_coord(&(f64::from(x), y_range.start));
        label(&root, &text, (px - width(&text) / 2, py + 8))?;
    }
    for y in y_low..=y_high {
        let text = format!("1e{y}");
        let (px, py) = chart.backend_coord(&(x_range.start, f64::from(y)));
        label(&root, &text, (px - width(&text) - 8, py - glyph_height / 2))?;
    }
    let (right, bottom) = chart.backend_coord(&(x_range.end, y_range.start));
    let (left, top) = chart.backend_coord(&(x_range.start, y_range.end));
    label(
        &root,
        "wall s",
        (right - width("wall s"), bottom + 8 + 2 * glyph_height),
    )?;
    label(
        &root,
        "error",
        (left - width("error") / 2, top - 2 * glyph_height),
    )?;
    root.present().map_err(|e| e.to_string())?;
    Ok(drawn.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pareto_front_keeps_the_runs_nothing_beats() {
        // (time, error): run 1 is beaten by run 0 (slower and less accurate), run 3 by run 2.
        let points = [
            (1.0, 0.1),
            (2.0, 0.2),
            (3.0, 0.01),
            (4.0, 0.01),
            (8.0, 0.001),
        ];
        assert_eq!(pareto_front(&points), [0, 2, 4]);
        assert_eq!(pareto_front(&[]), Vec::<usize>::new());
    }

    #[test]
    fn the_plot_is_a_png_and_skips_zero_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("error.png");
        let drawn = error_against_time(&path, &[(0.5, 0.1), (2.0, 0.0), (4.0, 1e-3)]).unwrap();
        assert_eq!(drawn, 2);
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        assert_eq!(error_against_time(&path, &[(1.0, 0.0)]).unwrap(), 0);
    }
}
