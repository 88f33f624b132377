//! Hostile inputs (issue 13, defects 1, 2, 4 and 6): parameters at the edge of double
//! precision, expressions of 20,000 terms or 100,000 levels, steps that cannot move.
//! Each runs the built binary under a 20 s limit (a hang fails the test instead of
//! blocking the suite) and asserts the exit code, that stderr names the cause, and that
//! no output file is left behind.

use std::path::Path;

mod common;

struct Outcome {
    code: Option<i32>,
    stdout: String,
    stderr: String,
    dir: tempfile::TempDir,
}

impl Outcome {
    fn left(&self, name: &str) -> bool {
        self.dir.path().join(name).exists()
    }
}

/// Run `detune ARGS` in a fresh directory holding the overcentre as `oc.toml`, the
/// inceptor as `inc.toml` and `extra` files; kill it and fail after 20 s.
fn run(args: &[&str], extra: &[(&str, &str)]) -> Outcome {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("oc.toml"), common::overcentre_text()).unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(
        root.join("models/inceptor.toml"),
        dir.path().join("inc.toml"),
    )
    .unwrap();
    for (name, text) in extra {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let (code, stdout, stderr) = common::run_within_20s(dir.path(), args);
    Outcome {
        code,
        stdout,
        stderr,
        dir,
    }
}

/// Exit 1 (an error, not a crash or a signal), stderr containing every one of `needles`,
/// and no `out.csv`.
fn refused(o: &Outcome, needles: &[&str]) {
    assert_eq!(o.code, Some(1), "stderr: {}", o.stderr);
    for n in needles {
        assert!(o.stderr.contains(n), "`{n}` not in: {}", o.stderr);
    }
    assert!(!o.left("out.csv"), "an output file was left");
    assert!(!o.stderr.contains("panicked"), "{}", o.stderr);
}

// Defect 1: non-finite input to a decomposition (formerly a hang or a panic).

#[test]
fn huge_force_does_not_hang_any_analysis() {
    for cmd in ["equilibrium", "modes"] {
        for set in ["Fs=1e308", "Fs=-1e308"] {
            let o = run(&[cmd, "oc.toml", "--set", set], &[]);
            refused(&o, &["error:"]);
        }
    }
    let o = run(
        &[
            "frf", "oc.toml", "--set", "Fs=1e308", "--param", "omega", "--from", "1", "--to", "3",
            "--step", "1", "-o", "out.csv",
        ],
        &[],
    );
    refused(&o, &["error:"]);
}

#[test]
fn huge_stiffness_is_refused() {
    for set in ["k=1e308", "k=-1e308"] {
        let o = run(&["equilibrium", "oc.toml", "--set", set], &[]);
        refused(
            &o,
            &[
                "the equilibrium equations overflow",
                set.replace('=', " = ").as_str(),
            ],
        );
    }
}

/// An overflow from finite inputs (a force or stiffness of ±1e308) is said to be one,
/// naming the parameter, not "undefined (NaN) … sqrt or ln of a negative number" nor, in
/// a simulation, "a singular pose".
#[test]
fn an_overflow_is_called_an_overflow_and_names_the_huge_parameter() {
    for (cmd, set, name) in [
        ("modes", "Fs=1e308", "Fs = 1e308"),
        ("equilibrium", "Fs=-1e308", "Fs = -1e308"),
        ("modes", "k=-1e308", "k = -1e308"),
    ] {
        let o = run(&[cmd, "oc.toml", "--set", set], &[]);
        refused(
            &o,
            &[
                "the equilibrium equations overflow",
                &format!("{name} is too large for double precision"),
                "give `",
            ],
        );
        for wrong in ["NaN", "sqrt", "division by zero"] {
            assert!(!o.stderr.contains(wrong), "{}", o.stderr);
        }
    }
    let o = run(
        &[
            "sweep", "oc.toml", "--set", "k=1e308", "--param", "omega", "--from", "1", "--to", "2",
            "--step", "1", "-o", "out.csv",
        ],
        &[],
    );
    refused(&o, &["the equilibrium equations overflow", "k = 1e308"]);
    let o = run(
        &["simulate", "oc.toml", "--set", "Fs=1e300", "-o", "out.csv"],
        &[],
    );
    refused(
        &o,
        &[
            "the equations of motion overflow at t = 0.000000 s",
            "Fs = 1e300 is too large for double precision",
        ],
    );
    assert!(!o.stderr.contains("singular pose"), "{}", o.stderr);
}

