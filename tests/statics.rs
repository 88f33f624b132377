//! Statics of the overcentre mechanism against the shared references: equilibria and
//! their stability, the S-curve by continuation with its folds, and a pitchfork.

mod common;

use common::{overcentre as model, reference};

use detune::statics::Statics;
use detune::statics::continuation::{ContinuationOptions, continue_equilibria};
use detune::{System, assemble};

const THETA1: usize = 2;

#[test]
fn default_start_lands_in_the_upper_well_and_minus_085_in_the_lower() {
    for (sets, want) in [
        (vec![], 36.9265879665f64),
        (vec![("theta1_0", "-0.85")], -49.6032000040),
    ] {
        let m = model(&sets);
        let sys = System::new(&m).unwrap();
        let s = assemble(&sys).unwrap();
        let e = Statics::new(&sys, &s.q).unwrap().solve(&s.q).unwrap();
        let got = e.q[THETA1].to_degrees();
        assert!((got - want).abs() <= 1e-9 * want.abs(), "{got} vs {want}");
        assert!(e.stable);
    }
}

#[test]
fn all_three_baseline_equilibria_with_stability() {
    let r = reference();
    let refs = r["baseline (gravity, L0 = 2)"]["equilibria"]
        .as_array()
        .unwrap();
    let m = model(&[]);
    let sys = System::new(&m).unwrap();
    let s = assemble(&sys).unwrap();
    let all = Statics::new(&sys, &s.q).unwrap().all(&s).unwrap();
    assert_eq!(
        all.len(),
        3,
        "{:?}",
        all.iter()
            .map(|e| e.q[THETA1].to_degrees())
            .collect::<Vec<_>>()
    );
    for (e, want) in all.iter().zip(refs) {
        let th = want["theta_rad"].as_f64().unwrap();
        assert!(
            (e.q[THETA1] - th).abs() <= 1e-9 * th.abs(),
            "{} vs {th}",
            e.q[THETA1]
        );
        assert_eq!(e.stable, want["stable"].as_bool().unwrap());
        let w2 = want["omega2"].as_f64().unwrap();
        assert!(
            (e.omega2[0] - w2).abs() <= 1e-8 * w2.abs(),
            "ω² {} vs {w2}",
            e.omega2[0]
        );
    }
}

fn s_curve_force(theta: f64) -> f64 {
    let (l, k, l0, g) = (2.0 * 2f64.sqrt(), 50.0, 2.0, 9.81);
    g * 2.0 / 2.0 - k * (l * theta.cos() - l0) * theta.tan()
}

#[test]
fn continuation_in_fs_traces_the_s_curve_and_finds_both_folds() {
    let m = model(&[]);
    let opts = ContinuationOptions {
        param: "Fs".into(),
        from: -10.0,
        to: 30.0,
        step: 0.5,
        max_steps: 2000,
    };
    let b = continue_equilibria(&System::new(&m).unwrap(), &opts).unwrap();
    assert!(!b.truncated);
    // every point satisfies the closed-form balance and the tabulated curve
    let (_, table) = common::read_csv(format!(
        "{}/tests/data/static_curve.csv",
        env!("CARGO_MANIFEST_DIR")
    ));
    for p in &b.points {
        let th = p.q[THETA1];
        let f = s_curve_force(th);
        assert!(
            (p.value - f).abs() <= 1e-9,
            "Fs {} vs closed form {f} at θ1 = {th}",
            p.value
        );
        // the tabulated reference (0.1° grid): linear interpolation error is small
        let deg = th.to_degrees();
        let k = table
            .iter()
            .position(|r| r[0] > deg)
            .unwrap_or_else(|| panic!("θ1 = {deg}° outside the table"));
        let (a, c) = (&table[k - 1], &table[k]);
        let fi = a[1] + (c[1] - a[1]) * (deg - a[0]) / (c[0] - a[0]);
        assert!(
            (p.value - fi).abs() <= 2e-3 * (1.0 + fi.abs()),
            "{} vs table {fi} at {deg}°",
            p.value
        );
        // stability: stable on the outer branches, unstable between the folds
        let fold = 27.0136024717f64.to_radians();
        assert_eq!(p.stable, th.abs() > fold, "stability at θ1 = {deg}°");
    }
    assert_eq!(b.points.first().unwrap().value, -10.0);
    assert_eq!(b.points.last().unwrap().value, 30.0);
    let r = reference();
    let folds = r["folds"].as_array().unwrap();
    assert_eq!(b.folds.len(), 2);
    for (f, want) in b.folds.iter().zip(folds) {
        let (fw, tw) = (
            want["F"].as_f64().unwrap(),
            want["theta_rad"].as_f64().unwrap(),
        );
        assert!(
            (f.value - fw).abs() <= 1e-8 * fw.abs(),
            "fold at {} vs {fw}",
            f.value
        );
        assert!(
            (f.q[THETA1] - tw).abs() <= 1e-8 * tw.abs(),
            "fold θ {} vs {tw}",
            f.q[THETA1]
        );
    }
    assert!(b.branch_points.is_empty());
}

