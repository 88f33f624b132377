//! A steady state whose extrapolated restart cannot be integrated falls back to plain
//! iteration. The overcentre at F0 = 1 N, c = 2 N·s/m, ω = 3 rad/s: after three periods
//! (the Poincaré change still 9 % of the amplitude) minimal polynomial extrapolation
//! guesses a wild state that lies on the constraints (bar 1 wound to −12.8 rad, 15 rad/s)
//! and the run from it fails (the step size falls to zero 0.24 s in). The sweep stopped
//! there with "the step size fell to zero at t = 0.241058 s" though `simulate` runs
//! cleanly. Now the run from the guess is undone as a worse one is, plain iteration goes
//! on from the last integrated state, and the steady state is the one a long simulation
//! reaches: the truth it is checked against, within the sweep's settling tolerance.

mod common;
use common::{detune, read_csv};
use serde_json::Value;

/// `sweep models/overcentre.toml --set F0=1 --set c=2 --param omega --from 3 --to 3
/// --step 0.25 --response bar1.theta --json` with `extra`: bar1.theta's amplitude.
fn sweep_amplitude(extra: &[&str]) -> f64 {
    let mut args = vec![
        "sweep",
        "models/overcentre.toml",
        "--set",
        "F0=1",
        "--set",
        "c=2",
        "--param",
        "omega",
        "--from",
        "3",
        "--to",
        "3",
        "--step",
        "0.25",
        "--response",
        "bar1.theta",
        "--json",
    ];
    args.extend_from_slice(extra);
    let (code, out, err) = detune(&args);
    assert_eq!(code, 0, "{args:?} failed: {err}");
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["complete"], true);
    let p = &v["points"][0];
    assert_eq!(p["omega"], 3.0);
    assert_eq!(p["settled"], true, "{p}");
    assert_eq!(p["period_multiple"], 1);
    p["bar1.theta_amplitude"].as_f64().unwrap()
}

/// Half peak-to-peak of one period's samples, each extreme refined by the parabola
/// through it and its periodic neighbours (as the sweep measures it).
fn half_peak_to_peak(x: &[f64]) -> f64 {
    let n = x.len();
    let refine = |i: usize| {
        let (ym, y0, yp) = (x[(i + n - 1) % n], x[i], x[(i + 1) % n]);
        let d = ym - 2.0 * y0 + yp;
        if d == 0.0 {
            y0
        } else {
            y0 - 0.125 * (ym - yp) * (ym - yp) / d
        }
    };
    let imax = (0..n).max_by(|&a, &b| x[a].total_cmp(&x[b])).unwrap();
    let imin = (0..n).min_by(|&a, &b| x[a].total_cmp(&x[b])).unwrap();
    0.5 * (refine(imax) - refine(imin))
}

#[test]
fn a_failed_extrapolated_restart_falls_back_to_plain_iteration() {
    // The truth: 100 periods simulated continuously from the model's own initial pose
    // (bar 1 at 45°, not the sweep's equilibrium), 128 samples a period as the sweep's;
    // the last period's half peak-to-peak, every position's and bar 1's angle's.
    let period = std::f64::consts::TAU / 3.0;
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("sim.csv");
    let (t_end, dt) = (format!("{}", 100.0 * period), format!("{}", period / 128.0));
    let (code, _, err) = detune(&[
        "simulate",
        "models/overcentre.toml",
        "--set",
        "F0=1",
        "--set",
        "c=2",
        "--set",
        "omega=3",
        "--t-end",
        &t_end,
        "--dt-out",
        &dt,
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let (header, rows) = read_csv(&csv);
    assert_eq!(rows.len(), 100 * 128 + 1);
    let last = &rows[99 * 128..100 * 128];
    let amplitude = |name: &str| {
        let k = header.iter().position(|h| h == name).unwrap();
        half_peak_to_peak(&last.iter().map(|r| r[k]).collect::<Vec<_>>())
    };
    let truth = amplitude("bar1.theta");
    // the simulation has settled: the period before agrees to 1e-10 rad
    let before = &rows[98 * 128..99 * 128];
    let k = header.iter().position(|h| h == "bar1.theta").unwrap();
    let prev = half_peak_to_peak(&before.iter().map(|r| r[k]).collect::<Vec<_>>());
    assert!((prev - truth).abs() < 1e-10, "{prev} vs {truth}");
    // The sweep settles when Poincaré points agree to --settle-tol (1e-8) of each
    // component's amplitude plus the largest position amplitude (bar2.x's, 0.30 m):
    // the angle is known to 1e-8 × (0.12 + 0.30) rad.
    let largest = header[1..]
        .iter()
        .map(|h| amplitude(h))
        .fold(0.0f64, f64::max);
    let tol = 1e-8 * (truth + largest);
    for extra in [&[][..], &["--integrator", "radau"][..]] {
        let a = sweep_amplitude(extra);
        assert!(
            (a - truth).abs() <= tol,
            "{extra:?}: sweep amplitude {a} vs simulation {truth} (tolerance {tol:.2e})"
        );
    }
}
