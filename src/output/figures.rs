//! The figures of the analyses, built from their results (drawn by [`super::plot`]):
//! a simulation's angles against time, an equilibrium branch against its parameter, a
//! sweep's amplitude against frequency with the linear natural frequencies marked.

use super::plot::{LinePlot, Series, Style};
use crate::dynamics::simulate::Trajectory;
use crate::frequency::Direction;
use crate::frequency::study::{NaturalFrequency, SweepRun};
use crate::statics::continuation::{Branch, BranchPoint};

/// SI unit of a coordinate: rad for an angle, else m.
pub fn unit(angle: bool) -> &'static str {
    if angle { "rad" } else { "m" }
}

/// Angle coordinates against time (all coordinates if the model has no angles); `name`
/// is the model's.
pub fn trajectory_figure(name: &str, traj: &Trajectory) -> LinePlot {
    let angles: Vec<usize> = (0..traj.coordinates.len())
        .filter(|&i| traj.angles[i])
        .collect();
    let pick = if angles.is_empty() {
        (0..traj.coordinates.len()).collect()
    } else {
        angles.clone()
    };
    LinePlot {
        title: format!("{name}: simulation"),
        x_label: "t [s]".into(),
        y_label: if angles.is_empty() {
            "coordinate [SI]".into()
        } else {
            "angle [rad]".into()
        },
        series: pick
            .iter()
            .map(|&i| Series {
                label: traj.coordinates[i].clone(),
                x: traj.t.clone(),
                y: traj.q.iter().map(|q| q[i]).collect(),
                style: Style::Solid,
            })
            .collect(),
        vertical: Vec::new(),
        marks: Vec::new(),
    }
}

/// The paper's Figure 6: the branch in (parameter, coordinate `idx`), stable solid,
/// unstable dashed, folds and branch points marked, with the branches switched to at the
/// branch points; `name` is the model's, `angle` whether the coordinate
/// is an angle.
pub fn branch_figure(name: &str, b: &Branch, idx: usize, angle: bool) -> LinePlot {
    let mut series = Vec::new();
    let mut seg: Vec<&BranchPoint> = Vec::new();
    let flush = |seg: &mut Vec<&BranchPoint>, series: &mut Vec<Series>| {
        if seg.len() > 1 {
            let stable = seg[1].stable;
            series.push(Series {
                label: if stable {
                    "stable".into()
                } else {
                    "unstable".into()
                },
                x: seg.iter().map(|p| p.value).collect(),
                y: seg.iter().map(|p| p.q[idx]).collect(),
                style: if stable { Style::Solid } else { Style::Dashed },
            });
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
    for (label, marked) in [("folds", &b.folds), ("branch points", &b.branch_points)] {
        if !marked.is_empty() {
            series.push(Series {
                label: label.into(),
                x: marked.iter().map(|p| p.value).collect(),
                y: marked.iter().map(|p| p.q[idx]).collect(),
                style: Style::Markers,
            });
        }
    }
    LinePlot {
        title: format!("{name}: equilibria against {}", b.param),
        x_label: b.param.clone(),
        y_label: format!("{} [{}]", b.coordinates[idx], unit(angle)),
        series,
        vertical: Vec::new(),
        marks: Vec::new(),
    }
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

/// Amplitude of the first response against frequency, one curve per run (`--values`
/// entry), direction and well, the natural frequencies as vertical lines; for a family, a
/// second panel with the amplitude divided by the run's value (the paper's Figures 8–9).
pub fn sweep_figures(
    runs: &[SweepRun],
    natural: &[NaturalFrequency],
    marks: &[(String, f64)],
) -> Vec<LinePlot> {
    let first = &runs[0].sweep;
    let name = &first.responses[0];
    let unit = first.units[0];
    // the wells the responses visit: with more than one, each curve is split by well and
    // each well's linear natural frequencies are marked, named by the well
    let visited = |run: &SweepRun| -> Vec<isize> {
        let mut w: Vec<isize> = run.sweep.points.iter().map(|p| p.well).collect();
        w.sort();
        w.dedup();
        w
    };
    let several = runs.iter().any(|r| visited(r).len() > 1);
    let start_tag = if several {
        format!(", well {}", first.wells.start)
    } else {
        String::new()
    };
    let mut vertical: Vec<(f64, String)> = natural
        .iter()
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
            (n.omega, format!("linear ω_n = {:.4} rad/s{tag}", n.omega))
        })
        .collect();
    if several && runs.len() == 1 {
        let w = &first.wells;
        for k in visited(&runs[0]) {
            let Ok(k) = usize::try_from(k) else { continue };
            if k == w.start || !w.equilibria[k].stable {
                continue;
            }
            for w2 in w.equilibria[k].omega2.iter().filter(|x| **x > 0.0) {
                let omega = w2.sqrt();
                vertical.push((omega, format!("linear ω_n = {omega:.4} rad/s (well {k})")));
            }
        }
    }
    let marks: Vec<(f64, String)> = marks
        .iter()
        .map(|(label, w)| (*w, format!("{label} ({w:.4} rad/s)")))
        .collect();
    let curves = |normalized: bool| -> Vec<Series> {
        let mut out = Vec::new();
        for run in runs {
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
                let scale = match (normalized, run.tag()) {
                    (true, Some((_, v))) if v != 0.0 => 1.0 / v.abs(),
                    (true, Some(_)) => continue, // nothing to normalize by
                    _ => 1.0,
                };
                let mut label = run.label().unwrap_or_else(|| name.clone());
                if dir != Direction::Independent {
                    label.push_str(&format!(" ({})", dir.name()));
                }
                let mut wells: Vec<isize> = pts.iter().map(|p| p.well).collect();
                wells.sort();
                wells.dedup();
                // one series per well, never joined across wells
                for &k in &wells {
                    let mine: Vec<_> = pts.iter().filter(|p| p.well == k).collect();
                    let label = if wells.len() > 1 {
                        format!("{label}, {}", well_name(run, k))
                    } else {
                        label.clone()
                    };
                    out.push(Series {
                        label,
                        x: mine.iter().map(|p| p.steady.omega).collect(),
                        y: mine
                            .iter()
                            .map(|p| p.steady.measures[0].amplitude * scale)
                            .collect(),
                        style: if dir == Direction::Down {
                            Style::Dashed
                        } else {
                            Style::Solid
                        },
                    });
                }
            }
        }
        out
    };
    let mut plots = vec![LinePlot {
        title: format!("{name}: stepped-sine amplitude"),
        x_label: format!("{} [rad/s]", first.param),
        y_label: format!("{name} amplitude [{unit}]"),
        series: curves(false),
        vertical: vertical.clone(),
        marks: marks.clone(),
    }];
    if let Some((vname, _)) = runs[0].tag() {
        plots.push(LinePlot {
            title: format!("{name}: amplitude / {vname}"),
            x_label: format!("{} [rad/s]", first.param),
            y_label: if runs[0].unit.is_empty() {
                format!("{name} amplitude / {vname}")
            } else {
                format!("{name} amplitude / {vname} [{unit}/{}]", runs[0].unit)
            },
            series: curves(true),
            vertical,
            marks,
        });
    }
    plots
}

