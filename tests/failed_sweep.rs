//! A sweep that fails part-way keeps the frequencies it finished (issues 10/13): at
//! F0 = 80 N the overcentre's bars are driven into their folded pose (bar 1 at −90°, a
//! rank loss of the constraints) from ω = 1 rad/s on, and the integration toward a steady
//! state cannot go on there. The frequencies before it (0.5 and 0.75 rad/s) are written,
//! marked incomplete as an interrupted sweep's are (the CSV's last line `# incomplete:
//! ...`, the JSON's `"complete": false`, the plot's title), with the failing frequency and
//! the reason (the JSON's `failure`); the exit code stays 1 and the message says what was
//! kept. The rows kept are exactly those of a run that stops short of the failure, which
//! succeeds: the truth they are checked against.

use serde_json::Value;
mod common;
use common::detune;

/// `sweep models/overcentre.toml --set F0=80 --param omega --from 0.5 --to TO --step 0.25
/// --response bar1.theta` with `extra`.
fn overcentre_sweep(to: &str, extra: &[&str]) -> (i32, String, String) {
    let mut args = vec![
        "sweep",
        "models/overcentre.toml",
        "--set",
        "F0=80",
        "--param",
        "omega",
        "--from",
        "0.5",
        "--to",
        to,
        "--step",
        "0.25",
        "--response",
        "bar1.theta",
    ];
    args.extend_from_slice(extra);
    detune(&args)
}

/// The data rows of a sweep CSV (header and comment lines apart) and its last line.
fn rows(path: &std::path::Path) -> (String, Vec<String>, String) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let all: Vec<&str> = lines.collect();
    let data = all
        .iter()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.to_string())
        .collect();
    (header, data, all.last().unwrap_or(&"").to_string())
}

/// The amplitude column of CSV rows, as numbers.
fn amplitudes(header: &str, rows: &[String]) -> Vec<(f64, f64)> {
    let k = header
        .split(',')
        .position(|h| h == "bar1.theta_amplitude")
        .unwrap();
    rows.iter()
        .map(|r| {
            let f: Vec<&str> = r.split(',').collect();
            (f[0].parse().unwrap(), f[k].parse().unwrap())
        })
        .collect()
}

