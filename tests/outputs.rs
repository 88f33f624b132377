//! Outputs that never destroy or linger, signals and exit codes (issue 13, defect 5),
//! through the built binary: symlinks, hard links, FIFOs and devices as outputs, all
//! outputs committed together or none, SIGTERM/SIGHUP during long runs, stale temporary
//! files, bounded model input.

use std::os::unix::fs::FileTypeExt;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

mod common;
use common::detune;

/// A short simulation of the overcentre mechanism writing its CSV to `out`, plus `extra`.
fn simulate(out: &str, extra: &[&str]) -> (i32, String, String) {
    let mut args = vec![
        "simulate",
        "models/overcentre.toml",
        "--t-end",
        "0.5",
        "--dt-out",
        "0.05",
        "-o",
        out,
    ];
    args.extend_from_slice(extra);
    detune(&args)
}

/// The reference CSV of [`simulate`], written to a plain file.
fn reference_csv() -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("ref.csv");
    let (code, _, err) = simulate(p.to_str().unwrap(), &[]);
    assert_eq!(code, 0, "{err}");
    std::fs::read_to_string(p).unwrap()
}

/// The `.detune-*` temporary files in `dir`.
fn temps(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".detune-"))
        .collect()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn an_output_through_a_symlink_writes_its_target_and_keeps_the_link() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("target.csv");
    let link = dir.path().join("link.csv");
    std::fs::write(&target, "old\n").unwrap();
    std::os::unix::fs::symlink("target.csv", &link).unwrap();
    let (code, _, err) = simulate(s(&link), &[]);
    assert_eq!(code, 0, "{err}");
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(std::fs::read_to_string(&target).unwrap(), reference_csv());
    // a dangling link is followed too: its target is created
    std::fs::remove_file(&target).unwrap();
    let (code, _, err) = simulate(s(&link), &[]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(std::fs::read_to_string(&target).unwrap(), reference_csv());
    assert!(temps(dir.path()).is_empty());
}

#[test]
fn an_output_that_is_the_model_through_a_link_is_refused_and_the_model_kept() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("m.toml");
    let text = common::overcentre_text();
    std::fs::write(&model, &text).unwrap();
    let hard = dir.path().join("hard.csv");
    std::fs::hard_link(&model, &hard).unwrap();
    let soft = dir.path().join("soft.csv");
    std::os::unix::fs::symlink(&model, &soft).unwrap();
    for out in [&hard, &soft, &model] {
        let (code, _, err) = detune(&["simulate", s(&model), "--t-end", "0.1", "-o", s(out)]);
        assert_eq!(code, 1, "{err}");
        assert!(err.contains("would overwrite the model file"), "{err}");
        assert!(err.contains(s(out)), "the error names the output: {err}");
        assert_eq!(std::fs::read_to_string(&model).unwrap(), text);
    }
    // the same for the JSON and the plot
    let (code, _, err) = detune(&[
        "simulate",
        s(&model),
        "--t-end",
        "0.1",
        "-o",
        s(&dir.path().join("ok.csv")),
        "--json",
        s(&hard),
    ]);
    assert_eq!(code, 1, "{err}");
    assert_eq!(std::fs::read_to_string(&model).unwrap(), text);
    assert!(!dir.path().join("ok.csv").exists());
    assert!(temps(dir.path()).is_empty());
}

#[test]
fn an_output_that_is_the_environment_file_through_a_link_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let env = dir.path().join("env.toml");
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("environments/uh-60.toml"),
    )
    .unwrap();
    std::fs::write(&env, &text).unwrap();
    let link = dir.path().join("out.csv");
    std::fs::hard_link(&env, &link).unwrap();
    let (code, _, err) = detune(&[
        "margins",
        "models/inceptor.toml",
        "--environment",
        s(&env),
        "-o",
        s(&link),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("would overwrite the environment file"),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(&env).unwrap(), text);
}

