//! Stiff models (issue 13, defect 3): a trial step's non-finite value is not fatal, DOP853
//! says early that a model is stiff, and Radau IIA integrates it and agrees with the
//! reduced-order Lagrange reference on the baseline.

mod common;

use detune::dynamics::integrator::Integrator;
use detune::{SimOptions, System, assemble, simulate};
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_detune")
}

fn model() -> String {
    format!("{}/models/overcentre.toml", env!("CARGO_MANIFEST_DIR"))
}

fn out(name: &str) -> String {
    let dir = std::env::temp_dir().join(format!("detune-stiff-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name).to_string_lossy().into_owned()
}

/// `--set c=1e7` used to abort with "non-finite value" from a rejected trial step: with
/// DOP853 it now runs (saying it is stiff), with Radau it completes in a few steps.
#[test]
fn huge_damper_is_not_a_non_finite_error() {
    let o = Command::new(bin())
        .args(["simulate", &model(), "--set", "c=1e7", "--t-end", "0.01"])
        .args(["-o", &out("c7.csv")])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("non-finite"), "{err}");
    assert!(err.contains("the model is stiff"), "{err}");
    assert!(err.contains("--integrator radau"), "{err}");
    let o = Command::new(bin())
        .args(["simulate", &model(), "--set", "c=1e7", "--t-end", "0.5"])
        .args(["--integrator", "radau", "-o", &out("c7r.csv")])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let steps: usize = text
        .split("s: ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.parse().ok())
        .expect("step count");
    assert!(steps < 200, "{text}");
}

/// `--set k=1e10` took tens of seconds without a word: the warning comes within the first
/// steps (the run is killed after it, or after 10 s), with |λ| the stiff spring's mode.
/// Closed form at the start (θ1 = 45°, spring at its free length, m1 = m2 = m, L1 = L2 =
/// L): the spring joins the bars' centres, its length is L cos θ1, so its stiffness on θ1
/// is k L² sin² θ1 = k L²/2; the inertia on θ1 is m L²/3 (bar 1 about A) + m L²/12 + m L²
/// (9/4 sin² θ1 + 1/4 cos² θ1) (bar 2) = 5/3 m L²; ω² = 0.3 k/m (gravity adds 1e-9 of it).
#[test]
fn stiff_spring_is_reported_early() {
    let mut child = Command::new(bin())
        .args(["simulate", &model(), "--set", "k=1e10", "--t-end", "0.5"])
        .args(["-o", &out("k10.csv")])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(|l| l.ok()) {
            if line.starts_with("warning: the model is stiff") {
                let _ = tx.send(line);
                return;
            }
        }
    });
    let began = Instant::now();
    let line = rx.recv_timeout(Duration::from_secs(10));
    let _ = child.kill();
    let _ = child.wait();
    let line = line.expect("a stiffness warning within 10 s");
    let lambda: f64 = line
        .split("|λ| ≈ ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|x| x.parse().ok())
        .expect("|λ| in the warning");
    let omega = (0.3f64 * 1e10).sqrt();
    assert!(
        (lambda / omega - 1.0).abs() < 1e-3,
        "|λ| = {lambda}, ω = {omega}: {line}"
    );
    assert!(line.contains("steps"), "{line}");
    eprintln!("warned after {:?}", began.elapsed());
}

/// Radau IIA on the baseline free case matches the reduced-order Lagrange reference.
#[test]
fn radau_matches_the_lagrange_reference() {
    let model = common::overcentre(&[]);
    let sys = System::new(&model).unwrap();
    let start = assemble(&sys).unwrap();
    let opts = SimOptions {
        integrator: Integrator::Radau,
        ..SimOptions::default()
    };
    let traj = simulate(&sys, &start, &opts, &mut |_| true).unwrap();
    let (_, rows) = common::read_csv(format!(
        "{}/tests/data/lagrange_free.csv",
        env!("CARGO_MANIFEST_DIR")
    ));
    let theta = traj.coordinate("bar1.theta").unwrap();
    assert_eq!(theta.len(), rows.len());
    let worst = rows
        .iter()
        .zip(&theta)
        .map(|(r, x)| (r[1] - x).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-8, "max |θ1 error| = {worst:e} rad");
    assert!(traj.stats.max_constraint_residual < 1e-10);
}

/// A slider on a huge damper to ground (1 DoF, m ẍ + c ẋ + k x = 0, x(0) = 0.1 m at rest;
/// c = 1e6 N·s/m, k = 100 N/m, m = 1 kg): eigenvalues r₂ = (−c − √(c² − 4mk))/2m ≈ −1e6
/// and r₁ = k/(m r₂) ≈ −1e-4 1/s, stiffness ratio 1e10. Radau IIA follows the slow
/// exponential in a handful of steps and agrees with the closed form
/// x = A e^{r₁t} + B e^{r₂t}, A = x₀ r₂/(r₂ − r₁), B = x₀ − A.
#[test]
fn radau_follows_an_overdamped_slider_closed_form() {
    let text = r#"
[model]
name = "slider"

[parameters]
k = { value = 100, unit = "N/m" }
c = { value = 1e6, unit = "N*s/m" }
m = { value = 1, unit = "kg" }

[[bodies]]
name = "b"
mass = "m"
inertia = 1
x = 0.1
y = 0
theta = 0
fix = ["x"]

[[joints]]
name = "p"
type = "prismatic"
body1 = "b"
point1 = [0, 0]
body2 = "ground"
point2 = [0, 0]
axis = [1, 0]

[[forces]]
name = "s"
type = "spring_damper"
body1 = "ground"
point1 = [-1, 0]
body2 = "b"
point2 = [0, 0]
stiffness = "k"
damping = "c"
free_length = 1
"#;
    let model = common::from_text("slider", text, &[]);
    let sys = System::new(&model).unwrap();
    let start = assemble(&sys).unwrap();
    let opts = SimOptions {
        t_end: 1.0,
        dt_out: 0.05,
        integrator: Integrator::Radau,
        ..SimOptions::default()
    };
    let traj = simulate(&sys, &start, &opts, &mut |_| true).unwrap();
    let (m, c, k, x0) = (1.0f64, 1e6f64, 100.0f64, 0.1f64);
    let r2 = (-c - (c * c - 4.0 * m * k).sqrt()) / (2.0 * m);
    let r1 = k / (m * r2);
    let a = x0 * r2 / (r2 - r1);
    let b = x0 - a;
    let x = traj.coordinate("b.x").unwrap();
    assert_eq!(traj.coordinates[0], "b.x");
    let v: Vec<f64> = traj.vs().map(|v| v[0]).collect();
    for (i, &t) in traj.t.iter().enumerate() {
        let xe = a * (r1 * t).exp() + b * (r2 * t).exp();
        let ve = a * r1 * (r1 * t).exp() + b * r2 * (r2 * t).exp();
        assert!((x[i] - xe).abs() < 1e-9, "t = {t}: x = {} vs {xe}", x[i]);
        assert!((v[i] - ve).abs() < 1e-10, "t = {t}: v = {} vs {ve}", v[i]);
    }
    assert!(
        traj.stats.accepted_steps < 100,
        "{} steps",
        traj.stats.accepted_steps
    );
}

/// tests/data/stiff_sdof.toml: a 2 kg block on a spring (ω_n ≈ 20 rad/s) carrying a bead
/// of mass m2 on a stiff damper c2 = 1e3 N·s/m (and spring k2 = 1e4 N/m).
fn stiff_sdof() -> String {
    format!("{}/tests/data/stiff_sdof.toml", env!("CARGO_MANIFEST_DIR"))
}

/// The fast eigenvalue of the bead's motion relative to the block, |r| of
/// μ r² + c2 r + k2 = 0 (μ = m m2/(m + m2), the block's own spring 1e-4 of k2 aside).
fn bead_rate(m2: f64) -> f64 {
    let (m, c2, k2) = (2.0, 1e3, 1e4);
    let mu = m * m2 / (m + m2);
    (c2 + (c2 * c2 - 4.0 * mu * k2).sqrt()) / (2.0 * mu)
}

/// The first stiffness warning of a command (which is then killed), within 30 s.
fn stiff_warning_of(args: &[&str]) -> Option<String> {
    let mut child = Command::new(bin())
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(|l| l.ok()) {
            if line.starts_with("warning: the model is stiff") {
                let _ = tx.send(line);
                return;
            }
        }
    });
    let line = rx.recv_timeout(Duration::from_secs(30)).ok();
    let _ = child.kill();
    let _ = child.wait();
    line
}

