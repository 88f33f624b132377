//! The nonlinear frequency response: pseudo-arclength continuation of the periodic
//! orbit in the forcing frequency (or any parameter), through folds, with its Floquet
//! multipliers, and its folds, period doublings, Neimark–Sacker points and peaks located
//! on the branch.
//!
//! # Continuation
//!
//! The unknowns are u = (ξ/σ_x, p/σ_p): the state in the tangent chart at the last point
//! (see [`super`]) and the parameter, each scaled by the size of the curve (σ_p the
//! parameter range, σ_x the largest state of the linear response over it), so that the
//! step ds measures a fraction of the whole picture. The predictor steps along the unit
//! tangent t (the null vector of the bordered Jacobian [(M − I)σ_x, ∂P/∂p σ_p], M the
//! monodromy on the manifold), plus the curvature term ½·ds²·(t − t₋)/h from the
//! tangent's change t₋ → t over the last step h (a second-order predictor: it cuts the
//! first residual about five times, and the corrections by one Newton step of three);
//! the corrector solves the fixed-point equations with the
//! arclength condition tᵀ(u − u₀) = ds by Newton. The step grows after easy corrections
//! and is halved after failed ones or a turn of the tangent by more than 25°.
//!
//! # Located points
//!
//! Between two points a test function changes sign:
//! - fold (saddle-node): the parameter component t_p of the tangent;
//! - period doubling: μ + 1 for the real multiplier nearest −1;
//! - Neimark–Sacker: |μ| − 1 for the complex pair nearest the unit circle.
//!
//! The curve's points are integrated at rtol 1e-8 (`CURVE_RTOL`) and converged to about
//! 1e-6 of their amplitude; the located points below are computed at 1e-12, with central
//! differences in their variational columns.
//!
//! Each is located by the Illinois variant of regula falsi on the arclength, every trial
//! a corrected point of the branch (a bordered solve, from the nearest trial so far), to
//! 1e-9 of the step in arclength: a fold to better than 1e-8 rad/s in ω; a period
//! doubling's test function scatters by about 1e-6 between neighbouring orbits (source
//! not found: docs/performance.md), ±8e-8 rad/s on the overcentre, stated ±1e-7 of ω.
//!
//! # Chords: most periods without their variational columns
//!
//! A full period (the state with its 2·DoF directions and the parameter's) costs
//! 2 + 2·DoF evaluations a stage; the state's period alone, 1. Newton needs the full
//! ones for its matrix, not for every iterate:
//! - **From the last point** (where a full period costs at least 5: two DoF or more,
//!   `CHORD_FULL_COST`; and the last orbit is not unstable, `CHORD_GROWTH`): chord
//!   iterations with the last point's bordered Jacobian, updated by Broyden's secant
//!   along the iterates, each the state's period alone, until the residual is at the
//!   tolerance; then one full period at the converged orbit gives the point its own
//!   multipliers and tangent. The inceptor's 7 mm curve: four of the state's periods and
//!   1.2 full ones a point, against 2.5 full and one state's before.
//! - **After a full Newton period** within 1e-4 of the orbit (`LIGHT_MARGIN`): chords from that
//!   period's Jacobian; the point is `stale` (`NfrPoint::stale`: its multipliers and
//!   tangent are that iterate's). Where a test function changes sign next to a stale
//!   point, it is integrated in full first.
//! - **A peak's trials** (below) by chords from the nearest orbit so far; the peak's own
//!   orbit gets its full period.
//!
//! A chord that stops converging (a residual not halved) hands over to Newton with full
//! periods; the located folds and bifurcations use full periods throughout.
//!
//! # Peaks
//!
//! Peaks (interior maxima of an amplitude on a stable part) are located by successive
//! parabolic interpolation on the arclength, every trial a corrected point, the
//! amplitude measured on 2048 samples a period, integrated at 1e-11 (`PEAK_PRECISE`).
//!
//! Written by hand: no crate continues periodic orbits of a model given as a file.

use super::{Flow, Shooting, ShootingOptions, multipliers};
use crate::diag::{Error, Result};
use crate::failure::Failure;
use crate::frequency::measure::Measures;
use crate::linear::Linearization;
use crate::request::{Argument, parameter};
use crate::statics::Statics;
use crate::system::System;
use nalgebra::{Complex, DMatrix, DVector};
use std::sync::atomic::AtomicBool;

/// Settings of a continuation.
#[derive(Debug, Clone)]
pub struct NfrOptions {
    /// The continued parameter (the forcing frequency, or any other).
    pub param: String,
    pub from: f64,
    pub to: f64,
    /// Responses measured at every point.
    pub responses: Vec<String>,
    pub shooting: ShootingOptions,
    /// Give up (an incomplete curve) after this many points.
    pub max_points: usize,
    /// Largest step, as a fraction of the curve's size (see the module doc).
    pub max_step: f64,
}

impl NfrOptions {
    pub fn new(param: &str, from: f64, to: f64, responses: Vec<String>) -> NfrOptions {
        NfrOptions {
            param: param.into(),
            from,
            to,
            responses,
            // forward-difference columns along the curve (1 + 2·DoF + 1 right-hand sides a
            // stage instead of 1 + 2·(2·DoF + 1)) and the curve's points to 1e-8: the
            // located points take central differences at 1e-12 (`Tracer::precise`)
            shooting: ShootingOptions {
                central: false,
                rtol: CURVE_RTOL,
                atol: CURVE_ATOL,
                ..ShootingOptions::default()
            },
            max_points: 3000,
            max_step: 0.04,
        }
    }
}

/// The integration's tolerances along the curve. A point of the curve is converged to
/// about 100·rtol of its amplitude (1e-6: `Tracer::correct`), ample for a curve and its
/// events' brackets; the located points (folds, bifurcations, peaks) are computed
/// `PRECISE` times tighter (1e-12, 1e-14).
pub const CURVE_RTOL: f64 = 1e-8;
pub const CURVE_ATOL: f64 = 1e-10;
/// How much tighter than the curve's the integration of the located points is.
const PRECISE: f64 = 1e-4;

/// How much tighter than the curve's the integration of a peak's orbits is at most: a
/// peak's rtol is where the integration's noise (100·rtol) meets the Newton tolerance its
/// amplitudes are converged to (1e-9: 1e-11), or this times the curve's if tighter (at
/// the default 1e-8 the two agree). At 1e-12 (`PRECISE`) the inceptor's peak came out
/// 2e-6 rad/s apart with the same uncertainty (7.0e-5), for 15 000 evaluations more.
const PEAK_PRECISE: f64 = 1e-3;

/// What a located point is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Located {
    Fold,
    PeriodDoubling,
    NeimarkSacker,
    Peak,
}

impl Located {
    pub fn name(self) -> &'static str {
        match self {
            Located::Fold => "fold",
            Located::PeriodDoubling => "period_doubling",
            Located::NeimarkSacker => "neimark_sacker",
            Located::Peak => "peak",
        }
    }
}

/// One periodic orbit of the curve.
#[derive(Debug, Clone)]
pub struct NfrPoint {
    /// The continued parameter.
    pub value: f64,
    /// The forcing frequency, rad/s.
    pub omega: f64,
    /// One per response.
    pub measures: Vec<Measures>,
    /// Floquet multipliers on the manifold (2·DoF), largest modulus first.
    pub multipliers: Vec<Complex<f64>>,
    /// Every multiplier inside the unit circle.
    pub stable: bool,
    /// A located fold, bifurcation or peak (not a step of the continuation).
    pub located: Option<Located>,
    /// Scaled arclength from the start (branch 1 continues after branch 0's end).
    pub s: f64,
    /// The branch it is on (0 from the start of the range, 1 from its end).
    pub branch: usize,
    /// The state at forcing phase 0 (q, v).
    pub x: Vec<f64>,
    /// Its multipliers (and `stable`) are those of a Newton iterate before it, at most
    /// 1e-4 of the orbit away (`LIGHT_MARGIN`): the orbit itself was found by chords, the
    /// state's period alone (`Tracer::chord`). Never for a located point.
    pub stale: bool,
}

/// A located fold or bifurcation.
#[derive(Debug, Clone)]
pub struct Special {
    pub kind: Located,
    pub value: f64,
    pub omega: f64,
    /// One per response: half peak-to-peak.
    pub amplitude: Vec<f64>,
    pub multipliers: Vec<Complex<f64>>,
    /// Stable on the side the continuation came from.
    pub stable_before: bool,
    /// The continued parameter's direction before it (+1 increasing, −1 decreasing).
    pub direction_before: f64,
    /// How well `value` is known: the last change of the located value (the iteration
    /// stops below 1e-10 of it), at least 1e-9 of the value for a fold and 1e-7 for a
    /// bifurcation; where locating failed, half the continuation step that brackets the
    /// point, which is then given at the bracket's end nearer the zero.
    pub uncertainty: f64,
    /// False when locating failed (the point is the bracket's end).
    pub refined: bool,
}

/// A response of a curve whose peaks were not sought (see [`Nfr::no_peaks`]).
#[derive(Debug, Clone, serde::Serialize)]
pub struct NfrNoPeaks {
    pub response: String,
    /// Why, with the numbers (the response's unit).
    #[serde(flatten)]
    pub why: crate::frequency::measure::Still,
}

/// A located peak: an interior maximum of a response's amplitude on a stable part.
#[derive(Debug, Clone, serde::Serialize)]
pub struct NfrPeak {
    pub response: String,
    pub value: f64,
    pub omega: f64,
    pub amplitude: f64,
    /// How well `value` is known, in the continued parameter's unit (`peak_uncertainty`;
    /// for a peak whose refinement failed, half its neighbours' spacing).
    pub uncertainty: f64,
    /// False when the refinement failed and the peak is the continuation's own point.
    pub refined: bool,
}

/// The curve.
#[derive(Debug, Clone)]
pub struct Nfr {
    pub param: String,
    /// The forcing frequency's parameter.
    pub omega_param: String,
    pub responses: Vec<String>,
    pub units: Vec<&'static str>,
    pub coordinates: Vec<String>,
    /// The equilibrium the linear start is about.
    pub equilibrium: Vec<f64>,
    /// In arclength order, located points included.
    pub points: Vec<NfrPoint>,
    pub folds: Vec<Special>,
    pub period_doublings: Vec<Special>,
    pub neimark_sacker: Vec<Special>,
    pub peaks: Vec<NfrPeak>,
    /// The responses whose peaks were not sought, and why (see
    /// [`crate::frequency::measure::stillness`]).
    pub no_peaks: Vec<NfrNoPeaks>,
    /// False when interrupted or stopped short: `points` holds what was computed.
    pub complete: bool,
    /// The branches traced: from the start, and from the far end when the first does not
    /// get there.
    pub branches: Vec<BranchSummary>,
    pub dof: usize,
    pub periods: usize,
    pub rhs_evaluations: usize,
    /// Sign changes of the stability tests between orbits whose largest multiplier
    /// exceeds 1e3, not reported: single shooting does not resolve the smaller
    /// multipliers there.
    pub unresolved_events: usize,
    /// The linear response's smallest displacement over the range (the norm over the
    /// coordinates) against the equilibrium's largest coordinate: below about 5e-7 a
    /// period's rounding approaches the Newton tolerance, and a curve may stall
    /// (`Shooting::fit_to_motion`; the overcentre's lower well at F0 = 1e-5 N over 1.5–5
    /// rad/s, 7.6e-8, does).
    pub motion: f64,
}

/// A chord iteration must cut the residual at least this much, else the full Newton
/// takes over.
const CHORD_CONTRACTION: f64 = 0.5;
/// A full period's iterate goes on by chords (and the point gets its multipliers: stale
/// by this step, `NfrPoint::stale`) when its residual, squared, is this many times below
/// the tolerance: the next residual, about its square, then meets the tolerance with
/// room for Newton's constant (a step of at most 1e-4 of the orbit at the curve's 1e-6).
/// Farther, Newton's next full period (a chord from 1e-3 put the overcentre's multipliers
/// 2 % off). 10 and 1: more chords fail and must be repeated with the full period
/// (overcentre: 0.82 M, 1.04 M evaluations against 0.65 M); 1000: 0.74 M.
const LIGHT_MARGIN: f64 = 100.0;
/// The chord from the last point hands over to the converged orbit's full period when
/// its next residual, at the last contraction, is below this fraction of the Newton
/// tolerance (saves a check of the state's period).
const CHORD_HANDOFF: f64 = 0.3;
/// Chords from the last point only where a full period costs at least this many times
/// the state's alone. A point by chords takes about four of the state's periods and one
/// full (for its multipliers), Newton's about two full and one check: the chords pay
/// where a full period costs more than three (the inceptor: 6, 0.63 M → 0.35 M
/// evaluations), not on the overcentre (4: 0.52 M → 0.54 M).
const CHORD_FULL_COST: usize = 5;
/// Chords from a point only where its orbit amplifies errors less than this.
const CHORD_GROWTH: f64 = 2.0;
/// Broyden's update only from a residual this many times the Newton tolerance.
const CHORD_SECANT: f64 = 100.0;
/// The most chord iterations for one point.
const CHORD_ITERATIONS: usize = 8;