#[test]
fn a_fifo_gets_the_csv_written_directly() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.csv");
    let ok = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(ok.success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
    };
    let (code, _, err) = simulate(s(&fifo), &[]);
    if code != 0 {
        // the reader waits for a writer: give it an empty one rather than hang
        drop(std::fs::OpenOptions::new().write(true).open(&fifo));
    }
    assert_eq!(code, 0, "{err}");
    assert_eq!(reader.join().unwrap(), reference_csv());
    assert!(
        std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo()
    );
    assert!(temps(dir.path()).is_empty());
}

#[test]
fn dev_null_stays_a_device() {
    let (code, _, err) = simulate("/dev/null", &["--json", "/dev/null"]);
    assert_eq!(code, 0, "{err}");
    let t = std::fs::symlink_metadata("/dev/null").unwrap().file_type();
    assert!(t.is_char_device());
}

#[test]
fn a_failing_last_output_leaves_none_of_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("a.csv");
    let json = dir.path().join("a.json");
    std::fs::write(&csv, "the previous run's\n").unwrap();
    // /dev/full takes no byte (ENOSPC): the plot, a special file, is written last, after
    // the CSV and the JSON were renamed into place; they are rolled back
    let (code, _, err) = simulate(s(&csv), &["--json", s(&json), "--plot", "/dev/full"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("/dev/full"), "{err}");
    assert_eq!(
        std::fs::read_to_string(&csv).unwrap(),
        "the previous run's\n"
    );
    assert!(!json.exists());
    assert!(temps(dir.path()).is_empty());
    // a plot whose directory is a file: refused before any work, nothing written
    let (code, _, err) = simulate(
        s(&dir.path().join("b.csv")),
        &["--plot", s(&csv.join("p.svg"))],
    );
    assert_eq!(code, 1, "{err}");
    assert!(!dir.path().join("b.csv").exists());
    assert!(temps(dir.path()).is_empty());
}

/// Spawn `detune args`, wait until it has made its temporary files, send `signal`.
fn interrupt(args: &[&str], dir: &Path, signal: libc::c_int) -> std::process::Output {
    let child = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // the outputs are planned (temporary files made) before any work; then let it work
    for _ in 0..500 {
        if !temps(dir).is_empty() {
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(1000));
    // SAFETY: sending a signal to our own child.
    assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, signal) }, 0);
    child.wait_with_output().unwrap()
}

fn long_sweep(csv: &str) -> Vec<String> {
    [
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
        csv,
    ]
    .map(String::from)
    .to_vec()
}

#[test]
fn sigterm_and_sighup_stop_a_sweep_keeping_the_points_marked_incomplete() {
    for (signal, code) in [(libc::SIGTERM, 143), (libc::SIGHUP, 129)] {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("fr.csv");
        let args = long_sweep(s(&csv));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = interrupt(&args, dir.path(), signal);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(code), "{err}");
        let text = std::fs::read_to_string(&csv).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert!(lines[0].starts_with("omega,direction,bar1.theta_amplitude"));
        assert!(lines.last().unwrap().starts_with("# incomplete"), "{text}");
        // the rows kept are whole and in the sweep's order (0.5, 0.502, ... rad/s)
        let omegas: Vec<f64> = lines[1..lines.len() - 1]
            .iter()
            .map(|r| r.split(',').next().unwrap().parse().unwrap())
            .collect();
        assert!(
            !omegas.is_empty() && omegas.len() < 3751,
            "{}",
            omegas.len()
        );
        for (k, w) in omegas.iter().enumerate() {
            assert!((w - (0.5 + 0.002 * k as f64)).abs() < 1e-9, "{w}");
        }
        assert!(temps(dir.path()).is_empty(), "{:?}", temps(dir.path()));
    }
}

fn long_simulation(csv: &str) -> Vec<String> {
    [
        "simulate",
        "models/overcentre.toml",
        "--t-end",
        "100000",
        "--dt-out",
        "0.01",
        "-o",
        csv,
    ]
    .map(String::from)
    .to_vec()
}

