//! `detune backbone`: the backbone curve of a mode, the amplitude-dependent natural
//! frequency of the undamped, unforced mechanism (`detune::periodic::backbone`).

use super::args::ModelArgs;
use super::print_json;
use clap::Args;
use detune::diag::{Error, Result};
use detune::output::plot::{LinePlot, Series, Style};
use detune::output::units::{Units, WithUnits};
use detune::output::{Provenance, check_outputs, num, write_atomic};
use detune::periodic::backbone::{Backbone, BackboneOptions, backbone, mode_index, undamped_modes};
use std::sync::atomic::Ordering;

#[derive(Args)]
pub struct BackboneArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// The mode: its name as `detune modes` prints it (the model's [[modes]] name, or
    /// "mode 2"), or its number from 1.
    #[arg(long = "of-mode", value_name = "NAME|N")]
    pub of_mode: String,
    /// Follow the family to this amplitude: the reference coordinate's displacement from
    /// the equilibrium at the orbit's turning point, a number (SI: m or rad) or a quantity
    /// ("10 deg", "3 mm") [default: until ω has moved by 25 % of the linear ω_n].
    #[arg(long = "to-amplitude", value_name = "A", allow_hyphen_values = true)]
    pub to_amplitude: Option<String>,
    /// A response measured on every orbit (its amplitude, half peak-to-peak). Repeatable
    /// [default: the reference coordinate].
    #[arg(long, value_name = "NAME")]
    pub response: Vec<String>,
    /// The reference coordinate, whose turning point fixes the phase and whose
    /// displacement is the amplitude [default: as `modes` normalizes the shape: the first
    /// angle coordinate, or the shape's largest entry].
    #[arg(long, value_name = "NAME")]
    pub normalize: Option<String>,
    /// Relative error tolerance of the integration per step.
    #[arg(long, default_value_t = 1e-10, value_name = "R")]
    pub rtol: f64,
    /// Absolute error tolerance of the integration per step (SI).
    #[arg(long, default_value_t = 1e-12, value_name = "A")]
    pub atol: f64,
    /// The integrator of each period and its variational equations: `dop853` (explicit)
    /// or `radau` (Radau IIA, implicit: for a model too stiff for DOP853; slower
    /// otherwise).
    #[arg(long, value_enum, default_value_t = super::args::IntegratorChoice::Dop853, value_name = "METHOD")]
    pub integrator: super::args::IntegratorChoice,
    /// Print JSON: {"mode", "points": [{"amplitude", "omega", "<response>_amplitude"...}],
    /// "units", ...}.
    #[arg(long)]
    pub json: bool,
    /// CSV: `amplitude,omega,<response>_amplitude...`.
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    pub output: Option<String>,
    /// Figure (.svg or .png): the amplitude against the frequency, the linear ω_n drawn.
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<String>,
    #[command(flatten)]
    pub freq: super::args::FreqUnitArg,
    #[command(flatten)]
    pub plot_size: super::args::PlotSize,
}

