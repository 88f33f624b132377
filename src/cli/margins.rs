//! `detune margins`: does every mode clear every forcing line of an environment by the
//! required margin? Exit 0 when it does, 3 when a mode fails ([`super::Outcome`]).

use super::args::ModelArgs;
use super::{Outcome, print_json};
use clap::Args;
use detune::diag::{Error, Result};
use detune::environment::{Environment, ForcingLine, resolve};
use detune::linear::modal_analysis;
use detune::linear::sensitivity::UnstableCorner;
use detune::margins::{MarginCheck, MarginRow, ModeInterval, Requirement, Side, UnstableMode};
use detune::output::Provenance;
use detune::output::margins::{MarginsReport, write_margins_csv};
use detune::output::units::FreqUnit;
use std::f64::consts::TAU;

/// The units of `margins --json` (its rows' keys, the CSV's columns).
pub const MARGIN_UNITS: [(&str, &str); 20] = [
    ("margin_pct", "%"),
    ("omega_n_rad_s", "rad/s"),
    ("min_rad_s", "rad/s"),
    ("max_rad_s", "rad/s"),
    ("damping_ratio", "1"),
    ("line_rad_s", "rad/s"),
    ("band_lo_rad_s", "rad/s"),
    ("band_hi_rad_s", "rad/s"),
    ("separation_pct", "%"),
    ("required_pct", "%"),
    ("omega_rad_s", "rad/s"),
    ("from_rad_s", "rad/s"),
    ("to_rad_s", "rad/s"),
    ("freq_hz", "Hz"),
    ("rpm", "rpm"),
    ("blades", "1"),
    ("multiple", "1"),
    ("eigenvalue", "1/s"),
    ("growth_rate_1_s", "1/s"),
    ("omega_d_rad_s", "rad/s"),
];

#[derive(Args)]
pub struct MarginsArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Forcing environment: a shipped one's id or name, case-insensitive (UH-60, UH-1N,
    /// H135, AH-64), or the path of an environment file (docs/environments.md).
    #[arg(long, value_name = "NAME|PATH")]
    pub environment: String,
    /// Required separation of every mode from every line, |ω_mode − ω_line| / ω_line:
    /// "10%" or 0.1. Your choice, not a standard.
    #[arg(
        long,
        default_value = "10%",
        value_name = "PCT",
        allow_hyphen_values = true
    )]
    pub margin: String,
    /// Scale the required margin by each mode's amplification factor ≈ 1/(2ζ) (a
    /// heuristic, API 684-style, not a standard: see docs/environments.md).
    #[arg(long)]
    pub damping_aware: bool,
    /// Vary a parameter (as in `sensitivity`: `k_fs=±10%`, `k_fs=±0.5 N/m`, a list):
    /// each mode's whole tolerance interval must clear. Repeatable.
    #[arg(long, value_name = "NAME=CHANGE", allow_hyphen_values = true)]
    pub vary: Vec<String>,
    /// Print JSON on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
    /// CSV: one row per mode × line, the JSON rows' keys as columns.
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    pub output: Option<String>,
    #[command(flatten)]
    pub freq: super::args::FreqUnitArg,
}

