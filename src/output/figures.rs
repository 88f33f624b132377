//! The figures of the analyses, built from their results (drawn by [`super::plot`]):
//! a simulation's coordinates against time, an equilibrium branch against its parameter,
//! a sweep's amplitudes against frequency with the linear natural frequencies marked, the
//! linear frequency response (amplitude and phase), a mode tracking.
//!
//! Every figure says which case it shows (a caption: model, file, `--set` overrides, the
//! well), carries units on its axes and legend entries, and draws with the fixed meanings
//! of [`super::style`]: stable solid, unstable dashed, a sweep down dotted, linear
//! references thin dash-dot, forcing lines orange, events (peaks, folds, branch points,
//! jumps) black-edged markers with their values written beside them.

use super::plot::{LinePlot, Note, Relabel, Scale, Series, Style};
use super::units::FreqUnit;
use crate::dynamics::simulate::Trajectory;
use crate::frequency::Direction;
use crate::frequency::study::{NaturalFrequency, SweepRun};
use crate::statics::continuation::{Branch, BranchPoint};

/// SI unit of a coordinate: rad for an angle, else m.
pub fn unit(angle: bool) -> &'static str {
    if angle { "rad" } else { "m" }
}

/// `name [unit]`, or `name [-]` for a dimensionless quantity.
pub(crate) fn with_unit(name: &str, unit: &str) -> String {
    format!("{name} [{}]", if unit.is_empty() { "-" } else { unit })
}

/// The case a figure shows: model name and file, `--set` overrides.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Case {
    pub model: String,
    pub file: String,
    /// `NAME=VALUE` as given.
    pub overrides: Vec<String>,
    /// What else the caption says about the case (`per unit of D0`).
    pub notes: Vec<String>,
}

impl Case {
    pub fn of(model: &crate::model::Model) -> Case {
        Case {
            model: model.name.clone(),
            file: model.source.path.clone(),
            overrides: model
                .overrides
                .iter()
                .map(|(n, v)| format!("{n}={v}"))
                .collect(),
            notes: Vec::new(),
        }
    }
    /// A case of a model name only (tests, library callers).
    pub fn named(name: &str) -> Case {
        Case {
            model: name.to_string(),
            ..Case::default()
        }
    }
    /// `model overcentre (models/overcentre.toml), --set F0=10` and `extra` parts.
    pub fn caption(&self, extra: &[String]) -> String {
        let mut parts = vec![if self.file.is_empty() {
            format!("model {}", self.model)
        } else {
            let file = std::path::Path::new(&self.file)
                .file_name()
                .and_then(|f| f.to_str())
                .unwrap_or(&self.file);
            format!("model {} ({file})", self.model)
        }];
        if !self.overrides.is_empty() {
            parts.push(format!("--set {}", self.overrides.join(" ")));
        }
        parts.extend(self.notes.iter().cloned());
        parts.extend(extra.iter().filter(|e| !e.is_empty()).cloned());
        parts.join(", ")
    }
}

/// The coordinates `pick` (default: the angles, or all if the model has none) against
/// time: one panel for the angles [rad], one for the lengths [m].
pub fn trajectory_figures(case: &Case, traj: &Trajectory, pick: &[usize]) -> Vec<LinePlot> {
    let n = traj.coordinates.len();
    let pick: Vec<usize> = if !pick.is_empty() {
        pick.to_vec()
    } else if (0..n).any(|i| traj.angles[i]) {
        (0..n).filter(|&i| traj.angles[i]).collect()
    } else {
        (0..n).collect()
    };
    let mut plots = Vec::new();
    for angle in [true, false] {
        let mine: Vec<usize> = pick
            .iter()
            .copied()
            .filter(|&i| traj.angles[i] == angle)
            .collect();
        if mine.is_empty() {
            continue;
        }
        let u = unit(angle);
        let mut p = LinePlot::new(
            format!(
                "simulation: {} against time",
                if angle { "angles" } else { "lengths" }
            ),
            "t [s]",
            if angle { "angle [rad]" } else { "length [m]" },
        );
        if plots.is_empty() {
            p.caption = case.caption(&[]);
        }
        p.series = mine
            .iter()
            .map(|&i| {
                Series::new(
                    format!("{} [{u}]", traj.coordinates[i]),
                    traj.t.clone(),
                    traj.qs().map(|q| q[i]).collect(),
                    Style::Solid,
                )
            })
            .collect();
        plots.push(p);
    }
    plots
}

