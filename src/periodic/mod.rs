//! Periodic orbits of the forced constrained mechanism by single shooting on the
//! constraint manifold, with their monodromy matrices from the variational equations.
//!
//! # The map
//!
//! A state x = (q, v) lies on the manifold 𝓜 = {Φ(q, 0) = 0, A(q)v + Φ_t(q, 0) = 0}
//! (dimension 2·DoF). The forced motion over one period T of the forcing, integrated as
//! `simulate` integrates it (the Udwadia–Kalaba equations, DOP853, drift projected after
//! each step), is the Poincaré map P: 𝓜 → 𝓜. A periodic orbit is a fixed point of P.
//!
//! # Shooting, and why single
//!
//! The unknowns are the state at forcing phase 0 and the continued parameter. The
//! residual is written in a chart of 𝓜: with T_c an orthonormal basis of the tangent space
//! at a centre x_c (the null space of the constraint rows' Jacobian
//! G = [[A, 0], [∂(Av + Φ_t)/∂q, A]]), R(x) = T_cᵀ (P(x) − x) ∈ ℝ^{2·DoF}, and a Newton
//! step moves x along the tangent basis T_x at the iterate itself, x ← π(x + T_x η)
//! (π: the projection of `simulate` back onto 𝓜), so every iterate is a consistent state
//! and no coordinate ever leaves the constraints. Single shooting suffices here: the
//! mechanisms are damped or conservative, one forcing period is short against the growth
//! of any unstable direction (|μ| ≤ 10³ on the curves of docs/nonlinear-frequency-response.md),
//! and the integration error control makes P accurate to its tolerance. Multiple shooting
//! would only pay for strongly unstable orbits.
//!
//! # The monodromy matrix
//!
//! The variational equations Ẋ = ∂F/∂y · X (F the right-hand side of the first-order
//! system y = (q, v)) are integrated with the state, for the 2·DoF tangent directions and,
//! when asked, the parameter direction (Ẋ_p = ∂F/∂y X_p + ∂F/∂p). Their products
//! ∂F/∂y · X are directional derivatives of F by differences along each column — forward
//! along the curve (step √ε: error ~1e-8 of the column, 1 evaluation a column), central at
//! the located points (step 6e-6: ~1e-11, 2 evaluations) — evaluated at every stage of the same
//! steps as the state: the derivative of the integrated flow, not finite differences of
//! whole periods (whose error would be the integrator's tolerance over the step). The
//! multipliers are the eigenvalues of T_xᵀ Φ(T) T_x at a fixed point, the monodromy on
//! the manifold. Written by hand: no crate integrates variational equations of a
//! constrained multibody system.

pub mod backbone;
pub mod continuation;

use crate::diag::Result;
use crate::dynamics::integrator::{Integrator, IntegratorOptions};
use crate::dynamics::simulate::ConstrainedOde;
use crate::dynamics::{
    DynWorkspace, project_position, project_velocity, residual_norm, velocity_residual_blocks,
};
use crate::failure::Failure;
use crate::system::System;
use crate::system::outputs::{Output, Probe};
use differential_equations::ode::ODE;
use nalgebra::{Complex, DMatrix, DVector};
use std::cell::{Cell, RefCell};
use std::sync::atomic::{AtomicBool, Ordering};

/// Settings of the shooting.
#[derive(Debug, Clone)]
pub struct ShootingOptions {
    pub rtol: f64,
    pub atol: f64,
    /// Samples per period for the measures.
    pub samples: usize,
    /// Newton converges when every component of P(x) − x is below this fraction of the
    /// orbit's amplitude (positions and velocities separately).
    pub tol: f64,
    /// The variational columns by central differences of the right-hand side (error
    /// ~1e-11 of a column, 2 evaluations a column); false: forward differences (~1e-8,
    /// 1 evaluation), enough for Newton's matrix and the tangent, not for locating. (The
    /// continued parameter's column is central also where the tolerances were fitted to a
    /// small motion: `Shooting::flow`.)
    pub central: bool,
    /// The integrator of the periods and their variational equations: DOP853, or Radau
    /// IIA for a stiff model.
    pub integrator: Integrator,
    /// DOP853's largest step, s, in a period that carries variational columns (∞: no
    /// limit). `nfr` and `backbone` set it to 2/λ, λ the linearization's fastest natural
    /// frequency ([`COLUMN_STEP_RESOLUTION`]).
    pub max_column_step: f64,
}

