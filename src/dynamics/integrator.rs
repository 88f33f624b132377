//! The ODE integrators behind one small function: DOP853 (8th order, explicit, adaptive,
//! dense output) or Radau IIA (5th order, implicit, for stiff models). Radau IIA is the
//! crate `differential-equations` 0.7.0's; DOP853 is stepped by [`super::dop853`], the
//! same method written to the same operations as that crate's so every number is the
//! same, without its allocation per stage and per sample (see there why).
//!
//! [`integrate`] samples the solution at equally spaced output times from the dense
//! output, and after each accepted step hands the state to a hook that may change it
//! (drift projection); the integrator then restarts from the changed state with its
//! current step size. Anything that is an ODE `ẏ = F(t, y)` can be integrated this way:
//! the constrained dynamics, or a hand-written minimal-coordinate model in a benchmark.
//!
//! # Trial steps and non-finite values
//!
//! A right-hand side that is NaN or infinite inside a trial step (a stage far off the
//! solution, at a pose where a force or constraint is undefined) is never fatal by itself:
//! the step is rejected and retried smaller. DOP853 does so on its own (its error
//! estimate is then not finite and the step shrinks by its smallest factor, 0.2); a step
//! that the method would accept with such a stage anywhere in it (Radau's Newton
//! iteration does not notice NaN) is undone here and retried from its start with a
//! quarter of its size. Only a step size that falls below a floor (1e-14 of the run, or
//! the rounding of t) in this way is an error: [`Failure::NonFinite`] with the time and
//! the step size when non-finite values drove it there, [`Failure::StepSizeUnderflow`]
//! otherwise.
//!
//! # Stiffness
//!
//! DOP853's steps are checked as Hairer's DOP853 checks them (Hairer, Nørsett & Wanner,
//! *Solving ODEs I*, §IV.2 and the code's `IASTI` test): after an accepted step,
//! h·|λ| ≈ h·‖f(y₁) − f(ŷ)‖ / ‖y₁ − ŷ‖ with ŷ the last stage (also at t + h) estimates the
//! product of the step and the eigenvalue along the direction the step's error lives in.
//! DOP853's stability region reaches about h·|λ| = 6.1; 15 tests above it (without 6 below
//! it in between) mean that stability, not accuracy, limits the step: the model is stiff.
//! This is done here, at every accepted step, from the stages the method evaluated (no
//! extra right-hand side): the crate's own test runs every 100th step only, compares a
//! derivative with a state, and stops the run. The run goes on; [`Stiffness`] records the
//! numbers (|λ|, the step it forces, the steps the run will take) and is handed to the
//! caller as soon as it is known.
//!
//! A second check ([`StiffnessTest::monitor`]) reports a run projected past
//! [`MANY_STEPS`] whose steps resolve a fast motion the output does not: its fastest
//! eigenvalue (by finite differences) ties the steps (h·|λ| > 0.01) and turns by more
//! than half a cycle between two samples (|λ|·dt_out > π), a stiff element's vibration
//! followed at tight tolerances. A run that is merely long (the mechanism's own motion,
//! resolved by its samples) is not stiff.
//!
//! # Radau IIA
//!
//! `ImplicitRungeKutta::radau5` (Hairer & Wanner's RADAU5: three stages, order 5,
//! L-stable, simplified Newton with the Jacobian by forward differences, which the crate
//! does, collocation dense output). The crate scales the tolerances as RADAU5 does
//! (rtol' = 0.1·rtol^(2/3)), which makes the accuracy at a given `rtol` comparable with
//! DOP853's. After the hook changes the state the integration restarts with a new solver
//! (the crate has no way to set the state of one): the Jacobian is then recomputed.

use crate::diag::{Error, Result};
use crate::failure::Failure;
use differential_equations::interpolate::Interpolation;
use differential_equations::methods::{Ordinary, Radau};
use differential_equations::ode::{ODE, OrdinaryNumericalMethod};
use differential_equations::prelude::ImplicitRungeKutta;
use differential_equations::status::Status;
use differential_equations::traits::State;
use std::cell::{Cell, RefCell};

use super::dop853::Dop853;

