//! `detune`: the command line. A thin layer: parse arguments, call the library, write files.

use clap::{Args, Parser, Subcommand};
use detune::diag::{Error, Result};
use detune::dynamics::simulate::{SimOptions, Trajectory, simulate};
use detune::dynamics::{assemble, constraint_rank};
use detune::linear::{frequency_response, modal_analysis};
use detune::output::plot::{LinePlot, Series, Style, write_line_plot};
use detune::output::results::{
    branch_json, equilibrium_json, frf_json, modes_json, write_branch_csv, write_frf_csv,
};
use detune::output::{Provenance, check_outputs, write_json, write_trajectory_csv};
use detune::statics::Statics;
use detune::statics::continuation::{
    Branch, BranchPoint, ContinuationOptions, continue_equilibria,
};
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
    /// Static equilibrium nearest the initial pose (loads at their mean over a period), or
    /// every equilibrium of its assembly branch with --all.
    #[command(allow_negative_numbers = true)]
    Equilibrium(EquilibriumArgs),
    /// Follow equilibria through limit points while a parameter changes (pseudo-arclength).
    #[command(allow_negative_numbers = true)]
    Continue(ContinueArgs),
    /// Modes of the linearized constrained dynamics about the equilibrium nearest the
    /// initial pose.
    #[command(allow_negative_numbers = true)]
    Modes(ModesArgs),
    /// Linear frequency response about the equilibrium nearest the initial pose.
    #[command(allow_negative_numbers = true)]
    Frf(FrfArgs),
    /// Stepped-sine frequency response of the nonlinear model: steady states by time
    /// simulation, resonances located by refinement.
    #[command(allow_negative_numbers = true)]
    Sweep(SweepArgs),
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum ModeArg {
    /// every frequency from the equilibrium at rest, in parallel
    Independent,
    /// increasing frequency, each from the previous steady state
    Up,
    /// decreasing frequency, each from the previous steady state
    Down,
    /// up, then down; reports where they differ (hysteresis)
    Both,
}

#[derive(Args)]
struct SweepArgs {
    #[command(flatten)]
    model: ModelArgs,
    #[command(flatten)]
    grid: FrequencyGrid,
    /// Locate every resonance (local maximum of the amplitude) to this resolution, rad/s.
    #[arg(long, value_name = "R", allow_hyphen_values = true)]
    refine: Option<f64>,
    #[arg(long, value_enum, default_value = "independent")]
    mode: ModeArg,
    /// Repeat the sweep for each value of a parameter: PARAM=v1,v2,... (e.g. F0=0.1,1,2).
    #[arg(long, value_name = "PARAM=V1,V2,...", allow_hyphen_values = true)]
    values: Option<String>,
    /// Settling tolerance: Poincaré points agree to this fraction of the amplitude.
    #[arg(
        long,
        default_value_t = 1e-8,
        value_name = "TOL",
        allow_hyphen_values = true
    )]
    settle_tol: f64,
    /// Most periods per frequency.
    #[arg(long, default_value_t = 600, value_name = "N")]
    max_periods: usize,
    #[command(flatten)]
    tol: Tolerances,
    /// CSV: one row per frequency (and direction and --values entry).
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    output: Option<String>,
    /// Print the JSON result.
    #[arg(long)]
    json: bool,
    /// SVG: amplitude of the first response against frequency (with --values, also
    /// normalized by the value), the linear natural frequencies marked.
    #[arg(long, value_name = "OUT.svg")]
    plot: Option<String>,
}

#[derive(Args)]
struct EquilibriumArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Every equilibrium on the assembly branch of the initial pose, with stability.
    #[arg(long)]
    all: bool,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct ContinueArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Parameter to vary.
    #[arg(long, value_name = "NAME")]
    param: String,
    /// Start value (SI).
    #[arg(long, value_name = "A", allow_hyphen_values = true)]
    from: f64,
    /// End value (SI).
    #[arg(long, value_name = "B", allow_hyphen_values = true)]
    to: f64,
    /// Largest arclength step, in the units of the coordinates and the parameter
    /// [default: (B − A)/50].
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    step: Option<f64>,
    /// Most continuation steps (points after the start point).
    #[arg(long, default_value_t = 5000, value_name = "N")]
    max_steps: usize,
    /// Print the JSON summary (folds, branch points) instead of a table.
    #[arg(long)]
    json: bool,
    /// CSV of the branch: `<param>,<coordinates>...,stable`.
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    output: Option<String>,
    /// SVG of the branch (stable solid, unstable dashed, folds marked).
    #[arg(long, value_name = "OUT.svg")]
    plot: Option<String>,
    /// Coordinate drawn against the parameter [default: the first angle].
    #[arg(long, value_name = "NAME")]
    plot_coordinate: Option<String>,
}

