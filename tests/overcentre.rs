//! The overcentre mechanism against independent truth: the shared reduced-order Lagrange
//! reference data, the project's own reduced-order Lagrange model (a second formulation),
//! the paper's hand-derived A and b, energy conservation, and a redundant constraint.

mod common;

use common::reduced::Overcentre;
use detune::dynamics::{DynWorkspace, constraint_rank};
use detune::{Model, SimOptions, State, System, Trajectory, assemble, simulate};
use nalgebra::{DMatrix, DVector};

fn load(sets: &[(&str, &str)]) -> (Model, System, State) {
    let model = common::overcentre(sets);
    let sys = System::new(&model).expect("compiles");
    let state = assemble(&sys).expect("assembles");
    (model, sys, state)
}

fn run(sys: &System, state: &State, opts: &SimOptions) -> Trajectory {
    simulate(sys, state, opts, &mut |_| true).expect("simulates")
}

fn reference(name: &str) -> Vec<(f64, f64)> {
    let (_, rows) = common::read_csv(format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR")));
    rows.iter().map(|r| (r[0], r[1])).collect()
}

/// Largest |θ1 − θ1_ref| over the reference samples.
fn max_error(traj: &Trajectory, reference: &[(f64, f64)]) -> f64 {
    let theta = traj.coordinate("bar1.theta").unwrap();
    assert_eq!(
        theta.len(),
        reference.len(),
        "one sample per reference time"
    );
    let mut worst: f64 = 0.0;
    for (k, (t, r)) in reference.iter().enumerate() {
        assert!((traj.t[k] - t).abs() < 1e-9);
        worst = worst.max((theta[k] - r).abs());
    }
    worst
}

fn check_reference(sets: &[(&str, &str)], file: &str) -> Trajectory {
    let (_, sys, state) = load(sets);
    let traj = run(&sys, &state, &SimOptions::default());
    let err = max_error(&traj, &reference(file));
    assert!(err <= 1e-8, "{file}: max |θ1 error| = {err:e} rad");
    assert!(
        traj.stats.max_constraint_residual <= 1e-10,
        "residual {:e}",
        traj.stats.max_constraint_residual
    );
    traj
}

#[test]
fn free_case_matches_lagrange_reference() {
    check_reference(&[], "lagrange_free.csv");
}

#[test]
fn forced3_matches_lagrange_reference() {
    check_reference(&[("F0", "3"), ("omega", "1.5")], "lagrange_forced3.csv");
}

#[test]
fn forced10_snaps_through_and_matches_lagrange_reference() {
    let traj = check_reference(&[("F0", "10"), ("omega", "1.5")], "lagrange_forced10.csv");
    let theta = traj.coordinate("bar1.theta").unwrap();
    // first crossing of the flat pose (a dead point of the transmission)
    let k = theta.iter().position(|&x| x < 0.0).expect("snaps through");
    let (t0, t1, a, b) = (traj.t[k - 1], traj.t[k], theta[k - 1], theta[k]);
    let crossing = t0 + (t1 - t0) * a / (a - b);
    assert!((crossing - 3.1268).abs() < 1e-3, "crossing at {crossing}");
    // settles in the lower well: stays below the flat pose for the last 10 s
    let late = traj.t.iter().position(|&t| t >= 10.0).unwrap();
    assert!(theta[late..].iter().all(|&x| x < 0.0));
}

/// Paper Eq. 10 (A) and Eq. 11 (b), written out by hand, at random states.
#[test]
fn jacobian_and_bias_equal_the_papers_hand_derivation() {
    let (model, sys, _) = load(&[("L2", "3.1"), ("L1", "2.3")]);
    let l1 = model.parameters.value("L1").unwrap();
    let l2 = model.parameters.value("L2").unwrap();
    let mut ws = DynWorkspace::new(&sys);
    let mut seed = 12345u64;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    };
    for _ in 0..50 {
        let q: Vec<f64> = (0..6).map(|_| 3.0 * rnd()).collect();
        let v: Vec<f64> = (0..6).map(|_| 5.0 * rnd()).collect();
        let (t1, t2) = (q[2], q[5]);
        let (w1, w2) = (v[2], v[5]);
        #[rustfmt::skip]
        let a_paper = DMatrix::from_row_slice(5, 6, &[
            1.0, 0.0, l1 / 2.0 * t1.sin(), 0.0, 0.0, 0.0,
            0.0, 1.0, -l1 / 2.0 * t1.cos(), 0.0, 0.0, 0.0,
            1.0, 0.0, -l1 / 2.0 * t1.sin(), -1.0, 0.0, l2 / 2.0 * t2.sin(),
            0.0, 1.0, l1 / 2.0 * t1.cos(), 0.0, -1.0, -l2 / 2.0 * t2.cos(),
            0.0, 0.0, 0.0, 0.0, 1.0, -l2 / 2.0 * t2.cos(),
        ]);
        let b_paper = DVector::from_row_slice(&[
            -l1 / 2.0 * w1 * w1 * t1.cos(),
            -l1 / 2.0 * w1 * w1 * t1.sin(),
            l1 / 2.0 * w1 * w1 * t1.cos() - l2 / 2.0 * w2 * w2 * t2.cos(),
            l1 / 2.0 * w1 * w1 * t1.sin() - l2 / 2.0 * w2 * w2 * t2.sin(),
            -l2 / 2.0 * w2 * w2 * t2.sin(),
        ]);
        let mut a = DMatrix::zeros(5, 6);
        let mut b = DVector::zeros(5);
        sys.jacobian(&mut ws.sys, &q, 0.0, &mut a);
        sys.bias(&mut ws.sys, &q, &v, 0.0, &mut b);
        assert!(
            (&a - &a_paper).amax() <= 1e-12,
            "A differs by {:e}",
            (&a - &a_paper).amax()
        );
        assert!(
            (&b - &b_paper).amax() <= 1e-12,
            "b differs by {:e}",
            (&b - &b_paper).amax()
        );
    }
}