pub fn run(a: MarginsArgs) -> Result<Outcome> {
    let margin = parse_margin(&a.margin)?;
    let env = resolve(&a.environment)?;
    // the output is neither the model file nor the environment file (nor a link to one)
    let mut inputs = vec![("model file", a.model.model.as_str())];
    if !env.shipped {
        inputs.push(("environment file", env.file.as_str()));
    }
    let outputs = detune::output::OutputSet::plan(&inputs, &[a.output.as_deref()])?;
    let (model, sys) = a.model.load()?;
    let modal = modal_analysis(&sys, None)?;
    let names = detune::linear::sensitivity::mode_names(&sys, &modal);
    let (points, skipped) = detune::margins::mode_points_named(&modal, &names);
    let (modes, unstable_corners) = intervals(&model, &sys, &a.vary, points)?;
    let rule = if a.damping_aware {
        Requirement::DampingAware
    } else {
        Requirement::Fixed
    };
    let lines = env.forcing_lines();
    // an unstable point of the tolerance box fails the check, as an unstable nominal
    // design does
    let check = detune::margins::check_design(&modal, &names, &modes, &lines, margin, rule)?
        .with_unstable_corners(unstable_corners);
    let fu = a.freq.freq_unit;
    if let Some(o) = &a.output {
        write_margins_csv(o, &check)?;
        outputs.commit()?;
        eprintln!("wrote {o}");
    }
    if a.json {
        let provenance = Provenance::of(&model);
        let units = detune::output::units::Units::new().with_all(MARGIN_UNITS);
        let warnings = if a.vary.is_empty() {
            Vec::new()
        } else {
            // (the --vary were parsed, and the warnings printed, by `intervals`)
            let vs = super::args::varies_quietly(&model, &sys, &a.vary)?;
            super::args::damping_warnings(&model, &sys, &vs)
        };
        print_json(&super::Warned {
            doc: detune::output::units::WithUnits {
                doc: MarginsReport::new(&check, &env, &skipped, &provenance),
                units: &units,
            },
            warnings: super::args::damping_warning_values(&warnings),
        });
        for s in summary(&check, &env, fu) {
            eprintln!("{s}");
        }
    } else {
        print_environment(&env, &lines, fu);
        if modal.linearization.dof() == 0 {
            println!(
                "\n{}, nothing can resonate with a forcing line",
                detune::linear::no_modes_words(&sys)
            );
        } else if modes.is_empty() {
            println!("\nno oscillatory modes: nothing can resonate with a forcing line");
        }
        for s in &skipped {
            let lam = s.eigenvalue;
            let lam = if lam.abs() < 1e15 {
                format!("{lam:.6}")
            } else {
                detune::diag::num(lam)
            };
            println!("note: λ = {lam} 1/s left out: {}", s.reason);
        }
        print_table(&check, fu);
        println!();
        for s in summary(&check, &env, fu) {
            println!("{s}");
        }
    }
    Ok(if check.pass {
        Outcome::Passed
    } else {
        Outcome::CheckFailed
    })
}

/// The modes as checked: points (the nominal design), or with `--vary` each mode's
/// interval over the whole tolerance box (the sensitivity study's worst case: corners
/// evaluated by full modal analyses, see `detune sensitivity`).
///
/// With the points of the box whose equilibrium is unstable (corners, interior samples,
/// and the cases inside the box): each fails the check.
fn intervals(
    model: &detune::Model,
    sys: &detune::System,
    vary: &[String],
    points: Vec<ModeInterval>,
) -> Result<(Vec<ModeInterval>, Vec<UnstableCorner>)> {
    if vary.is_empty() {
        return Ok((points, Vec::new()));
    }
    let vs = super::args::varies(model, sys, vary)?;
    let study = detune::linear::sensitivity::sensitivity(sys, &vs, None, None)?;
    // the unstable points fail the check (named in its summary), no longer only a warning;
    // a box with unsolved points is refused
    let unstable = detune::margins::box_unstable_points(&study, &vs)?;
    for m in &study.modes {
        if !m.worst_case.non_monotone.is_empty() {
            eprintln!(
                "warning: {}'s ω_n is not monotonic in {} over the range: its interval includes interior samples but is an estimate between them",
                m.name,
                m.worst_case.non_monotone.join(", ")
            );
        }
    }
    Ok((detune::margins::with_intervals(points, &study), unstable))
}

