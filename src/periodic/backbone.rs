//! The backbone curve of a mode: the amplitude-dependent natural frequency of the
//! undamped, unforced mechanism, by continuation of its conservative family of periodic
//! orbits from the linear mode.
//!
//! # The conservative system
//!
//! The model's forcing amplitude (`[model] forcing_amplitude`) is set to 0 and its
//! velocity-dependent loads are switched off by [`System::undamped`]: every force element
//! is evaluated at zero velocities (a spring–damper keeps k·s and loses c·ṡ, friction
//! vanishes, a user's law f(x, ẋ) becomes f(x, 0); the inertial velocity terms stay). A
//! system-level switch rather than a change of the damping coefficients, so it covers
//! every element kind, including a user's law, and the parameters stay what the model
//! says. The result must be autonomous: a model still depending on time with the forcing
//! amplitude at 0 is refused.
//!
//! # The orbit's equations
//!
//! The unknowns are the state x on the constraint manifold (moved in the tangent chart of
//! [`super`], x ← π(x + T_x η), η ∈ ℝ^{2·DoF}) and the frequency ω = 2π/T (the forcing
//! frequency's parameter of [`Shooting`], whose flow gives dP/dω with the period's
//! dependence). The equations are
//!
//! * the fixed point T_xᵀ(P(x) − x) = 0 (2·DoF rows),
//! * the phase condition v_r(0)/ω = 0: the orbit starts at a turning point of the
//!   reference coordinate r,
//! * the amplitude condition q_r(0) − q*_r = a: a is the reference coordinate's
//!   displacement from the equilibrium at that turning point (positive a: the turning
//!   point on the side the mode shape points to).
//!
//! The reference coordinate is the one the mode shape is normalized to, as `detune modes`
//! normalizes it (`normalize`, default the first angle coordinate, or the shape's largest
//! entry when that one does not move in the mode).
//!
//! A conservative system's fixed-point equations are redundant: the energy is the same at
//! x and at P(x), so the 2·DoF rows have rank 2·DoF − 1 at an orbit (the monodromy has
//! the double multiplier 1: the flow direction and the family's direction). With the two
//! conditions there are 2·DoF + 2 equations for 2·DoF + 1 unknowns, consistent at the
//! orbit: each Newton step solves them in the least-squares sense (SVD), which converges
//! quadratically on a consistent system and needs no artificial unfolding term (which
//! would change the equations of motion and have to be shown to vanish).
//!
//! # The family
//!
//! The amplitude a is the continuation parameter: from the linear mode (x = q* + a·φ,
//! v = 0, ω = ω_n, φ the undamped shape with φ_r = 1) at a small first amplitude, then in
//! steps of a with a secant predictor for x and ω. A step grows after an easy correction
//! (≤ 3 iterations), shrinks after a hard one, and is halved when Newton fails or ω moves
//! by more than 3 % of ω_n in one step. The family stops short (the result says where and
//! why) when the step falls below 1e-6 of the amplitude: near a separatrix (an unstable
//! equilibrium: the period grows without bound) or an internal resonance with another
//! mode. Without a target amplitude (`to_amplitude` infinite) the family is followed until
//! ω has moved by `max_shift` of ω_n.
//!
//! Accuracy: Newton stops when P(x) − x is below `tol` of the orbit's amplitude, which
//! puts ω within about tol/2π relative, plus the integration's error (`rtol`).
//! `tests/backbone.rs` checks the Duffing oscillator's exact backbone to 1e-8.
//!
//! Written by hand: no crate continues periodic orbits of a constrained model from a file.

use super::{Shooting, ShootingOptions};
use crate::diag::{Error, Result};
use crate::frequency::measure::Measures;
use crate::linear::{ModalAnalysis, modal_analysis};
use crate::system::System;
use nalgebra::{DMatrix, DVector};
use std::sync::atomic::{AtomicBool, Ordering};

/// Settings of a backbone curve.
#[derive(Debug, Clone)]
pub struct BackboneOptions {
    /// Responses measured on every orbit (default: the reference coordinate).
    pub responses: Vec<String>,
    /// The reference coordinate (as `modes --normalize`; default the first angle).
    pub normalize: Option<String>,
    pub shooting: ShootingOptions,
    /// Give up (an incomplete curve) after this many points.
    pub max_points: usize,
    /// Without a target amplitude: stop once |ω/ω_n − 1| reaches this.
    pub max_shift: f64,
}