/// The simulation's first panel ([`trajectory_figures`] with the default coordinates).
pub fn trajectory_figure(name: &str, traj: &Trajectory) -> LinePlot {
    trajectory_figures(&Case::named(name), traj, &[])
        .into_iter()
        .next()
        .unwrap_or_default()
}

/// The paper's Figure 6: the branch in (parameter, coordinate `idx`), stable solid,
/// unstable dashed, folds and branch points marked and labelled, with the branches
/// switched to at the branch points; `angle` whether the coordinate is an angle,
/// `param_unit` the parameter's unit.
pub fn branch_figure(
    case: &Case,
    b: &Branch,
    idx: usize,
    angle: bool,
    param_unit: &str,
) -> LinePlot {
    let plot = branch_figure_in(case, b, idx, angle, param_unit, FreqUnit::RadPerSecond);
    let again = std::sync::Arc::new((case.clone(), b.clone(), param_unit.to_string()));
    with_relabel(vec![plot], move |unit| {
        let (case, b, param_unit) = &*again;
        vec![branch_figure_in(case, b, idx, angle, param_unit, unit)]
    })
    .pop()
    .unwrap_or_default()
}

/// [`branch_figure`] of a frequency parameter (rad/s) drawn in `unit` (`--freq-unit`):
/// the axis, the fold and branch point labels (made in the unit) and the data.
pub fn branch_figure_in(
    case: &Case,
    b: &Branch,
    idx: usize,
    angle: bool,
    param_unit: &str,
    unit_f: FreqUnit,
) -> LinePlot {
    let mut series = Vec::new();
    let mut seg: Vec<&BranchPoint> = Vec::new();
    let flush = |seg: &mut Vec<&BranchPoint>, series: &mut Vec<Series>| {
        if seg.len() > 1 {
            let stable = seg[1].stable;
            series.push(
                Series::new(
                    if stable { "stable" } else { "unstable" },
                    seg.iter().map(|p| p.value).collect(),
                    seg.iter().map(|p| p.q[idx]).collect(),
                    if stable { Style::Solid } else { Style::Dashed },
                )
                .color(0),
            );
        }
        seg.clear();
    };
    // every branch (the switched ones start at their branch point, so they join it)
    for (from, points, ..) in b.all() {
        if let Some(k) = from {
            seg.push(&b.branch_points[k]);
        }
        for p in points {
            if let Some(last) = seg.last()
                && last.stable != p.stable
                && seg.len() > 1
            {
                seg.push(p);
                flush(&mut seg, &mut series);
            }
            seg.push(p);
        }
        flush(&mut seg, &mut series);
    }
    let u = unit(angle);
    let pu = if param_unit.is_empty() {
        ""
    } else {
        param_unit
    };
    let mut notes = Vec::new();
    for (label, marked) in [("folds", &b.folds), ("branch points", &b.branch_points)] {
        if !marked.is_empty() {
            series.push(Series::new(
                label,
                marked.iter().map(|p| p.value).collect(),
                marked.iter().map(|p| p.q[idx]).collect(),
                Style::Markers,
            ));
            for p in marked.iter() {
                notes.push(Note {
                    x: p.value,
                    y: p.q[idx],
                    text: format!(
                        "{} {} = {}",
                        if label == "folds" {
                            "fold"
                        } else {
                            "branch point"
                        },
                        unit_f.quantity(&b.param),
                        match unit_f {
                            FreqUnit::RadPerSecond => format!("{} {pu}", short(p.value)),
                            u => freq(p.value, u),
                        }
                    )
                    .trim_end()
                    .to_string(),
                });
            }
        }
    }
    LinePlot {
        title: format!("equilibria against {}", b.param),
        caption: case.caption(&[]),
        x_label: with_unit(&b.param, param_unit),
        y_label: format!("{} [{u}]", b.coordinates[idx]),
        series,
        notes,
        ..LinePlot::default()
    }
    .rescaled(unit_f)
}

