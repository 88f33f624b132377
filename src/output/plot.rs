//! Line plots as SVG or PNG (plotters: the SVG backend, and the bitmap backend with the
//! embedded font of [`super::style`], so no system font library is needed).
//!
//! Plot functions are pure functions of result structs: they never run an analysis.
//!
//! Plotters draws the frame (axes, ticks, grid, axis descriptions, texts). Curves,
//! markers and legend samples are drawn here, by [`Painter`], in float pixel
//! coordinates: plotters' backends take integer pixels, which makes a smooth curve a
//! staircase in SVG. In SVG they are `<polyline>`/`<path>` elements with two decimals
//! (class `curve`, `legend`, `marker`, linked by `data-series`); in PNG they are rasterized
//! through plotters at the nearest pixel. Hand-written for that reason, and because
//! plotters' own legend is drawn inside the plot area (over the data) with a plain line
//! whatever the series' style: the legend here sits below the plot area and draws each
//! entry in its curve's pen (colour, width, dash pattern, marker).
//!
//! Also hand-written, as plotters has neither: titles and captions wrapped to the
//! figure's width, and the placement of the notes (peaks, jumps, folds) near their points
//! but clear of the curves, the vertical lines and each other (a leader line when one is
//! set away). [`Panels::check`] refuses a `--plot-size` whose panels cannot hold a plot.

use super::style::{self, Fonts, Marker};
use crate::diag::{Error, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// One curve of a line plot.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend entry, with its unit (empty: no entry).
    pub label: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// How the series is drawn.
    pub style: Style,
    /// Palette slot ([`style::PALETTE`]); None: one slot per distinct label, in order.
    pub color: Option<usize>,
}

impl Series {
    pub fn new(label: impl Into<String>, x: Vec<f64>, y: Vec<f64>, style: Style) -> Series {
        Series {
            label: label.into(),
            x,
            y,
            style,
            color: None,
        }
    }
    /// The same series in palette slot `k`.
    pub fn color(mut self, k: usize) -> Series {
        self.color = Some(k);
        self
    }
}

/// Line style of a series, with fixed meanings across every plot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Style {
    /// A stable equilibrium or a computed response (a sweep up or from rest).
    Solid,
    /// Unstable.
    Dashed,
    /// A sweep down.
    Dotted,
    /// Marked points only (peaks, folds, branch points, jumps).
    Markers,
}

/// The vertical axis' scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scale {
    #[default]
    Linear,
    /// Logarithmic (positive values only; the rest is left out).
    Log,
}

/// A labelled point (a peak, a fold, a jump), the label drawn beside it.
#[derive(Debug, Clone, PartialEq)]
pub struct Note {
    pub x: f64,
    pub y: f64,
    pub text: String,
}

impl LinePlot {
    /// The plot of a frequency axis in rad/s redrawn in `unit` (`--freq-unit`). A plot
    /// made by a figure builder ([`super::figures`]) is made again by it in the unit
    /// ([`LinePlot::relabel`]): its labels are written in the unit where they are made,
    /// with significant digits (`jump up 0.6366→0.6525 Hz`). A plot made by hand has its
    /// series' x, the vertical lines and the marks rescaled ([`LinePlot::rescaled`]) and
    /// every `<number> rad/s` in its labels rewritten in the unit, with as many decimals
    /// as it had. A cyclic unit's natural frequency is f_n, not ω_n: `ω_n = 0.4732 Hz`
    /// would read as an angular frequency, so `ω_n` becomes `f_n` (`ω_n = |λ|` becomes
    /// `f_n = |λ|/2π`) in Hz and in rpm alike. Only the picture changes: the data written
    /// to CSV/JSON stay in rad/s.
    pub fn in_frequency_unit(self, unit: super::units::FreqUnit) -> Self {
        if unit == super::units::FreqUnit::RadPerSecond {
            return self;
        }
        if let Some(again) = &self.relabel {
            return (again.0)(unit);
        }
        let relabel = |text: &str| -> String {
            // each `<number> rad/s` becomes `<number in unit> <unit>`, with as many
            // decimals as it had
            let mut out = String::new();
            let mut last = 0;
            for (range, w, decimals) in super::units::rad_s_in_text(text) {
                out.push_str(&text[last..range.start]);
                out.push_str(&unit.show(w, decimals));
                last = range.end + " rad/s".len();
            }
            out.push_str(&text[last..]);
            out.replace("ω_n = |λ|", "f_n = |λ|/2π")
                .replace("ω_n", "f_n")
        };
        let mut p = self;
        for s in &mut p.series {
            s.label = relabel(&s.label);
        }
        for (_, label) in p.vertical.iter_mut().chain(p.marks.iter_mut()) {
            *label = relabel(label);
        }
        for n in &mut p.notes {
            n.text = relabel(&n.text);
        }
        p.caption = relabel(&p.caption);
        p.title = relabel(&p.title);
        p.rescaled(unit)
    }

    /// The plot's frequency axis in `unit`, its labels left as they are (written in the
    /// unit already): the series' x, the vertical lines, the marks and the notes
    /// rescaled; the x label `ω [rad/s]` becomes `f [Hz]` and one named after a
    /// parameter, `omega [rad/s]`, becomes `omega/2π [Hz]`; the title names what the
    /// axis shows (`… against omega/2π`).
    pub fn rescaled(mut self, unit: super::units::FreqUnit) -> Self {
        if unit == super::units::FreqUnit::RadPerSecond {
            return self;
        }
        for s in &mut self.series {
            s.x.iter_mut().for_each(|x| *x = unit.of(*x));
        }
        for (x, _) in self.vertical.iter_mut().chain(self.marks.iter_mut()) {
            *x = unit.of(*x);
        }
        for n in &mut self.notes {
            n.x = unit.of(n.x);
        }
        // the title names what the axis shows: `… against omega` over an `omega/2π [Hz]`
        // axis becomes `… against omega/2π` (`against ω`: `against f`)
        let shown = match self.x_label.strip_suffix(" [rad/s]") {
            Some("ω") => Some(("ω".to_string(), "f".to_string())),
            Some(name) => Some((name.to_string(), unit.quantity(name))),
            None => None,
        };
        self.x_label = match &shown {
            Some((_, quantity)) => format!("{quantity} [{}]", unit.symbol()),
            None => self
                .x_label
                .replace("[rad/s]", &format!("[{}]", unit.symbol())),
        };
        if let Some((name, quantity)) = &shown {
            self.title = against(&self.title, name, quantity);
        }
        self.relabel = None;
        self
    }
}

/// How a figure builder makes a panel again in another frequency unit (see
/// [`LinePlot::in_frequency_unit`]).
#[derive(Clone)]
pub struct Relabel(pub std::sync::Arc<dyn Fn(super::units::FreqUnit) -> LinePlot + Send + Sync>);

impl std::fmt::Debug for Relabel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Relabel")
    }
}

/// `title` with each ` against NAME` (NAME a whole word: at the end, or followed by a
/// space, a comma, a colon or a parenthesis) naming `quantity` instead.
fn against(title: &str, name: &str, quantity: &str) -> String {
    let pattern = format!(" against {name}");
    let mut out = String::new();
    let mut rest = title;
    while let Some(at) = rest.find(&pattern) {
        let end = at + pattern.len();
        let whole = rest[end..]
            .chars()
            .next()
            .is_none_or(|c| matches!(c, ' ' | ',' | ':' | ';' | '(' | ')'));
        out.push_str(&rest[..at]);
        if whole {
            out.push_str(" against ");
            out.push_str(quantity);
        } else {
            out.push_str(&pattern);
        }
        rest = &rest[end..];
    }
    out.push_str(rest);
    out
}