/// The linear frequency response: one panel per response (amplitude against frequency,
/// up to six), the undamped natural frequencies `natural` (rad/s) as dashed lines, the
/// refined peaks marked, and `marks` (a rotor's forcing lines) in their own colour.
pub fn frf_figures(
    fr: &crate::linear::FrequencyResponse,
    units: &[&str],
    natural: &[f64],
    marks: &[(String, f64)],
) -> Vec<LinePlot> {
    let vertical: Vec<(f64, String)> = natural
        .iter()
        .map(|w| (*w, format!("undamped ω_n = {w:.4} rad/s")))
        .collect();
    let marks: Vec<(f64, String)> = marks
        .iter()
        .map(|(label, w)| (*w, format!("{label} ({w:.4} rad/s)")))
        .collect();
    fr.responses
        .iter()
        .enumerate()
        .take(6)
        .map(|(r, name)| {
            let unit = units.get(r).copied().unwrap_or("");
            let peaks: Vec<_> = fr.peaks.iter().filter(|p| &p.response == name).collect();
            let mut series = vec![Series {
                label: format!("{name} (linear)"),
                x: fr.omega.clone(),
                y: fr.values.iter().map(|row| row[r].0).collect(),
                style: Style::Solid,
            }];
            if !peaks.is_empty() {
                series.push(Series {
                    label: peaks
                        .iter()
                        .map(|p| format!("peak {:.4} rad/s", p.omega))
                        .collect::<Vec<_>>()
                        .join(", "),
                    x: peaks.iter().map(|p| p.omega).collect(),
                    y: peaks.iter().map(|p| p.amplitude).collect(),
                    style: Style::Markers,
                });
            }
            LinePlot {
                title: format!("{name}: linear frequency response"),
                x_label: format!("{} [rad/s]", fr.param),
                y_label: format!("{name} amplitude [{unit}]"),
                series,
                vertical: vertical.clone(),
                marks: marks.clone(),
            }
        })
        .collect()
}

/// A mode tracking: ω_n against the parameter, one curve per label (every value solved,
/// inserted ones included), crossings and veerings marked; `unit` the parameter's.
pub fn tracking_figure(t: &crate::linear::tracking::ModeTracking, unit: &str) -> LinePlot {
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
            Series {
                label: name.clone(),
                x,
                y,
                style: Style::Solid,
            }
        })
        .collect();
    if !t.crossings.is_empty() {
        series.push(Series {
            label: "crossings".into(),
            x: t.crossings.iter().map(|c| c.value).collect(),
            y: t.crossings.iter().map(|c| c.omega_n_rad_s).collect(),
            style: Style::Markers,
        });
    }
    let vertical = t
        .veerings
        .iter()
        .map(|v| {
            (
                v.value,
                format!("veering {} / {}", v.labels[0], v.labels[1]),
            )
        })
        .collect();
    let unit = if unit.is_empty() { "-" } else { unit };
    LinePlot {
        title: format!("natural frequencies against {}", t.param),
        x_label: format!("{} [{unit}]", t.param),
        y_label: "ω_n [rad/s]".into(),
        series,
        vertical,
        marks: Vec::new(),
    }
}

/// The summary lines of a sweep's wells, per direction, when a response leaves the well
/// the sweep starts from: "the response left its starting well (well 2: bar1.theta =
/// 0.644 rad) at 15 of 23 frequencies (independent): 0.5–4 rad/s in well 0 (bar1.theta =
/// -0.866 rad)". Coarse-grid points only (refinement adds none across wells). None when
/// every response stays in the starting well.
pub fn well_summary(run: &SweepRun) -> Vec<String> {
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
        wells.sort();
        wells.dedup();
        let parts: Vec<String> = wells
            .iter()
            .map(|&k| {
                let w: Vec<f64> = left
                    .iter()
                    .filter(|p| p.well == k)
                    .map(|p| p.steady.omega)
                    .collect();
                let (lo, hi) = (w[0], w[w.len() - 1]);
                let range = if lo == hi {
                    format!("{lo} rad/s")
                } else {
                    format!("{lo}–{hi} rad/s")
                };
                format!("{range} in {}", well_name(run, k))
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
