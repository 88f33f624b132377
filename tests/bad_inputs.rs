//! A catalogue of bad inputs: each gives a located message with a hint, a non-zero exit,
//! no panic, and no output file.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;

use common::overcentre_text as shipped;

struct Outcome {
    code: Option<i32>,
    stderr: String,
    output_exists: bool,
    dir: tempfile::TempDir,
}

/// Run `detune simulate` on `text` written to `bad.toml`, with extra arguments (and
/// `--t-end 3` unless they give one).
fn simulate(text: &str, extra: &[&str]) -> Outcome {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("bad.toml");
    std::fs::write(&model, text).unwrap();
    let out: PathBuf = dir.path().join("out.csv");
    let o = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(dir.path())
        .args(["simulate", "bad.toml", "-o", "out.csv", "--plot", "out.svg"])
        .args(if extra.contains(&"--t-end") {
            &[][..]
        } else {
            &["--t-end", "3"][..]
        })
        .args(extra)
        .output()
        .unwrap();
    Outcome {
        code: o.status.code(),
        stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
        output_exists: out.exists() || dir.path().join("out.svg").exists(),
        dir,
    }
}

/// The common promises: non-zero exit, no panic, no output, a help line, and the message.
fn assert_clean_failure(o: &Outcome, message: &str) {
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
        "no hint in:\n{}",
        o.stderr
    );
    // no temporary files left behind either
    let left: Vec<_> = std::fs::read_dir(o.dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left.len(), 1, "files left: {left:?}");
}

/// `bad.toml:LINE:COL` of the first occurrence of `needle` in `text` (plus `offset` chars).
fn location(text: &str, needle: &str, offset: usize) -> String {
    let at = text.find(needle).expect("needle in text") + offset;
    let line = text[..at].matches('\n').count() + 1;
    let col = at - text[..at].rfind('\n').map_or(0, |i| i + 1) + 1;
    format!("bad.toml:{line}:{col}")
}

fn replaced(from: &str, to: &str) -> String {
    let s = shipped();
    assert!(s.contains(from), "`{from}` not in the shipped model");
    s.replacen(from, to, 1)
}

#[test]
fn toml_syntax_error() {
    let text = replaced("[parameters]", "[parameters");
    let o = simulate(&text, &[]);
    // the unclosed header: reported where the `]` is missing
    assert_clean_failure(&o, &location(&text, "[parameters", 11));
}

#[test]
fn unknown_parameter_in_expression() {
    let text = replaced("inertia = \"m1*L1^2/12\"", "inertia = \"m1*Lx^2/12\"");
    let o = simulate(&text, &[]);
    assert_clean_failure(&o, "unknown parameter `Lx`");
    assert!(
        o.stderr.contains(&location(&text, "Lx^2", 0)),
        "{}",
        o.stderr
    );
}

#[test]
fn unknown_body_in_joint_and_expression() {
    let text = replaced("body1 = \"bar2\"", "body1 = \"bar3\"");
    let o = simulate(&text, &[]);
    assert_clean_failure(&o, "unknown body `bar3`");
    assert!(
        o.stderr.contains(&location(&text, "\"bar3\"", 0)),
        "{}",
        o.stderr
    );

    let text = shipped() + "\n[[constraints]]\nexpr = \"bar9.x - 1\"\n";
    let o = simulate(&text, &[]);
    assert_clean_failure(&o, "unknown body `bar9`");
    assert!(
        o.stderr.contains(&location(&text, "bar9.x", 0)),
        "{}",
        o.stderr
    );
}

#[test]
fn unknown_coordinate_in_expression() {
    let text = shipped() + "\n[[constraints]]\nexpr = \"bar1.phi - 1\"\n";
    let o = simulate(&text, &[]);
    assert_clean_failure(&o, "unknown coordinate `bar1.phi`");
    assert!(
        o.stderr.contains(&location(&text, "bar1.phi", 0)),
        "{}",
        o.stderr
    );
}

#[test]
fn unit_of_the_wrong_dimension() {
    let text = replaced("mass = \"m1\"", "mass = \"3 mm\"");
    let o = simulate(&text, &[]);
    assert_clean_failure(&o, "mass");
    assert!(
        o.stderr.contains(&location(&text, "\"3 mm\"", 0)),
        "{}",
        o.stderr
    );

    // a --set value whose unit differs from the parameter's declared unit
    let o = simulate(&shipped(), &["--set", "k=3 mm"]);
    assert_clean_failure(&o, "--set k=3 mm");
}

#[test]
fn unknown_unit() {
    let text = replaced(
        "value = 50, unit = \"N/m\"",
        "value = \"50 N/mmm\", unit = \"N/m\"",
    );
    let o = simulate(&text, &[]);
    assert_clean_failure(&o, "mmm");
    assert!(
        o.stderr.contains(&location(&text, "mmm", 0)),
        "{}",
        o.stderr
    );
}

