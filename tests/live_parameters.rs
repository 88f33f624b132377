//! Live parameters: changing one on the compiled system equals compiling the model with
//! `--set`, parameters defined from it follow, a value the model cannot take is refused
//! without changing anything, and derivatives with respect to a parameter by automatic
//! differentiation equal differences.

mod common;

use common::overcentre as model;
use detune::System;
use detune::statics::Statics;

/// Φ, f and M at a few states.
fn fingerprint(sys: &System) -> Vec<f64> {
    let mut out = Vec::new();
    for k in 0..3 {
        let q: Vec<f64> = (0..sys.n()).map(|i| 0.3 + 0.17 * (i + k) as f64).collect();
        let v: Vec<f64> = (0..sys.n()).map(|i| 0.1 * i as f64 - 0.2).collect();
        out.extend(sys.residual(&q, 0.7).iter());
        let mut f = vec![0.0; sys.n()];
        sys.forces(&q, &v, 0.7, &mut f);
        out.extend(f);
    }
    out.extend(sys.mass_matrix.iter());
    out.extend(&sys.initial.q);
    out
}

#[test]
fn set_param_equals_compiling_with_set_and_derived_parameters_follow() {
    // s = L1 (the force's position) and the inertias, guesses and joints follow L1
    for (name, value) in [("L1", "2.5"), ("k", "80"), ("F0", "3"), ("omega", "1.5")] {
        let mut live = System::new(&model(&[])).unwrap();
        let i = live.param_index(name).unwrap();
        live.set_param(i, value.parse().unwrap()).unwrap();
        let compiled = System::new(&model(&[(name, value)])).unwrap();
        assert_eq!(
            fingerprint(&live),
            fingerprint(&compiled),
            "{name} = {value}"
        );
        assert_eq!(live.params(), compiled.params());
    }
    let mut sys = System::new(&model(&[])).unwrap();
    let (l1, s) = (
        sys.param_index("L1").unwrap(),
        sys.param_index("s").unwrap(),
    );
    sys.set_param(l1, 3.0).unwrap();
    assert_eq!(sys.param(s), 3.0);
    // a parameter set itself no longer follows its definition
    sys.set_param(s, 1.0).unwrap();
    sys.set_param(l1, 2.0).unwrap();
    assert_eq!(sys.param(s), 1.0);
}

#[test]
fn a_value_the_model_cannot_take_is_refused_and_changes_nothing() {
    let mut sys = System::new(&model(&[])).unwrap();
    let before = fingerprint(&sys);
    let m1 = sys.param_index("m1").unwrap();
    let e = sys.set_param(m1, -1.0).unwrap_err().to_string();
    assert!(
        e.contains("the mass of `bar1` must be positive, it is -1 kg"),
        "{e}"
    );
    assert!(e.contains("overcentre.toml:"), "located in the file: {e}");
    assert_eq!(fingerprint(&sys), before);
    let l0 = sys.param_index("L0").unwrap();
    let e = sys.set_param(l0, -0.5).unwrap_err().to_string();
    assert!(
        e.contains("the free length must be zero or positive"),
        "{e}"
    );
    let k = sys.param_index("k").unwrap();
    let e = sys.set_param(k, f64::NAN).unwrap_err().to_string();
    assert!(e.contains("the stiffness evaluates to NaN"), "{e}");
}

#[test]
fn parameter_derivative_of_the_equilibrium_equations_equals_differences() {
    // dH/dp by AD (duals seeded on p; hyper-duals for the reactions) against central
    // differences of recompiled systems, for parameters entering every kind of term
    let sys = System::new(&model(&[("Fs", "3"), ("F0", "2"), ("omega", "1.5")])).unwrap();
    let s = detune::assemble(&sys).unwrap();
    let st = Statics::new(&sys, &s.q).unwrap();
    let eq = st.solve(&s.q).unwrap();
    // a point off the equilibrium, with multipliers, so every term is non-zero
    let mut x: Vec<f64> = eq.q.iter().map(|q| q + 0.01).collect();
    x.extend(eq.lambda.iter().map(|l| l * 1.1 + 0.3));
    for name in ["L1", "L2", "m1", "k", "L0", "g", "s", "Fs", "F0", "omega"] {
        let i = sys.param_index(name).unwrap();
        let ad = st.residual_dp(&x, i);
        let p = sys.param(i);
        let h = 1e-5 * p.abs().max(1.0);
        let r = |v: f64| {
            let s2 = sys.with_param(i, v).unwrap();
            Statics::with_rows(&s2, st.rows.clone())
                .unwrap()
                .residual(&x)
        };
        let fd = (r(p + h) - r(p - h)) / (2.0 * h);
        let err = (&ad - &fd).amax();
        let size = ad.amax().max(1.0);
        // central differences: truncation ~ h² |H'''|, rounding ~ 1e-16 |H| / h
        assert!(
            err <= 1e-7 * size,
            "{name}: |AD − FD| = {err:e} (|AD| = {size:e})"
        );
    }
    // omega enters the loads only through ωt: their mean over a period does not depend on it
    let w = sys.param_index("omega").unwrap();
    assert!(st.residual_dp(&x, w).amax() <= 1e-12);
}
