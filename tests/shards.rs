//! Studies that survive interruption and outgrow one machine (issue 13): a sweep killed
//! with SIGKILL and resumed from its checkpoint, and a study run in shards and merged,
//! write exactly (byte for byte) what one uninterrupted run writes; checkpoints and
//! shards of another study are refused. Overcentre lower well, tiny grids.

use std::path::Path;
use std::process::{Command, Output};

fn detune(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .output()
        .unwrap()
}

fn words(line: &str) -> Vec<&str> {
    line.split_whitespace().collect()
}

fn with<'a>(base: &'a str, more: &[&'a str]) -> Vec<&'a str> {
    let mut v = words(base);
    v.extend_from_slice(more);
    v
}

fn ok(out: &Output) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(0), "{err}");
    err
}

fn refused(out: &Output, needle: &str) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains(needle), "expected {needle:?} in: {err}");
    err
}

fn path(dir: &Path, name: &str) -> String {
    dir.join(name).to_str().unwrap().to_string()
}

fn read(p: &str) -> String {
    std::fs::read_to_string(p).unwrap()
}

/// An up sweep over the jump of the lower well at F0 = 4 N: each frequency starts from
/// the previous steady state, so a resumed sweep must continue the chain from the stored
/// end state, bit for bit.
const UP: &str = "sweep models/overcentre.toml --set theta1_0=-0.85 --set c=0.2 --set F0=4 \
    --param omega --from 3.4 --to 4.4 --step 0.1 --response bar1.theta --max-periods 200 \
    --mode up";

#[test]
fn a_sweep_killed_with_sigkill_resumes_to_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let (one, resumed, ckpt) = (
        path(dir.path(), "one.csv"),
        path(dir.path(), "resumed.csv"),
        path(dir.path(), "up.ckpt"),
    );
    let single = detune(&with(UP, &["-o", &one]));
    ok(&single);
    let mut child = Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(with(UP, &["-o", &resumed, "--checkpoint", &ckpt]))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // killed once the header and two frequencies are in the checkpoint
    let lines = || std::fs::read_to_string(&ckpt).map_or(0, |t| t.lines().count());
    let began = std::time::Instant::now();
    while lines() < 3 && began.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL: nothing is flushed or cleaned up
    let status = child.wait().unwrap();
    assert_eq!(status.code(), None, "the sweep ended before it was killed");
    assert!(!Path::new(&resumed).exists(), "a killed run wrote its CSV");
    let done = lines() - 1;
    // a crash mid-write leaves a torn last line: ignored and cut off
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(&ckpt)
        .unwrap();
    std::io::Write::write_all(&mut f, b"{\"run\":0,\"kind\":\"coa").unwrap();
    drop(f);
    let again = detune(&with(UP, &["-o", &resumed, "--checkpoint", &ckpt]));
    let err = ok(&again);
    assert!(
        err.contains(&format!("{done} steady states done before")),
        "{err}"
    );
    assert!((2..11).contains(&done), "{done} of 11 frequencies done");
    assert_eq!(read(&one), read(&resumed));
    // the jump up (between 3.9 and 4 rad/s) found again by the resumed chain
    assert!(read(&resumed).lines().count() == 12);
    // the same checkpoint with other options is refused, and left as it was
    let before = read(&ckpt);
    refused(
        &detune(&with(UP, &["--settle-tol", "1e-6", "--checkpoint", &ckpt])),
        "is of a sweep with other options",
    );
    assert_eq!(before, read(&ckpt));
    // a model file is not a checkpoint: refused, never overwritten
    refused(
        &detune(&with(UP, &["--checkpoint", "models/overcentre.toml"])),
        "is not a detune sweep checkpoint",
    );
}

/// An independent sweep over a 2 × 2 grid of --values (F0 and c): 16 cases, shared
/// round robin by three shards.
const GRID: &str = "sweep models/overcentre.toml --set theta1_0=-0.85 --param omega \
    --from 3.8 --to 4.4 --step 0.2 --response bar1.theta --max-periods 200 \
    --values F0=0.5,1 --values c=1,2";

