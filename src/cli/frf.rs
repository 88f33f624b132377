//! `detune frf`: the linear frequency response about the equilibrium nearest the
//! initial pose.

use super::args::{FrequencyGrid, ModelArgs};
use super::print_json;
use clap::Args;
use detune::diag::Result;
use detune::output::json::FrfReport;
use detune::output::results::write_frf_csv;
use detune::output::units::{Units, WithUnits};
use detune::output::{Provenance, check_outputs};

#[derive(Args)]
pub struct FrfArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    #[command(flatten)]
    pub grid: FrequencyGrid,
    /// The transfer function per unit of the forcing amplitude (the model's
    /// `[model] forcing_amplitude`, set to 1 in SI: rad/N for a force, rad/m for a base
    /// motion). CSV columns unchanged.
    #[arg(long)]
    pub per_unit: bool,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// CSV: `<param>,<name>_amplitude,<name>_phase_deg,...`.
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    pub output: Option<String>,
    /// Figure (.svg or .png): each response's amplitude and phase against frequency, the
    /// natural frequencies ω_n = |λ| of the damped modes drawn and the refined peaks
    /// marked.
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<String>,
    /// A labelled frequency drawn on the plot, LABEL=VALUE (VALUE in rad/s or a
    /// quantity): `--mark "UH-60 main rotor 1P=258 rpm"`. Repeatable.
    #[arg(long, value_name = "LABEL=VALUE")]
    pub mark: Vec<String>,
    #[command(flatten)]
    pub freq: super::args::FreqUnitArg,
    /// Amplitude axis of --plot: linear, log (logarithmic axis) or db (20 log10 of the
    /// amplitude in SI: dB re 1 rad, re 1 m).
    #[arg(long, value_enum, default_value = "linear", value_name = "SCALE")]
    pub plot_scale: PlotScale,
    #[command(flatten)]
    pub plot_size: super::args::PlotSize,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum PlotScale {
    Linear,
    Log,
    Db,
}

