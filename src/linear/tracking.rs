//! Modes that keep their names: naming the modes at the baseline, their energy shares, and
//! tracking the names across a parameter's values.
//!
//! **MAC.** Two shapes a, b (complex, n) are compared by the mass-weighted modal assurance
//! criterion
//!
//! ```text
//! MAC_W(a, b) = |aᴴ W b|² / ((aᴴ W a)(bᴴ W b))        (0 … 1, 1: the same shape)
//! ```
//!
//! with W the mass matrix M at the equilibrium (n × n): the kinetic-energy inner product,
//! so that a heavy body's motion counts for more than a light one's and the criterion does
//! not depend on the coordinates' units. A shape declared in the model file
//! (`[[modes]]`, [`crate::system::DeclaredMode`]) gives only some coordinates S: it is
//! compared with the computed shapes restricted to S, W = M[S, S] (when M[S, S] is not
//! positive definite, a coordinate without inertia of its own among S, W = I instead).
//!
//! **Names at the baseline** ([`name_modes`]). Each declared mode takes the computed mode
//! with which its MAC is largest; a declared mode whose best MAC is below [`MATCH_MAC`]
//! is refused ([`Failure::ModeUnmatched`]), and so are a declared shape whose MACs with
//! two modes are within [`AMBIGUOUS_MAC`] (it does not tell them apart: a shape of one
//! coordinate has MAC 1 with every mode in which that coordinate moves;
//! [`Failure::ModeAmbiguous`]) and two declared modes whose best is the same computed
//! mode ([`Failure::ModesShareMatch`]). A computed mode in which none of the declared
//! coordinates moves (beyond 1e-9 of its largest entry) has MAC 0. When neither happens each
//! declared mode has its own best, which is the optimal one-to-one assignment. The other
//! modes are named `mode k`, k their rank by ω_n at the baseline among all modes (as
//! `detune modes` lists them): the numbers of named modes are skipped, so that `mode 3`
//! is the third mode whether or not the first two have names.
//!
//! **Energy shares** ([`energy_shares`]). A mode's shape x (complex, n; the motion is
//! Re[x e^{λt}]) has the cycle-averaged kinetic energy ∝ Re(x_bᴴ M_bb x_b) in body b (M_bb
//! the block of M of the body's velocities; M is block-diagonal by body) and the strain
//! energy ∝ Re(xᴴ K_e x) in force element e, where K_e = −∂f̄_e/∂q is the stiffness of that
//! element alone at the equilibrium (its loads averaged over the forcing period, as the
//! linearization's). The stiffness of the constraint reactions −Σ λ_i ∇²Φ_i (a mechanism
//! preloaded by gravity or a spring has it) belongs to no one element: it is its own entry,
//! `constraint reactions`. K = Σ_e K_e + K_reactions exactly (gravity's force does not
//! depend on the coordinates, the CG positions, so gravity's stiffness is in the
//! reactions'), so the strain shares sum to 1; a share is negative where the element
//! softens the mode (a compressed spring, a reaction that destabilizes). Along a
//! negative stiffness (the divergent modes of a saddle, an inverted pendulum) the total is
//! negative: the mode releases potential energy rather than storing it, and the shares are
//! each element's energy over the energy released, E_e / |E|, summing to −1 (negative
//! where the element releases energy, positive where it stores some).
//!
//! **Tracking** ([`track_modes`]). From the baseline the parameter is stepped through
//! the values; at each value the `[trim]` is re-solved and the equilibrium continued from
//! the previous pose (Newton), the system linearized and its modes computed. The labels of
//! the previous step are carried to the new modes by the one-to-one assignment that
//! maximizes the sum of MAC_M(previous shape, new shape) (all permutations for up to 8
//! modes, greedily by MAC beyond), with the distance of each eigenvalue from its
//! prediction ([`Predictor`]: the secant through the last two steps, [`Secant`]; the
//! analytic dλ/dp can be plugged in) as a tie-break. Where the assignment is poor (a MAC
//! below [`TrackOptions::min_mac`]) or ambiguous (a label's second-best MAC within
//! [`TrackOptions::ambiguity`] of its best, the second-best a mode whose shape differs from
//! the chosen one's: the two real modes into which an overdamped pair splits have one
//! shape, which no smaller step tells apart, and the prediction decides between them), the
//! step is halved (intermediate values inserted) down to 2^−[`TrackOptions::max_halvings`]
//! of it; then the step is taken and a warning given (one per run of such steps). A label
//! whose mode has gone (fewer modes than labels, after a pair turned into real modes and
//! back) is lost from there on. A value where the trim, the equilibrium or the modes fail
//! ends the tracking with that error, naming the value.
//!
//! **Crossings and veerings** ([`ModeTracking`]). A *crossing* of labels a, b: the sign of
//! ω_a − ω_b changes between two consecutive values (at the value interpolated linearly).
//! A *veering* of labels a, b: their relative gap g = |ω_a − ω_b| / ((ω_a + ω_b)/2) has
//! an interior local minimum at a value p* without a crossing between the neighbouring
//! local maxima of g (or the ends of the range) p_lo < p* < p_hi, the two are adjacent in
//! frequency at p*, and their shapes exchange across it: MAC(x_a(p_lo), x_b(p_hi)) >
//! MAC(x_a(p_lo), x_a(p_hi)) and MAC(x_b(p_lo), x_a(p_hi)) > MAC(x_b(p_lo), x_b(p_hi))
//! (each label ends looking more like the other's start than like its own), MAC weighted
//! by M at p*.
//!
//! Written here by hand: the assignment is a brute force over a handful of modes, which no
//! crate's general assignment solver would make simpler.

