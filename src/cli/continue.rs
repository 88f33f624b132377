//! `detune continue`: equilibria followed through limit points while a parameter
//! changes (pseudo-arclength), folds and branch points located, and the branches that
//! cross at a branch point followed too.

use super::args::ModelArgs;
use super::print_json;
use clap::Args;
use detune::System;
use detune::diag::Result;
use detune::output::figures::{Case, branch_figure};
use detune::output::json::BranchReport;
use detune::output::plot::write_panels_sized;
use detune::output::results::write_branch_csv;
use detune::output::units::{FreqUnit, Units, WithUnits};
use detune::output::{Provenance, check_outputs};
use detune::request::Argument;
use detune::statics::continuation::{ContinuationOptions, continue_equilibria_until};

#[derive(Args)]
pub struct ContinueArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Parameter to vary.
    #[arg(long, value_name = "NAME")]
    pub param: String,
    /// Start value: a number (SI) or a quantity ("-10 deg").
    #[arg(long, value_name = "A", allow_hyphen_values = true)]
    pub from: String,
    /// End value: a number (SI) or a quantity.
    #[arg(long, value_name = "B", allow_hyphen_values = true)]
    pub to: String,
    /// Largest arclength step, in the units of the coordinates and the parameter
    /// [default: (B − A)/50].
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub step: Option<String>,
    /// Most continuation steps (points after the start point).
    #[arg(long, default_value_t = 5000, value_name = "N")]
    pub max_steps: usize,
    /// Print the JSON summary (folds, branch points) instead of a table.
    #[arg(long)]
    pub json: bool,
    /// CSV of the branches: `<param>,<coordinates>...,stable,branch` (`branch` 0: the one
    /// followed from the start; 1, 2, …: those switched to at its branch points).
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    pub output: Option<String>,
    /// SVG of the branches (stable solid, unstable dashed, folds and branch points marked).
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<String>,
    /// Coordinate drawn against the parameter, one panel each; repeatable (as sweep's
    /// --response) [default: the first angle].
    #[arg(long, value_name = "NAME")]
    pub plot_coordinate: Vec<String>,
    #[command(flatten)]
    pub plot_size: super::args::PlotSize,
    /// When the parameter (or one solved by [trim]) is a frequency (rad/s): the unit its
    /// values are printed and plotted in. The CSV and JSON stay in rad/s.
    #[command(flatten)]
    pub freq: super::args::FreqUnitArg,
}

