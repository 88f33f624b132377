//! The report's design sections: the sensitivity of the modes (table and tornado), the
//! margins against the environment's forcing lines, and the tuning proposal. Each runs
//! the library's analysis ([`crate::linear::sensitivity`], [`crate::margins`],
//! [`crate::tune`]), puts its result into the sidecar under its own key and shows it with
//! keyed cells, like the sections of [`super::build`].

use super::{Cell, Column, Digits, Report, Section, Table};
use crate::diag::Result;
use crate::environment::Environment;
use crate::linear::sensitivity::{Sensitivity, Vary, sensitivity};
use crate::margins::{ModeInterval, Requirement, check_margins, mode_points_named};
use crate::system::System;

/// What the design sections need.
pub struct Studies<'a> {
    pub sys: &'a System,
    /// The varied parameters. `given`: from the user (their ranges are tolerances, and
    /// the margins use each mode's whole interval); otherwise an illustration (each
    /// design parameter ±10 %, see [`default_varies`]).
    pub varies: &'a [Vary],
    pub given: bool,
    /// Parameters left out of the illustration, with why.
    pub dropped: &'a [(String, String)],
    pub environment: Option<&'a Environment>,
    /// Required separation, a fraction.
    pub margin: f64,
    /// Propose a tuning (needs `given` ranges and an environment).
    pub tune: bool,
    /// Each parameter's unit, for the tables.
    pub units: &'a dyn Fn(&str) -> String,
}

/// Each parameter the report varies when none is given: every parameter with a value of
/// its own (not defined from others), non-zero, not solved by the `[trim]`, and not the
/// forcing frequency, at ±10 %; a parameter whose ±10 % cannot be solved (a linkage that
/// no longer closes, an equilibrium past a fold) is left out and returned with why.
pub fn default_varies(
    sys: &System,
    forcing_amplitude: Option<usize>,
) -> (Vec<Vary>, Vec<(String, String)>) {
    let base = crate::linear::modal_analysis(sys, None).ok();
    let mut dropped = Vec::new();
    let all: Vec<Vary> = default_candidates(sys, forcing_amplitude);
    let kept = all
        .into_iter()
        .filter(|v| {
            for (label, value) in &v.cases {
                if let Err(e) = crate::linear::sensitivity::modes_at(
                    sys,
                    &[(v.param, *value)],
                    None,
                    base.as_ref(),
                ) {
                    dropped.push((v.name.clone(), format!("{label}: {e}")));
                    return false;
                }
            }
            true
        })
        .collect();
    (kept, dropped)
}

fn default_candidates(sys: &System, forcing_amplitude: Option<usize>) -> Vec<Vary> {
    let trimmed: Vec<usize> = sys
        .trim
        .as_ref()
        .filter(|t| t.off.is_none())
        .map(|t| t.params.clone())
        .unwrap_or_default();
    (0..sys.param_names().len())
        .filter(|&i| {
            let p = sys.param(i);
            sys.param_definition(i).is_none()
                && p != 0.0
                && p.is_finite()
                && !trimmed.contains(&i)
                && Some(i) != sys.forcing_param()
                && Some(i) != forcing_amplitude
        })
        .map(|i| {
            let p = sys.param(i);
            let name = sys.param_names()[i].clone();
            Vary {
                param: i,
                cases: vec![(format!("{name}+10%"), p * 1.1), (format!("{name}-10%"), p * 0.9)],
                name,
                range: (p.min(p * 0.9).min(p * 1.1), p.max(p * 0.9).max(p * 1.1)),
            }
        })
        .collect()
}

fn cols(c: &[(&str, &str)]) -> Vec<Column> {
    c.iter().map(|(t, u)| Column::new(*t, *u)).collect()
}

