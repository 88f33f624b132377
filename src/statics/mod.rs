//! Static equilibrium on the constraint manifold, its stability, and every equilibrium of
//! an assembly branch.
//!
//! The equilibrium equations are the KKT system in x = (q, λ):
//!
//! ```text
//! R(x) = [ f̄(q) + A_rᵀ λ ]  = 0      (n)     f̄ = impressed forces at rest, averaged over
//!        [ Φ_r(q)        ]           (r)         one period of the forcing
//! J(x) = [ ∂f̄/∂q + Σ λ_i ∇²Φ_i   A_rᵀ ]
//!        [ A_r                    0   ]
//! ```
//!
//! where `_r` keeps the r independent constraint rows (redundant rows are dropped once, at
//! the start pose). ∂f̄/∂q comes from `Dual64` passes, the constraint curvature
//! Σ λ_i ∇²Φ_i from `HyperDual64` passes. The tangent stiffness on the manifold is
//! `K_r = Nᵀ K N` with `K = −(∂f̄/∂q + Σ λ_i ∇²Φ_i)` and N an orthonormal basis of the null
//! space of A: the λ term is the stiffness of the constraint reactions (a gravity-loaded
//! mechanism has it), easy to omit and easy to count twice.
//!
//! The damped Newton method here is hand-written (about 40 lines): the Levenberg–Marquardt
//! crates do not support nalgebra 0.35 (see docs/performance.md and CRATES notes).
//!
//! Every equilibrium ([`Statics::all`]): with one fixed (driving) coordinate, Newton from
//! the poses of a sweep of it along the assembly branch; with several, Newton from the
//! start and from 256 Halton points over the box of the fixed coordinates (at most 257
//! Newton solves whatever their number). The Halton radical inverse is written here (ten
//! lines; the `halton` crate would add a dependency for them). The seeds' solves run in
//! parallel (rayon) and are kept in the seeds' order, so the result does not depend on the
//! threads; a seed's solve that stalls at a least-squares point gives up early
//! ([`STALL_RATIO`]). Σ λ_i ∇²Φ_i takes one hyper-dual pass per group of coordinate pairs
//! that no constraint element reads together ([`Statics::constraint_curvature`]).

pub mod continuation;
pub mod trim;

use crate::diag::{Error, Result};
use crate::dynamics::{DynWorkspace, State};
use crate::failure::Failure;
pub use crate::linalg::{RANK_TOL, generalized_eigenvalues, null_space_of, solve_least_squares};
use crate::linalg::{all_finite, amax};
use crate::scalar::{Env, Scalar};
use crate::system::{System, wrap_angle};
use nalgebra::{DMatrix, DVector};
use num_dual::{Dual64, HyperDual64};

/// Samples per period for averaging time-dependent loads (exact for harmonics below 64).
const PERIOD_SAMPLES: usize = 64;

/// The static problem of one compiled system.
#[derive(Debug, Clone)]
pub struct Statics<'a> {
    /// The system, with a moving ground held at its mean pose.
    pub sys: std::borrow::Cow<'a, System>,
    /// Independent constraint rows.
    pub rows: Vec<usize>,
    /// Times at which loads are averaged (one period of the forcing, or just t = 0).
    times: Vec<f64>,
    /// The passes of [`Statics::constraint_curvature`], planned for these rows.
    curvature: (Vec<usize>, Vec<Vec<CurvaturePair>>),
}

/// A solved equilibrium.
#[derive(Debug, Clone)]
pub struct Equilibrium {
    /// Coordinates (n).
    pub q: Vec<f64>,
    /// Constraint multipliers of the independent rows (r): A_rᵀ λ is the constraint force.
    pub lambda: Vec<f64>,
    /// |R|∞ at the solution (N and m mixed: force rows and constraint rows).
    pub residual: f64,
    pub iterations: usize,
    /// All eigenvalues of M_r⁻¹ K_r positive.
    pub stable: bool,
    /// Eigenvalues ω² of M_r⁻¹ K_r (rad²/s²), ascending; negative where unstable.
    pub omega2: Vec<f64>,
}

