//! The stress–strain PNG of `peridyn modulus` (plotters' bitmap backend, line series, and the
//! built-in pixel font of [`super::glyphs`] for the labels).

use std::path::Path;

use plotters::prelude::*;

use super::glyphs;
use super::Sample;

/// Image size in pixels.
const SIZE: (u32, u32) = (800, 600);
/// Font pixel size in image pixels.
pub const SCALE: i32 = 2;

/// Round tick values covering [0, max]: steps of 1, 2 or 5 × 10^k, four to eight of them,
/// each written in Rust's shortest form (`0`, `2e-3`, `1e9`).
fn ticks(max: f64) -> Vec<(f64, String)> {
    let raw = max / 8.0;
    let power = raw.log10().floor() as i32;
    let scaled = raw / 10f64.powi(power);
    let mantissa = [1u64, 2, 5, 10]
        .into_iter()
        .find(|&m| m as f64 >= scaled)
        .unwrap_or(10);
    (0..)
        .map(|k| {
            // Written as text first so the label is the decimal the tick stands for.
            let value: f64 = format!("{}e{power}", k * mantissa).parse().unwrap_or(0.0);
            let text = if k == 0 {
                "0".to_string()
            } else {
                format!("{value:e}")
            };
            (value, text)
        })
        .take_while(|(value, _)| *value <= max)
        .collect()
}

/// Draws `text` with its top-left corner at `at` (image pixels).
pub fn label(
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    text: &str,
    at: (i32, i32),
) -> Result<(), String> {
    for (column, row) in glyphs::pixels(text) {
        let x = at.0 + column * SCALE;
        let y = at.1 + row * SCALE;
        root.draw(&Rectangle::new(
            [(x, y), (x + SCALE - 1, y + SCALE - 1)],
            BLACK.filled(),
        ))
        .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Width of `text` in image pixels.
pub fn width(text: &str) -> i32 {
    text.chars().count() as i32 * glyphs::ADVANCE * SCALE
}

/// Writes the engineering stress–strain curve of `samples` (from the origin through every
/// loaded frame, with a marker per frame) to `path`, with the line σ = E₀ ε when `expected`
/// is given.
pub fn stress_strain(path: &Path, samples: &[Sample], expected: Option<f64>) -> Result<(), String> {
    let root = BitMapBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let max_strain = samples.iter().map(|s| s.strain.abs()).fold(0.0, f64::max) * 1.1;
    let max_stress = samples
        .iter()
        .map(|s| s.stress)
        .chain(expected.map(|e| e.abs() * max_strain))
        .fold(0.0, f64::max)
        * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .margin(30)
        .x_label_area_size(50)
        .y_label_area_size(110)
        .build_cartesian_2d(0.0..max_strain, 0.0..max_stress)
        .map_err(|e| e.to_string())?;
    let x_ticks = ticks(max_strain);
    let y_ticks = ticks(max_stress);
    let grid = RGBColor(220, 220, 220);
    let lines = x_ticks
        .iter()
        .map(|(x, _)| vec![(*x, 0.0), (*x, max_stress)])
        .chain(
            y_ticks
                .iter()
                .map(|(y, _)| vec![(0.0, *y), (max_strain, *y)]),
        );
    chart
        .draw_series(lines.map(|points| PathElement::new(points, grid)))
        .map_err(|e| e.to_string())?;
    let frame = vec![
        (0.0, max_stress),
        (0.0, 0.0),
        (max_strain, 0.0),
        (max_strain, max_stress),
        (0.0, max_stress),
    ];
    chart
        .draw_series(std::iter::once(PathElement::new(frame, BLACK)))
        .map_err(|e| e.to_string())?;
    if let Some(modulus) = expected {
        let line = vec![(0.0, 0.0), (max_strain, modulus.abs() * max_strain)];
        chart
            .draw_series(LineSeries::new(
                line,
                RGBColor(160, 160, 160).stroke_width(2),
            ))
            .map_err(|e| e.to_string())?;
    }
    let curve =
        std::iter::once((0.0, 0.0)).chain(samples.iter().map(|s| (s.strain.abs(), s.stress)));
    chart
        .draw_series(LineSeries::new(curve, BLUE.stroke_width(2)))
        .map_err(|e| e.to_string())?;
    for sample in samples {
        let (x, y) = chart.backend_coord(&(sample.strain.abs(), sample.stress));
        root.draw(&Rectangle::new(
            [(x - 4, y - 4), (x + 4, y + 4)],
            BLUE.filled(),
        ))
        .map_err(|e| e.to_string())?;
    }
    let glyph_height = glyphs::HEIGHT * SCALE;
    for (x, text) in &x_ticks {
        let (px, py) = chart.backend_coord(&(*x, 0.0));
        label(&root, text, (px - width(text) / 2, py + 8))?;
    }
    for (y, text) in &y_ticks {
        let (px, py) = chart.backend_coord(&(0.0, *y));
        label(&root, text, (px - width(text) - 8, py - glyph_height / 2))?;
    }
    let (right, bottom) = chart.backend_coord(&(max_strain, 0.0));
    let (left, top) = chart.backend_coord(&(0.0, max_stress));
    label(
        &root,
        "strain",
        (right - width("strain"), bottom + 8 + 2 * glyph_height),
    )?;
    label(
        &root,
        "stress",
        (left - width("stress") / 2, top - 2 * glyph_height),
    )?;
    root.present().map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        let strain: Vec<String> = ticks(0.0055).into_iter().map(|(_, t)| t).collect();
        assert_eq!(strain, ["0", "1e-3", "2e-3", "3e-3", "4e-3", "5e-3"]);
        let stress = ticks(9.9e9);
        assert_eq!(stress.last().unwrap().1, "8e9");
        assert_eq!(stress.len(), 5);
    }
}