impl Default for BackboneOptions {
    fn default() -> Self {
        BackboneOptions {
            responses: Vec::new(),
            normalize: None,
            shooting: ShootingOptions::default(),
            max_points: 400,
            max_shift: 0.25,
        }
    }
}

/// One periodic orbit of the family.
#[derive(Debug, Clone)]
pub struct BackbonePoint {
    /// The reference coordinate's displacement from the equilibrium at the turning point
    /// (its unit: m or rad).
    pub amplitude: f64,
    /// The orbit's frequency 2π/T, rad/s.
    pub omega: f64,
    /// Half peak-to-peak of each response over the orbit.
    pub amplitudes: Vec<f64>,
    /// The state at the turning point (q, v).
    pub x: Vec<f64>,
}

/// Why a family stopped before its end.
#[derive(Debug, Clone)]
pub struct Stop {
    /// The last amplitude reached, and its frequency.
    pub amplitude: f64,
    pub omega: f64,
    /// What happened, in words.
    pub reason: String,
    /// What to try.
    pub help: String,
}

/// The backbone curve of one mode.
#[derive(Debug, Clone)]
pub struct Backbone {
    /// The mode (0-based, in the order of the undamped modal analysis).
    pub mode: usize,
    /// Its name (the model's `[[modes]]` name, or `mode k`).
    pub mode_name: String,
    /// The linear undamped natural frequency, rad/s: the curve's limit at a → 0.
    pub omega_linear: f64,
    /// The reference coordinate (its index and name).
    pub reference: usize,
    pub reference_name: String,
    /// The equilibrium (q*).
    pub equilibrium: Vec<f64>,
    pub responses: Vec<String>,
    /// The responses' units.
    pub units: Vec<&'static str>,
    /// In increasing amplitude.
    pub points: Vec<BackbonePoint>,
    /// The family reached its end (the target amplitude, or the frequency shift).
    pub complete: bool,
    /// Where and why it stopped short.
    pub stop: Option<Stop>,
    pub periods: usize,
    pub rhs_evaluations: usize,
}

/// The conservative system of `sys`: its forcing amplitude at 0 and its velocity-dependent
/// loads off ([`System::undamped`]); refused when it still depends on time.
pub fn conservative(sys: &System) -> Result<System> {
    let mut s = sys.undamped();
    if let Some(i) = sys.forcing_amplitude_param() {
        s.set_param(i, 0.0)?;
    }
    Ok(s)
}

/// The undamped modes of `sys` (its conservative system) and their names.
pub fn undamped_modes(
    sys: &System,
    normalize: Option<&str>,
) -> Result<(System, ModalAnalysis, Vec<String>)> {
    let s = conservative(sys)?;
    let ma = modal_analysis(&s, normalize)?;
    let names = crate::linear::sensitivity::mode_names(&s, &ma);
    Ok((s, ma, names))
}

