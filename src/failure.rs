//! Numerical failures as typed values that carry their numbers (times, residuals,
//! iteration counts). The library says what happened, in physics; what to do about it
//! with the command line's flags is the CLI's business (`cli::advice`), and
//! [`Failure::hint`] is the flag-free hint a library user gets.

/// An initial velocity given in the model: body `body`'s `velocity` (a coordinate's
/// name, or a free body's `vx` … `wz`) at `value` (SI: m/s or rad/s).
#[derive(Debug, Clone, PartialEq)]
pub struct GivenVelocity {
    pub body: String,
    pub velocity: String,
    pub value: f64,
}

fn given_velocity(given: &Option<GivenVelocity>) -> String {
    match given {
        Some(g) => format!(
            ": body `{}`'s given velocity {} = {} breaks it",
            g.body,
            g.velocity,
            crate::diag::num(g.value)
        ),
        None => String::new(),
    }
}

impl Failure {
    /// The same failure with its model time `t` (where it has one) moved later by `dt`:
    /// a run that started `dt` after the motion's own start (a sweep's steady state
    /// restarted after an extrapolation).
    pub fn later_by(mut self, dt: f64) -> Failure {
        match &mut self {
            Failure::StepLimit { t, .. }
            | Failure::Interrupted { t }
            | Failure::SimulationInterrupted { t }
            | Failure::NonFinite { t, .. }
            | Failure::SingularMass { t, .. }
            | Failure::StepSizeUnderflow { t, .. }
            | Failure::TooManySteps { t }
            | Failure::Stiff { t } => *t += dt,
            _ => {}
        }
        self
    }
}

