//! A sensitivity study's files: the CSV table, the JSON document and the tornado chart.

use super::plot::{Figure, Format, Painter, render, write_figure};
use super::style::{self, Fonts};
use super::{Provenance, num, write_atomic};
use crate::diag::Result;
use crate::linear::sensitivity::Sensitivity;
use plotters::coord::Shift;
use plotters::prelude::*;

/// `sensitivity --json`: the study with its provenance.
#[derive(Debug, serde::Serialize)]
pub struct SensitivityReport<'a> {
    pub provenance: &'a Provenance,
    /// The varied parameters: name, baseline value (SI), unit.
    pub parameters: Vec<ParameterJson>,
    #[serde(flatten)]
    pub study: &'a Sensitivity,
    /// Column → unit of the CSV and of the numbers here.
    pub units: std::collections::BTreeMap<&'static str, &'static str>,
}

#[derive(Debug, serde::Serialize)]
pub struct ParameterJson {
    pub name: String,
    pub value: f64,
    pub unit: String,
    pub min: f64,
    pub max: f64,
}

impl<'a> SensitivityReport<'a> {
    pub fn new(
        study: &'a Sensitivity,
        provenance: &'a Provenance,
        parameters: Vec<ParameterJson>,
    ) -> Self {
        let units = [
            ("omega_n_rad_s", "rad/s"),
            ("undamped_omega_rad_s", "rad/s"),
            ("peak_omega_rad_s", "rad/s"),
            ("damping_ratio", "1"),
            ("change_pct_omega_n", "%"),
            ("change_pct_undamped", "%"),
            ("domega_n_dp", "rad/s per SI unit of the parameter"),
            ("dzeta_dp", "1 per SI unit of the parameter"),
            ("fd", "rad/s per SI unit of the parameter"),
            ("fd_uncertainty", "rad/s per SI unit of the parameter"),
            ("fd_dzeta_dp", "1 per SI unit of the parameter"),
            ("fd_dzeta_uncertainty", "1 per SI unit of the parameter"),
            ("elasticity", "1"),
            ("value", "SI unit of the parameter"),
            ("min_rad_s", "rad/s"),
            ("max_rad_s", "rad/s"),
        ]
        .into_iter()
        .collect();
        SensitivityReport {
            provenance,
            parameters,
            study,
            units,
        }
    }
}

/// The CSV header of [`write_sensitivity_csv`].
pub const SENSITIVITY_CSV_HEADER: &str = "mode,param,label,value,omega_n_rad_s,damping_ratio,undamped_omega_rad_s,change_pct_omega_n,change_pct_undamped,peak_omega_rad_s";

/// One row per mode and case, the baseline first (param and label `baseline`); SI units,
/// an empty field where a value does not exist (no undamped partner, no sweep).
pub fn write_sensitivity_csv(path: &str, s: &Sensitivity) -> Result<()> {
    write_atomic(path, |w| {
        writeln!(w, "{SENSITIVITY_CSV_HEADER}")?;
        let opt = |x: Option<f64>| x.map(num).unwrap_or_default();
        for m in &s.modes {
            writeln!(
                w,
                "{},baseline,baseline,,{},{},{},0,{},{}",
                m.name,
                num(m.omega_n_rad_s),
                num(m.damping_ratio),
                opt(m.undamped_omega_rad_s),
                if m.undamped_omega_rad_s.is_some() {
                    "0"
                } else {
                    ""
                },
                opt(m.peak_omega_rad_s)
            )?;
            for c in &m.cases {
                writeln!(
                    w,
                    "{},{},{},{},{},{},{},{},{},{}",
                    m.name,
                    c.param,
                    c.label,
                    num(c.value),
                    num(c.omega_n_rad_s),
                    num(c.damping_ratio),
                    opt(c.undamped_omega_rad_s),
                    num(c.change_pct_omega_n),
                    opt(c.change_pct_undamped),
                    opt(c.peak_omega_rad_s)
                )?;
            }
        }
        Ok(())
    })
}

