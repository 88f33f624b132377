//! Time simulation: the fundamental equation integrated by DOP853 (8th order, adaptive,
//! dense output; crate `differential-equations`, wrapped here so it can be swapped), with
//! drift removed by projecting positions and velocities back onto the constraint manifold
//! after accepted steps.
//!
//! The integrator is driven step by step: after each accepted step the requested output
//! times inside it are sampled from the dense output, then, if the constraint residual
//! exceeds the projection tolerance, the state is projected and the integrator restarted
//! from it with its current step size (one extra right-hand-side evaluation).

use super::{
    DynWorkspace, State, accelerations, project_position, project_velocity, residual_norm,
};
use crate::diag::{Error, Result};
use crate::system::System;
use differential_equations::interpolate::Interpolation;
use differential_equations::ode::{ODE, OrdinaryNumericalMethod};
use differential_equations::prelude::ExplicitRungeKutta;
use differential_equations::status::Status;
use std::cell::{Cell, RefCell};

/// Settings of a simulation. Defaults: 20 s, output every 0.01 s, rtol 1e-10, atol 1e-12.
#[derive(Debug, Clone)]
pub struct SimOptions {
    /// End time, s (start is 0).
    pub t_end: f64,
    /// Output interval, s.
    pub dt_out: f64,
    /// Relative tolerance of the local error.
    pub rtol: f64,
    /// Absolute tolerance of the local error (SI units of each state entry).
    pub atol: f64,
    /// Project when |Φ|∞ or |A v + Φ_t|∞ exceeds this.
    pub projection_tol: f64,
    /// Give up after this many steps.
    pub max_steps: usize,
}

impl Default for SimOptions {
    fn default() -> Self {
        SimOptions {
            t_end: 20.0,
            dt_out: 0.01,
            rtol: 1e-10,
            atol: 1e-12,
            projection_tol: 1e-12,
            max_steps: 10_000_000,
        }
    }
}

/// Counters of a run.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct SimStats {
    pub accepted_steps: usize,
    pub rejected_steps: usize,
    pub rhs_evaluations: usize,
    pub projections: usize,
    /// Right-hand sides whose pseudoinverse took the SVD path (rank-deficient or
    /// ill-conditioned A M^-½).
    pub svd_solves: usize,
    /// Largest |Φ|∞ seen at output samples and at step ends before projection, m or rad.
    pub max_constraint_residual: f64,
}

/// Sampled solution.
#[derive(Debug, Clone)]
pub struct Trajectory {
    pub coordinates: Vec<String>,
    pub t: Vec<f64>,
    /// q at each sample (n each).
    pub q: Vec<Vec<f64>>,
    /// v at each sample (n each).
    pub v: Vec<Vec<f64>>,
    pub stats: SimStats,
}

impl Trajectory {
    /// Time history of one coordinate.
    pub fn coordinate(&self, name: &str) -> Option<Vec<f64>> {
        let i = self.coordinates.iter().position(|c| c == name)?;
        Some(self.q.iter().map(|q| q[i]).collect())
    }
}

/// The first-order system y = (q, v), ẏ = (v, v̇).
struct Rhs<'a> {
    sys: &'a System,
    ws: RefCell<DynWorkspace>,
    evals: Cell<usize>,
    /// Time of the first non-finite derivative.
    non_finite: Cell<Option<f64>>,
}

impl ODE<f64, Vec<f64>> for Rhs<'_> {
    fn diff(&self, t: f64, y: &Vec<f64>, dydt: &mut Vec<f64>) {
        let n = self.sys.n();
        let (q, v) = y.split_at(n);
        dydt[..n].copy_from_slice(v);
        let mut ws = self.ws.borrow_mut();
        accelerations(self.sys, &mut ws, q, v, t, &mut dydt[n..]);
        self.evals.set(self.evals.get() + 1);
        if self.non_finite.get().is_none() && dydt.iter().any(|x| !x.is_finite()) {
            self.non_finite.set(Some(t));
        }
    }
}