/// `--margin`: "10%", "10 %" or a fraction 0.1; above 0 and below 100 %.
pub fn parse_margin(text: &str) -> Result<f64> {
    let t = text.trim();
    let bad =
        |message: String, help: &str| Error::request(format!("--margin {text}: {message}"), help);
    let (number, percent) = match t.strip_suffix('%') {
        Some(n) => (n.trim(), true),
        None => (t, false),
    };
    let Ok(x) = number.parse::<f64>() else {
        return Err(bad(
            "expected a percentage or a fraction".into(),
            "for example --margin 10% or --margin 0.1",
        ));
    };
    let m = if percent { x / 100.0 } else { x };
    if !m.is_finite() || m <= 0.0 {
        return Err(bad(
            "a margin must be above 0".into(),
            "give the separation you require, e.g. --margin 10% (the default; your choice, not a standard)",
        ));
    }
    if m >= 1.0 {
        let help = if percent {
            "a separation of 100 % or more from every line cannot be met by a mode below it: give e.g. --margin 10%".to_string()
        } else {
            format!("a number without % is a fraction: did you mean --margin {x}%?")
        };
        return Err(bad(format!("{:.4} % is 100 % or more", 100.0 * m), &help));
    }
    Ok(m)
}

/// ω in rad/s with Hz and rpm.
fn freq(w: f64) -> String {
    format!(
        "{w:.4} rad/s = {:.4} Hz = {:.1} rpm",
        w / TAU,
        w * 60.0 / TAU
    )
}

fn print_environment(env: &Environment, lines: &[ForcingLine], fu: FreqUnit) {
    use detune::output::units::text_in_unit;
    println!(
        "environment: {} ({}{})",
        env.name,
        env.file,
        if env.shipped {
            ", shipped with detune"
        } else {
            ""
        }
    );
    println!("  source: {}", text_in_unit(&env.source, fu));
    if let Some(n) = &env.notes {
        println!("  note: {}", text_in_unit(n, fu));
    }
    println!("forcing lines:");
    for l in lines {
        let band = if l.band_lo_rad_s < l.band_hi_rad_s {
            format!(
                "  band {:.4}–{:.4} rad/s ({:.4}–{:.4} Hz)",
                l.band_lo_rad_s,
                l.band_hi_rad_s,
                l.band_lo_rad_s / TAU,
                l.band_hi_rad_s / TAU
            )
        } else {
            String::new()
        };
        let from = match l.rotor {
            Some(detune::environment::RotorKind::Main) => "main rotor",
            Some(detune::environment::RotorKind::Tail) => "tail rotor",
            None => "extra",
        };
        println!("  {:<8} {from:<10} {}{band}", l.label, freq(l.omega_rad_s));
    }
}

