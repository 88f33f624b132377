//! Issue 13: a signal that comes after the results were complete stops nothing. Each
//! command that can be interrupted with partial results kept (`sweep`, `continue`, `frf`,
//! `nfr`) is signalled while it prints its `--json` document into a pipe nobody reads
//! yet, after its `-o` CSV was committed: the outputs are whole, the run says so on
//! stderr and exits 0 (not 143, which would have a scheduler requeue a finished run).
//! Deterministic: the CSV exists only once committed, after the results were complete,
//! and the printing blocks until the test reads (each document is larger than a pipe's
//! 64 KiB).

mod common;
use common::detune;

use std::io::Read;
use std::process::{Command, Stdio};
use std::time::Duration;

/// Runs `detune args... --json -o CSV`, sends SIGTERM once the CSV exists and the process
/// is blocked printing, and checks the exit code, the note, the document and that the CSV
/// equals an uninterrupted run's.
fn signalled_after_complete(args: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("out.csv");
    let csv_s = csv.to_str().unwrap();
    let mut full: Vec<&str> = args.to_vec();
    full.extend(["--json", "-o", csv_s]);
    let mut child = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(&full)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let began = std::time::Instant::now();
    while !csv.exists() {
        if began.elapsed() > Duration::from_secs(30) {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("{args:?}: no CSV after 30 s");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(200));
    assert!(
        child.try_wait().unwrap().is_none(),
        "{args:?} ended before the signal: its JSON fitted in the pipe"
    );
    // SAFETY: sending a signal to our own child.
    assert_eq!(
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) },
        0
    );
    let mut stdout = String::new();
    child
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut stdout)
        .unwrap();
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{args:?}: {err}");
    assert!(
        err.contains("note: SIGTERM received after the results were complete; outputs written"),
        "{args:?}: {err}"
    );
    let doc: serde_json::Value = serde_json::from_str(&stdout)
        .unwrap_or_else(|e| panic!("{args:?}: the JSON is not whole ({e}): {stdout:.300}"));
    if let Some(c) = doc.get("complete") {
        assert_eq!(c, &serde_json::Value::Bool(true), "{args:?}");
    }
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(!text.contains("# incomplete"), "{args:?}");
    // the same run uninterrupted writes the same CSV
    let again = dir.path().join("again.csv");
    let mut plain: Vec<&str> = args.to_vec();
    plain.extend(["-o", again.to_str().unwrap()]);
    let (code, _, e) = detune(&plain);
    assert_eq!(code, 0, "{args:?}: {e}");
    assert_eq!(std::fs::read_to_string(&again).unwrap(), text, "{args:?}");
}

#[test]
fn sweep_signalled_after_its_results_exits_0() {
    signalled_after_complete(&[
        "sweep",
        "models/overcentre.toml",
        "--set",
        "F0=0.5",
        "--param",
        "omega",
        "--from",
        "1",
        "--to",
        "6",
        "--step",
        "0.05",
    ]);
}

#[test]
fn continue_signalled_after_its_results_exits_0() {
    signalled_after_complete(&[
        "continue",
        "models/overcentre.toml",
        "--param",
        "k",
        "--from",
        "50",
        "--to",
        "200",
        "--step",
        "0.5",
    ]);
}

#[test]
fn frf_signalled_after_its_results_exits_0() {
    signalled_after_complete(&[
        "frf",
        "models/overcentre.toml",
        "--set",
        "F0=1",
        "--param",
        "omega",
        "--from",
        "0.1",
        "--to",
        "10",
        "--step",
        "0.01",
    ]);
}

#[test]
fn nfr_signalled_after_its_results_exits_0() {
    signalled_after_complete(&[
        "nfr",
        "models/overcentre.toml",
        "--set",
        "F0=1",
        "--param",
        "omega",
        "--from",
        "0.5",
        "--to",
        "1",
    ]);
}