#[test]
fn overflowing_gravity_is_the_loads_overflow() {
    let o = run(&["equilibrium", "oc.toml", "--set", "g=1e308"], &[]);
    refused(&o, &["the loads overflow", "1.8e308"]);
}

/// The inceptor's rotary damper at 1e160 N·m·s/rad: nalgebra's SVD used to panic on its
/// NaN singular values ("Singular value was NaN", exit 101).
#[test]
fn huge_damper_on_the_inceptor_does_not_panic() {
    let o = run(&["modes", "inc.toml", "--set", "c_d=1e160"], &[]);
    assert_eq!(o.code, Some(1), "{}", o.stderr);
    assert!(!o.stderr.contains("panicked"), "{}", o.stderr);
}

// Defect 4: no non-finite result reported as a success.

/// The inceptor's damper at 1e160: λ² M + λ C + K overflows for its overdamped mode
/// (λ ≈ -1.1e160 1/s), whose shape was written as null (NaN) to the report's JSON.
#[test]
fn report_with_an_overflowing_mode_shape_is_refused() {
    let o = run(
        &["report", "inc.toml", "--set", "c_d=1e160", "-o", "r.html"],
        &[],
    );
    assert_eq!(o.code, Some(1), "{}", o.stderr);
    assert!(
        o.stderr
            .contains("the shape of the mode at λ = -1.111111e160 1/s"),
        "{}",
        o.stderr
    );
    assert!(!o.left("r.html") && !o.left("r.json"));
}

/// c = 1e160: c² overflows in the state matrix's eigenvalues, which were printed as NaN
/// frequencies with exit 0.
#[test]
fn huge_damping_gives_no_nan_frequencies() {
    let o = run(&["modes", "oc.toml", "--set", "c=1e160", "--json"], &[]);
    refused(&o, &["not finite", "double precision"]);
    assert!(!o.stdout.contains("NaN") && !o.stdout.contains("null"));
}

/// ω² M overflows above ω ≈ 1.3e154 rad/s: the frf wrote NaN rows.
#[test]
fn frf_above_1e154_writes_no_nan_rows() {
    let o = run(
        &[
            "frf", "oc.toml", "--set", "F0=1", "--param", "omega", "--from", "1e154", "--to",
            "1e160", "--step", "1e159", "-o", "out.csv",
        ],
        &[],
    );
    refused(
        &o,
        &["dynamic stiffness", "is not finite", "1.00001e159 rad/s"],
    );
}

// Defect 2: expressions that overflowed the stack (SIGABRT, exit 134).

#[test]
fn sum_of_20000_terms_via_set_is_a_located_error() {
    let sum = format!("Fs={}", vec!["1"; 20_000].join("+"));
    let o = run(&["equilibrium", "oc.toml", "--set", &sum], &[]);
    refused(&o, &["longer than 2000 tokens"]);
    let product = format!("Fs={}", vec!["1"; 20_000].join("*"));
    let o = run(&["equilibrium", "oc.toml", "--set", &product], &[]);
    refused(&o, &["longer than 2000 tokens"]);
}

#[test]
fn sum_of_20000_terms_in_a_model_file_is_located() {
    let text = common::overcentre_text().replace(
        "Fs = { value = 0,",
        &format!("Fs = {{ value = \"{}\",", vec!["1"; 20_000].join("+")),
    );
    assert!(text.len() > 40_000);
    let o = run(&["equilibrium", "long.toml"], &[("long.toml", &text)]);
    refused(&o, &["longer than 2000 tokens", "long.toml"]);
    // the line of `Fs` in the file
    let line = text.lines().position(|l| l.starts_with("Fs = ")).unwrap() + 1;
    assert!(
        o.stderr.contains(&format!("long.toml:{line}:")),
        "{}",
        o.stderr
    );
}

#[test]
fn nesting_100000_deep_is_a_located_error() {
    let deep = format!("{}1{}", "(".repeat(100_000), ")".repeat(100_000));
    let text = common::overcentre_text()
        .replace("Fs = { value = 0,", &format!("Fs = {{ value = \"{deep}\","));
    let o = run(&["equilibrium", "deep.toml"], &[("deep.toml", &text)]);
    refused(&o, &["nested deeper than 200 levels", "deep.toml"]);
    // unary minus chains through --set (60,000: below the kernel's 128 KiB per argument)
    let minus = format!("Fs={}1", "-".repeat(60_000));
    let o = run(&["equilibrium", "oc.toml", "--set", &minus], &[]);
    refused(&o, &["error:"]);
}

