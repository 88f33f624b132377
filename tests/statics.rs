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
    let b = continue_equilibria(&m, &opts).unwrap();
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
    assert!((b.points.last().unwrap().value - 30.0).abs() < 1e-9);
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
            (f.q[THETA1] - tw).abs() <= 1e-6 * tw.abs(),
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
    let b = continue_equilibria(&m, &opts).unwrap();
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