/// The mode `of` names (its name, `mode k`, or its number k from 1), 0-based.
pub fn mode_index(sys: &System, of: &str, normalize: Option<&str>) -> Result<usize> {
    let (_, ma, names) = undamped_modes(sys, normalize)?;
    if names.is_empty() {
        return Err(crate::tune::no_degrees_of_freedom(
            sys,
            "no backbone (the free periodic orbits grow from a mode)",
        ));
    }
    let list = || {
        names
            .iter()
            .enumerate()
            .map(|(k, n)| format!("{} `{n}` ({:.6} rad/s)", k + 1, ma.modes[k].omega_n_rad_s))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let of = of.trim();
    if let Some(k) = names.iter().position(|n| n == of) {
        return Ok(k);
    }
    if let Ok(k) = of.parse::<usize>() {
        if k >= 1 && k <= names.len() {
            return Ok(k - 1);
        }
        return Err(Error::request(
            format!(
                "mode {k}: the model has {} mode(s) at its equilibrium (undamped): {}",
                names.len(),
                list()
            ),
            "give a mode's number from 1 or its name",
        ));
    }
    Err(Error::request(
        format!("no mode is named `{of}`; the modes are: {}", list()),
        "give a mode's number from 1 or its name as `detune modes` prints it",
    ))
}

/// The backbone curve of mode `mode` (0-based, as [`mode_index`] counts) of `sys`, from
/// its linear limit to `to_amplitude` (the reference coordinate's displacement at the
/// turning point, m or rad; `f64::INFINITY`: until ω has moved by `max_shift`). See the
/// module doc. `progress(points, amplitude)` after every point.
pub fn backbone(
    sys: &System,
    mode: usize,
    to_amplitude: f64,
    opts: &BackboneOptions,
    progress: &dyn Fn(usize, f64),
    cancel: &AtomicBool,
) -> Result<Backbone> {
    if !(to_amplitude > 0.0) {
        return Err(Error::request(
            format!(
                "the backbone's target amplitude {to_amplitude} is not positive: it is the reference coordinate's displacement from the equilibrium at the orbit's turning point"
            ),
            "give a positive amplitude (m or rad), or none to follow the family until its frequency has moved by a quarter",
        ));
    }
    let (sys0, ma, names) = undamped_modes(sys, opts.normalize.as_deref())?;
    let Some(md) = ma.modes.get(mode) else {
        return Err(Error::request(
            format!(
                "mode index {mode} (mode {}): the model has {} mode(s) at its equilibrium",
                mode + 1,
                ma.modes.len()
            ),
            "count the modes from 0 here (from 1 on the command line), as `detune modes` lists them",
        ));
    };
    let omega_n = md.omega_n_rad_s;
    if !(md.omega_d_rad_s > 0.0) || !omega_n.is_finite() {
        return Err(Error::request(
            format!(
                "mode {} (`{}`) does not oscillate at this equilibrium (eigenvalue {} 1/s): it has no backbone",
                mode + 1,
                names[mode],
                md.eigenvalue.re
            ),
            "pick an oscillating mode, or an equilibrium that is stable (--set the initial pose nearer it)",
        ));
    }
    let freq = sys0
        .forcing_param()
        .ok_or(crate::request::Invalid::NoForcingFrequency)?;
    let eq = ma.equilibrium.q.clone();
    let n = sys0.nq();
    let r = md.normalized_to;
    // a reference coordinate asked for that this mode does not move: the shape was
    // normalized to another (the amplitude would be measured on it, unsaid)
    if let Some(asked) = opts.normalize.as_deref()
        && sys0.coordinates[r] != asked
    {
        let largest = md.shape.iter().map(|c| c.norm()).fold(0.0, f64::max);
        let moving: Vec<&str> = md
            .shape
            .iter()
            .zip(&sys0.coordinates)
            .filter(|(c, _)| c.norm() > 1e-9 * largest)
            .map(|(_, name)| name.as_str())
            .collect();
        return Err(Error::request(
            format!(
                "mode {} (`{}`) does not move {asked} (its shape's entry there is zero), so its amplitude cannot be measured on it",
                mode + 1,
                names[mode]
            ),
            format!(
                "normalize to a coordinate the mode moves: {}",
                moving.join(", ")
            ),
        ));
    }
    // autonomous: the loads and constraints at rest at the equilibrium do not change in time
    {
        let mut f0 = vec![0.0; sys0.nv()];
        let zero = vec![0.0; sys0.nv()];
        sys0.forces(&eq, &zero, 0.0, &mut f0);
        let p0 = sys0.residual(&eq, 0.0);
        let size = crate::linalg::amax(&f0).max(1.0);
        for t in [0.137, 0.61, 1.9, 4.3] {
            let mut f = vec![0.0; sys0.nv()];
            sys0.forces(&eq, &zero, t, &mut f);
            let df = f
                .iter()
                .zip(&f0)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let dp = (sys0.residual(&eq, t) - &p0).amax();
            if df > 1e-9 * size || dp > 1e-12 {
                return Err(Error::request(
                    format!(
                        "with its forcing amplitude at 0 the model still depends on time (the loads change by {df:.3e} N between t = 0 and t = {t} s{}): a backbone is a free oscillation of an autonomous system",
                        if dp > 1e-12 {
                            ", and its constraints move"
                        } else {
                            ""
                        }
                    ),
                    "name the forcing's amplitude parameter in [model] forcing_amplitude, or --set the other time-dependent loads to 0",
                ));
            }
        }
    }
    let responses_names = if opts.responses.is_empty() {
        vec![sys0.coordinates[r].clone()]
    } else {
        opts.responses.clone()
    };
    let outputs = sys0.outputs(&responses_names)?;
    let units: Vec<&'static str> = outputs.iter().map(|o| o.unit(&sys0)).collect();
    // the columns' steps resolve the fastest mode (`COLUMN_STEP_RESOLUTION`)
    let mut shooting = opts.shooting.clone();
    let fastest = super::fastest(&ma.modes);
    if fastest > 0.0 && shooting.integrator == crate::dynamics::integrator::Integrator::Dop853 {
        shooting.max_column_step = super::COLUMN_STEP_RESOLUTION / fastest;
    }
    let mut sh = Shooting::new(&sys0, freq, &outputs, shooting)?;
    sh.set(omega_n)?;
    let phi: Vec<f64> = md.shape.iter().map(|c| c.re).collect();
    let finite = to_amplitude.is_finite();
    // the first amplitude and the largest step
    let scale = if finite {
        to_amplitude
    } else if sys0.is_angle(r) {
        1.0
    } else {
        eq.iter()
            .enumerate()
            .filter(|(i, _)| !sys0.is_angle(*i))
            .fold(0.0f64, |m, (_, v)| m.max(v.abs()))
            .max(1e-3)
            .min(1.0)
    };
    let first = if finite { scale / 50.0 } else { 1e-3 * scale };
    let max_step = if finite { scale / 20.0 } else { f64::INFINITY };
    // the first orbit's displacement against the coordinates' values (the shape scaled
    // to `first` at the reference coordinate), as `nfr` measures it
    // (`Shooting::fit_to_motion`)
    let size = crate::linalg::amax(&eq);
    let displacement = first / phi[r].abs() * phi.iter().map(|c| c * c).sum::<f64>().sqrt();
    let motion = displacement / size;
    sh.fit_to_motion(motion, displacement);
    let mut ctx = Ctx {
        sh,
        n,
        r,
        eq: eq.clone(),
        cancel,
    };
    let mut points: Vec<BackbonePoint> = Vec::new();
    let mut stop: Option<Stop> = None;
    let mut complete = false;
    // the first orbit, from the linear mode
    let mut x0: Vec<f64> = (0..2 * n)
        .map(|i| if i < n { eq[i] + first * phi[i] } else { 0.0 })
        .collect();
    ctx.sh.project(&mut x0);
    match ctx.correct(x0, omega_n, first)? {
        Some(p) => {
            progress(1, p.amplitude);
            points.push(p);
        }
        None => {
            if cancel.load(Ordering::Relaxed) {
                stop = Some(Stop {
                    amplitude: 0.0,
                    omega: omega_n,
                    reason: "interrupted".into(),
                    help: String::new(),
                });
            } else {
                return Err(Error::numerical(
                    format!(
                        "no periodic orbit of mode {} (`{}`) found at the first amplitude {first:.3e} {} of {} (ω_n = {omega_n:.6} rad/s): shooting from the linear mode does not converge",
                        mode + 1,
                        names[mode],
                        if sys0.is_angle(r) { "rad" } else { "m" },
                        sys0.coordinates[r],
                    ),
                    if motion < super::TOO_SMALL_MOTION {
                        format!(
                            "the first orbit (a fiftieth of the target amplitude) moves the coordinates by {motion:.1e} of their values, too little for shooting in double precision: give a larger target amplitude (at this size the mode is linear, its ω_n as `detune modes` gives it)"
                        )
                    } else {
                        "give another target amplitude (larger where this one is tiny against the model's dimensions, smaller where the family may end before it), or --normalize another coordinate that moves in this mode".to_string()
                    },
                ));
            }
        }
    }
    let mut da = if finite { first } else { 0.5 * first };
    while stop.is_none() && !points.is_empty() {
        let last = points.last().expect("one").clone();
        if finite && last.amplitude >= to_amplitude * (1.0 - 1e-12) {
            complete = true;
            break;
        }
        if !finite && (last.omega / omega_n - 1.0).abs() >= opts.max_shift {
            complete = true;
            break;
        }
        if points.len() >= opts.max_points {
            stop = Some(Stop {
                amplitude: last.amplitude,
                omega: last.omega,
                reason: format!("the point limit ({}) was reached", opts.max_points),
                help: "raise the point limit (BackboneOptions::max_points), or ask for a smaller amplitude".into(),
            });
            break;
        }
        if cancel.load(Ordering::Relaxed) {
            stop = Some(Stop {
                amplitude: last.amplitude,
                omega: last.omega,
                reason: "interrupted".into(),
                help: String::new(),
            });
            break;
        }
        let mut step = da.min(max_step);
        if finite {
            step = step.min(to_amplitude - last.amplitude);
        }
        let a = last.amplitude + step;
        // secant predictor
        let (xp, wp) = match points.len() {
            1 => {
                let f = a / last.amplitude;
                let x: Vec<f64> = (0..2 * n)
                    .map(|i| {
                        if i < n {
                            eq[i] + f * (last.x[i] - eq[i])
                        } else {
                            f * last.x[i]
                        }
                    })
                    .collect();
                (x, last.omega)
            }
            k => {
                let prev = &points[k - 2];
                let f = step / (last.amplitude - prev.amplitude);
                let x: Vec<f64> = last
                    .x
                    .iter()
                    .zip(&prev.x)
                    .map(|(l, p)| l + f * (l - p))
                    .collect();
                (x, last.omega + f * (last.omega - prev.omega))
            }
        };
        let mut xp = xp;
        ctx.sh.project(&mut xp);
        let before = ctx.sh.flows;
        let got = ctx.correct(xp, wp, a)?;
        let its = ctx.sh.flows - before;
        match got {
            Some(p) if (p.omega - last.omega).abs() <= 0.03 * omega_n => {
                points.push(p);
                progress(points.len(), a);
                if its <= 3 {
                    da = step * 1.5;
                } else if its >= 6 {
                    da = step * 0.6;
                } else {
                    da = step;
                }
            }
            _ if cancel.load(Ordering::Relaxed) => {
                stop = Some(Stop {
                    amplitude: last.amplitude,
                    omega: last.omega,
                    reason: "interrupted".into(),
                    help: String::new(),
                });
            }
            _ => {
                da = step * 0.5;
                if da < 1e-6 * last.amplitude {
                    let unit = if sys0.is_angle(r) { "rad" } else { "m" };
                    let trend = if last.omega < omega_n {
                        "its frequency falls (softening): the orbit may be approaching a separatrix, the orbit through an unstable equilibrium, where the period grows without bound"
                    } else {
                        "its frequency rises (hardening): the orbit may meet an internal resonance with another mode, or leave the region the model holds together in"
                    };
                    stop = Some(Stop {
                        amplitude: last.amplitude,
                        omega: last.omega,
                        reason: format!(
                            "the family cannot be continued beyond {} = {:.6e} {unit} from the equilibrium (ω = {:.6} rad/s): the orbits no longer converge; {trend}",
                            sys0.coordinates[r], last.amplitude, last.omega
                        ),
                        help: "ask for a smaller amplitude (up to where it stopped), or tighten the integration (rtol) to get closer".into(),
                    });
                }
            }
        }
    }
    Ok(Backbone {
        mode,
        mode_name: names[mode].clone(),
        omega_linear: omega_n,
        reference: r,
        reference_name: sys0.coordinates[r].clone(),
        equilibrium: eq,
        responses: responses_names,
        units,
        points,
        complete: complete && stop.is_none(),
        stop,
        periods: ctx.sh.flows,
        rhs_evaluations: ctx.sh.rhs_evaluations,
    })
}

/// The corrector's state.
struct Ctx<'c> {
    sh: Shooting,
    n: usize,
    /// The reference coordinate.
    r: usize,
    eq: Vec<f64>,
    cancel: &'c AtomicBool,
}

