//! `detune check`: coordinates, constraints, rank, degrees of freedom, parameters (SI).

use super::args::ModelArgs;
use clap::Args;
use detune::System;
use detune::diag::Result;
use detune::dynamics::{assemble, constraint_rank};

#[derive(Args)]
#[command(allow_negative_numbers = true)]
pub struct CheckArgs {
    #[command(flatten)]
    pub model: ModelArgs,
}

pub fn run(a: CheckArgs) -> Result<()> {
    let model = a.model.load()?;
    let sys = System::new(&model)?;
    println!("model {} ({})", model.name, model.source.path);
    if let Some(d) = &model.description {
        println!("  {d}");
    }
    println!("\nparameters (SI):");
    let p = &model.parameters;
    for (i, par) in p.list.iter().enumerate() {
        let dim = p.dims[i].map(|d| format!(" {d}")).unwrap_or_default();
        let set = p.overridden[i]
            .as_ref()
            .map(|s| format!("   (--set {s})"))
            .unwrap_or_default();
        println!("  {:<12} = {:<22}{dim}{set}", par.name, p.values[i]);
    }
    let state = assemble(&sys);
    println!("\ncoordinates ({}):", sys.n());
    match &state {
        Ok(s) => {
            for (i, c) in sys.coordinates.iter().enumerate() {
                let fixed = if sys.initial.fixed[i] {
                    "  (fixed)"
                } else {
                    ""
                };
                println!("  {c:<16} initial {:>22.15}{fixed}", s.q[i]);
            }
        }
        Err(_) => {
            for c in &sys.coordinates {
                println!("  {c}");
            }
        }
    }
    println!("\nconstraints ({} equations):", sys.m());
    for c in &sys.constraint_names {
        println!("  {c}");
    }
    let s = state?;
    let rank = constraint_rank(&sys, &s.q, 0.0);
    println!(
        "\nconstraint rank at the initial pose: {rank} of {} equations",
        sys.m()
    );
    if rank < sys.m() {
        println!(
            "  ({} redundant or singular; the pseudoinverse handles them)",
            sys.m() - rank
        );
    }
    println!("degrees of freedom: {}", sys.n() - rank);
    println!(
        "initial constraint residual: {:.3e}",
        detune::dynamics::residual_norm(&sys, &s.q, 0.0)
    );
    Ok(())
}