use super::{C64, Linearization, ModalAnalysis, Mode, modal_analysis};
use crate::diag::{Error, Result};
use crate::dynamics::State;
use crate::failure::Failure;
use crate::request::{Argument, Invalid, parameter};
use crate::statics::Statics;
use crate::system::System;
use nalgebra::{Complex, DMatrix, DVector};
use num_dual::Dual64;

/// The least MAC with which a declared shape names a computed mode at the baseline.
pub const MATCH_MAC: f64 = 0.5;

/// A declared shape whose MACs with two modes are within this of each other does not
/// tell them apart.
pub const AMBIGUOUS_MAC: f64 = 0.1;

/// The most steps from the baseline to the first value of a tracking.
const MAX_APPROACH: usize = 200;

/// The name of the strain-energy entry of the constraint reactions' stiffness.
pub const CONSTRAINT_REACTIONS: &str = "constraint reactions";

/// The mass-weighted MAC of two complex shapes (see the module doc): |aᴴWb|² /
/// ((aᴴWa)(bᴴWb)); 0 when either has no weighted norm.
pub fn mac(a: &DVector<Complex<f64>>, b: &DVector<Complex<f64>>, w: &DMatrix<f64>) -> f64 {
    let wc = w.map(|v| Complex::new(v, 0.0));
    let ab = (a.adjoint() * &wc * b)[(0, 0)];
    let aa = (a.adjoint() * &wc * a)[(0, 0)].re;
    let bb = (b.adjoint() * &wc * b)[(0, 0)].re;
    if !(aa > 0.0 && bb > 0.0) {
        return 0.0;
    }
    (ab.norm_sqr() / (aa * bb)).clamp(0.0, 1.0)
}

/// A shape as a complex vector.
pub fn shape_vector(shape: &[C64]) -> DVector<Complex<f64>> {
    DVector::from_iterator(shape.len(), shape.iter().map(|c| Complex::new(c.re, c.im)))
}

/// Shares by name (a body, a force element), in the model's order; serialized as a JSON
/// object `{name: fraction}`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Shares(pub Vec<(String, f64)>);

impl Shares {
    /// The share of `name`.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.0.iter().find(|(n, _)| n == name).map(|(_, x)| *x)
    }
    /// The largest share and its name.
    pub fn largest(&self) -> Option<(&str, f64)> {
        self.0
            .iter()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(n, x)| (n.as_str(), *x))
    }
}

impl serde::Serialize for Shares {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

/// A mode's kinetic energy by body and strain energy by force element (fractions; see
/// the module doc).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct EnergyShares {
    /// Body → fraction of the kinetic energy (sums to 1).
    pub kinetic: Shares,
    /// Force element (and [`CONSTRAINT_REACTIONS`]) → fraction of the strain energy (sums
    /// to 1; empty when the mode stores none, a rigid-body mode). Where the mode releases
    /// potential energy instead (a negative stiffness along it: the divergent modes of a
    /// saddle) each entry is the element's energy over the energy released, E_e / |E|,
    /// and they sum to −1 ([`EnergyShares::strain_released`]).
    pub strain: Shares,
}

impl EnergyShares {
    /// Whether the mode releases potential energy rather than storing it (a negative
    /// stiffness along it): the strain shares then sum to −1.
    pub fn strain_released(&self) -> bool {
        self.strain.0.iter().map(|(_, x)| x).sum::<f64>() < 0.0
    }
}

/// The stiffness of each force element alone, and of the constraint reactions, at an
/// equilibrium: `(name, K_e)` (n × n each), summing to the linearization's K.
pub fn element_stiffnesses(
    sys: &System,
    q: &[f64],
    lambda: &[f64],
    rows: &[usize],
) -> Result<Vec<(String, DMatrix<f64>)>> {
    let mut st = Statics::new(sys, q)?;
    st.rows = rows.to_vec();
    let n = st.sys.n();
    let times = st.times().to_vec();
    let mut names: Vec<String> = Vec::new();
    for f in &st.sys.force_names {
        if !names.contains(f) {
            names.push(f.clone());
        }
    }
    let mut out = Vec::new();
    let zero = vec![Dual64::from(0.0); n];
    let mut f = vec![Dual64::from(0.0); n];
    for name in names {
        let mut k = DMatrix::zeros(n, n);
        let mut qd: Vec<Dual64> = q.iter().map(|&x| Dual64::from(x)).collect();
        for j in 0..n {
            qd[j].eps = 1.0;
            for &t in &times {
                st.sys
                    .element_forces_in(&name, &qd, &zero, Dual64::from(t), st.sys.env(), &mut f);
                for i in 0..n {
                    k[(i, j)] -= f[i].eps / times.len() as f64;
                }
            }
            qd[j].eps = 0.0;
        }
        out.push((name, k));
    }
    out.push((
        CONSTRAINT_REACTIONS.to_string(),
        -st.constraint_curvature(q, lambda),
    ));
    Ok(out)
}

/// Each body's range of velocities (its block of M), in the model's order.
fn body_blocks(sys: &System) -> Vec<(String, std::ops::Range<usize>)> {
    let mut starts: Vec<(usize, &str)> = sys
        .bodies
        .iter()
        .map(|b| (b.voff, b.name.as_str()))
        .collect();
    starts.sort();
    let mut out: Vec<(String, std::ops::Range<usize>)> = Vec::new();
    for (k, (start, name)) in starts.iter().enumerate() {
        let end = starts.get(k + 1).map_or(sys.nv(), |s| s.0);
        out.push((name.to_string(), *start..end));
    }
    // the model's order
    out.sort_by_key(|(n, _)| sys.bodies.iter().position(|b| &b.name == n));
    out
}

/// Re(xᴴ A x).
fn quadratic(x: &DVector<Complex<f64>>, a: &DMatrix<f64>) -> f64 {
    let ac = a.map(|v| Complex::new(v, 0.0));
    (x.adjoint() * ac * x)[(0, 0)].re
}

