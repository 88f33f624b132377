//! A sensitivity study's files: the CSV table, the JSON document and the tornado chart.

use super::{Provenance, num, write_atomic};
use crate::diag::Result;
use crate::linear::sensitivity::Sensitivity;
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
                "{},baseline,baseline,,{},{},{},0,{},",
                m.name,
                num(m.omega_n_rad_s),
                num(m.damping_ratio),
                opt(m.undamped_omega_rad_s),
                if m.undamped_omega_rad_s.is_some() {
                    "0"
                } else {
                    ""
                }
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
    let mut svg = String::new();
    let rows: usize = s.modes.len().max(1);
    {
        let root =
            SVGBackend::with_string(&mut svg, (900, 130 + 260 * rows as u32)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let (top, body) = root.split_vertically(56);
        top.draw(&Text::new(
            title.to_string(),
            (20, 8),
            ("sans-serif", 22).into_font(),
        ))
        .map_err(|e| e.to_string())?;
        top.draw(&Text::new(
            "each bar: the parameter's cases (labelled); blue lowers ω_n, orange raises it",
            (20, 32),
            ("sans-serif", 15).into_font(),
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
            let span = bars
                .iter()
                .map(|b| b.1.abs().max(b.2.abs()))
                .fold(0.0, f64::max)
                .max(1e-9)
                * 1.6;
            let n = bars.len().max(1);
            let mut chart = ChartBuilder::on(area)
                .caption(
                    format!(
                        "{}: ω_n = {:.4} rad/s ({:.4} Hz)",
                        m.name,
                        m.omega_n_rad_s,
                        m.omega_n_rad_s / (2.0 * std::f64::consts::PI)
                    ),
                    ("sans-serif", 20),
                )
                .margin(12)
                .x_label_area_size(45)
                .y_label_area_size(150)
                .build_cartesian_2d(-span..span, 0.0..n as f64)
                .map_err(|e| e.to_string())?;
            let names: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
            chart
                .configure_mesh()
                .disable_y_mesh()
                .x_desc("change of ω_n [%]")
                .y_labels(n * 2 + 1)
                .y_label_formatter(&|y| {
                    let k = (n as f64 - y - 0.5).round();
                    if (y.fract() - 0.5).abs() < 1e-6 && k >= 0.0 && (k as usize) < names.len() {
                        names[k as usize].clone()
                    } else {
                        String::new()
                    }
                })
                .label_style(("sans-serif", 16))
                .axis_desc_style(("sans-serif", 16))
                .draw()
                .map_err(|e| e.to_string())?;
            let down = RGBColor(0, 114, 178);
            let up = RGBColor(213, 94, 0);
            for (k, b) in bars.iter().enumerate() {
                let y = (n - 1 - k) as f64;
                chart
                    .draw_series([
                        Rectangle::new([(b.1, y + 0.2), (0.0, y + 0.8)], down.filled()),
                        Rectangle::new([(0.0, y + 0.2), (b.2, y + 0.8)], up.filled()),
                    ])
                    .map_err(|e| e.to_string())?;
                for (x, anchor, label) in [(b.1, -1.0, &b.3), (b.2, 1.0, &b.4)] {
                    if x != 0.0 {
                        chart
                            .draw_series(std::iter::once(Text::new(
                                format!("{label}: {x:+.2} %"),
                                (
                                    x + anchor * span * 0.02
                                        - if anchor < 0.0 { span * 0.30 } else { 0.0 },
                                    y + 0.62,
                                ),
                                ("sans-serif", 15).into_font(),
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
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

/// Write the tornado chart (atomically).
pub fn write_tornado(path: &str, s: &Sensitivity, title: &str) -> Result<()> {
    let svg = tornado_svg(s, title).map_err(|e| crate::diag::Error::io(path, e))?;
    write_atomic(path, |w| w.write_all(svg.as_bytes()))
}
