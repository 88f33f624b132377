//! The report's own figures (pure functions of their inputs), drawn through the line
//! plots' machinery ([`crate::output::plot`]: the same fonts, palette, float-precision
//! curves and legend below the plot): the linear frequency response on log–log axes
//! with the forcing bands shaded and the resonances marked, and the interference
//! (Campbell) diagram.
//!
//! They are drawn here rather than as a `LinePlot`, which has no shaded bands and no
//! logarithmic frequency axis.

use crate::output::plot::{
    Entry, Figure, Format, Frame, Painter, Pen, axes, draw_header, draw_legend, forcing_pen,
    legend_height, legend_layout, reference_pen, render,
};
use crate::output::style::{self, Fonts};
use crate::output::units::FreqUnit;
use plotters::coord::Shift;
use plotters::prelude::*;

const BAND: RGBColor = style::FORCING;

/// A forcing band on a frequency axis: label, lowest, nominal and highest ω (rad/s).
#[derive(Debug, Clone)]
pub struct Band {
    pub label: String,
    pub lo: f64,
    pub nominal: f64,
    pub hi: f64,
}

/// The linear response figure's data.
#[derive(Debug, Clone)]
pub struct FrfPlot {
    pub title: String,
    /// Frequencies, rad/s (ascending, positive).
    pub omega: Vec<f64>,
    /// Per curve: its name and amplitudes (same length as `omega`).
    pub curves: Vec<(String, Vec<f64>)>,
    /// The amplitudes' unit.
    pub unit: String,
    /// Resonances: label and ω (rad/s), drawn as reference lines.
    pub resonances: Vec<(String, f64)>,
    /// Refined peaks (ω rad/s, amplitude), marked on the curves.
    pub peaks: Vec<(f64, f64)>,
    pub bands: Vec<Band>,
    /// The unit of the frequency axis (`--freq-unit`); the data above stay in rad/s.
    pub freq_unit: FreqUnit,
}

impl FrfPlot {
    /// The data with every frequency in `freq_unit` (drawn as they are then).
    fn in_unit(&self) -> FrfPlot {
        let u = self.freq_unit;
        let mut p = self.clone();
        p.omega.iter_mut().for_each(|w| *w = u.of(*w));
        p.resonances.iter_mut().for_each(|(_, w)| *w = u.of(*w));
        p.peaks.iter_mut().for_each(|(w, _)| *w = u.of(*w));
        for b in &mut p.bands {
            (b.lo, b.nominal, b.hi) = (u.of(b.lo), u.of(b.nominal), u.of(b.hi));
        }
        p
    }
}

/// The report figures' size, px.
const SIZE: (u32, u32) = (900, 600);

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

fn curve_pen(i: usize, s: f64) -> Pen {
    let k = i % style::PALETTE.len();
    Pen {
        color: style::PALETTE[k],
        width: style::CURVE_WIDTH * s,
        dash: Vec::new(),
        marker: Some((
            style::MARKERS[k],
            style::CURVE_MARKER * s,
            style::PALETTE[k],
        )),
        marker_spacing: style::MARKER_SPACING * s,
    }
}

fn event_pen(m: style::Marker, fill: RGBColor, s: f64) -> Pen {
    Pen {
        color: style::EVENT,
        width: 0.0,
        dash: Vec::new(),
        marker: Some((m, style::EVENT_MARKER * s, fill)),
        marker_spacing: 0.0,
    }
}

/// Header, chart area and legend of a report figure: the frame's pixel range and where
/// the legend goes.
struct Layout<'a, DB: DrawingBackend> {
    chart: DrawingArea<DB, Shift>,
    placed: Vec<Option<(f64, usize)>>,
    legend_y: f64,
    root: &'a DrawingArea<DB, Shift>,
}

fn layout<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    title: &str,
    entries: &[Entry],
    f: &Fonts,
) -> std::result::Result<Layout<'a, DB>, String> {
    let (w, h) = root.dim_in_pixel();
    let head = draw_header(root, title, "", f)?;
    let (placed, rows) = legend_layout(root, entries, w as f64 - 24.0 * f.scale, f);
    let lh = legend_height(rows, f);
    let chart_h = (h as f64 - head - lh).max(80.0);
    let (_, rest) = root.split_vertically(head.round() as i32);
    let (chart, _) = rest.split_vertically(chart_h.round() as i32);
    Ok(Layout {
        chart,
        placed,
        legend_y: head + chart_h + 4.0 * f.scale,
        root,
    })
}