/// A period carrying variational columns takes steps of at most this many radians of
/// the linearization's fastest mode (h·λ ≤ 2). The steps of a period are chosen by the
/// state's error, and the columns are scaled far below it (`Variational::tiny`): a mode
/// the orbit hardly excites did not limit them. tests/data/weak_pair.toml's second block
/// (316 rad/s, ζ = 0.0016) beside a 20 rad/s forcing was crossed at h·λ ≈ 5.8, near
/// DOP853's stability limit: its multipliers came out anywhere from 0.05 to 121 where
/// they are 0.855, with false instability and a false Neimark–Sacker point on a linear
/// model. Measured on it (relative error of that pair's modulus, the whole 19–21 rad/s
/// curve): h·λ ≤ 4: 28 %, 3: 5 %, 2: 0.14 %, 1.5: 0.016 %, 1: 0.004 %. A mode
/// the state's own steps resolve (the overcentre, the inceptor) is untouched.
pub const COLUMN_STEP_RESOLUTION: f64 = 2.0;

/// The fastest natural frequency of `modes`, rad/s (0 for none): what a period's steps
/// must resolve ([`COLUMN_STEP_RESOLUTION`]).
pub(crate) fn fastest(modes: &[crate::linear::Mode]) -> f64 {
    modes
        .iter()
        .map(|m| m.omega_n_rad_s)
        .filter(|w| w.is_finite())
        .fold(0.0, f64::max)
}

impl ShootingOptions {
    /// The Newton tolerance of an orbit (relative to its amplitude) whose largest
    /// multiplier's modulus is `growth` (at least 1): `tol`, or the integration's error
    /// amplified over the period, 100·rtol·growth, if larger. With growth 1 it is the
    /// noise of a stable orbit's amplitude.
    pub fn newton_tol(&self, growth: f64) -> f64 {
        self.tol.max(100.0 * self.rtol * growth)
    }
}

impl Default for ShootingOptions {
    fn default() -> Self {
        ShootingOptions {
            rtol: 1e-10,
            atol: 1e-12,
            samples: 128,
            tol: 1e-9,
            central: true,
            integrator: Integrator::Dop853,
            max_column_step: f64::INFINITY,
        }
    }
}

/// One period integrated with its variational equations.
#[derive(Debug, Clone)]
pub struct Flow {
    /// P(x): the state after one period (2n).
    pub end: Vec<f64>,
    /// ∂P/∂x · D for the directions D the flow was asked for (2n × k).
    pub jac: DMatrix<f64>,
    /// dP/dp, the continued parameter's column (the period's dependence included, and
    /// the start's: see `start_dp`).
    pub dp: Option<DVector<f64>>,
    /// dx/dp of the start state kept on the manifold as p changes (zero unless the
    /// constraints move with p: a base motion's velocity at t = 0 moves with its ω).
    pub start_dp: Option<DVector<f64>>,
    /// Per sample (the period's end excluded), the responses.
    pub values: Vec<Vec<f64>>,
    /// Half peak-to-peak of each state component over the period.
    pub scale: Vec<f64>,
}

impl Flow {
    /// d(P(x) − x)/dp: the residual's column for the parameter.
    pub fn p_column(&self) -> DVector<f64> {
        match (&self.dp, &self.start_dp) {
            (Some(d), Some(s)) => d - s,
            (Some(d), None) => d.clone(),
            _ => DVector::zeros(self.end.len()),
        }
    }
}

/// Periodic orbits of one model at values of one parameter.
pub struct Shooting {
    /// The model, its continued parameter set to the value of the last flow.
    pub sys: System,
    /// The continued parameter.
    pub param: usize,
    /// The forcing-frequency parameter (T = 2π/ω).
    pub freq: usize,
    pub opts: ShootingOptions,
    probe: Probe,
    ws: DynWorkspace,
    /// Right-hand-side evaluations so far (each evaluation of the state or of one
    /// perturbed state counts 1).
    pub rhs_evaluations: usize,
    /// Periods integrated.
    pub flows: usize,
    /// The most steps a period has taken so far: a flow that needs many times more (a
    /// Newton iterate far off, whose motion crawls through a singular pose) is given up.
    typical_steps: usize,
    /// The drift from the manifold (position or velocity residual) past which a period's
    /// state is projected back onto it: 1e-12, less for an orbit small against its
    /// coordinates (`Shooting::fit_to_motion`).
    drift: f64,
    /// The factor `fit_to_motion` scaled the tolerances by (1: none).
    fit: f64,
    /// `fit_to_motion` held the absolute tolerance to the motion (its second rule).
    absolute_fit: bool,
}

/// The motion's size against its coordinates' below which the shooting's tolerances
/// are scaled with it (`Shooting::fit_to_motion`).
const SMALL_MOTION: f64 = 1e-2;

