//! Messages about a model file that point at what is wrong (issue 10, point 7): initial
//! velocities the joints do not allow name the file, line, body and velocity; a misspelt
//! `type` is reported before the fields that type would not know; a misspelt velocity in a
//! load is suggested as a velocity; loads that read coordinates and velocities are
//! dimension-checked.

use detune::failure::{Failure, GivenVelocity};
use detune::{Model, System, assemble};
use std::process::Command;

/// A compound pendulum on a pivot with a torsion spring–damper and a torque
/// (tests/data/torsion_pendulum.toml).
const PENDULUM: &str = include_str!("data/torsion_pendulum.toml");

/// `text` with `from` replaced once by `to` (which must be there).
fn edit(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "`{from}` not in the model");
    text.replacen(from, to, 1)
}

/// 1-based line and column (characters) of the first `needle` in `text`, counted here.
fn line_col(text: &str, needle: &str) -> (usize, usize) {
    let at = text
        .find(needle)
        .unwrap_or_else(|| panic!("`{needle}` not in the text"));
    let before = &text[..at];
    let line = before.lines().count() + usize::from(before.ends_with('\n') || before.is_empty());
    let col = before.rsplit('\n').next().unwrap().chars().count() + 1;
    (line, col)
}

/// The rendered error of loading and compiling `text` as `bad.toml`.
fn load_error(text: &str) -> String {
    match Model::from_str("bad.toml", text).and_then(|m| System::new(&m)) {
        Ok(_) => panic!("the model loaded"),
        Err(e) => e.render(false),
    }
}

