//! Linearization about an equilibrium on the constraint manifold, modes, and the linear
//! frequency response.
//!
//! With N an orthonormal basis of the null space of A at the equilibrium q* (n × k) and
//! independent coordinates ξ, q ≈ q* + N ξ:
//!
//! ```text
//! M_r = Nᵀ M N,   C_r = Nᵀ C N,   K_r = Nᵀ K N
//! C = −∂f̄/∂v,     K = −(∂f̄/∂q + Σ λ_i ∇²Φ_i)      (f̄: forces averaged over a period)
//! ```
//!
//! The λ term is the stiffness of the constraint reactions. The second-order terms of the
//! manifold's parametrization multiply the total generalized force f̄ + Aᵀλ, which is zero
//! at equilibrium, so nothing else enters.
//!
//! Harmonic forcing enters two ways: loads f(q*, 0, t) (a force, a damper to a moving
//! anchor) with first harmonic F, and moving constraints Φ(q*, t) (base excitation) with
//! first harmonic P. The response y = Im[Y e^{iωt}] is Y = N η + Y_p with the particular
//! solution Y_p = −A⁺ P of the linearized constraints A Y + P = 0 and
//!
//! ```text
//! (Nᵀ Z N) η = Nᵀ (F − Z Y_p),    Z = K − ω² M + iω C   (n × n)
//! ```
//!
//! Modes: eigenvalues of the state matrix [0 I; −M_r⁻¹K_r −M_r⁻¹C_r] (nalgebra, Schur);
//! each shape is the null vector of the complex matrix λ²M_r + λC_r + K_r (complex SVD),
//! mapped back to the model's coordinates by N. Undamped: eig(M_r⁻¹ K_r).

pub mod sensitivity;
pub mod tracking;

use crate::diag::{Error, Result};
use crate::failure::Failure;
use crate::request::{Argument, Invalid, parameter};
use crate::statics::{Equilibrium, Statics, generalized_eigenvalues};
use crate::system::System;
use crate::system::outputs::Output;
use nalgebra::{Complex, DMatrix, DVector};
use num_dual::Dual64;

/// The reduced linear system about an equilibrium.
#[derive(Debug, Clone)]
pub struct Linearization {
    /// Equilibrium coordinates (n).
    pub q: Vec<f64>,
    /// Null-space basis (n × k).
    pub basis: DMatrix<f64>,
    /// Reduced mass, damping, stiffness (k × k).
    pub mass: DMatrix<f64>,
    pub damping: DMatrix<f64>,
    pub stiffness: DMatrix<f64>,
    /// The same in the model's coordinates (n × n): M, C, K.
    pub full_mass: DMatrix<f64>,
    pub full_damping: DMatrix<f64>,
    pub full_stiffness: DMatrix<f64>,
    /// The mean constraint Jacobian Ā at q* (m × n).
    pub jacobian: DMatrix<f64>,
}

/// The first harmonics of a model's forcing at rest at an equilibrium, so that
/// f − f̄ = Im[F e^{iωt}] and Φ − Φ̄ = Im[P e^{iωt}].
#[derive(Debug, Clone)]
pub struct Forcing {
    /// Generalized force, including the constraint reactions' change (n).
    pub force: DVector<Complex<f64>>,
    /// Constraint function: the motion of the constraints (m).
    pub constraint: DVector<Complex<f64>>,
}

/// One mode.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Mode {
    /// |λ|, rad/s.
    pub omega_n_rad_s: f64,
    /// Im λ ≥ 0, rad/s (0 for a real eigenvalue).
    pub omega_d_rad_s: f64,
    /// ω_n / 2π.
    pub freq_hz: f64,
    /// −Re λ / |λ|.
    pub damping_ratio: f64,
    pub eigenvalue: C64,
    /// Shape in the model's coordinates (n), normalized to the reference coordinate.
    pub shape: Vec<C64>,
    /// The coordinate (index) whose entry is 1: the requested reference, or the largest
    /// entry when the reference does not move in this mode.
    pub normalized_to: usize,
}

/// How a mode moves, from its eigenvalue λ and the round-off threshold of its analysis
/// ([`ModalAnalysis::threshold`]): the one verdict every command gives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Motion {
    /// A complex pair with Re λ ≤ threshold: a (damped, or undamped) oscillation.
    Oscillating,
    /// A complex pair with Re λ > threshold: an oscillation that grows (negative damping,
    /// flutter); its ω_n, f and ζ (< 0) still describe its frequency.
    GrowingOscillation,
    /// A real λ > threshold: grows as e^(+λt) without oscillating (a divergence, about a
    /// statically unstable equilibrium).
    Divergent,
    /// A real λ < −threshold: decays as e^(λt) without oscillating (an overdamped mode, or
    /// the decaying partner of a saddle's divergence).
    Decaying,
    /// A real λ within round-off of 0: a neutral direction (a mechanism free to drift).
    Neutral,
}

impl Motion {
    /// Re λ > threshold: the mode grows and its equilibrium is dynamically unstable.
    pub fn grows(self) -> bool {
        matches!(self, Motion::GrowingOscillation | Motion::Divergent)
    }
    /// A real eigenvalue: no frequency, no damping ratio.
    pub fn is_real(self) -> bool {
        matches!(self, Motion::Divergent | Motion::Decaying | Motion::Neutral)
    }
}

impl Mode {
    /// How the mode moves, with `threshold` (1/s) the round-off below which a real part is
    /// zero ([`ModalAnalysis::threshold`]; [`ModalAnalysis::motion`] passes it).
    pub fn motion(&self, threshold: f64) -> Motion {
        let re = self.eigenvalue.re;
        match (self.omega_d_rad_s > 0.0, re > threshold, re < -threshold) {
            (true, true, _) => Motion::GrowingOscillation,
            (true, false, _) => Motion::Oscillating,
            (false, true, _) => Motion::Divergent,
            (false, false, true) => Motion::Decaying,
            (false, false, false) => Motion::Neutral,
        }
    }

