//! `equilibrium --all` lists every equilibrium once: poses equal modulo 2π in their angles
//! are one. A slider-crank (tests/data/slider_crank.toml: crank r pinned at the origin, rod
//! l whose far end slides on y = 0, gravity −y) revolves, so the sweep of its crank angle
//! reaches each equilibrium twice; its potential is (m1 + m2) g (r/2) sin θ whatever l,
//! so the equilibria are θ = −π/2 (stable) and +π/2 (unstable), and nothing else.
//!
//! With several degrees of freedom the search is not a sweep of one angle: a double
//! pendulum (tests/data/double_pendulum.toml) has its four poses θ1, θ2 = ±π/2, both bars
//! inverted included, each once, and a triple pendulum its eight. A four-bar
//! (tests/data/four_bar.toml) is checked against its potential along the crank angle,
//! computed here from the closed-form loop closure.

use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::process::Command;

/// `detune equilibrium FILE --all --json`'s list of equilibria.
fn all_equilibria(file: &str) -> Vec<serde_json::Value> {
    all_equilibria_of(&[file])
}

/// `detune equilibrium --all --json ARGS...`'s list of equilibria.
fn all_equilibria_of(args: &[&str]) -> Vec<serde_json::Value> {
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args(["equilibrium", "--all", "--json"])
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v["equilibria"].as_array().unwrap().clone()
}

/// Coordinate `name` of a JSON equilibrium.
fn coord(e: &serde_json::Value, name: &str) -> f64 {
    e["coordinates"][name]
        .as_f64()
        .unwrap_or_else(|| panic!("no {name} in {e:#}"))
}

/// a − b as an angle, in (−π, π].
fn angle_diff(a: f64, b: f64) -> f64 {
    let r = (a - b).rem_euclid(TAU);
    if r > PI { r - TAU } else { r }
}

/// Both bars of a double pendulum hang, stand, or one of each: V = g [m1 (L1/2) sin θ1 +
/// m2 (L1 sin θ1 + (L2/2) sin θ2)] is stationary exactly where cos θ1 = cos θ2 = 0, and a
/// minimum only at (−π/2, −π/2). The earlier search (a sweep of each angle from the start)
/// reported 7 poses, repeating three and missing both-inverted.
#[test]
fn a_double_pendulum_has_its_four_poses_once() {
    let list = all_equilibria("tests/data/double_pendulum.toml");
    let want = [
        (-FRAC_PI_2, -FRAC_PI_2, true),
        (-FRAC_PI_2, FRAC_PI_2, false),
        (FRAC_PI_2, -FRAC_PI_2, false),
        (FRAC_PI_2, FRAC_PI_2, false),
    ];
    assert_eq!(list.len(), want.len(), "{list:#?}");
    let (l1, l2) = (1.0, 0.7);
    for (e, (t1, t2, stable)) in list.iter().zip(want) {
        let (th1, th2) = (coord(e, "bar1.theta"), coord(e, "bar2.theta"));
        assert!(
            angle_diff(th1, t1).abs() < 1e-10 && angle_diff(th2, t2).abs() < 1e-10,
            "(θ1, θ2) = ({th1}, {th2}), want ({t1}, {t2})"
        );
        assert_eq!(e["stable"].as_bool(), Some(stable), "{e:#}");
        // the pose itself: bar 2's centre at L1 sin θ1 + (L2/2) sin θ2
        let y2 = l1 * t1.sin() + l2 / 2.0 * t2.sin();
        assert!((coord(e, "bar2.y") - y2).abs() < 1e-10, "{e:#}");
    }
}

