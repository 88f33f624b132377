//! `detune sweep`: the stepped-sine frequency response of the nonlinear model, for one
//! model or a family over the values of a parameter (`--values`, repeatable for a grid),
//! resumable from a checkpoint (`--checkpoint`) and split over processes (`--shard`,
//! joined by `detune merge`, which runs the same code with every case from the shards:
//! see [`execute`]).

use super::args::{FrequencyGrid, ModelArgs, Tolerances};
use super::{INTERRUPTED, interrupt_on_ctrl_c, print_json, progress_bar};
use clap::Args;
use detune::diag::{Error, Result};
use detune::frequency::checkpoint::{self, CaseLog, Checkpoint, Header, NoLog, Shard};
use detune::frequency::study::SweepStudy;
use detune::frequency::{Progress, SteadyOptions, SweepMode, SweepOptions};
use detune::output::Provenance;
use detune::output::commit::OutputSet;
use detune::output::figures::{Case, sweep_figures};
use detune::output::json::SweepReport;
use detune::output::plot::write_panels_sized;
use detune::output::results::write_sweep_csv;
use detune::output::units::{Units, WithUnits};
use std::sync::atomic::{AtomicBool, Ordering};

/// The units of `sweep --json`: the CSV's columns (the frequency in rad/s, each response's
/// measures in its unit, the phase in degrees; the `--values` parameter in its unit), the
/// coordinates, and the peaks', jumps' and hysteresis' keys.
fn sweep_units(runs: &[detune::frequency::study::SweepRun], sys: &detune::System) -> Units {
    let first = &runs[0].sweep;
    let mut u = Units::new().with(first.param.clone(), "rad/s");
    for ((name, _), unit) in runs[0].tags().into_iter().zip(&runs[0].units) {
        u.add(name, unit.clone());
    }
    add_measure_units(&mut u, &first.responses, &first.units);
    u.with_all([("periods", "1"), ("period_multiple", "1"), ("well", "1")])
        .coordinates(sys)
        .with_all([
            ("omega", "rad/s"),
            ("uncertainty", "rad/s"),
            ("from", "rad/s"),
            ("to", "rad/s"),
            (
                "amplitude",
                "the response's unit (its `<response>_amplitude`)",
            ),
            ("amplitude_before", "the response's unit"),
            ("amplitude_after", "the response's unit"),
            ("change", "the response's unit"),
            ("noise", "the response's unit"),
            ("size", "the response's unit"),
            ("omega2", "rad^2/s^2"),
        ])
}

/// The units of each response's measures (`<r>_amplitude` ... `<r>_thd`), as the CSV
/// columns of a sweep and of `nfr` name them.
pub fn add_measure_units(u: &mut Units, responses: &[String], units: &[&'static str]) {
    for (r, unit) in responses.iter().zip(units) {
        for m in ["amplitude", "max", "min", "mean", "h1", "h2"] {
            u.add(format!("{r}_{m}"), *unit);
        }
        u.add(format!("{r}_phase_deg"), "deg");
        u.add(format!("{r}_thd"), "1");
    }
}

/// The tolerance whose term dominates a still response's noise, as advice.
fn tighten(w: &detune::frequency::measure::Still) -> &'static str {
    if w.absolute {
        "tighten --atol"
    } else {
        "tighten --rtol"
    }
}