    /// The mode's numbers as `modes --json` and the report's sidecar give them
    /// ([`ModeFields`]); `threshold` as in [`Mode::motion`].
    pub fn fields(&self, threshold: f64) -> ModeFields {
        let motion = self.motion(threshold);
        // a real eigenvalue has no frequency: ω_n = |λ| and ζ = ∓1 would describe one
        let oscillating = |x: f64| (!motion.is_real()).then_some(x);
        let growth = motion.grows().then_some(self.eigenvalue.re);
        let decay = (motion == Motion::Decaying).then_some(-self.eigenvalue.re);
        ModeFields {
            omega_n_rad_s: oscillating(self.omega_n_rad_s),
            omega_d_rad_s: self.omega_d_rad_s,
            freq_hz: oscillating(self.freq_hz),
            damping_ratio: oscillating(self.damping_ratio),
            eigenvalue: self.eigenvalue,
            divergent: motion == Motion::Divergent,
            growth_rate_1_s: growth,
            time_constant_s: growth.map(|r| 1.0 / r),
            motion,
            growing: motion.grows(),
            non_oscillatory: motion.is_real(),
            decay_rate_1_s: decay,
            decay_time_constant_s: decay.map(|r| 1.0 / r),
        }
    }
}

/// A mode's numbers in JSON (`modes --json`'s modes and the report's sidecar, one
/// constructor: [`Mode::fields`]). A real eigenvalue (divergent, decaying or neutral) has
/// `null` ω_n, f and ζ: it does not oscillate. A growing oscillation keeps them (ζ < 0).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ModeFields {
    /// |λ|, rad/s; `null` for a real eigenvalue.
    pub omega_n_rad_s: Option<f64>,
    /// |Im λ|, rad/s (0 for a real eigenvalue).
    pub omega_d_rad_s: f64,
    /// ω_n / 2π, Hz; `null` for a real eigenvalue.
    pub freq_hz: Option<f64>,
    /// −Re λ / |λ|; `null` for a real eigenvalue, negative for a growing oscillation.
    pub damping_ratio: Option<f64>,
    pub eigenvalue: C64,
    /// A real eigenvalue above round-off: grows as e^(+λt) without oscillating.
    pub divergent: bool,
    /// Re λ of a growing mode (divergent, or a growing oscillation), 1/s; `null` otherwise.
    pub growth_rate_1_s: Option<f64>,
    /// 1/Re λ of a growing mode, s; `null` otherwise.
    pub time_constant_s: Option<f64>,
    /// `oscillating`, `growing_oscillation`, `divergent`, `decaying` or `neutral`.
    pub motion: Motion,
    /// Re λ above round-off (divergent or a growing oscillation): the equilibrium is
    /// dynamically unstable.
    pub growing: bool,
    /// A real eigenvalue: no frequency (divergent, decaying or neutral).
    pub non_oscillatory: bool,
    /// −λ of a decaying real mode, 1/s; `null` otherwise.
    pub decay_rate_1_s: Option<f64>,
    /// 1/(−λ) of a decaying real mode, s; `null` otherwise.
    pub decay_time_constant_s: Option<f64>,
}

/// A complex number as `{re, im}`.
#[derive(Debug, Clone, Copy, serde::Serialize, PartialEq)]
pub struct C64 {
    pub re: f64,
    pub im: f64,
}

impl C64 {
    /// The modulus |z| (by `hypot`).
    pub fn norm(&self) -> f64 {
        self.re.hypot(self.im)
    }
}

impl From<Complex<f64>> for C64 {
    fn from(c: Complex<f64>) -> Self {
        C64 { re: c.re, im: c.im }
    }
}

/// ∂f̄/∂v at rest (n × n), by dual numbers.
fn velocity_jacobian(st: &Statics, q: &[f64]) -> DMatrix<f64> {
    let sys: &System = &st.sys;
    let n = sys.n();
    let times = st.times();
    let qd: Vec<Dual64> = q.iter().map(|&x| Dual64::from(x)).collect();
    let mut vd = vec![Dual64::from(0.0); n];
    let mut f = vec![Dual64::from(0.0); n];
    let mut c = DMatrix::zeros(n, n);
    for j in 0..n {
        vd[j].eps = 1.0;
        for &t in times {
            sys.forces(&qd, &vd, Dual64::from(t), &mut f);
            for i in 0..n {
                c[(i, j)] += f[i].eps / times.len() as f64;
            }
        }
        vd[j].eps = 0.0;
    }
    c
}

impl Linearization {
    /// Linearize about an equilibrium.
    pub fn new(st: &Statics, eq: &Equilibrium) -> Linearization {
        let jacobian = st.mean_jacobian(&eq.q);
        let basis = crate::statics::null_space_of(&jacobian);
        let full_stiffness = st.stiffness(&eq.q, &eq.lambda);
        let full_damping = -velocity_jacobian(st, &eq.q);
        let full_mass = st.sys.mass_matrix_at(&eq.q);
        let stiffness = basis.transpose() * &full_stiffness * &basis;
        let damping = basis.transpose() * &full_damping * &basis;
        let mass = basis.transpose() * &full_mass * &basis;
        Linearization {
            q: eq.q.clone(),
            basis,
            mass,
            damping,
            stiffness,
            full_mass,
            full_damping,
            full_stiffness,
            jacobian,
        }
    }

    /// Degrees of freedom k.
    pub fn dof(&self) -> usize {
        self.basis.ncols()
    }

    /// Undamped ω² = eig(M_r⁻¹ K_r), rad²/s², ascending (negative where unstable).
    pub fn undamped_omega2(&self) -> Vec<f64> {
        generalized_eigenvalues(&self.stiffness, &self.mass)
    }