impl<DB: DrawingBackend> Layout<'_, DB> {
    fn legend(
        &self,
        painter: &mut Painter<'_, DB>,
        entries: &[Entry],
        f: &Fonts,
    ) -> std::result::Result<(), String> {
        draw_legend(
            self.root,
            painter,
            entries,
            &self.placed,
            12.0 * f.scale,
            self.legend_y,
            f,
            "r-",
        )
    }
}

/// A label at pixel (x, y) in `color`.
fn label<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    text: &str,
    (x, y): (f64, f64),
    color: RGBColor,
    f: &Fonts,
) -> std::result::Result<(), String> {
    root.draw(&Text::new(
        text.to_string(),
        (x.round() as i32, y.round() as i32),
        style::font(f.note).color(&color),
    ))
    .map_err(err)
}

impl Figure for FrfPlot {
    fn size(&self) -> (u32, u32) {
        SIZE
    }
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        painter: &mut Painter<'_, DB>,
    ) -> std::result::Result<(), String> {
        let p = &self.in_unit();
        let sym = p.freq_unit.symbol();
        let f = Fonts::for_width(SIZE.0);
        let s = f.scale;
        let (x0, x1) = (
            p.omega.first().copied().unwrap_or(1.0),
            p.omega.last().copied().unwrap_or(10.0),
        );
        let ys = p
            .curves
            .iter()
            .flat_map(|(_, y)| y.iter().copied())
            .filter(|y| y.is_finite() && *y > 0.0);
        let (mut y0, mut y1) = (f64::INFINITY, 0.0f64);
        for y in ys {
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        if !(y0.is_finite() && y1 > 0.0) {
            (y0, y1) = (1e-3, 1.0);
        }
        // at most six decades below the largest amplitude
        y0 = y0.max(y1 * 1e-6) / 1.5;
        y1 *= 3.0;
        let mut entries: Vec<Entry> = p
            .curves
            .iter()
            .enumerate()
            .map(|(i, (name, _))| Entry {
                label: format!("{name} [{}]", p.unit),
                pen: curve_pen(i, s),
            })
            .collect();
        if !p.peaks.is_empty() {
            entries.push(Entry {
                label: "refined peaks".into(),
                pen: event_pen(style::Marker::TriangleDown, WHITE, s),
            });
        }
        if !p.resonances.is_empty() {
            entries.push(Entry {
                label: format!("natural frequencies (labelled) [{sym}]"),
                pen: reference_pen(s),
            });
        }
        if !p.bands.is_empty() {
            entries.push(Entry {
                label: format!("forcing line [{sym}] and its band (shaded)"),
                pen: forcing_pen(s),
            });
        }
        let lay = layout(root, &p.title, &entries, &f)?;
        let px = axes(
            &lay.chart,
            // the cycle rate in Hz or rpm is f, as the tables name it
            &format!("{} [{sym}]", p.freq_unit.rate()),
            &format!("amplitude [{}]", p.unit),
            (x0, x1),
            (y0, y1),
            true,
            true,
            &f,
        )?;
        let fr = Frame::new(px, (x0, x1), (y0, y1), true, true);
        for b in &p.bands {
            if b.hi < x0 || b.lo > x1 {
                continue;
            }
            let (Some(l), Some(r)) = (fr.column(b.lo.max(x0)), fr.column(b.hi.min(x1))) else {
                continue;
            };
            root.draw(&Rectangle::new(
                [
                    (l.round() as i32, fr.top as i32),
                    (r.round() as i32, fr.bottom as i32),
                ],
                BAND.mix(0.3).filled(),
            ))
            .map_err(err)?;
            if let Some(c) = fr.column(b.nominal) {
                painter.line(
                    &[(c, fr.bottom), (c, fr.top)],
                    &forcing_pen(s),
                    "forcing",
                    "r-forcing",
                )?;
                label(
                    root,
                    &b.label,
                    (c + 4.0 * s, fr.top + 4.0 * s),
                    style::EVENT,
                    &f,
                )?;
            }
        }
        for (text, w) in &p.resonances {
            let Some(c) = fr.column(*w) else { continue };
            painter.line(
                &[(c, fr.bottom), (c, fr.top)],
                &reference_pen(s),
                "reference",
                "r-reference",
            )?;
            label(
                root,
                text,
                (c + 4.0 * s, fr.bottom - f.note * 1.6),
                style::REFERENCE,
                &f,
            )?;
        }
        for (i, (_, y)) in p.curves.iter().enumerate() {
            let pts: Vec<(f64, f64)> = p
                .omega
                .iter()
                .zip(y)
                .filter_map(|(w, a)| fr.map(*w, a.max(y0)))
                .collect();
            painter.curve(&pts, &entries[i].pen, "curve", &format!("r-{i}"), 40.0 * s)?;
        }
        if !p.peaks.is_empty() {
            let k = p.curves.len();
            for &(w, a) in &p.peaks {
                if let Some(at) = fr.map(w, a.max(y0)) {
                    painter.marker(at, &entries[k].pen, "curve-marker", &format!("r-{k}"))?;
                }
            }
        }
        lay.legend(painter, &entries, &f)
    }
}