fn print_table(check: &MarginCheck, fu: FreqUnit) {
    let sym = fu.symbol();
    // the companion column: Hz, or rad/s when the table is in Hz
    let cu = fu.companion();
    let ctitle = match cu {
        FreqUnit::Hertz => "f [Hz]",
        _ => "ω [rad/s]",
    };
    println!(
        "\nrequired separation: {} % (your choice, not a standard){}",
        check.margin_pct,
        match check.requirement {
            Requirement::Fixed => String::new(),
            Requirement::DampingAware => "; DAMPING-AWARE (heuristic, API 684-style, not a standard): scaled by 1 − 1/(AF − 1.5), AF = 1/(2ζ); none below AF = 2.5".to_string(),
        }
    );
    if check.rows.is_empty() {
        // no oscillatory mode: no table (the verdict says so)
        return;
    }
    let varied = check.rows.iter().any(|r| r.min_rad_s < r.max_rad_s);
    let mw = check
        .rows
        .iter()
        .map(|r| r.mode.chars().count())
        .max()
        .unwrap_or(4)
        .max(4);
    println!(
        "{:<mw$} {:>12} {:>9} {:>8} {}{:<8} {:>12} {:>9} {:>12} {:>8} {:>11} {:>5}",
        "mode",
        format!("{} [{sym}]", super::modes::natural(fu, "n")),
        if cu == FreqUnit::Hertz {
            "f [Hz]"
        } else {
            "ω_n [rad/s]"
        },
        "ζ",
        if varied {
            format!("{:>25} ", format!("interval [{sym}]"))
        } else {
            String::new()
        },
        "line",
        // a line's frequency: ω in rad/s, f (a cycle rate) in Hz or rpm
        format!("{} [{sym}]", fu.rate()),
        ctitle,
        "separation",
        "side",
        "required",
        ""
    );
    for r in &check.rows {
        let interval = if varied {
            format!(
                "{:>25} ",
                format!("{:.4}–{:.4}", fu.of(r.min_rad_s), fu.of(r.max_rad_s))
            )
        } else {
            String::new()
        };
        // a band in both columns (rad/s and Hz), a line as one value in each
        let (line_w, line_f) = if r.band_lo_rad_s < r.band_hi_rad_s {
            (
                format!(
                    "{:.2}–{:.2}",
                    fu.of(r.band_lo_rad_s),
                    fu.of(r.band_hi_rad_s)
                ),
                format!(
                    "{:.3}–{:.3}",
                    cu.of(r.band_lo_rad_s),
                    cu.of(r.band_hi_rad_s)
                ),
            )
        } else {
            (
                format!("{:.4}", fu.of(r.line_rad_s)),
                format!("{:.4}", cu.of(r.line_rad_s)),
            )
        };
        println!(
            "{:<mw$} {:>12.4} {:>9.4} {:>8.4} {interval}{:<8} {:>12} {:>9} {:>10.2} % {:>8} {:>9.2} % {:>5}",
            r.mode,
            fu.of(r.omega_n_rad_s),
            cu.of(r.omega_n_rad_s),
            r.damping_ratio,
            r.line,
            line_w,
            line_f,
            r.separation_pct,
            r.side.as_str(),
            r.required_pct,
            if r.pass { "pass" } else { "FAIL" }
        );
    }
}

/// A mode as a summary names it: `mode 2 (26.53 rad/s)`, or its interval.
fn mode_words(r: &MarginRow, fu: FreqUnit) -> String {
    let sym = fu.symbol();
    if r.min_rad_s < r.max_rad_s {
        format!(
            "{} ({:.2}–{:.2} {sym})",
            r.mode,
            fu.of(r.min_rad_s),
            fu.of(r.max_rad_s)
        )
    } else {
        format!("{} ({})", r.mode, fu.show(r.omega_n_rad_s, 2))
    }
}

/// A line as a summary names it: `UH-60 1P (27.02 rad/s)`, or its band.
fn line_words(r: &MarginRow, env: &Environment, fu: FreqUnit) -> String {
    if r.band_lo_rad_s < r.band_hi_rad_s {
        format!(
            "{} {} ({:.2}–{:.2} {})",
            env.id,
            r.line,
            fu.of(r.band_lo_rad_s),
            fu.of(r.band_hi_rad_s),
            fu.symbol()
        )
    } else {
        format!("{} {} ({})", env.id, r.line, fu.show(r.line_rad_s, 2))
    }
}