/// The integration method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Integrator {
    /// Dormand–Prince 8(5,3), explicit: the fastest for models that are not stiff.
    #[default]
    Dop853,
    /// Radau IIA of order 5, implicit: stable at any step, for stiff models (a very stiff
    /// spring or damper on a light body).
    Radau,
}

impl Integrator {
    /// The name as the command line and the JSON spell it.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Dop853 => "dop853",
            Integrator::Radau => "radau",
        }
    }

    /// Whether this is the default (DOP853).
    pub fn is_default(&self) -> bool {
        *self == Integrator::Dop853
    }
}

impl std::fmt::Display for Integrator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Settings of one integration.
#[derive(Debug, Clone)]
pub struct IntegratorOptions {
    /// Start and end time, s.
    pub t0: f64,
    pub t_end: f64,
    /// Output interval, s: samples at t0, t0 + dt_out, ..., and t_end.
    pub dt_out: f64,
    pub rtol: f64,
    pub atol: f64,
    /// Give up after this many steps (accepted + rejected).
    pub max_steps: usize,
    /// The method.
    pub method: Integrator,
    /// DOP853 only: the dense output (the samples) by the method on the first this many
    /// components only, the rest interpolated linearly between the step's ends; see
    /// `Dop853::dense_prefix` for what the ODE must then do. None: all.
    pub dense_prefix: Option<usize>,
    /// DOP853 only: the largest step, in the time's unit (∞: none).
    pub max_step: f64,
}

/// A run found stiff: DOP853's steps are held by the model's fastest motion, either by
/// its stability bound (Hairer's test: `stability_limited`), or because the tolerances
/// make it resolve a fast motion (a stiff element's vibration) over a run long against it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Stiffness {
    /// When the test concluded, s.
    pub t: f64,
    /// The fastest eigenvalue's magnitude, |λ| in 1/s: the spectral radius of the
    /// right-hand side's Jacobian (by finite differences) at `t`, or where that fails,
    /// Hairer's estimate along the steps.
    pub lambda: f64,
    /// The mean accepted step, s, over the tests (or since the start).
    pub step: f64,
    /// `step` × `lambda`: about 6 when stability holds the steps.
    pub h_lambda: f64,
    /// Hairer's test concluded (the steps sit on DOP853's stability bound); otherwise the
    /// run was found to take more than [`MANY_STEPS`] steps, each a fraction of the
    /// fastest motion's time constant.
    pub stability_limited: bool,
    /// Steps taken so far (accepted + rejected).
    pub steps: usize,
    /// Steps the whole run will take at the present rate (accepted + rejected).
    pub projected_steps: f64,
    /// |λ| × the run's length: how many of the fastest time constants the run spans (the
    /// stiffness ratio against the run's own time scale).
    pub stiffness_ratio: f64,
}

/// Counters of one integration.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct IntegratorStats {
    pub accepted_steps: usize,
    pub rejected_steps: usize,
    pub rhs_evaluations: usize,
    /// Restarts after the hook changed the state.
    pub restarts: usize,
    /// The sample sink ended the run before its end time.
    #[serde(skip)]
    pub stopped: bool,
    /// [`integrate_stoppable`] only: `progress` cancelled the run at the end of the step
    /// reaching this time, s (also `stopped`). [`integrate_with`] fails as interrupted there.
    #[serde(skip)]
    pub cancelled_at: Option<f64>,
    /// Set when DOP853 found the run stiff (see the module docs).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stiffness: Option<Stiffness>,
}

/// Counts evaluations, notes non-finite derivatives (per step), and keeps the stages
/// DOP853's stiffness test reads.
struct Guarded<'a, F> {
    ode: &'a F,
    evals: Cell<usize>,
    /// A non-finite derivative since the last `begin_step`.
    non_finite: Cell<bool>,
    /// Record the stages of a DOP853 step (calls counted from `begin_step`).
    record: Cell<bool>,
    calls: Cell<usize>,
    /// (y, f) of the last stage (call 11 of a step, at t + h), and f(y₁) (call 12, made
    /// only when the step is accepted).
    last_stage: RefCell<(Vec<f64>, Vec<f64>)>,
    f_new: RefCell<Vec<f64>>,
}

/// The DOP853 step's call (from 1) that evaluates its last stage (c = 1), and the one
/// that evaluates f at the accepted end (the first same as last).
const DOP853_LAST_STAGE: usize = 11;
const DOP853_END: usize = 12;

