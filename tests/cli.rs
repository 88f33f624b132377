//! The command-line contract: check, simulate, CSV layout, JSON provenance.

use std::process::Command;

fn detune(args: &[&str]) -> (i32, String, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .output()
        .unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn check_reports_rank_and_degrees_of_freedom() {
    let (code, out, err) = detune(&["check", "models/overcentre.toml"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("constraint rank at the initial pose: 5 of 5"),
        "{out}"
    );
    assert!(out.contains("degrees of freedom: 1"), "{out}");
    assert!(
        out.contains("bar1.theta") && out.contains("B.slot"),
        "{out}"
    );
    assert!(out.contains("2.8284271247461903"), "L1 in SI: {out}");
}

#[test]
fn simulate_writes_csv_svg_and_json_with_provenance() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("o.csv");
    let svg = dir.path().join("o.svg");
    let json = dir.path().join("o.json");
    let (code, _, err) = detune(&[
        "simulate",
        "models/overcentre.toml",
        "--set",
        "Fs=-3",
        "--set",
        "omega=4.3 Hz",
        "--set",
        "F0=0.5",
        "--t-end",
        "1",
        "--dt-out",
        "0.25",
        "--velocities",
        "-o",
        csv.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        "t,bar1.x,bar1.y,bar1.theta,bar2.x,bar2.y,bar2.theta,bar1.x_dot,bar1.y_dot,bar1.theta_dot,bar2.x_dot,bar2.y_dot,bar2.theta_dot"
    );
    assert_eq!(lines.len(), 1 + 5, "t = 0, 0.25, 0.5, 0.75, 1");
    let last: Vec<f64> = lines[5].split(',').map(|x| x.parse().unwrap()).collect();
    assert_eq!(last[0], 1.0);
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(j["provenance"]["overrides"][0], "Fs=-3");
    assert_eq!(j["provenance"]["model_sha256"].as_str().unwrap().len(), 64);
    assert_eq!(j["provenance"]["detune_version"], env!("CARGO_PKG_VERSION"));
    assert!(j["stats"]["max_constraint_residual"].as_f64().unwrap() < 1e-10);
}

#[test]
fn bad_option_values_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("o.csv");
    for (flag, value) in [("--dt-out", "0"), ("--t-end", "-1"), ("--rtol", "0")] {
        let (code, _, err) = detune(&[
            "simulate",
            "models/overcentre.toml",
            flag,
            value,
            "-o",
            csv.to_str().unwrap(),
        ]);
        assert_eq!(code, 1, "{flag} {value}: {err}");
        assert!(err.contains(flag) && err.contains("help"), "{err}");
        assert!(!csv.exists());
    }
}
