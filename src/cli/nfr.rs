//! `detune nfr`: the nonlinear frequency response by continuation of periodic orbits,
//! stable and unstable, with folds, period doublings, Neimark–Sacker points and peaks
//! located (see `detune::periodic`).

use super::args::{IntegratorChoice, ModelArgs, frequency_value, param_value};
use super::{INTERRUPTED, interrupt_on_ctrl_c, print_json};
use clap::Args;
use detune::diag::{Error, Result};
use detune::output::figures::Case;
use detune::output::nfr::{NfrReport, jump_words, nfr_figures, write_nfr_csv};
use detune::output::plot::write_panels_sized;
use detune::output::units::{Units, WithUnits, significant};
use detune::output::{Provenance, check_outputs};
use detune::periodic::continuation::{NfrOptions, nfr};

#[derive(Args)]
pub struct NfrArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// The continued parameter: the forcing frequency (rad/s) or any other parameter.
    #[arg(long, value_name = "NAME")]
    pub param: String,
    /// Start of the range: the curve starts from the linear response here. A number (SI:
    /// rad/s for the forcing frequency) or a quantity in the parameter's dimension
    /// ("0.5 Hz", "2 N", "20 kN/m").
    #[arg(long, value_name = "A", allow_hyphen_values = true)]
    pub from: String,
    /// End of the range.
    #[arg(long, value_name = "B", allow_hyphen_values = true)]
    pub to: String,
    /// Response to measure at every point (repeatable) [default: every coordinate]: any
    /// name `sweep --response` takes.
    #[arg(long, value_name = "NAME")]
    pub response: Vec<String>,
    /// The integration's tolerances and method.
    #[command(flatten)]
    pub tol: CurveTolerances,
    /// Give up after this many points (the curve is then written, marked incomplete); at
    /// least 1/--max-step + 1, the points of the largest steps across the range.
    #[arg(long, default_value_t = 3000, value_name = "N")]
    pub max_points: usize,
    /// Largest continuation step, as a fraction of the curve's size (parameter range,
    /// largest linear response): above 0, at most 1.
    #[arg(long, default_value_t = 0.04, value_name = "S")]
    pub max_step: f64,
    /// CSV: one row per periodic orbit (see docs/nonlinear-frequency-response.md).
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    pub output: Option<String>,
    /// Print the JSON result.
    #[arg(long)]
    pub json: bool,
    /// Figure (.svg or .png): each response's amplitude against the parameter, stable
    /// solid, unstable dashed, folds, bifurcations and peaks marked.
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<String>,
    /// Draw the backbone curve of this mode (a name or a number from 1, as `backbone
    /// --of-mode`) under the forced curve: the amplitude-dependent natural frequency of
    /// the undamped, unforced mechanism. Repeatable; needs --plot, and --param must be the
    /// forcing frequency.
    #[arg(long, value_name = "MODE")]
    pub backbone: Vec<String>,
    #[command(flatten)]
    pub freq: super::args::FreqUnitArg,
    #[command(flatten)]
    pub plot_size: super::args::PlotSize,
}

/// The defaults of `CurveTolerances` as `--help` shows them (the library's
/// `CURVE_RTOL`, `CURVE_ATOL`: the test below holds them equal).
const CURVE_RTOL_TEXT: &str = "1e-8";
const CURVE_ATOL_TEXT: &str = "1e-10";

#[cfg(test)]
#[test]
fn curve_tolerance_defaults_are_the_librarys() {
    use detune::periodic::continuation::{CURVE_ATOL, CURVE_RTOL};
    assert_eq!(CURVE_RTOL_TEXT.parse::<f64>().unwrap(), CURVE_RTOL);
    assert_eq!(CURVE_ATOL_TEXT.parse::<f64>().unwrap(), CURVE_ATOL);
}