/// Integrate from a consistent state. `progress` receives the fraction done.
pub fn simulate(
    sys: &System,
    start: &State,
    opts: &SimOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<Trajectory> {
    check_options(opts)?;
    let n = sys.n();
    let rhs = Rhs {
        sys,
        ws: RefCell::new(DynWorkspace::new(sys)),
        evals: Cell::new(0),
        non_finite: Cell::new(None),
    };
    let mut proj_ws = DynWorkspace::new(sys);
    let t0 = start.t;
    let t_end = t0 + opts.t_end;
    let mut y0: Vec<f64> = start.q.iter().chain(&start.v).copied().collect();
    let mut stats = SimStats::default();
    let mut traj = Trajectory {
        coordinates: sys.coordinates.clone(),
        t: Vec::new(),
        q: Vec::new(),
        v: Vec::new(),
        stats: SimStats::default(),
    };
    let n_out = (opts.t_end / opts.dt_out + 1e-9).floor() as usize;
    let out_time = |k: usize| {
        if k > n_out {
            t_end
        } else {
            (t0 + k as f64 * opts.dt_out).min(t_end)
        }
    };
    // The last sample is t_end itself when t_end is not a multiple of dt_out.
    let last_k = if t0 + n_out as f64 * opts.dt_out < t_end - 1e-12 * t_end.abs().max(1.0) {
        n_out + 1
    } else {
        n_out
    };
    let record = |traj: &mut Trajectory, stats: &mut SimStats, t: f64, y: &[f64]| {
        let r = residual_norm(sys, &y[..n], t);
        stats.max_constraint_residual = stats.max_constraint_residual.max(r);
        traj.t.push(t);
        traj.q.push(y[..n].to_vec());
        traj.v.push(y[n..].to_vec());
    };
    record(&mut traj, &mut stats, t0, &y0);
    let mut next_k = 1;
    if opts.t_end == 0.0 {
        traj.stats = stats;
        return Ok(traj);
    }
    let mut solver = ExplicitRungeKutta::dop853()
        .rtol(opts.rtol)
        .atol(opts.atol)
        .max_steps(usize::MAX);
    // ẏ at a step end, cached by time (invalidated when the state is projected).
    let mut deriv_cache: Option<(f64, Vec<f64>)> = None;
    solver
        .init(&rhs, t0, t_end, &y0)
        .map_err(|e| integration_error(e, sys))?;
    while next_k <= last_k {
        let t = solver.t();
        if t + solver.h() > t_end {
            solver.set_h(t_end - t);
        }
        if stats.accepted_steps + stats.rejected_steps >= opts.max_steps {
            return Err(Error::numerical(
                format!(
                    "the simulation stopped at t = {t:.6} s after {} steps",
                    opts.max_steps
                ),
                "loosen --rtol/--atol or shorten --t-end; a very small step points to a singular pose",
            ));
        }
        let r = solver.step(&rhs);
        if let Some(tb) = rhs.non_finite.get() {
            return Err(non_finite_error(sys, tb));
        }
        r.map_err(|e| integration_error(e, sys))?;
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
            let y = if tk == t_new {
                solver.y().clone()
            } else {
                if ends.is_none() {
                    let t_prev = solver.t_prev();
                    let f0 = match deriv_cache.take() {
                        Some((tc, f)) if tc == t_prev => f,
                        _ => derivative(&rhs, t_prev, solver.y_prev()),
                    };
                    ends = Some((f0, derivative(&rhs, t_new, solver.y())));
                }
                let (f0, f1) = ends.as_ref().expect("set above");
                dense_output(&mut solver, tk, f0, f1).map_err(|e| integration_error(e, sys))?
            };
            record(&mut traj, &mut stats, tk, &y);
            next_k += 1;
        }
        if let Some((_, f1)) = ends {
            deriv_cache = Some((t_new, f1));
        }
        progress((t_new - t0) / opts.t_end);
        if next_k > last_k {
            break;
        }
        // Drift: project and restart when the residual exceeds the tolerance.
        let y = solver.y();
        let (q, v) = y.split_at(n);
        let pos = residual_norm(sys, q, t_new);
        stats.max_constraint_residual = stats.max_constraint_residual.max(pos);
        let vel = super::velocity_residual(sys, &mut proj_ws, q, v, t_new).amax();
        if pos > opts.projection_tol || vel > opts.projection_tol {
            y0.copy_from_slice(y);
            let (q, v) = y0.split_at_mut(n);
            project_position(sys, &mut proj_ws, q, t_new, opts.projection_tol * 1e-2, 5);
            project_velocity(sys, &mut proj_ws, q, v, t_new);
            stats.projections += 1;
            deriv_cache = None;
            solver.h0 = solver.h().min(t_end - t_new);
            if solver.h0 <= 0.0 {
                break;
            }
            solver
                .init(&rhs, t_new, t_end, &y0)
                .map_err(|e| integration_error(e, sys))?;
            if let Some(tb) = rhs.non_finite.get() {
                return Err(non_finite_error(sys, tb));
            }
        }
    }
    stats.rhs_evaluations = rhs.evals.get();
    stats.svd_solves = rhs.ws.borrow().svd_solves;
    traj.stats = stats;
    Ok(traj)
}