#[test]
fn pitchfork_in_free_length_without_gravity() {
    let m = model(&[("g", "0"), ("theta1_0", "0")]);
    let opts = ContinuationOptions {
        param: "L0".into(),
        from: 2.5,
        to: 3.2,
        step: 0.05,
        max_steps: 500,
    };
    let b = continue_equilibria(&System::new(&m).unwrap(), &opts).unwrap();
    assert!(b.folds.is_empty());
    assert_eq!(b.branch_points.len(), 1);
    let bp = &b.branch_points[0];
    assert!(
        (bp.value - 2.0 * 2f64.sqrt()).abs() <= 1e-8 * 2.83,
        "branch point at {}",
        bp.value
    );
    for p in &b.points {
        assert!(p.q[THETA1].abs() < 1e-10);
        assert_eq!(p.stable, p.value > 2.0 * 2f64.sqrt(), "at L0 = {}", p.value);
    }
}

#[test]
fn pitchfork_side_branches_at_acos_of_free_length_over_diagonal() {
    // g = 0, Fs = 0: the balance k (L cos θ1 − L0) tan θ1 = 0 has θ1 = 0 and, for L0 < L,
    // θ1 = ±acos(L0/L) (L = 2√2), both stable, the middle one unstable.
    let l = 2.0 * 2f64.sqrt();
    for l0 in [2.0, 2.6] {
        let st_model = model(&[("g", "0"), ("L0", &l0.to_string())]);
        let sys = System::new(&st_model).unwrap();
        let s = assemble(&sys).unwrap();
        let all = Statics::new(&sys, &s.q).unwrap().all(&s).unwrap();
        let mut thetas: Vec<(f64, bool)> = all.iter().map(|e| (e.q[THETA1], e.stable)).collect();
        thetas.sort_by(|a, b| a.0.total_cmp(&b.0));
        let side = (l0 / l).acos();
        assert_eq!(thetas.len(), 3, "{thetas:?}");
        assert!(
            (thetas[0].0 + side).abs() < 1e-10 && thetas[0].1,
            "{thetas:?}"
        );
        assert!(thetas[1].0.abs() < 1e-10 && !thetas[1].1, "{thetas:?}");
        assert!(
            (thetas[2].0 - side).abs() < 1e-10 && thetas[2].1,
            "{thetas:?}"
        );
    }
}

#[test]
fn continuation_ends_exactly_on_the_range_and_never_leaves_it() {
    // A parameter that does not move the equilibrium (c): steps land on the end exactly.
    for (from, to) in [(1.0, 2.0), (2.0, 1.0)] {
        let opts = ContinuationOptions {
            param: "c".into(),
            from,
            to,
            step: 0.25,
            max_steps: 100,
        };
        let b = continue_equilibria(&System::new(&model(&[])).unwrap(), &opts).unwrap();
        let values: Vec<f64> = b.points.iter().map(|p| p.value).collect();
        assert_eq!(values.len(), 5, "{values:?}");
        assert_eq!(*values.last().unwrap(), to);
    }
    // A mass down to 0.01 kg: the model is invalid at m1 ≤ 0, just past the range, and
    // nothing (predictor, corrector, difference quotient) may evaluate it there.
    for (from, to) in [(1.0, 0.01), (1e-7, 1.0)] {
        let opts = ContinuationOptions {
            param: "m1".into(),
            from,
            to,
            step: (to - from).abs() / 50.0,
            max_steps: 1000,
        };
        let b = continue_equilibria(&System::new(&model(&[])).unwrap(), &opts).unwrap();
        let (lo, hi) = (from.min(to), from.max(to));
        assert!(b.points.iter().all(|p| p.value >= lo && p.value <= hi));
        assert_eq!(b.points.last().unwrap().value, to);
    }
}

#[test]
fn a_start_at_the_singular_pose_is_refused_not_answered_absurdly() {
    // θ1 = 90°: bar 2 folds onto bar 1 and A loses rank. Newton from there once returned
    // a pose with an angle of −1337 rad; it must say why it cannot start there instead.
    let m = model(&[("theta1_0", "1.5707963")]);
    let sys = System::new(&m).unwrap();
    let s = assemble(&sys).unwrap();
    let e = Statics::new(&sys, &s.q).unwrap().nearest(&s).unwrap_err();
    assert!(e.to_string().contains("singular pose"), "{e}");
    // A little away from it, the upper well.
    let m = model(&[("theta1_0", "1.5")]);
    let sys = System::new(&m).unwrap();
    let s = assemble(&sys).unwrap();
    let e = Statics::new(&sys, &s.q).unwrap().nearest(&s).unwrap();
    assert!((e.q[THETA1] - 36.9265879665f64.to_radians()).abs() < 1e-9);
}

/// Regression: continuing in L1 past 4 m, where bar 2's initial guess
/// asin(L1 sin θ1_0 / L2) is undefined, looped for ever in an SVD of the NaN guess (each
/// corrector step chose the constraint rows at the model's guess). The branch does not
/// depend on the guess: it must go on to the end of the range.
#[test]
fn continuation_goes_past_a_parameter_where_the_initial_guess_is_undefined() {
    let opts = ContinuationOptions {
        param: "L1".into(),
        from: 2.8,
        to: 4.2,
        step: 0.028,
        max_steps: 1000,
    };
    let b = continue_equilibria(&System::new(&model(&[])).unwrap(), &opts).unwrap();
    assert_eq!(b.points.last().unwrap().value, 4.2);
}
