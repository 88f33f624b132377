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
    let (model, sys) = a.model.load()?;
    let report = CheckReport::new(&model, &sys);
    print!("{report}");
    report.assembly.map(|_| ())
}
