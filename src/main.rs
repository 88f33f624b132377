//! `detune`: the command line. A thin layer: parse arguments, call the library, write files.

use clap::{Args, Parser, Subcommand};
use detune::diag::{Error, Result};
use detune::dynamics::simulate::{SimOptions, Trajectory, simulate};
use detune::dynamics::{assemble, constraint_rank};
use detune::output::plot::{LinePlot, Series, Style, write_line_plot};
use detune::output::{Provenance, write_json, write_trajectory_csv};
use detune::{Model, System};
use std::io::IsTerminal;

#[derive(Parser)]
#[command(
    name = "detune",
    version,
    about = "Preliminary-design dynamics of constrained mechanisms: equations of motion from a model file (Udwadia–Kalaba), simulation, and more.",
    after_help = "Units: everything is SI (m, kg, s, N, rad). Model files and --set may write quantities with units, e.g. \"7 mm\", \"4.3 Hz\" (= 27.02 rad/s)."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Check a model: coordinates, constraints, rank, degrees of freedom, parameters (SI).
    Check(CheckArgs),
    /// Simulate the motion from the model's initial state and write CSV (and an SVG plot).
    #[command(allow_negative_numbers = true)]
    Simulate(SimulateArgs),
}

#[derive(Args)]
struct ModelArgs {
    /// Model file (TOML), e.g. models/overcentre.toml.
    model: String,
    /// Override a parameter: NAME=VALUE, where VALUE is a number (SI), a quantity ("3 mm")
    /// or an expression over other parameters ("L1/2"). Repeatable.
    #[arg(long = "set", value_name = "NAME=VALUE", allow_hyphen_values = true)]
    set: Vec<String>,
}

impl ModelArgs {
    fn load(&self) -> Result<Model> {
        let model = Model::load(&self.model)?;
        let overrides = parse_sets(&self.set)?;
        model.with_overrides(&overrides)
    }
}

#[derive(Args)]
#[command(allow_negative_numbers = true)]
struct CheckArgs {
    #[command(flatten)]
    model: ModelArgs,
}

#[derive(Args)]
struct SimulateArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// End time, s.
    #[arg(long, default_value_t = 20.0, value_name = "S")]
    t_end: f64,
    /// Output interval, s.
    #[arg(long, default_value_t = 0.01, value_name = "S")]
    dt_out: f64,
    /// Relative error tolerance per step.
    #[arg(long, default_value_t = 1e-10, value_name = "R")]
    rtol: f64,
    /// Absolute error tolerance per step (SI units of each coordinate and velocity).
    #[arg(long, default_value_t = 1e-12, value_name = "A")]
    atol: f64,
    /// Add velocity columns `<name>_dot`.
    #[arg(long)]
    velocities: bool,
    /// Output CSV: `t,<body>.<coordinate>,...` in SI.
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    output: String,
    /// Also draw the angle coordinates (or all coordinates) against time as SVG.
    #[arg(long, value_name = "OUT.svg")]
    plot: Option<String>,
    /// Also write a JSON summary (provenance, statistics, final state).
    #[arg(long, value_name = "OUT.json")]
    json: Option<String>,
}

fn parse_sets(sets: &[String]) -> Result<Vec<(String, String)>> {
    sets.iter()
        .map(|s| match s.split_once('=') {
            Some((n, v)) if !n.trim().is_empty() && !v.trim().is_empty() => {
                Ok((n.trim().to_string(), v.trim().to_string()))
            }
            _ => Err(Error::request(
                format!("--set {s}: expected NAME=VALUE"),
                "for example --set Fs=-3 or --set \"L1=2.5 m\"",
            )),
        })
        .collect()
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Check(a) => check(a),
        Command::Simulate(a) => simulate_cmd(a),
    };
    if let Err(e) = result {
        eprint!("{}", e.render(std::io::stderr().is_terminal()));
        std::process::exit(1);
    }
}

fn check(a: CheckArgs) -> Result<()> {
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

fn simulate_cmd(a: SimulateArgs) -> Result<()> {
    let model = a.model.load()?;
    let sys = System::new(&model)?;
    let start = assemble(&sys)?;
    let opts = SimOptions {
        t_end: a.t_end,
        dt_out: a.dt_out,
        rtol: a.rtol,
        atol: a.atol,
        ..SimOptions::default()
    };
    let bar = indicatif::ProgressBar::new(1000);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "simulating {bar:40} {percent:>3}% {elapsed} (eta {eta})",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let began = std::time::Instant::now();
    let traj = simulate(&sys, &start, &opts, &mut |f| {
        if began.elapsed().as_millis() > 300 {
            bar.set_position((f * 1000.0) as u64);
        }
    });
    bar.finish_and_clear();
    let traj = traj?;
    write_trajectory_csv(&a.output, &traj, a.velocities)?;
    if let Some(p) = &a.plot {
        write_line_plot(p, &trajectory_plot(&model, &traj))?;
    }
    let st = &traj.stats;
    if let Some(j) = &a.json {
        let last = traj.q.len() - 1;
        let final_state: serde_json::Map<String, serde_json::Value> = traj
            .coordinates
            .iter()
            .enumerate()
            .map(|(i, c)| (c.clone(), serde_json::json!(traj.q[last][i])))
            .collect();
        write_json(
            j,
            &serde_json::json!({
                "provenance": Provenance::of(&model),
                "options": {"t_end": opts.t_end, "dt_out": opts.dt_out, "rtol": opts.rtol, "atol": opts.atol},
                "stats": st,
                "final": {"t": traj.t[last], "coordinates": final_state},
                "output": a.output,
            }),
        )?;
    }
    println!(
        "simulated {} s in {:.3} s: {} steps ({} rejected), {} right-hand sides, {} projections; largest constraint residual {:.2e}",
        opts.t_end,
        began.elapsed().as_secs_f64(),
        st.accepted_steps,
        st.rejected_steps,
        st.rhs_evaluations,
        st.projections,
        st.max_constraint_residual
    );
    println!("wrote {}", a.output);
    if let Some(p) = &a.plot {
        println!("wrote {p}");
    }
    if let Some(j) = &a.json {
        println!("wrote {j}");
    }
    Ok(())
}

/// Angle coordinates against time (all coordinates if the model has no angles).
fn trajectory_plot(model: &Model, traj: &Trajectory) -> LinePlot {
    let angles: Vec<usize> = (0..traj.coordinates.len())
        .filter(|&i| traj.coordinates[i].ends_with(".theta"))
        .collect();
    let pick = if angles.is_empty() {
        (0..traj.coordinates.len()).collect()
    } else {
        angles.clone()
    };
    LinePlot {
        title: format!("{}: simulation", model.name),
        x_label: "t [s]".into(),
        y_label: if angles.is_empty() {
            "coordinate [SI]".into()
        } else {
            "angle [rad]".into()
        },
        series: pick
            .iter()
            .map(|&i| Series {
                label: traj.coordinates[i].clone(),
                x: traj.t.clone(),
                y: traj.q.iter().map(|q| q[i]).collect(),
                style: Style::Solid,
            })
            .collect(),
    }
}
