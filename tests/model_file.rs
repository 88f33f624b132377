//! The model file and `--set`: units, dependent parameters, assembly branches.

mod common;

use common::overcentre_text as shipped_text;
use detune::{Model, System, assemble};
use std::f64::consts::PI;

fn model() -> Model {
    common::overcentre(&[])
}

/// The error of loading and compiling the shipped model with its first `from` replaced
/// by `to`.
fn load_error(from: &str, to: &str) -> String {
    let text = shipped_text();
    assert!(text.contains(from), "{from}");
    Model::from_str("t.toml", &text.replacen(from, to, 1))
        .and_then(|m| System::check(&m))
        .unwrap_err()
        .to_string()
}

fn with(sets: &[(&str, &str)]) -> detune::Result<Model> {
    let sets: Vec<(String, String)> = sets
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    model()
        .with_overrides(&sets)
        .and_then(|m| System::check(&m).map(|_| m))
}

#[test]
fn baseline_parameters_are_si() {
    let m = model();
    let p = &m.parameters;
    assert_eq!(p.value("L1"), Some(2.0 * 2f64.sqrt()));
    assert_eq!(p.value("s"), p.value("L1"));
    assert_eq!(p.value("theta1_0"), Some(PI / 4.0));
}

#[test]
fn frequencies_convert_with_two_pi() {
    let want = 4.3 * 2.0 * PI; // 27.0177 rad/s
    let hz = with(&[("omega", "4.3 Hz")]).unwrap();
    assert!((hz.parameters.value("omega").unwrap() - want).abs() < 1e-12);
    let rpm = with(&[("omega", "258 rpm")]).unwrap();
    assert!((rpm.parameters.value("omega").unwrap() - want).abs() < 1e-12);
    // and a plain number is SI (rad/s): no conversion
    let si = with(&[("omega", "27.0177")]).unwrap();
    assert_eq!(si.parameters.value("omega"), Some(27.0177));
}

#[test]
fn quantities_and_expressions_in_set() {
    let m = with(&[
        ("theta1_0", "45 deg"),
        ("L0", "2000 mm"),
        ("m1", "2*m2"),
        ("Fs", "-3"),
    ])
    .unwrap();
    let p = &m.parameters;
    assert!((p.value("theta1_0").unwrap() - PI / 4.0).abs() < 1e-15);
    assert!((p.value("L0").unwrap() - 2.0).abs() < 1e-15);
    assert_eq!(p.value("m1"), Some(2.0));
    assert_eq!(p.value("Fs"), Some(-3.0));
    // c in lbf*s/in: 1 lbf·s/in = 175.1268 N·s/m
    let m = with(&[("c", "1 lbf*s/in")]).unwrap();
    assert!((m.parameters.value("c").unwrap() - 4.4482216152605 / 0.0254).abs() < 1e-9);
}

#[test]
fn dependent_parameters_are_reevaluated() {
    // s = L1 in the file: overriding L1 moves s with it; overriding s itself wins.
    let m = with(&[("L1", "2.5")]).unwrap();
    assert_eq!(m.parameters.value("s"), Some(2.5));
    let m = with(&[("L1", "2.5"), ("s", "L1/2")]).unwrap();
    assert_eq!(m.parameters.value("s"), Some(1.25));
}

#[test]
fn set_errors_name_the_problem() {
    let e = with(&[("k", "3 mm")]).unwrap_err().to_string();
    assert!(e.contains("N/m") && e.contains("help"), "{e}");
    let e = with(&[("nope", "1")]).unwrap_err().to_string();
    assert!(e.contains("no parameter `nope`"), "{e}");
    let e = with(&[("k", "5 furlongs")]).unwrap_err().to_string();
    assert!(e.contains("furlongs"), "{e}");
    let e = with(&[("k", "2*kk")]).unwrap_err().to_string();
    assert!(e.contains("kk"), "{e}");
    // a parameter's own name in its --set means its value before: not a cycle
    assert_eq!(
        with(&[("k", "k/2")]).unwrap().parameters.value("k"),
        Some(25.0)
    );
}