/// A sweep whose integration is stiff says so once, on stderr with the numbers and
/// `--integrator radau`, and in the JSON under `warnings` (|λ| the bead's closed-form
/// rate); with `--integrator radau` it says nothing and its curve is the same.
#[test]
fn a_stiff_sweep_says_so_once_and_in_its_json() {
    let sweep = |extra: &[&str]| {
        let o = Command::new(bin())
            .args(["sweep", &stiff_sdof(), "--param", "omega", "--from", "15"])
            .args(["--to", "25", "--step", "1", "--response", "block.x"])
            .args(["--set", "m2=0.1", "--json"])
            .args(extra)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{err}");
        let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (doc, err)
    };
    let (doc, err) = sweep(&[]);
    assert_eq!(
        err.matches("warning: the model is stiff").count(),
        1,
        "{err}"
    );
    assert!(err.contains("at omega = "), "{err}");
    assert!(err.contains("--integrator radau"), "{err}");
    let w = &doc["warnings"][0];
    assert_eq!(w["kind"], "stiff", "{w}");
    let lambda = w["lambda"].as_f64().unwrap();
    assert!(
        (lambda / bead_rate(0.1) - 1.0).abs() < 1e-3,
        "|λ| = {lambda}, closed form {}",
        bead_rate(0.1)
    );
    assert!(w["help"].as_str().unwrap().contains("--integrator radau"));
    assert!(w["omega"].as_f64().unwrap() >= 15.0);
    let (radau, err) = sweep(&["--integrator", "radau"]);
    assert!(!err.contains("stiff"), "{err}");
    assert!(radau.get("warnings").is_none(), "{radau}");
    let amps = |d: &serde_json::Value| -> Vec<f64> {
        d["points"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["block.x_amplitude"].as_f64().unwrap())
            .collect()
    };
    let (a, b) = (amps(&doc), amps(&radau));
    assert_eq!(a.len(), 11);
    for (x, y) in a.iter().zip(&b) {
        assert!((x / y - 1.0).abs() < 1e-6, "dop853 {x} vs radau {y}");
    }
}