/// A point with what the continuation needs of it.
#[derive(Clone)]
struct Node {
    point: NfrPoint,
    /// Tangent basis at x (2n × 2d).
    basis: DMatrix<f64>,
    /// Unit tangent in scaled chart coordinates (2d + 1): (ξ/σ_x, p/σ_p).
    tangent: DVector<f64>,
    /// Newton iterations it took.
    iterations: usize,
    /// The Newton residual it was accepted at, relative to the orbit's amplitude.
    residual: f64,
    /// The point's move on the manifold with p where the constraints move with p
    /// (`Flow::start_dp`), in scaled units (dx/dp·σ_p/σ_x): the state changes by
    /// σ_x·(basis·t_ξ + shift·t_p) per unit arclength.
    shift: Option<DVector<f64>>,
    /// The bordered Jacobian of the residual in this node's chart, scaled:
    /// [(M − I)·σ_x, ∂R/∂p·σ_p] (d × (d + 1)), from its last full period (a chord's
    /// point: the one its chord started from, `Tracer::chord`). Empty where no period
    /// was integrated with its variational columns (a start guess).
    chart: DMatrix<f64>,
}

/// A search whose first this many trials all fall on one side of the zero gives up
/// (`Tracer::locate_inner`): its bracket's far end is not what precise trials compute.
const ONE_SIDED: usize = 6;

/// A fold's located value is settled when the extremum of a parabola through the trials
/// beside it is this close to the best trial's value, relative (1e-8 rad/s at 25 rad/s).
const FOLD_SETTLED: f64 = 4e-10;

/// The value at the vertex of the parabola (value against arclength) through the three
/// trials nearest `best` in arclength (`best` among them), when the vertex lies between
/// the outer two and the parabola bends the way the fold's test function turns
/// (`turn`: its sign at the bracket's far end, where the arclength is larger: negative
/// for a maximum of the value, positive for a minimum).
fn vertex_near(tried: &[Node], best: &Node, turn: f64) -> Option<f64> {
    let sb = best.point.s;
    let mut near: Vec<&Node> = tried.iter().collect();
    near.sort_by(|x, y| (x.point.s - sb).abs().total_cmp(&(y.point.s - sb).abs()));
    near.dedup_by(|x, y| x.point.s == y.point.s);
    if near.len() < 3 {
        return None;
    }
    let mut three = [near[0], near[1], near[2]];
    three.sort_by(|x, y| x.point.s.total_cmp(&y.point.s));
    let [(s0, p0), (s1, p1), (s2, p2)] = three.map(|n| (n.point.s, n.point.value));
    // divided differences: p = p0 + d1 (s − s0) + d2 (s − s0)(s − s1)
    let d01 = (p1 - p0) / (s1 - s0);
    let d12 = (p2 - p1) / (s2 - s1);
    let d2 = (d12 - d01) / (s2 - s0);
    if !(d2 * turn > 0.0 && d2.is_finite()) {
        return None;
    }
    // p'(s) = d01 + d2 (2s − s0 − s1) = 0
    let sv = 0.5 * (s0 + s1) - d01 / (2.0 * d2);
    if !(sv >= s0 && sv <= s2) {
        return None;
    }
    Some(p0 + d01 * (sv - s0) + d2 * (sv - s0) * (sv - s1))
}

/// What locating a fold or bifurcation in a bracket came to (`Tracer::locate`).
enum Locating {
    /// The point, its uncertainty and, for a fold searched from precise ends, the sign
    /// of the test at the bracket's first end: the parameter's direction toward the
    /// fold, + before a maximum of the parameter (the curve's points beside a fold can
    /// overshoot its value in the integration's noise).
    Found(Box<Node>, f64, Option<f64>),
    /// The bracket's ends, computed again precisely, have no sign change between them:
    /// the curve's was its noise.
    Vanished,
    /// Not located: the caller reports the bracket.
    Failed,
}

/// How chord iterations ended (`Tracer::chord`).
enum ChordEnd {
    /// Converged: the point, stale (its multipliers and chart are where the chord
    /// started from).
    Point(Box<Node>),
    /// Converged, or about to (the next residual, at the last contraction, below
    /// `CHORD_HANDOFF` of the tolerance), where the caller's full period is to follow
    /// (`full_end`): (x, p) the iterate.
    Handoff,
    /// Not converging: (x, p) the iterate of the smallest residual.
    Failed,
}

/// Where chord iterations start from (`Tracer::chord`).
struct Chart {
    /// The chart's tangent basis (2n × d).
    basis: DMatrix<f64>,
    /// The residual's bordered Jacobian in it, scaled (as `Node::chart`).
    jac: DMatrix<f64>,
    /// The arclength condition's row in the chart's scaled unknowns (d + 1).
    row: DVector<f64>,
    /// The multipliers of the period the Jacobian is from.
    multipliers: Vec<Complex<f64>>,
    /// That period's start move with p (as `Node::shift`), which the Jacobian's parameter
    /// column carries.
    shift: Option<DVector<f64>>,
    /// The residual (relative) the chord starts from: its first iterate must be below
    /// `CHORD_CONTRACTION` of it.
    rel: f64,
}

impl Node {
    /// The tangent in ambient scaled coordinates (2n + 1), to compare tangents of
    /// different charts.
    fn ambient(&self) -> DVector<f64> {
        let d = self.basis.ncols();
        let mut t = self.basis.clone() * self.tangent.rows(0, d);
        if let Some(shift) = &self.shift {
            t += shift * self.tangent[d];
        }
        let mut a = DVector::zeros(t.len() + 1);
        a.rows_mut(0, t.len()).copy_from(&t);
        a[t.len()] = self.tangent[d];
        a
    }

    /// How much the orbit amplifies an error over a period: its largest multiplier's
    /// modulus, at least 1.
    fn growth(&self) -> f64 {
        self.point
            .multipliers
            .iter()
            .fold(1.0f64, |m, mu| m.max(mu.norm()))
    }

    /// The state's move with a change `dp` of the parameter where the constraints move
    /// with it (`shift` in state units; None where they do not).
    fn start_move(&self, dp: f64, sx: f64, sp: f64) -> Option<DVector<f64>> {
        start_move(self.shift.as_ref(), dp, sx, sp)
    }

    /// This node oriented along `base` (its ambient tangent not against base's).
    fn along(mut self, base: &Node) -> Node {
        if base.ambient().dot(&self.ambient()) < 0.0 {
            self.tangent.neg_mut();
        }
        self
    }

    fn tp(&self) -> f64 {
        self.tangent[self.tangent.len() - 1]
    }
}

/// The curve's curvature between two of its points (a before b): the change of the
/// ambient scaled tangent per unit arclength. None if they are not apart.
fn curvature(a: &Node, b: &Node) -> Option<DVector<f64>> {
    let h = b.point.s - a.point.s;
    (h > 0.0).then(|| (b.ambient() - a.ambient()) / h)
}

/// The state's move with a change `dp` of the parameter, from a scaled `shift`
/// (`Node::shift`).
fn start_move(shift: Option<&DVector<f64>>, dp: f64, sx: f64, sp: f64) -> Option<DVector<f64>> {
    shift.map(|shift| shift * (sx * dp / sp))
}

/// The unit null direction of a d × (d + 1) bordered Jacobian: the curve's tangent in
/// its chart (the eigenvector of KᵀK of the smallest eigenvalue).
fn null_direction(k: &DMatrix<f64>) -> DVector<f64> {
    let d = k.nrows();
    let ktk = k.transpose() * k;
    // NaNs (reaching the node's checks) rather than an uncapped iteration on a
    // non-finite matrix; the same numbers as SymmetricEigen::new otherwise
    let eig = crate::linalg::symmetric_eigen_or_nan(ktk);
    let imin = (0..=d)
        .min_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]))
        .unwrap_or(d);
    let mut tangent = eig.eigenvectors.column(imin).into_owned();
    tangent.normalize_mut();
    tangent
}

/// Each response's measures over one period's samples.
fn measures_of(values: &[Vec<f64>]) -> Vec<Measures> {
    (0..values.first().map_or(0, |v| v.len()))
        .map(|r| {
            let s: Vec<f64> = values.iter().map(|v| v[r]).collect();
            Measures::of(&s, 1)
        })
        .collect()
}

/// The continuation's state.
struct Tracer<'c> {
    sh: Shooting,
    max_step: f64,
    sx: f64,
    sp: f64,
    cancel: &'c AtomicBool,
    /// Events skipped on unresolved orbits (`RESOLVED`).
    unresolved: usize,
    /// How closely a corrected point meets the arclength condition (scaled units):
    /// `ARC_TOL` along the curve, 1e-10 for the located points (`Tracer::precise`).
    arc_tol: f64,
    /// Every point with its full period (no chords): `Tracer::refresh`.
    no_chords: bool,
    /// Chord iterations from any base with a chart, fixed values included (a peak's
    /// trials: `Tracer::peak`); otherwise only along the curve (`Tracer::correct_at`).
    chord_any: bool,
    /// The model has no damping at the start's equilibrium (its linearization's damping
    /// matrix is zero): its orbits are conservative (`stable_of`).
    undamped: bool,
}

/// The arclength condition's tolerance along the curve: it only says where on the curve
/// a point lies (a step of at most `max_step`, 0.04), not how well the point is on it.
const ARC_TOL: f64 = 1e-7;