    /// Damped modes sorted by ω_n; one per complex pair, every real eigenvalue. Shapes are
    /// normalized so that coordinate `reference` is 1 (if it moves in that mode).
    pub fn modes(&self, reference: usize) -> Result<Vec<Mode>> {
        let k = self.dof();
        if k == 0 {
            return Ok(Vec::new());
        }
        crate::linalg::check_finite(&self.mass, "reduced mass matrix")?;
        crate::linalg::check_finite(&self.stiffness, "reduced stiffness matrix")?;
        crate::linalg::check_finite(&self.damping, "reduced damping matrix")?;
        let minv = self
            .mass
            .clone()
            .try_inverse()
            .ok_or(Failure::NonFiniteResult {
                quantity: "the inverse of the reduced mass matrix (singular)".into(),
                value: f64::INFINITY,
            })?;
        let mut s = DMatrix::zeros(2 * k, 2 * k);
        s.view_mut((0, k), (k, k))
            .copy_from(&DMatrix::identity(k, k));
        s.view_mut((k, 0), (k, k))
            .copy_from(&(-&minv * &self.stiffness));
        s.view_mut((k, k), (k, k))
            .copy_from(&(-&minv * &self.damping));
        let eig = crate::linalg::complex_eigenvalues(s, "state matrix [0 I; −M⁻¹K −M⁻¹C]")?;
        let mut modes: Vec<Mode> = Vec::new();
        for lam in eig.iter() {
            let scale = lam.norm().max(1e-300);
            if lam.im < -1e-12 * scale {
                continue; // the conjugate of a listed mode
            }
            let lam = if lam.im.abs() <= 1e-12 * scale {
                Complex::new(lam.re, 0.0)
            } else {
                *lam
            };
            let x = self.shape(lam);
            // λ² M + λ C + K overflows for |λ| beyond ~1e154 (a damper near 1e160)
            if let Some(z) = x.iter().find(|z| !(z.re.is_finite() && z.im.is_finite())) {
                return Err(Failure::NonFiniteResult {
                    quantity: if lam.im == 0.0 {
                        format!(
                            "the shape of the mode at λ = {} 1/s",
                            crate::diag::num(lam.re)
                        )
                    } else {
                        format!(
                            "the shape of the mode at λ = {} ± {}i 1/s",
                            crate::diag::num(lam.re),
                            crate::diag::num(lam.im.abs())
                        )
                    },
                    value: if z.re.is_finite() { z.im } else { z.re },
                }
                .into());
            }
            let full = self.basis.map(|v| Complex::new(v, 0.0)) * x;
            let r = full[reference];
            let imax = (0..full.len())
                .max_by(|&i, &j| full[i].norm().total_cmp(&full[j].norm()))
                .unwrap_or(0);
            // normalize to the largest entry when the reference does not move
            let (norm, normalized_to) = if r.norm() > 1e-9 * full[imax].norm() {
                (r, reference)
            } else {
                (full[imax], imax)
            };
            let shape: Vec<C64> = full.iter().map(|c| (c / norm).into()).collect();
            let wn = lam.norm();
            modes.push(Mode {
                omega_n_rad_s: wn,
                omega_d_rad_s: lam.im.abs(),
                freq_hz: wn / (2.0 * std::f64::consts::PI),
                damping_ratio: if wn > 0.0 { -lam.re / wn } else { 0.0 },
                eigenvalue: lam.into(),
                shape,
                normalized_to,
            });
        }
        modes.sort_by(|a, b| {
            a.omega_n_rad_s
                .total_cmp(&b.omega_n_rad_s)
                .then(a.eigenvalue.re.total_cmp(&b.eigenvalue.re))
        });
        Ok(modes)
    }

    /// Null vector of λ²M_r + λC_r + K_r (right singular vector of the smallest
    /// singular value).
    fn shape(&self, lam: Complex<f64>) -> DVector<Complex<f64>> {
        let c = |m: &DMatrix<f64>| m.map(|v| Complex::new(v, 0.0));
        let p = c(&self.mass) * (lam * lam) + c(&self.damping) * lam + c(&self.stiffness);
        let k = p.ncols();
        let svd = crate::linalg::svd_or_nan(p, false, true);
        let v_t = svd.v_t.expect("requested");
        let imin = (0..k)
            .min_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]))
            .unwrap_or(0);
        v_t.row(imin).transpose().map(|z| z.conj())
    }

    /// Steady response amplitudes of all coordinates to a harmonic forcing (a generalized
    /// force Im[F e^{iωt}] and a constraint motion Im[P e^{iωt}]): returns the complex
    /// amplitudes Y (n), q(t) − q* = Im[Y e^{iωt}].
    pub fn response(&self, omega: f64, forcing: &Forcing) -> Result<DVector<Complex<f64>>> {
        let c = |m: &DMatrix<f64>| m.map(|v| Complex::new(v, 0.0));
        let nb = c(&self.basis);
        let dynamic = c(&self.stiffness) - c(&self.mass) * Complex::new(omega * omega, 0.0)
            + c(&self.damping) * Complex::new(0.0, omega);
        // ω²M overflows above ω ≈ 1e154 rad/s: an error, not a row of NaN
        crate::linalg::check_finite(
            &dynamic,
            &format!(
                "dynamic stiffness K − ω²M + iωC at ω = {} rad/s",
                crate::diag::num(omega)
            ),
        )?;
        let moving = forcing.constraint.iter().any(|z| z.norm() > 0.0);
        let particular = if moving {
            // Y_p = −Ā⁺ P (minimum norm), real and imaginary parts separately
            let a = self.jacobian.clone();
            let re =
                crate::statics::solve_least_squares(a.clone(), &forcing.constraint.map(|z| -z.re));
            let im = crate::statics::solve_least_squares(a, &forcing.constraint.map(|z| -z.im));
            Some(DVector::from_fn(re.len(), |i, _| {
                Complex::new(re[i], im[i])
            }))
        } else {
            None
        };
        let rhs = match &particular {
            None => nb.transpose() * &forcing.force,
            Some(yp) => {
                let z = c(&self.full_stiffness)
                    - c(&self.full_mass) * Complex::new(omega * omega, 0.0)
                    + c(&self.full_damping) * Complex::new(0.0, omega);
                nb.transpose() * (&forcing.force - z * yp)
            }
        };
        // Singular relative to the size of its terms (not to its own largest singular
        // value, which for one degree of freedom is the smallest one too).
        let scale =
            self.stiffness.norm() + omega * omega * self.mass.norm() + omega * self.damping.norm();
        let sv = crate::linalg::svd_or_nan(dynamic.clone(), false, false).singular_values;
        if !sv.is_empty() && sv.min() <= 1e-10 * scale {
            return Err(Failure::UndampedResonance { omega }.into());
        }
        let x = dynamic
            .lu()
            .solve(&rhs)
            .ok_or(Failure::UndampedResonance { omega })?;
        let y = match particular {
            None => nb * x,
            Some(yp) => nb * x + yp,
        };
        if let Some(v) = y.iter().find(|z| !(z.re.is_finite() && z.im.is_finite())) {
            return Err(Failure::NonFiniteResult {
                quantity: format!(
                    "a response amplitude at ω = {} rad/s",
                    crate::diag::num(omega)
                ),
                value: if v.re.is_finite() { v.im } else { v.re },
            }
            .into());
        }
        Ok(y)
    }
}

