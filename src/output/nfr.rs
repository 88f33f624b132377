//! Outputs of the nonlinear frequency response (`detune nfr`): the CSV rows (which the
//! JSON's `points` share), the JSON document, and the figure.

use super::Provenance;
use super::figures::{Case, short, with_unit};
use super::plot::{LinePlot, Note, Series, Style};
use super::results::{Cell, MEASURES, measure_values, write_rows};
use super::units::FreqUnit;
use crate::diag::Result;
use crate::periodic::continuation::{BranchSummary, Located, Nfr, NfrPeak, Special};
use nalgebra::Complex;
use serde::Serialize;
use serde_json::{Map, Value};

/// Header: `<param>`, `omega` (when another parameter is continued), `branch`, then per
/// response `<response>_<measure>` as in `sweep`, then `stable`, `floquet_max` (the
/// largest multiplier's modulus), `mu<k>_re`, `mu<k>_im` (k = 1..2·DoF, largest modulus
/// first) and `located` (fold, period_doubling, neimark_sacker, peak; empty for a step).
pub fn nfr_header(c: &Nfr) -> Vec<String> {
    let mut h = vec![c.param.clone()];
    if c.param != c.omega_param {
        h.push(c.omega_param.clone());
    }
    h.push("branch".into());
    for r in &c.responses {
        for m in MEASURES {
            h.push(format!("{r}_{m}"));
        }
    }
    h.push("stable".into());
    h.push("floquet_max".into());
    for k in 1..=2 * c.dof {
        h.push(format!("mu{k}_re"));
        h.push(format!("mu{k}_im"));
    }
    h.push("located".into());
    h
}

/// One row per point (see [`nfr_header`]).
pub fn nfr_rows(c: &Nfr) -> Vec<Vec<Cell<'_>>> {
    c.points
        .iter()
        .map(|p| {
            let mut row = vec![Cell::Number(p.value)];
            if c.param != c.omega_param {
                row.push(Cell::Number(p.omega));
            }
            row.push(Cell::Count(p.branch));
            for m in &p.measures {
                row.extend(measure_values(m).map(Cell::Number));
            }
            row.push(Cell::Flag(p.stable));
            row.push(Cell::Number(
                p.multipliers.first().map_or(f64::NAN, |m| m.norm()),
            ));
            for k in 0..2 * c.dof {
                let m = p
                    .multipliers
                    .get(k)
                    .copied()
                    .unwrap_or(Complex::new(f64::NAN, f64::NAN));
                row.push(Cell::Number(m.re));
                row.push(Cell::Number(m.im));
            }
            row.push(Cell::Text(p.located.map_or("", Located::name)));
            row
        })
        .collect()
}

/// The CSV (an interrupted curve ends with a comment line `# incomplete: ...`).
pub fn write_nfr_csv(path: &str, c: &Nfr) -> Result<()> {
    let footer: &[&str] = if c.complete {
        &[]
    } else {
        &["# incomplete: the continuation stopped early; the rows above are the points computed"]
    };
    write_rows(path, &nfr_header(c), &nfr_rows(c), footer)
}

/// A multiplier in the JSON.
#[derive(Serialize)]
pub struct MultiplierJson {
    pub re: f64,
    pub im: f64,
    pub modulus: f64,
}

fn multipliers_json(mu: &[Complex<f64>]) -> Vec<MultiplierJson> {
    mu.iter()
        .map(|m| MultiplierJson {
            re: m.re,
            im: m.im,
            modulus: m.norm(),
        })
        .collect()
}

/// A located fold or bifurcation in the JSON.
#[derive(Serialize)]
pub struct SpecialJson {
    /// The continued parameter.
    pub value: f64,
    /// The forcing frequency, rad/s.
    pub omega: f64,
    /// Per response: half peak-to-peak.
    pub amplitude: Map<String, Value>,
    pub multipliers: Vec<MultiplierJson>,
    /// What a stepped-sine sweep does there, in words.
    pub jump: String,
    /// How well `value` is known (the continued parameter's unit).
    pub uncertainty: f64,
    /// False when locating failed: the point is the end of the continuation step that
    /// brackets it, and `uncertainty` half that step.
    pub refined: bool,
}