/// `detune <command> bad.toml <args>` on `text`: exit code and stderr.
fn run(command: &str, text: &str, args: &[&str]) -> (Option<i32>, String) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.toml"), text).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(dir.path())
        .arg(command)
        .arg("bad.toml")
        .args(args)
        .output()
        .unwrap();
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// The bar hangs from its end (θ = −π/2, the pivot at (−L/2, 0) in the bar's frame, i.e.
/// L/2 above the CG): with ω = θ̇ and the CG's ẋ given, the pivot moves along x at
/// ẋ − ω·L/2 (L = 0.8 m): 1 − 0.5·0.4 = 0.8 m/s, which no other velocity can cancel (ẏ,
/// the one solved for, moves the pivot along y).
#[test]
fn inconsistent_initial_velocities_name_the_body_the_velocity_and_where_it_is_given() {
    let text = edit(
        PENDULUM,
        "theta = \"-pi/2\"\n",
        "theta = \"-pi/2\"\nvelocity = { theta = 0.5, x = 1 }\n",
    );
    let sys = System::new(&Model::from_str("bad.toml", &text).unwrap()).unwrap();
    let e = assemble(&sys).expect_err("the velocities break the pivot");
    let Some(Failure::InconsistentVelocities {
        residual,
        constraint,
        given,
    }) = e.failure()
    else {
        panic!("{e:?}");
    };
    let (omega, half_length, xdot) = (0.5, 0.4, 1.0);
    assert!(
        (residual - (xdot - omega * half_length)).abs() < 1e-12,
        "{residual}"
    );
    assert_eq!(constraint, "pivot.x");
    assert_eq!(
        given,
        &Some(GivenVelocity {
            body: "bar".into(),
            velocity: "x".into(),
            value: 1.0,
        })
    );
    // located at the value of `x = 1` in the velocity table, as the loader's errors are
    let (line, col) = line_col(&text, "x = 1 }");
    let at = format!("bad.toml:{line}:{}: ", col + "x = ".len());
    let rendered = e.render(false);
    assert!(rendered.starts_with(&format!("error: {at}the initial velocities are inconsistent with the constraints (residual 8.000e-1 in `pivot.x`): body `bar`'s given velocity x = 1 breaks it")), "{rendered}");
    assert!(
        rendered.contains("velocity = { theta = 0.5, x = 1 }"),
        "{rendered}"
    );
    assert!(
        rendered.contains("remove `x` from body `bar`'s `velocity`"),
        "{rendered}"
    );
    // the command line says the same
    let (code, err) = run("simulate", &text, &["--t-end", "0.1", "-o", "out.csv"]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains(&at) && err.contains("body `bar`'s given velocity x = 1"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    // statics do not look at the initial velocities
    let (code, err) = run("equilibrium", &text, &[]);
    assert_eq!(code, Some(0), "{err}");
}

/// A misspelt `type` is the problem, not the fields of the type meant: the joint, force
/// and body families, planar and spatial; an unknown field elsewhere is still reported.
#[test]
fn an_unknown_type_is_reported_before_the_fields_it_would_not_know() {
    // (from, to: with a field the type does not know, message, help); the file's reading
    // stops at that field; without it the type is looked up among the loaded elements:
    // the same message either way
    let cases = [
        (
            "type = \"torsion\"\n",
            "type = \"torsionn\"\nstifness = 3\n",
            "unknown force type `torsionn`",
            "did you mean `torsion`?",
        ),
        (
            "type = \"revolute\"\n",
            "type = \"revolut\"\naxis3 = [1, 0]\n",
            "unknown joint type `revolut`",
            "did you mean `revolute`?",
        ),
        (
            "name = \"bar\"\n",
            "name = \"bar\"\ntype = \"planr\"\ncolour = \"red\"\n",
            "unknown body type `planr`",
            "did you mean `planar`?",
        ),
    ];
    let without_field = cases.map(|(from, to, m, h)| {
        let mut lines: Vec<&str> = to.lines().collect();
        lines.pop();
        (from, lines.join("\n") + "\n", m, h)
    });
    let cases = cases
        .map(|(from, to, m, h)| (from, to.to_string(), m, h))
        .into_iter()
        .chain(without_field);
    for (from, to, message, help) in cases {
        let text = edit(PENDULUM, from, &to);
        let bad = to.split('\n').find(|l| l.starts_with("type")).unwrap();
        let (line, col) = line_col(&text, bad);
        let value_col = col + "type = ".len();
        let err = load_error(&text);
        assert!(
            err.starts_with(&format!("error: bad.toml:{line}:{value_col}: {message}")),
            "{err}"
        );
        assert!(err.contains(help), "{err}");
        assert!(!err.contains("unknown field"), "{err}");
    }
    // a field no table knows, in another table, is still reported with the type
    let text = edit(
        &edit(
            PENDULUM,
            "type = \"torsion\"\n",
            "type = \"torsionn\"\nstifness = 3\n",
        ),
        "type = \"gravity\"\n",
        "type = \"gravity\"\nacceleratoin = 1\n",
    );
    let err = load_error(&text);
    assert!(err.contains("unknown force type `torsionn`"), "{err}");
    assert!(err.contains("unknown field `acceleratoin`"), "{err}");
    assert!(!err.contains("`stifness`"), "{err}");
    assert!(err.contains("2 problems in bad.toml"), "{err}");
    // spatial models have their own types (`spherical` is not a planar joint)
    let inceptor = include_str!("../models/inceptor.toml");
    let text = edit(
        inceptor,
        "type = \"revolute\"\n",
        "type = \"sphericl\"\nsocket = 1\n",
    );
    let err = load_error(&text);
    assert!(err.contains("unknown joint type `sphericl`"), "{err}");
    assert!(err.contains("did you mean `spherical`?"), "{err}");
    assert!(!err.contains("socket"), "{err}");
}

/// In a load, velocities are names too: a misspelt one is suggested as itself.
#[test]
fn a_misspelt_velocity_in_a_load_is_suggested_as_a_velocity() {
    let text = edit(PENDULUM, "torque = \"T\"", "torque = \"T*bar.theta_dto\"");
    let err = load_error(&text);
    let (line, col) = line_col(&text, "bar.theta_dto");
    assert!(
        err.starts_with(&format!(
            "error: bad.toml:{line}:{col}: unknown coordinate `bar.theta_dto`"
        )),
        "{err}"
    );
    assert!(err.contains("did you mean `bar.theta_dot`?"), "{err}");
    // where velocities may not be read, the coordinate is the suggestion
    let text = format!("{PENDULUM}\n[[constraints]]\nexpr = \"bar.thetaa\"\n");
    let err = load_error(&text);
    assert!(err.contains("did you mean `bar.theta`?"), "{err}");
}

/// A velocity asked for by a name the body does not have (`bar.vx`, `bar.omega`): not
/// "did you mean `bar.x`?" (a position) but how velocities are named and the body's own;
/// a free body's velocities are `<body>.vx` ... `<body>.wz` (docs/model-format.md).
#[test]
fn a_velocity_by_another_name_is_told_how_velocities_are_named() {
    for wrong in ["bar.vx", "bar.omega", "bar.w"] {
        let text = edit(
            PENDULUM,
            "torque = \"T\"",
            &format!("torque = \"T - 0.1*{wrong}\""),
        );
        let err = load_error(&text);
        let (line, col) = line_col(&text, wrong);
        assert!(
            err.starts_with(&format!(
                "error: bad.toml:{line}:{col}: unknown coordinate `{wrong}`"
            )),
            "{err}"
        );
        assert!(
            err.contains(
                "forces may use velocities as NAME_dot: bar.x_dot, bar.y_dot, bar.theta_dot"
            ) && err.contains("the coordinates of `bar` are bar.x, bar.y, bar.theta"),
            "{err}"
        );
        assert!(!err.contains("did you mean"), "{err}");
    }
    // a near miss of a velocity keeps its suggestion
    let text = edit(
        PENDULUM,
        "torque = \"T\"",
        "torque = \"T - 0.1*bar.thetadot\"",
    );
    assert!(load_error(&text).contains("`bar.theta_dot`?"));
    // a free body (spatial): its velocities by their own names
    let free = r#"
[[bodies]]
name = "top"
rotation = "free"
mass = 1
inertia = [0.004, 0.004, 0.006]

[[forces]]
name = "drag"
type = "point_force"
body = "top"
force = ["-0.1*top.omega", 0, 0]
"#;
    let err = load_error(free);
    assert!(err.contains("unknown coordinate `top.omega`"), "{err}");
    assert!(
        err.contains("forces may use a free body's velocities as `top.vx` ... `top.wz`: top.vx, top.vy, top.vz, top.wx, top.wy, top.wz"),
        "{err}"
    );
    // a velocity that loads: the same force with `top.vx`
    let ok = free.replace("top.omega", "top.vx");
    Model::from_str("ok.toml", &ok)
        .and_then(|m| System::new(&m))
        .unwrap();
}

/// Coordinates and velocities carry their dimensions in a load: x, y in m, θ in rad
/// (none), their rates per second, in an expression that has a dimension of its own (a
/// quantity or a parameter with a unit). A wrong product is refused where it is written;
/// the right one (a damping torque −c·θ̇, c in N·m·s/rad) loads, and so does one whose
/// coefficients are plain (SI) numbers.
#[test]
fn loads_with_coordinates_and_velocities_are_dimension_checked() {
    let refused = [
        (
            "torque = \"T\"",
            "torque = \"T*bar.theta_dot\"",
            "a torque is a quantity in N·m; this value is in W",
        ),
        (
            "torque = \"T\"",
            "torque = \"m*g*bar.y*bar.y\"",
            "a torque is a quantity in N·m; this value is in kg·m^3·s^-2",
        ),
        (
            "torque = \"T\"",
            "torque = \"T + m*g*bar.theta\"",
            "adding or subtracting quantities in N·m and N",
        ),
    ];
    for (from, to, message) in refused {
        let text = edit(PENDULUM, from, to);
        let err = load_error(&text);
        let (line, _) = line_col(&text, &to["torque = ".len()..]);
        assert!(
            err.contains(&format!("bad.toml:{line}:")) && err.contains(message),
            "{to}: {err}"
        );
    }
    // a point force: F·θ (N) is a force, F·x (N·m) is not
    let force = "\n[[forces]]\nname = \"push\"\ntype = \"point_force\"\nbody = \"bar\"\nforce = [\"FORCE\", 0]\n";
    let with = |f: &str| format!("{PENDULUM}{}", force.replace("FORCE", f));
    let err = load_error(&with("m*g*bar.x"));
    assert!(
        err.contains("a force is a quantity in N; this value is in N·m"),
        "{err}"
    );
    for ok in [
        "-c*bar.theta_dot",
        "-k*(bar.theta + pi/2) + T",
        "m*g*L/2*sin(bar.theta)",
        // without a unit of its own, a plain-number coefficient is SI: N·m·s/rad here
        "-0.4*bar.theta_dot - 12*(bar.theta + pi/2)",
    ] {
        let text = edit(PENDULUM, "torque = \"T\"", &format!("torque = \"{ok}\""));
        let sys = Model::from_str("ok.toml", &text).and_then(|m| System::new(&m));
        assert!(sys.is_ok(), "{ok}: {}", sys.err().unwrap());
    }
    for ok in ["m*g*bar.theta", "-k*bar.theta/L", "m*bar.y_dot/(1 s)"] {
        let sys = Model::from_str("ok.toml", &with(ok)).and_then(|m| System::new(&m));
        assert!(sys.is_ok(), "{ok}: {}", sys.err().unwrap());
    }
}
