//! The backbone curve (issue 12, point 3) against closed forms, through the multibody path.
//!
//! * The Duffing oscillator of tests/data/duffing.toml (1 kg on a slider, a general spring
//!   anchored 1 m away with free length 1 m: force −(ω0² x + β x³) − c ẋ): its backbone is
//!   exactly ω(a) = π √(ω0² + β a²) / (2 K(m)), m = β a² / (2 (ω0² + β a²)), K the complete
//!   elliptic integral of the first kind (parameter convention) computed here by the AGM,
//!   K(m) = π / (2 AGM(1, √(1 − m))). Checked to 1e-8 relative at every point, hardening
//!   and softening (below the separatrix x = √(ω0²/|β|)), with the damper c of the model
//!   switched off by the backbone (undamped) and not by the test.
//! * The overcentre's lower-well mode (theta1_0 = −0.85, the damper left at its c = 5):
//!   softening, and its small-amplitude limit equal to the undamped linear ω_n of the
//!   model with c = 0 (from K and M alone) to 1e-6.
//! * The command: its CSV header and JSON keys, and the refusals.

use detune::periodic::ShootingOptions;
use detune::periodic::backbone::{BackboneOptions, backbone};
use std::process::Command;
use std::sync::atomic::AtomicBool;

fn load(path: &str, sets: &[(&str, &str)]) -> detune::System {
    let model = detune::Model::load(path).unwrap();
    let sets: Vec<(String, String)> = sets
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let model = model.with_overrides(&sets).unwrap();
    detune::System::new(&model).unwrap()
}

const DUFFING: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/duffing.toml");
const OVERCENTRE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/models/overcentre.toml");