impl<'a, F> Guarded<'a, F> {
    fn new(ode: &'a F) -> Self {
        Guarded {
            ode,
            evals: Cell::new(0),
            non_finite: Cell::new(false),
            record: Cell::new(false),
            calls: Cell::new(0),
            last_stage: RefCell::new((Vec::new(), Vec::new())),
            f_new: RefCell::new(Vec::new()),
        }
    }

    fn begin_step(&self, record: bool) {
        self.non_finite.set(false);
        self.calls.set(0);
        self.record.set(record);
    }
}

impl<F: ODE<f64, Vec<f64>>, Y: Slice> ODE<f64, Y> for Guarded<'_, F> {
    fn diff(&self, t: f64, y: &Y, dydt: &mut Y) {
        let (y, dydt) = (y.vec(), dydt.vec_mut());
        self.ode.diff(t, y, dydt);
        self.evals.set(self.evals.get() + 1);
        if dydt.iter().any(|x| !x.is_finite()) {
            self.non_finite.set(true);
        }
        if self.record.get() {
            let c = self.calls.get() + 1;
            self.calls.set(c);
            if c == DOP853_LAST_STAGE {
                let mut s = self.last_stage.borrow_mut();
                s.0.clone_from(y);
                s.1.clone_from(dydt);
            } else if c == DOP853_END {
                self.f_new.borrow_mut().clone_from(dydt);
            }
        }
    }

    /// The wrapped right-hand side's Jacobian (Radau's Newton matrix): its own where it
    /// has one (the shooting's variational equations give theirs by blocks), else the
    /// crate's forward differences, which are 1 + dim evaluations, counted as such.
    fn jacobian(&self, t: f64, y: &Y, j: &mut differential_equations::linalg::Matrix<f64>) {
        self.ode.jacobian(t, y.vec(), j);
        self.evals.set(self.evals.get() + 1 + y.len());
        if j.data.iter().any(|x| !x.is_finite()) {
            self.non_finite.set(true);
        }
    }
}

/// A state vector the integrators share: `Vec<f64>` for DOP853, [`RState`] for Radau.
trait Slice: State<f64> {
    fn vec(&self) -> &Vec<f64>;
    fn vec_mut(&mut self) -> &mut Vec<f64>;
    fn of(v: Vec<f64>) -> Self;
}

impl Slice for Vec<f64> {
    fn vec(&self) -> &Vec<f64> {
        self
    }
    fn vec_mut(&mut self) -> &mut Vec<f64> {
        self
    }
    fn of(v: Vec<f64>) -> Self {
        v
    }
}

/// The state as Radau sees it: a `Vec<f64>` whose `State::zeros()` has the run's
/// dimension. differential-equations 0.7.0's Radau5 starts its Newton iteration and its
/// error scale from `Y::zeros()`, which for `Vec<f64>` is empty (it fails on the first
/// step); this type reads the dimension from the thread's running integration
/// ([`RadauDim`]) instead.
#[derive(Debug, Clone)]
struct RState(Vec<f64>);

thread_local! {
    /// The dimension of the Radau integration running on this thread.
    static RADAU_DIM: Cell<usize> = const { Cell::new(0) };
}

/// Sets [`RADAU_DIM`] for one integration, and restores it after.
struct RadauDim(usize);

impl RadauDim {
    fn set(n: usize) -> RadauDim {
        RadauDim(RADAU_DIM.with(|d| d.replace(n)))
    }
}

impl Drop for RadauDim {
    fn drop(&mut self) {
        RADAU_DIM.with(|d| d.set(self.0));
    }
}

impl Slice for RState {
    fn vec(&self) -> &Vec<f64> {
        &self.0
    }
    fn vec_mut(&mut self) -> &mut Vec<f64> {
        &mut self.0
    }
    fn of(v: Vec<f64>) -> Self {
        RState(v)
    }
}