/// First harmonics of the forcing at rest at the equilibrium `eq` (independent
/// constraint rows `rows`) over one period of ω: the generalized force
/// f(q*, 0, t) + A(q*, t)ᵀ λ* and the constraint function Φ(q*, t), each
/// ≈ mean + a sin ωt + b cos ωt, returned as a + i b (so x − x̄ = Im[X e^{iωt}]).
pub fn forcing_harmonics(sys: &System, eq: &Equilibrium, rows: &[usize], omega: f64) -> Forcing {
    const SAMPLES: usize = 64;
    let (n, m) = (sys.n(), sys.m());
    let q = &eq.q;
    let zero = vec![0.0; n];
    let mut f = vec![0.0; n];
    let mut force = DVector::from_element(n, Complex::new(0.0, 0.0));
    let mut constraint = DVector::from_element(m, Complex::new(0.0, 0.0));
    if omega == 0.0 {
        return Forcing { force, constraint };
    }
    let mut ws = crate::dynamics::DynWorkspace::new(sys);
    let lambda = DVector::from_column_slice(&eq.lambda);
    let period = 2.0 * std::f64::consts::PI / omega.abs();
    for k in 0..SAMPLES {
        let t = k as f64 * period / SAMPLES as f64;
        sys.forces(q, &zero, t, &mut f);
        let (s, c) = (omega * t).sin_cos();
        let w = 2.0 / SAMPLES as f64;
        if sys.rheonomic {
            // the constraints move: their reactions turn with them, and Φ(q*, t) ≠ 0
            sys.jacobian(&mut ws.sys, q, t, &mut ws.a);
            let reaction = ws.a.select_rows(rows.iter()).transpose() * &lambda;
            for i in 0..n {
                f[i] += reaction[i];
            }
            let phi = sys.residual(q, t);
            for i in 0..m {
                constraint[i] += Complex::new(phi[i] * s, phi[i] * c) * w;
            }
        }
        for i in 0..n {
            force[i] += Complex::new(f[i] * s, f[i] * c) * w;
        }
    }
    Forcing { force, constraint }
}

/// Modes about the equilibrium nearest a model's initial pose.
#[derive(Debug, Clone)]
pub struct ModalAnalysis {
    pub coordinates: Vec<String>,
    pub equilibrium: Equilibrium,
    pub linearization: Linearization,
    /// Damped modes sorted by ω_n.
    pub modes: Vec<Mode>,
    /// Undamped ω², rad²/s², ascending.
    pub undamped_omega2: Vec<f64>,
    /// Index of the coordinate the shapes are normalized to.
    pub reference: usize,
    /// The independent constraint rows of the equilibrium (its multipliers' rows).
    pub rows: Vec<usize>,
}

/// How far above the round-off of a double eigenvalue at 0 a real part must lie to be
/// growth (or decay): a neutral direction (a Jordan block at 0) is computed as
/// ±√(ε‖A‖), ‖A‖ the size of the first-order matrix [0 I; −M⁻¹K −M⁻¹C] in SI (see
/// [`ModalAnalysis::threshold`]); this factor is the margin over it.
pub const GROWTH_ROUND_OFF: f64 = 10.0;

impl ModalAnalysis {
    /// The real part (1/s) below which a mode neither grows nor decays:
    /// [`GROWTH_ROUND_OFF`] × √(ε‖A‖), with ‖A‖ = max(1, max |undamped ω²|, max |λ|) the
    /// largest entry scale of the first-order matrix (its identity block, its stiffness
    /// block M⁻¹K, its damping block M⁻¹C, whose stiff entries c/m are a damper mode's
    /// |λ|). About 5e-7 1/s on the overcentre. Not a fraction of the largest |λ| (as first
    /// written, 1e-6 of it): a stiff damper (|λ| = c/m = 1e8 1/s) then read a divergence
    /// of +20 1/s as neutral, and `margins` passed it.
    pub fn threshold(&self) -> f64 {
        let stiffness = self
            .undamped_omega2
            .iter()
            .fold(0.0f64, |m, w| m.max(w.abs()));
        let largest = self
            .modes
            .iter()
            .map(|m| m.omega_n_rad_s)
            .fold(0.0, f64::max);
        let norm = 1.0f64.max(stiffness).max(largest);
        GROWTH_ROUND_OFF * (f64::EPSILON * norm).sqrt()
    }

    /// How mode `k` moves ([`Mode::motion`] at this analysis's threshold).
    pub fn motion(&self, k: usize) -> Motion {
        self.modes[k].motion(self.threshold())
    }

    /// Mode `k`'s JSON numbers ([`Mode::fields`] at this analysis's threshold).
    pub fn fields(&self, k: usize) -> ModeFields {
        self.modes[k].fields(self.threshold())
    }

