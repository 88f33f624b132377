//! `detune tune`: the smallest change of the varied parameters that clears every forcing
//! band of an environment by the margin, with alternatives (one per choice of sides).

use super::args::{ModelArgs, varies};
use super::margins::parse_margin;
use super::print_json;
use clap::Args;
use detune::diag::{Error, Result};
use detune::environment::resolve;
use detune::output::Provenance;
use detune::output::command::shell_word;
use detune::tune::{Optimizer, Tolerance, TuneOptions, Tuning, tune};

#[derive(Args)]
pub struct TuneArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Forcing environment: a shipped one's id or name (UH-60, UH-1N, H135, AH-64) or a
    /// file (docs/environments.md).
    #[arg(long, value_name = "NAME|PATH")]
    pub environment: String,
    /// A free parameter and its bounds: `k_fs=50%..200%` (p0·50/100 … p0·200/100), or
    /// `k_fs=±30%`, `k_fs=1e5,2e5` (the lowest and highest values). Repeatable.
    #[arg(long = "vary", value_name = "NAME=RANGE", allow_hyphen_values = true)]
    pub vary: Vec<String>,
    /// Required separation of every mode from every band: "10%" or 0.1 (your choice, not
    /// a standard).
    #[arg(long, default_value = "10%", value_name = "PCT")]
    pub margin: String,
    /// Weight of a parameter's squared relative change in the cost, NAME=W (default 1).
    #[arg(long = "weight", value_name = "NAME=W")]
    pub weight: Vec<String>,
    /// Verify each design also by a stepped-sine sweep of the nonlinear model at the
    /// model's forcing (set its `forcing_amplitude`, e.g. --set "D0=7 mm" for the
    /// inceptor): `--verify sweep`.
    #[arg(long, value_name = "sweep")]
    pub verify: Option<String>,
    /// The response the sweep measures [default: the first angle coordinate].
    #[arg(long, value_name = "NAME")]
    pub response: Option<String>,
    /// The --verify sweep's integrator and tolerances.
    #[command(flatten)]
    pub tol: super::args::Tolerances,
    /// --verify sweep: append each steady state of the designs' sweeps to FILE as it is
    /// computed; the same command with the same FILE resumes, skipping what is done (the
    /// output is identical to an uninterrupted run's). A FILE of another model, --set,
    /// --vary or options (anything that changes the designs or their sweeps), or of
    /// another command, is refused.
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<String>,
    /// A manufacturing tolerance the design must clear the bands over, as `margins --vary`
    /// checks it: `k_fs=±10%` (relative: ±10 % of the design's value) or `k_fs=±500 N/m`.
    /// Repeatable; a parameter may be both free (--vary) and toleranced.
    #[arg(
        long = "tolerance",
        value_name = "NAME=±TOL",
        allow_hyphen_values = true
    )]
    pub tolerance: Vec<String>,
    /// The optimizer of each choice of sides: auto (SLSQP with the analytic gradients,
    /// COBYLA where SLSQP fails), slsqp, or cobyla (derivative-free).
    #[arg(long, default_value = "auto", value_parser = ["auto", "slsqp", "cobyla"])]
    pub optimizer: String,
    /// The most designs listed.
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub designs: usize,
    /// Print JSON on standard output.
    #[arg(long)]
    pub json: bool,
    /// JSON file of the result (as --json prints it).
    #[arg(short = 'o', long = "output", value_name = "OUT.json")]
    pub output: Option<String>,
    #[command(flatten)]
    pub freq: super::args::FreqUnitArg,
}

#[derive(serde::Serialize)]
struct TuneReport<'a> {
    provenance: &'a Provenance,
    environment: &'a str,
    margin_pct: f64,
    #[serde(flatten)]
    tuning: &'a Tuning,
    /// A stiff integration of `--verify sweep` (none: no key).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    warnings: Vec<serde_json::Value>,
    /// Key → unit: the varied parameters (their SI units), the modes (rad/s), the
    /// margins' keys.
    units: detune::output::units::Units,
}