/// A number in at most 4 significant decimals, trailing zeros trimmed.
pub(crate) fn short(x: f64) -> String {
    let s = if x != 0.0 && (x.abs() < 1e-3 || x.abs() >= 1e5) {
        format!("{x:.3e}")
    } else {
        let d = (3 - x.abs().log10().floor() as i32).clamp(0, 6) as usize;
        let s = format!("{x:.d$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    if s == "-0" { "0".into() } else { s }
}

/// A well in a legend: `well 1 (bar1.theta = -0.866 rad)`, the pose given by the first
/// response when it is a coordinate, else by the coordinate that differs most between the
/// run's equilibria; `across wells` for −1.
pub fn well_name(run: &SweepRun, k: isize) -> String {
    let w = &run.sweep.wells;
    let Ok(k) = usize::try_from(k) else {
        return "across wells".to_string();
    };
    let spread = |i: usize| {
        let (lo, hi) = w
            .equilibria
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), e| {
                (l.min(e.q[i]), h.max(e.q[i]))
            });
        hi - lo
    };
    let n = run.sweep.coordinates.len();
    let i = run
        .sweep
        .coordinates
        .iter()
        .position(|c| *c == run.sweep.responses[0])
        .or_else(|| (0..n).max_by(|a, b| spread(*a).total_cmp(&spread(*b))))
        .unwrap_or(0);
    let unit = if run.angles.get(i).copied().unwrap_or(false) {
        "rad"
    } else {
        "m"
    };
    format!(
        "well {k} ({} = {:.3} {unit})",
        run.sweep.coordinates[i], w.equilibria[k].q[i]
    )
}

/// Amplitude against frequency, one panel per response (at most six), one curve per run
/// (`--values` entry), direction (up and from rest solid, down dotted) and well, the
/// natural frequencies as reference lines, refined peaks and jumps marked and labelled;
/// when the family parameter is the forcing amplitude (`forcing`: the model's
/// `[model] forcing_amplitude`), a panel per response with the amplitude divided by it
/// (the paper's Figures 8–9). An interrupted sweep says so in its titles.
pub fn sweep_figures(
    case: &Case,
    runs: &[SweepRun],
    natural: &[NaturalFrequency],
    marks: &[(String, f64)],
    forcing: Option<&str>,
) -> Vec<LinePlot> {
    let plots = sweep_figures_in(case, runs, natural, marks, forcing, FreqUnit::RadPerSecond);
    let again = std::sync::Arc::new((
        case.clone(),
        runs.to_vec(),
        natural.to_vec(),
        marks.to_vec(),
        forcing.map(str::to_string),
    ));
    with_relabel(plots, move |unit| {
        let (case, runs, natural, marks, forcing) = &*again;
        sweep_figures_in(case, runs, natural, marks, forcing.as_deref(), unit)
    })
}

/// Each plot of `plots` made again in another frequency unit by `make` (the same
/// builder, the same panels in the same order).
pub(crate) fn with_relabel(
    plots: Vec<LinePlot>,
    make: impl Fn(FreqUnit) -> Vec<LinePlot> + Send + Sync + 'static,
) -> Vec<LinePlot> {
    let make = std::sync::Arc::new(make);
    plots
        .into_iter()
        .enumerate()
        .map(|(k, mut p)| {
            let make = make.clone();
            p.relabel = Some(Relabel(std::sync::Arc::new(move |unit| {
                make(unit).into_iter().nth(k).unwrap_or_default()
            })));
            p
        })
        .collect()
}

/// A frequency (rad/s) as a figure's label writes it in `unit`: in rad/s `short`
/// (`4.1 rad/s`), in Hz and rpm to four significant digits (`0.6525 Hz`).
pub(crate) fn freq(w: f64, unit: FreqUnit) -> String {
    format!("{} {}", short(unit.of(w)), unit.symbol())
}

/// A natural frequency or a forcing line (rad/s) as a legend writes it in `unit`: with
/// four decimals in every unit (`2.9732 rad/s`, `0.4732 Hz`, `28.3935 rpm`), as precise
/// as a reference line is read.
fn line_freq(w: f64, unit: FreqUnit) -> String {
    format!("{:.4} {}", unit.of(w), unit.symbol())
}