/// `detune nfr --json`.
#[derive(Serialize)]
pub struct NfrReport<'a> {
    pub param: &'a str,
    pub complete: bool,
    pub points: Vec<Map<String, Value>>,
    pub folds: Vec<SpecialJson>,
    pub period_doublings: Vec<SpecialJson>,
    pub neimark_sacker: Vec<SpecialJson>,
    pub peaks: &'a [NfrPeak],
    /// The responses whose peaks were not sought, and why (as `sweep --json`'s).
    pub no_peaks: &'a [crate::periodic::continuation::NfrNoPeaks],
    pub branches: &'a [BranchSummary],
    /// Degrees of freedom (2·DoF multipliers per point).
    pub dof: usize,
    /// Forcing periods integrated, and right-hand-side evaluations (each state or
    /// perturbed state evaluated counts 1).
    pub periods: usize,
    pub rhs_evaluations: usize,
    /// Sign changes of the stability tests on orbits too unstable (largest multiplier
    /// above 1e3) for the smaller multipliers to be resolved: not reported as folds or
    /// bifurcations.
    pub unresolved_events: usize,
    pub provenance: &'a Provenance,
}

impl<'a> NfrReport<'a> {
    pub fn new(c: &'a Nfr, provenance: &'a Provenance) -> Self {
        let header = nfr_header(c);
        let special = |s: &Special| SpecialJson {
            value: s.value,
            omega: s.omega,
            amplitude: c
                .responses
                .iter()
                .cloned()
                .zip(s.amplitude.iter().map(|a| Value::from(*a)))
                .collect(),
            multipliers: multipliers_json(&s.multipliers),
            jump: jump_words(c, s),
            uncertainty: s.uncertainty,
            refined: s.refined,
        };
        NfrReport {
            param: &c.param,
            complete: c.complete,
            points: nfr_rows(c)
                .iter()
                .map(|row| {
                    let mut m = super::json::row_object(&header, row);
                    // `located` is null for a step, not ""
                    if m.get("located").and_then(Value::as_str) == Some("") {
                        m.insert("located".into(), Value::Null);
                    }
                    m
                })
                .collect(),
            folds: c.folds.iter().map(special).collect(),
            period_doublings: c.period_doublings.iter().map(special).collect(),
            neimark_sacker: c.neimark_sacker.iter().map(special).collect(),
            peaks: &c.peaks,
            no_peaks: &c.no_peaks,
            branches: &c.branches,
            dof: c.dof,
            periods: c.periods,
            rhs_evaluations: c.rhs_evaluations,
            unresolved_events: c.unresolved_events,
            provenance,
        }
    }
}

/// What a stepped-sine sweep does at a located fold or bifurcation: a fold ends the
/// stable branch it is reached on (a jump), a period doubling makes the stable orbit
/// unstable to a period-2 one (a jump or a period-2 response), a Neimark–Sacker point to a
/// quasi-periodic one. The sweep that meets it comes along the stable side.
pub fn jump_words(c: &Nfr, s: &Special) -> String {
    // the direction of the continued parameter on the stable side, toward the point
    // a fold is an extremum of the parameter along the branch: both of its sides reach
    // it moving the same way; a bifurcation is crossed, its stable side behind it
    let toward = if s.kind == Located::Fold || s.stable_before {
        s.direction_before
    } else {
        -s.direction_before
    };
    let sweep = if toward > 0.0 { "up" } else { "down" };
    let p = &c.param;
    match s.kind {
        Located::Fold => {
            format!("fold (saddle-node): the stable branch ends; a sweep {sweep} in {p} jumps here")
        }
        Located::PeriodDoubling => format!(
            "period doubling: the orbit loses stability to a period-2 orbit; a sweep {sweep} in {p} jumps here (or turns period-2)"
        ),
        Located::NeimarkSacker => format!(
            "Neimark-Sacker: the orbit loses stability to a quasi-periodic motion; a sweep {sweep} in {p} leaves it here"
        ),
        Located::Peak => "peak".into(),
    }
}

/// A backbone curve drawn under the forced one: its label, and per orbit ω (rad/s) and
/// each response's amplitude (in the curve's response order).
#[derive(Debug, Clone)]
pub struct BackboneLine {
    pub label: String,
    pub omega: Vec<f64>,
    pub amplitudes: Vec<Vec<f64>>,
}

/// One panel per response: its amplitude against the continued parameter, each branch
/// stable solid and unstable dashed, folds, period doublings, Neimark–Sacker points and
/// peaks marked and labelled, the backbones (`nfr --backbone`) dotted under them.
pub fn nfr_figures(
    case: &Case,
    c: &Nfr,
    param_unit: &str,
    backbones: &[BackboneLine],
) -> Vec<LinePlot> {
    let plots = nfr_figures_in(case, c, param_unit, backbones, FreqUnit::RadPerSecond);
    let again = std::sync::Arc::new((
        case.clone(),
        c.clone(),
        param_unit.to_string(),
        backbones.to_vec(),
    ));
    super::figures::with_relabel(plots, move |unit| {
        let (case, c, param_unit, backbones) = &*again;
        nfr_figures_in(case, c, param_unit, backbones, unit)
    })
}

