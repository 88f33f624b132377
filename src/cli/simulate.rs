//! `detune simulate`: the motion from the model's initial state, as CSV (and an SVG plot
//! and a JSON summary).

use super::args::{ModelArgs, Tolerances};
use super::progress_bar;
use clap::Args;
use detune::diag::Result;
use detune::dynamics::assemble;
use detune::dynamics::simulate::{SimOptions, Trajectory, simulate_stoppable};
use detune::output::figures::{Case, trajectory_figures};
use detune::output::json::SimulationSummary;
use detune::output::plot::write_panels_sized;
use detune::output::units::{Units, WithUnits};
use detune::output::{
    Provenance, check_outputs, trajectory_header, trajectory_row, write_atomic, write_json,
};
use detune::system::outputs::Probe;

#[derive(Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// End time: s, or a quantity ("500 ms").
    #[arg(
        long,
        default_value = "20",
        value_name = "S",
        allow_hyphen_values = true
    )]
    pub t_end: String,
    /// Output interval: s, or a quantity ("1 ms").
    #[arg(
        long,
        default_value = "0.01",
        value_name = "S",
        allow_hyphen_values = true
    )]
    pub dt_out: String,
    #[command(flatten)]
    pub tol: Tolerances,
    /// Add velocity columns `<name>_dot`.
    #[arg(long)]
    pub velocities: bool,
    /// Add a column for a response (repeatable), after the coordinates (and velocities):
    /// a force element's `<name>.tension|elongation|rate` or `.torque|twist|twist_rate`, a
    /// named point's `<body>.<point>.x` (`y`, `z`, with `_rel`, `_dot`, `_ddot`), a joint's
    /// reaction `<joint>.force_x` (`force_y`, `force_z`), or a coordinate.
    #[arg(long, value_name = "NAME")]
    pub response: Vec<String>,
    /// Output CSV: `t,<body>.<coordinate>,...` in SI.
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    pub output: Option<String>,
    /// Figure (.svg or .png): the coordinates against time (angles and lengths in their
    /// own panels).
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<String>,
    /// Coordinate drawn on --plot (repeatable) [default: the angles, or every
    /// coordinate if there are none].
    #[arg(long, value_name = "NAME")]
    pub plot_coordinate: Vec<String>,
    #[command(flatten)]
    pub plot_size: super::args::PlotSize,
    /// Also write a JSON summary (provenance, statistics, final state).
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<String>,
}