/// Trace the curve. `progress(points, value)` after every point.
pub fn nfr(
    sys: &System,
    opts: &NfrOptions,
    progress: &dyn Fn(usize, f64),
    cancel: &AtomicBool,
) -> Result<Nfr> {
    let param = parameter(
        sys.param_names(),
        &opts.param,
        Argument::ContinuationParameter,
    )?;
    if !(opts.from.is_finite() && opts.to.is_finite()) {
        return Err(Error::request(
            format!("--from {} --to {}: not finite", opts.from, opts.to),
            "give finite numbers for --from and --to",
        ));
    }
    if opts.from == opts.to {
        return Err(Error::request(
            format!(
                "--from {} --to {}: the range of {} is empty",
                opts.from, opts.to, opts.param
            ),
            "give two different finite values",
        ));
    }
    let freq = sys
        .forcing_param()
        .ok_or(crate::request::Invalid::NoForcingFrequency)?;
    let omega_param = sys.param_names()[freq].clone();
    let sys0 = sys.with_param(param, opts.from)?;
    if param == freq && !(opts.to > 0.0) {
        return Err(Error::request(
            format!("--to {}: a forcing frequency must be positive", opts.to),
            "give a positive end of the range (rad/s or a quantity such as \"0.5 Hz\")",
        ));
    }
    if !(sys0.param(freq) > 0.0) {
        return Err(Error::request(
            format!(
                "the forcing frequency {omega_param} is {} rad/s: a periodic orbit needs a positive one",
                sys0.param(freq)
            ),
            format!("set it (--set {omega_param}=...) or continue in {omega_param}"),
        ));
    }
    let responses = sys0.outputs(&opts.responses)?;
    let units: Vec<&'static str> = responses.iter().map(|o| o.unit(&sys0)).collect();
    // The linear response about the equilibrium at the start: the first guess.
    let Linear {
        eq,
        x: x0,
        lin,
        forcing,
        y,
    } = linear_start(&sys0, freq, &omega_param)?;
    let omega0 = sys0.param(freq);
    // the longest period of the range, against the fastest motion of the linearization
    // (the forcing frequency along the range where it is an expression of the continued
    // parameter, `omega = w0/4` continued in w0; it must stay positive)
    let slowest = if param == freq {
        opts.from.min(opts.to)
    } else {
        let mut slowest = omega0;
        let omega_at = |v: f64| -> Result<f64> { Ok(sys.with_param(param, v)?.param(freq)) };
        let mut positive = opts.from;
        for j in 1..=20 {
            let v = opts.from + (opts.to - opts.from) * j as f64 / 20.0;
            let w = omega_at(v)?;
            if !(w > 0.0) {
                // where it stops being positive: bisected between the samples
                let (mut a, mut b) = (positive, v);
                for _ in 0..60 {
                    let m = 0.5 * (a + b);
                    if m == a || m == b {
                        break;
                    }
                    if omega_at(m)? > 0.0 {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                // (6 significant digits, as `diag::about` gives 3: the crossing is
                // where to end the range)
                let shown = |x: f64| crate::diag::num(format!("{x:.5e}").parse().unwrap_or(x));
                return Err(Error::request(
                    format!(
                        "the forcing frequency {omega_param} reaches 0 rad/s at {} = {} (it is {} rad/s at {}): a periodic orbit needs a positive one all along the range",
                        opts.param,
                        shown(b),
                        shown(w),
                        shown(v)
                    ),
                    format!(
                        "end the range before {} = {} (--from/--to)",
                        opts.param,
                        shown(b)
                    ),
                ));
            }
            positive = v;
            slowest = slowest.min(w);
        }
        slowest
    };
    // the fastest mode along the range, for DOP853's steps (`COLUMN_STEP_RESOLUTION`): a
    // parameter that stiffens the model (weak_pair's k2 from 1e5 to 1e7 N/m) brings
    // faster modes than the start's
    let explicit = opts.shooting.integrator == crate::dynamics::integrator::Integrator::Dop853;
    let mut fastest = if explicit { fastest_mode(&lin) } else { 0.0 };
    let n = sys0.nq();
    // The scales: the parameter's range, and the largest linear state over it.
    let sp = (opts.to - opts.from).abs();
    let state_norm = |y: &DVector<Complex<f64>>, w: f64| {
        (0..n)
            .map(|i| y[i].norm_sqr() * (1.0 + w * w))
            .sum::<f64>()
            .sqrt()
    };
    let mut sx = state_norm(&y, omega0);
    // and the smallest displacement (`Shooting::fit_to_motion`: the integration's error
    // control is relative to the positions' values; the velocities have no offset)
    let displacement =
        |y: &DVector<Complex<f64>>| (0..n).map(|i| y[i].norm_sqr()).sum::<f64>().sqrt();
    let mut smallest = displacement(&y);
    if param == freq {
        for j in 0..=200 {
            let w = opts.from + (opts.to - opts.from) * j as f64 / 200.0;
            if w > 0.0
                && let Ok(yw) = lin.response(w, &forcing)
            {
                sx = sx.max(state_norm(&yw, w));
                smallest = smallest.min(displacement(&yw));
            }
        }
    } else {
        // another parameter moves the equilibrium and the forcing: the linear response
        // across the range (a forcing amplitude from 0.01 to 2 has its largest orbit at
        // the far end)
        for j in 1..=10 {
            let v = opts.from + (opts.to - opts.from) * j as f64 / 10.0;
            if let Ok(sv) = sys.with_param(param, v)
                && let Ok(l) = linear_start(&sv, freq, &omega_param)
            {
                sx = sx.max(state_norm(&l.y, sv.param(freq)));
                smallest = smallest.min(displacement(&l.y));
                if explicit {
                    fastest = fastest.max(fastest_mode(&l.lin));
                }
            }
        }
    }
    let mut shooting = opts.shooting.clone();
    if explicit {
        check_period(fastest, slowest)?;
        if fastest > 0.0 {
            shooting.max_column_step = crate::periodic::COLUMN_STEP_RESOLUTION / fastest;
        }
    }
    let sx = sx.max(1e-12);
    // the motion against its coordinates' values (`Shooting::fit_to_motion`): the
    // smallest displacement over the range against the equilibrium's largest coordinate
    // (none for a mechanism about the origin); and absolutely, times the slowest
    // frequency below 1 rad/s, where the velocities are the smaller motion (the Duffing
    // at F0 = 1e-7 N over 0.05–0.3 rad/s stalled at 0.0525 rad/s with a false peak)
    let motion = smallest / crate::linalg::amax(&eq.q);
    let undamped = lin.damping.iter().all(|c| *c == 0.0);
    let fitted = |s: &System| {
        Shooting::fitted(
            s,
            param,
            &responses,
            shooting.clone(),
            motion,
            smallest * slowest.min(1.0),
        )
    };
    let mut tr = Tracer {
        sh: fitted(&sys0)?,
        max_step: opts.max_step,
        sx,
        sp,
        cancel,
        unresolved: 0,
        arc_tol: ARC_TOL,
        no_chords: false,
        chord_any: false,
        undamped,
    };
    let dof = {
        let b = tr.sh.tangent_basis(&x0);
        b.ncols() / 2
    };
    let first = tr.start(x0, opts.from, opts.to, opts)?;
    let mut specials: Vec<Special> = Vec::new();
    let mut all: Vec<Node> = Vec::new();
    let mut branches = Vec::new();
    let mut budget = opts.max_points;
    let one = tr.branch(
        first,
        opts.from,
        opts.to,
        0,
        &[],
        &mut specials,
        &mut budget,
        progress,
    )?;
    let mut interrupted = one.end == BranchEnd::Interrupted;
    // a branch that stalls leaves a gap in the range: the curve is not complete
    let covers = |e: BranchEnd| {
        matches!(
            e,
            BranchEnd::Reached | BranchEnd::Returned | BranchEnd::Joined
        )
    };
    let mut complete = covers(one.end) && !interrupted;
    all.extend(one.nodes.iter().cloned());
    branches.push(one.summary(0, opts));
    // The far end: another branch may live there, apart from the first (a resonance
    // whose two sides meet only in a chaotic tangle, or the small branch of a softening
    // resonance when the first came down the large one); skipped when its orbit is on
    // the first branch.
    // (Optional when the first branch got there: where it cannot start, e.g. no forcing
    // at the far end, the curve stands without it.)
    let reached = one.end == BranchEnd::Reached;
    let far = || -> Result<(System, Linear)> {
        let sys1 = tr.sh.sys.with_param(param, opts.to)?;
        let guess = linear_start(&sys1, freq, &omega_param)?;
        Ok((sys1, guess))
    };
    // a first branch that did not reach the far end, with no budget left to look for
    // a branch there: the curve is not known to be complete
    if budget == 0 && !reached {
        complete = false;
    }
    let far = if !interrupted && budget > 0 {
        match far() {
            Ok(f) => Some(f),
            Err(_) if reached => None,
            Err(e) => return Err(e),
        }
    } else {
        None
    };
    if let Some((sys1, guess)) = far {
        let guess = (guess.eq, guess.x);
        let mut end_tr = Tracer {
            sh: fitted(&sys1)?,
            max_step: opts.max_step,
            sx: tr.sx,
            sp: tr.sp,
            cancel,
            unresolved: 0,
            arc_tol: ARC_TOL,
            no_chords: false,
            chord_any: false,
            undamped,
        };
        if let Ok(start) = end_tr.start(guess.1, opts.to, opts.from, opts)
            && !on_branch(&start, &all, &tr.sh.sys)
        {
            let s0 = all.iter().map(|n| n.point.s).fold(0.0, f64::max) + 1.0;
            let mut start = start;
            start.point.s = s0;
            let two = end_tr.branch(
                start,
                opts.to,
                opts.from,
                1,
                &all,
                &mut specials,
                &mut budget,
                progress,
            )?;
            interrupted |= two.end == BranchEnd::Interrupted;
            // the first branch covered the range: a second that stops short leaves an
            // isolated branch partly traced, not a gap
            complete &= (reached || covers(two.end)) && !interrupted;
            all.extend(two.nodes.iter().cloned());
            branches.push(two.summary(1, opts));
        }
        tr.sh.flows += end_tr.sh.flows;
        tr.unresolved += end_tr.unresolved;
        tr.sh.rhs_evaluations += end_tr.sh.rhs_evaluations;
    }
    all.sort_by(|a, b| a.point.s.total_cmp(&b.point.s));
    // peaks on the stable parts
    let mut peaks = Vec::new();
    let mut no_peaks = Vec::new();
    if !interrupted {
        let mut found = Vec::new();
        let still = crate::frequency::measure::stillness(
            &(0..responses.len())
                .map(|r| all.iter().map(|n| n.point.measures[r]).collect())
                .collect::<Vec<Vec<_>>>(),
            &units,
            // the tolerances the orbits were integrated with (fitted to a small motion)
            tr.sh.opts.atol,
            tr.sh.opts.rtol,
        );
        for (r, why) in still.iter().enumerate() {
            if let (Some(why), true) = (why, all.len() >= 3) {
                no_peaks.push(NfrNoPeaks {
                    response: opts.responses[r].clone(),
                    why: *why,
                });
            }
        }
        for r in (0..responses.len()).filter(|&r| still[r].is_none()) {
            for i in 1..all.len().saturating_sub(1) {
                let a = |k: usize| all[k].point.measures[r].amplitude;
                if all[i - 1].point.branch == all[i + 1].point.branch
                    && all[i - 1].point.stable
                    && all[i].point.stable
                    && all[i + 1].point.stable
                    && a(i) > a(i - 1)
                    && a(i) >= a(i + 1)
                    && prominent(&all, i, r, tr.sh.opts.newton_tol(1.0))
                {
                    match tr.peak(&all, i, r) {
                        Ok(Some((mut nd, uncertainty, refined))) => {
                            nd.point.located = Some(Located::Peak);
                            peaks.push(NfrPeak {
                                response: opts.responses[r].clone(),
                                value: nd.point.value,
                                omega: nd.point.omega,
                                amplitude: nd.point.measures[r].amplitude,
                                uncertainty,
                                refined,
                            });
                            found.push(nd);
                        }
                        Err(e) if is_interrupt(&e) => break,
                        // the refinement failed: the continuation's own point, with
                        // its neighbours' spacing as the uncertainty
                        _ => peaks.push(NfrPeak {
                            response: opts.responses[r].clone(),
                            value: all[i].point.value,
                            omega: all[i].point.omega,
                            amplitude: a(i),
                            uncertainty: 0.5
                                * (all[i + 1].point.value - all[i - 1].point.value).abs(),
                            refined: false,
                        }),
                    }
                }
            }
        }
        // a refined peak's orbit joins the points while the point limit leaves room (the
        // peak itself is reported either way)
        found.truncate(budget);
        all.extend(found);
        all.sort_by(|a, b| a.point.s.total_cmp(&b.point.s));
    }
    let pick =
        |k: Located| -> Vec<Special> { specials.iter().filter(|s| s.kind == k).cloned().collect() };
    // a signal during the peaks or the far end's start: what is here is incomplete
    let interrupted = interrupted || cancel.load(std::sync::atomic::Ordering::Relaxed);
    Ok(Nfr {
        param: opts.param.clone(),
        omega_param,
        responses: opts.responses.clone(),
        units,
        coordinates: sys0.coordinates.clone(),
        equilibrium: eq.q.clone(),
        points: all.into_iter().map(|n| n.point).collect(),
        folds: pick(Located::Fold),
        period_doublings: pick(Located::PeriodDoubling),
        neimark_sacker: pick(Located::NeimarkSacker),
        peaks,
        no_peaks,
        complete: complete && !interrupted,
        branches,
        dof,
        periods: tr.sh.flows,
        rhs_evaluations: tr.sh.rhs_evaluations,
        unresolved_events: tr.unresolved,
        motion,
    })
}

impl Nfr {
    /// The SI unit of a response of this curve ("" for a name it does not have).
    pub fn unit_of(&self, response: &str) -> &'static str {
        self.responses
            .iter()
            .position(|r| r == response)
            .map_or("", |i| self.units[i])
    }
}

/// Drop the located points beyond the range `from`..`to`, and the reports of them (an
/// unrefined one stays while the range lies within its bracket).
/// Returns how many located points were dropped (their charge against the point limit
/// is given back).
fn keep_within(from: f64, to: f64, located: &mut Vec<Node>, specials: &mut Vec<Special>) -> usize {
    let (lo, hi) = (from.min(to), from.max(to));
    let beyond = |x: f64| (x - x.clamp(lo, hi)).abs();
    let before = located.len();
    located.retain(|n| beyond(n.point.value) == 0.0);
    specials.retain(|sp| {
        beyond(sp.value) == 0.0 || (!sp.refined && beyond(sp.value) <= sp.uncertainty)
    });
    before - located.len()
}

/// Whether the local maximum of response `r`'s amplitude at `all[i]` stands above the
/// points' noise: on each side, along its stable part of the same branch, the amplitude
/// falls by more than its noise (`noise` or the point's own Newton residual, relative to
/// the amplitude) before it rises above the maximum again. A wiggle of a flank or of a
/// flat stretch at the integration's noise is not a peak: at `--rtol 1e-6`, before the
/// arclength row carried a base motion's move, the inceptor's curve (7 mm, breakout)
/// crawled and showed eleven such maxima besides its one peak, each with a higher point a
/// few points away and differences of 1e-7 to 1e-6 of the amplitude.
/// (A side whose stable part ends first, at a fold or bifurcation, stands.)
fn prominent(all: &[Node], i: usize, r: usize, noise: f64) -> bool {
    let a = |k: usize| all[k].point.measures[r].amplitude;
    let top = a(i);
    let delta = top * noise.max(all[i].residual);
    let on = |k: usize| all[k].point.branch == all[i].point.branch && all[k].point.stable;
    let side = |mut k: usize, step: isize| -> bool {
        loop {
            let Some(next) = k
                .checked_add_signed(step)
                .filter(|&j| j < all.len() && on(j))
            else {
                return true;
            };
            k = next;
            if a(k) > top {
                return false;
            }
            if top - a(k) > delta {
                return true;
            }
        }
    };
    side(i, -1) && side(i, 1)
}

/// The most steps the shooting's integrator may need for one forcing period: a period
/// with variational columns steps at h·λ ≤ 2 for the linearization's fastest natural
/// frequency λ (`COLUMN_STEP_RESOLUTION`; DOP853's stability bound alone is about 6),
/// whatever the accuracy asks.
pub const PERIOD_STEPS: usize = 10_000;

/// Refuse a forcing frequency whose period DOP853 cannot cross in [`PERIOD_STEPS`]
/// steps: at ω far below the model's fastest motion (1e-4 rad/s on the overcentre, whose
/// |λ| is 3 1/s) every period takes tens of thousands of steps, each with the variational
/// equations, and the first point alone runs for minutes without a word. The bound is a
/// lower one (the overcentre at 1e-4 rad/s: 3.1e4 by the stability bound, about 5e4
/// taken); at the budget a period costs about 1e4 steps, a second or so on the
/// overcentre. `lambda`: the fastest natural frequency along the range.
fn check_period(lambda: f64, omega: f64) -> Result<()> {
    // (the columns' periods step at h·λ ≤ COLUMN_STEP_RESOLUTION, below DOP853's
    // stability bound of about 6)
    let steps = std::f64::consts::TAU / omega * lambda / crate::periodic::COLUMN_STEP_RESOLUTION;
    if omega > 0.0 && steps > PERIOD_STEPS as f64 {
        return Err(Failure::PeriodUnresolved {
            omega,
            lambda,
            steps,
            max_steps: PERIOD_STEPS,
        }
        .into());
    }
    Ok(())
}

/// The linearization's fastest natural frequency, rad/s (0 where its modes cannot be
/// computed).
fn fastest_mode(lin: &Linearization) -> f64 {
    lin.modes(0)
        .map_or(0.0, |modes| crate::periodic::fastest(&modes))
}

/// The linear response about the equilibrium at the system's parameter values.
struct Linear {
    eq: crate::statics::Equilibrium,
    /// The state at forcing phase 0, q* + Im Y, ω Re Y (not yet on the manifold).
    x: Vec<f64>,
    lin: Linearization,
    forcing: crate::linear::Forcing,
    y: DVector<Complex<f64>>,
}

fn linear_start(sys: &System, freq: usize, omega_param: &str) -> Result<Linear> {
    let start = crate::dynamics::assemble_at_rest(sys)?;
    let st = Statics::new(sys, &start.q)?;
    let eq = st.nearest(&start)?;
    let omega = sys.param(freq);
    let forcing = crate::linear::harmonic_forcing(sys, &eq, &st.rows, omega_param, omega)?;
    let lin = Linearization::new(&st, &eq);
    let y = lin.response(omega, &forcing)?;
    let n = sys.nq();
    let mut x = vec![0.0; 2 * n];
    for i in 0..n {
        x[i] = eq.q[i] + y[i].im;
        x[n + i] = omega * y[i].re;
    }
    Ok(Linear {
        eq,
        x,
        lin,
        forcing,
        y,
    })
}

/// Whether a point lies on one of `nodes`' branches already: within 1e-3 of the largest
/// coordinate of a point there at the same parameter value, or between two neighbours;
/// an angle coordinate of `sys` compared modulo 2π (the shaken pendulum's far-end start
/// about θ = −2π had traced its branch a second time).
fn on_branch(n: &Node, nodes: &[Node], sys: &System) -> bool {
    let p = n.point.value;
    nodes.windows(2).any(|w| {
        let (a, b) = (&w[0].point, &w[1].point);
        if a.branch != b.branch || (a.value - p) * (b.value - p) > 0.0 {
            return false;
        }
        let f = if b.value == a.value {
            0.0
        } else {
            (p - a.value) / (b.value - a.value)
        };
        let x: Vec<f64> = a.x.iter().zip(&b.x).map(|(u, v)| u + f * (v - u)).collect();
        let d = x
            .iter()
            .zip(&n.point.x)
            .enumerate()
            .map(|(i, (u, v))| {
                let e = u - v;
                if i < sys.nq() && sys.is_angle(i) {
                    crate::system::wrap_angle(e).abs()
                } else {
                    e.abs()
                }
            })
            .fold(0.0, f64::max);
        let size = n.point.x.iter().fold(0.0f64, |m, v| m.max(v.abs())) + 1e-12;
        d <= 1e-3 * size
    })
}

/// How a branch ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BranchEnd {
    /// At the far end of the range.
    Reached,
    /// Back out through the end it started from.
    Returned,
    /// It meets a branch traced before.
    Joined,
    /// The corrector no longer converges (steps below 1e-6 of the curve).
    Stalled,
    /// The orbit's largest multiplier exceeds what single shooting resolves.
    Unstable,
    PointLimit,
    Interrupted,
}