/// A response whose peaks were not sought (`sweep`, `nfr`), in words: why, with the
/// numbers, and what would resolve it. `head` names it (`no peaks sought for x (up)`).
pub fn no_peaks_words(head: &str, w: &detune::frequency::measure::Still, unit: &str) -> String {
    use detune::frequency::measure::StillKind;
    match w.kind {
        StillKind::RoundOff if w.amplitude == 0.0 => {
            format!("{head}: it does not move (amplitude 0 {unit})")
        }
        StillKind::RoundOff => format!(
            "{head}: it does not move (largest amplitude {:.3e} {unit}: round-off beside the other responses in {unit})",
            w.amplitude
        ),
        // far below the noise: what the tolerances show is a constant amplitude
        StillKind::Unchanging if w.change < 1e-2 * w.noise => format!(
            "{head}: its amplitude is the same all along the range ({:.6e} {unit}, to {:.1e} {unit}): the forcing does not change it (a motion the moving ground carries, say)",
            w.amplitude, w.change
        ),
        // below double precision's resolution of its value: no tolerance resolves it
        StillKind::BelowNoise | StillKind::Unchanging if w.amplitude < 1e-13 * w.size => {
            format!(
                "{head}: its amplitude, {:.3e} {unit}, is below what double precision resolves at its value ({:.3e} {unit}): no tolerance can resolve it",
                w.amplitude, w.size
            )
        }
        StillKind::BelowNoise => format!(
            "{head}: its largest amplitude, {:.3e} {unit}, is below the integration's noise ({:.1e} {unit}); {} to resolve it",
            w.amplitude,
            w.noise,
            tighten(w)
        ),
        StillKind::Unchanging => format!(
            "{head}: its amplitude ({:.3e} {unit} at most) changes by {:.1e} {unit} over the range, within the integration's noise ({:.1e} {unit}): constant, or a motion too small against its coordinate's value to resolve; {} to resolve it",
            w.amplitude,
            w.change,
            w.noise,
            tighten(w)
        ),
    }
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum ModeArg {
    /// every frequency from the equilibrium at rest, in parallel
    Independent,
    /// increasing frequency, each from the previous steady state
    Up,
    /// decreasing frequency, each from the previous steady state
    Down,
    /// up, then down; reports where they differ (hysteresis)
    Both,
}

#[derive(Args)]
pub struct SweepArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    #[command(flatten)]
    pub grid: FrequencyGrid,
    /// Locate every resonance (local maximum of the amplitude) to this resolution: rad/s,
    /// or a quantity ("0.01 Hz").
    #[arg(long, value_name = "R", allow_hyphen_values = true)]
    pub refine: Option<String>,
    #[arg(long, value_enum, default_value = "independent")]
    pub mode: ModeArg,
    /// Repeat the sweep for each value of a parameter: PARAM=v1,v2,... (e.g. F0=0.1,1,2).
    /// Repeatable: every combination (a grid), the first --values varying slowest.
    #[arg(long, value_name = "PARAM=V1,V2,...", allow_hyphen_values = true)]
    pub values: Vec<String>,
    /// Settling tolerance: Poincaré points agree to this fraction of the amplitude.
    #[arg(
        long,
        default_value_t = 1e-8,
        value_name = "TOL",
        allow_hyphen_values = true
    )]
    pub settle_tol: f64,
    /// Most periods per frequency.
    #[arg(long, default_value_t = 600, value_name = "N")]
    pub max_periods: usize,
    #[command(flatten)]
    pub tol: Tolerances,
    /// CSV: one row per frequency (and direction and --values entry).
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    pub output: Option<String>,
    /// Print the JSON result.
    #[arg(long)]
    pub json: bool,
    /// Figure (.svg or .png): each response's amplitude against frequency (with
    /// --values over the forcing amplitude, also divided by it), the linear natural
    /// frequencies drawn, refined peaks and jumps marked.
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<String>,
    /// A labelled frequency drawn on the plot, LABEL=VALUE (VALUE in rad/s or a
    /// quantity): `--mark "UH-60 main rotor 1P=258 rpm"`. Repeatable.
    #[arg(long, value_name = "LABEL=VALUE")]
    pub mark: Vec<String>,
    #[command(flatten)]
    pub freq: super::args::FreqUnitArg,
    #[command(flatten)]
    pub plot_size: super::args::PlotSize,
    /// Append each finished frequency (of each --values case) to FILE as it completes;
    /// the same command with the same FILE resumes, skipping what is done (the outputs are
    /// identical to an uninterrupted run's). A FILE of another model, options or detune
    /// version is refused.
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<String>,
    /// Compute shard K of N (1 ≤ K ≤ N) of the study's cases into --checkpoint FILE;
    /// join the N checkpoints with `detune merge`. Independent sweeps are split by
    /// frequency × --values case, up/down/both by --values case only. Needs
    /// --checkpoint (a usage error, exit 2, without it).
    #[arg(long, value_name = "K/N", requires = "checkpoint")]
    pub shard: Option<String>,
    /// Refine the peaks of a coarse independent sweep already computed (the CSV of a run
    /// or of `detune merge` with the same options): its frequencies are read, not
    /// recomputed; only the refinement is simulated. Needs --refine.
    #[arg(long, value_name = "ALL.csv")]
    pub refine_from: Option<String>,
}

/// Where a sweep's cases come from: the command line (with its arguments after
/// `sweep`, stored in a checkpoint's header), or the shards' checkpoints of a merge.
pub enum Source {
    Command(Vec<String>),
    Merge(Box<Checkpoint>),
}

pub fn run(a: SweepArgs) -> Result<()> {
    let command = std::env::args_os()
        .skip(2)
        .map(|s| s.to_string_lossy().into_owned())
        .collect();
    execute(a, Source::Command(command))
}

