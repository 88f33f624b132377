//! `detune sensitivity`: how each mode moves with each varied parameter: the cases (the
//! paper's Tables 2–3), analytic derivatives with finite-difference checks, the worst
//! case over the tolerance box, a tornado chart.

use super::args::{ModelArgs, Tolerances, varies};
use super::print_json;
use clap::{Args, ValueEnum};
use detune::diag::{Error, Result};
use detune::linear::sensitivity::{Check, Sensitivity, sensitivity};
use detune::output::sensitivity::{
    ParameterJson, SensitivityReport, write_sensitivity_csv, write_tornado,
};
use detune::output::units::FreqUnit;
use detune::output::{Provenance, check_outputs};

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Modes of the linearization (fast).
    Linear,
    /// Peaks of stepped-sine sweeps of the nonlinear model (slow).
    Sweep,
    /// Both.
    Both,
}

#[derive(Args)]
pub struct SensitivityArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// A varied parameter, NAME=CHANGE: `k_fs=±10%` (or `+-10%`), `k_fs=±0.5 N/m`,
    /// `k_fs=80%..120%`, or a list `k_fs=1.1e5,1.4e5`. Repeatable, each parameter once.
    #[arg(
        long = "vary",
        value_name = "NAME=CHANGE",
        allow_hyphen_values = true,
        required = true
    )]
    pub vary: Vec<String>,
    /// How the resonances are found in each case.
    #[arg(long, value_enum, default_value_t = Method::Linear)]
    pub method: Method,
    /// The response whose stepped-sine peaks are found with --method sweep|both
    /// [default: the first angle coordinate].
    #[arg(long, value_name = "NAME")]
    pub response: Option<String>,
    /// The sweeps' integrator and tolerances (--method sweep|both).
    #[command(flatten)]
    pub tol: Tolerances,
    /// --method sweep|both: append each steady state of the cases' sweeps to FILE as it
    /// is computed; the same command with the same FILE resumes, skipping what is done
    /// (the outputs are identical to an uninterrupted run's). A FILE of another model,
    /// --vary, --set or options, or of another command, is refused.
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<String>,
    /// Print JSON on standard output.
    #[arg(long)]
    pub json: bool,
    /// CSV: one row per mode and case (the baseline first).
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    pub output: Option<String>,
    /// SVG: a tornado chart of the change of each mode's ω_n per parameter.
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<String>,
    #[command(flatten)]
    pub freq: super::args::FreqUnitArg,
    #[command(flatten)]
    pub plot_size: super::args::PlotSize,
}