#[test]
fn three_shards_merged_equal_one_run_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| path(dir.path(), n);
    let single = detune(&with(GRID, &["-o", &p("one.csv"), "--json"]));
    ok(&single);
    let csv = read(&p("one.csv"));
    let mut rows = csv.lines();
    assert!(
        rows.next()
            .unwrap()
            .starts_with("omega,direction,F0,c,bar1.theta_amplitude,")
    );
    // the grid: every combination, the first --values varying slowest
    let cases: Vec<(f64, f64)> = rows
        .map(|r| {
            let f: Vec<&str> = r.split(',').collect();
            (f[2].parse().unwrap(), f[3].parse().unwrap())
        })
        .collect();
    assert_eq!(cases.len(), 16);
    for (k, want) in [(0.5, 1.0), (0.5, 2.0), (1.0, 1.0), (1.0, 2.0)]
        .iter()
        .enumerate()
    {
        assert!(
            cases[4 * k..4 * k + 4].iter().all(|c| c == want),
            "{cases:?}"
        );
    }
    for k in 1..=3 {
        let shard = format!("{k}/3");
        let out = detune(&with(
            GRID,
            &["--shard", &shard, "--checkpoint", &p(&format!("p{k}.ckpt"))],
        ));
        ok(&out);
        assert!(String::from_utf8_lossy(&out.stdout).contains(&format!("shard {k}/3")));
    }
    let (p1, p2, p3) = (p("p1.ckpt"), p("p2.ckpt"), p("p3.ckpt"));
    // 16 cases: 6, 5 and 5 lines after the header
    let cases_in = |f: &str| read(f).lines().count() - 1;
    assert_eq!([cases_in(&p1), cases_in(&p2), cases_in(&p3)], [6, 5, 5]);
    let merged = detune(&[
        "merge",
        &p3,
        &p1,
        &p2,
        "-o",
        &p("all.csv"),
        "--json",
        "--checkpoint",
        &p("all.ckpt"),
    ]);
    ok(&merged);
    assert_eq!(csv, read(&p("all.csv")));
    let json = |o: &Output| -> serde_json::Value { serde_json::from_slice(&o.stdout).unwrap() };
    let (a, b) = (json(&single), json(&merged));
    assert!(a["peaks"].as_array().unwrap().len() == 4, "{}", a["peaks"]);
    assert_eq!(a["peaks"], b["peaks"]);
    assert_eq!(a, b);

    // refining the merged curve from the merged checkpoint gives the refined run
    let refined = |extra: &[&str]| {
        let mut args = with(GRID, &["--refine", "0.05", "-o"]);
        args.extend_from_slice(extra);
        ok(&detune(&args));
    };
    refined(&[&p("refined.csv")]);
    refined(&[&p("refined-from.csv"), "--checkpoint", &p("all.ckpt")]);
    assert_eq!(read(&p("refined.csv")), read(&p("refined-from.csv")));
    // and from the merged CSV
    refined(&[&p("refined-csv.csv"), "--refine-from", &p("all.csv")]);
    assert_eq!(read(&p("refined.csv")), read(&p("refined-csv.csv")));
    assert!(read(&p("refined.csv")).lines().count() > 17);

    // a shard missing, given twice, or of another study: refused
    refused(
        &detune(&["merge", &p1, &p3]),
        "shard 2/3 of the study is missing",
    );
    refused(&detune(&["merge", &p1, &p1, &p3]), "is given twice");
    let other = p("other.ckpt");
    ok(&detune(&with(
        GRID,
        &[
            "--set",
            "theta1_0=-0.8",
            "--shard",
            "2/3",
            "--checkpoint",
            &other,
        ],
    )));
    refused(
        &detune(&["merge", &p1, &other, &p3]),
        "the shards are not of one study",
    );
    // a shard that did not finish: its cases are missing
    let torn = p("torn.ckpt");
    std::fs::write(&torn, read(&p2).lines().next().unwrap().to_string() + "\n").unwrap();
    refused(
        &detune(&["merge", &p1, &torn, &p3]),
        "which shard 2/3 computes: it is incomplete",
    );
}

#[test]
fn shards_are_refused_where_they_cannot_work() {
    let dir = tempfile::tempdir().unwrap();
    let ckpt = path(dir.path(), "s.ckpt");
    let err = refused(
        &detune(&with(
            GRID,
            &["--refine", "0.05", "--shard", "1/2", "--checkpoint", &ckpt],
        )),
        "--refine cannot be used with --shard 1/2",
    );
    assert!(err.contains("--refine R --checkpoint all.ckpt"), "{err}");
    // a missing argument is a usage error (exit 2), named by clap
    let out = detune(&with(GRID, &["--shard", "1/2"]));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--checkpoint"), "{err}");
    refused(
        &detune(&with(GRID, &["--shard", "3/2", "--checkpoint", &ckpt])),
        "expected K/N with 1 ≤ K ≤ N",
    );
    // sequential sweeps share --values cases only: 4 here
    refused(
        &detune(&with(
            GRID,
            &["--mode", "up", "--shard", "1/5", "--checkpoint", &ckpt],
        )),
        "sharded by --values case only",
    );
    assert!(
        !Path::new(&ckpt).exists(),
        "a refused shard wrote its checkpoint"
    );
}