/// A line plot (one panel of a figure).
#[derive(Debug, Clone, Default)]
pub struct LinePlot {
    pub title: String,
    /// The case the figure shows (model, overrides, well), drawn under the title.
    pub caption: String,
    pub x_label: String,
    pub y_label: String,
    pub y_scale: Scale,
    pub series: Vec<Series>,
    /// Vertical reference lines (x, label), e.g. a linear natural frequency: thin grey
    /// dash-dot.
    pub vertical: Vec<(f64, String)>,
    /// Vertical lines of the environment (x, label), e.g. a rotor's forcing frequency:
    /// drawn solid in the forcing colour.
    pub marks: Vec<(f64, String)>,
    /// Labels beside marked points.
    pub notes: Vec<Note>,
    /// The figure builder's way to make this panel again in another frequency unit
    /// (None: a plot made by hand).
    pub relabel: Option<Relabel>,
}

impl LinePlot {
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> LinePlot {
        LinePlot {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            ..LinePlot::default()
        }
    }
}

// ---- output formats and sizes ----

/// A figure's file format, from its extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Svg,
    Png,
}

impl Format {
    /// `.svg` or `.png` (any case); a stream (`/dev/stdout`, a FIFO) without either is
    /// SVG; anything else is refused, naming the flag.
    pub fn of(flag: &str, path: &str) -> Result<Format> {
        let ext = std::path::Path::new(path)
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("svg") => Ok(Format::Svg),
            Some("png") => Ok(Format::Png),
            // a stream (`/dev/stdout`, a FIFO) has no extension to honour: SVG, as `draw`
            // writes it there
            _ if super::commit::is_stream(path) => Ok(Format::Svg),
            _ => Err(Error::request(
                format!(
                    "{flag} {path}: a figure is written as .svg or .png, not {}",
                    ext.map(|e| format!("`.{e}`"))
                        .unwrap_or_else(|| "a name without extension".into())
                ),
                format!(
                    "name the figure `.svg` (vector) or `.png` (bitmap), e.g. {flag} figure.svg"
                ),
            )),
        }
    }
}

/// The smallest and largest `--plot-size` side, px.
pub const MIN_SIDE: u32 = 300;
pub const MAX_SIDE: u32 = 8000;

/// `--plot-size WxH` (px, e.g. `1600x1000`), each side within [`MIN_SIDE`]–[`MAX_SIDE`].
pub fn parse_size(text: &str) -> Result<(u32, u32)> {
    let bad = |why: String| {
        Error::request(
            format!("--plot-size {text}: {why}"),
            format!(
                "give the figure's width and height in pixels as WxH, each {MIN_SIDE}–{MAX_SIDE}, e.g. --plot-size 1600x1000"
            ),
        )
    };
    let t = text.trim().to_ascii_lowercase();
    let Some((w, h)) = t.split_once(['x', '×']) else {
        return Err(bad("expected WIDTHxHEIGHT".into()));
    };
    let side = |s: &str, what: &str| -> Result<u32> {
        let v: u32 = s.trim().parse().map_err(|_| {
            bad(format!(
                "the {what} `{}` is not a whole number of pixels",
                s.trim()
            ))
        })?;
        if !(MIN_SIDE..=MAX_SIDE).contains(&v) {
            return Err(bad(format!(
                "the {what} {v} px is outside {MIN_SIDE}–{MAX_SIDE} px"
            )));
        }
        Ok(v)
    };
    Ok((side(w, "width")?, side(h, "height")?))
}

/// Default size of a figure of `panels` stacked panels, px.
pub fn default_size(panels: usize) -> (u32, u32) {
    (style::BASE_WIDTH, 520 * panels.max(1) as u32)
}

// ---- drawing in float pixel coordinates ----

/// How a curve, a legend sample or a marker is drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct Pen {
    pub color: RGBColor,
    /// Line width, px (0: no line).
    pub width: f64,
    /// Dash pattern, px (empty: solid).
    pub dash: Vec<f64>,
    /// Marker: shape, radius px, fill.
    pub marker: Option<(Marker, f64, RGBColor)>,
    /// Markers along a line every this many px (0: markers at every point, no line
    /// markers when `width` > 0 and this is 0).
    pub marker_spacing: f64,
}

/// Maps data to float pixels inside a plot area.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    pub left: f64,
    pub right: f64,
    pub top: f64,
    pub bottom: f64,
    pub x: (f64, f64),
    pub y: (f64, f64),
    pub x_log: bool,
    pub y_log: bool,
}

impl Frame {
    /// From a plotters plotting area's pixel range (absolute).
    pub fn new(
        px: (std::ops::Range<i32>, std::ops::Range<i32>),
        x: (f64, f64),
        y: (f64, f64),
        x_log: bool,
        y_log: bool,
    ) -> Frame {
        Frame {
            left: px.0.start as f64,
            right: (px.0.end - 1) as f64,
            top: px.1.start as f64,
            bottom: (px.1.end - 1) as f64,
            x,
            y,
            x_log,
            y_log,
        }
    }
    fn frac(v: f64, (lo, hi): (f64, f64), log: bool) -> Option<f64> {
        if !v.is_finite() || (log && v <= 0.0) {
            return None;
        }
        Some(if log {
            (v.ln() - lo.ln()) / (hi.ln() - lo.ln())
        } else {
            (v - lo) / (hi - lo)
        })
    }
    /// The pixel of (x, y), clamped to the plot area; None for a value not drawable.
    pub fn map(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let tx = Self::frac(x, self.x, self.x_log)?;
        let ty = Self::frac(y, self.y, self.y_log)?;
        // (a degenerate area, right < left or bottom < top, maps to its edge: never a
        // panic)
        let within = |v: f64, a: f64, b: f64| v.max(a.min(b)).min(a.max(b));
        Some((
            within(
                self.left + tx * (self.right - self.left),
                self.left,
                self.right,
            ),
            within(
                self.bottom - ty * (self.bottom - self.top),
                self.top,
                self.bottom,
            ),
        ))
    }
    /// The pixel column of x (None outside the axis).
    pub fn column(&self, x: f64) -> Option<f64> {
        let tx = Self::frac(x, self.x, self.x_log)?;
        (-1e-9..=1.0 + 1e-9)
            .contains(&tx)
            .then(|| self.left + tx * (self.right - self.left))
    }
}