pub fn run(a: SimulateArgs) -> Result<()> {
    let (model, sys) = a.model.load()?;
    if a.output.is_none() && a.plot.is_none() && a.json.is_none() {
        return Err(detune::diag::Error::request(
            "simulate: nothing to write",
            "give -o OUT.csv (the samples), --plot OUT.svg (a figure) or --json OUT.json (a summary)",
        ));
    }
    // an output on standard output (`--plot /dev/stdout`, `-o /dev/stdout`) is alone
    // there: the summary then goes to stderr, as `draw -o /dev/stdout` does
    let size = a
        .plot_size
        .check_streamed(a.plot.as_deref(), a.output.as_deref())?;
    let streamed: Vec<&str> = [a.output.as_deref(), a.plot.as_deref(), a.json.as_deref()]
        .into_iter()
        .flatten()
        .filter(|p| detune::output::commit::is_stdout(p))
        .collect();
    if streamed.len() > 1 {
        return Err(detune::diag::Error::request(
            format!(
                "{} {} name standard output: the outputs would run into each other",
                streamed.join(" and "),
                if streamed.len() == 2 { "both" } else { "all" }
            ),
            "send at most one output to standard output, the others to files",
        ));
    }
    let summary_to_stderr = !streamed.is_empty();
    macro_rules! say {
        ($($t:tt)*) => {
            if summary_to_stderr {
                eprintln!($($t)*)
            } else {
                println!($($t)*)
            }
        };
    }
    if !a.plot_coordinate.is_empty() && a.plot.is_none() {
        return Err(detune::diag::Error::request(
            "--plot-coordinate without --plot: there is no figure to draw it on",
            "add --plot OUT.svg (or .png)",
        ));
    }
    let picks: Vec<usize> = a
        .plot_coordinate
        .iter()
        .map(|n| detune::linear::coordinate(&sys, n, detune::request::Argument::PlotCoordinate))
        .collect::<Result<_>>()?;
    let outputs = check_outputs(
        &model.source.path,
        &[a.output.as_deref(), a.plot.as_deref(), a.json.as_deref()],
    )?;
    // a signal stops the run after the integrator's current step: the samples computed
    // are kept, marked incomplete (the CSV's last line, the JSON's `complete`)
    super::interrupt_on_ctrl_c();
    let mut probe = Probe::new(&sys, sys.outputs(&a.response)?);
    let mut values = vec![0.0; a.response.len()];
    let start = assemble(&sys)?;
    let opts = SimOptions {
        t_end: super::args::time_value("--t-end", &a.t_end)?,
        dt_out: super::args::time_value("--dt-out", &a.dt_out)?,
        rtol: a.tol.rtol,
        atol: a.tol.atol,
        integrator: a.tol.integrator(),
        ..SimOptions::default()
    };
    let bar = progress_bar(
        1000,
        "simulating {bar:40} {percent:>3}% {elapsed} (eta {eta})",
    );
    let began = std::time::Instant::now();
    // The CSV streams as the samples come (written to a temporary file, kept only if the
    // run succeeds): memory stays flat in the run's length. Kept in memory: the whole
    // trajectory only for a plot, else the last sample (the JSON's final state).
    let keep_all = a.plot.is_some();
    let mut traj = Trajectory::empty(&sys);
    let mut outcome = None;
    // the last forcing period's poses (all the samples when unforced: the last is used),
    // to classify the end state by its well
    let period = sys
        .forcing_frequency()
        .filter(|w| *w > 0.0)
        .map_or(0.0, |w| std::f64::consts::TAU / w);
    let mut tail: std::collections::VecDeque<(f64, Vec<f64>)> = Default::default();
    // a sample time as written in a message (12.34, not 12.340000000000002)
    let shown = |t: f64| detune::diag::num((t * 1e9).round() / 1e9);
    let interrupted = || super::INTERRUPTED.load(std::sync::atomic::Ordering::SeqCst);
    // the model time of the last sample written when a signal stopped the run
    let mut stopped_at: Option<f64> = None;
    // the model time reached when a signal stopped the run between two samples
    let mut reached: Option<f64> = None;
    let mut last_sample: Option<f64> = None;
    let mut fill = |w: &mut dyn std::io::Write| {
        let columns = a.velocities.then(|| sys.velocity_columns());
        trajectory_header(w, &sys.coordinates, columns.as_deref(), &a.response)?;
        let mut io_error = None;
        let run = simulate_stoppable(
            &sys,
            &start,
            &opts,
            &mut |t, q, v| {
                probe.eval(&sys, t, q, v, &mut values);
                if let Err(e) = trajectory_row(w, t, q, v, a.velocities, &values) {
                    io_error = Some(e);
                    return false;
                }
                if !keep_all {
                    traj.clear();
                }
                tail.push_back((t, q.to_vec()));
                while tail.front().is_some_and(|(t0, _)| *t0 < t - period - 1e-9) {
                    tail.pop_front();
                }
                traj.push(t, q, v);
                last_sample = Some(t);
                // a signal ends the run here, after this sample (the integrator returns
                // what it computed, cleanly)
                if interrupted() {
                    stopped_at = Some(t);
                    return false;
                }
                true
            },
            // a signal also ends the run after any integrator step, so that a run whose
            // steps are far shorter than --dt-out hears it at once: the samples written
            // so far are kept, and the stats say where it stopped
            &mut |f| {
                if began.elapsed().as_millis() > 300 {
                    bar.set_position((f * 1000.0) as u64);
                }
                !interrupted()
            },
            &mut |s| bar.suspend(|| eprintln!("{}", stiffness_warning(s, began.elapsed()))),
        );
        let failed = run.is_err();
        if let Ok(stats) = &run
            && stats.cancelled_at.is_some()
            && stopped_at.is_none()
        {
            // cancelled between samples: the last sample written is where the file ends;
            // the model time the run had reached is what the messages say
            stopped_at = last_sample.or(Some(0.0));
            reached = stats.cancelled_at;
        }
        outcome = Some(run);
        match io_error {
            Some(e) => Err(e),
            // no file is kept for a failed run
            None if failed => Err(std::io::Error::other("the simulation failed")),
            None => match (stopped_at, reached) {
                (Some(t), Some(r)) => writeln!(
                    w,
                    "# incomplete: interrupted at t = {} s; the rows above are the samples computed, up to t = {} s",
                    detune::output::num(r),
                    detune::output::num(t)
                ),
                (Some(t), None) => writeln!(
                    w,
                    "# incomplete: interrupted at t = {} s; the rows above are the samples computed",
                    detune::output::num(t)
                ),
                (None, _) => Ok(()),
            },
        }
    };
    let written = match &a.output {
        Some(o) => write_atomic(o, fill),
        None => fill(&mut std::io::sink()).map_err(|e| detune::diag::Error::io("(no -o)", e)),
    };
    bar.finish_and_clear();
    match outcome {
        Some(Err(e)) => return Err(e),
        Some(Ok(stats)) => traj.stats = stats,
        None => {}
    }
    written?;
    if stopped_at.is_none() {
        // every sample is computed and written: a signal from now on stops nothing
        super::results_complete();
    }
    if let Some(p) = &a.plot {
        let mut figures = trajectory_figures(&Case::of(&model), &traj, &picks);
        if let Some(t) = stopped_at {
            for figure in &mut figures {
                figure
                    .title
                    .push_str(&format!(" (incomplete: interrupted at t = {} s)", shown(t)));
            }
        }
        write_panels_sized(p, &figures, size)?;
    }
    let tail: Vec<(f64, Vec<f64>)> = tail.into_iter().collect();
    let end = detune::frequency::wells::end_well(&sys, &start.q, &tail);
    if let Some(j) = &a.json {
        let provenance = Provenance::of(&model);
        let mut summary =
            SimulationSummary::new(&provenance, &opts, &traj, a.output.as_deref().unwrap_or(""));
        summary.complete = stopped_at.is_none();
        if let Some((wells, well)) = &end {
            summary = summary.with_wells(wells, *well);
        }
        let units = Units::new()
            .with("t", "s")
            .coordinates(&sys)
            .velocities(&sys)
            .responses(&sys, &a.response)
            .with_all([
                ("t_end", "s"),
                ("dt_out", "s"),
                ("atol", "SI unit of each coordinate and velocity"),
                ("rtol", "1"),
                ("max_constraint_residual", "m or rad"),
                ("max_drift", "m or rad"),
                ("omega2", "rad^2/s^2"),
            ]);
        write_json(
            j,
            &WithUnits {
                doc: summary,
                units: &units,
            },
        )?;
    }
    outputs.commit()?;
    let st = &traj.stats;
    if let Some(t) = stopped_at {
        // the message (and the exit code 128 + the signal) come from main
        for f in a.output.iter().chain(&a.plot).chain(&a.json) {
            eprintln!("wrote {f} (incomplete: up to t = {} s)", shown(t));
        }
        return Err(detune::failure::Failure::SimulationInterrupted {
            t: reached.unwrap_or(t),
        }
        .into());
    }
    say!(
        "simulated {} s in {:.3} s: {} steps ({} rejected), {} right-hand sides, {} projections; largest constraint residual {:.2e} m or rad (drift before projection {:.2e} m or rad)",
        detune::diag::num(opts.t_end),
        began.elapsed().as_secs_f64(),
        st.accepted_steps,
        st.rejected_steps,
        st.rhs_evaluations,
        st.projections,
        st.max_constraint_residual,
        st.max_drift
    );
    if let Some((wells, well)) = &end {
        let what = if period > 0.0 {
            "the last forcing period oscillates about"
        } else {
            "the final pose is nearest to"
        };
        match usize::try_from(*well) {
            Ok(k) => {
                let pose: Vec<String> = sys
                    .coordinates
                    .iter()
                    .zip(&wells.equilibria[k].q)
                    .filter(|(c, _)| sys.coordinate_index(c).is_some_and(|i| sys.is_angle(i)))
                    .map(|(c, v)| format!("{c} = {v:.3} rad"))
                    .collect();
                say!(
                    "well {k} of {}: {what} the {} equilibrium ({}){}",
                    wells.equilibria.len(),
                    if wells.equilibria[k].stable {
                        "stable"
                    } else {
                        "UNSTABLE"
                    },
                    pose.join(", "),
                    if k == wells.start {
                        ", where it started"
                    } else {
                        ", not where it started"
                    }
                );
            }
            Err(_) => say!(
                "well -1: the last forcing period spans two wells (of {} equilibria)",
                wells.equilibria.len()
            ),
        }
    }
    if let Some(o) = &a.output {
        say!("wrote {o}");
    }
    if let Some(p) = &a.plot {
        say!("wrote {p}");
    }
    if let Some(j) = &a.json {
        say!("wrote {j}");
    }
    Ok(())
}

