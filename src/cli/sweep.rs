//! `detune sweep`: the stepped-sine frequency response of the nonlinear model, for one
//! model or a family over the values of a parameter (`--values`).

use super::args::{FrequencyGrid, ModelArgs, Tolerances};
use super::{INTERRUPTED, interrupt_on_ctrl_c, print_json, progress_bar, unit_of};
use clap::Args;
use detune::diag::{Error, Result};
use detune::linear::modal_analysis;
use detune::output::plot::{LinePlot, Series, Style};
use detune::output::{Provenance, check_outputs};
use detune::{Model, System};

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
    /// Locate every resonance (local maximum of the amplitude) to this resolution, rad/s.
    #[arg(long, value_name = "R", allow_hyphen_values = true)]
    pub refine: Option<f64>,
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
}

pub fn run(a: SweepArgs) -> Result<()> {
    use detune::frequency::{SteadyOptions, SweepMode, SweepOptions, sweep};
    use detune::output::results::{SweepRun, sweep_json, write_sweep_csv};
    let model = a.model.load()?;
    check_outputs(
        &model.source.path,
        &[a.output.as_deref(), a.plot.as_deref()],
    )?;
    let (values, responses) = a.grid.resolve(&model)?;
    let family: Vec<(Option<(String, f64)>, Model)> = match &a.values {
        None => vec![(None, model.clone())],
        Some(spec) => {
            let (name, list) = spec.split_once('=').ok_or_else(|| {
                Error::request(
                    format!("--values {spec}: expected PARAM=v1,v2,..."),
                    "for example --values F0=0.1,1,2,3,4",
                )
            })?;
            let name = name.trim();
            if name.is_empty() {
                return Err(Error::request(
                    format!("--values {spec}: no parameter named before `=`"),
                    "for example --values F0=0.1,1,2,3,4",
                ));
            }
            if name == a.grid.param {
                return Err(Error::request(
                    format!("--values {spec}: `{name}` is the swept parameter (--param)"),
                    "give --values a different parameter, e.g. the forcing amplitude F0",
                ));
            }
            let mut out = Vec::new();
            for v in list.split(',') {
                if v.trim().is_empty() {
                    return Err(Error::request(
                        format!("--values {spec}: an empty entry"),
                        "separate the values by single commas: --values F0=0.1,1,2",
                    ));
                }
                let m = model
                    .with_overrides(&[(name.to_string(), v.trim().to_string())])
                    .map_err(|e| match e {
                        Error::Request { message, help } => Error::Request {
                            message: message.replace("--set ", "--values "),
                            help,
                        },
                        other => other.context(&format!("--values {name}={}", v.trim())),
                    })?;
                let value = m.parameters.value(name).unwrap_or(f64::NAN);
                out.push((Some((name.to_string(), value)), m));
            }
            out
        }
    };
    let opts = SweepOptions {
        param: a.grid.param.clone(),
        values: values.clone(),
        mode: match a.mode {
            ModeArg::Independent => SweepMode::Independent,
            ModeArg::Up => SweepMode::Up,
            ModeArg::Down => SweepMode::Down,
            ModeArg::Both => SweepMode::Both,
        },
        responses: responses.clone(),
        refine: a.refine,
        steady: SteadyOptions {
            rtol: a.tol.rtol,
            atol: a.tol.atol,
            settle_tol: a.settle_tol,
            max_periods: a.max_periods,
            ..SteadyOptions::default()
        },
    };
    if !(a.settle_tol > 0.0 && a.settle_tol < 1.0) {
        return Err(Error::request(
            format!("--settle-tol {} is not valid", a.settle_tol),
            "give a fraction such as 1e-8",
        ));
    }
    // One compiled system per run.
    let systems: Vec<System> = family
        .iter()
        .map(|(_, m)| System::new(m))
        .collect::<Result<_>>()?;
    // Every run is checked before any is simulated: a bad --values entry fails at once.
    for ((value, _), m) in family.iter().zip(&systems) {
        detune::frequency::prepare(m, &opts).map_err(|e| match value {
            Some((name, v)) => e.context(&format!("--values {name}={v}")),
            None => e,
        })?;
    }
    interrupt_on_ctrl_c();
    let per_run = values.len()
        * if matches!(a.mode, ModeArg::Both) {
            2
        } else {
            1
        };
    let bar = progress_bar(
        (per_run * family.len()) as u64,
        "sweeping {bar:40} {pos}/{len} frequencies {elapsed} (eta {eta})",
    );
    let began = std::time::Instant::now();
    let mut sweeps = Vec::new();
    let mut offset = 0u64;
    for ((value, _), m) in family.iter().zip(&systems) {
        let b = bar.clone();
        let base = offset;
        let s = sweep(
            m,
            &opts,
            &move |done| {
                let pos = base + done as u64;
                if pos > b.length().unwrap_or(0) {
                    b.set_length(pos);
                }
                b.set_position(pos);
            },
            &INTERRUPTED,
        );
        let s = match s {
            Ok(s) => s,
            Err(e) => {
                bar.finish_and_clear();
                return Err(e);
            }
        };
        offset = bar.position();
        let complete = s.complete;
        sweeps.push((value.clone(), s));
        if !complete {
            break;
        }
    }
    bar.finish_and_clear();
    let runs: Vec<SweepRun> = sweeps
        .iter()
        .map(|(v, s)| SweepRun {
            value: v.as_ref().map(|(n, x)| (n.as_str(), *x)),
            sweep: s,
        })
        .collect();
    let complete = runs.iter().all(|r| r.sweep.complete);
    if let Some(o) = &a.output {
        write_sweep_csv(o, &runs)?;
        eprintln!("wrote {o}{}", if complete { "" } else { " (incomplete)" });
    }
    if let Some(p) = &a.plot {
        // The linear natural frequencies of every run (a static load in --values moves
        // them; an amplitude does not): one unlabelled set when every run has the same,
        // else each distinct one tagged with its run.
        let mut per_run: Vec<(Vec<f64>, String)> = Vec::new();
        for ((value, _), m) in family.iter().zip(&systems).take(runs.len()) {
            let index = m.require_param(&a.grid.param, "--param")?;
            let at = detune::linear::at_frequency(m, index, values[0])?;
            let Ok(ma) = modal_analysis(&at, None) else {
                continue;
            };
            let w: Vec<f64> = ma
                .undamped_omega2
                .iter()
                .filter(|w| **w > 0.0)
                .map(|w| w.sqrt())
                .collect();
            let tag = value
                .as_ref()
                .map(|(n, v)| format!(" ({n} = {v})"))
                .unwrap_or_default();
            per_run.push((w, tag));
        }
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-6 * x.abs().max(y.abs());
        let same = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| close(*x, *y))
        };
        let mut omega_n: Vec<(f64, String)> = Vec::new();
        if per_run.iter().all(|(w, _)| same(w, &per_run[0].0)) {
            if let Some((w, _)) = per_run.first() {
                omega_n = w.iter().map(|x| (*x, String::new())).collect();
            }
        } else {
            for (w, tag) in &per_run {
                for x in w {
                    if !omega_n.iter().any(|(y, _)| close(*x, *y)) {
                        omega_n.push((*x, tag.clone()));
                    }
                }
            }
        }
        detune::output::plot::write_panels(p, &sweep_plots(&runs, &omega_n))?;
        eprintln!("wrote {p}");
    }
    if a.json {
        print_json(&sweep_json(&runs, &Provenance::of(&model)));
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
                .value
                .map(|(n, v)| format!(" [{n} = {v}]"))
                .unwrap_or_default();
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
        return Err(Error::numerical(
            "the sweep was interrupted",
            "the frequencies completed were written and marked incomplete",
        ));
    }
    Ok(())
}

