//! `detune equilibrium`: the static equilibrium nearest the initial pose, or every
//! equilibrium of its assembly branch.

use super::args::ModelArgs;
use super::print_json;
use clap::Args;
use detune::System;
use detune::diag::Result;
use detune::dynamics::assemble;
use detune::output::Provenance;
use detune::output::results::equilibrium_json;
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
    let model = a.model.load()?;
    let sys = System::new(&model)?;
    let start = assemble(&sys)?;
    let st = Statics::new(&sys, &start.q)?;
    let list = if a.all {
        st.all(&start)?
    } else {
        vec![st.nearest(&start)?]
    };
    if a.json {
        let prov = Provenance::of(&model);
        let v = if a.all {
            serde_json::json!({
                "equilibria": list.iter().map(|e| equilibrium_json(&sys.coordinates, e)).collect::<Vec<_>>(),
                "provenance": prov,
            })
        } else {
            let mut v = equilibrium_json(&sys.coordinates, &list[0]);
            v["provenance"] = serde_json::json!(prov);
            v
        };
        print_json(&v);
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
