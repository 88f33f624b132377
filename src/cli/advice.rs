//! The library's typed errors in this command line's terms. A failure carries its
//! numbers and a flag-free hint ([`detune::failure::Failure::hint`]); here the hint names
//! the flag that changes the outcome. An invalid request names the library's argument
//! ([`detune::request::Argument`]); here it names the flag that gave it.

use detune::diag::{Advice, Wording};
use detune::failure::Failure;
use detune::request::{Argument, Invalid};

/// The command line's wording of the library's errors (`Error::render_with`).
pub struct Cli;

impl Advice for Cli {
    fn failure(&self, failure: &Failure) -> Option<String> {
        advice(failure)
    }
    fn failure_in(&self, failure: &Failure, context: &[String]) -> Option<String> {
        vary_advice(failure, context).or_else(|| advice(failure))
    }
    fn invalid(&self, invalid: &Invalid) -> Option<Wording> {
        wording(invalid)
    }
    /// A family's runs are the `--values` entries.
    fn run(&self, param: &str, value: &str) -> Option<String> {
        Some(format!("--values {param}={value}"))
    }
}

/// The help line for a failure, where the command line has better advice than the
/// library's hint.
pub fn advice(f: &Failure) -> Option<String> {
    use Failure::*;
    Some(match f {
        StepLimit { .. } => {
            "loosen --rtol/--atol or shorten the run; a very small step points to a singular pose".into()
        }
        StepSizeUnderflow { .. } => "the mechanism may be at a singular pose (a rank loss of the constraints) or the forces change abruptly; check the model, or loosen --rtol/--atol".into(),
        TooManySteps { .. } => "loosen --rtol/--atol or shorten the run; for a stiff model (a very stiff spring or damper on a light body) use --integrator radau".into(),
        ForcingUnresolved { omega, max_steps, .. } => format!(
            "shorten --t-end to below {} s ({max_steps} forcing periods), or --set the forcing frequency to a physical value",
            detune::diag::num(*max_steps as f64 * std::f64::consts::TAU / omega)
        ),
        PeriodUnresolved { lambda, max_steps, .. } => {
            let floor = detune::failure::period_floor(*lambda, *max_steps);
            format!(
                "use --integrator radau (implicit: stable at any step), or soften the element that sets the model's fastest motion ({2} 1/s); with the explicit dop853 the forcing frequency must be above {0} rad/s ({1} Hz) here: with --param omega start --from above it, else --set the forcing frequency above it; far below the natural frequencies the response is quasi-static: `detune continue --param <forcing amplitude>` computes it as equilibria",
                detune::diag::about(floor),
                detune::diag::about(floor / std::f64::consts::TAU),
                detune::diag::about(*lambda)
            )
        }
        Stiff { .. } => "a very stiff spring or damper makes the explicit DOP853 crawl: use --integrator radau (implicit, stable at any step), or soften it".into(),
        Integrator { bad_input: true, .. } => "check --t-end, --rtol and --atol".into(),
        ConstraintsNotKept { .. } => "tighten --rtol/--atol (the defaults are 1e-10 and 1e-12); if that does not help, the mechanism may pass a singular pose".into(),
        ContinuationStalled { .. } => "the branch may end here (a singular pose or no equilibrium), or --step is far too large for this model (the default is the range / 50): try a smaller --step".into(),
        SweepInterrupted => "the frequencies completed were written and marked incomplete".into(),
        StudyInterrupted { kept: true, .. } => "the part computed until then was written (a CSV ends with a line `# incomplete: ...`, the JSON says \"complete\": false; exit 130 SIGINT, 143 SIGTERM, 129 SIGHUP)".into(),
        StudyInterrupted { kept: false, .. } => "the run was cancelled; nothing was written (exit 130 SIGINT, 143 SIGTERM, 129 SIGHUP)".into(),
        Interrupted { .. } => "the run was cancelled; nothing was written (exit 130 SIGINT, 143 SIGTERM, 129 SIGHUP)".into(),
        SimulationInterrupted { .. } => "the samples computed up to then were written, the CSV ending with a line `# incomplete: ...` and the JSON summary saying \"complete\": false (exit 130 SIGINT, 143 SIGTERM, 129 SIGHUP)".into(),
        BranchTurns { .. } => "the branch may end here (a singular pose); try a smaller --step".into(),
        SingularStart => "start away from it: --set the initial value of the coordinate the model fixes for assembly to another value".into(),
        NoStartEquilibrium { round_off: true, .. } => "the residual is the round-off of the equilibrium equations (about 1e-16 of their largest term), which no pose lowers: a parameter (--from, or one given by --set) is far beyond physical size; give physical values".into(),
        NoStartEquilibrium { .. } => "start --from where the mechanism has an equilibrium near its initial pose, or --set the initial angle or the loads; the branch is followed from there".into(),
        // the equations' round-off, not a pose too far off
        NoEquilibrium { residual, round_off: true, .. } => format!("the residual {residual:.3e} is the round-off of the equilibrium equations (about 1e-16 of their largest term), which no pose lowers: a parameter is far beyond physical size (--set it to a physical value)"),
        NoEquilibrium { .. } => "start closer to an equilibrium (e.g. --set the initial angle), or check that one exists for these loads".into(),
        DeadPoint { .. } => "beyond it the mechanism locks, a link cannot reach, or the branch to follow is ambiguous: end --from/--to before it, or drive another coordinate (--drive)".into(),
        _ => return None,
    })
}