impl State<f64> for RState {
    fn len(&self) -> usize {
        self.0.len()
    }
    fn get_component(&self, index: usize) -> f64 {
        self.0[index]
    }
    fn set_component(&mut self, index: usize, value: f64) {
        self.0[index] = value;
    }
    fn map_components_mut<G>(&mut self, f: G)
    where
        G: FnMut(usize, &mut f64),
    {
        self.0.map_components_mut(f)
    }
    fn zeros_like(&self) -> Self {
        RState(vec![0.0; self.0.len()])
    }
    fn zeros() -> Self {
        RState(vec![0.0; RADAU_DIM.with(Cell::get)])
    }
    fn mul_add_assign(&mut self, alpha: f64, other: &Self) {
        self.0.mul_add_assign(alpha, &other.0)
    }
    fn scale_mut(&mut self, alpha: f64) {
        self.0.scale_mut(alpha)
    }
}

/// Hairer's stiffness test, run after every accepted DOP853 step.
struct StiffnessTest {
    /// Positive tests in the current streak, and negative ones since the last positive.
    positive: usize,
    negative: usize,
    /// At the streak's start: time, steps (accepted + rejected), accepted steps.
    from: (f64, usize, usize),
    /// Sum of |λ| over the streak.
    lambda_sum: f64,
    declared: bool,
}

/// DOP853's stability bound on h·|λ| (Hairer's 6.1), and the positive tests in a row that
/// declare a run stiff.
const STABILITY_BOUND: f64 = 6.1;
const STIFF_TESTS: usize = 15;

/// A run projected to take more steps than this, whose steps are each more than
/// [`FAST_FRACTION`] of the fastest time constant 1/|λ|, and whose samples do not resolve
/// that motion (|λ|·dt_out above [`UNRESOLVED`]), is reported as held by its fastest
/// motion. The projection is made after 1000, 2000, 4000, ... accepted steps.
pub const MANY_STEPS: f64 = 1e5;
const FAST_FRACTION: f64 = 0.01;
/// |λ|·dt_out above π: the fastest motion turns by more than half a cycle between two
/// output samples (above their Nyquist rate), so the samples cannot show it and it is not
/// what the run is for. Below it the fastest motion is the one asked for, and a long run
/// simply takes many steps: `simulate models/overcentre.toml --set F0=3 --set omega=2
/// --t-end 100000 --dt-out 0.1` (|λ| ≈ 1.8 1/s, the mechanism's own mode, |λ|·dt_out ≈
/// 0.18) was called stiff for its length alone (1.3e6 steps) before this condition.
const UNRESOLVED: f64 = std::f64::consts::PI;
const FIRST_LOOK: usize = 1000;

impl StiffnessTest {
    fn new() -> Self {
        StiffnessTest {
            positive: 0,
            negative: 0,
            from: (0.0, 0, 0),
            lambda_sum: 0.0,
            declared: false,
        }
    }

    /// One accepted step [t0, t1] ending in y1; `stats` counted it already. Returns the
    /// verdict when this test concludes the run is stiff (once).
    fn check<F>(
        &mut self,
        guarded: &Guarded<'_, F>,
        (t0, t1): (f64, f64),
        y1: &[f64],
        stats: &IntegratorStats,
        opts: &IntegratorOptions,
    ) -> Option<Stiffness> {
        if self.declared || guarded.calls.get() < DOP853_END {
            return None;
        }
        let (ys, fs) = &*guarded.last_stage.borrow();
        let f1 = &*guarded.f_new.borrow();
        if ys.len() != y1.len() || f1.len() != y1.len() {
            return None;
        }
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..y1.len() {
            num += (f1[i] - fs[i]).powi(2);
            den += (y1[i] - ys[i]).powi(2);
        }
        let h = t1 - t0;
        if !(den > 0.0) || !num.is_finite() || !(h > 0.0) {
            return None;
        }
        let lambda = (num / den).sqrt();
        let steps = stats.accepted_steps + stats.rejected_steps;
        if h * lambda > STABILITY_BOUND {
            if self.positive == 0 {
                self.from = (t0, steps - 1, stats.accepted_steps - 1);
                self.lambda_sum = 0.0;
            }
            self.negative = 0;
            self.positive += 1;
            self.lambda_sum += lambda;
            if self.positive == STIFF_TESTS {
                self.declared = true;
                let (tw, sw, aw) = self.from;
                let rate = (t1 - tw) / (steps - sw) as f64;
                let lambda = self.lambda_sum / self.positive as f64;
                let step = (t1 - tw) / (stats.accepted_steps - aw) as f64;
                return Some(Stiffness {
                    t: t1,
                    lambda,
                    step,
                    h_lambda: step * lambda,
                    stability_limited: true,
                    steps,
                    projected_steps: steps as f64 + (opts.t_end - t1) / rate,
                    stiffness_ratio: lambda * (opts.t_end - opts.t0),
                });
            }
        } else {
            self.negative += 1;
            if self.negative == 6 {
                self.positive = 0;
            }
        }
        None
    }
}