/// Add the sensitivity, margins and (when asked) tuning sections to `report`.
pub fn add_studies(report: &mut Report, s: &Studies) -> Result<()> {
    let study = if s.varies.is_empty() {
        None
    } else {
        Some(sensitivity(s.sys, s.varies, None, None)?)
    };
    if let Some(study) = &study {
        report.add_data("sensitivity", study)?;
        let section = sensitivity_section(report, study, s)?;
        report.document.sections.push(section);
    }
    let Some(env) = s.environment else {
        return Ok(());
    };
    let lines = env.forcing_lines();
    let ma = crate::linear::modal_analysis(s.sys, None)?;
    let (mut points, _) =
        mode_points_named(&ma, &crate::linear::sensitivity::mode_names(s.sys, &ma));
    if let (true, Some(study)) = (s.given, &study) {
        points = points
            .into_iter()
            .zip(&study.modes)
            .map(|(p, m)| ModeInterval {
                min_rad_s: m.worst_case.min_rad_s.min(p.omega_n_rad_s),
                max_rad_s: m.worst_case.max_rad_s.max(p.omega_n_rad_s),
                ..p
            })
            .collect();
    }
    let check = check_margins(&points, &lines, s.margin, Requirement::Fixed)?;
    report.add_data("margins", &check)?;
    let d = &report.sidecar;
    let mut rows = Vec::new();
    for (k, r) in check.rows.iter().enumerate() {
        let key = |f: &str| format!("margins/rows/{k}/{f}");
        rows.push(vec![
            Cell::text(&r.mode),
            d.num(key("min_rad_s"), Digits::Fixed(3)),
            d.num(key("max_rad_s"), Digits::Fixed(3)),
            Cell::text(&r.line),
            d.num(key("line_rad_s"), Digits::Fixed(3)),
            d.num(key("separation_pct"), Digits::Fixed(2)),
            Cell::text(format!("{:?}", r.side).to_lowercase()),
            d.num(key("required_pct"), Digits::Fixed(2)),
            Cell::text(if r.pass { "pass" } else { "FAIL" }),
        ]);
    }
    let failures: Vec<String> = check
        .rows
        .iter()
        .filter(|r| !r.pass)
        .map(|r| {
            format!(
                "{} ({:.2}–{:.2} rad/s) is {:.2} % from {} {} ({:.2} rad/s)",
                r.mode, r.min_rad_s, r.max_rad_s, r.separation_pct, env.name, r.line, r.line_rad_s
            )
        })
        .collect();
    let verdict = if check.pass {
        format!(
            "PASS: every mode clears every forcing line of {} by {:.1} % (the margin is a choice, not a standard).",
            env.name,
            s.margin * 100.0
        )
    } else {
        format!(
            "FAIL at a {:.1} % margin (a choice, not a standard): {}.",
            s.margin * 100.0,
            failures.join("; ")
        )
    };
    let interval_note = if s.given {
        "Each mode's interval is its lowest and highest ω_n over the tolerance box of the varied parameters (the sensitivity section's worst case); the separation is that of the interval's worst point."
    } else {
        "The modes are those of the nominal design (no tolerances given: run the report with --vary for intervals)."
    };
    let section = Section::new("margins", "Margins against the forcing lines")
        .prose(format!(
            "Separation |ω_mode − ω_line| / ω_line of every mode (ω_n = |λ|) from every forcing line of {} (to a band's nearest edge). {interval_note}",
            env.name
        ))
        .prose(verdict)
        .table(Table {
            caption: "Mode × line".into(),
            columns: cols(&[
                ("mode", ""),
                ("ω_n lowest", "rad/s"),
                ("ω_n highest", "rad/s"),
                ("line", ""),
                ("line", "rad/s"),
                ("separation", "%"),
                ("side", ""),
                ("required", "%"),
                ("", ""),
            ]),
            rows,
        });
    report.document.sections.push(section);

    if s.tune {
        let t = crate::tune::tune(
            s.sys,
            s.varies,
            &lines,
            &crate::tune::TuneOptions {
                margin: s.margin,
                ..Default::default()
            },
        )?;
        report.add_data("tuning", &t)?;
        let d = &report.sidecar;
        let mut section = Section::new("tuning", "Tuning proposal").prose(format!(
            "The smallest change Σ((p − p0)/p0)² of {} within the given ranges that puts every mode outside every line of {} by {:.1} % (plus 1e-4), one design per choice of sides, each verified by a full modal analysis and margins check. {} design(s) found, {} choice(s) infeasible.",
            s.varies.iter().map(|v| v.name.as_str()).collect::<Vec<_>>().join(", "),
            env.name,
            s.margin * 100.0,
            t.designs.len(),
            t.infeasible.len()
        ));
        for (k, design) in t.designs.iter().enumerate() {
            let mut rows = Vec::new();
            for (name, _) in &design.parameters {
                let p0 = s
                    .varies
                    .iter()
                    .find(|v| &v.name == name)
                    .map(|v| s.sys.param(v.param))
                    .unwrap_or(f64::NAN);
                rows.push(vec![
                    Cell::text(name),
                    Cell::text(format!("{p0:.6e} {}", (s.units)(name))),
                    d.num(
                        format!("tuning/designs/{k}/parameters/{}", super::escape_key(name)),
                        Digits::Sig(7),
                    ),
                    Cell::text((s.units)(name)),
                ]);
            }
            section = section.table(Table {
                caption: format!(
                    "Design {} (cost {:.4e}; closest separation {:.2} %)",
                    k + 1,
                    design.cost,
                    design.closest_pct
                ),
                columns: cols(&[("parameter", ""), ("baseline", ""), ("design", ""), ("unit", "")]),
                rows,
            });
        }
        for i in &t.infeasible {
            section = section.prose(format!("Infeasible: {}", i.reason));
        }
        report.document.sections.push(section);
    }
    Ok(())
}