impl<'a> Statics<'a> {
    /// Set up the static problem; independent rows are chosen at `q_ref`.
    pub fn new(sys: &'a System, q_ref: &[f64]) -> Result<Statics<'a>> {
        let (sys, times) = Statics::at_mean(sys)?;
        let rows = independent_rows(&sys, q_ref);
        Ok(Statics::planned(sys, rows, times))
    }

    /// The system as statics sees it (a moving ground held at its mean pose over the
    /// forcing period) and the times at which time-dependent loads are averaged.
    fn at_mean(sys: &'a System) -> Result<(std::borrow::Cow<'a, System>, Vec<f64>)> {
        let times = Statics::averaging_times(sys)?;
        if !sys.ground.is_moving() {
            return Ok((std::borrow::Cow::Borrowed(sys), times));
        }
        let frozen = sys.with_ground_at_mean(&times);
        let times = if frozen.depends_on_time() {
            times
        } else {
            vec![0.0]
        };
        Ok((std::borrow::Cow::Owned(frozen), times))
    }

    /// A static problem with given independent rows (none are chosen: a continuation
    /// keeps the rows of its start, whatever the model's initial guess at p).
    pub fn with_rows(sys: &'a System, rows: Vec<usize>) -> Result<Statics<'a>> {
        let (sys, times) = Statics::at_mean(sys)?;
        Ok(Statics::planned(sys, rows, times))
    }

    /// The static problem with its curvature passes planned.
    fn planned(
        sys: std::borrow::Cow<'a, System>,
        rows: Vec<usize>,
        times: Vec<f64>,
    ) -> Statics<'a> {
        let mut st = Statics {
            sys,
            rows,
            times,
            curvature: (Vec::new(), Vec::new()),
        };
        st.curvature = (st.rows.clone(), st.curvature_passes());
        st
    }

    /// The times at which time-dependent loads and constraints are averaged: one period
    /// of the forcing frequency, or t = 0 when nothing depends on time.
    fn averaging_times(sys: &System) -> Result<Vec<f64>> {
        sys.refuse_free_bodies("statics and modes")?;
        Ok(if sys.depends_on_time() {
            match sys.forcing_frequency() {
                Some(w) if w != 0.0 => {
                    let period = 2.0 * std::f64::consts::PI / w.abs();
                    (0..PERIOD_SAMPLES)
                        .map(|k| k as f64 * period / PERIOD_SAMPLES as f64)
                        .collect()
                }
                Some(_) => vec![0.0],
                // a time-dependent custom constraint of an unforced model (a prescribed
                // drive): taken at t = 0
                None if !sys.forces_depend_on_time() && !sys.ground.is_moving() => vec![0.0],
                None => {
                    return Err(Error::request(
                        "the loads or the ground move with time, but the model does not say over which period to average them for statics",
                        "add `forcing_frequency = \"omega\"` (the parameter holding the forcing's angular frequency, rad/s) to [model]",
                    ));
                }
            }
        } else {
            vec![0.0]
        })
    }

    /// x ⊕ s·dx for x = (q, λ, …) (see [`advance`]).
    pub fn advance(&self, x: &[f64], dx: &[f64], s: f64) -> Vec<f64> {
        advance(&self.sys, x, dx, s)
    }

    /// Times at which time-dependent loads are averaged.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// Size of x = (q, λ).
    pub fn dim(&self) -> usize {
        self.sys.n() + self.rows.len()
    }

    /// Mean impressed force at rest over one period, generic for derivatives.
    pub fn static_force<D: Scalar>(&self, q: &[D], out: &mut [D]) {
        self.static_force_in(q, self.sys.env(), out)
    }

    /// [`Statics::static_force`] with parameters from `env` (for ∂/∂p).
    pub fn static_force_in<D: Scalar, E: Env<D>>(&self, q: &[D], env: E, out: &mut [D]) {
        let n = self.sys.n();
        let zero = vec![D::from(0.0); n];
        let mut f = vec![D::from(0.0); n];
        out.fill(D::from(0.0));
        let times = self.sample_times(&self.times, env);
        let w = 1.0 / times.len() as f64;
        for &t in &times {
            self.sys.forces_in(q, &zero, t, env, &mut f);
            for i in 0..n {
                out[i] += f[i] * w;
            }
        }
    }

    /// `times` in type D: one period of the forcing frequency read from `env` (so that a
    /// derivative with respect to the frequency moves the samples with the period, and
    /// the mean of a harmonic load does not depend on it), or the single time given.
    fn sample_times<D: Scalar, E: Env<D>>(&self, times: &[f64], env: E) -> Vec<D> {
        match (times.len(), self.sys.forcing_param()) {
            (1, _) | (_, None) => times.iter().map(|&t| D::from(t)).collect(),
            (k, Some(f)) => {
                let period = D::from(2.0 * std::f64::consts::PI) / env.param(f).abs();
                (0..k)
                    .map(|i| D::from(i as f64) * period / k as f64)
                    .collect()
            }
        }
    }

    /// ∂R/∂p_i at x = (q, λ): the derivative of the equilibrium equations with respect to
    /// parameter `i`, by automatic differentiation (dual numbers seeded on the parameter,
    /// hyper-dual for the constraint forces A_rᵀ λ).
    pub fn residual_dp(&self, x: &[f64], i: usize) -> DVector<f64> {
        let sys: &System = &self.sys;
        let n = sys.n();
        let (q, lambda) = x.split_at(n);
        let p = sys.param(i);
        let (pd, cd) = sys.seeded(i, Dual64::new(p, 1.0));
        let env = crate::scalar::Seeded {
            params: &pd,
            coefs: &cd,
        };
        let qd: Vec<Dual64> = q.iter().map(|&x| Dual64::from(x)).collect();
        let mut f = vec![Dual64::from(0.0); n];
        self.static_force_in(&qd, env, &mut f);
        let mut phi = vec![Dual64::from(0.0); sys.m()];
        self.static_phi_in(&qd, env, &mut phi);
        // ∂(A_rᵀ λ)_j/∂p = ∂²(λ·Φ_r)/∂q_j∂p
        let (ph, ch) = sys.seeded(i, HyperDual64::new(p, 0.0, 1.0, 0.0));
        let envh = crate::scalar::Seeded {
            params: &ph,
            coefs: &ch,
        };
        let mut qh: Vec<HyperDual64> = q.iter().map(|&x| HyperDual64::from(x)).collect();
        let mut phih = vec![HyperDual64::from(0.0); sys.m()];
        let mut r = DVector::zeros(self.dim());
        for j in 0..n {
            qh[j].eps1 = 1.0;
            self.static_phi_in(&qh, envh, &mut phih);
            qh[j].eps1 = 0.0;
            r[j] = f[j].eps + self.reaction_mixed(lambda, &phih);
        }
        for (k, &row) in self.rows.iter().enumerate() {
            r[n + k] = phi[row].eps;
        }
        r
    }

    /// Times at which the constraints are averaged: the forcing period when they depend
    /// on time (a moving ground), else t = 0.
    fn constraint_times(&self) -> &[f64] {
        if self.sys.rheonomic {
            &self.times
        } else {
            &[0.0]
        }
    }

    /// Mean constraint function Φ̄(q) over one period (Φ(q, 0) when it does not depend on
    /// time), generic for derivatives.
    pub fn static_phi<D: Scalar>(&self, q: &[D], out: &mut [D]) {
        self.static_phi_in(q, self.sys.env(), out)
    }

    /// [`Statics::static_phi`] with parameters from `env`.
    pub fn static_phi_in<D: Scalar, E: Env<D>>(&self, q: &[D], env: E, out: &mut [D]) {
        let times = self.sample_times(self.constraint_times(), env);
        if times.len() == 1 {
            return self.sys.phi_in(q, times[0], env, out);
        }
        let mut p = vec![D::from(0.0); self.sys.m()];
        out.fill(D::from(0.0));
        let w = 1.0 / times.len() as f64;
        for &t in &times {
            self.sys.phi_in(q, t, env, &mut p);
            for i in 0..p.len() {
                out[i] += p[i] * w;
            }
        }
    }

    /// Ā = ∂Φ̄/∂q (m × n).
    pub fn mean_jacobian(&self, q: &[f64]) -> DMatrix<f64> {
        let times = self.constraint_times();
        // the system's scratch buffers only (a DynWorkspace also factors the mass matrix)
        let mut ws = crate::system::Workspace::new(&self.sys);
        let mut a = DMatrix::zeros(self.sys.m(), self.sys.nv());
        if times.len() == 1 {
            self.sys.jacobian(&mut ws, q, times[0], &mut a);
            return a;
        }
        let mut sum = DMatrix::zeros(self.sys.m(), self.sys.n());
        for &t in times {
            self.sys.jacobian(&mut ws, q, t, &mut a);
            sum += &a;
        }
        sum / times.len() as f64
    }

    /// ∂f̄/∂q (n × n).
    pub fn force_jacobian(&self, q: &[f64]) -> DMatrix<f64> {
        let n = self.sys.n();
        let mut k = DMatrix::zeros(n, n);
        let mut qd: Vec<Dual64> = q.iter().map(|&x| Dual64::from(x)).collect();
        let mut out = vec![Dual64::from(0.0); n];
        for j in 0..n {
            qd[j].eps = 1.0;
            self.static_force(&qd, &mut out);
            qd[j].eps = 0.0;
            for i in 0..n {
                k[(i, j)] = out[i].eps;
            }
        }
        k
    }

    /// Σ λ_i ∇²Φ_i over the independent rows (n × n), by hyper-dual passes.
    ///
    /// Entry (j, k) is Σ λ_r ∂²Φ_r/∂q_j∂q_k over the rows r of the constraint elements
    /// that read both q_j and q_k (the blocks of A): every other row's term is exactly
    /// zero. Pairs whose elements read none of another pair's coordinates share one pass
    /// (see [`Statics::curvature_passes`]): an element's rows see only their own pair's
    /// seeds, so each entry has the value, to the bit, of a pass of its own (on the
    /// inceptor 65 passes instead of 153).
    pub fn constraint_curvature(&self, q: &[f64], lambda: &[f64]) -> DMatrix<f64> {
        let n = self.sys.n();
        let mut h = DMatrix::zeros(n, n);
        let mut qh: Vec<HyperDual64> = q.iter().map(|&x| HyperDual64::from(x)).collect();
        let mut phi = vec![HyperDual64::from(0.0); self.sys.m()];
        // planned at construction, unless the rows were changed since
        let fresh;
        let passes = if self.curvature.0 == self.rows {
            &self.curvature.1
        } else {
            fresh = self.curvature_passes();
            &fresh
        };
        for pass in passes {
            for p in pass {
                qh[p.j].eps1 = 1.0;
                qh[p.k].eps2 = 1.0;
            }
            self.static_phi(&qh, &mut phi);
            for p in pass {
                qh[p.j].eps1 = 0.0;
                qh[p.k].eps2 = 0.0;
            }
            for p in pass {
                // in the order of the rows, as a sum over all of them (whose other terms
                // are zeros)
                let v = p
                    .rows
                    .iter()
                    .map(|&i| lambda[i] * phi[self.rows[i]].eps1eps2)
                    .sum();
                h[(p.j, p.k)] = v;
                h[(p.k, p.j)] = v;
            }
        }
        h
    }

    /// The hyper-dual passes of [`Statics::constraint_curvature`]: every pair j ≤ k of
    /// coordinates that some constraint element with an independent row reads both of,
    /// with those rows (indices into `rows`), greedily grouped (in the order j, then k)
    /// so that no element reads coordinates of two pairs of one pass.
    fn curvature_passes(&self) -> Vec<Vec<CurvaturePair>> {
        let sys: &System = &self.sys;
        let n = sys.n();
        let blocks = sys.blocks();
        // the elements with an independent row, and the rows of each
        let mut rows_of: Vec<Vec<usize>> = vec![Vec::new(); blocks.len()];
        for (i, &r) in self.rows.iter().enumerate() {
            if let Some(b) = blocks
                .iter()
                .position(|b| r >= b.row0 && r < b.row0 + b.rows)
            {
                rows_of[b].push(i);
            }
        }
        let live: Vec<usize> = (0..blocks.len())
            .filter(|&b| !rows_of[b].is_empty())
            .collect();
        let words = live.len().div_ceil(64).max(1);
        // the live elements reading each coordinate, as a bit set
        let mut reads = vec![vec![0u64; words]; n];
        for (bit, &b) in live.iter().enumerate() {
            for &c in &blocks[b].cols {
                if c < n {
                    reads[c][bit / 64] |= 1 << (bit % 64);
                }
            }
        }
        let mut passes: Vec<(Vec<u64>, Vec<CurvaturePair>)> = Vec::new();
        for j in 0..n {
            for k in j..n {
                let both: Vec<u64> = reads[j].iter().zip(&reads[k]).map(|(a, b)| a & b).collect();
                if both.iter().all(|&w| w == 0) {
                    continue;
                }
                let mut rows: Vec<usize> = (0..live.len())
                    .filter(|&bit| both[bit / 64] >> (bit % 64) & 1 == 1)
                    .flat_map(|bit| rows_of[live[bit]].iter().copied())
                    .collect();
                rows.sort_unstable();
                let touched: Vec<u64> =
                    reads[j].iter().zip(&reads[k]).map(|(a, b)| a | b).collect();
                let pair = CurvaturePair { j, k, rows };
                match passes
                    .iter_mut()
                    .find(|(used, _)| used.iter().zip(&touched).all(|(u, t)| u & t == 0))
                {
                    Some((used, pass)) => {
                        for (u, t) in used.iter_mut().zip(&touched) {
                            *u |= t;
                        }
                        pass.push(pair);
                    }
                    None => passes.push((touched, vec![pair])),
                }
            }
        }
        passes.into_iter().map(|(_, p)| p).collect()
    }

    /// Σ λ_r ∂²Φ_r of a hyper-dual pass over the independent rows: the mixed second
    /// derivative of the constraint reactions' work λ·Φ_r.
    fn reaction_mixed(&self, lambda: &[f64], phi: &[HyperDual64]) -> f64 {
        self.rows
            .iter()
            .zip(lambda)
            .map(|(&r, l)| l * phi[r].eps1eps2)
            .sum()
    }

    /// A_r (r × n) of the mean constraints.
    pub fn jacobian_rows(&self, q: &[f64]) -> DMatrix<f64> {
        self.mean_jacobian(q).select_rows(self.rows.iter())
    }

    /// R(x) = (f̄ + A_rᵀ λ, Φ_r).
    pub fn residual(&self, x: &[f64]) -> DVector<f64> {
        self.residual_rows(x).0
    }

    /// R(x) and the Ā_r it used (which J(x) needs too: computed once, see
    /// [`Statics::kkt_jacobian_with`]).
    pub fn residual_rows(&self, x: &[f64]) -> (DVector<f64>, DMatrix<f64>) {
        let n = self.sys.n();
        let (q, lambda) = x.split_at(n);
        let mut f = vec![0.0; n];
        self.static_force(q, &mut f);
        let ar = self.jacobian_rows(q);
        let cf = ar.transpose() * DVector::from_column_slice(lambda);
        let mut phi = vec![0.0; self.sys.m()];
        self.static_phi(q, &mut phi);
        let mut r = DVector::zeros(self.dim());
        for i in 0..n {
            r[i] = f[i] + cf[i];
        }
        for (k, &row) in self.rows.iter().enumerate() {
            r[n + k] = phi[row];
        }
        (r, ar)
    }

    /// J(x) = ∂R/∂x.
    pub fn kkt_jacobian(&self, x: &[f64]) -> DMatrix<f64> {
        self.kkt_jacobian_with(x, &self.jacobian_rows(&x[..self.sys.n()]))
    }

    /// J(x) with Ā_r at x already computed (by [`Statics::residual_rows`]).
    pub fn kkt_jacobian_with(&self, x: &[f64], ar: &DMatrix<f64>) -> DMatrix<f64> {
        let n = self.sys.n();
        let (q, lambda) = x.split_at(n);
        let kq = self.force_jacobian(q) + self.constraint_curvature(q, lambda);
        let d = self.dim();
        let mut j = DMatrix::zeros(d, d);
        j.view_mut((0, 0), (n, n)).copy_from(&kq);
        j.view_mut((0, n), (n, ar.nrows()))
            .copy_from(&ar.transpose());
        j.view_mut((n, 0), (ar.nrows(), n)).copy_from(&ar);
        j
    }

    /// Least-squares multipliers at q: A_rᵀ λ ≈ −f̄.
    pub fn multipliers(&self, q: &[f64]) -> Vec<f64> {
        let n = self.sys.n();
        let mut f = vec![0.0; n];
        self.static_force(q, &mut f);
        let ar = self.jacobian_rows(q);
        if ar.nrows() == 0 {
            return Vec::new();
        }
        if !all_finite(ar.as_slice()) || !all_finite(&f) {
            // undefined there (nalgebra's SVD would panic or never return): NaN multipliers,
            // which the Newton solve reports as an undefined residual
            return vec![f64::NAN; self.rows.len()];
        }
        let svd = crate::linalg::svd_or_nan(ar.transpose(), true, true);
        let eps = RANK_TOL * svd.singular_values.max();
        let l = svd
            .solve(&(-DVector::from_column_slice(&f)), eps)
            .unwrap_or_else(|_| DVector::zeros(self.rows.len()));
        l.iter().copied().collect()
    }

    /// Orthonormal basis of the null space of Ā at q (n × (n − rank)).
    pub fn null_space(&self, q: &[f64]) -> DMatrix<f64> {
        null_space_of(&self.mean_jacobian(q))
    }

    /// Tangent stiffness on the manifold K_r = Nᵀ K N, K = −(∂f̄/∂q + Σ λ_i ∇²Φ_i).
    pub fn reduced_stiffness(&self, q: &[f64], lambda: &[f64], nb: &DMatrix<f64>) -> DMatrix<f64> {
        nb.transpose() * self.stiffness(q, lambda) * nb
    }

    /// Stiffness in the model's coordinates K = −(∂f̄/∂q + Σ λ_i ∇²Φ_i) (n × n).
    pub fn stiffness(&self, q: &[f64], lambda: &[f64]) -> DMatrix<f64> {
        -(self.force_jacobian(q) + self.constraint_curvature(q, lambda))
    }

    /// Stability and ω² = eig(M_r⁻¹ K_r) at an equilibrium.
    pub fn stability(&self, q: &[f64], lambda: &[f64]) -> (bool, Vec<f64>) {
        let nb = self.null_space(q);
        if nb.ncols() == 0 {
            return (true, Vec::new());
        }
        let kr = self.reduced_stiffness(q, lambda, &nb);
        let mr = nb.transpose() * &self.sys.mass_matrix_at(q) * &nb;
        let omega2 = generalized_eigenvalues(&kr, &mr);
        let stable = omega2.iter().all(|&w| w > 0.0);
        (stable, omega2)
    }

    /// Damped Newton on R(x) = 0 from the pose q0 (which should satisfy the constraints).
    pub fn solve(&self, q0: &[f64]) -> Result<Equilibrium> {
        let n = self.sys.n();
        let mut x: Vec<f64> = q0.to_vec();
        x.extend(self.multipliers(q0));
        let (x, iterations, residual) = self.newton(x, 60)?;
        let (q, lambda) = x.split_at(n);
        let (stable, omega2) = self.stability(q, lambda);
        Ok(Equilibrium {
            q: q.to_vec(),
            lambda: lambda.to_vec(),
            residual,
            iterations,
            stable,
            omega2,
        })
    }

    /// Newton from a seed of a search ([`Statics::solve`], but a solve that stalls gives
    /// up, see [`STALL_RATIO`]): the equilibrium without its stability, which
    /// [`Statics::with_stability`] adds to the solutions a search keeps.
    fn solve_seed(&self, q0: &[f64]) -> Option<Equilibrium> {
        let n = self.sys.n();
        let mut x: Vec<f64> = q0.to_vec();
        x.extend(self.multipliers(q0));
        let (x, iterations, residual) = self.newton_with(x, 60, true).ok()?;
        let (q, lambda) = x.split_at(n);
        Some(Equilibrium {
            q: q.to_vec(),
            lambda: lambda.to_vec(),
            residual,
            iterations,
            stable: false,
            omega2: Vec::new(),
        })
    }

    /// The Newton solves of a search's seeds, in parallel, in the seeds' order.
    fn solve_seeds(&self, seeds: &[Vec<f64>]) -> Vec<Option<Equilibrium>> {
        use rayon::prelude::*;
        seeds.par_iter().map(|s| self.solve_seed(s)).collect()
    }

    /// `e` with its stability and ω² (as [`Statics::solve`] gives them).
    fn with_stability(&self, mut e: Equilibrium) -> Equilibrium {
        (e.stable, e.omega2) = self.stability(&e.q, &e.lambda);
        e
    }

    /// The equilibrium nearest a start state: Newton from its pose; if that fails, Newton
    /// from every seed of the assembly branch ([`Statics::all`]) and the solution nearest
    /// the start pose.
    pub fn nearest(&self, start: &State) -> Result<Equilibrium> {
        match self.solve(&start.q) {
            Ok(e) => Ok(e),
            Err(first) => {
                let Ok(all) = self.all(start) else {
                    if free_jacobian_conditioning(&self.sys, &start.q, &self.rows) < 1e-6 {
                        return Err(Failure::SingularStart.into());
                    }
                    return Err(first);
                };
                let dist = |e: &Equilibrium| {
                    e.q.iter()
                        .zip(&start.q)
                        .map(|(a, b)| (a - b).powi(2))
                        .sum::<f64>()
                };
                Ok(all
                    .into_iter()
                    .min_by(|a, b| dist(a).total_cmp(&dist(b)))
                    .expect("all() returns at least one"))
            }
        }
    }

    /// Convergence thresholds: force rows relative to the load scale, constraint rows
    /// relative to the coordinates.
    pub(crate) fn converged(&self, r: &DVector<f64>, x: &[f64], force_scale: f64) -> bool {
        let n = self.sys.n();
        let qs = coordinate_size(&x[..n]);
        let fr = r.rows(0, n).amax();
        let cr = r.rows(n, self.rows.len()).amax();
        // an overflowing load scale (a load near f64::MAX) accepts nothing
        force_scale.is_finite() && fr <= 1e-11 * force_scale && cr <= 1e-13 * qs
    }

    pub(crate) fn force_scale(&self, q: &[f64]) -> f64 {
        let mut f = vec![0.0; self.sys.n()];
        self.static_force(q, &mut f);
        let g: f64 = self.sys.bodies.iter().map(|b| b.mass).sum::<f64>()
            * if self.sys.spatial {
                self.sys.gravity.iter().map(|g| g * g).sum::<f64>().sqrt()
            } else {
                self.sys.gravity[0].hypot(self.sys.gravity[1])
            };
        1.0 + f.iter().fold(g, |a, v| a.max(v.abs()))
    }

    /// Newton with backtracking on |R|₂; returns (x, iterations, |R|∞).
    pub fn newton(&self, x: Vec<f64>, max_iter: usize) -> Result<(Vec<f64>, usize, f64)> {
        self.newton_with(x, max_iter, false)
    }

    /// [`Statics::newton`]; with `give_up`, a solve that has stalled (see [`STALL_RATIO`])
    /// fails early, without a pose in its message (for a search, which drops it): the
    /// solves that converge take the same iterations to the bit.
    fn newton_with(
        &self,
        mut x: Vec<f64>,
        max_iter: usize,
        give_up: bool,
    ) -> Result<(Vec<f64>, usize, f64)> {
        let n = self.sys.n();
        let mut stalled = 0;
        let scale = self.force_scale(&x[..n]);
        if !scale.is_finite() {
            return Err(Error::Numerical {
                message: format!(
                    "the loads overflow: their scale (the largest generalized force, and the weight) is {scale}"
                ),
                help: Some(
                    "a parameter is near the largest number a double holds (1.8e308): give it a physical value".into(),
                ),
            });
        }
        let (mut r, mut ar) = self.residual_rows(&x);
        let mut it = 0;
        while !self.converged(&r, &x, scale) {
            if it == max_iter || !r.iter().all(|v| v.is_finite()) {
                let pose: Vec<String> = self
                    .sys
                    .coordinates
                    .iter()
                    .zip(&x)
                    .map(|(c, v)| format!("{c} = {v:.6}"))
                    .collect();
                let residual = amax(r.as_slice());
                // from finite inputs, an infinity (or the NaN of inf − inf) is an overflow,
                // not an undefined expression: a parameter near the largest double (a
                // stiffness of 1e308 times a stretch) names itself
                let huge =
                    crate::failure::huge_parameters(self.sys.param_names(), self.sys.params());
                let infinite = r.iter().any(|v| v.is_infinite());
                // the round-off of the force rows: 1e-16 of their largest term (a row of
                // the Jacobian times the coordinates' size)
                let round_off = residual.is_finite() && {
                    let j = self.kkt_jacobian_with(&x, &ar);
                    let qs = coordinate_size(&x[..n]);
                    let term = j.rows(0, n).amax() * qs;
                    term.is_finite() && residual <= 1e-13 * term
                };
                return Err(if residual.is_finite() {
                    Failure::NoEquilibrium {
                        residual,
                        iterations: it,
                        pose: pose.join(", "),
                        round_off,
                    }
                } else if !huge.is_empty() || infinite {
                    Failure::Overflow {
                        what: "equilibrium equations".into(),
                        t: None,
                        huge,
                    }
                } else {
                    Failure::UndefinedEquilibrium {
                        iterations: it,
                        pose: pose.join(", "),
                    }
                }
                .into());
            }
            it += 1;
            let j = self.kkt_jacobian_with(&x, &ar);
            let norm0 = r.norm();
            let dx = if give_up {
                let dx = solve_least_squares(j.clone(), &r);
                let predicted = (&r - &j * &dx).norm();
                if predicted > STALL_RATIO * norm0 {
                    stalled += 1;
                } else {
                    stalled = 0;
                }
                if stalled == STALL_COUNT {
                    return Err(Failure::NoEquilibrium {
                        residual: amax(r.as_slice()),
                        iterations: it,
                        pose: String::new(),
                        round_off: false,
                    }
                    .into());
                }
                dx
            } else {
                solve_least_squares(j, &r)
            };
            // Trust region: no coordinate moves more than 0.2 (rad, or m scaled by the
            // model's size, at most 10) in one iteration, so Newton does not leap to a far
            // equilibrium, yet can travel far when the equilibrium is far.
            let size = coordinate_size(&x[..n]).min(10.0);
            let biggest = dx.rows(0, n).amax();
            let mut step = if biggest > 0.2 * size {
                0.2 * size / biggest
            } else {
                1.0
            };
            loop {
                let trial = self.advance(&x, dx.as_slice(), -step);
                let (rt, art) = self.residual_rows(&trial);
                if rt.norm() < norm0 || step < 1e-6 {
                    x = trial;
                    r = rt;
                    ar = art;
                    break;
                }
                step *= 0.5;
            }
        }
        Ok((x, it, r.amax()))
    }

    /// Every equilibrium on the assembly branch of `start`: the driving coordinates (those
    /// the model fixes for assembly) are swept in 2° (or 2 %) steps in both directions,
    /// re-assembling from the previous pose, until the constraints lose rank or stop
    /// closing; Newton runs from every seed; solutions inside the swept range are kept,
    /// duplicates removed, sorted by the first driving coordinate. With several driving
    /// coordinates the box they span is searched instead (see `all_multi`); with k ≥ 2
    /// degrees of freedom and fewer fixed coordinates, angles complete them first.
    pub fn all(&self, start: &State) -> Result<Vec<Equilibrium>> {
        let sys: &System = &self.sys;
        let mut drivers: Vec<usize> = (0..sys.n()).filter(|&i| sys.initial.fixed[i]).collect();
        // several degrees of freedom, fewer fixed coordinates: angles complete them
        let dof = self.null_space(&start.q).ncols();
        if dof >= 2
            && drivers.len() < dof
            && let Some(more) = self.independent_angles(&start.q, &drivers, dof)
        {
            drivers = more;
        }
        if drivers.is_empty() {
            return Ok(vec![self.solve(&start.q)?]);
        }
        if drivers.len() >= 2 {
            return self.all_multi(start, &drivers);
        }
        let mut seeds = vec![start.q.clone()];
        let mut ranges = Vec::new();
        for &d in &drivers {
            let (lo, hi) = (
                self.sweep(start, d, -1.0, &mut seeds),
                self.sweep(start, d, 1.0, &mut seeds),
            );
            ranges.push((d, lo, hi));
        }
        // Poses equal modulo 2π in their angles are one equilibrium (a crank that revolves
        // reaches each twice): the first found is kept (the seeds start at the initial
        // pose and move away from it).
        let apart = |a: &[f64], b: &[f64]| self.apart(a, b);
        let mut found: Vec<Equilibrium> = Vec::new();
        for e in self.solve_seeds(&seeds).into_iter().flatten() {
            let inside = ranges
                .iter()
                .all(|&(d, lo, hi)| e.q[d] >= lo - 1e-9 && e.q[d] <= hi + 1e-9);
            if !inside {
                continue;
            }
            if !found.iter().any(|f| apart(&f.q, &e.q) < 1e-7) {
                found.push(self.with_stability(self.in_first_turn(e)));
            }
        }
        if found.is_empty() {
            return Err(Failure::NoEquilibriumOnBranch.into());
        }
        let d0 = drivers[0];
        found.sort_by(|a, b| a.q[d0].total_cmp(&b.q[d0]));
        Ok(found)
    }

    /// `e` with every angle taken in (−π, π] (450° found from a start at 573° is shown as
    /// 90°), where that pose is the same equilibrium: its residual, with the same
    /// multipliers, passes the Newton test. That holds when the elements see the angles
    /// only through their sines and cosines; a torsion spring on a raw angle, k (θ − θ0),
    /// does not, and its equilibrium keeps the angles found.
    pub fn in_first_turn(&self, e: Equilibrium) -> Equilibrium {
        let angles = self.sys.angles();
        let mut q = e.q.clone();
        for (x, &angle) in q.iter_mut().zip(&angles) {
            if angle && x.abs() > std::f64::consts::PI {
                *x = wrap_angle(*x);
            }
        }
        if q == e.q {
            return e;
        }
        let mut x = q.clone();
        x.extend_from_slice(&e.lambda);
        let r = self.residual(&x);
        let scale = self.force_scale(&q);
        if !(scale.is_finite() && self.converged(&r, &x, scale)) {
            return e;
        }
        Equilibrium {
            q,
            residual: r.amax(),
            ..e
        }
    }

    /// The largest difference between two poses, angles compared modulo 2π.
    fn apart(&self, a: &[f64], b: &[f64]) -> f64 {
        let angles = self.sys.angles();
        a.iter()
            .zip(b)
            .zip(&angles)
            .map(|((x, y), &angle)| {
                let d = (x - y).abs();
                if angle {
                    let r = d.rem_euclid(std::f64::consts::TAU);
                    r.min(std::f64::consts::TAU - r)
                } else {
                    d
                }
            })
            .fold(0.0, f64::max)
    }

    /// `drivers` completed to `dof` independent coordinates by angles not yet in it (in
    /// model order): an angle joins when the constraint Jacobian of the coordinates left
    /// free keeps the rank of A_r, so that those can still be assembled. None when the
    /// angles do not suffice.
    fn independent_angles(&self, q: &[f64], drivers: &[usize], dof: usize) -> Option<Vec<usize>> {
        let sys: &System = &self.sys;
        let ar = self.jacobian_rows(q);
        let rank = |a: DMatrix<f64>| {
            if a.nrows() == 0 || a.ncols() == 0 {
                return 0;
            }
            let sv = crate::linalg::svd_or_nan(a, false, false).singular_values;
            sv.iter().filter(|&&s| s > RANK_TOL * sv.max()).count()
        };
        let full = rank(ar.clone());
        let mut chosen = drivers.to_vec();
        for i in (0..sys.n()).filter(|&i| sys.is_angle(i) && !drivers.contains(&i)) {
            if chosen.len() == dof {
                break;
            }
            let free: Vec<usize> = (0..sys.n())
                .filter(|&j| j != i && !chosen.contains(&j))
                .collect();
            if rank(ar.select_columns(free.iter())) == full {
                chosen.push(i);
            }
        }
        (chosen.len() == dof).then_some(chosen)
    }

    /// [`Statics::all`] with k ≥ 2 fixed (driving) coordinates: Newton from the start pose
    /// and from [`MULTI_SEEDS`] seeds spread over the drivers' box — the first points
    /// (from index 1) of the Halton sequence in bases 2, 3, 5, …, an angle driver over
    /// [−π, π), a length driver over the range its one-dimensional sweep reaches — each
    /// assembled (the free coordinates) from the nearest seed already assembled. At most
    /// `MULTI_SEEDS + 1` Newton solves of at most 60 iterations whatever k. Solutions are
    /// kept once (modulo 2π in angles; of two copies, the one whose driving angles lie
    /// nearest zero), sorted by the driving coordinates in turn, angles taken in (−π, π].
    fn all_multi(&self, start: &State, drivers: &[usize]) -> Result<Vec<Equilibrium>> {
        let sys: &System = &self.sys;
        let pi = std::f64::consts::PI;
        let mut boxes = Vec::new();
        for &d in drivers {
            boxes.push(if sys.is_angle(d) {
                (-pi, pi)
            } else {
                let mut discard = Vec::new();
                (
                    self.sweep(start, d, -1.0, &mut discard),
                    self.sweep(start, d, 1.0, &mut discard),
                )
            });
        }
        let free: Vec<usize> = (0..sys.n()).filter(|i| !drivers.contains(i)).collect();
        let mut ws = DynWorkspace::new(sys);
        let mut seeds = vec![start.q.clone()];
        for i in 1..=MULTI_SEEDS {
            let target = halton_point(i, &boxes);
            let mut trial = nearest_seed(sys, &seeds, drivers, &target).clone();
            for (&d, &t) in drivers.iter().zip(&target) {
                trial[d] = t;
            }
            if assemble_free(sys, &mut ws, &mut trial, &free) {
                seeds.push(trial);
            }
        }
        let wrapped = |e: &Equilibrium, k: usize| {
            let (d, v) = (drivers[k], e.q[drivers[k]]);
            if sys.is_angle(d) { wrap_angle(v) } else { v }
        };
        let offset = |e: &Equilibrium| {
            drivers
                .iter()
                .filter(|&&d| sys.is_angle(d))
                .map(|&d| e.q[d].abs())
                .fold(0.0, f64::max)
        };
        let mut found: Vec<Equilibrium> = Vec::new();
        for e in self.solve_seeds(&seeds).into_iter().flatten() {
            let inside = drivers.iter().zip(&boxes).all(|(&d, &(lo, hi))| {
                sys.is_angle(d) || (e.q[d] >= lo - 1e-9 && e.q[d] <= hi + 1e-9)
            });
            if !inside {
                continue;
            }
            match found.iter_mut().find(|f| self.apart(&f.q, &e.q) < 1e-7) {
                Some(f) if offset(&e) < offset(f) - 1e-9 => {
                    *f = self.with_stability(self.in_first_turn(e))
                }
                Some(_) => {}
                None => found.push(self.with_stability(self.in_first_turn(e))),
            }
        }
        if found.is_empty() {
            return Err(Failure::NoEquilibriumOnBranch.into());
        }
        found.sort_by(|a, b| {
            (0..drivers.len())
                .map(|k| wrapped(a, k).total_cmp(&wrapped(b, k)))
                .find(|o| o.is_ne())
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        Ok(found)
    }

    /// Sweep driver `d` from the start pose in direction `dir`; push seeds; return the last
    /// value reached.
    fn sweep(&self, start: &State, d: usize, dir: f64, seeds: &mut Vec<Vec<f64>>) -> f64 {
        let sys: &System = &self.sys;
        let angle = sys.is_angle(d);
        let step = if angle {
            2f64.to_radians()
        } else {
            0.02 * start.q[d].abs().max(1e-3)
        };
        let limit = if angle { 180 } else { 50 };
        let mut ws = DynWorkspace::new(sys);
        let mut q = start.q.clone();
        let mut last = start.q[d];
        // σ_min/σ_max of ∂Φ_r/∂q_free along the sweep: a V-shaped dip toward zero marks a
        // singular pose (where the assembly can switch branches): stop before it.
        let sigma0 = free_jacobian_conditioning(sys, &q, &self.rows);
        let mut history: Vec<(f64, Vec<f64>, f64)> = vec![(sigma0, q.clone(), last)];
        let mut kept = 0;
        for k in 1..=limit {
            let target = start.q[d] + dir * step * k as f64;
            let mut trial = q.clone();
            trial[d] = target;
            // re-assemble the free coordinates from the previous pose
            if !assemble_at(sys, &mut ws, &mut trial) {
                break;
            }
            // A small driver step that moves another coordinate a lot has crossed a
            // singular pose onto another assembly (from a start at the singular pose an
            // angle was seen to spin by hundreds of turns): stop there.
            let size = 1.0 + q.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let jump = (0..sys.n())
                .filter(|&i| i != d)
                .map(|i| (trial[i] - q[i]).abs())
                .fold(0.0, f64::max);
            if jump > 0.5 * size {
                break;
            }
            let sigma = free_jacobian_conditioning(sys, &trial, &self.rows);
            let n = history.len();
            if sigma < 1e-9 {
                break;
            }
            if n >= 2 {
                let (s1, s2) = (history[n - 1].0, history[n - 2].0);
                if s1 < s2 && s1 < sigma && s1 < 0.25 * sigma0 {
                    // dip at the previous sample: the singular pose lies next to it
                    kept = kept.min(n - 2);
                    break;
                }
            }
            history.push((sigma, trial.clone(), target));
            kept = history.len() - 1;
            q = trial;
        }
        for (_, pose, value) in history.iter().take(kept + 1).skip(1) {
            seeds.push(pose.clone());
            last = *value;
        }
        last
    }
}

/// One entry (j ≤ k) of a curvature pass: the independent rows (indices into `rows`)
/// of the constraint elements that read both coordinates.
#[derive(Debug, Clone)]
struct CurvaturePair {
    j: usize,
    k: usize,
    rows: Vec<usize>,
}

/// A search's Newton solve has stalled when the full step, by the linear model J·dx, would
/// leave more than this fraction of |R|₂, [`STALL_COUNT`] iterations in a row: the residual
/// is orthogonal to the range of a singular J, a least-squares point that is no solution,
/// where the iterates stay (the inceptor's seeds far from its equilibrium end there with
/// their constraint rows at 1e-2 m after 7 iterations on average, and then spent the 53
/// others in line searches down to the smallest step). The ratio is bimodal: on the
/// converging solves of every model in models/ and tests/data/ (and the inceptor with
/// breakout, k_t = 40, φ0 = 30°) it stays below 0.01 (0.0083 on veering_pendulums, 4e-5
/// on the inceptor); the stalled ones sit at 0.999–1 from their first stalled iteration.
const STALL_RATIO: f64 = 0.999;
const STALL_COUNT: usize = 2;

/// Seeds of [`Statics::all`] with several driving coordinates (see `all_multi`).
const MULTI_SEEDS: usize = 256;

/// Point `i` of the Halton sequence (bases 2, 3, 5, …, one per dimension) mapped into the
/// box `[lo_k, hi_k)`: low-discrepancy, so any number of points covers the box evenly,
/// in any dimension (a grid of a fixed count does not exist above 8 dimensions).
fn halton_point(i: usize, boxes: &[(f64, f64)]) -> Vec<f64> {
    const PRIMES: [usize; 16] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53];
    boxes
        .iter()
        .enumerate()
        .map(|(k, &(lo, hi))| {
            let base = PRIMES[k % PRIMES.len()];
            // radical inverse of i in `base`
            let (mut n, mut f, mut r) = (i, 1.0, 0.0);
            while n > 0 {
                f /= base as f64;
                r += f * (n % base) as f64;
                n /= base;
            }
            lo + r * (hi - lo)
        })
        .collect()
}

/// The seed whose driving coordinates lie nearest `target` (angles modulo 2π).
fn nearest_seed<'s>(
    sys: &System,
    seeds: &'s [Vec<f64>],
    drivers: &[usize],
    target: &[f64],
) -> &'s Vec<f64> {
    let dist = |s: &Vec<f64>| {
        drivers
            .iter()
            .zip(target)
            .map(|(&d, t)| {
                let e = s[d] - t;
                if sys.is_angle(d) { wrap_angle(e) } else { e }.powi(2)
            })
            .sum::<f64>()
    };
    seeds
        .iter()
        .min_by(|a, b| dist(a).total_cmp(&dist(b)))
        .expect("the start pose is a seed")
}