/// The tightest relative tolerance `fit_to_motion` gives a period.
const RTOL_MIN: f64 = 1e-15;

/// A motion (relative to the coordinates' values, as [`Shooting::fit_to_motion`] takes
/// it) below which shooting cannot resolve an orbit in double precision, even fitted:
/// a curve that stalls there (`continuation::Nfr::motion`), or a backbone whose first
/// orbit does not converge, is put down to its size, and the advice is a larger motion.
/// The overcentre's lower well at F0 = 1e-5 N over 1.5–5 rad/s (7.6e-8) stalls; at 1e-4 N
/// (7.6e-7) it is traced whole.
pub const TOO_SMALL_MOTION: f64 = 5e-7;

/// The rounding of a period's end state, relative to its largest coordinate
/// (`Shooting::rounding`; measured about 6e-15 on the overcentre).
pub(crate) const ROUNDING: f64 = 1e-13;

/// Relative step of the central differences of the right-hand side.
const FD_STEP: f64 = 6e-6;

impl Shooting {
    pub fn new(
        sys: &System,
        param: usize,
        responses: &[Output],
        opts: ShootingOptions,
    ) -> Result<Shooting> {
        sys.refuse_free_bodies("the periodic-orbit continuation")?;
        let freq = sys
            .forcing_param()
            .ok_or(crate::request::Invalid::NoForcingFrequency)?;
        Ok(Shooting {
            sys: sys.clone(),
            param,
            freq,
            opts,
            probe: Probe::new(sys, responses.to_vec()),
            ws: DynWorkspace::new(sys),
            rhs_evaluations: 0,
            flows: 0,
            typical_steps: 0,
            drift: 1e-12,
            fit: 1.0,
            absolute_fit: false,
        })
    }