#[derive(Args)]
struct ModesArgs {
    #[command(flatten)]
    model: ModelArgs,
    /// Coordinate whose shape entry is 1 [default: the first angle coordinate].
    #[arg(long, value_name = "NAME")]
    normalize: Option<String>,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct FrfArgs {
    #[command(flatten)]
    model: ModelArgs,
    #[command(flatten)]
    grid: FrequencyGrid,
    /// Print JSON.
    #[arg(long)]
    json: bool,
    /// CSV: `<param>,<name>_amplitude,<name>_phase_deg,...`.
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    output: Option<String>,
}

/// The integrator's error tolerances (`simulate`, `sweep`).
#[derive(Args)]
struct Tolerances {
    /// Relative error tolerance per step.
    #[arg(
        long,
        default_value_t = 1e-10,
        value_name = "R",
        allow_hyphen_values = true
    )]
    rtol: f64,
    /// Absolute error tolerance per step (SI units of each coordinate and velocity).
    #[arg(
        long,
        default_value_t = 1e-12,
        value_name = "A",
        allow_hyphen_values = true
    )]
    atol: f64,
}

/// The frequencies of `frf` and `sweep`, and what they report.
#[derive(Args)]
struct FrequencyGrid {
    /// The forcing's frequency parameter (rad/s).
    #[arg(long, value_name = "NAME")]
    param: String,
    /// First frequency, rad/s.
    #[arg(long, value_name = "A", allow_hyphen_values = true)]
    from: f64,
    /// Last frequency, rad/s (included when the step divides the range).
    #[arg(long, value_name = "B", allow_hyphen_values = true)]
    to: f64,
    /// Frequency step, rad/s.
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    step: f64,
    /// Coordinate to report (repeatable) [default: every coordinate].
    #[arg(long, value_name = "NAME")]
    response: Vec<String>,
}

impl FrequencyGrid {
    /// The frequencies and the reported coordinates (every one when none is named).
    fn resolve(&self, model: &Model) -> Result<(Vec<f64>, Vec<String>)> {
        let values = detune::linear::grid(self.from, self.to, self.step)?;
        let responses = if self.response.is_empty() {
            model.coordinate_names()
        } else {
            self.response.clone()
        };
        Ok((values, responses))
    }
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
    #[arg(
        long,
        default_value_t = 20.0,
        value_name = "S",
        allow_hyphen_values = true
    )]
    t_end: f64,
    /// Output interval, s.
    #[arg(
        long,
        default_value_t = 0.01,
        value_name = "S",
        allow_hyphen_values = true
    )]
    dt_out: f64,
    #[command(flatten)]
    tol: Tolerances,
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
    // `detune modes ... | head`: a closed pipe ends the process quietly, as it does for
    // other command-line tools, instead of making `println!` panic.
    #[cfg(unix)]
    // SAFETY: restoring the default action of a signal before any thread is started.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Check(a) => check(a),
        Command::Simulate(a) => simulate_cmd(a),
        Command::Equilibrium(a) => equilibrium_cmd(a),
        Command::Continue(a) => continue_cmd(a),
        Command::Modes(a) => modes_cmd(a),
        Command::Frf(a) => frf_cmd(a),
        Command::Sweep(a) => sweep_cmd(a),
    };
    if let Err(e) = result {
        eprint!(
            "{}",
            e.render_with(std::io::stderr().is_terminal(), &advice)
        );
        std::process::exit(1);
    }
}