/// The warning for a run DOP853 found stiff, with its numbers and what to do.
pub fn stiffness_warning(
    s: &detune::dynamics::integrator::Stiffness,
    elapsed: std::time::Duration,
) -> String {
    stiffness_warning_in(s, Some(elapsed), "", "the run")
}

/// [`stiffness_warning`] of one integration of a longer command: `context` follows "the
/// model is stiff" (" at omega = 3 rad/s"), `run` names the integration ("this steady
/// state's integration").
pub fn stiffness_warning_in(
    s: &detune::dynamics::integrator::Stiffness,
    elapsed: Option<std::time::Duration>,
    context: &str,
    run: &str,
) -> String {
    let (held, help) = if s.stability_limited {
        (
            format!(
                "DOP853's stability holds its steps to about {:.2e} s (h·|λ| ≈ {:.1})",
                s.step, s.h_lambda
            ),
            "use --integrator radau (implicit Radau IIA: stable at any step, its steps follow the slow motion)",
        )
    } else {
        (
            format!(
                "DOP853's steps of about {:.2e} s (h·|λ| ≈ {:.2}) follow it at these tolerances",
                s.step, s.h_lambda
            ),
            "if that fast motion (a stiff spring or damper on a light body) does not matter at the scale of the run, loosen --rtol/--atol and use --integrator radau (implicit Radau IIA: it damps what its steps do not resolve); a lightly damped fast vibration larger than --atol must be followed by either method",
        )
    };
    format!(
        "warning: the model is stiff{context}: its fastest motion has |λ| ≈ {:.3e} 1/s (a time constant of {:.2e} s; {run} spans {:.2e} of them), and {held}: {run} will take about {:.2e} steps ({} so far, at t = {:.3e} s{})\nhelp: {help}",
        s.lambda,
        1.0 / s.lambda,
        s.stiffness_ratio,
        s.projected_steps,
        s.steps,
        s.t,
        elapsed
            .map(|e| format!(", after {:.3} s", e.as_secs_f64()))
            .unwrap_or_default(),
    )
}