#[test]
fn coordinates_constraints_and_rank() {
    let m = model();
    let sys = System::new(&m).unwrap();
    assert_eq!(
        sys.coordinates,
        [
            "bar1.x",
            "bar1.y",
            "bar1.theta",
            "bar2.x",
            "bar2.y",
            "bar2.theta"
        ]
    );
    assert_eq!(sys.constraint_names, ["A.x", "A.y", "J.x", "J.y", "B.slot"]);
    let s = assemble(&sys).unwrap();
    assert_eq!(detune::dynamics::constraint_rank(&sys, &s.q, 0.0), 5);
    // A loses rank where the bars fold back at θ1 = ±90° (B on top of A... of J's vertical)
    let mut q = s.q.clone();
    let l = m.parameters.value("L1").unwrap();
    q[2] = PI / 2.0;
    q[0] = 0.0;
    q[1] = l / 2.0;
    q[5] = PI / 2.0;
    q[3] = 0.0;
    q[4] = l / 2.0;
    assert!(detune::dynamics::residual_norm(&sys, &q, 0.0) < 1e-12);
    assert_eq!(detune::dynamics::constraint_rank(&sys, &q, 0.0), 4);
}

#[test]
fn assembly_solves_the_free_coordinates() {
    let m = with(&[("theta1_0", "0.3"), ("L2", "3.5")]).unwrap();
    let sys = System::new(&m).unwrap();
    let s = assemble(&sys).unwrap();
    let (l1, l2) = (2.0 * 2f64.sqrt(), 3.5);
    let th1 = 0.3f64;
    let th2 = PI - (l1 * th1.sin() / l2).asin();
    assert!((s.q[2] - th1).abs() < 1e-15);
    assert!((s.q[5] - th2).abs() < 1e-12, "θ2 = {}", s.q[5]);
    assert!((s.q[3] - (l1 * th1.cos() - l2 / 2.0 * th2.cos())).abs() < 1e-12);
    assert!(s.v.iter().all(|v| v.abs() < 1e-14));
}

#[test]
fn assembly_follows_the_guesses_to_the_other_branch() {
    // Guess bar 2 folded back onto A: B at the origin, θ2 = θ1 (equal bars).
    let text = shipped_text()
        .replace(
            "x = \"L1*cos(theta1_0) + L2/2*cos(asin(L1*sin(theta1_0)/L2))\"",
            "x = \"0.45*L1*cos(theta1_0)\"",
        )
        .replace(
            "theta = \"pi - asin(L1*sin(theta1_0)/L2)\"",
            "theta = \"theta1_0 + 0.1\"",
        );
    let m = Model::from_str("folded.toml", &text).unwrap();
    let sys = System::new(&m).unwrap();
    let s = assemble(&sys).unwrap();
    let b_x = s.q[3] - 2f64.sqrt() * s.q[5].cos();
    assert!(b_x.abs() < 1e-12, "B at x = {b_x}");
    assert!((s.q[5] - PI / 4.0).abs() < 1e-12);
}

#[test]
fn initial_velocity_is_held_and_the_rest_solved() {
    let text = shipped_text().replace(
        "fix = [\"theta\"]",
        "fix = [\"theta\"]\nvelocity = { theta = 0.5 }",
    );
    let m = Model::from_str("moving.toml", &text).unwrap();
    let sys = System::new(&m).unwrap();
    let s = assemble(&sys).unwrap();
    assert_eq!(s.v[2], 0.5);
    // equal bars: θ2 = π − θ1, so θ̇2 = −θ̇1; ẋ1 = −L/2 sinθ1 θ̇1
    assert!((s.v[5] + 0.5).abs() < 1e-12);
    assert!((s.v[0] + 2f64.sqrt() * (PI / 4.0).sin() * 0.5).abs() < 1e-12);
}

#[test]
fn overrides_accumulate() {
    let m = with(&[("L1", "2.5")]).unwrap();
    let m = m.with_overrides(&[("Fs".into(), "1".into())]).unwrap();
    assert_eq!(m.parameters.value("L1"), Some(2.5));
    assert_eq!(m.parameters.value("s"), Some(2.5));
    assert_eq!(m.parameters.value("Fs"), Some(1.0));
    assert_eq!(m.overrides.len(), 2);
}

