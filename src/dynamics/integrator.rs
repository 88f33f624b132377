//! The ODE integrator behind one small function: DOP853 (8th order, adaptive, dense
//! output) from the crate `differential-equations` 0.7.0, driven step by step.
//!
//! [`integrate`] samples the solution at equally spaced output times from the dense
//! output, and after each accepted step hands the state to a hook that may change it
//! (drift projection); the integrator then restarts from the changed state with its
//! current step size. Anything that is an ODE `ẏ = F(t, y)` can be integrated this way:
//! the constrained dynamics, or a hand-written minimal-coordinate model in a benchmark.

use crate::diag::{Error, Result};
use crate::failure::Failure;
use differential_equations::interpolate::Interpolation;
use differential_equations::ode::{ODE, OrdinaryNumericalMethod};
use differential_equations::prelude::ExplicitRungeKutta;
use differential_equations::status::Status;
use std::cell::Cell;

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
}

/// Counts evaluations and catches the first non-finite derivative.
struct Guarded<'a, F> {
    ode: &'a F,
    evals: Cell<usize>,
    non_finite: Cell<Option<f64>>,
}

impl<F: ODE<f64, Vec<f64>>> ODE<f64, Vec<f64>> for Guarded<'_, F> {
    fn diff(&self, t: f64, y: &Vec<f64>, dydt: &mut Vec<f64>) {
        self.ode.diff(t, y, dydt);
        self.evals.set(self.evals.get() + 1);
        if self.non_finite.get().is_none() && dydt.iter().any(|x| !x.is_finite()) {
            self.non_finite.set(Some(t));
        }
    }
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
    let (t0, t_end) = (opts.t0, opts.t_end);
    let span = t_end - t0;
    let mut stats = IntegratorStats::default();
    let n_out = (span / opts.dt_out + 1e-9).floor() as usize;
    // The last sample is t_end itself when the span is not a multiple of dt_out.
    let last_k = if t0 + n_out as f64 * opts.dt_out < t_end - 1e-12 * t_end.abs().max(1.0) {
        n_out + 1
    } else {
        n_out
    };
    let out_time = |k: usize| (t0 + k as f64 * opts.dt_out).min(t_end);
    if !sample(t0, y0) {
        stats.stopped = true;
        return Ok(stats);
    }
    if span <= 0.0 {
        return Ok(stats);
    }
    let guarded = Guarded {
        ode,
        evals: Cell::new(0),
        non_finite: Cell::new(None),
    };
    let mut solver = ExplicitRungeKutta::dop853()
        .rtol(opts.rtol)
        .atol(opts.atol)
        .max_steps(usize::MAX);
    solver
        .init(&guarded, t0, t_end, &y0.to_vec())
        .map_err(integration_error)?;
    // ẏ at the end of the previous step, for the dense-output correction.
    let mut deriv_cache: Option<(f64, Vec<f64>)> = None;
    let mut next_k = 1;
    let mut y = y0.to_vec();
    while next_k <= last_k {
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
        let r = solver.step(&guarded);
        if let Some(tb) = guarded.non_finite.get() {
            return Err(non_finite_error(tb));
        }
        r.map_err(integration_error)?;
        if let Status::RejectedStep = solver.status() {
            stats.rejected_steps += 1;
            continue;
        }
        stats.accepted_steps += 1;
        let t_new = solver.t();
        // Dense output at the requested times inside this step.
        let mut ends: Option<(Vec<f64>, Vec<f64>)> = None;
        while next_k <= last_k && out_time(next_k) <= t_new {
            let tk = out_time(next_k);
            let go_on = if tk == t_new {
                sample(tk, solver.y())
            } else {
                if ends.is_none() {
                    let t_prev = solver.t_prev();
                    let f0 = match deriv_cache.take() {
                        Some((tc, f)) if tc == t_prev => f,
                        _ => derivative(&guarded, t_prev, solver.y_prev()),
                    };
                    ends = Some((f0, derivative(&guarded, t_new, solver.y())));
                }
                let (f0, f1) = ends.as_ref().expect("set above");
                let yk = dense_output(&mut solver, tk, f0, f1).map_err(integration_error)?;
                sample(tk, &yk)
            };
            next_k += 1;
            if !go_on {
                stats.stopped = true;
                stats.rhs_evaluations = guarded.evals.get();
                return Ok(stats);
            }
        }
        if let Some((_, f1)) = ends {
            deriv_cache = Some((t_new, f1));
        }
        if !progress((t_new - t0) / span) {
            return Err(Failure::Interrupted { t: t_new }.into());
        }
        if next_k > last_k {
            break;
        }
        y.copy_from_slice(solver.y());
        if after_step(t_new, &mut y) {
            stats.restarts += 1;
            deriv_cache = None;
            solver.h0 = solver.h().min(t_end - t_new);
            if solver.h0 <= 0.0 {
                break;
            }
            solver
                .init(&guarded, t_new, t_end, &y)
                .map_err(integration_error)?;
            if let Some(tb) = guarded.non_finite.get() {
                return Err(non_finite_error(tb));
            }
        }
    }
    stats.rhs_evaluations = guarded.evals.get();
    Ok(stats)
}

