//! DOP853 stepping that allocates nothing per step or per sample.
//!
//! Hand-written, and why: `differential-equations` 0.7.0's `ExplicitRungeKutta::dop853`
//! (which detune used before) clones a state vector for every stage, for the error
//! estimate, for every dense-output coefficient and for every interpolated sample (about
//! 30 heap allocations a step and 2 a sample); on the overcentre's 20 s free case
//! (80 steps, 2001 samples) allocation and copying were about a sixth of the run, and most
//! of the hand-written minimal model's. `ode_solvers`' `Dop853` is allocation-free only
//! on fixed-size nalgebra vectors (a model's dimension is known at run time only; on a
//! `DVector` its stage expressions allocate) and integrates a whole interval through its
//! own output callback rather than stepping under the caller's control (the drift
//! projections restart the integration from a changed state); neither it nor any other
//! crate would give the numbers detune has pinned so far. This is the same method,
//! written to perform **the same
//! floating-point operations in the same order** as that crate's step, initial step size
//! and interpolant (coefficients taken from the crate's own tableau,
//! `ButcherTableau::dop853`), on buffers made once per integration. So the steps, their
//! acceptance and every sample are the same numbers to the last bit; tests/dop853.rs
//! checks this against the crate on several problems.
//!
//! It also keeps the crate's behaviour where it matters to a run: the initial step
//! estimate (Hairer's `HINIT` as the crate writes it), the step-size control (safety 0.9,
//! factors within [0.2, 10], no growth right after a rejection), the step-size collapse
//! error, and the crate's own stiffness stop (every 100th step; see
//! [`Dop853::step_in_place`]). The dense output is Hairer's DOP853 interpolant, evaluated
//! as [`super::integrator`] corrected the crate's (its 7th-degree part has θ and 1 − θ
//! swapped) with the same arithmetic.
//!
//! It implements the crate's `OrdinaryNumericalMethod` and `Interpolation` traits, so the
//! integrator's step loop drives it as it drives the crate's Radau IIA.

use differential_equations::error::Error;
use differential_equations::interpolate::Interpolation;
use differential_equations::ode::{ODE, OrdinaryNumericalMethod};
use differential_equations::stats::Evals;
use differential_equations::status::Status;
use differential_equations::tableau::ButcherTableau;
use differential_equations::utils::{constrain_step_size, validate_step_size_parameters};

/// Stages of the step (the 12th at c = 1), stages with the dense output's three extra
/// ones and f at the new point, and dense-output coefficients.
const S: usize = 12;
const I: usize = 16;
const O: usize = 8;

type Y = Vec<f64>;
type Res<T> = std::result::Result<T, Error<f64, Y>>;

/// DOP853 with its state, stages and dense-output coefficients in buffers reused from
/// step to step.
pub struct Dop853 {
    /// Initial step of the next `init` (0: Hairer's estimate).
    pub h0: f64,
    rtol: f64,
    atol: f64,
    h: f64,
    t: f64,
    y: Y,
    dydt: Y,
    h_prev: f64,
    t_prev: f64,
    y_prev: Y,
    /// f at the start of the last accepted step.
    dydt_prev: Y,
    k: [Y; I],
    cont: [Y; O],
    y_stage: Y,
    ysti: Y,
    yseg: Y,
    y_new: Y,
    err_state: Y,
    c: [f64; I],
    a: [[f64; I]; I],
    b: [f64; S],
    bh: [f64; S],
    er: [f64; S],
    bi: [[f64; I]; I],
    stiffness_counter: usize,
    non_stiffness_counter: usize,
    steps: usize,
    status: Status<f64, Y>,
    /// The dense output's components (None: all): see [`Dop853::dense_prefix`].
    dense_len: Option<usize>,
    /// The largest step (∞: none): see [`Dop853::max_step`].
    h_max: f64,
}

const SAFETY: f64 = 0.9;
const MIN_SCALE: f64 = 0.2;
const MAX_SCALE: f64 = 10.0;
const H_MIN: f64 = 0.0;
const ORDER: usize = 8;