/// A double pendulum that fixes nothing for assembly: `Statics::all` picks the two angles
/// itself (the free positions still close the joints) and finds the same four poses; it
/// used to return only the equilibrium nearest the initial pose.
#[test]
fn a_double_pendulum_without_fixed_coordinates_is_searched_by_its_angles() {
    let text = std::fs::read_to_string("tests/data/double_pendulum.toml")
        .unwrap()
        .replace("fix = [\"theta\"]\n", "");
    assert!(!text.contains("fix"));
    let model = detune::Model::from_str("double_pendulum (no fix)", &text).unwrap();
    let sys = detune::System::new(&model).unwrap();
    let start = detune::assemble(&sys).unwrap();
    let all = detune::statics::Statics::new(&sys, &start.q)
        .unwrap()
        .all(&start)
        .unwrap();
    let (th1, th2) = (2, 5);
    let got: Vec<(f64, f64, bool)> = all.iter().map(|e| (e.q[th1], e.q[th2], e.stable)).collect();
    let want = [
        (-FRAC_PI_2, -FRAC_PI_2, true),
        (-FRAC_PI_2, FRAC_PI_2, false),
        (FRAC_PI_2, -FRAC_PI_2, false),
        (FRAC_PI_2, FRAC_PI_2, false),
    ];
    assert_eq!(got.len(), want.len(), "{got:?}");
    for (g, w) in got.iter().zip(want) {
        assert!(
            angle_diff(g.0, w.0).abs() < 1e-10 && angle_diff(g.1, w.1).abs() < 1e-10 && g.2 == w.2,
            "{g:?}, want {w:?}"
        );
    }
}

/// Three degrees of freedom: a triple pendulum's eight poses θ1, θ2, θ3 = ±π/2, each
/// once, sorted by θ1, then θ2, then θ3; only all hanging is stable.
#[test]
fn a_triple_pendulum_has_its_eight_poses_once() {
    let list = all_equilibria("tests/data/triple_pendulum.toml");
    assert_eq!(list.len(), 8, "{list:#?}");
    let (l1, l2, l3) = (1.0, 0.7, 0.5);
    for (i, e) in list.iter().enumerate() {
        // pose i: bit 2 the sign of θ1, bit 1 of θ2, bit 0 of θ3 (set = +π/2)
        let t: Vec<f64> = [4, 2, 1]
            .iter()
            .map(|b| if i & b != 0 { FRAC_PI_2 } else { -FRAC_PI_2 })
            .collect();
        for (k, want) in t.iter().enumerate() {
            let th = coord(e, &format!("bar{}.theta", k + 1));
            assert!(
                angle_diff(th, *want).abs() < 1e-10,
                "pose {i}: bar{}.theta = {th}, want {want}",
                k + 1
            );
        }
        assert_eq!(e["stable"].as_bool(), Some(i == 0), "{e:#}");
        let y3 = l1 * t[0].sin() + l2 * t[1].sin() + l3 / 2.0 * t[2].sin();
        assert!((coord(e, "bar3.y") - y3).abs() < 1e-10, "{e:#}");
    }
}

/// The four-bar's potential along its crank angle θ, from the closed-form loop closure:
/// A = a (cos θ, sin θ); B where the circles |B − A| = b and |B − D| = c meet, on the side
/// the model assembles; V = g [m1 y_A/2 + m2 (y_A + y_B)/2 + m3 y_B/2]. Returns (B, dV/dθ),
/// dV/dθ exact: the rocker turns at ω3 = s·A′ / (r × s) with s = B − A, r = B − D (the
/// coupler's length is constant: s·(B′ − A′) = 0, B′ = ω3 ẑ × r).
fn four_bar(theta: f64) -> ([f64; 2], f64) {
    let (a, b, c, d) = (0.3, 1.0, 0.8, 1.0);
    let (m1, m2, m3, g) = (1.0, 2.0, 1.5, 9.81);
    let (ax, ay) = (a * theta.cos(), a * theta.sin());
    let e = ((d - ax).powi(2) + ay.powi(2)).sqrt();
    let h = (b * b - c * c + e * e) / (2.0 * e);
    let k = (b * b - h * h).sqrt();
    let bx = ax + (h * (d - ax) + k * ay) / e;
    let by = ay + (-h * ay + k * (d - ax)) / e;
    let (dax, day) = (-ay, ax);
    let (s, r) = ([bx - ax, by - ay], [bx - d, by]);
    let omega3 = (s[0] * dax + s[1] * day) / (r[0] * s[1] - r[1] * s[0]);
    let dby = omega3 * r[0];
    let dv = g * (m1 * day / 2.0 + m2 * (day + dby) / 2.0 + m3 * dby / 2.0);
    ([bx, by], dv)
}