/// [`sweep_figures`] with every frequency in `unit` (`--freq-unit`): the axis, the labels
/// (made in the unit, with significant digits) and the data drawn; CSV and JSON stay in
/// rad/s.
pub fn sweep_figures_in(
    case: &Case,
    runs: &[SweepRun],
    natural: &[NaturalFrequency],
    marks: &[(String, f64)],
    forcing: Option<&str>,
    unit_f: FreqUnit,
) -> Vec<LinePlot> {
    let first = &runs[0].sweep;
    let rate = unit_f.rate();
    // the wells the responses visit: when that is not the starting well alone, each
    // curve is split by well and named by it, and the linear natural frequencies of the
    // wells visited are marked, named by the well (those of a well no point is in are
    // not: they would mark a resonance the curves cannot show)
    let visited = |run: &SweepRun| -> Vec<isize> {
        let mut w: Vec<isize> = run.sweep.points.iter().map(|p| p.well).collect();
        w.sort();
        w.dedup();
        w
    };
    let several = runs.iter().any(|r| {
        let v = visited(r);
        v.len() > 1 || v.iter().any(|k| *k != r.sweep.wells.start as isize)
    });
    let in_start = !several
        || runs
            .iter()
            .any(|r| visited(r).contains(&(r.sweep.wells.start as isize)));
    let start_tag = if several {
        format!(", well {}", first.wells.start)
    } else {
        String::new()
    };
    let mut vertical: Vec<(f64, String)> = natural
        .iter()
        .filter(|_| in_start)
        .map(|n| {
            let tag = n
                .run
                .as_ref()
                .map(|label| format!(" ({label}{start_tag})"))
                .unwrap_or_else(|| {
                    if several {
                        format!(" (well {})", first.wells.start)
                    } else {
                        String::new()
                    }
                });
            (
                n.omega,
                format!("linear {rate}_n = {}{tag}", line_freq(n.omega, unit_f)),
            )
        })
        .collect();
    if several {
        // the other wells visited, per run: one line per well's frequency, named by the
        // run when the runs' frequencies differ
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-6 * x.abs().max(y.abs());
        let mut others: Vec<(usize, Vec<(f64, Option<String>)>)> = Vec::new();
        for run in runs {
            let w = &run.sweep.wells;
            for k in visited(run) {
                let Ok(k) = usize::try_from(k) else { continue };
                if k == w.start || k >= w.equilibria.len() || !w.equilibria[k].stable {
                    continue;
                }
                let label = (!run.values.is_empty())
                    .then(|| crate::frequency::study::values_label(&run.values));
                let entry = match others.iter_mut().find(|(j, _)| *j == k) {
                    Some(e) => e,
                    None => {
                        others.push((k, Vec::new()));
                        others.last_mut().expect("pushed")
                    }
                };
                for w2 in w.equilibria[k].omega2.iter().filter(|x| **x > 0.0) {
                    entry.1.push((w2.sqrt(), label.clone()));
                }
            }
        }
        for (k, lines) in others {
            // a frequency every run visiting the well has is named by the well alone
            let runs_here = {
                let mut l: Vec<&Option<String>> = lines.iter().map(|(_, l)| l).collect();
                l.dedup();
                l.len()
            };
            let mut shown: Vec<(f64, String)> = Vec::new();
            for (omega, label) in &lines {
                let shared = lines.iter().filter(|(o, _)| close(*o, *omega)).count() >= runs_here;
                let tag = match label {
                    Some(l) if !shared => format!("{l}, well {k}"),
                    _ => format!("well {k}"),
                };
                if !shown.iter().any(|(o, t)| close(*o, *omega) && *t == tag) {
                    shown.push((*omega, tag));
                }
            }
            for (omega, tag) in shown {
                vertical.push((
                    omega,
                    format!("linear {rate}_n = {} ({tag})", line_freq(omega, unit_f)),
                ));
            }
        }
    }
    let marks: Vec<(f64, String)> = marks
        .iter()
        .map(|(label, w)| (*w, format!("{label} ({})", line_freq(*w, unit_f))))
        .collect();
    let complete = runs.iter().all(|r| r.sweep.complete);
    let computed: usize = runs.iter().map(|r| r.sweep.points.len()).sum();
    let failed = runs.iter().find_map(|r| r.sweep.failure.as_ref());
    let incomplete = match (complete, failed) {
        (true, _) => String::new(),
        (false, Some(f)) => format!(
            " — INCOMPLETE: failed at {} after {computed} frequencies",
            match unit_f {
                FreqUnit::RadPerSecond => format!("{} rad/s", crate::diag::num(f.omega)),
                u => freq(f.omega, u),
            }
        ),
        (false, None) => format!(" — INCOMPLETE: interrupted after {computed} frequencies"),
    };
    let family = runs[0].tag().map(|(n, _)| n.to_string());
    let normalize = family.is_some() && family.as_deref() == forcing;
    let mut extra = Vec::new();
    if several {
        extra.push(format!(
            "starting in {}",
            well_name(&runs[0], first.wells.start as isize)
        ));
    }
    let caption = case.caption(&extra);
    let curves = |r: usize, normalized: bool| -> (Vec<Series>, Vec<Note>) {
        let name = &first.responses[r];
        let unit = first.units[r];
        let mut out = Vec::new();
        let mut notes = Vec::new();
        let mut slot = 0usize;
        let mut peaks = (Vec::new(), Vec::new());
        let mut jumps = (Vec::new(), Vec::new());
        for run in runs {
            let scale = match (normalized, run.tag()) {
                (true, Some((_, v))) if v != 0.0 => 1.0 / v.abs(),
                (true, Some(_)) => continue, // nothing to normalize by
                _ => 1.0,
            };
            let run_slot = slot;
            let mut wells_seen: Vec<isize> = Vec::new();
            for dir in [Direction::Independent, Direction::Up, Direction::Down] {
                let pts: Vec<_> = run
                    .sweep
                    .points
                    .iter()
                    .filter(|p| p.direction == dir)
                    .collect();
                if pts.is_empty() {
                    continue;
                }
                let mut label = run.label().unwrap_or_else(|| format!("{name} [{unit}]"));
                if dir != Direction::Independent {
                    label.push_str(&format!(" ({})", dir.name()));
                }
                let mut wells: Vec<isize> = pts.iter().map(|p| p.well).collect();
                wells.sort();
                wells.dedup();
                // one series per well, never joined across wells
                for &k in &wells {
                    let mine: Vec<_> = pts.iter().filter(|p| p.well == k).collect();
                    let label = if wells.len() > 1 || several {
                        format!("{label}, {}", well_name(run, k))
                    } else {
                        label.clone()
                    };
                    let w = wells_seen.iter().position(|x| *x == k).unwrap_or_else(|| {
                        wells_seen.push(k);
                        wells_seen.len() - 1
                    });
                    slot = slot.max(run_slot + w + 1);
                    out.push(
                        Series::new(
                            label,
                            mine.iter().map(|p| p.steady.omega).collect(),
                            mine.iter()
                                .map(|p| p.steady.measures[r].amplitude * scale)
                                .collect(),
                            if dir == Direction::Down {
                                Style::Dotted
                            } else {
                                Style::Solid
                            },
                        )
                        .color(run_slot + w),
                    );
                }
            }
            // the unit of the values drawn: per unit of the family's parameter when
            // normalized
            let unit = if normalized && !run.unit.is_empty() {
                format!("{unit}/{}", run.unit)
            } else {
                unit.to_string()
            };
            // every varied parameter of the run (with two `--values`, `F0 = 2 N` alone
            // would name two curves)
            let tag = run
                .label()
                .filter(|_| runs.len() > 1)
                .map(|l| format!(" ({l})"))
                .unwrap_or_default();
            for pk in run.sweep.peaks.iter().filter(|p| &p.response == name) {
                peaks.0.push(pk.omega);
                peaks.1.push(pk.amplitude * scale);
                notes.push(Note {
                    x: pk.omega,
                    y: pk.amplitude * scale,
                    text: format!(
                        "peak {}, {} {unit}{tag}",
                        freq(pk.omega, unit_f),
                        short(pk.amplitude * scale)
                    ),
                });
            }
            for j in run.sweep.jumps.iter().filter(|j| &j.response == name) {
                jumps.0.extend([j.from, j.to]);
                jumps
                    .1
                    .extend([j.amplitude_before * scale, j.amplitude_after * scale]);
                notes.push(Note {
                    x: j.to,
                    y: j.amplitude_after * scale,
                    text: format!(
                        "jump {} {}→{}{tag}",
                        j.direction.name(),
                        short(unit_f.of(j.from)),
                        freq(j.to, unit_f)
                    ),
                });
            }
        }
        if !peaks.0.is_empty() {
            // refined only when the sweep refined them (`--refine`): else the grid's maxima
            let refined = runs
                .iter()
                .any(|run| run.sweep.points.iter().any(|p| p.refined));
            out.push(Series::new(
                if refined { "refined peaks" } else { "peaks" },
                peaks.0,
                peaks.1,
                Style::Markers,
            ));
        }
        if !jumps.0.is_empty() {
            out.push(Series::new(
                "jumps (both edges)",
                jumps.0,
                jumps.1,
                Style::Markers,
            ));
        }
        (out, notes)
    };
    let mut plots = Vec::new();
    let x_label = format!("{} [rad/s]", first.param);
    let n = first.responses.len().min(6);
    for r in 0..n {
        let name = &first.responses[r];
        let (series, notes) = curves(r, false);
        plots.push(LinePlot {
            title: format!("{name}: stepped-sine amplitude{incomplete}"),
            caption: if r == 0 {
                caption.clone()
            } else {
                String::new()
            },
            x_label: x_label.clone(),
            y_label: format!("{name} amplitude [{}]", first.units[r]),
            series,
            vertical: vertical.clone(),
            marks: marks.clone(),
            notes,
            ..LinePlot::default()
        });
    }
    if normalize && let Some(vname) = &family {
        for r in 0..n {
            let name = &first.responses[r];
            let unit = first.units[r];
            let (series, notes) = curves(r, true);
            plots.push(LinePlot {
                title: format!("{name}: amplitude / {vname}{incomplete}"),
                x_label: x_label.clone(),
                y_label: if runs[0].unit.is_empty() {
                    format!("{name} amplitude / {vname} [{unit}]")
                } else {
                    format!("{name} amplitude / {vname} [{unit}/{}]", runs[0].unit)
                },
                series,
                vertical: vertical.clone(),
                marks: marks.clone(),
                notes,
                ..LinePlot::default()
            });
        }
    }
    plots.into_iter().map(|p| p.rescaled(unit_f)).collect()
}

