//! `detune`: the command line: the commands (one file each under `src/cli/`), dispatch,
//! error rendering and the exit code. The work is the library's.

mod cli;

use clap::{Parser, Subcommand};
use cli::check::CheckArgs;
use cli::r#continue::ContinueArgs;
use cli::draw::DrawArgs;
use cli::equilibrium::EquilibriumArgs;
use cli::frf::FrfArgs;
use cli::kinematics::KinematicsArgs;
use cli::margins::MarginsArgs;
use cli::merge::MergeArgs;
use cli::modes::ModesArgs;
use cli::nfr::NfrArgs;
use cli::report::ReportArgs;
use cli::sensitivity::SensitivityArgs;
use cli::simulate::SimulateArgs;
use cli::sweep::SweepArgs;
use cli::tune::TuneArgs;
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
    /// initial pose, named, with their energy shares; with --param, tracked over a
    /// parameter's values.
    #[command(allow_negative_numbers = true)]
    Modes(ModesArgs),
    /// Linear frequency response about the equilibrium nearest the initial pose.
    #[command(allow_negative_numbers = true)]
    Frf(FrfArgs),
    /// Stepped-sine frequency response of the nonlinear model: steady states by time
    /// simulation, resonances located by refinement.
    #[command(allow_negative_numbers = true)]
    Sweep(SweepArgs),
    /// Nonlinear frequency response by continuation of periodic orbits: stable and
    /// unstable, with folds, period doublings, Neimark-Sacker points and peaks located.
    #[command(allow_negative_numbers = true)]
    Nfr(NfrArgs),
    /// Join the checkpoints of a sharded sweep (`sweep --shard K/N --checkpoint FILE`)
    /// into the CSV, JSON and plot one unsharded run writes, byte for byte.
    Merge(MergeArgs),
    /// The closure solved along a driven coordinate on the branch through the assembled
    /// pose, with transmission ratios d<drive>/d<NAME> from its tangent.
    #[command(allow_negative_numbers = true)]
    Kinematics(KinematicsArgs),
    /// Draw the assembled initial pose as SVG: front, side, top and isometric views
    /// (spatial models) or the X–Y plane (planar models), joints marked by type.
    #[command(allow_negative_numbers = true)]
    Draw(DrawArgs),
    /// How each mode moves with each varied parameter: cases, analytic derivatives (with
    /// finite-difference checks), the worst case over the tolerance box, a tornado chart.
    #[command(allow_negative_numbers = true)]
    Sensitivity(SensitivityArgs),
    /// Does every mode clear every forcing line of an environment (a helicopter's rotor
    /// harmonics) by the required margin? Exit 0 when it does, 3 when one does not.
    #[command(allow_negative_numbers = true)]
    Margins(MarginsArgs),
    /// The smallest change of the varied parameters that clears every forcing band of an
    /// environment by the margin, with alternatives. Exit 3 when none exists.
    #[command(allow_negative_numbers = true)]
    Tune(TuneArgs),
    /// The backbone curve of a mode: the amplitude-dependent natural frequency of the
    /// undamped, unforced mechanism (its family of free periodic orbits from the linear mode).
    #[command(allow_negative_numbers = true)]
    Backbone(cli::backbone::BackboneArgs),
    /// One self-contained HTML report for a design review (model, equilibrium, modes,
    /// linear response, interference diagram) and its JSON sidecar.
    #[command(allow_negative_numbers = true)]
    Report(ReportArgs),
}

fn main() {
    // `detune modes ... | head`: a closed pipe ends the process quietly, as it does for
    // other command-line tools, instead of making `println!` panic.
    #[cfg(unix)]
    // SAFETY: restoring the default action of a signal before any thread is started.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // A standard output that refuses the write (`> /dev/full`, a full disk): `println!`
    // panics with "failed printing to stdout"; said as an error (exit 1), with the
    // temporary files of outputs not yet committed removed, instead of a panic (101).
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if let Some(why) = msg.strip_prefix("failed printing to stdout: ") {
            detune::output::commit::remove_temps_now();
            // (stderr may refuse too: a panic inside this hook would abort)
            use std::io::Write;
            let _ = writeln!(
                std::io::stderr(),
                "error: cannot write to standard output: {why}\nhelp: free space on its disk, or redirect it elsewhere"
            );
            std::process::exit(1);
        }
        default_hook(info);
    }));
    let cli = Cli::parse();
    // SIGINT, SIGTERM, SIGHUP: a long command stops and keeps what it has; exit 130/143/129
    cli::handle_signals();
    // a command that checks something sets the exit code of its outcome (`cli::Outcome`)
    let mut exit_code = 0;
    let result = match cli.command {
        Command::Check(a) => cli::check::run(a),
        Command::Simulate(a) => cli::simulate::run(a),
        Command::Equilibrium(a) => cli::equilibrium::run(a),
        Command::Continue(a) => cli::r#continue::run(a),
        Command::Modes(a) => cli::modes::run(a),
        Command::Sensitivity(a) => cli::sensitivity::run(a),
        Command::Frf(a) => cli::frf::run(a),
        Command::Nfr(a) => cli::nfr::run(a),
        Command::Sweep(a) => cli::sweep::run(a),
        Command::Merge(a) => cli::merge::run(a),
        Command::Kinematics(a) => cli::kinematics::run(a),
        Command::Draw(a) => cli::draw::run(a),
        Command::Margins(a) => cli::margins::run(a).map(|o| exit_code = o.exit_code()),
        Command::Tune(a) => cli::tune::run(a).map(|o| exit_code = o.exit_code()),
        Command::Report(a) => cli::report::run(a),
        Command::Backbone(a) => cli::backbone::run(a),
    };
    // exit codes (README, docs/reliability.md): 0 success, 1 error, 2 usage (clap), 3 a
    // check failed, 128 + the signal (130 SIGINT, 143 SIGTERM, 129 SIGHUP) interrupted
    if let Err(e) = result {
        eprint!(
            "{}",
            e.render_with(std::io::stderr().is_terminal(), &cli::advice::Cli)
        );
        // (an error after the results were complete, a failed commit, is an error: 1)
        std::process::exit(cli::exit_code_of_error());
    }
    // a signal after the results were complete (cli::results_complete) ends nothing: 0
    let exit_code = cli::exit_code_after(exit_code);
    if exit_code != 0 {
        use std::io::Write;
        let _ = std::io::stdout().flush();
        std::process::exit(exit_code);
    }
}
