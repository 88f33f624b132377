//! The command-line contract: check, simulate, CSV layout, JSON provenance.

mod common;
use common::detune;
use std::process::Command;

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
    // Negative values in exponent notation reach detune's own checks (clap once took
    // `-1e-3` for a flag).
    for (flag, value) in [
        ("--dt-out", "0"),
        ("--t-end", "-1"),
        ("--rtol", "0"),
        ("--rtol", "-1e-3"),
        ("--atol", "-1e-3"),
    ] {
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

#[test]
fn equilibrium_json_contract() {
    let (code, out, err) = detune(&[
        "equilibrium",
        "models/overcentre.toml",
        "--set",
        "theta1_0=-0.85",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(
        (j["coordinates"]["bar1.theta"].as_f64().unwrap() - (-0.865739159594518)).abs() < 1e-12
    );
    assert_eq!(j["stable"], true);
    assert!(j["residual"].as_f64().unwrap() < 1e-10);
    let (code, out, _) = detune(&["equilibrium", "models/overcentre.toml", "--all", "--json"]);
    assert_eq!(code, 0);
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    let stable: Vec<bool> = j["equilibria"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["stable"].as_bool().unwrap())
        .collect();
    assert_eq!(stable, [true, false, true]);
}

#[test]
fn continue_json_and_csv_contract() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("s.csv");
    let svg = dir.path().join("s.svg");
    let (code, out, err) = detune(&[
        "continue",
        "models/overcentre.toml",
        "--param",
        "Fs",
        "--from",
        "-10",
        "--to",
        "30",
        "--step",
        "0.5",
        "--json",
        "-o",
        csv.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(j["param"], "Fs");
    let folds = j["folds"].as_array().unwrap();
    assert_eq!(folds.len(), 2);
    assert!((folds[0]["value"].as_f64().unwrap() - 23.0614126719).abs() < 1e-8);
    assert!(j["branch_points"].as_array().unwrap().is_empty());
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        "Fs,bar1.x,bar1.y,bar1.theta,bar2.x,bar2.y,bar2.theta,stable,branch"
    );
    assert_eq!(lines.len() - 1, j["points"].as_u64().unwrap() as usize);
    // stable, on branch 0 (no branch point: the one followed from the start only)
    assert!(lines[1].starts_with("-10,") && lines[1].ends_with(",1,0"));
    assert_eq!(j["branches"].as_array().unwrap().len(), 1);
    let svg = std::fs::read_to_string(&svg).unwrap();
    // Figure 6: legend entries for both kinds of branch and the folds, one marker per
    // fold (and one in the legend), and the unstable branch drawn dashed.
    let texts: Vec<&str> = svg
        .split("<text")
        .skip(1)
        .filter_map(|t| t.split_once('>').and_then(|(_, r)| r.split_once("</text>")))
        .map(|(inner, _)| inner.trim())
        .collect();
    for label in ["stable", "unstable", "folds"] {
        assert!(texts.contains(&label), "no legend entry {label}: {texts:?}");
    }
    assert_eq!(svg.matches("data-marker=\"diamond\"").count(), 2 + 1);
    assert!(svg.contains("stroke-dasharray"));
}

#[test]
fn modes_json_contract_stable_and_unstable() {
    let (code, out, err) = detune(&[
        "modes",
        "models/overcentre.toml",
        "--set",
        "theta1_0=-0.85",
        "--set",
        "c=1",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    let m = &j["modes"][0];
    assert!((m["omega_n_rad_s"].as_f64().unwrap() - 4.285913414135145).abs() < 1e-7);
    assert!((m["omega_d_rad_s"].as_f64().unwrap() - 4.282972036981866).abs() < 1e-7);
    assert!(
        (m["freq_hz"].as_f64().unwrap() - 4.285913414135145 / (2.0 * std::f64::consts::PI)).abs()
            < 1e-8
    );
    assert_eq!(m["shape"]["bar1.theta"]["re"], 1.0);
    assert!(j["undamped_omega2"][0].as_f64().unwrap() > 0.0);
    // starting at 15°: the unstable middle equilibrium, real eigenvalues, ω² < 0
    let (code, out, _) = detune(&[
        "modes",
        "models/overcentre.toml",
        "--set",
        "theta1_0=15 deg",
        "--set",
        "c=1",
        "--json",
    ]);
    assert_eq!(code, 0);
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(j["stable"], false);
    assert!(j["undamped_omega2"][0].as_f64().unwrap() < 0.0);
    for m in j["modes"].as_array().unwrap() {
        assert_eq!(m["eigenvalue"]["im"], 0.0);
        assert_eq!(m["omega_d_rad_s"], 0.0);
    }
}

#[test]
fn frf_csv_contract() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("f.csv");
    let (code, _, err) = detune(&[
        "frf",
        "models/overcentre.toml",
        "--set",
        "theta1_0=-0.85",
        "--set",
        "F0=0.01",
        "--set",
        "c=1",
        "--param",
        "omega",
        "--from",
        "0.5",
        "--to",
        "8",
        "--step",
        "0.5",
        "--response",
        "bar1.theta",
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "omega,bar1.theta_amplitude,bar1.theta_phase_deg");
    assert_eq!(lines.len(), 1 + 16);
}

#[test]
fn bad_analysis_requests_are_refused() {
    let cases: &[(&[&str], &str)] = &[
        (
            &[
                "continue",
                "models/overcentre.toml",
                "--param",
                "Fz",
                "--from",
                "0",
                "--to",
                "1",
            ],
            "`Fs`",
        ),
        (
            &[
                "continue",
                "models/overcentre.toml",
                "--param",
                "Fs",
                "--from",
                "1",
                "--to",
                "1",
            ],
            "empty range",
        ),
        (
            &[
                "continue",
                "models/overcentre.toml",
                "--param",
                "Fs",
                "--from",
                "0",
                "--to",
                "1",
                "--step",
                "0",
            ],
            "--step",
        ),
        (
            &[
                "frf",
                "models/overcentre.toml",
                "--param",
                "omega",
                "--from",
                "1",
                "--to",
                "2",
                "--step",
                "0.5",
            ],
            "zero forcing",
        ),
        (
            &[
                "frf",
                "models/overcentre.toml",
                "--set",
                "F0=1",
                "--param",
                "omega",
                "--from",
                "2",
                "--to",
                "1",
                "--step",
                "0.5",
            ],
            "empty range",
        ),
        (
            // not finite is not "empty" (was: "empty range: --from NaN --to 3")
            &[
                "sweep",
                "models/overcentre.toml",
                "--set",
                "F0=1",
                "--param",
                "omega",
                "--from",
                "nan",
                "--to",
                "3",
                "--step",
                "0.5",
            ],
            "--from NaN --to 3: not finite",
        ),
        (
            &[
                "frf",
                "models/overcentre.toml",
                "--set",
                "F0=1",
                "--param",
                "omega",
                "--from",
                "1",
                "--to",
                "2",
                "--step",
                "-1",
            ],
            "--step",
        ),
        (
            &["modes", "models/overcentre.toml", "--normalize", "bar1.phi"],
            "bar1.phi",
        ),
        (
            &["equilibrium", "models/overcentre.toml", "--set", "Fs=1e6"],
            "no equilibrium",
        ),
    ];
    for (args, want) in cases {
        let (code, out, err) = detune(args);
        assert_eq!(code, 1, "{args:?}: {out} {err}");
        assert!(
            err.contains(want) && err.contains("help"),
            "{args:?}: {err}"
        );
    }
    // --values: the swept parameter, an empty name or entry, a zero amplitude in the list
    // (refused before the first entries are swept)
    let sweep = "sweep models/overcentre.toml --set F0=1 --param omega --from 3 --to 4 --step 0.5";
    for (values, want) in [
        ("omega=1", "is the swept parameter"),
        ("=1,2", "no parameter named"),
        ("F0=1,,2", "an empty entry"),
        ("F0=4,3,0", "--values F0=0: zero forcing"),
    ] {
        let mut args: Vec<&str> = sweep.split(' ').collect();
        args.extend(["--values", values]);
        let (code, out, err) = detune(&args);
        assert_eq!(code, 1, "{values}: {out} {err}");
        assert!(
            err.contains(want) && err.contains("help"),
            "{values}: {err}"
        );
    }
}

#[test]
fn sweep_csv_and_json_contract() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("fr.csv");
    let svg = dir.path().join("fr.svg");
    let (code, out, err) = detune(&[
        "sweep",
        "models/overcentre.toml",
        "--set",
        "theta1_0=-0.85",
        "--set",
        "c=1",
        "--param",
        "omega",
        "--from",
        "3.8",
        "--to",
        "4.6",
        "--step",
        "0.2",
        "--refine",
        "0.05",
        "--response",
        "bar1.theta",
        "--values",
        "F0=0.5,1",
        "--json",
        "-o",
        csv.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let header = text.lines().next().unwrap();
    assert_eq!(
        header,
        "omega,direction,F0,bar1.theta_amplitude,bar1.theta_max,bar1.theta_min,bar1.theta_mean,bar1.theta_h1,bar1.theta_phase_deg,bar1.theta_h2,bar1.theta_thd,settled,periods,period_multiple,refined,well"
    );
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(j["complete"], true);
    let points = j["points"].as_array().unwrap();
    assert_eq!(points.len(), text.lines().count() - 1);
    assert_eq!(points[0]["direction"], "independent");
    assert!(points[0]["bar1.theta_amplitude"].as_f64().unwrap() > 0.0);
    let peaks = j["peaks"].as_array().unwrap();
    assert_eq!(peaks.len(), 2, "one per F0");
    assert!(
        peaks
            .iter()
            .all(|p| (p["omega"].as_f64().unwrap() - 4.27).abs() < 0.05
                && p["uncertainty"].as_f64().unwrap() <= 0.025)
    );
    assert!((j["equilibrium"]["bar1.theta"].as_f64().unwrap() + 0.8657391595945).abs() < 1e-9);
    assert!(
        std::fs::read_to_string(&svg)
            .unwrap()
            .contains("amplitude / F0")
    );
}

#[test]
fn interrupted_sweep_writes_a_complete_file_marked_incomplete() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("fr.csv");
    let child = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "sweep",
            "models/overcentre.toml",
            "--set",
            "theta1_0=-0.85",
            "--set",
            "F0=4",
            "--set",
            "c=0.2",
            "--param",
            "omega",
            "--from",
            "0.5",
            "--to",
            "8",
            "--step",
            "0.002",
            "--mode",
            "up",
            "--response",
            "bar1.theta",
            "-o",
            csv.to_str().unwrap(),
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    // 130: interrupted by SIGINT, partial results kept
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted"), "{err}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].starts_with("omega,direction,bar1.theta_amplitude"));
    assert!(lines.last().unwrap().starts_with("# incomplete"));
    assert!(
        lines.len() > 2 && lines.len() < 3000,
        "{} rows",
        lines.len()
    );
    for row in &lines[1..lines.len() - 1] {
        assert_eq!(row.split(',').count(), lines[0].split(',').count());
    }
}

/// Regression: a mechanism with no degree of freedom made `modes` panic in the eigen
/// solver (an empty matrix).
#[test]
fn modes_of_a_mechanism_without_degrees_of_freedom() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("fixed.toml");
    std::fs::write(
        &model,
        "[[bodies]]\nname = \"a\"\nmass = 1\ninertia = 1\nfix = [\"x\", \"y\", \"theta\"]\n\n[[joints]]\ntype = \"fixed\"\nbody1 = \"a\"\n",
    )
    .unwrap();
    let (code, out, err) = detune(&["modes", model.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("no degrees of freedom"), "{out}");
    let (code, out, _) = detune(&["modes", model.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0);
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(j["modes"].as_array().unwrap().is_empty());
    // Regression: `equilibrium --all` swept its fixed coordinates and panicked in
    // nalgebra's SVD of an empty matrix (no free coordinate to re-assemble)
    let (code, out, err) = detune(&["equilibrium", model.to_str().unwrap(), "--all", "--json"]);
    assert_eq!(code, 0, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    let list = j["equilibria"].as_array().unwrap();
    assert_eq!(list.len(), 1, "{out}");
    assert_eq!(list[0]["coordinates"]["a.theta"].as_f64(), Some(0.0));
}

#[test]
fn modes_tracking_reads_quantities_and_refuses_bad_ranges() {
    let m = "models/inceptor.toml";
    let (code, si, _) = detune(&[
        "modes", m, "--param", "k_t", "--from", "200", "--to", "900", "--points", "3", "--json",
    ]);
    assert_eq!(code, 0);
    let (code, q, _) = detune(&[
        "modes",
        m,
        "--param",
        "k_t",
        "--from",
        "200 N*m/rad",
        "--to",
        "0.9 kN*m/rad",
        "--points",
        "3",
        "--json",
    ]);
    assert_eq!(code, 0);
    let value = |s: &str| -> serde_json::Value { serde_json::from_str(s).unwrap() };
    assert_eq!(
        value(&si)["tracking"]["steps"],
        value(&q)["tracking"]["steps"]
    );
    for (args, said) in [
        (vec!["--from", "2", "--to", "2"], "--from 2 --to 2"),
        (
            vec!["--from", "200", "--to", "300", "--step", "-1"],
            "--step -1",
        ),
        (vec!["--from", "200 mm", "--to", "300"], "--from 200 mm"),
    ] {
        let mut all = vec!["modes", m, "--param", "k_t"];
        all.extend(args);
        let (code, _, err) = detune(&all);
        assert_ne!(code, 0);
        assert!(err.contains(said), "{err}");
    }
    // a parameter the trim solves follows the others: it cannot be tracked
    let (code, _, err) = detune(&["modes", m, "--param", "L0", "--from", "0.1", "--to", "0.11"]);
    assert_ne!(code, 0);
    assert!(
        err.contains("`L0` is solved by the model's [trim]"),
        "{err}"
    );
}

/// Issue 10 point 4: `--from/--to/--step/--refine` take frequency quantities and
/// `--t-end/--dt-out` time quantities, as `--set` does; a wrong dimension is refused with
/// a hint. Each quantity grid equals the same grid in SI.
#[test]
fn grids_and_times_accept_quantities() {
    let tau = std::f64::consts::TAU;
    let frf = |from: &str, to: &str, step: &str| -> Vec<f64> {
        let (code, out, err) = detune(&[
            "frf",
            "models/overcentre.toml",
            "--set",
            "F0=1",
            "--param",
            "omega",
            "--from",
            from,
            "--to",
            to,
            "--step",
            step,
            "--response",
            "bar1.theta",
            "--json",
        ]);
        assert_eq!(code, 0, "{err}");
        let j: serde_json::Value = serde_json::from_str(&out).unwrap();
        j["points"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["omega"].as_f64().unwrap())
            .collect()
    };
    let hz = frf("0.5 Hz", "1 Hz", "0.1 Hz");
    let si = frf(
        &(0.5 * tau).to_string(),
        &tau.to_string(),
        &(0.1 * tau).to_string(),
    );
    assert_eq!(hz.len(), 6);
    for (a, b) in hz.iter().zip(&si) {
        assert!((a - b).abs() < 1e-12, "{a} vs {b}");
    }
    let rpm = frf("30 rpm", "60 rpm", "6 rpm");
    assert!((rpm[0] - std::f64::consts::PI).abs() < 1e-9 && rpm.len() == 6);
    let (code, _, err) = detune(&[
        "frf",
        "models/overcentre.toml",
        "--set",
        "F0=1",
        "--param",
        "omega",
        "--from",
        "3 kg",
        "--to",
        "2",
        "--step",
        "0.1",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("--from 3 kg") && err.contains("Hz"), "{err}");
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("s.csv");
    let (code, _, err) = detune(&[
        "simulate",
        "models/overcentre.toml",
        "--t-end",
        "500 ms",
        "--dt-out",
        "100 ms",
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let last = text
        .lines()
        .last()
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .parse::<f64>()
        .unwrap();
    assert!(
        (last - 0.5).abs() < 1e-12 && text.lines().count() == 7,
        "{text}"
    );
    let (code, _, err) = detune(&[
        "simulate",
        "models/overcentre.toml",
        "--t-end",
        "2 m",
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("--t-end 2 m"), "{err}"); // sweep takes the same quantities (its grid in Hz is the rad/s grid × 2π), and
    // --refine is checked like the grid: a frequency step, not a mass
    let sweep = |refine: &str| {
        detune(&[
            "sweep",
            "models/overcentre.toml",
            "--set",
            "F0=1",
            "--param",
            "omega",
            "--from",
            "0.5 Hz",
            "--to",
            "0.6 Hz",
            "--step",
            "0.05 Hz",
            "--refine",
            refine,
            "--response",
            "bar1.theta",
            "--json",
        ])
    };
    let (code, out, err) = sweep("0.001 Hz");
    assert_eq!(code, 0, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    let grid: Vec<f64> = j["points"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| p["refined"] == false)
        .map(|p| p["omega"].as_f64().unwrap())
        .collect();
    assert_eq!(grid.len(), 3, "{grid:?}");
    // (a grid value is rounded to 9 more decimals than its step: 3.1415926536)
    for (w, f) in grid.iter().zip([0.5, 0.55, 0.6]) {
        assert!(
            (w - tau * f).abs() < 1e-9 * tau * 0.05,
            "{w} vs {}",
            tau * f
        );
    }
    let (code, _, err) = sweep("3 kg");
    assert_eq!(code, 1);
    assert!(err.contains("--refine 3 kg"), "{err}");
}

/// A standard output that refuses the write (`> /dev/full`): an error that says so,
/// exit 1, not a panic (it was exit 101, "failed printing to stdout"), for a command
/// that prints a table (`modes`) and one that prints JSON (`nfr --json`).
#[cfg(target_os = "linux")]
#[test]
fn a_full_standard_output_is_an_error_not_a_panic() {
    for args in [
        &["modes", "models/overcentre.toml"][..],
        &[
            "nfr",
            "models/overcentre.toml",
            "--set",
            "theta1_0=-0.85",
            "--set",
            "c=1",
            "--set",
            "F0=0.01",
            "--param",
            "omega",
            "--from",
            "3",
            "--to",
            "3.5",
            "--response",
            "bar1.theta",
            "--json",
        ][..],
    ] {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let o = Command::new(env!("CARGO_BIN_EXE_detune"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(args)
            .stdout(full)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains("cannot write to standard output: No space left on device")
                && !err.contains("panicked"),
            "{args:?}: {err}"
        );
    }
}