/// A traced branch.
struct Branch {
    nodes: Vec<Node>,
    end: BranchEnd,
    /// Reached or returned, but its orbit at the range's end could not be corrected:
    /// it ends at its last orbit inside.
    short: bool,
}

/// What a branch covered and how it ended, for the outputs.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BranchSummary {
    pub index: usize,
    /// The continued parameter where it starts and ends.
    pub from: f64,
    pub to: f64,
    pub points: usize,
    /// How it ended, in words (`words` with the values as `f64` displays them).
    pub end: String,
    /// How it ended.
    pub ended: BranchEnd,
    /// The largest Floquet multiplier's modulus at its last point.
    pub floquet_max: f64,
    /// It got to the range's end, but the orbit exactly there could not be corrected (a
    /// forcing amplitude's 0, whose orbit is the equilibrium; a strongly unstable
    /// orbit): it ends at `to`, its last orbit inside the range.
    pub short_of_end: bool,
}

impl BranchSummary {
    /// How it ended, in words, with the parameter's values written by `shown`.
    pub fn words(&self, param: &str, shown: &dyn Fn(f64) -> String) -> String {
        let (last, mu, p) = (shown(self.to), self.floquet_max, param);
        let mut words = match self.ended {
            BranchEnd::Reached => format!("reached {p} = {last}"),
            BranchEnd::Returned => format!("turned back and left the range at {p} = {last}"),
            BranchEnd::Joined => format!("joins the branch traced before at {p} = {last}"),
            BranchEnd::Stalled => format!(
                "stopped at {p} = {last}: the corrector no longer converges (largest multiplier {mu:.3e})"
            ),
            BranchEnd::Unstable => format!(
                "stopped at {p} = {last}: the orbit's largest Floquet multiplier ({mu:.3e}) is beyond what single shooting resolves"
            ),
            BranchEnd::PointLimit => {
                format!("stopped at {p} = {last} after {} points", self.points)
            }
            BranchEnd::Interrupted => format!("interrupted at {p} = {last}"),
        };
        if self.short_of_end {
            words.push_str(
                " (its last orbit inside the range: the orbit at the range's end could not be corrected)",
            );
        }
        words
    }
}

impl Branch {
    fn summary(&self, index: usize, opts: &NfrOptions) -> BranchSummary {
        let first = self.nodes.first().map_or(f64::NAN, |n| n.point.value);
        let last = self.nodes.last().map_or(f64::NAN, |n| n.point.value);
        let mu = self.nodes.last().map_or(0.0, |n| {
            n.point.multipliers.first().map_or(0.0, |m| m.norm())
        });
        let mut summary = BranchSummary {
            index,
            from: first,
            to: last,
            points: self.nodes.len(),
            end: String::new(),
            ended: self.end,
            floquet_max: mu,
            short_of_end: self.short,
        };
        summary.end = summary.words(&opts.param, &|v| format!("{v}"));
        summary
    }
}

fn is_interrupt(e: &Error) -> bool {
    matches!(
        e,
        Error::Failed {
            failure: Failure::SweepInterrupted | Failure::Interrupted { .. },
            ..
        }
    )
}

/// The kinds of located points whose test functions change between a and b.
fn events(a: &Node, b: &Node, undamped: bool) -> Vec<Located> {
    let mut out = Vec::new();
    if a.tp() * b.tp() < 0.0 {
        out.push(Located::Fold);
    }
    let count = |n: &Node, pred: &dyn Fn(&Complex<f64>) -> bool| {
        n.point.multipliers.iter().filter(|m| pred(m)).count()
    };
    // a band of 1e-6 about the unit circle: an undamped orbit's multipliers lie on it,
    // and round-off must not make crossings of them (CONSERVATIVE for an undamped model:
    // the monodromy's error at the curve's tolerance, up to 5e-5, is more)
    let band = if undamped { CONSERVATIVE } else { 1e-6 };
    let real_below = |m: &Complex<f64>| is_real(m) && m.re < -1.0 - band;
    if count(a, &real_below) != count(b, &real_below) {
        out.push(Located::PeriodDoubling);
    }
    // (a conservative orbit's complex pairs stay on the circle: no Neimark–Sacker point;
    // the undamped overcentre showed ten where round-off moved them across it)
    let complex_out = |m: &Complex<f64>| !is_real(m) && m.norm() > 1.0 + 1e-6;
    if !undamped
        && count(a, &complex_out) != count(b, &complex_out)
        && a.point.multipliers.iter().any(|m| !is_real(m))
        && b.point.multipliers.iter().any(|m| !is_real(m))
    {
        out.push(Located::NeimarkSacker);
    }
    out
}

/// How far outside the unit circle an undamped orbit's multipliers may lie and the orbit
/// still count as stable (elliptic): the monodromy's error at the curve's tolerance (the
/// undamped overcentre's |μ| scatter up to 1 + 2.5e-5 about the circle, |det M| up to
/// 1 ± 6.5e-5).
const CONSERVATIVE: f64 = 1e-4;

/// An orbit is stable when its multipliers lie inside the unit circle. An undamped
/// mechanism's (`Tracer::undamped`: no damping in its linearization) keep their
/// phase-space volume: they lie on the circle (elliptic: neutrally stable) or off it in
/// reciprocal pairs (hyperbolic), and the orbit is stable when none lies outside by
/// more than the monodromy's error (the undamped overcentre's flipped between stable
/// and unstable with |μ|max = 1 ± 4e-7). The model decides, not the multipliers: a
/// slightly negatively damped one (c = −2.5e-4 N·s/m, |det M| = 1 + 9e-5) is unstable.
fn stable_of(mu: &[Complex<f64>], undamped: bool) -> bool {
    if undamped {
        mu.iter().all(|m| m.norm() <= 1.0 + CONSERVATIVE)
    } else {
        mu.iter().all(|m| m.norm() < 1.0)
    }
}

fn is_real(m: &Complex<f64>) -> bool {
    m.im.abs() <= 1e-9 * (1.0 + m.norm())
}

/// The test function of a kind at a node (None where it is not defined there).
fn test(kind: Located, n: &Node) -> Option<f64> {
    let mu = &n.point.multipliers;
    match kind {
        Located::Fold => Some(n.tp()),
        // det(M + I) = Π(μ + 1): real, continuous, of one sign while complex pairs
        // come and go, zero where a real multiplier passes −1
        Located::PeriodDoubling => Some(
            mu.iter()
                .fold(Complex::new(1.0, 0.0), |p, m| p * (m + 1.0))
                .re,
        ),
        // the bialternate product Π_{i<j}(μ_i μ_j − 1): zero where a complex pair is on
        // the unit circle (detected only between points with complex pairs)
        Located::NeimarkSacker => {
            let mut p = Complex::new(1.0, 0.0);
            for i in 0..mu.len() {
                for j in i + 1..mu.len() {
                    p *= mu[i] * mu[j] - 1.0;
                }
            }
            Some(p.re)
        }
        Located::Peak => None,
    }
}

/// The stated relative uncertainty of a located period doubling or Neimark–Sacker point:
/// its test function, from the monodromy, scatters by about 1e-6 between orbits 1e-9
/// apart (±8e-8 rad/s on the overcentre's period doubling; docs/performance.md).
const BIFURCATION_REL: f64 = 1e-7;

/// The largest multiplier modulus up to which the others are resolved: the monodromy's
/// relative error (1e-8 to 1e-6 with forward-difference columns and the integration)
/// times it must stay well below the smaller multipliers' distance from the unit circle.
/// Beyond it (the overcentre's orbits toward its separatrix reach 7e3), damped orbits
/// showed smaller multipliers of modulus 1.4, impossible for a damped mechanism.
const RESOLVED: f64 = 1e3;

/// The loosest Newton tolerance an orbit is corrected to (relative to its amplitude):
/// where an unstable orbit amplifies the integration's error so much that 100·rtol·|μ|
/// would exceed it, that orbit is integrated more tightly (`Tracer::correct`).
pub(crate) const NOISE_CAP: f64 = 1e-5;

/// The largest Newton residual (relative to the orbit's amplitude) accepted as the
/// integration's noise when the iteration stops converging (`Tracer::correct`).
pub(crate) const NOISE_FLOOR: f64 = 1e-6;

/// How far a Newton residual at the noise may rise from one full period to the next and
/// still count as stalled there, not diverging (`Tracer::correct_at`): the noise moves
/// it both ways. tests/data/weak_pair.toml at k2 = 1e7 N/m (a 3162 rad/s block at x =
/// 3 m, 500 steps a period): its refined peak's residual went 1.58e-9 → 1.71e-9 →
/// 2.42e-9 against a tolerance of 1e-9, and the peak was left unrefined.
const NOISE_RISE: f64 = 1.5;