    /// The modes that grow (Re λ above round-off), by index in `modes`: the one
    /// predicate of "unstable" for `modes`, `margins`, `sensitivity`, `tune` and the report.
    pub fn growing(&self) -> Vec<usize> {
        let t = self.threshold();
        (0..self.modes.len())
            .filter(|&k| self.modes[k].motion(t).grows())
            .collect()
    }

    /// Dynamic stability: no mode grows. `None` with no degrees of freedom (nothing
    /// moves, nothing to claim). Static stability (every undamped ω² > 0) is
    /// `equilibrium.stable`: with negative damping an equilibrium is statically stable
    /// and dynamically unstable.
    pub fn dynamically_stable(&self) -> Option<bool> {
        (self.linearization.dof() > 0).then(|| self.growing().is_empty())
    }

    /// The fastest-growing mode's index, if any grows.
    pub fn fastest_growing(&self) -> Option<usize> {
        self.growing().into_iter().max_by(|&a, &b| {
            self.modes[a]
                .eigenvalue
                .re
                .total_cmp(&self.modes[b].eigenvalue.re)
        })
    }
}

/// A growth (or decay) rate, 1/s, as the text shows it: `decimals` decimals from 1e-3 up
/// (`+0.1300`), 4 significant digits in scientific notation below (`+1.000e-4`: a slow
/// growth is not printed as `+0.0000`); `signed` prefixes `+` to a positive rate.
pub fn rate_text(rate: f64, decimals: usize, signed: bool) -> String {
    match (rate != 0.0 && rate.abs() < 1e-3, signed) {
        (true, true) => format!("{rate:+.3e}"),
        (true, false) => format!("{rate:.3e}"),
        (false, true) => format!("{rate:+.decimals$}"),
        (false, false) => format!("{rate:.decimals$}"),
    }
}

/// The one sentence every command gives for a model with no degrees of freedom (every
/// coordinate fixed or driven by a constraint): `the model has no degrees of freedom (its
/// constraints fix or drive every one of its 3 coordinates): it has no modes`. Each
/// command adds what follows for it (`, so nothing can resonate`).
pub fn no_modes_words(sys: &System) -> String {
    format!(
        "the model has no degrees of freedom (its constraints fix or drive every one of its {} coordinates): it has no modes",
        sys.nq()
    )
}

/// How a growing mode grows, in words: `mode 1 grows as e^(+0.1300 t), oscillating at
/// 2.9703 rad/s`, or `mode 3 diverges as e^(+19.9950 t) without oscillating`.
pub fn growth_words(u: &crate::margins::UnstableMode) -> String {
    if u.omega_d_rad_s > 0.0 {
        format!(
            "{} grows as e^({} t), oscillating at {:.4} rad/s",
            u.mode,
            rate_text(u.growth_rate_1_s, 4, true),
            u.omega_d_rad_s
        )
    } else {
        format!(
            "{} diverges as e^({} t) without oscillating",
            u.mode,
            rate_text(u.growth_rate_1_s, 4, true)
        )
    }
}

/// An equilibrium's stability in words, both truths: static (`stable`: every undamped
/// ω² positive) and dynamic (`dynamic`: no mode grows; `growing` the growing modes, as
/// [`crate::margins::unstable_modes`] gives them). `None` for either: no degrees of
/// freedom. E.g. `statically stable, dynamically UNSTABLE (mode 1 grows as e^(+0.130 t),
/// oscillating at 2.970 rad/s)`; plain `stable` when both hold.
pub fn stability_words(
    stable: Option<bool>,
    dynamic: Option<bool>,
    growing: &[crate::margins::UnstableMode],
) -> String {
    let how = || {
        growing
            .iter()
            .map(growth_words)
            .collect::<Vec<_>>()
            .join("; ")
    };
    match (stable, dynamic) {
        (None, _) | (_, None) => "no degrees of freedom".into(),
        (Some(true), Some(true)) => "stable".into(),
        (Some(true), Some(false)) => {
            format!("statically stable, dynamically UNSTABLE ({})", how())
        }
        (Some(false), Some(false)) => {
            format!("UNSTABLE, statically and dynamically ({})", how())
        }
        (Some(false), Some(true)) => {
            "statically UNSTABLE or neutral (an undamped ω² ≤ 0), dynamically: no mode grows".into()
        }
    }
}

/// Index of a coordinate by name, or the invalid request: `argument` names no coordinate.
pub fn coordinate(sys: &System, name: &str, argument: Argument) -> Result<usize> {
    Ok(crate::request::coordinate(
        &sys.coordinates,
        name,
        argument,
    )?)
}

/// The first angle coordinate (by its dimension), else the first.
pub fn default_reference(sys: &System) -> usize {
    (0..sys.n()).find(|&i| sys.is_angle(i)).unwrap_or(0)
}

/// Equilibrium nearest the initial pose, linearization, modes.
pub fn modal_analysis(sys: &System, normalize: Option<&str>) -> Result<ModalAnalysis> {
    let reference = match normalize {
        Some(name) => coordinate(sys, name, Argument::Normalize)?,
        None => default_reference(sys),
    };
    let start = crate::dynamics::assemble_at_rest(sys)?;
    let st = Statics::new(sys, &start.q)?;
    let equilibrium = st.nearest(&start)?;
    modal_analysis_at(sys, &st, equilibrium, reference)
}

/// The modal analysis about a given `equilibrium` of `st` (`equilibrium --all` has
/// several), shapes normalized to coordinate `reference`.
pub fn modal_analysis_at(
    sys: &System,
    st: &Statics,
    equilibrium: crate::statics::Equilibrium,
    reference: usize,
) -> Result<ModalAnalysis> {
    let linearization = Linearization::new(st, &equilibrium);
    let modes = linearization.modes(reference)?;
    let undamped_omega2 = linearization.undamped_omega2();
    Ok(ModalAnalysis {
        coordinates: sys.coordinates.clone(),
        equilibrium,
        linearization,
        modes,
        undamped_omega2,
        reference,
        rows: st.rows.clone(),
    })
}

