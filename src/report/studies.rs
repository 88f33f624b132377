//! The report's design sections: the sensitivity of the modes (table and tornado), the
//! margins against the environment's forcing lines, and the tuning proposal. Each runs
//! the library's analysis ([`crate::linear::sensitivity`], [`crate::margins`],
//! [`crate::tune`]), puts its result into the sidecar under its own key and shows it with
//! keyed cells, like the sections of [`super::build`].

use super::{Cell, Column, Digits, Report, Section, Table};
use crate::diag::Result;
use crate::environment::Environment;
use crate::linear::sensitivity::{Sensitivity, Vary, sensitivity};
use crate::margins::{Requirement, mode_points_named};
use crate::output::command::shell_word;
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
    /// Propose a tuning (needs `tune_varies` and an environment).
    pub tune: bool,
    /// The parameters the tuning may change, with their ranges.
    pub tune_varies: &'a [Vary],
    /// Each parameter's unit, for the tables.
    pub units: &'a dyn Fn(&str) -> String,
    /// The `--vary` texts as given (with `given`): the tolerances a tuning must clear the
    /// bands over, and the flags of the printed check commands.
    pub vary_texts: &'a [String],
    /// The model file and the user's overrides as shell words, leaving out those of the
    /// given parameters (for the printed check commands).
    pub command_words: &'a dyn Fn(&[&str]) -> String,
}

/// Each parameter the report varies when none is given: every parameter with a value of
/// its own (not defined from others), non-zero, not solved by the `[trim]`, and not the
/// forcing frequency, at ±10 %; a parameter whose ±10 % cannot be solved (a linkage that
/// no longer closes, an equilibrium past a fold) is left out and returned with why, and so
/// is one on which no mode depends at this design (every eigenvalue unchanged to 1e-12 at
/// both cases, e.g. a breakout law's preload while the law is switched off), with the
/// reason [`INERT`].
pub const INERT: &str = "no mode depends on it at this design";

/// See [`INERT`].
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
            let mut moves = false;
            for (label, value) in &v.cases {
                match crate::linear::sensitivity::modes_at(
                    sys,
                    &[(v.param, *value)],
                    None,
                    base.as_ref(),
                ) {
                    Err(e) => {
                        dropped.push((v.name.clone(), format!("{label}: {e}")));
                        return false;
                    }
                    Ok((_, m)) => {
                        let same = base.as_ref().is_some_and(|b| {
                            b.modes.len() == m.modes.len()
                                && b.modes.iter().zip(&m.modes).all(|(x, y)| {
                                    let (a, b) = (x.eigenvalue, y.eigenvalue);
                                    (a.re - b.re).hypot(a.im - b.im) <= 1e-12 * a.norm().max(1e-300)
                                })
                        });
                        moves |= !same;
                    }
                }
            }
            if !moves {
                dropped.push((v.name.clone(), INERT.to_string()));
            }
            moves
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
                cases: vec![
                    (format!("{name}+10%"), p * 1.1),
                    (format!("{name}-10%"), p * 0.9),
                ],
                name,
                range: (p.min(p * 0.9).min(p * 1.1), p.max(p * 0.9).max(p * 1.1)),
            }
        })
        .collect()
}

fn cols(c: &[(&str, &str)]) -> Vec<Column> {
    c.iter().map(|(t, u)| Column::new(*t, *u)).collect()
}

