//! Snapshots of every command's outputs on the shipped overcentre, with small settings:
//!
//! * `*.json.keys`: the JSON's structure: every key path in order with the type of its
//!   value (`integer`, `float`, `string`, `bool`, `null`, `array`, `object`); an array
//!   is summarized by the structure of its elements (each distinct one once);
//! * `*.csv.header`: the CSV's header line;
//! * `*.txt`: the text on stdout and stderr, numbers replaced by `#` and runs of spaces
//!   by one (the layout of the lines, their words and their order);
//! * `*.svg.labels`: the SVG's texts (titles, axis labels, legend), tick labels left out
//!   and numbers replaced by `#`.
//! * `request_errors.txt`: the exact stderr and exit code of each kind of invalid
//!   request (numbers kept: they are what the messages are about).
//!
//! Values that vary (numbers, the model path, the SHA) are not pinned, except a few
//! stable numbers checked here directly. The expected files are in `tests/snapshots/`;
//! `DETUNE_UPDATE_SNAPSHOTS=1 cargo test --release --test snapshots` rewrites them (then
//! review the diff).

use serde_json::Value;
use std::path::Path;
use std::process::Command;

const MODEL: &str = "models/overcentre.toml";

struct Run {
    stdout: String,
    stderr: String,
}

/// Run the binary from the crate root with the words of `line` (`MODEL` stands for the
/// shipped model) and then `extra`; it must succeed.
fn detune(line: &str, extra: &[&str]) -> Run {
    let mut args: Vec<&str> = line
        .split_whitespace()
        .map(|w| if w == "MODEL" { MODEL } else { w })
        .collect();
    args.extend(extra);
    let o = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(&args)
        .output()
        .unwrap();
    let run = Run {
        stdout: String::from_utf8_lossy(&o.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
    };
    assert_eq!(o.status.code(), Some(0), "{args:?}: {}", run.stderr);
    run
}

/// Compare `actual` with `tests/snapshots/<name>` (or write it when updating).
fn snapshot(name: &str, actual: &str) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/snapshots")
        .join(name);
    if std::env::var_os("DETUNE_UPDATE_SNAPSHOTS").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, actual).unwrap();
        return;
    }
    let expected = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (DETUNE_UPDATE_SNAPSHOTS=1 writes it)",
            path.display()
        )
    });
    assert!(
        expected == actual,
        "snapshot {name} differs\n--- expected\n{expected}\n--- actual\n{actual}"
    );
}

/// The structure of a JSON value, one line per key path (see the module docs).
fn shape(v: &Value, path: &str, out: &mut Vec<String>) {
    let at = if path.is_empty() { "(root)" } else { path };
    match v {
        Value::Null => out.push(format!("{at}: null")),
        Value::Bool(_) => out.push(format!("{at}: bool")),
        Value::Number(n) if n.is_f64() => out.push(format!("{at}: float")),
        Value::Number(_) => out.push(format!("{at}: integer")),
        Value::String(_) => out.push(format!("{at}: string")),
        Value::Object(map) => {
            out.push(format!("{at}: object"));
            for (k, x) in map {
                shape(x, &format!("{path}/{k}"), out);
            }
        }
        Value::Array(items) if items.is_empty() => out.push(format!("{at}: array (empty)")),
        Value::Array(items) => {
            out.push(format!("{at}: array"));
            let mut distinct: Vec<Vec<String>> = Vec::new();
            for x in items {
                let mut lines = Vec::new();
                shape(x, &format!("{path}/[]"), &mut lines);
                if !distinct.contains(&lines) {
                    distinct.push(lines);
                }
            }
            let several = distinct.len() > 1;
            for (k, lines) in distinct.into_iter().enumerate() {
                if several {
                    out.push(format!("{path}/[] variant {}:", k + 1));
                }
                out.extend(lines);
            }
        }
    }
}

/// Parse JSON text (key order kept) and pin its structure as `<name>.json.keys`.
fn json_snapshot(name: &str, text: &str) -> Value {
    let v: Value = serde_json::from_str(text).unwrap_or_else(|e| panic!("{name}: {e}\n{text}"));
    let mut lines = Vec::new();
    shape(&v, "", &mut lines);
    snapshot(&format!("{name}.json.keys"), &(lines.join("\n") + "\n"));
    v
}

/// Pin the header line of a CSV file as `<name>.csv.header`.
fn csv_header_snapshot(name: &str, path: &Path) {
    let text = std::fs::read_to_string(path).unwrap();
    let header = text.lines().next().unwrap();
    snapshot(&format!("{name}.csv.header"), &format!("{header}\n"));
}