/// Issue 10, point 6: a signal stops `simulate` at its next output sample; the samples
/// computed are kept (CSV and JSON summary), marked incomplete, and the message says at
/// which model time it stopped; the exit code is 128 + the signal.
#[test]
fn a_signal_stops_a_simulation_keeping_the_samples_marked_incomplete() {
    for (signal, code) in [
        (libc::SIGINT, 130),
        (libc::SIGTERM, 143),
        (libc::SIGHUP, 129),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("long.csv");
        let json = dir.path().join("long.json");
        let mut args = long_simulation(s(&csv));
        args.extend(["--json".to_string(), s(&json).to_string()]);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = interrupt(&args, dir.path(), signal);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(code), "{err}");
        let text = std::fs::read_to_string(&csv).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[0],
            "t,bar1.x,bar1.y,bar1.theta,bar2.x,bar2.y,bar2.theta"
        );
        let last = lines.last().unwrap();
        let stopped: f64 = last
            .strip_prefix("# incomplete: interrupted at t = ")
            .and_then(|r| r.split_once(" s;"))
            .map(|(t, _)| t.parse().unwrap())
            .unwrap_or_else(|| panic!("{last}"));
        // whole rows, every 0.01 s from 0, the last at the time reported
        let times: Vec<f64> = lines[1..lines.len() - 1]
            .iter()
            .map(|r| {
                assert_eq!(r.split(',').count(), 7, "{r}");
                r.split(',').next().unwrap().parse().unwrap()
            })
            .collect();
        assert!(times.len() > 1 && stopped < 100000.0, "{}", times.len());
        for (k, t) in times.iter().enumerate() {
            assert!((t - 0.01 * k as f64).abs() < 1e-9, "{t} at row {k}");
        }
        assert_eq!(*times.last().unwrap(), stopped);
        // the message names the model time (to 1e-6 s), the files kept and the exit
        assert!(
            err.contains(&format!("interrupted at model time t = {stopped:.6} s")),
            "{err}"
        );
        assert!(err.contains("(incomplete: up to t = "), "{err}");
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert_eq!(summary["complete"], false);
        assert_eq!(summary["final"]["t"].as_f64(), Some(stopped));
        assert_eq!(summary["units"]["t"], "s");
        assert_eq!(summary["units"]["bar1.theta"], "rad");
        assert!(temps(dir.path()).is_empty(), "{:?}", temps(dir.path()));
    }
}