pub fn run(a: TuneArgs) -> Result<super::Outcome> {
    let margin = parse_margin(&a.margin)?;
    let env = resolve(&a.environment)?;
    let (model, sys) = a.model.load()?;
    let mut inputs = vec![("model file", model.source.path.as_str())];
    if !env.shipped {
        inputs.push(("environment file", env.file.as_str()));
    }
    let outputs = detune::output::OutputSet::plan(&inputs, &[a.output.as_deref()])?;
    if a.vary.is_empty() {
        return Err(Error::request(
            "tune needs at least one free parameter",
            "give the parameters the design may change with their bounds, e.g. --vary k_fs=50%..200% --vary gearbox_scale=80%..120%",
        ));
    }
    let vs = varies(&model, &sys, &a.vary)?;
    let mut weights = vec![1.0; vs.len()];
    for w in &a.weight {
        let bad = || {
            Error::request(
                format!("--weight {w}: expected NAME=W with W > 0 and NAME a varied parameter"),
                "for example --weight k_fs=2 (its change costs twice as much)",
            )
        };
        let (n, v) = w.split_once('=').ok_or_else(bad)?;
        let i = vs.iter().position(|x| x.name == n.trim()).ok_or_else(bad)?;
        let v: f64 = v.trim().parse().map_err(|_| bad())?;
        if !(v > 0.0 && v.is_finite()) {
            return Err(bad());
        }
        weights[i] = v;
    }
    let lines = env.forcing_lines();
    let tolerances = tolerances(&model, &sys, &a.tolerance)?;
    let opts = TuneOptions {
        margin,
        weights,
        max_designs: a.designs.max(1),
        tolerances,
        optimizer: match a.optimizer.as_str() {
            "slsqp" => Optimizer::Slsqp,
            "cobyla" => Optimizer::Cobyla,
            _ => Optimizer::Auto,
        },
        ..TuneOptions::default()
    };
    let sweep = match a.verify.as_deref() {
        None => false,
        Some("sweep") => true,
        Some(other) => {
            return Err(Error::request(
                format!("--verify {other}: unknown verification"),
                "--verify sweep (each design is always verified by its modes and linear response)",
            ));
        }
    };
    if let Some(c) = &a.checkpoint {
        if !sweep {
            return Err(Error::request(
                format!("--checkpoint {c}: without --verify sweep there are no sweeps to resume"),
                "--checkpoint goes with --verify sweep",
            ));
        }
        if a.output
            .as_deref()
            .is_some_and(|o| detune::output::commit::same_file(o, c))
        {
            return Err(Error::request(
                format!("--checkpoint {c} is also the output"),
                "give the checkpoint its own file (e.g. tune.ckpt)",
            ));
        }
    }
    let mut t = tune(&sys, &vs, &lines, &opts)?;
    let watch = super::StiffWatch::new(
        &sys.forcing_param()
            .map(|f| sys.param_names()[f].clone())
            .unwrap_or_default(),
    );
    if sweep {
        let steady = a.tol.steady();
        let bar = indicatif::ProgressBar::hidden();
        super::interrupt_on_ctrl_c();
        let response = match &a.response {
            Some(r) => {
                sys.output(r)?;
                r.clone()
            }
            None => sys.coordinates[detune::linear::default_reference(&sys)].clone(),
        };
        let context = |k: usize| {
            format!(
                "--verify sweep of design {} ({})",
                k + 1,
                super::args::set_forcing_amplitude(&model, &sys)
            )
        };
        // each design's system and sweep, known before any sweep: the checkpoint's
        // fingerprint holds them all
        let setups = t
            .designs
            .iter()
            .enumerate()
            .map(|(k, d)| {
                detune::tune::verify_sweep_setup(&sys, d, &response, &steady)
                    .map_err(|e| e.context(&context(k)))
            })
            .collect::<Result<Vec<_>>>()?;
        let log = open_checkpoint(&a, &model, &t, &response, &setups)?;
        for (k, (d, (s, sweep_opts))) in t.designs.iter_mut().zip(&setups).enumerate() {
            let (peaks, clear) = detune::tune::verify_sweep_logged(
                s,
                sweep_opts,
                &lines,
                margin,
                &super::INTERRUPTED,
                log.as_ref(),
                k,
                &|at| watch.found(&format!("the sweep of design {}", k + 1), at, &bar),
            )
            .map_err(|e| {
                if let (Some(c), true) = (&a.checkpoint, e.failure().is_some_and(interrupted))
                {
                    eprintln!(
                        "the steady states computed are in the checkpoint {c}: the same command resumes from them"
                    );
                }
                e.context(&context(k))
            })?;
            d.sweep_peaks_rad_s = Some(peaks);
            d.sweep_peaks_clear = Some(clear);
        }
    }
    let provenance = Provenance::of(&model);
    let report = TuneReport {
        provenance: &provenance,
        environment: &env.name,
        margin_pct: margin * 100.0,
        tuning: &t,
        warnings: watch.warnings(),
        units: {
            let mut u = detune::output::units::Units::new().with("cost", "1");
            for v in &vs {
                u.add(v.name.clone(), model.param_unit(&v.name));
            }
            for d in &t.designs {
                for n in d.modes.keys() {
                    u.add(n.clone(), "rad/s");
                }
            }
            u.with_all([
                ("closest_pct", "%"),
                ("frf_peaks_rad_s", "rad/s"),
                ("sweep_peaks_rad_s", "rad/s"),
                ("tolerance_intervals", "rad/s"),
                ("value", "SI unit of the parameter `param`"),
            ])
            .with_all(super::margins::MARGIN_UNITS)
        },
    };
    let fu = a.freq.freq_unit;
    let sym = fu.symbol();
    // a --vary or --tolerance case that makes a damping coefficient negative (warned of
    // on standard error when parsed)
    let mut warnings = super::args::damping_warnings(&model, &sys, &vs);
    let tolerated: Vec<_> = opts.tolerances.iter().map(|t| t.vary.clone()).collect();
    warnings.extend(super::args::damping_warnings(&model, &sys, &tolerated));
    let mut report = report;
    report
        .warnings
        .extend(super::args::damping_warning_values(&warnings));
    if let Some(o) = &a.output {
        let text = serde_json::to_string_pretty(&report).unwrap_or_default();
        detune::output::write_atomic(o, |w| w.write_all(text.as_bytes()))?;
        outputs.commit()?;
        eprintln!("wrote {o}");
    }
    if a.json {
        print_json(&report);
    } else {
        println!(
            "{} against {} at a {:.4} % margin (your choice, not a standard): {} choice{} of sides solved",
            model.name,
            env.name,
            margin * 100.0,
            t.choices,
            if t.choices == 1 { "" } else { "s" }
        );
        if t.baseline_passes {
            println!("the baseline already clears every band: the best design is the baseline");
        }
        for (k, d) in t.designs.iter().enumerate() {
            let params: Vec<String> = d
                .parameters
                .iter()
                .map(|(n, v)| {
                    let p0 = vs
                        .iter()
                        .find(|x| &x.name == n)
                        .map(|x| sys.param(x.param))
                        .unwrap_or(f64::NAN);
                    let v = v.as_f64().unwrap_or(f64::NAN);
                    let u = model.param_unit(n);
                    let u = if u.is_empty() { u } else { format!(" {u}") };
                    format!("{n} = {v}{u} ({:+.3} %)", (v - p0) / p0 * 100.0)
                })
                .collect();
            let modes: Vec<String> = d
                .modes
                .iter()
                .map(|(n, w)| format!("{n} {}", fu.show(w.as_f64().unwrap_or(f64::NAN), 4)))
                .collect();
            println!(
                "\ndesign {}: cost {:.6e}; {}\n  modes: {}; closest separation {:.3} %{}",
                k + 1,
                d.cost,
                params.join(", "),
                modes.join(", "),
                d.closest_pct,
                if d.tolerance_intervals.is_some() {
                    " (over the tolerances)"
                } else {
                    ""
                }
            );
            if let Some(iv) = &d.tolerance_intervals {
                let spans: Vec<String> = iv
                    .iter()
                    .map(|(n, v)| {
                        let at = |k: usize| v.get(k).and_then(|x| x.as_f64()).unwrap_or(f64::NAN);
                        format!("{n} {:.4}–{:.4} {sym}", fu.of(at(0)), fu.of(at(1)))
                    })
                    .collect();
                println!("  over the tolerance box: {}", spans.join(", "));
            }
            for b in &d.at_bounds {
                println!(
                    "  {} is at its {} bound ({}): a wider range would allow a smaller change",
                    b.param,
                    b.bound,
                    format!("{} {}", b.value, model.param_unit(&b.param)).trim_end()
                );
            }
            if !d.frf_peaks_rad_s.is_empty() {
                println!(
                    "  linear response peaks: {} {sym}{}",
                    d.frf_peaks_rad_s
                        .iter()
                        .map(|w| format!("{:.4}", fu.of(*w)))
                        .collect::<Vec<_>>()
                        .join(", "),
                    match d.frf_peaks_clear {
                        Some(true) => " (every peak clears every band too)",
                        Some(false) =>
                            " (NOTE: a peak lies within the margin of a band although every mode clears it: a response peak is not at ω_n; ask a larger --margin if the peaks must clear too)",
                        None => "",
                    }
                );
            }
            if let (Some(p), Some(clear)) = (&d.sweep_peaks_rad_s, d.sweep_peaks_clear) {
                println!(
                    "  stepped-sine peaks: {} {sym} ({})",
                    p.iter()
                        .map(|w| format!("{:.4}", fu.of(*w)))
                        .collect::<Vec<_>>()
                        .join(", "),
                    if clear {
                        "every peak clears every band"
                    } else {
                        "NOTE: a peak lies within the margin of a band"
                    }
                );
            }
            let sets: Vec<String> = d
                .parameters
                .iter()
                .map(|(n, v)| format!("--set {n}={}", v.as_f64().unwrap_or(f64::NAN)))
                .collect();
            let names: Vec<&str> = d.parameters.keys().map(|k| k.as_str()).collect();
            println!(
                "  check: detune margins {} --environment {} --margin {}% {}{}",
                a.model.command_words(&names),
                shell_word(&a.environment),
                margin * 100.0,
                sets.join(" "),
                a.tolerance
                    .iter()
                    .map(|t| format!(" --vary {}", shell_word(t)))
                    .collect::<String>()
            );
        }
        if !t.infeasible.is_empty() {
            println!("\nchoices of sides that cannot be met within the bounds:");
            for i in &t.infeasible {
                println!("  {}", i.reason);
            }
        }
        if t.designs.is_empty() {
            // every choice blocked by the tolerance box (an unstable point of it, or a
            // spread too wide to estimate): the remedy is the tolerances, not the ranges
            use detune::tune::Blocked;
            let all = |f: &dyn Fn(&Blocked) -> bool| {
                !t.infeasible.is_empty()
                    && t.infeasible
                        .iter()
                        .all(|i| i.blocked.as_ref().is_some_and(f))
            };
            // (with tolerances, a design that does not verify failed on its box: a case
            // of it with no equilibrium)
            let tolerated = !a.tolerance.is_empty();
            if all(&|b| {
                matches!(b, Blocked::SpreadReachesZero { .. })
                    || (tolerated && matches!(b, Blocked::DoesNotVerify { .. }))
            }) {
                println!(
                    "\nthe tolerance box is too wide to tune over: narrow the --tolerance ranges (`detune margins MODEL --vary ...` with the same tolerances shows what the box reaches)"
                );
            } else if all(&|b| {
                matches!(
                    b,
                    Blocked::UnstableOverTolerances { .. } | Blocked::SpreadReachesZero { .. }
                )
            }) {
                println!(
                    "\nno design found is stable over its tolerance box (tune minimizes the change and does not search for stability over the tolerances: check a larger change with `detune margins MODEL --set NAME=VALUE --vary ...` and the same tolerances); or narrow the --tolerance that reaches the unstable point (a damping tolerance below 100 % keeps every damper passive)"
                );
            } else {
                println!(
                    "\nno design within the bounds clears every band: widen the ranges, vary another parameter, or lower the margin"
                );
            }
        }
    }
    Ok(if t.designs.is_empty() {
        super::Outcome::CheckFailed
    } else {
        super::Outcome::Passed
    })
}