/// What to do about a failure, with this command line's flags (the library's own hint,
/// [`detune::failure::Failure::hint`], names none).
fn advice(f: &detune::failure::Failure) -> Option<String> {
    use detune::failure::Failure::*;
    Some(match f {
        StepLimit { .. } => {
            "loosen --rtol/--atol or shorten the run; a very small step points to a singular pose".into()
        }
        StepSizeUnderflow { .. } => "the mechanism may be at a singular pose (a rank loss of the constraints) or the forces change abruptly; check the model, or loosen --rtol/--atol".into(),
        TooManySteps { .. } => "loosen --rtol/--atol or shorten the run".into(),
        Integrator { bad_input: true, .. } => "check --t-end, --rtol and --atol".into(),
        ConstraintsNotKept { .. } => "tighten --rtol/--atol (the defaults are 1e-10 and 1e-12); if that does not help, the mechanism may pass a singular pose".into(),
        ContinuationStalled { .. } => "the branch may end here (a singular pose or no equilibrium), or --step is far too large for this model (the default is the range / 50): try a smaller --step".into(),
        BranchTurns { .. } => "the branch may end here (a singular pose); try a smaller --step".into(),
        SingularStart => "start away from it: --set the initial value of the coordinate the model fixes for assembly to another value".into(),
        NoEquilibrium { .. } => "start closer to an equilibrium (e.g. --set the initial angle), or check that one exists for these loads".into(),
        _ => return None,
    })
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
    check_outputs(
        &model.source.path,
        &[Some(&a.output), a.plot.as_deref(), a.json.as_deref()],
    )?;
    let sys = System::new(&model)?;
    let start = assemble(&sys)?;
    let opts = SimOptions {
        t_end: a.t_end,
        dt_out: a.dt_out,
        rtol: a.tol.rtol,
        atol: a.tol.atol,
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
        true
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
        "simulated {} s in {:.3} s: {} steps ({} rejected), {} right-hand sides, {} projections; largest constraint residual {:.2e} (drift before projection {:.2e})",
        opts.t_end,
        began.elapsed().as_secs_f64(),
        st.accepted_steps,
        st.rejected_steps,
        st.rhs_evaluations,
        st.projections,
        st.max_constraint_residual,
        st.max_drift
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
        vertical: Vec::new(),
    }
}

fn print_json(v: &serde_json::Value) {
    println!("{}", serde_json::to_string_pretty(v).unwrap_or_default());
}

