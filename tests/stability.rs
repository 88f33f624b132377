//! One stability verdict everywhere (issues 10 and 11): the one "growing" predicate
//! (`ModalAnalysis::growing`, Re λ above 1e-6 of the largest |λ|), static and dynamic
//! stability said apart, real eigenvalues without a frequency in `modes --json` and the
//! report, the unstable nominal design and tolerance corners in `sensitivity` and
//! `margins`. Each number against a closed form:
//!
//! * the 1-DoF block of tests/data/sdof.toml (m = 2 kg, k = 800 N/m, damper c):
//!   λ = (−c ± √(c² − 4km)) / 2m;
//! * the compound pendulum of tests/data/torsion_pendulum.toml turned upside down
//!   (g = −9.81: the hanging pose is inverted; k = c = 0): λ = ±√(m g (L/2) / I_O) with
//!   I_O = m L²/3.

use detune::linear::{C64, Mode, Motion};
use serde_json::Value;
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_detune");
const SDOF: &str = "tests/data/sdof.toml";
const PENDULUM: &str = "tests/data/torsion_pendulum.toml";
const M: f64 = 2.0;
const K: f64 = 800.0;

fn run(args: &[&str]) -> Output {
    Command::new(BIN)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .output()
        .unwrap()
}

fn json(args: &[&str]) -> Value {
    let out = run(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn close(got: f64, want: f64, rel: f64) {
    assert!(
        (got - want).abs() <= rel * want.abs().max(1e-300),
        "{got} vs {want}"
    );
}

/// λ = (−c ± √(c² − 4km)) / 2m of the block: (re, |im|) of the upper root, or the two real
/// roots.
fn sdof_roots(c: f64) -> (f64, f64) {
    let d = c * c - 4.0 * K * M;
    if d < 0.0 {
        (-c / (2.0 * M), (-d).sqrt() / (2.0 * M))
    } else {
        ((-c - d.sqrt()) / (2.0 * M), (-c + d.sqrt()) / (2.0 * M))
    }
}

/// Negative damping (c = −6 N·s/m): statically stable (k > 0), dynamically UNSTABLE, an
/// oscillation growing as e^(+c/2m t) = e^(+1.5 t) at ω_d = √(4km − c²)/2m. JSON keeps
/// `stable` (static) and adds `dynamically_stable` and the growing modes; the mode keeps
/// its ω_n = √(k/m) = 20 rad/s and ζ = c/(2√(km)) = −0.075, flagged `growing`.
#[test]
fn negative_damping_is_statically_stable_and_dynamically_unstable() {
    let (re, im) = sdof_roots(-6.0);
    assert_eq!(re, 1.5);
    let v = json(&["modes", SDOF, "--set", "c=-6", "--json"]);
    assert_eq!(v["stable"], true);
    assert_eq!(v["dynamically_stable"], false);
    let g = v["growing_modes"].as_array().unwrap();
    assert_eq!(g.len(), 1, "{g:?}");
    close(f(&g[0]["growth_rate_1_s"]), re, 1e-10);
    close(f(&g[0]["omega_d_rad_s"]), im, 1e-10);
    let m = &v["modes"][0];
    assert_eq!(m["growing"], true);
    assert_eq!(m["divergent"], false);
    assert_eq!(m["non_oscillatory"], false);
    assert_eq!(m["motion"], "growing_oscillation");
    close(f(&m["growth_rate_1_s"]), re, 1e-10);
    close(f(&m["time_constant_s"]), 1.0 / re, 1e-10);
    close(f(&m["omega_n_rad_s"]), (K / M).sqrt(), 1e-10);
    close(f(&m["damping_ratio"]), -6.0 / (2.0 * (K * M).sqrt()), 1e-9);
    close(
        f(&m["freq_hz"]),
        (K / M).sqrt() / std::f64::consts::TAU,
        1e-10,
    );
    // the text says both truths, with the growth and the frequency
    let out = run(&["modes", SDOF, "--set", "c=-6"]);
    let text = String::from_utf8_lossy(&out.stdout);
    let first = text.lines().next().unwrap();
    assert_eq!(
        first,
        format!(
            "equilibrium: statically stable, dynamically UNSTABLE (mode 1 grows as e^({re:+.4} t), oscillating at {im:.4} rad/s)"
        )
    );
    assert!(text.contains("GROWING: e^(+1.500000 t)"), "{text}");
    // positive damping: both stable, nothing growing
    let v = json(&["modes", SDOF, "--json"]);
    assert_eq!(
        (&v["stable"], &v["dynamically_stable"]),
        (&Value::Bool(true), &Value::Bool(true))
    );
    assert_eq!(v["growing_modes"], serde_json::json!([]));
    assert_eq!(v["modes"][0]["growing"], false);
}

/// Negative damping beyond critical (c = −100): two real roots (100 ± 60)/4 = 10 and
/// 40 1/s, both divergent although k > 0: still statically stable.
#[test]
fn strong_negative_damping_diverges_without_oscillating() {
    let (a, b) = sdof_roots(-100.0);
    assert_eq!((a, b), (10.0, 40.0));
    let v = json(&["modes", SDOF, "--set", "c=-100", "--json"]);
    assert_eq!(v["stable"], true);
    assert_eq!(v["dynamically_stable"], false);
    let rates: Vec<f64> = v["growing_modes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| f(&g["growth_rate_1_s"]))
        .collect();
    assert_eq!(rates.len(), 2);
    close(rates[0], a, 1e-10);
    close(rates[1], b, 1e-10);
    for m in v["modes"].as_array().unwrap() {
        assert_eq!(m["divergent"], true);
        assert_eq!(m["omega_n_rad_s"], Value::Null);
    }
}

/// An overdamped mode (c = 100 N·s/m: λ = −10 and −40 1/s) and the saddle's decaying
/// partner are non-oscillatory: `modes --json` gives them no frequency and no ζ (as the
/// text says "non-oscillatory"), and their decay rate −λ.
#[test]
fn an_overdamped_mode_has_no_frequency() {
    let (a, b) = sdof_roots(100.0);
    assert_eq!((a, b), (-40.0, -10.0));
    let v = json(&["modes", SDOF, "--set", "c=100", "--json"]);
    assert_eq!(v["dynamically_stable"], true);
    let modes = v["modes"].as_array().unwrap();
    let mut decay: Vec<f64> = modes.iter().map(|m| f(&m["decay_rate_1_s"])).collect();
    decay.sort_by(f64::total_cmp);
    close(decay[0], 10.0, 1e-10);
    close(decay[1], 40.0, 1e-10);
    for m in modes {
        assert_eq!(m["motion"], "decaying");
        assert_eq!(m["non_oscillatory"], true);
        assert_eq!(m["growing"], false);
        for key in [
            "omega_n_rad_s",
            "freq_hz",
            "damping_ratio",
            "growth_rate_1_s",
        ] {
            assert_eq!(m[key], Value::Null, "{key}: {m}");
        }
        close(
            f(&m["decay_time_constant_s"]),
            1.0 / f(&m["decay_rate_1_s"]),
            1e-12,
        );
    }
}

/// The inverted pendulum: λ = ±√(mgl/I) with l = L/2, I = mL²/3 (m = 1.5 kg, L = 0.8 m,
/// g = 9.81): a saddle, statically and dynamically unstable. `modes --json` and the
/// report's sidecar give the same numbers (one constructor): the decaying root with no
/// frequency and its decay rate, the divergent root with its growth rate.
#[test]
fn an_inverted_pendulum_is_a_saddle_in_modes_and_in_the_report() {
    let (m, l, g): (f64, f64, f64) = (1.5, 0.8, 9.81);
    let rate = (m * g * (l / 2.0) / (m * l * l / 3.0)).sqrt();
    let args = ["--set", "g=-9.81", "--set", "k=0", "--set", "c=0"];
    let mut a = vec!["modes", PENDULUM, "--json"];
    a.extend(args);
    let v = json(&a);
    assert_eq!(v["stable"], false);
    assert_eq!(v["dynamically_stable"], false);
    let modes = v["modes"].as_array().unwrap();
    assert_eq!(modes.len(), 2);
    let decaying = modes.iter().find(|m| m["motion"] == "decaying").unwrap();
    let divergent = modes.iter().find(|m| m["motion"] == "divergent").unwrap();
    close(f(&decaying["decay_rate_1_s"]), rate, 1e-9);
    assert_eq!(decaying["freq_hz"], Value::Null);
    assert_eq!(decaying["damping_ratio"], Value::Null);
    close(f(&divergent["growth_rate_1_s"]), rate, 1e-9);
    assert_eq!(divergent["divergent"], true);

    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("r.html");
    let mut a = vec!["report", PENDULUM, "-o", html.to_str().unwrap()];
    a.extend(args);
    let out = run(&a);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let said = String::from_utf8_lossy(&out.stdout) + String::from_utf8_lossy(&out.stderr);
    assert!(
        said.contains("(ω_n non-oscillatory, divergent rad/s)"),
        "{said}"
    );
    let side: Value =
        serde_json::from_str(&std::fs::read_to_string(html.with_extension("json")).unwrap())
            .unwrap();
    assert_eq!(side["equilibrium"]["stable"], false);
    assert_eq!(side["equilibrium"]["dynamically_stable"], false);
    // the same fields as modes --json, key by key (the report adds mode, rpm, energy)
    for (r, j) in side["modes"].as_array().unwrap().iter().zip(modes) {
        for (key, value) in j.as_object().unwrap() {
            if [
                "shape",
                "name",
                "kinetic_energy_share",
                "strain_energy_share",
                "normalized_to",
            ]
            .contains(&key.as_str())
            {
                continue;
            }
            assert_eq!(&r[key], value, "{key}");
        }
        assert_eq!(r["rpm"], Value::Null);
    }
    let page = std::fs::read_to_string(&html).unwrap();
    assert!(
        page.contains("non-oscillatory: decays as e^(−"),
        "no decaying mode row"
    );
    assert!(page.contains("UNSTABLE, statically and dynamically"));
}

/// The one predicate: a real part within 1e-6 of the largest |λ| is round-off, not
/// growth (a neutral double zero computed as ±√ε‖A‖); above it, a mode grows, real or
/// complex.
#[test]
fn round_off_is_not_growth() {
    let mode = |re: f64, im: f64| {
        let wn = (re * re + im * im).sqrt();
        Mode {
            omega_n_rad_s: wn,
            omega_d_rad_s: im.abs(),
            freq_hz: wn / std::f64::consts::TAU,
            damping_ratio: if wn > 0.0 { -re / wn } else { 0.0 },
            eigenvalue: C64 { re, im },
            shape: vec![C64 { re: 1.0, im: 0.0 }],
            normalized_to: 0,
        }
    };
    let threshold = 1e-6 * 20.0; // the largest |λ| of the analysis: 20 rad/s
    assert_eq!(mode(1e-8, 0.0).motion(threshold), Motion::Neutral);
    assert_eq!(mode(-1e-8, 0.0).motion(threshold), Motion::Neutral);
    assert_eq!(mode(1e-8, 20.0).motion(threshold), Motion::Oscillating);
    assert_eq!(mode(1e-3, 0.0).motion(threshold), Motion::Divergent);
    assert_eq!(mode(-1e-3, 0.0).motion(threshold), Motion::Decaying);
    assert_eq!(
        mode(1e-3, 20.0).motion(threshold),
        Motion::GrowingOscillation
    );
    let fields = mode(1e-8, 0.0).fields(threshold);
    assert!(!fields.divergent && !fields.growing && fields.non_oscillatory);
    assert_eq!(fields.growth_rate_1_s, None);
    // a free block (k = c = 0): a double zero, neutral, nothing divergent
    let v = json(&["modes", SDOF, "--set", "k=0", "--set", "c=0", "--json"]);
    for m in v["modes"].as_array().unwrap() {
        assert_eq!(m["motion"], "neutral", "{m}");
        assert_eq!(m["divergent"], false);
    }
    assert_eq!(v["dynamically_stable"], true);
}

/// `sensitivity` on an unstable nominal design warns about it first, and its JSON says
/// `baseline_unstable` with the growing mode (c = −6: Re λ = 1.5 1/s).
#[test]
fn sensitivity_warns_of_an_unstable_baseline_first() {
    let out = run(&[
        "sensitivity",
        SDOF,
        "--set",
        "c=-6",
        "--vary",
        "k=±10%",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.lines().next().unwrap().starts_with(
            "warning: the nominal design (the baseline) is UNSTABLE: mode 1 grows as e^(+1.5000 t)"
        ),
        "{stderr}"
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["baseline_unstable"], true);
    close(
        f(&v["baseline_growing_modes"][0]["growth_rate_1_s"]),
        1.5,
        1e-10,
    );
    let kinds: Vec<&str> = v["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|w| w["kind"].as_str())
        .collect();
    assert_eq!(kinds.first(), Some(&"unstable_baseline"), "{kinds:?}");
    // a stable one says so too
    let v = json(&["sensitivity", SDOF, "--vary", "k=±10%", "--json"]);
    assert_eq!(v["baseline_unstable"], false);
}

/// `sensitivity` on a model with no degrees of freedom: nothing to compute is an error
/// (exit 1) that says so, not an empty success.
#[test]
fn sensitivity_without_degrees_of_freedom_is_an_error() {
    let out = run(&[
        "sensitivity",
        "tests/data/driven_pendulum.toml",
        "--vary",
        "g=±10%",
    ]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("the model has no degrees of freedom (its constraints fix or drive every one of its 3 coordinates): it has no modes, so sensitivity has nothing to compute"),
        "{stderr}"
    );
    assert!(stderr.contains("help:"), "{stderr}");
    assert!(out.stdout.is_empty());
}

/// `margins --vary`: a corner of the tolerance box that is unstable fails the check
/// (exit 3), named in the text and the JSON. c = 2 ± 5 N·s/m reaches c = −3, where the
/// block grows as e^(+3/(2m) t) = e^(+0.75 t).
#[test]
fn an_unstable_tolerance_corner_fails_the_margins() {
    let args = [
        "margins",
        SDOF,
        "--environment",
        "UH-60",
        "--set",
        "c=2",
        "--vary",
        "c=±5",
    ];
    let out = run(&args);
    assert_eq!(
        out.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let (re, im) = sdof_roots(-3.0);
    assert!(
        text.contains(&format!(
            "the tolerance box's corner c=-3 is UNSTABLE: an oscillation grows as e^({re:+.4}·t) at ω_d = {im:.4} rad/s"
        )),
        "{text}"
    );
    assert!(text.contains("FAIL: the tolerance box reaches unstable designs"));
    let mut a = args.to_vec();
    a.push("--json");
    let out = run(&a);
    assert_eq!(out.status.code(), Some(3));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["pass"], false);
    let corners = v["unstable_corners"].as_array().unwrap();
    let c = corners.iter().find(|c| c["label"] == "c=-3").unwrap();
    assert_eq!(c["corner"], true);
    close(f(&c["growth_rate_1_s"]), 0.75, 1e-10);
    close(f(&c["omega_d_rad_s"]), im, 1e-10);
    // the nominal design and its stable corner alone pass (c = 2 ± 1)
    let out = run(&[
        "margins",
        SDOF,
        "--environment",
        "UH-60",
        "--set",
        "c=2",
        "--vary",
        "c=±1",
    ]);
    assert_eq!(out.status.code(), Some(0));
}

/// `modes` on the unstable inceptor (k_fs = −20000 N/m): its declared names cannot tell
/// the modes apart there; it falls back to numbering them, with a note, as `margins`
/// does (exit 0), and says which mode diverges.
#[test]
fn modes_fall_back_to_numbers_where_the_names_do_not_apply() {
    let out = run(&[
        "modes",
        "models/inceptor.toml",
        "--set",
        "k_fs=-20000",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("note: the model's [[modes]] names do not apply to this design"),
        "{stderr}"
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let names: Vec<&str> = v["modes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names[0], "mode 1");
    assert_eq!(v["dynamically_stable"], false);
    assert_eq!(v["growing_modes"][0]["mode"], "mode 1");
    // the same divergence as `margins` reports (tests/margins.rs: 5.8357 1/s)
    close(f(&v["growing_modes"][0]["growth_rate_1_s"]), 5.8357, 1e-4);
}

/// `equilibrium` says both truths as `modes` does (re-audit of issues 10/11): the block
/// with c = −6 N·s/m is statically stable (ω² = k/m = 400 rad²/s²) and dynamically
/// UNSTABLE, growing as e^(+c/2m t) = e^(+1.5 t) at ω_d = √(4km − c²)/2m; `--json` adds
/// `dynamically_stable` beside `stable` (and per equilibrium with `--all`).
#[test]
fn equilibrium_says_dynamic_stability_as_modes_does() {
    let (re, im) = sdof_roots(-6.0);
    let out = run(&["equilibrium", SDOF, "--set", "c=-6"]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let want = format!(
        "  statically stable, dynamically UNSTABLE (mode 1 grows as e^({re:+.4} t), oscillating at {im:.4} rad/s); ω² = 400.000000 rad²/s²"
    );
    assert!(text.contains(&want), "no {want:?} in\n{text}");
    // the same words as modes'
    let modes = run(&["modes", SDOF, "--set", "c=-6"]);
    let first = String::from_utf8_lossy(&modes.stdout)
        .lines()
        .next()
        .unwrap()
        .to_string();
    assert!(
        want.contains(first.trim_start_matches("equilibrium: ")),
        "{first}"
    );
    let v = json(&["equilibrium", SDOF, "--set", "c=-6", "--json"]);
    assert_eq!(v["stable"], true);
    assert_eq!(v["dynamically_stable"], false);
    close(f(&v["undamped_omega2"][0]), K / M, 1e-10);
    // positive damping: both stable, the words unchanged
    let v = json(&["equilibrium", SDOF, "--json"]);
    assert_eq!(
        (&v["stable"], &v["dynamically_stable"]),
        (&Value::Bool(true), &Value::Bool(true))
    );
    let text = String::from_utf8_lossy(&run(&["equilibrium", SDOF]).stdout).to_string();
    assert!(
        text.contains("  stable (ω² = 400.000000 rad²/s²)"),
        "{text}"
    );
    // --all: the inverted pendulum's saddle diverges at √(mgl/I) (l = L/2, I = mL²/3)
    let (m, l, g): (f64, f64, f64) = (1.5, 0.8, 9.81);
    let rate = (m * g * (l / 2.0) / (m * l * l / 3.0)).sqrt();
    let args = [
        "equilibrium",
        PENDULUM,
        "--all",
        "--set",
        "g=-9.81",
        "--set",
        "k=0",
        "--set",
        "c=0",
    ];
    let v = json(&[&args[..], &["--json"]].concat());
    let all = v["equilibria"].as_array().unwrap();
    assert!(!all.is_empty());
    for e in all {
        assert_eq!(e["stable"], false, "{e}");
        assert_eq!(e["dynamically_stable"], false, "{e}");
        close(f(&e["undamped_omega2"][0]), -rate * rate, 1e-9);
    }
    let text = String::from_utf8_lossy(&run(&args).stdout).to_string();
    assert!(
        text.contains(&format!(
            "UNSTABLE, statically and dynamically (mode 2 diverges as e^(+{rate:.4} t) without oscillating)"
        )),
        "{text}"
    );
}

/// A slow growth is not printed as zero: c = −1e-3 N·s/m grows as e^(+c/2m t) with
/// c/2m = 2.5e-4 1/s, above the round-off threshold (1e-6 × ω_n = 2e-5): shown in 4
/// significant digits wherever a growth rate is printed.
#[test]
fn a_slow_growth_is_printed_in_significant_digits() {
    let (re, _) = sdof_roots(-1e-3);
    close(re, 2.5e-4, 1e-12);
    assert_eq!(detune::linear::rate_text(re, 4, true), "+2.500e-4");
    assert_eq!(detune::linear::rate_text(0.13, 4, true), "+0.1300");
    assert_eq!(detune::linear::rate_text(5.8357, 4, false), "5.8357");
    let text =
        String::from_utf8_lossy(&run(&["modes", SDOF, "--set", "c=-1e-3"]).stdout).to_string();
    assert!(
        text.lines()
            .next()
            .unwrap()
            .contains("mode 1 grows as e^(+2.500e-4 t)"),
        "{text}"
    );
    assert!(
        text.contains("GROWING: e^(+2.500e-4 t), time constant 4000.000000 s"),
        "{text}"
    );
    assert!(!text.contains("+0.0000 t"), "{text}");
    let text = String::from_utf8_lossy(&run(&["equilibrium", SDOF, "--set", "c=-1e-3"]).stdout)
        .to_string();
    assert!(text.contains("grows as e^(+2.500e-4 t)"), "{text}");
}

/// The report of a growing oscillation (c = −6 N·s/m: ζ = c/2√(km) = −0.075, growth
/// +1.5 1/s) marks its modes-table row, and its standard output says the verdict.
#[test]
fn the_report_marks_a_growing_oscillation_and_says_unstable() {
    let (re, im) = sdof_roots(-6.0);
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("r.html");
    let out = run(&[
        "report",
        SDOF,
        "--set",
        "c=-6",
        "-o",
        html.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let said = String::from_utf8_lossy(&out.stdout);
    let want = format!(
        "equilibrium: statically stable, dynamically UNSTABLE (mode 1 grows as e^({re:+.4} t), oscillating at {im:.4} rad/s)"
    );
    assert!(said.lines().any(|l| l == want), "no {want:?} in\n{said}");
    let page = std::fs::read_to_string(&html).unwrap();
    let row = format!(
        "<td><span class=\"num\" data-key=\"modes/0/damping_ratio\">{:.4}</span> (growing: e^(+<span class=\"num\" data-key=\"modes/0/growth_rate_1_s\">{re:.3}</span> t), 1/s)</td>",
        -6.0 / (2.0 * (K * M).sqrt())
    );
    assert!(page.contains(&row), "no {row} in the page");
    // a stable design: no verdict line, no marker
    let out = run(&["report", SDOF, "-o", html.to_str().unwrap()]);
    assert!(out.status.success());
    assert!(!String::from_utf8_lossy(&out.stdout).contains("UNSTABLE"));
    assert!(
        !std::fs::read_to_string(&html)
            .unwrap()
            .contains("growing: e^")
    );
}

/// `margins --vary`'s unstable points carry labels rounded to 6 significant digits, the
/// corner flagged apart from the interior samples. The torsion pendulum (k = 12 N·m/rad)
/// varied by ±40.1234567: the lower corner k = −28.1234567 and the samples a quarter and a
/// half of the way up to the baseline (−18.0925925…, −8.0617283…) have K = k + m g L/2 < 0
/// and diverge at λ = (−c + √(c² − 4 I K)) / 2I.
#[test]
fn margins_unstable_points_have_rounded_labels() {
    let growth = |k: f64| {
        let (m, l, g, c) = (1.5, 0.8, 9.81, 0.4);
        let (i, kk) = (m * l * l / 3.0, k + m * g * l / 2.0);
        (-c + (c * c - 4.0 * i * kk).sqrt()) / (2.0 * i)
    };
    let args = [
        "margins",
        PENDULUM,
        "--environment",
        "UH-60",
        "--vary",
        "k=±40.1234567",
        "--json",
    ];
    let out = run(&args);
    assert_eq!(
        out.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let low = 12.0 - 40.1234567;
    let want = [
        ("k=-28.1235", true, low),
        ("k=-18.0926", false, low + (12.0 - low) * 0.25),
        ("k=-8.06173", false, low + (12.0 - low) * 0.5),
    ];
    let got = v["unstable_corners"].as_array().unwrap();
    assert_eq!(got.len(), want.len(), "{got:?}");
    for (label, corner, k) in want {
        let u = got
            .iter()
            .find(|u| u["label"] == label)
            .unwrap_or_else(|| panic!("no {label} in {got:?}"));
        assert_eq!(u["corner"], corner, "{u}");
        close(f(&u["growth_rate_1_s"]), growth(k), 1e-8);
        assert_eq!(u["omega_d_rad_s"], 0.0);
    }
}

/// A stiff element does not hide a divergence (the fresh-eyes review's D1): the block
/// (m = 2 kg) on a negative spring k with a stiff bead (m2 = 1e-3 kg) hung on it by
/// k2, c2. Its positive real root of det(λ²M + λC + K) = (mλ² + c2λ + k + k2)(m2λ² + c2λ
/// + k2) − (c2λ + k2)² = 0 (c = 0), found here by bisection, grows; with a threshold of
/// 1e-6 of the largest |λ| (c2/m2 = 1e8 1/s, or the 1e10 N/m spring's 3.2e6 rad/s) it
/// was read as neutral and `margins` passed the design (exit 0).
#[test]
fn a_stiff_element_does_not_hide_a_divergence() {
    let (m, m2) = (2.0, 1e-3);
    for (k, k2, c2) in [(-800.0, 1e4, 1e5), (-8.0, 1e10, 0.0)] {
        let p = |l: f64| {
            (m * l * l + c2 * l + k + k2) * (m2 * l * l + c2 * l + k2) - (c2 * l + k2).powi(2)
        };
        // p < 0 at 0 (k k2 < 0), > 0 at √(|k|/m) + 1
        let (mut lo, mut hi) = (0.0, (-k / m).sqrt() + 1.0);
        assert!(p(lo) < 0.0 && p(hi) > 0.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if p(mid) < 0.0 { lo = mid } else { hi = mid }
        }
        let (ks, k2s, c2s) = (format!("k={k}"), format!("k2={k2}"), format!("c2={c2}"));
        let sets = ["--set", &ks, "--set", "c=0", "--set", &k2s, "--set", &c2s];
        let v = json(
            &[
                &["modes", "tests/data/stiff_sdof.toml", "--json"][..],
                &sets,
            ]
            .concat(),
        );
        assert_eq!(v["dynamically_stable"], Value::Bool(false), "{v:#}");
        let growing: Vec<f64> = v["modes"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|m| m["growing"] == Value::Bool(true))
            .map(|m| f(&m["growth_rate_1_s"]))
            .collect();
        assert_eq!(growing.len(), 1, "{v:#}");
        close(growing[0], lo, 1e-6);
        let out = run(&[
            &[
                "margins",
                "tests/data/stiff_sdof.toml",
                "--environment",
                "UH-60",
            ][..],
            &sets,
        ]
        .concat());
        assert_eq!(
            out.status.code(),
            Some(3),
            "{}",
            String::from_utf8_lossy(&out.stdout)
        );
    }
}

/// The veering pendulums (tests/data/veering_pendulums.toml: m = 1 kg at l1 = 1 m and
/// l2 = 0.8 m, coupled by kc = 0.05 N·m/rad) with an extra rotary damper on pendulum 1.
fn veering_with(extra: &str) -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("vp.toml");
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/veering_pendulums.toml"),
    )
    .unwrap();
    std::fs::write(&path, text + extra).unwrap();
    let p = path.to_str().unwrap().to_string();
    (dir, p)
}

/// `equilibrium` names a growing mode by the model's `[[modes]]` names, as `modes` does
/// (it said `mode 1`): a negative rotary damper c = −0.01 N·m·s/rad on pendulum 1 makes
/// "pendulum 1 swings" grow at Re λ ≈ −c / (2 I_O), I_O = I + m l1² = 1.001 kg·m².
#[test]
fn equilibrium_names_a_growing_mode_as_modes_does() {
    let (_dir, model) = veering_with(
        "\n[[forces]]\nname = \"pump\"\ntype = \"torsion\"\nbody1 = \"p1\"\nbody2 = \"ground\"\nstiffness = 0\ndamping = -0.01\n",
    );
    let rate = 0.01 / (2.0 * 1.001);
    let said = format!("pendulum 1 swings grows as e^(+{rate:.4} t)");
    for command in ["equilibrium", "modes"] {
        let out = run(&[command, &model]);
        assert!(out.status.success());
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains(&said), "{command}: {text}");
        assert!(!text.contains("mode 1 grows"), "{command}: {text}");
    }
}

/// The divergent modes of an unstable equilibrium release potential energy: the strain
/// shares were "none" (a negative total was taken for no energy). The veering pendulums
/// inverted (g = −9.81): along a mode of shape (θ1, θ2) gravity, through the constraint
/// reactions, gives E_r = −9.81 m (l1 θ1² + l2 θ2²) and the coupling E_c = kc (θ1 − θ2)²;
/// each share is E/|E_r + E_c| (summing to −1: the reactions release, the coupling stores).
#[test]
fn a_divergent_mode_releases_potential_energy() {
    let file = "tests/data/veering_pendulums.toml";
    let m = json(&["modes", file, "--set", "g=-9.81", "--json"]);
    let modes = m["modes"].as_array().unwrap();
    assert_eq!(modes.len(), 4);
    for mode in modes {
        // real eigenvalues ±3.1, ±3.5 1/s: a divergence and its decaying twin, one shape
        assert!(f(&mode["eigenvalue"]["re"]).abs() > 3.0, "{mode}");
        let theta = |c: &str| {
            let (re, im) = (f(&mode["shape"][c]["re"]), f(&mode["shape"][c]["im"]));
            (re, im)
        };
        let ((r1, i1), (r2, i2)) = (theta("p1.theta"), theta("p2.theta"));
        let e_r = -9.81 * (r1 * r1 + i1 * i1 + 0.8 * (r2 * r2 + i2 * i2));
        let e_c = 0.05 * ((r1 - r2).powi(2) + (i1 - i2).powi(2));
        let total = (e_r + e_c).abs();
        let shares = &mode["strain_energy_share"];
        close(f(&shares["constraint reactions"]), e_r / total, 1e-8);
        close(f(&shares["coupling"]), e_c / total, 1e-8);
    }
    let out = run(&["modes", file, "--set", "g=-9.81"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(!text.contains("strain: none"), "{text}");
    assert_eq!(
        text.matches("strain: released, not stored").count(),
        4,
        "{text}"
    );
    assert!(text.contains("constraint reactions −10"), "{text}");
}
