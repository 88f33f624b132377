//! Stepped-sine frequency response: steady states detected on the Poincaré section,
//! measured by Fourier projection, swept independently (in parallel) or sequentially
//! (up / down, to reveal jumps), with every resonance located by refinement.
//!
//! Per frequency ω (period T = 2π/ω) the motion is integrated continuously from t = 0 (the
//! forcing is T-periodic), restarted only where the state jumps (an extrapolation). The
//! state at the end of each period is a point of the Poincaré map; the response has settled when successive points agree to the
//! settling tolerance relative to the response amplitude, or, for a period-k response
//! (k = 2..4), when points k periods apart agree. Convergence of the lightly damped
//! transients is accelerated by minimal polynomial extrapolation (MPE) of the Poincaré
//! sequence, projected back onto the constraint manifold; an extrapolation that does not
//! reduce the next period's change, or whose run cannot be integrated, is discarded and
//! plain iteration continues from the last integrated state. Settling
//! is always verified by integrated periods, never assumed.
//!
//! Written by hand: no crate does stepped-sine analysis of constrained mechanisms.

pub mod checkpoint;
pub mod measure;
pub mod study;
pub mod wells;

use crate::diag::{Error, Result};
use crate::dynamics::integrator::Stiffness;
use crate::dynamics::simulate::SimOptions;
use crate::dynamics::{
    DynWorkspace, State, project_position, project_velocity, velocity_residual_blocks,
};
use crate::failure::Failure;
use crate::linalg::amax;
use crate::request::{Argument, Invalid};
use crate::statics::{Equilibrium, Statics};
use crate::system::System;
use crate::system::outputs::{Output, Probe};
use measure::Measures;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Settings of one steady-state computation.
#[derive(Debug, Clone)]
pub struct SteadyOptions {
    pub rtol: f64,
    pub atol: f64,
    /// Poincaré points agree to this fraction of the response amplitude.
    pub settle_tol: f64,
    /// Give up (report `settled = false`) after this many periods.
    pub max_periods: usize,
    /// Samples per period for the measures.
    pub samples: usize,
    /// Accelerate settling by extrapolating the Poincaré sequence.
    pub extrapolate: bool,
    /// The classical protocol instead of detection: integrate exactly this many periods
    /// and measure the last one (`settled` is then false: nothing was checked).
    pub fixed_periods: Option<usize>,
    /// The integration method (Radau IIA for stiff models).
    pub integrator: crate::dynamics::integrator::Integrator,
}

impl Default for SteadyOptions {
    fn default() -> Self {
        SteadyOptions {
            rtol: 1e-10,
            atol: 1e-12,
            settle_tol: 1e-8,
            max_periods: 600,
            samples: 128,
            extrapolate: true,
            fixed_periods: None,
            integrator: Default::default(),
        }
    }
}

/// The settled response at one frequency.
#[derive(Debug, Clone)]
pub struct SteadyState {
    /// Forcing frequency, rad/s.
    pub omega: f64,
    pub settled: bool,
    /// Periods integrated.
    pub periods: usize,
    /// 1 for a response with the forcing's period, k for a period-k (subharmonic) one.
    pub period_multiple: usize,
    /// One per requested response.
    pub measures: Vec<Measures>,
    /// State at the end (forcing phase 0), to start the next frequency of a sequential sweep.
    pub end: State,
    /// The coordinates (nq) at the samples of the measured period(s), the endpoint
    /// excluded: what [`wells::Wells::classify`] reads.
    pub orbit: Vec<Vec<f64>>,
    /// Right-hand-side evaluations of its integrations (0 for a case read back from a
    /// checkpoint or a CSV: nothing was integrated).
    pub rhs_evaluations: usize,
}

/// Steady response from `start` (t = 0 at forcing phase 0) at the system's forcing
/// frequency ω (its live `forcing_frequency` parameter: the one value the loads and the
/// sampling both read). The responses are measured from their values at the samples
/// (coordinates read from q; other responses evaluated at each sample's t, q, v).
///
/// The motion is integrated continuously across periods (one integration, sampled
/// `opts.samples` times a period); a run is restarted only where the Poincaré sequence is
/// extrapolated (or an extrapolation is undone), since the state then jumps.
pub fn steady_state(
    sys: &System,
    start: &State,
    responses: &[Output],
    opts: &SteadyOptions,
    cancel: &AtomicBool,
) -> Result<SteadyState> {
    steady_state_watched(sys, start, responses, opts, cancel, &|_| {})
}