fn agm(mut a: f64, mut b: f64) -> f64 {
    // quadratic convergence: 10 rounds reach round-off from any 0 < b/a ≤ 10 (a fixed
    // count: the two means may alternate in the last bit and never be equal)
    for _ in 0..40 {
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    a
}

/// The exact Duffing backbone ω(a).
fn exact(w0: f64, beta: f64, a: f64) -> f64 {
    let s = w0 * w0 + beta * a * a;
    let m = beta * a * a / (2.0 * s);
    let k = std::f64::consts::PI / (2.0 * agm(1.0, (1.0 - m).sqrt()));
    std::f64::consts::PI * s.sqrt() / (2.0 * k)
}

fn opts(responses: &[&str]) -> BackboneOptions {
    BackboneOptions {
        responses: responses.iter().map(|s| s.to_string()).collect(),
        shooting: ShootingOptions {
            rtol: 1e-12,
            atol: 1e-14,
            tol: 1e-10,
            ..Default::default()
        },
        ..Default::default()
    }
}

fn duffing(beta: f64, to: f64) {
    let sys = load(DUFFING, &[("beta", &beta.to_string())]);
    let b = backbone(
        &sys,
        0,
        to,
        &opts(&["body.x"]),
        &|_, _| {},
        &AtomicBool::new(false),
    )
    .unwrap();
    assert!(b.complete, "{:?}", b.stop);
    assert_eq!(b.reference_name, "body.x");
    assert!((b.omega_linear - 2.0).abs() < 1e-9, "{}", b.omega_linear);
    assert!(b.points.len() >= 10);
    let last = b.points.last().unwrap();
    assert!(
        (last.amplitude - to).abs() < 1e-12,
        "ends at {}",
        last.amplitude
    );
    let mut worst: f64 = 0.0;
    for p in &b.points {
        let want = exact(2.0, beta, p.amplitude);
        let rel = (p.omega - want).abs() / want;
        worst = worst.max(rel);
        assert!(
            rel <= 1e-8,
            "β = {beta}, a = {}: ω = {:.12} vs exact {want:.12} ({rel:.2e})",
            p.amplitude,
            p.omega
        );
        // the potential is even: the orbit swings from +a to −a (both turning points are
        // samples: t = 0 and T/2)
        assert!(
            (p.amplitudes[0] - p.amplitude).abs() <= 1e-8 * p.amplitude,
            "a = {}: half peak-to-peak {}",
            p.amplitude,
            p.amplitudes[0]
        );
    }
    // the curve bends the right way, by a visible amount
    let shift = last.omega / 2.0 - 1.0;
    assert!(shift * beta > 0.0 && shift.abs() > 0.02, "shift {shift}");
    eprintln!("β = {beta}: {} points, worst {worst:.2e}", b.points.len());
}

#[test]
fn duffing_hardening_backbone_is_the_elliptic_closed_form() {
    // ω from 2 to 2.37 rad/s at a = 0.9 m (the spring's anchor is 1 m away)
    duffing(2.0, 0.9);
}

#[test]
fn duffing_softening_backbone_is_the_elliptic_closed_form() {
    // the separatrix is at √(4/8) = 0.707 m; ω falls to 1.1 rad/s at a = 0.65 m
    duffing(-8.0, 0.65);
}

#[test]
fn overcentre_lower_well_softens_from_its_linear_frequency() {
    let sys = load(OVERCENTRE, &[("theta1_0", "-0.85")]);
    // the independent linear ω_n: the model with c = 0, from K and M
    let c0 = load(OVERCENTRE, &[("theta1_0", "-0.85"), ("c", "0")]);
    let ma = detune::linear::modal_analysis(&c0, None).unwrap();
    let wn = ma.undamped_omega2[0].sqrt();
    assert!((wn - 4.29).abs() < 0.01, "ω_n = {wn}");
    let b = backbone(
        &sys,
        0,
        0.6,
        &opts(&["bar1.theta"]),
        &|_, _| {},
        &AtomicBool::new(false),
    )
    .unwrap();
    assert!(b.complete, "{:?}", b.stop);
    assert_eq!(b.reference_name, "bar1.theta");
    assert!((b.omega_linear - wn).abs() <= 1e-9 * wn);
    // softening: ω falls with the amplitude, at every step
    for w in b.points.windows(2) {
        assert!(
            w[1].omega < w[0].omega,
            "ω rises from {} to {} between a = {} and {}",
            w[0].omega,
            w[1].omega,
            w[0].amplitude,
            w[1].amplitude
        );
    }
    let last = b.points.last().unwrap();
    assert!(last.omega < 0.95 * wn, "ω at a = 0.6 rad: {}", last.omega);
    // the small-amplitude limit: ω = ω_n + c₂ a² (+ O(a³), an asymmetric well) from the
    // two smallest orbits, extrapolated to a = 0
    let small = backbone(
        &sys,
        0,
        2e-3,
        &opts(&[]),
        &|_, _| {},
        &AtomicBool::new(false),
    )
    .unwrap();
    let (p, q) = (&small.points[0], &small.points[1]);
    let c2 = (q.omega - p.omega) / (q.amplitude.powi(2) - p.amplitude.powi(2));
    let limit = p.omega - c2 * p.amplitude.powi(2);
    assert!(
        (limit - wn).abs() <= 1e-6 * wn,
        "limit {limit:.10} vs ω_n {wn:.10} (points {} {} at a = {:e}, {:e})",
        p.omega,
        q.omega,
        p.amplitude,
        q.amplitude
    );
    assert!(c2 < 0.0, "softening: c₂ = {c2}");
}

/// At amplitudes small against the bars' coordinates (2e-7 to 1e-4 rad, coordinates up
/// to 4 m) the backbone is the linear ω_n (the softening there is below 1e-10 of it):
/// within 1e-8 at every orbit (the orbits are converged to the rounding of their
/// coordinates, `Shooting::rounding`: 2e-9 off at 7e-7 rad). The shooting's tolerances
/// are fitted to the motion (`Shooting::fit_to_motion`); before, the first orbit's ω was
/// 3e-7 below ω_n and rose with the amplitude, and below 1e-6 rad no orbit converged,
/// with the advice to give a smaller amplitude.
#[test]
fn overcentre_small_amplitudes_are_linear() {
    let sys = load(OVERCENTRE, &[("theta1_0", "-0.85")]);
    let c0 = load(OVERCENTRE, &[("theta1_0", "-0.85"), ("c", "0")]);
    let wn = detune::linear::modal_analysis(&c0, None)
        .unwrap()
        .undamped_omega2[0]
        .sqrt();
    // the command's defaults (rtol 1e-10); at 1e-7 rad it takes seconds (rtol at 1e-15)
    for to in [1e-5, 1e-4] {
        let b = backbone(
            &sys,
            0,
            to,
            &BackboneOptions::default(),
            &|_, _| {},
            &AtomicBool::new(false),
        )
        .unwrap();
        assert!(b.complete, "{:?}", b.stop);
        for p in &b.points {
            assert!(
                (p.omega - wn).abs() <= 1e-8 * wn,
                "ω = {} at a = {:e}, ω_n = {wn}",
                p.omega,
                p.amplitude
            );
        }
    }
}

#[test]
fn undamped_is_the_model_without_its_damper() {
    // a second formulation: the overcentre's undamped forces are those of the model with
    // c = 0, at any state; its damped forces are not
    let sys = load(OVERCENTRE, &[("theta1_0", "-0.85")]);
    let c0 = load(OVERCENTRE, &[("theta1_0", "-0.85"), ("c", "0")]);
    let und = sys.undamped();
    assert!(und.is_undamped() && !sys.is_undamped());
    let q = detune::assemble(&sys).unwrap().q;
    let v = [0.3, -0.2, 0.5, 0.1, 0.4, -0.7];
    let f = |s: &detune::System| {
        let mut f = vec![0.0; 6];
        s.forces(&q, &v, 0.7, &mut f);
        f
    };
    let (fu, f0, fd) = (f(&und), f(&c0), f(&sys));
    for i in 0..6 {
        assert!(
            (fu[i] - f0[i]).abs() <= 1e-12 * (1.0 + f0[i].abs()),
            "{fu:?} vs {f0:?}"
        );
    }
    assert!(fd.iter().zip(&f0).any(|(a, b)| (a - b).abs() > 1e-3));
    // and the spring's tension response is its elastic part
    let o = und.outputs(&["spring.tension".to_string()]).unwrap();
    let o0 = c0.outputs(&["spring.tension".to_string()]).unwrap();
    let (mut a, mut b) = ([0.0], [0.0]);
    detune::system::outputs::Probe::new(&und, o).eval(&und, 0.7, &q, &v, &mut a);
    detune::system::outputs::Probe::new(&c0, o0).eval(&c0, 0.7, &q, &v, &mut b);
    assert!(
        (a[0] - b[0]).abs() <= 1e-12 * (1.0 + b[0].abs()),
        "{a:?} vs {b:?}"
    );
}

fn detune(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_detune"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn the_command_writes_its_csv_and_json() {
    let dir = std::env::temp_dir().join(format!("detune-backbone-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("bb.csv");
    let svg = dir.join("bb.svg");
    let out = detune(&[
        "backbone",
        DUFFING,
        "--of-mode",
        "1",
        "--to-amplitude",
        "500 mm",
        "--response",
        "body.x",
        "--response",
        "spring.tension",
        "--json",
        "-o",
        csv.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "amplitude,omega,body.x_amplitude,spring.tension_amplitude"
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["mode"], "mode 1");
    assert_eq!(j["complete"], true);
    let points = j["points"].as_array().unwrap();
    assert_eq!(points.len(), text.lines().count() - 1);
    let last = points.last().unwrap();
    let a = last["amplitude"].as_f64().unwrap();
    assert!((a - 0.5).abs() < 1e-12);
    let w = last["omega"].as_f64().unwrap();
    assert!((w - exact(2.0, 0.5, a)).abs() < 1e-8 * w);
    // the spring's tension at rest: (ω0² a + β a³)·1 kg, the damper off
    let t = last["spring.tension_amplitude"].as_f64().unwrap();
    assert!(
        (t - (4.0 * a + 0.5 * a * a * a)).abs() < 1e-7,
        "tension {t}"
    );
    for (k, u) in [
        ("amplitude", "m"),
        ("omega", "rad/s"),
        ("omega_linear", "rad/s"),
        ("body.x_amplitude", "m"),
        ("spring.tension_amplitude", "N"),
    ] {
        assert_eq!(j["units"][k], u, "{k}");
    }
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_requests_are_refused_with_what_to_do() {
    let err = |args: &[&str]| -> String {
        let out = detune(args);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let e = err(&["backbone", OVERCENTRE, "--of-mode", "2"]);
    assert!(e.contains("mode 2: the model has 1 mode(s)"), "{e}");
    let e = err(&["backbone", OVERCENTRE, "--of-mode", "swing"]);
    assert!(e.contains("no mode is named `swing`"), "{e}");
    let e = err(&[
        "backbone",
        OVERCENTRE,
        "--of-mode",
        "1",
        "--to-amplitude",
        "0",
    ]);
    assert!(e.contains("must be positive"), "{e}");
    let e = err(&[
        "backbone",
        OVERCENTRE,
        "--of-mode",
        "1",
        "--to-amplitude",
        "-0.1",
    ]);
    assert!(e.contains("must be positive"), "{e}");
    let e = err(&[
        "backbone",
        OVERCENTRE,
        "--of-mode",
        "1",
        "--to-amplitude",
        "3 mm",
    ]);
    assert!(e.contains("is an angle"), "{e}");
    // a relative tolerance outside 1e-15..1e-3 (orbits converged to ~100·rtol): refused
    for rtol in ["1e-2", "1e-20"] {
        let e = err(&["backbone", OVERCENTRE, "--of-mode", "1", "--rtol", rtol]);
        assert!(e.contains("from 1e-15 to 1e-3"), "{e}");
    }
    // a reference coordinate the mode does not move: refused (the amplitude was measured
    // on another coordinate, unsaid), naming the ones it moves
    let e = err(&[
        "backbone",
        DUFFING,
        "--of-mode",
        "1",
        "--normalize",
        "body.y",
        "--to-amplitude",
        "0.1",
    ]);
    assert!(
        e.contains("does not move body.y") && e.contains("moves: body.x"),
        "{e}"
    );
    // an amplitude far below what double precision resolves against the coordinates'
    // values (the bars' 2 m): the first orbit cannot converge, and the advice is a larger
    // amplitude, not another coordinate
    let e = err(&[
        "backbone",
        OVERCENTRE,
        "--of-mode",
        "1",
        "--to-amplitude",
        "1e-11",
    ]);
    assert!(
        e.contains("first amplitude 2.000e-13 rad of bar1.theta")
            && e.contains("too little for shooting in double precision")
            && e.contains("give a larger target amplitude"),
        "{e}"
    );
    // the Duffing spring's anchor is 1 m away: the family ends before a = 1 m, where it
    // says, the curve so far still written
    let out = detune(&[
        "backbone",
        DUFFING,
        "--of-mode",
        "1",
        "--to-amplitude",
        "1.5",
        "--json",
    ]);
    assert_eq!(out.status.code(), Some(1));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("cannot be continued beyond body.x = 1.0"), "{e}");
    assert!(e.contains("smaller amplitude"), "{e}");
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["complete"], false);
    assert!(j["points"].as_array().unwrap().len() > 5);
    // the library: a mode index out of range, an amplitude that is not positive
    let sys = load(OVERCENTRE, &[("theta1_0", "-0.85")]);
    let no = AtomicBool::new(false);
    let o = BackboneOptions::default();
    let e = backbone(&sys, 1, 0.1, &o, &|_, _| {}, &no)
        .unwrap_err()
        .to_string();
    assert!(e.contains("mode index 1 (mode 2)"), "{e}");
    for a in [0.0, -1.0, f64::NAN] {
        let e = backbone(&sys, 0, a, &o, &|_, _| {}, &no)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not positive"), "{a}: {e}");
    }
}