impl StiffnessTest {
    /// After 1000, 2000, 4000, ... accepted steps: a run projected to take more than
    /// [`MANY_STEPS`] whose steps are tied to its fastest motion (h·ρ(J) above
    /// [`FAST_FRACTION`]) while its samples do not resolve that motion (ρ(J)·dt_out
    /// above [`UNRESOLVED`]). The Jacobian is formed by finite differences of the model's own
    /// right-hand side (not counted in the stats).
    fn monitor<F: ODE<f64, Vec<f64>>>(
        &mut self,
        ode: &F,
        t1: f64,
        y1: &[f64],
        stats: &IntegratorStats,
        opts: &IntegratorOptions,
    ) -> Option<Stiffness> {
        let a = stats.accepted_steps;
        if self.declared
            || a < FIRST_LOOK
            || !(a / FIRST_LOOK).is_power_of_two()
            || a % FIRST_LOOK != 0
        {
            return None;
        }
        let (t0, span) = (opts.t0, opts.t_end - opts.t0);
        let steps = stats.accepted_steps + stats.rejected_steps;
        let done = t1 - t0;
        if !(done > 0.0) {
            return None;
        }
        let projected = steps as f64 * span / done;
        if !(projected > MANY_STEPS) {
            return None;
        }
        let lambda = spectral_radius(ode, t1, y1)?;
        let step = done / a as f64;
        if !(step * lambda > FAST_FRACTION) || !(lambda * opts.dt_out > UNRESOLVED) {
            return None;
        }
        self.declared = true;
        Some(Stiffness {
            t: t1,
            lambda,
            step,
            h_lambda: step * lambda,
            stability_limited: false,
            steps,
            projected_steps: projected,
            stiffness_ratio: lambda * span,
        })
    }
}

/// The spectral radius of ∂f/∂y at (t, y): the Jacobian by forward differences (steps
/// √ε·max(|y_j|, 1), as the crates' own default), its eigenvalues by a Schur decomposition
/// with an iteration cap. `None` when anything is not finite or it does not converge.
fn spectral_radius<F: ODE<f64, Vec<f64>>>(ode: &F, t: f64, y: &[f64]) -> Option<f64> {
    let n = y.len();
    let mut f0 = vec![0.0; n];
    ode.diff(t, &y.to_vec(), &mut f0);
    let mut jac = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut yp = y.to_vec();
    let mut fp = vec![0.0; n];
    for j in 0..n {
        let d = f64::EPSILON.sqrt() * y[j].abs().max(1.0);
        yp[j] = y[j] + d;
        ode.diff(t, &yp, &mut fp);
        yp[j] = y[j];
        for i in 0..n {
            jac[(i, j)] = (fp[i] - f0[i]) / d;
        }
    }
    if jac.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let schur = nalgebra::linalg::Schur::try_new(jac, f64::EPSILON, 10_000)?;
    let rho = schur
        .complex_eigenvalues()
        .iter()
        .map(|z| z.norm())
        .fold(0.0, f64::max);
    (rho.is_finite() && rho > 0.0).then_some(rho)
}

/// Integrate `ode` from `y0` at `opts.t0` to `opts.t_end`.
///
/// * `sample(t, y)` receives every output sample in order; it returns `false` to end the
///   run there, cleanly (the stats then say `stopped`).
/// * `after_step(t, y)` runs after each accepted step that is not the last; it returns
///   `true` if it changed `y` (the integrator then restarts from it).
/// * `progress(fraction)` after each accepted step; it returns `false` to stop the
///   integration there (a cancelled run: the call fails with an "interrupted" error).
pub fn integrate<F: ODE<f64, Vec<f64>>>(
    ode: &F,
    y0: &[f64],
    opts: &IntegratorOptions,
    sample: &mut dyn FnMut(f64, &[f64]) -> bool,
    after_step: &mut dyn FnMut(f64, &mut Vec<f64>) -> bool,
    progress: &mut dyn FnMut(f64) -> bool,
) -> Result<IntegratorStats> {
    integrate_with(ode, y0, opts, sample, after_step, progress, &mut |_| {})
}