/// The energy shares of every mode of `modal` (see the module doc), in its order.
pub fn energy_shares(sys: &System, modal: &ModalAnalysis) -> Result<Vec<EnergyShares>> {
    let eq = &modal.equilibrium;
    let stiff = element_stiffnesses(sys, &eq.q, &eq.lambda, &modal.rows)?;
    Ok(modal
        .modes
        .iter()
        .map(|m| shares_of(sys, &modal.linearization, &stiff, m))
        .collect())
}

/// The energy shares of one mode, given the elements' stiffnesses.
pub fn shares_of(
    sys: &System,
    lin: &Linearization,
    stiff: &[(String, DMatrix<f64>)],
    mode: &Mode,
) -> EnergyShares {
    let x = shape_vector(&mode.shape);
    let blocks = body_blocks(sys);
    let kinetic: Vec<(String, f64)> = blocks
        .iter()
        .map(|(name, r)| {
            let xb = x.rows(r.start, r.len()).into_owned();
            let mb = lin
                .full_mass
                .view((r.start, r.start), (r.len(), r.len()))
                .into_owned();
            (name.clone(), quadratic(&xb, &mb))
        })
        .collect();
    let strain: Vec<(String, f64)> = stiff
        .iter()
        .map(|(name, k)| (name.clone(), quadratic(&x, k)))
        .collect();
    // what the elements could store at this amplitude: a total below round-off of it is
    // no energy (a rigid-body or neutral mode), whatever its sign
    let reach = stiff.iter().map(|(_, k)| k.amax()).sum::<f64>() * x.norm_squared();
    EnergyShares {
        kinetic: normalized(kinetic),
        strain: strain_shares(strain, reach),
    }
}

/// The strain shares: fractions of the total when it is positive (as [`normalized`]);
/// when it is negative beyond round-off of `reach` (a negative stiffness: the mode
/// lowers the potential energy, a saddle's divergence), fractions of the energy released,
/// E_e / |E|, which sum to −1 (negative where an element releases energy, positive where
/// it stores some); empty when there is none.
fn strain_shares(v: Vec<(String, f64)>, reach: f64) -> Shares {
    let total: f64 = v.iter().map(|(_, x)| x).sum();
    let scale = v.iter().fold(0.0f64, |a, (_, x)| a.max(x.abs()));
    if total.is_finite() && total < -1e-12 * scale && -total > 1e-9 * reach {
        return Shares(v.into_iter().map(|(n, x)| (n, x / -total)).collect());
    }
    normalized(v)
}

/// Fractions of the total (empty when the total is not positive: no energy to share).
fn normalized(v: Vec<(String, f64)>) -> Shares {
    let total: f64 = v.iter().map(|(_, x)| x).sum();
    let scale = v.iter().fold(0.0f64, |a, (_, x)| a.max(x.abs()));
    if !total.is_finite() || total <= 1e-12 * scale {
        return Shares::default();
    }
    Shares(v.into_iter().map(|(n, x)| (n, x / total)).collect())
}

/// A mode's name at the baseline.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ModeName {
    /// The declared name, or `mode k` (k the rank by ω_n at the baseline).
    pub name: String,
    /// The MAC of the declared shape with the mode (declared names only).
    pub declared_mac: Option<f64>,
}

/// The MACs of a declared shape with each mode of `modal` (restricted to the shape's
/// coordinates, weighted by M there; see the module doc).
pub fn declared_macs(sys: &System, modal: &ModalAnalysis, index: usize) -> Vec<f64> {
    let d = &sys.declared_modes[index];
    let s: Vec<usize> = d.shape.iter().map(|(i, _)| *i).collect();
    let m = &modal.linearization.full_mass;
    let mut w = DMatrix::from_fn(s.len(), s.len(), |i, j| m[(s[i], s[j])]);
    if w.clone().cholesky().is_none() {
        w = DMatrix::identity(s.len(), s.len());
    }
    let a = DVector::from_iterator(s.len(), d.shape.iter().map(|(_, x)| Complex::new(*x, 0.0)));
    modal
        .modes
        .iter()
        .map(|md| {
            let b = DVector::from_iterator(
                s.len(),
                s.iter()
                    .map(|&i| Complex::new(md.shape[i].re, md.shape[i].im)),
            );
            // coordinates that do not move in the mode (rounding only): no match
            let size = md.shape.iter().fold(0.0f64, |m, c| m.max(c.norm()));
            if b.iter().all(|c| c.norm() <= 1e-9 * size) {
                return 0.0;
            }
            mac(&a, &b, &w)
        })
        .collect()
}

/// The names of the modes of `modal` (one per mode, in its order): the model's declared
/// modes matched by MAC, the others `mode k` (see the module doc).
pub fn name_modes(sys: &System, modal: &ModalAnalysis) -> Result<Vec<ModeName>> {
    let mut names: Vec<ModeName> = (0..modal.modes.len())
        .map(|k| ModeName {
            name: format!("mode {}", k + 1),
            declared_mac: None,
        })
        .collect();
    let mut taken: Vec<Option<(usize, f64)>> = vec![None; modal.modes.len()];
    for (d, decl) in sys.declared_modes.iter().enumerate() {
        let macs = declared_macs(sys, modal, d);
        let best = (0..macs.len()).max_by(|&i, &j| macs[i].total_cmp(&macs[j]));
        let Some(best) = best.filter(|&b| macs[b] >= MATCH_MAC) else {
            return Err(Failure::ModeUnmatched {
                name: decl.name.clone(),
                best: macs.iter().copied().fold(0.0, f64::max),
                threshold: MATCH_MAC,
                macs,
            }
            .into());
        };
        // a shape that does not tell two modes apart (one coordinate moves in both)
        if let Some(second) = (0..macs.len())
            .filter(|&j| j != best)
            .max_by(|&i, &j| macs[i].total_cmp(&macs[j]))
            .filter(|&j| macs[j] > macs[best] - AMBIGUOUS_MAC)
        {
            return Err(Failure::ModeAmbiguous {
                name: decl.name.clone(),
                modes: [best.min(second) + 1, best.max(second) + 1],
                macs: [macs[best.min(second)], macs[best.max(second)]],
            }
            .into());
        }
        if let Some((other, other_mac)) = taken[best] {
            return Err(Failure::ModesShareMatch {
                first: sys.declared_modes[other].name.clone(),
                second: decl.name.clone(),
                mode: best + 1,
                first_mac: other_mac,
                second_mac: macs[best],
            }
            .into());
        }
        taken[best] = Some((d, macs[best]));
        names[best] = ModeName {
            name: decl.name.clone(),
            declared_mac: Some(macs[best]),
        };
    }
    Ok(names)
}