    /// 2n: the length of a state (q, v).
    pub fn len(&self) -> usize {
        self.sys.nq() + self.sys.nv()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Set the continued parameter.
    pub fn set(&mut self, p: f64) -> Result<()> {
        self.sys.set_param(self.param, p)
    }

    /// The continued parameter's value.
    pub fn value(&self) -> f64 {
        self.sys.param(self.param)
    }

    /// The forcing frequency, rad/s.
    pub fn omega(&self) -> f64 {
        self.sys.param(self.freq)
    }

    /// The forcing period, s.
    pub fn period(&self) -> f64 {
        2.0 * std::f64::consts::PI / self.omega()
    }

    /// dω/dp, the forcing frequency's rate with the continued parameter: 1 when it is
    /// the forcing frequency, by automatic differentiation through the parameters'
    /// expressions when ω is derived from it (`omega = w0/4` continued in w0), 0 when ω
    /// does not depend on it.
    pub fn omega_rate(&self) -> f64 {
        self.sys.param_rate(self.freq, self.param)
    }

    /// `Shooting::new`, its tolerances fitted to a motion `ratio` of its coordinates'
    /// size and of displacement `size` (`fit_to_motion`).
    pub fn fitted(
        sys: &System,
        param: usize,
        responses: &[Output],
        opts: ShootingOptions,
        ratio: f64,
        size: f64,
    ) -> Result<Shooting> {
        let mut sh = Shooting::new(sys, param, responses, opts)?;
        sh.fit_to_motion(ratio, size);
        Ok(sh)
    }

    /// Tolerances for a small motion. The integration's error control and the drift
    /// projection are relative to the coordinates' values or absolute, the Newton
    /// iteration relative to the orbit's amplitude:
    /// * where the orbit is a small fraction `ratio` of its coordinates (its
    ///   displacement's norm against the largest coordinate: the overcentre's lower well
    ///   at F0 = 1e-4 N over 1.5–5 rad/s, 7.6e-7), the integration's error is larger than
    ///   the Newton tolerance and the curve stalls. Below `SMALL_MOTION` the tolerances
    ///   and the drift threshold are scaled down by ratio / `SMALL_MOTION`; above it
    ///   nothing changes.
    /// * the absolute tolerance is held to rtol / `SMALL_MOTION` (100·rtol) of the
    ///   motion's `size` (the norm of its displacement over the positions, SI; `nfr`
    ///   gives it times the slowest frequency where that is below 1 rad/s, for the
    ///   velocities), as the first rule holds the relative one, and the drift threshold
    ///   is scaled with it. A mechanism about the
    ///   origin has no coordinates for `ratio` to be relative to (infinite), and only this
    ///   applies: the forced Duffing oscillator at F0 = 1e-7 N moves 2e-8 m, and with the
    ///   curve's atol of 1e-10 its Newton residual stayed near 4e-3 of the orbit and the
    ///   curve stalled at 1.53 rad/s.
    pub fn fit_to_motion(&mut self, ratio: f64, size: f64) {
        let (rtol, atol) = (self.opts.rtol, self.opts.atol);
        let g = ratio / SMALL_MOTION;
        if g < 1.0 {
            // (no tighter than RTOL_MIN: below it the steps shrink to the rounding)
            self.opts.rtol = (self.opts.rtol * g).max(RTOL_MIN.min(self.opts.rtol));
            self.opts.atol = (self.opts.atol * g).max(1e-3 * RTOL_MIN.min(self.opts.atol));
            self.drift = (self.drift * g).max(1e-15);
            self.fit = g;
        }
        // (no tighter than the first rule's floor: a motion of 2e-13 rad of the
        // overcentre's 2 m bars, which cannot converge, took a minute to say so)
        let cap = (rtol / SMALL_MOTION * size).max(1e-3 * RTOL_MIN.min(atol));
        if size > 0.0 && cap < self.opts.atol {
            let ga = cap / self.opts.atol;
            self.opts.atol = cap;
            self.drift = (self.drift * ga).max(1e-15).min(self.drift);
            self.absolute_fit = true;
        }
    }

    /// The tightest relative tolerance a period is integrated to: 1e-14, scaled as the
    /// tolerances are for a small motion (`fit_to_motion`), to `RTOL_MIN` at most.
    pub(crate) fn rtol_floor(&self) -> f64 {
        (1e-14 * self.fit).max(RTOL_MIN)
    }

    /// Put x on the manifold (positions, then velocities, at forcing phase 0).
    pub fn project(&mut self, x: &mut [f64]) -> f64 {
        let n = self.sys.nq();
        let (q, v) = x.split_at_mut(n);
        project_position(&self.sys, &mut self.ws, q, 0.0, 1e-14, 20);
        project_velocity(&self.sys, &mut self.ws, q, v, 0.0);
        let pos = residual_norm(&self.sys, q, 0.0);
        let vel = velocity_residual_blocks(&self.sys, &mut self.ws, q, v, 0.0);
        pos.max(vel)
    }

    /// An orthonormal basis of the manifold's tangent space at x (2n × 2·DoF).
    pub fn tangent_basis(&mut self, x: &[f64]) -> DMatrix<f64> {
        let sys = &self.sys;
        let (n, m) = (sys.nq(), sys.m());
        let mut a = DMatrix::zeros(m, n);
        let (q, v) = x.split_at(n);
        let psi = |ws: &mut DynWorkspace, q: &[f64]| -> DVector<f64> {
            crate::dynamics::velocity_residual(sys, ws, q, v, 0.0)
        };
        sys.jacobian(&mut self.ws.sys, q, 0.0, &mut a);
        let mut g = DMatrix::zeros(2 * m, 2 * n);
        g.view_mut((0, 0), (m, n)).copy_from(&a);
        g.view_mut((m, n), (m, n)).copy_from(&a);
        let mut qp = q.to_vec();
        for j in 0..n {
            let h = 1e-6 * (1.0 + q[j].abs());
            qp[j] = q[j] + h;
            let up = psi(&mut self.ws, &qp);
            qp[j] = q[j] - h;
            let down = psi(&mut self.ws, &qp);
            qp[j] = q[j];
            for i in 0..m {
                g[(m + i, j)] = (up[i] - down[i]) / (2.0 * h);
            }
        }
        crate::linalg::null_space_of(&g)
    }

    /// Integrate one period from x (consistent), with the variational equations along
    /// the columns of `dirs` and, if `with_dp`, along the continued parameter.
    pub fn flow(
        &mut self,
        x: &[f64],
        dirs: &DMatrix<f64>,
        with_dp: bool,
        cancel: &AtomicBool,
    ) -> Result<Flow> {
        let n2 = self.len();
        let k = dirs.ncols();
        let period = self.period();
        let p = self.value();
        let dp = 1e-6 * p.abs().max(1e-3);
        // The parameter column by central differences where the directions are, and
        // wherever the motion is small against its coordinates (`fit_to_motion`): its
        // derivative ∂F/∂p is then as small as the forcing, while the rounding of F is
        // that of the static loads, and a forward difference at √ε scatters the column
        // (the linear inceptor at 0.1 mm: by ±40 % from one point to the next, which
        // turned the tangent by up to 40° and stalled the curve at 27.67 rad/s).
        // (so too where the absolute tolerance was held to the motion: the forced Duffing
        // oscillator about the origin at F0 = 1e-7 N over 3–10 rad/s, its column
        // scattered by ±35 % between orbits 1e-5 rad/s apart, took 662 points and 1.3 M
        // evaluations and stalled at 4.80 rad/s; central, 39 points and 42 k)
        let p_central = self.opts.central || self.fit < 1.0 || self.absolute_fit;
        // the parameter column's own step: √ε for a forward difference
        let dp_column = if p_central {
            dp
        } else {
            FD_STEP_FORWARD * p.abs().max(1e-3)
        };
        // the start's shift with p: where the projection puts x at p ± dp
        let start_dp = if with_dp {
            let mut up = x.to_vec();
            let mut down = x.to_vec();
            self.sys.set_param(self.param, p + dp)?;
            self.project(&mut up);
            self.sys.set_param(self.param, p - dp)?;
            self.project(&mut down);
            self.sys.set_param(self.param, p)?;
            Some(DVector::from_fn(n2, |i, _| (up[i] - down[i]) / (2.0 * dp)))
        } else {
            None
        };
        let perturbed = if with_dp {
            let down = if p_central { p - dp } else { p };
            Some((
                self.sys.with_param(self.param, p + dp_column)?,
                self.sys.with_param(self.param, down)?,
            ))
        } else {
            None
        };
        let ode = Variational {
            base: ConstrainedOde::new(&self.sys),
            perturbed: perturbed.as_ref().map(|(a, b)| {
                let width = if p_central { 2.0 * dp } else { dp_column };
                (ConstrainedOde::new(a), ConstrainedOde::new(b), width)
            }),
            n2,
            k,
            evals: Cell::new(0),
            buf: RefCell::new((vec![0.0; n2], vec![0.0; n2], vec![0.0; n2], vec![0.0; n2])),
            tiny: 1e-6 * self.opts.atol,
            central: self.opts.central,
            p_central,
        };
        let cols = k + usize::from(with_dp);
        let mut y0 = vec![0.0; n2 * (1 + cols)];
        y0[..n2].copy_from_slice(x);
        for j in 0..k {
            for (y, d) in y0[n2 * (1 + j)..n2 * (2 + j)]
                .iter_mut()
                .zip(dirs.column(j).iter())
            {
                *y = d * ode.tiny;
            }
        }
        if let Some(d) = &start_dp {
            for (y, v) in y0[n2 * (1 + k)..].iter_mut().zip(d.iter()) {
                *y = v * ode.tiny;
            }
        }
        let per = self.opts.samples;
        let max_step = if cols > 0 {
            self.opts.max_column_step
        } else {
            f64::INFINITY
        };
        // the steps the columns' limit alone takes over a period
        let limited = if max_step.is_finite() {
            4 * (period / max_step).ceil().min(1e9) as usize
        } else {
            0
        };
        let iopts = IntegratorOptions {
            t0: 0.0,
            t_end: period,
            dt_out: period / per as f64,
            rtol: self.opts.rtol,
            atol: match self.opts.integrator {
                Integrator::Dop853 => self.opts.atol,
                // Radau IIA's error estimate is the looser (its tolerances are scaled as
                // RADAU5 does): at the default --atol a small orbit (the overcentre at
                // c = 1e4, 4e-5 rad) came out converged to only ~1e-4 of its amplitude,
                // and the curve zigzagged with false peaks. Its absolute tolerance is
                // taken 1e-4 times --atol, which costs it little (relative control
                // rules wherever the orbit is not tiny).
                Integrator::Radau => RADAU_ATOL_FACTOR * self.opts.atol,
            },
            // 20 times the most a period has taken (a million before the first)
            // (and at least 4 times what the columns' step limit alone asks: a period
            // with columns may take many more steps than one of the state alone, on
            // which the typical count may rest)
            max_steps: if self.typical_steps > 0 {
                (20 * self.typical_steps).max(2_000).max(limited)
            } else {
                1_000_000
            },
            method: self.opts.integrator,
            // the samples are read for the state only: the dense output's three stages
            // a step on the state alone (about a sixth of a period with its columns)
            dense_prefix: (cols > 0).then_some(n2),
            max_step,
        };
        let n = self.sys.nq();
        let sys = &self.sys;
        let probe = &mut self.probe;
        let mut values = Vec::with_capacity(per + 1);
        let mut lo = x.to_vec();
        let mut hi = x.to_vec();
        let mut last = y0.clone();
        let proj = RefCell::new(DynWorkspace::new(sys));
        let drift = self.drift;
        let outputs = probe.outputs().len();
        let stats = crate::dynamics::integrator::integrate(
            &ode,
            &y0,
            &iopts,
            &mut |t, y| {
                let (q, v) = y[..n2].split_at(n);
                let mut out = vec![0.0; outputs];
                probe.eval(sys, t, q, v, &mut out);
                values.push(out);
                for i in 0..n2 {
                    lo[i] = lo[i].min(y[i]);
                    hi[i] = hi[i].max(y[i]);
                }
                // the last sample is the period's end
                last.copy_from_slice(y);
                true
            },
            &mut |t, y| {
                let (q, v) = y[..n2].split_at_mut(n);
                let pos = residual_norm(sys, q, t);
                let mut ws = proj.borrow_mut();
                let vel = velocity_residual_blocks(sys, &mut ws, q, v, t);
                if pos > drift || vel > drift {
                    project_position(sys, &mut ws, q, t, 1e-14, 5);
                    project_velocity(sys, &mut ws, q, v, t);
                    true
                } else {
                    false
                }
            },
            &mut |_| !cancel.load(Ordering::Relaxed),
        )?;
        self.rhs_evaluations += ode.evals.get();
        self.flows += 1;
        // a running maximum that at most doubles a flow: one crawling flow (a far Newton
        // iterate) does not wear the guard away
        let steps = stats.accepted_steps + stats.rejected_steps;
        self.typical_steps = if self.typical_steps == 0 {
            steps
        } else {
            self.typical_steps.max(steps.min(2 * self.typical_steps))
        };
        if cancel.load(Ordering::Relaxed) {
            return Err(Failure::SweepInterrupted.into());
        }
        if values.len() < per + 1 {
            return Err(Failure::NonFiniteResult {
                quantity: format!(
                    "the samples of one period ({} of {})",
                    values.len(),
                    per + 1
                ),
                value: f64::NAN,
            }
            .into());
        }
        values.truncate(per);
        let mut end = last[..n2].to_vec();
        // the end state exactly on the manifold (drift since the last projection)
        {
            let (q, v) = end.split_at_mut(n);
            let mut ws = proj.borrow_mut();
            project_position(sys, &mut ws, q, 0.0, 1e-14, 5);
            project_velocity(sys, &mut ws, q, v, 0.0);
        }
        let tiny = ode.tiny;
        let jac = DMatrix::from_fn(n2, k, |i, j| last[n2 * (1 + j) + i] / tiny);
        let dp = with_dp.then(|| {
            let mut col = DVector::from_fn(n2, |i, _| last[n2 * (1 + k) + i] / tiny);
            let domega = self.omega_rate();
            if domega != 0.0 {
                // the period T = 2π/ω moves the end too: dT/dp = −(T/ω)·dω/dp
                let mut f = vec![0.0; n2];
                ode.base.diff(period, &last[..n2].to_vec(), &mut f);
                let dt = -period / self.sys.param(self.freq) * domega;
                for i in 0..n2 {
                    col[i] += f[i] * dt;
                }
            }
            col
        });
        if !crate::linalg::all_finite(&end) || !crate::linalg::all_finite(jac.as_slice()) {
            return Err(Failure::NonFiniteResult {
                quantity: "the state after one period".into(),
                value: f64::NAN,
            }
            .into());
        }
        let scale = lo.iter().zip(&hi).map(|(l, h)| 0.5 * (h - l)).collect();
        Ok(Flow {
            end,
            jac,
            dp,
            start_dp,
            values,
            scale,
        })
    }

    /// max_i |a_i − b_i| / (scale_i + floor), the floor the largest scale of the same kind
    /// (positions, velocities): a change relative to the orbit's amplitude, as the
    /// stepped sine's settling measures it (nq = nv here: free bodies are refused).
    pub fn relative(&self, a: &[f64], b: &[f64], scale: &[f64]) -> f64 {
        crate::frequency::relative_change(a, b, scale)
    }

    /// The residual (as `relative` measures it) that rounding alone leaves in a period
    /// started at `x` of an orbit of half-ranges `scale`: `ROUNDING` of the largest
    /// coordinate, against the orbit's amplitude. Negligible where the orbit is not tiny
    /// against its coordinates' values; where it is (the overcentre at F0 = 1e-4 N moves
    /// 1e-6 rad about coordinates of up to 5), the sum of the steps rounds to about
    /// 3e-14 whatever the tolerances, and a Newton tolerance below that would never be
    /// met. At most `continuation::NOISE_CAP`, the loosest tolerance an orbit is
    /// corrected to: an orbit of no amplitude (the equilibrium at zero forcing) is not
    /// converged by rounding alone.
    pub fn rounding(&self, x: &[f64], scale: &[f64]) -> f64 {
        let n = x.len() / 2;
        let kind = |r: std::ops::Range<usize>| {
            let size = crate::linalg::amax(&x[r.clone()]);
            let amp = scale[r].iter().fold(0.0f64, |m, s| m.max(*s)) + 1e-14;
            ROUNDING * size / amp
        };
        kind(0..n)
            .max(kind(n..x.len()))
            .min(continuation::NOISE_CAP)
    }

    /// The Newton tolerance of a period started at `x` of an orbit of half-ranges
    /// `scale` whose largest multiplier's modulus is `growth`: `newton_tol`, or the
    /// rounding (`rounding`) if larger.
    pub fn newton_tol_at(&self, growth: f64, x: &[f64], scale: &[f64]) -> f64 {
        self.opts.newton_tol(growth).max(self.rounding(x, scale))
    }
}

/// Floquet multipliers: the eigenvalues of the monodromy on the manifold, sorted by
/// modulus, largest first.
///
/// The Schur iteration is capped and its input checked finite
/// ([`crate::linalg::complex_eigenvalues`]: the same numbers as nalgebra's uncapped
/// `complex_eigenvalues`); where it fails, NaN multipliers, which no stability test passes.
pub fn multipliers(monodromy: &DMatrix<f64>) -> Vec<Complex<f64>> {
    let n = monodromy.nrows();
    let mut mu: Vec<Complex<f64>> =
        crate::linalg::complex_eigenvalues(monodromy.clone(), "monodromy matrix")
            .unwrap_or_else(|_| vec![Complex::new(f64::NAN, f64::NAN); n]);
    mu.sort_by(|a, b| b.norm().total_cmp(&a.norm()).then(b.im.total_cmp(&a.im)));
    mu
}

/// The state and its variational columns as one first-order system.
struct Variational<'a> {
    base: ConstrainedOde<'a>,
    /// The right-hand side at p + dp and at p − dp (central: `p_central`) or p
    /// (forward), and the difference of the two parameter values.
    perturbed: Option<(ConstrainedOde<'a>, ConstrainedOde<'a>, f64)>,
    n2: usize,
    /// Direction columns (the parameter column follows them).
    k: usize,
    evals: Cell<usize>,
    /// Scratch: a perturbed state, two right-hand sides, the unperturbed one.
    buf: RefCell<(Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>)>,
    /// The variational columns are integrated scaled by this (1e-6 of the absolute
    /// tolerance): their equations are linear, so the scaling is exact, and their error
    /// then stays far below the tolerance, so that the steps are chosen by the state's
    /// error (the central differences' ~1e-11 noise would otherwise hold the steps
    /// down). DOP853's error norm is a root mean square over every component, so the
    /// columns' near-zero errors dilute it: a period with c columns has its state
    /// integrated about √(1 + c) times more loosely than the state's period alone (2× on
    /// the overcentre, 2.4× on the inceptor). Measured 2026-11-27: the norm taken over
    /// the state alone (the same steps as the state's period) cost the inceptor's 7 mm
    /// curve 297 579 → 577 035 evaluations and the overcentre's 461 708 → 504 302, for
    /// the same folds and peaks within their uncertainties: not adopted.
    tiny: f64,
    /// Central differences (else forward).
    central: bool,
    /// The parameter column by central differences (else forward; `Shooting::flow`).
    p_central: bool,
}

