//! Validation of the test oracle `common::reduced::Overcentre` (the hand-derived reduced-order
//! Lagrange model of the overcentre mechanism): it must reproduce the shared reference data,
//! conserve energy without damping or forcing, and its analytic θ1-derivatives must agree
//! with central finite differences.

mod common;

use common::reduced::{Kinematics, Overcentre, Point};

const RTOL: f64 = 1e-12;
const ATOL: f64 = 1e-12;

fn data_path(name: &str) -> String {
    format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// The reference samples (t, θ1) of one `lagrange_*.csv` file.
fn reference(name: &str) -> (Vec<f64>, Vec<f64>) {
    let (header, rows) = common::read_csv(data_path(name));
    assert_eq!(header, ["t", "theta1"], "{name}: columns");
    assert_eq!(rows.len(), 2001, "{name}: t = 0 … 20 s every 0.01 s");
    rows.iter().map(|r| (r[0], r[1])).unzip()
}

/// The baseline with the harmonic force F0 sin(ω t).
fn forced(f0: f64, omega: f64) -> Overcentre {
    Overcentre {
        f0,
        omega,
        ..Overcentre::baseline()
    }
}

/// Runs the oracle on a reference file's times and returns its θ1 and the max |error|.
fn check_reference(oracle: &Overcentre, name: &str) -> (Vec<f64>, f64) {
    let (times, theta_ref) = reference(name);
    assert_eq!(
        theta_ref[0],
        std::f64::consts::FRAC_PI_4,
        "{name}: starts at π/4"
    );
    let theta = oracle.simulate(std::f64::consts::FRAC_PI_4, &times, RTOL, ATOL);
    let err = theta
        .iter()
        .zip(&theta_ref)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    eprintln!("{name}: max |θ1 − θ1_ref| = {err:.3e} rad");
    assert!(err <= 1e-8, "{name}: max |θ1 error| = {err:e} rad");
    (theta, err)
}

#[test]
fn free_case_matches_reference() {
    check_reference(&Overcentre::baseline(), "lagrange_free.csv");
}

#[test]
fn forced_3n_case_matches_reference() {
    check_reference(&forced(3.0, 1.5), "lagrange_forced3.csv");
}

/// 10 N at 1.5 rad/s drives the mechanism over centre: θ1 first crosses 0 near
/// t = 3.1268 s and the run ends on the other side (θ1 < 0).
#[test]
fn forced_10n_case_matches_reference_and_snaps_through() {
    let oracle = forced(10.0, 1.5);
    let (theta, _) = check_reference(&oracle, "lagrange_forced10.csv");
    let (times, theta_ref) = reference("lagrange_forced10.csv");
    assert!(
        *theta.last().unwrap() < 0.0 && *theta_ref.last().unwrap() < 0.0,
        "ends below 0"
    );

    // first sign change on the grid, then Newton on the oracle's own trajectory
    let k = theta
        .windows(2)
        .position(|w| w[0] > 0.0 && w[1] <= 0.0)
        .expect("θ1 crosses 0");
    assert!(
        theta_ref[k] > 0.0 && theta_ref[k + 1] <= 0.0,
        "the reference crosses in the same interval"
    );
    let mut t = times[k];
    for _ in 0..4 {
        let (th, th_dot) =
            oracle.simulate_with_rate(std::f64::consts::FRAC_PI_4, 0.0, &[t], RTOL, ATOL)[0];
        t -= th / th_dot;
    }
    let th = oracle.simulate(std::f64::consts::FRAC_PI_4, &[t], RTOL, ATOL)[0];
    eprintln!("forced10: θ1 = 0 at t = {t:.9} s (residual {th:.1e} rad)");
    assert!(th.abs() <= 1e-10);
    assert!((times[k]..=times[k + 1]).contains(&t));
    assert!(
        (t - 3.1268).abs() <= 5e-5,
        "crossing at {t} s (3.1268 to 4 decimals)"
    );
}

/// c = 0 and no force: T + V_gravity + V_spring stays constant over 20 s.
#[test]
fn energy_is_conserved_without_damping_or_forcing() {
    for theta0 in [std::f64::consts::FRAC_PI_4, 0.3, -0.7] {
        let oracle = Overcentre {
            c: 0.0,
            ..Overcentre::baseline()
        };
        let times: Vec<f64> = (0..=2000).map(|k| k as f64 * 0.01).collect();
        let traj = oracle.simulate_with_rate(theta0, 0.0, &times, RTOL, ATOL);
        let e0 = oracle.energy(theta0, 0.0);
        let drift = traj
            .iter()
            .map(|&(th, v)| (oracle.energy(th, v) - e0).abs())
            .fold(0.0, f64::max);
        let swing = traj.iter().map(|&(_, v)| v.abs()).fold(0.0, f64::max);
        eprintln!(
            "θ1(0) = {theta0}: energy {e0:.6} J, max drift {drift:.3e} J, max |θ̇1| {swing:.3} rad/s"
        );
        assert!(swing > 0.1, "the mechanism moves");
        assert!(
            drift <= 1e-9,
            "energy drift {drift:e} J from θ1(0) = {theta0}"
        );
    }
}

/// The baseline pose θ1 = π/4: J = (2, 2), B = (4, 0), θ2 = 3π/4, spring unstretched (d = L0).
#[test]
fn baseline_geometry() {
    let o = Overcentre::baseline();
    let k = o.kinematics(std::f64::consts::FRAC_PI_4);
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-14;
    assert!(close(k.theta2, 3.0 * std::f64::consts::FRAC_PI_4));
    assert!(close(k.g1.p[0], 1.0) && close(k.g1.p[1], 1.0));
    assert!(close(k.g2.p[0], 3.0) && close(k.g2.p[1], 1.0));
    assert!(close(k.d, 2.0));
    // B = J − L2 e2 lies on the ground to the right of A
    let b = [2.0 * k.g2.p[0] - 2.0, 2.0 * k.g2.p[1] - 2.0];
    assert!(close(b[0], 4.0) && close(b[1], 0.0));
    // L1 = L2 = L, m1 = m2 = 1, |θ1| < π/2: θ2' = −1, G2' = (−3L/2 sin θ1, L/2 cos θ1), so
    // M = L²/3 + L²(1/4 + 2 sin²θ1) + L²/12 = L² (2/3 + 2 sin²θ1)
    let l2 = o.l1 * o.l1;
    for th in [-1.2, -0.4, 0.0, std::f64::consts::FRAC_PI_4, 1.3] {
        let expected = l2 * (2.0 / 3.0 + 2.0 * th.sin().powi(2));
        assert!((o.mass(th) - expected).abs() <= 1e-12 * expected, "M({th})");
    }
}

/// The static balance agrees with the tabulated S-curve `static_curve.csv` (θ1 in degrees,
/// F = the static force Fs holding the mechanism there).
#[test]
fn static_force_matches_tabulated_curve() {
    let (header, rows) = common::read_csv(data_path("static_curve.csv"));
    assert_eq!(header[..2], ["theta1_deg", "F"]);
    let o = Overcentre::baseline();
    let mut worst: f64 = 0.0;
    for r in &rows {
        let f = o.static_force(r[0].to_radians());
        worst = worst.max((f - r[1]).abs() / (1.0 + r[1].abs()));
        let balanced = Overcentre { fs: f, ..o.clone() };
        assert!(balanced.static_residual(r[0].to_radians()).abs() <= 1e-9 * (1.0 + f.abs()));
    }
    eprintln!("static curve: max relative |Fs − F_table| = {worst:.3e}");
    assert!(worst <= 1e-9, "static force vs table: {worst:e}");
}

/// An asymmetric variant: unequal bars, spring offsets, force inside bar 1.
fn asymmetric() -> Overcentre {
    Overcentre {
        l1: 2.0,
        l2: 3.0,
        m: 0.3,
        n: -0.2,
        s: 1.5,
        m1: 1.3,
        m2: 0.7,
        ..Overcentre::baseline()
    }
}

/// Picks one tracked point out of the kinematics.
type PointOf = fn(&Kinematics) -> Point;

/// Central difference of f at θ with step h.
fn central(f: impl Fn(f64) -> f64, theta: f64, h: f64) -> f64 {
    (f(theta + h) - f(theta - h)) / (2.0 * h)
}

fn assert_close(what: &str, theta: f64, analytic: f64, numeric: f64, worst: &mut f64) {
    let err = (analytic - numeric).abs() / (1.0 + analytic.abs());
    *worst = worst.max(err);
    assert!(
        err <= 1e-8,
        "{what} at θ1 = {theta}: analytic {analytic}, finite difference {numeric}"
    );
}

/// Analytic first and second θ1-derivatives of θ2, the CGs, the spring points, the force
/// point, d, M against central differences; the generalized forces against −dV/dθ1.
#[test]
fn analytic_derivatives_match_finite_differences() {
    let o = asymmetric();
    let h = 1e-5;
    let mut worst: f64 = 0.0;
    for i in -12..=12 {
        let theta = 0.11 * i as f64 + 0.013; // |θ1| ≤ 1.33, |L1 sin θ1| < L2
        let k = o.kinematics(theta);
        let kin = |t: f64| o.kinematics(t);

        // θ2 itself: sin θ2 = L1 sin θ1 / L2 and B on the ground to the right of A
        assert!((k.theta2.sin() - o.l1 * theta.sin() / o.l2).abs() <= 1e-14);
        let bx = o.l1 * theta.cos() - o.l2 * k.theta2.cos();
        assert!(bx > 0.0);

        let t2 = |t: f64| kin(t).theta2;
        let t2d = |t: f64| kin(t).theta2_d1;
        assert_close("θ2'", theta, k.theta2_d1, central(t2, theta, h), &mut worst);
        assert_close(
            "θ2''",
            theta,
            k.theta2_d2,
            central(t2d, theta, h),
            &mut worst,
        );

        let points: [(&str, PointOf); 5] = [
            ("G1", |k| k.g1),
            ("G2", |k| k.g2),
            ("P1", |k| k.p1),
            ("P2", |k| k.p2),
            ("A + s e1", |k| k.force_point),
        ];
        for (name, pick) in points {
            for axis in 0..2 {
                let p = pick(&k);
                let pos = |t: f64| pick(&kin(t)).p[axis];
                let vel = |t: f64| pick(&kin(t)).d1[axis];
                assert_close(
                    &format!("{name}'[{axis}]"),
                    theta,
                    p.d1[axis],
                    central(pos, theta, h),
                    &mut worst,
                );
                assert_close(
                    &format!("{name}''[{axis}]"),
                    theta,
                    p.d2[axis],
                    central(vel, theta, h),
                    &mut worst,
                );
            }
        }
        // the points sit where they should along the bars
        let e1 = [theta.cos(), theta.sin()];
        let e2 = [k.theta2.cos(), k.theta2.sin()];
        for axis in 0..2 {
            assert!((k.p1.p[axis] - (k.g1.p[axis] + o.m * e1[axis])).abs() <= 1e-14);
            assert!((k.p2.p[axis] - (k.g2.p[axis] + o.n * e2[axis])).abs() <= 1e-14);
            assert!((k.force_point.p[axis] - o.s * e1[axis]).abs() <= 1e-14);
            let j = o.l1 * e1[axis];
            assert!((k.g2.p[axis] - (j - o.l2 / 2.0 * e2[axis])).abs() <= 1e-14);
        }

        assert_close(
            "d'",
            theta,
            k.d_d1,
            central(|t| kin(t).d, theta, h),
            &mut worst,
        );
        assert_close(
            "d''",
            theta,
            k.d_d2,
            central(|t| kin(t).d_d1, theta, h),
            &mut worst,
        );
        assert_close(
            "M'",
            theta,
            o.mass_slope(theta),
            central(|t| o.mass(t), theta, h),
            &mut worst,
        );

        // conservative generalized forces are −dV/dθ1
        let v_grav = |t: f64| {
            let k = kin(t);
            o.g * (o.m1 * k.g1.p[1] + o.m2 * k.g2.p[1])
        };
        assert_close(
            "Q_gravity",
            theta,
            o.gravity_force(theta),
            -central(v_grav, theta, h),
            &mut worst,
        );
        let springy = Overcentre {
            g: 0.0,
            c: 0.0,
            fs: 0.0,
            f0: 0.0,
            ..o.clone()
        };
        let q_spring = springy.generalized_force(theta, 0.0, 0.0);
        assert_close(
            "Q_spring",
            theta,
            q_spring,
            -central(|t| springy.potential_energy(t), theta, h),
            &mut worst,
        );
        // the dashpot: −c ḋ d' = −c d'² θ̇
        let damped = Overcentre {
            g: 0.0,
            k: 0.0,
            fs: 0.0,
            f0: 0.0,
            ..o.clone()
        };
        let q_damp = damped.generalized_force(theta, 0.7, 0.0);
        assert!((q_damp + o.c * k.d_d1 * k.d_d1 * 0.7).abs() <= 1e-12);
        // the applied force: F times the virtual vertical displacement of its point
        let pushed = Overcentre {
            g: 0.0,
            k: 0.0,
            c: 0.0,
            fs: 2.0,
            f0: 0.0,
            ..o.clone()
        };
        let q_force = pushed.generalized_force(theta, 0.0, 0.0);
        let y_force = |t: f64| kin(t).force_point.p[1];
        assert_close(
            "Q_force",
            theta,
            q_force,
            2.0 * central(y_force, theta, h),
            &mut worst,
        );
    }
    eprintln!("analytic vs central differences: max relative error {worst:.3e}");
}

/// The equation of motion is Lagrange's: with c = 0 and F = 0,
/// d/dt(∂L/∂θ̇) − ∂L/∂θ = M θ̈ + ½ M' θ̇² + dV/dθ = 0 at every (θ, θ̇), checked by
/// differencing the Lagrangian L = ½ M θ̇² − V along a short trajectory piece.
#[test]
fn acceleration_satisfies_lagrange_equation_for_asymmetric_variant() {
    let o = Overcentre {
        c: 0.0,
        ..asymmetric()
    };
    let h = 1e-5;
    for (theta, theta_dot) in [(0.4, 0.0), (0.9, -1.3), (-0.6, 2.2)] {
        let acc = o.acceleration(theta, theta_dot, 0.0);
        // ∂L/∂θ = ½ M'(θ) θ̇² − dV/dθ by differences of M and V
        let dl_dtheta = 0.5 * central(|t| o.mass(t), theta, h) * theta_dot * theta_dot
            - central(|t| o.potential_energy(t), theta, h);
        // d/dt(M θ̇) = M' θ̇² + M θ̈
        let ddt_p = central(|t| o.mass(t), theta, h) * theta_dot * theta_dot + o.mass(theta) * acc;
        let residual = ddt_p - dl_dtheta;
        assert!(
            residual.abs() <= 1e-7 * (1.0 + dl_dtheta.abs()),
            "Lagrange residual {residual:e} at θ1 = {theta}"
        );
    }
    // and along an integrated trajectory the energy is constant for this variant too
    let times: Vec<f64> = (0..=500).map(|k| k as f64 * 0.02).collect();
    let traj = o.simulate_with_rate(0.6, 0.0, &times, RTOL, ATOL);
    let e0 = o.energy(0.6, 0.0);
    let drift = traj
        .iter()
        .map(|&(th, v)| (o.energy(th, v) - e0).abs())
        .fold(0.0, f64::max);
    eprintln!("asymmetric variant, 10 s: energy drift {drift:.3e} J");
    assert!(drift <= 1e-9, "energy drift {drift:e} J");
}

/// With damping and forcing the energy balance holds:
/// E(t) − E(0) = ∫ (F(τ) s cos θ1 − c d'² θ̇1) θ̇1 dτ, accumulated with the trapezoid rule on
/// a fine grid.
#[test]
fn power_balance_with_damping_and_forcing() {
    let o = Overcentre {
        fs: 0.5,
        f0: 3.0,
        omega: 1.5,
        ..asymmetric()
    };
    let dt = 1e-4;
    let times: Vec<f64> = (0..=20_000).map(|k| k as f64 * dt).collect();
    let traj = o.simulate_with_rate(0.6, 0.0, &times, RTOL, ATOL);
    let power = |t: f64, th: f64, v: f64| {
        let k = o.kinematics(th);
        (o.force(t) * k.force_point.d1[1] - o.c * k.d_d1 * k.d_d1 * v) * v
    };
    let mut work = 0.0;
    let mut worst: f64 = 0.0;
    let e0 = o.energy(0.6, 0.0);
    for i in 1..times.len() {
        let (a, b) = (traj[i - 1], traj[i]);
        work += 0.5 * dt * (power(times[i - 1], a.0, a.1) + power(times[i], b.0, b.1));
        worst = worst.max((o.energy(b.0, b.1) - e0 - work).abs());
    }
    eprintln!("power balance over 2 s: max |ΔE − W| = {worst:.3e} J");
    assert!(worst <= 1e-6, "energy balance off by {worst:e} J");
}

#[test]
fn simulate_handles_trivial_time_lists() {
    let o = Overcentre::baseline();
    assert!(o.simulate(0.5, &[], RTOL, ATOL).is_empty());
    assert_eq!(o.simulate(0.5, &[0.0], RTOL, ATOL), vec![0.5]);
    let out = o.simulate_with_rate(0.5, 0.1, &[0.0, 0.25], RTOL, ATOL);
    assert_eq!(out[0], (0.5, 0.1));
    assert_ne!(out[1].0, 0.5);
}
