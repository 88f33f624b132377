//! Bad input to spatial models (issue 9): each is a clear error at the file, line and
//! column of its cause, with a hint, a non-zero exit, no panic and no output file. The
//! cases mutate the shipped inceptor model.

use std::process::Command;

const SHIPPED: &str = include_str!("../models/inceptor.toml");

struct Outcome {
    code: Option<i32>,
    stderr: String,
    output_exists: bool,
}

/// `detune simulate bad.toml -o out.csv` on the shipped model with `from` replaced by `to`.
fn run(from: &str, to: &str) -> (String, Outcome) {
    assert!(SHIPPED.contains(from), "`{from}` not in the shipped model");
    let text = SHIPPED.replacen(from, to, 1);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.toml"), &text).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(dir.path())
        .args(["simulate", "bad.toml", "-o", "out.csv", "--t-end", "0.1"])
        .output()
        .unwrap();
    let outcome = Outcome {
        code: o.status.code(),
        stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
        output_exists: dir.path().join("out.csv").exists(),
    };
    (text, outcome)
}

/// `bad.toml:LINE:COL` of the first occurrence of `needle` in `text` (plus `offset`).
fn location(text: &str, needle: &str, offset: usize) -> String {
    let at = text.find(needle).expect("needle in text") + offset;
    let line = text[..at].matches('\n').count() + 1;
    let col = at - text[..at].rfind('\n').map_or(0, |i| i + 1) + 1;
    format!("bad.toml:{line}:{col}")
}

/// The promises, and the message at the location of `needle`.
fn assert_located(text: &str, o: &Outcome, message: &str, needle: &str) {
    assert_located_at(text, o, message, needle, 0)
}

fn assert_located_at(text: &str, o: &Outcome, message: &str, needle: &str, offset: usize) {
    assert_eq!(o.code, Some(1), "exit code; stderr:\n{}", o.stderr);
    assert!(!o.stderr.contains("panicked"), "{}", o.stderr);
    assert!(!o.output_exists, "an output file was written");
    assert!(
        o.stderr.contains(message),
        "expected `{message}` in:\n{}",
        o.stderr
    );
    assert!(
        o.stderr.to_lowercase().contains("help"),
        "no hint:\n{}",
        o.stderr
    );
    let at = location(text, needle, offset);
    assert!(o.stderr.contains(&at), "expected {at} in:\n{}", o.stderr);
}