/// [`integrate`], and `stiff` hears at once when DOP853 finds the run stiff (the run goes
/// on; the stats keep the same numbers).
pub fn integrate_with<F: ODE<f64, Vec<f64>>>(
    ode: &F,
    y0: &[f64],
    opts: &IntegratorOptions,
    sample: &mut dyn FnMut(f64, &[f64]) -> bool,
    after_step: &mut dyn FnMut(f64, &mut Vec<f64>) -> bool,
    progress: &mut dyn FnMut(f64) -> bool,
    stiff: &mut dyn FnMut(&Stiffness),
) -> Result<IntegratorStats> {
    let stats = integrate_stoppable(ode, y0, opts, sample, after_step, progress, stiff)?;
    match stats.cancelled_at {
        Some(t) => Err(Failure::Interrupted { t }.into()),
        None => Ok(stats),
    }
}

/// [`integrate_with`], where a cancel by `progress` (checked after every accepted step)
/// ends the run cleanly, as the sample sink's stop does: the stats say `stopped` and
/// `cancelled_at` (the model time reached), and keep their counts. A front end that
/// writes its samples as they come keeps them, marked incomplete, with the run's numbers.
pub fn integrate_stoppable<F: ODE<f64, Vec<f64>>>(
    ode: &F,
    y0: &[f64],
    opts: &IntegratorOptions,
    sample: &mut dyn FnMut(f64, &[f64]) -> bool,
    after_step: &mut dyn FnMut(f64, &mut Vec<f64>) -> bool,
    progress: &mut dyn FnMut(f64) -> bool,
    stiff: &mut dyn FnMut(&Stiffness),
) -> Result<IntegratorStats> {
    let mut stats = IntegratorStats::default();
    if !sample(opts.t0, y0) {
        stats.stopped = true;
        return Ok(stats);
    }
    if opts.t_end - opts.t0 <= 0.0 {
        return Ok(stats);
    }
    let guarded = Guarded::new(ode);
    let run = Run {
        opts,
        sample,
        after_step,
        progress,
        stiff,
    };
    match opts.method {
        Integrator::Dop853 => {
            let mut solver = Dop853::new(opts.rtol, opts.atol);
            if let Some(m) = opts.dense_prefix {
                solver.dense_prefix(m);
            }
            solver.max_step(opts.max_step);
            let dense = |s: &mut Dop853, t: f64, out: &mut Vec<f64>| {
                s.dense_into(t, out);
                Ok(())
            };
            run.drive(&guarded, y0, solver, true, &|s, h| s.h0 = h, &dense, stats)
        }
        Integrator::Radau => {
            let _dim = RadauDim::set(y0.len());
            let make = |h0: f64| {
                // per-component tolerances: the crate rescales them in place once per
                // component, which compounds on a scalar (to rtol' = 1e-3 whatever asked)
                ImplicitRungeKutta::<Ordinary, Radau, f64, RState, 5, 3, 3>::radau5()
                    .rtol(vec![opts.rtol; y0.len()])
                    .atol(vec![opts.atol; y0.len()])
                    .h0(h0)
                    .max_steps(usize::MAX)
            };
            run.drive(
                &guarded,
                y0,
                make(0.0),
                false,
                &|s, h| *s = make(h),
                &interpolate_into,
                stats,
            )
        }
    }
}

/// One integration's settings and callbacks.
struct Run<'c> {
    opts: &'c IntegratorOptions,
    sample: &'c mut dyn FnMut(f64, &[f64]) -> bool,
    after_step: &'c mut dyn FnMut(f64, &mut Vec<f64>) -> bool,
    progress: &'c mut dyn FnMut(f64) -> bool,
    stiff: &'c mut dyn FnMut(&Stiffness),
}