/// ẏ at (t, y): one right-hand side.
fn derivative(rhs: &Rhs, t: f64, y: &Vec<f64>) -> Vec<f64> {
    let mut f = vec![0.0; y.len()];
    rhs.diff(t, y, &mut f);
    f
}

/// Dense output of DOP853 at `t` inside the last accepted step [t0, t1], h = t1 − t0.
///
/// differential-equations 0.7.0 evaluates the 7th-degree part of Hairer's DOP853
/// interpolant with s and 1 − s swapped (`conpar`), which leaves errors of ~1e-9 where the
/// step ends are exact to 1e-14. With θ = (t − t0)/h, the correct interpolant P and the
/// crate's P_w share their cubic part c(θ) = c0 + θ(c1 + (1−θ)(c2 + θ c3)) and differ in
/// the high-order part by θ ↔ 1 − θ, which gives exactly
///
/// ```text
/// P(θ) = P_w(1 − θ) + c(θ) − c(1 − θ) = P_w(1 − θ) + (2θ − 1)(c1 + θ(1 − θ) c3),
/// c1 = y1 − y0,   c3 = 2 c1 − h (f0 + f1)
/// ```
///
/// where f0, f1 are ẏ at the step ends. Checked against cos t for y'' = −y to 3e-14.
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

fn check_options(o: &SimOptions) -> Result<()> {
    let bad = |what: &str, v: f64, hint: &str| {
        Err(Error::request(
            format!("{what} = {v} is not valid"),
            hint.to_string(),
        ))
    };
    if !(o.t_end >= 0.0) || !o.t_end.is_finite() {
        return bad("--t-end", o.t_end, "give a duration ≥ 0 s");
    }
    if !(o.dt_out > 0.0) || !o.dt_out.is_finite() {
        return bad("--dt-out", o.dt_out, "give an output interval > 0 s");
    }
    if !(o.rtol > 0.0 && o.rtol < 1.0) {
        return bad(
            "--rtol",
            o.rtol,
            "give a relative tolerance between 0 and 1, e.g. 1e-10",
        );
    }
    if !(o.atol > 0.0) || !o.atol.is_finite() {
        return bad(
            "--atol",
            o.atol,
            "give an absolute tolerance > 0, e.g. 1e-12",
        );
    }
    if o.t_end / o.dt_out > 5e7 {
        return bad(
            "--dt-out",
            o.dt_out,
            "that is more than 50 million samples; use a larger --dt-out",
        );
    }
    Ok(())
}

fn non_finite_error(sys: &System, t: f64) -> Error {
    let _ = sys;
    Error::numerical(
        format!(
            "the equations of motion produced a non-finite value (NaN or infinity) at t = {t:.6} s"
        ),
        "an expression in a force or constraint is undefined there (sqrt or ln of a negative number, division by zero), or the mechanism reached a singular pose",
    )
}

fn integration_error(
    e: differential_equations::error::Error<f64, Vec<f64>>,
    sys: &System,
) -> Error {
    use differential_equations::error::Error as E;
    let _ = sys;
    match e {
        E::StepSize { t, .. } => Error::numerical(
            format!("the step size fell to zero at t = {t:.6} s"),
            "the mechanism may be at a singular pose (a rank loss of the constraints) or the forces change abruptly; check the model, or loosen --rtol/--atol",
        ),
        E::MaxSteps { t, .. } => Error::numerical(
            format!("too many steps at t = {t:.6} s"),
            "loosen --rtol/--atol or shorten --t-end",
        ),
        E::Stiffness { t, .. } => Error::numerical(
            format!("the problem became stiff at t = {t:.6} s"),
            "a very stiff spring or damper makes an explicit integrator crawl; soften it or shorten --t-end",
        ),
        other => Error::numerical(format!("integration failed: {other:?}"), "check the model"),
    }
}