/// Every `--tolerance`, parsed as `--vary` is (about the baseline); relative when given
/// in %.
fn tolerances(
    model: &detune::Model,
    sys: &detune::System,
    texts: &[String],
) -> Result<Vec<Tolerance>> {
    let vs = super::args::varies_as(model, sys, texts, "--tolerance")?;
    Ok(vs
        .into_iter()
        .zip(texts)
        .map(|(vary, t)| Tolerance {
            vary,
            relative: t.contains('%'),
        })
        .collect())
}

/// A failure that is a signal's interruption.
fn interrupted(f: &detune::failure::Failure) -> bool {
    matches!(
        f,
        detune::failure::Failure::SweepInterrupted
            | detune::failure::Failure::StudyInterrupted { .. }
            | detune::failure::Failure::Interrupted { .. }
    )
}

/// `--checkpoint FILE` of the designs' `--verify sweep`s (one run per design, in the
/// order listed): opened (resumed when it exists) with a fingerprint of everything that
/// changes a case's result: the model, its parameters (`--set`), each design's
/// parameters and trimmed system's parameter values, and its sweep's options (grid,
/// response, refinement, integrator and tolerances). Different --vary, --weight,
/// --tolerance, --margin or environment that change the designs change it too.
fn open_checkpoint(
    a: &TuneArgs,
    model: &detune::model::Model,
    t: &Tuning,
    response: &str,
    setups: &[(detune::System, detune::frequency::SweepOptions)],
) -> Result<Box<dyn detune::frequency::checkpoint::CaseLog>> {
    let Some(path) = &a.checkpoint else {
        return Ok(Box::new(detune::frequency::checkpoint::NoLog));
    };
    let mut text = format!(
        "detune {}\ntune model {} parameters {:?}\nresponse {response}\n",
        env!("CARGO_PKG_VERSION"),
        model.hash,
        model.parameters.values,
    );
    for (d, (s, opts)) in t.designs.iter().zip(setups) {
        // the parameters' bits, as a case's result depends on them
        let bits: Vec<u64> = (0..s.param_names().len())
            .map(|i| s.param(i).to_bits())
            .collect();
        text.push_str(&format!(
            "design {}\nsystem {bits:?}\noptions {opts:?}\n",
            serde_json::to_string(&d.parameters).unwrap_or_default()
        ));
    }
    let grid = setups
        .first()
        .map(|(_, o)| o.values.clone())
        .unwrap_or_default();
    super::sensitivity::open_study_checkpoint(path, model, &text, &grid, setups.len(), "tune")
}