/// Draws curves and markers in float pixel coordinates: into an SVG overlay, or
/// rasterized on a plotters drawing area.
pub enum Painter<'a, DB: DrawingBackend> {
    Svg(&'a mut String),
    Raster(&'a DrawingArea<DB, Shift>),
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// Split a polyline into its dashes.
fn dashes(pts: &[(f64, f64)], pattern: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    let (mut k, mut left, mut on) = (0usize, pattern[0], true);
    for w in pts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        let mut t = 0.0;
        if on && cur.is_empty() {
            cur.push(a);
        }
        while len - t > left {
            t += left;
            let p = (a.0 + (b.0 - a.0) * t / len, a.1 + (b.1 - a.1) * t / len);
            if on {
                cur.push(p);
                out.push(std::mem::take(&mut cur));
            } else {
                cur.push(p);
            }
            on = !on;
            k = (k + 1) % pattern.len();
            left = pattern[k];
        }
        left -= len - t;
        if on {
            cur.push(b);
        }
    }
    if on && cur.len() > 1 {
        out.push(cur);
    }
    out
}

/// Points every `spacing` px of arc length along a polyline, the first at `offset`.
fn along(pts: &[(f64, f64)], spacing: f64, offset: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut next = offset;
    let mut s = 0.0;
    for w in pts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        while next <= s + len && len > 0.0 {
            let t = (next - s) / len;
            out.push((a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t));
            next += spacing;
        }
        s += len;
    }
    out
}

/// A marker's outline as SVG path data (cross: two strokes).
fn marker_path(m: Marker, (x, y): (f64, f64), r: f64) -> String {
    let p = |pts: &[(f64, f64)]| {
        let mut d = String::new();
        for (i, (px, py)) in pts.iter().enumerate() {
            d.push_str(&format!(
                "{}{:.2},{:.2} ",
                if i == 0 { "M" } else { "L" },
                x + px * r,
                y + py * r
            ));
        }
        d.push('Z');
        d
    };
    match m {
        Marker::Circle => format!(
            "M{:.2},{:.2} a{r:.2},{r:.2} 0 1,0 {:.2},0 a{r:.2},{r:.2} 0 1,0 {:.2},0",
            x - r,
            y,
            2.0 * r,
            -2.0 * r
        ),
        Marker::Square => p(&[(-0.85, -0.85), (0.85, -0.85), (0.85, 0.85), (-0.85, 0.85)]),
        Marker::Diamond => p(&[(0.0, -1.2), (1.1, 0.0), (0.0, 1.2), (-1.1, 0.0)]),
        Marker::TriangleUp => p(&[(0.0, -1.15), (1.05, 0.75), (-1.05, 0.75)]),
        Marker::TriangleDown => p(&[(0.0, 1.15), (1.05, -0.75), (-1.05, -0.75)]),
        Marker::Cross => format!(
            "M{:.2},{:.2} L{:.2},{:.2} M{:.2},{:.2} L{:.2},{:.2}",
            x - r,
            y - r,
            x + r,
            y + r,
            x - r,
            y + r,
            x + r,
            y - r
        ),
    }
}

fn marker_polygon(m: Marker, (x, y): (f64, f64), r: f64) -> Vec<(i32, i32)> {
    let pts: Vec<(f64, f64)> = match m {
        Marker::Square => vec![(-0.85, -0.85), (0.85, -0.85), (0.85, 0.85), (-0.85, 0.85)],
        Marker::Diamond => vec![(0.0, -1.2), (1.1, 0.0), (0.0, 1.2), (-1.1, 0.0)],
        Marker::TriangleUp => vec![(0.0, -1.15), (1.05, 0.75), (-1.05, 0.75)],
        Marker::TriangleDown => vec![(0.0, 1.15), (1.05, -0.75), (-1.05, -0.75)],
        _ => vec![],
    };
    pts.iter()
        .map(|(px, py)| ((x + px * r).round() as i32, (y + py * r).round() as i32))
        .collect()
}

fn ipt(p: (f64, f64)) -> (i32, i32) {
    (p.0.round() as i32, p.1.round() as i32)
}

impl<DB: DrawingBackend> Painter<'_, DB> {
    /// A polyline in `pen` (its line only), tagged `class` and `key` in SVG.
    pub fn line(
        &mut self,
        pts: &[(f64, f64)],
        pen: &Pen,
        class: &str,
        key: &str,
    ) -> std::result::Result<(), String> {
        if pts.len() < 2 || pen.width <= 0.0 {
            return Ok(());
        }
        match self {
            Painter::Svg(out) => {
                let dash = if pen.dash.is_empty() {
                    String::new()
                } else {
                    format!(
                        " stroke-dasharray=\"{}\"",
                        pen.dash
                            .iter()
                            .map(|d| format!("{d:.2}"))
                            .collect::<Vec<_>>()
                            .join(" ")
                    )
                };
                let points: Vec<String> =
                    pts.iter().map(|(x, y)| format!("{x:.2},{y:.2}")).collect();
                out.push_str(&format!(
                    "<polyline class=\"{class}\" data-series=\"{key}\" fill=\"none\" stroke=\"{}\" stroke-width=\"{:.2}\"{dash} stroke-linejoin=\"round\" points=\"{}\"/>\n",
                    style::hex(pen.color),
                    pen.width,
                    points.join(" ")
                ));
            }
            Painter::Raster(area) => {
                let st = pen.color.stroke_width(pen.width.round().max(1.0) as u32);
                let pieces = if pen.dash.is_empty() {
                    vec![pts.to_vec()]
                } else {
                    dashes(pts, &pen.dash)
                };
                for piece in pieces {
                    area.draw(&PathElement::new(
                        piece.into_iter().map(ipt).collect::<Vec<_>>(),
                        st,
                    ))
                    .map_err(err)?;
                }
            }
        }
        Ok(())
    }

    /// The pen's marker at `at`.
    pub fn marker(
        &mut self,
        at: (f64, f64),
        pen: &Pen,
        class: &str,
        key: &str,
    ) -> std::result::Result<(), String> {
        let Some((shape, r, fill)) = pen.marker else {
            return Ok(());
        };
        let edge = if shape == Marker::Cross {
            fill
        } else {
            style::EVENT
        };
        match self {
            Painter::Svg(out) => {
                let fill_attr = if shape == Marker::Cross {
                    "none".to_string()
                } else {
                    style::hex(fill)
                };
                out.push_str(&format!(
                    "<path class=\"{class}\" data-series=\"{key}\" data-marker=\"{}\" d=\"{}\" fill=\"{fill_attr}\" stroke=\"{}\" stroke-width=\"{:.2}\"/>\n",
                    shape.name(),
                    marker_path(shape, at, r),
                    style::hex(edge),
                    if shape == Marker::Cross { 2.0 } else { 1.2 } * (r / style::CURVE_MARKER).max(1.0).min(1.5)
                ));
            }
            Painter::Raster(area) => match shape {
                Marker::Circle => {
                    area.draw(&Circle::new(ipt(at), r.round() as i32, fill.filled()))
                        .map_err(err)?;
                    area.draw(&Circle::new(
                        ipt(at),
                        r.round() as i32,
                        edge.stroke_width(1),
                    ))
                    .map_err(err)?;
                }
                Marker::Cross => {
                    for (a, b) in [
                        ((at.0 - r, at.1 - r), (at.0 + r, at.1 + r)),
                        ((at.0 - r, at.1 + r), (at.0 + r, at.1 - r)),
                    ] {
                        area.draw(&PathElement::new(
                            vec![ipt(a), ipt(b)],
                            fill.stroke_width(2),
                        ))
                        .map_err(err)?;
                    }
                }
                _ => {
                    let poly = marker_polygon(shape, at, r);
                    area.draw(&Polygon::new(poly.clone(), fill.filled()))
                        .map_err(err)?;
                    let mut closed = poly.clone();
                    closed.push(poly[0]);
                    area.draw(&PathElement::new(closed, edge.stroke_width(1)))
                        .map_err(err)?;
                }
            },
        }
        Ok(())
    }

    /// A curve: its line, and its markers (every point, or spaced along the line).
    pub fn curve(
        &mut self,
        pts: &[(f64, f64)],
        pen: &Pen,
        class: &str,
        key: &str,
        offset: f64,
    ) -> std::result::Result<(), String> {
        self.line(pts, pen, class, key)?;
        if pen.marker.is_some() {
            let at = if pen.width > 0.0 && pen.marker_spacing > 0.0 {
                let mut at = along(pts, pen.marker_spacing, offset);
                if at.is_empty() && !pts.is_empty() {
                    // a short curve still shows its marker, as its legend entry does
                    let len: f64 = pts
                        .windows(2)
                        .map(|w| ((w[1].0 - w[0].0).powi(2) + (w[1].1 - w[0].1).powi(2)).sqrt())
                        .sum();
                    at = along(pts, f64::INFINITY, len / 2.0);
                    if at.is_empty() {
                        at.push(pts[0]);
                    }
                }
                at
            } else if pen.width > 0.0 {
                Vec::new()
            } else {
                pts.to_vec()
            };
            for p in at {
                self.marker(p, pen, &format!("{class}-marker"), key)?;
            }
        }
        Ok(())
    }
}