/// `detune merge` run from another directory than the shards': the stored command's
/// relative model path is resolved where the shards ran (told by where their checkpoints
/// are now and the path their command gave them), and the merged CSV is byte for byte
/// the one run's; a model that is nowhere to be found is refused, saying where it looked.
#[test]
fn merge_finds_the_shards_model_from_another_directory() {
    let root = tempfile::tempdir().unwrap();
    let (run, other) = (root.path().join("run"), root.path().join("other"));
    std::fs::create_dir_all(run.join("out")).unwrap();
    std::fs::create_dir_all(&other).unwrap();
    let model = format!("{}/models/overcentre.toml", env!("CARGO_MANIFEST_DIR"));
    std::fs::copy(&model, run.join("overcentre.toml")).unwrap();
    let at = |dir: &Path, args: &[&str]| -> Output {
        Command::new(env!("CARGO_BIN_EXE_detune"))
            .current_dir(dir)
            .args(args)
            .output()
            .unwrap()
    };
    let base = "sweep overcentre.toml --set theta1_0=-0.85 --set F0=1 --param omega \
        --from 2 --to 3 --step 0.25 --response bar1.theta --max-periods 200";
    ok(&at(&run, &with(base, &["-o", "one.csv"])));
    for k in 1..=2 {
        let (shard, ckpt) = (format!("{k}/2"), format!("out/p{k}.ckpt"));
        ok(&at(
            &run,
            &with(base, &["--shard", &shard, "--checkpoint", &ckpt]),
        ));
    }
    let merge = [
        "merge",
        "../run/out/p2.ckpt",
        "../run/out/p1.ckpt",
        "-o",
        "all.csv",
    ];
    ok(&at(&other, &merge));
    let one = read(run.join("one.csv").to_str().unwrap());
    assert_eq!(read(other.join("all.csv").to_str().unwrap()), one);
    // the checkpoints moved away from the model: refused, naming the places tried
    for k in 1..=2 {
        let name = format!("p{k}.ckpt");
        std::fs::rename(run.join("out").join(&name), other.join(&name)).unwrap();
    }
    let err = refused(
        &at(&other, &["merge", "p1.ckpt", "p2.ckpt", "-o", "moved.csv"]),
        "the shards' model overcentre.toml (relative to the directory they ran in) is not found",
    );
    assert!(err.contains("run detune merge in that directory"), "{err}");
    assert!(!other.join("moved.csv").exists());
    // beside the checkpoints it is found again
    std::fs::copy(&model, other.join("overcentre.toml")).unwrap();
    ok(&at(
        &root.path().join("run"),
        &[
            "merge",
            "../other/p1.ckpt",
            "../other/p2.ckpt",
            "-o",
            "again.csv",
        ],
    ));
    assert_eq!(read(run.join("again.csv").to_str().unwrap()), one);
}

/// `sensitivity --method sweep --checkpoint FILE`: a study stopped part way (its
/// checkpoint cut after a third of the steady states, the last line torn, as SIGKILL
/// leaves it) resumes with the same command to exactly the output of a run without a
/// checkpoint; a checkpoint of other cases, of a sweep, or with --method linear is
/// refused.
#[test]
fn a_sensitivity_study_resumes_from_its_checkpoint_to_the_same_bytes() {
    const SENS: &str = "sensitivity tests/data/sdof.toml --set F0=1 --vary k=880 \
        --method sweep --response block.x --json";
    let dir = tempfile::tempdir().unwrap();
    let ckpt = path(dir.path(), "s.ckpt");
    let plain = detune(&words(SENS));
    ok(&plain);
    let first = detune(&with(SENS, &["--checkpoint", &ckpt]));
    ok(&first);
    assert_eq!(first.stdout, plain.stdout);
    let full = read(&ckpt);
    let lines: Vec<&str> = full.lines().collect();
    assert!(lines.len() > 60, "{} lines", lines.len());
    let keep = lines.len() / 3;
    let torn = &lines[keep][..lines[keep].len() / 2];
    std::fs::write(&ckpt, format!("{}\n{torn}", lines[..keep].join("\n"))).unwrap();
    let resumed = detune(&with(SENS, &["--checkpoint", &ckpt]));
    let err = ok(&resumed);
    assert!(
        err.contains(&format!(
            "resuming from the checkpoint {ckpt}: {} steady states done before",
            keep - 1
        )),
        "{err}"
    );
    assert_eq!(
        String::from_utf8_lossy(&resumed.stdout),
        String::from_utf8_lossy(&plain.stdout)
    );
    assert_eq!(read(&ckpt).lines().count(), lines.len());
    // other cases: refused with the command that wrote it
    let other = SENS.replace("k=880", "k=900");
    let err = refused(
        &detune(&with(&other, &["--checkpoint", &ckpt])),
        "is of a study with other options or --set",
    );
    assert!(
        err.contains("detune sensitivity tests/data/sdof.toml"),
        "{err}"
    );
    // a sweep's checkpoint is not a sensitivity study's, and the other way round
    refused(
        &detune(&with(
            "sweep tests/data/sdof.toml --set F0=1 --param omega --from 15 --to 25 --step 1",
            &["--checkpoint", &ckpt],
        )),
        "is of a `detune sensitivity` study, not of this `detune sweep`",
    );
    refused(
        &detune(&["merge", &ckpt, "-o", &path(dir.path(), "m.csv")]),
        "not of a sharded sweep",
    );
    refused(
        &detune(&with(
            "sensitivity tests/data/sdof.toml --vary k=880",
            &["--checkpoint", &ckpt],
        )),
        "--method linear has no sweeps to resume",
    );
}