/// [`steady_state`], and `stiff` hears as soon as an integration (DOP853) is found stiff
/// (see [`crate::dynamics::integrator`]); the computation goes on.
pub fn steady_state_watched(
    sys: &System,
    start: &State,
    responses: &[Output],
    opts: &SteadyOptions,
    cancel: &AtomicBool,
    stiff: &(dyn Fn(&Stiffness) + Sync),
) -> Result<SteadyState> {
    let mut probe = Probe::new(sys, responses.to_vec());
    let omega = sys.forcing_frequency().ok_or(Invalid::NoForcingFrequency)?;
    let period = 2.0 * std::f64::consts::PI / omega;
    let per = opts.samples;
    let dof = sys
        .nv()
        .saturating_sub(crate::dynamics::constraint_rank(sys, &start.q, 0.0));
    let mut map = Poincare {
        sys,
        ws: DynWorkspace::new(sys),
        q_ref: start.q.clone(),
        order: (2 * dof).clamp(1, 8),
        points: Vec::new(),
        recent: Vec::new(),
        recent_q: Vec::new(),
        extrapolate: opts.extrapolate,
        pending_check: None,
        last_change: f64::INFINITY,
        responses: responses.len(),
        opts,
        omega,
    };
    map.points.push(map.pack(start));
    let mut state = start.clone();
    let total = opts.fixed_periods.unwrap_or(opts.max_periods);
    let mut done = 0; // periods integrated
    let mut rhs_evaluations = 0;
    let mut outcome: Option<SteadyState> = None;
    // The integrated state an extrapolation replaced, while the run goes on from it.
    let mut before_extrapolation: Option<State> = None;
    while done < total && outcome.is_none() {
        if cancel.load(Ordering::Relaxed) {
            return Err(Failure::SweepInterrupted.into());
        }
        let sim = SimOptions {
            t_end: (total - done) as f64 * period,
            dt_out: period / per as f64,
            rtol: opts.rtol,
            atol: opts.atol,
            integrator: opts.integrator,
            ..SimOptions::default()
        };
        // this period's samples (q, v), the first one being the previous period's end
        let mut buf: Vec<(Vec<f64>, Vec<f64>)> = Vec::with_capacity(per + 1);
        // and the responses at each of them
        let mut vals: Vec<Vec<f64>> = Vec::with_capacity(per + 1);
        let mut restart: Option<State> = None;
        let mut last = state.clone();
        // this run's t = 0, in the time integrated at this frequency so far
        let t0 = done as f64 * period;
        let run = crate::dynamics::simulate::simulate_watched(
            sys,
            &state,
            &sim,
            &mut |t, q, v| {
                buf.push((q.to_vec(), v.to_vec()));
                vals.push(probe.values(sys, t, q, v));
                if buf.len() < per + 1 {
                    return true;
                }
                done += 1;
                let end = State {
                    t: 0.0,
                    q: q.to_vec(),
                    v: v.to_vec(),
                };
                let action = if opts.fixed_periods.is_some() {
                    map.record(&buf, &vals);
                    Action::Continue
                } else {
                    map.period_end(&buf, &vals, &end, done)
                };
                last = end;
                buf.drain(..per);
                vals.drain(..per);
                match action {
                    Action::Continue => done < total,
                    Action::Settled(s) => {
                        outcome = Some(s);
                        false
                    }
                    Action::Restart(s) => {
                        restart = Some(s);
                        false
                    }
                }
            },
            &mut |_| !cancel.load(Ordering::Relaxed),
            &mut |s| stiff(s),
        );
        let stats = match run {
            Ok(stats) => stats,
            // A run from an extrapolated state that cannot be integrated (MPE of a
            // transient far from settled can guess a wild state that still lies on the
            // constraints) is undone, as a worse one is: plain iteration goes on from the
            // integrated state the extrapolation replaced. A failure of plain iteration
            // is the motion's own, and is returned.
            Err(_) if !cancel.load(Ordering::Relaxed) && before_extrapolation.is_some() => {
                let fallback = before_extrapolation.take().expect("checked");
                map.undo_extrapolation(&fallback);
                state = fallback;
                continue;
            }
            // its time counted from this frequency's first period, not from the run's
            // restart
            Err(crate::diag::Error::Failed {
                failure,
                context,
                at,
            }) => {
                return Err(crate::diag::Error::Failed {
                    failure: failure.later_by(t0),
                    context,
                    at,
                });
            }
            Err(e) => return Err(e),
        };
        rhs_evaluations += stats.rhs_evaluations;
        state = restart.unwrap_or(last);
        // the next run starts from an extrapolation (to be checked), or from an
        // integrated state (plain iteration, or an extrapolation undone)
        before_extrapolation = map.pending_check.as_ref().map(|(_, end)| end.clone());
    }
    if let Some(mut s) = outcome {
        s.rhs_evaluations = rhs_evaluations;
        return Ok(s);
    }
    // Not settled (or the fixed protocol): the last period's measures, flagged.
    let measures = (0..responses.len())
        .map(|r| Measures::of(&map.recent.last().expect("one period")[r], 1))
        .collect();
    Ok(SteadyState {
        omega,
        settled: false,
        periods: total,
        period_multiple: 1,
        measures,
        end: state,
        orbit: map.recent_q.last().cloned().unwrap_or_default(),
        rhs_evaluations,
    })
}

/// What to do after a period.
enum Action {
    Continue,
    Settled(SteadyState),
    /// Restart from this state (an extrapolation, or one undone).
    Restart(State),
}

/// The Poincaré map of one frequency: its points since the last extrapolation, the
/// sampled last 4 periods, and the extrapolation's state.
struct Poincare<'a> {
    sys: &'a System,
    ws: DynWorkspace,
    q_ref: Vec<f64>,
    order: usize,
    points: Vec<DVector<f64>>,
    /// Per period, per response: the samples (without the period's end).
    recent: Vec<Vec<Vec<f64>>>,
    /// Per period: the coordinates at its samples (without the period's end).
    recent_q: Vec<Vec<Vec<f64>>>,
    extrapolate: bool,
    pending_check: Option<(f64, State)>,
    last_change: f64,
    /// Number of responses.
    responses: usize,
    opts: &'a SteadyOptions,
    omega: f64,
}

impl Poincare<'_> {
    fn pack(&self, s: &State) -> DVector<f64> {
        pack(self.sys, &self.q_ref, s)
    }

    /// Keep the samples of a period (`buf`: the states at its samples and its end,
    /// `vals`: the responses there).
    fn record(&mut self, buf: &[(Vec<f64>, Vec<f64>)], vals: &[Vec<f64>]) {
        let k_last = vals.len() - 1;
        self.recent_q
            .push(buf[..k_last].iter().map(|(q, _)| q.clone()).collect());
        if self.recent_q.len() > 4 {
            self.recent_q.remove(0);
        }
        self.recent.push(
            (0..self.responses)
                .map(|r| vals[..k_last].iter().map(|s| s[r]).collect())
                .collect(),
        );
        if self.recent.len() > 4 {
            self.recent.remove(0);
        }
    }

    /// Give up extrapolating: the sequence starts again at `fallback`, the integrated
    /// state an extrapolation replaced, and plain iteration goes on from it.
    fn undo_extrapolation(&mut self, fallback: &State) {
        self.extrapolate = false;
        self.pending_check = None;
        self.points = vec![self.pack(fallback)];
    }

    /// The end of period `p` (`buf` its samples, `vals` the responses at them, `end` its
    /// end state).
    fn period_end(
        &mut self,
        buf: &[(Vec<f64>, Vec<f64>)],
        vals: &[Vec<f64>],
        end: &State,
        p: usize,
    ) -> Action {
        let opts = self.opts;
        self.record(buf, vals);
        let y = self.pack(end);
        let scale = amplitude_scale(buf);
        let change = relative_change(
            y.as_slice(),
            self.points.last().expect("non-empty").as_slice(),
            scale.as_slice(),
        );
        // An extrapolation that made things worse is undone.
        if let Some((before, fallback)) = self.pending_check.take()
            && change > before
        {
            self.undo_extrapolation(&fallback);
            return Action::Restart(fallback);
        }
        self.points.push(y.clone());
        let points = &self.points;
        // Settled with the forcing's period, or with k periods.
        for k in 1..=4 {
            // a period-k response repeats its whole cycle: the last k Poincaré points all
            // agree with the points k periods before them (a slowly decaying transient
            // that alternates can match once, not k times in a row)
            let need = if k == 1 { 2 } else { 2 * k };
            if points.len() >= need && self.recent.len() >= k {
                let len = points.len();
                let c = (0..if k == 1 { 1 } else { k })
                    .map(|j| {
                        relative_change(
                            points[len - 1 - j].as_slice(),
                            points[len - 1 - j - k].as_slice(),
                            scale.as_slice(),
                        )
                    })
                    .fold(0.0, f64::max);
                let shorter = (1..k).any(|j| {
                    points.len() > j
                        && relative_change(
                            y.as_slice(),
                            points[points.len() - 1 - j].as_slice(),
                            scale.as_slice(),
                        ) <= opts.settle_tol
                });
                if c <= opts.settle_tol && !shorter {
                    let window = &self.recent[self.recent.len() - k..];
                    let measures = (0..self.responses)
                        .map(|r| {
                            let samples: Vec<f64> =
                                window.iter().flat_map(|w| w[r].iter().copied()).collect();
                            Measures::of(&samples, k)
                        })
                        .collect();
                    let orbit = self.recent_q[self.recent_q.len() - k..].concat();
                    return Action::Settled(SteadyState {
                        omega: self.omega,
                        settled: true,
                        periods: p,
                        period_multiple: k,
                        measures,
                        end: end.clone(),
                        orbit,
                        // the caller adds its integrations' count
                        rhs_evaluations: 0,
                    });
                }
            }
        }
        // Extrapolate the Poincaré sequence once enough points are in.
        let mut action = Action::Continue;
        if self.extrapolate
            && points.len() >= self.order + 2
            && change < self.last_change
            && let Some(s) = mpe(&points[points.len() - self.order - 2..])
        {
            let sys = self.sys;
            let mut guess = unpack(sys, &self.q_ref, &s);
            let pos = project_position(sys, &mut self.ws, &mut guess.q, 0.0, 1e-14, 10);
            project_velocity(sys, &mut self.ws, &guess.q, &mut guess.v, 0.0);
            let vel = velocity_residual_blocks(sys, &mut self.ws, &guess.q, &guess.v, 0.0);
            // only a guess that lies on the constraints (an extrapolation far off the
            // manifold may not project back: the run would then fail on it)
            let size = 1.0 + amax(&guess.q) + amax(&guess.v);
            if pos <= 1e-10 * size && vel <= 1e-9 * size {
                self.pending_check = Some((change, end.clone()));
                self.points = vec![self.pack(&guess)];
                action = Action::Restart(guess);
            }
        }
        self.last_change = change;
        action
    }
}