/// A request for the response at `values` of `param` (`frf`, `sweep`): `param` must be
/// the model's forcing frequency, and the frequencies positive and finite (rad/s).
/// Returns the parameter's index.
pub fn check_frequencies(sys: &System, param: &str, values: &[f64]) -> Result<usize> {
    let index = parameter(sys.param_names(), param, Argument::FrequencyParameter)?;
    match sys.forcing_param() {
        Some(f) if f != index => {
            // derived from it (`omega = w0/4`): its definition, for the words
            let definition = sys
                .param_definition(f)
                .filter(|_| sys.param_rate(f, index) != 0.0);
            return Err(Invalid::NotForcingFrequency {
                name: param.to_string(),
                forcing: sys.param_names()[f].clone(),
                definition,
            }
            .into());
        }
        None => return Err(Invalid::NoForcingFrequency.into()),
        _ => {}
    }
    if let Some(definition) = sys.param_definition(index) {
        return Err(Invalid::DerivedForcingFrequency {
            name: param.to_string(),
            definition,
        }
        .into());
    }
    let bad = values.iter().find(|w| !(**w > 0.0) || !w.is_finite());
    if values.is_empty() || bad.is_some() {
        return Err(Invalid::BadFrequencies {
            param: param.to_string(),
            value: bad.copied(),
        }
        .into());
    }
    Ok(index)
}

/// The system with its forcing-frequency parameter (index `param`) set to `omega`
/// (> 0): statics then averages the time-dependent loads over the forcing's period. (A
/// load that depends on time through ωt has the same mean at every ω ≠ 0; at a model's
/// own ω = 0 a `cos(omega*t)` load would be taken at its value at t = 0.)
pub fn at_frequency(sys: &System, param: usize, omega: f64) -> Result<System> {
    sys.with_param(param, omega)
}

/// The forcing harmonics at the equilibrium (see [`forcing_harmonics`]), or an error when
/// they are zero: zero forcing gives no response curve, not a curve of zeros.
pub fn harmonic_forcing(
    sys: &System,
    eq: &Equilibrium,
    rows: &[usize],
    param: &str,
    omega: f64,
) -> Result<Forcing> {
    let forcing = forcing_harmonics(sys, eq, rows, omega);
    // rounding of the constant loads leaves ~1e-16 of them in the harmonic sums
    let mut mean = vec![0.0; sys.n()];
    sys.forces(&eq.q, &vec![0.0; sys.n()], 0.0, &mut mean);
    let load = mean.iter().fold(1.0f64, |a, v| a.max(v.abs()));
    let size = 1.0 + eq.q.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    if forcing.force.iter().all(|c| c.norm() <= 1e-12 * load)
        && forcing.constraint.iter().all(|c| c.norm() <= 1e-14 * size)
    {
        return Err(Error::request(
            format!(
                "zero forcing: the model's loads have no harmonic part at {param} = {} rad/s",
                crate::diag::num(omega)
            ),
            "give the forcing (a load or a ground motion) an amplitude, or check that it depends on this parameter",
        ));
    }
    Ok(forcing)
}

/// Linear frequency response of some coordinates over values of the forcing frequency.
#[derive(Debug, Clone)]
pub struct FrequencyResponse {
    pub param: String,
    pub responses: Vec<String>,
    /// Frequencies, rad/s.
    pub omega: Vec<f64>,
    /// Per frequency, per response: (amplitude in SI, phase in degrees), q = q* + A sin(ωt + φ).
    pub values: Vec<Vec<(f64, f64)>>,
    pub equilibrium: Equilibrium,
    pub coordinates: Vec<String>,
    /// The interior local maxima of each response's amplitude on the grid, refined to the
    /// maximum of the linear response between the neighbouring grid points.
    pub peaks: Vec<LinearPeak>,
}

/// A maximum of a linear response's amplitude.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LinearPeak {
    pub response: String,
    /// rad/s.
    pub omega: f64,
    /// SI (rad for an angle).
    pub amplitude: f64,
    /// rad/s: the larger of the refinement's final half-bracket and the shift of the
    /// maximum that round-off in the amplitudes can cause (√(2δ/κ), κ = −A''/A there).
    pub uncertainty: f64,
}

/// The maximum of `f` on [a, b] (unimodal there) by golden-section search to `tol`:
/// (argument, value, final half-width).
fn golden_max(
    mut f: impl FnMut(f64) -> Result<f64>,
    mut a: f64,
    mut b: f64,
    tol: f64,
) -> Result<(f64, f64, f64)> {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (f(c)?, f(d)?);
    while (b - a) > tol {
        if fc >= fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = f(c)?;
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = f(d)?;
        }
    }
    let (x, v) = if fc >= fd { (c, fc) } else { (d, fd) };
    Ok((x, v, (b - a) / 2.0))
}

/// A response linearized about an equilibrium q*: its position-level quantity
/// h(q, v, t) ([`System::output_state`]) is h(q*, 0, t) + H_q δq + H_v δv to first order,
/// and the response is its `order`-th time derivative.
#[derive(Debug, Clone)]
pub struct LinearOutput {
    pub output: Output,
    /// ∂h/∂q and ∂h/∂v at (q*, 0) with the ground at its mean pose (empty for a
    /// coordinate, which is read from the response directly).
    pub hq: Vec<f64>,
    pub hv: Vec<f64>,
}

impl LinearOutput {
    /// Linearize `output` about `q` of `frozen`: the system with a moving ground held at
    /// its mean pose over the forcing period. A coordinate is read from the response
    /// directly, and a joint reaction is linearized through the multipliers (see
    /// `reaction_amplitude`): neither needs a gradient.
    pub fn new(frozen: &System, output: Output, q: &[f64]) -> Self {
        let (hq, hv) = match output {
            Output::Coordinate(_) | Output::Reaction { .. } => (Vec::new(), Vec::new()),
            _ => frozen.output_gradient(&output, q, 0.0),
        };
        LinearOutput { output, hq, hv }
    }

