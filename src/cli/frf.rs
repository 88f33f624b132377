//! `detune frf`: the linear frequency response about the equilibrium nearest the
//! initial pose.

use super::args::{FrequencyGrid, ModelArgs};
use super::print_json;
use clap::Args;
use detune::diag::Result;
use detune::linear::frequency_response;
use detune::output::json::FrfReport;
use detune::output::results::write_frf_csv;
use detune::output::{Provenance, check_outputs};

#[derive(Args)]
pub struct FrfArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    #[command(flatten)]
    pub grid: FrequencyGrid,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// CSV: `<param>,<name>_amplitude,<name>_phase_deg,...`.
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    pub output: Option<String>,
}

pub fn run(a: FrfArgs) -> Result<()> {
    let (model, sys) = a.model.load()?;
    check_outputs(&model.source.path, &[a.output.as_deref()])?;
    let (values, responses) = a.grid.resolve(&model)?;
    let fr = frequency_response(&sys, &a.grid.param, &values, &responses)?;
    if let Some(o) = &a.output {
        write_frf_csv(o, &fr)?;
        eprintln!("wrote {o}");
    }
    if a.json {
        print_json(&FrfReport::new(&fr, &Provenance::of(&model)));
    } else if a.output.is_none() {
        let head: Vec<String> = fr
            .responses
            .iter()
            .map(|r| format!("{:>12} {:>9}", format!("{r} amp"), "phase"))
            .collect();
        println!("{:>10}  {}", fr.param, head.join("  "));
        for (k, w) in fr.omega.iter().enumerate() {
            let cols: Vec<String> = fr.values[k]
                .iter()
                .map(|(amp, ph)| format!("{amp:.6e} {ph:8.3}°"))
                .collect();
            println!("{w:10.5}  {}", cols.join("  "));
        }
    }
    if !a.json {
        for p in &fr.peaks {
            eprintln!(
                "peak {}: {} = {:.6} ± {:.1e} rad/s, amplitude {:.6e}",
                p.response, fr.param, p.omega, p.uncertainty, p.amplitude
            );
        }
    }
    Ok(())
}