impl Run<'_> {
    /// The step loop for either method. `set_h0` prepares a restart with a given initial
    /// step: DOP853 re-initializes the same solver, as the default path always has (its
    /// step sequence is pinned by the reference tests); Radau gets a new solver. `dop`:
    /// DOP853's dense output correction and the stiffness test.
    ///
    /// Radau starts every step with a new solver (Jacobian and decompositions at the
    /// step's start and size): differential-equations 0.7.0's Radau5 keeps the LU
    /// decompositions of I·γ/h − J made for the previous step size after a rejected step,
    /// and after an accepted one that changes h while reusing the Jacobian (RADAU5
    /// recomputes them there), so its Newton iteration then diverges at any step size
    /// (seen on the overcentre with k = 1e10: h halved to 1e-15 at t = 7 ms).
    fn drive<F, Y, S>(
        self,
        guarded: &Guarded<'_, F>,
        y0: &[f64],
        mut solver: S,
        dop: bool,
        set_h0: &dyn Fn(&mut S, f64),
        dense: &dyn Fn(&mut S, f64, &mut Vec<f64>) -> Result<()>,
        mut stats: IntegratorStats,
    ) -> Result<IntegratorStats>
    where
        F: ODE<f64, Vec<f64>>,
        Y: Slice,
        S: OrdinaryNumericalMethod<f64, Y> + Interpolation<f64, Y>,
    {
        let Run {
            opts,
            sample,
            after_step,
            progress,
            stiff,
        } = self;
        let (t0, t_end) = (opts.t0, opts.t_end);
        let span = t_end - t0;
        let n_out = (span / opts.dt_out + 1e-9).floor() as usize;
        // The last sample is t_end itself when the span is not a multiple of dt_out.
        let last_k = if t0 + n_out as f64 * opts.dt_out < t_end - 1e-12 * t_end.abs().max(1.0) {
            n_out + 1
        } else {
            n_out
        };
        let out_time = |k: usize| (t0 + k as f64 * opts.dt_out).min(t_end);
        // the smallest step that is not a step size collapse
        let floor = |t: f64| (1e-14 * span).max(8.0 * f64::EPSILON * t.abs());
        // restart from (t, y) with initial step h
        let restart = |solver: &mut S, t: f64, y: &Y, h: f64| {
            guarded.begin_step(false);
            set_h0(solver, h);
            solver.init(guarded, t, t_end, y)
        };
        solver
            .init(guarded, t0, t_end, &Y::of(y0.to_vec()))
            .map_err(integration_error)?;
        let mut test = StiffnessTest::new();
        // one interpolated sample
        let mut yk = Vec::with_capacity(y0.len());
        let mut next_k = 1;
        let mut y = y0.to_vec();
        // Radau: a new solver before each step (see `drive`'s docs)
        let mut renew = false;
        while next_k <= last_k {
            if renew && solver.t() < t_end {
                let (t, y) = (solver.t(), solver.y().clone());
                let h = solver.h().min(t_end - t);
                restart(&mut solver, t, &y, h).map_err(integration_error)?;
                if guarded.non_finite.get() {
                    return Err(Failure::NonFinite { t, h }.into());
                }
            }
            let t = solver.t();
            if t + solver.h() > t_end {
                solver.set_h(t_end - t);
            }
            if stats.accepted_steps + stats.rejected_steps >= opts.max_steps {
                return Err(Failure::StepLimit {
                    t,
                    steps: opts.max_steps,
                }
                .into());
            }
            let h_tried = solver.h();
            guarded.begin_step(dop);
            let r = solver.step(guarded);
            guarded.record.set(false);
            let rejected = matches!(solver.status(), Status::RejectedStep);
            if guarded.non_finite.get() {
                // a non-finite derivative inside the step: the step is rejected, never
                // the run (unless the step size collapses doing so)
                stats.rejected_steps += 1;
                renew = !dop;
                let (tp, h) = if r.is_err() || !rejected {
                    // the method failed on it, or took the step anyway: undo it
                    let (tp, yp) = if r.is_ok() {
                        (solver.t_prev(), solver.y_prev().clone())
                    } else {
                        (t, solver.y().clone())
                    };
                    let h = 0.25 * h_tried;
                    if h >= floor(tp) {
                        restart(&mut solver, tp, &yp, h).map_err(integration_error)?;
                        stats.restarts += 1;
                        if guarded.non_finite.get() {
                            // at the start of the step, which was accepted
                            return Err(Failure::NonFinite { t: tp, h }.into());
                        }
                    }
                    (tp, h)
                } else {
                    (t, solver.h())
                };
                if !(h >= floor(tp)) {
                    return Err(Failure::NonFinite { t: tp, h }.into());
                }
                continue;
            }
            r.map_err(integration_error)?;
            renew = !dop;
            if rejected {
                stats.rejected_steps += 1;
                if !(solver.h() >= floor(t)) {
                    return Err(Failure::StepSizeUnderflow { t, h: solver.h() }.into());
                }
                continue;
            }
            stats.accepted_steps += 1;
            let t_new = solver.t();
            if solver.y().vec().iter().any(|x| !x.is_finite()) {
                return Err(Failure::NonFinite {
                    t: t_new,
                    h: t_new - solver.t_prev(),
                }
                .into());
            }
            if dop
                && let Some(s) = test.check(
                    guarded,
                    (solver.t_prev(), t_new),
                    solver.y().vec(),
                    &stats,
                    opts,
                )
            {
                // the fastest eigenvalue itself, where it can be had
                let mut s = s;
                if let Some(rho) = spectral_radius(guarded.ode, t_new, solver.y().vec()) {
                    s.lambda = rho;
                    s.h_lambda = s.step * rho;
                    s.stiffness_ratio = rho * span;
                }
                stiff(&s);
                stats.stiffness = Some(s);
            }
            if dop && let Some(s) = test.monitor(guarded.ode, t_new, solver.y().vec(), &stats, opts)
            {
                stiff(&s);
                stats.stiffness = Some(s);
            }
            // Dense output at the requested times inside this step.
            while next_k <= last_k && out_time(next_k) <= t_new {
                let tk = out_time(next_k);
                let go_on = if tk == t_new {
                    sample(tk, solver.y().vec())
                } else {
                    dense(&mut solver, tk, &mut yk)?;
                    sample(tk, &yk)
                };
                next_k += 1;
                if !go_on {
                    stats.stopped = true;
                    stats.rhs_evaluations = guarded.evals.get();
                    return Ok(stats);
                }
            }
            if !progress((t_new - t0) / span) {
                stats.stopped = true;
                stats.cancelled_at = Some(t_new);
                stats.rhs_evaluations = guarded.evals.get();
                return Ok(stats);
            }
            if next_k > last_k {
                break;
            }
            y.copy_from_slice(solver.y().vec());
            if after_step(t_new, &mut y) {
                stats.restarts += 1;
                let h0 = solver.h().min(t_end - t_new);
                if h0 <= 0.0 {
                    break;
                }
                restart(&mut solver, t_new, &Y::of(y.clone()), h0).map_err(integration_error)?;
                renew = false;
                if guarded.non_finite.get() {
                    return Err(Failure::NonFinite { t: t_new, h: h0 }.into());
                }
            }
        }
        stats.rhs_evaluations = guarded.evals.get();
        Ok(stats)
    }
}