/// The integration's tolerances along the curve: looser than `simulate`'s defaults,
/// since the located points are computed 10⁴ times tighter whatever these are.
#[derive(Args)]
pub struct CurveTolerances {
    /// Relative error tolerance per step for the curve's points, which are converged to
    /// about 100·rtol·|μ|max of their amplitude (|μ|max the largest Floquet multiplier's
    /// modulus; an unstable orbit is integrated more tightly to keep this below 1e-5); the
    /// folds, bifurcations and peaks are integrated 10⁴ times tighter.
    #[arg(long, default_value = CURVE_RTOL_TEXT, value_name = "R", allow_hyphen_values = true)]
    pub rtol: f64,
    /// Absolute error tolerance per step (SI units of each coordinate and velocity); the
    /// located points' is 10⁴ times tighter.
    #[arg(long, default_value = CURVE_ATOL_TEXT, value_name = "A", allow_hyphen_values = true)]
    pub atol: f64,
    /// The integrator of each period and its variational equations: `dop853` (explicit,
    /// the fastest for most models) or `radau` (Radau IIA, implicit: for a stiff model, a
    /// very stiff spring or damper on a light body, whose forcing periods DOP853 cannot
    /// cross; several times slower otherwise).
    #[arg(long, value_enum, default_value_t = IntegratorChoice::Dop853, value_name = "METHOD")]
    pub integrator: IntegratorChoice,
}