#[test]
fn negative_or_zero_mass() {
    let text = replaced("m1 = { value = 1,", "m1 = { value = -1,");
    let o = simulate(&text, &[]);
    assert_clean_failure(&o, "must be positive");
    assert!(
        o.stderr.contains(&location(&text, "mass = \"m1\"", 7)),
        "{}",
        o.stderr
    );

    let o = simulate(&shipped(), &["--set", "m2=0"]);
    assert_clean_failure(&o, "must be positive");
}

#[test]
fn negative_free_length() {
    let o = simulate(&shipped(), &["--set", "L0=-2"]);
    assert_clean_failure(&o, "the free length must be zero or positive, it is -2 m");
    assert!(o.stderr.contains("bad.toml:"), "{}", o.stderr);
}

#[test]
fn parameter_cycle() {
    let text = replaced("L0 = { value = 2,", "L0 = { value = \"s\",").replacen(
        "value = \"L1\"",
        "value = \"L0\"",
        1,
    );
    let o = simulate(&text, &[]);
    assert_clean_failure(&o, "parameter cycle: L0 → s → L0");
    // located at the value of the first parameter of the cycle
    let at = location(&text, "L0 = { value = \"s\"", 15);
    assert!(o.stderr.contains(&at), "{at} in {}", o.stderr);
}

#[test]
fn pose_that_cannot_be_assembled() {
    // L1 sin θ1 = 2 > L2: bar 2 cannot reach the ground line.
    let o = simulate(&shipped(), &["--set", "L2=1.5"]);
    assert_clean_failure(&o, "cannot be assembled");
}

#[test]
fn nan_during_integration() {
    let text = replaced("\"Fs + F0*sin(omega*t)\"", "\"sqrt(1 - t)\"");
    let o = simulate(&text, &[]);
    assert_clean_failure(&o, "non-finite");
    assert!(
        o.stderr.contains("t = 1.0") || o.stderr.contains("t = 0.99"),
        "{}",
        o.stderr
    );
}

#[test]
fn unknown_parameter_in_set() {
    let o = simulate(&shipped(), &["--set", "FS=3"]);
    assert_clean_failure(&o, "no parameter `FS`");
    assert!(o.stderr.contains("did you mean `Fs`"), "{}", o.stderr);
}

#[test]
fn missing_model_file() {
    let dir = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(dir.path())
        .args(["simulate", "nope.toml", "-o", "out.csv"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("nope.toml"));
    assert!(!Path::new(&dir.path().join("out.csv")).exists());
}

#[test]
fn parameter_that_is_not_a_finite_number() {
    // Used by the model (the spring's free length): refused where it is used, quoting its
    // definition.
    let text = replaced(
        "L0 = { value = 2,",
        "L0 = { value = \"L1/(k/(50 N/m) - 1)\",",
    );
    let o = simulate(&text, &[]);
    assert_clean_failure(&o, "`L0` evaluates to inf (L0 = \"L1/(k/(50 N/m) - 1)\")");
    assert!(
        o.stderr
            .contains(&location(&text, "free_length = \"L0\"", 15)),
        "{}",
        o.stderr
    );
    // From --set: named with the value given.
    for (set, what) in [("Fs=0/0", "NaN"), ("Fs=sqrt(-1)", "NaN"), ("Fs=1/0", "inf")] {
        let o = simulate(&shipped(), &["--set", set]);
        assert_clean_failure(&o, &format!("`Fs` evaluates to {what} (--set {set})"));
    }
    // Not used by the model: may stay undefined (a period 2π/ω at the model's ω = 0).
    let text = replaced(
        "L0 = { value = 2,",
        "T = { value = \"2*pi/omega\", unit = \"s\" }\nL0 = { value = 2,",
    );
    let o = simulate(&text, &[]);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
}

#[test]
fn nan_from_the_first_evaluation_is_reported_not_hung_on() {
    // Undefined already at t = 0: the first right-hand side (the integrator's initial
    // step-size estimate) meets it. nalgebra's SVD never returns on NaN, so this once hung.
    let text = replaced("\"Fs + F0*sin(omega*t)\"", "\"sqrt(-1 - t)\"");
    let o = simulate(&text, &[]);
    assert_clean_failure(&o, "non-finite");
    assert!(o.stderr.contains("t = 0.000000"), "{}", o.stderr);
}

#[test]
fn a_run_that_cannot_keep_the_constraints_is_refused() {
    // --atol 1: steps so large that the projection cannot bring the state back.
    let o = simulate(&shipped(), &["--atol", "1", "--t-end", "20"]);
    assert_clean_failure(&o, "constraints could not be kept");
}

#[test]
fn outputs_that_cannot_be_written_are_refused_before_the_run() {
    // A missing directory for the last of three outputs: nothing at all is written.
    let o = simulate(&shipped(), &["--json", "nodir/out.json"]);
    assert_clean_failure(&o, "the directory nodir does not exist");
    // An output over the model file, or two outputs on one path.
    let o = simulate(&shipped(), &["--json", "bad.toml"]);
    assert_clean_failure(&o, "would overwrite the model file");
    let o = simulate(&shipped(), &["--json", "./out.csv"]);
    assert_clean_failure(&o, "the same file as the output out.csv");
}

#[test]
fn one_mistake_gives_one_message() {
    // L1 fails to parse; `s = L1` and the bodies that use L1 must not add "unknown
    // parameter `L1`" messages after the real one.
    let text = replaced("\"2*sqrt(2)\"", "\"2*sqrtt(2)\"");
    let o = simulate(&text, &[]);
    assert_clean_failure(&o, "unknown function `sqrtt`");
    assert!(o.stderr.contains("did you mean `sqrt`"), "{}", o.stderr);
    assert!(!o.stderr.contains("unknown parameter"), "{}", o.stderr);
    assert_eq!(o.stderr.matches("error:").count(), 1, "{}", o.stderr);
}

/// Issue 13 point 4: a load whose scale overflows (g = 1e308: the weight is infinite)
/// accepted any residual as converged and printed a pose with residual 4.3e307 as an
/// equilibrium, exit 0. Now refused, and the statics' commands fail cleanly.
#[test]
fn an_overflowing_load_is_no_equilibrium() {
    for cmd in ["equilibrium", "modes"] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_detune"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args([cmd, "models/overcentre.toml", "--set", "g=1e308"])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{cmd}: {err}");
        assert!(err.contains("the loads overflow"), "{cmd}: {err}");
        assert!(!String::from_utf8_lossy(&out.stdout).contains("residual"));
    }
}

