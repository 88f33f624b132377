//! Tuning: the smallest change of the varied parameters that puts every mode outside every
//! forcing band by the required margin.
//!
//! The variables are the relative changes x_i = (p_i − p0_i)/s_i (s_i = |p0_i|, or the
//! width of the range where p0_i = 0), bounded by the `--vary` ranges; the cost is
//! Σ w_i x_i². A mode passes a line when it sits below the band by the margin,
//! ω ≤ lo (1 − m − ε), or above it, ω ≥ hi (1 + m + ε), with ε = 1e-4 of clearance so that
//! the design as printed passes `margins` too. Each line and margin forbids a zone
//! [lo (1 − m), hi (1 + m)]; overlapping zones merge; a mode must sit in one of the gaps
//! between them. The feasible set is a union of boxes in frequency, one per choice of gap
//! per mode ("sides"), so every choice that the tolerance box can reach is solved as its
//! own smooth problem: SLSQP (the `slsqp` crate, a port of NLopt's) with the constraint
//! gradients from the analytic eigenvalue derivatives
//! ([`crate::linear::sensitivity::mode_derivatives`]). Each evaluation follows the modes
//! from the baseline along the straight path to the trial point, by MAC against the
//! previous step with step halving where the match is poor
//! ([`crate::linear::sensitivity::modes_followed`]), so a label stays on its physical mode
//! through a veering or a crossing. Each design
//! found is then verified as `margins` checks it: the parameters set, the trim re-solved,
//! the modes about the equilibrium nearest the initial pose, every row of the margins
//! table. Choices that cannot be met are reported with the mode and the band that block
//! them.

use crate::diag::{Error, Result};
use crate::environment::ForcingLine;
use crate::linear::sensitivity::{
    Vary, baseline_labels, evaluate, follow, mode_derivatives, oscillatory,
};
use crate::linear::tracking::Solved;
use crate::linear::{ModalAnalysis, modal_analysis};
use crate::margins::{MarginRow, Requirement, mode_points_named};
use crate::system::System;
use std::cell::RefCell;

/// Options of [`tune`].
#[derive(Debug, Clone)]
pub struct TuneOptions {
    /// Required separation, a fraction (0.1 for 10 %).
    pub margin: f64,
    /// Extra clearance beyond the margin, a fraction of the line (1e-4).
    pub clearance: f64,
    /// Weight of each varied parameter's squared relative change (1 each by default).
    pub weights: Vec<f64>,
    /// The most designs reported.
    pub max_designs: usize,
    /// The most SLSQP evaluations per side choice.
    pub max_evaluations: usize,
    /// Manufacturing tolerances the design must clear the bands over (each mode's whole
    /// interval over the tolerance box about the design, as `margins --vary` checks it);
    /// none: the nominal design only.
    pub tolerances: Vec<Tolerance>,
    /// The optimizer: SLSQP with COBYLA as fallback (default), or one of them only.
    pub optimizer: Optimizer,
}

/// Which constrained optimizer solves each choice of sides.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Optimizer {
    /// SLSQP with the analytic gradients; COBYLA where SLSQP does not meet the choice.
    #[default]
    Auto,
    /// SLSQP only.
    Slsqp,
    /// COBYLA (derivative-free) only.
    Cobyla,
}

/// A parameter's tolerance: its range about its value, given about the baseline
/// (`k_fs=±10%`). A relative tolerance scales with the design's value (±10 % of the tuned
/// k_fs); an absolute one (`±500 N/m`) is the same offset about it.
#[derive(Debug, Clone)]
pub struct Tolerance {
    /// As parsed about the baseline value.
    pub vary: Vary,
    /// Given in % of the value.
    pub relative: bool,
}

impl Tolerance {
    /// The parameter's range about the value `p` (the baseline's being `p0`).
    pub fn about(&self, p0: f64, p: f64) -> (f64, f64) {
        let (lo, hi) = self.vary.range;
        if self.relative && p0 != 0.0 {
            let (a, b) = (lo / p0 * p, hi / p0 * p);
            (a.min(b), a.max(b))
        } else {
            (p + lo - p0, p + hi - p0)
        }
    }

    /// The tolerance about the value `p`, as a [`Vary`] whose cases are its two ends.
    pub fn at(&self, p0: f64, p: f64) -> Vary {
        let (lo, hi) = self.about(p0, p);
        Vary {
            param: self.vary.param,
            name: self.vary.name.clone(),
            cases: vec![
                (format!("{}={lo}", self.vary.name), lo),
                (format!("{}={hi}", self.vary.name), hi),
            ],
            range: (lo, hi),
        }
    }
}

impl Default for TuneOptions {
    fn default() -> Self {
        TuneOptions {
            margin: 0.1,
            clearance: 1e-4,
            weights: Vec::new(),
            max_designs: 3,
            max_evaluations: 200,
            tolerances: Vec::new(),
            optimizer: Optimizer::Auto,
        }
    }
}

/// Where one mode sits relative to one line.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SideChoice {
    pub mode: String,
    pub line: String,
    /// `below` or `above`.
    pub side: &'static str,
}