/// How `frf --plot` draws amplitudes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AmplitudeScale {
    #[default]
    Linear,
    /// Logarithmic axis.
    Log,
    /// 20 log10(amplitude / 1 SI unit): dB re 1 rad, re 1 m, …
    Db,
}

/// The linear frequency response: per response (at most six) an amplitude panel
/// (`scale`) and a phase panel [deg], the natural frequencies `natural` (rad/s: ω_n =
/// |λ| of the damped modes, as the modes table and the report give them) as reference
/// lines, the refined peaks marked and labelled, and `marks` (a rotor's
/// forcing lines) in the forcing colour.
pub fn frf_figures(
    case: &Case,
    fr: &crate::linear::FrequencyResponse,
    units: &[&str],
    natural: &[f64],
    marks: &[(String, f64)],
    scale: AmplitudeScale,
) -> Vec<LinePlot> {
    let plots = frf_figures_in(
        case,
        fr,
        units,
        natural,
        marks,
        scale,
        FreqUnit::RadPerSecond,
    );
    let again = std::sync::Arc::new((
        case.clone(),
        fr.clone(),
        units.iter().map(|u| u.to_string()).collect::<Vec<_>>(),
        natural.to_vec(),
        marks.to_vec(),
    ));
    with_relabel(plots, move |unit| {
        let (case, fr, units, natural, marks) = &*again;
        let units: Vec<&str> = units.iter().map(String::as_str).collect();
        frf_figures_in(case, fr, &units, natural, marks, scale, unit)
    })
}