// ---- figures ----

/// A figure drawable on any plotters backend (plus a [`Painter`] for float curves).
pub trait Figure {
    fn size(&self) -> (u32, u32);
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        painter: &mut Painter<'_, DB>,
    ) -> std::result::Result<(), String>;
    /// The same figure at another size, everything in it scaled with the width (for a
    /// PNG drawn larger and reduced: smooth lines). None: drawn at its size only.
    fn resized(&self, _size: (u32, u32)) -> Option<Self>
    where
        Self: Sized,
    {
        None
    }
}

/// A PNG is drawn this many times larger in each direction and reduced by averaging,
/// where that stays within [`MAX_SUPERSAMPLED`] pixels: plotters' bitmap backend draws
/// lines and markers without anti-aliasing, whole pixels on or off (stair-stepped
/// curves); the average of the 3×3 sub-pixels smooths them as a vector renderer would.
const SUPERSAMPLE: u32 = 3;

/// The most pixels a supersampled drawing may take (3 bytes each): 36 M, about 108 MB.
const MAX_SUPERSAMPLED: u64 = 36_000_000;

/// An RGB image of `w·k × h·k` reduced to `w × h` by averaging each k × k block.
fn reduce(big: &[u8], w: u32, h: u32, k: u32) -> Vec<u8> {
    let (w, h, k) = (w as usize, h as usize, k as usize);
    let row = w * k * 3;
    let mut out = vec![0u8; w * h * 3];
    for y in 0..h {
        for x in 0..w {
            for c in 0..3 {
                let mut sum = 0u32;
                for dy in 0..k {
                    let base = (y * k + dy) * row + x * k * 3 + c;
                    for dx in 0..k {
                        sum += u32::from(big[base + dx * 3]);
                    }
                }
                let n = (k * k) as u32;
                out[(y * w + x) * 3 + c] = ((sum + n / 2) / n) as u8;
            }
        }
    }
    out
}

/// Render a figure as SVG text or PNG bytes.
pub fn render<F: Figure>(fig: &F, format: Format) -> std::result::Result<Vec<u8>, String> {
    style::register_font();
    let (w, h) = fig.size();
    match format {
        Format::Svg => {
            let mut svg = String::new();
            let mut overlay = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
                root.fill(&WHITE).map_err(err)?;
                fig.draw(&root, &mut Painter::Svg(&mut overlay))?;
                root.present().map_err(err)?;
            }
            match svg.rfind("</svg>") {
                Some(end) => svg.insert_str(end, &overlay),
                None => svg.push_str(&overlay),
            }
            Ok(svg.into_bytes())
        }
        Format::Png => {
            let k = SUPERSAMPLE;
            let big = (u64::from(w) * u64::from(k)) * (u64::from(h) * u64::from(k));
            let large = (big <= MAX_SUPERSAMPLED)
                .then(|| fig.resized((w * k, h * k)))
                .flatten();
            let draw = |f: &F, (w, h): (u32, u32)| -> std::result::Result<Vec<u8>, String> {
                let mut buf = vec![255u8; w as usize * h as usize * 3];
                {
                    let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
                    root.fill(&WHITE).map_err(err)?;
                    let mut painter = Painter::Raster(&root);
                    f.draw(&root, &mut painter)?;
                    root.present().map_err(err)?;
                }
                Ok(buf)
            };
            let buf = match &large {
                Some(l) => reduce(&draw(l, (w * k, h * k))?, w, h, k),
                None => draw(fig, (w, h))?,
            };
            let mut png_bytes = Vec::new();
            {
                let mut enc = png::Encoder::new(&mut png_bytes, w, h);
                enc.set_color(png::ColorType::Rgb);
                enc.set_depth(png::BitDepth::Eight);
                let mut wr = enc.write_header().map_err(err)?;
                wr.write_image_data(&buf).map_err(err)?;
                wr.finish().map_err(err)?;
            }
            Ok(png_bytes)
        }
    }
}

/// Render a figure to `path` (atomically), in the format its extension names.
pub fn write_figure<F: Figure>(path: &str, fig: &F) -> Result<()> {
    let format = Format::of("--plot", path)?;
    let bytes = render(fig, format).map_err(|e| Error::io(path, format!("plot failed: {e}")))?;
    super::write_atomic(path, |w| w.write_all(&bytes))
}

/// Stacked line plots at a size (px).
pub struct Panels<'a> {
    pub plots: &'a [LinePlot],
    pub size: (u32, u32),
    /// How many times larger than asked the figure is drawn (3 for a supersampled PNG,
    /// see [`Figure::resized`]; 1 otherwise).
    pub zoom: f64,
}