/// A computation that could not be completed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Failure {
    #[error("the integration stopped at t = {} s after {steps} steps", crate::diag::fixed(*.t, 6))]
    StepLimit { t: f64, steps: usize },
    #[error("interrupted at t = {} s", crate::diag::fixed(*.t, 6))]
    Interrupted { t: f64 },
    #[error("the sweep was interrupted")]
    SweepInterrupted,
    /// A long computation other than a sweep or simulation (a continuation, a mode
    /// tracking, a linear frequency response) stopped by a signal; `kept`: its partial
    /// result is returned, marked incomplete.
    #[error("{what} was interrupted")]
    StudyInterrupted { what: String, kept: bool },
    /// A simulation stopped by a signal at model time `t` (s), its samples up to `t` kept.
    #[error("the simulation was interrupted at model time t = {} s", crate::diag::fixed(*.t, 6))]
    SimulationInterrupted { t: f64 },
    /// The right-hand side stays non-finite however small the step: at the accepted state
    /// at `t`, or just after it (the step size fell to `h`, s, trying to avoid it).
    #[error(
        "the equations of motion produced a non-finite value (NaN or infinity) at t = {} s (steps down to {h:.3e} s could not avoid it)",
        crate::diag::fixed(*.t, 6)
    )]
    NonFinite { t: f64, h: f64 },
    #[error(
        "the mass matrix of `{body}`'s angles became singular at t = {} s (reciprocal condition number {rcond:.3e}): its rotation sequence is at a singular pose (gimbal lock)",
        crate::diag::fixed(*.t, 6)
    )]
    SingularMass { t: f64, body: String, rcond: f64 },
    /// The step size fell below the integrator's floor (`h`, s; 0 when unknown).
    #[error("the step size fell to zero at t = {} s{}", crate::diag::fixed(*.t, 6), step_size(*.h))]
    StepSizeUnderflow { t: f64, h: f64 },
    /// A run of more forcing periods than the integrator may take steps (it resolves the
    /// forcing only with at least one step per period).
    #[error(
        "the forcing at {} rad/s turns {} times in the run of {} s, more than the {max_steps} steps the integrator may take: it needs at least one step per forcing period to resolve it",
        crate::diag::num(*.omega),
        crate::diag::num(*.periods),
        crate::diag::num(*.t_end)
    )]
    ForcingUnresolved {
        omega: f64,
        t_end: f64,
        periods: f64,
        max_steps: usize,
    },
    /// One forcing period (the shooting of a periodic orbit integrates whole periods)
    /// spans so many of the model's fastest time constants 1/|λ| that the explicit
    /// integrator, whose periods with variational equations step at h·|λ| ≤ 2 (to resolve
    /// the fastest mode's multipliers; stability alone asks ≲ 6), needs more than
    /// `max_steps` steps a period (`steps`, a lower bound).
    #[error(
        "one forcing period at {} rad/s (T = {} s) spans {} of the model's fastest time constant (|λ| = {} 1/s): the shooting's explicit integrator needs at least {} steps a period (h·|λ| ≤ 2), more than the {max_steps} it allows",
        crate::diag::num(*.omega),
        crate::diag::about(std::f64::consts::TAU / *.omega),
        crate::diag::about(std::f64::consts::TAU / *.omega * *.lambda),
        crate::diag::about(*.lambda),
        crate::diag::about(*.steps)
    )]
    PeriodUnresolved {
        omega: f64,
        lambda: f64,
        steps: f64,
        max_steps: usize,
    },
    #[error("too many steps at t = {} s", crate::diag::fixed(*.t, 6))]
    TooManySteps { t: f64 },
    #[error("the problem became stiff at t = {} s", crate::diag::fixed(*.t, 6))]
    Stiff { t: f64 },
    #[error("integration failed: {message}")]
    Integrator { message: String, bad_input: bool },
    #[error(
        "the initial pose cannot be assembled: the guess for `{coordinate}` is undefined (NaN) with these parameters"
    )]
    UndefinedGuess { coordinate: String },
    #[error(
        "the initial pose cannot be assembled: the constraint `{constraint}` is undefined ({}) at the pose reached after {iterations} iterations",
        crate::diag::num(*.value)
    )]
    UndefinedConstraint {
        constraint: String,
        value: f64,
        iterations: usize,
    },
    #[error(
        "the initial pose cannot be assembled: constraint residual {residual:.3e} after {iterations} iterations (worst: `{worst}`)"
    )]
    NoAssembly {
        residual: f64,
        iterations: usize,
        worst: String,
        /// The coordinates held during assembly and their values.
        fixed: Vec<(String, f64)>,
    },
    /// The velocities the model gives cannot all be kept: the velocity constraint
    /// `constraint` stays violated by `residual` (m/s or rad/s) however the others are
    /// chosen; `given`: the given velocity that contributes most to it (none when the
    /// model gives none: a moving ground the coordinates cannot follow).
    #[error(
        "the initial velocities are inconsistent with the constraints (residual {residual:.3e} in `{constraint}`){}",
        given_velocity(given)
    )]
    InconsistentVelocities {
        residual: f64,
        constraint: String,
        given: Option<GivenVelocity>,
    },
    #[error(
        "the constraints could not be kept: the largest constraint residual reached {residual:.3e}"
    )]
    ConstraintsNotKept { residual: f64 },
    #[error(
        "continuation stopped at {param} = {}: the corrector does not converge even with steps of {min_step:.3e} (the largest step {step:.3e} / 1e6)",
        crate::diag::num(*.value)
    )]
    ContinuationStalled {
        param: String,
        value: f64,
        step: f64,
        min_step: f64,
    },
    #[error(
        "continuation stopped at {param} = {}: the branch turns too sharply to follow",
        crate::diag::num(*.value)
    )]
    BranchTurns { param: String, value: f64 },
    #[error(
        "no equilibrium found: the initial pose is (next to) a singular pose of the constraints, where their Jacobian loses rank and the assembly is ambiguous"
    )]
    SingularStart,
    #[error(
        "no equilibrium found: residual {residual:.3e} after {iterations} iterations; last pose {pose}"
    )]
    NoEquilibrium {
        residual: f64,
        iterations: usize,
        pose: String,
        /// The residual is at the round-off of the equations' largest terms (1e-13 of
        /// them or less): no pose lowers it (a parameter far beyond physical size, such as
        /// a stiffness of 1e40 N/m against loads of newtons).
        round_off: bool,
    },
    #[error(
        "no equilibrium found: the equilibrium equations are undefined (NaN) after {iterations} iterations, at the pose {pose}"
    )]
    UndefinedEquilibrium { iterations: usize, pose: String },
    /// A computation whose inputs were finite produced an infinity (or the NaN of one):
    /// a term beyond the largest double (about 1.8e308). `what` names the equations
    /// ("equilibrium equations", "equations of motion"), `t` the time where known, `huge`
    /// the parameters beyond [`HUGE`] that caused it (largest first; may be empty).
    #[error(
        "the {what} overflow{}: {}",
        .t.map(|t| format!(" at t = {} s", crate::diag::fixed(t, 6))).unwrap_or_default(),
        overflow_cause(.huge)
    )]
    Overflow {
        what: String,
        t: Option<f64>,
        huge: Vec<(String, f64)>,
    },
    #[error("no equilibrium found on the assembly branch of the initial pose")]
    NoEquilibriumOnBranch,
    /// A continuation's start: Newton from the initial pose at p = `from` finds no
    /// equilibrium (its last iterate is not one, often not even assembled: not shown).
    #[error(
        "continuation cannot start at {param} = {}: no equilibrium near the initial pose ({why} after {iterations} Newton iterations; the last iterate is not an equilibrium)",
        crate::diag::num(*.value)
    )]
    NoStartEquilibrium {
        param: String,
        value: f64,
        why: String,
        iterations: usize,
        /// The residual is the equations' round-off (`NoEquilibrium::round_off`).
        round_off: bool,
    },
    /// A matrix handed to a decomposition (SVD, eigenvalues) holds a NaN or an infinity:
    /// `what` names the matrix, `row`, `col` (from 0) and `value` the first bad entry.
    #[error(
        "the {what} is not finite: its entry ({row}, {col}) is {value} (a parameter too large or too small for double precision)"
    )]
    NonFiniteMatrix {
        what: String,
        row: usize,
        col: usize,
        value: String,
    },
    /// A decomposition that did not converge within its iteration cap.
    #[error("the {what} did not converge in {iterations} iterations")]
    NoConvergence { what: String, iterations: usize },
    /// A result about to be reported holds a NaN or an infinity: `quantity` names the
    /// first one.
    #[error("the result is not finite: {quantity} = {}", crate::diag::num(*.value))]
    NonFiniteResult { quantity: String, value: f64 },
    #[error(
        "the trim does not converge: no value of {params} makes the held pose a static equilibrium (residual {residual:.3e})"
    )]
    TrimFailed { params: String, residual: f64 },
    #[error(
        "the linear system is singular at ω = {} rad/s (an undamped resonance: the response is unbounded)",
        crate::diag::num(*.omega)
    )]
    UndampedResonance { omega: f64 },
    /// A kinematic path ends where the closure, with the driven coordinate held, has no
    /// solution on the branch followed (a dead point: the other coordinates' Jacobian
    /// loses rank there): `value` is the last drive value reached, `target` the one that
    /// was not; `angle` whether the drive is an angle (then also shown in degrees).
    #[error(
        "the branch ends at {drive} = {}: the closure is singular there (a dead point, or branches cross), {} is not reached",
        drive_value(*.value, *.angle),
        drive_value(*.target, *.angle)
    )]
    DeadPoint {
        drive: String,
        value: f64,
        target: f64,
        angle: bool,
    },
    /// A named mode (`[[modes]]`) whose shape matches no computed mode at the baseline:
    /// its best mass-weighted MAC is below `threshold`; `macs` are its MACs with each
    /// computed mode, in frequency order.
    #[error(
        "the named mode `{name}` matches no mode of the model: its best MAC is {best:.3} (below {threshold}); MACs with the modes by frequency: {}",
        list_macs(.macs)
    )]
    ModeUnmatched {
        name: String,
        best: f64,
        threshold: f64,
        macs: Vec<f64>,
    },
    /// A named mode whose shape matches two computed modes (`modes`, 1 = the lowest)
    /// about equally well (`macs`): it does not tell them apart.
    #[error(
        "the named mode `{name}` matches modes {} and {} about equally (MAC {:.3} and {:.3}): its shape does not tell them apart",
        .modes[0], .modes[1], .macs[0], .macs[1]
    )]
    ModeAmbiguous {
        name: String,
        modes: [usize; 2],
        macs: [f64; 2],
    },
    /// Two named modes whose shapes both match best the same computed mode (`mode`, 1 =
    /// the lowest) at the baseline, with their MACs with it.
    #[error(
        "the named modes `{first}` (MAC {first_mac:.3}) and `{second}` (MAC {second_mac:.3}) both match mode {mode} best: one computed mode cannot carry two names"
    )]
    ModesShareMatch {
        first: String,
        second: String,
        mode: usize,
        first_mac: f64,
        second_mac: f64,
    },
}