/// The sweep of `a`, its cases from `source`: computed (looked up in and recorded to
/// `--checkpoint FILE`, a shard's share only with `--shard`), or all taken from the
/// shards' checkpoints of a merge, which then writes exactly what one run writes.
pub fn execute(a: SweepArgs, source: Source) -> Result<()> {
    let shard = a.shard.as_deref().map(Shard::parse).transpose()?;
    if let Some(s) = shard {
        refuse_with_shard(&a, s)?;
    }
    let (model, compiled) = a.model.load()?;
    let size = a.plot_size.check(a.plot.as_deref(), a.output.as_deref())?;
    // an output over the --refine-from CSV would replace the study it refines
    let mut inputs = vec![("model file", model.source.path.as_str())];
    if let Some(csv) = &a.refine_from {
        inputs.push(("--refine-from CSV", csv.as_str()));
    }
    let outputs = OutputSet::plan(&inputs, &[a.output.as_deref(), a.plot.as_deref()])?;
    if let Some(c) = &a.checkpoint
        && [a.output.as_deref(), a.plot.as_deref()]
            .into_iter()
            .flatten()
            .any(|o| detune::output::commit::same_file(o, c))
    {
        return Err(Error::request(
            format!("--checkpoint {c} is also an output"),
            "give the checkpoint its own file (e.g. sweep.ckpt)",
        ));
    }
    let (values, responses) = a.grid.resolve(&model)?;
    // a figure size with no room for the panels must not cost a sweep either: a panel per
    // response, and as many again normalized by the forcing amplitude when --values
    // varies it (`output::figures::sweep_figures`)
    let normalized = a
        .values
        .first()
        .and_then(|v| v.split_once('='))
        .is_some_and(|(name, _)| Some(name.trim()) == model.forcing_amplitude.as_deref());
    let runs = a
        .values
        .iter()
        .map(|v| v.split(',').count())
        .product::<usize>();
    super::args::check_panels(size, responses.len() * if normalized { 2 } else { 1 }, runs)?;
    // checked before any simulation: a bad mark must not cost a sweep
    let marks = super::args::frequency_marks(&a.mark, &values, a.plot.is_some())?;
    let opts = SweepOptions {
        param: a.grid.param.clone(),
        values,
        mode: match a.mode {
            ModeArg::Independent => SweepMode::Independent,
            ModeArg::Up => SweepMode::Up,
            ModeArg::Down => SweepMode::Down,
            ModeArg::Both => SweepMode::Both,
        },
        responses,
        refine: a
            .refine
            .as_deref()
            .map(|r| super::args::frequency_value("--refine", r))
            .transpose()?,
        steady: SteadyOptions {
            rtol: a.tol.rtol,
            atol: a.tol.atol,
            integrator: a.tol.integrator(),
            settle_tol: a.settle_tol,
            max_periods: a.max_periods,
            ..SteadyOptions::default()
        },
    };
    // Every run is checked before any is simulated: a bad --values entry fails at once.
    let study = SweepStudy::new(&model, &a.values, opts)?;
    let labels: Vec<String> = study
        .runs
        .iter()
        .map(|r| detune::frequency::study::values_label(&r.values))
        .collect();
    if let Some(s) = shard {
        let cases = study.shardable_cases();
        if s.n > cases {
            return Err(Error::request(
                format!(
                    "--shard {}/{}: the study has {cases} independent case{} to share, fewer than {} shards{}",
                    s.k,
                    s.n,
                    if cases == 1 { "" } else { "s" },
                    s.n,
                    if study.sequential() {
                        " (up, down and both sweep each --values case in one sequence: they are sharded by --values case only, never by frequency)"
                    } else {
                        " (frequencies × --values cases)"
                    }
                ),
                format!("use at most {cases} shards"),
            ));
        }
    }
    let merging = matches!(source, Source::Merge(_));
    let log: Box<dyn CaseLog> = match source {
        Source::Merge(mut c) => {
            if c.header.fingerprint != study.fingerprint() {
                return Err(Error::request(
                    format!(
                        "the shards are not of this model: the model file {} (or a file it reads) changed since they ran (sha256 {} in the shards, {} now)",
                        model.source.path,
                        &c.header.model_sha256[..12.min(c.header.model_sha256.len())],
                        &model.hash[..12.min(model.hash.len())]
                    ),
                    "merge with the model the shards ran on, or run them again",
                ));
            }
            c.set_grid(&study.options.values);
            c.run_labels = labels;
            c
        }
        Source::Command(_) if a.refine_from.is_some() => {
            let csv = a.refine_from.as_deref().unwrap_or_default();
            Box::new(refine_from(csv, &a, &study)?)
        }
        Source::Command(command) => match &a.checkpoint {
            None => Box::new(NoLog),
            Some(path) => {
                let header = Header {
                    format: checkpoint::FORMAT.into(),
                    format_version: checkpoint::FORMAT_VERSION,
                    detune_version: checkpoint::detune_version(),
                    model_file: model.source.path.clone(),
                    model_sha256: model.hash.clone(),
                    overrides: Provenance::of(&model).overrides,
                    fingerprint: study.fingerprint(),
                    command,
                    shard: shard.unwrap_or(Shard::ALL),
                    sequential: study.sequential(),
                    grid: study.options.values.len(),
                    runs: study.runs.len(),
                    study: None,
                };
                let mut c = Checkpoint::open(path, header, &study.options.values)?;
                c.run_labels = labels;
                if c.reused > 0 {
                    eprintln!(
                        "resuming from the checkpoint {path}: {} steady states done before",
                        c.reused
                    );
                }
                Box::new(c)
            }
        },
    };
    if !merging {
        interrupt_on_ctrl_c();
    }
    const GRID: &str = "sweeping {bar:40} {pos}/{len} frequencies {elapsed} (eta {eta})";
    const REFINE: &str = "refining peaks {bar:40} {pos}/{len} steady states {elapsed} (eta {eta})";
    let grid_len = study.frequencies_of(log.as_ref()) as u64;
    let bar = progress_bar(grid_len, GRID);
    // the coarse grid and the peak refinement are separate stages, each with its own bar
    let refining = AtomicBool::new(false);
    let style = |t: &str| {
        indicatif::ProgressStyle::with_template(t)
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
    };
    let began = std::time::Instant::now();
    let watch = super::StiffWatch::new(&a.grid.param);
    let runs = study.run_partial(
        &|p: Progress| {
            let refine = p.refine_expected > 0;
            if refine != refining.swap(refine, Ordering::SeqCst) {
                bar.set_style(style(if refine { REFINE } else { GRID }));
                bar.set_length(if refine {
                    p.refine_expected as u64
                } else {
                    grid_len
                });
                bar.reset_eta();
            }
            let (pos, len) = if refine {
                (p.refined as u64, p.refine_expected as u64)
            } else {
                (p.grid as u64, grid_len)
            };
            if pos > bar.length().unwrap_or(len) {
                bar.set_length(pos);
            }
            bar.set_position(pos);
        },
        &INTERRUPTED,
        log.as_ref(),
        &|at| watch.found("", at, &bar),
    );
    bar.finish_and_clear();
    let runs = runs.map_err(|e| {
        no_steady_state(
            e,
            &model,
            &compiled,
            &[],
            &a,
            "nothing was written",
            checkpoint::CaseKind::Coarse,
        )
    })?;
    let complete = runs.iter().all(|r| r.sweep.complete);
    let points: usize = runs.iter().map(|r| r.sweep.points.len()).sum();
    // a frequency whose steady state could not be computed stopped the sweep: what was
    // finished before it is written, marked incomplete as an interrupted sweep's is, and
    // the run still fails (exit 1), saying what was kept
    let failed = runs
        .iter()
        .find_map(|r| Some((r, r.sweep.failure.clone()?)));
    if complete && failed.is_none() {
        // every frequency is computed: a signal from now on stops nothing (exit 0 with a
        // note once the outputs are written, as simulate, nfr and backbone)
        super::results_complete();
    }
    let failed_error = |kept: &str| -> Option<Error> {
        let (run, f) = failed.as_ref()?;
        // the failing run's own system and values (a --values family's run differs from
        // the base model: its forcing, the command that shows its motion)
        let sys = study
            .runs
            .iter()
            .find(|r| r.values == run.values)
            .map_or(&compiled, |r| &r.system);
        let e = no_steady_state(f.error.clone(), &model, sys, &run.values, &a, kept, f.kind);
        let e = if let Error::Numerical { .. } = e {
            e
        } else {
            // a failure without its own wording: its message and help, and what was kept
            let (message, help) = typed_parts(&e);
            Error::numerical(
                format!(
                    "the sweep stopped at {} = {} rad/s ({}): {message}; {kept}",
                    a.grid.param,
                    detune::diag::num(f.omega),
                    f.stage()
                ),
                help,
            )
        };
        Some(match run.values.as_slice() {
            [] => e,
            [(name, v)] => e.in_run(name, v),
            more => e.in_run("--values", detune::frequency::study::values_label(more)),
        })
    };
    if failed.is_some() && points == 0 {
        let kept = match (shard, &a.checkpoint) {
            // an independent shard's frequencies above the failure may have finished
            (Some(_), Some(path)) => format!(
                "no frequency of this shard below it was finished; the checkpoint {path} keeps any finished above it"
            ),
            _ => "nothing was written".to_string(),
        };
        return Err(failed_error(&kept).expect("a failure"));
    }
    if let (Some(s), Some(path)) = (shard, &a.checkpoint) {
        println!(
            "shard {}/{}: {points} frequencies in {:.2} s{}, in the checkpoint {path}; join all {} with `detune merge CHECKPOINT... -o all.csv`",
            s.k,
            s.n,
            began.elapsed().as_secs_f64(),
            if failed.is_some() {
                " (incomplete: stopped by a failing frequency)"
            } else if complete {
                ""
            } else {
                " (incomplete: run the same command again to resume)"
            },
            s.n
        );
        if let Some(e) = failed_error(&format!(
            "the {points} frequencies of this shard finished before it are in the checkpoint {path}"
        )) {
            return Err(e);
        }
        if !complete {
            return Err(detune::failure::Failure::SweepInterrupted.into());
        }
        return Ok(());
    }
    let fu = a.freq.freq_unit;
    let sym = fu.symbol();
    if let Some(o) = &a.output {
        write_sweep_csv(o, &runs)?;
    }
    if let Some(p) = &a.plot {
        let natural = study.natural_frequencies(runs.len())?;
        let forcing = compiled
            .forcing_amplitude_param()
            .map(|i| compiled.param_names()[i].clone());
        let figures: Vec<_> = sweep_figures(
            &Case::of(&model),
            &runs,
            &natural,
            &marks,
            forcing.as_deref(),
        )
        .into_iter()
        .map(|f| f.in_frequency_unit(fu))
        .collect();
        write_panels_sized(p, &figures, size)?;
    }
    // an interrupted sweep keeps the frequencies completed, marked incomplete
    outputs.commit()?;
    if let Some(o) = &a.output {
        eprintln!("wrote {o}{}", if complete { "" } else { " (incomplete)" });
    }
    if let Some(p) = &a.plot {
        eprintln!("wrote {p}");
    }
    if a.json {
        let units = sweep_units(&runs, &compiled);
        print_json(&WithUnits {
            doc: super::Warned {
                doc: SweepReport::new(&runs, &Provenance::of(&model)),
                warnings: watch.warnings(),
            },
            units: &units,
        });
    } else {
        let points: usize = runs.iter().map(|r| r.sweep.points.len()).sum();
        let periods: usize = runs
            .iter()
            .flat_map(|r| &r.sweep.points)
            .map(|p| p.steady.periods)
            .sum();
        let unsettled = runs
            .iter()
            .flat_map(|r| &r.sweep.points)
            .filter(|p| !p.steady.settled)
            .count();
        println!(
            "{points} frequencies in {:.2} s, {:.1} periods per frequency{}",
            began.elapsed().as_secs_f64(),
            periods as f64 / points.max(1) as f64,
            if unsettled > 0 {
                format!(", {unsettled} NOT settled (raise --max-periods)")
            } else {
                String::new()
            }
        );
        // a grid frequency as the user reads it: as computed in rad/s, else in the unit
        let shown = |w: f64| -> String {
            if fu == detune::output::units::FreqUnit::RadPerSecond {
                w.to_string()
            } else {
                format!("{:.6}", fu.of(w))
            }
        };
        for run in &runs {
            // the run's values with their units, as the plot's notes name them
            let tag = match run.label() {
                Some(l) if !l.is_empty() => format!(" [{l}]"),
                _ => String::new(),
            };
            for line in detune::output::figures::well_summary(run, fu) {
                println!("{line}{tag}");
            }
            for j in &run.sweep.jumps {
                let unit = run.sweep.unit_of(&j.response);
                println!(
                    "jump {} between {} and {} {sym}{tag}: {} amplitude {:.4} → {:.4} {unit}",
                    j.direction.name(),
                    shown(j.from),
                    shown(j.to),
                    j.response,
                    j.amplitude_before,
                    j.amplitude_after
                );
            }
            for pk in &run.sweep.peaks {
                let unit = run.sweep.unit_of(&pk.response);
                // refined, or the grid's maximum (± its step), as `nfr` and `frf` say it
                println!(
                    "peak{tag} {} ({}): {} = {}, amplitude {:.6e} {unit}",
                    pk.response,
                    pk.direction.name(),
                    fu.quantity(&a.grid.param),
                    detune::output::units::located(
                        fu.of(pk.omega),
                        fu.of(pk.uncertainty),
                        sym,
                        a.refine.is_none().then_some("the grid's step"),
                    ),
                    pk.amplitude
                );
            }
            for np in &run.sweep.no_peaks {
                let unit = run.sweep.unit_of(&np.response);
                let head = format!(
                    "no peaks sought{tag} for {} ({})",
                    np.response,
                    np.direction.name()
                );
                println!("{}", no_peaks_words(&head, &np.why, unit));
            }
            for h in &run.sweep.hysteresis {
                println!(
                    "hysteresis{tag}: up and down differ from {} to {} {sym}",
                    shown(h.from),
                    shown(h.to)
                );
            }
        }
    }
    if let Some(e) = failed
        .as_ref()
        .and_then(|(_, f)| failed_error(&kept_words(&runs, &a, points, f)))
    {
        return Err(e);
    }
    if !complete {
        return Err(detune::failure::Failure::SweepInterrupted.into());
    }
    Ok(())
}