/// x ⊕ s·dx for x = (q, λ, …): the coordinates through the system's retraction, the
/// rest (multipliers, a continuation parameter) added.
pub fn advance(sys: &System, x: &[f64], dx: &[f64], s: f64) -> Vec<f64> {
    let (nq, nv) = (sys.nq(), sys.nv());
    let mut y = x.to_vec();
    sys.retract(&mut y[..nq], &dx[..nv], s);
    for (a, d) in y[nq..].iter_mut().zip(&dx[nv..]) {
        *a += s * d;
    }
    y
}

/// The tangent from x0 to x1 for x = (q, λ, …) (see [`advance`]).
pub fn difference(sys: &System, x1: &[f64], x0: &[f64]) -> Vec<f64> {
    let (nq, nv) = (sys.nq(), sys.nv());
    let mut d = vec![0.0; x1.len() - nq + nv];
    sys.difference(&x1[..nq], &x0[..nq], &mut d[..nv]);
    for ((o, a), b) in d[nv..].iter_mut().zip(&x1[nq..]).zip(&x0[nq..]) {
        *o = a - b;
    }
    d
}

/// σ_min/σ_max of ∂Φ_r/∂q_free (1 when nothing is free or nothing constrains).
fn free_jacobian_conditioning(sys: &System, q: &[f64], rows: &[usize]) -> f64 {
    let free: Vec<usize> = (0..sys.n()).filter(|&i| !sys.initial.fixed[i]).collect();
    if free.is_empty() || rows.is_empty() {
        return 1.0;
    }
    let mut ws = DynWorkspace::new(sys);
    sys.jacobian(&mut ws.sys, q, 0.0, &mut ws.a);
    let af = ws.a.select_rows(rows.iter()).select_columns(free.iter());
    let sv = crate::linalg::svd_or_nan(af, false, false).singular_values;
    sv.min() / sv.max()
}