/// Second formulation: the reduced-order Lagrange model in θ1 alone, on asymmetric
/// variants (unequal bars, spring offsets, force position, forcing).
#[test]
fn asymmetric_variants_match_reduced_lagrange_model() {
    let variants: &[&[(&str, f64)]] = &[
        &[
            ("L1", 2.0),
            ("L2", 3.0),
            ("m", 0.3),
            ("n", -0.2),
            ("s", 1.5),
            ("F0", 2.0),
            ("omega", 2.1),
            ("theta1_0", 0.6),
        ],
        &[
            ("L1", 2.5),
            ("L2", 3.2),
            ("m1", 1.7),
            ("m2", 0.6),
            ("m", -0.4),
            ("n", 0.5),
            ("s", 1.0),
            ("Fs", 1.0),
            ("c", 0.5),
            ("theta1_0", -0.5),
        ],
        &[
            ("L1", 1.5),
            ("L2", 2.0),
            ("k", 80.0),
            ("L0", 1.2),
            ("m", 0.2),
            ("n", 0.3),
            ("s", 0.7),
            ("Fs", -2.0),
            ("F0", 4.0),
            ("omega", 3.3),
            ("c", 1.0),
            ("theta1_0", 0.9),
        ],
    ];
    let times: Vec<f64> = (0..=2000).map(|k| k as f64 * 0.01).collect();
    for v in variants {
        let sets: Vec<(&str, String)> = v.iter().map(|(n, x)| (*n, format!("{x:?}"))).collect();
        let sets_ref: Vec<(&str, &str)> = sets.iter().map(|(n, x)| (*n, x.as_str())).collect();
        let (model, sys, state) = load(&sets_ref);
        let oracle = Overcentre::from_model(&model);
        let expected = oracle.simulate(
            model.parameters.value("theta1_0").unwrap(),
            &times,
            1e-12,
            1e-12,
        );
        let traj = run(&sys, &state, &SimOptions::default());
        let theta = traj.coordinate("bar1.theta").unwrap();
        let err = theta
            .iter()
            .zip(&expected)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err <= 1e-8, "variant {v:?}: max |θ1 error| = {err:e} rad");
    }
}

/// The slot constraint repeated as a custom expression: rank 5 of 6 rows, so every
/// right-hand side goes through the SVD pseudoinverse; the motion must not change.
#[test]
fn redundant_constraint_gives_the_same_motion() {
    let text = common::overcentre_text()
        + "\n[[constraints]]\nname = \"slot again\"\nexpr = \"bar2.y - L2/2*sin(bar2.theta)\"\n";
    let model = Model::from_str("redundant.toml", &text).unwrap();
    let sets = vec![
        ("F0".to_string(), "3".to_string()),
        ("omega".to_string(), "1.5".to_string()),
    ];
    let model = model.with_overrides(&sets).unwrap();
    let sys = System::new(&model).unwrap();
    assert_eq!(sys.m(), 6);
    let state = assemble(&sys).unwrap();
    assert_eq!(constraint_rank(&sys, &state.q, 0.0), 5);
    // The two paths differ by rounding only; projections (each a correction of up to the
    // projection tolerance) are kept below the comparison's 1e-12.
    let tight = SimOptions {
        projection_tol: 1e-14,
        ..SimOptions::default()
    };
    let redundant = run(&sys, &state, &tight);
    assert!(redundant.stats.svd_solves > 0);

    let (_, plain_sys, plain_state) = load(&[("F0", "3"), ("omega", "1.5")]);
    let plain = run(&plain_sys, &plain_state, &tight);
    assert_eq!(plain.stats.svd_solves, 0);
    let a = redundant.coordinate("bar1.theta").unwrap();
    let b = plain.coordinate("bar1.theta").unwrap();
    let diff = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(diff <= 1e-12, "redundant vs plain: {diff:e} rad");
}

/// c = 0 and no force: total energy is constant; constraint drift stays below 1e-10.
#[test]
fn energy_is_conserved_without_damping() {
    let (model, sys, state) = load(&[("c", "0")]);
    let traj = run(&sys, &state, &SimOptions::default());
    let energy = |k: usize| {
        sys.kinetic_energy(traj.q(k), traj.v(k)) + sys.potential_energy(traj.q(k), traj.t[k])
    };
    let e0 = energy(0);
    let drift = (0..traj.t.len())
        .map(|k| (energy(k) - e0).abs())
        .fold(0.0, f64::max);
    assert!(drift <= 1e-8, "energy drift {drift:e} J");
    assert!(traj.stats.max_constraint_residual <= 1e-10);
    // the same check with the reduced model's energy of (θ1, θ̇1): an independent formula
    let oracle = Overcentre::from_model(&model);
    let i = sys.coordinate_index("bar1.theta").unwrap();
    let e_ref = oracle.energy(traj.q(0)[i], traj.v(0)[i]);
    for k in 0..traj.t.len() {
        let e = oracle.energy(traj.q(k)[i], traj.v(k)[i]);
        assert!(
            (e - e_ref).abs() <= 1e-8,
            "reduced-model energy drifts by {:e} J at t = {}",
            e - e_ref,
            traj.t[k]
        );
    }
}