/// A rendered error's message and help line, from its typed parts (the command line's
/// advice for a failure or an invalid request), for quoting it inside another.
fn typed_parts(e: &Error) -> (String, String) {
    use detune::diag::Advice;
    let cli = super::advice::Cli;
    if let Some(f) = e.failure() {
        return (f.to_string(), cli.failure(f).unwrap_or_else(|| f.hint()));
    }
    if let Some(i) = e.invalid() {
        return cli
            .invalid(i)
            .map(|w| (w.message, w.help))
            .unwrap_or_else(|| (i.to_string(), i.hint()));
    }
    match e {
        Error::Numerical { message, help } | Error::Request { message, help } => {
            (message.clone(), help.clone().unwrap_or_default())
        }
        _ => (e.headline(), String::new()),
    }
}

/// What a failed sweep kept, for its error message, by the failing stage: `kept the 2
/// frequencies finished before it (0.5 to 0.75 rad/s), written marked incomplete:
/// /tmp/x.csv, the plot /tmp/x.svg, the JSON on standard output`; after a jump check or
/// a peak refinement, the whole coarse grid (and that the peak is left out).
fn kept_words(
    runs: &[detune::frequency::study::SweepRun],
    a: &SweepArgs,
    points: usize,
    failure: &detune::frequency::SweepFailure,
) -> String {
    use detune::frequency::checkpoint::CaseKind;
    let omegas = runs
        .iter()
        .flat_map(|r| &r.sweep.points)
        .map(|p| p.steady.omega);
    let lo = omegas.clone().fold(f64::INFINITY, f64::min);
    let hi = omegas.fold(f64::NEG_INFINITY, f64::max);
    let mut to = Vec::new();
    if let Some(o) = &a.output {
        to.push(o.clone());
    }
    if let Some(p) = &a.plot {
        to.push(format!("the plot {p}"));
    }
    if a.json {
        to.push("the JSON on standard output".into());
    }
    // the runs that kept something (a failing run may have kept nothing)
    let with_points = runs.iter().filter(|r| !r.sweep.points.is_empty()).count();
    let cases = if runs.len() > 1 {
        format!(
            "in {with_points} --values case{}, ",
            if with_points == 1 { "" } else { "s" }
        )
    } else {
        String::new()
    };
    let n = format!("{points} frequenc{}", if points == 1 { "y" } else { "ies" });
    let what = match failure.kind {
        CaseKind::Coarse => format!("kept the {n} finished before it"),
        CaseKind::Back => format!(
            "kept the whole coarse grid ({n}); the jumps from that edge on were not checked"
        ),
        CaseKind::Refine => format!(
            "kept the whole coarse grid and the other peaks ({n}); the peak being refined there is left out"
        ),
    };
    format!(
        "{what} ({cases}{} to {} rad/s){}",
        detune::diag::num(lo),
        detune::diag::num(hi),
        if to.is_empty() {
            ", printed above (give -o, --plot or --json to write them)".to_string()
        } else {
            format!(", written marked incomplete: {}", to.join(", "))
        }
    )
}

