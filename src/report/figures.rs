//! The report's own figures, drawn with plotters into SVG strings (pure functions of
//! their inputs): the linear frequency response on log–log axes with the forcing bands
//! shaded and the resonances marked, and the interference (Campbell) diagram.
//!
//! They are drawn here rather than through `output::plot::LinePlot`, which has linear
//! axes only and no shaded bands.

use plotters::prelude::*;

const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(23, 190, 207),
];
const BAND: RGBColor = RGBColor(255, 170, 60);
const MARK: RGBColor = RGBColor(200, 90, 0);

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
    /// Resonances: label and ω (rad/s), drawn as dashed vertical lines.
    pub resonances: Vec<(String, f64)>,
    /// Refined peaks (ω rad/s, amplitude), marked on the curves.
    pub peaks: Vec<(f64, f64)>,
    pub bands: Vec<Band>,
}

/// `12.500` → `12.5`, `10.000` → `10`.
fn trim_zeros(s: String) -> String {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// The frequency response on log–log axes, bands shaded (those that reach into the
/// plotted range), resonances and peaks marked.
pub fn frf_svg(p: &FrfPlot) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
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
        y1 *= 2.0;
        let mut chart = ChartBuilder::on(&root)
            .caption(&p.title, ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(75)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("ω [rad/s]")
            .y_desc(format!("amplitude [{}]", p.unit))
            .x_label_formatter(&|x| trim_zeros(format!("{x:.3}")))
            .y_label_formatter(&|y| format!("{y:.1e}"))
            .draw()
            .map_err(err)?;
        for b in &p.bands {
            if b.hi < x0 || b.lo > x1 {
                continue;
            }
            let (lo, hi) = (b.lo.max(x0), b.hi.min(x1));
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(lo, y0), (hi, y1)],
                    BAND.mix(0.35).filled(),
                )))
                .map_err(err)?;
            if b.nominal >= x0 && b.nominal <= x1 {
                chart
                    .draw_series(LineSeries::new(
                        vec![(b.nominal, y0), (b.nominal, y1)],
                        MARK.stroke_width(1),
                    ))
                    .map_err(err)?;
                chart
                    .draw_series(std::iter::once(Text::new(
                        b.label.clone(),
                        (b.nominal * 1.01, y1 / 1.6),
                        ("sans-serif", 15).into_font().color(&MARK),
                    )))
                    .map_err(err)?;
            }
        }
        for (label, w) in &p.resonances {
            if *w < x0 || *w > x1 {
                continue;
            }
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(*w, y0), (*w, y1)],
                    4,
                    4,
                    BLACK.stroke_width(1),
                ))
                .map_err(err)?;
            chart
                .draw_series(std::iter::once(Text::new(
                    label.clone(),
                    (*w * 1.01, y0 * 1.3),
                    ("sans-serif", 14),
                )))
                .map_err(err)?;
        }
        for (i, (name, y)) in p.curves.iter().enumerate() {
            let color = COLORS[i % COLORS.len()];
            let pts: Vec<(f64, f64)> = p
                .omega
                .iter()
                .copied()
                .zip(y.iter().map(|v| v.max(y0)))
                .collect();
            chart
                .draw_series(LineSeries::new(pts, color.stroke_width(2)))
                .map_err(err)?
                .label(name.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
        }
        if !p.peaks.is_empty() {
            chart
                .draw_series(
                    p.peaks
                        .iter()
                        .map(|&(w, a)| TriangleMarker::new((w, a.max(y0)), 6, BLACK.filled())),
                )
                .map_err(err)?
                .label("peaks")
                .legend(|(x, y)| TriangleMarker::new((x + 10, y), 5, BLACK.filled()));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
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
}

/// Mode frequencies against rotor speed (horizontal lines: the mechanism's modes do not
/// depend on the rotor speed), the n/rev lines through the origin, the operating range
/// shaded when known and the nominal speed drawn, crossings marked (filled inside the
/// operating range).
pub fn campbell_svg(p: &CampbellPlot) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (xe, ye) = (p.rpm_end, p.omega_end);
        let mut chart = ChartBuilder::on(&root)
            .caption(&p.title, ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..xe, 0.0..ye)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(format!("{} rotor speed [rpm]", p.rotor))
            .y_desc("frequency [rad/s]")
            .draw()
            .map_err(err)?;
        if let Some([lo, hi]) = p.rpm_range {
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(lo, 0.0), (hi, ye)],
                    BAND.mix(0.35).filled(),
                )))
                .map_err(err)?
                .label("operating range")
                .legend(|(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 20, y + 5)], BAND.mix(0.35).filled())
                });
        }
        chart
            .draw_series(LineSeries::new(
                vec![(p.rpm_nominal, 0.0), (p.rpm_nominal, ye)],
                MARK.stroke_width(2),
            ))
            .map_err(err)?
            .label(format!("nominal {:.0} rpm", p.rpm_nominal))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], MARK.stroke_width(2)));
        for (label, w) in &p
            .lines
            .iter()
            .map(|l| (&l.label, l.slope))
            .collect::<Vec<_>>()
        {
            // from the origin to where the line leaves the box
            let x_end = xe.min(ye / w);
            chart
                .draw_series(LineSeries::new(
                    vec![(0.0, 0.0), (x_end, w * x_end)],
                    MARK.stroke_width(1),
                ))
                .map_err(err)?;
            // the label just inside the box where the line leaves it
            let (tx, ty) = if x_end < xe {
                (x_end + 0.004 * xe, ye * 0.985)
            } else {
                (xe * 0.96, w * xe * 0.97)
            };
            chart
                .draw_series(std::iter::once(Text::new(
                    (*label).clone(),
                    (tx, ty),
                    ("sans-serif", 14).into_font().color(&MARK),
                )))
                .map_err(err)?;
        }
        for (i, (label, w)) in p.modes.iter().enumerate() {
            let color = COLORS[i % COLORS.len()];
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(0.0, *w), (xe, *w)],
                    8,
                    4,
                    color.stroke_width(2),
                ))
                .map_err(err)?
                .label(format!("{label}: ω_n = {w:.2} rad/s"))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
        }
        chart
            .draw_series(p.crossings.iter().map(|&(x, y, inside)| {
                let style = if inside {
                    RED.filled()
                } else {
                    RED.stroke_width(2)
                };
                Circle::new((x, y), 6, style)
            }))
            .map_err(err)?;
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}