/// [`nfr_figures`] of a curve over the forcing frequency (rad/s) drawn in `unit`
/// (`--freq-unit`): the axis, the labels (made in the unit) and the data.
pub fn nfr_figures_in(
    case: &Case,
    c: &Nfr,
    param_unit: &str,
    backbones: &[BackboneLine],
    unit_f: FreqUnit,
) -> Vec<LinePlot> {
    let at = |v: f64| match unit_f {
        FreqUnit::RadPerSecond => format!("{} {param_unit}", short(v)).trim_end().to_string(),
        u => super::figures::freq(v, u),
    };
    (0..c.responses.len())
        .map(|r| {
            let unit = c.units.get(r).copied().unwrap_or("");
            let mut series = Vec::new();
            // segments of one stability on one branch (each joined to the next)
            let mut seg: Vec<(f64, f64)> = Vec::new();
            let mut seg_stable = true;
            let mut seg_branch = usize::MAX;
            let mut flush = |seg: &mut Vec<(f64, f64)>, stable: bool| {
                if seg.len() > 1 {
                    series.push(
                        Series::new(
                            if stable { "stable" } else { "unstable" },
                            seg.iter().map(|p| p.0).collect(),
                            seg.iter().map(|p| p.1).collect(),
                            if stable { Style::Solid } else { Style::Dashed },
                        )
                        .color(0),
                    );
                }
                seg.clear();
            };
            for p in &c.points {
                let xy = (p.value, p.measures[r].amplitude);
                if p.branch != seg_branch {
                    flush(&mut seg, seg_stable);
                    seg_branch = p.branch;
                    seg_stable = p.stable;
                } else if p.stable != seg_stable {
                    // located points sit on the boundary: both segments share them
                    seg.push(xy);
                    flush(&mut seg, seg_stable);
                    seg_stable = p.stable;
                }
                seg.push(xy);
            }
            flush(&mut seg, seg_stable);
            for (k, b) in backbones.iter().enumerate() {
                series.push(
                    Series::new(
                        b.label.clone(),
                        b.omega.clone(),
                        b.amplitudes.iter().map(|a| a[r]).collect(),
                        Style::Dotted,
                    )
                    .color(5 + k),
                );
            }
            let mut notes = Vec::new();
            let groups: [(&str, &[Special]); 3] = [
                ("folds", &c.folds),
                ("period doublings", &c.period_doublings),
                ("Neimark-Sacker points", &c.neimark_sacker),
            ];
            for (label, marked) in groups {
                if marked.is_empty() {
                    continue;
                }
                series.push(
                    Series::new(
                        label,
                        marked.iter().map(|s| s.value).collect(),
                        marked.iter().map(|s| s.amplitude[r]).collect(),
                        Style::Markers,
                    )
                    .color(1 + groups.iter().position(|g| g.0 == label).unwrap_or(0)),
                );
                for s in marked {
                    let word = match s.kind {
                        Located::Fold => "fold",
                        Located::PeriodDoubling => "period doubling",
                        Located::NeimarkSacker => "Neimark-Sacker",
                        Located::Peak => "peak",
                    };
                    notes.push(Note {
                        x: s.value,
                        y: s.amplitude[r],
                        text: format!("{word} {}", at(s.value)),
                    });
                }
            }
            let peaks: Vec<&NfrPeak> = c
                .peaks
                .iter()
                .filter(|p| p.response == c.responses[r])
                .collect();
            if !peaks.is_empty() {
                series.push(
                    Series::new(
                        "peaks",
                        peaks.iter().map(|p| p.value).collect(),
                        peaks.iter().map(|p| p.amplitude).collect(),
                        Style::Markers,
                    )
                    .color(4),
                );
                for p in peaks {
                    notes.push(Note {
                        x: p.value,
                        y: p.amplitude,
                        text: format!("peak {}", at(p.value)),
                    });
                }
            }
            LinePlot {
                title: format!("{} amplitude against {}", c.responses[r], c.param),
                caption: case.caption(&[]),
                x_label: with_unit(&c.param, param_unit),
                y_label: with_unit(&format!("{} amplitude", c.responses[r]), unit),
                series,
                notes,
                ..LinePlot::default()
            }
            .rescaled(unit_f)
        })
        .collect()
}