// Defect 6: messages.

#[test]
fn t_end_1e300_blames_t_end_in_short_numbers() {
    let o = run(
        &["simulate", "oc.toml", "--t-end", "1e300", "-o", "out.csv"],
        &[],
    );
    refused(&o, &["--t-end 1e300 s"]);
    assert!(!o.stderr.contains("000000000000"), "{}", o.stderr);
}

#[test]
fn continue_with_a_step_that_cannot_move_is_refused() {
    let o = run(
        &[
            "continue", "oc.toml", "--param", "Fs", "--from", "0", "--to", "10", "--step",
            "1e-300", "-o", "out.csv",
        ],
        &[],
    );
    refused(&o, &["--step 1e-300", "double precision"]);
}

#[test]
fn values_nan_keeps_its_context() {
    let o = run(
        &[
            "sweep", "oc.toml", "--param", "omega", "--from", "1", "--to", "2", "--step", "1",
            "--values", "F0=nan", "-o", "out.csv",
        ],
        &[],
    );
    refused(&o, &["--values F0=nan"]);
}

// Issue 13 audit (6a, C1, C3, B3): numbers in messages in short form, counts beyond any
// integer as floats, and each refusal naming the flag that sets it.

#[test]
fn a_step_of_1e_300_is_refused_with_a_short_count() {
    // (2 − 1) / 1e-300 points: about 1e300, not a saturated 18446744073709551615
    for (cmd, limit) in [
        ("sweep", "10000000"),
        ("frf", "10000000"),
        ("modes", "100000"),
    ] {
        let o = run(
            &[
                cmd, "oc.toml", "--param", "omega", "--from", "1", "--to", "2", "--step", "1e-300",
                "-o", "out.csv",
            ],
            &[],
        );
        refused(
            &o,
            &[&format!(
                "--step 1e-300 gives about 1e300 points, more than {limit}"
            )],
        );
        assert!(!o.stderr.contains("0.0000"), "{}", o.stderr);
        assert!(!o.stderr.contains("18446744073709551615"), "{}", o.stderr);
    }
}

#[test]
fn a_tune_range_of_extreme_levels_is_echoed_short() {
    let o = run(
        &[
            "tune",
            "inc.toml",
            "--environment",
            "UH-60",
            "--vary",
            "k_fs=1e-300%..1e300%",
        ],
        &[],
    );
    // the case that fails is named as given, not as 300 digits
    refused(&o, &["the case k_fs=1e300%: the trim does not converge"]);
    assert!(!o.stderr.contains("0.000000000"), "{}", o.stderr);
}