/// The shooting's absolute tolerance with Radau IIA, as a fraction of the one asked for.
const RADAU_ATOL_FACTOR: f64 = 1e-4;

/// Relative step of the forward differences of the right-hand side (√ε: error ~1e-8).
const FD_STEP_FORWARD: f64 = 1.5e-8;

/// The parameter column is differenced in one with its state part while that state step
/// is at most this many times the column's own.
const MERGED_STEP_RATIO: f64 = 100.0;

impl ODE<f64, Vec<f64>> for Variational<'_> {
    fn diff(&self, t: f64, y: &Vec<f64>, dy: &mut Vec<f64>) {
        let n2 = self.n2;
        if y.len() == n2 {
            // the state alone: DOP853's dense-output stages (`Dop853::dense_prefix`)
            self.base.diff(t, y, dy);
            self.evals.set(self.evals.get() + 1);
            return;
        }
        let mut buf = self.buf.borrow_mut();
        let (xs, up, down, f0) = &mut *buf;
        xs.copy_from_slice(&y[..n2]);
        self.base.diff(t, xs, f0);
        dy[..n2].copy_from_slice(f0);
        let mut evals = 1;
        let size = 1.0 + crate::linalg::amax(&y[..n2]);
        let cols = self.k + usize::from(self.perturbed.is_some());
        for j in 0..cols {
            let col = &y[n2 * (1 + j)..n2 * (2 + j)];
            let out = n2 * (1 + j);
            let norm = crate::linalg::amax(col);
            let finite = norm.is_finite();
            // the difference step that suits the column alone (infinite for a zero column)
            let natural = if self.central {
                FD_STEP
            } else {
                FD_STEP_FORWARD
            } * size
                / norm;
            // The parameter column's equation Ẋ_p = J·X_p + tiny·∂F/∂p is one directional
            // derivative of F in (y, p), along (X_p, tiny): with the state step
            // width/tiny it is the difference of F at the perturbed parameter systems,
            // one evaluation (two, central) instead of two (four). Taken so when that
            // state step is not far above the column's own (the difference's error grows
            // with its step), else the two parts apart.
            if j == self.k
                && let Some((plus, minus, width)) = &self.perturbed
            {
                let half = if self.p_central { 0.5 } else { 1.0 };
                let h = half * width / self.tiny;
                // (against the step of a difference of the merged one's kind: central
                // where the parameter's part is, though the directions are forward)
                let own = if self.p_central {
                    FD_STEP * size / norm
                } else {
                    natural
                };
                if finite && h <= MERGED_STEP_RATIO * own {
                    for i in 0..n2 {
                        xs[i] = y[i] + h * col[i];
                    }
                    plus.diff(t, xs, up);
                    if self.p_central {
                        for i in 0..n2 {
                            xs[i] = y[i] - h * col[i];
                        }
                        minus.diff(t, xs, down);
                        evals += 2;
                        for i in 0..n2 {
                            dy[out + i] = (up[i] - down[i]) / (2.0 * h);
                        }
                    } else {
                        evals += 1;
                        for i in 0..n2 {
                            dy[out + i] = (up[i] - f0[i]) / h;
                        }
                    }
                    continue;
                }
            }
            if norm > 0.0 && finite {
                if self.central {
                    let h = natural;
                    for i in 0..n2 {
                        xs[i] = y[i] + h * col[i];
                    }
                    self.base.diff(t, xs, up);
                    for i in 0..n2 {
                        xs[i] = y[i] - h * col[i];
                    }
                    self.base.diff(t, xs, down);
                    evals += 2;
                    for i in 0..n2 {
                        dy[out + i] = (up[i] - down[i]) / (2.0 * h);
                    }
                } else {
                    let h = natural;
                    for i in 0..n2 {
                        xs[i] = y[i] + h * col[i];
                    }
                    self.base.diff(t, xs, up);
                    evals += 1;
                    for i in 0..n2 {
                        dy[out + i] = (up[i] - f0[i]) / h;
                    }
                }
            } else {
                dy[out..out + n2].fill(0.0);
            }
            if j == self.k
                && let Some((plus, minus, width)) = &self.perturbed
            {
                xs.copy_from_slice(&y[..n2]);
                plus.diff(t, xs, up);
                if self.p_central {
                    minus.diff(t, xs, down);
                    evals += 2;
                } else {
                    down.copy_from_slice(f0);
                    evals += 1;
                }
                for i in 0..n2 {
                    dy[out + i] += self.tiny * (up[i] - down[i]) / width;
                }
            }
        }
        self.evals.set(self.evals.get() + evals);
    }

    /// Radau IIA's Newton matrix for the augmented state: the state's Jacobian J (forward
    /// differences, the crate's own rule: 1 + 2n evaluations) on every diagonal block.
    /// Each column's equation is J times the column (plus the parameter's term), so its
    /// block is J; the columns' dependence on the state (second derivatives times a
    /// column scaled to `tiny`) is below the Newton iteration's resolution and left out,
    /// which a simplified Newton iteration allows. The crate's default would difference
    /// the whole augmented right-hand side along each of its 2n(1 + k) unknowns.
    fn jacobian(&self, t: f64, y: &Vec<f64>, j: &mut differential_equations::linalg::Matrix<f64>) {
        let n2 = self.n2;
        let blocks = 1 + self.k + usize::from(self.perturbed.is_some());
        let mut buf = self.buf.borrow_mut();
        let (xs, up, _, f0) = &mut *buf;
        xs.copy_from_slice(&y[..n2]);
        self.base.diff(t, xs, f0);
        j.fill(0.0);
        let eps = f64::EPSILON.sqrt();
        for c in 0..n2 {
            let h = eps * y[c].abs().max(1.0);
            xs[c] = y[c] + h;
            self.base.diff(t, xs, up);
            xs[c] = y[c];
            for r in 0..n2 {
                let d = (up[r] - f0[r]) / h;
                for b in 0..blocks {
                    j[(b * n2 + r, b * n2 + c)] = d;
                }
            }
        }
        self.evals.set(self.evals.get() + 1 + n2);
    }
}