    /// The complex amplitude of the response at ω from the coordinates' Y: with
    /// q − q* = Im[Y e^{iωt}] (so δv = Im[iωY e^{iωt}]), the response less its mean is
    /// Im[(iω)^order (H_q Y + iω H_v Y + G) e^{iωt}], G the first harmonic of h(q*, 0, t)
    /// over a period (the moving ground's share: a spring's anchor, a `_rel` position).
    /// `sys` is the system at ω, moving ground and all.
    pub fn amplitude(
        &self,
        sys: &System,
        q: &[f64],
        omega: f64,
        y: &DVector<Complex<f64>>,
    ) -> Complex<f64> {
        if let Output::Coordinate(i) = self.output {
            return y[i];
        }
        let iw = Complex::new(0.0, omega);
        let mut z = Complex::new(0.0, 0.0);
        for (j, yj) in y.iter().enumerate() {
            z += yj * self.hq[j] + iw * yj * self.hv[j];
        }
        if sys.depends_on_time() {
            let zero = vec![0.0; sys.nv()];
            let w = 2.0 / PERIOD_SAMPLES as f64;
            for t in period_samples(omega) {
                let h: f64 = sys.output_state(&self.output, q, &zero, t);
                let (s, c) = (omega * t).sin_cos();
                z += Complex::new(h * s, h * c) * w;
            }
        }
        for _ in 0..self.output.order() {
            z *= iw;
        }
        z
    }
}

/// The complex amplitude of a joint reaction at ω, from the coordinates' response Y: the
/// multipliers' change Λ solves Āᵀ Λ = Z Y − F (the linearized equations of motion, Z =
/// K − ω²M + iωC, F the forcing's first harmonic), and δR = Bᵀ Λ + (∂B/∂q · Y)ᵀ λ* plus
/// the first harmonic of B(q*, t)ᵀ λ* (a constraint that moves with the ground). `sys` is
/// the system at ω, `frozen` the one the linearization saw (its ground at its mean pose).
#[allow(clippy::too_many_arguments)]
fn reaction_amplitude(
    sys: &System,
    frozen: &System,
    modal: &ModalAnalysis,
    forcing: &Forcing,
    y: &DVector<Complex<f64>>,
    omega: f64,
    element: usize,
    axis: usize,
) -> Complex<f64> {
    let lin = &modal.linearization;
    let eq = &modal.equilibrium;
    let c = |m: &DMatrix<f64>| m.map(|v| Complex::new(v, 0.0));
    let z = c(&lin.full_stiffness) - c(&lin.full_mass) * Complex::new(omega * omega, 0.0)
        + c(&lin.full_damping) * Complex::new(0.0, omega);
    let r = &z * y - &forcing.force;
    // Ā_r Ā_rᵀ Λ = Ā_r r, real and imaginary parts
    let ar = lin.jacobian.select_rows(modal.rows.iter());
    let g = &ar * ar.transpose();
    let solve = |b: DVector<f64>| crate::statics::solve_least_squares(g.clone(), &(&ar * b));
    let lre = solve(r.map(|x| x.re));
    let lim = solve(r.map(|x| x.im));
    let m = sys.m();
    let (mut lam, mut dre, mut dim) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
    for (k, &row) in modal.rows.iter().enumerate() {
        lam[row] = eq.lambda[k];
        dre[row] = lre[k];
        dim[row] = lim[k];
    }
    let yre: Vec<f64> = y.iter().map(|x| x.re).collect();
    let yim: Vec<f64> = y.iter().map(|x| x.im).collect();
    let mut out = Complex::new(
        frozen.reaction_variation(element, axis, &eq.q, 0.0, &lam, &dre, &yre),
        frozen.reaction_variation(element, axis, &eq.q, 0.0, &lam, &dim, &yim),
    );
    if sys.rheonomic {
        let w = 2.0 / PERIOD_SAMPLES as f64;
        for t in period_samples(omega) {
            let h = sys.reaction(element, axis, &eq.q, t, &lam);
            let (s, co) = (omega * t).sin_cos();
            out += Complex::new(h * s, h * co) * w;
        }
    }
    out
}

/// Samples of the forcing's period for the harmonics of the linear response.
const PERIOD_SAMPLES: usize = 64;

/// `PERIOD_SAMPLES` times over one period of ω.
fn period_samples(omega: f64) -> Vec<f64> {
    if omega == 0.0 {
        return vec![0.0];
    }
    let period = 2.0 * std::f64::consts::PI / omega.abs();
    (0..PERIOD_SAMPLES)
        .map(|k| k as f64 * period / PERIOD_SAMPLES as f64)
        .collect()
}

/// The steady harmonic response of the linearized system about the equilibrium nearest
/// the initial pose, to the model's forcing at each value of `param` (the forcing's
/// angular frequency, rad/s). Exact for the linear system. The responses are any that
/// [`System::output`] resolves (see [`LinearOutput`]).
pub fn frequency_response(
    sys: &System,
    param: &str,
    values: &[f64],
    responses: &[String],
) -> Result<FrequencyResponse> {
    frequency_response_until(
        sys,
        param,
        values,
        responses,
        &std::sync::atomic::AtomicBool::new(false),
    )
}

