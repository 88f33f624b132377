//! Frequency margins: the separation of each mode from each forcing line, checked against
//! independent numbers (the inceptor's reference modes in tests/data/inceptor/modes.json,
//! rpm·2π/60, a compound pendulum's closed-form frequency), the exit codes, and the
//! refusals.

mod common;

use detune::environment::{ForcingLine, resolve};
use detune::margins::{ModeInterval, Requirement, Side, check_margins, required, separation};
use detune::request::{Argument, Invalid};
use std::f64::consts::PI;
use std::process::Command;

fn detune(dir: &str, args: &[&str]) -> (i32, String, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn repo(args: &[&str]) -> (i32, String, String) {
    detune(env!("CARGO_MANIFEST_DIR"), args)
}

fn json(out: &str) -> serde_json::Value {
    serde_json::from_str(out).unwrap_or_else(|e| panic!("{e}: {out}"))
}

/// The reference ω_n = |λ| and ζ of the inceptor's damped modes (minimal-coordinate model).
fn inceptor_reference() -> Vec<(f64, f64)> {
    let v: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(common::data("inceptor/modes.json")).unwrap(),
    )
    .unwrap();
    v["baseline"]["minimal"]["damped"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            (
                m["omega_n_rad_s"].as_f64().unwrap(),
                m["zeta"].as_f64().unwrap(),
            )
        })
        .collect()
}

/// The row of `mode` × `line` in a JSON report.
fn row<'a>(j: &'a serde_json::Value, mode: &str, line: &str) -> &'a serde_json::Value {
    j["rows"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["mode"] == mode && r["line"] == line)
        .unwrap_or_else(|| panic!("no row {mode} × {line}"))
}