/// The frequency response on log–log axes, bands shaded (those that reach into the
/// plotted range), resonances and peaks marked.
pub fn frf_svg(p: &FrfPlot) -> Result<String, String> {
    render(p, Format::Svg).map(|b| String::from_utf8_lossy(&b).into_owned())
}

/// A forcing line of the Campbell diagram: ω = `slope` × the main rotor's speed Ω (rpm),
/// in rad/s per rpm.
#[derive(Debug, Clone)]
pub struct CampbellLine {
    pub label: String,
    pub slope: f64,
}

/// The interference diagram's data.
#[derive(Debug, Clone)]
pub struct CampbellPlot {
    pub title: String,
    /// The speed axis' rotor name.
    pub rotor: String,
    /// Nominal speed of that rotor, rpm.
    pub rpm_nominal: f64,
    /// Its operating range, rpm, if known.
    pub rpm_range: Option<[f64; 2]>,
    /// Modes: label and ω_n (rad/s).
    pub modes: Vec<(String, f64)>,
    pub lines: Vec<CampbellLine>,
    /// Crossings (rotor rpm, ω rad/s, inside the operating range).
    pub crossings: Vec<(f64, f64, bool)>,
    /// Right end of the speed axis, rpm; top of the frequency axis, rad/s.
    pub rpm_end: f64,
    pub omega_end: f64,
    /// The unit of the frequency axis (`--freq-unit`); the data above stay in rad/s.
    pub freq_unit: FreqUnit,
}

impl CampbellPlot {
    /// The data with every frequency in `freq_unit` (the speed axis stays in rpm).
    fn in_unit(&self) -> CampbellPlot {
        let u = self.freq_unit;
        let mut p = self.clone();
        p.modes.iter_mut().for_each(|(_, w)| *w = u.of(*w));
        p.lines.iter_mut().for_each(|l| l.slope = u.of(l.slope));
        p.crossings.iter_mut().for_each(|c| c.1 = u.of(c.1));
        p.omega_end = u.of(p.omega_end);
        p
    }
}

/// Mode frequencies against rotor speed (horizontal lines: the mechanism's modes do not
/// depend on the rotor speed), the n/rev lines through the origin, the operating range
/// shaded when known and the nominal speed drawn, crossings marked (filled inside the
/// operating range).
pub fn campbell_svg(p: &CampbellPlot) -> Result<String, String> {
    render(p, Format::Svg).map(|b| String::from_utf8_lossy(&b).into_owned())
}