fn equilibrium_cmd(a: EquilibriumArgs) -> Result<()> {
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

fn continue_cmd(a: ContinueArgs) -> Result<()> {
    let model = a.model.load()?;
    check_outputs(
        &model.source.path,
        &[a.output.as_deref(), a.plot.as_deref()],
    )?;
    let opts = ContinuationOptions {
        param: a.param.clone(),
        from: a.from,
        to: a.to,
        step: a.step.unwrap_or((a.to - a.from).abs() / 50.0),
        max_steps: a.max_steps,
    };
    // Every request is checked before the work, so a bad one leaves no file behind.
    let sys = System::new(&model)?;
    let idx = match &a.plot_coordinate {
        Some(name) => detune::linear::coordinate(&sys, name, "--plot-coordinate")?,
        None => detune::linear::default_reference(&sys),
    };
    let branch = continue_equilibria(&sys, &opts)?;
    if let Some(o) = &a.output {
        write_branch_csv(o, &branch)?;
    }
    if let Some(p) = &a.plot {
        write_line_plot(p, &branch_plot(&model, &branch, idx))?;
    }
    if a.json {
        print_json(&branch_json(&branch, &Provenance::of(&model)));
    } else {
        println!(
            "{} points from {} = {} to {}{}",
            branch.points.len(),
            branch.param,
            a.from,
            branch.points.last().map_or(a.from, |p| p.value),
            if branch.truncated {
                " (stopped at --max-steps)"
            } else {
                ""
            }
        );
        for f in &branch.folds {
            println!(
                "fold at {} = {:.10}: {}",
                branch.param,
                f.value,
                pose(&sys, &f.q)
            );
        }
        for b in &branch.branch_points {
            println!(
                "branch point at {} = {:.10}: {}",
                branch.param,
                b.value,
                pose(&sys, &b.q)
            );
        }
    }
    for f in [&a.output, &a.plot].into_iter().flatten() {
        eprintln!("wrote {f}");
    }
    Ok(())
}

fn pose(sys: &System, q: &[f64]) -> String {
    sys.coordinates
        .iter()
        .zip(q)
        .map(|(c, v)| format!("{c} = {v:.8}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The paper's Figure 6: the branch in (parameter, coordinate), stable solid, unstable
/// dashed, folds marked.
fn branch_plot(model: &Model, b: &Branch, idx: usize) -> LinePlot {
    let mut series = Vec::new();
    let mut seg: Vec<&BranchPoint> = Vec::new();
    let flush = |seg: &mut Vec<&BranchPoint>, series: &mut Vec<Series>| {
        if seg.len() > 1 {
            let stable = seg[1].stable;
            series.push(Series {
                label: if stable {
                    "stable".into()
                } else {
                    "unstable".into()
                },
                x: seg.iter().map(|p| p.value).collect(),
                y: seg.iter().map(|p| p.q[idx]).collect(),
                style: if stable { Style::Solid } else { Style::Dashed },
            });
        }
        seg.clear();
    };
    for p in &b.points {
        if let Some(last) = seg.last()
            && last.stable != p.stable
        {
            seg.push(p);
            flush(&mut seg, &mut series);
        }
        seg.push(p);
    }
    flush(&mut seg, &mut series);
    if !b.folds.is_empty() {
        series.push(Series {
            label: "folds".into(),
            x: b.folds.iter().map(|p| p.value).collect(),
            y: b.folds.iter().map(|p| p.q[idx]).collect(),
            style: Style::Markers,
        });
    }
    if !b.branch_points.is_empty() {
        series.push(Series {
            label: "branch points".into(),
            x: b.branch_points.iter().map(|p| p.value).collect(),
            y: b.branch_points.iter().map(|p| p.q[idx]).collect(),
            style: Style::Markers,
        });
    }
    LinePlot {
        title: format!("{}: equilibria against {}", model.name, b.param),
        x_label: b.param.clone(),
        y_label: format!("{} [{}]", b.coordinates[idx], unit_of(&b.coordinates[idx])),
        series,
        vertical: Vec::new(),
    }
}

/// SI unit of a coordinate by its name.
fn unit_of(coordinate: &str) -> &'static str {
    if coordinate.ends_with(".theta") || coordinate.ends_with(".phi") {
        "rad"
    } else {
        "m"
    }
}

fn modes_cmd(a: ModesArgs) -> Result<()> {
    let model = a.model.load()?;
    let m = modal_analysis(&System::new(&model)?, a.normalize.as_deref())?;
    if a.json {
        print_json(&modes_json(&m, &Provenance::of(&model)));
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
        println!("  {c:<16} {v:>22.12}");
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

fn frf_cmd(a: FrfArgs) -> Result<()> {
    let model = a.model.load()?;
    check_outputs(&model.source.path, &[a.output.as_deref()])?;
    let (values, responses) = a.grid.resolve(&model)?;
    let fr = frequency_response(&System::new(&model)?, &a.grid.param, &values, &responses)?;
    if let Some(o) = &a.output {
        write_frf_csv(o, &fr)?;
        eprintln!("wrote {o}");
    }
    if a.json {
        print_json(&frf_json(&fr, &Provenance::of(&model)));
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
    Ok(())
}

static INTERRUPTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

fn sweep_cmd(a: SweepArgs) -> Result<()> {
    use detune::frequency::{SteadyOptions, SweepMode, SweepOptions, sweep};
    use detune::output::results::{SweepRun, sweep_json, write_sweep_csv};
    let model = a.model.load()?;
    check_outputs(
        &model.source.path,
        &[a.output.as_deref(), a.plot.as_deref()],
    )?;
    let (values, responses) = a.grid.resolve(&model)?;
    let family: Vec<(Option<(String, f64)>, Model)> = match &a.values {
        None => vec![(None, model.clone())],
        Some(spec) => {
            let (name, list) = spec.split_once('=').ok_or_else(|| {
                Error::request(
                    format!("--values {spec}: expected PARAM=v1,v2,..."),
                    "for example --values F0=0.1,1,2,3,4",
                )
            })?;
            let name = name.trim();
            if name.is_empty() {
                return Err(Error::request(
                    format!("--values {spec}: no parameter named before `=`"),
                    "for example --values F0=0.1,1,2,3,4",
                ));
            }
            if name == a.grid.param {
                return Err(Error::request(
                    format!("--values {spec}: `{name}` is the swept parameter (--param)"),
                    "give --values a different parameter, e.g. the forcing amplitude F0",
                ));
            }
            let mut out = Vec::new();
            for v in list.split(',') {
                if v.trim().is_empty() {
                    return Err(Error::request(
                        format!("--values {spec}: an empty entry"),
                        "separate the values by single commas: --values F0=0.1,1,2",
                    ));
                }
                let m = model
                    .with_overrides(&[(name.to_string(), v.trim().to_string())])
                    .map_err(|e| match e {
                        Error::Request { message, help } => Error::Request {
                            message: message.replace("--set ", "--values "),
                            help,
                        },
                        other => other.context(&format!("--values {name}={}", v.trim())),
                    })?;
                let value = m.parameters.value(name).unwrap_or(f64::NAN);
                out.push((Some((name.to_string(), value)), m));
            }
            out
        }
    };
    let opts = SweepOptions {
        param: a.grid.param.clone(),
        values: values.clone(),
        mode: match a.mode {
            ModeArg::Independent => SweepMode::Independent,
            ModeArg::Up => SweepMode::Up,
            ModeArg::Down => SweepMode::Down,
            ModeArg::Both => SweepMode::Both,
        },
        responses: responses.clone(),
        refine: a.refine,
        steady: SteadyOptions {
            rtol: a.tol.rtol,
            atol: a.tol.atol,
            settle_tol: a.settle_tol,
            max_periods: a.max_periods,
            ..SteadyOptions::default()
        },
    };
    if !(a.settle_tol > 0.0 && a.settle_tol < 1.0) {
        return Err(Error::request(
            format!("--settle-tol {} is not valid", a.settle_tol),
            "give a fraction such as 1e-8",
        ));
    }
    // One compiled system per run.
    let systems: Vec<System> = family
        .iter()
        .map(|(_, m)| System::new(m))
        .collect::<Result<_>>()?;
    // Every run is checked before any is simulated: a bad --values entry fails at once.
    for ((value, _), m) in family.iter().zip(&systems) {
        detune::frequency::prepare(m, &opts).map_err(|e| match value {
            Some((name, v)) => e.context(&format!("--values {name}={v}")),
            None => e,
        })?;
    }
    let _ = ctrlc::set_handler(|| INTERRUPTED.store(true, std::sync::atomic::Ordering::SeqCst));
    let per_run = values.len()
        * if matches!(a.mode, ModeArg::Both) {
            2
        } else {
            1
        };
    let bar = indicatif::ProgressBar::new((per_run * family.len()) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "sweeping {bar:40} {pos}/{len} frequencies {elapsed} (eta {eta})",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let began = std::time::Instant::now();
    let mut sweeps = Vec::new();
    let mut offset = 0u64;
    for ((value, _), m) in family.iter().zip(&systems) {
        let b = bar.clone();
        let base = offset;
        let s = sweep(
            m,
            &opts,
            &move |done| {
                let pos = base + done as u64;
                if pos > b.length().unwrap_or(0) {
                    b.set_length(pos);
                }
                b.set_position(pos);
            },
            &INTERRUPTED,
        );
        let s = match s {
            Ok(s) => s,
            Err(e) => {
                bar.finish_and_clear();
                return Err(e);
            }
        };
        offset = bar.position();
        let complete = s.complete;
        sweeps.push((value.clone(), s));
        if !complete {
            break;
        }
    }
    bar.finish_and_clear();
    let runs: Vec<SweepRun> = sweeps
        .iter()
        .map(|(v, s)| SweepRun {
            value: v.as_ref().map(|(n, x)| (n.as_str(), *x)),
            sweep: s,
        })
        .collect();
    let complete = runs.iter().all(|r| r.sweep.complete);
    if let Some(o) = &a.output {
        write_sweep_csv(o, &runs)?;
        eprintln!("wrote {o}{}", if complete { "" } else { " (incomplete)" });
    }
    if let Some(p) = &a.plot {
        // The linear natural frequencies of every run (a static load in --values moves
        // them; an amplitude does not): one unlabelled set when every run has the same,
        // else each distinct one tagged with its run.
        let mut per_run: Vec<(Vec<f64>, String)> = Vec::new();
        for ((value, _), m) in family.iter().zip(&systems).take(runs.len()) {
            let index = m.require_param(&a.grid.param, "--param")?;
            let at = detune::linear::at_frequency(m, index, values[0])?;
            let Ok(ma) = modal_analysis(&at, None) else {
                continue;
            };
            let w: Vec<f64> = ma
                .undamped_omega2
                .iter()
                .filter(|w| **w > 0.0)
                .map(|w| w.sqrt())
                .collect();
            let tag = value
                .as_ref()
                .map(|(n, v)| format!(" ({n} = {v})"))
                .unwrap_or_default();
            per_run.push((w, tag));
        }
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-6 * x.abs().max(y.abs());
        let same = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| close(*x, *y))
        };
        let mut omega_n: Vec<(f64, String)> = Vec::new();
        if per_run.iter().all(|(w, _)| same(w, &per_run[0].0)) {
            if let Some((w, _)) = per_run.first() {
                omega_n = w.iter().map(|x| (*x, String::new())).collect();
            }
        } else {
            for (w, tag) in &per_run {
                for x in w {
                    if !omega_n.iter().any(|(y, _)| close(*x, *y)) {
                        omega_n.push((*x, tag.clone()));
                    }
                }
            }
        }
        detune::output::plot::write_panels(p, &sweep_plots(&runs, &omega_n))?;
        eprintln!("wrote {p}");
    }
    if a.json {
        print_json(&sweep_json(&runs, &Provenance::of(&model)));
    } else {
        let points: usize = runs.iter().map(|r| r.sweep.points.len()).sum();
        let periods: usize = runs
            .iter()
            .flat_map(|r| &r.sweep.points)
            .map(|p| p.steady.periods)
            .sum();
        let unsettled = runs
            .iter()
            .flat_map(|r| &r.sweep.points)
            .filter(|p| !p.steady.settled)
            .count();
        println!(
            "{points} frequencies in {:.2} s, {:.1} periods per frequency{}",
            began.elapsed().as_secs_f64(),
            periods as f64 / points.max(1) as f64,
            if unsettled > 0 {
                format!(", {unsettled} NOT settled (raise --max-periods)")
            } else {
                String::new()
            }
        );
        for run in &runs {
            let tag = run
                .value
                .map(|(n, v)| format!(" [{n} = {v}]"))
                .unwrap_or_default();
            for pk in &run.sweep.peaks {
                println!(
                    "peak{tag} {} ({}): {} = {:.6} ± {:.1e} rad/s, amplitude {:.6e}",
                    pk.response,
                    pk.direction.name(),
                    a.grid.param,
                    pk.omega,
                    pk.uncertainty,
                    pk.amplitude
                );
            }
            for h in &run.sweep.hysteresis {
                println!(
                    "hysteresis{tag}: up and down differ from {} to {} rad/s",
                    h.from, h.to
                );
            }
        }
    }
    if !complete {
        return Err(Error::numerical(
            "the sweep was interrupted",
            "the frequencies completed were written and marked incomplete",
        ));
    }
    Ok(())
}

/// Amplitude of the first response against frequency, one curve per --values entry and
/// direction; with --values, the same normalized by the value (the paper's Figures 8–9).
fn sweep_plots(
    runs: &[detune::output::results::SweepRun],
    omega_n: &[(f64, String)],
) -> Vec<LinePlot> {
    let first = runs[0].sweep;
    let name = &first.responses[0];
    let vertical: Vec<(f64, String)> = omega_n
        .iter()
        .map(|(w, tag)| (*w, format!("linear ω_n = {w:.4} rad/s{tag}")))
        .collect();
    let curves = |normalized: bool| -> Vec<Series> {
        let mut out = Vec::new();
        for run in runs {
            for dir in [
                detune::frequency::Direction::Independent,
                detune::frequency::Direction::Up,
                detune::frequency::Direction::Down,
            ] {
                let pts: Vec<_> = run
                    .sweep
                    .points
                    .iter()
                    .filter(|p| p.direction == dir)
                    .collect();
                if pts.is_empty() {
                    continue;
                }
                let scale = match (normalized, run.value) {
                    (true, Some((_, v))) if v != 0.0 => 1.0 / v.abs(),
                    (true, Some(_)) => continue, // nothing to normalize by
                    _ => 1.0,
                };
                let mut label = run
                    .value
                    .map(|(n, v)| format!("{n} = {v}"))
                    .unwrap_or_else(|| name.clone());
                if dir != detune::frequency::Direction::Independent {
                    label.push_str(&format!(" ({})", dir.name()));
                }
                out.push(Series {
                    label,
                    x: pts.iter().map(|p| p.steady.omega).collect(),
                    y: pts
                        .iter()
                        .map(|p| p.steady.measures[0].amplitude * scale)
                        .collect(),
                    style: if dir == detune::frequency::Direction::Down {
                        Style::Dashed
                    } else {
                        Style::Solid
                    },
                });
            }
        }
        out
    };
    let mut plots = vec![LinePlot {
        title: format!("{name}: stepped-sine amplitude"),
        x_label: format!("{} [rad/s]", first.param),
        y_label: format!("{name} amplitude [{}]", unit_of(name)),
        series: curves(false),
        vertical: vertical.clone(),
    }];
    if let Some((vname, _)) = runs[0].value {
        plots.push(LinePlot {
            title: format!("{name}: amplitude / {vname}"),
            x_label: format!("{} [rad/s]", first.param),
            y_label: format!("{name} amplitude / {vname}"),
            series: curves(true),
            vertical,
        });
    }
    plots
}
