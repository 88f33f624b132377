//! Pseudo-arclength continuation of equilibria in any parameter, through limit points
//! (folds), with stability along the branch, folds located accurately, and branch points
//! (the stiffness becomes singular without a fold) detected.
//!
//! Written by hand: no maintained Rust crate does numerical continuation.
//!
//! Unknowns y = (x, p), x = (q, λ). Predictor y + Δs·τ along the unit tangent τ
//! (null vector of [J_x  H_p]); corrector: Newton on [H(y); τ̂ᵀ (y − y_pred)] = 0, where
//! τ̂ is τ with its λ entries zeroed (arclength is measured in coordinates and the
//! parameter only, so large multipliers do not shrink the steps). ∂H/∂p by automatic
//! differentiation with the parameter live in the compiled system
//! ([`Statics::residual_dp`]): exact, and the model is never evaluated outside
//! [from, to] for a derivative. A step whose prediction would leave
//! the range ends on its boundary (natural-parameter corrector there); a Newton iterate
//! that strays outside and finds the model invalid counts as a failed step. A fold is where τ_p and det J_x both change sign, a branch
//! point where one of them does (the augmented determinant det [J; τᵀ] changes sign):
//! det J_x on a branch that keeps its direction in p, τ_p on a pitchfork's side branch,
//! which turns there onto the other side; both are located by secant iteration along the
//! arclength between the two points that bracket them.
//!
//! Start: the equilibrium nearest the model's initial pose at p = from
//! ([`Statics::nearest`]); none there is [`Failure::NoStartEquilibrium`], before any step.
//! Branch switching: at each branch point of the branch followed from the start, the
//! crossing branch's direction is the null vector φ of the singular J_x as (φ, 0), made
//! orthogonal to the followed tangent (weighted as the arclength); the corrector from the
//! branch point ± one step along it, on the hyperplane normal to it, lands on the crossing
//! branch, which is then followed like the first, to both sides ([`Branch::switched`]).

use super::{Statics, solve_least_squares};
use crate::diag::Result;
use crate::failure::Failure;
use crate::system::System;
use nalgebra::{DMatrix, DVector};
use std::sync::atomic::{AtomicBool, Ordering};

/// Settings of a continuation run.
#[derive(Debug, Clone)]
pub struct ContinuationOptions {
    /// Parameter name.
    pub param: String,
    /// Range of the parameter: start and end (the branch is followed while p stays in it).
    pub from: f64,
    pub to: f64,
    /// Largest arclength step (in the units of the coordinates and the parameter).
    pub step: f64,
    /// Give up after this many points.
    pub max_steps: usize,
}

/// One point of a branch.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BranchPoint {
    /// Parameter value.
    pub value: f64,
    /// Coordinates (n).
    pub q: Vec<f64>,
    pub stable: bool,
    /// The values of the parameters the model's `[trim]` solves (see [`Branch::solved`]).
    pub solved: Vec<f64>,
}

/// A followed branch.
#[derive(Debug, Clone)]
pub struct Branch {
    pub param: String,
    pub coordinates: Vec<String>,
    pub points: Vec<BranchPoint>,
    pub folds: Vec<BranchPoint>,
    pub branch_points: Vec<BranchPoint>,
    /// The run ended because it reached `max_steps` before leaving the range.
    pub truncated: bool,
    /// The parameters the model's `[trim]` solves at every point (empty: no trim, or it
    /// is off, or it solves the continued parameter).
    pub solved: Vec<String>,
    /// The branches through the branch points of this one, each followed from its
    /// branch point to one side (two per simple bifurcation), in the order of
    /// `branch_points`.
    pub switched: Vec<Switched>,
    /// False when the run was cancelled: the points are those computed until then (the
    /// last branch ends early; branches not started yet are missing).
    pub complete: bool,
}

/// One branch of a run: the branch point it leaves (None for the primary), its points,
/// folds, branch points, and whether it stopped at `max_steps`.
pub type BranchView<'a> = (
    Option<usize>,
    &'a [BranchPoint],
    &'a [BranchPoint],
    &'a [BranchPoint],
    bool,
);

