//! Snap-through and well changes are results (issue 10, point 1): the F0 = 10 N sweep of
//! the overcentre from its upper well snaps into the lower well below 4 rad/s; every
//! steady state is classified by its well (against the equilibria of the closed form),
//! no peak joins two wells, the plot has one series per well; jumps of up/down sweeps
//! are reported as jumps, not peaks.

use serde_json::Value;
mod common;
use common::detune;

/// The overcentre's equilibria in closed form: both bars of length L, the spring between
/// the centres of mass (length L cos θ), both centres at height L/2 sin θ, so
/// V(θ) = (m1 + m2) g L/2 sin θ + ½ k (L cos θ − L0)² and V′(θ) = 0 is
/// (m1 + m2) g L/2 cos θ − k (L cos θ − L0) L sin θ = 0, solved by bisection on a fine
/// grid over (−π/2, π/2). Returns (θ, stable = V″ > 0).
fn closed_form_equilibria() -> Vec<(f64, bool)> {
    let (l, g, k, l0) = (2.0 * 2f64.sqrt(), 9.81, 50.0, 2.0);
    let dv = |t: f64| 2.0 * g * l / 2.0 * t.cos() - k * (l * t.cos() - l0) * l * t.sin();
    let mut out = Vec::new();
    let n = 2000;
    let h = 3.1 / n as f64;
    for i in 0..n {
        let (mut a, mut b) = (-1.55 + i as f64 * h, -1.55 + (i + 1) as f64 * h);
        if dv(a) * dv(b) > 0.0 {
            continue;
        }
        for _ in 0..100 {
            let m = 0.5 * (a + b);
            if dv(a) * dv(m) <= 0.0 {
                b = m;
            } else {
                a = m;
            }
        }
        let t = 0.5 * (a + b);
        let stable = (dv(t + 1e-6) - dv(t - 1e-6)) > 0.0;
        out.push((t, stable));
    }
    out
}

#[test]
fn snap_through_is_reported_by_well() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("snap.csv");
    let svg = dir.path().join("snap.svg");
    let common = [
        "sweep",
        "models/overcentre.toml",
        "--set",
        "F0=10",
        "--param",
        "omega",
        "--from",
        "0.5",
        "--to",
        "6",
        "--step",
        "0.25",
        "--response",
        "bar1.theta",
    ];
    let mut args = common.to_vec();
    args.extend(["-o", csv.to_str().unwrap(), "--plot", svg.to_str().unwrap()]);
    let (code, out, err) = detune(&args);
    assert_eq!(code, 0, "{err}");

    // the equilibria listed are the closed form's, with its stability
    let truth = closed_form_equilibria();
    assert_eq!(truth.len(), 3, "{truth:?}");
    let mut json_args = common.to_vec();
    json_args.push("--json");
    let (code, json, err) = detune(&json_args);
    assert_eq!(code, 0, "{err}");
    let j: Value = serde_json::from_str(&json).unwrap();
    let eqs = j["equilibria"].as_array().unwrap();
    assert_eq!(eqs.len(), 3);
    let index_of = |theta: f64| -> i64 {
        let e = eqs
            .iter()
            .find(|e| (e["coordinates"]["bar1.theta"].as_f64().unwrap() - theta).abs() < 1e-8)
            .unwrap_or_else(|| panic!("no equilibrium at θ1 = {theta}: {eqs:?}"));
        e["index"].as_i64().unwrap()
    };
    for (t, stable) in &truth {
        let e = &eqs[index_of(*t) as usize];
        assert_eq!(e["stable"].as_bool().unwrap(), *stable, "θ1 = {t}");
        // and dynamically (as `equilibrium --json`): with the damper's c > 0 no mode of a
        // minimum grows, and the saddle's divergence does
        assert_eq!(e["dynamically_stable"].as_bool(), Some(*stable), "θ1 = {t}");
    }
    let upper = index_of(truth[2].0); // θ1 ≈ +0.644 rad
    let lower = index_of(truth[0].0); // θ1 ≈ −0.866 rad
    assert!(truth[2].0 > 0.6 && truth[0].0 < -0.8);
    assert!(eqs[upper as usize]["start"].as_bool().unwrap());

    // the well column: the lower well up to 4 rad/s, the upper one from 4.25 rad/s
    // (the direction column is text: parse by hand)
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .map(|f| f.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (w, well, mean) = (col("omega"), col("well"), col("bar1.theta_mean"));
    assert_eq!(header.last().unwrap(), "well");
    assert_eq!(rows.len(), 23);
    for r in &rows {
        let expected = if r[w] <= 4.0 { lower } else { upper };
        assert_eq!(r[well] as i64, expected, "ω = {}", r[w]);
        // and the mean pose lies in that well (a second check, by θ1 alone)
        let nearest = truth
            .iter()
            .min_by(|a, b| (a.0 - r[mean]).abs().total_cmp(&(b.0 - r[mean]).abs()))
            .unwrap();
        assert_eq!(index_of(nearest.0), expected, "ω = {}", r[w]);
    }

    // the summary says so, with units
    assert!(
        out.contains(&format!(
            "the response left its starting well (well {upper}: bar1.theta = 0.644 rad) at 15 of 23 frequencies (independent): 0.5–4 rad/s in well {lower} (bar1.theta = -0.866 rad)"
        )),
        "{out}"
    );

    // no peak joins the two wells: the grid maximum (4 rad/s, next to 4.25 in the other
    // well) is not reported, and any peak's neighbours share its well
    assert!(!out.contains("peak"), "{out}");
    for p in j["peaks"].as_array().unwrap() {
        let om = p["omega"].as_f64().unwrap();
        let near: Vec<i64> = j["points"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|q| (q["omega"].as_f64().unwrap() - om).abs() <= 0.25 + 1e-9)
            .map(|q| q["well"].as_i64().unwrap())
            .collect();
        assert!(near.windows(2).all(|x| x[0] == x[1]), "{p}");
    }
    assert_eq!(j["jumps"].as_array().unwrap().len(), 0); // independent: no jumps

    // the plot: one series per well, each named in the legend, not joined
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains(&format!("well {lower} (bar1.theta = -0.866 rad)")));
    assert!(text.contains(&format!("well {upper} (bar1.theta = 0.644 rad)")));
    assert!(
        text.contains(&format!("(well {upper})")),
        "ω_n named by its well"
    );
}