/// A state as one vector for the Poincaré sequence: the coordinates as the tangent from
/// `q_ref` (so the extrapolation works on the tangent space, whatever the coordinates
/// are), then the velocities.
fn pack(sys: &System, q_ref: &[f64], s: &State) -> DVector<f64> {
    let nv = sys.nv();
    let mut y = DVector::zeros(2 * nv);
    sys.difference(&s.q, q_ref, &mut y.as_mut_slice()[..nv]);
    y.rows_mut(nv, nv).copy_from_slice(&s.v);
    y
}

/// The state of a packed vector (see [`pack`]): q = q_ref ⊕ δ.
fn unpack(sys: &System, q_ref: &[f64], y: &DVector<f64>) -> State {
    let nv = sys.nv();
    let mut q = q_ref.to_vec();
    sys.retract(&mut q, &y.as_slice()[..nv], 1.0);
    State {
        t: 0.0,
        q,
        v: y.as_slice()[nv..].to_vec(),
    }
}

/// Half peak-to-peak of every state component over a period (positions and velocities).
fn amplitude_scale(samples: &[(Vec<f64>, Vec<f64>)]) -> DVector<f64> {
    let n = samples[0].0.len();
    DVector::from_fn(2 * n, |i, _| {
        let series = |s: &(Vec<f64>, Vec<f64>)| if i < n { s.0[i] } else { s.1[i - n] };
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for s in samples {
            lo = lo.min(series(s));
            hi = hi.max(series(s));
        }
        0.5 * (hi - lo)
    })
}

/// max_i |a_i − b_i| / (scale_i + floor): change relative to each component's amplitude.
/// The floor (the largest amplitude of the same kind, positions or velocities, and 1e-14)
/// keeps components that hardly move from dominating: a coordinate that follows the
/// others through a constraint at second order (a pendulum's height, 1e-9 m at a
/// 1e-4 rad swing) carries the projection's noise (1e-13), which no settling removes.
/// The state is positions then velocities, as many of each (a Poincaré point here, a
/// periodic orbit's state in [`crate::periodic`]).
pub(crate) fn relative_change(a: &[f64], b: &[f64], scale: &[f64]) -> f64 {
    let n = a.len() / 2;
    let qmax = scale[..n].iter().fold(0.0f64, |m, s| m.max(*s));
    let vmax = scale[n..].iter().fold(0.0f64, |m, s| m.max(*s));
    (0..a.len())
        .map(|i| {
            let floor = if i < n { qmax } else { vmax } + 1e-14;
            (a[i] - b[i]).abs() / (scale[i] + floor)
        })
        .fold(0.0, f64::max)
}

/// Minimal polynomial extrapolation of a vector sequence x_0..x_{k+1} to its limit.
fn mpe(x: &[DVector<f64>]) -> Option<DVector<f64>> {
    let k = x.len() - 2;
    let d = x[0].len();
    // differences u_j = x_{j+1} − x_j
    let u = DMatrix::from_fn(d, k + 1, |i, j| x[j + 1][i] - x[j][i]);
    let a = u.columns(0, k).into_owned();
    let b = -u.column(k).into_owned();
    let svd = crate::linalg::svd_or_nan(a, true, true);
    let eps = 1e-12 * svd.singular_values.max();
    let c = svd.solve(&b, eps).ok()?;
    let mut coef: Vec<f64> = c.iter().copied().collect();
    coef.push(1.0);
    let sum: f64 = coef.iter().sum();
    if sum.abs() < 1e-12 {
        return None;
    }
    let mut s = DVector::zeros(d);
    for (j, cj) in coef.iter().enumerate() {
        s += &x[j] * (cj / sum);
    }
    Some(s)
}

/// How a sweep moves through its frequencies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// Every frequency from the equilibrium at rest.
    Independent,
    /// Increasing frequency, each from the previous steady state.
    Up,
    /// Decreasing frequency, each from the previous steady state.
    Down,
}

impl Direction {
    pub fn name(self) -> &'static str {
        match self {
            Direction::Independent => "independent",
            Direction::Up => "up",
            Direction::Down => "down",
        }
    }
}

/// Sweep modes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SweepMode {
    Independent,
    Up,
    Down,
    Both,
}

/// Settings of a sweep.
#[derive(Debug, Clone)]
pub struct SweepOptions {
    /// The forcing's frequency parameter.
    pub param: String,
    /// Coarse grid, rad/s, ascending.
    pub values: Vec<f64>,
    pub mode: SweepMode,
    /// Responses (names: coordinates, or any response `System::output` resolves).
    pub responses: Vec<String>,
    /// Final resolution of the located peaks, rad/s (None: no refinement).
    pub refine: Option<f64>,
    pub steady: SteadyOptions,
}

/// One computed frequency.
#[derive(Debug, Clone)]
pub struct SweepPoint {
    pub direction: Direction,
    pub steady: SteadyState,
    /// Added by peak refinement (not on the coarse grid).
    pub refined: bool,
    /// The equilibrium the response oscillates about: an index into
    /// [`Sweep::wells`]' equilibria, or [`wells::SPANS`] (−1) for an orbit that spans two
    /// wells.
    pub well: isize,
}

/// A located resonance.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Peak {
    pub response: String,
    pub direction: Direction,
    /// Frequency of the amplitude maximum, rad/s.
    pub omega: f64,
    /// Half peak-to-peak amplitude there (SI).
    pub amplitude: f64,
    /// rad/s: the larger of the final bracket's half-width and the shift of the maximum
    /// that amplitude errors at the settling tolerance can cause (see `refine_peak`).
    pub uncertainty: f64,
}