/// A body and its share of a mode's kinetic energy.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BodyShare {
    pub body: String,
    /// Fraction (0 … 1).
    pub share: f64,
}

/// One mode of [`describe_modes`]: its name, energy shares and the body that holds most
/// of its kinetic energy.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct NamedMode {
    pub name: ModeName,
    pub energy: EnergyShares,
    /// The body with the largest kinetic-energy share, and the share.
    pub dominant_body: Option<BodyShare>,
}

/// Names and energy shares of every mode of `modal` (in its order).
pub fn describe_modes(sys: &System, modal: &ModalAnalysis) -> Result<Vec<NamedMode>> {
    with_shares(sys, modal, name_modes(sys, modal)?)
}

/// `names` (one per mode of `modal`) with each mode's energy shares and dominant body.
fn with_shares(
    sys: &System,
    modal: &ModalAnalysis,
    names: Vec<ModeName>,
) -> Result<Vec<NamedMode>> {
    let shares = energy_shares(sys, modal)?;
    Ok(names
        .into_iter()
        .zip(shares)
        .map(|(name, energy)| NamedMode {
            dominant_body: energy.kinetic.largest().map(|(b, x)| BodyShare {
                body: b.to_string(),
                share: x,
            }),
            name,
            energy,
        })
        .collect())
}

/// [`describe_modes`], falling back to numbering the modes by frequency when the model's
/// declared `[[modes]]` cannot be matched (a design far from the one they describe, e.g.
/// an unstable one: a shape that matches two modes, or none): as `margins` and
/// `sensitivity` do ([`super::sensitivity::mode_names`]). The second value says why,
/// when it fell back.
pub fn describe_modes_or_numbered(
    sys: &System,
    modal: &ModalAnalysis,
) -> Result<(Vec<NamedMode>, Option<String>)> {
    let (names, note) = match name_modes(sys, modal) {
        Ok(n) => (n, None),
        Err(e) => (
            (0..modal.modes.len())
                .map(|k| ModeName {
                    name: format!("mode {}", k + 1),
                    declared_mac: None,
                })
                .collect(),
            Some(
                e.failure()
                    .map(|f| f.to_string())
                    .unwrap_or_else(|| e.to_string()),
            ),
        ),
    };
    Ok((with_shares(sys, modal, names)?, note))
}

/// Options of [`track_modes`].
#[derive(Debug, Clone)]
pub struct TrackOptions {
    /// The least MAC with the previous step a label may have without halving the step.
    pub min_mac: f64,
    /// A label's second-best MAC within this of its best is ambiguous: halve the step.
    pub ambiguity: f64,
    /// The most halvings of a step (the smallest step is 2^−this of the grid's).
    pub max_halvings: usize,
    /// The coordinate the shapes are normalized to (default: the first angle).
    pub normalize: Option<String>,
    /// Set (by a signal) to stop at the next value of the parameter:
    /// [`Failure::StudyInterrupted`](crate::failure::Failure::StudyInterrupted), nothing kept.
    pub cancel: Option<&'static std::sync::atomic::AtomicBool>,
}

impl Default for TrackOptions {
    fn default() -> Self {
        TrackOptions {
            min_mac: 0.9,
            ambiguity: 0.1,
            max_halvings: 8,
            normalize: None,
            cancel: None,
        }
    }
}

/// An error once `opts.cancel` is set: the tracking stops at its next value.
fn stop_if_cancelled(opts: &TrackOptions) -> Result<()> {
    match opts.cancel {
        Some(c) if c.load(std::sync::atomic::Ordering::Relaxed) => {
            Err(crate::failure::Failure::StudyInterrupted {
                what: "the mode tracking".into(),
                kept: false,
            }
            .into())
        }
        _ => Ok(()),
    }
}

/// One solved value of the parameter on a tracking path.
#[derive(Debug, Clone)]
pub struct Solved {
    pub value: f64,
    pub modal: ModalAnalysis,
    /// For each label, the index of its mode in `modal.modes` (None: lost).
    pub modes: Vec<Option<usize>>,
    /// For each label, its MAC with its previous step (1 at the start).
    pub macs: Vec<f64>,
}

impl Solved {
    /// The eigenvalue of label `l`.
    pub fn eigenvalue(&self, l: usize) -> Option<Complex<f64>> {
        self.modes[l].map(|k| {
            let e = self.modal.modes[k].eigenvalue;
            Complex::new(e.re, e.im)
        })
    }
}

/// The hook for predicting each label's eigenvalue at the next value from the path
/// solved so far (the analytic dλ/dp of a sensitivity analysis, or [`Secant`]).
pub trait Predictor {
    /// `path`: the values solved so far (at least one), the last the current one; returns
    /// per label the predicted λ at `next` (None: no prediction).
    fn predict(&self, sys: &System, path: &[Solved], next: f64) -> Vec<Option<Complex<f64>>>;
}