pub fn run(a: ContinueArgs) -> Result<()> {
    let (model, sys) = a.model.load()?;
    let size = a.plot_size.check(a.plot.as_deref(), a.output.as_deref())?;
    let outputs = check_outputs(
        &model.source.path,
        &[a.output.as_deref(), a.plot.as_deref()],
    )?;
    let value = |flag: &str, text: &str| super::args::param_value(&model, &a.param, flag, text);
    let (from, to) = (value("--from", &a.from)?, value("--to", &a.to)?);
    let step = match &a.step {
        Some(s) => value("--step", s)?,
        None => (to - from).abs() / 50.0,
    };
    let opts = ContinuationOptions {
        param: a.param.clone(),
        from,
        to,
        step,
        max_steps: a.max_steps,
    };
    // Every request is checked before the work, so a bad one leaves no file behind.
    let mut picked: Vec<usize> = Vec::new();
    for name in &a.plot_coordinate {
        let i = detune::linear::coordinate(&sys, name, Argument::PlotCoordinate)?;
        if !picked.contains(&i) {
            picked.push(i);
        }
    }
    if picked.is_empty() {
        picked.push(detune::linear::default_reference(&sys));
    }
    // the coordinate the printed branch lines name: the first drawn
    let idx = picked[0];
    let fu = a.freq.freq_unit;
    // a parameter in rad/s is printed and plotted in --freq-unit
    let is_freq = |name: &str| model.param_unit(name) == "rad/s";
    // a value of parameter `name` with its unit (` N`, ` Hz`), `decimals` or as computed
    let show = |name: &str, x: f64, decimals: Option<usize>| -> String {
        let (x, u) = if is_freq(name) {
            (fu.of(x), fu.symbol().to_string())
        } else {
            (x, model.param_unit(name))
        };
        let u = if u.is_empty() { u } else { format!(" {u}") };
        match decimals {
            Some(d) => format!("{x:.d$}{u}"),
            None => format!("{x}{u}"),
        }
    };
    // a signal stops the continuation at its next step; the branch so far is kept,
    // marked incomplete, and the exit code says which signal (130, 143, 129)
    super::interrupt_on_ctrl_c();
    let branch = continue_equilibria_until(&sys, &opts, &super::INTERRUPTED)?;
    if branch.complete {
        // the branch ran to its end: a signal from now on stops nothing
        super::results_complete();
    }
    if fu != FreqUnit::RadPerSecond
        && !is_freq(&a.param)
        && !branch.solved.iter().any(|n| is_freq(n))
    {
        eprintln!(
            "note: --freq-unit {fu} changes frequencies only; {} is not one (its unit: {}), so the values are shown as they are",
            a.param,
            match model.param_unit(&a.param) {
                u if u.is_empty() => "none".to_string(),
                u => u,
            }
        );
    }
    if let Some(o) = &a.output {
        write_branch_csv(o, &branch)?;
    }
    if let Some(p) = &a.plot {
        let case = Case::of(&model);
        let figures: Vec<_> = picked
            .iter()
            .map(|&i| {
                let figure = branch_figure(
                    &case,
                    &branch,
                    i,
                    sys.is_angle(i),
                    &model.param_unit(&a.param),
                );
                if is_freq(&a.param) {
                    figure.in_frequency_unit(fu)
                } else {
                    figure
                }
            })
            .collect();
        write_panels_sized(p, &figures, size)?;
    }
    outputs.commit()?;
    if a.json {
        let pu = model.param_unit(&branch.param);
        let mut units = Units::new().with(branch.param.clone(), pu.clone());
        for name in &branch.solved {
            units.add(name.clone(), model.param_unit(name));
        }
        let units = units.coordinates(&sys).with("value", pu);
        print_json(&WithUnits {
            doc: BranchReport::new(&branch, &Provenance::of(&model)),
            units: &units,
        });
    } else {
        // the requested ends as given; a run that turned back at a fold says so
        let end = branch.points.last().map_or(from, |p| p.value);
        let param = &branch.param;
        // the parameter as named in the lines: `spin/2π` when a frequency is shown in Hz
        // or rpm (cycles: `spin = 0.3 Hz` would read as an angular frequency)
        let pn = if is_freq(param) {
            fu.quantity(param)
        } else {
            param.clone()
        };
        // the parameter's unit after each of its values (` N`; none when dimensionless)
        let pu = {
            let u = model.param_unit(param);
            if u.is_empty() { u } else { format!(" {u}") }
        };
        let reached = (end - to).abs() <= 1e-9 * (1.0 + to.abs());
        // a requested end as given; a plain number (SI) in --freq-unit when converted
        let given = |text: &str| -> String {
            match text.trim().parse::<f64>() {
                Ok(x) if is_freq(param) && fu != FreqUnit::RadPerSecond => show(param, x, Some(6)),
                _ => given(text, &pu),
            }
        };
        let how = if reached {
            format!("to {}", given(&a.to))
        } else if let Some(f) = branch.folds.first() {
            format!(
                "turned at the fold at {pn} = {}; ends at {pn} = {}",
                show(param, f.value, Some(6)),
                show(param, end, None)
            )
        } else if let Some(b) = branch
            .branch_points
            .iter()
            .find(|b| (b.value - end) * (to - from) > 0.0)
        {
            // a pitchfork reached along a side branch: it turns there, onto the other side
            format!(
                "turned at the branch point at {pn} = {}; ends at {pn} = {}",
                show(param, b.value, Some(6)),
                show(param, end, None)
            )
        } else {
            format!(
                "ends at {pn} = {} (before {})",
                show(param, end, None),
                given(&a.to)
            )
        };
        if !branch.switched.is_empty() {
            let total: usize = branch.points.len()
                + branch
                    .switched
                    .iter()
                    .map(|s| s.points.len())
                    .sum::<usize>();
            println!(
                "{total} points on {} branches (the CSV's `branch` column: 0 is the start's)",
                1 + branch.switched.len()
            );
        }
        if !branch.complete {
            println!(
                "interrupted: the points computed until then (the branch ends early{})",
                if branch.branch_points.is_empty() {
                    ""
                } else {
                    "; branches through its branch points may be missing"
                }
            );
        }
        println!(
            "{}{} points from {pn} = {} {how}{}",
            if branch.switched.is_empty() {
                ""
            } else {
                "branch 0: "
            },
            branch.points.len(),
            given(&a.from),
            if branch.truncated {
                " (stopped at --max-steps)"
            } else {
                ""
            }
        );
        if let (Some(p0), Some(p1)) = (branch.points.first(), branch.points.last()) {
            for (k, name) in branch.solved.iter().enumerate() {
                println!(
                    "solved by [trim]: {name} from {} to {}",
                    show(name, p0.solved[k], None),
                    show(name, p1.solved[k], None)
                );
            }
        }
        for (kind, points) in [
            ("fold", &branch.folds),
            ("branch point", &branch.branch_points),
        ] {
            for p in points {
                println!(
                    "{kind} at {pn} = {}: {}",
                    show(param, p.value, Some(10)),
                    pose(&sys, &p.q)
                );
            }
        }
        // the branches switched to at the branch points, one line each
        for (k, s) in branch.switched.iter().enumerate() {
            let (Some(p0), Some(p1)) = (s.points.first(), s.points.last()) else {
                continue;
            };
            let stability = match (
                s.points.iter().all(|p| p.stable),
                s.points.iter().any(|p| p.stable),
            ) {
                (true, _) => "stable",
                (false, false) => "unstable",
                _ => "stable in part",
            };
            println!(
                "branch {} from the branch point at {pn} = {} ({} = {:.8}{} first): {} points to {pn} = {}, {stability}{}{}",
                k + 1,
                show(param, branch.branch_points[s.branch_point].value, Some(10)),
                sys.coordinates[idx],
                p0.q[idx],
                super::unit_and_degrees(&sys, &sys.coordinates[idx], p0.q[idx]),
                s.points.len(),
                show(param, p1.value, None),
                if s.folds.is_empty() {
                    String::new()
                } else {
                    format!(", {} folds", s.folds.len())
                },
                if s.truncated {
                    " (stopped at --max-steps)"
                } else {
                    ""
                }
            );
        }
    }
    for f in [&a.output, &a.plot].into_iter().flatten() {
        eprintln!(
            "wrote {f}{}",
            if branch.complete { "" } else { " (incomplete)" }
        );
    }
    if !branch.complete {
        return Err(detune::failure::Failure::StudyInterrupted {
            what: "the continuation".into(),
            kept: true,
        }
        .into());
    }
    Ok(())
}

/// A value of the parameter as the user gave it (`3.2`, `"-10 deg"`), with the unit
/// `pu` after a plain number.
fn given(text: &str, pu: &str) -> String {
    if text.trim().parse::<f64>().is_ok() {
        format!("{}{pu}", text.trim())
    } else {
        text.trim().to_string()
    }
}

/// Each coordinate with its unit (an angle in degrees too: the system says which
/// coordinates are angles).
fn pose(sys: &System, q: &[f64]) -> String {
    sys.coordinates
        .iter()
        .zip(q)
        .map(|(c, v)| format!("{c} = {v:.8}{}", super::unit_and_degrees(sys, c, *v)))
        .collect::<Vec<_>>()
        .join(", ")
}
