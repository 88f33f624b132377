//! Continuation through a branch point: the branches that cross it are followed too
//! (the overcentre's pitchfork in the spring's free length without gravity), the summary
//! of a run that turns back at a fold, and a start without an equilibrium.

mod common;

use common::overcentre as model;

use detune::System;
use detune::statics::continuation::{ContinuationOptions, continue_equilibria};

const THETA1: usize = 2;

#[test]
fn pitchfork_continuation_returns_three_branches_with_the_side_ones_at_acos_l0_over_l() {
    // g = 0, Fs = 0: k (L cos θ1 − L0) tan θ1 = 0, so θ1 = 0 for every L0 and, for
    // L0 < L, θ1 = ±acos(L0/L) (L = L1 = L2 = 2√2); the branch point is L0 = L.
    let l = 2.0 * 2f64.sqrt();
    let m = model(&[("g", "0"), ("theta1_0", "0")]);
    let opts = ContinuationOptions {
        param: "L0".into(),
        from: 2.5,
        to: 3.2,
        step: 0.05,
        max_steps: 500,
    };
    let b = continue_equilibria(&System::new(&m).unwrap(), &opts).unwrap();
    assert_eq!(b.branch_points.len(), 1);
    assert!((b.branch_points[0].value - l).abs() <= 1e-8 * l);
    // the trivial branch: θ1 = 0, unstable below L, stable above
    assert!(b.points.iter().all(|p| p.q[THETA1].abs() < 1e-10));
    assert!(b.points.iter().any(|p| p.stable) && b.points.iter().any(|p| !p.stable));
    for p in &b.points {
        assert_eq!(p.stable, p.value > l, "trivial branch at L0 = {}", p.value);
    }
    // two side branches, one per side of the branch point
    assert_eq!(b.switched.len(), 2, "three branches in all");
    let mut signs = Vec::new();
    for s in &b.switched {
        assert_eq!(s.branch_point, 0);
        assert!(!s.truncated && s.folds.is_empty());
        assert!(s.points.len() > 5, "{} points", s.points.len());
        let sign = s.points[0].q[THETA1].signum();
        signs.push(sign);
        for p in &s.points {
            let want = sign * (p.value / l).acos();
            assert!(
                (p.q[THETA1] - want).abs() <= 1e-10,
                "θ1 = {} vs ±acos(L0/L) = {want} at L0 = {}",
                p.q[THETA1],
                p.value
            );
            assert!(p.value < l && p.stable, "at L0 = {}", p.value);
        }
        // followed to the end of the range
        assert_eq!(s.points.last().unwrap().value, 2.5);
    }
    signs.sort_by(f64::total_cmp);
    assert_eq!(signs, [-1.0, 1.0]);
}