pub fn run(a: BackboneArgs) -> Result<()> {
    let (model, sys) = a.model.load()?;
    let size = a.plot_size.check(a.plot.as_deref(), a.output.as_deref())?;
    let outputs = check_outputs(
        &model.source.path,
        &[a.output.as_deref(), a.plot.as_deref()],
    )?;
    for (flag, v) in [("--rtol", a.rtol), ("--atol", a.atol)] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(Error::request(
                format!("{flag} {v}: a tolerance must be positive"),
                "for example --rtol 1e-10 --atol 1e-12",
            ));
        }
    }
    super::nfr::check_rtol(a.rtol, "for example --rtol 1e-10 --atol 1e-12")?;
    let normalize = a.normalize.as_deref();
    if let Some(name) = normalize {
        detune::linear::coordinate(&sys, name, detune::request::Argument::Normalize)?;
    }
    let mode = mode_index(&sys, &a.of_mode, normalize).map_err(|e| e.context("--of-mode"))?;
    let (sys0, ma, _) = undamped_modes(&sys, normalize)?;
    let r = ma.modes[mode].normalized_to;
    let reference = sys0.coordinates[r].clone();
    let to = match &a.to_amplitude {
        None => f64::INFINITY,
        Some(text) => {
            let v =
                super::args::quantity("--to-amplitude", text, &reference, sys0.coordinate_dims[r])?;
            if !(v > 0.0 && v.is_finite()) {
                return Err(Error::request(
                    format!(
                        "--to-amplitude {text}: the amplitude must be positive (it is {reference}'s displacement from the equilibrium at the orbit's turning point)"
                    ),
                    "give a positive amplitude, e.g. --to-amplitude \"20 deg\", or leave it out to follow the family until ω has moved by 25 %",
                ));
            }
            v
        }
    };
    let opts = BackboneOptions {
        responses: a.response.clone(),
        normalize: a.normalize.clone(),
        shooting: detune::periodic::ShootingOptions {
            rtol: a.rtol,
            atol: a.atol,
            integrator: a.integrator.method(),
            ..Default::default()
        },
        ..Default::default()
    };
    super::interrupt_on_ctrl_c();
    let bb = super::nfr::with_heartbeat("backbone", "the first orbit".to_string(), |say| {
        backbone(
            &sys,
            mode,
            to,
            &opts,
            &|k, amp| say(format!("{k} orbits, amplitude {amp:.4e}")),
            &super::INTERRUPTED,
        )
    })?;
    if bb.stop.is_none() {
        // the whole backbone: a signal from now on stops nothing
        super::results_complete();
    }
    let unit_of = |k: usize| bb.units[k];
    let label = mode_label(&bb);
    let ref_unit = if sys0.is_angle(r) { "rad" } else { "m" };
    if let Some(o) = &a.output {
        write_csv(o, &bb)?;
    }
    if let Some(p) = &a.plot {
        let figs: Vec<LinePlot> = figures(&model, &bb, ref_unit)
            .into_iter()
            .map(|f| f.in_frequency_unit(a.freq.freq_unit))
            .collect();
        detune::output::plot::write_panels_sized(p, &figs, size)?;
    }
    outputs.commit()?;
    for f in [&a.output, &a.plot].into_iter().flatten() {
        eprintln!("wrote {f}");
    }
    if a.json {
        let mut units = Units::new().with_all([
            ("amplitude", ref_unit),
            ("omega", "rad/s"),
            ("omega_linear", "rad/s"),
            ("mode_number", "1"),
            ("periods", "1"),
            ("rhs_evaluations", "1"),
        ]);
        for (k, r) in bb.responses.iter().enumerate() {
            units.add(format!("{r}_amplitude"), unit_of(k));
        }
        print_json(&WithUnits {
            doc: json(&bb, &Provenance::of(&model)),
            units: &units,
        });
    } else if a.output.is_none() {
        // the printed table in --freq-unit (the CSV and JSON stay in rad/s)
        let fu = a.freq.freq_unit;
        let linear = if fu == detune::output::units::FreqUnit::RadPerSecond {
            format!("linear ω_n = {:.8} rad/s", bb.omega_linear)
        } else {
            format!(
                "linear f_n = {:.8} {} ({:.8} rad/s)",
                fu.of(bb.omega_linear),
                fu.symbol(),
                bb.omega_linear
            )
        };
        println!(
            "backbone of {label} (undamped, unforced): {linear}; amplitude = {} at the turning point, from the equilibrium",
            bb.reference_name
        );
        let head: Vec<String> = bb
            .responses
            .iter()
            .enumerate()
            .map(|(k, r)| format!("{:>22}", format!("{r} amp [{}]", unit_of(k))))
            .collect();
        println!(
            "{:>16} {:>16}  {}",
            format!("amplitude [{ref_unit}]"),
            format!("{} [{}]", fu.rate(), fu.symbol()),
            head.join(" ")
        );
        for p in &bb.points {
            let cols: Vec<String> = p
                .amplitudes
                .iter()
                .map(|x| format!("{x:>22.10e}"))
                .collect();
            println!(
                "{:>16.8e} {:>16.10}  {}",
                p.amplitude,
                fu.of(p.omega),
                cols.join(" ")
            );
        }
    }
    if let Some(s) = &bb.stop {
        if super::INTERRUPTED.load(Ordering::Relaxed) {
            eprintln!(
                "interrupted: the backbone up to amplitude {:.6e} {ref_unit} is written, marked incomplete",
                s.amplitude
            );
        } else {
            // the curve so far is written and printed; the exit code says it is short
            let written = if a.output.is_some() || a.plot.is_some() || a.json {
                " (the curve up to there is written, marked incomplete)"
            } else {
                ""
            };
            return Err(Error::numerical(
                format!("the backbone is incomplete{written}: {}", s.reason),
                s.help.replace("rtol", "--rtol"),
            ));
        }
    }
    Ok(())
}