/// Issue 12's bad input: a nonlinear element's nonsense parameters are located errors
/// (file:line:column) saying what to do, also when a `--set` makes them so: an end stop
/// whose lower limit is not below its upper one, a negative breakout preload, a zero
/// smoothing width, a negative backlash gap.
#[test]
fn nonlinear_elements_with_nonsense_parameters() {
    let with = |force: &str| -> String {
        format!(
            "{}\n[[forces]]\nname = \"e\"\nbody1 = \"bar1\"\n{force}\n",
            shipped()
        )
    };
    for (force, needle, offset, message) in [
        (
            "type = \"torsion_end_stop\"\nstiffness = 1e3\nlower = 0.9\nupper = 0.7",
            "lower = 0.9",
            8,
            "the lower limit of `e` must be below the upper limit: it is 0.9 rad, the upper limit 0.7 rad",
        ),
        (
            "type = \"torsion_end_stop\"\nstiffness = 1e3\nlower = 0.7\nupper = 0.7",
            "lower = 0.7",
            8,
            "the lower limit of `e` must be below the upper limit: it is 0.7 rad",
        ),
        (
            "type = \"breakout\"\nstiffness = 403\npreload = -5.5\nstiffness2 = 250",
            "preload = -5.5",
            10,
            "the preload of `e` must be positive",
        ),
        (
            "type = \"torsion_end_stop\"\nstiffness = 1e3\nupper = 1.2\nsmoothing = 0",
            "smoothing = 0",
            12,
            "the smoothing of `e` must be positive",
        ),
        (
            "type = \"torsion_backlash\"\nstiffness = 10\ngap = -0.01",
            "gap = -0.01",
            6,
            "the gap of `e` must be positive",
        ),
    ] {
        let text = with(force);
        let o = simulate(&text, &[]);
        assert_clean_failure(&o, message);
        let at = location(&text, needle, offset);
        assert!(o.stderr.contains(&at), "{at} in {}", o.stderr);
    }
    // a parameter that makes the limits cross only with --set: said, with the --set
    let text = with(
        "type = \"torsion_end_stop\"\nstiffness = 1e3\nlower = \"theta1_0 - 0.5\"\nupper = 1.2",
    );
    let o = simulate(&text, &["--set", "theta1_0=1.8"]);
    assert_clean_failure(
        &o,
        "the lower limit of `e` must be below the upper limit: it is 1.3 rad, the upper limit 1.2 rad (with --set theta1_0=1.8)",
    );
    assert!(
        o.stderr.contains("swap them if they are reversed"),
        "{}",
        o.stderr
    );
    assert!(o.stderr.contains(&location(&text, "\"theta1_0 - 0.5\"", 0)));
}
