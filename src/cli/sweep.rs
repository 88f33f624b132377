//! `detune sweep`: the stepped-sine frequency response of the nonlinear model, for one
//! model or a family over the values of a parameter (`--values`).

use super::args::{FrequencyGrid, ModelArgs, Tolerances};
use super::{INTERRUPTED, interrupt_on_ctrl_c, print_json, progress_bar};
use clap::Args;
use detune::diag::Result;
use detune::frequency::study::SweepStudy;
use detune::frequency::{SteadyOptions, SweepMode, SweepOptions};
use detune::output::figures::{Case, sweep_figures};
use detune::output::json::SweepReport;
use detune::output::plot::write_panels_sized;
use detune::output::results::write_sweep_csv;
use detune::output::{Provenance, check_outputs};

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
    pub plot_size: super::args::PlotSize,
}

pub fn run(a: SweepArgs) -> Result<()> {
    let (model, compiled) = a.model.load()?;
    let size = a.plot_size.check(a.plot.as_deref(), a.output.as_deref())?;
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
    if let Some(o) = &a.output {
        write_sweep_csv(o, &runs)?;
    }
    if let Some(p) = &a.plot {
        let natural = study.natural_frequencies(runs.len())?;
        let forcing = compiled
            .forcing_amplitude_param()
            .map(|i| compiled.param_names()[i].clone());
        let figures = sweep_figures(
            &Case::of(&model),
            &runs,
            &natural,
            &marks,
            forcing.as_deref(),
        );
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
        print_json(&SweepReport::new(&runs, &Provenance::of(&model)));
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
                    "jump {} between {} and {} rad/s{tag}: {} amplitude {:.4} → {:.4} {unit}",
                    j.direction.name(),
                    j.from,
                    j.to,
                    j.response,
                    j.amplitude_before,
                    j.amplitude_after
                );
            }
            for pk in &run.sweep.peaks {
                println!(
                    "peak{tag} {} ({}): {} = {:.6} ± {:.1e} rad/s, amplitude {:.6e}",
                    pk.response,
                    pk.direction.name(),
                    a.grid.param,
                    pk.omega,
                    pk.uncertainty,
                    pk.amplitude
                );
            }
            for h in &run.sweep.hysteresis {
                println!(
                    "hysteresis{tag}: up and down differ from {} to {} rad/s",
                    h.from, h.to
                );
            }
        }
    }
    if !complete {
        return Err(detune::failure::Failure::SweepInterrupted.into());
    }
    Ok(())
}