/// A design that clears every band.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Design {
    /// Each varied parameter's value, SI.
    pub parameters: serde_json::Map<String, serde_json::Value>,
    /// Σ w_i ((p_i − p0_i)/s_i)².
    pub cost: f64,
    /// Each mode's side of each line.
    pub sides: Vec<SideChoice>,
    /// The verification: every mode × line as `margins` computes it at this design.
    pub margins: Vec<MarginRow>,
    /// Each mode's ω_n at this design, rad/s.
    pub modes: serde_json::Map<String, serde_json::Value>,
    /// The smallest separation over every mode and line, %.
    pub closest_pct: f64,
    /// The optimizer that found it: `SLSQP` (with the analytic gradients), `COBYLA`
    /// (derivative-free), tried where SLSQP did not meet the side choice, or
    /// `SLSQP+COBYLA` (with tolerances, SLSQP's point polished by COBYLA).
    pub optimizer: &'static str,
    /// The free parameters the design leaves at a bound of their range: a wider range
    /// would give a cheaper design.
    pub at_bounds: Vec<BoundHit>,
    /// With tolerances: each mode's lowest and highest ω_n over the tolerance box about
    /// the design (full modal analyses at its corners and along its edges), rad/s, as
    /// `margins --vary` computes them; the margins rows use these intervals.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tolerance_intervals: Option<serde_json::Map<String, serde_json::Value>>,
    /// The peaks of the design's linear frequency response (the first angle coordinate,
    /// per unit of the forcing amplitude; none when the model declares no forcing), rad/s.
    pub frf_peaks_rad_s: Vec<f64>,
    /// Whether every such peak is outside every band by the margin too (a peak sits near,
    /// not at, its mode's ω_n: a design at the margin's edge may have a peak just inside).
    pub frf_peaks_clear: Option<bool>,
    /// With `--verify sweep`: the stepped-sine peaks of the nonlinear model at this design
    /// ([`verify_sweep`]), rad/s, and whether they clear every band by the margin.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sweep_peaks_rad_s: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sweep_peaks_clear: Option<bool>,
}

/// A free parameter at a bound of its range.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BoundHit {
    pub param: String,
    /// `lower` or `upper`.
    pub bound: &'static str,
    /// The bound, SI.
    pub value: f64,
}

/// A choice of sides that no design within the bounds meets, and why.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Infeasible {
    pub sides: Vec<SideChoice>,
    /// [`Infeasible::blocked`] in words.
    pub reason: String,
    /// Why, with its numbers (None: no reason could be given).
    pub blocked: Option<Blocked>,
}

/// Why a choice of sides was not met, with its numbers (rad/s, %).
#[derive(Debug, Clone, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Blocked {
    /// The modes could not be computed at the optimizer's last point.
    NotComputed,
    /// `mode` reaches no further than `reached_rad_s` (`over_tolerances`: its lowest or
    /// highest over the tolerance box), short of `limit_rad_s`, the edge of `line`'s zone
    /// by the margin: `raise` it cannot be raised above the line, else not lowered below.
    Stays {
        mode: String,
        reached_rad_s: f64,
        limit_rad_s: f64,
        line: String,
        raise: bool,
        over_tolerances: bool,
    },
    /// Over the bounds `mode` spans only `min_rad_s`–`max_rad_s`, all within
    /// `margin_pct` of `lines`.
    Spans {
        mode: String,
        min_rad_s: f64,
        max_rad_s: f64,
        margin_pct: f64,
        lines: String,
    },
    /// The optimizer's design fails the full margins check: `mode` spans
    /// `min_rad_s`–`max_rad_s`, `separation_pct` from `line` where `required_pct` is needed.
    FailsCheck {
        over_tolerances: bool,
        mode: String,
        min_rad_s: f64,
        max_rad_s: f64,
        separation_pct: f64,
        line: String,
        required_pct: f64,
    },
    /// The design found could not be verified (the error).
    DoesNotVerify { error: String },
    /// The design found is unstable: `mode` grows at `growth_rate_1_s` = Re λ > 0 (1/s).
    Unstable { mode: String, growth_rate_1_s: f64 },
    /// The design found is stable, but its tolerance box reaches an unstable design:
    /// at `point` (a corner `k=1.1, c=-2.5`, or a point along one range) a mode grows at
    /// `growth_rate_1_s` = Re λ > 0 (1/s).
    UnstableOverTolerances { point: String, growth_rate_1_s: f64 },
    /// `mode`'s first-order interval over the tolerance box reaches `low_rad_s` ≤ 0: the
    /// tolerances are too wide for a first-order spread about the design (the box may
    /// reach an unstable design, or one with no equilibrium near the design's).
    SpreadReachesZero { mode: String, low_rad_s: f64 },
}

impl Blocked {
    /// The reason in words, each number written by `num(field, value, decimals)` (the
    /// field's JSON key under `blocked`): plain in [`Display`](std::fmt::Display), keyed
    /// into the sidecar in the report. One wording for both.
    pub fn words(&self, num: &dyn Fn(&str, f64, usize) -> String) -> String {
        match self {
            Blocked::NotComputed => {
                "the modes could not be computed at the optimizer's last point".into()
            }
            Blocked::Stays {
                mode,
                reached_rad_s,
                limit_rad_s,
                line,
                raise,
                over_tolerances,
            } => {
                let over = if *over_tolerances {
                    " over its tolerances"
                } else {
                    ""
                };
                let (side, verb) = if *raise {
                    ("below", "raised above")
                } else {
                    ("above", "lowered below")
                };
                format!(
                    "{mode} stays at {} rad/s{over}, {side} {} rad/s: it cannot be {verb} {line} by the margin within the bounds",
                    num("reached_rad_s", *reached_rad_s, 4),
                    num("limit_rad_s", *limit_rad_s, 4),
                )
            }
            Blocked::Spans {
                mode,
                min_rad_s,
                max_rad_s,
                margin_pct,
                lines,
            } => format!(
                "{mode} spans only {}–{} rad/s over the bounds, all within {} % of {lines}: it cannot be moved clear of {lines} within the bounds",
                num("min_rad_s", *min_rad_s, 4),
                num("max_rad_s", *max_rad_s, 4),
                num("margin_pct", *margin_pct, 4),
            ),
            Blocked::FailsCheck {
                over_tolerances,
                mode,
                min_rad_s,
                max_rad_s,
                separation_pct,
                line,
                required_pct,
            } => format!(
                "{}: {mode} spans {}–{} rad/s, {} % from {line} (needs {} %)",
                if *over_tolerances {
                    "the design found fails the margins check over the tolerance box"
                } else {
                    "the design found fails the full margins check (mode tracking lost?)"
                },
                num("min_rad_s", *min_rad_s, 4),
                num("max_rad_s", *max_rad_s, 4),
                num("separation_pct", *separation_pct, 3),
                num("required_pct", *required_pct, 3),
            ),
            Blocked::DoesNotVerify { error } => {
                format!("the design found does not verify: {error}")
            }
            Blocked::Unstable {
                mode,
                growth_rate_1_s,
            } => format!(
                "the design found is unstable: {mode} grows at Re λ = {} 1/s (the equilibrium is unstable), so it cannot pass",
                num("growth_rate_1_s", *growth_rate_1_s, 4),
            ),
            Blocked::SpreadReachesZero { mode, low_rad_s } => format!(
                "{mode}'s first-order interval over the tolerance box reaches {} rad/s (ω_n ≤ 0): the tolerances are too wide for a spread about the design (the box may reach an unstable design, or one with no equilibrium near it)",
                num("low_rad_s", *low_rad_s, 4),
            ),
            Blocked::UnstableOverTolerances {
                point,
                growth_rate_1_s,
            } => format!(
                "the design found (the smallest change that clears the bands) is stable, but its tolerance box reaches an unstable design: at {point} a mode grows at Re λ = {} 1/s, so a part within tolerance can leave its equilibrium and the design cannot pass (the search keeps the modes clear of the bands over the box, not the box stable: a larger change may be stable over it)",
                num("growth_rate_1_s", *growth_rate_1_s, 4),
            ),
        }
    }
}