impl Dop853 {
    /// A stepper with scalar tolerances.
    pub fn new(rtol: f64, atol: f64) -> Dop853 {
        let tab = ButcherTableau::<f64, S, I>::dop853();
        let none = || -> [f64; S] { [0.0; S] };
        Dop853 {
            h0: 0.0,
            rtol,
            atol,
            h: 0.0,
            t: 0.0,
            y: Vec::new(),
            dydt: Vec::new(),
            h_prev: 0.0,
            t_prev: 0.0,
            y_prev: Vec::new(),
            dydt_prev: Vec::new(),
            k: std::array::from_fn(|_| Vec::new()),
            cont: std::array::from_fn(|_| Vec::new()),
            y_stage: Vec::new(),
            ysti: Vec::new(),
            yseg: Vec::new(),
            y_new: Vec::new(),
            err_state: Vec::new(),
            c: tab.c,
            a: tab.a,
            b: tab.b,
            bh: tab.bh.unwrap_or_else(none),
            er: tab.er.unwrap_or_else(none),
            bi: tab.bi.unwrap_or([[0.0; I]; I]),
            stiffness_counter: 0,
            non_stiffness_counter: 0,
            steps: 0,
            status: Status::Uninitialized,
            dense_len: None,
            h_max: f64::INFINITY,
        }
    }

    /// Interpolate only the first `m` components with the method's dense output: the
    /// three extra stages it needs are evaluated on those components alone (the ODE is
    /// called with a state of length `m` and must then give their derivatives, which
    /// must not depend on the other components). The other components are interpolated
    /// linearly between the step's ends (exact at both). For a state carrying
    /// variational columns whose samples are not read (a shooting period): the dense
    /// output's stages then cost one evaluation of the state each instead of one per
    /// column besides. The steps and the prefix's samples are the same bits as without.
    pub fn dense_prefix(&mut self, m: usize) {
        self.dense_len = Some(m);
    }

    /// Steps no longer than `h` (the initial one included; ∞: none, the crate's default).
    pub fn max_step(&mut self, h: f64) {
        self.h_max = h;
    }

    /// The components the dense output interpolates with the method, of `n`.
    fn dense_len(&self, n: usize) -> usize {
        self.dense_len.map_or(n, |m| m.min(n))
    }

    /// The components past the dense prefix at θ = (t − t_prev)/h of the last step,
    /// into `out`: the straight line between the step's ends.
    fn linear_past_prefix(&self, theta: f64, out: &mut Y) {
        let (y0, y1) = (&self.y_prev, &self.y);
        for i in self.dense_len(out.len())..out.len() {
            out[i] = (1.0 - theta) * y0[i] + theta * y1[i];
        }
    }

    /// f at the start and at the end of the last accepted step.
    pub fn end_derivatives(&self) -> (&[f64], &[f64]) {
        (&self.dydt_prev, &self.dydt)
    }

    /// Σ ((x_i / sk_i)²) with sk_i = atol + rtol·max(|y_i|, |y_new_i|), as the crate's
    /// `State::error_norm` for `Vec<f64>`.
    fn error_norm(&self, err: &[f64]) -> f64 {
        let mut sum = 0.0;
        for i in 0..self.y.len() {
            let sk = self.atol + self.rtol * self.y[i].abs().max(self.y_new[i].abs());
            let e = err[i] / sk;
            sum += e * e;
        }
        sum
    }

    /// Hairer's initial step (`HINIT`) as differential-equations 0.7.0 computes it
    /// (`InitialStepSize::<Ordinary>::compute`, private there): two right-hand sides.
    fn initial_step<F: ODE<f64, Y> + ?Sized>(&self, ode: &F, t0: f64, tf: f64, y0: &Y) -> f64 {
        let n_dim = y0.len();
        let posneg = (tf - t0).signum();
        let mut f0 = vec![0.0; n_dim];
        let mut f1 = vec![0.0; n_dim];
        ode.diff(t0, y0, &mut f0);
        let (mut dnf, mut dny) = (0.0f64, 0.0f64);
        let mut sk_vec = Vec::with_capacity(n_dim);
        for n in 0..n_dim {
            let sk = self.atol + self.rtol * y0[n].abs();
            sk_vec.push(sk);
            dnf += (f0[n] / sk).powi(2);
            dny += (y0[n] / sk).powi(2);
        }
        let mut h = if dnf <= 1.0e-10 || dny <= 1.0e-10 {
            1.0e-6
        } else {
            (dny / dnf).sqrt() * 0.01
        };
        h = h.min(self.h_max);
        h *= posneg;
        let mut y1 = y0.clone();
        for (a, b) in y1.iter_mut().zip(&f0) {
            *a += h * *b;
        }
        ode.diff(t0 + h, &y1, &mut f1);
        let mut der2 = 0.0f64;
        for n in 0..n_dim {
            der2 += ((f1[n] - f0[n]) / sk_vec[n]).powi(2);
        }
        der2 = der2.sqrt() / h.abs();
        let der12 = dnf.sqrt().max(der2);
        let h1 = if der12 <= 1.0e-15 {
            h.abs() * 1.0e-3f64.max(1.0e-6)
        } else {
            (0.01 / der12).powf(1.0 / ORDER as f64)
        };
        let interval = (tf - t0).abs();
        h = (h.abs() * 100.0)
            .min(h1)
            .min(self.h_max)
            .max(H_MIN)
            .min(interval);
        h * posneg
    }

