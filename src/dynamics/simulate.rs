//! Time simulation: the fundamental equation integrated by DOP853 or, for stiff models,
//! Radau IIA ([`super::integrator`]),
//! with drift removed by projecting positions and velocities back onto the constraint
//! manifold after accepted steps whose residual exceeds the projection tolerance (the
//! integrator then restarts from the projected state with its current step size).

use super::integrator::{Integrator, IntegratorOptions, Stiffness, integrate_stoppable};
use super::{
    DynWorkspace, MIN_RCOND, State, accelerations, project_position, project_velocity,
    residual_norm, velocity_residual_blocks,
};
use crate::diag::Result;
use crate::failure::Failure;
use crate::system::System;
use differential_equations::ode::ODE;
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
    /// Project a step end when |Φ|∞ or |A v + Φ_t|∞ exceeds this, and a written sample
    /// (dense output between projected step ends) when its |Φ|∞ exceeds 10× this: the
    /// samples then satisfy the constraints to 1e-11 by default, and most of them need no
    /// Newton projection (projecting every sample to 1e-12 cost 25 % of a run).
    pub projection_tol: f64,
    /// Give up after this many steps.
    pub max_steps: usize,
    /// The method: DOP853 (default) or, for stiff models, Radau IIA.
    pub integrator: Integrator,
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
            integrator: Integrator::Dop853,
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
    /// Largest |Φ|∞ of the written samples, m or rad.
    pub max_constraint_residual: f64,
    /// Largest |Φ|∞ of the integrated solution before projection (step ends and samples):
    /// the drift that projection removes.
    pub max_drift: f64,
    /// Set when DOP853 found the run stiff: its steps held by stability, not accuracy.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stiffness: Option<Stiffness>,
    /// [`simulate_stoppable`] only: `progress` cancelled the run at this model time, s
    /// (the samples up to it were written).
    #[serde(skip)]
    pub cancelled_at: Option<f64>,
}

/// Sampled solution: the sample times `t` and, per sample, the coordinates q (nq =
/// `coordinates.len()`) and the velocities v (nv = `velocities.len()`). q and v are each
/// kept in one flat buffer, sample after sample (no allocation per sample); read them by
/// [`Trajectory::q`], [`Trajectory::v`], [`Trajectory::qs`], [`Trajectory::vs`], and add
/// samples by [`Trajectory::push`].
#[derive(Debug, Clone)]
pub struct Trajectory {
    pub coordinates: Vec<String>,
    /// Whether each coordinate is an angle (rad), as [`System::is_angle`] says.
    pub angles: Vec<bool>,
    /// The velocities' names ([`System::velocities`]).
    pub velocities: Vec<String>,
    /// The sample times, s (read-only: samples are added by [`Trajectory::push`] and
    /// removed by [`Trajectory::clear`], which keep q and v in step).
    pub t: Vec<f64>,
    /// q of every sample, sample-major: sample k's at `k * nq..(k + 1) * nq`.
    q: Vec<f64>,
    /// v of every sample, sample-major: sample k's at `k * nv..(k + 1) * nv`.
    v: Vec<f64>,
    pub stats: SimStats,
}

impl Trajectory {
    /// No samples yet, for the coordinates of `sys`.
    pub fn empty(sys: &System) -> Trajectory {
        Trajectory {
            coordinates: sys.coordinates.clone(),
            angles: sys.angles(),
            velocities: sys.velocities.clone(),
            t: Vec::new(),
            q: Vec::new(),
            v: Vec::new(),
            stats: SimStats::default(),
        }
    }

    /// The number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether there is no sample.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The coordinates q of sample `k` (nq of them). Panics when `k` is past the last.
    pub fn q(&self, k: usize) -> &[f64] {
        let n = self.coordinates.len();
        &self.q[k * n..(k + 1) * n]
    }

    /// The velocities v of sample `k` (nv of them). Panics when `k` is past the last.
    pub fn v(&self, k: usize) -> &[f64] {
        let n = self.velocities.len();
        &self.v[k * n..(k + 1) * n]
    }

    /// Every sample's coordinates q, in time order.
    pub fn qs(&self) -> impl ExactSizeIterator<Item = &[f64]> + DoubleEndedIterator + Clone {
        (0..self.len()).map(|k| self.q(k))
    }

    /// Every sample's velocities v, in time order.
    pub fn vs(&self) -> impl ExactSizeIterator<Item = &[f64]> + DoubleEndedIterator + Clone {
        (0..self.len()).map(|k| self.v(k))
    }