/// What `--shard` cannot be combined with, refused before any work.
fn refuse_with_shard(a: &SweepArgs, s: Shard) -> Result<()> {
    if a.refine.is_some() {
        return Err(Error::request(
            format!(
                "--refine cannot be used with --shard {}/{}: refining a peak needs the whole coarse curve, which a shard does not have",
                s.k, s.n
            ),
            "sweep the coarse grid in shards, merge them (`detune merge SHARD.ckpt... -o all.csv --checkpoint all.ckpt`), then refine in one unsharded run that reuses every coarse frequency: the same sweep command without --shard, with --refine R --refine-from all.csv (independent sweeps) or --refine R --checkpoint all.ckpt (any mode)",
        ));
    }
    if a.checkpoint.is_none() {
        return Err(Error::request(
            format!(
                "--shard {}/{} needs --checkpoint FILE: a shard's results go there",
                s.k, s.n
            ),
            "e.g. --shard 2/8 --checkpoint part-2.ckpt; then `detune merge part-*.ckpt -o all.csv`",
        ));
    }
    if a.output.is_some() || a.plot.is_some() || a.json {
        return Err(Error::request(
            format!(
                "--shard {}/{} writes its cases to --checkpoint only: -o, --plot and --json are of the whole study",
                s.k, s.n
            ),
            "give -o, --plot and --json to `detune merge`, which joins the shards' checkpoints",
        ));
    }
    Ok(())
}

