//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod reduced;

use std::path::Path;

/// Reads a numeric CSV file with one header line: returns the column names and the rows.
/// Panics on a missing file, a ragged row or a non-numeric field (this is test code).
pub fn read_csv(path: impl AsRef<Path>) -> (Vec<String>, Vec<Vec<f64>>) {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<String> = lines
        .next()
        .unwrap_or_else(|| panic!("{} is empty", path.display()))
        .split(',')
        .map(|h| h.trim().to_string())
        .collect();
    let rows = lines
        .enumerate()
        .map(|(i, line)| {
            let row: Vec<f64> = line
                .split(',')
                .map(|f| {
                    f.trim().parse().unwrap_or_else(|e| {
                        panic!("{} line {}: bad number {f:?}: {e}", path.display(), i + 2)
                    })
                })
                .collect();
            assert_eq!(
                row.len(),
                header.len(),
                "{} line {}: wrong field count",
                path.display(),
                i + 2
            );
            row
        })
        .collect();
    (header, rows)
}

/// Path of a file in `tests/data`.
pub fn data(name: &str) -> String {
    format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// The shipped overcentre model file's text (for variants made by replacing a line).
pub fn overcentre_text() -> String {
    std::fs::read_to_string(format!(
        "{}/models/overcentre.toml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

/// The shipped overcentre model with `--set`-style overrides.
pub fn overcentre(sets: &[(&str, &str)]) -> detune::Model {
    with_sets(
        detune::Model::load(&format!(
            "{}/models/overcentre.toml",
            env!("CARGO_MANIFEST_DIR")
        ))
        .unwrap(),
        sets,
    )
}

/// A model from its text (`name` used in messages) with `--set`-style overrides.
pub fn from_text(name: &str, text: &str, sets: &[(&str, &str)]) -> detune::Model {
    with_sets(detune::Model::from_str(name, text).unwrap(), sets)
}

/// `model` with `--set`-style overrides (panics on a bad one: test code).
pub fn with_sets(model: detune::Model, sets: &[(&str, &str)]) -> detune::Model {
    let sets: Vec<(String, String)> = sets
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    model.with_overrides(&sets).unwrap()
}

/// The shared reference values (`reference.json`).
pub fn reference() -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(data("reference.json")).unwrap()).unwrap()
}

/// Run the detune binary from the crate root: (exit code, stdout, stderr); -1 for a
/// process ended by a signal.
pub fn detune(args: &[&str]) -> (i32, String, String) {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_detune"))
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

/// Run `detune ARGS` in `dir` (stdin empty, stdout and stderr to files there); kill it
/// and fail the test if it has not returned within 20 s (a hang). Returns the exit code
/// (None: a signal), stdout and stderr.
pub fn run_within_20s(dir: &Path, args: &[&str]) -> (Option<i32>, String, String) {
    use std::process::{Command, Stdio};
    use std::time::{Duration, Instant};
    let out_path = dir.join("stdout.txt");
    let err_path = dir.join("stderr.txt");
    let mut child = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(dir)
        .args(args)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out_path).unwrap())
        .stderr(std::fs::File::create(&err_path).unwrap())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(20) {
            let _ = child.kill();
            let _ = child.wait();
            panic!("detune {:.200?} did not return within 20 s", args);
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    (
        status.code(),
        std::fs::read_to_string(&out_path).unwrap(),
        std::fs::read_to_string(&err_path).unwrap(),
    )
}

/// The largest relative difference of an `nfr` curve's amplitudes (its first response,
/// `response`) from the linear response (`frf`) at its points' frequencies.
pub fn worst_against_frf(
    sys: &detune::System,
    c: &detune::periodic::continuation::Nfr,
    response: &str,
) -> f64 {
    let w: Vec<f64> = c.points.iter().map(|p| p.omega).collect();
    let fr = detune::linear::frequency_response(sys, "omega", &w, &[response.into()]).unwrap();
    c.points
        .iter()
        .zip(&fr.values)
        .map(|(p, v)| (p.measures[0].amplitude / v[0].0 - 1.0).abs())
        .fold(0.0, f64::max)
}