impl<'a> Panels<'a> {
    /// `plots` stacked at `size`.
    pub fn new(plots: &'a [LinePlot], size: (u32, u32)) -> Panels<'a> {
        Panels {
            plots,
            size,
            zoom: 1.0,
        }
    }

    fn fonts(&self) -> Fonts {
        let n = self.plots.len().max(1) as f64;
        Fonts::for_panel(self.size.0, self.size.1 as f64 / n, self.zoom)
    }

    /// The panels that lack room for a plot area of [`MIN_PLOT`] at this size: for each,
    /// its index and the height it needs, px.
    fn cramped(&self) -> Vec<(usize, f64, f64)> {
        style::register_font();
        let mut svg = String::new();
        let root = SVGBackend::with_string(&mut svg, self.size).into_drawing_area();
        let f = self.fonts();
        let areas = root.split_evenly((self.plots.len().max(1), 1));
        let mut out = Vec::new();
        for (k, (plot, area)) in self.plots.iter().zip(areas.iter()).enumerate() {
            let l = panel_layout(plot, area, &f);
            let h = area.dim_in_pixel().1 as f64;
            if l.needed > h || l.plot_w < MIN_PLOT.1 * f.scale {
                out.push((k, l.needed, h));
            }
        }
        out
    }

    /// Refuse a size whose panels cannot hold a plot (`--plot-size`), naming the
    /// smallest height that can at this width.
    pub fn check(&self) -> Result<()> {
        let cramped = self.cramped();
        if cramped.is_empty() {
            return Ok(());
        }
        let (w, h) = self.size;
        let n = self.plots.len().max(1) as u32;
        // the smallest height that fits (text grows with the panel height up to the
        // width's scale, so try heights upwards)
        let mut fit = None;
        let mut tall = h;
        while tall < MAX_SIDE {
            tall = (tall + 20 * n).min(MAX_SIDE);
            let wider = Panels::new(self.plots, (w, tall));
            if wider.cramped().is_empty() {
                fit = Some(tall);
                break;
            }
        }
        let narrow = (w as f64) < MIN_PLOT.1 + 300.0;
        let panels = if n == 1 {
            "its one panel".to_string()
        } else {
            format!("each of its {n} panels")
        };
        let (k, needed, has) = cramped[0];
        Err(Error::request(
            format!(
                "--plot-size {w}x{h}: the figure has no room for its plot: {panels} gets {} px, and panel {} needs {:.0} px for its title, axes, legend and a plot area",
                has.round(),
                k + 1,
                needed.ceil()
            ),
            match fit {
                Some(t) => format!(
                    "give the figure at least {t} px of height at this width, e.g. --plot-size {w}x{t}{}, or leave out --plot-size",
                    if narrow { " (or make it wider)" } else { "" }
                ),
                None => "plot fewer responses at a time, or leave out --plot-size".to_string(),
            },
        ))
    }
}

impl Figure for Panels<'_> {
    fn size(&self) -> (u32, u32) {
        self.size
    }
    fn resized(&self, size: (u32, u32)) -> Option<Self> {
        Some(Panels {
            plots: self.plots,
            size,
            zoom: self.zoom * size.0 as f64 / self.size.0 as f64,
        })
    }
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        painter: &mut Painter<'_, DB>,
    ) -> std::result::Result<(), String> {
        let fonts = self.fonts();
        let areas = root.split_evenly((self.plots.len().max(1), 1));
        for (k, (plot, area)) in self.plots.iter().zip(areas.iter()).enumerate() {
            draw_panel(plot, area, &fonts, painter, k)?;
        }
        Ok(())
    }
}

/// Render a line plot to an SVG string (default size).
pub fn line_plot_svg(plot: &LinePlot) -> std::result::Result<String, String> {
    panels_svg(std::slice::from_ref(plot))
}

/// Render plots stacked vertically in one SVG (default size).
pub fn panels_svg(plots: &[LinePlot]) -> std::result::Result<String, String> {
    let fig = Panels::new(plots, default_size(plots.len()));
    render(&fig, Format::Svg).map(|b| String::from_utf8_lossy(&b).into_owned())
}

/// Write a line plot (SVG or PNG by the extension; atomically).
pub fn write_line_plot(path: &str, plot: &LinePlot) -> Result<()> {
    write_panels(path, std::slice::from_ref(plot))
}

/// Write stacked plots to one figure (SVG or PNG by the extension; atomically).
pub fn write_panels(path: &str, plots: &[LinePlot]) -> Result<()> {
    write_panels_sized(path, plots, None)
}

/// [`write_panels`] at a size (px; None: [`default_size`]).
pub fn write_panels_sized(path: &str, plots: &[LinePlot], size: Option<(u32, u32)>) -> Result<()> {
    let fig = Panels::new(plots, size.unwrap_or_else(|| default_size(plots.len())));
    if size.is_some() {
        fig.check()?;
    }
    write_figure(path, &fig)
}

fn range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if log {
        if !lo.is_finite() {
            return (0.1, 10.0);
        }
        let lo = lo.max(hi * 1e-8);
        if hi / lo < 1.0 + 1e-9 {
            return (lo / 2.0, hi * 2.0);
        }
        let pad = (hi / lo).powf(0.05);
        let (lo, hi) = (lo / pad, hi * pad * pad);
        // a narrow span reaches out to the powers of ten around it, so the axis has
        // labelled ticks (plotters labels a log axis at its decades)
        if hi / lo < 100.0 {
            return (
                10f64.powf(lo.log10().floor()),
                10f64.powf(hi.log10().ceil()),
            );
        }
        return (lo, hi);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 * (1.0 + hi.abs()) {
        return (lo - 0.5, hi + 0.5);
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + 2.0 * pad)
}

/// A legend entry: its text and pen.
#[derive(Debug, Clone)]
pub struct Entry {
    pub label: String,
    pub pen: Pen,
}

/// Pens of a plot's series (by index) and its legend entries (series first, deduplicated
/// by label and pen, then the reference lines and the forcing marks).
fn pens(plot: &LinePlot, f: &Fonts) -> (Vec<(Pen, usize)>, Vec<Entry>) {
    let s = f.scale;
    let mut labels: Vec<&str> = Vec::new();
    let mut events: Vec<&str> = Vec::new();
    let mut out = Vec::new();
    let mut entries: Vec<Entry> = Vec::new();
    for series in &plot.series {
        let pen = if series.style == Style::Markers {
            let j = events
                .iter()
                .position(|l| *l == series.label)
                .unwrap_or_else(|| {
                    events.push(&series.label);
                    events.len() - 1
                });
            let fill = series
                .color
                .map(|k| style::PALETTE[k % style::PALETTE.len()])
                .unwrap_or(RGBColor(255, 255, 255));
            Pen {
                color: style::EVENT,
                width: 0.0,
                dash: Vec::new(),
                marker: Some((
                    style::event_marker(&series.label, j),
                    style::EVENT_MARKER * s,
                    fill,
                )),
                marker_spacing: 0.0,
            }
        } else {
            let k = series.color.unwrap_or_else(|| {
                labels
                    .iter()
                    .position(|l| *l == series.label)
                    .unwrap_or_else(|| {
                        labels.push(&series.label);
                        labels.len() - 1
                    })
            }) % style::PALETTE.len();
            let dash: &[f64] = match series.style {
                Style::Dashed => &style::DASHED,
                Style::Dotted => &style::DOTTED,
                _ => &[],
            };
            Pen {
                color: style::PALETTE[k],
                width: style::CURVE_WIDTH * s,
                dash: dash.iter().map(|d| d * s).collect(),
                marker: Some((
                    style::MARKERS[k],
                    style::CURVE_MARKER * s,
                    style::PALETTE[k],
                )),
                marker_spacing: style::MARKER_SPACING * s,
            }
        };
        let key = match entries
            .iter()
            .position(|e| e.label == series.label && e.pen == pen)
        {
            Some(i) => i,
            None => {
                entries.push(Entry {
                    label: series.label.clone(),
                    pen: pen.clone(),
                });
                entries.len() - 1
            }
        };
        out.push((pen, key));
    }
    for (_, label) in &plot.vertical {
        entries.push(Entry {
            label: label.clone(),
            pen: reference_pen(s),
        });
    }
    for (_, label) in &plot.marks {
        entries.push(Entry {
            label: label.clone(),
            pen: forcing_pen(s),
        });
    }
    (out, entries)
}

/// The pen of a linear reference line (ω_n).
pub fn reference_pen(s: f64) -> Pen {
    Pen {
        color: style::REFERENCE,
        width: style::REFERENCE_WIDTH * s,
        dash: style::DASH_DOT.iter().map(|d| d * s).collect(),
        marker: None,
        marker_spacing: 0.0,
    }
}

