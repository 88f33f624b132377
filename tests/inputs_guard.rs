//! Inputs that must neither crash, hang nor be destroyed (issue 13 points 2 and 5, issue
//! 10 D8): parameter chains of any length, inputs other than the model read with a
//! bound (checkpoints, `merge`'s shards, `--refine-from`), `--refine-from` guarded
//! against the outputs, checkpoints refused across builds, and GNU `timeout`'s double
//! SIGTERM. Each runs the built binary under a 20 s limit (a hang fails the test).

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const SDOF: &str = include_str!("data/sdof.toml");

struct Outcome {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

/// Run `detune ARGS` in `dir`; kill it and fail after 20 s.
fn run(dir: &Path, args: &[&str]) -> Outcome {
    let (code, stdout, stderr) = common::run_within_20s(dir, args);
    Outcome {
        code,
        stdout,
        stderr,
    }
}

fn refused(o: &Outcome, needles: &[&str]) {
    assert_eq!(o.code, Some(1), "stderr: {}", o.stderr);
    for n in needles {
        assert!(o.stderr.contains(n), "`{n}` not in: {}", o.stderr);
    }
    assert!(!o.stderr.contains("panicked"), "{}", o.stderr);
}

/// The SDOF oscillator (m = 2 kg) with `n` parameters `p0 … p{n-1}` in a chain, each
/// defined by its neighbour (`up`: p_i = p_{i-1}, else p_i = p_{i+1}), the spring
/// k = 800 N/m × the chain's far end.
fn chain(n: usize, up: bool) -> String {
    let mut lines = Vec::with_capacity(n);
    let (root, end) = if up { (0, n - 1) } else { (n - 1, 0) };
    for i in 0..n {
        if i == root {
            lines.push(format!("p{i} = 1.0"));
        } else {
            let j = if up { i - 1 } else { i + 1 };
            lines.push(format!("p{i} = \"p{j}\""));
        }
    }
    SDOF.replace(
        "[parameters]\n",
        &format!("[parameters]\n{}\n", lines.join("\n")),
    )
    .replace(
        "k = { value = 800, unit = \"N/m\" }",
        &format!("k = {{ value = \"800*p{end}\", unit = \"N/m\" }}"),
    )
}

#[test]
fn a_chain_of_20000_parameters_is_evaluated_either_way() {
    let dir = tempfile::tempdir().unwrap();
    for up in [true, false] {
        std::fs::write(dir.path().join("chain.toml"), chain(20_000, up)).unwrap();
        let o = run(dir.path(), &["check", "chain.toml"]);
        assert_eq!(o.code, Some(0), "{}", o.stderr);
        // the value travels the whole chain: p_root = 2 makes k = 1600 N/m, and the
        // block (2 kg) on it has ω² = k/m = 800 rad²/s²
        let root = if up { "p0=2" } else { "p19999=2" };
        let o = run(
            dir.path(),
            &["equilibrium", "chain.toml", "--set", root, "--json"],
        );
        assert_eq!(o.code, Some(0), "{}", o.stderr);
        let j: serde_json::Value = serde_json::from_str(&o.stdout).unwrap();
        let w2 = j["undamped_omega2"][0].as_f64().unwrap();
        assert!((w2 - 800.0).abs() < 1e-9 * 800.0, "ω² = {w2}, 800 expected");
    }
}

/// Loading is linear in the number of parameters: 100,000 of them (4 MB) load within
/// the 20 s limit (a name looked up by a linear search took minutes).
#[test]
fn a_chain_of_100000_parameters_loads() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("chain.toml"), chain(100_000, true)).unwrap();
    let o = run(dir.path(), &["check", "chain.toml"]);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
}

#[test]
fn a_cycle_of_20000_parameters_is_reported_by_its_ends() {
    let dir = tempfile::tempdir().unwrap();
    let text = chain(20_000, true).replace("p0 = 1.0", "p0 = \"p19999\"");
    std::fs::write(dir.path().join("cycle.toml"), text).unwrap();
    let o = run(dir.path(), &["check", "cycle.toml"]);
    // found from k = 800*p19999 (parameters are walked in name order)
    refused(
        &o,
        &[
            "parameter cycle: p19999 → p19998 → p19997 → p19996 → p19995 → … 19991 more … → p3 → p2 → p1 → p0 → p19999",
        ],
    );
    assert!(o.stderr.len() < 10_000, "{} bytes of error", o.stderr.len());
}