/// `--refine-from ALL.csv`: the coarse cases of an independent sweep read from its CSV
/// (every number in it reads back to the same bits), the refinement computed. A coarse
/// frequency the CSV lacks is refused, never computed: the CSV must be of this sweep.
struct CsvCases {
    path: String,
    known: std::collections::HashMap<checkpoint::CaseKey, (detune::frequency::SteadyState, isize)>,
}

impl CaseLog for CsvCases {
    fn lookup(
        &self,
        key: &checkpoint::CaseKey,
    ) -> Result<Option<(detune::frequency::SteadyState, isize)>> {
        match self.known.get(key) {
            Some(c) => Ok(Some(c.clone())),
            None if key.kind == checkpoint::CaseKind::Refine => Ok(None),
            None => Err(Error::request(
                format!(
                    "{} lacks the frequency {} rad/s of this sweep (run {})",
                    self.path,
                    f64::from_bits(key.omega),
                    key.run + 1
                ),
                "--refine-from reads the CSV of the same sweep (the same model, --set, --values, grid and options, without --refine)",
            )),
        }
    }
    fn record(
        &self,
        _: &checkpoint::CaseKey,
        _: &detune::frequency::SteadyState,
        _: isize,
    ) -> Result<()> {
        Ok(())
    }
}

fn refine_from(path: &str, a: &SweepArgs, study: &SweepStudy) -> Result<CsvCases> {
    use detune::frequency::checkpoint::{CaseKey, CaseKind};
    use detune::frequency::measure::Measures;
    if a.refine.is_none() || study.sequential() || a.checkpoint.is_some() || a.shard.is_some() {
        return Err(Error::request(
            "--refine-from needs --refine R, an independent sweep (--mode independent), and neither --checkpoint nor --shard",
            "for up/down/both the refinement starts from stored end states, which a CSV lacks: merge the shards with --checkpoint all.ckpt and refine with --refine R --checkpoint all.ckpt",
        ));
    }
    let bad = |why: String| {
        Error::request(
            format!("--refine-from {path}: {why}"),
            "give the CSV written by the same sweep (or by `detune merge`), without --refine",
        )
    };
    // bounded: `--refine-from /dev/zero` or an endless pipe is refused, not read forever
    let give = "give the CSV written by the same sweep (or by `detune merge`), without --refine";
    let bytes = detune::model::read_bounded(
        path,
        &detune::model::Bounded {
            what: "sweep CSV",
            limit: detune::model::MAX_DATA_BYTES,
            pipes: true,
            give,
            shorter: give,
        },
    )
    .map_err(|e| match e {
        Error::Io { message, .. } => bad(message),
        Error::Request { message, help } => Error::Request {
            message: format!("--refine-from {message}"),
            help,
        },
        e => e,
    })?;
    let text = detune::model::utf8(path, "sweep CSV", bytes).map_err(|e| match e {
        Error::Io { message, .. } => bad(message),
        e => e,
    })?;
    let mut lines = text.lines();
    let opts = &study.options;
    let names: Vec<&str> = study.runs[0]
        .values
        .iter()
        .map(|(n, _)| n.as_str())
        .collect();
    let mut want = vec![opts.param.clone(), "direction".to_string()];
    want.extend(names.iter().map(|n| n.to_string()));
    for r in &opts.responses {
        want.extend(
            detune::output::results::MEASURES
                .iter()
                .map(|m| format!("{r}_{m}")),
        );
    }
    want.extend(["settled", "periods", "period_multiple", "refined", "well"].map(String::from));
    if lines.next() != Some(want.join(",").as_str()) {
        return Err(bad(format!(
            "its header is not this sweep's: expected {}",
            want.join(",")
        )));
    }
    let nv = names.len();
    let mut known = std::collections::HashMap::new();
    for (i, line) in lines.enumerate() {
        if line.starts_with('#') {
            return Err(bad(format!("it is incomplete ({line})")));
        }
        let f: Vec<&str> = line.split(',').collect();
        let num = |s: &str| -> Result<f64> {
            s.parse::<f64>()
                .map_err(|_| bad(format!("line {}: {s:?} is not a number", i + 2)))
        };
        let int = |s: &str| -> Result<i64> {
            s.parse::<i64>()
                .map_err(|_| bad(format!("line {}: {s:?} is not an integer", i + 2)))
        };
        if f.len() != want.len() || f[1] != "independent" {
            return Err(bad(format!(
                "line {} is not a row of an independent sweep",
                i + 2
            )));
        }
        let omega = num(f[0])?;
        let values: Vec<f64> = f[2..2 + nv].iter().map(|s| num(s)).collect::<Result<_>>()?;
        let run = study
            .runs
            .iter()
            .position(|r| {
                r.values
                    .iter()
                    .zip(&values)
                    .all(|((_, x), y)| x.to_bits() == y.to_bits())
            })
            .ok_or_else(|| bad(format!("line {}: no --values case has these values", i + 2)))?;
        let mut k = 2 + nv;
        let mut measures = Vec::new();
        for _ in &opts.responses {
            let x: Vec<f64> = f[k..k + 8].iter().map(|s| num(s)).collect::<Result<_>>()?;
            k += 8;
            measures.push(Measures {
                amplitude: x[0],
                max: x[1],
                min: x[2],
                mean: x[3],
                h1: x[4],
                phase_deg: x[5],
                h2: x[6],
                thd: x[7],
            });
        }
        let refined = int(f[k + 3])? != 0;
        let key = CaseKey {
            run,
            kind: if refined {
                CaseKind::Refine
            } else {
                CaseKind::Coarse
            },
            direction: detune::frequency::Direction::Independent,
            omega: omega.to_bits(),
        };
        let s = detune::frequency::SteadyState {
            omega,
            settled: int(f[k])? != 0,
            periods: int(f[k + 1])? as usize,
            period_multiple: int(f[k + 2])? as usize,
            measures,
            // an independent sweep starts every frequency from rest: no end state is read
            end: detune::dynamics::State {
                t: 0.0,
                q: Vec::new(),
                v: Vec::new(),
            },
            orbit: Vec::new(),
            rhs_evaluations: 0,
        };
        known.insert(key, (s, int(f[k + 4])? as isize));
    }
    Ok(CsvCases {
        path: path.to_string(),
        known,
    })
}