/// The CSV: `amplitude,omega,<response>_amplitude...`.
fn write_csv(path: &str, bb: &Backbone) -> Result<()> {
    write_atomic(path, |w| {
        let mut head = vec!["amplitude".to_string(), "omega".to_string()];
        head.extend(bb.responses.iter().map(|r| format!("{r}_amplitude")));
        writeln!(w, "{}", head.join(","))?;
        for p in &bb.points {
            let mut row = vec![num(p.amplitude), num(p.omega)];
            row.extend(p.amplitudes.iter().map(|x| num(*x)));
            writeln!(w, "{}", row.join(","))?;
        }
        if !bb.complete {
            let why = bb.stop.as_ref().map_or("", |s| s.reason.as_str());
            writeln!(w, "# incomplete: {why}")?;
        }
        Ok(())
    })
}

/// The JSON document (before its units).
fn json(bb: &Backbone, provenance: &Provenance) -> serde_json::Value {
    use serde_json::{Map, Value, json};
    let points: Vec<Value> = bb
        .points
        .iter()
        .map(|p| {
            let mut m = Map::new();
            m.insert("amplitude".into(), Value::from(p.amplitude));
            m.insert("omega".into(), Value::from(p.omega));
            for (r, x) in bb.responses.iter().zip(&p.amplitudes) {
                m.insert(format!("{r}_amplitude"), Value::from(*x));
            }
            Value::Object(m)
        })
        .collect();
    json!({
        "mode": bb.mode_name,
        "mode_number": bb.mode + 1,
        "omega_linear": bb.omega_linear,
        "reference": bb.reference_name,
        "responses": bb.responses,
        "complete": bb.complete,
        "stop": bb.stop.as_ref().map(|s| json!({
            "amplitude": s.amplitude,
            "omega": s.omega,
            "reason": s.reason,
            "help": s.help,
        })),
        "points": points,
        "periods": bb.periods,
        "rhs_evaluations": bb.rhs_evaluations,
        "provenance": provenance,
    })
}

/// One panel per quantity: the reference amplitude, then each other response, against ω.
fn figures(model: &detune::Model, bb: &Backbone, ref_unit: &str) -> Vec<LinePlot> {
    let case = detune::output::figures::Case::of(model);
    let omega: Vec<f64> = bb.points.iter().map(|p| p.omega).collect();
    let mut panels = Vec::new();
    let mut panel = |name: &str, unit: &str, y: Vec<f64>| {
        let mut lp = LinePlot::new(
            format!("Backbone of {}", mode_label(bb)),
            "ω [rad/s]",
            format!("{name} [{}]", if unit.is_empty() { "-" } else { unit }),
        );
        lp.caption = case.caption(&["undamped, unforced".to_string()]);
        lp.series.push(Series::new(
            format!("{name} [{unit}]"),
            omega.clone(),
            y,
            Style::Solid,
        ));
        lp.vertical.push((
            bb.omega_linear,
            format!("linear ω_n = {:.4} rad/s", bb.omega_linear),
        ));
        panels.push(lp);
    };
    panel(
        &format!("{} at the turning point", bb.reference_name),
        ref_unit,
        bb.points.iter().map(|p| p.amplitude).collect(),
    );
    for (k, r) in bb.responses.iter().enumerate() {
        if *r == bb.reference_name {
            continue;
        }
        panel(
            &format!("{r} amplitude"),
            bb.units[k],
            bb.points.iter().map(|p| p.amplitudes[k]).collect(),
        );
    }
    panels
}

/// `mode 2`, or `mode 2 `shaft-twist`` for a named mode.
fn mode_label(bb: &Backbone) -> String {
    if bb.mode_name == format!("mode {}", bb.mode + 1) {
        bb.mode_name.clone()
    } else {
        format!("mode {} `{}`", bb.mode + 1, bb.mode_name)
    }
}
