//! `detune equilibrium`: the static equilibrium nearest the initial pose, or every
//! equilibrium of its assembly branch.

use super::args::ModelArgs;
use super::print_json;
use clap::Args;
use detune::diag::Result;
use detune::dynamics::assemble;
use detune::output::Provenance;
use detune::output::json::{EquilibriaReport, EquilibriumJson, EquilibriumReport};
use detune::statics::Statics;

#[derive(Args)]
pub struct EquilibriumArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Every equilibrium on the assembly branch of the initial pose, with stability.
    #[arg(long)]
    pub all: bool,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: EquilibriumArgs) -> Result<()> {
    let (model, sys) = a.model.load()?;
    let start = assemble(&sys)?;
    let st = Statics::new(&sys, &start.q)?;
    let list = if a.all {
        st.all(&start)?
    } else {
        vec![st.nearest(&start)?]
    };
    if a.json {
        let provenance = Provenance::of(&model);
        let json = |e| EquilibriumJson::new(&sys.coordinates, e);
        if a.all {
            print_json(&EquilibriaReport {
                equilibria: list.iter().map(json).collect(),
                provenance: &provenance,
            });
        } else {
            print_json(&EquilibriumReport {
                equilibrium: json(&list[0]),
                provenance: &provenance,
            });
        }
        return Ok(());
    }
    for (k, e) in list.iter().enumerate() {
        if a.all {
            println!("equilibrium {} of {}:", k + 1, list.len());
        }
        for (c, v) in sys.coordinates.iter().zip(&e.q) {
            println!("  {c:<16} {v:>22.12}");
        }
        let w2: Vec<String> = e.omega2.iter().map(|w| format!("{w:.6}")).collect();
        println!(
            "  {} (ω² = {} rad²/s²), residual {:.2e} after {} iterations",
            if e.stable { "stable" } else { "UNSTABLE" },
            w2.join(", "),
            e.residual,
            e.iterations
        );
    }
    Ok(())
}
