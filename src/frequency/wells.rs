//! Which well a steady state oscillates in: every response of a sweep (and the end of a
//! simulation) is classified by the static equilibrium it oscillates about, so that a
//! snap-through into another well is a result, not a kink in one smooth curve.
//!
//! The wells are the equilibria of [`Statics::all`] (`equilibrium --all`), stable and
//! unstable, solved once per sweep under the loads' mean over a forcing period (the
//! statics of a sweep do not depend on ω unless a parameter does). A steady state is
//! classified from the coordinates sampled over its measured period(s) (its orbit):
//!
//! * its **well** is the equilibrium nearest to the period-mean configuration (the mean of
//!   the tangents from the first sample, retracted back: angles do not wrap, rotations of
//!   free bodies are averaged on the tangent space), by the mass-weighted distance
//!   d² = δᵀ M δ, δ the tangent from the equilibrium with angles (of planar bodies and
//!   of spatial bodies' angle sequences) taken modulo 2π into (−π, π] (as `--all`
//!   deduplicates them);
//! * it **spans two wells** ([`SPANS`], −1) when at least [`SPAN_FRACTION`] of its
//!   samples are nearest to a *stable* equilibrium other than its well. An orbit confined
//!   to one well has its samples nearest to that well's equilibrium or, at the top of its
//!   excursion, to the saddle on the well's rim (which is not another well, so it does not
//!   count); an orbit that crosses the separatrix spends a substantial part of the period
//!   on the far side — about half for a symmetric cross-well orbit — so a quarter is a
//!   margin below that which a one-well orbit does not reach. (On the overcentre at
//!   F0 = 10 N the one-well orbits come nowhere near the other stable pose: see
//!   tests/wells.rs.) An orbit whose mean lies nearest to an unstable equilibrium has all
//!   its samples counted, and spans wells when it visits them.
//!
//! Written by hand: no crate classifies orbits of a constrained mechanism.

use crate::dynamics::assemble_at_rest;
use crate::statics::{Equilibrium, Statics};
use crate::system::System;
use nalgebra::{DMatrix, DVector};

/// The well of an orbit that spans two (or more) wells.
pub const SPANS: isize = -1;

/// The fraction of an orbit's samples nearest to another stable equilibrium from which it
/// spans two wells (see the module doc).
pub const SPAN_FRACTION: f64 = 0.25;

/// The equilibria a system's responses are classified by.
#[derive(Debug, Clone)]
pub struct Wells {
    /// Every equilibrium found, in the order of `equilibrium --all`.
    pub equilibria: Vec<Equilibrium>,
    /// The index of the equilibrium a sweep starts from.
    pub start: usize,
    /// DYNAMIC stability of each equilibrium (no mode of the linearization about it
    /// grows, as `equilibrium --json` gives it): `None` where its modes could not be
    /// computed or it has no degrees of freedom.
    pub dynamically_stable: Vec<Option<bool>>,
    /// Mass matrix (nv × nv) at each equilibrium.
    mass: Vec<DMatrix<f64>>,
}

impl Wells {
    /// The equilibria of `sys` (loads averaged over a forcing period) and the index of
    /// `start` among them (added when the search missed it). When the search for every
    /// equilibrium fails, `start` is the only one: every response is then in well 0.
    pub fn find(sys: &System, start: &Equilibrium) -> Wells {
        let statics = assemble_at_rest(sys)
            .ok()
            .and_then(|rest| Some((Statics::new(sys, &rest.q).ok()?, rest)));
        let equilibria: Vec<Equilibrium> = statics
            .as_ref()
            .and_then(|(st, rest)| st.all(rest).ok())
            .unwrap_or_default();
        let mass: Vec<DMatrix<f64>> = equilibria
            .iter()
            .map(|e| sys.mass_matrix_at(&e.q))
            .collect();
        let mut wells = Wells {
            equilibria,
            start: 0,
            dynamically_stable: Vec::new(),
            mass,
        };
        match wells.nearest(sys, &start.q, false) {
            Some((k, d2)) if d2 <= 1e-10 * (1.0 + wells.scale2(sys, k)) => wells.start = k,
            _ => {
                wells.mass.push(sys.mass_matrix_at(&start.q));
                wells.equilibria.push(start.clone());
                wells.start = wells.equilibria.len() - 1;
            }
        }
        // dynamic stability too, from the modes about each (as `equilibrium` gives it)
        let reference = crate::linear::default_reference(sys);
        wells.dynamically_stable = wells
            .equilibria
            .iter()
            .map(|e| {
                let (st, _) = statics.as_ref()?;
                crate::linear::modal_analysis_at(sys, st, e.clone(), reference)
                    .ok()?
                    .dynamically_stable()
            })
            .collect();
        wells
    }