/// A response of a sweep whose peaks were not sought (see [`Sweep::no_peaks`]).
#[derive(Debug, Clone, serde::Serialize)]
pub struct NoPeaks {
    pub response: String,
    pub direction: Direction,
    /// Why, with the numbers (the response's unit).
    #[serde(flatten)]
    pub why: measure::Still,
}

/// An edge of a sequential (`up`/`down`) sweep where the response jumps: between two
/// neighbouring frequencies of the coarse grid, in the sweep's order (see [`jumps`]).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Jump {
    pub response: String,
    pub direction: Direction,
    /// The frequency before the jump, rad/s (in the sweep's order: `from > to` down).
    pub from: f64,
    /// The frequency after it, rad/s.
    pub to: f64,
    /// Half peak-to-peak amplitude at `from` (SI).
    pub amplitude_before: f64,
    /// Half peak-to-peak amplitude at `to` (SI).
    pub amplitude_after: f64,
}

/// A frequency interval where the up and down sweeps settle on different responses.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Hysteresis {
    pub from: f64,
    pub to: f64,
}

/// The result of a sweep.
#[derive(Debug, Clone)]
pub struct Sweep {
    pub param: String,
    pub responses: Vec<String>,
    /// The SI unit of each response.
    pub units: Vec<&'static str>,
    pub coordinates: Vec<String>,
    /// Equilibrium the sweep starts from.
    pub equilibrium: Vec<f64>,
    /// Sorted by direction, then frequency.
    pub points: Vec<SweepPoint>,
    /// Local maxima of the amplitude within one well, jump edges excluded.
    pub peaks: Vec<Peak>,
    /// The responses whose peaks were not sought, per direction, and why: they do not
    /// move beyond round-off, or their amplitude does not change along the curve by more
    /// than the integration's noise (see [`measure::stillness`]). A real resonance of a motion
    /// too small against its coordinate's value for the tolerances is among them: said,
    /// not dropped without a word.
    pub no_peaks: Vec<NoPeaks>,
    /// Jumps of the sequential sweeps (`up`, `down`, `both`).
    pub jumps: Vec<Jump>,
    /// The equilibria the responses are classified by, and the one the sweep starts from.
    pub wells: wells::Wells,
    /// Where up and down differ by more than 1 % (mode `both`).
    pub hysteresis: Vec<Hysteresis>,
    /// False when interrupted or stopped by a failure: `points` holds what was computed
    /// (on a failure, the frequencies before the failing one: see [`Sweep::failure`]).
    pub complete: bool,
    /// The frequency whose steady state could not be computed, where the sweep stopped
    /// (None: it did not fail). The sweep keeps what it had finished before it, marked
    /// incomplete, as an interrupted one does; [`Sweep::into_result`] turns it into the
    /// error for a caller that wants the whole curve or nothing.
    pub failure: Option<SweepFailure>,
    /// The first integration of the sweep found stiff (DOP853's steps held by the
    /// model's fastest motion), with its frequency: the sweep is right but slow, and
    /// `--integrator radau` is the remedy. None with Radau, or when nothing was stiff.
    pub stiffness: Option<StiffAt>,
    /// Right-hand-side evaluations of every steady state this run integrated: the coarse
    /// grid, the jump checks and the refinement (cases read from a checkpoint count 0).
    pub rhs_evaluations: usize,
}

/// A stiff integration of a sweep: at which forcing frequency, and the numbers.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StiffAt {
    /// The forcing frequency of the steady state whose integration was found stiff, rad/s.
    pub omega: f64,
    pub stiffness: Stiffness,
}

/// A frequency whose steady state could not be computed (the integration toward it
/// failed: a singular pose, a step size that fell to zero, a non-finite value), where a
/// sweep stops. What a sweep keeps then is deterministic, whatever the threads did: an
/// independent sweep keeps every frequency of the grid below the lowest failing one
/// (frequencies above it that are not started yet are skipped; any finished ones are
/// dropped from the result, though a checkpoint keeps them), an `up`/`down` sweep the
/// frequencies before it in its order (a `both` sweep that fails going up does not go
/// down); a failure in a jump check or a peak refinement keeps the whole coarse grid
/// (and the peaks refined, the jumps found).
#[derive(Debug, Clone)]
pub struct SweepFailure {
    /// The failing frequency, rad/s.
    pub omega: f64,
    pub direction: Direction,
    /// The coarse grid, a jump check (the step back over a steep edge) or a peak's
    /// refinement.
    pub kind: checkpoint::CaseKind,
    /// What went wrong there (with the frequency in its context).
    pub error: Error,
}

impl SweepFailure {
    /// What went wrong, in one line, without the frequency (the failure's own words).
    pub fn reason(&self) -> String {
        self.error.headline()
    }

    /// What the sweep kept, in words, by stage: the coarse grid's frequencies before the
    /// failing one; after a jump check, the whole coarse grid (no jumps from that edge
    /// on); after a peak refinement, the whole coarse grid and the other peaks (this peak
    /// left out).
    pub fn kept(&self) -> &'static str {
        match self.kind {
            checkpoint::CaseKind::Coarse => "the frequencies completed before it",
            checkpoint::CaseKind::Back => {
                "the whole coarse grid; the jumps from that edge on were not checked"
            }
            checkpoint::CaseKind::Refine => {
                "the whole coarse grid and the other peaks; the peak being refined there is left out"
            }
        }
    }

    /// The stage the failing frequency belongs to, in words.
    pub fn stage(&self) -> &'static str {
        match self.kind {
            checkpoint::CaseKind::Coarse => "the coarse grid",
            checkpoint::CaseKind::Back => "a jump check",
            checkpoint::CaseKind::Refine => "a peak refinement",
        }
    }
}

impl Sweep {
    /// The SI unit of a response of this sweep ("" for a name it does not have).
    pub fn unit_of(&self, response: &str) -> &'static str {
        self.responses
            .iter()
            .position(|r| r == response)
            .map_or("", |i| self.units[i])
    }

    /// The sweep, or the error of the frequency it failed at (a caller that needs the
    /// whole curve: its peaks, a verdict on them). An interrupted sweep is returned as is.
    pub fn into_result(self) -> Result<Sweep> {
        match self.failure {
            Some(f) => Err(f.error),
            None => Ok(self),
        }
    }
}

/// How a case of a sweep ended badly: `Stop`, an error that ends the sweep (a checkpoint
/// that cannot be read or written, an interruption); `Failed`, the frequency's steady
/// state could not be computed (the sweep keeps what it finished before it).
enum CaseError {
    Stop(Error),
    Failed(SweepFailure),
}

impl From<Error> for CaseError {
    fn from(e: Error) -> Self {
        CaseError::Stop(e)
    }
}

type CaseResult = std::result::Result<(SteadyState, isize), CaseError>;

/// Hears of a sweep's first stiff integration (its frequency and the numbers), as soon as
/// it is found: a front end warns then, not after the sweep.
pub type StiffHook<'a> = &'a (dyn Fn(&StiffAt) + Sync);