/// Amplitude of the first response against frequency, one curve per --values entry and
/// direction; with --values, the same normalized by the value (the paper's Figures 8–9).
fn sweep_plots(
    runs: &[detune::output::results::SweepRun],
    omega_n: &[(f64, String)],
) -> Vec<LinePlot> {
    let first = runs[0].sweep;
    let name = &first.responses[0];
    let vertical: Vec<(f64, String)> = omega_n
        .iter()
        .map(|(w, tag)| (*w, format!("linear ω_n = {w:.4} rad/s{tag}")))
        .collect();
    let curves = |normalized: bool| -> Vec<Series> {
        let mut out = Vec::new();
        for run in runs {
            for dir in [
                detune::frequency::Direction::Independent,
                detune::frequency::Direction::Up,
                detune::frequency::Direction::Down,
            ] {
                let pts: Vec<_> = run
                    .sweep
                    .points
                    .iter()
                    .filter(|p| p.direction == dir)
                    .collect();
                if pts.is_empty() {
                    continue;
                }
                let scale = match (normalized, run.value) {
                    (true, Some((_, v))) if v != 0.0 => 1.0 / v.abs(),
                    (true, Some(_)) => continue, // nothing to normalize by
                    _ => 1.0,
                };
                let mut label = run
                    .value
                    .map(|(n, v)| format!("{n} = {v}"))
                    .unwrap_or_else(|| name.clone());
                if dir != detune::frequency::Direction::Independent {
                    label.push_str(&format!(" ({})", dir.name()));
                }
                out.push(Series {
                    label,
                    x: pts.iter().map(|p| p.steady.omega).collect(),
                    y: pts
                        .iter()
                        .map(|p| p.steady.measures[0].amplitude * scale)
                        .collect(),
                    style: if dir == detune::frequency::Direction::Down {
                        Style::Dashed
                    } else {
                        Style::Solid
                    },
                });
            }
        }
        out
    };
    let mut plots = vec![LinePlot {
        title: format!("{name}: stepped-sine amplitude"),
        x_label: format!("{} [rad/s]", first.param),
        y_label: format!("{name} amplitude [{}]", unit_of(name)),
        series: curves(false),
        vertical: vertical.clone(),
    }];
    if let Some((vname, _)) = runs[0].value {
        plots.push(LinePlot {
            title: format!("{name}: amplitude / {vname}"),
            x_label: format!("{} [rad/s]", first.param),
            y_label: format!("{name} amplitude / {vname}"),
            series: curves(true),
            vertical,
        });
    }
    plots
}