    /// The crate's interpolant (with its θ ↔ 1 − θ slip in the 7th-degree part) at
    /// `t_interp` in [t_prev, t], into `out`.
    fn crate_interpolant(&self, t_interp: f64, out: &mut Y) {
        let s = (t_interp - self.t_prev) / self.h_prev;
        let s1 = 1.0 - s;
        // acc = cont7; for i = 6..1: acc = acc·factor + cont_i; y = cont0 + s·acc, with
        // the factors s1, s, s1 for i = 6, 5, 4 (high-order part) and s1, s, s1 for
        // i = 3, 2, 1 (cubic part)
        const FACTOR_IS_S1: [bool; O] = [false, true, false, true, true, false, true, false];
        out.resize(self.y.len(), 0.0);
        let n = self.dense_len(self.y.len());
        for m in 0..n {
            let mut acc = self.cont[O - 1][m];
            for i in (1..O - 1).rev() {
                acc *= if FACTOR_IS_S1[i] { s1 } else { s };
                acc += 1.0 * self.cont[i][m];
            }
            out[m] = self.cont[0][m] + s * acc;
        }
    }

    /// Dense output of DOP853 at `t` inside the last accepted step [t0, t1],
    /// h = t1 − t0, into `out`.
    ///
    /// differential-equations 0.7.0 evaluates the 7th-degree part of Hairer's DOP853
    /// interpolant with θ and 1 − θ swapped (`conpar`), which leaves errors of ~1e-9 where
    /// the step ends are exact to 1e-14. With θ = (t − t0)/h, the correct interpolant P and
    /// the crate's P_w share their cubic part c(θ) = c0 + θ(c1 + (1−θ)(c2 + θ c3)) and
    /// differ in the high-order part only by θ ↔ 1 − θ, which gives exactly
    ///
    /// ```text
    /// P(θ) = P_w(1 − θ) + c(θ) − c(1 − θ) = P_w(1 − θ) + (2θ − 1)(c1 + θ(1 − θ) c3),
    /// c1 = y1 − y0,   c3 = 2 c1 − h (f0 + f1)
    /// ```
    ///
    /// where f0, f1 are ẏ at the step ends (the step's first stage and its f at the new
    /// point, both kept: no right-hand side is evaluated here). Evaluated in this form (the
    /// crate's interpolant at the mirrored time, then the correction) so the samples are
    /// the same bits as when the crate did the stepping. Checked against cos t for
    /// y'' = −y to 3e-14, and by the overcentre tests (samples between steps agree with
    /// the reference to 1e-10).
    pub fn dense_into(&self, t: f64, out: &mut Y) {
        let (t0, t1) = (self.t_prev, self.t);
        let h = t1 - t0;
        let theta = (t - t0) / h;
        let mirrored = (t0 + (1.0 - theta) * h).clamp(t0, t1);
        self.crate_interpolant(mirrored, out);
        let (y0, y1) = (&self.y_prev, &self.y);
        let (f0, f1) = (&self.dydt_prev, &self.dydt);
        let m = self.dense_len(out.len());
        self.linear_past_prefix(theta, out);
        for i in 0..m {
            let c1 = y1[i] - y0[i];
            let c3 = 2.0 * c1 - h * (f0[i] + f1[i]);
            out[i] += (2.0 * theta - 1.0) * (c1 + theta * (1.0 - theta) * c3);
        }
    }
}

/// `dst = src` without reallocating once the lengths match.
fn copy(dst: &mut Y, src: &[f64]) {
    dst.clear();
    dst.extend_from_slice(src);
}