pub fn run(a: SensitivityArgs) -> Result<()> {
    let (model, sys) = a.model.load()?;
    let size = a.plot_size.check(a.plot.as_deref(), a.output.as_deref())?;
    let outputs = check_outputs(
        &model.source.path,
        &[a.output.as_deref(), a.plot.as_deref()],
    )?;
    if let Some(c) = &a.checkpoint {
        if a.method == Method::Linear {
            return Err(Error::request(
                format!("--checkpoint {c}: --method linear has no sweeps to resume"),
                "--checkpoint goes with --method sweep|both",
            ));
        }
        if [a.output.as_deref(), a.plot.as_deref()]
            .into_iter()
            .flatten()
            .any(|o| detune::output::commit::same_file(o, c))
        {
            return Err(Error::request(
                format!("--checkpoint {c} is also an output"),
                "give the checkpoint its own file (e.g. sensitivity.ckpt)",
            ));
        }
    }
    let vs = varies(&model, &sys, &a.vary)?;
    let response = match &a.response {
        Some(r) => {
            sys.output(r)?;
            r.clone()
        }
        None => sys.coordinates[detune::linear::default_reference(&sys)].clone(),
    };
    if a.method != Method::Linear && sys.forcing_param().is_none() {
        return Err(Error::request(
            "--method sweep|both: the model has no forcing frequency to sweep",
            "add `forcing_frequency = \"omega\"` to [model], or use --method linear",
        ));
    }
    // A case with no equilibrium near the baseline's: the change takes the mechanism
    // past a fold. The statics' generic advice (another initial pose) is wrong here.
    let mut study = sensitivity(&sys, &vs, None, None).map_err(|e| match &e {
        Error::Failed {
            failure: f @ detune::failure::Failure::NoEquilibrium { .. },
            context,
            ..
        } => Error::numerical(
            format!("{}: {f}", context.join(": ")),
            // the advice tune, margins and report give (naming the parameter)
            super::advice::vary_advice(f, context).unwrap_or_else(|| {
                "narrow the range of that --vary: each case starts from the baseline's equilibrium, and none near it means the change takes the mechanism past a fold".into()
            }),
        ),
        _ => e,
    })?;
    // the nominal design first: an unstable baseline makes every case's change a change
    // of frequencies that are not resonances (JSON: `baseline_unstable`)
    let baseline = baseline_warning(&study);
    if let Some(w) = &baseline {
        eprintln!("warning: {w}");
    }
    if study.modes.is_empty() {
        return Err(nothing_to_vary(&sys, &study));
    }
    let watch = super::StiffWatch::new(
        &sys.forcing_param()
            .map(|f| sys.param_names()[f].clone())
            .unwrap_or_default(),
    );
    if a.method != Method::Linear {
        super::interrupt_on_ctrl_c();
        let cases: usize = 1 + vs.iter().map(|v| v.cases.len()).sum::<usize>();
        let bar = super::progress_bar(
            cases as u64,
            "stepped-sine sweeps {bar:30} {pos}/{len} cases, eta {eta}",
        );
        let steady = a.tol.steady();
        detune::linear::sensitivity::add_sweep_peaks(
            &sys,
            &vs,
            &mut study,
            &response,
            &steady,
            &|done, _| bar.set_position(done as u64),
            &super::INTERRUPTED,
            &|case, at| watch.found(&format!("the sweep of {case}"), at, &bar),
            &|opts, runs| open_checkpoint(&a, &model, &vs, &response, opts, runs),
        )
        .map_err(|e| {
            if let (Some(c), Some(detune::failure::Failure::StudyInterrupted { .. })) =
                (&a.checkpoint, e.failure())
            {
                eprintln!(
                    "the steady states computed are in the checkpoint {c}: the same command resumes from them"
                );
            }
            if let Error::Numerical { .. } | Error::Failed { .. } = e {
                e
            } else {
                e.context(&format!(
                    "--method sweep ({}, so there is a response to sweep)",
                    super::args::set_forcing_amplitude(&model, &sys)
                ))
            }
        })?;
        bar.finish_and_clear();
    }
    let unit = |name: &str| -> String { model.param_unit(name) };
    // a case whose equilibrium is unstable: warned on standard error (and in the JSON's
    // warnings), the case marked `"unstable": true`
    let unstable = unstable_warnings(&study);
    for w in &unstable {
        eprintln!("warning: {w}");
    }
    if let Some(o) = &a.output {
        write_sensitivity_csv(o, &study)?;
    }
    if let Some(p) = &a.plot {
        let title = format!(
            "{}: change of each mode's ω_n{}",
            model.name,
            if model.overrides.is_empty() {
                String::new()
            } else {
                format!(
                    " ({})",
                    model
                        .overrides
                        .iter()
                        .map(|(n, v)| format!("{n}={v}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
        );
        write_tornado(p, &study, &title, size)?;
    }
    outputs.commit()?;
    for f in [&a.output, &a.plot].into_iter().flatten() {
        eprintln!("wrote {f}");
    }
    if a.json {
        let params = vs
            .iter()
            .map(|v| ParameterJson {
                name: v.name.clone(),
                value: sys.param(v.param),
                unit: unit(&v.name),
                min: v.range.0,
                max: v.range.1,
            })
            .collect();
        let mut warnings = watch.warnings();
        warnings.extend(super::args::damping_warning_values(
            &super::args::damping_warnings(&model, &sys, &vs),
        ));
        warnings.extend(
            baseline
                .iter()
                .map(|t| serde_json::json!({"kind": "unstable_baseline", "message": t})),
        );
        warnings.extend(
            unstable
                .iter()
                .map(|t| serde_json::json!({"kind": "unstable_case", "message": t})),
        );
        print_json(&super::Warned {
            doc: SensitivityReport::new(&study, &Provenance::of(&model), params),
            warnings,
        });
        return Ok(());
    }
    print_tables(&study, &|n| unit(n), a.freq.freq_unit);
    Ok(())
}

/// The warning for an unstable nominal design (the baseline: some mode grows), if it is.
pub fn baseline_warning(study: &Sensitivity) -> Option<String> {
    if !study.baseline_unstable {
        return None;
    }
    let how: Vec<String> = study
        .baseline_growing_modes
        .iter()
        .map(detune::linear::growth_words)
        .collect();
    Some(format!(
        "the nominal design (the baseline) is UNSTABLE: {}; its equilibrium is left at once, so its frequencies and the cases' changes from them are not resonances about a steady state",
        how.join("; ")
    ))
}

/// One sentence per case whose equilibrium is unstable, and one for a tolerance box that
/// reaches unstable designs.
pub fn unstable_warnings(study: &Sensitivity) -> Vec<String> {
    let mut out: Vec<String> = study
        .unstable_cases
        .iter()
        .map(|c| {
            format!(
                "the case {}: the equilibrium is unstable ({}, growth rate Re λ = {} 1/s); its frequencies are not resonances",
                c.label,
                if c.omega_d_rad_s == 0.0 {
                    "a divergent mode".to_string()
                } else {
                    format!("an oscillation growing at ω_d = {:.4} rad/s", c.omega_d_rad_s)
                },
                detune::linear::rate_text(c.growth_rate_1_s, 4, false)
            )
        })
        .collect();
    let n = study
        .modes
        .iter()
        .map(|m| m.worst_case.corners_unstable)
        .max()
        .unwrap_or(0);
    if n > 0 {
        out.push(format!(
            "{n} corner{} or sample{} of the tolerance box {} an unstable equilibrium (a growing mode): the box reaches designs that leave their equilibrium",
            if n == 1 { "" } else { "s" },
            if n == 1 { "" } else { "s" },
            if n == 1 { "has" } else { "have" }
        ));
    }
    out
}

/// The tables of a study.
fn print_tables(s: &Sensitivity, unit: &dyn Fn(&str) -> String, fu: FreqUnit) {
    let hz = |w: f64| w / (2.0 * std::f64::consts::PI);
    // frequencies in the --freq-unit (rad/s by default, then with Hz beside)
    let f = |w: f64| fu.of(w);
    let sym = fu.symbol();
    // ω_n in rad/s, f_n in Hz or rpm (cycle rates); the undamped frequency likewise
    let nat = super::modes::natural(fu, "n");
    let undamped = fu.rate();
    let beside = |w: f64, d: usize| {
        if fu == FreqUnit::RadPerSecond {
            format!(" ({:.d$} Hz)", hz(w))
        } else {
            String::new()
        }
    };
    if let Some(w) = baseline_warning(s) {
        println!("WARNING: {w}\n");
    }
    for m in &s.modes {
        println!(
            "{}: {nat} = {:.6} {sym}{}, ζ = {:.5}{}",
            m.name,
            f(m.omega_n_rad_s),
            beside(m.omega_n_rad_s, 5),
            m.damping_ratio,
            m.undamped_omega_rad_s
                .map(|u| format!(", undamped {undamped} = {:.6} {sym}", f(u)))
                .unwrap_or_default()
        );
        if let Some(p) = m.peak_omega_rad_s {
            println!("  stepped-sine peak (baseline): {:.6} {sym}", f(p));
        }
        // the stepped-sine peaks' column only with --method sweep|both
        let swept = m.cases.iter().any(|c| c.peak_omega_rad_s.is_some());
        println!(
            "  {:<22} {:>16} {:>14} {:>9} {:>14} {:>9} {:>9}{}",
            "case",
            "value",
            format!("{nat} [{sym}]"),
            "change",
            format!("undamped {undamped} [{sym}]"),
            "change",
            "ζ",
            if swept {
                format!(" {:>14}", format!("peak [{sym}]"))
            } else {
                String::new()
            }
        );
        for c in &m.cases {
            println!(
                "  {:<22} {:>16} {:>14.6} {:>+8.3}% {:>14} {:>9} {:>9.5}{}{}",
                c.label,
                format!("{:.6e} {}", c.value, unit(&c.param)),
                f(c.omega_n_rad_s),
                c.change_pct_omega_n,
                c.undamped_omega_rad_s
                    .map(|u| format!("{:.6}", f(u)))
                    .unwrap_or_else(|| "-".into()),
                c.change_pct_undamped
                    .map(|u| format!("{u:+.3}%"))
                    .unwrap_or_else(|| "-".into()),
                c.damping_ratio,
                if swept {
                    format!(
                        " {:>14}",
                        c.peak_omega_rad_s
                            .map(|p| format!("{:.6}", f(p)))
                            .unwrap_or_else(|| "-".into())
                    )
                } else {
                    String::new()
                },
                if c.unstable {
                    "  UNSTABLE equilibrium: not a resonance"
                } else {
                    ""
                }
            );
        }
        // the derivative of the frequency shown: dω_n/dp in rad/s, df_n/dp in Hz or rpm
        // (a cycle rate, as the table's f_n), per the parameter's SI unit
        let nat = super::modes::natural(fu, "n");
        println!(
            "  {:<16} {:>22} {:>22} {:>11} {:>16} {:>16}",
            "parameter",
            format!("d{nat}/dp [{sym}/p]"),
            "(central difference)",
            "elasticity",
            "dζ/dp",
            "(central diff.)"
        );
        for d in &m.derivatives {
            let u = unit(&d.param);
            let per = if u.is_empty() {
                String::new()
            } else {
                format!(" per {u}")
            };
            println!(
                "  {:<16} {:>22} {:>22} {:>11.5} {:>16.6e} {:>16.6e}  ({sym}{per}; 1{per})",
                d.param,
                format!("{:.8e}", f(d.domega_n_dp)),
                format!("{:.8e}", f(d.fd)),
                d.elasticity,
                d.dzeta_dp,
                d.fd_dzeta_dp
            );
            // the differences' own error estimates, and what the check found
            let pm = |u: f64| {
                if u.is_finite() {
                    format!("±{u:.1e}")
                } else {
                    "± unknown".to_string()
                }
            };
            println!(
                "  {:<16} {:>22} {:>22} {:>11} {:>16} {:>16}",
                "",
                "",
                pm(f(d.fd_uncertainty)),
                "",
                "",
                pm(d.fd_dzeta_uncertainty)
            );
            let quantities = [
                ("dω_n/dp", d.check, d.domega_n_dp, d.fd, d.fd_uncertainty),
                (
                    "dζ/dp",
                    d.dzeta_check,
                    d.dzeta_dp,
                    d.fd_dzeta_dp,
                    d.fd_dzeta_uncertainty,
                ),
            ];
            let rel = |an: f64, fd: f64| {
                if fd != 0.0 {
                    format!(", {:.1e} relative", ((an - fd) / fd).abs())
                } else {
                    String::new()
                }
            };
            let mut gaps = Vec::new();
            let mut unchecked = Vec::new();
            for (what, c, an, fd, unc) in quantities {
                match c {
                    Check::Agrees => {}
                    Check::Disagrees => gaps.push(format!(
                        "{what} by {:.2e}{}, beyond the difference's own error estimate {unc:.2e}",
                        (an - fd).abs(),
                        rel(an, fd)
                    )),
                    Check::Unchecked if unc.is_finite() => unchecked.push(format!(
                        "{what} (the difference {fd:.6e} ± {unc:.1e}{}, is too noisy to check it to 1e-5)",
                        if fd != 0.0 {
                            format!(", ±{:.1e} relative", (unc / fd).abs())
                        } else {
                            String::new()
                        }
                    )),
                    Check::Unchecked => unchecked.push(format!(
                        "{what} (its difference's error is unknown: the mode was not matched 4 steps away, near a crossing)"
                    )),
                }
            }
            if !unchecked.is_empty() {
                println!(
                    "  unchecked with respect to {}: {}: the analytic value stands, unconfirmed by the finite difference",
                    d.param,
                    unchecked.join("; ")
                );
            }
            if !gaps.is_empty() {
                println!(
                    "  WARNING: the analytic derivatives with respect to {} disagree with their finite differences ({}): do not trust them (please report this model)",
                    d.param,
                    gaps.join("; ")
                );
            }
        }
        println!(
            "  (d{nat}/dp in {sym} and dζ/dp in 1, per SI unit p of the parameter (each row's unit at its end); elasticity = (p/{nat})·d{nat}/dp, dimensionless)"
        );
        let w = &m.worst_case;
        println!(
            "  worst case over the tolerance box: {:.6} to {:.6} {sym}{}, from {} corner{} evaluated; first-order estimate {:.6} to {:.6} {sym}\n",
            f(w.min_rad_s),
            f(w.max_rad_s),
            if fu == FreqUnit::RadPerSecond {
                format!(" ({:.5} to {:.5} Hz)", hz(w.min_rad_s), hz(w.max_rad_s))
            } else {
                String::new()
            },
            w.corners_evaluated,
            if w.corners_evaluated == 1 { "" } else { "s" },
            f(w.first_order_min_rad_s),
            f(w.first_order_max_rad_s)
        );
        // the first-order estimate off by more than a tenth of the interval: the ranges
        // are too wide for the derivatives alone
        let miss = (w.first_order_min_rad_s - w.min_rad_s)
            .abs()
            .max((w.first_order_max_rad_s - w.max_rad_s).abs());
        if miss > 0.1 * (w.max_rad_s - w.min_rad_s) {
            println!(
                "  note: the first-order estimate misses the evaluated interval by up to {:.4} {sym}: ω_n is far from linear in the parameters over these ranges; the evaluated interval is the one to use\n",
                f(miss)
            );
        }
        if !w.non_monotone.is_empty() {
            println!(
                "  WARNING: ω_n is not monotonic in {} over the range: its extreme lies inside the box; the interval includes {} interior samples but is an estimate there\n",
                w.non_monotone.join(", "),
                w.interior_samples
            );
        }
        if w.corners_failed > 0 {
            println!(
                "  WARNING: {} corner{} of the box could not be solved (no equilibrium near the baseline's: the ranges reach past a fold, or a linkage that no longer closes); the interval above does not cover {}\n",
                w.corners_failed,
                if w.corners_failed == 1 { "" } else { "s" },
                if w.corners_failed == 1 { "it" } else { "them" }
            );
        }
    }
}

/// `--checkpoint FILE` of the sensitivity's sweeps (`runs` of them, one per case, on the
/// grid of `opts`): opened (resumed when it exists) with a fingerprint of everything that
/// changes a case's result: the model, its parameters (`--set`), the cases (`--vary`),
/// the response and the sweep's options.
fn open_checkpoint(
    a: &SensitivityArgs,
    model: &detune::model::Model,
    vs: &[detune::linear::sensitivity::Vary],
    response: &str,
    opts: &detune::frequency::SweepOptions,
    runs: usize,
) -> Result<Box<dyn detune::frequency::checkpoint::CaseLog>> {
    let Some(path) = &a.checkpoint else {
        return Ok(Box::new(detune::frequency::checkpoint::NoLog));
    };
    let cases: Vec<_> = vs.iter().map(|v| (v.param, &v.cases)).collect();
    let text = format!(
        "detune {}\nsensitivity model {} parameters {:?}\ncases {cases:?}\nresponse {response}\noptions {opts:?}\n",
        env!("CARGO_PKG_VERSION"),
        model.hash,
        model.parameters.values,
    );
    open_study_checkpoint(path, model, &text, &opts.values, runs, "sensitivity")
}

/// The `--checkpoint FILE` of a study (sensitivity, tune: `runs` sweeps over the same
/// `grid` of frequencies), its header fingerprinted by `text` (the study's cases and
/// options); says on stderr how much it resumes.
pub(super) fn open_study_checkpoint(
    path: &str,
    model: &detune::model::Model,
    text: &str,
    grid: &[f64],
    runs: usize,
    study: &str,
) -> Result<Box<dyn detune::frequency::checkpoint::CaseLog>> {
    use detune::frequency::checkpoint::{self, Checkpoint, Header, Shard};
    use sha2::{Digest, Sha256};
    let fingerprint = Sha256::digest(text.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    let header = Header {
        format: checkpoint::FORMAT.into(),
        format_version: checkpoint::FORMAT_VERSION,
        detune_version: env!("CARGO_PKG_VERSION").into(),
        model_file: model.source.path.clone(),
        model_sha256: model.hash.clone(),
        overrides: Provenance::of(model).overrides,
        fingerprint,
        command: std::env::args_os()
            .skip(2)
            .map(|s| s.to_string_lossy().into_owned())
            .collect(),
        shard: Shard::ALL,
        sequential: false,
        grid: grid.len(),
        runs,
        study: Some(study.into()),
    };
    let c = Checkpoint::open(path, header, grid)?;
    if c.reused > 0 {
        eprintln!(
            "resuming from the checkpoint {path}: {} steady states done before",
            c.reused
        );
    }
    Ok(Box::new(c))
}

/// The error of a study with no oscillatory mode: nothing to compute (a model with no
/// degrees of freedom, or whose modes are all real: divergent, overdamped or neutral).
fn nothing_to_vary(sys: &detune::System, study: &Sensitivity) -> Error {
    let dof = detune::linear::modal_analysis(sys, None)
        .map(|m| m.linearization.dof())
        .unwrap_or(0);
    if dof == 0 {
        Error::request(
            format!(
                "{}, so sensitivity has nothing to compute (no frequency to move)",
                detune::linear::no_modes_words(sys)
            ),
            "sensitivity studies a mechanism that can move: free a coordinate (a driven constraint fixes it), or use `detune simulate` for a driven mechanism; `detune check MODEL` shows the degrees of freedom",
        )
    } else {
        Error::request(
            format!(
                "nothing to compute: none of the model's {dof} degree{} of freedom oscillates (every eigenvalue is real: overdamped, neutral{}), so no mode has a frequency to vary",
                if dof == 1 { "" } else { "s" },
                if study.baseline_unstable {
                    ", or divergent: the nominal design is UNSTABLE"
                } else {
                    ""
                }
            ),
            "`detune modes MODEL` shows the eigenvalues; a resonance needs a stiffness and less than critical damping",
        )
    }
}