impl Figure for CampbellPlot {
    fn size(&self) -> (u32, u32) {
        SIZE
    }
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        painter: &mut Painter<'_, DB>,
    ) -> std::result::Result<(), String> {
        let p = &self.in_unit();
        let sym = p.freq_unit.symbol();
        let f = Fonts::for_width(SIZE.0);
        let s = f.scale;
        let (xe, ye) = (p.rpm_end, p.omega_end);
        let mut entries: Vec<Entry> = p
            .modes
            .iter()
            .enumerate()
            .map(|(i, (label, w))| Entry {
                label: format!("{label}: ω_n = {w:.2} {sym}"),
                pen: curve_pen(i, s),
            })
            .collect();
        let n_modes = entries.len();
        let mut thin = forcing_pen(s);
        thin.width = style::REFERENCE_WIDTH * s;
        entries.push(Entry {
            label: format!("forcing lines n/rev [{sym}] (labelled)"),
            pen: thin.clone(),
        });
        entries.push(Entry {
            label: format!("nominal {:.0} rpm", p.rpm_nominal),
            pen: forcing_pen(s),
        });
        // with no operating range a crossing is neither in nor out of it: one grey marker
        let judged = p.rpm_range.is_some();
        if !p.crossings.is_empty() {
            if judged {
                entries.push(Entry {
                    label: "crossing in the operating range".into(),
                    pen: event_pen(style::Marker::Circle, style::EVENT, s),
                });
                entries.push(Entry {
                    label: "crossing outside it".into(),
                    pen: event_pen(style::Marker::Circle, WHITE, s),
                });
            } else {
                entries.push(Entry {
                    label: "crossing (no operating range given: not judged in or out)".into(),
                    pen: event_pen(style::Marker::Circle, RGBColor(150, 150, 150), s),
                });
            }
        }
        let lay = layout(root, &p.title, &entries, &f)?;
        let px = axes(
            &lay.chart,
            &format!("{} rotor speed [rpm]", p.rotor),
            &format!("frequency [{sym}]"),
            (0.0, xe),
            (0.0, ye),
            false,
            false,
            &f,
        )?;
        let fr = Frame::new(px, (0.0, xe), (0.0, ye), false, false);
        if let Some([lo, hi]) = p.rpm_range
            && let (Some(l), Some(r)) = (fr.column(lo.max(0.0)), fr.column(hi.min(xe)))
        {
            root.draw(&Rectangle::new(
                [
                    (l.round() as i32, fr.top as i32),
                    (r.round() as i32, fr.bottom as i32),
                ],
                BAND.mix(0.3).filled(),
            ))
            .map_err(err)?;
            label(
                root,
                "operating range",
                (l + 4.0 * s, fr.bottom - f.note * 1.6),
                style::EVENT,
                &f,
            )?;
        }
        if let Some(c) = fr.column(p.rpm_nominal) {
            painter.line(
                &[(c, fr.bottom), (c, fr.top)],
                &entries[n_modes + 1].pen,
                "forcing",
                &format!("r-{}", n_modes + 1),
            )?;
        }
        // each line's label just inside the box where the line leaves it, moved back along
        // the line until it overlaps no label placed before (lines that leave through the
        // top close together, 4T 12P 8P, would write theirs on top of each other)
        let mut placed: Vec<[f64; 4]> = Vec::new();
        for l in &p.lines {
            let w = l.slope;
            // from the origin to where the line leaves the box
            let x_end = xe.min(ye / w);
            let (Some(a), Some(b)) = (fr.map(0.0, 0.0), fr.map(x_end, w * x_end)) else {
                continue;
            };
            painter.line(&[a, b], &thin, "forcing", &format!("r-{n_modes}"))?;
            let (tw, th) = root
                .estimate_text_size(&l.label, &style::font(f.note).into())
                .map(|(w, h)| (w as f64, h as f64))
                .unwrap_or((l.label.chars().count() as f64 * f.note * 0.6, f.note));
            let at = |t: f64| -> (f64, f64) {
                // the point a length t back from b toward a, and the label beside it
                let len = ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt().max(1.0);
                let (x, y) = (b.0 + (a.0 - b.0) * t / len, b.1 + (a.1 - b.1) * t / len);
                if x_end < xe {
                    (x + 4.0 * s, y + 2.0 * s)
                } else {
                    (x - tw - 6.0 * s, y - th - 2.0 * s)
                }
            };
            // apart by half an em at least, so that neighbours do not read as one string
            let gap = 0.5 * f.note;
            let free = |(x, y): (f64, f64)| {
                placed.iter().all(|q| {
                    x + tw + gap <= q[0]
                        || q[2] + gap <= x
                        || y + th + gap <= q[1]
                        || q[3] + gap <= y
                })
            };
            let step = 0.5 * th;
            let (tx, ty) = (0..200)
                .map(|k| at(k as f64 * step))
                .find(|&q| free(q))
                .unwrap_or_else(|| at(0.0));
            placed.push([tx, ty, tx + tw, ty + th]);
            label(root, &l.label, (tx, ty), style::EVENT, &f)?;
        }
        for (i, (_, w)) in p.modes.iter().enumerate() {
            let (Some(a), Some(b)) = (fr.map(0.0, *w), fr.map(xe, *w)) else {
                continue;
            };
            painter.curve(
                &[a, b],
                &entries[i].pen,
                "curve",
                &format!("r-{i}"),
                30.0 * s,
            )?;
        }
        for &(x, y, inside) in &p.crossings {
            let k = n_modes + if !judged || inside { 2 } else { 3 };
            if let Some(at) = fr.map(x, y) {
                painter.marker(at, &entries[k].pen, "curve-marker", &format!("r-{k}"))?;
            }
        }
        lay.legend(painter, &entries, &f)
    }
}