/// `sensitivity --method sweep` and `tune --verify sweep` run their sweeps with
/// `--integrator`: with DOP853 the very stiff bead (|λ| ≈ 1e6 1/s) is reported early
/// (naming the case); with Radau they finish, without a warning, on the stepped-sine
/// peak of the 2.001 kg block's displacement, ω_n·sqrt(1 − 2ζ²) = sqrt(k/M − c²/(2M²)),
/// to the sweeps' refinement (1/20 of their 0.23 rad/s step).
#[test]
fn sensitivity_and_tune_sweeps_use_the_integrator_asked_for() {
    let model = stiff_sdof();
    let sens = [
        "sensitivity",
        &model,
        "--vary",
        "k=880",
        "--method",
        "sweep",
        "--response",
        "block.x",
    ];
    let line = stiff_warning_of(&sens).expect("a stiffness warning within 30 s");
    assert!(line.contains("(the sweep of the baseline)"), "{line}");
    let lambda: f64 = line
        .split("|λ| ≈ ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|x| x.parse().ok())
        .expect("|λ| in the warning");
    assert!((lambda / bead_rate(1e-3) - 1.0).abs() < 1e-3, "{line}");
    let (m, k, c) = (2.001f64, 800.0f64, 6.0f64);
    let peak = (k / m - c * c / (2.0 * m * m)).sqrt();
    let o = Command::new(bin())
        .args(sens)
        .args(["--integrator", "radau", "--json"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("stiff"), "{err}");
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(doc.get("warnings").is_none());
    let got = doc["modes"][0]["peak_omega_rad_s"].as_f64().unwrap();
    assert!((got - peak).abs() < 0.012, "peak {got}, closed form {peak}");

    let tune = [
        "tune",
        &model,
        "--environment",
        "UH-60",
        "--vary",
        "k=50%..200%",
        "--designs",
        "1",
        "--verify",
        "sweep",
        "--response",
        "block.x",
    ];
    let line = stiff_warning_of(&tune).expect("a stiffness warning within 30 s");
    assert!(line.contains("(the sweep of design 1)"), "{line}");
    let o = Command::new(bin())
        .args(tune)
        .args(["--integrator", "radau", "--json"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("stiff"), "{err}");
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let got = doc["designs"][0]["sweep_peaks_rad_s"][0].as_f64().unwrap();
    assert!((got - peak).abs() < 0.012, "peak {got}, closed form {peak}");
}

/// `nfr` on the stiff model: DOP853 cannot cross a forcing period (|λ| = 1e6 1/s against
/// T ≈ 0.3 s) and is refused at once with `--integrator radau` as the advice; with
/// `--integrator radau` the curve runs and, the model being linear, its peak is the
/// linear frequency response's (`frf`, a second formulation: K − ω²M + iωC solved in the
/// frequency domain): the amplitude to 1e-6 relative, the frequency within the stated ±.
#[test]
fn nfr_on_a_stiff_model_runs_with_radau_and_equals_the_frf() {
    let range = [
        "--param",
        "omega",
        "--from",
        "19.5",
        "--to",
        "20.3",
        "--response",
        "block.x",
    ];
    let explicit = Command::new(bin())
        .arg("nfr")
        .arg(stiff_sdof())
        .args(range)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&explicit.stderr);
    assert_eq!(explicit.status.code(), Some(1), "{err}");
    assert!(
        err.contains("use --integrator radau") && err.contains("1000000 1/s"),
        "{err}"
    );
    let json = |cmd: &str, more: &[&str]| -> serde_json::Value {
        let o = Command::new(bin())
            .arg(cmd)
            .arg(stiff_sdof())
            .args(more)
            .arg("--json")
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{cmd}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let mut implicit: Vec<&str> = range.to_vec();
    implicit.extend(["--integrator", "radau"]);
    let nfr = json("nfr", &implicit);
    assert_eq!(nfr["complete"], true);
    let frf = json(
        "frf",
        &[
            "--param",
            "omega",
            "--from",
            "19.5",
            "--to",
            "20.3",
            "--step",
            "0.05",
            "--response",
            "block.x",
        ],
    );
    let (p, q) = (&nfr["peaks"][0], &frf["peaks"][0]);
    let amp = |v: &serde_json::Value| v["amplitude"].as_f64().unwrap();
    let at = |v: &serde_json::Value| v["omega"].as_f64().unwrap();
    assert!(
        (amp(p) / amp(q) - 1.0).abs() < 1e-6,
        "nfr {} against frf {}",
        amp(p),
        amp(q)
    );
    let pm = p["uncertainty"].as_f64().unwrap() + q["uncertainty"].as_f64().unwrap();
    assert!(
        (at(p) - at(q)).abs() <= pm && pm < 1e-3,
        "nfr {} against frf {} (± {pm})",
        at(p),
        at(q)
    );
}

/// A small orbit with `nfr --integrator radau` (the overcentre with a huge damper, c =
/// 1e4 N·s/m: 4e-5 rad at F0 = 1 N). At the default --atol Radau's looser error estimate
/// left each orbit converged to ~1e-4 of its amplitude: the curve doubled back hundreds of
/// times with two amplitudes at ω = 2 and ~200 false peaks. The curve is now monotonic in
/// ω, has no peak (the response only falls), and equals the linear response (`frf`: at
/// 4e-5 rad the mechanism is linear to ~1e-9) to 1e-5 at both ends.
#[test]
fn nfr_with_radau_on_a_small_orbit_is_a_smooth_curve() {
    let base = [
        "--set",
        "F0=1",
        "--set",
        "c=1e4",
        "--param",
        "omega",
        "--response",
        "bar1.theta",
    ];
    let json = |more: &[&str]| -> serde_json::Value {
        let o = Command::new(bin())
            .args(more)
            .arg(model())
            .args(base)
            .arg("--json")
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let nfr = json(&["nfr", "--from", "2", "--to", "3", "--integrator", "radau"]);
    let frf = json(&["frf", "--from", "2", "--to", "3", "--step", "1"]);
    let points = nfr["points"].as_array().unwrap();
    assert!(points.len() < 100, "{} points", points.len());
    let omegas: Vec<f64> = points
        .iter()
        .map(|p| p["omega"].as_f64().unwrap())
        .collect();
    assert!(omegas.windows(2).all(|w| w[1] > w[0]), "{omegas:?}");
    assert_eq!(
        nfr["peaks"].as_array().unwrap().len(),
        0,
        "{}",
        nfr["peaks"]
    );
    let amp = |p: &serde_json::Value| p["bar1.theta_amplitude"].as_f64().unwrap();
    let linear = frf["points"].as_array().unwrap();
    for (n, l) in [
        (&points[0], &linear[0]),
        (points.last().unwrap(), linear.last().unwrap()),
    ] {
        let want = l["bar1.theta_amplitude"].as_f64().unwrap();
        assert!(
            (amp(n) / want - 1.0).abs() < 1e-5,
            "nfr {} against frf {want}",
            amp(n)
        );
    }
}