impl Branch {
    /// Every branch: the primary (number 0), then the switched ones in order.
    pub fn all(&self) -> Vec<BranchView<'_>> {
        let mut v: Vec<BranchView<'_>> = vec![(
            None,
            &self.points,
            &self.folds,
            &self.branch_points,
            self.truncated,
        )];
        v.extend(self.switched.iter().map(|s| {
            (
                Some(s.branch_point),
                s.points.as_slice(),
                s.folds.as_slice(),
                s.branch_points.as_slice(),
                s.truncated,
            )
        }));
        v
    }
}

/// A branch followed from a branch point of the primary branch, to one side of it.
#[derive(Debug, Clone)]
pub struct Switched {
    /// Index in [`Branch::branch_points`] of the branch point it leaves.
    pub branch_point: usize,
    /// From the first point past the branch point (the branch point is not repeated)
    /// to where the branch leaves the range.
    pub points: Vec<BranchPoint>,
    pub folds: Vec<BranchPoint>,
    /// Branch points on this branch (reported, not switched again).
    pub branch_points: Vec<BranchPoint>,
    /// The branch reached `max_steps` before leaving the range.
    pub truncated: bool,
}

/// The equilibrium equations as a function of (x, p).
struct Family<'m> {
    sys: &'m System,
    param: String,
    index: usize,
    rows: Vec<usize>,
    n: usize,
    /// The requested range of the parameter.
    lo: f64,
    hi: f64,
    /// The model's `[trim]`, when it is on: its parameters are unknowns after the
    /// multipliers in y, its held coordinates at their initial values (which may follow
    /// the parameter, e.g. a datum angle) extra equations: (coordinate, parameter).
    trim: Vec<(usize, usize)>,
    /// Set by a signal: stop following at the next step.
    cancel: &'m AtomicBool,
}

/// A corrected point: y = (x, p), with the data needed at it.
#[derive(Clone)]
struct Pt {
    y: DVector<f64>,
    /// Unit tangent (weighted norm), oriented along the run.
    tau: DVector<f64>,
    /// det J_x.
    det: f64,
}

