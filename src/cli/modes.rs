//! `detune modes`: modes of the linearized constrained dynamics about the equilibrium
//! nearest the initial pose, with their names and energy shares; with `--param`, the
//! modes tracked over a parameter's values (`detune::linear::tracking`).

use super::args::ModelArgs;
use super::print_json;
use clap::Args;
use detune::diag::Result;
use detune::linear::tracking::{
    ModeTracking, TrackOptions, describe_modes_or_numbered, track_modes, values,
};
use detune::linear::{Motion, modal_analysis};
use detune::output::Provenance;
use detune::output::check_outputs;
use detune::output::json::{ModesReport, TrackingReport};
use detune::output::units::{FreqUnit, Units, WithUnits};

/// The units of `modes --json` besides the coordinates'.
const MODE_UNITS: [(&str, &str); 12] = [
    ("omega_n_rad_s", "rad/s"),
    ("omega_d_rad_s", "rad/s"),
    ("freq_hz", "Hz"),
    ("damping_ratio", "1"),
    ("eigenvalue", "1/s"),
    ("growth_rate_1_s", "1/s"),
    ("time_constant_s", "s"),
    ("decay_rate_1_s", "1/s"),
    ("decay_time_constant_s", "s"),
    ("undamped_omega2", "rad^2/s^2"),
    (
        "shape",
        "the coordinate's unit per unit of the normalized_to coordinate",
    ),
    ("kinetic_energy_share", "1"),
];

#[derive(Args)]
pub struct ModesArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Coordinate whose shape entry is 1 [default: the first angle coordinate].
    #[arg(long, value_name = "NAME")]
    pub normalize: Option<String>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Track the modes over this parameter's values (with --from, --to): ω_n and ζ of
    /// each named mode, crossings and veerings.
    #[arg(long, value_name = "NAME", requires_all = ["from", "to"])]
    pub param: Option<String>,
    /// First value of the tracked parameter: a number (SI) or a quantity in its
    /// dimension, e.g. "200 N*m/rad".
    #[arg(long, value_name = "A", allow_hyphen_values = true, requires = "param")]
    pub from: Option<String>,
    /// Last value of the tracked parameter (SI or a quantity).
    #[arg(long, value_name = "B", allow_hyphen_values = true, requires = "param")]
    pub to: Option<String>,
    /// Step of the tracked parameter (SI or a quantity) [default: 51 points].
    #[arg(long, value_name = "S", conflicts_with = "points", requires = "param")]
    pub step: Option<String>,
    /// Number of values of the tracked parameter, ends included [default: 51].
    #[arg(long, value_name = "N", requires = "param")]
    pub points: Option<usize>,
    /// CSV of the tracking: `<param>,<label>.omega_n_rad_s,<label>.damping_ratio,<label>.mac,...`.
    #[arg(
        short = 'o',
        long = "output",
        value_name = "OUT.csv",
        requires = "param"
    )]
    pub output: Option<String>,
    /// SVG of the tracking: ω_n against the parameter, one curve per named mode.
    #[arg(long, value_name = "OUT.svg", requires = "param")]
    pub plot: Option<String>,
    #[command(flatten)]
    pub freq: super::args::FreqUnitArg,
    #[command(flatten)]
    pub plot_size: super::args::PlotSize,
}