#[test]
fn up_and_down_jumps_are_jumps_not_peaks() {
    // F0 = 3 N: the upper well's softening resonance folds; the up sweep jumps up onto the
    // resonant branch, the down sweep falls off it, and between them up and down differ
    let (code, out, err) = detune(&[
        "sweep",
        "models/overcentre.toml",
        "--set",
        "F0=3",
        "--param",
        "omega",
        "--from",
        "1.8",
        "--to",
        "3",
        "--step",
        "0.1",
        "--response",
        "bar1.theta",
        "--mode",
        "both",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let j: Value = serde_json::from_str(&out).unwrap();
    let jumps = j["jumps"].as_array().unwrap();
    assert_eq!(jumps.len(), 2, "{jumps:?}");
    for jp in jumps {
        let keys: Vec<&str> = jp.as_object().unwrap().keys().map(|k| k.as_str()).collect();
        assert_eq!(
            keys,
            [
                "response",
                "direction",
                "from",
                "to",
                "amplitude_before",
                "amplitude_after"
            ]
        );
    }
    let (up, down) = (&jumps[0], &jumps[1]);
    assert_eq!(up["direction"], "up");
    assert_eq!(down["direction"], "down");
    // the jumps bound the interval where the two sweeps differ (found independently, by
    // comparing them point by point)
    let h = &j["hysteresis"].as_array().unwrap()[0];
    let (h0, h1) = (h["from"].as_f64().unwrap(), h["to"].as_f64().unwrap());
    assert!((up["from"].as_f64().unwrap() - h1).abs() < 1e-9, "{up} {h}");
    assert!((up["to"].as_f64().unwrap() - (h1 + 0.1)).abs() < 1e-9);
    assert!(
        (down["from"].as_f64().unwrap() - h0).abs() < 1e-9,
        "{down} {h}"
    );
    assert!((down["to"].as_f64().unwrap() - (h0 - 0.1)).abs() < 1e-9);
    // up jumps up, down falls down; each lands on the other sweep's amplitude there
    let amp = |dir: &str, w: f64| {
        j["points"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["direction"] == dir && (p["omega"].as_f64().unwrap() - w).abs() < 1e-9)
            .unwrap()["bar1.theta_amplitude"]
            .as_f64()
            .unwrap()
    };
    let (ub, ua) = (
        up["amplitude_before"].as_f64().unwrap(),
        up["amplitude_after"].as_f64().unwrap(),
    );
    assert!(ua > 1.2 * ub);
    assert!((ua - amp("down", h1 + 0.1)).abs() < 1e-6 * ua);
    let (db, da) = (
        down["amplitude_before"].as_f64().unwrap(),
        down["amplitude_after"].as_f64().unwrap(),
    );
    assert!(db > 1.5 * da);
    assert!((da - amp("up", h0 - 0.1)).abs() < 1e-6 * da);
    // no peak at a jump edge: the up sweep's largest grid amplitude is right after its jump
    for p in j["peaks"].as_array().unwrap() {
        let om = p["omega"].as_f64().unwrap();
        for jp in jumps {
            let (a, b) = (jp["from"].as_f64().unwrap(), jp["to"].as_f64().unwrap());
            assert!(
                (om - a).abs() > 1e-9 && (om - b).abs() > 1e-9,
                "peak {p} on jump {jp}"
            );
        }
    }
}

#[test]
fn simulate_reports_the_well_it_ends_in() {
    // F0 = 10 N at 3 rad/s snaps through (tests/overcentre.rs pins the motion against the
    // Lagrange reference): the last period oscillates about the lower stable pose
    let dir = tempfile::tempdir().unwrap();
    let (csv, json) = (dir.path().join("s.csv"), dir.path().join("s.json"));
    let truth = closed_form_equilibria();
    for (sets, theta, text) in [
        (
            vec!["--set", "F0=10", "--set", "omega=3", "--t-end", "40"],
            truth[0].0,
            "oscillates about the stable equilibrium (bar1.theta = -0.866 rad",
        ),
        (
            vec!["--t-end", "2"],
            truth[2].0,
            "the final pose is nearest to the stable equilibrium (bar1.theta = 0.644 rad",
        ),
    ] {
        let mut args = vec!["simulate", "models/overcentre.toml"];
        args.extend(sets);
        args.extend([
            "-o",
            csv.to_str().unwrap(),
            "--json",
            json.to_str().unwrap(),
        ]);
        let (code, out, err) = detune(&args);
        assert_eq!(code, 0, "{err}");
        assert!(out.contains(text), "{out}");
        let j: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let k = j["well"].as_i64().unwrap() as usize;
        let e = &j["equilibria"][k];
        assert!((e["coordinates"]["bar1.theta"].as_f64().unwrap() - theta).abs() < 1e-8);
        assert_eq!(e["stable"], true);
    }
}

/// The rule "−1 for an orbit that spans two wells", on the overcentre's wells (its
/// equilibria, stable at θ1 ≈ −0.866 and +0.644 rad, a saddle between): an orbit that
/// spends half its samples at each stable pose spans them (−1); one that stays at the
/// lower pose with a fifth of its samples (below the quarter of the rule) at the upper
/// one is in the lower well; one that visits the saddle on the rim (not a well) is too,
/// unless its mean is nearest the saddle.
/// The orbit's samples are equilibrium poses, exact configurations of the mechanism.
#[test]
fn an_orbit_over_both_wells_spans_them() {
    use detune::frequency::wells::{SPAN_FRACTION, SPANS, Wells};
    let model = detune::Model::load("models/overcentre.toml").unwrap();
    let sys = detune::System::new(&model).unwrap();
    let rest = detune::dynamics::assemble_at_rest(&sys).unwrap();
    let start = detune::statics::Statics::new(&sys, &rest.q)
        .unwrap()
        .nearest(&rest)
        .unwrap();
    let wells = Wells::find(&sys, &start);
    let truth = closed_form_equilibria();
    let pose = |theta: f64| -> (usize, Vec<f64>) {
        let k = wells
            .equilibria
            .iter()
            .position(|e| (e.q[2] - theta).abs() < 1e-8)
            .unwrap_or_else(|| panic!("no equilibrium at θ1 = {theta}"));
        (k, wells.equilibria[k].q.clone())
    };
    let (lower, ql) = pose(truth[0].0);
    let (_, qs) = pose(truth[1].0);
    let (upper, qu) = pose(truth[2].0);
    assert!(!truth[1].1 && truth[0].1 && truth[2].1);
    // the other pose in the lower pose's turn (each angle within π of it), as a
    // continuous orbit carries it: `equilibrium --all` shows each pose with its angles in
    // (−π, π], where the lower well's bar2.theta is −2.28 rad and the saddle's 2.88
    let angles = sys.angles();
    let orbit = |n_lower: usize, other: &[f64], n_other: usize| -> Vec<Vec<f64>> {
        let other: Vec<f64> = other
            .iter()
            .zip(&ql)
            .zip(&angles)
            .map(|((&x, &l), &angle)| {
                if angle {
                    x - std::f64::consts::TAU * ((x - l) / std::f64::consts::TAU).round()
                } else {
                    x
                }
            })
            .collect();
        let mut o = vec![ql.clone(); n_lower];
        o.extend(std::iter::repeat_n(other, n_other));
        o
    };
    // half and half: spans (whichever the mean is nearest to)
    assert_eq!(wells.classify(&sys, &orbit(10, &qu, 10)), SPANS);
    // exactly a quarter on the far side spans; a fifth does not
    assert_eq!(SPAN_FRACTION, 0.25);
    assert_eq!(wells.classify(&sys, &orbit(15, &qu, 5)), SPANS);
    assert_eq!(wells.classify(&sys, &orbit(16, &qu, 4)), lower as isize);
    // the saddle on the rim is no well: a quarter of the samples there (the top of the
    // excursion), still the lower well
    assert_eq!(wells.classify(&sys, &orbit(15, &qs, 5)), lower as isize);
    // an orbit whose mean is nearest the saddle, visiting the lower well: spans (the
    // module's rule for a mean nearest an unstable equilibrium)
    assert_eq!(wells.classify(&sys, &orbit(10, &qs, 10)), SPANS);
    // and the upper well alone is the upper well
    assert_eq!(wells.classify(&sys, &[qu.clone()]), upper as isize);
}

/// Angles are compared modulo 2π in the wells' distance, for a spatial body turning by a
/// sequence of angles as for a planar one: a pose 2π away in each angle is the same pose
/// (the tangent between them wraps to zero), and a planar pose 2π away is in the same
/// well.
#[test]
fn angles_of_spatial_bodies_wrap_in_the_well_distance() {
    let text = r#"
[[bodies]]
name = "rod"
mass = 1
inertia = [0.01, 0.01, 0.002]
x = 0
y = 0.2
z = -0.3
rotation = [["z", "psi"], ["x", "th"]]
angles = { psi = 0.3, th = 0.5 }

[[joints]]
name = "pivot"
type = "spherical"
body1 = "rod"
point1 = [0, 0, 0.36]
body2 = "ground"
point2 = [0, 0, 0]
"#;
    let model = detune::Model::from_str("spatial.toml", text).unwrap();
    let sys = detune::System::new(&model).unwrap();
    let n = sys.nq();
    let q0: Vec<f64> = (0..n).map(|i| 0.1 * i as f64).collect();
    let angles: Vec<usize> = (0..n).filter(|&i| sys.is_angle(i)).collect();
    assert_eq!(angles.len(), 2, "psi and th are angles");
    let mut q1 = q0.clone();
    q1[angles[0]] += std::f64::consts::TAU;
    q1[angles[1]] -= 2.0 * std::f64::consts::TAU;
    q1[0] += 0.25; // and a length that does not wrap
    let mut d = vec![0.0; sys.nv()];
    sys.difference(&q1, &q0, &mut d);
    sys.wrap_angles(&mut d);
    for (i, x) in d.iter().enumerate() {
        let want = if i == 0 { 0.25 } else { 0.0 };
        assert!(
            (x - want).abs() < 1e-12,
            "component {i}: {x} (tangent {d:?})"
        );
    }
    // a planar pose 2π away in both bars' angles: the well it started in
    let model = detune::Model::load("models/overcentre.toml").unwrap();
    let sys = detune::System::new(&model).unwrap();
    let rest = detune::dynamics::assemble_at_rest(&sys).unwrap();
    let start = detune::statics::Statics::new(&sys, &rest.q)
        .unwrap()
        .nearest(&rest)
        .unwrap();
    let wells = detune::frequency::wells::Wells::find(&sys, &start);
    let mut q = start.q.clone();
    q[2] += std::f64::consts::TAU;
    q[5] -= std::f64::consts::TAU;
    assert!(wells.distance2(&sys, &q, wells.start) < 1e-20);
    assert_eq!(wells.classify(&sys, &[q]), wells.start as isize);
}

/// Issue 10/11 leftover, "no JSON at all": at F0 = 80 N the overcentre's bars are driven
/// into their folded pose (bar 1 at −90°, B on A: the constraints lose rank) and the
/// integration toward a steady state cannot go on. That is an error, not an empty
/// success: exit 1, and the message says where the sweep stopped, what happens to the
/// mechanism and what to try (a smaller F0, a higher start, the `simulate` command that
/// shows the motion). Here it fails at its first frequency: nothing was finished, nothing
/// is written, nothing on standard output (a sweep that fails later keeps what it
/// finished: tests/failed_sweep.rs).
#[test]
fn a_forcing_beyond_the_folded_pose_is_an_error_that_says_so() {
    let (code, out, err) = detune(&[
        "sweep",
        "models/overcentre.toml",
        "--set",
        "F0=80",
        "--param",
        "omega",
        "--from",
        "1",
        "--to",
        "1.5",
        "--step",
        "0.25",
        "--json",
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(out.is_empty(), "{out}");
    for says in [
        "the sweep stopped at omega = 1 rad/s, where the motion cannot be integrated",
        "nothing was written",
        "singular pose",
        "--set F0=",
        "F0 = 80 N now",
        "detune simulate models/overcentre.toml --set F0=80 --set omega=1 --t-end",
    ] {
        assert!(err.contains(says), "no {says:?} in {err}");
    }
    // the motion the hint shows: bar 1 swings down to the folded pose, −90°
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("motion.csv");
    let (code, _, err) = detune(&[
        "simulate",
        "models/overcentre.toml",
        "--set",
        "F0=80",
        "--set",
        "omega=1",
        "--t-end",
        "4.05",
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let (head, rows) = common::read_csv(&csv);
    let k = head.iter().position(|h| h == "bar1.theta").unwrap();
    let lowest = rows.iter().map(|r| r[k]).fold(f64::INFINITY, f64::min);
    assert!(
        (lowest + std::f64::consts::FRAC_PI_2).abs() < 0.05,
        "bar 1 reaches {lowest} rad"
    );
}

/// The hysteresis intervals of an up/down sweep cover every grid frequency where the two
/// sweeps differ, in amplitude by more than 1 % or in well, and no other: at F0 = 10 N,
/// 5.25 rad/s has up in the lower well and down in the upper one with amplitudes within
/// 1 % (0.1012 and 0.1020 rad), which the amplitude alone called equal.
#[test]
fn hysteresis_counts_a_change_of_well() {
    let (code, out, err) = detune(&[
        "sweep",
        "models/overcentre.toml",
        "--set",
        "F0=10",
        "--param",
        "omega",
        "--from",
        "0.5",
        "--to",
        "6",
        "--step",
        "0.25",
        "--response",
        "bar1.theta",
        "--mode",
        "both",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let j: Value = serde_json::from_str(&out).unwrap();
    let points = j["points"].as_array().unwrap();
    let at = |dir: &str, w: f64| {
        points
            .iter()
            .find(|p| {
                p["direction"] == dir
                    && p["refined"] == false
                    && (p["omega"].as_f64().unwrap() - w).abs() < 1e-12
            })
            .map(|p| {
                (
                    p["bar1.theta_amplitude"].as_f64().unwrap(),
                    p["well"].as_i64().unwrap(),
                )
            })
            .unwrap()
    };
    let intervals: Vec<(f64, f64)> = j["hysteresis"]
        .as_array()
        .unwrap()
        .iter()
        .map(|h| (h["from"].as_f64().unwrap(), h["to"].as_f64().unwrap()))
        .collect();
    let mut well_only = 0;
    for k in 0..=22 {
        let w = 0.5 + 0.25 * k as f64;
        let ((u, wu), (d, wd)) = (at("up", w), at("down", w));
        let by_amplitude = (u - d).abs() > 0.01 * u.abs().max(d.abs());
        let differ = by_amplitude || wu != wd;
        well_only += usize::from(wu != wd && !by_amplitude);
        let inside = intervals
            .iter()
            .any(|(a, b)| w >= a - 1e-9 && w <= b + 1e-9);
        assert_eq!(
            inside, differ,
            "{w} rad/s: up {u} in {wu}, down {d} in {wd}, {intervals:?}"
        );
    }
    // the case this guards: a frequency told apart by its well only
    assert!(well_only >= 1);
}

/// Where the wells alternate from one frequency to the next (F0 = 30 N: orbits about the
/// lower well and across both), the summary lists each well's runs of consecutive grid
/// frequencies, as the CSV's `well` column has them, not one range per well (it printed
/// "1.5–4 rad/s in across wells; 1–5.5 rad/s in well 0").
#[test]
fn the_well_summary_lists_runs_of_frequencies() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("w.csv");
    let (code, out, err) = detune(&[
        "sweep",
        "models/overcentre.toml",
        "--set",
        "F0=30",
        "--param",
        "omega",
        "--from",
        "1",
        "--to",
        "6",
        "--step",
        "0.5",
        "--response",
        "bar1.theta",
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<(String, i64)> = text
        .lines()
        .skip(1)
        .map(|r| {
            let f: Vec<&str> = r.split(',').collect();
            (f[0].to_string(), f.last().unwrap().parse().unwrap())
        })
        .collect();
    let runs = |k: i64| {
        let mut parts: Vec<String> = Vec::new();
        let mut i = 0;
        while i < rows.len() {
            if rows[i].1 != k {
                i += 1;
                continue;
            }
            let mut j = i;
            while j + 1 < rows.len() && rows[j + 1].1 == k {
                j += 1;
            }
            parts.push(if i == j {
                rows[i].0.clone()
            } else {
                format!("{}–{}", rows[i].0, rows[j].0)
            });
            i = j + 1;
        }
        parts.join(", ")
    };
    let all = format!("{out}{err}");
    // both kinds occur, each in more than one run (the case this guards)
    for (k, words) in [(0, "rad/s in well 0"), (-1, "rad/s across wells")] {
        let r = runs(k);
        assert!(r.contains(", "), "{k}: {r}");
        assert!(all.contains(&format!("{r} {words}")), "{r} {words}\n{all}");
    }
}

/// With a negative damper (c = −1 N·s/m) every well's oscillation grows: each equilibrium
/// keeps its static verdict (`stable`, the closed form's) and is dynamically unstable
/// (`dynamically_stable` false), in `simulate`'s JSON as in `equilibrium --json` (a copy
/// of `stable` would fail here).
#[test]
fn a_negative_damper_makes_every_well_dynamically_unstable() {
    let dir = tempfile::tempdir().unwrap();
    let (csv, json) = (dir.path().join("s.csv"), dir.path().join("s.json"));
    let (code, _, err) = detune(&[
        "simulate",
        "models/overcentre.toml",
        "--set",
        "c=-1",
        "--t-end",
        "1",
        "-o",
        csv.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let j: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let eqs = j["equilibria"].as_array().unwrap();
    let truth = closed_form_equilibria();
    assert_eq!(eqs.len(), truth.len());
    for (t, stable) in &truth {
        let e = eqs
            .iter()
            .find(|e| (e["coordinates"]["bar1.theta"].as_f64().unwrap() - t).abs() < 1e-8)
            .unwrap_or_else(|| panic!("no equilibrium at θ1 = {t}: {eqs:?}"));
        assert_eq!(e["stable"].as_bool(), Some(*stable), "θ1 = {t}");
        assert_eq!(e["dynamically_stable"].as_bool(), Some(false), "θ1 = {t}");
    }
}