/// A parameter's magnitude beyond which it is named as the cause of an overflow: the
/// product of two such values exceeds the largest double (about 1.8e308).
pub const HUGE: f64 = 1e150;

/// The parameters (`names`, `values`: a system's) whose magnitude is beyond [`HUGE`],
/// largest first, at most four: the likely cause of an overflow.
pub fn huge_parameters(names: &[String], values: &[f64]) -> Vec<(String, f64)> {
    let mut huge: Vec<(String, f64)> = names
        .iter()
        .zip(values)
        .filter(|(_, v)| v.abs() > HUGE && v.is_finite())
        .map(|(n, v)| (n.clone(), *v))
        .collect();
    huge.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
    huge.truncate(4);
    huge
}

fn overflow_cause(huge: &[(String, f64)]) -> String {
    let names: Vec<String> = huge
        .iter()
        .map(|(n, v)| format!("{n} = {}", crate::diag::num(*v)))
        .collect();
    match names.len() {
        0 => "a term exceeds the largest number a double holds (about 1.8e308)".into(),
        1 => format!(
            "{} is too large for double precision (a term exceeds about 1.8e308)",
            names[0]
        ),
        _ => format!(
            "{} are too large for double precision (a term exceeds about 1.8e308)",
            names.join(", ")
        ),
    }
}

