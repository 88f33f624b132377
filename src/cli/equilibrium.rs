//! `detune equilibrium`: the static equilibrium nearest the initial pose, or every
//! equilibrium of its assembly branch.

use super::args::ModelArgs;
use super::print_json;
use clap::Args;
use detune::diag::Result;
use detune::output::Provenance;
use detune::output::json::{EquilibriaReport, EquilibriumJson, EquilibriumReport};
use detune::output::units::{Units, WithUnits};
use detune::statics::Statics;

#[derive(Args)]
pub struct EquilibriumArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Every equilibrium, once (poses 2π apart in an angle are one), sorted, with stability:
    /// along the assembly branch for one degree of freedom, from seeds over the angles for
    /// several (docs/statics-and-modes.md says what is guaranteed).
    #[arg(long)]
    pub all: bool,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: EquilibriumArgs) -> Result<()> {
    let (model, sys) = a.model.load()?;
    let start = detune::dynamics::assemble_at_rest(&sys)?;
    let st = Statics::new(&sys, &start.q)?;
    let list = if a.all {
        st.all(&start)?
    } else {
        // shown with its angles in (−π, π] as `--all` shows it, where that is the same
        // equilibrium (a start beyond a turn finds the crank at 630°: −90°)
        vec![st.in_first_turn(st.nearest(&start)?)]
    };
    // dynamic stability too (no mode grows), as `modes` gives it: with negative damping
    // a statically stable equilibrium is dynamically unstable. Modes that cannot be
    // computed leave it unknown (null), the static verdict standing alone.
    let reference = detune::linear::default_reference(&sys);
    let modal: Vec<Option<detune::linear::ModalAnalysis>> = list
        .iter()
        .map(|e| detune::linear::modal_analysis_at(&sys, &st, e.clone(), reference).ok())
        .collect();
    let dynamic = |k: usize| modal[k].as_ref().and_then(|m| m.dynamically_stable());
    let solved = sys.trim_solved();
    let trim_off = sys.trim_off().map(|p| {
        format!("off: {p} is given with --set, so the held pose need not be an equilibrium")
    });
    if a.json {
        let solved: Option<std::collections::BTreeMap<String, f64>> =
            solved.map(|v| v.into_iter().collect());
        let provenance = Provenance::of(&model);
        let json = |(k, e)| EquilibriumJson::new(&sys.coordinates, e, dynamic(k));
        let mut units = Units::new().coordinates(&sys).with_all([
            (
                "residual",
                "SI (the largest equation's residual: N, N·m, m or rad)",
            ),
            ("undamped_omega2", "rad^2/s^2"),
        ]);
        for name in solved.iter().flat_map(|s| s.keys()) {
            units.add(name.clone(), model.param_unit(name));
        }
        if a.all {
            print_json(&WithUnits {
                doc: EquilibriaReport {
                    equilibria: list.iter().enumerate().map(json).collect(),
                    solved,
                    trim: trim_off,
                    provenance: &provenance,
                },
                units: &units,
            });
        } else {
            print_json(&WithUnits {
                doc: EquilibriumReport {
                    equilibrium: json((0, &list[0])),
                    solved,
                    trim: trim_off,
                    provenance: &provenance,
                },
                units: &units,
            });
        }
        return Ok(());
    }
    if let Some(v) = &solved {
        for (name, value) in v {
            let unit = model.param_unit(name);
            println!("solved by [trim]: {name} = {value:.12} {unit}");
        }
    }
    if let Some(off) = &trim_off {
        println!("trim {off}");
    }
    for (k, e) in list.iter().enumerate() {
        if a.all {
            println!("equilibrium {} of {}:", k + 1, list.len());
        }
        for (c, v) in sys.coordinates.iter().zip(&e.q) {
            println!(
                "  {c:<16} {v:>22.12}{}",
                super::unit_and_degrees(&sys, c, *v)
            );
        }
        let w2: Vec<String> = e.omega2.iter().map(|w| format!("{w:.6}")).collect();
        if e.omega2.is_empty() {
            // nothing can move: the constraints (perhaps driven in time) fix the pose
            println!(
                "  {}; residual {:.2e} (SI: N, N·m, m, rad) after {} iterations",
                detune::linear::no_modes_words(&sys),
                e.residual,
                e.iterations
            );
            continue;
        }
        // both truths, in the words `modes` uses; the static verdict alone when the modes
        // could not be computed
        let words = match &modal[k] {
            Some(m) => {
                // the growing modes by the model's [[modes]] names, as `modes` names them
                // (numbered by frequency where the names do not apply to this design)
                let names: Vec<String> = if m.growing().is_empty() {
                    Vec::new()
                } else {
                    detune::linear::tracking::name_modes(&sys, m)
                        .map(|n| n.into_iter().map(|n| n.name).collect())
                        .unwrap_or_default()
                };
                detune::linear::stability_words(
                    Some(e.stable),
                    m.dynamically_stable(),
                    &detune::margins::unstable_modes(m, &names),
                )
            }
            None if e.stable => "stable (statically; modes not computed)".to_string(),
            None => "UNSTABLE".to_string(),
        };
        // (the unstable words carry their own parentheses: which mode grows, how fast)
        let (open, close) = if words.contains('(') {
            ("; ", "")
        } else {
            (" (", ")")
        };
        println!(
            "  {words}{open}ω² = {} rad²/s²{close}, residual {:.2e} (SI: N, N·m, m, rad) after {} iterations",
            w2.join(", "),
            e.residual,
            e.iterations
        );
    }
    Ok(())
}