    /// Append a sample: time `t`, coordinates `q` (nq), velocities `v` (nv).
    pub fn push(&mut self, t: f64, q: &[f64], v: &[f64]) {
        debug_assert_eq!(q.len(), self.coordinates.len());
        debug_assert_eq!(v.len(), self.velocities.len());
        self.t.push(t);
        self.q.extend_from_slice(q);
        self.v.extend_from_slice(v);
    }

    /// Remove every sample (keeping the buffers' room).
    pub fn clear(&mut self) {
        self.t.clear();
        self.q.clear();
        self.v.clear();
    }

    /// Make room for `samples` more samples at once.
    pub fn reserve(&mut self, samples: usize) {
        self.t.reserve(samples);
        self.q.reserve(samples * self.coordinates.len());
        self.v.reserve(samples * self.velocities.len());
    }

    /// Time history of one coordinate.
    pub fn coordinate(&self, name: &str) -> Option<Vec<f64>> {
        let i = self.coordinates.iter().position(|c| c == name)?;
        Some(self.qs().map(|q| q[i]).collect())
    }

    /// Time history of one velocity.
    pub fn velocity(&self, name: &str) -> Option<Vec<f64>> {
        let i = self.velocities.iter().position(|c| c == name)?;
        Some(self.vs().map(|v| v[i]).collect())
    }
}

/// The first-order system y = (q, v) (nq + nv), ẏ = (q̇(q, v), v̇).
pub struct ConstrainedOde<'a> {
    sys: &'a System,
    ws: RefCell<DynWorkspace>,
    /// The latest right-hand side whose angles' mass matrix was singular: (t, body,
    /// reciprocal condition number). Its derivative is NaN: the step is rejected, and the
    /// integration stops when the steps cannot avoid it.
    singular: Cell<Option<(f64, usize, f64)>>,
}

impl<'a> ConstrainedOde<'a> {
    pub fn new(sys: &'a System) -> Self {
        ConstrainedOde {
            sys,
            ws: RefCell::new(DynWorkspace::new(sys)),
            singular: Cell::new(None),
        }
    }

    /// The failure of a run that stopped at a singular mass matrix, if it did.
    fn singular_mass(&self) -> Option<Failure> {
        self.singular
            .get()
            .map(|(t, k, rcond)| Failure::SingularMass {
                t,
                body: self.sys.bodies[k].name.clone(),
                rcond,
            })
    }
}

impl ODE<f64, Vec<f64>> for ConstrainedOde<'_> {
    fn diff(&self, t: f64, y: &Vec<f64>, dydt: &mut Vec<f64>) {
        let n = self.sys.nq();
        let (q, v) = y.split_at(n);
        self.sys.qdot(q, v, &mut dydt[..n]);
        let mut ws = self.ws.borrow_mut();
        accelerations(self.sys, &mut ws, q, v, t, &mut dydt[n..]);
        // an angle sequence at (next to) its singular pose: its angle rates are about to
        // blow up; stop here, saying so, rather than integrate through it
        if let Some((k, rcond)) = ws.worst_mass()
            && rcond < MIN_RCOND
        {
            // the latest: trial stages past the singular pose are rejected, and the
            // run fails only when the steps cannot avoid it any more
            self.singular.set(Some((t, k, rcond)));
            dydt.fill(f64::NAN);
        }
    }
}

/// Written samples are projected when their residual exceeds this × `projection_tol`.
const SAMPLE_TOL_FACTOR: f64 = 10.0;

/// Integrate from a consistent state. `progress` receives the fraction done after each
/// step and returns `false` to cancel the run (which then fails as interrupted).
pub fn simulate(
    sys: &System,
    start: &State,
    opts: &SimOptions,
    progress: &mut dyn FnMut(f64) -> bool,
) -> Result<Trajectory> {
    let mut traj = Trajectory::empty(sys);
    // room for every sample at once, so the sample lists are not copied as they grow
    // (a run of more than 65536 samples, or one the options refuse, grows as it goes)
    let samples = opts.t_end / opts.dt_out;
    if (0.0..=65536.0).contains(&samples) {
        traj.reserve(samples as usize + 2);
    }
    traj.stats = simulate_with(
        sys,
        start,
        opts,
        &mut |t, q, v| {
            traj.push(t, q, v);
            true
        },
        progress,
    )?;
    Ok(traj)
}