pub fn run(a: FrfArgs) -> Result<()> {
    let (model, sys) = a.model.load()?;
    let size = a.plot_size.check(a.plot.as_deref(), a.output.as_deref())?;
    // with --per-unit, the amplitudes are per unit of the forcing amplitude (`/N`)
    let mut per = String::new();
    let sys = if a.per_unit {
        let Some(i) = sys.forcing_amplitude_param() else {
            return Err(detune::diag::Error::request(
                "--per-unit: the model does not say which parameter is the forcing's amplitude",
                "add `forcing_amplitude = \"F0\"` (the amplitude parameter's name) to the model's [model] table",
            ));
        };
        let name = &sys.param_names()[i];
        let unit = model.param_unit(name);
        eprintln!(
            "note: per unit of the forcing amplitude {name} (1 {unit}): amplitudes are per {unit}"
        );
        if !unit.is_empty() {
            per = format!("/{unit}");
        }
        sys.with_param(i, 1.0)?
    } else {
        sys
    };
    let outputs = check_outputs(
        &model.source.path,
        &[a.output.as_deref(), a.plot.as_deref()],
    )?;
    let (values, responses) = a.grid.resolve(&model)?;
    let marks = super::args::frequency_marks(&a.mark, &values, a.plot.is_some())?;
    // a signal stops it at the next frequency; nothing is written (exit 130, 143, 129)
    super::interrupt_on_ctrl_c();
    let fr = detune::linear::frequency_response_until(
        &sys,
        &a.grid.param,
        &values,
        &responses,
        &super::INTERRUPTED,
    )?;
    // every frequency is computed (an interrupted one returned an error above): a signal
    // from now on stops nothing
    super::results_complete();
    let fu = a.freq.freq_unit;
    let sym = fu.symbol();
    // each response's amplitude unit (rad, m, N; per unit of the forcing with --per-unit)
    let amplitude_unit = |r: &str| -> String {
        let u = sys.output(r).map(|o| o.unit(&sys)).unwrap_or("");
        format!("{u}{per}")
    };
    if let Some(o) = &a.output {
        write_frf_csv(o, &fr)?;
    }
    if let Some(p) = &a.plot {
        let units: Vec<&str> = responses
            .iter()
            .map(|r| sys.output(r).map(|o| o.unit(&sys)).unwrap_or(""))
            .collect();
        let index = sys.param_index(&a.grid.param);
        let natural: Vec<f64> = index
            .and_then(|i| detune::linear::at_frequency(&sys, i, values[0]).ok())
            .and_then(|at| detune::linear::modal_analysis(&at, None).ok())
            // ω_n = |λ| of each oscillating mode of the damped system, as the modes
            // table and the report mark it
            .map(|m| {
                m.modes
                    .iter()
                    .filter(|x| x.omega_d_rad_s > 0.0 && x.omega_n_rad_s.is_finite())
                    .map(|x| x.omega_n_rad_s)
                    .collect()
            })
            .unwrap_or_default();
        use detune::output::figures::AmplitudeScale;
        let scale = match a.plot_scale {
            PlotScale::Linear => AmplitudeScale::Linear,
            PlotScale::Log => AmplitudeScale::Log,
            PlotScale::Db => AmplitudeScale::Db,
        };
        let mut case = detune::output::figures::Case::of(&model);
        if a.per_unit {
            let name = sys
                .forcing_amplitude_param()
                .map(|i| sys.param_names()[i].clone())
                .unwrap_or_default();
            case.notes
                .push(format!("per unit of the forcing amplitude {name}"));
        }
        let per_units: Vec<String> = units.iter().map(|u| format!("{u}{per}")).collect();
        let units: Vec<&str> = per_units.iter().map(String::as_str).collect();
        let figures: Vec<_> =
            detune::output::figures::frf_figures(&case, &fr, &units, &natural, &marks, scale)
                .into_iter()
                .map(|f| f.in_frequency_unit(fu))
                .collect();
        detune::output::plot::write_panels_sized(p, &figures, size)?;
    }
    outputs.commit()?;
    for f in [&a.output, &a.plot].into_iter().flatten() {
        eprintln!("wrote {f}");
    }
    if a.json {
        let mut units = Units::new().with(fr.param.clone(), "rad/s");
        for r in &fr.responses {
            units.add(format!("{r}_amplitude"), amplitude_unit(r));
            units.add(format!("{r}_phase_deg"), "deg");
        }
        let units = units.coordinates(&sys).with_all([
            ("omega", "rad/s"),
            ("uncertainty", "rad/s"),
            (
                "amplitude",
                "the response's amplitude unit (its `<response>_amplitude`)",
            ),
        ]);
        print_json(&WithUnits {
            doc: FrfReport::new(&fr, &Provenance::of(&model)),
            units: &units,
        });
    } else if a.output.is_none() {
        let head: Vec<String> = fr
            .responses
            .iter()
            .map(|r| {
                format!(
                    "{:>12} {:>9}",
                    format!("{r} amp [{}]", amplitude_unit(r)),
                    "phase"
                )
            })
            .collect();
        println!(
            "{:>10}  {}",
            format!("{} [{sym}]", fu.quantity(&fr.param)),
            head.join("  ")
        );
        for (k, w) in fr.omega.iter().enumerate() {
            let cols: Vec<String> = fr.values[k]
                .iter()
                .map(|(amp, ph)| format!("{amp:.6e} {ph:8.3}°"))
                .collect();
            println!("{:10.5}  {}", fu.of(*w), cols.join("  "));
        }
    }
    if !a.json {
        for p in &fr.peaks {
            eprintln!(
                "peak {}: {} = {}, amplitude {:.6e} {}",
                p.response,
                fu.quantity(&fr.param),
                detune::output::units::located(fu.of(p.omega), fu.of(p.uncertainty), sym, None),
                p.amplitude,
                amplitude_unit(&p.response)
            );
        }
    }
    Ok(())
}