pub fn run(a: NfrArgs) -> Result<()> {
    // the requests that need no model, refused before any work
    if !a.backbone.is_empty() && a.plot.is_none() {
        return Err(Error::request(
            format!(
                "--backbone {}: the backbone is drawn on the figure, and there is no --plot",
                a.backbone.join(" --backbone ")
            ),
            "add --plot curve.svg (or .png), or leave --backbone out (`detune backbone` computes it on its own)",
        ));
    }

    let hint = "leave it out for the default (--rtol 1e-8, --atol 1e-10, --max-step 0.04), or give e.g. --rtol 1e-10 for a curve converged more tightly";
    check_rtol(a.tol.rtol, hint)?;
    for (flag, v) in [("--atol", a.tol.atol), ("--max-step", a.max_step)] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(Error::request(
                format!("{flag} {}: must be a positive number", shown(v)),
                hint,
            ));
        }
    }
    if a.max_step > 1.0 {
        return Err(Error::request(
            format!(
                "--max-step {}: larger than the whole curve (the step is a fraction of the curve's size: its parameter range and its largest linear response)",
                shown(a.max_step)
            ),
            "give a fraction of at most 1, or leave --max-step out (0.04); a larger step does not make a coarser curve, since the step follows the curvature",
        ));
    }
    // the largest steps cross the range in 1/max_step of them: fewer points cannot make
    // a curve from --from to --to
    let least = (1.0 / a.max_step).ceil().min(1e9) as usize + 1;
    if a.max_points < least {
        return Err(Error::request(
            format!(
                "--max-points {}: too few to make a curve; the least useful value is {least} (with --max-step {}, the largest steps cross the range in {} points)",
                a.max_points,
                a.max_step,
                least - 1
            ),
            format!(
                "leave --max-points out (3000), or give at least {least}; a fold or a slow flank takes many more"
            ),
        ));
    }
    let (model, sys) = a.model.load()?;
    let size = a.plot_size.check(a.plot.as_deref(), a.output.as_deref())?;
    let outputs = check_outputs(
        &model.source.path,
        &[a.output.as_deref(), a.plot.as_deref()],
    )?;
    let is_freq = sys
        .forcing_param()
        .is_some_and(|i| sys.param_names()[i] == a.param);
    let value = |flag: &str, text: &str| -> Result<f64> {
        if is_freq {
            frequency_value(flag, text)
        } else {
            param_value(&model, &a.param, flag, text)
        }
    };
    if !a.backbone.is_empty() && !is_freq {
        return Err(Error::request(
            format!(
                "--backbone draws against the forcing frequency, and --param {} is not it",
                a.param
            ),
            "continue in the forcing frequency to draw backbones, or leave --backbone out",
        ));
    }
    let modes: Vec<usize> = a
        .backbone
        .iter()
        .map(|m| detune::periodic::backbone::mode_index(&sys, m, None))
        .collect::<Result<_>>()?;
    let from = value("--from", &a.from)?;
    let to = value("--to", &a.to)?;
    let param_unit = if is_freq {
        "rad/s".to_string()
    } else {
        model.param_unit(&a.param)
    };
    if from == to && from.is_finite() {
        return Err(Error::request(
            format!(
                "--from {:?} --to {:?}: the range of {} is empty (both {} {param_unit})",
                a.from,
                a.to,
                a.param,
                detune::diag::num(from)
            ),
            "give two different values",
        ));
    }
    // The continuation starts from the linear response at --from: in the forcing
    // amplitude, there is none at 0 (the orbit there is the equilibrium itself, which the
    // library does not take as a start yet).
    if let Some(f0) = sys.forcing_amplitude_param()
        && sys.param_names()[f0] == a.param
        && from == 0.0
        && to != 0.0
    {
        let start = to.abs() * 1e-3;
        return Err(Error::request(
            format!(
                "--from {}: the curve starts from the linear response at --from, and at {} = 0 the orbit is the equilibrium itself, with no response to start from",
                a.from, a.param
            ),
            format!(
                "start at a small value of the same sign as --to, e.g. --from \"{} {param_unit}\" (1e-3 of --to): the curve from there is the same",
                detune::diag::num(start.copysign(to))
            ),
        ));
    }
    let responses = if a.response.is_empty() {
        model.coordinate_names()
    } else {
        a.response.clone()
    };
    let mut opts = NfrOptions::new(&a.param, from, to, responses);
    opts.shooting.rtol = a.tol.rtol;
    opts.shooting.atol = a.tol.atol;
    opts.shooting.integrator = a.tol.integrator.method();
    opts.max_points = a.max_points;
    opts.max_step = a.max_step;
    interrupt_on_ctrl_c();
    let began = std::time::Instant::now();
    let param = a.param.clone();
    let fu = a.freq.freq_unit;
    // the parameter as named in the lines: `omega/2π` when a frequency is shown in Hz or
    // rpm (cycles: `omega = 0.45 Hz` would read as an angular frequency)
    let pn = if is_freq {
        fu.quantity(&param)
    } else {
        param.clone()
    };
    // a value of the continued parameter as printed: in the chosen frequency unit, or
    // in the parameter's unit, to 7 significant digits
    let shown = |v: f64| -> String {
        if is_freq {
            let f = fu.of(v);
            if f != 0.0 && !(1e-4..1e7).contains(&f.abs()) {
                // 1e150 rad/s, not 151 digits
                format!("{f:.6e} {}", fu.symbol())
            } else {
                format!("{f:.6} {}", fu.symbol())
            }
        } else {
            format!("{} {param_unit}", significant(v, 7))
                .trim_end()
                .to_string()
        }
    };
    // a located value, to the digits its uncertainty supports (at least 7 significant)
    let shown_to = |v: f64, u: f64| -> String {
        let digits = if u > 0.0 && v != 0.0 {
            ((v.abs() / u).log10().ceil() as i64 + 1).clamp(7, 15) as usize
        } else {
            7
        };
        let (x, unit) = if is_freq {
            (fu.of(v), fu.symbol())
        } else {
            (v, param_unit.as_str())
        };
        format!("{} {unit}", significant(x, digits))
            .trim_end()
            .to_string()
    };
    // a difference of values (an uncertainty): two significant digits
    let shown_difference = |v: f64| -> String {
        let v = if is_freq { fu.of(v) } else { v };
        let unit = if is_freq {
            fu.symbol()
        } else {
            param_unit.as_str()
        };
        format!("{} {unit}", significant(v, 2))
            .trim_end()
            .to_string()
    };
    let curve = with_heartbeat(
        "continuing",
        format!("the first point at {pn} = {}", shown(from)),
        |say| {
            nfr(
                &sys,
                &opts,
                &|n, v| say(format!("{n} points, {pn} = {}", shown(v))),
                &INTERRUPTED,
            )
        },
    );
    let mut curve = curve?;
    // how each branch ended, in the JSON: its values with their SI unit (the library's
    // words carry the bare number)
    let si_unit = match param_unit.as_str() {
        "" | "1" => String::new(),
        u => format!(" {u}"),
    };
    for b in &mut curve.branches {
        // (the parameter's own name: `pn` is the cycles form with --freq-unit Hz, whose
        // value would be in rad/s here)
        b.end = b.words(&param, &|v| format!("{v}{si_unit}"));
    }
    if curve.complete && a.backbone.is_empty() {
        // the whole curve: a signal from now on stops nothing
        super::results_complete();
    }
    if let Some(o) = &a.output {
        write_nfr_csv(o, &curve)?;
    }
    if let Some(p) = &a.plot {
        // the backbones, to the largest amplitude of the curve (of the backbone's own
        // reference coordinate when it is a response), else 25 % of frequency shift
        let mut lines = Vec::new();
        for (spec, &mode) in a.backbone.iter().zip(&modes) {
            let bopts = detune::periodic::backbone::BackboneOptions {
                responses: curve.responses.clone(),
                ..Default::default()
            };
            match detune::periodic::backbone::backbone(
                &sys,
                mode,
                f64::INFINITY,
                &bopts,
                &|_, _| {},
                &INTERRUPTED,
            ) {
                Ok(b) => lines.push(detune::output::nfr::BackboneLine {
                    label: format!("backbone of mode {spec}"),
                    omega: b.points.iter().map(|p| p.omega).collect(),
                    amplitudes: b.points.iter().map(|p| p.amplitudes.clone()).collect(),
                }),
                Err(e) => eprintln!("warning: the backbone of mode {spec} is not drawn: {e}"),
            }
        }
        if curve.complete && !INTERRUPTED.load(std::sync::atomic::Ordering::SeqCst) {
            // the whole curve and its backbones
            super::results_complete();
        }
        let figures: Vec<_> = nfr_figures(&Case::of(&model), &curve, &param_unit, &lines)
            .into_iter()
            .map(|f| if is_freq { f.in_frequency_unit(fu) } else { f })
            .collect();
        write_panels_sized(p, &figures, size)?;
    }
    outputs.commit()?;
    for f in [&a.output, &a.plot].into_iter().flatten() {
        eprintln!(
            "wrote {f}{}",
            if curve.complete { "" } else { " (incomplete)" }
        );
    }
    if a.json {
        let mut units = Units::new().with(curve.param.clone(), param_unit.clone());
        units.add(curve.omega_param.clone(), "rad/s");
        super::sweep::add_measure_units(&mut units, &curve.responses, &curve.units);
        let units = units.with_all([
            ("branch", "1"),
            ("floquet_max", "1"),
            ("value", param_unit.as_str()),
            ("omega", "rad/s"),
            (
                "amplitude",
                "the response's unit (its `<response>_amplitude`)",
            ),
            ("multipliers", "1 (complex: re, im, modulus)"),
            ("periods", "1"),
            ("rhs_evaluations", "1"),
            ("uncertainty", param_unit.as_str()),
            ("refined", "1 (true or false)"),
            ("from", param_unit.as_str()),
            ("to", param_unit.as_str()),
            ("unresolved_events", "1"),
            ("change", "the response's unit"),
            ("noise", "the response's unit"),
            ("size", "the response's unit"),
        ]);
        print_json(&WithUnits {
            doc: NfrReport::new(&curve, &Provenance::of(&model)),
            units: &units,
        });
    } else {
        println!(
            "{} points on {} branch{} in {:.2} s ({} periods, {} right-hand-side evaluations); {} degree{} of freedom, {} Floquet multipliers a point",
            curve.points.len(),
            curve.branches.len(),
            if curve.branches.len() == 1 { "" } else { "es" },
            began.elapsed().as_secs_f64(),
            curve.periods,
            curve.rhs_evaluations,
            curve.dof,
            if curve.dof == 1 { "" } else { "s" },
            2 * curve.dof
        );
        for b in &curve.branches {
            println!(
                "branch {}: from {} = {}, {} points; {}",
                b.index,
                pn,
                shown(b.from),
                b.points,
                b.words(&pn, &shown)
            );
        }
        let amp = |s: &detune::periodic::continuation::Special| -> String {
            curve
                .responses
                .iter()
                .zip(&s.amplitude)
                .zip(&curve.units)
                .map(|((r, x), u)| format!("{r} {x:.6e} {u}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        for s in curve
            .folds
            .iter()
            .chain(&curve.period_doublings)
            .chain(&curve.neimark_sacker)
        {
            println!(
                "{} at {} = {} ({}): amplitude {}; {}",
                match s.kind {
                    detune::periodic::continuation::Located::Fold => "fold",
                    detune::periodic::continuation::Located::PeriodDoubling => "period doubling",
                    _ => "Neimark-Sacker point",
                },
                pn,
                shown_to(s.value, s.uncertainty),
                located_to(s.refined, s.uncertainty, &shown_difference),
                amp(s),
                jump_words(&curve, s)
            );
        }
        if curve.unresolved_events > 0 {
            println!(
                "{} sign change{} of the stability tests between orbits whose largest Floquet multiplier exceeds 1e3 not reported: single shooting does not resolve the smaller multipliers there (the curve's points are right; their stability is that of the largest multiplier)",
                curve.unresolved_events,
                if curve.unresolved_events == 1 {
                    ""
                } else {
                    "s"
                }
            );
        }
        for p in &curve.peaks {
            let unit = curve.unit_of(&p.response);
            println!(
                "peak {}: {} = {} ({}), amplitude {:.6e} {unit}",
                p.response,
                pn,
                shown_to(p.value, p.uncertainty),
                located_to(p.refined, p.uncertainty, &shown_difference),
                p.amplitude
            );
        }
        for np in &curve.no_peaks {
            let unit = curve.unit_of(&np.response);
            let head = format!("no peaks sought for {}", np.response);
            println!("{}", super::sweep::no_peaks_words(&head, &np.why, unit));
        }
    }
    if !curve.complete {
        if INTERRUPTED.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(detune::failure::Failure::StudyInterrupted {
                what: "the continuation".into(),
                kept: true,
            }
            .into());
        }
        // what stopped it, from the branches' ends (the library's words)
        use detune::periodic::continuation::BranchEnd;
        let ended = |what: BranchEnd| curve.branches.iter().any(|b| b.ended == what);
        let help = if ended(BranchEnd::Stalled) && curve.motion < detune::periodic::TOO_SMALL_MOTION
        {
            &format!(
                "the forced motion falls to {:.1e} of the coordinates' values in the range, too small for shooting in double precision: raise the forcing amplitude (the response is linear at this level: `detune frf` gives it), or end --from/--to where the motion is larger",
                curve.motion
            )
        } else if ended(BranchEnd::Stalled) {
            "the branch lines above say where: tighten --rtol/--atol, lower --max-step, or end --from/--to before that value (a non-smooth element there may need a wider smoothing)"
        } else if ended(BranchEnd::Unstable) {
            "the orbit there is too unstable for single shooting: end --from/--to before that value"
        } else {
            "raise --max-points, or narrow --from/--to around what matters"
        };
        return Err(Error::request(
            format!(
                "the continuation stopped after {} points without covering the range",
                curve.points.len()
            ),
            help,
        ));
    }
    Ok(())
}

/// `--rtol` of a periodic orbit, refused outside 1e-15..1e-3 with `hint`: its Newton
/// iteration converges to about 100·rtol of its amplitude (worse than 10 % above 1e-3:
/// `--rtol 0.5` gave a period doubling 2.1e-5 rad/s off, stated ± 3.2e-7), and below
/// 1e-15 the steps shrink to the rounding. Also `backbone`'s.
pub fn check_rtol(v: f64, hint: &str) -> Result<()> {
    if (1e-15..=1e-3).contains(&v) {
        return Ok(());
    }
    Err(Error::request(
        format!(
            "--rtol {}: must be a positive number from 1e-15 to 1e-3 (orbits are converged to about 100·rtol of their amplitude; below 1e-15 the integration's steps shrink to the rounding)",
            shown(v)
        ),
        hint,
    ))
}

/// A tolerance as a user types it: 1e-20, not 0.00000000000000000001.
fn shown(v: f64) -> String {
    if v != 0.0 && v.abs() < 1e-4 {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// How often a long run says where it is on a stderr that is not a terminal (a log
/// file, a pipe, a batch job's output).
pub const HEARTBEAT: std::time::Duration = std::time::Duration::from_secs(10);

/// Run `work` with its progress shown: `work` is given `say(message)` to call as it moves
/// on. On a terminal, a spinner `{label} ⠋ {message} {elapsed}` that ticks by itself (a
/// slow point, seconds near the period floor, still shows time passing); on any other
/// stderr, where the spinner is hidden, a plain line `{label}: {message} ({elapsed} s)`
/// every [`HEARTBEAT`] while the work lasts (none for a run shorter than that).
pub fn with_heartbeat<T>(label: &str, first: String, work: impl FnOnce(&dyn Fn(String)) -> T) -> T {
    if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        let bar = indicatif::ProgressBar::new_spinner();
        bar.set_style(
            indicatif::ProgressStyle::with_template(&format!(
                "{label} {{spinner}} {{msg}} {{elapsed}}"
            ))
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
        );
        bar.set_message(first);
        bar.enable_steady_tick(std::time::Duration::from_millis(200));
        let out = work(&|m| bar.set_message(m));
        bar.finish_and_clear();
        return out;
    }
    heartbeat_lines(label, first, HEARTBEAT, &mut std::io::stderr(), work)
}

/// [`with_heartbeat`] off a terminal: `label: message (elapsed s)` to `out` every `every`
/// while `work` runs (the first after `every`).
fn heartbeat_lines<T, W: std::io::Write + Send>(
    label: &str,
    first: String,
    every: std::time::Duration,
    out: &mut W,
    work: impl FnOnce(&dyn Fn(String)) -> T,
) -> T {
    use std::sync::{Condvar, Mutex};
    let began = std::time::Instant::now();
    let message = Mutex::new(first);
    let done = (Mutex::new(false), Condvar::new());
    std::thread::scope(|scope| {
        scope.spawn(|| {
            let (lock, cv) = &done;
            let mut finished = lock.lock().unwrap_or_else(|e| e.into_inner());
            let mut next = began + every;
            while !*finished {
                let now = std::time::Instant::now();
                if now >= next {
                    let m = message.lock().map(|m| m.clone()).unwrap_or_default();
                    let _ = writeln!(out, "{label}: {m} ({:.0} s)", began.elapsed().as_secs_f64());
                    next += every;
                    continue;
                }
                finished = cv
                    .wait_timeout(finished, next - now)
                    .unwrap_or_else(|e| e.into_inner())
                    .0;
            }
        });
        let result = work(&|m| {
            if let Ok(mut slot) = message.lock() {
                *slot = m;
            }
        });
        let (lock, cv) = &done;
        *lock.lock().unwrap_or_else(|e| e.into_inner()) = true;
        cv.notify_all();
        result
    })
}

#[cfg(test)]
#[test]
fn heartbeat_lines_say_the_latest_message_while_the_work_lasts() {
    let mut out: Vec<u8> = Vec::new();
    let every = std::time::Duration::from_millis(40);
    let answer = heartbeat_lines(
        "continuing",
        "the first point".into(),
        every,
        &mut out,
        |say| {
            std::thread::sleep(5 * every);
            say("3 points, omega = 2.5 rad/s".into());
            std::thread::sleep(10 * every);
            42
        },
    );
    assert_eq!(answer, 42);
    let text = String::from_utf8(out).unwrap();
    // a line a tick, each with the message of its moment: the latest one too
    assert!(
        text.lines()
            .all(|l| l.starts_with("continuing: ") && l.ends_with(" s)")),
        "{text}"
    );
    assert!(
        text.lines()
            .any(|l| l.starts_with("continuing: 3 points, omega = 2.5 rad/s (")),
        "{text}"
    );
    // and none after the work: a short run says nothing
    let mut quiet: Vec<u8> = Vec::new();
    heartbeat_lines(
        "x",
        "y".into(),
        std::time::Duration::from_secs(60),
        &mut quiet,
        |_| (),
    );
    assert!(quiet.is_empty());
}

/// How well a located point is known: "± 2.5e-5 rad/s", or, where locating failed,
/// that it is the continuation's own point.
fn located_to(refined: bool, uncertainty: f64, shown: &dyn Fn(f64) -> String) -> String {
    if refined {
        format!("± {}", shown(uncertainty))
    } else {
        format!(
            "not refined: ± {}, the continuation's step",
            shown(uncertainty)
        )
    }
}