impl Family<'_> {
    /// The system at y: the parameter y[d] and the trim's parameters.
    fn system(&self, y: &DVector<f64>) -> Result<System> {
        let d = y.len() - 1;
        let p = y[d];
        let mut s = self
            .sys
            .with_param(self.index, p)
            .map_err(|e| e.context(&format!("continuation at {} = {p}", self.param)))?;
        let nr = self.n + self.rows.len();
        for (k, &(_, param)) in self.trim.iter().enumerate() {
            s.set_param(param, y[nr + k])
                .map_err(|e| e.context(&format!("continuation at {} = {p}", self.param)))?;
        }
        Ok(s)
    }

    /// H, [J_x H_p], det J_x.
    fn linearize(&self, y: &DVector<f64>) -> Result<(DVector<f64>, DMatrix<f64>, f64)> {
        let d = y.len() - 1;
        let nr = self.n + self.rows.len();
        let x = &y.as_slice()[..nr];
        let sys = self.system(y)?;
        let st = Statics::with_rows(&sys, self.rows.clone())?;
        let (h0, ar) = st.residual_rows(x);
        let jx = st.kkt_jacobian_with(x, &ar);
        let hp = st.residual_dp(x, self.index);
        let mut h = DVector::zeros(d);
        h.rows_mut(0, nr).copy_from(&h0);
        let mut j = DMatrix::zeros(d, d + 1);
        j.view_mut((0, 0), (nr, nr)).copy_from(&jx);
        let held_dp = if self.trim.is_empty() {
            Vec::new()
        } else {
            sys.initial_dp(self.index)
        };
        for (k, &(coord, param)) in self.trim.iter().enumerate() {
            h[nr + k] = y[coord] - sys.initial.q[coord];
            j.view_mut((0, nr + k), (nr, 1))
                .copy_from(&st.residual_dp(x, param));
            j[(nr + k, coord)] = 1.0;
            j[(nr + k, d)] = -held_dp[coord];
        }
        let det = j.view((0, 0), (d, d)).determinant();
        j.view_mut((0, d), (nr, 1)).copy_from(&hp);
        Ok((h, j, det))
    }

    /// y ⊕ s·dy: coordinates through the retraction, multipliers and parameter added.
    fn advance(&self, y: &DVector<f64>, dy: &DVector<f64>, s: f64) -> DVector<f64> {
        DVector::from_vec(super::advance(self.sys, y.as_slice(), dy.as_slice(), s))
    }

    /// The tangent from y0 to y1.
    fn difference(&self, y1: &DVector<f64>, y0: &DVector<f64>) -> DVector<f64> {
        DVector::from_vec(super::difference(self.sys, y1.as_slice(), y0.as_slice()))
    }

    /// Weight vector: 1 for q and p, 0 for λ.
    fn weights(&self, len: usize) -> DVector<f64> {
        DVector::from_fn(
            len,
            |i, _| if i < self.n || i == len - 1 { 1.0 } else { 0.0 },
        )
    }

    /// Unit tangent at y, oriented along `prev` (or toward increasing p·dir).
    fn tangent(&self, j: &DMatrix<f64>, prev: Option<&DVector<f64>>, dir: f64) -> DVector<f64> {
        let d = j.nrows();
        let mut b = DMatrix::zeros(d + 1, d + 1);
        b.view_mut((0, 0), (d, d + 1)).copy_from(j);
        let border = match prev {
            Some(t) => t.component_mul(&self.weights(d + 1)),
            None => {
                let mut e = DVector::zeros(d + 1);
                e[d] = dir;
                e
            }
        };
        b.set_row(d, &border.transpose());
        let mut rhs = DVector::zeros(d + 1);
        rhs[d] = 1.0;
        let mut t = solve_least_squares(b, &rhs);
        let w = self.weights(d + 1);
        let norm = t.component_mul(&w).norm();
        t /= norm;
        if let Some(p) = prev
            && t.dot(&p.component_mul(&w)) < 0.0
        {
            t.neg_mut();
        }
        t
    }

    fn converged(&self, h: &DVector<f64>, scale: f64) -> bool {
        let fr = h.rows(0, self.n).amax();
        let cr = h.rows(self.n, h.len() - self.n).amax();
        fr <= 1e-10 * scale && cr <= 1e-12
    }

    /// Corrector from the prediction `base + s·tau`, constrained to the hyperplane
    /// τ̂ᵀ (y − y_pred) = 0 (pseudo-arclength). Returns the corrected point and the
    /// iterations used.
    fn correct(&self, base: &Pt, s: f64, scale: f64) -> Result<Option<(Pt, usize)>> {
        let w = self.weights(base.y.len());
        let tw = base.tau.component_mul(&w);
        self.correct_on(base, s, scale, tw)
    }

    /// Corrector from the prediction `base + s·tau` at the parameter value it predicts
    /// (natural-parameter Newton): lands exactly on a range boundary.
    fn correct_at_parameter(&self, base: &Pt, s: f64, scale: f64) -> Result<Option<(Pt, usize)>> {
        let mut e = DVector::zeros(base.y.len());
        e[base.y.len() - 1] = 1.0;
        self.correct_on(base, s, scale, e)
    }

    /// Newton from `base + s·tau` on [H(y); rowᵀ (y − y_pred)] = 0.
    fn correct_on(
        &self,
        base: &Pt,
        s: f64,
        scale: f64,
        tw: DVector<f64>,
    ) -> Result<Option<(Pt, usize)>> {
        let pred = self.advance(&base.y, &base.tau, s);
        let mut y = pred.clone();
        let d = y.len() - 1;
        for it in 0..10 {
            // A Newton iterate may stray past the range; where the model is invalid there
            // (a mass ≤ 0), that is a failed corrector (the step is halved), not the end.
            let (h, j, det) = match self.linearize(&y) {
                Ok(l) => l,
                Err(_) if y[d] < self.lo || y[d] > self.hi => return Ok(None),
                Err(e) => return Err(e),
            };
            if !h.iter().all(|v| v.is_finite()) {
                return Ok(None);
            }
            let g = tw.dot(&self.difference(&y, &pred));
            if self.converged(&h, scale) && g.abs() < 1e-12 {
                let tau = self.tangent(&j, Some(&base.tau), 1.0);
                return Ok(Some((Pt { y, tau, det }, it)));
            }
            let mut b = DMatrix::zeros(d + 1, d + 1);
            b.view_mut((0, 0), (d, d + 1)).copy_from(&j);
            b.set_row(d, &tw.transpose());
            let mut r = DVector::zeros(d + 1);
            r.rows_mut(0, d).copy_from(&h);
            r[d] = g;
            let dy = solve_least_squares(b, &r);
            y = self.advance(&y, &dy, -1.0);
        }
        Ok(None)
    }

    /// Secant (Illinois) along the arclength from `base` for a zero of `f(point)` between
    /// s = 0 (value f0) and s = s1 (value f1).
    fn locate(
        &self,
        base: &Pt,
        s1: f64,
        f0: f64,
        f1: f64,
        scale: f64,
        f: &dyn Fn(&Pt) -> f64,
    ) -> Result<Option<Pt>> {
        let (mut a, mut fa, mut b, mut fb) = (0.0, f0, s1, f1);
        let mut best: Option<Pt> = None;
        let mut side = 0;
        for _ in 0..60 {
            let mut s = (a * fb - b * fa) / (fb - fa);
            if !s.is_finite() || s <= a.min(b) || s >= a.max(b) {
                s = 0.5 * (a + b);
            }
            let Some((pt, _)) = self.correct(base, s, scale)? else {
                return Ok(best);
            };
            let fs = f(&pt);
            best = Some(pt);
            if fs == 0.0 || (b - a).abs() < 1e-14 * (1.0 + s.abs()) {
                break;
            }
            if fs.signum() == fa.signum() {
                a = s;
                fa = fs;
                if side == -1 {
                    fb *= 0.5;
                }
                side = -1;
            } else {
                b = s;
                fb = fs;
                if side == 1 {
                    fa *= 0.5;
                }
                side = 1;
            }
            if fs.abs() < 1e-14 {
                break;
            }
        }
        Ok(best)
    }
}

