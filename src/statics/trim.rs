//! Trim: parameters solved so that a stated pose is a static equilibrium (`[trim]` in the
//! model file: the inceptor's force-sensor natural length L0 so that the stick rests at
//! φ0 under gravity).
//!
//! The unknowns are the free coordinates, the multipliers and the solved parameters; the
//! held coordinates stay at their initial values. Newton on the equilibrium equations
//! R(q, λ; p) = 0 with the held coordinates' columns of ∂R/∂(q, λ) replaced by ∂R/∂p
//! (automatic differentiation, [`Statics::residual_dp`]).

use super::Statics;
use crate::diag::Result;
use crate::dynamics::State;
use crate::failure::Failure;
use crate::system::System;

/// [`trimmed`] from the system's assembled initial state.
pub fn trim(sys: &System) -> Result<(System, Vec<(String, f64)>)> {
    if sys.trim.as_ref().is_none_or(|t| t.off.is_some()) {
        return Ok((sys.clone(), Vec::new()));
    }
    let start = crate::dynamics::assemble_at_rest(sys)?;
    trimmed(sys, &start)
}

/// The system with its `[trim]` parameters solved (a copy; the same system if it has no
/// trim or the trim is off because a solved parameter was given), and the solved values
/// `(name, value)`.
pub fn trimmed(sys: &System, start: &State) -> Result<(System, Vec<(String, f64)>)> {
    let Some(trim) = sys
        .trim
        .clone()
        .filter(|t| t.off.is_none() && !t.params.is_empty())
    else {
        return Ok((sys.clone(), Vec::new()));
    };
    if trim.params.len() != trim.coords.len() {
        return Err(Failure::TrimFailed {
            params: "the trim".into(),
            residual: f64::NAN,
        }
        .into());
    }
    let mut s = sys.clone();
    let n = s.nv();
    let mut q = start.q.clone();
    for &c in &trim.coords {
        q[c] = s.initial.q[c];
    }
    let rows = super::independent_rows(&s, &q);
    let mut lambda = Statics::with_rows(&s, rows.clone())?.multipliers(&q);
    let names: Vec<String> = trim
        .params
        .iter()
        .map(|&i| s.param_names()[i].clone())
        .collect();
    let mut last = f64::INFINITY;
    for it in 0..=50 {
        let st = Statics::with_rows(&s, rows.clone())?;
        let mut x = q.clone();
        x.extend(&lambda);
        let (r, ar) = st.residual_rows(&x);
        let scale = st.force_scale(&q);
        last = r.amax();
        if st.converged(&r, &x, scale) {
            if let Some(t) = s.trim.as_mut() {
                t.solved = true;
            }
            // the datum is the initial pose: a simulation starts there, at rest (the
            // model's guesses for coordinates no constraint reaches, such as a gearbox
            // behind a compliant shaft, would start it twisted)
            s.initial.q.copy_from_slice(&q);
            let solved = names
                .iter()
                .zip(&trim.params)
                .map(|(nm, &i)| (nm.clone(), s.param(i)))
                .collect();
            return Ok((s, solved));
        }
        if it == 50 || !last.is_finite() {
            break;
        }
        let mut j = st.kkt_jacobian_with(&x, &ar);
        for (&c, &p) in trim.coords.iter().zip(&trim.params) {
            let dp = st.residual_dp(&x, p);
            j.set_column(c, &dp);
        }
        // equilibrated: the solved parameter's column (a stiffness times an arm) and the
        // constraint rows differ by many orders of magnitude
        let dx = crate::linalg::solve_equilibrated(j, &r);
        let mut dq: Vec<f64> = dx.as_slice()[..n].to_vec();
        let mut dps = Vec::new();
        for (&c, &p) in trim.coords.iter().zip(&trim.params) {
            dps.push((p, dq[c]));
            dq[c] = 0.0;
        }
        s.retract(&mut q, &dq, -1.0);
        for (k, l) in lambda.iter_mut().enumerate() {
            *l -= dx[n + k];
        }
        // a step to a value the model cannot take (a negative length, a non-finite
        // value: no trim, e.g. with a zero stiffness) ends the trim, as a failed trim
        let mut refused = false;
        for (p, d) in dps {
            let v = s.param(p) - d;
            refused |= !v.is_finite() || s.set_param(p, v).is_err();
        }
        if refused {
            break;
        }
    }
    Err(Failure::TrimFailed {
        params: names.join(", "),
        residual: last,
    }
    .into())
}