/// The pen of a forcing line.
pub fn forcing_pen(s: f64) -> Pen {
    Pen {
        color: style::FORCING,
        width: style::CURVE_WIDTH * s,
        dash: Vec::new(),
        marker: None,
        marker_spacing: 0.0,
    }
}

fn font(em: f64) -> FontDesc<'static> {
    style::font(em)
}

/// Lay legend entries out in rows across `width` px: each entry's (x, row) and the
/// number of rows. Empty labels are left out.
pub(crate) fn legend_layout<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[Entry],
    width: f64,
    f: &Fonts,
) -> (Vec<Option<(f64, usize)>>, usize) {
    let sample = 46.0 * f.scale;
    let gap = 8.0 * f.scale;
    let spacing = 26.0 * f.scale;
    let (mut x, mut row) = (0.0, 0usize);
    let mut placed = Vec::new();
    let mut any = false;
    for e in entries {
        if e.label.is_empty() {
            placed.push(None);
            continue;
        }
        let tw = area
            .estimate_text_size(&e.label, &font(f.legend).into())
            .map(|(w, _)| w as f64)
            .unwrap_or(e.label.chars().count() as f64 * f.legend * 0.6);
        let w = sample + gap + tw;
        if any && x + w > width {
            row += 1;
            x = 0.0;
        }
        placed.push(Some((x, row)));
        x += w + spacing;
        any = true;
    }
    (placed, if any { row + 1 } else { 0 })
}

/// Draw legend entries laid out by [`legend_layout`] with their top-left at (x0, y0)
/// (absolute px).
#[allow(clippy::too_many_arguments)]
pub fn draw_legend<DB: DrawingBackend>(
    root_area: &DrawingArea<DB, Shift>,
    painter: &mut Painter<'_, DB>,
    entries: &[Entry],
    placed: &[Option<(f64, usize)>],
    x0: f64,
    y0: f64,
    f: &Fonts,
    key_prefix: &str,
) -> std::result::Result<(), String> {
    let row_h = f.legend * 1.85;
    let sample = 46.0 * f.scale;
    let gap = 8.0 * f.scale;
    let (ax, ay) = {
        let (xr, yr) = root_area.get_pixel_range();
        (xr.start as f64, yr.start as f64)
    };
    for (k, (e, p)) in entries.iter().zip(placed).enumerate() {
        let Some((x, row)) = p else { continue };
        let cy = y0 + *row as f64 * row_h + row_h / 2.0;
        let key = format!("{key_prefix}{k}");
        let (sx0, sx1) = (x0 + x, x0 + x + sample);
        if e.pen.width > 0.0 {
            painter.line(&[(sx0, cy), (sx1, cy)], &e.pen, "legend", &key)?;
        }
        if e.pen.marker.is_some() {
            painter.marker(((sx0 + sx1) / 2.0, cy), &e.pen, "legend-marker", &key)?;
        }
        root_area
            .draw(&Text::new(
                e.label.clone(),
                ((sx1 + gap - ax).round() as i32, (cy - ay).round() as i32),
                TextStyle::from(font(f.legend)).pos(Pos::new(HPos::Left, VPos::Center)),
            ))
            .map_err(err)?;
    }
    Ok(())
}

/// Height a legend of `rows` rows takes, px.
pub(crate) fn legend_height(rows: usize, f: &Fonts) -> f64 {
    if rows == 0 {
        0.0
    } else {
        rows as f64 * f.legend * 1.85 + 10.0 * f.scale
    }
}

/// Tick label of a log axis: 1e-3, 0.01, 0.1, 1, 10, 100, 1e3.
fn log_tick(v: &f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if (0.01..1000.0).contains(&a) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

/// Tick label of a linear axis: as short as the tick spacing allows.
fn lin_tick(v: &f64) -> String {
    // a tick at zero computed as −5.55e-17
    if v.abs() < 1e-10 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        return format!("{v:.2e}");
    }
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.to_string() }
}

/// The frame (axes, ticks, grid, axis descriptions) of a panel, drawn by plotters; the
/// plot area's pixel range.
#[allow(clippy::too_many_arguments)]
pub(crate) fn axes<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    x_label: &str,
    y_label: &str,
    x: (f64, f64),
    y: (f64, f64),
    x_log: bool,
    y_log: bool,
    f: &Fonts,
) -> std::result::Result<(std::ops::Range<i32>, std::ops::Range<i32>), String> {
    let s = f.scale;
    let x_area = (f.tick * 1.6 + f.label * 1.7 + 4.0 * s) as u32;
    let y_area = (f.tick * 4.4 + f.label * 1.9) as u32;
    let grid = style::GRID.stroke_width(1);
    let edge = RGBColor(60, 60, 60).stroke_width(1);
    // as many x ticks as their labels have room for (8 at the default width)
    let x_ticks = ((area.dim_in_pixel().0 as f64 - y_area as f64 - 32.0 * s) / (85.0 * s))
        .floor()
        .clamp(3.0, 8.0) as usize;
    macro_rules! mesh {
        ($chart:expr, $xf:expr, $yf:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(x_label)
                .y_desc(y_label)
                .label_style(font(f.tick))
                .axis_desc_style(font(f.label))
                .x_label_formatter($xf)
                .y_label_formatter($yf)
                .light_line_style(WHITE)
                .bold_line_style(grid)
                .axis_style(edge)
                .x_labels(x_ticks)
                .y_labels(7)
                .draw()
                .map_err(err)?;
            chart.plotting_area().get_pixel_range()
        }};
    }
    let builder = |area| {
        let mut b = ChartBuilder::on(area);
        b.margin_right((24.0 * s) as u32)
            .margin_top((8.0 * s) as u32)
            .margin_left((8.0 * s) as u32)
            .x_label_area_size(x_area)
            .y_label_area_size(y_area);
        b
    };
    Ok(match (x_log, y_log) {
        (false, false) => mesh!(
            builder(area)
                .build_cartesian_2d(x.0..x.1, y.0..y.1)
                .map_err(err)?,
            &lin_tick,
            &lin_tick
        ),
        (false, true) => mesh!(
            builder(area)
                .build_cartesian_2d(x.0..x.1, (y.0..y.1).log_scale())
                .map_err(err)?,
            &lin_tick,
            &log_tick
        ),
        (true, false) => mesh!(
            builder(area)
                .build_cartesian_2d((x.0..x.1).log_scale(), y.0..y.1)
                .map_err(err)?,
            &log_tick,
            &lin_tick
        ),
        (true, true) => mesh!(
            builder(area)
                .build_cartesian_2d((x.0..x.1).log_scale(), (y.0..y.1).log_scale())
                .map_err(err)?,
            &log_tick,
            &log_tick
        ),
    })
}