/// Follow the equilibrium branch through the equilibrium nearest the model's initial pose
/// at p = `from`, until p leaves [from, to] or `max_steps` points were computed; then,
/// from every branch point found on it, the branches that cross it, to both sides.
pub fn continue_equilibria(sys: &System, opts: &ContinuationOptions) -> Result<Branch> {
    continue_equilibria_until(sys, opts, &AtomicBool::new(false))
}

/// [`continue_equilibria`], stopped at the next step once `cancel` is set: the branch so
/// far is returned with `complete = false` (a signal's partial result).
pub fn continue_equilibria_until(
    sys: &System,
    opts: &ContinuationOptions,
    cancel: &AtomicBool,
) -> Result<Branch> {
    let index = check(sys, opts)?;
    let dir = (opts.to - opts.from).signum();
    let at_from = |e: crate::diag::Error| {
        e.context(&format!("continuation at {} = {}", opts.param, opts.from))
    };
    let sys0 = sys.with_param(index, opts.from).map_err(at_from)?;
    // The model's trim follows the parameter (unless it is the parameter continued).
    let trim: Vec<(usize, usize)> = match &sys.trim {
        Some(t) if t.off.is_none() && !t.params.contains(&index) => t
            .coords
            .iter()
            .zip(&t.params)
            .map(|(&c, &p)| (c, p))
            .collect(),
        _ => Vec::new(),
    };
    let sys0 = if trim.is_empty() {
        sys0
    } else {
        super::trim::trim(&sys0).map_err(at_from)?.0
    };
    let start = crate::dynamics::assemble_at_rest(&sys0)?;
    let st0 = Statics::new(&sys0, &start.q)?;
    // No equilibrium at the start: fail here, before any step, and without the last
    // Newton iterate's pose (it is not an equilibrium, often not even assembled).
    let eq = st0.nearest(&start).map_err(|e| match e.failure() {
        Some(Failure::NoEquilibrium {
            residual,
            iterations,
            round_off,
            ..
        }) => Failure::NoStartEquilibrium {
            param: opts.param.clone(),
            value: opts.from,
            why: format!("residual {residual:.3e}"),
            iterations: *iterations,
            round_off: *round_off,
        }
        .into(),
        Some(Failure::UndefinedEquilibrium { iterations, .. }) => Failure::NoStartEquilibrium {
            param: opts.param.clone(),
            value: opts.from,
            why: "the equations undefined (NaN)".into(),
            round_off: false,
            iterations: *iterations,
        }
        .into(),
        _ => at_from(e),
    })?;
    let n = sys0.n();
    let (lo, hi) = (opts.from.min(opts.to), opts.from.max(opts.to));
    let fam = Family {
        sys,
        index,
        param: opts.param.clone(),
        rows: st0.rows.clone(),
        n,
        lo,
        hi,
        trim: trim.clone(),
        cancel,
    };
    let scale = {
        let mut f = vec![0.0; n];
        st0.static_force(&eq.q, &mut f);
        1.0 + f.iter().fold(0.0f64, |a, v| a.max(v.abs()))
    };
    let mut y0: Vec<f64> = eq.q.clone();
    y0.extend(&eq.lambda);
    y0.extend(trim.iter().map(|&(_, p)| sys0.param(p)));
    y0.push(opts.from);
    let y0 = DVector::from_vec(y0);
    let (_, j0, det0) = fam.linearize(&y0)?;
    let tau0 = fam.tangent(&j0, None, dir);
    let first = Pt {
        y: y0,
        tau: tau0,
        det: det0,
    };
    let (primary, located) = fam.follow(first, opts, scale)?;
    // Branch switching: the branches through every branch point of the primary branch.
    let mut switched = Vec::new();
    for (k, bp) in located.iter().enumerate() {
        for side in [1.0, -1.0] {
            if cancel.load(Ordering::Relaxed) {
                break;
            }
            let Some(first) = fam.leave(bp, side, opts.step, scale)? else {
                continue;
            };
            let (trace, _) = fam.follow(first, opts, scale)?;
            switched.push(Switched {
                branch_point: k,
                points: trace.points,
                folds: trace.folds,
                branch_points: trace.branch_points,
                truncated: trace.truncated,
            });
        }
    }
    Ok(Branch {
        param: opts.param.clone(),
        coordinates: sys0.coordinates.clone(),
        points: primary.points,
        folds: primary.folds,
        branch_points: primary.branch_points,
        truncated: primary.truncated,
        solved: trim
            .iter()
            .map(|&(_, p)| sys.param_names()[p].clone())
            .collect(),
        switched,
        complete: !cancel.load(Ordering::Relaxed),
    })
}