fn check_request(sys: &System, opts: &SweepOptions) -> Result<usize> {
    let index = crate::linear::check_frequencies(sys, &opts.param, &opts.values)?;
    if let Some(r) = opts.refine
        && (!(r > 0.0) || !r.is_finite())
    {
        return Err(Invalid::NotPositive {
            argument: Argument::Refine,
            value: r,
        }
        .into());
    }
    // A peak's bracket is its two neighbours, 2 steps wide.
    if let (Some(r), [w0, w1, ..]) = (opts.refine, opts.values.as_slice())
        && r >= 2.0 * (w1 - w0).abs()
    {
        return Err(Invalid::RefineTooCoarse {
            refine: r,
            step: (w1 - w0).abs(),
        }
        .into());
    }
    if opts.steady.max_periods == 0 {
        return Err(Invalid::Zero {
            argument: Argument::MaxPeriods,
        }
        .into());
    }
    if opts.steady.fixed_periods == Some(0) {
        return Err(Invalid::Zero {
            argument: Argument::FixedPeriods,
        }
        .into());
    }
    // a frequency's simulation writes `samples` a period: refuse here, naming the
    // periods, what its own check would blame on a duration the sweep has no flag for
    let (argument, periods) = match opts.steady.fixed_periods {
        Some(n) => (Argument::FixedPeriods, n),
        None => (Argument::MaxPeriods, opts.steady.max_periods),
    };
    let samples = periods as f64 * opts.steady.samples as f64;
    let limit = crate::dynamics::simulate::MAX_SAMPLES;
    if samples > limit as f64 {
        return Err(Invalid::TooManyPoints {
            argument,
            value: periods as f64,
            points: samples,
            limit,
        }
        .into());
    }
    Ok(index)
}

/// Everything a sweep checks before it simulates: the request, the responses, the
/// equilibrium it starts from (under the loads' mean over a forcing
/// period, see [`crate::linear::at_frequency`]) and a non-zero forcing. Cheap (no
/// simulation): call it on every model of a family before sweeping any of them.
pub fn prepare(sys: &System, opts: &SweepOptions) -> Result<(System, Vec<Output>, Equilibrium)> {
    let index = check_request(sys, opts)?;
    let sys0 = crate::linear::at_frequency(sys, index, opts.values[0])?;
    let responses = sys0.outputs(&opts.responses)?;
    let start = crate::dynamics::assemble_at_rest(&sys0)?;
    let st = Statics::new(&sys0, &start.q)?;
    let eq = st.nearest(&start)?;
    crate::linear::harmonic_forcing(&sys0, &eq, &st.rows, &opts.param, opts.values[0])?;
    Ok((sys0, responses, eq))
}

/// Run a sweep. `progress` is called with the number of frequencies done (coarse grid
/// and refinement); `cancel` stops it within one integration step, returning what was computed with
/// `complete = false`. A frequency whose steady state cannot be computed is an error (its
/// own, with the frequency in its context): nothing is returned. [`sweep_logged_partial`]
/// keeps what a failing sweep finished instead (the `detune sweep` command's way).
pub fn sweep(
    sys: &System,
    opts: &SweepOptions,
    progress: &(dyn Fn(usize) + Sync),
    cancel: &AtomicBool,
) -> Result<Sweep> {
    sweep_watched(sys, opts, progress, cancel, &|_| {})
}

/// [`sweep`], and `stiff` hears of the first integration found stiff, as soon as it is
/// (the sweep goes on; [`Sweep::stiffness`] keeps the same numbers).
pub fn sweep_watched(
    sys: &System,
    opts: &SweepOptions,
    progress: &(dyn Fn(usize) + Sync),
    cancel: &AtomicBool,
    stiff: StiffHook,
) -> Result<Sweep> {
    let report = |p: Progress| progress(p.grid + p.refined);
    sweep_logged(sys, opts, &report, cancel, &checkpoint::NoLog, 0, stiff)
}

/// How far a sweep is: steady states of the coarse grid done (with the jump checks of
/// the sequential modes), and of the peak refinement (done, and the number expected: two
/// per bisection round of each peak's bracket).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Progress {
    pub grid: usize,
    pub refined: usize,
    pub refine_expected: usize,
}

/// [`sweep`] as run `run` of a study, its steady states looked up in and recorded to
/// `log` (a checkpoint: see [`checkpoint`]): a case the log knows is not computed again,
/// each case computed is recorded as soon as it is done, and an independent sweep
/// computes only the coarse-grid frequencies the log selects (a shard; the sweep is then
/// partial: no peaks, jumps or hysteresis, which need the whole curve). A failing
/// frequency is an error, as for [`sweep`] (the log keeps the cases recorded before it).
pub fn sweep_logged(
    sys: &System,
    opts: &SweepOptions,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
    log: &dyn checkpoint::CaseLog,
    run: usize,
    stiff: StiffHook,
) -> Result<Sweep> {
    sweep_logged_partial(sys, opts, progress, cancel, log, run, stiff)?.into_result()
}