#[test]
fn an_independent_sweep_that_fails_keeps_the_frequencies_below_the_failure() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("failed.csv");
    let svg = dir.path().join("failed.svg");
    let (code, out, err) = overcentre_sweep(
        "6",
        &[
            "-o",
            csv.to_str().unwrap(),
            "--plot",
            svg.to_str().unwrap(),
            "--json",
        ],
    );
    assert_eq!(code, 1, "{err}");
    for says in [
        "the sweep stopped at omega = 1 rad/s, where the motion cannot be integrated",
        "kept the 2 frequencies finished before it (0.5 to 0.75 rad/s), written marked incomplete",
        csv.to_str().unwrap(),
        "the JSON on standard output",
        "singular pose",
    ] {
        assert!(err.contains(says), "no {says:?} in {err}");
    }
    assert!(!err.contains("nothing was written"), "{err}");

    // the truth: the same sweep stopped short of the failure succeeds
    let short = dir.path().join("short.csv");
    let (code, short_out, err) =
        overcentre_sweep("0.75", &["-o", short.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let (h0, want, last0) = rows(&short);
    assert!(!last0.starts_with('#'), "{last0}");

    let (h, got, last) = rows(&csv);
    assert_eq!(h, h0);
    // the same frequencies, the same numbers to the last bit
    assert_eq!(got, want);
    let amp = amplitudes(&h, &got);
    assert_eq!(amp.iter().map(|a| a.0).collect::<Vec<_>>(), vec![0.5, 0.75]);
    // bar 1 swings across the flat pose (more than ±1.5 rad): real steady states
    assert!(amp.iter().all(|a| a.1 > 1.5 && a.1 < 1.6), "{amp:?}");
    assert!(
        last.starts_with(
            "# incomplete: failed at omega = 1 rad/s (independent, the coarse grid): the step size fell to zero"
        ),
        "{last}"
    );
    assert!(
        last.ends_with("the rows above are the frequencies completed before it"),
        "{last}"
    );

    // the JSON: the same points, "complete": false (as an interrupted sweep's) and why
    let doc: Value = serde_json::from_str(&out).unwrap();
    let short_doc: Value = serde_json::from_str(&short_out).unwrap();
    assert_eq!(doc["complete"], Value::Bool(false));
    assert_eq!(short_doc["complete"], Value::Bool(true));
    assert_eq!(doc["points"], short_doc["points"]);
    assert!(short_doc.get("failure").is_none());
    let f = &doc["failure"];
    assert_eq!(f["omega"].as_f64(), Some(1.0));
    assert_eq!(f["direction"], "independent");
    assert_eq!(f["stage"], "coarse");
    let message = f["message"].as_str().unwrap();
    assert!(
        message.starts_with("the step size fell to zero"),
        "{message}"
    );
    // the existing keys are all there
    for key in [
        "equilibrium",
        "points",
        "peaks",
        "jumps",
        "hysteresis",
        "complete",
        "provenance",
        "equilibria",
        "units",
    ] {
        assert!(doc.get(key).is_some(), "no {key}");
    }
    // the plot says so (its title wrapped to the figure's width: its lines joined)
    let plot = std::fs::read_to_string(&svg).unwrap();
    let doc = roxmltree::Document::parse(&plot).unwrap();
    let texts: Vec<&str> = doc
        .descendants()
        .filter(|n| n.has_tag_name("text"))
        .filter_map(|n| n.text())
        .map(str::trim)
        .collect();
    assert!(
        texts
            .join(" ")
            .contains("INCOMPLETE: failed at 1 rad/s after 2 frequencies"),
        "the plot's title: {texts:?}"
    );
}

#[test]
fn an_up_sweep_that_fails_keeps_the_frequencies_before_it_and_a_checkpoint_resumes_it() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("up.csv");
    let ckpt = dir.path().join("up.ckpt");
    let args = [
        "--mode",
        "up",
        "-o",
        csv.to_str().unwrap(),
        "--checkpoint",
        ckpt.to_str().unwrap(),
    ];
    let (code, _, err) = overcentre_sweep("2", &args);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("kept the 2 frequencies finished before it (0.5 to 0.75 rad/s)"),
        "{err}"
    );
    let first = std::fs::read_to_string(&csv).unwrap();

    let short = dir.path().join("short.csv");
    let (code, _, err) = overcentre_sweep("0.75", &["--mode", "up", "-o", short.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let (_, want, _) = rows(&short);
    let (_, got, last) = rows(&csv);
    assert_eq!(got, want);
    assert!(got.iter().all(|r| r.split(',').nth(1) == Some("up")));
    assert!(
        last.starts_with("# incomplete: failed at omega = 1 rad/s (up, the coarse grid)"),
        "{last}"
    );

    // the checkpoint holds the frequencies finished: the same command resumes from them,
    // fails at the same frequency and writes the same file
    let (code, _, err) = overcentre_sweep("2", &args);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("resuming from the checkpoint") && err.contains("2 steady states done before"),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(&csv).unwrap(), first);
}