/// The context of an error of the report's tuning (its ranges are not the sensitivity's:
/// a front end names them apart).
pub const TUNING: &str = "the tuning";

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
    let names = crate::linear::sensitivity::mode_names(s.sys, &ma);
    let (mut points, _) = mode_points_named(&ma, &names);
    if let (true, Some(study)) = (s.given, &study) {
        points = crate::margins::with_intervals(points, study);
    }
    // an unstable design fails, whatever its separations
    let mut check =
        crate::margins::check_design(&ma, &names, &points, &lines, s.margin, Requirement::Fixed)?;
    // with the user's tolerances, an unstable point of the box fails it too (as `margins
    // --vary` does)
    if let (true, Some(study)) = (s.given, &study) {
        check = check.with_unstable_corners(crate::margins::box_unstable_points(study, s.varies)?);
    }
    report.add_data("margins", &check)?;
    if let Some(profile) = &env.profile {
        let section = profile_section(report, s, env, profile, &ma)?;
        report.document.sections.push(section);
    }
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
        .enumerate()
        .filter(|(_, r)| !r.pass)
        .map(|(k, r)| {
            let n = |f: &str| d.inline(format!("margins/rows/{k}/{f}"), Digits::Fixed(2));
            format!(
                "{} ({}–{} rad/s) is {} % from {} {} ({} rad/s){}",
                r.mode,
                n("min_rad_s"),
                n("max_rad_s"),
                n("separation_pct"),
                env.name,
                r.line,
                n("line_rad_s"),
                // a negative separation: the interval reaches across the line
                if r.separation_pct < 0.0 {
                    ", negative: the interval reaches across the line"
                } else {
                    ""
                }
            )
        })
        .collect();
    let margin = d.inline("margins/margin_pct", Digits::Fixed(1));
    let unstable: Vec<String> = (0..check.unstable.len())
        .map(|k| {
            format!(
                "{} grows at Re λ = {} 1/s",
                check.unstable[k].mode,
                d.inline(
                    format!("margins/unstable/{k}/growth_rate_1_s"),
                    Digits::Fixed(4)
                )
            )
        })
        .collect();
    // what an unstable verdict adds about the separations
    let also_close = || {
        if failures.is_empty() {
            ".".to_string()
        } else {
            format!(
                "; and at a {margin} % margin (a choice, not a standard): {}.",
                failures.join("; ")
            )
        }
    };
    let verdict = if !unstable.is_empty() {
        format!(
            "FAIL: the equilibrium is UNSTABLE ({}): a design that leaves its equilibrium cannot pass, whatever its separations{}",
            unstable.join("; "),
            also_close()
        )
    } else if !check.unstable_corners.is_empty() {
        let corners: Vec<String> = (0..check.unstable_corners.len())
            .map(|k| {
                format!(
                    "{} (grows at Re λ = {} 1/s)",
                    check.unstable_corners[k].label,
                    d.inline(
                        format!("margins/unstable_corners/{k}/growth_rate_1_s"),
                        Digits::Fixed(4)
                    )
                )
            })
            .collect();
        format!(
            "FAIL: the tolerance box reaches UNSTABLE designs, at {}: a part within tolerance can leave its equilibrium, whatever the separations{}",
            corners.join("; "),
            also_close()
        )
    } else if check.pass {
        format!(
            "PASS: every mode clears every forcing line of {} by {margin} % (the margin is a choice, not a standard).",
            env.name,
        )
    } else {
        format!(
            "FAIL at a {margin} % margin (a choice, not a standard): {}.",
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
        // the given tolerances are the tuning's too: its designs clear every band over
        // the box about them
        let tolerances: Vec<crate::tune::Tolerance> = if s.given {
            s.varies
                .iter()
                .zip(s.vary_texts)
                .map(|(v, t)| crate::tune::Tolerance {
                    vary: v.clone(),
                    relative: t.contains('%'),
                })
                .collect()
        } else {
            Vec::new()
        };
        let opts = crate::tune::TuneOptions {
            margin: s.margin,
            tolerances,
            ..Default::default()
        };
        let t = crate::tune::tune(s.sys, s.tune_varies, &lines, &opts)
            .map_err(|e| e.context(TUNING))?;
        report.add_data("tuning", &t)?;
        report.add_data("tuning_clearance", &opts.clearance)?;
        let baseline: serde_json::Map<String, serde_json::Value> = s
            .tune_varies
            .iter()
            .map(|v| (v.name.clone(), s.sys.param(v.param).into()))
            .collect();
        report.add_data("tuning_baseline", &baseline)?;
        let d = &report.sidecar;
        let mut section = Section::new("tuning", "Tuning proposal").prose(format!(
            "The smallest change Σ((p − p0)/p0)² of {} within the given ranges that puts every mode outside every line of {} by {} % (plus a relative clearance of {}){}, one design for each way of placing the modes between the lines, each verified by a full modal analysis and margins check. {} design(s) found, {} placement(s) infeasible.",
            s.tune_varies.iter().map(|v| v.name.as_str()).collect::<Vec<_>>().join(", "),
            env.name,
            d.inline("margins/margin_pct", Digits::Fixed(1)),
            d.inline("tuning_clearance", Digits::Sci(0)),
            if s.given {
                format!(
                    " over the whole tolerance box about the design ({}), as the margins section checks the baseline",
                    s.vary_texts.join(", ")
                )
            } else {
                " at the nominal design (no tolerances given: with --vary the designs clear the bands over the tolerance box too)".to_string()
            },
            t.designs.len(),
            t.infeasible.len()
        ));
        for (k, design) in t.designs.iter().enumerate() {
            let mut rows = Vec::new();
            for (name, _) in &design.parameters {
                let key = super::escape_key(name);
                rows.push(vec![
                    Cell::text(name),
                    d.num(format!("tuning_baseline/{key}"), Digits::Sig(7)),
                    d.num(
                        format!("tuning/designs/{k}/parameters/{key}"),
                        Digits::Sig(7),
                    ),
                    Cell::text((s.units)(name)),
                ]);
            }
            for (name, _) in &design.modes {
                rows.push(vec![
                    Cell::text(format!("{name} ω_n")),
                    Cell::text(""),
                    d.num(
                        format!("tuning/designs/{k}/modes/{}", super::escape_key(name)),
                        Digits::Fixed(4),
                    ),
                    Cell::text("rad/s"),
                ]);
                if design
                    .tolerance_intervals
                    .as_ref()
                    .is_some_and(|iv| iv.contains_key(name))
                {
                    for (end, label) in [(0, "lowest"), (1, "highest")] {
                        rows.push(vec![
                            Cell::text(format!("{name} ω_n, {label} over the tolerances")),
                            Cell::text(""),
                            d.num(
                                format!(
                                    "tuning/designs/{k}/tolerance_intervals/{}/{end}",
                                    super::escape_key(name)
                                ),
                                Digits::Fixed(4),
                            ),
                            Cell::text("rad/s"),
                        ]);
                    }
                }
            }
            let names: Vec<&str> = design.parameters.keys().map(|k| k.as_str()).collect();
            let sets: Vec<String> = design
                .parameters
                .iter()
                .map(|(n, v)| format!("--set {n}={}", v.as_f64().unwrap_or(f64::NAN)))
                .chain(
                    s.vary_texts
                        .iter()
                        .filter(|_| s.given)
                        .map(|t| format!("--vary {}", shell_word(t))),
                )
                .collect();
            let mut notes = Vec::new();
            for (j, b) in design.at_bounds.iter().enumerate() {
                notes.push(format!(
                    "{} is at the {} bound of its range ({}): a wider range would allow a smaller change.",
                    b.param,
                    b.bound,
                    format!(
                        "{} {}",
                        d.inline(format!("tuning/designs/{k}/at_bounds/{j}/value"), Digits::Sig(6)),
                        (s.units)(&b.param)
                    )
                    .trim_end()
                ));
            }
            if design.frf_peaks_clear == Some(false) {
                notes.push(format!(
                    "Note: a peak of the design's linear frequency response ({} rad/s) lies within the margin of a line although every mode clears it (a response peak is not at ω_n); ask a larger margin if the peaks must clear too.",
                    (0..design.frf_peaks_rad_s.len())
                        .map(|i| d.inline(
                            format!("tuning/designs/{k}/frf_peaks_rad_s/{i}"),
                            Digits::Fixed(4)
                        ))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
            section = section
                .table(Table {
                    caption: format!(
                        "Design {} (cost {}; closest separation {} %)",
                        k + 1,
                        d.inline(format!("tuning/designs/{k}/cost"), Digits::Sci(4)),
                        d.inline(format!("tuning/designs/{k}/closest_pct"), Digits::Fixed(2)),
                    ),
                    columns: cols(&[("", ""), ("baseline", ""), ("design", ""), ("unit", "")]),
                    rows,
                })
                .prose(format!("Check design {}:", k + 1))
                .code(format!(
                    "detune margins {} --environment {} --margin {}% {}",
                    (s.command_words)(&names),
                    shell_word(&env.id),
                    s.margin * 100.0,
                    sets.join(" ")
                ));
            for n in notes {
                section = section.prose(n);
            }
        }
        for (i, inf) in t.infeasible.iter().enumerate() {
            section = section.prose(format!("Infeasible: {}", blocked_text(d, i, inf)));
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
            {
                let (inert, unsolved): (Vec<_>, Vec<_>) =
                    s.dropped.iter().partition(|(_, why)| why == INERT);
                let mut text = String::new();
                if !unsolved.is_empty() {
                    text += &format!(
                    " Left out, because ±10 % of them cannot be solved: {}.",
                    unsolved
                        .iter()
                        .map(|(n, why)| {
                            let first = why.lines().next().unwrap_or("");
                            format!("{n} ({})", first.split("; last pose").next().unwrap_or(first))
                        })
                        .collect::<Vec<_>>()
                        .join("; ")
                    );
                }
                if !inert.is_empty() {
                    text += &format!(
                        " Left out, because {}: {}.",
                        INERT.replace(" it ", " them "),
                        inert.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>().join(", ")
                    );
                }
                text
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
                "{}: ω_n = {} rad/s, ζ = {} — cases",
                m.name,
                d.inline(
                    format!("sensitivity/modes/{mi}/omega_n_rad_s"),
                    Digits::Fixed(4)
                ),
                d.inline(
                    format!("sensitivity/modes/{mi}/damping_ratio"),
                    Digits::Fixed(4)
                ),
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
                "{}: derivatives (per SI unit of the parameter); worst case {}–{} rad/s",
                m.name,
                d.inline(
                    format!("sensitivity/modes/{mi}/worst_case/min_rad_s"),
                    Digits::Fixed(4)
                ),
                d.inline(
                    format!("sensitivity/modes/{mi}/worst_case/max_rad_s"),
                    Digits::Fixed(4)
                ),
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
    let svg =
        crate::output::sensitivity::tornado_svg(study, "Change of each mode's ω_n per parameter")
            .map_err(|e| crate::diag::Error::io("report.html", e))?;
    Ok(section.figure(
        "Tornado chart: the change of ω_n (%) at each parameter's lowest and highest case, widest on top.",
        svg,
    ))
}

/// The model's forcing amplitude parameter and a copy of the system with it at 1 (SI): the
/// report's unit forcing when the model's own is zero (`frf/unit_forcing`), else the
/// non-zero parameter whose zero leaves no harmonic forcing.
fn unit_forced(report: &Report, sys: &System) -> Option<(usize, System)> {
    if let Some(name) = report
        .sidecar
        .get("frf/unit_forcing/param")
        .and_then(|v| v.as_str())
    {
        let i = sys.param_index(name)?;
        return Some((i, sys.with_param(i, 1.0).ok()?));
    }
    if let Some(i) = sys.forcing_amplitude_param() {
        return Some((i, sys.with_param(i, 1.0).ok()?));
    }
    let f = sys.forcing_param()?;
    let probe = |s: &System| -> bool {
        let Ok(ma) = crate::linear::modal_analysis(s, None) else {
            return false;
        };
        let w = s.param(f).abs().max(1.0);
        let mut at = s.clone();
        at.set_param(f, w).is_ok()
            && crate::linear::harmonic_forcing(&at, &ma.equilibrium, &ma.rows, "ω", w).is_ok()
    };
    (0..sys.param_names().len())
        .filter(|&i| i != f && sys.param(i) != 0.0 && sys.param_definition(i).is_none())
        .find(|&i| sys.with_param(i, 0.0).is_ok_and(|z| !probe(&z)))
        .and_then(|i| Some((i, sys.with_param(i, 1.0).ok()?)))
}

/// Each angle coordinate's amplitude at each tone of the environment's sine-on-random
/// profile (|H| × level) and its RMS over the random floor (√∫|H|²·PSD df), with |H| the
/// linear response per unit of the forcing amplitude parameter.
fn profile_section(
    report: &mut Report,
    s: &Studies,
    env: &Environment,
    profile: &crate::environment::Profile,
    ma: &crate::linear::ModalAnalysis,
) -> Result<Section> {
    let mut section = Section::new("profile", "Response to the vibration profile").prose(format!(
        "The levels are the environment file's ({}; source: {}), in {} (the PSD in {}²/Hz); detune does not supply levels.",
        env.name,
        profile.source.as_deref().unwrap_or("not given"),
        profile.unit,
        profile.unit
    ));
    let Some((amp, unit_sys)) = unit_forced(report, s.sys) else {
        return Ok(section.prose(
            "The model's forcing amplitude parameter could not be identified (no parameter whose value makes the harmonic forcing), so the response to the profile is not computed.",
        ));
    };
    let amp_name = s.sys.param_names()[amp].clone();
    let Some(f) = unit_sys.forcing_param() else {
        return Ok(section);
    };
    let unit_ma = crate::linear::modal_analysis(&unit_sys, None)?;
    let coords: Vec<usize> = (0..unit_sys.n())
        .filter(|&i| unit_sys.is_angle(i))
        .collect();
    let coords = if coords.is_empty() {
        (0..unit_sys.n()).collect()
    } else {
        coords
    };
    let at = std::cell::RefCell::new(unit_sys.clone());
    let cache: std::cell::RefCell<Vec<(f64, Vec<f64>)>> = std::cell::RefCell::new(Vec::new());
    let gains = |w: f64| -> Vec<f64> {
        if let Some((_, g)) = cache.borrow().iter().find(|(x, _)| *x == w) {
            return g.clone();
        }
        let mut a = at.borrow_mut();
        let g = (|| -> Option<Vec<f64>> {
            a.set_param(f, w).ok()?;
            let forcing =
                crate::linear::harmonic_forcing(&a, &unit_ma.equilibrium, &unit_ma.rows, "ω", w)
                    .ok()?;
            let y = unit_ma.linearization.response(w, &forcing).ok()?;
            Some(coords.iter().map(|&i| y[i].norm()).collect())
        })()
        .unwrap_or_else(|| vec![f64::NAN; coords.len()]);
        let mut c = cache.borrow_mut();
        if c.len() > 4096 {
            c.clear();
        }
        c.push((w, g.clone()));
        g
    };
    let hints: Vec<f64> = ma.modes.iter().map(|m| m.omega_n_rad_s).collect();
    #[derive(serde::Serialize)]
    struct ProfileJson {
        amplitude_parameter: String,
        responses: Vec<ProfileResponse>,
    }
    #[derive(serde::Serialize)]
    struct ProfileResponse {
        response: String,
        tones: Vec<crate::environment::ToneResponse>,
        random_rms: f64,
    }
    let responses: Vec<ProfileResponse> = coords
        .iter()
        .enumerate()
        .map(|(k, &i)| ProfileResponse {
            response: unit_sys.coordinates[i].clone(),
            tones: crate::environment::tone_responses(profile, |w| gains(w)[k]),
            random_rms: crate::environment::random_rms(profile, |w| gains(w)[k], &hints),
        })
        .collect();
    report.add_data(
        "profile",
        &ProfileJson {
            amplitude_parameter: amp_name.clone(),
            responses,
        },
    )?;
    let d = &report.sidecar;
    let n = d
        .get("profile/responses")
        .and_then(|v| v.as_array())
        .map_or(0, |a| a.len());
    let mut rows = Vec::new();
    for r in 0..n {
        let name = d.text(&format!("profile/responses/{r}/response"));
        let tones = d
            .get(&format!("profile/responses/{r}/tones"))
            .and_then(|v| v.as_array())
            .map_or(0, |a| a.len());
        for t in 0..tones {
            let key = |f: &str| format!("profile/responses/{r}/tones/{t}/{f}");
            rows.push(vec![
                name.clone(),
                d.text(&key("tone")),
                d.num(key("omega_rad_s"), Digits::Fixed(3)),
                d.num(key("level"), Digits::Sig(4)),
                d.num(key("gain"), Digits::Sci(4)),
                d.num(key("amplitude"), Digits::Sci(4)),
            ]);
        }
        rows.push(vec![
            name,
            Cell::text("random floor (RMS)"),
            Cell::text(""),
            Cell::text(""),
            Cell::text(""),
            d.num(format!("profile/responses/{r}/random_rms"), Digits::Sci(4)),
        ]);
    }
    section = section
        .prose(format!(
            "|H| is each coordinate's linear response per unit of `{amp_name}` (SI), the levels being converted to `{amp_name}`'s unit{}. Amplitudes in rad (angles) or m.",
            if profile.is_acceleration() { " (acceleration levels by 1/ω², PSDs by 1/ω⁴)" } else { "" }
        ))
        .table(Table {
            caption: "Amplitude at each tone and RMS over the random floor".into(),
            columns: cols(&[
                ("response", ""),
                ("tone", ""),
                ("ω", "rad/s"),
                ("level", &profile.unit),
                ("|H| per unit forcing", ""),
                ("amplitude", ""),
            ]),
            rows,
        });
    Ok(section)
}

/// Why the `i`-th infeasible placement of the tuning was not met, in the library's words
/// ([`crate::tune::Blocked::words`]) with its numbers keyed into the sidecar
/// (`tuning/infeasible/{i}/blocked/...`).
fn blocked_text(d: &super::Sidecar, i: usize, inf: &crate::tune::Infeasible) -> String {
    match &inf.blocked {
        Some(b) => b.words(&|field, _, decimals| {
            d.inline(
                format!("tuning/infeasible/{i}/blocked/{field}"),
                Digits::Fixed(decimals),
            )
        }),
        None => inf.reason.clone(),
    }
}