impl Ctx<'_> {
    /// Newton (least squares) from (x, ω) to the orbit of amplitude `a`; None when it does
    /// not converge (or is interrupted).
    fn correct(
        &mut self,
        mut x: Vec<f64>,
        mut omega: f64,
        a: f64,
    ) -> Result<Option<BackbonePoint>> {
        let (n, r) = (self.n, self.r);
        // a step that halves or doubles the frequency has left the family (and would
        // integrate a period of any length)
        let (lo, hi) = (0.5 * omega, 2.0 * omega);
        let mut prev = f64::INFINITY;
        let mut worse = 0;
        for it in 0..15 {
            if !(omega > lo && omega < hi) || !x.iter().all(|v| v.is_finite()) {
                return Ok(None);
            }
            if self.sh.set(omega).is_err() {
                return Ok(None);
            }
            let tb = self.sh.tangent_basis(&x);
            let d = tb.ncols();
            let flow = match self.sh.flow(&x, &tb, true, self.cancel) {
                Ok(f) => f,
                Err(_) => return Ok(None),
            };
            let rel = self.sh.relative(&flow.end, &x, &flow.scale);
            let amp = x[r] - self.eq[r] - a;
            let phase = x[n + r] / omega;
            let size = flow.scale[r].max(a.abs()) + 1e-300;
            let cond = amp.abs().max(phase.abs()) / size;
            // converged, or stalled at the integration's noise after a Newton step (near
            // a separatrix the period is sensitive to the amplitude and the noise grows:
            // the same floor as the forced curve's, `continuation::NOISE_FLOOR`)
            // (neither below the rounding of the coordinates against the orbit's size:
            // the amplitude condition is a difference of the reference coordinate and
            // its equilibrium value, `Shooting::rounding`)
            let tol = self.sh.opts.tol.max(self.sh.rounding(&x, &flow.scale));
            let cond_tol = 1e-10f64.max(
                (super::ROUNDING * x[r].abs().max(self.eq[r].abs()) / size)
                    .min(super::continuation::NOISE_CAP),
            );
            let converged = rel <= tol && cond <= cond_tol;
            let noise = it > 0
                && rel <= super::continuation::NOISE_FLOOR
                && cond <= 1e-8
                && rel.max(cond) > 0.25 * prev;
            if converged || noise {
                let amplitudes = (0..flow.values.first().map_or(0, |v| v.len()))
                    .map(|k| {
                        let s: Vec<f64> = flow.values.iter().map(|v| v[k]).collect();
                        Measures::of(&s, 1).amplitude
                    })
                    .collect();
                return Ok(Some(BackbonePoint {
                    amplitude: a,
                    omega,
                    amplitudes,
                    x,
                }));
            }
            let total = rel.max(cond);
            if !(total < prev) && it > 0 {
                worse += 1;
                if worse >= 2 || it >= 6 {
                    return Ok(None);
                }
            }
            prev = total;
            // [T_xᵀ(J − T_x), T_xᵀ dP/dω; e_{v_r}ᵀ T_x / ω, 0; e_{q_r}ᵀ T_x, 0]
            let dp = flow.dp.as_ref().expect("asked");
            let mut jm = DMatrix::zeros(d + 2, d + 1);
            let fx = tb.transpose() * (&flow.jac - &tb);
            jm.view_mut((0, 0), (d, d)).copy_from(&fx);
            jm.view_mut((0, d), (d, 1))
                .copy_from(&(tb.transpose() * dp));
            for j in 0..d {
                jm[(d, j)] = tb[(n + r, j)] / omega;
                jm[(d + 1, j)] = tb[(r, j)];
            }
            let diff = DVector::from_fn(x.len(), |i, _| flow.end[i] - x[i]);
            let mut rhs = DVector::zeros(d + 2);
            rhs.rows_mut(0, d).copy_from(&(-(tb.transpose() * &diff)));
            rhs[d] = -phase;
            rhs[d + 1] = -amp;
            let step = crate::linalg::solve_least_squares(jm, &rhs);
            if !step.iter().all(|v| v.is_finite()) {
                return Ok(None);
            }
            let dx = &tb * step.rows(0, d);
            for (xi, s) in x.iter_mut().zip(dx.iter()) {
                *xi += s;
            }
            omega += step[d];
            self.sh.project(&mut x);
        }
        Ok(None)
    }
}
