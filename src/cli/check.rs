//! `detune check`: coordinates, constraints, rank, degrees of freedom, parameters (SI).

use super::args::ModelArgs;
use clap::Args;
use detune::check::CheckReport;
use detune::diag::Result;

#[derive(Args)]
#[command(allow_negative_numbers = true)]
pub struct CheckArgs {
    #[command(flatten)]
    pub model: ModelArgs,
}

/// Print the report; a pose that cannot be assembled ends it after the constraints, and
/// is the error.
pub fn run(a: CheckArgs) -> Result<()> {
    let (model, sys) = a.model.load_untrimmed()?;
    let report = CheckReport::new(&model, &sys);
    print!("{report}");
    report.assembly.as_ref().map_err(|e| e.clone())?;
    if let Some(t) = &sys.trim {
        if let Some(off) = sys.trim_off() {
            println!("trim: off ({off} is given with --set)");
        } else {
            let held: Vec<&str> = t
                .coords
                .iter()
                .map(|&c| sys.coordinates[c].as_str())
                .collect();
            let (_, solved) = detune::statics::trim::trim(&sys)?;
            let values: Vec<String> = solved
                .iter()
                .map(|(n, v)| {
                    let unit = model
                        .parameters
                        .index(n)
                        .and_then(|i| model.parameters.dims[i])
                        .map(|d| format!(" {d}"))
                        .unwrap_or_default();
                    format!("{n} = {v:.12}{unit}")
                })
                .collect();
            println!(
                "trim: {} solved so that {} at its initial value is at rest",
                values.join(", "),
                held.join(", ")
            );
        }
    }
    Ok(())
}