/// The step size a step size failure reached, when known.
fn step_size(h: f64) -> String {
    if h > 0.0 {
        format!(" (h = {h:.3e} s)")
    } else {
        String::new()
    }
}

/// MACs as `1: 0.981, 2: 0.120`.
fn list_macs(macs: &[f64]) -> String {
    macs.iter()
        .enumerate()
        .map(|(k, m)| format!("{}: {m:.3}", k + 1))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A value of a driven coordinate in words: SI, and degrees for an angle.
fn drive_value(x: f64, angle: bool) -> String {
    if angle && x.to_degrees().is_finite() {
        format!(
            "{} rad ({}°)",
            crate::diag::fixed(x, 9),
            crate::diag::fixed(x.to_degrees(), 6)
        )
    } else if angle {
        format!("{} rad", crate::diag::fixed(x, 9))
    } else {
        format!("{} m", crate::diag::fixed(x, 9))
    }
}

/// The lowest forcing frequency (rad/s) whose period the shooting's explicit integrator,
/// held to h·|λ| ≤ 2 (`periodic::COLUMN_STEP_RESOLUTION`), crosses in `max_steps` steps:
/// 2π|λ| / (2 · max_steps).
pub fn period_floor(lambda: f64, max_steps: usize) -> f64 {
    std::f64::consts::TAU * lambda / (crate::periodic::COLUMN_STEP_RESOLUTION * max_steps as f64)
}

impl Failure {
    /// What the numbers suggest, without naming any command-line flag.
    pub fn hint(&self) -> String {
        use Failure::*;
        match self {
            StepLimit { .. } | TooManySteps { .. } => {
                "loosen the integration tolerances or shorten the run; a very small step points to a singular pose".into()
            }
            Interrupted { .. } => "the run was cancelled".into(),
            ForcingUnresolved { omega, max_steps, .. } => format!(
                "shorten the run to below {} s ({max_steps} forcing periods), or lower the forcing frequency to a physical value",
                crate::diag::num(*max_steps as f64 * std::f64::consts::TAU / omega)
            ),
            PeriodUnresolved { lambda, max_steps, .. } => format!(
                "start the curve above {} rad/s, or soften a very stiff element; far below the natural frequencies the response is quasi-static (continue equilibria in the forcing amplitude instead)",
                crate::diag::about(period_floor(*lambda, *max_steps))
            ),
            SweepInterrupted => "the sweep was interrupted".into(),
            StudyInterrupted { kept: true, .. } => "the part computed until then is kept, marked incomplete".into(),
            StudyInterrupted { kept: false, .. } => "the run was cancelled".into(),
            SimulationInterrupted { .. } => "the samples computed up to then are kept, marked incomplete".into(),
            NonFinite { .. } => "an expression in a force or constraint is undefined there (sqrt or ln of a negative number, division by zero), or the mechanism reached a singular pose".into(),
            SingularMass { .. } => "two axes of the body's rotation sequence line up there, so its angles cannot follow the motion: use another rotation sequence whose singular pose the motion does not reach, or `rotation = \"free\"` (a unit quaternion, which has none)".into(),
            StepSizeUnderflow { .. } => "the mechanism may be at a singular pose (a rank loss of the constraints) or the forces change abruptly; check the model, or loosen the integration tolerances".into(),
            Stiff { .. } => "a very stiff spring or damper makes an explicit integrator crawl; integrate with the implicit Radau IIA (`Integrator::Radau`), soften it, or shorten the run".into(),
            Integrator { bad_input: true, .. } => "check the run's length and tolerances".into(),
            Integrator { .. } => "check the model".into(),
            UndefinedGuess { .. } => "the mechanism probably cannot close in this configuration (a link too short to reach); check the parameters and the fixed coordinates, or give a guess that stays defined".into(),
            UndefinedConstraint { .. } => "check its expression: sqrt or ln of a negative number, or a division by zero, at the guessed pose".into(),
            NoAssembly { fixed, .. } => format!(
                "no pose satisfies the constraints with {}; check those values and the guesses of the other coordinates",
                if fixed.is_empty() {
                    "the guesses given".to_string()
                } else {
                    fixed
                        .iter()
                        .map(|(c, v)| format!("{c} = {}", crate::diag::num(*v)))
                        .collect::<Vec<_>>()
                        .join(", ")
                }
            ),
            InconsistentVelocities { given: Some(g), .. } => format!("give fewer initial velocities, or velocities the joints allow: remove `{}` from body `{}`'s `velocity` (a velocity not given is solved from the constraints), or change it to one they allow", g.velocity, g.body),
            InconsistentVelocities { given: None, .. } => "give fewer initial velocities, or velocities the joints allow; with none given, the moving ground drives the joints in a way the bodies' coordinates cannot follow (a body turning about one axis on a ground that turns about another): give the body the angles to follow it, or move the ground differently".into(),
            ConstraintsNotKept { .. } => "tighten the integration tolerances; if that does not help, the mechanism may pass a singular pose".into(),
            ContinuationStalled { .. } => "the branch may end here (a singular pose or no equilibrium), or the step is far too large for this model: try a smaller one".into(),
            BranchTurns { .. } => "the branch may end here (a singular pose); try a smaller step".into(),
            SingularStart => "start away from it: change the coordinate the model fixes for assembly".into(),
            NoEquilibrium { residual, round_off: true, .. } => format!("the residual {residual:.3e} is the round-off of the equilibrium equations (about 1e-16 of their largest term), which no pose lowers: a parameter is far beyond physical size; give the parameters physical values"),
            NoEquilibrium { .. } => "start closer to an equilibrium (another initial pose), or check that one exists for these loads".into(),
            UndefinedEquilibrium { .. } => "a load or a moving constraint is undefined there at some time of the forcing period (statics averages them over it): sqrt or ln of a negative number, or a division by zero".into(),
            TrimFailed { .. } => "check that the solved parameters can balance the held pose (a stiffness of zero, or a load the parameter does not act on, cannot be trimmed), or fix their values".into(),
            NoStartEquilibrium { round_off: true, .. } => "the residual is the round-off of the equilibrium equations (about 1e-16 of their largest term), which no pose lowers: a parameter (the range's start, or another) is far beyond physical size; give physical values".into(),
            NoStartEquilibrium { .. } => "start the range where the mechanism has an equilibrium near its initial pose (change the start value, the initial pose, or the loads); the branch is followed from there".into(),
            NonFiniteMatrix { .. } | NonFiniteResult { .. } => "a parameter is too large or too small for double precision (beyond about 1e150, a product of two such overflows): give it a physical value".into(),
            NoConvergence { .. } => "the matrix is badly scaled: parameters differing by many orders of magnitude; give them physical values".into(),
            NoEquilibriumOnBranch => "check the loads: the mechanism may have no static equilibrium (e.g. a force larger than any spring can hold)".into(),
            Overflow { huge, .. } if !huge.is_empty() => format!(
                "give {} a physical value: beyond about 1e150 the product of two such overflows",
                huge.iter().map(|(n, _)| format!("`{n}`")).collect::<Vec<_>>().join(", ")
            ),
            Overflow { .. } => "a parameter, load or coordinate is too large for double precision: give the parameters physical values".into(),
            UndampedResonance { .. } => "add damping or step around that frequency".into(),
            DeadPoint { drive, .. } => format!(
                "beyond it the mechanism locks, a link cannot reach, or the branch to follow is ambiguous: end the range before it, or drive another coordinate than `{drive}`"
            ),
            ModeUnmatched { .. } => "check the mode's shape in the model's [[modes]] (its coordinates' relative amplitudes, as `detune modes` lists them), or remove the name".into(),
            ModeAmbiguous { .. } => "give the shape the coordinates in which the two modes differ (a shape of one coordinate matches every mode that moves it)".into(),
            ModesShareMatch { .. } => "make the two shapes tell the modes apart (give the coordinates in which they differ), or name only one of them".into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn library_messages_and_hints_name_no_flag() {
        let all = [
            Failure::StepLimit { t: 1.0, steps: 10 },
            Failure::Interrupted { t: 1.0 },
            Failure::SweepInterrupted,
            Failure::StudyInterrupted {
                what: "the continuation".into(),
                kept: true,
            },
            Failure::SimulationInterrupted { t: 1.0 },
            Failure::NonFinite { t: 1.0, h: 1e-12 },
            Failure::StepSizeUnderflow { t: 1.0, h: 1e-15 },
            Failure::SingularMass {
                t: 1.0,
                body: "rod".into(),
                rcond: 1e-9,
            },
            Failure::TooManySteps { t: 1.0 },
            Failure::ForcingUnresolved {
                omega: 1e150,
                t_end: 1.0,
                periods: 1.6e149,
                max_steps: 10_000_000,
            },
            Failure::PeriodUnresolved {
                omega: 1e-4,
                lambda: 3.0,
                steps: 3.1e4,
                max_steps: 10_000,
            },
            Failure::Stiff { t: 1.0 },
            Failure::Integrator {
                message: "x".into(),
                bad_input: true,
            },
            Failure::UndefinedGuess {
                coordinate: "b.x".into(),
            },
            Failure::UndefinedConstraint {
                constraint: "c".into(),
                value: f64::NAN,
                iterations: 3,
            },
            Failure::NoAssembly {
                residual: 1e-3,
                iterations: 100,
                worst: "J.x".into(),
                fixed: vec![("bar1.theta".into(), 0.7)],
            },
            Failure::InconsistentVelocities {
                residual: 1.0,
                constraint: "pivot.y".into(),
                given: Some(GivenVelocity {
                    body: "bar".into(),
                    velocity: "y".into(),
                    value: 0.5,
                }),
            },
            Failure::ConstraintsNotKept { residual: 1e-3 },
            Failure::ContinuationStalled {
                param: "Fs".into(),
                value: 1.0,
                step: 0.5,
                min_step: 5e-7,
            },
            Failure::BranchTurns {
                param: "Fs".into(),
                value: 1.0,
            },
            Failure::SingularStart,
            Failure::NoEquilibrium {
                residual: 1.0,
                iterations: 50,
                pose: "b.x = 1".into(),
                round_off: false,
            },
            Failure::NoEquilibriumOnBranch,
            Failure::NoStartEquilibrium {
                param: "k".into(),
                value: 100.0,
                why: "residual 1.000e0".into(),
                iterations: 60,
                round_off: false,
            },
            Failure::TrimFailed {
                params: "L0".into(),
                residual: 1.0,
            },
            Failure::UndefinedEquilibrium {
                iterations: 0,
                pose: "b.x = 1".into(),
            },
            Failure::UndampedResonance { omega: 4.0 },
            Failure::Overflow {
                what: "equilibrium equations".into(),
                t: None,
                huge: vec![("Fs".into(), 1e308)],
            },
            Failure::Overflow {
                what: "equations of motion".into(),
                t: Some(0.0),
                huge: Vec::new(),
            },
            Failure::DeadPoint {
                drive: "bar1.theta".into(),
                value: 0.78,
                target: 0.8,
                angle: true,
            },
            Failure::ModeUnmatched {
                name: "in-phase".into(),
                best: 0.3,
                threshold: 0.5,
                macs: vec![0.3, 0.1],
            },
            Failure::ModeAmbiguous {
                name: "a".into(),
                modes: [1, 2],
                macs: [1.0, 0.95],
            },
            Failure::ModesShareMatch {
                first: "a".into(),
                second: "b".into(),
                mode: 1,
                first_mac: 0.9,
                second_mac: 0.8,
            },
        ];
        for f in &all {
            let (m, h) = (f.to_string(), f.hint());
            assert!(!m.contains("--") && !h.contains("--"), "{m} / {h}");
            assert!(!m.is_empty() && !h.is_empty());
        }
        // the numbers are carried, and shown
        let f = Failure::NoAssembly {
            residual: 1.5e-3,
            iterations: 100,
            worst: "J.x".into(),
            fixed: vec![("bar1.theta".into(), 0.7)],
        };
        assert!(f.to_string().contains("1.500e-3") && f.hint().contains("bar1.theta = 0.7"));
    }
}

#[cfg(test)]
mod later_tests {
    use super::Failure;

    /// A failure in a restarted run says its time from the motion's start.
    #[test]
    fn a_failure_moved_later_says_the_later_time() {
        let f = Failure::StepSizeUnderflow { t: 1.25, h: 3e-11 }.later_by(20.0);
        assert_eq!(f, Failure::StepSizeUnderflow { t: 21.25, h: 3e-11 });
        assert!(f.to_string().contains("at t = 21.250000 s"), "{f}");
        assert_eq!(
            Failure::NonFinite { t: 2.0, h: 1e-9 }.later_by(0.5),
            Failure::NonFinite { t: 2.5, h: 1e-9 }
        );
        // no time: unchanged
        assert_eq!(
            Failure::SweepInterrupted.later_by(3.0),
            Failure::SweepInterrupted
        );
    }
}