/// [`simulate`], streaming: every written sample (t, q, v) goes to `sink` as it is
/// computed, and nothing is kept (memory flat in the run's length). `sink` returns
/// `false` to end the run there, cleanly (a steady state found, a file full). The
/// refusal of a run whose constraints could not be kept comes after the samples: a
/// caller writing a file writes it to a temporary and keeps it only on success.
pub fn simulate_with(
    sys: &System,
    start: &State,
    opts: &SimOptions,
    sink: &mut dyn FnMut(f64, &[f64], &[f64]) -> bool,
    progress: &mut dyn FnMut(f64) -> bool,
) -> Result<SimStats> {
    simulate_watched(sys, start, opts, sink, progress, &mut |_| {})
}

/// [`simulate_with`], and `stiff` hears as soon as DOP853 finds the run stiff (its steps
/// held by its stability bound: see [`super::integrator`]); the run goes on, and the
/// stats keep the same numbers. A front end tells the user early, with the numbers.
pub fn simulate_watched(
    sys: &System,
    start: &State,
    opts: &SimOptions,
    sink: &mut dyn FnMut(f64, &[f64], &[f64]) -> bool,
    progress: &mut dyn FnMut(f64) -> bool,
    stiff: &mut dyn FnMut(&Stiffness),
) -> Result<SimStats> {
    let stats = simulate_stoppable(sys, start, opts, sink, progress, stiff)?;
    match stats.cancelled_at {
        Some(t) => Err(Failure::Interrupted { t }.into()),
        None => Ok(stats),
    }
}

/// [`simulate_watched`], where a cancel by `progress` (asked after every integrator step,
/// so a signal is heard within one step, not one output sample) ends the run cleanly: the
/// samples up to then went to `sink`, and the stats say `cancelled_at` with the run's
/// counts so far.
pub fn simulate_stoppable(
    sys: &System,
    start: &State,
    opts: &SimOptions,
    sink: &mut dyn FnMut(f64, &[f64], &[f64]) -> bool,
    progress: &mut dyn FnMut(f64) -> bool,
    stiff: &mut dyn FnMut(&Stiffness),
) -> Result<SimStats> {
    check_options(opts)?;
    check_forcing(sys, opts)?;
    let n = sys.nq();
    let ode = ConstrainedOde::new(sys);
    let proj_ws = RefCell::new(DynWorkspace::new(sys));
    let y0: Vec<f64> = start.q.iter().chain(&start.v).copied().collect();
    let max_residual = std::cell::Cell::new(0.0f64);
    let drift = std::cell::Cell::new(0.0f64);
    let mut projections = 0;
    let iopts = IntegratorOptions {
        t0: start.t,
        t_end: start.t + opts.t_end,
        dt_out: opts.dt_out,
        rtol: opts.rtol,
        atol: opts.atol,
        max_steps: opts.max_steps,
        method: opts.integrator,
        dense_prefix: None,
        max_step: f64::INFINITY,
    };
    let (mut q, mut v) = (vec![0.0; n], vec![0.0; y0.len() - n]);
    let istats = integrate_stoppable(
        &ode,
        &y0,
        &iopts,
        // Samples from the dense output lie between projected step ends: project them too
        // when they drift past the tolerance, so every written state is consistent.
        &mut |t, y| {
            q.copy_from_slice(&y[..n]);
            v.copy_from_slice(&y[n..]);
            sys.normalize(&mut q);
            let pos = residual_norm(sys, &q, t);
            drift.set(drift.get().max(pos));
            // the residual of the written sample: `pos` unless it was projected
            let r = if pos > SAMPLE_TOL_FACTOR * opts.projection_tol {
                let mut ws = proj_ws.borrow_mut();
                let r = project_position(sys, &mut ws, &mut q, t, opts.projection_tol * 1e-2, 5);
                project_velocity(sys, &mut ws, &q, &mut v, t);
                r
            } else {
                pos
            };
            // a NaN residual must not vanish in f64::max
            max_residual.set(crate::linalg::amax(&[max_residual.get(), r]));
            sink(t, &q, &v)
        },
        // Drift: project when the residual exceeds the tolerance (and normalize the
        // quaternions when their norm has drifted as far).
        &mut |t, y| {
            let (q, v) = y.split_at_mut(n);
            let normalized = sys.norm_drift(q) > opts.projection_tol;
            if normalized {
                sys.normalize(q);
            }
            let pos = residual_norm(sys, q, t);
            drift.set(drift.get().max(pos));
            let mut ws = proj_ws.borrow_mut();
            let vel = velocity_residual_blocks(sys, &mut ws, q, v, t);
            if pos > opts.projection_tol || vel > opts.projection_tol {
                project_position(sys, &mut ws, q, t, opts.projection_tol * 1e-2, 5);
                project_velocity(sys, &mut ws, q, v, t);
                projections += 1;
                true
            } else {
                normalized
            }
        },
        progress,
        stiff,
    )
    .map_err(|e| match (&e, ode.singular_mass()) {
        (
            crate::diag::Error::Failed {
                failure: Failure::NonFinite { .. },
                ..
            },
            Some(f),
        ) => f.into(),
        // a non-finite value or a collapsed step with a parameter beyond double
        // precision's range (a force of 1e300: accelerations the step size estimate
        // cannot take): an overflow, not an undefined expression or a singular pose
        (
            crate::diag::Error::Failed {
                failure: Failure::NonFinite { t, .. } | Failure::StepSizeUnderflow { t, .. },
                ..
            },
            _,
        ) if !crate::failure::huge_parameters(sys.param_names(), sys.params()).is_empty() => {
            Failure::Overflow {
                what: "equations of motion".into(),
                t: Some(*t),
                huge: crate::failure::huge_parameters(sys.param_names(), sys.params()),
            }
            .into()
        }
        _ => e,
    })?;
    // The projection keeps written states on the constraints to `projection_tol`; a
    // residual far above it means it failed (a run far too loose, or a singular pose),
    // and the trajectory is not a motion of the mechanism: refuse it rather than write it.
    let limit = 1e-6f64.max(100.0 * SAMPLE_TOL_FACTOR * opts.projection_tol);
    if !(max_residual.get() <= limit) {
        return Err(Failure::ConstraintsNotKept {
            residual: max_residual.get(),
        }
        .into());
    }
    Ok(SimStats {
        accepted_steps: istats.accepted_steps,
        rejected_steps: istats.rejected_steps,
        rhs_evaluations: istats.rhs_evaluations,
        projections,
        svd_solves: ode.ws.borrow().svd_solves,
        max_constraint_residual: max_residual.get(),
        max_drift: drift.get(),
        stiffness: istats.stiffness,
        cancelled_at: istats.cancelled_at,
    })
}