/// `text` broken at spaces into lines no wider than `width` px in `font` (a word longer
/// than the width stays whole on its line).
fn wrap<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    font: &FontDesc<'_>,
    width: f64,
) -> Vec<String> {
    let measure = |t: &str| {
        area.estimate_text_size(t, &font.clone().into())
            .map(|(w, _)| w as f64)
            .unwrap_or(t.chars().count() as f64 * font.get_size() * 0.5)
    };
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split(' ') {
        let candidate = if line.is_empty() {
            word.to_string()
        } else {
            format!("{line} {word}")
        };
        if !line.is_empty() && measure(&candidate) > width {
            lines.push(std::mem::take(&mut line));
            line = word.to_string();
        } else {
            line = candidate;
        }
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// The title's and the caption's lines, wrapped to the width of `area`.
fn header_lines<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    caption: &str,
    f: &Fonts,
) -> (Vec<String>, Vec<String>) {
    let width = area.dim_in_pixel().0 as f64 - 24.0 * f.scale;
    let title_font = font(f.title).style(FontStyle::Bold);
    let lines = |text: &str, fd: &FontDesc<'_>| {
        if text.is_empty() {
            Vec::new()
        } else {
            wrap(area, text, fd, width)
        }
    };
    (lines(title, &title_font), lines(caption, &font(f.caption)))
}

/// Height the title and caption of a panel take, px (see [`draw_header`]).
fn header_height(title_lines: usize, caption_lines: usize, f: &Fonts) -> f64 {
    let s = f.scale;
    let mut y = 8.0 * s;
    if title_lines > 0 {
        y += f.title * (1.55 + 1.25 * (title_lines - 1) as f64);
    }
    if caption_lines > 0 {
        y += f.caption * (1.55 + 1.25 * (caption_lines - 1) as f64);
    }
    y + 2.0 * s
}

/// Title and caption of a panel at its top, each wrapped to the panel's width; returns
/// the height they take, px.
pub fn draw_header<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    caption: &str,
    f: &Fonts,
) -> std::result::Result<f64, String> {
    let s = f.scale;
    let (title_lines, caption_lines) = header_lines(area, title, caption, f);
    let mut y = 8.0 * s;
    let x = (12.0 * s) as i32;
    for (i, line) in title_lines.iter().enumerate() {
        if i > 0 {
            y += f.title * 1.25;
        }
        area.draw(&Text::new(
            line.clone(),
            (x, y as i32),
            font(f.title).style(FontStyle::Bold),
        ))
        .map_err(err)?;
    }
    if !title_lines.is_empty() {
        y += f.title * 1.55;
    }
    for (i, line) in caption_lines.iter().enumerate() {
        if i > 0 {
            y += f.caption * 1.25;
        }
        area.draw(&Text::new(
            line.clone(),
            (x, y as i32),
            font(f.caption).color(&RGBColor(50, 50, 50)),
        ))
        .map_err(err)?;
    }
    let h = header_height(title_lines.len(), caption_lines.len(), f);
    debug_assert!(caption_lines.is_empty() || (h - (y + f.caption * 1.55 + 2.0 * s)).abs() < 1.0);
    Ok(h)
}

/// Where a note's text goes: its top-left corner, and whether it sits away from its point
/// (drawn with a leader line).
struct Placed {
    text: String,
    at: (f64, f64),
    point: (f64, f64),
    size: (f64, f64),
    leader: bool,
}

/// Place note texts near their points, clear of each other, of the curves and of the
/// vertical lines where a place near the point allows (tried in order: beside the point
/// above and below, on either side, then further up and down), else in the least crowded
/// of those places, with a leader line to the point when it sits away from it.
fn place_notes<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    frame: &Frame,
    notes: &[Note],
    obstacles: &[(f64, f64)],
    columns: &[f64],
    f: &Fonts,
) -> Vec<Placed> {
    let s = f.scale;
    let mut boxes: Vec<(f64, f64, f64, f64)> = Vec::new();
    let mut out = Vec::new();
    let pad = 3.0 * s;
    for n in notes {
        let Some((px, py)) = frame.map(n.x, n.y) else {
            continue;
        };
        let (tw, th) = area
            .estimate_text_size(&n.text, &font(f.note).into())
            .map(|(w, h)| (w as f64, h as f64))
            .unwrap_or((n.text.chars().count() as f64 * f.note * 0.6, f.note));
        let gap = 9.0 * s;
        let xs = [px + gap, px - gap - tw, px - tw / 2.0];
        let mut ys = vec![py - th - gap, py + gap];
        for k in 1..=8 {
            let step = k as f64 * (th + 4.0 * s);
            ys.push(py - th - gap - step);
            ys.push(py + gap + step);
        }
        let mut best: Option<(f64, (f64, f64))> = None;
        'search: for (iy, y) in ys.iter().enumerate() {
            for x in xs {
                let (x, y) = (
                    x.min(frame.right - tw).max(frame.left + 2.0),
                    y.min(frame.bottom - th).max(frame.top + 1.0),
                );
                let (x0, y0, x1, y1) = (x - pad, y - pad, x + tw + pad, y + th + pad);
                let inside = |(a, b): (f64, f64)| a >= x0 && a <= x1 && b >= y0 && b <= y1;
                let labels = boxes
                    .iter()
                    .filter(|&&(a, b, c, d)| x < c && x + tw > a && y < d && y + th > b)
                    .count() as f64;
                let curves = obstacles.iter().filter(|p| inside(**p)).count() as f64;
                let lines = columns.iter().filter(|c| **c >= x0 && **c <= x1).count() as f64;
                // the marked point itself, and a place far from it, count against
                let covers = if inside((px, py)) { 1.0 } else { 0.0 };
                let score =
                    1000.0 * labels + curves + 30.0 * lines + 50.0 * covers + 0.5 * iy as f64;
                if best.is_none_or(|(b, _)| score < b) {
                    best = Some((score, (x, y)));
                }
                if labels + curves + lines + covers == 0.0 {
                    break 'search;
                }
            }
        }
        let Some((_, (x, y))) = best else { continue };
        boxes.push((x, y, x + tw, y + th));
        // away from the point: more than a text height off it
        let dx = if px < x {
            x - px
        } else if px > x + tw {
            px - x - tw
        } else {
            0.0
        };
        let dy = if py < y {
            y - py
        } else if py > y + th {
            py - y - th
        } else {
            0.0
        };
        out.push(Placed {
            text: n.text.clone(),
            at: (x, y),
            point: (px, py),
            size: (tw, th),
            leader: dx.hypot(dy) > th + gap * 1.5,
        });
    }
    out
}

/// Points along the curves of a plot every few pixels (what a note should not cover).
fn curve_points(frame: &Frame, plot: &LinePlot, step: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for series in &plot.series {
        let pts: Vec<Option<(f64, f64)>> = series
            .x
            .iter()
            .zip(&series.y)
            .map(|(x, y)| frame.map(*x, *y))
            .collect();
        for w in pts.windows(2) {
            if let [Some(a), Some(b)] = w {
                let len = (b.0 - a.0).hypot(b.1 - a.1);
                let n = (len / step).ceil().max(1.0) as usize;
                for k in 0..n {
                    let t = k as f64 / n as f64;
                    out.push((a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t));
                }
            }
        }
        if let Some(Some(last)) = pts.last() {
            out.push(*last);
        }
    }
    out
}

/// The smallest plot area a panel keeps, px at scale 1 (height, width).
const MIN_PLOT: (f64, f64) = (90.0, 120.0);

/// How a panel's height is shared: the header, the chart (axes and plot area), the legend.
struct PanelLayout {
    entries: Vec<Entry>,
    pens: Vec<(Pen, usize)>,
    placed: Vec<Option<(f64, usize)>>,
    chart_h: f64,
    /// The height the panel needs for a plot area of [`MIN_PLOT`], px.
    needed: f64,
    /// The plot area's width, px.
    plot_w: f64,
}