/// Gauss–Newton assembly of the non-fixed coordinates at fixed drivers.
fn assemble_at(sys: &System, ws: &mut DynWorkspace, q: &mut [f64]) -> bool {
    let free: Vec<usize> = (0..sys.n()).filter(|&i| !sys.initial.fixed[i]).collect();
    assemble_free(sys, ws, q, &free)
}

/// Gauss–Newton assembly of the coordinates `free`, the others held.
fn assemble_free(sys: &System, ws: &mut DynWorkspace, q: &mut [f64], free: &[usize]) -> bool {
    for _ in 0..30 {
        let phi = sys.residual(q, 0.0);
        if phi.amax() < 1e-13 {
            return true;
        }
        sys.jacobian(&mut ws.sys, q, 0.0, &mut ws.a);
        let af = ws.a.select_columns(free.iter());
        let dx = solve_least_squares(af, &phi);
        let mut delta = vec![0.0; sys.nv()];
        for (k, &i) in free.iter().enumerate() {
            delta[i] = dx[k];
        }
        sys.retract(q, &delta, -1.0);
        if !q.iter().all(|v| v.is_finite()) {
            return false;
        }
    }
    sys.residual(q, 0.0).amax() < 1e-11
}

/// Rows of A that are independent at q (greedy, in model order).
pub fn independent_rows(sys: &System, q: &[f64]) -> Vec<usize> {
    let mut ws = DynWorkspace::new(sys);
    sys.jacobian(&mut ws.sys, q, 0.0, &mut ws.a);
    if !all_finite(ws.a.as_slice()) {
        // undefined at q (a NaN guess): keep every row (nalgebra's SVD never returns on NaN)
        return (0..sys.m()).collect();
    }
    let mut rows: Vec<usize> = Vec::new();
    let mut rank = 0;
    for i in 0..sys.m() {
        let mut trial = rows.clone();
        trial.push(i);
        let sub = ws.a.select_rows(trial.iter());
        let sv = crate::linalg::svd_or_nan(sub, false, false).singular_values;
        let r = sv.iter().filter(|&&s| s > RANK_TOL * sv.max()).count();
        if r > rank {
            rows = trial;
            rank = r;
        }
    }
    rows
}

/// 1 + the largest |q_i|: the size the equilibrium's tolerances and steps are relative to.
fn coordinate_size(q: &[f64]) -> f64 {
    1.0 + q.iter().fold(0.0f64, |a, v| a.max(v.abs()))
}