/// With `--values`, the runs before the failing one are kept whole; the failing run's
/// frequencies before the failure too; the failure names its run.
#[test]
fn a_failing_values_case_keeps_the_cases_before_it() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("family.csv");
    let (code, out, err) = overcentre_sweep(
        "1.5",
        &[
            "--values",
            "F0=10,80",
            "-o",
            csv.to_str().unwrap(),
            "--json",
        ],
    );
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("--values F0=80"), "{err}");
    assert!(
        err.contains(
            "kept the 7 frequencies finished before it (in 2 --values cases, 0.5 to 1.5 rad/s)"
        ),
        "{err}"
    );
    // the advice is the failing run's (F0 = 80 N, not the model's 0 N), and the command
    // that shows its motion sets its F0
    assert!(err.contains("F0 = 80 N in this run"), "{err}");
    assert!(!err.contains("F0 = 0 N"), "{err}");
    assert!(
        err.contains("detune simulate models/overcentre.toml --set F0=80 --set omega=1 "),
        "{err}"
    );
    let (header, got, last) = rows(&csv);
    assert!(header.starts_with("omega,direction,F0,"), "{header}");
    let f0: Vec<f64> = got
        .iter()
        .map(|r| r.split(',').nth(2).unwrap().parse().unwrap())
        .collect();
    assert_eq!(f0, vec![10.0, 10.0, 10.0, 10.0, 10.0, 80.0, 80.0]);
    assert!(
        last.starts_with(
            "# incomplete: failed at omega = 1 rad/s (independent, the coarse grid, F0 = 80)"
        ),
        "{last}"
    );
    let doc: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(doc["failure"]["F0"].as_f64(), Some(80.0));
    assert_eq!(doc["failure"]["omega"].as_f64(), Some(1.0));
    assert_eq!(doc["complete"], Value::Bool(false));

    // F0 = 10 N alone, complete: the same rows for its run
    let alone = dir.path().join("alone.csv");
    let (code, _, err) =
        overcentre_sweep("1.5", &["--values", "F0=10", "-o", alone.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let (_, want, _) = rows(&alone);
    assert_eq!(&got[..5], &want[..]);
}

/// Review of issues 10/13: the library's `sweep` (and `sweep_watched`, `sweep_logged`)
/// stay strict, as before the partial sweeps: a failing frequency is an error, not a
/// partial curve returned as Ok. `sweep_logged_partial` (the command's entry) keeps the
/// frequencies before the failure, with the failure named.
#[test]
fn the_library_sweep_stays_strict_and_the_partial_entry_keeps_the_finished_part() {
    use detune::frequency::{SteadyOptions, SweepMode, SweepOptions, checkpoint::NoLog};
    use std::sync::atomic::AtomicBool;
    let m = common::overcentre(&[("F0", "80")]);
    let sys = detune::System::new(&m).unwrap();
    let opts = SweepOptions {
        param: "omega".into(),
        values: vec![0.5, 0.75, 1.0, 1.25],
        mode: SweepMode::Independent,
        responses: vec!["bar1.theta".into()],
        refine: None,
        steady: SteadyOptions::default(),
    };
    let cancel = AtomicBool::new(false);
    let e = detune::frequency::sweep(&sys, &opts, &|_| {}, &cancel)
        .expect_err("a failing frequency is an error");
    let s =
        detune::frequency::sweep_logged_partial(&sys, &opts, &|_| {}, &cancel, &NoLog, 0, &|_| {})
            .unwrap();
    let f = s.failure.as_ref().expect("the failure is named");
    assert_eq!(f.omega, 1.0);
    assert_eq!(f.error.headline(), e.headline());
    assert!(!s.complete);
    let kept: Vec<f64> = s.points.iter().map(|p| p.steady.omega).collect();
    assert_eq!(kept, vec![0.5, 0.75]);
}

/// A failing --values run that kept nothing is not counted among the cases kept, and the
/// range is not wrapped in a second pair of parentheses.
#[test]
fn a_failing_values_case_that_kept_nothing_is_not_counted() {
    let (code, _, err) = detune(&[
        "sweep",
        "models/overcentre.toml",
        "--values",
        "F0=10,80",
        "--param",
        "omega",
        "--from",
        "1",
        "--to",
        "1.5",
        "--step",
        "0.25",
        "--response",
        "bar1.theta",
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("kept the 3 frequencies finished before it (in 1 --values case, 1 to 1.5 rad/s), printed above"),
        "{err}"
    );
}