impl std::fmt::Display for Blocked {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.words(&|_, x, decimals| format!("{x:.decimals$}")))
    }
}

impl Infeasible {
    fn new(sides: Vec<SideChoice>, blocked: Option<Blocked>) -> Infeasible {
        Infeasible {
            sides,
            reason: blocked.as_ref().map(|b| b.to_string()).unwrap_or_default(),
            blocked,
        }
    }
}

/// The designs found (best first) and the side choices that could not be met.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Tuning {
    pub designs: Vec<Design>,
    pub infeasible: Vec<Infeasible>,
    /// The baseline already clears every band.
    pub baseline_passes: bool,
    /// Number of side choices solved.
    pub choices: usize,
}

/// A gap between forbidden zones: (lowest, highest) allowed ω_n, rad/s, and the lines
/// below and above it.
#[derive(Debug, Clone)]
struct Gap {
    lo: f64,
    hi: f64,
    /// The lines whose zones lie below / above the gap.
    below: Vec<String>,
    above: Vec<String>,
}

fn gaps(lines: &[ForcingLine], margin: f64, clearance: f64) -> Vec<Gap> {
    let mut zones: Vec<(f64, f64, String)> = lines
        .iter()
        .map(|l| {
            (
                l.band_lo_rad_s * (1.0 - margin - clearance),
                l.band_hi_rad_s * (1.0 + margin + clearance),
                l.label.clone(),
            )
        })
        .collect();
    zones.sort_by(|a, b| a.0.total_cmp(&b.0));
    // merge overlapping zones
    let mut merged: Vec<(f64, f64, Vec<String>)> = Vec::new();
    for (lo, hi, label) in zones {
        match merged.last_mut() {
            Some(last) if lo <= last.1 => {
                last.1 = last.1.max(hi);
                last.2.push(label);
            }
            _ => merged.push((lo, hi, vec![label])),
        }
    }
    let mut out = Vec::new();
    let mut lo = 0.0;
    let mut below: Vec<String> = Vec::new();
    for (zlo, zhi, labels) in &merged {
        out.push(Gap {
            lo,
            hi: *zlo,
            below: below.clone(),
            above: labels.clone(),
        });
        lo = *zhi;
        below.extend(labels.iter().cloned());
    }
    out.push(Gap {
        lo,
        hi: f64::INFINITY,
        below,
        above: Vec::new(),
    });
    out
}

/// One evaluation of the modes at x: each baseline mode's ω_n (matched by MAC) and its
/// gradient in x.
#[derive(Clone)]
struct Eval {
    x: Vec<f64>,
    omega: Vec<f64>,
    grad: Vec<Vec<f64>>,
    /// Per mode, the first-order lowest and highest change of ω_n over the tolerance box
    /// about x (≤ 0, ≥ 0), rad/s.
    spread: Vec<(f64, f64)>,
}

struct Problem<'a> {
    sys: &'a System,
    varies: &'a [Vary],
    /// The baseline modes followed (indices into `base.modes`).
    keep: Vec<usize>,
    p0: Vec<f64>,
    scale: Vec<f64>,
    tolerances: &'a [Tolerance],
    cache: RefCell<Vec<Eval>>,
    /// Points solved so far with their labels (the baseline first): each evaluation
    /// follows the modes from the nearest of them, so the labels move with the
    /// optimizer's steps and a step costs one modal analysis.
    solved: RefCell<Vec<(Vec<f64>, System, Solved)>>,
}