impl OrdinaryNumericalMethod<f64, Y> for Dop853 {
    fn init<F>(&mut self, ode: &F, t0: f64, tf: f64, y0: &Y) -> Res<Evals>
    where
        F: ODE<f64, Y> + ?Sized,
    {
        let mut evals = Evals::new();
        if self.h0 == 0.0 {
            self.h0 = self.initial_step(ode, t0, tf, y0);
            evals.function += 2;
        }
        self.h = validate_step_size_parameters::<f64, Y>(self.h0, H_MIN, self.h_max, t0, tf)?;
        self.stiffness_counter = 0;
        let n = y0.len();
        self.t = t0;
        copy(&mut self.y, y0);
        for v in self
            .k
            .iter_mut()
            .chain(self.cont.iter_mut())
            .chain([&mut self.dydt, &mut self.dydt_prev])
        {
            v.clear();
            v.resize(n, 0.0);
        }
        for v in [
            &mut self.y_stage,
            &mut self.ysti,
            &mut self.yseg,
            &mut self.y_new,
            &mut self.err_state,
        ] {
            v.resize(n, 0.0);
        }
        ode.diff(self.t, &self.y, &mut self.k[0]);
        copy(&mut self.dydt, &self.k[0]);
        evals.function += 1;
        self.t_prev = self.t;
        copy(&mut self.y_prev, &self.y);
        copy(&mut self.dydt_prev, &self.dydt);
        self.status = Status::Initialized;
        Ok(evals)
    }

    fn step<F>(&mut self, ode: &F) -> Res<Evals>
    where
        F: ODE<f64, Y> + ?Sized,
    {
        self.step_in_place(ode)
    }

    fn t(&self) -> f64 {
        self.t
    }
    fn y(&self) -> &Y {
        &self.y
    }
    fn t_prev(&self) -> f64 {
        self.t_prev
    }
    fn y_prev(&self) -> &Y {
        &self.y_prev
    }
    fn h(&self) -> f64 {
        self.h
    }
    fn set_h(&mut self, h: f64) {
        self.h = h;
    }
    fn status(&self) -> &Status<f64, Y> {
        &self.status
    }
    fn set_status(&mut self, status: Status<f64, Y>) {
        self.status = status;
    }
}