#[test]
fn a_second_signal_ends_the_run_at_once_leaving_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("long.csv");
    let args = long_simulation(s(&csv));
    let mut child = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(&args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    for _ in 0..500 {
        if !temps(dir.path()).is_empty() {
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(
        !temps(dir.path()).is_empty(),
        "the run made no temporary file"
    );
    std::thread::sleep(Duration::from_millis(300));
    let pid = child.id() as libc::pid_t;
    // SAFETY: signals to our own child.
    unsafe {
        libc::kill(pid, libc::SIGINT);
        // (delivered to another thread at the same moment, the two would race; 5 ms
        // was too little on a loaded machine with the other signal tests running)
        std::thread::sleep(Duration::from_millis(30));
        libc::kill(pid, libc::SIGTERM);
    }
    // the first signal names the exit code; the second ends the run at once, so the CSV
    // is either not written or written whole, marked incomplete (the first signal stops
    // the run, which may commit before the second arrives)
    assert_eq!(child.wait().unwrap().code(), Some(130));
    if let Ok(text) = std::fs::read_to_string(&csv) {
        assert!(
            text.lines()
                .last()
                .is_some_and(|l| l.starts_with("# incomplete: interrupted at t = ")),
            "{text}"
        );
    }
    assert!(temps(dir.path()).is_empty(), "{:?}", temps(dir.path()));
}

#[test]
fn stale_temporary_files_of_dead_runs_are_removed_and_live_ones_kept() {
    let dir = tempfile::tempdir().unwrap();
    let host = detune::output::commit::host();
    // a process that has ended: its id is free
    let mut dead = Command::new("true").spawn().unwrap();
    let dead_pid = dead.id();
    dead.wait().unwrap();
    let stale = format!(".detune-{host}-{dead_pid}-a1b2c3.tmp");
    let live = format!(".detune-{host}-{}-d4e5f6.tmp", std::process::id());
    let other_host = format!(".detune-{host}x-{dead_pid}-a1b2c3.tmp");
    for n in [&stale, &live, &other_host] {
        std::fs::write(dir.path().join(n), "partial").unwrap();
    }
    let (code, _, err) = simulate(s(&dir.path().join("o.csv")), &[]);
    assert_eq!(code, 0, "{err}");
    let mut left = temps(dir.path());
    left.sort();
    let mut expected = vec![live, other_host];
    expected.sort();
    assert_eq!(left, expected);
}

#[test]
fn a_device_as_model_is_refused_and_a_pipe_read() {
    let (code, _, err) = detune(&["check", "/dev/zero"]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("/dev/zero") && err.contains("character device"),
        "{err}"
    );
    // a pipe works: the model on standard input
    let text = common::overcentre_text();
    let mut child = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args(["check", "/dev/stdin"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    {
        use std::io::Write;
        let mut stdin = child.stdin.take().unwrap();
        stdin.write_all(text.as_bytes()).unwrap();
    }
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("degrees of freedom: 1"), "{stdout}");
}

#[test]
fn a_model_over_16_mib_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("huge.toml");
    let mut text = common::overcentre_text();
    let line = format!("# {}\n", "x".repeat(1021));
    while text.len() < 17 * 1024 * 1024 {
        text.push_str(&line);
    }
    std::fs::write(&model, &text).unwrap();
    let (code, _, err) = detune(&["check", s(&model)]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains(s(&model)) && err.contains("16 MiB"), "{err}");
    // just under the limit it is a model like any other
    text.truncate(common::overcentre_text().len());
    while text.len() + line.len() < 16 * 1024 * 1024 {
        text.push_str(&line);
    }
    std::fs::write(&model, &text).unwrap();
    let (code, _, err) = detune(&["check", s(&model)]);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn usage_errors_exit_2_and_errors_1() {
    let (code, _, _) = detune(&["simulate", "--no-such-flag"]);
    assert_eq!(code, 2);
    let (code, _, _) = detune(&["check", "no/such/model.toml"]);
    assert_eq!(code, 1);
}

#[test]
fn a_command_without_steps_to_stop_at_ends_at_a_signal_leaving_no_temporary_file() {
    // `kinematics` does not check the flag between its points: the signal handler itself
    // unlinks the run's temporary files and exits 128 + the signal
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("k.csv");
    let args = [
        "kinematics",
        "models/overcentre.toml",
        "--drive",
        "bar1.theta",
        "--from",
        "0.3",
        "--to",
        "1.2",
        "--step",
        "1e-7",
        "-o",
        s(&csv),
    ];
    let out = interrupt(&args, dir.path(), libc::SIGTERM);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(143), "{err}");
    assert!(!csv.exists());
    assert!(temps(dir.path()).is_empty(), "{:?}", temps(dir.path()));
}

/// Issue 13: a signal stops `continue` at its next step; the branch so far is written,
/// the CSV ending `# incomplete: interrupted at Fs = ...` and the JSON saying
/// "complete": false, exit 130. Every point kept is an equilibrium: the last one equals
/// `detune equilibrium --set Fs=<its value>` (Newton's statics, not the continuation).
#[test]
fn a_signal_stops_a_continuation_keeping_the_branch_marked_incomplete() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("branch.csv");
    let args = [
        "continue",
        "models/overcentre.toml",
        "--param",
        "Fs",
        "--from",
        "0",
        "--to",
        "5",
        "--step",
        "1e-6",
        "--max-steps",
        "100000000",
        "-o",
        s(&csv),
    ];
    let out = interrupt(&args, dir.path(), libc::SIGINT);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("the continuation was interrupted"), "{err}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].starts_with("Fs,bar1.x,"), "{}", lines[0]);
    let last = lines.last().unwrap();
    let stopped: f64 = last
        .strip_prefix("# incomplete: interrupted at Fs = ")
        .and_then(|r| r.split_once(';'))
        .map(|(v, _)| v.parse().unwrap())
        .unwrap_or_else(|| panic!("{last}"));
    let rows: Vec<Vec<f64>> = lines[1..lines.len() - 1]
        .iter()
        .map(|r| r.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert!(rows.len() > 2 && stopped < 5.0, "{} rows", rows.len());
    assert!(rows.iter().all(|r| r.len() == 9));
    assert_eq!(rows.last().unwrap()[0], stopped);
    assert!(rows.windows(2).all(|w| w[1][0] > w[0][0]));
    let (code, json, err) = detune(&[
        "equilibrium",
        "models/overcentre.toml",
        "--set",
        &format!("Fs={stopped:e}"),
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let eq: serde_json::Value = serde_json::from_str(&json).unwrap();
    let theta = eq["coordinates"]["bar1.theta"].as_f64().unwrap();
    let got = rows.last().unwrap()[3];
    assert!((got - theta).abs() < 1e-9, "{got} vs {theta}");
    assert!(temps(dir.path()).is_empty(), "{:?}", temps(dir.path()));
}

/// A signal stops `frf` (a huge grid) and `modes --param` at their next frequency or
/// value: nothing is written, no temporary file is left, exit 143 for SIGTERM.
#[test]
fn a_signal_stops_frf_and_mode_tracking_writing_nothing() {
    for (what, args) in [
        (
            "the linear frequency response",
            vec![
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
                "1e-5",
            ],
        ),
        (
            "the mode tracking",
            vec![
                "modes",
                "models/overcentre.toml",
                "--param",
                "k",
                "--from",
                "10",
                "--to",
                "100",
                "--points",
                "100000",
            ],
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("out.csv");
        let mut args = args.clone();
        args.extend(["-o", s(&csv)]);
        let out = interrupt(&args, dir.path(), libc::SIGTERM);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(143), "{err}");
        assert!(err.contains(&format!("{what} was interrupted")), "{err}");
        assert!(!csv.exists());
        assert!(temps(dir.path()).is_empty(), "{:?}", temps(dir.path()));
    }
}

/// The tests read the JSON's numbers back exactly (serde_json's `float_roundtrip`): without
/// it, 0.41000000000000003 reads as 0.41, and the interrupted simulation's check of the
/// final time against the CSV's failed whenever the signal landed on such a sample.
#[test]
fn json_times_read_back_to_the_bit() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("end.json");
    let t_end = 41.0 * 0.01; // 0.41000000000000003, not 0.41
    assert_ne!(t_end, 0.41);
    let (code, _, err) = detune(&[
        "simulate",
        "models/overcentre.toml",
        "--t-end",
        &format!("{t_end}"),
        "--dt-out",
        "0.01",
        "--json",
        s(&json),
    ]);
    assert_eq!(code, 0, "{err}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(summary["final"]["t"].as_f64(), Some(t_end));
}

/// Run `detune args` (stderr piped), send `signal` after `after` (unless `None`), and wait
/// at most `deadline` for it to end by itself: killed there, the test fails saying so
/// rather than hanging in the harness.
fn run_within(
    args: &[&str],
    signal: Option<(libc::c_int, Duration)>,
    deadline: Duration,
) -> std::process::Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let began = std::time::Instant::now();
    if let Some((signal, after)) = signal {
        std::thread::sleep(after);
        // SAFETY: sending a signal to our own child.
        assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, signal) }, 0);
    }
    while child.try_wait().unwrap().is_none() {
        if began.elapsed() > deadline {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("detune {args:?} still ran after {deadline:?}: killed");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// Issue 13 audit B1: a simulation whose steps are far shorter than its output interval
/// (a fast forcing: ω = 1e5 rad/s, samples only at 0 and 100 s, millions of steps between)
/// hears SIGTERM after the integrator's current step, not at the next sample minutes
/// later: it ends with 143, the sample at t = 0 kept and marked incomplete, the JSON
/// saying `complete: false` with the steps taken.
#[test]
fn a_signal_between_samples_stops_a_simulation_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("fast.csv");
    let json = dir.path().join("fast.json");
    let out = run_within(
        &[
            "simulate",
            "models/overcentre.toml",
            "--set",
            "theta1_0=-0.85",
            "--set",
            "F0=1",
            "--set",
            "omega=1e5",
            "--t-end",
            "100",
            "--dt-out",
            "100",
            "-o",
            s(&csv),
            "--json",
            s(&json),
        ],
        Some((libc::SIGTERM, Duration::from_millis(1500))),
        Duration::from_secs(60),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(143), "{err}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 3, "{text}");
    assert!(lines[1].starts_with("0,0.9333571158482028,"), "{text}");
    // the footer and the message give the model time the run had reached (between the
    // samples at 0 and 100 s), the footer also the last sample's
    let reached: f64 = lines[2]
        .strip_prefix("# incomplete: interrupted at t = ")
        .and_then(|r| r.split_once(" s;"))
        .map(|(t, _)| t.parse().unwrap())
        .unwrap_or_else(|| panic!("{text}"));
    assert!(reached > 0.0 && reached < 100.0, "{text}");
    assert!(lines[2].ends_with("up to t = 0 s"), "{text}");
    assert!(
        err.contains(&format!("interrupted at model time t = {reached:.6} s")),
        "{err}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(summary["complete"], false);
    // the steps taken before the signal are counted (the run had not reached a sample)
    let steps = summary["stats"]["accepted_steps"].as_u64().unwrap();
    assert!(steps > 0 && steps < 10_000_000, "{steps}");
    assert!(temps(dir.path()).is_empty(), "{:?}", temps(dir.path()));
}

/// Issue 13 audit B1: a forcing far faster than the run can resolve (ω = 1e150 rad/s over
/// 1 s: 1.6e149 periods against 10 million steps, at least one step a period) is refused
/// at once with the numbers and the flags, not integrated for minutes to the step limit.
#[test]
fn a_forcing_faster_than_the_steps_can_resolve_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("s.csv");
    let out = run_within(
        &[
            "simulate",
            "models/overcentre.toml",
            "--set",
            "theta1_0=-0.85",
            "--set",
            "F0=1",
            "--set",
            "omega=1e150",
            "--t-end",
            "1",
            "-o",
            s(&csv),
        ],
        None,
        Duration::from_secs(30),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    // 1e150 × 1 / 2π periods; shorten to 1e7 periods = 2π·1e7 / 1e150 s
    assert!(
        err.contains("the forcing at 1e150 rad/s turns 1.591549e149 times in the run of 1 s, more than the 10000000 steps"),
        "{err}"
    );
    assert!(
        err.contains("shorten --t-end to below 6.283185e-143 s"),
        "{err}"
    );
    assert!(!csv.exists());
    assert!(temps(dir.path()).is_empty(), "{:?}", temps(dir.path()));
}

/// Issue 13, last audit point 2: a FIFO output with no reader. Outputs to special files
/// are written last, and `open` on a FIFO blocks until a reader appears; the run polls no
/// more by then, so one SIGTERM used to set the flag and leave it blocked (a second one
/// ended it). One signal ends it now, at once: exit 143, the message names the FIFO's
/// case, the regular output committed before it is kept whole, and no temporary file is
/// left (the special output's is made in TMPDIR, here the test's directory).
#[test]
fn one_signal_ends_a_write_blocked_on_a_fifo_with_no_reader() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.csv");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let json = dir.path().join("run.json");
    let mut child = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("TMPDIR", dir.path())
        .args([
            "simulate",
            "models/overcentre.toml",
            "--t-end",
            "1",
            "-o",
            s(&fifo),
            "--json",
            s(&json),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // the regular output is committed before the FIFO is opened: then it blocks there
    let began = std::time::Instant::now();
    while !json.exists() {
        assert!(
            began.elapsed() < Duration::from_secs(20),
            "no JSON after 20 s"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(300));
    assert!(child.try_wait().unwrap().is_none(), "it did not block");
    // SAFETY: sending a signal to our own child.
    assert_eq!(
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) },
        0
    );
    let signalled = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if signalled.elapsed() > Duration::from_secs(5) {
            child.kill().unwrap();
            child.wait().unwrap();
            // a reader would have freed it: give the FIFO none, and fail
            panic!("one SIGTERM did not end a write blocked on a FIFO within 5 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(143), "{err}");
    assert!(err.contains("interrupted while writing to a FIFO"), "{err}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(summary["complete"], serde_json::Value::Bool(true));
    assert!(
        std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo()
    );
    assert!(temps(dir.path()).is_empty(), "{:?}", temps(dir.path()));
}

/// `detune` in `dir`, the overcentre given by its absolute path.
fn in_dir(dir: &Path, args: &[&str]) -> std::process::Output {
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/overcentre.toml");
    let args: Vec<&str> = args
        .iter()
        .map(|a| if *a == "MODEL" { s(&model) } else { *a })
        .collect();
    Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(dir)
        .args(&args)
        .output()
        .unwrap()
}

/// `--checkpoint` is compared with the outputs as the same file (device and inode when it
/// exists, else the absolute path), as the outputs are with the inputs: `./x.csv` and
/// `x.csv` are one file (they were compared as strings), and so are a link and its
/// target. Refused before any work, nothing written.
#[test]
fn a_checkpoint_that_is_an_output_under_another_name_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = |out: &str, ckpt: &str| {
        in_dir(
            dir.path(),
            &[
                "sweep",
                "MODEL",
                "--set",
                "F0=1",
                "--param",
                "omega",
                "--from",
                "2",
                "--to",
                "3",
                "--step",
                "0.5",
                "-o",
                out,
                "--checkpoint",
                ckpt,
            ],
        )
    };
    for (out, ckpt) in [("x.csv", "./x.csv"), ("./y.csv", "y.csv")] {
        let o = sweep(out, ckpt);
        assert_eq!(o.status.code(), Some(1), "{o:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains(&format!("--checkpoint {ckpt} is also an output")),
            "{err}"
        );
        assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
    }
    // an existing output reached through a link
    std::fs::write(dir.path().join("z.csv"), "keep").unwrap();
    std::os::unix::fs::symlink("z.csv", dir.path().join("link.ckpt")).unwrap();
    let o = sweep("z.csv", "link.ckpt");
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    assert_eq!(
        std::fs::read_to_string(dir.path().join("z.csv")).unwrap(),
        "keep"
    );
    let o = in_dir(
        dir.path(),
        &[
            "sensitivity",
            "MODEL",
            "--set",
            "F0=1",
            "--vary",
            "k=±10%",
            "--method",
            "sweep",
            "-o",
            "s.csv",
            "--checkpoint",
            "./s.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("is also an output"),
        "{o:?}"
    );
    assert!(!dir.path().join("s.csv").exists());
}

/// `simulate --plot /dev/stdout` writes the SVG alone on standard output and its summary
/// on stderr, as `draw -o /dev/stdout` does; two outputs on standard output are refused;
/// another command whose results are printed on standard output refuses it with the
/// reason.
#[test]
fn simulate_writes_its_figure_alone_on_standard_output() {
    let dir = tempfile::tempdir().unwrap();
    let o = in_dir(
        dir.path(),
        &[
            "simulate",
            "MODEL",
            "--t-end",
            "0.5",
            "--plot",
            "/dev/stdout",
        ],
    );
    assert!(o.status.success(), "{o:?}");
    let out = String::from_utf8(o.stdout).unwrap();
    assert!(out.starts_with("<svg"), "{}", &out[..out.len().min(200)]);
    assert!(
        out.trim_end().ends_with("</svg>"),
        "{}",
        &out[out.len().saturating_sub(200)..]
    );
    assert!(!out.contains("simulated"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("simulated 0.5 s") && err.contains("wrote /dev/stdout"),
        "{err}"
    );
    let o = in_dir(
        dir.path(),
        &[
            "simulate",
            "MODEL",
            "--t-end",
            "0.5",
            "--plot",
            "/dev/stdout",
            "-o",
            "/dev/fd/1",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    assert!(o.stdout.is_empty());
    let o = in_dir(
        dir.path(),
        &[
            "sweep",
            "MODEL",
            "--set",
            "F0=1",
            "--param",
            "omega",
            "--from",
            "2",
            "--to",
            "3",
            "--step",
            "0.5",
            "--plot",
            "/dev/stdout",
        ],
    );
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("would mix with the figure"),
        "{o:?}"
    );
    assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
}