/// [`sweep_logged`], keeping what a failing sweep finished: a frequency whose steady
/// state cannot be computed stops the sweep, which is returned with `complete = false`
/// and the failure in [`Sweep::failure`] (what is kept: see [`SweepFailure`]). A caller
/// must look at `failure` (or call [`Sweep::into_result`]): the curve may be partial.
pub fn sweep_logged_partial(
    sys: &System,
    opts: &SweepOptions,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
    log: &dyn checkpoint::CaseLog,
    run: usize,
    stiff: StiffHook,
) -> Result<Sweep> {
    use checkpoint::{CaseKey, CaseKind};
    // the first stiff integration, told once (the steady states run in parallel)
    let stiffness: std::sync::OnceLock<StiffAt> = std::sync::OnceLock::new();
    let (sys0, responses, eq) = prepare(sys, opts)?;
    let index = sys0.forcing_param().expect("checked by prepare");
    // the wells: the statics under the loads' mean, the same at every ω of the sweep
    let wells = wells::Wells::find(&sys0, &eq);
    // Start states are kept relative to the ground (which may move with the forcing):
    // each frequency starts from one with the ground's velocity at that frequency.
    let rest = State {
        t: 0.0,
        q: eq.q.clone(),
        v: vec![0.0; sys0.nv()],
    };
    let grid_done = AtomicUsize::new(0);
    let rhs_evaluations = AtomicUsize::new(0);
    let refine_done = AtomicUsize::new(0);
    let refine_expected = AtomicUsize::new(0);
    let report = || {
        progress(Progress {
            grid: grid_done.load(Ordering::SeqCst),
            refined: refine_done.load(Ordering::SeqCst),
            refine_expected: refine_expected.load(Ordering::SeqCst),
        })
    };
    let at = |omega: f64| sys0.with_param(index, omega);
    // one compiled system; each frequency sets its parameter on a copy (no recompiling),
    // and the integration reads ω from it: one source of truth
    let eval = |omega: f64, from: &State| -> Result<SteadyState> {
        let s = at(omega)?;
        let start = absolute(&s, from);
        let found = |st: &Stiffness| {
            let at = StiffAt {
                omega,
                stiffness: st.clone(),
            };
            if stiffness.set(at).is_ok()
                && let Some(at) = stiffness.get()
            {
                stiff(at);
            }
        };
        let st = steady_state_watched(&s, &start, &responses, &opts.steady, cancel, &found)
            .map_err(|e| e.context(&format!("{} = {omega}", opts.param)))?;
        rhs_evaluations.fetch_add(st.rhs_evaluations, Ordering::SeqCst);
        Ok(st)
    };
    // one case: from the log if it has it, else computed, classified by well and recorded
    let case = |kind: CaseKind, dir: Direction, omega: f64, from: &State| -> CaseResult {
        let key = CaseKey {
            run,
            kind,
            direction: dir,
            omega: omega.to_bits(),
        };
        let out = match log.lookup(&key)? {
            Some(known) => known,
            None => {
                let s = match eval(omega, from) {
                    Ok(s) => s,
                    // an interruption, not a failure of this frequency
                    Err(e) if cancel.load(Ordering::Relaxed) => return Err(CaseError::Stop(e)),
                    Err(error) => {
                        return Err(CaseError::Failed(SweepFailure {
                            omega,
                            direction: dir,
                            kind,
                            error,
                        }));
                    }
                };
                let well = wells.classify(&sys0, &s.orbit);
                log.record(&key, &s, well)?;
                (s, well)
            }
        };
        match kind {
            CaseKind::Refine => refine_done.fetch_add(1, Ordering::SeqCst),
            _ => grid_done.fetch_add(1, Ordering::SeqCst),
        };
        report();
        Ok(out)
    };
    // the end of a steady state at ω, relative to the ground
    let relative_end = |s: &SteadyState| -> Result<State> { Ok(relative(&at(s.omega)?, &s.end)) };
    let mut points: Vec<SweepPoint> = Vec::new();
    let mut complete = true;
    let mut failure: Option<SweepFailure> = None;
    // a shard's share of an independent sweep: the curve is not whole
    let mut partial = false;
    let directions: Vec<Direction> = match opts.mode {
        SweepMode::Independent => vec![Direction::Independent],
        SweepMode::Up => vec![Direction::Up],
        SweepMode::Down => vec![Direction::Down],
        SweepMode::Both => vec![Direction::Up, Direction::Down],
    };
    for &dir in &directions {
        let (pts, ok) = match dir {
            Direction::Independent => {
                let mine: Vec<usize> = (0..opts.values.len())
                    .filter(|&i| log.selected(run, i))
                    .collect();
                partial |= mine.len() < opts.values.len();
                // after a failure, the frequencies above the lowest failing one so far are
                // not started: the result keeps those below the lowest failing one, which
                // are never skipped (deterministic, whatever the threads do)
                let lowest_failed = AtomicUsize::new(usize::MAX);
                let results: Vec<Option<CaseResult>> = mine
                    .par_iter()
                    .map(|&i| {
                        if i > lowest_failed.load(Ordering::SeqCst) {
                            return None;
                        }
                        let r = case(CaseKind::Coarse, dir, opts.values[i], &rest);
                        if matches!(r, Err(CaseError::Failed(_))) {
                            lowest_failed.fetch_min(i, Ordering::SeqCst);
                        }
                        Some(r)
                    })
                    .collect();
                collect(results.into_iter().flatten().collect(), dir)
            }
            Direction::Up | Direction::Down => {
                let mut order: Vec<f64> = opts.values.clone();
                if dir == Direction::Down {
                    order.reverse();
                }
                let mut from = rest.clone();
                let mut results = Vec::new();
                for w in order {
                    let r = case(CaseKind::Coarse, dir, w, &from);
                    if let Ok((s, _)) = &r {
                        from = relative_end(s)?;
                    }
                    let stop = r.is_err();
                    results.push(r);
                    if stop {
                        break;
                    }
                }
                collect(results, dir)
            }
        };
        let (ok, failed) = ok;
        if let Err(e) = ok {
            if !cancel.load(Ordering::Relaxed) {
                return Err(e);
            }
            complete = false;
        }
        if failed.is_some() {
            failure = failed;
            complete = false;
        }
        points.extend(pts);
        if !complete {
            break;
        }
    }
    // Jumps of the sequential sweeps, on the coarse grid. An edge (ω_k → ω_k+1 in the
    // sweep's order) whose response changes well is a jump; one whose amplitude changes
    // steeply is stepped back: the steady state at ω_k from the one at ω_k+1. On a smooth
    // curve (one response at ω_k, however steep the flank) it is the same response; past a
    // fold it is another (the branch the sweep jumped to still exists at ω_k): a jump.
    // which responses of a line have no peaks and no jumps to find: round-off, or an
    // amplitude that does not change beyond the integration's noise (`measure::stillness`)
    let units: Vec<&str> = responses.iter().map(|o| o.unit(&sys0)).collect();
    let still_of = |line: &[&SweepPoint]| {
        measure::stillness(
            &(0..responses.len())
                .map(|r| line.iter().map(|p| p.steady.measures[r]).collect())
                .collect::<Vec<Vec<_>>>(),
            &units,
            opts.steady.atol,
            opts.steady.rtol,
        )
    };
    let mut jumps = Vec::new();
    if complete && !partial {
        'jumps: for &dir in directions.iter().filter(|d| **d != Direction::Independent) {
            let mut line: Vec<&SweepPoint> = points
                .iter()
                .filter(|p| p.direction == dir && !p.refined)
                .collect();
            line.sort_by(|a, b| a.steady.omega.total_cmp(&b.steady.omega));
            if dir == Direction::Down {
                line.reverse();
            }
            let still = still_of(&line);
            for (r, name) in opts.responses.iter().enumerate() {
                for (k, well) in jump_candidates(&line, r) {
                    // a still response's amplitude changes are its noise: no jump of
                    // its own (the inceptor's stick.z, 1e-16 m of round-off, "jumped"
                    // at seven edges of a sweep up and down); a change of well is the
                    // mechanism's, and stays
                    if still[r].is_some() && !well {
                        continue;
                    }
                    let (p0, p1) = (&line[k].steady, &line[k + 1].steady);
                    let jump = well || {
                        let back = match case(CaseKind::Back, dir, p0.omega, &relative_end(p1)?) {
                            Ok((b, _)) => b,
                            Err(CaseError::Stop(e)) if cancel.load(Ordering::Relaxed) => {
                                complete = false;
                                let _ = e;
                                break;
                            }
                            Err(CaseError::Stop(e)) => return Err(e),
                            Err(CaseError::Failed(f)) => {
                                failure = Some(f);
                                complete = false;
                                break 'jumps;
                            }
                        };
                        let (a, b) = (p0.measures[r].amplitude, back.measures[r].amplitude);
                        (a - b).abs() > JUMP_DIFFER * a.abs().max(b.abs())
                    };
                    if jump {
                        jumps.push(Jump {
                            response: name.clone(),
                            direction: dir,
                            from: p0.omega,
                            to: p1.omega,
                            amplitude_before: p0.measures[r].amplitude,
                            amplitude_after: p1.measures[r].amplitude,
                        });
                    }
                }
            }
        }
    }
    let is_jump_edge = |dir: Direction, r: usize, w0: f64, w1: f64| {
        jumps.iter().any(|j| {
            j.direction == dir
                && j.response == opts.responses[r]
                && ((j.from == w0 && j.to == w1) || (j.from == w1 && j.to == w0))
        })
    };
    // Refinement around every local maximum within one well, per response and direction.
    let mut peaks = Vec::new();
    let mut no_peaks = Vec::new();
    if complete && !partial {
        let mut jobs = Vec::new();
        for &dir in &directions {
            let mut line: Vec<&SweepPoint> = points.iter().filter(|p| p.direction == dir).collect();
            line.sort_by(|a, b| a.steady.omega.total_cmp(&b.steady.omega));
            // a response that does not move, or whose amplitude does not change, has
            // round-off for its local maxima: no peaks to refine
            let still = still_of(&line);
            for (r, why) in still.iter().enumerate() {
                if let (Some(why), true) = (why, line.len() >= 3) {
                    no_peaks.push(NoPeaks {
                        response: opts.responses[r].clone(),
                        direction: dir,
                        why: *why,
                    });
                }
            }
            for r in (0..responses.len()).filter(|&r| still[r].is_none()) {
                for i in 1..line.len().saturating_sub(1) {
                    let a = |k: usize| line[k].steady.measures[r].amplitude;
                    let w = |k: usize| line[k].steady.omega;
                    // a maximum is a resonance of one well: not a point where the response
                    // changes well, nor the edge of a jump
                    let one_well = line[i].well != wells::SPANS
                        && line[i - 1].well == line[i].well
                        && line[i + 1].well == line[i].well;
                    let edge = is_jump_edge(dir, r, w(i - 1), w(i))
                        || is_jump_edge(dir, r, w(i), w(i + 1));
                    if a(i) > a(i - 1) && a(i) >= a(i + 1) && one_well && !edge {
                        // start state on the branch: the neighbour before it in the sweep
                        let from = match dir {
                            Direction::Independent => rest.clone(),
                            Direction::Up => relative_end(&line[i - 1].steady)?,
                            Direction::Down => relative_end(&line[i + 1].steady)?,
                        };
                        jobs.push((
                            dir,
                            r,
                            line[i - 1].steady.omega,
                            line[i].steady.omega,
                            line[i + 1].steady.omega,
                            a(i),
                            from,
                        ));
                    }
                }
            }
        }
        if let Some(res) = opts.refine {
            let expected: usize = jobs
                .iter()
                .map(|(_, _, lo, _, hi, ..)| 2 * bisections(hi - lo, res))
                .sum();
            refine_expected.store(expected, Ordering::SeqCst);
            report();
        }
        let refined: Vec<std::result::Result<(Peak, Vec<SweepPoint>), CaseError>> = jobs
            .into_par_iter()
            .map(|(dir, r, lo, mid, hi, amp, from)| {
                refine_peak(
                    &|w: f64, from: &State| case(CaseKind::Refine, dir, w, from),
                    &from,
                    dir,
                    r,
                    &opts.responses[r],
                    (lo, mid, hi),
                    amp,
                    opts.refine,
                    opts.steady.settle_tol,
                )
            })
            .collect();
        for res in refined {
            match res {
                Ok((peak, extra)) => {
                    peaks.push(peak);
                    points.extend(extra);
                }
                Err(CaseError::Stop(e)) => {
                    if !cancel.load(Ordering::Relaxed) {
                        return Err(e);
                    }
                    complete = false;
                }
                // the first failing refinement in the order of the peaks (every one runs
                // to its end: which fails first is deterministic)
                Err(CaseError::Failed(f)) => {
                    failure.get_or_insert(f);
                    complete = false;
                }
            }
        }
    }
    points.sort_by(|a, b| {
        (a.direction as u8)
            .cmp(&(b.direction as u8))
            .then(a.steady.omega.total_cmp(&b.steady.omega))
    });
    points.dedup_by(|a, b| a.direction == b.direction && a.steady.omega == b.steady.omega);
    peaks.sort_by(|a, b| a.omega.total_cmp(&b.omega));
    let hysteresis = if opts.mode == SweepMode::Both && complete && !partial {
        hysteresis(&points, &opts.values)
    } else {
        Vec::new()
    };
    Ok(Sweep {
        param: opts.param.clone(),
        responses: opts.responses.clone(),
        units: responses.iter().map(|o| o.unit(&sys0)).collect(),
        coordinates: sys0.coordinates.clone(),
        equilibrium: eq.q,
        points,
        peaks,
        no_peaks,
        jumps,
        wells,
        hysteresis,
        complete,
        failure,
        stiffness: stiffness.into_inner(),
        rhs_evaluations: rhs_evaluations.into_inner(),
    })
}

