//! `detune sweep`: the stepped-sine frequency response of the nonlinear model, for one
//! model or a family over the values of a parameter (`--values`).

use super::args::{FrequencyGrid, ModelArgs, Tolerances};
use super::{INTERRUPTED, interrupt_on_ctrl_c, print_json, progress_bar};
use clap::Args;
use detune::diag::Result;
use detune::frequency::study::SweepStudy;
use detune::frequency::{SteadyOptions, SweepMode, SweepOptions};
use detune::output::figures::sweep_figures;
use detune::output::json::SweepReport;
use detune::output::plot::write_panels;
use detune::output::results::write_sweep_csv;
use detune::output::units::{Units, WithUnits};
use detune::output::{Provenance, check_outputs};

/// The units of `sweep --json`: the CSV's columns (the frequency in rad/s, each response's
/// measures in its unit, the phase in degrees; the `--values` parameter in its unit), the
/// coordinates, and the peaks', jumps' and hysteresis' keys.
fn sweep_units(runs: &[detune::frequency::study::SweepRun], sys: &detune::System) -> Units {
    let first = &runs[0].sweep;
    let mut u = Units::new().with(first.param.clone(), "rad/s");
    if let Some((name, _)) = runs[0].tag() {
        u.add(name, runs[0].unit.clone());
    }
    for (r, unit) in first.responses.iter().zip(&first.units) {
        for m in ["amplitude", "max", "min", "mean", "h1", "h2"] {
            u.add(format!("{r}_{m}"), *unit);
        }
        u.add(format!("{r}_phase_deg"), "deg");
        u.add(format!("{r}_thd"), "1");
    }
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
            ("omega2", "rad^2/s^2"),
        ])
}

#[derive(Clone, Copy, clap::ValueEnum)]
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
    #[arg(long, value_name = "PARAM=V1,V2,...", allow_hyphen_values = true)]
    pub values: Option<String>,
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
    /// SVG: amplitude of the first response against frequency (with --values, also
    /// normalized by the value), the linear natural frequencies marked.
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<String>,
    /// A labelled frequency drawn on the plot, LABEL=VALUE (VALUE in rad/s or a
    /// quantity): `--mark "UH-60 main rotor 1P=258 rpm"`. Repeatable.
    #[arg(long, value_name = "LABEL=VALUE")]
    pub mark: Vec<String>,
    #[command(flatten)]
    pub freq: super::args::FreqUnitArg,
}

pub fn run(a: SweepArgs) -> Result<()> {
    let (model, _compiled) = a.model.load()?;
    let outputs = check_outputs(
        &model.source.path,
        &[a.output.as_deref(), a.plot.as_deref()],
    )?;
    let (values, responses) = a.grid.resolve(&model)?;
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
    let study = SweepStudy::new(&model, a.values.as_deref(), opts)?;
    interrupt_on_ctrl_c();
    let bar = progress_bar(
        study.frequencies() as u64,
        "sweeping {bar:40} {pos}/{len} frequencies {elapsed} (eta {eta})",
    );
    let began = std::time::Instant::now();
    let runs = study.run(
        &|done| {
            let pos = done as u64;
            if pos > bar.length().unwrap_or(0) {
                bar.set_length(pos);
            }
            bar.set_position(pos);
        },
        &INTERRUPTED,
    );
    bar.finish_and_clear();
    let runs = runs?;
    let complete = runs.iter().all(|r| r.sweep.complete);
    let fu = a.freq.freq_unit;
    let sym = fu.symbol();
    if let Some(o) = &a.output {
        write_sweep_csv(o, &runs)?;
    }
    if let Some(p) = &a.plot {
        let natural = study.natural_frequencies(runs.len())?;
        let figures: Vec<_> = sweep_figures(&runs, &natural, &marks)
            .into_iter()
            .map(|f| f.in_frequency_unit(fu))
            .collect();
        write_panels(p, &figures)?;
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
        let units = sweep_units(&runs, &_compiled);
        print_json(&WithUnits {
            doc: SweepReport::new(&runs, &Provenance::of(&model)),
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
            let tag = run
                .tag()
                .map(|(n, v)| format!(" [{n} = {v}]"))
                .unwrap_or_default();
            for line in detune::output::figures::well_summary(run) {
                println!("{line}{tag}");
            }
            for j in &run.sweep.jumps {
                let unit = run
                    .sweep
                    .responses
                    .iter()
                    .position(|r| *r == j.response)
                    .map(|i| run.sweep.units[i])
                    .unwrap_or("");
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
                let unit = run
                    .sweep
                    .responses
                    .iter()
                    .position(|r| *r == pk.response)
                    .map(|i| run.sweep.units[i])
                    .unwrap_or("");
                println!(
                    "peak{tag} {} ({}): {} = {:.6} ± {:.1e} {sym}, amplitude {:.6e} {unit}",
                    pk.response,
                    pk.direction.name(),
                    a.grid.param,
                    fu.of(pk.omega),
                    fu.of(pk.uncertainty),
                    pk.amplitude
                );
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
    if !complete {
        return Err(detune::failure::Failure::SweepInterrupted.into());
    }
    Ok(())
}