impl Tracer<'_> {
    /// The first point: Newton at p = from from the linear response; where that fails,
    /// from a settled stepped-sine response.
    fn start(&mut self, mut x0: Vec<f64>, from: f64, to: f64, opts: &NfrOptions) -> Result<Node> {
        self.sh.project(&mut x0);
        let base = |sh: &mut Shooting, x: Vec<f64>| -> Result<Node> {
            let basis = sh.tangent_basis(&x);
            let d = basis.ncols();
            let mut tangent = DVector::zeros(d + 1);
            tangent[d] = (to - from).signum();
            let omega = sh.omega();
            Ok(Node {
                point: NfrPoint {
                    value: sh.value(),
                    omega,
                    measures: Vec::new(),
                    multipliers: Vec::new(),
                    stable: true,
                    located: None,
                    s: 0.0,
                    branch: 0,
                    x,
                    stale: false,
                },
                basis,
                tangent,
                iterations: 0,
                residual: f64::INFINITY,
                shift: None,
                chart: DMatrix::zeros(0, 0),
            })
        };
        let guess = base(&mut self.sh, x0)?;
        if let Some(n) = self.correct(&guess, None, 0.0, Some(from))? {
            return Ok(self.orient(n, &guess));
        }
        // settle by integration, then Newton
        let mut state = crate::dynamics::State {
            t: 0.0,
            q: guess.point.x[..self.sh.sys.nq()].to_vec(),
            v: guess.point.x[self.sh.sys.nq()..].to_vec(),
        };
        let steady = crate::frequency::SteadyOptions {
            rtol: opts.shooting.rtol,
            atol: opts.shooting.atol,
            settle_tol: 1e-6,
            ..Default::default()
        };
        let hint = "start the curve at another value (a frequency away from resonances and jumps: near an undamped resonance the linear response is unbounded), or raise the damping";
        let s = match crate::frequency::steady_state(
            &self.sh.sys,
            &state,
            &[],
            &steady,
            self.cancel,
        ) {
            Ok(s) => s,
            Err(e) if is_interrupt(&e) => return Err(e),
            Err(e) => {
                let why = e.headline();
                return Err(Error::request(
                    format!(
                        "no periodic orbit found at {} = {}: shooting from the linear response does not converge, and the motion started there cannot be settled ({why})",
                        opts.param, from
                    ),
                    hint,
                ));
            }
        };
        state = s.end;
        let x: Vec<f64> = state.q.iter().chain(&state.v).copied().collect();
        let guess = base(&mut self.sh, x)?;
        match self.correct(&guess, None, 0.0, Some(from))? {
            Some(n) => Ok(self.orient(n, &guess)),
            None => Err(Error::request(
                format!(
                    "no periodic orbit found at {} = {}: shooting from the linear response and from a settled response does not converge",
                    opts.param, from
                ),
                hint,
            )),
        }
    }

    /// Trace a branch from `first` (at `from`) toward `to`, until it gets there, turns
    /// back out of the range, meets one of `before`, or stalls; its folds and
    /// bifurcations go to `specials` (and their points into the branch).
    #[allow(clippy::too_many_arguments)]
    fn branch(
        &mut self,
        mut first: Node,
        from: f64,
        to: f64,
        index: usize,
        before: &[Node],
        specials: &mut Vec<Special>,
        budget: &mut usize,
        progress: &dyn Fn(usize, f64),
    ) -> Result<Branch> {
        first.point.branch = index;
        let mut nodes = vec![first];
        // every point of the curve costs one of the budget: the branch's start, each step
        // and each located point
        *budget = budget.saturating_sub(1);
        let dir = (to - from).signum();
        let mut ds = 0.01f64.min(self.max_step);
        let mut located: Vec<Node> = Vec::new();
        // the arclength of the far end of the last fold bracket whose precise ends (and
        // the step before's) agreed: the fold may lie in the step after it
        let mut vanished_fold: Option<f64> = None;
        let finish = |mut nodes: Vec<Node>, located: Vec<Node>, end| {
            nodes.extend(located);
            nodes.sort_by(|a: &Node, b: &Node| a.point.s.total_cmp(&b.point.s));
            Ok(Branch {
                nodes,
                end,
                short: false,
            })
        };
        loop {
            if *budget == 0 {
                return finish(nodes, located, BranchEnd::PointLimit);
            }
            if self.cancel.load(std::sync::atomic::Ordering::Relaxed) {
                return finish(nodes, located, BranchEnd::Interrupted);
            }
            let mut last = nodes.last().expect("a start").clone();
            let k = (nodes.len() >= 2).then(|| curvature(&nodes[nodes.len() - 2], &last));
            let next = match self.correct(&last, k.flatten().as_ref(), ds, None) {
                Ok(n) => n,
                Err(e) if is_interrupt(&e) => {
                    return finish(nodes, located, BranchEnd::Interrupted);
                }
                Err(_) => None,
            };
            let Some(mut next) = next else {
                ds *= 0.5;
                if ds < 1e-6 {
                    return finish(nodes, located, BranchEnd::Stalled);
                }
                continue;
            };
            // a sharp turn: a smaller step
            // (the cosine: an ambient tangent is not of unit length where the start
            // moves with p, `Node::shift`)
            let (ta, tb) = (last.ambient(), next.ambient());
            if ta.dot(&tb) < 0.9 * ta.norm() * tb.norm() && ds > 1e-6 {
                ds *= 0.5;
                continue;
            }
            next.point.s = last.point.s + ds;
            // where an orbit is too unstable for its smaller multipliers to be resolved,
            // their sign changes are not bifurcations (and the tangent zig-zags)
            let resolved = |n: &Node| {
                n.point
                    .multipliers
                    .first()
                    .is_none_or(|m| m.norm() <= RESOLVED)
            };
            let mut found = events(&last, &next, self.undamped);
            // A stale point's multipliers are an iterate's before it (`Tracer::chord`): where
            // a test function changes sign next to one, its full period first, so that
            // the bracket is the true one (and where the earlier point's sign was the
            // stale one's error, the event lies in the step before it).
            // (the last field: searched without a sign change of the curve's test)
            let mut brackets: Vec<(Located, Node, Node, f64, bool)> = Vec::new();
            if !found.is_empty() && (last.point.stale || next.point.stale) {
                if next.point.stale
                    && let Ok(Some(mut r)) = self.refresh(&next)
                {
                    r.point.s = next.point.s;
                    next = r;
                }
                if last.point.stale
                    && let Ok(Some(mut r)) = self.refresh(&last)
                {
                    r.point.s = last.point.s;
                    if nodes.len() >= 2 {
                        let prev = nodes[nodes.len() - 2].clone();
                        let h = r.point.s - prev.point.s;
                        for kind in events(&prev, &r, self.undamped) {
                            if resolved(&prev) && resolved(&r) {
                                brackets.push((kind, prev.clone(), r.clone(), h, false));
                            }
                        }
                    }
                    *nodes.last_mut().expect("a start") = r.clone();
                    last = r;
                }
                found = events(&last, &next, self.undamped);
            }
            if !(resolved(&last) && resolved(&next)) {
                self.unresolved += found.len();
                found.clear();
            }
            // The continued parameter turns back at `last` with no sign change of the
            // fold test about it: a fold that the test's noise hides (the inceptor's
            // 8 mm curve traced downward: every point's test had the same wrong sign
            // while ω turned twice). Searched from precise ends (`Tracer::locate`).
            // So too where the test changed sign at `last` but that bracket's precise
            // ends agreed (the sign changed a step early: the inceptor's upper fold at
            // 9.5 mm traced upward, its lower one at 8.5 mm traced downward, were lost).
            let early = vanished_fold.take() == Some(last.point.s);
            let turned_back = !found.contains(&Located::Fold)
                && nodes.len() >= 2
                && resolved(&last)
                && resolved(&next)
                && {
                    let prev = &nodes[nodes.len() - 2];
                    let (a, b, c) = (prev.point.value, last.point.value, next.point.value);
                    let same = |x: &Node, y: &Node| {
                        matches!((test(Located::Fold, x), test(Located::Fold, y)),
                            (Some(gx), Some(gy)) if gx * gy > 0.0)
                    };
                    (b - a) * (c - b) < 0.0 && (early || same(prev, &last))
                };
            brackets.extend(
                found
                    .into_iter()
                    .map(|kind| (kind, last.clone(), next.clone(), ds, false)),
            );
            if turned_back {
                brackets.push((Located::Fold, last.clone(), next.clone(), ds, true));
            }
            for (kind, last, next, ds, forced) in brackets {
                // a count of multipliers can change by two with no crossing (a complex
                // pair meeting on the real axis outside the circle): only a sign change
                // of the test function is an event
                let (Some(ga), Some(gb)) = (test(kind, &last), test(kind, &next)) else {
                    continue;
                };
                if ga * gb > 0.0 && !forced {
                    continue;
                }
                // (the direction before a fold: toward it, the value being its extremum;
                // the curve point's tangent can be noisy there, the inceptor at 8 mm; from
                // the precise ends' test where the search had them, since a curve point
                // beside the fold can overshoot its value, the inceptor at 9.5 mm)
                let special = |before: &Node,
                               nd: &Node,
                               uncertainty: f64,
                               refined: bool,
                               precise: Option<f64>| {
                    let toward = precise.unwrap_or((nd.point.value - before.point.value).signum());
                    Special {
                        kind,
                        value: nd.point.value,
                        omega: nd.point.omega,
                        amplitude: nd.point.measures.iter().map(|m| m.amplitude).collect(),
                        multipliers: nd.point.multipliers.clone(),
                        stable_before: before.point.stable,
                        direction_before: if kind == Located::Fold
                            && refined
                            && (precise.is_some() || nd.point.value != before.point.value)
                        {
                            toward
                        } else {
                            before.tp().signum()
                        },
                        uncertainty,
                        refined,
                    }
                };
                let mut outcome = self.locate(&last, &next, ds, kind);
                // the bracket searched: its ends and its step
                let (mut lo, mut hi, mut width_s) = (last.clone(), next.clone(), ds);
                // The bracket's ends, computed precisely, agree: the curve's noisy sign
                // changed a step late (the inceptor's upper fold at 9 mm) or changed for
                // nothing (its 7 mm curve at --rtol 1e-6). The step before, precisely;
                // where its ends agree too, no event.
                if matches!(outcome, Ok(Locating::Vanished))
                    && let Some(prev) = nodes
                        .iter()
                        .rev()
                        .find(|n| n.point.s < last.point.s)
                        .cloned()
                {
                    // (not where this kind was located already)
                    let done = located.iter().any(|n| {
                        n.point.located == Some(kind)
                            && n.point.s > prev.point.s
                            && n.point.s <= last.point.s
                    });
                    if !done {
                        let h = last.point.s - prev.point.s;
                        outcome = self.locate(&prev, &last, h, kind);
                        (lo, hi, width_s) = (prev, last.clone(), h);
                    }
                }
                match outcome {
                    // (found twice, from this bracket and from the step before the next
                    // one's: once)
                    Ok(Locating::Found(nd, uncertainty, _))
                        if specials.iter().any(|sp| {
                            sp.refined
                                && sp.kind == kind
                                && (sp.value - nd.point.value).abs()
                                    <= 10.0 * sp.uncertainty.max(uncertainty)
                        }) => {}
                    Ok(Locating::Found(nd, uncertainty, toward)) => {
                        let mut nd = *nd;
                        nd.point.located = Some(kind);
                        // an unrefined report of the same point before, superseded
                        specials.retain(|sp| {
                            sp.refined
                                || sp.kind != kind
                                || (sp.value - nd.point.value).abs() > sp.uncertainty
                        });
                        specials.push(special(&lo, &nd, uncertainty, true, toward));
                        located.push(nd);
                        *budget = budget.saturating_sub(1);
                    }
                    Ok(Locating::Vanished) => {
                        if kind == Located::Fold && !forced {
                            vanished_fold = Some(next.point.s);
                        }
                    }
                    Err(e) if is_interrupt(&e) => {
                        return finish(nodes, located, BranchEnd::Interrupted);
                    }
                    // a turn of the parameter alone, not located (its ends not computed
                    // again, or no zero found between them): no sign change of the fold
                    // test anywhere, no evidence of a fold; not reported (noise turns
                    // of 1e-6 rad/s occur beside the inceptor's 9 mm folds)
                    _ if forced => {}
                    // not located: reported at the bracket's end nearer the zero, with
                    // the bracket as its uncertainty (for a fold the whole step's extent
                    // in the parameter: both ends lie on one side of it)
                    _ => {
                        let g = |n: &Node| test(kind, n).map_or(f64::INFINITY, f64::abs);
                        let near = if g(&lo) <= g(&hi) { &lo } else { &hi };
                        let width = if kind == Located::Fold {
                            self.sp * width_s
                        } else {
                            (hi.point.value - lo.point.value).abs()
                        };
                        // two brackets either side of one point whose test function
                        // alone changed sign (its noise: the inceptor at 9 mm) are
                        // reported once
                        let twice = specials.iter().any(|sp| {
                            !sp.refined && sp.kind == kind && sp.value == near.point.value
                        });
                        if !twice {
                            specials.push(special(&lo, near, width, false, None));
                        }
                    }
                }
            }
            if *budget == 0 {
                // a point located inside this step took the last of the budget: the
                // branch ends there, without the step's own point (and without what
                // was located beyond the range's end, if the step crossed it)
                *budget += keep_within(from, to, &mut located, specials);
                return finish(nodes, located, BranchEnd::PointLimit);
            }
            *budget -= 1;
            let v = next.point.value;
            // out of the range: the point at its end exactly (`to` reached, or `from` for
            // a branch that turned back: there this side's point, not the branch's start
            // across the fold)
            let edge = if (v - to) * dir >= 0.0 {
                Some((to, BranchEnd::Reached))
            } else if (v - from) * dir < 0.0 {
                Some((from, BranchEnd::Returned))
            } else {
                None
            };
            if let Some((edge, ended)) = edge {
                let dist = |a: &Node, b: &Node| {
                    a.point
                        .x
                        .iter()
                        .zip(&b.point.x)
                        .map(|(u, v)| (u - v).powi(2))
                        .sum::<f64>()
                };
                // from the nearer of the two, then the other (a long fixed-value
                // predictor can land on another orbit, which the distance check below
                // refuses)
                let nearer_next = (next.point.value - edge).abs() < (last.point.value - edge).abs();
                let order = if nearer_next {
                    [&next, &last]
                } else {
                    [&last, &next]
                };
                let mut short = true;
                for near in order {
                    match self.correct(near, None, 0.0, Some(edge)) {
                        Ok(Some(mut end))
                            if ended == BranchEnd::Reached
                                || dist(&end, &next) < dist(&end, &nodes[0]) =>
                        {
                            end.point.s = last.point.s
                                + ((edge - last.point.value) / (v - last.point.value)) * ds;
                            nodes.push(end);
                            short = false;
                            break;
                        }
                        Err(e) if is_interrupt(&e) => {
                            return finish(nodes, located, BranchEnd::Interrupted);
                        }
                        _ => {}
                    }
                }
                // where neither converges (a forcing amplitude's 0, where the orbit is
                // the equilibrium; a strongly unstable orbit), the branch ends at its
                // last orbit inside the range, none outside it, and says so (`short`).
                // No located point beyond the range's end stays either (one that could
                // not be located does if the range lies within its bracket).
                *budget += keep_within(from, to, &mut located, specials);
                if short {
                    // the step gave no point: it does not count against the budget
                    *budget += 1;
                }
                let mut b = finish(nodes, located, ended)?;
                b.short = short;
                return Ok(b);
            }
            let joined = !before.is_empty() && on_branch(&next, before, &self.sh.sys);
            let growth = next.point.multipliers.first().map_or(0.0, |m| m.norm());
            let its = next.iterations;
            nodes.push(next);
            progress(nodes.len(), v);
            if joined {
                return finish(nodes, located, BranchEnd::Joined);
            }
            if growth > 1e6 {
                return finish(nodes, located, BranchEnd::Unstable);
            }
            if its <= 4 {
                ds = (ds * 1.5).min(self.max_step);
            } else if its >= 8 {
                ds *= 0.6;
            }
        }
    }

    /// A point again with its full period, no chords (its own multipliers and tangent).
    fn refresh(&mut self, n: &Node) -> Result<Option<Node>> {
        self.full_periods(n, Some(n.point.value))
    }

    /// `n` corrected again with full periods throughout (no chords), at the value
    /// `fixed` or on the curve's normal through it (None).
    fn full_periods(&mut self, n: &Node, fixed: Option<f64>) -> Result<Option<Node>> {
        let any = std::mem::replace(&mut self.chord_any, false);
        let no = std::mem::replace(&mut self.no_chords, true);
        let out = self.correct(n, None, 0.0, fixed);
        self.no_chords = no;
        self.chord_any = any;
        out
    }

    /// The tangent of the first point pointing toward `to`.
    fn orient(&self, mut n: Node, guess: &Node) -> Node {
        if n.tp() * guess.tp() < 0.0 {
            n.tangent.neg_mut();
        }
        n
    }

    /// A point of the branch: from `base` a step `ds` along its tangent, corrected (the
    /// arclength condition), or with `fixed` at that parameter value (then `ds` is
    /// ignored). None when Newton does not converge.
    ///
    /// The integration is tightened where `base` amplifies its error (largest multiplier
    /// |μ|): the Newton tolerance is 100·rtol·|μ| (`correct_at`), kept at most `NOISE_CAP`.
    fn correct(
        &mut self,
        base: &Node,
        curvature: Option<&DVector<f64>>,
        ds: f64,
        fixed: Option<f64>,
    ) -> Result<Option<Node>> {
        let f = (NOISE_CAP / (100.0 * self.sh.opts.rtol * base.growth())).min(1.0);
        if !(f < 1.0) {
            return self.correct_at(base, curvature, ds, fixed);
        }
        let floor = self.sh.rtol_floor();
        self.with_options(
            |o| tighten(o, f, floor),
            |t| t.correct_at(base, curvature, ds, fixed),
        )
    }

    /// `f` with the shooting's options changed by `adjust`, restored after.
    fn with_options<T>(
        &mut self,
        adjust: impl FnOnce(&mut ShootingOptions),
        f: impl FnOnce(&mut Self) -> T,
    ) -> T {
        let keep = self.sh.opts.clone();
        adjust(&mut self.sh.opts);
        let out = f(self);
        self.sh.opts = keep;
        out
    }

    fn correct_at(
        &mut self,
        base: &Node,
        curvature: Option<&DVector<f64>>,
        ds: f64,
        fixed: Option<f64>,
    ) -> Result<Option<Node>> {
        let d = base.basis.ncols();
        let (sx, sp) = (self.sx, self.sp);
        let tx = base.tangent.rows(0, d).into_owned();
        let tpar = base.tangent[d];
        // the predictor: a step s along the tangent (to the value, when one is fixed; the
        // start has no tangent and keeps x as it is)
        let (s, mut p) = match fixed {
            None => (ds, base.point.value + sp * ds * tpar),
            Some(v) if tpar.abs() > 1e-12 => ((v - base.point.value) / (sp * tpar), v),
            Some(v) => (0.0, v),
        };
        let mut step = &base.basis * &tx * (sx * s);
        // a second-order predictor: the curve's curvature (in scaled ambient units, per
        // unit arclength), from the change of the tangent between two points of it
        if let Some(k) = curvature.filter(|_| fixed.is_none()) {
            let n = step.len();
            let h = 0.5 * s * s;
            for i in 0..n {
                step[i] += sx * h * k[i];
            }
            p += sp * h * k[n];
        }
        // the start's own move with p, where the constraints move with it (without it
        // the predicted point lies off the arclength and the first residual is larger)
        if let Some(moved) = base
            .start_move(p - base.point.value, sx, sp)
            .filter(|_| fixed.is_none())
        {
            step += moved;
        }
        let mut x: Vec<f64> = base
            .point
            .x
            .iter()
            .zip(step.iter())
            .map(|(a, b)| a + b)
            .collect();
        // onto the manifold at the predicted p (a base motion's velocity moves with ω)
        self.sh.set(p)?;
        self.sh.project(&mut x);
        // chords: after a full period, Newton with its Jacobian goes on by the state's
        // period alone (`Tracer::chord`); a peak's trials start so, from the point
        // they are stepped from
        let along_curve = self.arc_tol == ARC_TOL && !self.no_chords;
        let chords = along_curve || self.chord_any;
        let mut chord_its = 0;
        // (a full period's cost in evaluations a stage: the state, d directions and the
        // parameter, each once forward or twice central; a curve fitted to a small motion
        // takes its parameter's column central with forward directions, d + 3, counted
        // here as d + 2: counted right, sdof at F0 = 3e-7 N over 15–25 rad/s took its
        // chords from the base less often and cost 59 % more)
        let full_cost = if self.sh.opts.central {
            2 * d + 3
        } else {
            d + 2
        };
        let from_base =
            self.chord_any || (base.growth() < CHORD_GROWTH && full_cost >= CHORD_FULL_COST);
        if chords && base.chart.nrows() == d && d > 0 && from_base {
            let from = Chart {
                basis: base.basis.clone(),
                jac: base.chart.clone(),
                row: match fixed {
                    None => base.tangent.clone(),
                    Some(_) => DVector::from_fn(d + 1, |i, _| if i == d { 1.0 } else { 0.0 }),
                },
                multipliers: base.point.multipliers.clone(),
                shift: base.shift.clone(),
                rel: f64::INFINITY,
            };
            // along the curve the converged orbit gets its full period after (its own
            // multipliers and tangent); a peak's trial is done
            let (end, its) = self.chord(base, &from, &mut x, &mut p, ds, fixed, !self.chord_any)?;
            if let ChordEnd::Point(nd) = end {
                return Ok(Some(*nd));
            }
            chord_its = its;
        }
        let mut prev = f64::INFINITY;
        let mut worse = 0;
        let mut fresh = false;
        for it in 0..14 {
            self.sh.set(p)?;
            let tb = self.sh.tangent_basis(&x);
            if tb.ncols() != d {
                return Ok(None);
            }
            let flow = match self.sh.flow(&x, &tb, true, self.cancel) {
                Ok(f) => f,
                Err(e) if is_interrupt(&e) => return Err(e),
                Err(_) => return Ok(None),
            };
            let rel = self.sh.relative(&flow.end, &x, &flow.scale);
            let diff = DVector::from_fn(x.len(), |i, _| flow.end[i] - x[i]);
            let arc = self.arc(base, &x, p, ds, fixed);
            // the integration's error, amplified by the orbit's unstable multipliers,
            // bounds the residual that the fixed point can be found to
            let tol = self.sh.newton_tol_at(base.growth(), &x, &flow.scale);
            // The integration's noise: P is no smoother than its error control, which is
            // relative to the coordinates' size, not to the orbit's amplitude; where the
            // coordinates are large against a small orbit (a base-driven mechanism) and a
            // stiff law switches within the period (a breakout), a Newton residual that
            // stops falling has reached that noise. Accepted below NOISE_FLOOR.
            let converged = rel <= tol && arc.abs() <= self.arc_tol;
            let noise = fresh
                && rel <= NOISE_FLOOR
                && rel <= NOISE_RISE * prev
                && rel > 0.25 * prev
                && arc.abs() <= 1e-6;
            let its = chord_its.div_ceil(2) + it + 1;
            if converged || noise {
                return Ok(Some(self.node(x, p, tb, flow, base, (its, rel))));
            }
            fresh = true;
            if !(rel < prev) {
                worse += 1;
                if worse >= 2 || it >= 4 {
                    return Ok(None);
                }
            }
            prev = rel;
            // the bordered Newton system
            let fx = base.basis.transpose() * (&flow.jac - &tb);
            let fp = base.basis.transpose() * flow.p_column();
            let mut jm = DMatrix::zeros(d + 1, d + 1);
            jm.view_mut((0, 0), (d, d)).copy_from(&fx);
            jm.view_mut((0, d), (d, 1)).copy_from(&fp);
            match fixed {
                None => {
                    let row = (tx.transpose() * base.basis.transpose() * &tb) / sx;
                    jm.view_mut((d, 0), (1, d)).copy_from(&row);
                    // a change of p moves the start too, where the constraints move with
                    // p (the projection onto the new manifold: `Flow::start_dp`), and with
                    // it the arclength
                    let mut moved = flow
                        .start_dp
                        .clone()
                        .unwrap_or_else(|| DVector::zeros(x.len()));
                    if let Some(own) = base.start_move(1.0, sx, sp) {
                        moved -= own;
                    }
                    jm[(d, d)] = tpar / sp + tx.dot(&(base.basis.transpose() * moved)) / sx;
                }
                Some(_) => jm[(d, d)] = 1.0 / sp,
            }
            let mut rhs = DVector::zeros(d + 1);
            rhs.rows_mut(0, d)
                .copy_from(&(-(base.basis.transpose() * &diff)));
            rhs[d] = -arc;
            // the arclength row in the chart's scaled unknowns, for the chords
            let row = DVector::from_fn(d + 1, |j, _| jm[(d, j)] * if j < d { sx } else { sp });
            let Some(step) = jm.lu().solve(&rhs) else {
                return Ok(None);
            };
            let dxs = &tb * step.rows(0, d);
            for (xi, s) in x.iter_mut().zip(dxs.iter()) {
                *xi += s;
            }
            p += step[d];
            // onto the manifold of the new p (a moving constraint's depends on it)
            self.sh.set(p)?;
            self.sh.project(&mut x);
            if !x.iter().all(|v| v.is_finite()) || !p.is_finite() {
                return Ok(None);
            }
            // close to the orbit (`LIGHT_MARGIN`), the chord from this period's Jacobian: the point
            // is then stale, its multipliers this iterate's (a peak's trials: always)
            if chords && (self.chord_any || (rel * rel * LIGHT_MARGIN <= tol && arc.abs() <= 1e-3))
            {
                // the chord from this period's Jacobian, in its own chart
                let (jac, multipliers) = self.chart_of(&tb, &flow);
                let shift = self.shift_of(&flow);
                let from = Chart {
                    basis: tb,
                    jac,
                    row,
                    multipliers,
                    shift,
                    rel,
                };
                let (end, its) = self.chord(base, &from, &mut x, &mut p, ds, fixed, false)?;
                chord_its += its;
                if let ChordEnd::Point(mut nd) = end {
                    nd.iterations = chord_its.div_ceil(2) + it + 1;
                    return Ok(Some(*nd));
                }
            }
        }
        Ok(None)
    }

    /// A period's start move with p in scaled units (`Node::shift`).
    fn shift_of(&self, flow: &Flow) -> Option<DVector<f64>> {
        flow.start_dp.as_ref().map(|s| s * (self.sp / self.sx))
    }

    /// The bordered Jacobian of one period's residual in the chart `tb` (scaled:
    /// [(M − I)·σ_x, ∂R/∂p·σ_p]), with the multipliers of M.
    fn chart_of(&self, tb: &DMatrix<f64>, flow: &Flow) -> (DMatrix<f64>, Vec<Complex<f64>>) {
        let d = tb.ncols();
        let mono = tb.transpose() * &flow.jac;
        let mu = multipliers(&mono);
        let fp = tb.transpose() * flow.p_column();
        let mut k = DMatrix::zeros(d, d + 1);
        let mut mi = mono;
        for i in 0..d {
            mi[(i, i)] -= 1.0;
        }
        k.view_mut((0, 0), (d, d)).copy_from(&(mi * self.sx));
        k.view_mut((0, d), (d, 1)).copy_from(&(fp * self.sp));
        (k, mu)
    }

    /// The state's change from `base` in its chart (scaled by σ_x), less the base's own
    /// move with p (`Node::shift`).
    fn chart_move(&self, base: &Node, x: &[f64], p: f64) -> DVector<f64> {
        let mut dx = DVector::from_fn(x.len(), |i, _| x[i] - base.point.x[i]);
        if let Some(moved) = base.start_move(p - base.point.value, self.sx, self.sp) {
            dx -= moved;
        }
        base.basis.transpose() * dx / self.sx
    }

    /// The arclength condition's residual at (x, p): a step `ds` along `base`'s tangent,
    /// or p at the `fixed` value (scaled units).
    fn arc(&self, base: &Node, x: &[f64], p: f64, ds: f64, fixed: Option<f64>) -> f64 {
        let d = base.basis.ncols();
        match fixed {
            None => {
                base.tangent.rows(0, d).dot(&self.chart_move(base, x, p))
                    + base.tp() * (p - base.point.value) / self.sp
                    - ds
            }
            Some(v) => (p - v) / self.sp,
        }
    }

    /// Chord iterations from (x, p): Newton with a fixed Jacobian (`from`: a full
    /// period's, or for a peak's trial the point it is stepped from), updated by
    /// Broyden's rank-one secant along the iterates, each iterate the state's period
    /// alone (1 evaluation a stage instead of 2 + 2·DoF). A converged point is `stale`:
    /// its multipliers, tangent, chart and shift are `from`'s. `ChordEnd::Failed` (x, p
    /// put back at the iterate of the smallest residual; with the iterations spent) when
    /// an iterate's residual is not `CHORD_CONTRACTION` of the one before (the first: of
    /// `from.rel`) or `CHORD_ITERATIONS` did not suffice: the full Newton takes over.
    #[allow(clippy::too_many_arguments)]
    fn chord(
        &mut self,
        base: &Node,
        from: &Chart,
        x: &mut [f64],
        p: &mut f64,
        ds: f64,
        fixed: Option<f64>,
        full_end: bool,
    ) -> Result<(ChordEnd, usize)> {
        let d = from.basis.ncols();
        let (sx, sp) = (self.sx, self.sp);
        let mut f = from.jac.clone();
        let no_dirs = DMatrix::zeros(x.len(), 0);
        let tol = self.sh.opts.newton_tol(base.growth());
        let (x0, p0) = (x.to_vec(), *p);
        let mut prev: Option<(DVector<f64>, DVector<f64>)> = None;
        let mut rel0 = from.rel;
        // the iterate of the smallest residual so far, to hand the full Newton
        let mut best: Option<(Vec<f64>, f64, f64)> = None;
        let back = |x: &mut [f64], p: &mut f64, best: &Option<(Vec<f64>, f64, f64)>| {
            if let Some((bx, bp, _)) = best {
                x.copy_from_slice(bx);
                *p = *bp;
            }
        };
        for it in 0..CHORD_ITERATIONS {
            self.sh.set(*p)?;
            let flow = match self.sh.flow(x, &no_dirs, false, self.cancel) {
                Ok(f) => f,
                Err(e) if is_interrupt(&e) => return Err(e),
                Err(_) => {
                    back(x, p, &best);
                    return Ok((ChordEnd::Failed, it + 1));
                }
            };
            let rel = self.sh.relative(&flow.end, x, &flow.scale);
            if best.as_ref().is_none_or(|b| rel < b.2) {
                best = Some((x.to_vec(), *p, rel));
            }
            let arc = self.arc(base, x, *p, ds, fixed);
            if rel <= self.sh.newton_tol_at(base.growth(), x, &flow.scale)
                && arc.abs() <= self.arc_tol
            {
                if full_end {
                    return Ok((ChordEnd::Handoff, it + 1));
                }
                let nd = Node {
                    point: NfrPoint {
                        value: *p,
                        omega: self.sh.omega(),
                        measures: measures_of(&flow.values),
                        stable: stable_of(&from.multipliers, self.undamped),
                        multipliers: from.multipliers.clone(),
                        located: None,
                        s: base.point.s,
                        branch: base.point.branch,
                        x: x.to_vec(),
                        stale: true,
                    },
                    basis: from.basis.clone(),
                    tangent: null_direction(&from.jac),
                    // in the step control's Newton iterations: a chord converges
                    // linearly, about two of its iterations to one of Newton's
                    iterations: (it + 1).div_ceil(2),
                    residual: rel,
                    shift: from.shift.clone(),
                    chart: from.jac.clone(),
                }
                .along(base);
                return Ok((ChordEnd::Point(Box::new(nd)), it + 1));
            }
            if !(rel < CHORD_CONTRACTION * rel0) {
                back(x, p, &best);
                return Ok((ChordEnd::Failed, it + 1));
            }
            let diff = DVector::from_fn(x.len(), |i, _| flow.end[i] - x[i]);
            let r = from.basis.transpose() * diff;
            // the iterate in the chart's scaled coordinates (less the start's own move
            // with p, which the Jacobian's parameter column carries)
            let mut dx = DVector::from_fn(x.len(), |i, _| x[i] - x0[i]);
            if let Some(moved) = start_move(from.shift.as_ref(), *p - p0, sx, sp) {
                dx -= moved;
            }
            let mut u = DVector::zeros(d + 1);
            u.rows_mut(0, d)
                .copy_from(&(from.basis.transpose() * dx / sx));
            u[d] = (*p - p0) / sp;
            if let Some((u0, r0)) = &prev {
                // Broyden's update: the secant along the last step, while the residual's
                // change stands well above the integration's noise (a secant across a
                // step of the noise's size is noise)
                let du = &u - u0;
                let nn = du.norm_squared();
                if nn > 0.0 && rel0 > CHORD_SECANT * tol {
                    let miss = (&r - r0) - &f * &du;
                    f += miss * du.transpose() / nn;
                }
            }
            // the bordered step in scaled units
            let mut jm = DMatrix::zeros(d + 1, d + 1);
            jm.view_mut((0, 0), (d, d + 1)).copy_from(&f);
            for j in 0..=d {
                jm[(d, j)] = from.row[j];
            }
            let mut rhs = DVector::zeros(d + 1);
            rhs.rows_mut(0, d).copy_from(&(-&r));
            rhs[d] = -arc;
            let Some(step) = jm.lu().solve(&rhs) else {
                back(x, p, &best);
                return Ok((ChordEnd::Failed, it + 1));
            };
            let dxs = &from.basis * step.rows(0, d) * sx;
            for (xi, s) in x.iter_mut().zip(dxs.iter()) {
                *xi += s;
            }
            *p += step[d] * sp;
            self.sh.set(*p)?;
            self.sh.project(x);
            if !x.iter().all(|v| v.is_finite()) || !p.is_finite() {
                back(x, p, &best);
                return Ok((ChordEnd::Failed, it + 1));
            }
            // the next residual at this contraction well below the tolerance: the full
            // period instead of the state's (saves the check)
            if full_end && rel0.is_finite() && rel * (rel / rel0) <= CHORD_HANDOFF * tol {
                return Ok((ChordEnd::Handoff, it + 1));
            }
            prev = Some((u, r));
            rel0 = rel;
        }
        back(x, p, &best);
        Ok((ChordEnd::Failed, CHORD_ITERATIONS))
    }

    /// A converged point with its multipliers and tangent (oriented along `base`'s).
    fn node(
        &self,
        x: Vec<f64>,
        p: f64,
        tb: DMatrix<f64>,
        flow: Flow,
        base: &Node,
        (iterations, residual): (usize, f64),
    ) -> Node {
        let (k, mu) = self.chart_of(&tb, &flow);
        let tangent = null_direction(&k);
        let measures = measures_of(&flow.values);
        let stable = stable_of(&mu, self.undamped);
        Node {
            point: NfrPoint {
                value: p,
                omega: self.sh.omega(),
                measures,
                multipliers: mu,
                stable,
                located: None,
                s: base.point.s,
                branch: base.point.branch,
                x,
                stale: false,
            },
            basis: tb,
            tangent,
            iterations,
            residual,
            shift: self.shift_of(&flow),
            chart: k,
        }
        .along(base)
    }

    /// Locate the zero of `kind`'s test function between `a` and `b` (a step `ds` from
    /// a) by the Illinois method on the arclength.
    fn locate(&mut self, a: &Node, b: &Node, ds: f64, kind: Located) -> Result<Locating> {
        // the test functions are computed from the monodromy, whose error is the
        // integration's (and the differences')
        self.precise(None, true, |t| {
            // The search from the curve's own ends.
            let on_curve = |t: &mut Self| -> Result<Locating> {
                Ok(match t.locate_inner(a, b, ds, kind)? {
                    Some((n, u)) => Locating::Found(Box::new(n), u, None),
                    None => Locating::Failed,
                })
            };
            // The curve's test functions (forward differences at the curve's tolerance)
            // can disagree with the precise trials'. The fold test (the tangent's
            // parameter component) can even have the wrong sign where the curve is steep:
            // on the inceptor at 9 mm a point at 25.37925 rad/s had -1.35e-2 between
            // points of +1.7e-2 and +2.7e-2, ω increasing throughout, its ambient tangent
            // 0.03 rad from theirs, where precise trials beside it gave +2.2e-2. So a
            // fold's bracket has its ends computed again precisely (each on its own
            // normal to the curve: well posed at a fold too) before any trial; where
            // they still straddle the zero, the search from them; where they do not,
            // `Vanished` (the caller looks a step back). Measured: the inceptor's
            // fold-heavy curves (8, 9, 10 mm; 9 mm on 25-26; 8 mm downward) 6.29 M ->
            // 4.77 M evaluations, the overcentre's 2.5-5 rad/s 445 890 -> 461 708 (its
            // true fold pays for the two ends). A bifurcation is searched from the
            // curve's ends first, and from precise ends where that fails.
            if kind != Located::Fold
                && let found @ Locating::Found(..) = on_curve(t)?
            {
                return Ok(found);
            }
            // Where the precise path fails for a fold, the search from the curve's ends
            // (at --rtol 1e-6 the 9 mm upper fold's end could not be computed again
            // precisely, and the lower fold's third precise trial failed to converge:
            // both located so).
            let fallback = |t: &mut Self| {
                if kind == Located::Fold {
                    on_curve(t)
                } else {
                    Ok(Locating::Failed)
                }
            };
            let (Some(mut ra), Some(mut rb)) = (t.again(a)?, t.again(b)?) else {
                return fallback(t);
            };
            ra.point.s = a.point.s;
            rb.point.s = b.point.s;
            match (test(kind, &ra), test(kind, &rb)) {
                (Some(ga), Some(gb)) if ga * gb <= 0.0 => {
                    match t.locate_inner(&ra, &rb, ds, kind)? {
                        Some((n, u)) => Ok(Locating::Found(Box::new(n), u, Some(ga.signum()))),
                        None => fallback(t),
                    }
                }
                (Some(_), Some(_)) => Ok(Locating::Vanished),
                _ => fallback(t),
            }
        })
    }

    /// A point again with full periods at the current options, on the curve's normal
    /// through it (ds = 0 along its own tangent), no chords.
    fn again(&mut self, n: &Node) -> Result<Option<Node>> {
        self.full_periods(n, None)
    }

    /// `f` with the integration `PRECISE` times tighter (a peak's, `samples` given:
    /// `PEAK_PRECISE`) (and `samples` a period, if
    /// given; the variational columns by central differences if `central`): for the
    /// located points, whose test functions or amplitudes are differences of nearby
    /// orbits. (A peak needs its orbits' amplitudes, not their multipliers: forward
    /// differences serve its Newton steps.)
    fn precise<T>(
        &mut self,
        samples: Option<usize>,
        central: bool,
        f: impl FnOnce(&mut Self) -> T,
    ) -> T {
        self.arc_tol = 1e-10;
        let floor = self.sh.rtol_floor();
        let out = self.with_options(
            |o| {
                o.central = central;
                // a peak's: where 100·rtol meets its orbits' Newton tolerance (1e-11),
                // or PEAK_PRECISE of the curve's if tighter (below --rtol 1e-8)
                let f: f64 = if samples.is_some() {
                    PEAK_PRECISE.min(o.tol / (100.0 * o.rtol))
                } else {
                    PRECISE
                };
                tighten(o, f, floor);
                o.samples = samples.unwrap_or(o.samples);
            },
            f,
        );
        self.arc_tol = ARC_TOL;
        out
    }

    fn locate_inner(
        &mut self,
        a: &Node,
        b: &Node,
        ds: f64,
        kind: Located,
    ) -> Result<Option<(Node, f64)>> {
        let (Some(mut ga), Some(mut gb)) = (test(kind, a), test(kind, b)) else {
            return Ok(None);
        };
        if ga * gb > 0.0 {
            return Ok(None);
        }
        let (mut sa, mut sb) = (0.0, ds);
        let (mut pa, mut pb) = (a.point.value, b.point.value);
        let small = 1e-10 * (ga.abs() + gb.abs());
        let scale = ga.abs().max(gb.abs());
        let mut best: Option<(f64, Node)> = None;
        let mut side = 0;
        let mut s_prev = f64::NAN;
        let mut p_prev = f64::NAN;
        let mut change = f64::INFINITY;
        let mut converged = false;
        let mut tried: Vec<Node> = Vec::new();
        // the sides the trials fell on (-1: a's, 1: b's)
        let mut sides = (false, false);
        for _ in 0..60 {
            let s = (sa * gb - sb * ga) / (gb - ga);
            let s = if s.is_finite() && s > sa && s < sb {
                s
            } else {
                0.5 * (sa + sb)
            };
            // from the nearest orbit computed so far (a short predictor: the trials close
            // to the zero converge in one period instead of two or three)
            let from = tried
                .iter()
                .min_by(|x: &&Node, y: &&Node| {
                    (x.point.s - a.point.s - s)
                        .abs()
                        .total_cmp(&(y.point.s - a.point.s - s).abs())
                })
                .filter(|n| (n.point.s - a.point.s - s).abs() < s.abs())
                .unwrap_or(a)
                .clone();
            let Some(mut n) = self.correct(&from, None, a.point.s + s - from.point.s, None)? else {
                break;
            };
            n.point.s = a.point.s + s;
            let Some(g) = test(kind, &n) else {
                break;
            };
            tried.push(n.clone());
            let p = n.point.value;
            if best.as_ref().is_none_or(|(b, _)| g.abs() < b.abs()) {
                best = Some((g, n));
            }
            // Converged when the test function vanishes, the arclength stops moving, or
            // the located value does near the zero: at a fold the value is stationary in
            // the arclength, so it settles long before the arclength does
            // (two trials either side of a fold can also share a value: the test
            // function must be small too)
            // A bifurcation's test function scatters between neighbouring orbits (its
            // value's stated uncertainty `BIFURCATION_REL`): a bracket whose two orbits
            // agree to a third of that has found the zero as well as it can be found,
            // and the trials after it only chase the scatter (the overcentre's period
            // doubling: 6 of its 11 trials, about 55 000 evaluations); below, after the
            // bracket's update.
            change = (p - p_prev).abs();
            let settled = if kind == Located::Fold {
                1e-10 * p.abs().max(self.sp)
            } else {
                (0.3 * BIFURCATION_REL * p.abs()).max(1e-10 * self.sp)
            };
            if g.abs() <= small
                || (s - s_prev).abs() < 1e-10 * ds
                || (kind == Located::Fold && change <= settled && g.abs() <= 1e-4 * scale)
            {
                converged = true;
                break;
            }
            // A fold is the extremum of the value along the arclength: once trials have
            // fallen on both sides of the zero, where the vertex of the parabola through
            // the three trials nearest the best one is within `FOLD_SETTLED` of the best
            // trial's value (and the parabola bends as the test function turns), that
            // value is the fold's to as much. (Its test function's noise at the precise
            // tolerance can stay above the 1e-4 of the bracket's asked above: the
            // inceptor at 10 mm searched 13 trials within 1e-9 of one value.)
            if kind == Located::Fold
                && sides.0
                && sides.1
                && let Some((g_best, n_best)) = best.as_ref()
                && g_best.abs() <= 1e-3 * scale
                && let Some(v) = vertex_near(&tried, n_best, gb)
                && (v - n_best.point.value).abs() <= FOLD_SETTLED * p.abs().max(self.sp)
            {
                change = (v - n_best.point.value).abs();
                converged = true;
                break;
            }
            s_prev = s;
            p_prev = p;
            if g * ga > 0.0 {
                sa = s;
                ga = g;
                pa = p;
                sides.0 = true;
                if side == -1 {
                    gb *= 0.5;
                }
                side = -1;
            } else {
                sb = s;
                gb = g;
                pb = p;
                sides.1 = true;
                if side == 1 {
                    ga *= 0.5;
                }
                side = 1;
            }
            // Every trial on one side: the bracket's end on the other is not what the
            // precise trials compute (the curve's test function is noisier), and the
            // search would only creep toward it (60 trials): given up, for the caller
            // to compute the ends again (`Tracer::locate`).
            if tried.len() >= ONE_SIDED && !(sides.0 && sides.1) {
                break;
            }
            // a bifurcation: the zero lies between two orbits that agree to a third of
            // its stated uncertainty (two consecutive trials either side of it, the
            // rule before, can wait long for the scatter: the overcentre on 3-4.5 rad/s
            // took 16 trials where 6 had bracketed it to 1.2e-8 of the value)
            if kind != Located::Fold && (pa - pb).abs() <= settled && g.abs() <= 1e-4 * scale {
                change = (pa - pb).abs();
                converged = true;
                break;
            }
        }
        // located only when the search converged (a corrector that gave up, or 60
        // trials, leave it unrefined: the caller reports the bracket)
        if !converged {
            return Ok(None);
        }
        Ok(best.filter(|(g, _)| g.abs() <= 1e-3 * scale).map(|(_, n)| {
            // At least what the path to it moves it by (measured: the overcentre's fold
            // on two ranges 1.5e-9 apart, its period doubling up to 3.6e-8 with the
            // continuation's steps): 1e-9 of the value for a fold (the tangent's own
            // zero), 1e-7 for a bifurcation (the multipliers' errors), and the orbit's
            // own Newton residual
            let rel: f64 = if kind == Located::Fold {
                1e-9
            } else {
                BIFURCATION_REL
            };
            let floor = rel.max(n.residual) * n.point.value.abs();
            let u = if change.is_finite() {
                change.max(floor)
            } else {
                floor
            };
            (n, u)
        }))
    }

    /// Locate the peak of response `r`'s amplitude near `all[i]` by successive parabolic
    /// interpolation in the arclength (2048 samples a period, the integration `PEAK_PRECISE` times
    /// tighter), with the uncertainty of its frequency (`peak_uncertainty`).
    fn peak(&mut self, all: &[Node], i: usize, r: usize) -> Result<Option<(Node, f64, bool)>> {
        self.chord_any = true;
        let out = self.precise(Some(2048), false, |t| t.peak_inner(all, i, r));
        self.chord_any = false;
        out
    }

    fn peak_inner(
        &mut self,
        all: &[Node],
        i: usize,
        r: usize,
    ) -> Result<Option<(Node, f64, bool)>> {
        let base = &all[i - 1];
        let mut pts: Vec<(f64, f64, Node)> = Vec::new();
        for j in [i - 1, i, i + 1] {
            let ds = all[j].point.s - base.point.s;
            let n = if j == i - 1 {
                self.correct(base, None, 0.0, Some(base.point.value))?
            } else {
                self.correct(base, None, ds, None)?
            };
            let Some(mut n) = n else { return Ok(None) };
            n.point.s = all[j].point.s;
            pts.push((n.point.s, n.point.measures[r].amplitude, n));
        }
        // the noise's reach: closer than a tenth of it, the vertex no longer moves for
        // the better (the amplitudes are no more precise than the integration)
        let reach = peak_uncertainty(
            &all[i - 1..=i + 1],
            r,
            self.sh.opts.newton_tol(1.0) * all[i].point.measures[r].amplitude,
        );
        let mut converged = false;
        // the vertex's last move
        let mut moved = f64::INFINITY;
        for _ in 0..20 {
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (s0, a0) = (pts[0].0, pts[0].1);
            let (s1, a1) = (pts[1].0, pts[1].1);
            let (s2, a2) = (pts[2].0, pts[2].1);
            let den = (s1 - s0) * (a1 - a2) - (s1 - s2) * (a1 - a0);
            let num = (s1 - s0).powi(2) * (a1 - a2) - (s1 - s2).powi(2) * (a1 - a0);
            if den == 0.0 {
                break;
            }
            let s = s1 - 0.5 * num / den;
            if !(s > s0 && s < s2) {
                break;
            }
            if (s - s1).abs() < 1e-10 * (s2 - s0).max(1e-300) {
                converged = true;
                moved = 0.0;
                break;
            }
            // from the nearest of the three (a short predictor step)
            let near = pts
                .iter()
                .min_by(|x, y| (x.0 - s).abs().total_cmp(&(y.0 - s).abs()))
                .map(|x| x.2.clone())
                .unwrap_or_else(|| base.clone());
            let Some(mut n) = self.correct(&near, None, s - near.point.s, None)? else {
                break;
            };
            n.point.s = s;
            let a = n.point.measures[r].amplitude;
            // the vertex's move in the continued parameter, as `reach` is (not in ω: for
            // a parameter ω does not depend on, that move was 0 and the first trial
            // ended the refinement; for ω = w0/3 continued in w0 it was a third)
            let w_new = n.point.value;
            let w_old = pts[1].2.point.value;
            // keep the three around the largest
            pts.push((s, a, n));
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            let imax = (0..pts.len())
                .max_by(|&x, &y| pts[x].1.total_cmp(&pts[y].1))
                .unwrap_or(1)
                .clamp(1, pts.len() - 2);
            pts = pts.drain(imax - 1..=imax + 1).collect();
            moved = (w_new - w_old).abs();
            if moved < (1e-10 * w_new.abs().max(1.0)).max(0.1 * reach) {
                converged = true;
                break;
            }
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        // refined only when the parabola converged on its middle point, the largest
        let top = pts[1].1 >= pts[0].1 && pts[1].1 >= pts[2].1;
        let span = 0.5 * (pts[2].2.point.value - pts[0].2.point.value).abs();
        let imax = (0..3)
            .max_by(|&x, &y| pts[x].1.total_cmp(&pts[y].1))
            .unwrap_or(1);
        let best = pts.swap_remove(imax).2;
        // the peak's orbit with its full period: its own multipliers (the trials' are
        // those of the orbits their chords started from)
        // (where it fails, no refined peak: the caller reports the curve's own point)
        let best = match self.refresh(&best)? {
            Some(mut own) => {
                own.point.s = best.point.s;
                own
            }
            None => return Ok(None),
        };
        // the amplitude is known to the orbit's convergence: the Newton tolerance it was
        // corrected to, at least (a residual far below it is luck, not precision)
        let noise = best.residual.max(self.sh.opts.newton_tol(1.0));
        let u = peak_uncertainty(
            &all[i - 1..=i + 1],
            r,
            noise * best.point.measures[r].amplitude,
        );
        // (a triple narrower than the noise's reach has converged too: the parabola's
        // vertex then wanders out of it on the amplitudes' noise)
        let refined = top && (converged || span <= u);
        // converged: the noise's reach, or the vertex's last move if larger; a triple
        // narrower than the noise: its span; else the bracket
        let u = if refined && converged {
            u.max(moved)
        } else if refined {
            u.max(span)
        } else {
            span
        };
        Ok(best.point.stable.then_some((best, u, refined)))
    }
}