/// The secant through the last two solved values (the last value's λ when there is one).
#[derive(Debug, Clone, Copy, Default)]
pub struct Secant;

impl Predictor for Secant {
    fn predict(&self, _sys: &System, path: &[Solved], next: f64) -> Vec<Option<Complex<f64>>> {
        let last = &path[path.len() - 1];
        let prev = path.len().checked_sub(2).map(|k| &path[k]);
        (0..last.modes.len())
            .map(|l| {
                let now = last.eigenvalue(l)?;
                match prev.and_then(|p| p.eigenvalue(l).map(|e| (p.value, e))) {
                    Some((p0, before)) if p0 != last.value => {
                        Some(now + (now - before) * ((next - last.value) / (last.value - p0)))
                    }
                    _ => Some(now),
                }
            })
            .collect()
    }
}

/// A label's mode at one value.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct TrackedMode {
    pub omega_n_rad_s: f64,
    pub freq_hz: f64,
    pub damping_ratio: f64,
    pub eigenvalue: C64,
    /// MAC with the label's shape at the previous value solved (inserted values
    /// included), 1 at the first.
    pub mac: f64,
}

/// One value of the parameter in a [`ModeTracking`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct TrackStep {
    pub value: f64,
    /// Whether the value was asked for (false: inserted by step halving).
    pub requested: bool,
    /// Per label (in [`ModeTracking::labels`] order); None where the label was lost.
    pub modes: Vec<Option<TrackedMode>>,
    /// Per label, its shape (for the veering test and callers' plots).
    #[serde(skip)]
    pub shapes: Vec<Option<Vec<C64>>>,
    /// M at the equilibrium (n × n).
    #[serde(skip)]
    pub mass: DMatrix<f64>,
}

/// Two labels whose ω_n swap order.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Crossing {
    pub labels: [String; 2],
    /// The parameter value (linear interpolation of ω_a − ω_b between the two values).
    pub value: f64,
    /// ω_n there, rad/s (interpolated).
    pub omega_n_rad_s: f64,
}

/// Two labels that approach without crossing while their shapes exchange (module doc).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Veering {
    pub labels: [String; 2],
    /// The value of the least relative gap.
    pub value: f64,
    /// The least relative gap |ω_a − ω_b| / mean.
    pub relative_gap: f64,
    /// ω_n of the two there, rad/s.
    pub omega_n_rad_s: [f64; 2],
    /// The window [p_lo, p_hi] over which the shapes exchange.
    pub window: [f64; 2],
}

/// Modes tracked over a parameter's values.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ModeTracking {
    pub param: String,
    /// The parameter's value in the model (where the names were given).
    pub baseline: f64,
    /// The names, by ω_n at the baseline.
    pub labels: Vec<String>,
    /// Per label, the body holding most of its kinetic energy at the baseline, and its
    /// share.
    pub dominant_body: Vec<Option<BodyShare>>,
    /// Every value solved from the first requested to the last, inserted ones included.
    pub steps: Vec<TrackStep>,
    /// Per label, its least MAC with its previous step over the range.
    pub min_mac: Vec<f64>,
    pub crossings: Vec<Crossing>,
    pub veerings: Vec<Veering>,
    /// Steps taken although their assignment stayed poor at the smallest step.
    pub warnings: Vec<String>,
}

/// The modes of `sys` at `value` of parameter `index`, the `[trim]` re-solved and the
/// equilibrium continued from `q` (Newton; the nearest equilibrium if that fails).
fn solve_at(
    sys: &System,
    index: usize,
    value: f64,
    q: &[f64],
    reference: usize,
) -> Result<ModalAnalysis> {
    let at = sys.with_param(index, value)?;
    let start = State {
        t: 0.0,
        q: q.to_vec(),
        v: vec![0.0; sys.nv()],
    };
    let (at, _) = crate::statics::trim::trimmed(&at, &start)?;
    // a trimmed datum is an equilibrium already (the trim solved it, as
    // `sensitivity::modes_at` takes it); else Newton from the last step's equilibrium
    let q0 = if at.trim_solved().is_some() {
        at.initial.q.clone()
    } else {
        q.to_vec()
    };
    let st = Statics::new(&at, &q0)?;
    let equilibrium = match st.solve(&q0) {
        Ok(e) => e,
        Err(_) => st.nearest(&State {
            q: q0.clone(),
            ..start
        })?,
    };
    let linearization = Linearization::new(&st, &equilibrium);
    let modes = linearization.modes(reference)?;
    let undamped_omega2 = linearization.undamped_omega2();
    Ok(ModalAnalysis {
        coordinates: at.coordinates.clone(),
        equilibrium,
        linearization,
        modes,
        undamped_omega2,
        reference,
        rows: st.rows.clone(),
    })
}

/// One step of label carrying, for callers that move along their own path (several
/// parameters at once, an optimizer's steps): the labels of `last` assigned to the modes
/// of `next` as [`track_modes`] assigns them (`predicted`: per label the predicted λ at
/// `next`, or None), without halving. Returns per label its mode in `next.modes` (None:
/// lost) and its MAC, and whether the step was poor or ambiguous (a caller should then
/// take a smaller step).
pub fn carry_labels(
    last: &Solved,
    next: &ModalAnalysis,
    predicted: &[Option<Complex<f64>>],
    opts: &TrackOptions,
) -> (Vec<Option<usize>>, Vec<f64>, bool) {
    assign(last, next, predicted, opts)
}