#[test]
fn a_set_may_refer_to_the_parameters_own_value() {
    let m = with(&[("L1", "2*L1")]).unwrap();
    assert!((m.parameters.value("L1").unwrap() - 4.0 * 2f64.sqrt()).abs() < 1e-14);
    assert_eq!(m.parameters.value("s"), m.parameters.value("L1"));
}

#[test]
fn silent_wrong_answers_are_refused() {
    // a plain number with a non-SI declared unit
    let e = load_error(
        "L0 = { value = 2, unit = \"m\"",
        "L0 = { value = 2000, unit = \"mm\"",
    );
    assert!(e.contains("plain number") && e.contains("2000 mm"), "{e}");
    // sums of unlike quantities, functions of dimensioned quantities
    let e = load_error("free_length = \"L0\"", "free_length = \"2 m + 3 s\"");
    assert!(e.contains("adding or subtracting"), "{e}");
    let e = load_error("free_length = \"L0\"", "free_length = \"L0*cos(2 m)\"");
    assert!(e.contains("cos of a quantity in m"), "{e}");
    // a field that the type does not use
    let e = load_error(
        "type = \"revolute\"\nbody1 = \"bar1\"\npoint1 = [\"-L1/2\", 0]",
        "type = \"revolute\"\naxis = [1, 0]\nbody1 = \"bar1\"\npoint1 = [\"-L1/2\", 0]",
    );
    assert!(e.contains("`axis` is not a field of a `revolute`"), "{e}");
    // a point force on the ground
    let e = load_error(
        "body = \"bar1\"\npoint = [\"s - L1/2\", 0]",
        "body = \"ground\"\npoint = [\"s - L1/2\", 0]",
    );
    assert!(e.contains("acts on the ground"), "{e}");
}

#[test]
fn names_that_would_be_ambiguous_are_refused() {
    let e = load_error("name = \"J\"", "name = \"A\"");
    assert!(e.contains("two joints or constraints are named `A`"), "{e}");
    let e = load_error("name = \"bar2\"", "name = \"bar 2\"");
    assert!(e.contains("cannot name a body"), "{e}");
    let e = load_error(
        "g = { value = 9.81",
        "sin = { value = 1 }\ng = { value = 9.81",
    );
    assert!(e.contains("`sin` cannot name a parameter"), "{e}");
}

/// `[model] forcing_amplitude` names a parameter (located error otherwise) and needs a
/// forcing frequency; `frf --per-unit` is the response at that amplitude divided by it
/// (linear), and is refused with a hint on a model without it.
#[test]
fn forcing_amplitude_and_per_unit_response() {
    let text = common::overcentre_text();
    let bad = text.replace("forcing_amplitude = \"F0\"", "forcing_amplitude = \"F00\"");
    let err = detune::Model::from_str("bad.toml", &bad)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("`forcing_amplitude` names `F00`") && err.contains("bad.toml:"),
        "{err}"
    );
    let run = |args: &[&str]| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_detune"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(args)
            .output()
            .unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stdout).into_owned(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let amp = |out: &str| -> f64 {
        let j: serde_json::Value = serde_json::from_str(out).unwrap();
        j["points"][0]["stick.phi_amplitude"].as_f64().unwrap()
    };
    let grid = [
        "--param",
        "omega",
        "--from",
        "20",
        "--to",
        "20",
        "--step",
        "1",
        "--response",
        "stick.phi",
        "--json",
    ];
    let mut a = vec!["frf", "models/inceptor.toml", "--per-unit"];
    a.extend(grid);
    let (code, per_unit, err) = run(&a);
    assert_eq!(code, Some(0), "{err}");
    let mut b = vec!["frf", "models/inceptor.toml", "--set", "D0=7 mm"];
    b.extend(grid);
    let (_, at_7mm, _) = run(&b);
    assert!((amp(&per_unit) * 0.007 - amp(&at_7mm)).abs() < 1e-12 * amp(&at_7mm));
    let (code, _, err) = run(&[
        "frf",
        "tests/data/slider_crank.toml",
        "--per-unit",
        "--param",
        "omega",
        "--from",
        "1",
        "--to",
        "2",
        "--step",
        "1",
    ]);
    assert_eq!(code, Some(1));
    assert!(err.contains("forcing_amplitude"), "{err}");
}