/// A pose that cannot be assembled at a case of a `--vary` (the context `NAME: the case
/// LABEL`, as the sensitivity study, `margins --vary`, `tune` and `report` say it): the
/// range takes the linkage past where it closes. Narrow that flag's range.
pub fn vary_advice(f: &Failure, context: &[String]) -> Option<String> {
    use Failure::*;
    let no_equilibrium = matches!(f, NoEquilibrium { .. });
    let no_trim = matches!(f, TrimFailed { .. });
    if !no_equilibrium
        && !no_trim
        && !matches!(
            f,
            NoAssembly { .. } | UndefinedGuess { .. } | UndefinedConstraint { .. }
        )
    {
        return None;
    }
    let name = context
        .iter()
        .find_map(|c| c.split_once(": the case ").map(|(n, _)| n.trim()))?;
    // the report's tuning ranges are its --tune-vary, not its --vary (the tolerances)
    let flag = if context.iter().any(|c| c == detune::report::studies::TUNING) {
        "--tune-vary"
    } else {
        "--vary"
    };
    if no_trim {
        // the baseline trims: the change takes the held pose out of the trim's reach
        let (which, range) = if name.contains(' ') {
            (
                "at that corner of the tolerance box".to_string(),
                format!("the {flag} ranges"),
            )
        } else {
            (
                format!("at that value of `{name}`"),
                format!("the range of {flag} {name} (e.g. {flag} {name}=80%..120%, or ±10%)"),
            )
        };
        return Some(format!(
            "{which} no value of the trimmed parameters holds the datum pose in equilibrium, though the baseline's does (each case starts from the baseline's pose, on its branch of the linkage): narrow {range}"
        ));
    }
    if no_equilibrium {
        // each case starts from the baseline's equilibrium: none near it means the
        // change takes the mechanism past a fold (another initial pose is no remedy)
        let which = if name.contains(' ') {
            "at that corner of the tolerance box".to_string()
        } else {
            format!("at that value of `{name}`")
        };
        let range = if name.contains(' ') {
            format!("the {flag} ranges")
        } else {
            format!("the range of {flag} {name} (e.g. {flag} {name}=80%..120%, or ±10%)")
        };
        let continued = if name.contains(' ') { "NAME" } else { name };
        return Some(format!(
            "{which} the equilibrium the baseline starts from no longer exists (the change takes the mechanism past a fold): narrow {range}; `detune continue --param {continued}` shows where it ends"
        ));
    }
    if name.contains(' ') {
        // a corner of the tolerance box (`the tolerance box's corner: the case a=1, b=2`)
        return Some(format!(
            "at that corner of the tolerance box the linkage no longer closes: narrow the {flag} ranges (e.g. NAME=80%..120%, or ±10%), or check the values with --set and `detune check`"
        ));
    }
    Some(format!(
        "at that value of `{name}` the linkage no longer closes: narrow the range of {flag} {name} (e.g. {flag} {name}=80%..120%, or ±10%), or check the value with --set and `detune check`"
    ))
}