/// The shooting's tolerances `f` (< 1) times tighter: rtol no tighter than `floor`
/// (`Shooting::rtol_floor`), atol no tighter than 0.01 of it, and never looser than it
/// was (below that floor a small motion's period shrinks its steps to the rounding of
/// its large coordinates and meets its step limit: sdof's peak at F0 = 3e-7 N went
/// unrefined, ± 0.048 rad/s). For unstable orbits (`Tracer::correct`) and the located
/// points (`Tracer::precise`).
fn tighten(o: &mut ShootingOptions, f: f64, floor: f64) {
    o.rtol = (o.rtol * f).max(floor);
    o.atol = (o.atol * f).max((0.01 * floor).min(o.atol));
}

/// The uncertainty of a peak's place: an amplitude known to `da` (the orbits' accepted
/// Newton residual or the integration's noise, relative to the amplitude) on a parabola
/// of curvature a'' in the parameter (from the continuation's three points about the
/// peak) puts the maximum anywhere within √(2·da/|a''|): a flat peak is located less
/// well than a fold.
fn peak_uncertainty(around: &[Node], r: usize, da: f64) -> f64 {
    let w: Vec<f64> = around.iter().map(|n| n.point.value).collect();
    let a: Vec<f64> = around
        .iter()
        .map(|n| n.point.measures[r].amplitude)
        .collect();
    let d1 = (a[1] - a[0]) / (w[1] - w[0]);
    let d2 = (a[2] - a[1]) / (w[2] - w[1]);
    let curvature = 2.0 * (d2 - d1) / (w[2] - w[0]);
    let u = (2.0 * da / curvature.abs()).sqrt();
    if u.is_finite() {
        u.min(0.5 * (w[2] - w[0]).abs())
    } else {
        // a vertical flank or a flat top: no better than the bracket
        0.5 * (w[2] - w[0]).abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fold's value from the parabola through the trials beside it: exact for a
    /// parabola, whatever the order of the trials and with a far one left out; none
    /// where the three nearest do not enclose the vertex or the parabola bends against
    /// the test function's turn.
    #[test]
    fn the_vertex_of_the_trials_beside_a_fold() {
        let p = |s: f64| 25.4 - 3.0 * (s - 0.7).powi(2);
        let at = |ss: &[f64]| {
            let mut n = nodes(&vec![1.0; ss.len()]);
            for (node, &s) in n.iter_mut().zip(ss) {
                node.point.s = s;
                node.point.value = p(s);
            }
            n
        };
        let tried = at(&[0.2, 0.95, 0.71, 0.64, 3.0]);
        // a maximum of the value: the test function negative at the far end
        let v = vertex_near(&tried, &tried[2], -1.0).unwrap();
        assert!((v - 25.4).abs() < 1e-13, "{v}");
        // the three nearest 0.2 are 0.2, 0.64, 0.71: the vertex 0.7 lies between them
        assert!((vertex_near(&tried, &tried[0], -1.0).unwrap() - 25.4).abs() < 1e-12);
        // a test function that turns the other way is no fold of this parabola
        assert_eq!(vertex_near(&tried, &tried[2], 1.0), None);
        // all on one side of the vertex: no extrapolation
        let one_side = at(&[0.1, 0.2, 0.3]);
        assert_eq!(vertex_near(&one_side, &one_side[1], -1.0), None);
        // two trials (or repeats of one place) are not a parabola
        let two = at(&[0.6, 0.8, 0.8]);
        assert_eq!(vertex_near(&two, &two[0], -1.0), None);
    }

    /// Nodes of one stable branch with these amplitudes (Newton residual 1e-12).
    fn nodes(amplitudes: &[f64]) -> Vec<Node> {
        amplitudes
            .iter()
            .enumerate()
            .map(|(i, &a)| Node {
                point: NfrPoint {
                    value: i as f64,
                    omega: i as f64,
                    measures: vec![Measures::of(&[a, -a], 1)],
                    multipliers: Vec::new(),
                    stable: true,
                    located: None,
                    s: i as f64,
                    branch: 0,
                    x: Vec::new(),
                    stale: false,
                },
                basis: DMatrix::zeros(0, 0),
                tangent: DVector::zeros(1),
                iterations: 1,
                residual: 1e-12,
                shift: None,
                chart: DMatrix::zeros(0, 0),
            })
            .collect()
    }

    fn maxima(amplitudes: &[f64], noise: f64) -> Vec<usize> {
        let all = nodes(amplitudes);
        let a = |k: usize| all[k].point.measures[0].amplitude;
        (1..all.len() - 1)
            .filter(|&i| a(i) > a(i - 1) && a(i) >= a(i + 1) && prominent(&all, i, 0, noise))
            .collect()
    }

    #[test]
    fn a_peak_stands_and_the_noise_about_it_does_not() {
        // a clean peak
        assert_eq!(maxima(&[1.0, 2.0, 3.0, 2.0, 1.0], 1e-6), vec![2]);
        // a flat top with wiggles of 1e-7 of the amplitude: one peak, the highest
        let top = [1.0, 2.0, 3.0, 3.0 + 3e-7, 3.0 - 3e-7, 3.0 + 6e-7, 2.0, 1.0];
        assert_eq!(maxima(&top, 1e-6), vec![5]);
        // wiggles on a falling flank: none of them
        let flank = [3.0, 2.9, 2.8, 2.8 + 1e-6, 2.8 - 2e-6, 2.8 - 1e-6, 2.7, 2.6];
        assert_eq!(maxima(&flank, 1e-6), Vec::<usize>::new());
        // the same wiggle larger than the noise is a peak of its own
        let bump = [3.0, 2.9, 2.8, 2.85, 2.7, 2.75, 2.6, 2.5];
        assert_eq!(maxima(&bump, 1e-6), vec![3, 5]);
        // a side whose stable part ends before it falls by the noise stands
        let mut edge = nodes(&[1.0, 2.0, 3.0, 3.0 - 1e-9, 5.0]);
        edge[4].point.stable = false;
        assert!(prominent(&edge, 2, 0, 1e-6));
    }
}