pub fn run(a: ModesArgs) -> Result<()> {
    if let Some(param) = a.param.clone() {
        return track(a, &param);
    }
    let (model, sys) = a.model.load()?;
    let m = modal_analysis(&sys, a.normalize.as_deref())?;
    // a design far from the one the model's [[modes]] describe (an unstable one) may not
    // tell its modes apart by them: numbered by frequency instead, as `margins` does
    let (named, naming) = describe_modes_or_numbered(&sys, &m)?;
    if let Some(why) = &naming {
        eprintln!(
            "note: the model's [[modes]] names do not apply to this design ({why}): the modes are numbered by frequency instead"
        );
    }
    let growing = detune::margins::unstable_modes(
        &m,
        &named
            .iter()
            .map(|n| n.name.name.clone())
            .collect::<Vec<_>>(),
    );
    // the pose shown with its angles in (−π, π] where that is the same equilibrium, as
    // `equilibrium` shows it (the slider-crank from th0 = 10 rad at −90°, not 630°):
    // display only, the modes are those about the pose found
    let shown_q = detune::dynamics::assemble_at_rest(&sys)
        .ok()
        .and_then(|rest| detune::statics::Statics::new(&sys, &rest.q).ok())
        .map(|st| st.in_first_turn(m.equilibrium.clone()).q)
        .unwrap_or_else(|| m.equilibrium.q.clone());
    if a.json {
        let units = Units::new().coordinates(&sys).with_all(MODE_UNITS);
        let provenance = Provenance::of(&model);
        let mut doc = ModesReport::named(&m, &named, &provenance);
        doc.equilibrium = detune::output::json::Named::new(&m.coordinates, &shown_q);
        print_json(&WithUnits { doc, units: &units });
        return Ok(());
    }
    let fu = a.freq.freq_unit;
    let sym = fu.symbol();
    // both truths: static (the potential's minimum) and dynamic (no mode grows)
    let words = detune::linear::stability_words(
        detune::output::json::stability(&m.equilibrium),
        m.dynamically_stable(),
        &growing,
    );
    if words.contains('(') {
        // the unstable cases carry their own parentheses: which mode grows, how fast
        println!("equilibrium: {words}");
    } else {
        println!("equilibrium ({words}):");
    }
    for (c, v) in m.coordinates.iter().zip(&shown_q) {
        println!(
            "  {c:<16} {v:>22.12}{}",
            super::unit_and_degrees(&sys, c, *v)
        );
    }
    if m.linearization.dof() == 0 {
        println!("\n{}", detune::linear::no_modes_words(&sys));
        return Ok(());
    }
    println!("\nundamped: ω² = {:?} rad²/s²", m.undamped_omega2);
    for w2 in &m.undamped_omega2 {
        if *w2 > 0.0 && fu != FreqUnit::RadPerSecond {
            println!(
                "  f = {:.10} {sym} = ω {:.10} rad/s",
                fu.of(w2.sqrt()),
                w2.sqrt()
            );
        } else if *w2 > 0.0 {
            println!(
                "  ω = {:.10} rad/s = {:.6} Hz",
                w2.sqrt(),
                w2.sqrt() / (2.0 * std::f64::consts::PI)
            );
        } else {
            println!("  unstable direction: ω² = {w2:.6} rad²/s²");
        }
    }
    println!(
        "\n{:>4} {:>14} {:>14} {:>12} {:>10} {:>28}",
        "mode",
        format!("{} [{sym}]", natural(fu, "n")),
        format!("{} [{sym}]", natural(fu, "d")),
        // ω_n in the companion unit: Hz, or rad/s when the table is in Hz
        match fu.companion() {
            FreqUnit::Hertz => "f [Hz]",
            _ => "ω_n [rad/s]",
        },
        "ζ",
        "eigenvalue [1/s]"
    );
    for (k, md) in m.modes.iter().enumerate() {
        let motion = m.motion(k);
        if motion.is_real() {
            // a real eigenvalue: no oscillation, so no frequency or damping ratio to show
            let lambda = md.eigenvalue.re;
            if motion == Motion::Neutral {
                println!(
                    "{:>4} non-oscillatory: neutral (λ = 0 to round-off){:>13.8} {:+13.8}i",
                    k + 1,
                    md.eigenvalue.re,
                    md.eigenvalue.im
                );
                continue;
            }
            let (what, rate) = if motion == Motion::Divergent {
                ("DIVERGENT: grows", lambda)
            } else {
                ("non-oscillatory: decays", -lambda)
            };
            println!(
                "{:>4} {what} as e^({lambda:+.8} t): rate {rate:.8} 1/s, time constant {:.6} s{:>13.8} {:+13.8}i",
                k + 1,
                1.0 / rate,
                md.eigenvalue.re,
                md.eigenvalue.im
            );
            continue;
        }
        println!(
            "{:>4} {:>14.8} {:>14.8} {:>12.6} {:>10.6} {:>13.8} {:+13.8}i{}",
            k + 1,
            fu.of(md.omega_n_rad_s),
            fu.of(md.omega_d_rad_s),
            fu.companion().of(md.omega_n_rad_s),
            md.damping_ratio,
            md.eigenvalue.re,
            md.eigenvalue.im,
            if motion == Motion::GrowingOscillation {
                format!(
                    "  GROWING: e^({} t), time constant {:.6} s",
                    detune::linear::rate_text(md.eigenvalue.re, 6, true),
                    1.0 / md.eigenvalue.re
                )
            } else {
                String::new()
            }
        );
    }
    println!(
        "\nshapes (normalized to {} = 1; each entry in its coordinate's unit per unit of {}):",
        m.coordinates[m.reference], m.coordinates[m.reference]
    );
    let reference_unit = detune::output::units::coordinate_unit(&sys, m.reference);
    for (i, c) in m.coordinates.iter().enumerate() {
        let row: Vec<String> = m
            .modes
            .iter()
            .map(|md| format!("{:>10.6}{:+10.6}i", md.shape[i].re, md.shape[i].im))
            .collect();
        println!(
            "  {c:<16} {}  [{}/{reference_unit}]",
            row.join("  "),
            detune::output::units::coordinate_unit(&sys, i)
        );
    }
    for (k, md) in m.modes.iter().enumerate() {
        if md.normalized_to != m.reference {
            println!(
                "  mode {}: {} does not move; normalized to {} = 1 instead",
                k + 1,
                m.coordinates[m.reference],
                m.coordinates[md.normalized_to]
            );
        }
    }
    print_names(&named);
    Ok(())
}

