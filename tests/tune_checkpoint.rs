//! `tune --verify sweep --checkpoint FILE` (issue 13: studies that survive interruption):
//! the designs' stepped-sine sweeps append each steady state to FILE; the same command
//! resumes from it, also from a file cut mid-line by a crash, and writes exactly the
//! output of an uninterrupted run; a checkpoint of other options or of another command is
//! refused with the reason.

mod common;
use common::detune;

fn tune_args<'a>(d0: &'a str, out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![
        "tune",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--set",
        d0,
        "--vary",
        "k_fs=50%..200%",
        "--vary",
        "gearbox_scale=80%..120%",
        "--designs",
        "1",
        "--verify",
        "sweep",
        "-o",
        out,
    ];
    v.extend_from_slice(extra);
    v
}

#[test]
fn a_resumed_verification_writes_the_uninterrupted_output_and_a_foreign_checkpoint_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let (plain, full, resumed, ckpt) = (
        p("plain.json"),
        p("full.json"),
        p("resumed.json"),
        p("c.ckpt"),
    );
    // uninterrupted, without a checkpoint
    let (code, _, err) = detune(&tune_args("D0=0.7 mm", &plain, &[]));
    assert_eq!(code, 0, "{err}");
    let reference = std::fs::read(&plain).unwrap();
    // with a checkpoint: the same output, every steady state recorded (61 coarse
    // frequencies and the refinement's) after the header
    let (code, _, err) = detune(&tune_args("D0=0.7 mm", &full, &["--checkpoint", &ckpt]));
    assert_eq!(code, 0, "{err}");
    assert_eq!(std::fs::read(&full).unwrap(), reference);
    let text = std::fs::read_to_string(&ckpt).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].contains("\"study\":\"tune\""), "{}", lines[0]);
    assert!(lines.len() > 62, "{} lines", lines.len());
    // a run killed after 40 steady states, in the middle of writing the 41st
    let cut = format!(
        "{}\n{}",
        lines[..41].join("\n"),
        &lines[41][..lines[41].len() / 2]
    );
    std::fs::write(&ckpt, cut).unwrap();
    let (code, _, err) = detune(&tune_args("D0=0.7 mm", &resumed, &["--checkpoint", &ckpt]));
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("resuming from the checkpoint")
            && err.contains("40 steady states done before"),
        "{err}"
    );
    assert_eq!(
        std::fs::read(&resumed).unwrap(),
        reference,
        "resumed output differs"
    );
    assert_eq!(
        std::fs::read_to_string(&ckpt).unwrap().lines().count(),
        lines.len(),
        "the torn line was not replaced"
    );
    // another forcing amplitude: other designs' sweeps, refused with the command that
    // wrote the file; nothing written
    let other = p("other.json");
    let (code, _, err) = detune(&tune_args("D0=0.8 mm", &other, &["--checkpoint", &ckpt]));
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("is of a study with other options"), "{err}");
    assert!(err.contains("--set D0=0.7 mm --vary"), "{err}");
    assert!(!std::path::Path::new(&other).exists());
    // a sensitivity study's command given this file: refused
    let (code, _, err) = detune(&[
        "sensitivity",
        "models/inceptor.toml",
        "--set",
        "D0=0.7 mm",
        "--vary",
        "k_fs=±10%",
        "--method",
        "sweep",
        "--checkpoint",
        &ckpt,
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("is of a `detune tune` study"), "{err}");
    // --checkpoint without --verify sweep has nothing to resume
    let (code, _, err) = detune(&[
        "tune",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--vary",
        "k_fs=50%..200%",
        "--checkpoint",
        &ckpt,
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("--checkpoint goes with --verify sweep"),
        "{err}"
    );
}

/// A checkpoint that is the output under another name (`./x.json` for `x.json`, or a
/// link to it) is refused before any work, and nothing is written (compared as the same
/// file, device and inode, as the outputs are with the inputs).
#[test]
fn a_checkpoint_that_is_the_output_under_another_name_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.json");
    let out_s = out.to_str().unwrap().to_string();
    let dotted = format!("{}/./x.json", dir.path().to_str().unwrap());
    let (code, _, err) = detune(&tune_args("D0=0.7 mm", &out_s, &["--checkpoint", &dotted]));
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("is also the output"), "{err}");
    assert!(!out.exists());
    // an existing output reached through a link
    std::fs::write(&out, "keep").unwrap();
    let link = dir.path().join("link.ckpt");
    std::os::unix::fs::symlink(&out, &link).unwrap();
    let (code, _, err) = detune(&tune_args(
        "D0=0.7 mm",
        &out_s,
        &["--checkpoint", link.to_str().unwrap()],
    ));
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("is also the output"), "{err}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "keep");
}