/// The method's own dense output at `t` inside the last step, into `out` (Radau IIA's
/// collocation polynomial).
fn interpolate_into<Y: Slice, S: Interpolation<f64, Y>>(
    solver: &mut S,
    t: f64,
    out: &mut Vec<f64>,
) -> Result<()> {
    let yk = solver.interpolate(t).map_err(integration_error)?;
    out.clone_from(yk.vec());
    Ok(())
}

fn integration_error<Y: State<f64>>(e: differential_equations::error::Error<f64, Y>) -> Error {
    use differential_equations::error::Error as E;
    match e {
        E::StepSize { t, .. } => Failure::StepSizeUnderflow { t, h: 0.0 }.into(),
        E::MaxSteps { t, .. } => Failure::TooManySteps { t }.into(),
        E::Stiffness { t, .. } => Failure::Stiff { t }.into(),
        // the initial step estimate is zero when the accelerations at the start are
        // enormous (a stiffness near 1e308), not because of the run's length
        E::BadInput { msg } if msg.contains("Initial step size") => {
            Failure::StepSizeUnderflow { t: 0.0, h: 0.0 }.into()
        }
        E::BadInput { msg } => Failure::Integrator {
            message: msg,
            bad_input: true,
        }
        .into(),
        other => Failure::Integrator {
            message: format!("{other:?}"),
            bad_input: false,
        }
        .into(),
    }
}