impl Problem<'_> {
    fn values(&self, x: &[f64]) -> Vec<(usize, f64)> {
        self.varies
            .iter()
            .enumerate()
            .map(|(i, v)| {
                // a bound as given, not p0 + scale · x rounded (0.8, not 0.8000000000000046)
                let value = if x[i] == (v.range.0 - self.p0[i]) / self.scale[i] {
                    v.range.0
                } else if x[i] == (v.range.1 - self.p0[i]) / self.scale[i] {
                    v.range.1
                } else {
                    self.p0[i] + self.scale[i] * x[i]
                };
                (v.param, value)
            })
            .collect()
    }

    fn eval(&self, x: &[f64]) -> Option<Eval> {
        if let Some(e) = self.cache.borrow().iter().find(|e| e.x == x) {
            return Some(e.clone());
        }
        let (s, solved) = {
            let paths = self.solved.borrow();
            let dist = |y: &[f64]| -> f64 { y.iter().zip(x).map(|(a, b)| (a - b).powi(2)).sum() };
            let (y, sy, start) = paths
                .iter()
                .min_by(|a, b| dist(&a.0).total_cmp(&dist(&b.0)))
                .expect("the baseline is solved");
            let from: Vec<f64> = self.values(y).iter().map(|v| v.1).collect();
            follow(
                self.sys,
                &from,
                sy.clone(),
                start.clone(),
                &self.values(x),
                None,
            )
            .ok()?
        };
        {
            let mut paths = self.solved.borrow_mut();
            if paths.len() > 16 {
                paths.remove(1);
            }
            paths.push((x.to_vec(), s.clone(), solved.clone()));
        }
        let ma = &solved.modal;
        let matched: Vec<Option<(usize, f64)>> =
            solved.modes.iter().map(|j| j.map(|j| (j, 1.0))).collect();
        let ev = evaluate(ma);
        let mut omega = Vec::new();
        let mut grad = Vec::new();
        let derivs: Vec<_> = self
            .varies
            .iter()
            .map(|v| mode_derivatives(&s, ma, v.param, true).ok())
            .collect::<Option<Vec<_>>>()?;
        // each tolerance's range about x, and the derivatives along it
        let values = self.values(x);
        let tol: Vec<((f64, f64), Vec<_>)> = self
            .tolerances
            .iter()
            .map(|t| {
                let i = t.vary.param;
                let p = values
                    .iter()
                    .find(|v| v.0 == i)
                    .map_or(self.sys.param(i), |v| v.1);
                let (lo, hi) = t.about(self.sys.param(i), p);
                let d = match self.varies.iter().position(|v| v.param == i) {
                    Some(k) => derivs[k].clone(),
                    None => mode_derivatives(&s, ma, i, true).ok()?,
                };
                Some(((lo - p, hi - p), d))
            })
            .collect::<Option<Vec<_>>>()?;
        let mut spread = Vec::new();
        for &k in &self.keep {
            let (j, _) = matched[k]?;
            omega.push(ev.modes[j].0);
            grad.push(
                (0..self.varies.len())
                    .map(|i| derivs[i][j].domega_n * self.scale[i])
                    .collect(),
            );
            let (mut down, mut up) = (0.0, 0.0);
            for ((a, b), d) in &tol {
                let (a, b) = (d[j].domega_n * a, d[j].domega_n * b);
                down += a.min(b).min(0.0);
                up += a.max(b).max(0.0);
            }
            spread.push((down, up));
        }
        let e = Eval {
            x: x.to_vec(),
            omega,
            grad,
            spread,
        };
        let mut c = self.cache.borrow_mut();
        if c.len() > 8 {
            c.remove(0);
        }
        c.push(e.clone());
        Some(e)
    }
}

/// The error for a model with no degrees of freedom (every coordinate fixed or driven by
/// a constraint): it has no modes, so `what` (the analysis's own words).
pub fn no_degrees_of_freedom(sys: &System, what: &str) -> Error {
    Error::request(
        format!("{}, so {what}", crate::linear::no_modes_words(sys)),
        "check the model's constraints and fixed coordinates (`detune check` counts the degrees of freedom); a mechanism moved entirely by a prescribed motion has no dynamics of its own: simulate it instead",
    )
}