/// [`frequency_response`], stopped at the next frequency once `cancel` is set (by a
/// signal): [`crate::failure::Failure::StudyInterrupted`], nothing kept.
pub fn frequency_response_until(
    sys: &System,
    param: &str,
    values: &[f64],
    responses: &[String],
    cancel: &std::sync::atomic::AtomicBool,
) -> Result<FrequencyResponse> {
    let index = check_frequencies(sys, param, values)?;
    let mut at = at_frequency(sys, index, values[0])?;
    let outputs = at.outputs(responses)?;
    let modal = modal_analysis(&at, None)?;
    let q = modal.equilibrium.q.clone();
    // what the linearization saw of a moving ground (its mean pose at rest), once
    let frozen = at.with_ground_at_mean(&period_samples(values[0]));
    let linear: Vec<LinearOutput> = outputs
        .iter()
        .map(|o| LinearOutput::new(&frozen, *o, &q))
        .collect();
    let rows = modal.rows.clone();
    let mut out = Vec::with_capacity(values.len());
    for &w in values {
        if cancel.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(crate::failure::Failure::StudyInterrupted {
                what: "the linear frequency response".into(),
                kept: false,
            }
            .into());
        }
        at.set_param(index, w)?;
        let forcing = harmonic_forcing(&at, &modal.equilibrium, &rows, param, w)?;
        let y = modal.linearization.response(w, &forcing)?;
        out.push(
            linear
                .iter()
                .map(|l| {
                    let z = match l.output {
                        Output::Reaction { element, axis } => {
                            reaction_amplitude(&at, &frozen, &modal, &forcing, &y, w, element, axis)
                        }
                        _ => l.amplitude(&at, &q, w, &y),
                    };
                    (z.norm(), z.arg().to_degrees())
                })
                .collect::<Vec<_>>(),
        );
    }
    let mut peaks = Vec::new();
    // the largest amplitude of any response: a response whose own largest is round-off
    // beside it (a coordinate the forcing does not move, 1e-16 m/m) has no peaks
    let largest = out
        .iter()
        .flat_map(|row| row.iter().map(|x| x.0))
        .filter(|x| x.is_finite())
        .fold(0.0, f64::max);
    for (r, l) in linear.iter().enumerate() {
        let a: Vec<f64> = out.iter().map(|row: &Vec<(f64, f64)>| row[r].0).collect();
        let own = a
            .iter()
            .copied()
            .filter(|x| x.is_finite())
            .fold(0.0, f64::max);
        if own <= 1e-12 * largest {
            continue;
        }
        for k in 1..a.len().saturating_sub(1) {
            // a local maximum that stands above round-off (a coordinate that follows the
            // base rigidly has |H| = 1 to the last digit, with no peak)
            if !(a[k] > a[k - 1] && a[k] >= a[k + 1]) || a[k] - a[k - 1].min(a[k + 1]) <= 1e-9 * own
            {
                continue;
            }
            let amp = |w: f64| -> Result<f64> {
                at.set_param(index, w)?;
                let forcing = harmonic_forcing(&at, &modal.equilibrium, &rows, param, w)?;
                let y = modal.linearization.response(w, &forcing)?;
                Ok(match l.output {
                    Output::Reaction { element, axis } => {
                        reaction_amplitude(&at, &frozen, &modal, &forcing, &y, w, element, axis)
                    }
                    _ => l.amplitude(&at, &q, w, &y),
                }
                .norm())
            };
            let (lo, hi) = (values[k - 1], values[k + 1]);
            let tol = 1e-10 * hi.abs().max(1.0);
            let mut amp = amp;
            let (w, amplitude, half) = golden_max(&mut amp, lo, hi, tol)?;
            // the bracket is not the whole error: near a maximum A ≈ A_p (1 − κ (ω − ω_p)²
            // / 2), so a relative round-off δ of the amplitudes moves the located maximum by
            // up to √(2δ/κ) (about 1e-8 rad/s where the bracket says 1e-10: the responses of
            // one mode then differ in their 8th digit). κ from a second difference well
            // above round-off; δ = 64 ε, the linear solve's.
            let h = 0.01 * (hi - lo);
            let curvature = (2.0 * amplitude - amp(w + h)? - amp(w - h)?) / (h * h * amplitude);
            let floor = if curvature > 0.0 && curvature.is_finite() {
                (2.0 * 64.0 * f64::EPSILON / curvature).sqrt()
            } else {
                0.0
            };
            peaks.push(LinearPeak {
                response: responses[r].clone(),
                omega: w,
                amplitude,
                uncertainty: half.max(floor),
            });
        }
    }
    Ok(FrequencyResponse {
        param: param.to_string(),
        responses: responses.to_vec(),
        omega: values.to_vec(),
        values: out,
        equilibrium: modal.equilibrium,
        coordinates: modal.coordinates,
        peaks,
    })
}

/// The largest frequency grid, in steps.
const MAX_POINTS: usize = 10_000_000;

/// `from, from + step, ..., to` (to included when it falls on the grid within rounding).
pub fn grid(from: f64, to: f64, step: f64) -> Result<Vec<f64>> {
    if !(from.is_finite() && to.is_finite()) || to < from {
        return Err(Invalid::Range {
            what: Argument::Frequencies,
            from,
            to,
        }
        .into());
    }
    if !(step > 0.0) || !step.is_finite() {
        return Err(Invalid::NotPositive {
            argument: Argument::FrequencyStep,
            value: step,
        }
        .into());
    }
    let n = ((to - from) / step + 1e-9).floor();
    if n > MAX_POINTS as f64 {
        return Err(Invalid::TooManyPoints {
            argument: Argument::FrequencyStep,
            value: step,
            points: n,
            limit: MAX_POINTS,
        }
        .into());
    }
    // from + k·step rounded to the step's decimals, so 0.5 + 7·0.1 is written 1.2, not
    // 1.2000000000000002.
    let size = if from == 0.0 {
        step
    } else {
        step.min(from.abs())
    };
    let n = n as usize;
    Ok((0..=n)
        .map(|k| round_to_step(from + k as f64 * step, size))
        .collect())
}

/// `v` rounded to 9 more decimals than `size` has (at most 15), where `size` is the
/// finest magnitude that matters (a step, and the start of a grid): removes the binary
/// noise of sums of decimal steps while moving a value by less than 1e-9 of `size`.
pub fn round_to_step(v: f64, size: f64) -> f64 {
    let size = size.abs();
    if size == 0.0 || !size.is_finite() {
        return v;
    }
    let digits = (9.0 - size.log10().floor()).clamp(0.0, 15.0) as i32;
    let scale = 10f64.powi(digits);
    let r = (v * scale).round() / scale;
    if r.is_finite() { r } else { v }
}