/// The x range of a plot's data.
fn x_range(plot: &LinePlot) -> (f64, f64) {
    range(plot.series.iter().flat_map(|s| s.x.iter().copied()), false)
}

fn panel_layout<DB: DrawingBackend>(
    plot: &LinePlot,
    area: &DrawingArea<DB, Shift>,
    f: &Fonts,
) -> PanelLayout {
    let s = f.scale;
    let (w, h) = area.dim_in_pixel();
    let (t, c) = header_lines(area, &plot.title, &plot.caption, f);
    let head = header_height(t.len(), c.len(), f);
    let (pens, mut entries) = pens(plot, f);
    // reference and forcing lines outside the x range are not drawn: nor listed
    let xr = x_range(plot);
    let n_lines = plot.vertical.len() + plot.marks.len();
    let first_line = entries.len() - n_lines;
    for (i, (x, _)) in plot.vertical.iter().chain(&plot.marks).enumerate() {
        let lo = xr.0.min(xr.1) - 1e-9 * xr.0.abs().max(xr.1.abs());
        let hi = xr.0.max(xr.1) + 1e-9 * xr.0.abs().max(xr.1.abs());
        if !(lo..=hi).contains(x) {
            entries[first_line + i].label.clear();
        }
    }
    let margin = 12.0 * s;
    let (placed, rows) = legend_layout(area, &entries, w as f64 - 2.0 * margin, f);
    let legend_h = legend_height(rows, f);
    let x_area = f.tick * 1.6 + f.label * 1.7 + 4.0 * s;
    let y_area = f.tick * 4.4 + f.label * 1.9;
    let frame_v = x_area + 8.0 * s + 2.0;
    let needed = head + legend_h + frame_v + MIN_PLOT.0 * s;
    let chart_h = (h as f64 - head - legend_h).max(frame_v + 1.0);
    PanelLayout {
        entries,
        pens,
        placed,
        chart_h,
        needed,
        plot_w: w as f64 - y_area - 32.0 * s,
    }
}

fn draw_panel<DB: DrawingBackend>(
    plot: &LinePlot,
    area: &DrawingArea<DB, Shift>,
    f: &Fonts,
    painter: &mut Painter<'_, DB>,
    panel: usize,
) -> std::result::Result<(), String> {
    let s = f.scale;
    let layout = panel_layout(plot, area, f);
    let head = draw_header(area, &plot.title, &plot.caption, f)?;
    let (pens, entries, placed) = (&layout.pens, &layout.entries, &layout.placed);
    let margin = 12.0 * s;
    let chart_h = layout.chart_h;
    let (_, rest) = area.split_vertically(head.round() as i32);
    let (chart_area, _) = rest.split_vertically(chart_h.round() as i32);
    let log = plot.y_scale == Scale::Log;
    let xr = x_range(plot);
    let yr = range(plot.series.iter().flat_map(|s| s.y.iter().copied()), log);
    let px = axes(
        &chart_area,
        &plot.x_label,
        &plot.y_label,
        xr,
        yr,
        false,
        log,
        f,
    )?;
    let frame = Frame::new(px, xr, yr, false, log);
    let key = |k: usize| format!("{panel}-{k}");
    let n_series_entries = entries.len() - plot.vertical.len() - plot.marks.len();
    // references and forcing lines first (under the curves)
    let mut columns = Vec::new();
    for (i, (x, _)) in plot.vertical.iter().enumerate() {
        if let Some(cx) = frame.column(*x) {
            columns.push(cx);
            painter.line(
                &[(cx, frame.bottom), (cx, frame.top)],
                &entries[n_series_entries + i].pen,
                "reference",
                &key(n_series_entries + i),
            )?;
        }
    }
    for (i, (x, _)) in plot.marks.iter().enumerate() {
        let k = n_series_entries + plot.vertical.len() + i;
        if let Some(cx) = frame.column(*x) {
            columns.push(cx);
            painter.line(
                &[(cx, frame.bottom), (cx, frame.top)],
                &entries[k].pen,
                "forcing",
                &key(k),
            )?;
        }
    }
    // curves (split where a value cannot be drawn), then event markers on top
    for pass in [false, true] {
        for (i, (series, (pen, k))) in plot.series.iter().zip(pens).enumerate() {
            if (series.style == Style::Markers) != pass {
                continue;
            }
            let mut piece: Vec<(f64, f64)> = Vec::new();
            let offset = pen.marker_spacing * (0.3 + 0.11 * (i % 6) as f64);
            let mut pieces = Vec::new();
            for (x, y) in series.x.iter().zip(&series.y) {
                match frame.map(*x, *y) {
                    Some(p) => piece.push(p),
                    None => {
                        if !piece.is_empty() {
                            pieces.push(std::mem::take(&mut piece));
                        }
                    }
                }
            }
            if !piece.is_empty() {
                pieces.push(piece);
            }
            for piece in pieces {
                if pen.width > 0.0 && piece.len() == 1 {
                    // a lone point of a line: its marker
                    painter.marker(piece[0], pen, "curve-marker", &key(*k))?;
                } else {
                    painter.curve(&piece, pen, "curve", &key(*k), offset)?;
                }
            }
        }
    }
    // notes near their points, clear of the curves, the lines and each other
    let (ax, ay) = {
        let (x, y) = area.get_pixel_range();
        (x.start as f64, y.start as f64)
    };
    let obstacles = curve_points(&frame, plot, 3.0 * s);
    let leader_pen = Pen {
        color: style::EVENT,
        width: 1.0 * s,
        dash: Vec::new(),
        marker: None,
        marker_spacing: 0.0,
    };
    for (k, p) in place_notes(area, &frame, &plot.notes, &obstacles, &columns, f)
        .into_iter()
        .enumerate()
    {
        if p.leader {
            // from the point to the nearest point of the text's box
            let (x, y) = p.at;
            let (tw, th) = p.size;
            let end = (p.point.0.clamp(x, x + tw), p.point.1.clamp(y, y + th));
            painter.line(
                &[p.point, end],
                &leader_pen,
                "leader",
                &format!("{panel}-note{k}"),
            )?;
        }
        area.draw(&Text::new(
            p.text,
            ((p.at.0 - ax).round() as i32, (p.at.1 - ay).round() as i32),
            font(f.note).color(&style::EVENT),
        ))
        .map_err(err)?;
    }
    // the legend below the plot area, outside the data
    draw_legend(
        area,
        painter,
        entries,
        placed,
        ax + margin,
        ay + head + chart_h + 4.0 * s,
        f,
        &format!("{panel}-"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dashes_cover_the_pattern() {
        let d = dashes(&[(0.0, 0.0), (30.0, 0.0)], &[10.0, 5.0]);
        assert_eq!(d.len(), 2);
        assert_eq!(d[0], vec![(0.0, 0.0), (10.0, 0.0)]);
        assert_eq!(d[1], vec![(15.0, 0.0), (25.0, 0.0)]);
    }

    #[test]
    fn sizes_parse_and_are_bounded() {
        assert_eq!(parse_size("1600x1000").unwrap(), (1600, 1000));
        assert_eq!(parse_size("1600X1000").unwrap(), (1600, 1000));
        assert!(parse_size("1600").is_err());
        assert!(parse_size("10x10").is_err());
        assert!(parse_size("99999x1000").is_err());
        assert!(parse_size("ax1000").is_err());
    }
}