/// The assignment of the labels of `last` to the modes of `next`: per label the mode and
/// its MAC, and whether it is poor or ambiguous.
fn assign(
    last: &Solved,
    next: &ModalAnalysis,
    predicted: &[Option<Complex<f64>>],
    opts: &TrackOptions,
) -> (Vec<Option<usize>>, Vec<f64>, bool) {
    let nl = last.modes.len();
    let nc = next.modes.len();
    let w = &next.linearization.full_mass;
    let new: Vec<DVector<Complex<f64>>> =
        next.modes.iter().map(|m| shape_vector(&m.shape)).collect();
    // score[l][j] = MAC + a tie-break by the prediction (< 0.01)
    let mut macs = vec![vec![0.0; nc]; nl];
    let mut score = vec![vec![f64::NEG_INFINITY; nc]; nl];
    for l in 0..nl {
        let Some(k) = last.modes[l] else { continue };
        let old = shape_vector(&last.modal.modes[k].shape);
        for j in 0..nc {
            macs[l][j] = mac(&old, &new[j], w);
            let e = next.modes[j].eigenvalue;
            let closeness = predicted[l].map_or(0.0, |p| {
                let d = (Complex::new(e.re, e.im) - p).norm() / p.norm().max(1e-12);
                0.01 / (1.0 + d)
            });
            score[l][j] = macs[l][j] + closeness;
        }
    }
    let active: Vec<usize> = (0..nl).filter(|&l| last.modes[l].is_some()).collect();
    let chosen = best_assignment(&active, nc, &score);
    let mut modes = vec![None; nl];
    let mut out_macs = vec![0.0; nl];
    let mut poor = false;
    for (&l, j) in active.iter().zip(&chosen) {
        modes[l] = *j;
        match j {
            Some(j) => {
                out_macs[l] = macs[l][*j];
                if macs[l][*j] < opts.min_mac {
                    poor = true;
                }
                // a rival of a shape like the chosen one's (the two real modes of a pair
                // that has become overdamped) is no ambiguity a smaller step resolves:
                // the prediction decides between them
                let second = (0..nc)
                    .filter(|&i| i != *j && mac(&new[i], &new[*j], w) < opts.min_mac)
                    .map(|i| macs[l][i])
                    .fold(0.0, f64::max);
                if macs[l][*j] - second < opts.ambiguity {
                    poor = true;
                }
            }
            None => poor = true,
        }
    }
    (modes, out_macs, poor)
}

/// The one-to-one assignment of `labels` to `nc` columns maximizing the total score: all
/// permutations when both are at most 8, else greedily by score. None for a label left
/// without a column (fewer columns than labels).
fn best_assignment(labels: &[usize], nc: usize, score: &[Vec<f64>]) -> Vec<Option<usize>> {
    if labels.len() <= 8 && nc <= 8 {
        let mut best = (f64::NEG_INFINITY, vec![None; labels.len()]);
        let mut current = vec![None; labels.len()];
        let mut used = vec![false; nc];
        fn search(
            k: usize,
            labels: &[usize],
            score: &[Vec<f64>],
            used: &mut [bool],
            current: &mut Vec<Option<usize>>,
            total: f64,
            best: &mut (f64, Vec<Option<usize>>),
        ) {
            if k == labels.len() {
                if total > best.0 {
                    *best = (total, current.clone());
                }
                return;
            }
            let free = used.iter().filter(|u| !**u).count();
            for j in 0..used.len() {
                if used[j] {
                    continue;
                }
                used[j] = true;
                current[k] = Some(j);
                search(
                    k + 1,
                    labels,
                    score,
                    used,
                    current,
                    total + score[labels[k]][j],
                    best,
                );
                used[j] = false;
            }
            // a label left out only when there are fewer columns than labels to fill
            if free < labels.len() - k {
                current[k] = None;
                search(k + 1, labels, score, used, current, total, best);
            }
        }
        search(0, labels, score, &mut used, &mut current, 0.0, &mut best);
        return best.1;
    }
    let mut pairs: Vec<(usize, usize)> = (0..labels.len())
        .flat_map(|k| (0..nc).map(move |j| (k, j)))
        .collect();
    pairs.sort_by(|a, b| score[labels[b.0]][b.1].total_cmp(&score[labels[a.0]][a.1]));
    let mut out = vec![None; labels.len()];
    let mut used = vec![false; nc];
    for (k, j) in pairs {
        if out[k].is_none() && !used[j] {
            out[k] = Some(j);
            used[j] = true;
        }
    }
    out
}

/// The state of a tracking path.
struct Path<'a> {
    sys: &'a System,
    index: usize,
    reference: usize,
    opts: &'a TrackOptions,
    predictor: &'a dyn Predictor,
    solved: Vec<Solved>,
    /// Runs of steps taken although poor at the smallest step: (from, to, least MAC).
    poor: Vec<(f64, f64, f64)>,
}

impl Path<'_> {
    /// Step from the last value solved to `target`, halving where the assignment is poor.
    fn step_to(&mut self, target: f64, depth: usize) -> Result<()> {
        let last = self.solved.last().expect("a path starts solved");
        let from = last.value;
        let modal = match solve_at(
            self.sys,
            self.index,
            target,
            &last.modal.equilibrium.q,
            self.reference,
        ) {
            Ok(m) => m,
            // a step too long for Newton from the last equilibrium: halve it
            Err(_) if depth < self.opts.max_halvings => {
                let mid = 0.5 * (from + target);
                self.step_to(mid, depth + 1)?;
                return self.step_to(target, depth + 1);
            }
            Err(e) => {
                let name = &self.sys.param_names()[self.index];
                // a halved step's value, to 12 digits (0.10875, not 0.10875000000000001)
                let shown: f64 = format!("{target:.11e}").parse().unwrap_or(target);
                return Err(e.context(&format!(
                    "tracking the modes, at {name} = {}",
                    crate::diag::num(shown)
                )));
            }
        };
        let predicted = self.predictor.predict(self.sys, &self.solved, target);
        let last = self.solved.last().expect("a path starts solved");
        let (modes, macs, poor) = assign(last, &modal, &predicted, self.opts);
        if poor && depth < self.opts.max_halvings {
            let mid = 0.5 * (from + target);
            self.step_to(mid, depth + 1)?;
            return self.step_to(target, depth + 1);
        }
        if poor {
            let worst = macs.iter().copied().fold(1.0, f64::min);
            // one warning per run of consecutive poor steps
            match self.poor.last_mut() {
                Some(run) if run.1 == from => {
                    run.1 = target;
                    run.2 = run.2.min(worst);
                }
                _ => self.poor.push((from, target, worst)),
            }
        }
        self.solved.push(Solved {
            value: target,
            modal,
            modes,
            macs,
        });
        Ok(())
    }
}