/// Tune `sys` (trimmed) over `varies` (each with its range as bounds) so that every
/// oscillatory mode clears every line of `lines` by `opts.margin`.
pub fn tune(
    sys: &System,
    varies: &[Vary],
    lines: &[ForcingLine],
    opts: &TuneOptions,
) -> Result<Tuning> {
    if varies.is_empty() {
        return Err(Error::request(
            "a tuning needs at least one free parameter",
            "give the parameters the design may change, with their ranges (e.g. k_fs=50%..200%)",
        ));
    }
    let base = modal_analysis(sys, None)?;
    if base.modes.is_empty() {
        return Err(no_degrees_of_freedom(
            sys,
            "no mode to keep clear of the forcing bands",
        ));
    }
    let keep: Vec<usize> = (0..base.modes.len())
        .filter(|&i| oscillatory(&base.modes[i]))
        .collect();
    let all_names = crate::linear::sensitivity::mode_names(sys, &base);
    let names: Vec<String> = keep.iter().map(|&i| all_names[i].clone()).collect();
    let p0: Vec<f64> = varies.iter().map(|v| sys.param(v.param)).collect();
    let scale: Vec<f64> = varies
        .iter()
        .zip(&p0)
        .map(|(v, &p)| {
            if p != 0.0 {
                p.abs()
            } else {
                (v.range.1 - v.range.0).abs().max(f64::MIN_POSITIVE)
            }
        })
        .collect();
    let bounds: Vec<(f64, f64)> = varies
        .iter()
        .enumerate()
        .map(|(i, v)| {
            (
                (v.range.0 - p0[i]) / scale[i],
                (v.range.1 - p0[i]) / scale[i],
            )
        })
        .collect();
    let weights: Vec<f64> = (0..varies.len())
        .map(|i| opts.weights.get(i).copied().unwrap_or(1.0))
        .collect();
    let problem = Problem {
        sys,
        varies,
        keep: keep.clone(),
        p0: p0.clone(),
        scale: scale.clone(),
        tolerances: &opts.tolerances,
        cache: RefCell::new(Vec::new()),
        solved: RefCell::new(vec![(
            vec![0.0; varies.len()],
            sys.clone(),
            baseline_labels(&base),
        )]),
    };

    // what the box can reach, mode by mode (the sensitivity study's worst case)
    let reach = crate::linear::sensitivity::sensitivity(sys, varies, None, None)?;
    let gaps = gaps(lines, opts.margin, opts.clearance);
    let reachable: Vec<Vec<usize>> = reach
        .modes
        .iter()
        .map(|m| {
            let (lo, hi) = (m.worst_case.min_rad_s, m.worst_case.max_rad_s);
            let (lo, hi) = (
                lo.min(m.worst_case.first_order_min_rad_s),
                hi.max(m.worst_case.first_order_max_rad_s),
            );
            let pad = 0.05 * (hi - lo) + 1e-9 * hi;
            (0..gaps.len())
                .filter(|&g| gaps[g].hi >= lo - pad && gaps[g].lo <= hi + pad)
                .collect()
        })
        .collect();
    let mut infeasible = Vec::new();
    for (m, r) in reachable.iter().enumerate() {
        if r.is_empty() {
            let w = &reach.modes[m].worst_case;
            // the zone the whole span lies in: above the last gap that ends below it
            let blocking = gaps
                .iter()
                .rev()
                .find(|g| g.hi < w.min_rad_s)
                .map(|g| g.above.join(", "))
                .unwrap_or_default();
            infeasible.push(Infeasible::new(
                Vec::new(),
                Some(Blocked::Spans {
                    mode: names[m].clone(),
                    min_rad_s: w.min_rad_s,
                    max_rad_s: w.max_rad_s,
                    margin_pct: opts.margin * 100.0,
                    lines: blocking,
                }),
            ));
        }
    }
    // the baseline as the designs are checked (over its tolerances, when given)
    let baseline_passes = verify_design(&problem, &vec![0.0; varies.len()], lines, opts)
        .map(|v| v.check.pass)
        .unwrap_or(false);
    if !infeasible.is_empty() {
        return Ok(Tuning {
            designs: Vec::new(),
            infeasible,
            baseline_passes,
            choices: 0,
        });
    }
    // every combination of reachable gaps
    let mut choices: Vec<Vec<usize>> = vec![Vec::new()];
    for r in &reachable {
        choices = choices
            .into_iter()
            .flat_map(|c| {
                r.iter().map(move |&g| {
                    let mut c = c.clone();
                    c.push(g);
                    c
                })
            })
            .collect();
        if choices.len() > 256 {
            return Err(Error::request(
                format!(
                    "the ranges reach {} combinations of sides of the lines: too many to enumerate",
                    choices.len()
                ),
                "narrow the ranges",
            ));
        }
    }
    let sides_of = |choice: &[usize]| -> Vec<SideChoice> {
        let mut out = Vec::new();
        for (m, &g) in choice.iter().enumerate() {
            for l in &gaps[g].below {
                out.push(SideChoice {
                    mode: names[m].clone(),
                    line: l.clone(),
                    side: "above",
                });
            }
            for l in &gaps[g].above {
                out.push(SideChoice {
                    mode: names[m].clone(),
                    line: l.clone(),
                    side: "below",
                });
            }
        }
        out
    };
    let mut designs: Vec<Design> = Vec::new();
    let nchoices = choices.len();
    for choice in &choices {
        // per mode, what the verification found the tolerance box to add to the
        // first-order spread (≤ 0 below, ≥ 0 above), rad/s
        let mut extra: Vec<(f64, f64)> = vec![(0.0, 0.0); keep.len()];
        let mut outcome: std::result::Result<_, Option<Blocked>> = Err(None);
        let mut last_x: Option<Vec<f64>> = None;
        for _ in 0..ROUNDS {
            let (x, method) = match solve_choice(
                &problem, choice, &gaps, &bounds, &weights, &extra, opts, &names,
            ) {
                Ok(v) => v,
                Err(reason) => {
                    if outcome.is_err() {
                        outcome = Err(reason);
                    }
                    break;
                }
            };
            // the same point again: the spreads have settled
            if last_x.as_ref().is_some_and(|l| {
                l.iter()
                    .zip(&x)
                    .all(|(a, b)| (a - b).abs() <= 1e-10 * (1.0 + a.abs()))
            }) {
                break;
            }
            last_x = Some(x.clone());
            let v = match verify_design(&problem, &x, lines, opts) {
                Ok(v) => v,
                Err(e) => {
                    if outcome.is_err() {
                        outcome = Err(Some(Blocked::DoesNotVerify {
                            error: e.to_string(),
                        }));
                    }
                    break;
                }
            };
            let Some(e) = problem.eval(&x) else {
                break;
            };
            let pass = v.check.pass;
            if !pass && outcome.is_err() {
                outcome = Err(v
                    .check
                    .unstable
                    .first()
                    .map(|u| Blocked::Unstable {
                        mode: u.mode.clone(),
                        growth_rate_1_s: u.growth_rate_1_s,
                    })
                    .or_else(|| {
                        v.check
                            .unstable_corners
                            .first()
                            .map(|c| Blocked::UnstableOverTolerances {
                                point: c.label.clone(),
                                growth_rate_1_s: c.growth_rate_1_s,
                            })
                    })
                    .or_else(|| {
                        v.check.failures().first().map(|r| Blocked::FailsCheck {
                            over_tolerances: !opts.tolerances.is_empty(),
                            mode: r.mode.clone(),
                            min_rad_s: r.min_rad_s,
                            max_rad_s: r.max_rad_s,
                            separation_pct: r.separation_pct,
                            line: r.line.clone(),
                            required_pct: r.required_pct,
                        })
                    }));
            }
            if opts.tolerances.is_empty() {
                if pass {
                    outcome = Ok((x, method, v));
                }
                break;
            }
            // the box's true reach about x against the first-order spread: solve again
            // with the difference (a fifth more where the design failed), keeping the
            // cheapest design that passes
            let pad = if pass { 1.0 } else { 1.2 };
            for (m, name) in names.iter().enumerate() {
                if let Some(&(lo, hi)) = v.intervals.get(name) {
                    extra[m] = (
                        pad * (lo - e.omega[m] - e.spread[m].0),
                        pad * (hi - e.omega[m] - e.spread[m].1),
                    );
                }
            }
            if pass {
                let cost =
                    |x: &[f64]| -> f64 { x.iter().zip(&weights).map(|(x, w)| w * x * x).sum() };
                match &outcome {
                    Ok((best, _, _)) if cost(best) <= cost(&x) => {}
                    _ => outcome = Ok((x, method, v)),
                }
            }
        }
        let (x, method, v) = match outcome {
            Ok(o) => o,
            Err(blocked) => {
                infeasible.push(Infeasible::new(sides_of(choice), blocked));
                continue;
            }
        };
        let values = problem.values(&x);
        // the linear frequency response of the design: its peaks (per unit of the
        // declared forcing amplitude)
        let frf_peaks: Option<Vec<f64>> = (|| {
            let f = sys.forcing_param()?;
            let a = sys.forcing_amplitude_param()?;
            let mut s = sys.clone();
            for &(i, v) in &values {
                s.set_param(i, v).ok()?;
            }
            s.set_param(a, 1.0).ok()?;
            let (s, _) = crate::statics::trim::trim(&s).ok()?;
            let ws: Vec<f64> = v.modal.modes.iter().map(|m| m.omega_n_rad_s).collect();
            let lo = ws.iter().copied().fold(f64::INFINITY, f64::min) * 0.5;
            let hi = ws.iter().copied().fold(0.0, f64::max) * 1.5;
            let grid: Vec<f64> = (0..=200)
                .map(|k| lo * (hi / lo).powf(k as f64 / 200.0))
                .collect();
            let reference = s.coordinates[crate::linear::default_reference(&s)].clone();
            let fr = crate::linear::frequency_response(
                &s,
                &s.param_names()[f].clone(),
                &grid,
                &[reference],
            )
            .ok()?;
            Some(fr.peaks.iter().map(|p| p.omega).collect())
        })();
        let mut parameters = serde_json::Map::new();
        for (v, &(_, value)) in varies.iter().zip(&values) {
            parameters.insert(v.name.clone(), value.into());
        }
        let mut modes = serde_json::Map::new();
        for (k, m) in v
            .modal
            .modes
            .iter()
            .enumerate()
            .filter(|(_, m)| oscillatory(m))
        {
            modes.insert(v.names[k].clone(), m.omega_n_rad_s.into());
        }
        let closest = v
            .check
            .rows
            .iter()
            .map(|r| r.separation_pct)
            .fold(f64::INFINITY, f64::min);
        let at_bounds = varies
            .iter()
            .enumerate()
            .filter_map(|(i, vary)| {
                let tol = 1e-6 * (bounds[i].1 - bounds[i].0).abs().max(1e-12);
                let (bound, at) = if x[i] <= bounds[i].0 + tol {
                    ("lower", vary.range.0)
                } else if x[i] >= bounds[i].1 - tol {
                    ("upper", vary.range.1)
                } else {
                    return None;
                };
                Some(BoundHit {
                    param: vary.name.clone(),
                    bound,
                    value: at,
                })
            })
            .collect();
        let tolerance_intervals = (!opts.tolerances.is_empty()).then(|| {
            v.intervals
                .iter()
                .map(|(n, &(lo, hi))| (n.clone(), serde_json::json!([lo, hi])))
                .collect()
        });
        designs.push(Design {
            parameters,
            cost: x.iter().zip(&weights).map(|(x, w)| w * x * x).sum(),
            sides: sides_of(choice),
            margins: v.check.rows,
            modes,
            closest_pct: closest,
            optimizer: method,
            at_bounds,
            tolerance_intervals,
            sweep_peaks_rad_s: None,
            sweep_peaks_clear: None,
            frf_peaks_rad_s: frf_peaks.clone().unwrap_or_default(),
            frf_peaks_clear: frf_peaks.map(|p| {
                p.iter().all(|&w| {
                    lines.iter().all(|l| {
                        w <= l.band_lo_rad_s * (1.0 - opts.margin)
                            || w >= l.band_hi_rad_s * (1.0 + opts.margin)
                    })
                })
            }),
        });
    }
    designs.sort_by(|a, b| a.cost.total_cmp(&b.cost));
    // the same design reached by two choices: keep one
    designs.dedup_by(|a, b| {
        a.parameters
            .iter()
            .zip(&b.parameters)
            .all(|((_, x), (_, y))| {
                let (x, y) = (x.as_f64().unwrap_or(0.0), y.as_f64().unwrap_or(0.0));
                (x - y).abs() <= 1e-6 * x.abs().max(y.abs()).max(1e-300)
            })
    });
    designs.truncate(opts.max_designs);
    Ok(Tuning {
        designs,
        infeasible,
        baseline_passes,
        choices: nchoices,
    })
}