/// [`frf_figures`] with every frequency in `unit` (`--freq-unit`): the axis, the labels
/// (made in the unit: `f_n = |λ|/2π = 0.4732 Hz`) and the data drawn.
pub fn frf_figures_in(
    case: &Case,
    fr: &crate::linear::FrequencyResponse,
    units: &[&str],
    natural: &[f64],
    marks: &[(String, f64)],
    scale: AmplitudeScale,
    unit_f: FreqUnit,
) -> Vec<LinePlot> {
    let natural_name = match unit_f {
        FreqUnit::RadPerSecond => "ω_n = |λ|",
        _ => "f_n = |λ|/2π",
    };
    let vertical: Vec<(f64, String)> = natural
        .iter()
        .map(|w| (*w, format!("{natural_name} = {}", line_freq(*w, unit_f))))
        .collect();
    let marks: Vec<(f64, String)> = marks
        .iter()
        .map(|(label, w)| (*w, format!("{label} ({})", line_freq(*w, unit_f))))
        .collect();
    let db = |a: f64| 20.0 * a.log10();
    let mut plots = Vec::new();
    for (r, name) in fr.responses.iter().enumerate().take(6) {
        let unit = units.get(r).copied().unwrap_or("");
        let u = if unit.is_empty() { "-" } else { unit };
        let amp = |a: f64| {
            if scale == AmplitudeScale::Db {
                db(a)
            } else {
                a
            }
        };
        let peaks: Vec<_> = fr.peaks.iter().filter(|p| &p.response == name).collect();
        let (y_label, amp_unit) = match scale {
            AmplitudeScale::Db => (
                format!("{name} amplitude [dB re 1 {u}]"),
                format!("dB re 1 {u}"),
            ),
            _ => (format!("{name} amplitude [{u}]"), u.to_string()),
        };
        let mut series = vec![
            Series::new(
                format!("{name} (linear) [{amp_unit}]"),
                fr.omega.clone(),
                fr.values.iter().map(|row| amp(row[r].0)).collect(),
                Style::Solid,
            )
            .color(r % 6),
        ];
        let mut notes = Vec::new();
        if !peaks.is_empty() {
            series.push(Series::new(
                "refined peaks",
                peaks.iter().map(|p| p.omega).collect(),
                peaks.iter().map(|p| amp(p.amplitude)).collect(),
                Style::Markers,
            ));
            for p in &peaks {
                notes.push(Note {
                    x: p.omega,
                    y: amp(p.amplitude),
                    text: format!(
                        "peak {}, {} {amp_unit}",
                        freq(p.omega, unit_f),
                        short(amp(p.amplitude))
                    ),
                });
            }
        }
        plots.push(LinePlot {
            title: format!("{name}: linear frequency response, amplitude"),
            caption: if r == 0 {
                let lines = if natural.is_empty() {
                    vec![]
                } else {
                    vec![format!("dash-dot: {natural_name} of the damped modes")]
                };
                case.caption(&lines)
            } else {
                String::new()
            },
            x_label: format!("{} [rad/s]", fr.param),
            y_label,
            y_scale: if scale == AmplitudeScale::Log {
                Scale::Log
            } else {
                Scale::Linear
            },
            series,
            vertical: vertical.clone(),
            marks: marks.clone(),
            notes,
            ..LinePlot::default()
        });
        plots.push(LinePlot {
            title: format!("{name}: phase"),
            x_label: format!("{} [rad/s]", fr.param),
            y_label: format!("{name} phase [deg]"),
            series: vec![
                Series::new(
                    format!("{name} phase (linear) [deg]"),
                    fr.omega.clone(),
                    fr.values.iter().map(|row| row[r].1).collect(),
                    Style::Solid,
                )
                .color(r % 6),
            ],
            vertical: vertical.clone(),
            marks: marks.clone(),
            ..LinePlot::default()
        });
    }
    plots.into_iter().map(|p| p.rescaled(unit_f)).collect()
}