/// One sentence per failing row, worst first, then the verdict.
fn summary(check: &MarginCheck, env: &Environment, fu: FreqUnit) -> Vec<String> {
    let mode_words = |r: &MarginRow| mode_words(r, fu);
    let line_words = |r: &MarginRow, env: &Environment| line_words(r, env, fu);
    let mut out: Vec<String> = check.unstable.iter().map(unstable_words).collect();
    out.extend(check.unstable_corners.iter().map(corner_words));
    let failures = check.failures();
    for r in &failures {
        let needs = format!("needs {}", pct(r.required_pct));
        out.push(match r.side {
            Side::Overlap => format!("{} overlaps {}: {needs}", mode_words(r), line_words(r, env)),
            side => format!(
                "{} is {} {} {}: {needs}",
                mode_words(r),
                pct(r.separation_pct),
                side.as_str(),
                line_words(r, env)
            ),
        });
    }
    // what an unstable verdict adds about the separations
    let also_close = || {
        if failures.is_empty() {
            String::new()
        } else {
            format!(
                "; and {} of {} mode–line pairs are closer than required (margin {}, your choice, not a standard)",
                failures.len(),
                check.rows.len(),
                pct(check.margin_pct)
            )
        }
    };
    if !check.unstable.is_empty() {
        out.push(format!(
            "FAIL: the equilibrium is unstable ({} growing mode{}): a design that leaves its equilibrium cannot pass, whatever its separations{}",
            check.unstable.len(),
            if check.unstable.len() == 1 { "" } else { "s" },
            also_close()
        ));
    } else if !check.unstable_corners.is_empty() {
        let n = check.unstable_corners.len();
        out.push(format!(
            "FAIL: the tolerance box reaches unstable designs ({n} point{} of it, named above): a part within tolerance can leave its equilibrium, whatever the separations{}",
            if n == 1 { "" } else { "s" },
            also_close()
        ));
    } else if check.rows.is_empty() {
        out.push("PASS: no oscillatory mode to check".into());
    } else if failures.is_empty() {
        let mut s = format!(
            "PASS: every mode clears every line of {} by the required {} (your choice, not a standard)",
            env.id,
            pct(check.margin_pct)
        );
        if check.requirement == Requirement::DampingAware {
            s.push_str(", damping-aware (heuristic)");
        }
        if let Some(c) = check.closest() {
            s.push_str(&format!(
                "; closest: {} is {} {} {}",
                mode_words(c),
                pct(c.separation_pct),
                c.side.as_str(),
                line_words(c, env)
            ));
        }
        out.push(s);
    } else {
        out.push(format!(
            "FAIL: {} of {} mode–line pairs are closer than required (margin {}, your choice, not a standard)",
            failures.len(),
            check.rows.len(),
            pct(check.margin_pct)
        ));
    }
    out
}

use detune::linear::rate_text;

/// An unstable mode in words: which mode grows, and how fast.
pub fn unstable_words(u: &UnstableMode) -> String {
    if u.omega_d_rad_s == 0.0 {
        format!(
            "{} is UNSTABLE: a divergent mode, growth rate Re λ = {} 1/s (the equilibrium is unstable: it grows as e^({}·t) and does not oscillate)",
            u.mode,
            rate_text(u.growth_rate_1_s, 4, false),
            rate_text(u.growth_rate_1_s, 4, false)
        )
    } else {
        format!(
            "{} is UNSTABLE: an oscillation that grows, growth rate Re λ = {} 1/s at ω_d = {:.4} rad/s (negative damping: the equilibrium is unstable)",
            u.mode,
            rate_text(u.growth_rate_1_s, 4, false),
            u.omega_d_rad_s
        )
    }
}

/// An unstable point of the tolerance box in words: where, and how fast it grows.
pub fn corner_words(c: &UnstableCorner) -> String {
    format!(
        "the tolerance box's {} {} is UNSTABLE: {}",
        if c.corner { "corner" } else { "point" },
        c.label,
        if c.omega_d_rad_s > 0.0 {
            format!(
                "an oscillation grows as e^({}·t) at ω_d = {:.4} rad/s",
                rate_text(c.growth_rate_1_s, 4, true),
                c.omega_d_rad_s
            )
        } else {
            format!(
                "a mode diverges as e^({}·t) without oscillating",
                rate_text(c.growth_rate_1_s, 4, true)
            )
        }
    )
}

/// A percentage: whole as given (10 %), else to 0.1 (1.8 %), or 0.01 below 0.1 %.
fn pct(x: f64) -> String {
    if x == x.trunc() {
        format!("{x:.0} %")
    } else if x.abs() >= 0.1 {
        format!("{x:.1} %")
    } else {
        format!("{x:.2} %")
    }
}