/// The flag that gives an argument, if one does.
fn flag(argument: Argument) -> Option<&'static str> {
    use Argument::*;
    Some(match argument {
        FrequencyParameter | ContinuationParameter => "--param",
        TrackedParameter => "--param",
        TrackedStep => "--step",
        TrackedPoints => "--points",
        Response => "--response",
        Normalize => "--normalize",
        PlotCoordinate => "--plot-coordinate",
        FrequencyStep | ArclengthStep => "--step",
        MaxSteps => "--max-steps",
        Refine => "--refine",
        MaxPeriods => "--max-periods",
        SettleTol => "--settle-tol",
        Duration => "--t-end",
        OutputInterval => "--dt-out",
        RelativeTolerance => "--rtol",
        AbsoluteTolerance => "--atol",
        Drive => "--drive",
        Ratio => "--ratio",
        DriveStep => "--step",
        Varied => "--vary",
        Margin => "--margin",
        Frequencies | ContinuationRange | FixedPeriods | DriveRange => return None,
        TrackedValues => return None,
    })
}

/// An invalid request's message and help, naming the flags; `None` where the library's
/// wording names no argument a flag gives.
pub fn wording(invalid: &Invalid) -> Option<Wording> {
    use Invalid::*;
    let said = |message: String, help: &str| {
        Some(Wording {
            message,
            help: help.to_string(),
        })
    };
    let hint = invalid.hint();
    match invalid {
        UnknownParameter { argument, name, .. } => said(
            format!(
                "{} {name}: the model has no parameter `{name}`",
                flag(*argument)?
            ),
            &hint,
        ),
        UnknownCoordinate { argument, name, .. } => said(
            format!(
                "{} {name}: the model has no coordinate `{name}`",
                flag(*argument)?
            ),
            &hint,
        ),
        UnknownResponse { argument, name, .. } => said(
            format!(
                "{} {name}: the model has no response `{name}`",
                flag(*argument)?
            ),
            &hint,
        ),
        NotForcingFrequency {
            name,
            forcing,
            definition: Some(d),
        } => said(
            format!(
                "--param {name}: the forcing frequency `{forcing}` is defined from it ({forcing} = {d}); a frequency response steps the forcing frequency itself"
            ),
            &format!(
                "follow {name} with `detune nfr MODEL --param {name}` (the periodic orbits, with {forcing} following), or step --param {forcing} at a fixed {name} without defining {forcing} from it"
            ),
        ),
        NotForcingFrequency { name, forcing, .. } => said(
            format!(
                "--param {name}: the forcing of this model does not depend on `{name}`; it turns at `{forcing}`"
            ),
            &format!("use --param {forcing}"),
        ),
        BadFrequencies { param, .. } => said(
            format!("--param {param}: the frequencies must be positive and finite (rad/s)"),
            "give --from > 0",
        ),
        Range {
            what: Argument::DriveRange,
            from,
            to,
        } => said(
            format!("--from {from} --to {to}: not finite"),
            "give finite values, e.g. --from \"-15 deg\" --to \"35 deg\"",
        ),
        Range { from, to, .. } if !(from.is_finite() && to.is_finite()) => said(
            format!("--from {from} --to {to}: not finite"),
            "give finite numbers for --from and --to",
        ),
        Range { what, from, to } => said(
            format!("empty range: --from {from} --to {to}"),
            match what {
                Argument::Frequencies => {
                    "give --from below --to (or equal to it for one frequency)"
                }
                _ => &hint,
            },
        ),
        NotPositive { argument, value }
        | Negative { argument, value }
        | NotFraction { argument, value } => said(not_valid(*argument, *value)?, &hint),
        Zero { argument } => said(
            match argument {
                Argument::MaxPeriods => "--max-periods 0: no period would be simulated".into(),
                _ => format!("{} 0 computes nothing", flag(*argument)?),
            },
            &hint,
        ),
        TooManyPoints {
            argument,
            value,
            points,
            limit,
        } => match argument {
            Argument::OutputInterval => said(
                not_valid(*argument, *value)?,
                "that is more than 50 million samples; use a larger --dt-out",
            ),
            Argument::Duration => said(
                format!(
                    "--t-end {} s gives more than 50 million samples at this --dt-out",
                    detune::diag::num(*value)
                ),
                "shorten --t-end, or use a larger --dt-out",
            ),
            Argument::ArclengthStep => said(
                format!(
                    "--step {} needs at least {} steps to cross the range, more than --max-steps {limit}",
                    detune::diag::num(*value),
                    detune::diag::num(points.ceil())
                ),
                &format!(
                    "give --step of at least {} (the range / --max-steps), or raise --max-steps",
                    detune::diag::num(*value * *points / *limit as f64)
                ),
            ),
            Argument::MaxPeriods | Argument::FixedPeriods => said(
                format!(
                    "{} {} gives about {} samples, more than {limit} ({} a period)",
                    flag(*argument)?,
                    detune::diag::num(*value),
                    detune::diag::num(*points),
                    detune::diag::num(*points / *value)
                ),
                &format!(
                    "give {} up to {}",
                    flag(*argument)?,
                    limit / (*points / *value).max(1.0) as usize
                ),
            ),
            _ => said(
                format!(
                    "{} {} gives about {} points, more than {limit}",
                    flag(*argument)?,
                    detune::diag::num(*value),
                    detune::diag::about(*points)
                ),
                &hint,
            ),
        },
        StepTooSmall {
            argument,
            step,
            scale,
        } => said(
            format!(
                "{} {step:e} cannot move a value of size {scale:e} in double precision (below 1e-12 of it)",
                flag(*argument)?
            ),
            &format!("give {} above {:e}", flag(*argument)?, 1e-12 * scale),
        ),
        RefineTooCoarse { refine, step } => said(
            format!(
                "--refine {refine} is not finer than a peak's bracket (2 × the step {step}): nothing would be refined"
            ),
            "give --refine below --step (e.g. --step / 100), or leave it out",
        ),
        NotDriven { name, drive } => said(
            format!(
                "--ratio {name}: `{name}` does not move with --drive {drive} (no constraint couples them)"
            ),
            &hint,
        ),
        FixedDrive { drive } => said(
            format!("--drive {drive}: `{drive}` is fixed by the constraints at the assembled pose"),
            &hint,
        ),
        FamilySyntax { spec } => said(
            format!("--values {spec}: expected PARAM=v1,v2,..."),
            "for example --values F0=0.1,1,2,3,4",
        ),
        FamilyUnnamed { spec } => said(
            format!("--values {spec}: no parameter named before `=`"),
            "for example --values F0=0.1,1,2,3,4",
        ),
        FamilyVariesSwept { spec, name } => said(
            format!("--values {spec}: `{name}` is the swept parameter (--param)"),
            "give --values a different parameter, e.g. the forcing amplitude F0",
        ),
        FamilyEmptyEntry { spec } => said(
            format!("--values {spec}: an empty entry"),
            "separate the values by single commas: --values F0=0.1,1,2",
        ),
        NoForcingFrequency | DerivedForcingFrequency { .. } => None,
    }
}

/// `--step 0 is not valid`; `simulate`'s options say `--t-end = -1 is not valid`.
fn not_valid(argument: Argument, value: f64) -> Option<String> {
    let flag = flag(argument)?;
    Some(match argument {
        Argument::Duration
        | Argument::OutputInterval
        | Argument::RelativeTolerance
        | Argument::AbsoluteTolerance => {
            format!("{flag} = {} is not valid", detune::diag::num(value))
        }
        _ => format!("{flag} {} is not valid", detune::diag::num(value)),
    })
}