/// Track the modes of `sys` over the `values` of parameter `param` (see the module doc),
/// named at the model's own value of `param` (the baseline) by [`name_modes`], with the
/// secant predictor.
pub fn track_modes(
    sys: &System,
    param: &str,
    values: &[f64],
    opts: &TrackOptions,
) -> Result<ModeTracking> {
    track_modes_with(sys, param, values, opts, &Secant)
}

/// [`track_modes`] with another predictor.
pub fn track_modes_with(
    sys: &System,
    param: &str,
    values: &[f64],
    opts: &TrackOptions,
    predictor: &dyn Predictor,
) -> Result<ModeTracking> {
    let index = parameter(sys.param_names(), param, Argument::TrackedParameter)?;
    if values.is_empty() || values.iter().any(|v| !v.is_finite()) {
        return Err(Invalid::Range {
            what: Argument::TrackedValues,
            from: values.first().copied().unwrap_or(f64::NAN),
            to: values.last().copied().unwrap_or(f64::NAN),
        }
        .into());
    }
    if let Some(t) = &sys.trim
        && t.off.is_none()
        && t.params.contains(&index)
    {
        return Err(Error::request(
            format!(
                "`{param}` is solved by the model's [trim]: its value follows the other parameters"
            ),
            "track another parameter, or give it a value (which turns the trim off) and track that",
        ));
    }
    let baseline = sys.param(index);
    let modal = modal_analysis(sys, opts.normalize.as_deref())?;
    let reference = modal.reference;
    let described = describe_modes(sys, &modal)?;
    let labels: Vec<String> = described.iter().map(|n| n.name.name.clone()).collect();
    let dominant_body = described.into_iter().map(|n| n.dominant_body).collect();
    let nl = labels.len();
    let mut path = Path {
        sys,
        index,
        reference,
        opts,
        predictor,
        solved: vec![Solved {
            value: baseline,
            modes: (0..nl).map(Some).collect(),
            macs: vec![1.0; nl],
            modal,
        }],
        poor: Vec::new(),
    };
    // from the baseline to the first value, in steps no larger than the grid's
    let grid_step = values
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|s| *s > 0.0)
        .fold(f64::INFINITY, f64::min);
    let approach = values[0] - baseline;
    if approach != 0.0 {
        // (at most MAX_APPROACH steps: each is halved where the modes need it)
        let n = if grid_step.is_finite() {
            (approach.abs() / grid_step)
                .ceil()
                .clamp(1.0, MAX_APPROACH as f64) as usize
        } else {
            1
        };
        for k in 1..=n {
            stop_if_cancelled(opts)?;
            path.step_to(baseline + approach * k as f64 / n as f64, 0)?;
        }
    }
    let start = path.solved.len() - 1;
    let mut requested = vec![start];
    for &v in &values[1..] {
        stop_if_cancelled(opts)?;
        path.step_to(v, 0)?;
        requested.push(path.solved.len() - 1);
    }
    let mut asked = vec![false; path.solved.len()];
    for k in requested {
        asked[k] = true;
    }
    let solved = &path.solved[start..];
    let steps: Vec<TrackStep> = solved
        .iter()
        .enumerate()
        .map(|(k, s)| TrackStep {
            value: s.value,
            requested: asked[k + start],
            modes: (0..nl)
                .map(|l| {
                    s.modes[l].map(|j| {
                        let m = &s.modal.modes[j];
                        TrackedMode {
                            omega_n_rad_s: m.omega_n_rad_s,
                            freq_hz: m.freq_hz,
                            damping_ratio: m.damping_ratio,
                            eigenvalue: m.eigenvalue,
                            mac: if k == 0 && start == 0 { 1.0 } else { s.macs[l] },
                        }
                    })
                })
                .collect(),
            shapes: (0..nl)
                .map(|l| s.modes[l].map(|j| s.modal.modes[j].shape.clone()))
                .collect(),
            mass: s.modal.linearization.full_mass.clone(),
        })
        .collect();
    let min_mac = (0..nl)
        .map(|l| {
            steps
                .iter()
                .filter_map(|s| s.modes[l].as_ref().map(|m| m.mac))
                .fold(1.0, f64::min)
        })
        .collect();
    let crossings = crossings(&labels, &steps);
    let veerings = veerings(&labels, &steps);
    Ok(ModeTracking {
        param: param.to_string(),
        baseline,
        labels,
        dominant_body,
        steps,
        min_mac,
        crossings,
        veerings,
        warnings: path
            .poor
            .iter()
            .map(|(a, b, worst)| {
                format!(
                    "{param} from {a} to {b}: the modes' assignment stays poor or ambiguous at the smallest step (least MAC {worst:.3}); the labels there may have swapped"
                )
            })
            .collect(),
    })
}

/// ω_n of label `l` at step `s`.
fn omega(s: &TrackStep, l: usize) -> Option<f64> {
    s.modes[l].as_ref().map(|m| m.omega_n_rad_s)
}