/// ẏ at (t, y): one right-hand side.
fn derivative<F: ODE<f64, Vec<f64>>>(ode: &F, t: f64, y: &Vec<f64>) -> Vec<f64> {
    let mut f = vec![0.0; y.len()];
    ode.diff(t, y, &mut f);
    f
}

/// Dense output of DOP853 at `t` inside the last accepted step [t0, t1], h = t1 − t0.
///
/// differential-equations 0.7.0 evaluates the 7th-degree part of Hairer's DOP853
/// interpolant with θ and 1 − θ swapped (`conpar`), which leaves errors of ~1e-9 where the
/// step ends are exact to 1e-14. With θ = (t − t0)/h, the correct interpolant P and the
/// crate's P_w share their cubic part c(θ) = c0 + θ(c1 + (1−θ)(c2 + θ c3)) and differ in
/// the high-order part only by θ ↔ 1 − θ, which gives exactly
///
/// ```text
/// P(θ) = P_w(1 − θ) + c(θ) − c(1 − θ) = P_w(1 − θ) + (2θ − 1)(c1 + θ(1 − θ) c3),
/// c1 = y1 − y0,   c3 = 2 c1 − h (f0 + f1)
/// ```
///
/// where f0, f1 are ẏ at the step ends. Checked against cos t for y'' = −y to 3e-14, and
/// by the overcentre tests (samples between steps agree with the reference to 1e-10).
fn dense_output<S: Interpolation<f64, Vec<f64>> + OrdinaryNumericalMethod<f64, Vec<f64>>>(
    solver: &mut S,
    t: f64,
    f0: &[f64],
    f1: &[f64],
) -> std::result::Result<Vec<f64>, differential_equations::error::Error<f64, Vec<f64>>> {
    let (t0, t1) = (solver.t_prev(), solver.t());
    let h = t1 - t0;
    let theta = (t - t0) / h;
    let mirrored = (t0 + (1.0 - theta) * h).clamp(t0, t1);
    let mut y = solver.interpolate(mirrored)?;
    let (y0, y1) = (solver.y_prev(), solver.y());
    for i in 0..y.len() {
        let c1 = y1[i] - y0[i];
        let c3 = 2.0 * c1 - h * (f0[i] + f1[i]);
        y[i] += (2.0 * theta - 1.0) * (c1 + theta * (1.0 - theta) * c3);
    }
    Ok(y)
}

fn non_finite_error(t: f64) -> Error {
    Failure::NonFinite { t }.into()
}

fn integration_error(e: differential_equations::error::Error<f64, Vec<f64>>) -> Error {
    use differential_equations::error::Error as E;
    match e {
        E::StepSize { t, .. } => Failure::StepSizeUnderflow { t }.into(),
        E::MaxSteps { t, .. } => Failure::TooManySteps { t }.into(),
        E::Stiffness { t, .. } => Failure::Stiff { t }.into(),
        // the initial step estimate is zero when the accelerations at the start are
        // enormous (a stiffness near 1e308), not because of the run's length
        E::BadInput { msg } if msg.contains("Initial step size") => {
            Failure::StepSizeUnderflow { t: 0.0 }.into()
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