/// A natural (`which` "n") or damped ("d") frequency's symbol in `fu`: ω_n in rad/s, f_n
/// in Hz or rpm (cycle rates; docs/units.md).
pub(crate) fn natural(fu: FreqUnit, which: &str) -> String {
    format!("{}_{which}", fu.rate())
}

/// `percent` of a fraction, `55 %`.
fn percent(x: f64) -> String {
    format!("{:.0} %", 100.0 * x)
}

/// Shares with their signs, `constraint reactions −104 %, coupling +4 %`.
fn signed_list(s: &detune::linear::tracking::Shares) -> String {
    s.0.iter()
        .map(|(name, x)| {
            let pc = format!("{:.0}", 100.0 * x.abs());
            let sign = if pc == "0" {
                ""
            } else if *x < 0.0 {
                "−"
            } else {
                "+"
            };
            format!("{name} {sign}{pc} %")
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Each mode's name, the body holding most of its kinetic energy, and its shares.
fn print_names(named: &[detune::linear::tracking::NamedMode]) {
    println!("\nnames and energy shares (kinetic energy by body, strain energy by force element):");
    for (k, n) in named.iter().enumerate() {
        let dominant = n
            .dominant_body
            .as_ref()
            .map(|d| format!(" ({} {} KE)", d.body, percent(d.share)))
            .unwrap_or_default();
        let matched = n
            .name
            .declared_mac
            .map(|x| format!(", MAC {x:.3} with its [[modes]] shape"))
            .unwrap_or_default();
        println!("{:>4}  {}{dominant}{matched}", k + 1, n.name.name);
        let list = |s: &detune::linear::tracking::Shares| {
            s.0.iter()
                .map(|(name, x)| format!("{name} {}", percent(*x)))
                .collect::<Vec<_>>()
                .join(", ")
        };
        println!("        kinetic: {}", list(&n.energy.kinetic));
        if n.energy.strain.0.is_empty() {
            println!("        strain: none (the mode stores no strain energy)");
        } else if n.energy.strain_released() {
            // a negative stiffness (a saddle's divergence): the mode lowers the potential
            // energy; each share of the energy released, negative where it is released
            println!(
                "        strain: released, not stored (a negative stiffness: the mode lowers the potential energy): {} of the energy released (− releases, + stores)",
                signed_list(&n.energy.strain)
            );
        } else {
            println!("        strain: {}", list(&n.energy.strain));
        }
    }
}

/// `detune modes --param`: the modes tracked over the parameter's values.
fn track(a: ModesArgs, param: &str) -> Result<()> {
    let (model, sys) = a.model.load()?;
    let size = a.plot_size.check(a.plot.as_deref(), a.output.as_deref())?;
    let outputs = check_outputs(
        &model.source.path,
        &[a.output.as_deref(), a.plot.as_deref()],
    )?;
    let value = |flag: &str, text: &Option<String>| -> Result<Option<f64>> {
        text.as_deref()
            .map(|t| super::args::param_value(&model, param, flag, t))
            .transpose()
    };
    let from = value("--from", &a.from)?.unwrap_or(f64::NAN);
    let to = value("--to", &a.to)?.unwrap_or(f64::NAN);
    let step = value("--step", &a.step)?;
    let grid = values(from, to, step, a.points)?;
    // a signal stops the tracking at its next value; nothing is written (exit 130, 143,
    // 129)
    super::interrupt_on_ctrl_c();
    let opts = TrackOptions {
        normalize: a.normalize.clone(),
        cancel: Some(&super::INTERRUPTED),
        ..TrackOptions::default()
    };
    // the analytic dλ/dp predicts each label's eigenvalue at the next value
    let predictor = detune::linear::sensitivity::Analytic {
        param: sys.param_index(param).unwrap_or(usize::MAX),
    };
    let t = if predictor.param == usize::MAX {
        track_modes(&sys, param, &grid, &opts)?
    } else {
        detune::linear::tracking::track_modes_with(&sys, param, &grid, &opts, &predictor)?
    };
    let unit = model
        .parameters
        .index(param)
        .and_then(|i| model.parameters.list[i].unit.as_ref())
        .map(|(u, _)| u.as_str())
        .unwrap_or("");
    if let Some(o) = &a.output {
        detune::output::results::write_tracking_csv(o, &t)?;
    }
    if let Some(p) = &a.plot {
        // ω_n is the y axis here: drawn in the --freq-unit
        let fu = a.freq.freq_unit;
        let mut figure = detune::output::figures::tracking_figure(
            &detune::output::figures::Case::of(&model),
            &t,
            unit,
        );
        if fu != FreqUnit::RadPerSecond {
            // in Hz or rpm a natural frequency is f_n (a cycle rate), not ω_n: the
            // curves, the crossings' markers and notes, the legend and the axis alike
            let (from, to) = ("ω_n [rad/s]", format!("f_n [{fu}]"));
            for s in &mut figure.series {
                s.y.iter_mut().for_each(|y| *y = fu.of(*y));
                s.label = s.label.replace(from, &to);
            }
            for n in &mut figure.notes {
                n.y = fu.of(n.y);
            }
            figure.y_label = figure.y_label.replace(from, &to);
        }
        detune::output::plot::write_panels_sized(p, &[figure], size)?;
    }
    outputs.commit()?;
    for f in [&a.output, &a.plot].into_iter().flatten() {
        eprintln!("wrote {f}");
    }
    for w in &t.warnings {
        eprintln!("warning: {w}");
    }
    if a.json {
        let mut units = Units::new().with(param, unit);
        for l in &t.labels {
            units.add(format!("{l}.omega_n_rad_s"), "rad/s");
            units.add(format!("{l}.damping_ratio"), "1");
            units.add(format!("{l}.mac"), "1");
        }
        let units = units.with("value", unit).with_all([
            ("omega_n_rad_s", "rad/s"),
            ("damping_ratio", "1"),
            ("mac", "1"),
            ("min_mac", "1"),
            ("relative_gap", "1"),
            ("window", unit),
            ("baseline", unit),
        ]);
        print_json(&WithUnits {
            doc: TrackingReport {
                tracking: &t,
                param_unit: unit,
                provenance: &Provenance::of(&model),
            },
            units: &units,
        });
        return Ok(());
    }
    print_tracking(&t, unit, a.freq.freq_unit);
    Ok(())
}

/// The tracking as a table, then its crossings, veerings and least MACs.
fn print_tracking(t: &ModeTracking, unit: &str, fu: FreqUnit) {
    let u = if unit.is_empty() {
        String::new()
    } else {
        format!(" [{unit}]")
    };
    let sym = fu.symbol();
    let nat = natural(fu, "n");
    println!(
        "modes against {}{u} (named at {} = {}{u}); {nat} in {sym}, ζ the damping ratio:",
        t.param, t.param, t.baseline
    );
    let at_baseline: Vec<String> = t
        .labels
        .iter()
        .zip(&t.dominant_body)
        .map(|(l, d)| match d {
            Some(d) => format!("{l} ({} {} KE)", d.body, percent(d.share)),
            None => l.clone(),
        })
        .collect();
    println!("  at the baseline: {}", at_baseline.join(", "));
    let head: Vec<String> = t
        .labels
        .iter()
        .map(|l| format!("{:>26}", format!("{l}: {nat}, ζ")))
        .collect();
    println!("{:>14}  {}", format!("{}{u}", t.param), head.join(" "));
    for s in t.steps.iter().filter(|s| s.requested) {
        let cols: Vec<String> = s
            .modes
            .iter()
            .map(|m| match m {
                // (a ζ of rounding size printed as 0, not -0.000000)
                Some(m) => format!(
                    "{:>16} {:>9.6}",
                    detune::diag::fixed(fu.of(m.omega_n_rad_s), 6),
                    if m.damping_ratio.abs() < 5e-7 {
                        0.0
                    } else {
                        m.damping_ratio
                    }
                ),
                None => format!("{:>26}", "(lost)"),
            })
            .collect();
        println!(
            "{:>14}  {}",
            detune::diag::fixed(s.value, 6),
            cols.join(" ")
        );
    }
    let inserted = t.steps.iter().filter(|s| !s.requested).count();
    if inserted > 0 {
        println!("({inserted} value(s) inserted where the step was halved to follow the modes)");
    }
    if t.crossings.is_empty() {
        println!("\ncrossings: none");
    } else {
        println!("\ncrossings (two modes' {nat} swap order):");
        for c in &t.crossings {
            println!(
                "  {} and {} at {} = {}{u}, {nat} = {} {sym}",
                c.labels[0],
                c.labels[1],
                t.param,
                detune::diag::fixed(c.value, 6),
                detune::diag::fixed(fu.of(c.omega_n_rad_s), 6)
            );
        }
    }
    if t.veerings.is_empty() {
        println!("veerings: none");
    } else {
        println!("veerings (two modes approach without crossing and exchange shapes):");
        for v in &t.veerings {
            println!(
                "  {} and {} at {} = {}{u}: {nat} = {} and {} {sym}, least relative gap {:.2} %, shapes exchanged over {} to {}{u}",
                v.labels[0],
                v.labels[1],
                t.param,
                detune::diag::fixed(v.value, 6),
                detune::diag::fixed(fu.of(v.omega_n_rad_s[0]), 6),
                detune::diag::fixed(fu.of(v.omega_n_rad_s[1]), 6),
                100.0 * v.relative_gap,
                detune::diag::fixed(v.window[0], 6),
                detune::diag::fixed(v.window[1], 6)
            );
        }
    }
    println!("least MAC with the previous step:");
    for (l, m) in t.labels.iter().zip(&t.min_mac) {
        println!("  {l:<24} {m:.4}");
    }
}