/// A mode tracking: ω_n against the parameter, one curve per label (every value solved,
/// inserted ones included), crossings marked and veerings drawn; `unit` the parameter's.
pub fn tracking_figure(
    case: &Case,
    t: &crate::linear::tracking::ModeTracking,
    unit: &str,
) -> LinePlot {
    let mut series: Vec<Series> = t
        .labels
        .iter()
        .enumerate()
        .map(|(l, name)| {
            let (x, y): (Vec<f64>, Vec<f64>) = t
                .steps
                .iter()
                .filter_map(|s| s.modes[l].as_ref().map(|m| (s.value, m.omega_n_rad_s)))
                .unzip();
            Series::new(format!("{name} ω_n [rad/s]"), x, y, Style::Solid)
        })
        .collect();
    let unit = if unit.is_empty() { "-" } else { unit };
    let mut notes = Vec::new();
    if !t.crossings.is_empty() {
        series.push(Series::new(
            "crossings",
            t.crossings.iter().map(|c| c.value).collect(),
            t.crossings.iter().map(|c| c.omega_n_rad_s).collect(),
            Style::Markers,
        ));
        for c in &t.crossings {
            notes.push(Note {
                x: c.value,
                y: c.omega_n_rad_s,
                text: format!("crossing {} = {} {unit}", t.param, short(c.value)),
            });
        }
    }
    let vertical = t
        .veerings
        .iter()
        .map(|v| {
            (
                v.value,
                format!(
                    "veering {} / {} at {} {unit}",
                    v.labels[0],
                    v.labels[1],
                    short(v.value)
                ),
            )
        })
        .collect();
    LinePlot {
        title: format!("natural frequencies against {}", t.param),
        caption: case.caption(&[]),
        x_label: format!("{} [{unit}]", t.param),
        y_label: "ω_n [rad/s]".into(),
        series,
        vertical,
        notes,
        ..LinePlot::default()
    }
}