/// Refuse a run whose forcing turns more times than the integrator may take steps.
///
/// An explicit or implicit Runge–Kutta method sees the forcing only at its stages: a step
/// of a forcing period or longer aliases it (its error estimate then measures a sampled
/// sine, not the motion), so a run that resolves the forcing takes at least one step per
/// forcing period (DOP853 takes a dozen or more). A run of more periods than `max_steps`
/// would spend all its steps and stop at the step limit after minutes without a word
/// (ω = 1e150 rad/s over 1 s: 10 million steps, 300 s, t = 2.8e-5 s reached): refused at
/// once instead, with the numbers.
fn check_forcing(sys: &System, opts: &SimOptions) -> Result<()> {
    let Some(omega) = sys.forcing_frequency().filter(|w| *w > 0.0) else {
        return Ok(());
    };
    let periods = opts.t_end * omega / std::f64::consts::TAU;
    if periods > opts.max_steps as f64 {
        return Err(Failure::ForcingUnresolved {
            omega,
            t_end: opts.t_end,
            periods,
            max_steps: opts.max_steps,
        }
        .into());
    }
    Ok(())
}

fn check_options(o: &SimOptions) -> Result<()> {
    use crate::request::{Argument, Invalid};
    let invalid = if !(o.t_end >= 0.0) || !o.t_end.is_finite() {
        Invalid::Negative {
            argument: Argument::Duration,
            value: o.t_end,
        }
    } else if !(o.dt_out > 0.0) || !o.dt_out.is_finite() {
        Invalid::NotPositive {
            argument: Argument::OutputInterval,
            value: o.dt_out,
        }
    } else if !(o.rtol > 0.0 && o.rtol < 1.0) {
        Invalid::NotFraction {
            argument: Argument::RelativeTolerance,
            value: o.rtol,
        }
    } else if !(o.atol > 0.0) || !o.atol.is_finite() {
        Invalid::NotPositive {
            argument: Argument::AbsoluteTolerance,
            value: o.atol,
        }
    } else if o.t_end / o.dt_out > MAX_SAMPLES as f64 {
        // blame the duration unless the output interval is itself unreasonably fine
        let (argument, value) = if o.dt_out >= 1e-4 {
            (Argument::Duration, o.t_end)
        } else {
            (Argument::OutputInterval, o.dt_out)
        };
        Invalid::TooManyPoints {
            argument,
            value,
            points: o.t_end / o.dt_out,
            limit: MAX_SAMPLES,
        }
    } else {
        return Ok(());
    };
    Err(invalid.into())
}

/// The most output samples of a simulation (t_end / dt_out).
pub(crate) const MAX_SAMPLES: usize = 50_000_000;