#[test]
fn a_tiny_simulated_time_is_printed_short() {
    let o = run(
        &["simulate", "oc.toml", "--t-end", "1e-300", "-o", "out.csv"],
        &[],
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert!(
        o.stdout.starts_with("simulated 1e-300 s in "),
        "{}",
        o.stdout
    );
}

#[test]
fn a_continuation_step_too_small_for_max_steps_is_refused_naming_both() {
    // 10 N / 1e-11 N = 1e12 steps against --max-steps 5000 (formerly: 5001 points to
    // Fs = 4.98e-8 N, exit 0, not marked incomplete); the least step is 10 / 5000
    let o = run(
        &[
            "continue", "oc.toml", "--param", "Fs", "--from", "0", "--to", "10", "--step", "1e-11",
            "-o", "out.csv",
        ],
        &[],
    );
    refused(
        &o,
        &[
            "--step 1e-11 needs at least 1000000000000 steps to cross the range, more than --max-steps 5000",
            "give --step of at least 0.002",
        ],
    );
}

#[test]
fn a_sweep_of_too_many_periods_names_max_periods() {
    // 1e9 periods × 128 samples a period against 50 million samples
    let o = run(
        &[
            "sweep",
            "oc.toml",
            "--set",
            "F0=1",
            "--param",
            "omega",
            "--from",
            "1",
            "--to",
            "2",
            "--step",
            "0.5",
            "--max-periods",
            "1000000000",
            "-o",
            "out.csv",
        ],
        &[],
    );
    refused(
        &o,
        &[
            "--max-periods 1000000000 gives about 128000000000 samples, more than 50000000 (128 a period)",
            "give --max-periods up to 390625",
        ],
    );
    assert!(!o.stderr.contains("--t-end"), "{}", o.stderr);
}

/// Issue 13, last audit point 1: `nfr` at a forcing far below the model's fastest motion
/// integrated tens of thousands of DOP853 steps a period (with the variational
/// equations), minutes for the first point without a word. It is refused at once: the
/// overcentre's fastest |λ| is its mode's ω_n = √8.8397 = 2.9732 rad/s (`detune modes`),
/// so a period at 1e-4 rad/s needs at least 2π/1e-4 · 2.9732 / 2 = 93 405 steps (the
/// periods with variational equations step at h·|λ| ≤ 2; stability alone asked ≤ 6,
/// 31 135), above the 10 000 allowed; the floor is 2π · 2.9732 / 2e4 = 9.34e-4 rad/s.
#[test]
fn nfr_at_a_forcing_far_below_the_fastest_motion_is_refused_at_once() {
    let lambda = 8.839704763344846f64.sqrt();
    let steps = std::f64::consts::TAU / 1e-4 * lambda / 2.0;
    assert!((steps - 93_405.0).abs() < 1.0, "{steps}");
    let o = run(
        &[
            "nfr", "oc.toml", "--set", "F0=3", "--param", "omega", "--from", "1e-4", "--to",
            "1e-2", "-o", "out.csv",
        ],
        &[],
    );
    refused(
        &o,
        &[
            "one forcing period at 0.0001 rad/s (T = 62800 s)",
            "(|λ| = 2.97 1/s)",
            "at least 93400 steps a period",
            "more than the 10000 it allows",
            "the forcing frequency must be above 0.000934 rad/s",
        ],
    );
    // the same with the range given downwards, and in another parameter at that forcing
    let o = run(
        &[
            "nfr", "oc.toml", "--set", "F0=3", "--param", "omega", "--from", "1e-2", "--to",
            "1e-4", "-o", "out.csv",
        ],
        &[],
    );
    refused(&o, &["at least 93400 steps a period"]);
    let o = run(
        &[
            "nfr",
            "oc.toml",
            "--set",
            "omega=1e-4",
            "--param",
            "F0",
            "--from",
            "1",
            "--to",
            "3",
            "-o",
            "out.csv",
        ],
        &[],
    );
    refused(&o, &["at least 93400 steps a period"]);
}

/// Issue 10 leftovers (issue 13's last audit, point 6): a model with no degrees of freedom
/// (tests/data/driven_pendulum.toml: its one body's angle prescribed in time, so 3
/// coordinates and 3 constraint rows) has no modes; `tune` printed "modes: ; closest
/// separation inf %" and `backbone` ended its message in a colon before an empty list.
/// Both say so plainly now, exit 1.
#[test]
fn tune_and_backbone_say_a_model_has_no_degrees_of_freedom() {
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/driven_pendulum.toml"),
    )
    .unwrap();
    let model = [("driven.toml", text.as_str())];
    let said = "the model has no degrees of freedom (its constraints fix or drive every one of its 3 coordinates): it has no modes";
    let o = run(
        &[
            "tune",
            "driven.toml",
            "--environment",
            "uh60",
            "--vary",
            "g=50%..200%",
        ],
        &model,
    );
    refused(&o, &[said, "no mode to keep clear of the forcing bands"]);
    assert!(!o.stdout.contains("closest separation"), "{}", o.stdout);
    let o = run(&["backbone", "driven.toml", "--of-mode", "1"], &model);
    refused(&o, &[said, "so no backbone"]);
    assert!(!o.stderr.contains(": \n"), "{}", o.stderr);
    // equilibrium and margins say it in the same words (exit 0: nothing can resonate)
    for args in [
        &["equilibrium", "driven.toml"][..],
        &["margins", "driven.toml", "--environment", "uh60"][..],
    ] {
        let o = run(args, &model);
        assert_eq!(o.code, Some(0), "{args:?}: {}", o.stderr);
        assert!(o.stdout.contains(said), "{args:?}: {}", o.stdout);
    }
}

