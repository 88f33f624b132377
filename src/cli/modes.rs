//! `detune modes`: modes of the linearized constrained dynamics about the equilibrium
//! nearest the initial pose.

use super::args::ModelArgs;
use super::print_json;
use clap::Args;
use detune::diag::Result;
use detune::linear::modal_analysis;
use detune::output::Provenance;
use detune::output::json::ModesReport;

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
}

pub fn run(a: ModesArgs) -> Result<()> {
    let (model, sys) = a.model.load()?;
    let m = modal_analysis(&sys, a.normalize.as_deref())?;
    if a.json {
        print_json(&ModesReport::new(&m, &Provenance::of(&model)));
        return Ok(());
    }
    println!(
        "equilibrium ({}):",
        if m.equilibrium.stable {
            "stable"
        } else {
            "UNSTABLE"
        }
    );
    for (c, v) in m.coordinates.iter().zip(&m.equilibrium.q) {
        println!(
            "  {c:<16} {v:>22.12}{}",
            super::unit_and_degrees(&sys, c, *v)
        );
    }
    if m.linearization.dof() == 0 {
        println!(
            "\nno degrees of freedom: the constraints fix every coordinate, so there are no modes"
        );
        return Ok(());
    }
    println!("\nundamped: ω² = {:?} rad²/s²", m.undamped_omega2);
    for w2 in &m.undamped_omega2 {
        if *w2 > 0.0 {
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
        "mode", "ω_n [rad/s]", "ω_d [rad/s]", "f [Hz]", "ζ", "eigenvalue"
    );
    for (k, md) in m.modes.iter().enumerate() {
        if md.omega_d_rad_s == 0.0 {
            // a real eigenvalue: no oscillation, so no frequency or damping ratio to show
            let lambda = md.eigenvalue.re;
            let (what, rate) = if lambda > 0.0 {
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
            "{:>4} {:>14.8} {:>14.8} {:>12.6} {:>10.6} {:>13.8} {:+13.8}i",
            k + 1,
            md.omega_n_rad_s,
            md.omega_d_rad_s,
            md.freq_hz,
            md.damping_ratio,
            md.eigenvalue.re,
            md.eigenvalue.im
        );
    }
    println!(
        "\nshapes (normalized to {} = 1):",
        m.coordinates[m.reference]
    );
    for (i, c) in m.coordinates.iter().enumerate() {
        let row: Vec<String> = m
            .modes
            .iter()
            .map(|md| format!("{:>10.6}{:+10.6}i", md.shape[i].re, md.shape[i].im))
            .collect();
        println!("  {c:<16} {}", row.join("  "));
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
    Ok(())
}
