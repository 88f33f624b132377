//! The fuzzing corpus replayed on stable Rust: every input of `fuzz/corpus/*/` and every
//! crash or hang reproducer of `fuzz/regressions/` goes through the fuzz targets' harness
//! (`detune::fuzz_harness::analyses`, which runs the loader first), each in its own thread
//! with a time limit, so a panic, a non-finite result returned as a success, or a hang
//! fails CI without nightly (docs/reliability.md).

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

/// A case over this is a hang (the definition is 10 s; the harness's own budgets
/// keep every case well under it).
const LIMIT: Duration = Duration::from_secs(10);

fn inputs() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let mut out = Vec::new();
    for dir in ["corpus/loader", "corpus/analyses", "regressions"] {
        let Ok(entries) = std::fs::read_dir(root.join(dir)) else {
            continue;
        };
        for e in entries.flatten() {
            if e.path().is_file() && e.file_name() != ".gitkeep" {
                out.push(e.path());
            }
        }
    }
    out.sort();
    out
}

#[test]
fn every_corpus_input_and_reproducer_runs_without_panic_nan_or_hang() {
    let files = inputs();
    // the seed corpus alone is the shipped and test models
    assert!(files.len() >= 20, "only {} inputs found", files.len());
    let mut failures = Vec::new();
    let mut simulated = Vec::new();
    for path in &files {
        let data = std::fs::read(path).unwrap();
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            let r = std::panic::catch_unwind(|| detune::fuzz_harness::analyses(&data));
            let _ = tx.send(r.map_err(|e| {
                e.downcast_ref::<String>()
                    .cloned()
                    .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default()
            }));
        });
        match rx.recv_timeout(LIMIT) {
            Ok(Ok(r)) => {
                if r.simulated {
                    simulated.push(path.file_name().unwrap().to_string_lossy().to_string());
                }
            }
            Ok(Err(message)) => failures.push(format!("{}: panic: {message}", path.display())),
            // a hung thread cannot be killed: report it and stop (the process ends with
            // the test)
            Err(_) => {
                failures.push(format!(
                    "{}: no result in {LIMIT:?} (a hang)",
                    path.display()
                ));
                break;
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // the harness is no empty loop: the shipped models go all the way through it
    for model in ["overcentre.toml", "inceptor.toml"] {
        assert!(
            simulated.iter().any(|s| s == model),
            "{model} did not reach the simulation: {simulated:?}"
        );
    }
}
