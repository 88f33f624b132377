//! SVG plots (plotters, SVG backend only: no system font libraries needed).
//!
//! Plot functions are pure functions of result structs: they never run an analysis.

use crate::diag::{Error, Result};
use plotters::prelude::*;

/// One curve of a line plot.
pub struct Series {
    pub label: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// How the series is drawn.
    pub style: Style,
}

/// Line style of a series.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Style {
    Solid,
    /// e.g. an unstable branch
    Dashed,
    /// Marked points only (e.g. folds)
    Markers,
}

/// A simple line plot.
pub struct LinePlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Vertical reference lines (x, label), e.g. a linear natural frequency.
    pub vertical: Vec<(f64, String)>,
    /// Vertical lines of the environment (x, label), e.g. a rotor's forcing frequency:
    /// drawn solid in a colour of their own.
    pub marks: Vec<(f64, String)>,
}

impl LinePlot {
    /// The plot of a frequency axis in rad/s redrawn in `unit` (`--freq-unit`): the
    /// series' x, the vertical lines and the marks rescaled, `[rad/s]` in the x label and
    /// every `<number> rad/s` in the labels rewritten in the unit. Only the picture
    /// changes: the data written to CSV/JSON stay in rad/s.
    pub fn in_frequency_unit(mut self, unit: super::units::FreqUnit) -> Self {
        if unit == super::units::FreqUnit::RadPerSecond {
            return self;
        }
        let relabel = |text: &str| -> String {
            // each `<number> rad/s` becomes `<number in unit> <unit>`, with as many
            // decimals as it had
            let mut out = String::new();
            let mut rest = text;
            while let Some(at) = rest.find(" rad/s") {
                let (before, after) = rest.split_at(at);
                let start = before
                    .rfind(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == 'e'))
                    .map_or(0, |i| i + 1);
                match before[start..].parse::<f64>() {
                    Ok(w) if start < before.len() => {
                        let decimals = before[start..].split_once('.').map_or(0, |(_, d)| d.len());
                        out.push_str(&before[..start]);
                        out.push_str(&unit.show(w, decimals));
                    }
                    _ => {
                        out.push_str(before);
                        out.push_str(" rad/s");
                    }
                }
                rest = &after[" rad/s".len()..];
            }
            out.push_str(rest);
            out
        };
        for s in &mut self.series {
            s.x.iter_mut().for_each(|x| *x = unit.of(*x));
            s.label = relabel(&s.label);
        }
        for (x, label) in self.vertical.iter_mut().chain(self.marks.iter_mut()) {
            *x = unit.of(*x);
            *label = relabel(label);
        }
        self.x_label = self
            .x_label
            .replace("[rad/s]", &format!("[{}]", unit.symbol()));
        self.title = relabel(&self.title);
        self
    }
}

const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 * (1.0 + hi.abs()) {
        return (lo - 0.5, hi + 0.5);
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + pad)
}

/// Render a line plot to an SVG string.
pub fn line_plot_svg(plot: &LinePlot) -> std::result::Result<String, String> {
    panels_svg(std::slice::from_ref(plot))
}

/// Render plots stacked vertically in one SVG.
pub fn panels_svg(plots: &[LinePlot]) -> std::result::Result<String, String> {
    let mut svg = String::new();
    {
        let height = 540 * plots.len().max(1) as u32;
        let root = SVGBackend::with_string(&mut svg, (900, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let areas = root.split_evenly((plots.len().max(1), 1));
        for (plot, area) in plots.iter().zip(areas.iter()) {
            draw_panel(plot, area)?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

fn draw_panel(
    plot: &LinePlot,
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
) -> std::result::Result<(), String> {
    let (x0, x1) = range(plot.series.iter().flat_map(|s| s.x.iter().copied()));
    let (y0, y1) = range(plot.series.iter().flat_map(|s| s.y.iter().copied()));
    let mut chart = ChartBuilder::on(area)
        .caption(&plot.title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(&plot.x_label)
        .y_desc(&plot.y_label)
        .draw()
        .map_err(|e| e.to_string())?;
    // one color and one legend entry per distinct label
    let mut labels: Vec<&str> = Vec::new();
    for s in &plot.series {
        let first = !labels.contains(&s.label.as_str());
        if first {
            labels.push(&s.label);
        }
        let i = labels.iter().position(|l| *l == s.label).unwrap_or(0);
        let color = COLORS[i % COLORS.len()];
        let pts: Vec<(f64, f64)> = s.x.iter().copied().zip(s.y.iter().copied()).collect();
        let style = color.stroke_width(2);
        let drawn = match s.style {
            Style::Dashed => chart.draw_series(DashedLineSeries::new(pts, 6, 4, style)),
            Style::Solid => chart.draw_series(LineSeries::new(pts, style)),
            Style::Markers => chart.draw_series(
                pts.into_iter()
                    .map(|p| Circle::new(p, 5, color.filled()))
                    .collect::<Vec<_>>(),
            ),
        }
        .map_err(|e| e.to_string())?;
        if first && !s.label.is_empty() {
            drawn.label(s.label.clone()).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        }
    }
    for (x, label) in &plot.vertical {
        let line = vec![(*x, y0), (*x, y1)];
        chart
            .draw_series(DashedLineSeries::new(line, 4, 4, BLACK.stroke_width(1)))
            .map_err(|e| e.to_string())?
            .label(label.clone())
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(1)));
    }
    let mark_color = RGBColor(230, 120, 0);
    for (x, label) in &plot.marks {
        chart
            .draw_series(LineSeries::new(
                vec![(*x, y0), (*x, y1)],
                mark_color.stroke_width(2),
            ))
            .map_err(|e| e.to_string())?
            .label(label.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], mark_color.stroke_width(2))
            });
    }
    if !plot.series.is_empty() || !plot.marks.is_empty() {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Write a line plot to an SVG file (atomically).
pub fn write_line_plot(path: &str, plot: &LinePlot) -> Result<()> {
    write_panels(path, std::slice::from_ref(plot))
}

/// Write stacked plots to one SVG file (atomically).
pub fn write_panels(path: &str, plots: &[LinePlot]) -> Result<()> {
    let svg = panels_svg(plots).map_err(|e| Error::io(path, format!("plot failed: {e}")))?;
    super::write_atomic(path, |w| w.write_all(svg.as_bytes()))
}