    /// δᵀ M δ of the equilibrium's own coordinates (a size for the tolerance).
    fn scale2(&self, sys: &System, k: usize) -> f64 {
        let zero = vec![0.0; sys.nq()];
        self.distance2(sys, &zero, k)
    }

    /// Mass-weighted squared distance d² = δᵀ M δ from equilibrium `k` to `q` (kg·m², or
    /// kg·m² and kg·m² per rad² mixed as the mass matrix is), angles modulo 2π (planar
    /// bodies' and spatial bodies' angle sequences; [`System::wrap_angles`]).
    pub fn distance2(&self, sys: &System, q: &[f64], k: usize) -> f64 {
        let e = &self.equilibria[k].q;
        let nv = sys.nv();
        let mut d = DVector::zeros(nv);
        sys.difference(q, e, d.as_mut_slice());
        // angles modulo 2π, of planar bodies and of spatial bodies' angle sequences alike
        sys.wrap_angles(d.as_mut_slice());
        (d.transpose() * &self.mass[k] * &d)[0]
    }

    /// The equilibrium nearest to `q` (only the stable ones with `stable_only`) and its
    /// squared distance.
    pub fn nearest(&self, sys: &System, q: &[f64], stable_only: bool) -> Option<(usize, f64)> {
        (0..self.equilibria.len())
            .filter(|&k| !stable_only || self.equilibria[k].stable)
            .map(|k| (k, self.distance2(sys, q, k)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The well of an orbit (coordinates at samples equally spaced over whole periods):
    /// the index of the equilibrium nearest to its period-mean configuration, or
    /// [`SPANS`] when it crosses into another well (see the module doc). A single
    /// configuration (a state at rest) is its own mean.
    pub fn classify(&self, sys: &System, orbit: &[Vec<f64>]) -> isize {
        if orbit.is_empty() || self.equilibria.is_empty() {
            return SPANS;
        }
        let mean = mean_configuration(sys, orbit);
        let Some((well, _)) = self.nearest(sys, &mean, false) else {
            return SPANS;
        };
        // samples nearest to another stable equilibrium (a saddle on the rim is no well)
        let away = orbit
            .iter()
            .filter(|q| {
                self.nearest(sys, q, false)
                    .is_some_and(|(k, _)| k != well && self.equilibria[k].stable)
            })
            .count();
        if away as f64 >= SPAN_FRACTION * orbit.len() as f64 {
            SPANS
        } else {
            well as isize
        }
    }
}

/// The mean configuration of samples: the first sample ⊕ the mean of the tangents from it.
pub fn mean_configuration(sys: &System, orbit: &[Vec<f64>]) -> Vec<f64> {
    let nv = sys.nv();
    let base = &orbit[0];
    let mut sum = vec![0.0; nv];
    let mut d = vec![0.0; nv];
    for q in orbit {
        sys.difference(q, base, &mut d);
        for (s, x) in sum.iter_mut().zip(&d) {
            *s += x / orbit.len() as f64;
        }
    }
    let mut mean = base.clone();
    sys.retract(&mut mean, &sum, 1.0);
    mean
}

/// The well of the end of a simulation of `sys` from `start`: `tail` holds the last
/// samples (t, q); with a forcing frequency ω > 0 the samples of the last forcing period
/// (t > t_end − 2π/ω) are classified as an orbit (their mean: exact for samples evenly
/// spaced over the period, approximate when `--dt-out` does not divide it), else the
/// final pose alone. None when no equilibrium can be found from `start`.
pub fn end_well(sys: &System, start: &[f64], tail: &[(f64, Vec<f64>)]) -> Option<(Wells, isize)> {
    let (t_end, last) = tail.last()?;
    let rest = crate::dynamics::State {
        t: 0.0,
        q: start.to_vec(),
        v: vec![0.0; sys.nv()],
    };
    let eq = Statics::new(sys, start).ok()?.nearest(&rest).ok()?;
    let wells = Wells::find(sys, &eq);
    let orbit: Vec<Vec<f64>> = match sys.forcing_frequency().filter(|w| *w > 0.0) {
        Some(w) => {
            let from = t_end - std::f64::consts::TAU / w;
            tail.iter()
                .filter(|(t, _)| *t > from + 1e-12)
                .map(|(_, q)| q.clone())
                .collect()
        }
        None => vec![last.clone()],
    };
    let well = wells.classify(sys, &orbit);
    Some((wells, well))
}