/// Numbers replaced by `#` (not the digits of a name such as `bar1.theta` or `F0`), and
/// runs of spaces by one.
fn mask(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let prev = if i > 0 { chars[i - 1] } else { ' ' };
        let in_name = prev.is_alphanumeric() || prev == '_' || prev == '.';
        let signed = (c == '-' || c == '+')
            && chars.get(i + 1).is_some_and(|d| d.is_ascii_digit())
            && !in_name;
        if (c.is_ascii_digit() && !in_name) || signed {
            i += 1;
            while i < chars.len() {
                let d = chars[i];
                let exponent = (d == 'e' || d == 'E')
                    && chars.get(i + 1).is_some_and(|x| {
                        x.is_ascii_digit()
                            || ((*x == '-' || *x == '+')
                                && chars.get(i + 2).is_some_and(|y| y.is_ascii_digit()))
                    });
                if d.is_ascii_digit()
                    || (d == '.' && chars.get(i + 1).is_some_and(|x| x.is_ascii_digit()))
                {
                    i += 1;
                } else if exponent {
                    i += 2;
                } else {
                    break;
                }
            }
            out.push('#');
        } else if c == ' ' && out.ends_with(' ') {
            i += 1;
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

/// Pin the masked stdout and stderr as `<name>.txt`, the temporary directory named `DIR`.
fn text_snapshot(name: &str, run: &Run, dir: Option<&Path>) {
    let mut text = format!("--- stdout\n{}--- stderr\n{}", run.stdout, run.stderr);
    if let Some(d) = dir {
        text = text.replace(d.to_str().unwrap(), "DIR");
    }
    snapshot(&format!("{name}.txt"), &mask(&text));
}

/// Pin an SVG's texts (titles, axis labels, legend entries; not the tick labels) as
/// `<name>.svg.labels`.
fn svg_snapshot(name: &str, path: &Path) {
    let svg = std::fs::read_to_string(path).unwrap();
    let labels: Vec<String> = svg
        .split("<text")
        .skip(1)
        .filter_map(|t| t.split_once('>').and_then(|(_, r)| r.split_once("</text>")))
        .map(|(inner, _)| mask(inner.trim()))
        .filter(|l| l.trim_start_matches('-') != "#")
        .collect();
    snapshot(&format!("{name}.svg.labels"), &(labels.join("\n") + "\n"));
}

fn close(v: &Value, want: f64, tol: f64) {
    let x = v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"));
    assert!((x - want).abs() <= tol, "{x} is not {want} ± {tol}");
}

/// Output files in a temporary directory: the directory and each file's path.
fn outputs<const N: usize>(names: [&str; N]) -> (tempfile::TempDir, [String; N]) {
    let dir = tempfile::tempdir().unwrap();
    let paths = names.map(|n| dir.path().join(n).to_str().unwrap().to_string());
    (dir, paths)
}

/// The run's stderr only (its stdout is JSON, pinned by structure).
fn stderr_of(run: Run) -> Run {
    Run {
        stdout: String::new(),
        ..run
    }
}

#[test]
fn check_text() {
    let run = detune("check MODEL --set F0=0.1", &["--set", "L1=2.5 m"]);
    text_snapshot("check", &run, None);
    assert!(
        run.stdout
            .contains("  L1           = 2.5                    m   (--set 2.5 m)")
    );
}

const SIMULATE: &str = "simulate MODEL --set F0=3 --set omega=1.5 --t-end 1 --dt-out 0.25";

#[test]
fn simulate_json_csv_svg_and_text() {
    let (dir, [csv, json, svg]) = outputs(["sim.csv", "sim.json", "sim.svg"]);
    let run = detune(
        SIMULATE,
        &["-o", &csv, "--json", &json, "--plot", &svg, "--velocities"],
    );
    text_snapshot("simulate", &run, Some(dir.path()));
    let j = json_snapshot("simulate", &std::fs::read_to_string(&json).unwrap());
    csv_header_snapshot("simulate_velocities", Path::new(&csv));
    svg_snapshot("simulate", Path::new(&svg));
    assert_eq!(j["output"], csv.as_str());
    assert_eq!(j["options"]["t_end"], 1.0);
    close(&j["final"]["t"], 1.0, 0.0);
    close(
        &j["final"]["coordinates"]["bar1.theta"],
        0.6287136400189275,
        1e-8,
    );
    // without --velocities
    detune(SIMULATE, &["-o", &csv]);
    csv_header_snapshot("simulate", Path::new(&csv));
}

#[test]
fn equilibrium_json_and_text() {
    let j = json_snapshot(
        "equilibrium",
        &detune("equilibrium MODEL --json", &[]).stdout,
    );
    close(&j["coordinates"]["bar1.theta"], 0.6444905415426762, 1e-9);
    text_snapshot("equilibrium", &detune("equilibrium MODEL", &[]), None);

    let run = detune("equilibrium MODEL --all --json", &[]);
    let j = json_snapshot("equilibrium_all", &run.stdout);
    let e = j["equilibria"].as_array().unwrap();
    assert_eq!(e.len(), 3);
    for (e, want) in e
        .iter()
        .zip([-0.8657391595945181, 0.2618802491386227, 0.6444905415426762])
    {
        close(&e["coordinates"]["bar1.theta"], want, 1e-9);
    }
    close(&e[1]["undamped_omega2"][0], -12.545275, 1e-5);
    text_snapshot(
        "equilibrium_all",
        &detune("equilibrium MODEL --all", &[]),
        None,
    );
}

const CONTINUE: &str = "continue MODEL --param Fs --from -10 --to 30 --step 0.5";

#[test]
fn continue_json_csv_svg_and_text() {
    let (dir, [csv, svg]) = outputs(["curve.csv", "curve.svg"]);
    let run = detune(CONTINUE, &["--json", "-o", &csv, "--plot", &svg]);
    let j = json_snapshot("continue", &run.stdout);
    text_snapshot("continue_json", &stderr_of(run), Some(dir.path()));
    csv_header_snapshot("continue", Path::new(&csv));
    svg_snapshot("continue", Path::new(&svg));
    assert_eq!(j["param"], "Fs");
    close(&j["folds"][1]["value"], -3.4414126718705225, 1e-8);
    close(
        &j["folds"][1]["coordinates"]["bar1.theta"],
        0.47147630595651285,
        1e-8,
    );
    text_snapshot("continue", &detune(CONTINUE, &[]), None);
}

#[test]
fn modes_json_and_text() {
    let j = json_snapshot("modes", &detune("modes MODEL --json", &[]).stdout);
    close(&j["modes"][0]["omega_n_rad_s"], 2.9731640996327213, 1e-9);
    close(&j["undamped_omega2"][0], 8.839704763344846, 1e-8);
    assert_eq!(j["normalized_to"], "bar1.theta");
    assert_eq!(j["modes"][0]["normalized_to"], "bar1.theta");
    text_snapshot("modes", &detune("modes MODEL", &[]), None);
}

const FRF: &str = "frf MODEL --set theta1_0=-0.85 --set F0=0.01 --set c=1 --param omega \
    --from 0.5 --to 8 --step 2.5 --response bar1.theta --response bar2.x";

#[test]
fn frf_json_csv_and_text() {
    let (dir, [csv]) = outputs(["frf.csv"]);
    let run = detune(FRF, &["--json", "-o", &csv]);
    let j = json_snapshot("frf", &run.stdout);
    text_snapshot("frf_json", &stderr_of(run), Some(dir.path()));
    csv_header_snapshot("frf", Path::new(&csv));
    let rel = |v: &Value, want: f64| close(v, want, 1e-9 * want.abs());
    rel(&j["points"][1]["omega"], 3.0);
    rel(
        &j["points"][1]["bar1.theta_amplitude"],
        0.00013319740756153738,
    );
    rel(&j["points"][1]["bar2.x_phase_deg"], -5.805316900292289);
    text_snapshot("frf", &detune(FRF, &[]), None);
}

/// A sweep near the first resonance of the lower well, refined.
const SWEEP: &str = "sweep MODEL --set theta1_0=-0.85 --set c=1 --param omega \
    --from 3.8 --to 4.6 --step 0.2 --refine 0.05 --response bar1.theta";

#[test]
fn sweep_json_csv_svg_and_text() {
    let (dir, [csv, svg]) = outputs(["fr.csv", "fr.svg"]);
    let line = format!("{SWEEP} --set F0=0.5");
    let run = detune(&line, &["--json", "-o", &csv, "--plot", &svg]);
    let j = json_snapshot("sweep", &run.stdout);
    text_snapshot("sweep_json", &stderr_of(run), Some(dir.path()));
    csv_header_snapshot("sweep", Path::new(&csv));
    svg_snapshot("sweep", Path::new(&svg));
    close(&j["equilibrium"]["bar1.theta"], -0.865739159594518, 1e-9);
    assert_eq!(j["points"][0]["direction"], "independent");
    assert_eq!(j["peaks"][0]["response"], "bar1.theta");
    text_snapshot("sweep", &detune(&line, &[]), None);
}

#[test]
fn sweep_values_json_csv_svg_and_text() {
    let (_dir, [csv, svg]) = outputs(["fr.csv", "fr.svg"]);
    let line = format!("{SWEEP} --values F0=0.1,1");
    let run = detune(&line, &["--json", "-o", &csv, "--plot", &svg]);
    let j = json_snapshot("sweep_values", &run.stdout);
    csv_header_snapshot("sweep_values", Path::new(&csv));
    svg_snapshot("sweep_values", Path::new(&svg));
    // every run's equilibria (the wells); `start` marks the one each run starts from
    let all = j["equilibria"].as_array().unwrap();
    assert_eq!(all.len(), 6);
    let e: Vec<&Value> = all.iter().filter(|e| e["start"] == true).collect();
    assert_eq!(e.len(), 2);
    close(&e[0]["F0"], 0.1, 0.0);
    close(&e[1]["F0"], 1.0, 0.0);
    close(&e[1]["coordinates"]["bar1.theta"], -0.865739159594518, 1e-9);
    text_snapshot("sweep_values", &detune(&line, &[]), None);
}

/// Up and down at 4 N: the jump, hysteresis entries (with the --values parameter), and
/// a static load in --values (the natural frequencies then differ between runs).
#[test]
fn sweep_both_directions_and_a_static_load_in_values() {
    let (dir, [csv, svg]) = outputs(["fr.csv", "fr.svg"]);
    let both = "sweep MODEL --set theta1_0=-0.85 --set c=0.2 --param omega --from 3 --to 4 \
        --step 0.25 --mode both --response bar1.theta --values F0=4 --settle-tol 1e-4";
    let run = detune(both, &["--json", "-o", &csv, "--plot", &svg]);
    let j = json_snapshot("sweep_both", &run.stdout);
    csv_header_snapshot("sweep_both", Path::new(&csv));
    svg_snapshot("sweep_both", Path::new(&svg));
    assert!(!j["hysteresis"].as_array().unwrap().is_empty());
    text_snapshot("sweep_both", &detune(both, &[]), None);

    let line = format!("{SWEEP} --set F0=0.5 --values Fs=0,2");
    let run = detune(&line, &["-o", &csv, "--plot", &svg]);
    text_snapshot("sweep_static_values", &run, Some(dir.path()));
    svg_snapshot("sweep_static_values", Path::new(&svg));
}

/// Every kind of invalid request the command line can make, with its exact stderr and
/// exit code (numbers not masked: they are what the message is about): the library's
/// typed requests worded with the flags (`cli::advice`), in a `--values` run too.
#[test]
fn request_errors() {
    let fit = "--param omega --from 3 --to 4 --step 0.5";
    let lines = [
        "frf MODEL --param omega --from 3 --to 1 --step 0.5".to_string(),
        "frf MODEL --param omega --from inf --to inf --step 0.5".into(),
        "frf MODEL --param omega --from 1 --to 2 --step 0".into(),
        "frf MODEL --param omega --from 1 --to 2 --step nan".into(),
        "frf MODEL --param omega --from 0 --to 100 --step 1e-9".into(),
        "frf MODEL --param k --from 1 --to 2 --step 0.5".into(),
        "frf MODEL --param omegaa --from 1 --to 2 --step 0.5".into(),
        "frf MODEL --param zzzzz --from 1 --to 2 --step 0.5".into(),
        "frf MODEL --param omega --from -1 --to 1 --step 0.5".into(),
        "frf MODEL --set F0=1 --param omega --from 1 --to 2 --step 0.5 --response bar3.theta"
            .into(),
        "frf MODEL --set F0=1 --param omega --from 1 --to 2 --step 0.5 --response xyz".into(),
        format!("sweep MODEL --set F0=1 {fit} --refine 0"),
        format!("sweep MODEL --set F0=1 {fit} --refine inf"),
        format!("sweep MODEL --set F0=1 {fit} --refine 1"),
        format!("sweep MODEL --set F0=1 {fit} --max-periods 0"),
        format!("sweep MODEL --set F0=1 {fit} --settle-tol 1"),
        format!("sweep MODEL --set F0=1 {fit} --settle-tol nan"),
        format!("sweep MODEL {fit} --values F0"),
        format!("sweep MODEL {fit} --values =1,2"),
        format!("sweep MODEL {fit} --values omega=1,2"),
        format!("sweep MODEL {fit} --values F0=1,,2"),
        format!("sweep MODEL {fit} --values zz=1"),
        format!("sweep MODEL --set F0=1 {fit} --values m1=1,-1"),
        format!("sweep MODEL {fit} --values F0=0,1"),
        format!("sweep MODEL {fit} --values F0=1,2 --refine 5"),
        format!("sweep MODEL {fit} --values F0=1,2 --max-periods 0"),
        format!("sweep MODEL {fit} --values F0=1 --response bar3.theta"),
        format!("sweep MODEL {fit} --values L2=2.8,1 --set F0=1"),
        format!("sweep MODEL {fit} --values Fs=0,1e6 --set F0=1"),
        "sweep MODEL --param omegz --from 3 --to 4 --step 0.5 --values F0=1,2".into(),
        "sweep MODEL --param k --from 3 --to 4 --step 0.5 --values F0=1,2".into(),
        "sweep MODEL --param omega --from 0 --to 4 --step 1 --values F0=1,2".into(),
        "continue MODEL --param Fz --from 0 --to 1".into(),
        "continue MODEL --param Fs --from 1 --to 1".into(),
        "continue MODEL --param Fs --from 0 --to nan".into(),
        "continue MODEL --param Fs --from 0 --to 1 --step -1".into(),
        "continue MODEL --param Fs --from 0 --to 1 --max-steps 0".into(),
        "continue MODEL --param Fs --from 0 --to 1 --plot-coordinate qq".into(),
        "modes MODEL --normalize bar3.theta".into(),
        "simulate MODEL -o never.csv --t-end -1".into(),
        "simulate MODEL -o never.csv --dt-out 0".into(),
        "simulate MODEL -o never.csv --rtol 1".into(),
        "simulate MODEL -o never.csv --atol -1e-3".into(),
        "simulate MODEL -o never.csv --t-end 1e6 --dt-out 1e-5".into(),
    ];
    let mut text = String::new();
    for line in &lines {
        let args: Vec<&str> = line
            .split_whitespace()
            .map(|w| if w == "MODEL" { MODEL } else { w })
            .collect();
        let o = Command::new(env!("CARGO_BIN_EXE_detune"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(&args)
            .output()
            .unwrap();
        assert!(o.stdout.is_empty(), "{line}");
        text.push_str(&format!(
            "$ detune {line}\n[exit {:?}]\n{}",
            o.status.code(),
            String::from_utf8_lossy(&o.stderr)
        ));
    }
    assert!(
        !Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("never.csv")
            .exists()
    );
    snapshot("request_errors.txt", &text);
}

const TRACK: &str = "modes models/inceptor.toml --param k_t --from 200 --to 3000 --points 5";

#[test]
fn modes_tracking_json_csv_svg_and_text() {
    let (dir, [csv, svg]) = outputs(["track.csv", "track.svg"]);
    let run = detune(TRACK, &["--json", "-o", &csv, "--plot", &svg]);
    let j = json_snapshot("modes_track", &run.stdout);
    text_snapshot("modes_track_json", &stderr_of(run), Some(dir.path()));
    csv_header_snapshot("modes_track", Path::new(&csv));
    svg_snapshot("modes_track", Path::new(&svg));
    assert_eq!(j["tracking"]["labels"][0], "in-phase");
    assert_eq!(j["tracking"]["labels"][1], "shaft-twist");
    assert_eq!(j["param_unit"], "N*m/rad");
    // the CSV's rows are the requested values of the JSON's steps
    let (header, rows) = common_csv(Path::new(&csv));
    assert_eq!(header[1], "in-phase.omega_n_rad_s");
    let steps: Vec<&Value> = j["tracking"]["steps"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["requested"] == true)
        .collect();
    assert_eq!(rows.len(), 5);
    for (row, s) in rows.iter().zip(&steps) {
        // (serde_json reads floats to within an ulp)
        close(&s["value"], row[0], 1e-12 * row[0]);
        close(&s["modes"][1]["omega_n_rad_s"], row[4], 1e-12 * row[4]);
    }
    text_snapshot("modes_track", &detune(TRACK, &[]), None);
}

/// A numeric CSV: header and rows.
fn common_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    (header, rows)
}