/// Issue 13 point 3 (`--integrator dop853|radau` on every time-domain command):
/// `backbone` and `nfr` take both. The overcentre's backbone to 0.05 rad by Radau IIA
/// equals DOP853's (two integrators of the same orbits: ω to 1e-8 relative at every
/// amplitude), and `nfr --integrator radau` runs.
#[test]
fn backbone_and_nfr_take_either_integrator() {
    let backbone = |method: &str| -> Vec<(f64, f64)> {
        let o = run(
            &[
                "backbone",
                "oc.toml",
                "--of-mode",
                "1",
                "--to-amplitude",
                "0.05",
                "--integrator",
                method,
                "--json",
            ],
            &[],
        );
        assert_eq!(o.code, Some(0), "{method}: {}", o.stderr);
        let doc: serde_json::Value = serde_json::from_str(&o.stdout).unwrap();
        doc["points"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| {
                (
                    p["amplitude"].as_f64().unwrap(),
                    p["omega"].as_f64().unwrap(),
                )
            })
            .collect()
    };
    let (explicit, implicit) = (backbone("dop853"), backbone("radau"));
    assert!(explicit.len() > 5 && explicit.len() == implicit.len());
    for (e, i) in explicit.iter().zip(&implicit) {
        assert!(
            (e.0 - i.0).abs() < 1e-12 && (e.1 / i.1 - 1.0).abs() < 1e-8,
            "dop853 {e:?} against radau {i:?}"
        );
    }
    let o = run(
        &[
            "nfr",
            "oc.toml",
            "--set",
            "F0=1",
            "--param",
            "omega",
            "--from",
            "0.5",
            "--to",
            "1",
            "--integrator",
            "radau",
        ],
        &[],
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert!(
        o.stdout.contains("reached omega = 1.000000 rad/s"),
        "{}",
        o.stdout
    );
}

/// Numbers in errors come out in a few digits at any magnitude (issue 13, point 6): a
/// parameter value of a mode tracking or a continuation's start, a driven coordinate's
/// end, the forcing's turns and the run's limit, computed as 2π/ω (not 1.5915494309189534e199).
#[test]
fn huge_and_tiny_numbers_in_errors_are_short() {
    let long = |o: &Outcome| {
        assert!(
            !o.stderr.contains("0000000000") && !o.stdout.contains("0000000000"),
            "{}{}",
            o.stdout,
            o.stderr
        )
    };
    let o = run(
        &[
            "modes", "oc.toml", "--param", "k", "--from", "1", "--to", "1e308", "--step", "1e306",
        ],
        &[],
    );
    // the step 1 → 1e306 is halved 8 times (a solve that fails halves the step) before
    // the tracking gives up at 1e306/2^8
    refused(&o, &["tracking the modes, at k = 3.90625e303"]);
    long(&o);
    let o = run(
        &[
            "continue", "oc.toml", "--param", "k", "--from", "1e200", "--to", "1e201", "--step",
            "1e200", "-o", "out.csv",
        ],
        &[],
    );
    refused(
        &o,
        &[
            "continuation cannot start at k = 1e200:",
            "is the round-off of the equilibrium equations",
        ],
    );
    long(&o);
    // a residual at the round-off of the equations' terms (3.8e-16 of k): the advice is
    // the precision limit, not "start closer"
    for (k, residual) in [("1e200", "3.806e184"), ("1e20", "3.806e4")] {
        let o = run(&["equilibrium", "oc.toml", "--set", &format!("k={k}")], &[]);
        refused(
            &o,
            &[
                &format!("no equilibrium found: residual {residual}"),
                "is the round-off of the equilibrium equations",
            ],
        );
        assert!(!o.stderr.contains("start closer"), "{}", o.stderr);
    }
    // a pose with no equilibrium near it (the bars pushed to the dead point): not
    // round-off, the usual advice
    let o = run(&["equilibrium", "oc.toml", "--set", "Fs=1e6"], &[]);
    refused(&o, &["no equilibrium found", "start closer"]);
    assert!(!o.stderr.contains("round-off"), "{}", o.stderr);
    let o = run(
        &[
            "kinematics",
            "oc.toml",
            "--drive",
            "bar1.theta",
            "--from",
            "0",
            "--to",
            "1e308",
            "--step",
            "1e306",
            "-o",
            "out.csv",
        ],
        &[],
    );
    // 24 steps of 1e306 from 0 (the degrees of 2.4e307 rad overflow: not shown as inf°)
    refused(&o, &["the branch ends at bar1.theta = 2.4e307 rad:"]);
    assert!(!o.stderr.contains("inf"), "{}", o.stderr);
    long(&o);
    let o = run(
        &[
            "simulate",
            "oc.toml",
            "--set",
            "omega=1e200",
            "-o",
            "out.csv",
        ],
        &[],
    );
    // 1e200 rad/s over the 20 s run: 1e200·20/2π = 3.183099e200 turns; 1e7 periods last
    // 2π·1e7/1e200 = 6.283185e-193 s
    refused(
        &o,
        &[
            "turns 3.183099e200 times in the run of 20 s",
            "below 6.283185e-193 s",
        ],
    );
}