/// The points, folds and branch points of one followed branch.
struct Trace {
    points: Vec<BranchPoint>,
    folds: Vec<BranchPoint>,
    branch_points: Vec<BranchPoint>,
    truncated: bool,
}

impl Family<'_> {
    /// A branch point as reported: parameter, coordinates, stability, trim's values.
    fn point(&self, pt: &Pt) -> Result<BranchPoint> {
        let d = pt.y.len() - 1;
        let nr = self.n + self.rows.len();
        let sys = self.system(&pt.y)?;
        let st = Statics::with_rows(&sys, self.rows.clone())?;
        let y = pt.y.as_slice();
        Ok(BranchPoint {
            value: pt.y[d],
            q: y[..self.n].to_vec(),
            stable: st.stability(&y[..self.n], &y[self.n..nr]).0,
            solved: y[nr..d].to_vec(),
        })
    }

    /// Follow the branch from the corrected point `cur` along its tangent until p leaves
    /// [lo, hi] or `max_steps` points; also returns the branch points located exactly.
    fn follow(
        &self,
        mut cur: Pt,
        opts: &ContinuationOptions,
        scale: f64,
    ) -> Result<(Trace, Vec<Pt>)> {
        let (lo, hi) = (self.lo, self.hi);
        let d = cur.y.len() - 1;
        let mut trace = Trace {
            points: vec![self.point(&cur)?],
            folds: Vec::new(),
            branch_points: Vec::new(),
            truncated: false,
        };
        let mut located = Vec::new();
        let mut ds = opts.step;
        let min_ds = opts.step * 1e-6;
        let mut steps = 0;
        loop {
            if self.cancel.load(Ordering::Relaxed) {
                break;
            }
            if steps >= opts.max_steps {
                trace.truncated = true;
                break;
            }
            // A step whose prediction would leave the range is shortened to end on the
            // boundary, and corrected at that parameter value: the branch ends exactly on
            // `from`/`to` and the model is never evaluated outside the requested range.
            let tp = cur.tau[d];
            let bound = if tp > 0.0 { hi } else { lo };
            let to_bound = if tp == 0.0 {
                f64::INFINITY
            } else {
                (bound - cur.y[d]) / tp
            };
            let at_bound = to_bound <= ds;
            if at_bound && to_bound <= 1e-12 * ds {
                // On the boundary up to rounding (steps that add up to it, 3.1999999999999975
                // for 3.2): the last point is corrected exactly onto it, then the end.
                if cur.y[d] != bound
                    && let Some((mut e, _)) =
                        self.correct_at_parameter(&cur, to_bound.max(0.0), scale)?
                {
                    e.y[d] = bound;
                    if let Some(last) = trace.points.last_mut() {
                        *last = self.point(&e)?;
                    }
                }
                break;
            }
            let s = if at_bound { to_bound } else { ds };
            let corrected = if at_bound {
                self.correct_at_parameter(&cur, s, scale)?
            } else {
                self.correct(&cur, s, scale)?
            };
            let Some((mut next, iters)) = corrected else {
                ds = s * 0.5;
                if ds < min_ds {
                    return Err(Failure::ContinuationStalled {
                        param: opts.param.clone(),
                        value: cur.y[d],
                        step: opts.step,
                        min_step: min_ds,
                    }
                    .into());
                }
                continue;
            };
            // Reject a corrector that left the branch: too far from the prediction, or a
            // tangent turned by more than about 25°; retry with half the step.
            let w = self.weights(next.y.len());
            let dist = self.difference(&next.y, &cur.y).component_mul(&w).norm();
            if dist > 1.5 * s.max(1e-3 * ds) || next.tau.component_mul(&w).dot(&cur.tau) < 0.9 {
                ds = s * 0.5;
                if ds < min_ds {
                    return Err(Failure::BranchTurns {
                        param: opts.param.clone(),
                        value: cur.y[d],
                    }
                    .into());
                }
                continue;
            }
            steps += 1;
            // A fold turns the parameter (τ_p changes sign) and the stability (det J_x
            // changes sign); a branch point changes one of them only (the sign of the
            // augmented determinant det [J; τᵀ] changes): det J_x on the branch that keeps
            // its direction in p, τ_p on a pitchfork's side branch, which turns there.
            let tp_flip = cur.tau[d].signum() != next.tau[d].signum();
            let det_flip = cur.det.signum() != next.det.signum();
            let (f0, f1, by_det) = if tp_flip {
                (cur.tau[d], next.tau[d], false)
            } else {
                (cur.det, next.det, true)
            };
            if tp_flip || det_flip {
                let at = |p: &Pt| if by_det { p.det } else { p.tau[d] };
                if let Some(f) = self.locate(&cur, s, f0, f1, scale, &at)? {
                    if tp_flip && det_flip {
                        trace.folds.push(self.point(&f)?);
                    } else {
                        trace.branch_points.push(self.point(&f)?);
                        located.push(f);
                    }
                }
            }
            if at_bound {
                next.y[d] = bound; // exact already, up to the last Newton update
                trace.points.push(self.point(&next)?);
                break;
            }
            let p = next.y[d];
            if p < lo || p > hi {
                // The corrector crossed the boundary: the last point exactly on it.
                let bound = if p > hi { hi } else { lo };
                let f0 = cur.y[d] - bound;
                let f1 = p - bound;
                if let Some(mut e) = self.locate(&cur, s, f0, f1, scale, &|q| q.y[d] - bound)? {
                    e.y[d] = bound;
                    trace.points.push(self.point(&e)?);
                }
                break;
            }
            trace.points.push(self.point(&next)?);
            cur = next;
            if iters <= 3 {
                ds = (ds * 1.5).min(opts.step);
            }
        }
        Ok((trace, located))
    }

    /// The first point of the branch that crosses the branch point `bp` on the side
    /// `side` (±1) of its second tangent τ₂: the vector of the 2-dimensional null space
    /// of [J_x H_p] orthogonal to the followed tangent τ₁ (weighted inner product), of
    /// unit weighted norm; the corrector from bp + s·side·τ₂ on the hyperplane normal to
    /// τ₂ (which the followed branch does not cross near bp), with s halved until it
    /// converges. `None` when no second branch leaves there (φ has no coordinate or
    /// parameter part, or the corrector never lands inside the range).
    fn leave(&self, bp: &Pt, side: f64, step: f64, scale: f64) -> Result<Option<Pt>> {
        let d = bp.y.len() - 1;
        let (_, j, _) = self.linearize(&bp.y)?;
        // null space of [J_x H_p] (d × (d+1)), 2-dimensional at a simple branch point:
        // the right singular vectors of its two smallest singular values (a zero row
        // appended makes it square, so that the SVD gives all d + 1)
        let mut sq = DMatrix::zeros(d + 1, d + 1);
        sq.view_mut((0, 0), (d, d + 1)).copy_from(&j);
        let svd = crate::linalg::svd_or_nan(sq, false, true);
        let Some(v_t) = svd.v_t else {
            return Ok(None);
        };
        let mut order: Vec<usize> = (0..=d).collect();
        order.sort_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]));
        let (v1, v2) = (v_t.row(order[0]).transpose(), v_t.row(order[1]).transpose());
        // the combination of v1, v2 orthogonal to the followed tangent τ₁ (weighted)
        let w = self.weights(d + 1);
        let t1w = bp.tau.component_mul(&w);
        let (a, b) = (v2.dot(&t1w), -v1.dot(&t1w));
        let mut tau2 = if a.hypot(b) > 1e-12 {
            v1 * a + v2 * b
        } else {
            v1
        };
        let norm = tau2.component_mul(&w).norm();
        if norm.is_nan() || norm <= 1e-6 {
            return Ok(None);
        }
        // A sign independent of the SVD's: the largest coordinate entry positive.
        let big = (0..self.n).max_by(|&a, &b| tau2[a].abs().total_cmp(&tau2[b].abs()));
        let sign = big.map_or(1.0, |i| tau2[i].signum());
        tau2 *= side * sign / norm;
        let base = Pt {
            y: bp.y.clone(),
            tau: tau2,
            det: bp.det,
        };
        let mut s = step;
        while s >= step * 1e-4 {
            if let Some((pt, _)) = self.correct(&base, s, scale)? {
                let p = pt.y[d];
                let w = self.weights(d + 1);
                let dist = self.difference(&pt.y, &bp.y).component_mul(&w).norm();
                // landed on the crossing branch: at about s from bp, inside the range
                if p >= self.lo && p <= self.hi && dist > 0.5 * s && dist < 1.5 * s {
                    return Ok(Some(pt));
                }
            }
            s *= 0.5;
        }
        Ok(None)
    }
}