impl Dop853 {
    /// One step attempt, as the crate's `step` for DOP853 (same operations, same order;
    /// zero coefficients included, so even signed zeros and non-finite stages propagate
    /// alike). Its stiffness stop is kept as the crate has it: every 100th step, h·|λ|
    /// from ‖yseg − k12‖ / ‖f(y1) − y_stage12‖ (a derivative against a state; the
    /// integrator's own test is Hairer's, see [`super::integrator`]), 15 above 6.1 end
    /// the run with `Error::Stiffness`.
    fn step_in_place<F: ODE<f64, Y> + ?Sized>(&mut self, ode: &F) -> Res<Evals> {
        let mut evals = Evals::new();
        if self.h.abs() < self.h_prev.abs() * 1e-14 {
            let e = || Error::StepSize {
                t: self.t,
                y: self.y.clone(),
            };
            self.status = Status::Error(e());
            return Err(e());
        }
        self.steps += 1;
        let n = self.y.len();
        let h = self.h;
        for i in 1..S {
            self.y_stage.copy_from_slice(&self.y);
            for j in 0..i {
                let alpha = self.a[i][j] * h;
                for (v, kj) in self.y_stage.iter_mut().zip(&self.k[j]) {
                    *v += alpha * *kj;
                }
            }
            ode.diff(self.t + self.c[i] * h, &self.y_stage, &mut self.k[i]);
        }
        self.ysti.copy_from_slice(&self.y_stage);
        self.yseg.fill(0.0);
        for i in 0..S {
            let bi = self.b[i];
            for (v, ki) in self.yseg.iter_mut().zip(&self.k[i]) {
                *v += bi * *ki;
            }
        }
        for m in 0..n {
            self.y_new[m] = self.y[m] + h * self.yseg[m];
        }
        let t_new = self.t + h;
        evals.function += S - 1;

        self.err_state.fill(0.0);
        for j in 0..S {
            let e = self.er[j];
            for (v, kj) in self.err_state.iter_mut().zip(&self.k[j]) {
                *v += e * *kj;
            }
        }
        let mut err = self.error_norm(&self.err_state);
        // the second estimate in the same buffer: yseg − Σ bh_j k_j
        self.err_state.copy_from_slice(&self.yseg);
        for j in 0..S {
            let e = -self.bh[j];
            for (v, kj) in self.err_state.iter_mut().zip(&self.k[j]) {
                *v += e * *kj;
            }
        }
        let err2 = self.error_norm(&self.err_state);
        let mut deno = err + 0.01 * err2;
        if deno <= 0.0 {
            deno = 1.0;
        }
        err = h.abs() * err * (1.0 / (deno * n as f64)).sqrt();
        let error_exponent = 1.0 / ORDER as f64;
        let mut scale = SAFETY * err.powf(-error_exponent);
        scale = scale.max(MIN_SCALE).min(MAX_SCALE);

        if err <= 1.0 {
            ode.diff(t_new, &self.y_new, &mut self.dydt);
            evals.function += 1;
            if self.steps.is_multiple_of(100) {
                let stdnum = diff_norm_squared(&self.yseg, &self.k[S - 1]);
                let stden = diff_norm_squared(&self.dydt, &self.ysti);
                if stden > 0.0 {
                    let h_lamb = h * (stdnum / stden).sqrt();
                    if h_lamb > 6.1 {
                        self.non_stiffness_counter = 0;
                        self.stiffness_counter += 1;
                        if self.stiffness_counter == 15 {
                            let e = || Error::Stiffness {
                                t: self.t,
                                y: self.y.clone(),
                            };
                            self.status = Status::Error(e());
                            return Err(e());
                        }
                    }
                } else {
                    self.non_stiffness_counter += 1;
                    if self.non_stiffness_counter == 6 {
                        self.stiffness_counter = 0;
                    }
                }
            }

            // dense output coefficients (cont[1] = ydiff = y_new + (−1)·y, as `minus`)
            let [c0, c1, c2, c3, ..] = &mut self.cont;
            for m in 0..n {
                let ydiff = self.y_new[m] + -1.0 * self.y[m];
                c0[m] = self.y[m];
                c1[m] = ydiff;
                let mut bspl = 0.0;
                bspl += h * self.k[0][m];
                bspl += -1.0 * ydiff;
                c2[m] = bspl;
                let mut cont3 = ydiff;
                cont3 += -h * self.dydt[m];
                cont3 += -1.0 * bspl;
                c3[m] = cont3;
            }
            copy(&mut self.k[S], &self.dydt);
            // the dense output's components (the same operations on each as on all): the
            // stage and its derivative cut to them for the call (no reallocation), then
            // back to n (the rest of these stages is never read)
            let m = self.dense_len(n);
            for i in S + 1..I {
                copy(&mut self.y_stage, &self.y[..m]);
                for j in 0..i {
                    let alpha = self.a[i][j] * h;
                    for (v, kj) in self.y_stage.iter_mut().zip(&self.k[j]) {
                        *v += alpha * *kj;
                    }
                }
                self.k[i].truncate(m);
                ode.diff(self.t + self.c[i] * h, &self.y_stage, &mut self.k[i]);
                self.k[i].resize(n, 0.0);
                evals.function += 1;
            }
            self.y_stage.resize(n, 0.0);
            for i in 4..O {
                let ci = &mut self.cont[i][..m];
                ci.fill(0.0);
                for j in 0..I {
                    let bij = self.bi[i][j];
                    for (v, kj) in ci.iter_mut().zip(&self.k[j]) {
                        *v += bij * *kj;
                    }
                }
                for v in ci.iter_mut() {
                    *v *= h;
                }
            }

            self.t_prev = self.t;
            std::mem::swap(&mut self.y_prev, &mut self.y);
            copy(&mut self.dydt_prev, &self.k[0]);
            self.h_prev = h;
            self.t = t_new;
            std::mem::swap(&mut self.y, &mut self.y_new);
            copy(&mut self.k[0], &self.dydt);
            if let Status::RejectedStep = self.status {
                self.status = Status::Solving;
                scale = scale.min(1.0);
            }
        } else {
            self.status = Status::RejectedStep;
        }
        self.h = constrain_step_size(self.h * scale, H_MIN, self.h_max);
        Ok(evals)
    }
}

/// ‖a − b‖² as the crate's `State::diff_norm_squared` for `Vec<f64>` (a fold from 0).
fn diff_norm_squared(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |sum, (x, y)| {
        let d = x - y;
        sum + d * d
    })
}

impl Interpolation<f64, Y> for Dop853 {
    /// The crate's interpolant (not Hairer's: see [`Dop853::dense_into`]), allocating;
    /// the integrator uses `dense_into`.
    fn interpolate(&mut self, t_interp: f64) -> Res<Y> {
        if t_interp < self.t_prev || t_interp > self.t {
            return Err(Error::OutOfBounds {
                t_interp,
                t_prev: self.t_prev,
                t_curr: self.t,
            });
        }
        let mut out = Vec::new();
        self.crate_interpolant(t_interp, &mut out);
        // past a dense prefix: linearly, as `dense_into`
        self.linear_past_prefix((t_interp - self.t_prev) / self.h_prev, &mut out);
        Ok(out)
    }
}