/// The relative change of amplitude between neighbours above which an edge is checked
/// for a jump.
pub const JUMP_MIN_CHANGE: f64 = 0.1;

/// Two responses at one frequency differ when their amplitudes differ by more than this
/// fraction of the larger (as for hysteresis).
pub const JUMP_DIFFER: f64 = 0.01;

/// Candidate jumps of response `r` along a sequential sweep (`line`: its coarse-grid
/// points in the sweep's order), as indices k of the edges (k, k + 1): the response
/// changes well across the edge, or its amplitude changes by more than
/// [`JUMP_MIN_CHANGE`] of the larger amplitude. A candidate that changes well is a jump;
/// the others are checked by stepping back (see [`sweep`]).
fn jump_candidates(line: &[&SweepPoint], r: usize) -> Vec<(usize, bool)> {
    let amp = |k: usize| line[k].steady.measures[r].amplitude;
    (0..line.len().saturating_sub(1))
        .filter_map(|k| {
            let (a0, a1) = (amp(k), amp(k + 1));
            let well = line[k].well != line[k + 1].well;
            let steep = (a1 - a0).abs() > JUMP_MIN_CHANGE * a0.max(a1);
            (well || steep).then_some((k, well))
        })
        .collect()
}

/// A start state at t = 0 (forcing phase 0) of `sys` from one whose velocities are
/// relative to the ground: the ground's velocity at this frequency added (at rest relative
/// to a shaking ground, for `relative.v = 0`), made consistent with the constraints.
fn absolute(sys: &System, relative: &State) -> State {
    let g = sys.ground_velocity(&relative.q, 0.0);
    let mut v: Vec<f64> = relative.v.iter().zip(&g).map(|(a, b)| a + b).collect();
    if sys.rheonomic {
        let mut ws = DynWorkspace::new(sys);
        project_velocity(sys, &mut ws, &relative.q, &mut v, 0.0);
    }
    State {
        t: 0.0,
        q: relative.q.clone(),
        v,
    }
}