fn sensitivity_section(report: &Report, study: &Sensitivity, s: &Studies) -> Result<Section> {
    let d = &report.sidecar;
    let mut section = Section::new("sensitivity", "Sensitivity of the modes").prose(if s.given {
        format!(
            "Each case re-solves the trim, the equilibrium (from the baseline's) and the modes; the derivatives are analytic (eigenvectors of the damped constrained system, with the equilibrium's and the trim's shift), with a central finite difference beside them. Varied: {}.",
            s.varies
                .iter()
                .map(|v| v.cases.iter().map(|c| c.0.clone()).collect::<Vec<_>>().join(", "))
                .collect::<Vec<_>>()
                .join("; ")
        )
    } else {
        format!(
            "No tolerances were given (--vary): as an illustration, each parameter with a value of its own is changed by ±10 % in turn. The worst case below spans all of them at once, so it is not a tolerance statement.{}",
            if s.dropped.is_empty() {
                String::new()
            } else {
                format!(
                    " Left out, because ±10 % of them cannot be solved: {}.",
                    s.dropped
                        .iter()
                        .map(|(n, why)| {
                            let first = why.lines().next().unwrap_or("");
                            format!("{n} ({})", first.split("; last pose").next().unwrap_or(first))
                        })
                        .collect::<Vec<_>>()
                        .join("; ")
                )
            }
        )
    });
    for (mi, m) in study.modes.iter().enumerate() {
        let mut rows = Vec::new();
        for (k, c) in m.cases.iter().enumerate() {
            let key = |f: &str| format!("sensitivity/modes/{mi}/cases/{k}/{f}");
            rows.push(vec![
                Cell::text(&c.label),
                d.num(key("value"), Digits::Sig(6)),
                Cell::text((s.units)(&c.param)),
                d.num(key("omega_n_rad_s"), Digits::Fixed(4)),
                d.num(key("change_pct_omega_n"), Digits::Fixed(3)),
                d.num(key("undamped_omega_rad_s"), Digits::Fixed(4)),
                d.num(key("change_pct_undamped"), Digits::Fixed(3)),
                d.num(key("damping_ratio"), Digits::Fixed(4)),
            ]);
        }
        section = section.table(Table {
            caption: format!(
                "{}: ω_n = {:.4} rad/s, ζ = {:.4} — cases",
                m.name, m.omega_n_rad_s, m.damping_ratio
            ),
            columns: cols(&[
                ("case", ""),
                ("value", ""),
                ("unit", ""),
                ("ω_n", "rad/s"),
                ("change", "%"),
                ("undamped ω", "rad/s"),
                ("change", "%"),
                ("ζ", ""),
            ]),
            rows,
        });
        let mut rows = Vec::new();
        for (k, dv) in m.derivatives.iter().enumerate() {
            let key = |f: &str| format!("sensitivity/modes/{mi}/derivatives/{k}/{f}");
            rows.push(vec![
                Cell::text(&dv.param),
                d.num(key("domega_n_dp"), Digits::Sci(5)),
                d.num(key("fd"), Digits::Sci(5)),
                d.num(key("elasticity"), Digits::Fixed(4)),
                d.num(key("dzeta_dp"), Digits::Sci(4)),
            ]);
        }
        section = section.table(Table {
            caption: format!(
                "{}: derivatives (per SI unit of the parameter); worst case {:.4}–{:.4} rad/s",
                m.name, m.worst_case.min_rad_s, m.worst_case.max_rad_s
            ),
            columns: cols(&[
                ("parameter", ""),
                ("dω_n/dp", "rad/s per unit"),
                ("finite difference", "rad/s per unit"),
                ("elasticity (p/ω)dω/dp", ""),
                ("dζ/dp", "per unit"),
            ]),
            rows,
        });
    }
    let svg = crate::output::sensitivity::tornado_svg(study, "Change of each mode's ω_n per parameter")
        .map_err(|e| crate::diag::Error::io("report.html", e))?;
    Ok(section.figure(
        "Tornado chart: the change of ω_n (%) at each parameter's lowest and highest case, widest on top.",
        svg,
    ))
}