#[test]
fn unknown_rotation_axis() {
    let (t, o) = run(
        r#"rotation = [["z", "phi"]]"#,
        r#"rotation = [["w", "phi"]]"#,
    );
    assert_located(&t, &o, "unknown rotation axis `w`", r#"[["w""#);
}

#[test]
fn repeated_angle_name() {
    let (t, o) = run(r#"["x", "beta"]"#, r#"["x", "alpha"]"#);
    assert_located(
        &t,
        &o,
        "the angle `alpha` of `rod` is named twice",
        r#"[["z", "alpha"], ["x", "alpha"]]"#,
    );
}

#[test]
fn negative_principal_inertia() {
    let (t, o) = run(
        "inertia = [0.003, 0.098, 0.098]",
        "inertia = [0.003, -0.098, 0.098]",
    );
    assert_located(
        &t,
        &o,
        "the inertia Iyy of `stick` must be zero or positive",
        "-0.098",
    );
}

#[test]
fn no_inertia_about_the_axis_the_body_turns_about() {
    // a zero principal value is allowed only about an axis the body cannot turn about (the
    // rod's Iyy = 0 is): the stick turns about z
    let (t, o) = run(
        "inertia = [0.003, 0.098, 0.098]",
        "inertia = [0.003, 0.098, 0]",
    );
    assert_located(
        &t,
        &o,
        "body `stick` has no inertia about an axis its angles turn about",
        "[0.003, 0.098, 0]",
    );
}

#[test]
fn triangle_inequality_of_a_body_turning_about_every_axis() {
    let (t, o) = run(
        "rotation = [[\"z\", \"alpha\"], [\"x\", \"beta\"]]\nmass = \"m2\"\ninertia = [\"m2*l2^2/12\", 0, \"m2*l2^2/12\"]",
        "rotation = [[\"z\", \"alpha\"], [\"x\", \"beta\"], [\"y\", \"gamma\"]]\nmass = \"m2\"\ninertia = [1e-4, 1e-4, 3e-4]",
    );
    assert_located(
        &t,
        &o,
        "violates the triangle inequality",
        "[1e-4, 1e-4, 3e-4]",
    );
}

#[test]
fn joint_axis_of_zero_length() {
    let (t, o) = run("axis = [0, 0, 1]", "axis = [0, 0, 0]");
    // at its components (from the first)
    assert_located_at(
        &t,
        &o,
        "the axis of joint `J1` is zero",
        "[0, 0, 0]\n\n[[joints]]\nname = \"J2\"",
        1,
    );
}

#[test]
fn joint_between_a_body_and_itself() {
    let (t, o) = run(
        "point1 = [0.05, -0.11, 0.0]\nbody2 = \"rod\"",
        "point1 = [0.05, -0.11, 0.0]\nbody2 = \"stick\"",
    );
    assert_located(
        &t,
        &o,
        "joint `J2` connects a body to itself",
        "[[joints]]\nname = \"J2\"",
    );
}

#[test]
fn trim_holding_an_unknown_coordinate() {
    let (t, o) = run(r#"hold = ["stick.phi"]"#, r#"hold = ["stick.psi"]"#);
    assert_located(
        &t,
        &o,
        "`[trim] hold` names `stick.psi`, which is not a coordinate",
        "\"stick.psi\"",
    );
    assert!(
        o.stderr.contains("`stick.phi`"),
        "a suggestion:\n{}",
        o.stderr
    );
}

#[test]
fn trim_with_more_unknowns_than_conditions() {
    let (t, o) = run(r#"solve = ["L0"]"#, r#"solve = ["L0", "k_fs"]"#);
    assert_located(
        &t,
        &o,
        "solves 2 parameter(s) for 1 held coordinate(s)",
        "[trim]\nsolve",
    );
}

#[test]
fn ground_motion_that_is_not_a_function_of_time_alone() {
    let (t, o) = run(
        r#"motion = { x = "D0*sin(omega*t)" }"#,
        r#"motion = { x = "D0*sin(omega*t) + stick.phi" }"#,
    );
    assert_located(
        &t,
        &o,
        "`stick.phi` is a coordinate; this value may depend only on time `t`",
        "stick.phi\" }",
    );
}

#[test]
fn a_planar_body_in_a_spatial_model() {
    let (t, o) = run(
        "rotation = [[\"x\", \"theta\"]]\nmass = \"m4*gearbox_scale\"",
        "mass = \"m4*gearbox_scale\"",
    );
    assert_located(
        &t,
        &o,
        "body `gearbox` has no `rotation` in a spatial model",
        "\"gearbox\"",
    );
}

/// A trim whose parameter cannot balance the held pose (the shaft stiffness does not
/// act on the stick at rest): a clear failure, not a wrong answer.
#[test]
fn an_unsolvable_trim() {
    let text = SHIPPED
        .replacen(r#"solve = ["L0"]"#, r#"solve = ["k_t"]"#, 1)
        .replacen("value = 0.10311528080383249", "value = 0.103", 1);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.toml"), &text).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(dir.path())
        .args(["equilibrium", "bad.toml"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("the trim does not converge: no value of k_t"),
        "{err}"
    );
    assert!(err.contains("help"), "{err}");
}

/// Mistakes in a spatial body's mass, inertia or CG (an unknown name, a wrong unit, a
/// coordinate where a constant is needed): located errors, never a crash (the joints and
/// forces that refer to the body are still read).
#[test]
fn mistakes_in_a_spatial_bodys_mass_inertia_and_cg() {
    let (t, o) = run("mass = \"m1\"", "mass = \"m9\"");
    assert_located(&t, &o, "unknown parameter `m9`", "m9");
    let (t, o) = run(
        "inertia = [0.003, 0.098, 0.098]",
        "inertia = [\"0.003 kg\", 0.098, 0.098]",
    );
    assert_located(
        &t,
        &o,
        "the inertia Ixx of `stick` is a quantity in kg·m^2",
        "\"0.003 kg\"",
    );
    let (t, o) = run(
        "inertia = [0.003, 0.098, 0.098]",
        "inertia = [\"stick.phi\", 0.098, 0.098]",
    );
    assert_located(
        &t,
        &o,
        "`stick.phi` is a coordinate; this value must be constant",
        "stick.phi\", 0.098",
    );
    let (t, o) = run("cg = [0.36, 0.014, 0.0]", "cg = [\"q\", 0.014, 0.0]");
    assert_located(&t, &o, "unknown parameter `q`", "q\", 0.014");
}

/// A name is one thing across bodies, joints and forces (responses name them).
#[test]
fn a_force_named_like_a_body_or_another_force() {
    let (t, o) = run("name = \"shaft\"", "name = \"crank\"");
    assert_located(
        &t,
        &o,
        "the force `crank` has the name of a body",
        "[[forces]]\nname = \"crank\"",
    );
    let (t, o) = run("name = \"damper\"", "name = \"sensor\"");
    assert_located(
        &t,
        &o,
        "the force `sensor` has the name of another force",
        "[[forces]]\nname = \"sensor\"\ntype = \"torsion\"",
    );
}

/// A velocity in a constraint is refused where it is written (loads may read them).
#[test]
fn a_velocity_in_a_constraint() {
    let (t, o) = run(
        "[[forces]]\nname = \"gravity\"",
        "[[constraints]]\nexpr = \"crank.delta_dot\"\n\n[[forces]]\nname = \"gravity\"",
    );
    assert_located(
        &t,
        &o,
        "`crank.delta_dot` is a velocity; this value cannot depend on velocities",
        "crank.delta_dot",
    );
}

/// A spatial torque given as one value (the planar form) is refused where it is written.
#[test]
fn a_spatial_torque_of_one_value() {
    let (t, o) = run(
        "[[forces]]\nname = \"gravity\"",
        "[[forces]]\nname = \"motor\"\ntype = \"torque\"\nbody = \"crank\"\ntorque = \"2\"\n\n[[forces]]\nname = \"gravity\"",
    );
    assert_located(&t, &o, "a spatial torque has three components", "\"2\"\n");
}