/// Solves of one choice of sides: the first with the first-order tolerance spread, then
/// again with the spread the verification found about the last design (the cheapest
/// design that passes is kept).
const ROUNDS: usize = 5;

/// Solve one choice of sides (a gap per mode): the smallest change that puts each mode's
/// ω_n, widened by its tolerance spread (first-order, plus `extra`), inside its gap.
/// Returns x and the optimizer that met the choice, or why none did.
#[allow(clippy::too_many_arguments)]
fn solve_choice(
    problem: &Problem<'_>,
    choice: &[usize],
    gaps: &[Gap],
    bounds: &[(f64, f64)],
    weights: &[f64],
    extra: &[(f64, f64)],
    opts: &TuneOptions,
    names: &[String],
) -> std::result::Result<(Vec<f64>, &'static str), Option<Blocked>> {
    let n = bounds.len();
    // the lowest and highest ω_n of mode m over the tolerance box, first-order
    let low = |e: &Eval, m: usize| e.omega[m] + e.spread[m].0 + extra[m].0;
    let high = |e: &Eval, m: usize| e.omega[m] + e.spread[m].1 + extra[m].1;
    // constraints c(x) ≤ 0, relative: (lo − ω_low)/lo and (ω_high − hi)/hi; the
    // gradient is ω_n's (the spread changes slowly)
    type Con<'c> = Box<dyn Fn(&[f64], Option<&mut [f64]>, &mut ()) -> f64 + 'c>;
    let mut cons: Vec<Con<'_>> = Vec::new();
    for (m, &g) in choice.iter().enumerate() {
        let gap = &gaps[g];
        if gap.lo > 0.0 {
            let lo = gap.lo;
            cons.push(Box::new(
                move |x: &[f64], grad: Option<&mut [f64]>, _: &mut ()| match problem.eval(x) {
                    Some(e) => {
                        if let Some(gr) = grad {
                            for (i, gi) in gr.iter_mut().enumerate() {
                                *gi = -e.grad[m][i] / lo;
                            }
                        }
                        (lo - low(&e, m)) / lo
                    }
                    None => {
                        if let Some(gr) = grad {
                            gr.fill(0.0);
                        }
                        1e3
                    }
                },
            ));
        }
        if gap.hi.is_finite() {
            let hi = gap.hi;
            cons.push(Box::new(
                move |x: &[f64], grad: Option<&mut [f64]>, _: &mut ()| match problem.eval(x) {
                    Some(e) => {
                        if let Some(gr) = grad {
                            for (i, gi) in gr.iter_mut().enumerate() {
                                *gi = e.grad[m][i] / hi;
                            }
                        }
                        (high(&e, m) - hi) / hi
                    }
                    None => {
                        if let Some(gr) = grad {
                            gr.fill(0.0);
                        }
                        1e3
                    }
                },
            ));
        }
    }
    // why x does not meet the choice (None: it does)
    let blocking_at = |x: &[f64]| match problem.eval(x) {
        None => Some(Blocked::NotComputed),
        Some(e) => choice.iter().enumerate().find_map(|(m, &g)| {
            let gap = &gaps[g];
            let (a, b) = (low(&e, m), high(&e, m));
            let stays = |reached_rad_s, limit_rad_s, line: Option<&String>, raise| {
                Some(Blocked::Stays {
                    mode: names[m].clone(),
                    reached_rad_s,
                    limit_rad_s,
                    line: line.cloned().unwrap_or_default(),
                    raise,
                    over_tolerances: !opts.tolerances.is_empty(),
                })
            };
            if a <= 0.0 && gap.below.is_empty() {
                // no line below: the first-order spread itself reaches ω_n ≤ 0, the box
                // is too wide for a spread about the design to mean anything
                Some(Blocked::SpreadReachesZero {
                    mode: names[m].clone(),
                    low_rad_s: a,
                })
            } else if a < gap.lo * (1.0 - 0.5 * opts.clearance) {
                stays(a, gap.lo, gap.below.last(), true)
            } else if b > gap.hi * (1.0 + 0.5 * opts.clearance) {
                stays(b, gap.hi, gap.above.first(), false)
            } else {
                None
            }
        }),
    };
    let cost_of = |x: &[f64]| -> f64 { x.iter().zip(weights).map(|(x, w)| w * x * x).sum() };
    let mut blocking = None;
    let mut found: Option<(Vec<f64>, &'static str)> = None;
    if opts.optimizer != Optimizer::Cobyla {
        let cost = |x: &[f64], grad: Option<&mut [f64]>, _: &mut ()| -> f64 {
            if let Some(g) = grad {
                for i in 0..x.len() {
                    g[i] = 2.0 * weights[i] * x[i];
                }
            }
            cost_of(x)
        };
        type ConRef<'c> = &'c dyn Fn(&[f64], Option<&mut [f64]>, &mut ()) -> f64;
        let cons_ref: Vec<ConRef<'_>> = cons.iter().map(|c| c.as_ref()).collect();
        let tol = slsqp::StopTols {
            ftol_rel: 1e-10,
            xtol_rel: 1e-10,
            ..slsqp::StopTols::default()
        };
        let x = match slsqp::minimize(
            cost,
            &vec![0.0; n],
            bounds,
            &cons_ref,
            (),
            opts.max_evaluations,
            Some(tol),
        ) {
            Ok((_, x, _)) | Err((_, x, _)) => x,
        };
        blocking = blocking_at(&x);
        if blocking.is_none() {
            found = Some((x, "SLSQP"));
        }
    }
    // the derivative-free COBYLA (the `cobyla` crate; constraints as c(x) ≥ 0, no
    // gradients): the fallback where SLSQP did not meet the choice, and with tolerances a
    // polish of SLSQP's point, whose constraint gradients leave out the spread's own
    // (second-derivative) change and so stop short of the minimum
    type Cob<'c> = Box<dyn Fn(&[f64], &mut ()) -> f64 + 'c>;
    let cob: Vec<Cob<'_>> = cons
        .iter()
        .map(|c| Box::new(move |x: &[f64], _: &mut ()| -c(x, None, &mut ())) as Cob<'_>)
        .collect();
    type CobRef<'c> = &'c dyn Fn(&[f64], &mut ()) -> f64;
    let cob_ref: Vec<CobRef<'_>> = cob.iter().map(|c| c.as_ref()).collect();
    let cobyla_from = |x0: &[f64], span: f64, evaluations: usize| -> Vec<f64> {
        match cobyla::minimize(
            |x: &[f64], _: &mut ()| cost_of(x),
            x0,
            bounds,
            &cob_ref,
            (),
            evaluations,
            cobyla::RhoBeg::Set(bounds.iter().map(|b| span * (b.1 - b.0)).collect()),
            None,
        ) {
            Ok((_, y, _)) | Err((_, y, _)) => y,
        }
    };
    if found.is_none() && opts.optimizer != Optimizer::Slsqp {
        // from the baseline, the first simplex spanning half of each range; without
        // gradients it needs more evaluations than SLSQP, but as a fallback after SLSQP
        // failed (most often a choice that cannot be met) it gets SLSQP's
        let y = cobyla_from(
            &vec![0.0; n],
            0.5,
            if opts.optimizer == Optimizer::Cobyla {
                5 * opts.max_evaluations
            } else {
                opts.max_evaluations
            },
        );
        blocking = blocking_at(&y);
        if blocking.is_none() {
            found = Some((y, "COBYLA"));
        }
    } else if opts.optimizer == Optimizer::Auto
        && !opts.tolerances.is_empty()
        && let Some((x, _)) = found.clone()
    {
        let y = cobyla_from(&x, 0.02, opts.max_evaluations / 4);
        if blocking_at(&y).is_none() && cost_of(&y) < cost_of(&x) {
            found = Some((y, "SLSQP+COBYLA"));
        }
    }
    // a coordinate the optimizer left within 1e-9 of its range of a bound is put on it
    // (the design then names the bound as given), if the choice still holds there
    if let Some((x, _)) = &mut found {
        let snapped: Vec<f64> = x
            .iter()
            .zip(bounds)
            .map(|(&xi, &(lo, hi))| {
                let tol = 1e-9 * (hi - lo).abs();
                if (xi - lo).abs() <= tol {
                    lo
                } else if (xi - hi).abs() <= tol {
                    hi
                } else {
                    xi
                }
            })
            .collect();
        if snapped != *x && blocking_at(&snapped).is_none() {
            *x = snapped;
        }
    }
    found.ok_or(blocking)
}

/// A design checked as `margins` checks it.
struct Verified {
    check: crate::margins::MarginCheck,
    modal: ModalAnalysis,
    /// Every mode's name, in `modal.modes` order.
    names: Vec<String>,
    /// With tolerances: each mode's (lowest, highest) ω_n over the box about the design.
    intervals: std::collections::BTreeMap<String, (f64, f64)>,
}

/// Verify x as `margins` does: the parameters set, the trim re-solved, the modes about
/// the equilibrium nearest the initial pose, every row of the margins table; with
/// tolerances, each mode's interval over the box about the design from a full
/// sensitivity study (its corners and edges), as `margins --vary` computes it.
fn verify_design(
    problem: &Problem<'_>,
    x: &[f64],
    lines: &[ForcingLine],
    opts: &TuneOptions,
) -> Result<Verified> {
    let sys = problem.sys;
    let values = problem.values(x);
    let mut s = sys.clone();
    for &(i, v) in &values {
        s.set_param(i, v)?;
    }
    let (s, _) = crate::statics::trim::trim(&s)?;
    let modal = modal_analysis(&s, None)?;
    let names = crate::linear::sensitivity::mode_names(&s, &modal);
    let (mut points, _) = mode_points_named(&modal, &names);
    let mut intervals = std::collections::BTreeMap::new();
    let mut unstable_points = Vec::new();
    if !opts.tolerances.is_empty() {
        let box_: Vec<Vary> = opts
            .tolerances
            .iter()
            .map(|t| t.at(sys.param(t.vary.param), s.param(t.vary.param)))
            .collect();
        let study = crate::linear::sensitivity::sensitivity(&s, &box_, Some(&names), None)?;
        // a box with unsolved points is refused, as `margins --vary` refuses it
        unstable_points = crate::margins::box_unstable_points(&study, &box_)?;
        for m in &study.modes {
            intervals.insert(
                m.name.clone(),
                (m.worst_case.min_rad_s, m.worst_case.max_rad_s),
            );
        }
        points = crate::margins::with_intervals(points, &study);
    }
    // an unstable design fails, whatever its separations; so does one whose tolerance
    // box reaches an unstable design (as `margins --vary` checks it)
    let check = crate::margins::check_design(
        &modal,
        &names,
        &points,
        lines,
        opts.margin,
        Requirement::Fixed,
    )?
    .with_unstable_corners(unstable_points);
    Ok(Verified {
        check,
        modal,
        names,
        intervals,
    })
}

/// `--verify sweep`: a stepped-sine sweep of the nonlinear model at `design` (the model's
/// own forcing amplitude, which must not be zero) of `response` over 0.7 × the lowest to
/// 1.3 × the highest ω_n in 60 steps, peaks refined to 1/20 of a step; returns the peaks
/// (rad/s) and whether each clears every band by `margin`. The steady states are
/// computed with `steady` (integrator, tolerances); `stiff` hears of a stiff integration.
#[allow(clippy::too_many_arguments)]
pub fn verify_sweep(
    sys: &System,
    design: &Design,
    lines: &[ForcingLine],
    margin: f64,
    response: &str,
    steady: &crate::frequency::SteadyOptions,
    cancel: &std::sync::atomic::AtomicBool,
    stiff: crate::frequency::StiffHook,
) -> Result<(Vec<f64>, bool)> {
    let (s, opts) = verify_sweep_setup(sys, design, response, steady)?;
    verify_sweep_logged(
        &s,
        &opts,
        lines,
        margin,
        cancel,
        &crate::frequency::checkpoint::NoLog,
        0,
        stiff,
    )
}

/// The system (`sys` at `design`'s parameters, trimmed) and the sweep of
/// [`verify_sweep`] for `design`: what a checkpoint of the verification fingerprints.
pub fn verify_sweep_setup(
    sys: &System,
    design: &Design,
    response: &str,
    steady: &crate::frequency::SteadyOptions,
) -> Result<(System, crate::frequency::SweepOptions)> {
    let Some(f) = sys.forcing_param() else {
        return Err(Error::request(
            "a stepped-sine sweep needs the model's forcing frequency",
            "add `forcing_frequency = \"omega\"` to [model]",
        ));
    };
    let mut s = sys.clone();
    for (name, v) in &design.parameters {
        if let (Some(i), Some(v)) = (s.param_index(name), v.as_f64()) {
            s.set_param(i, v)?;
        }
    }
    let (s, _) = crate::statics::trim::trim(&s)?;
    let ws: Vec<f64> = design.modes.values().filter_map(|w| w.as_f64()).collect();
    let lo = ws.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = ws.iter().copied().fold(0.0, f64::max);
    let opts = crate::linear::sensitivity::peak_sweep(&s, f, lo, hi, response, steady);
    Ok((s, opts))
}

/// [`verify_sweep`] of a system and sweep from [`verify_sweep_setup`], its steady states
/// looked up in and recorded to `log` as run `run` (a checkpoint: `tune --verify sweep
/// --checkpoint FILE` resumes the designs' sweeps).
#[allow(clippy::too_many_arguments)]
pub fn verify_sweep_logged(
    s: &System,
    opts: &crate::frequency::SweepOptions,
    lines: &[ForcingLine],
    margin: f64,
    cancel: &std::sync::atomic::AtomicBool,
    log: &dyn crate::frequency::checkpoint::CaseLog,
    run: usize,
    stiff: crate::frequency::StiffHook,
) -> Result<(Vec<f64>, bool)> {
    // a failing frequency is an error (no verdict from part of the curve)
    let sw = crate::frequency::sweep_logged(s, opts, &|_| {}, cancel, log, run, stiff)?;
    // an interrupted sweep has no peaks: "every peak clears" would be a false verdict
    if !sw.complete {
        return Err(crate::failure::Failure::SweepInterrupted.into());
    }
    let peaks: Vec<f64> = sw.peaks.iter().map(|p| p.omega).collect();
    let clear = peaks.iter().all(|&w| {
        lines
            .iter()
            .all(|l| w <= l.band_lo_rad_s * (1.0 - margin) || w >= l.band_hi_rad_s * (1.0 + margin))
    });
    Ok((peaks, clear))
}