/// Issue 10 D8: a parameter whose value is refused is not reported again as "not a
/// parameter" where the model names it.
#[test]
fn a_refused_parameter_is_not_also_unknown() {
    let dir = tempfile::tempdir().unwrap();
    let text = SDOF.replace(
        "omega = { value = 0, unit = \"rad/s\" }",
        "omega = { value = \"3 furlongs\", unit = \"rad/s\" }",
    );
    std::fs::write(dir.path().join("m.toml"), text).unwrap();
    let o = run(dir.path(), &["check", "m.toml"]);
    refused(&o, &["unknown unit `furlongs`"]);
    assert!(!o.stderr.contains("not a parameter"), "{}", o.stderr);
    assert_eq!(o.stderr.matches("error:").count(), 1, "{}", o.stderr);
}

const SWEEP: &str = "sweep m.toml --set F0=1 --param omega --from 10 --to 30 --step 10 \
    --response block.x";

fn sweep(more: &[&str]) -> Vec<String> {
    SWEEP
        .split_whitespace()
        .chain(more.iter().copied())
        .map(String::from)
        .collect()
}

fn sweep_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.toml"), SDOF).unwrap();
    dir
}

fn args(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

#[cfg(unix)]
fn mkfifo(p: &Path) {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(p.as_os_str().as_bytes()).unwrap();
    // SAFETY: mkfifo on a NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
}

#[cfg(unix)]
#[test]
fn checkpoints_and_shards_are_regular_files_read_with_a_bound() {
    let dir = sweep_dir();
    let fifo = dir.path().join("fifo");
    mkfifo(&fifo);
    // a device is never read (it was read until the memory ran out)
    let o = run(dir.path(), &["merge", "/dev/zero", "-o", "q.csv"]);
    refused(
        &o,
        &["/dev/zero: is a character device, not a sweep checkpoint"],
    );
    // a FIFO nobody writes to is not opened (it blocked without a word)
    let o = run(dir.path(), &["merge", "fifo", "-o", "q.csv"]);
    refused(&o, &["fifo: is a pipe (FIFO), not a sweep checkpoint"]);
    let o = run(
        dir.path(),
        &args(&sweep(&["--checkpoint", "fifo", "-o", "q.csv"])),
    );
    refused(&o, &["the checkpoint fifo is not a regular file"]);
    let o = run(
        dir.path(),
        &args(&sweep(&["--checkpoint", "/dev/null", "-o", "q.csv"])),
    );
    refused(&o, &["the checkpoint /dev/null is not a regular file"]);
    // the --refine-from CSV likewise (it was read until killed)
    let o = run(
        dir.path(),
        &args(&sweep(&[
            "--refine",
            "0.5",
            "--refine-from",
            "/dev/zero",
            "-o",
            "q.csv",
        ])),
    );
    refused(&o, &["--refine-from /dev/zero: is a character device"]);
    assert!(!dir.path().join("q.csv").exists());
}

#[test]
fn the_refine_from_csv_is_never_an_output() {
    let dir = sweep_dir();
    let o = run(dir.path(), &args(&sweep(&["-o", "c.csv"])));
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let before = std::fs::read(dir.path().join("c.csv")).unwrap();
    for out in ["c.csv", "./c.csv"] {
        let o = run(
            dir.path(),
            &args(&sweep(&[
                "--refine",
                "0.5",
                "--refine-from",
                "c.csv",
                "-o",
                out,
            ])),
        );
        refused(&o, &["would overwrite the --refine-from CSV c.csv"]);
        assert_eq!(std::fs::read(dir.path().join("c.csv")).unwrap(), before);
    }
    // and the refinement from it still runs
    let o = run(
        dir.path(),
        &args(&sweep(&[
            "--refine",
            "0.5",
            "--refine-from",
            "c.csv",
            "-o",
            "r.csv",
        ])),
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
}

/// A checkpoint records the build (a hash of the sources): one from another build of
/// detune (the same crate version) is refused, on resume and on merge; the same build
/// resumes it.
#[test]
fn a_checkpoint_of_another_build_is_refused() {
    let dir = sweep_dir();
    let ck = dir.path().join("s.ckpt");
    let first = sweep(&["--checkpoint", "s.ckpt", "-o", "a.csv"]);
    let o = run(dir.path(), &args(&first));
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let text = std::fs::read_to_string(&ck).unwrap();
    let header: serde_json::Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
    let version = header["detune_version"].as_str().unwrap().to_string();
    let (crate_version, build) = version.split_once('+').expect("a build id");
    assert_eq!(crate_version, env!("CARGO_PKG_VERSION"));
    assert_eq!(build.len(), 16);
    // the same build resumes it: every case reused, the same bytes
    let again = sweep(&["--checkpoint", "s.ckpt", "-o", "b.csv"]);
    let o = run(dir.path(), &args(&again));
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    assert_eq!(
        std::fs::read(dir.path().join("a.csv")).unwrap(),
        std::fs::read(dir.path().join("b.csv")).unwrap()
    );
    // written by another build of the same version
    let other = text.replacen(&version, &format!("{crate_version}+0123456789abcdef"), 1);
    std::fs::write(&ck, &other).unwrap();
    let o = run(dir.path(), &args(&again));
    refused(
        &o,
        &[
            "was written by detune 0.1.0+0123456789abcdef",
            "(another build)",
        ],
    );
    // untouched
    assert_eq!(std::fs::read_to_string(&ck).unwrap(), other);
    let o = run(dir.path(), &["merge", "s.ckpt", "-o", "m.csv"]);
    refused(&o, &["s.ckpt was written by detune 0.1.0+0123456789abcdef"]);
    assert!(!dir.path().join("m.csv").exists());
}

/// GNU `timeout` sends SIGTERM twice (to the process, then to its group): that is one
/// request to stop, so the partial results are written (exit 143), not lost as after a
/// second signal.
#[cfg(unix)]
#[test]
fn a_doubled_sigterm_keeps_the_partial_results() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // a stiff run that takes far longer than the test waits
    let mut child = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(dir.path())
        .args([
            "simulate",
            root.join("models/overcentre.toml").to_str().unwrap(),
            "--set",
            "c=1e7",
            "--t-end",
            "50",
            "-o",
            "st.csv",
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1000));
    assert!(child.try_wait().unwrap().is_none(), "the run ended early");
    let pid = child.id() as libc::pid_t;
    // SAFETY: kill(2) on the child this test spawned.
    unsafe {
        libc::kill(pid, libc::SIGTERM);
    }
    // apart, so that the second is delivered on its own (back to back, the kernel may
    // merge it into the first, still pending, and the test would pass without the fix),
    // as GNU timeout's kill(pid) then kill(0) are; well inside the 1 s window
    std::thread::sleep(Duration::from_millis(50));
    // SAFETY: as above.
    unsafe {
        libc::kill(pid, libc::SIGTERM);
    }
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(20) {
            let _ = child.kill();
            panic!("did not stop within 20 s of SIGTERM");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut err = String::new();
    use std::io::Read;
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert_eq!(status.code(), Some(143), "{err}");
    assert!(!err.contains("no output written"), "{err}");
    let csv = std::fs::read_to_string(dir.path().join("st.csv")).expect("st.csv written");
    assert!(csv.starts_with("t,"), "{csv:.200}");
    assert!(csv.contains("# incomplete"), "{csv:.200}");
}

/// Thousands of broken definitions: the first problems, at once (each one searched all
/// names for a suggestion and rendered an excerpt of the whole file: minutes).
#[test]
fn twenty_thousand_broken_parameters_are_reported_briefly() {
    let dir = tempfile::tempdir().unwrap();
    let with = |f: &dyn Fn(usize) -> String| {
        let lines: Vec<String> = (0..20_000).map(f).collect();
        SDOF.replace(
            "[parameters]\n",
            &format!("[parameters]\n{}\n", lines.join("\n")),
        )
    };
    std::fs::write(
        dir.path().join("unknown.toml"),
        with(&|i| format!("p{i} = \"zz{i} + 1\"")),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("units.toml"),
        with(&|i| format!("p{i} = \"3 furlong\"")),
    )
    .unwrap();
    let o = run(dir.path(), &["check", "unknown.toml"]);
    // the evaluation stops at the first 30: the count says it is not of all
    refused(
        &o,
        &[
            "unknown parameter `zz",
            "(20005 in all, in [parameters])",
            "30 problems in unknown.toml (the evaluation of [parameters] stopped at its 30th problem: more may follow once these are fixed)",
        ],
    );
    assert!(
        o.stderr.len() < 100_000,
        "{} bytes of error",
        o.stderr.len()
    );
    // exactly 30: all of them, no "stopped"
    let thirty: Vec<String> = (0..30).map(|i| format!("p{i} = \"zz{i} + 1\"")).collect();
    std::fs::write(
        dir.path().join("thirty.toml"),
        SDOF.replace(
            "[parameters]\n",
            &format!("[parameters]\n{}\n", thirty.join("\n")),
        ),
    )
    .unwrap();
    let o = run(dir.path(), &["check", "thirty.toml"]);
    refused(&o, &["30 problems in thirty.toml\n"]);
    assert!(!o.stderr.contains("stopped"), "{}", o.stderr);
    let o = run(dir.path(), &["check", "units.toml"]);
    refused(
        &o,
        &[
            "unknown unit `furlong`",
            "… 19970 more problems not shown: fix these first",
            "20000 problems in units.toml",
        ],
    );
    assert!(
        o.stderr.len() < 100_000,
        "{} bytes of error",
        o.stderr.len()
    );
}