/// The summary lines of a sweep's wells, per direction, when a response leaves the well
/// the sweep starts from: "the response left its starting well (well 2: bar1.theta =
/// 0.644 rad) at 15 of 23 frequencies (independent): 0.5–4 rad/s in well 0 (bar1.theta =
/// -0.866 rad)", the frequencies in `unit` (`--freq-unit`), each well's as runs of
/// consecutive grid frequencies ("1, 2, 3–3.5 rad/s in well 0"). Coarse-grid points only
/// (refinement adds none across wells). None when every response stays in the starting
/// well.
pub fn well_summary(run: &SweepRun, unit: super::units::FreqUnit) -> Vec<String> {
    let start = run.sweep.wells.start as isize;
    let mut out = Vec::new();
    for dir in [Direction::Independent, Direction::Up, Direction::Down] {
        let pts: Vec<_> = run
            .sweep
            .points
            .iter()
            .filter(|p| p.direction == dir && !p.refined)
            .collect();
        let left: Vec<_> = pts.iter().filter(|p| p.well != start).collect();
        if left.is_empty() {
            continue;
        }
        let mut wells: Vec<isize> = left.iter().map(|p| p.well).collect();
        // the wells in their order, the orbits across wells last
        wells.sort_by_key(|&k| (k < 0, k));
        wells.dedup();
        let parts: Vec<String> = wells
            .iter()
            .map(|&k| {
                // the runs of consecutive grid frequencies in well k (wells can
                // alternate from one frequency to the next)
                let mut runs: Vec<(f64, f64)> = Vec::new();
                let mut open = false;
                for p in &pts {
                    if p.well != k {
                        open = false;
                        continue;
                    }
                    match runs.last_mut() {
                        Some(run) if open => run.1 = p.steady.omega,
                        _ => runs.push((p.steady.omega, p.steady.omega)),
                    }
                    open = true;
                }
                // a grid frequency as computed in rad/s, else in the unit (`--freq-unit`)
                let shown = |w: f64| match unit {
                    super::units::FreqUnit::RadPerSecond => w.to_string(),
                    u => format!("{:.6}", u.of(w)),
                };
                let sym = unit.symbol();
                let range = runs
                    .iter()
                    .map(|&(lo, hi)| {
                        if lo == hi {
                            shown(lo)
                        } else {
                            format!("{}–{}", shown(lo), shown(hi))
                        }
                    })
                    .collect::<Vec<_>>()
                    .join(", ");
                if k == crate::frequency::wells::SPANS {
                    format!("{range} {sym} across wells (the orbit spans two)")
                } else {
                    format!("{range} {sym} in {}", well_name(run, k))
                }
            })
            .collect();
        out.push(format!(
            "the response left its starting well ({}) at {} of {} frequencies ({}): {}",
            well_name(run, start)
                .replacen(" (", ": ", 1)
                .trim_end_matches(')'),
            left.len(),
            pts.len(),
            dir.name(),
            parts.join("; ")
        ));
    }
    out
}