fn check(sys: &System, opts: &ContinuationOptions) -> Result<usize> {
    use crate::request::{Argument, Invalid, parameter};
    let index = parameter(
        sys.param_names(),
        &opts.param,
        Argument::ContinuationParameter,
    )?;
    if !(opts.from.is_finite() && opts.to.is_finite()) || opts.from == opts.to {
        return Err(Invalid::Range {
            what: Argument::ContinuationRange,
            from: opts.from,
            to: opts.to,
        }
        .into());
    }
    if !(opts.step > 0.0) || !opts.step.is_finite() {
        return Err(Invalid::NotPositive {
            argument: Argument::ArclengthStep,
            value: opts.step,
        }
        .into());
    }
    // a step that cannot move the parameter in double precision would run every step in
    // place and report a one-point branch as a success
    let scale = opts.from.abs().max(opts.to.abs()).max(1.0);
    if opts.step < 1e-12 * scale {
        return Err(Invalid::StepTooSmall {
            argument: Argument::ArclengthStep,
            step: opts.step,
            scale,
        }
        .into());
    }
    if opts.max_steps == 0 {
        return Err(Invalid::Zero {
            argument: Argument::MaxSteps,
        }
        .into());
    }
    // every step moves the parameter by at most `step`: a range of more steps than
    // `max_steps` cannot be reached, and would stop short after all its steps
    let points = (opts.to - opts.from).abs() / opts.step;
    if points > opts.max_steps as f64 {
        return Err(Invalid::TooManyPoints {
            argument: Argument::ArclengthStep,
            value: opts.step,
            points,
            limit: opts.max_steps,
        }
        .into());
    }
    Ok(index)
}