/// A frequency whose motion cannot be integrated (the step size falls to zero, the
/// equations give NaN, the constraints are lost): the sweep has no steady state there and
/// stops; `kept` says what was written of the frequencies finished before it. Worded as
/// what happened to the mechanism and what to try: the forcing drives it into a singular
/// pose (issue 11: the overcentre at F0 = 80 N reaches its bars' folded pose, θ1 = −90°,
/// where the constraints lose rank).
fn no_steady_state(
    e: Error,
    model: &detune::Model,
    sys: &detune::System,
    values: &[(String, f64)],
    a: &SweepArgs,
    kept: &str,
    stage: checkpoint::CaseKind,
) -> Error {
    use detune::failure::Failure::{ConstraintsNotKept, NonFinite, StepSizeUnderflow};
    let Error::Failed {
        failure, context, ..
    } = &e
    else {
        return e;
    };
    let t = match failure {
        StepSizeUnderflow { t, .. } | NonFinite { t, .. } => *t,
        ConstraintsNotKept { .. } => f64::NAN,
        _ => return e,
    };
    let param = &a.grid.param;
    let Some(at) = context
        .iter()
        .rev()
        .find_map(|c| c.strip_prefix(&format!("{param} = ")))
    else {
        return e;
    };
    let forcing = sys
        .forcing_amplitude_param()
        .map(|i| {
            let name = &sys.param_names()[i];
            let how = if values.iter().any(|(n, _)| n == name) {
                "in this run: lower it in --values"
            } else {
                "now: --set {name}=..."
            }
            .replace("{name}", name);
            format!(
                "lower the forcing ({name} = {} {how}), ",
                format!(
                    "{} {}",
                    detune::diag::num(sys.param(i)),
                    model.param_unit(name)
                )
                .trim_end()
            )
        })
        .unwrap_or_default();
    let watch = if t.is_finite() {
        // the failing run's --values as --set (SI numbers, as --values gives them)
        let mut except = vec![param.as_str()];
        except.extend(values.iter().map(|(n, _)| n.as_str()));
        let sets: String = values
            .iter()
            .map(|(n, v)| format!(" --set {n}={}", detune::diag::num(*v)))
            .collect();
        format!(
            "; see the motion with `detune simulate {}{sets} --set {param}={at} --t-end {}`",
            a.model.command_words(&except),
            (t + 1.0).ceil()
        )
    } else {
        String::new()
    };
    let (instead, during) = match stage {
        checkpoint::CaseKind::Coarse => (format!("start --from above {at}, or "), ""),
        checkpoint::CaseKind::Back => (
            "sweep independently (--mode independent: no jump checks), or ".to_string(),
            " (a jump check)",
        ),
        checkpoint::CaseKind::Refine => (
            "sweep without --refine (the coarse grid finished), or ".to_string(),
            " (a peak refinement)",
        ),
    };
    Error::numerical(
        format!(
            "the sweep stopped at {param} = {at} rad/s{during}, where the motion cannot be integrated: {failure} in the run toward its steady state; {kept}"
        ),
        format!(
            "the forcing drives the mechanism into a pose where it cannot move on: a singular pose (its constraints lose rank, as the overcentre's bars do folded at ±90°), or a force that changes abruptly; a stepped sine needs a steady state at every frequency. Try: {forcing}{instead}loosen --rtol/--atol if the pose is regular{watch}"
        ),
    )
}