/// The four-bar's equilibria: dV/dθ = 0 found by a scan of 3600 steps over a revolution of
/// the crank and bisection; a root where dV/dθ rises is a minimum (stable).
#[test]
fn a_four_bar_has_the_equilibria_of_its_potential_once() {
    let n = 3600;
    let mut roots = Vec::new();
    for i in 0..n {
        let (mut lo, mut hi) = (
            -PI + TAU * i as f64 / n as f64,
            -PI + TAU * (i + 1) as f64 / n as f64,
        );
        let (flo, fhi) = (four_bar(lo).1, four_bar(hi).1);
        if flo == 0.0 || flo.signum() == fhi.signum() {
            continue;
        }
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if four_bar(mid).1.signum() == flo.signum() {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        roots.push((0.5 * (lo + hi), flo < 0.0));
    }
    assert_eq!(roots.len(), 2, "the independent computation: {roots:?}");
    let list = all_equilibria("tests/data/four_bar.toml");
    assert_eq!(list.len(), roots.len(), "{list:#?}");
    for &(theta, stable) in &roots {
        let matches: Vec<_> = list
            .iter()
            .filter(|e| angle_diff(coord(e, "crank.theta"), theta).abs() < 1e-9)
            .collect();
        assert_eq!(matches.len(), 1, "θ = {theta}: {list:#?}");
        let e = matches[0];
        assert_eq!(e["stable"].as_bool(), Some(stable), "{e:#}");
        // the rocker's angle, from the loop closure
        let ([bx, by], _) = four_bar(theta);
        let rocker = by.atan2(bx - 1.0);
        assert!(
            angle_diff(coord(e, "rocker.theta"), rocker).abs() < 1e-9,
            "{e:#}: rocker θ {rocker}"
        );
    }
}

#[test]
fn a_revolving_crank_has_each_equilibrium_once() {
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args([
            "equilibrium",
            "tests/data/slider_crank.toml",
            "--all",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let list = v["equilibria"].as_array().unwrap();
    assert_eq!(list.len(), 2, "{list:#?}");
    let half_pi = std::f64::consts::FRAC_PI_2;
    for (e, (want, stable)) in list.iter().zip([(-half_pi, true), (half_pi, false)]) {
        let th = e["coordinates"]["crank.theta"].as_f64().unwrap();
        assert!((th - want).abs() < 1e-10, "crank.theta = {th}, want {want}");
        assert_eq!(e["stable"].as_bool(), Some(stable));
    }
}

/// A start beyond a turn (th0 = 10 rad, 573°) finds the same two equilibria, shown with
/// their angles in (−π, π] (they were 450° and 630°): the crank's elements see its angle
/// only through sin and cos. A torsion spring sees the raw angle: the torsion pendulum
/// (tests/data/torsion_pendulum.toml) with T = 60 N·m rests at θ = 3.8132 rad (218°),
/// T = k (θ + π/2) + m g (L/2) cos θ, and keeps it (θ − 2π is no equilibrium).
#[test]
fn angles_are_shown_in_the_first_turn_unless_an_element_sees_the_raw_angle() {
    let list = all_equilibria_of(&["tests/data/slider_crank.toml", "--set", "th0=10"]);
    assert_eq!(list.len(), 2, "{list:#?}");
    for (e, (want, stable)) in list.iter().zip([(-FRAC_PI_2, true), (FRAC_PI_2, false)]) {
        let th = coord(e, "crank.theta");
        assert!((th - want).abs() < 1e-10, "crank.theta = {th}, want {want}");
        assert!(coord(e, "rod.theta").abs() <= PI);
        assert_eq!(e["stable"].as_bool(), Some(stable));
    }
    // the plain command (the equilibrium nearest the start) shows it the same way: the
    // stable one at −90°, where it showed 630°
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args([
            "equilibrium",
            "tests/data/slider_crank.toml",
            "--set",
            "th0=10",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    let one: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let th = coord(&one, "crank.theta");
    assert!((th + FRAC_PI_2).abs() < 1e-10, "crank.theta = {th}");
    // and `modes` shows the pose it computes its modes at the same way (display only:
    // ω² = 12.612857 rad²/s² about the pose found, as before)
    let modes = |json: bool| {
        let mut args = vec!["modes", "tests/data/slider_crank.toml", "--set", "th0=10"];
        if json {
            args.push("--json");
        }
        let out = Command::new(env!("CARGO_BIN_EXE_detune"))
            .args(&args)
            .output()
            .unwrap();
        assert!(out.status.success());
        String::from_utf8(out.stdout).unwrap()
    };
    let text = modes(false);
    let crank = text
        .lines()
        .find(|l| l.trim_start().starts_with("crank.theta"))
        .unwrap();
    assert!(crank.contains("(-90.000000°)"), "{text}");
    assert!(!text.contains("630"), "{text}");
    assert!(text.contains("ω² = [12.61285714285"), "{text}");
    let m: serde_json::Value = serde_json::from_str(&modes(true)).unwrap();
    let th = m["equilibrium"]["crank.theta"].as_f64().unwrap();
    assert!((th + FRAC_PI_2).abs() < 1e-10, "crank.theta = {th}");
    let list = all_equilibria_of(&["tests/data/torsion_pendulum.toml", "--set", "T=60"]);
    assert_eq!(list.len(), 1, "{list:#?}");
    let th = coord(&list[0], "bar.theta");
    let (m, l, g, k) = (1.5, 0.8, 9.81, 12.0);
    let torque = |t: f64| 60.0 - k * (t + FRAC_PI_2) - m * g * l / 2.0 * t.cos();
    assert!(
        th > PI && torque(th).abs() < 1e-9,
        "θ = {th}: {}",
        torque(th)
    );
}

/// An unstable equilibrium's divergent mode is shown as a growth rate and time constant,
/// not as a frequency with ζ = −1: undamped, its rate is √(−ω²) of the stiffness's negative
/// eigenvalue.
#[test]
fn a_divergent_mode_is_shown_as_a_growth_rate() {
    let args = [
        "modes",
        "models/overcentre.toml",
        "--set",
        "theta1_0=0.26",
        "--set",
        "c=0",
    ];
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args(args)
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args(args)
        .arg("--json")
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let w2 = v["undamped_omega2"][0].as_f64().unwrap();
    assert!(w2 < 0.0);
    let rate = (-w2).sqrt();
    let line = text
        .lines()
        .find(|l| l.contains("DIVERGENT"))
        .unwrap_or_else(|| panic!("no divergent mode in:\n{text}"));
    let number_after = |key: &str| -> f64 {
        let rest = &line[line.find(key).unwrap_or_else(|| panic!("{key} in {line}")) + key.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    assert!(
        (number_after("rate ") - rate).abs() < 1e-7,
        "{line} (rate {rate})"
    );
    assert!(
        (number_after("time constant ") - 1.0 / rate).abs() < 1e-5,
        "{line}"
    );
}

/// Issue 10, point 4: in `modes --json` a divergent mode (a real positive eigenvalue) is
/// flagged and given its growth rate and time constant; its ω_n, f and ζ (= −1), which
/// would describe a frequency it does not have, are null. Undamped (c = 0) the rate is
/// √(−ω²) of the stiffness's negative eigenvalue, a second formulation (the undamped
/// K_r, M_r eigenproblem against the state-space eigenvalue). The decaying real mode
/// beside it keeps its numbers and is not divergent.
#[test]
fn a_divergent_mode_in_json_has_a_growth_rate_and_no_frequency() {
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args([
            "modes",
            "models/overcentre.toml",
            "--set",
            "theta1_0=0.26",
            "--set",
            "c=0",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rate = (-v["undamped_omega2"][0].as_f64().unwrap()).sqrt();
    let modes = v["modes"].as_array().unwrap();
    let div: Vec<&serde_json::Value> = modes.iter().filter(|m| m["divergent"] == true).collect();
    assert_eq!(div.len(), 1, "{modes:#?}");
    let d = div[0];
    assert!((d["growth_rate_1_s"].as_f64().unwrap() - rate).abs() < 1e-9 * rate);
    assert!((d["time_constant_s"].as_f64().unwrap() - 1.0 / rate).abs() < 1e-9 / rate);
    assert_eq!(
        d["eigenvalue"]["re"].as_f64(),
        d["growth_rate_1_s"].as_f64()
    );
    for key in ["omega_n_rad_s", "freq_hz", "damping_ratio"] {
        assert!(d[key].is_null(), "{key} of a divergent mode: {}", d[key]);
    }
    assert_eq!(d["omega_d_rad_s"].as_f64(), Some(0.0));
    assert_eq!(v["units"]["growth_rate_1_s"], "1/s");
    assert_eq!(v["units"]["time_constant_s"], "s");
    // the other mode decays at the same rate (undamped: λ = ±√(−ω²)) and is not divergent;
    // non-oscillatory, it has no frequency either (as the text says), but its decay rate
    let other = modes.iter().find(|m| m["divergent"] == false).unwrap();
    assert!((other["decay_rate_1_s"].as_f64().unwrap() - rate).abs() < 1e-9 * rate);
    assert_eq!(other["non_oscillatory"], true);
    for key in ["omega_n_rad_s", "freq_hz", "damping_ratio"] {
        assert!(
            other[key].is_null(),
            "{key} of a decaying real mode: {}",
            other[key]
        );
    }
    assert!(other["growth_rate_1_s"].is_null() && other["time_constant_s"].is_null());
}

/// Issue 10, point 2: a driven model whose every coordinate is fixed by its constraints
/// (tests/data/driven_pendulum.toml: a pendulum whose angle is prescribed in time) has no
/// degrees of freedom, so no stability: `modes` says so instead of "equilibrium
/// (stable)", and the JSON of `modes`, `equilibrium` and `equilibrium --all` has
/// `"stable": null` (the key kept).
#[test]
fn a_driven_model_without_degrees_of_freedom_is_not_called_stable() {
    let file = "tests/data/driven_pendulum.toml";
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_detune"))
            .args(args)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap()
    };
    let text = run(&["modes", file]);
    assert!(
        text.starts_with("equilibrium (no degrees of freedom):\n"),
        "{text}"
    );
    assert!(!text.contains("stable"), "{text}");
    let json = |args: &[&str]| -> serde_json::Value { serde_json::from_str(&run(args)).unwrap() };
    let m = json(&["modes", file, "--json"]);
    assert!(m.get("stable").is_some_and(|s| s.is_null()), "{m}");
    assert_eq!(m["modes"].as_array().map(Vec::len), Some(0));
    // the pose is the prescribed one at t = 0: θ = 0.2 rad
    assert!((m["equilibrium"]["b.theta"].as_f64().unwrap() - 0.2).abs() < 1e-12);
    let e = json(&["equilibrium", file, "--json"]);
    assert!(e.get("stable").is_some_and(|s| s.is_null()), "{e}");
    let all = all_equilibria(file);
    assert_eq!(all.len(), 1);
    assert!(all[0].get("stable").is_some_and(|s| s.is_null()));
    // a model that can move keeps its boolean
    let s = json(&["equilibrium", "models/overcentre.toml", "--json"]);
    assert_eq!(s["stable"], true);
    // margins: no empty table before its verdict; the report: "no modes", not
    // "0 modes (ω_n none rad/s)"
    let text = run(&["margins", file, "--environment", "UH-60"]);
    assert!(
        text.contains("PASS: no oscillatory mode to check"),
        "{text}"
    );
    assert!(!text.contains("separation     side"), "{text}");
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("r.html");
    let text = run(&["report", file, "-o", html.to_str().unwrap()]);
    assert!(text.contains("driven_pendulum: no modes;"), "{text}");
}