/// The tornado chart as SVG: one panel per mode, one bar per parameter from its lowest
/// to its highest case's change of ω_n (%), widest on top, labelled with the cases.
pub fn tornado_svg(s: &Sensitivity, title: &str) -> std::result::Result<String, String> {
    let fig = Tornado {
        s,
        title,
        size: tornado_size(s),
    };
    render(&fig, Format::Svg).map(|b| String::from_utf8_lossy(&b).into_owned())
}

/// The tornado chart's default size, px.
pub fn tornado_size(s: &Sensitivity) -> (u32, u32) {
    (900, 130 + 260 * s.modes.len().max(1) as u32)
}

/// The tornado chart as a figure (SVG or PNG).
pub struct Tornado<'a> {
    pub s: &'a Sensitivity,
    pub title: &'a str,
    pub size: (u32, u32),
}

impl Figure for Tornado<'_> {
    fn size(&self) -> (u32, u32) {
        self.size
    }
    fn resized(&self, size: (u32, u32)) -> Option<Self> {
        Some(Tornado {
            s: self.s,
            title: self.title,
            size,
        })
    }
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        _painter: &mut Painter<'_, DB>,
    ) -> std::result::Result<(), String> {
        let (s, title) = (self.s, self.title);
        let f = Fonts::for_width(self.size.0);
        let sc = f.scale;
        let rows: usize = s.modes.len().max(1);
        let (top, body) =
            root.split_vertically((f.title * 1.6 + f.caption * 1.7 + 10.0 * sc) as i32);
        top.draw(&Text::new(
            title.to_string(),
            ((12.0 * sc) as i32, (8.0 * sc) as i32),
            style::font(f.title).style(FontStyle::Bold),
        ))
        .map_err(|e| e.to_string())?;
        top.draw(&Text::new(
            "each bar: the parameter's cases (labelled); blue (left) lowers ω_n, vermillion (right) raises it",
            ((12.0 * sc) as i32, (8.0 * sc + f.title * 1.6) as i32),
            style::font(f.caption),
        ))
        .map_err(|e| e.to_string())?;
        let areas = body.split_evenly((rows, 1));
        for (m, area) in s.modes.iter().zip(areas.iter()) {
            // per parameter: (name, lowest change, highest change, their cases' labels)
            let mut bars: Vec<(String, f64, f64, String, String)> = Vec::new();
            for c in &m.cases {
                let short = c
                    .label
                    .strip_prefix(&c.param)
                    .unwrap_or(&c.label)
                    .to_string();
                match bars.iter_mut().find(|b| b.0 == c.param) {
                    Some(b) => {
                        if c.change_pct_omega_n < b.1 {
                            b.1 = c.change_pct_omega_n;
                            b.3 = short;
                        } else if c.change_pct_omega_n > b.2 {
                            b.2 = c.change_pct_omega_n;
                            b.4 = short;
                        }
                    }
                    None => {
                        let x = c.change_pct_omega_n;
                        let (lo, hi) = (x.min(0.0), x.max(0.0));
                        let (ll, hl) = if x < 0.0 {
                            (short, String::new())
                        } else {
                            (String::new(), short)
                        };
                        bars.push((c.param.clone(), lo, hi, ll, hl));
                    }
                }
            }
            bars.sort_by(|a, b| (b.2 - b.1).total_cmp(&(a.2 - a.1)));
            // the bar labels, beside each bar's end
            let label = |l: &str, x: f64| format!("{l}: {x:+.2} %");
            let margin_px = 12.0 * sc;
            let y_area_px = 150.0 * sc;
            // half the plot's width, px: the x axis runs from −span to +span about its middle
            let half =
                ((area.dim_in_pixel().0 as f64 - y_area_px - 2.0 * margin_px) / 2.0).max(1.0);
            // a label's width, px: the font's estimate, and no less than 0.62 em a
            // character (a wide sans-serif's digits) where the viewer's font is wider
            let width = |t: &str| -> f64 {
                let est = area
                    .estimate_text_size(t, &style::font(f.note).into())
                    .map(|(w, _)| w as f64)
                    .unwrap_or(0.0);
                est.max(t.chars().count() as f64 * f.note * 0.62)
            };
            // the span: 1.6 × the longest bar, wider where a label beside its bar's end
            // (a gap of 2 % of the span, and 6 px to spare) would leave the figure
            let mut span = bars
                .iter()
                .map(|b| b.1.abs().max(b.2.abs()))
                .fold(0.0, f64::max)
                .max(1e-9)
                * 1.6;
            for b in &bars {
                for (x, l) in [(b.1, &b.3), (b.2, &b.4)] {
                    if x != 0.0 {
                        let room = 0.98 - (width(&label(l, x)) + 6.0 * sc) / half;
                        span = span.max(x.abs() / room.max(0.05));
                    }
                }
            }
            let n = bars.len().max(1);
            let mut chart = ChartBuilder::on(area)
                .caption(
                    format!(
                        "{}: ω_n = {:.4} rad/s ({:.4} Hz)",
                        m.name,
                        m.omega_n_rad_s,
                        m.omega_n_rad_s / (2.0 * std::f64::consts::PI)
                    ),
                    style::font(f.label),
                )
                .margin(margin_px as u32)
                .x_label_area_size((f.tick * 1.6 + f.label * 1.7) as u32)
                .y_label_area_size(y_area_px as u32)
                .build_cartesian_2d(-span..span, 0.0..n as f64)
                .map_err(|e| e.to_string())?;
            let names: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
            chart
                .configure_mesh()
                .disable_y_mesh()
                .x_desc("change of ω_n [%]")
                // plotters writes a tick at a rounding error from 0 as "-0.0": 0 is "0"
                .x_label_formatter(&|x| {
                    if x.abs() <= 1e-9 * span {
                        "0".to_string()
                    } else {
                        <plotters::coord::types::RangedCoordf64 as plotters::coord::ranged1d::ValueFormatter<f64>>::format(x)
                    }
                })
                .y_labels(n * 2 + 1)
                .y_label_formatter(&|y| {
                    let k = (n as f64 - y - 0.5).round();
                    if (y.fract() - 0.5).abs() < 1e-6 && k >= 0.0 && (k as usize) < names.len() {
                        names[k as usize].clone()
                    } else {
                        String::new()
                    }
                })
                .label_style(style::font(f.tick))
                .axis_desc_style(style::font(f.label))
                .draw()
                .map_err(|e| e.to_string())?;
            let down = style::PALETTE[0];
            let up = style::PALETTE[1];
            for (k, b) in bars.iter().enumerate() {
                let y = (n - 1 - k) as f64;
                chart
                    .draw_series([
                        Rectangle::new([(b.1, y + 0.2), (0.0, y + 0.8)], down.filled()),
                        Rectangle::new([(0.0, y + 0.2), (b.2, y + 0.8)], up.filled()),
                    ])
                    .map_err(|e| e.to_string())?;
                for (x, anchor, l) in [(b.1, -1.0, &b.3), (b.2, 1.0, &b.4)] {
                    if x != 0.0 {
                        // beside the bar's end: ending there (left), starting there (right)
                        let h = if anchor < 0.0 {
                            plotters::style::text_anchor::HPos::Right
                        } else {
                            plotters::style::text_anchor::HPos::Left
                        };
                        chart
                            .draw_series(std::iter::once(Text::new(
                                label(l, x),
                                (x + anchor * span * 0.02, y + 0.62),
                                TextStyle::from(style::font(f.note)).pos(
                                    plotters::style::text_anchor::Pos::new(
                                        h,
                                        plotters::style::text_anchor::VPos::Top,
                                    ),
                                ),
                            )))
                            .map_err(|e| e.to_string())?;
                    }
                }
            }
            chart
                .draw_series(LineSeries::new(
                    vec![(0.0, 0.0), (0.0, n as f64)],
                    BLACK.stroke_width(1),
                ))
                .map_err(|e| e.to_string())?;
        }
        Ok(())
    }
}

/// Write the tornado chart (SVG or PNG by the extension; atomically) at a size (px;
/// None: [`tornado_size`]).
pub fn write_tornado(
    path: &str,
    s: &Sensitivity,
    title: &str,
    size: Option<(u32, u32)>,
) -> Result<()> {
    write_figure(
        path,
        &Tornado {
            s,
            title,
            size: size.unwrap_or_else(|| tornado_size(s)),
        },
    )
}