#[test]
fn the_baseline_inceptor_fails_against_the_uh60_main_rotor_1p() {
    let (code, out, err) = repo(&[
        "margins",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--json",
    ]);
    assert_eq!(code, 3, "{err}");
    let j = json(&out);
    let reference = inceptor_reference();
    let w1p = 258.0 * 2.0 * PI / 60.0; // 27.0177 rad/s
    let (w2, zeta2) = reference[1]; // 26.5306 rad/s
    let r = row(&j, "shaft-twist", "1P");
    let expected = 100.0 * (w1p - w2) / w1p; // 1.80 %
    assert!((expected - 1.8029).abs() < 1e-3);
    assert!((r["omega_n_rad_s"].as_f64().unwrap() - w2).abs() < 1e-6 * w2);
    assert!((r["damping_ratio"].as_f64().unwrap() - zeta2).abs() < 1e-6);
    assert!((r["line_rad_s"].as_f64().unwrap() - w1p).abs() < 1e-12);
    assert!((r["separation_pct"].as_f64().unwrap() - expected).abs() < 1e-4);
    assert_eq!(r["side"], "below");
    assert_eq!(r["required_pct"], 10.0);
    assert_eq!(r["pass"], false);
    assert_eq!(j["pass"], false);
    assert_eq!(j["margin_pct"], 10.0);
    // 2 modes × (1P, 4P, 8P, 12P, 1T, 4T); every other row passes
    let rows = j["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 12);
    assert_eq!(rows.iter().filter(|r| r["pass"] == false).count(), 1);
    let w1 = reference[0].0;
    let r1 = row(&j, "in-phase", "1P");
    assert!((r1["separation_pct"].as_f64().unwrap() - 100.0 * (w1p - w1) / w1p).abs() < 1e-4);
    // the document: provenance, the environment with its lines
    assert_eq!(j["provenance"]["model_file"], "models/inceptor.toml");
    assert_eq!(j["environment"]["id"], "UH-60");
    assert_eq!(j["environment"]["sha256"].as_str().unwrap().len(), 64);
    assert_eq!(j["environment"]["lines"][5]["label"], "4T");
    for key in [
        "mode",
        "omega_n_rad_s",
        "min_rad_s",
        "max_rad_s",
        "damping_ratio",
        "line",
        "line_rad_s",
        "band_lo_rad_s",
        "band_hi_rad_s",
        "separation_pct",
        "side",
        "required_pct",
        "pass",
    ] {
        assert!(r.get(key).is_some(), "row key {key}");
    }
    assert!(
        err.contains("shaft-twist (26.53 rad/s) is 1.8 % below UH-60 1P (27.02 rad/s): needs 10 %"),
        "{err}"
    );
}

#[test]
fn the_table_states_the_margin_as_a_choice_and_every_number_with_its_unit() {
    let (code, out, err) = repo(&["margins", "models/inceptor.toml", "--environment", "uh60"]);
    assert_eq!(code, 3, "{err}");
    assert!(out.contains("10 % (your choice, not a standard)"), "{out}");
    assert!(
        out.contains("27.0177 rad/s = 4.3000 Hz = 258.0 rpm"),
        "{out}"
    );
    assert!(
        out.contains("shaft-twist (26.53 rad/s) is 1.8 % below UH-60 1P (27.02 rad/s): needs 10 %"),
        "{out}"
    );
    assert!(out.contains("FAIL: 1 of 12"), "{out}");
}

#[test]
fn the_inceptor_clears_the_ah64_and_a_stiffer_shaft_clears_the_uh60() {
    // AH-64 1P = 288 rpm = 30.16 rad/s: mode 2 is 12.0 % below it
    let (code, out, err) = repo(&[
        "margins",
        "models/inceptor.toml",
        "--environment",
        "AH-64",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let j = json(&out);
    assert_eq!(j["pass"], true);
    let w1p = 288.0 * 2.0 * PI / 60.0;
    let w2 = inceptor_reference()[1].0;
    let sep = row(&j, "shaft-twist", "1P")["separation_pct"]
        .as_f64()
        .unwrap();
    assert!((sep - 100.0 * (w1p - w2) / w1p).abs() < 1e-4);
    assert!(err.contains("PASS"), "{err}");
    // a stiffer output shaft moves mode 2 above the UH-60's 1P by more than 10 %
    let (code, out, err) = repo(&[
        "margins",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--set",
        "k_t=500",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let j = json(&out);
    let r = row(&j, "shaft-twist", "1P");
    let w = r["omega_n_rad_s"].as_f64().unwrap();
    let w1p = 258.0 * 2.0 * PI / 60.0;
    assert!(w > 1.1 * w1p, "{w}");
    assert!(
        (w - 29.92).abs() < 0.005,
        "docs/inceptor.md quotes 29.92 rad/s: {w}"
    );
    assert_eq!(r["side"], "above");
    assert!((r["separation_pct"].as_f64().unwrap() - 100.0 * (w - w1p) / w1p).abs() < 1e-9);
    assert_eq!(j["provenance"]["overrides"][0], "k_t=500");
}

/// A compound pendulum (tests/data/torsion_pendulum.toml): ω_n = |λ| = √(K/I) with
/// K = k + m g L/2 and I = m L²/3 about the pivot.
fn pendulum_omega(k: f64) -> f64 {
    let (m, l, g) = (1.5, 0.8, 9.81);
    ((k + m * g * l / 2.0) / (m * l * l / 3.0)).sqrt()
}

const BAND_ENV: &str = r#"name = "Test band"
id = "TB"
source = "made up for a test"

[main_rotor]
rpm = 6
blades = 2

[[bands]]
name = "shaker"
from = "8 rad/s"
to = "9 rad/s"
"#;

#[test]
fn a_band_is_cleared_to_its_nearest_edge() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("band.toml"), BAND_ENV).unwrap();
    let model = common::data("torsion_pendulum.toml");
    let d = dir.path().to_str().unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec![
            "margins",
            model.as_str(),
            "--environment",
            "band.toml",
            "--json",
        ];
        args.extend_from_slice(extra);
        detune(d, &args)
    };
    // 7.476 rad/s, below the band's lower edge 8 rad/s by 6.5 %
    let w = pendulum_omega(12.0);
    let (code, out, err) = run(&[]);
    assert_eq!(code, 3, "{err}");
    let j = json(&out);
    let r = row(&j, "mode 1", "shaker");
    assert!((r["omega_n_rad_s"].as_f64().unwrap() - w).abs() < 1e-9 * w);
    assert_eq!(
        (r["band_lo_rad_s"].as_f64(), r["band_hi_rad_s"].as_f64()),
        (Some(8.0), Some(9.0))
    );
    assert_eq!(r["line_rad_s"], 8.5);
    let expected = 100.0 * (8.0 - w) / 8.0;
    assert!(
        (r["separation_pct"].as_f64().unwrap() - expected).abs() < 1e-9,
        "{r}"
    );
    assert_eq!(r["side"], "below");
    assert!(
        err.contains("mode 1 (7.48 rad/s) is 6.5 % below TB shaker (8.00–9.00 rad/s): needs 10 %"),
        "{err}"
    );
    // at a 5 % margin it clears
    let (code, _, err) = run(&["--margin", "5%"]);
    assert_eq!(code, 0, "{err}");
    // stiffer: inside the band (overlap, negative separation); stiffer still: above it
    let k_in = 8.5f64.powi(2) * (1.5 * 0.64 / 3.0) - 1.5 * 9.81 * 0.4; // ω = 8.5 rad/s
    let (code, out, _) = run(&["--set", &format!("k={k_in}")]);
    assert_eq!(code, 3);
    let r = row(&json(&out), "mode 1", "shaker").clone();
    assert_eq!(r["side"], "overlap");
    let sep = r["separation_pct"].as_f64().unwrap();
    // halfway: 0.5 rad/s to either edge, max((8 − 8.5)/8, (8.5 − 9)/9) = −5.56 %
    assert!((sep - 100.0 * (-0.5f64 / 9.0)).abs() < 1e-6, "{sep}");
    let (code, out, _) = run(&["--set", "k=40"]);
    assert_eq!(code, 0);
    let r = row(&json(&out), "mode 1", "shaker").clone();
    let w = pendulum_omega(40.0);
    assert_eq!(r["side"], "above");
    assert!((r["separation_pct"].as_f64().unwrap() - 100.0 * (w - 9.0) / 9.0).abs() < 1e-6);
}

#[test]
fn the_csv_has_the_json_rows() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("m.csv");
    let (code, out, err) = repo(&[
        "margins",
        "models/inceptor.toml",
        "--environment",
        "UH-1N",
        "--json",
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert!(code == 0 || code == 3, "{err}");
    let j = json(&out);
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        "mode,omega_n_rad_s,min_rad_s,max_rad_s,damping_ratio,line,line_rad_s,band_lo_rad_s,band_hi_rad_s,separation_pct,side,required_pct,pass"
    );
    let rows = j["rows"].as_array().unwrap();
    assert_eq!(lines.len(), 1 + rows.len());
    for (line, r) in lines[1..].iter().zip(rows) {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f[0], r["mode"]);
        assert_eq!(f[5], r["line"]);
        // (serde_json reads floats to within an ulp or so)
        let sep = r["separation_pct"].as_f64().unwrap();
        assert!((f[9].parse::<f64>().unwrap() - sep).abs() < 1e-13 * sep.abs().max(1.0));
        assert_eq!(f[10], r["side"]);
        assert_eq!(f[12], r["pass"].to_string());
    }
    // UH-1N: 2 blades: 1P, 2P, 4P, 6P, 1T, 2T
    let labels: Vec<&str> = rows
        .iter()
        .take(6)
        .map(|r| r["line"].as_str().unwrap())
        .collect();
    assert_eq!(labels, ["1P", "2P", "4P", "6P", "1T", "2T"]);
}

#[test]
fn damping_aware_margins_are_scaled_by_the_amplification_factor() {
    // required = margin · (1 − 1/(AF − 1.5)), AF = 1/(2ζ); none for AF < 2.5
    assert_eq!(required(0.1, 0.05, Requirement::Fixed), 0.1);
    assert!(
        (required(0.1, 0.05, Requirement::DampingAware) - 0.1 * (1.0 - 1.0 / 8.5)).abs() < 1e-15
    );
    assert_eq!(required(0.1, 0.25, Requirement::DampingAware), 0.0);
    assert_eq!(required(0.1, 0.0, Requirement::DampingAware), 0.1);
    // a mode that needs no separation passes even across a line
    let heavy = ModeInterval {
        name: "mode 1".into(),
        omega_n_rad_s: 30.0,
        min_rad_s: 29.0,
        max_rad_s: 31.0,
        damping_ratio: 0.3,
    };
    let c = check_margins(
        std::slice::from_ref(&heavy),
        &[line(30.0, 30.0)],
        0.1,
        Requirement::DampingAware,
    )
    .unwrap();
    assert!(c.pass && c.rows[0].separation_pct < 0.0 && c.rows[0].side == Side::Overlap);
    let c = check_margins(&[heavy], &[line(30.0, 30.0)], 0.1, Requirement::Fixed).unwrap();
    assert!(!c.pass);
    // on the inceptor: mode 2 (ζ = 0.0526) needs 8.75 %, still more than its 1.8 %
    let (code, out, err) = repo(&[
        "margins",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--damping-aware",
        "--json",
    ]);
    assert_eq!(code, 3, "{err}");
    let j = json(&out);
    assert_eq!(j["requirement"]["rule"], "damping_aware");
    let zeta = inceptor_reference()[1].1;
    let af = 1.0 / (2.0 * zeta);
    let r = row(&j, "shaft-twist", "1P");
    assert!((r["required_pct"].as_f64().unwrap() - 10.0 * (1.0 - 1.0 / (af - 1.5))).abs() < 1e-5);
    let (_, out, _) = repo(&[
        "margins",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--damping-aware",
    ]);
    assert!(
        out.contains("DAMPING-AWARE (heuristic, API 684-style, not a standard)"),
        "{out}"
    );
}

fn line(lo: f64, hi: f64) -> ForcingLine {
    ForcingLine {
        label: "L".into(),
        rotor: None,
        multiple: None,
        omega_rad_s: 0.5 * (lo + hi),
        band_lo_rad_s: lo,
        band_hi_rad_s: hi,
    }
}

#[test]
fn an_interval_must_clear_at_its_worst_point() {
    // a point: |ω − ω_l| / ω_l
    assert_eq!(separation(27.0, 27.0, 30.0, 30.0), (0.1, Side::Below));
    assert_eq!(separation(33.0, 33.0, 30.0, 30.0).1, Side::Above);
    assert!((separation(33.0, 33.0, 30.0, 30.0).0 - 0.1).abs() < 1e-15);
    // an interval below: its top counts; above: its bottom
    assert_eq!(separation(20.0, 27.0, 30.0, 30.0), (0.1, Side::Below));
    assert!((separation(33.0, 40.0, 30.0, 30.0).0 - 0.1).abs() < 1e-15);
    // an interval across the line overlaps it
    let (s, side) = separation(28.0, 31.0, 30.0, 30.0);
    assert_eq!(side, Side::Overlap);
    assert!((s - (-1.0 / 30.0)).abs() < 1e-15); // a shift of 1 rad/s up would clear it
    // a sensitivity interval [26, 28.5] that a 10 % margin from 30 rad/s refuses, though
    // its nominal 27 alone clears
    let m = ModeInterval {
        name: "mode 2".into(),
        omega_n_rad_s: 27.0,
        min_rad_s: 26.0,
        max_rad_s: 28.5,
        damping_ratio: 0.05,
    };
    let c = check_margins(
        std::slice::from_ref(&m),
        &[line(30.0, 30.0)],
        0.1,
        Requirement::Fixed,
    )
    .unwrap();
    assert!(!c.pass);
    assert!((c.rows[0].separation_pct - 5.0).abs() < 1e-12);
    let point = ModeInterval::point("mode 2", 27.0, 0.05);
    let c = check_margins(&[point], &[line(30.0, 30.0)], 0.1, Requirement::Fixed).unwrap();
    assert!(c.pass, "exactly 10 % clears a 10 % margin");
}

#[test]
fn a_margin_outside_zero_to_one_is_refused_by_the_library() {
    for bad in [0.0, 1.0, -0.1, f64::NAN] {
        let e = check_margins(&[], &[], bad, Requirement::Fixed).unwrap_err();
        assert!(
            matches!(
                e.invalid(),
                Some(Invalid::NotFraction {
                    argument: Argument::Margin,
                    ..
                })
            ),
            "{e}"
        );
    }
}

#[test]
fn non_oscillatory_modes_are_left_out_and_said_so() {
    // an overdamped pendulum (ζ = c/(2√(K I)) ≈ 4.2): two real eigenvalues, no resonance
    let model = common::from_text(
        "p.toml",
        &std::fs::read_to_string(common::data("torsion_pendulum.toml")).unwrap(),
        &[("c", "20")],
    );
    let sys = detune::System::new(&model).unwrap();
    let modal = detune::linear::modal_analysis(&sys, None).unwrap();
    let (modes, skipped) = detune::margins::mode_points(&modal);
    assert!(modes.is_empty());
    assert_eq!(skipped.len(), 2);
    // λ₁λ₂ = K/I for the real pair
    let (k, i) = (12.0 + 1.5 * 9.81 * 0.4, 1.5 * 0.64 / 3.0);
    let product = skipped[0].eigenvalue * skipped[1].eigenvalue;
    assert!((product - k / i).abs() < 1e-6 * k / i, "{product}");
    let env = resolve("UH-60").unwrap();
    let c = check_margins(&modes, &env.forcing_lines(), 0.1, Requirement::Fixed).unwrap();
    assert!(c.pass && c.rows.is_empty());
    let (code, out, err) = repo(&[
        "margins",
        &common::data("torsion_pendulum.toml"),
        "--environment",
        "UH-60",
        "--set",
        "c=20",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("non-oscillatory"), "{out}");
    assert!(out.contains("no oscillatory modes"), "{out}");
}

#[test]
fn bad_requests_are_refused_before_any_output() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("m.csv");
    let csv = csv.to_str().unwrap();
    let model = format!("{}/models/inceptor.toml", env!("CARGO_MANIFEST_DIR"));
    let cases: &[(&[&str], &str)] = &[
        (&["--margin", "10"], "did you mean --margin 10%?"),
        (&["--margin", "0%"], "a margin must be above 0"),
        (&["--margin", "-5%"], "a margin must be above 0"),
        (&["--margin", "100%"], "is 100 % or more"),
        (&["--margin", "ten"], "expected a percentage or a fraction"),
        (&["--vary", "kt=±10%"], "no parameter `kt`"),
        // a case the trim cannot hold (the baseline can): narrow that range
        (
            &["--vary", "l2=±80%"],
            "the trim does not converge: no value of L0",
        ),
        (&["--vary", "l2=±80%"], "narrow the range of --vary l2"),
        (&["--environment", "CH-47"], "UH-60, UH-1N"),
        (&["--environment", "nope.toml"], "nope.toml"),
    ];
    for (extra, message) in cases {
        let mut args = vec!["margins", model.as_str(), "-o", csv];
        if !extra.contains(&"--environment") {
            args.extend(["--environment", "UH-60"]);
        }
        args.extend_from_slice(extra);
        let (code, _, err) = detune(dir.path().to_str().unwrap(), &args);
        assert_eq!(code, 1, "{extra:?}: {err}");
        assert!(
            err.contains(message),
            "{extra:?}: expected `{message}` in {err}"
        );
        assert!(err.contains("help:"), "{extra:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(!std::path::Path::new(csv).exists(), "{extra:?}");
    }
    // a fraction and a percentage are the same margin
    let (_, a, _) = repo(&[
        "margins",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--margin",
        "0.1",
        "--json",
    ]);
    let (_, b, _) = repo(&[
        "margins",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--margin",
        "10 %",
        "--json",
    ]);
    assert_eq!(json(&a)["rows"], json(&b)["rows"]);
}

#[test]
fn a_bad_environment_file_is_reported_with_its_location() {
    let dir = tempfile::tempdir().unwrap();
    let text = BAND_ENV.replace("to = \"9 rad/s\"", "to = \"7 rad/s\"");
    std::fs::write(dir.path().join("band.toml"), &text).unwrap();
    let model = format!("{}/models/inceptor.toml", env!("CARGO_MANIFEST_DIR"));
    let (code, _, err) = detune(
        dir.path().to_str().unwrap(),
        &["margins", &model, "--environment", "band.toml"],
    );
    assert_eq!(code, 1);
    assert!(
        err.contains(
            "band.toml:12:6: band `shaker` runs from 8.000000 rad/s down to 7.000000 rad/s"
        ),
        "{err}"
    );
    // an output that would overwrite the environment file: refused before any work
    std::fs::write(dir.path().join("good.toml"), BAND_ENV).unwrap();
    let (code, _, err) = detune(
        dir.path().to_str().unwrap(),
        &[
            "margins",
            &model,
            "--environment",
            "good.toml",
            "-o",
            "good.toml",
        ],
    );
    assert_eq!(code, 1);
    assert!(
        err.contains("this would overwrite the environment file"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("good.toml")).unwrap(),
        BAND_ENV
    );
}

/// With `--vary`, the whole tolerance interval must clear: k_t = 500 N·m/rad puts the
/// inceptor's mode 2 10.7 % above the UH-60 1P at the nominal design (pass), but the box
/// k_fs ±10 %, gearbox_scale ±5 % reaches down to 8.5 % (fail); the interval's ends are
/// the sensitivity study's worst case.
#[test]
fn tolerance_intervals_must_clear_whole() {
    let dir = tempfile::tempdir().unwrap();
    let model = format!("{}/models/inceptor.toml", env!("CARGO_MANIFEST_DIR"));
    let base = [
        "margins",
        model.as_str(),
        "--environment",
        "UH-60",
        "--set",
        "k_t=500",
    ];
    let (code, _, err) = detune(dir.path().to_str().unwrap(), &base);
    assert_eq!(code, 0, "{err}");
    let mut args = base.to_vec();
    args.extend([
        "--vary",
        "k_fs=±10%",
        "--vary",
        "gearbox_scale=±5%",
        "--json",
    ]);
    let (code, out, err) = detune(dir.path().to_str().unwrap(), &args);
    assert_eq!(code, 3, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    let row = j["rows"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["mode"] == "shaft-twist" && r["line"] == "1P")
        .unwrap();
    let (lo, hi) = (
        row["min_rad_s"].as_f64().unwrap(),
        row["max_rad_s"].as_f64().unwrap(),
    );
    let line = 258.0 * std::f64::consts::TAU / 60.0;
    assert!(lo < row["omega_n_rad_s"].as_f64().unwrap() && hi > lo);
    let sep = row["separation_pct"].as_f64().unwrap();
    assert!((sep - (lo - line) / line * 100.0).abs() < 1e-9, "{sep}");
    assert!(sep > 0.0 && sep < 10.0 && row["pass"] == false);
}

/// A frequency that is not monotonic in a varied parameter has its extreme inside the
/// box: the inceptor's in-phase mode peaks near l2 = +10 % (13.215 rad/s) while the ends
/// of l2 ±15 % give less, so the interval must include the interior (a line at
/// 14.65 rad/s is then within 10 %), with a warning. A box with a corner that has no
/// equilibrium cannot be verified and is refused, not passed.
#[test]
fn non_monotone_and_unverifiable_boxes() {
    let dir = tempfile::tempdir().unwrap();
    let root = env!("CARGO_MANIFEST_DIR");
    let inceptor = format!("{root}/models/inceptor.toml");
    let env = format!("{root}/tests/data/line_14_65.toml");
    let (code, out, err) = detune(
        dir.path().to_str().unwrap(),
        &[
            "margins",
            &inceptor,
            "--environment",
            &env,
            "--vary",
            "l2=±15%",
            "--json",
        ],
    );
    assert_eq!(code, 3, "{err}");
    assert!(err.contains("not monotonic in l2"), "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    let hi = row(&j, "in-phase", "probe")["max_rad_s"].as_f64().unwrap();
    let (_, m) = {
        let model = detune::Model::load(&inceptor).unwrap();
        let sys = detune::System::new(&model).unwrap();
        let i = sys.param_index("l2").unwrap();
        detune::linear::sensitivity::modes_at(&sys, &[(i, 0.135 * 1.1)], None, None).unwrap()
    };
    let at_10 = m.modes[0].omega_n_rad_s;
    assert!(
        hi >= at_10 - 1e-3,
        "interval max {hi} misses l2 +10 %'s {at_10}"
    );
    let overcentre = format!("{root}/models/overcentre.toml");
    let env = format!("{root}/tests/data/line_1_6.toml");
    let (code, _, err) = detune(
        dir.path().to_str().unwrap(),
        &[
            "margins",
            &overcentre,
            "--environment",
            &env,
            "--vary",
            "L0=±5%",
            "--vary",
            "k=±10%",
        ],
    );
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("cannot be verified"), "{err}");
}

/// The growing root of I λ² + c λ + K = 0 of the torsion pendulum (a uniform bar on a
/// pivot, I = m L²/3, K = k + m g L/2 hanging down): with k = −30 N·m/rad, K < 0 and the
/// hanging equilibrium diverges at λ = (−c + √(c² − 4 I K)) / (2 I) > 0.
fn pendulum_growth(k: f64) -> f64 {
    let (m, l, g, c) = (1.5, 0.8, 9.81, 0.4);
    let (i, kk) = (m * l * l / 3.0, k + m * g * l / 2.0);
    (-c + (c * c - 4.0 * i * kk).sqrt()) / (2.0 * i)
}

/// An unstable design never passes: a divergent mode (Re λ > 0) fails the check, exit 3,
/// with the mode and its growth rate in the text and the JSON, whatever the separations
/// (here none: the pendulum's only eigenvalues are real).
#[test]
fn an_unstable_equilibrium_fails_the_margins_check() {
    let path = common::data("torsion_pendulum.toml");
    let (code, out, err) = repo(&["margins", &path, "--environment", "UH-60", "--set", "k=-30"]);
    assert_eq!(code, 3, "{out}{err}");
    let g = pendulum_growth(-30.0);
    assert!(
        out.contains(&format!(
            "mode 1 is UNSTABLE: a divergent mode, growth rate Re λ = {g:.4} 1/s"
        )) || out.contains(&format!(
            "mode 2 is UNSTABLE: a divergent mode, growth rate Re λ = {g:.4} 1/s"
        )),
        "{out}"
    );
    assert!(out.contains("FAIL: the equilibrium is unstable"), "{out}");
    assert!(!out.contains("PASS"), "{out}");
    let (code, out, _) = repo(&[
        "margins",
        &path,
        "--environment",
        "UH-60",
        "--set",
        "k=-30",
        "--json",
    ]);
    assert_eq!(code, 3);
    let j = json(&out);
    assert_eq!(j["pass"], false);
    let u = j["unstable"].as_array().unwrap();
    assert_eq!(u.len(), 1, "{u:?}");
    let r = u[0]["growth_rate_1_s"].as_f64().unwrap();
    assert!((r - g).abs() < 1e-9 * g, "{r} vs the closed form {g}");
    assert_eq!(u[0]["omega_d_rad_s"], 0.0);
    // a stable pendulum has none, and the key is there
    let (code, out, _) = repo(&["margins", &path, "--environment", "UH-60", "--json"]);
    assert_eq!(code, 0);
    assert_eq!(json(&out)["unstable"].as_array().unwrap().len(), 0);

    // the inceptor with a negative force-sensor stiffness (the audit's case): its third
    // mode clears every line by 11.6 %, but the equilibrium diverges
    let (code, out, _) = repo(&[
        "margins",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--set",
        "k_fs=-20000",
    ]);
    assert_eq!(code, 3, "{out}");
    assert!(
        out.contains("is UNSTABLE: a divergent mode, growth rate Re λ = 5.8357 1/s"),
        "{out}"
    );
    assert!(!out.contains("PASS"), "{out}");
}

/// The library's check: `with_unstable` fails a passing table.
#[test]
fn with_unstable_fails_a_passing_check() {
    let env = resolve("UH-60").unwrap();
    let modes = [ModeInterval::point("m", 5.0, 0.05)];
    let c = check_margins(&modes, &env.forcing_lines(), 0.1, Requirement::Fixed).unwrap();
    assert!(c.pass && c.unstable.is_empty());
    let u = detune::margins::UnstableMode {
        mode: "m".into(),
        growth_rate_1_s: 1.0,
        omega_d_rad_s: 0.0,
    };
    let c = c.with_unstable(vec![u]);
    assert!(!c.pass);
}