/// Crossings: the sign of ω_a − ω_b changes between consecutive steps.
fn crossings(labels: &[String], steps: &[TrackStep]) -> Vec<Crossing> {
    let mut out = Vec::new();
    for a in 0..labels.len() {
        for b in a + 1..labels.len() {
            for w in steps.windows(2) {
                let (Some(a0), Some(b0), Some(a1), Some(b1)) = (
                    omega(&w[0], a),
                    omega(&w[0], b),
                    omega(&w[1], a),
                    omega(&w[1], b),
                ) else {
                    continue;
                };
                let (d0, d1) = (a0 - b0, a1 - b1);
                if d0 * d1 < 0.0 || (d0 != 0.0 && d1 == 0.0) {
                    let s = d0 / (d0 - d1);
                    out.push(Crossing {
                        labels: [labels[a].clone(), labels[b].clone()],
                        value: w[0].value + s * (w[1].value - w[0].value),
                        omega_n_rad_s: a0 + s * (a1 - a0),
                    });
                }
            }
        }
    }
    out.sort_by(|x, y| x.value.total_cmp(&y.value));
    out
}

/// Veerings (module doc).
fn veerings(labels: &[String], steps: &[TrackStep]) -> Vec<Veering> {
    let mut out = Vec::new();
    let n = steps.len();
    for a in 0..labels.len() {
        for b in a + 1..labels.len() {
            let gap: Vec<Option<f64>> = steps
                .iter()
                .map(|s| {
                    let (wa, wb) = (omega(s, a)?, omega(s, b)?);
                    Some((wa - wb).abs() / (0.5 * (wa + wb)))
                })
                .collect();
            for k in 1..n.saturating_sub(1) {
                let (Some(g0), Some(g), Some(g1)) = (gap[k - 1], gap[k], gap[k + 1]) else {
                    continue;
                };
                if !(g < g0 && g <= g1) {
                    continue;
                }
                // adjacent in frequency at the minimum
                let (wa, wb) = (
                    omega(&steps[k], a).unwrap_or(0.0),
                    omega(&steps[k], b).unwrap_or(0.0),
                );
                let (lo_w, hi_w) = (wa.min(wb), wa.max(wb));
                let between = (0..labels.len()).any(|c| {
                    c != a && c != b && omega(&steps[k], c).is_some_and(|w| w > lo_w && w < hi_w)
                });
                if between {
                    continue;
                }
                let mut lo = k;
                while lo > 0 && matches!((gap[lo - 1], gap[lo]), (Some(x), Some(y)) if x > y) {
                    lo -= 1;
                }
                let mut hi = k;
                while hi + 1 < n && matches!((gap[hi + 1], gap[hi]), (Some(x), Some(y)) if x >= y) {
                    hi += 1;
                }
                let sign = |s: &TrackStep| {
                    (omega(s, a).unwrap_or(0.0) - omega(s, b).unwrap_or(0.0)).signum()
                };
                if sign(&steps[lo]) != sign(&steps[hi]) {
                    continue; // a crossing, not a veering
                }
                let shape = |s: &TrackStep, l: usize| s.shapes[l].as_ref().map(|x| shape_vector(x));
                let (Some(alo), Some(blo), Some(ahi), Some(bhi)) = (
                    shape(&steps[lo], a),
                    shape(&steps[lo], b),
                    shape(&steps[hi], a),
                    shape(&steps[hi], b),
                ) else {
                    continue;
                };
                let w = &steps[k].mass;
                if mac(&alo, &bhi, w) > mac(&alo, &ahi, w)
                    && mac(&blo, &ahi, w) > mac(&blo, &bhi, w)
                {
                    out.push(Veering {
                        labels: [labels[a].clone(), labels[b].clone()],
                        value: steps[k].value,
                        relative_gap: g,
                        omega_n_rad_s: [wa, wb],
                        window: [steps[lo].value, steps[hi].value],
                    });
                }
            }
        }
    }
    out.sort_by(|x, y| x.value.total_cmp(&y.value));
    out
}

/// `n` values from `from` to `to` (`n` ≥ 2; 1: `from` alone), or by `step` (see
/// [`super::grid`]): the values a tracking steps through.
pub fn values(from: f64, to: f64, step: Option<f64>, points: Option<usize>) -> Result<Vec<f64>> {
    if !(from.is_finite() && to.is_finite()) || from == to {
        return Err(Invalid::Range {
            what: Argument::TrackedValues,
            from,
            to,
        }
        .into());
    }
    if let Some(s) = step {
        if !s.is_finite() || s <= 0.0 {
            return Err(Invalid::NotPositive {
                argument: Argument::TrackedStep,
                value: s,
            }
            .into());
        }
        let n = ((to - from).abs() / s + 1e-9).floor();
        if n > 100_000.0 {
            return Err(Invalid::TooManyPoints {
                argument: Argument::TrackedStep,
                value: s,
                points: n,
                limit: 100_000,
            }
            .into());
        }
        let dir = (to - from).signum();
        let size = if from == 0.0 { s } else { s.min(from.abs()) };
        let n = n as usize;
        let mut v: Vec<f64> = (0..=n)
            .map(|k| super::round_to_step(from + dir * k as f64 * s, size))
            .collect();
        if (v[v.len() - 1] - to).abs() > 1e-9 * s {
            v.push(to);
        }
        return Ok(v);
    }
    let n = points.unwrap_or(51);
    if n < 2 {
        return Err(Error::request(
            format!(
                "{} {n} is fewer than 2: a range has two ends",
                Argument::TrackedPoints
            ),
            "ask for 2 points or more",
        ));
    }
    if n > 100_000 {
        return Err(Invalid::TooManyPoints {
            argument: Argument::TrackedPoints,
            value: n as f64,
            points: n as f64,
            limit: 100_000,
        }
        .into());
    }
    Ok((0..n)
        .map(|k| from + (to - from) * k as f64 / (n - 1) as f64)
        .collect())
}