/// A state at t = 0 (forcing phase 0) of `sys` with its velocities relative to the
/// ground, which may move: the inverse of [`absolute`].
fn relative(sys: &System, s: &State) -> State {
    let g = sys.ground_velocity(&s.q, 0.0);
    State {
        t: 0.0,
        q: s.q.clone(),
        v: s.v.iter().zip(&g).map(|(a, b)| a - b).collect(),
    }
}

/// The rounds of bisection that bring a peak's bracket of `width` to `resolution`
/// (the refinement's expected work: two steady states a round).
fn bisections(mut width: f64, resolution: f64) -> usize {
    let mut n = 0;
    while width > resolution && n < 64 {
        width *= 0.5;
        n += 1;
    }
    n
}

/// The points of one direction's coarse grid, in the sweep's order: every one computed,
/// the first error that stops the sweep (an interruption keeps the points computed around
/// it), and the first failing frequency, before which the points end.
fn collect(
    results: Vec<CaseResult>,
    dir: Direction,
) -> (Vec<SweepPoint>, (Result<()>, Option<SweepFailure>)) {
    let mut pts = Vec::new();
    let mut status = Ok(());
    for r in results {
        match r {
            Ok((s, well)) => pts.push(SweepPoint {
                direction: dir,
                steady: s,
                refined: false,
                well,
            }),
            Err(CaseError::Stop(e)) => {
                if status.is_ok() {
                    status = Err(e);
                }
            }
            Err(CaseError::Failed(f)) => return (pts, (status, Some(f))),
        }
    }
    (pts, (status, None))
}

/// Bracket search for the amplitude maximum in (lo, hi) around `mid`, down to
/// `resolution`: each round evaluates the midpoints on both sides of the best point so far
/// (two frequencies at once, in parallel), and the bracket shrinks to the neighbours of the
/// new best point, halving it per round (golden section would gain 0.618 per evaluation, but
/// one at a time). The estimate is the vertex of the parabola through the best point and
/// its neighbours. The uncertainty is the larger of half the final bracket and the shift
/// that amplitude errors of the settling tolerance can cause: for a peak
/// A ≈ A_p − c (ω − ω_p)², an error δA = tol·A_p in the amplitudes moves the located
/// maximum by up to √(δA/c), with c from the parabola of the first round. (Asking for a
/// finer --refine than that floor refines the noise; --settle-tol lowers the floor.)
/// Deterministic: the same frequencies for any number of threads.
/// A steady state at a frequency from a start state, with the well it is in.
type Evaluate<'a> = dyn Fn(f64, &State) -> CaseResult + Sync + 'a;

#[allow(clippy::too_many_arguments)]
fn refine_peak(
    eval: &Evaluate,
    from: &State,
    dir: Direction,
    r: usize,
    name: &str,
    (lo, mid, hi): (f64, f64, f64),
    amp: f64,
    resolution: Option<f64>,
    settle_tol: f64,
) -> std::result::Result<(Peak, Vec<SweepPoint>), CaseError> {
    let mut extra = Vec::new();
    let Some(res) = resolution else {
        return Ok((
            Peak {
                response: name.to_string(),
                direction: dir,
                omega: mid,
                amplitude: amp,
                uncertainty: 0.5 * (hi - lo),
            },
            extra,
        ));
    };
    // (a, fa), (best, fb), (b, fbr): the best point and its bracketing neighbours
    let (mut a, mut b) = (lo, hi);
    let (mut xb, mut fb) = (mid, amp);
    let (mut fa, mut fbr) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    let mut curvature: Option<f64> = None;
    while b - a > res {
        // midpoints rounded to the resolution's decimals (no 4.024609375000001 in outputs)
        let (xl, xr) = (
            crate::linear::round_to_step(0.5 * (a + xb), res),
            crate::linear::round_to_step(0.5 * (xb + b), res),
        );
        let (left, right) = rayon::join(|| eval(xl, from), || eval(xr, from));
        let ((left, wl), (right, wr)) = (left?, right?);
        let (fl, fr) = (left.measures[r].amplitude, right.measures[r].amplitude);
        if curvature.is_none() {
            curvature = parabola(&[(xl, fl), (xb, fb), (xr, fr)]).map(|(c, _)| -c);
        }
        for (s, well) in [(left, wl), (right, wr)] {
            extra.push(SweepPoint {
                direction: dir,
                steady: s,
                refined: true,
                well,
            });
        }
        if fl > fb && fl >= fr {
            (b, fbr) = (xb, fb);
            (xb, fb) = (xl, fl);
        } else if fr > fb {
            (a, fa) = (xb, fb);
            (xb, fb) = (xr, fr);
        } else {
            (a, fa) = (xl, fl);
            (b, fbr) = (xr, fr);
        }
    }
    let vertex = if fa.is_finite() && fbr.is_finite() {
        parabola(&[(a, fa), (xb, fb), (b, fbr)])
            .map(|(_, v)| v)
            .filter(|v| *v >= a && *v <= b)
    } else {
        None
    };
    let noise = curvature.map_or(0.0, |c| (settle_tol * fb / c).sqrt());
    Ok((
        Peak {
            response: name.to_string(),
            direction: dir,
            omega: vertex.unwrap_or(xb),
            amplitude: fb,
            uncertainty: (0.5 * (b - a)).max(noise),
        },
        extra,
    ))
}

/// The parabola y = a x² + b x + c through three points, when it opens downward:
/// (a, vertex).
fn parabola(p: &[(f64, f64)]) -> Option<(f64, f64)> {
    if p.len() < 3 {
        return None;
    }
    let ((x0, y0), (x1, y1), (x2, y2)) = (p[0], p[1], p[2]);
    let d = (x0 - x1) * (x0 - x2) * (x1 - x2);
    if d == 0.0 {
        return None;
    }
    let a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / d;
    let b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / d;
    if a >= 0.0 {
        return None;
    }
    Some((a, -b / (2.0 * a)))
}

/// Coarse-grid intervals where the up and down sweeps differ: their amplitudes (first
/// response) by more than 1 %, or their wells (two orbits of nearly one amplitude about
/// different equilibria are different responses).
fn hysteresis(points: &[SweepPoint], grid: &[f64]) -> Vec<Hysteresis> {
    let at = |dir: Direction, w: f64| {
        points
            .iter()
            .find(|p| p.direction == dir && p.steady.omega == w && !p.refined)
            .map(|p| (p.steady.measures[0].amplitude, p.well))
    };
    let mut out: Vec<Hysteresis> = Vec::new();
    let mut open: Option<f64> = None;
    let mut last = grid[0];
    for &w in grid {
        let differ = match (at(Direction::Up, w), at(Direction::Down, w)) {
            (Some((u, wu)), Some((d, wd))) => {
                wu != wd || (u - d).abs() > 0.01 * u.abs().max(d.abs())
            }
            _ => false,
        };
        match (differ, open) {
            (true, None) => open = Some(w),
            (false, Some(s)) => {
                out.push(Hysteresis { from: s, to: last });
                open = None;
            }
            _ => {}
        }
        last = w;
    }
    if let Some(s) = open {
        out.push(Hysteresis { from: s, to: last });
    }
    out
}
