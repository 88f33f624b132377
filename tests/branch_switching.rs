//! Continuation through a branch point: the branches that cross it are followed too
//! (the overcentre's pitchfork in the spring's free length without gravity), the summary
//! of a run that turns back at a fold, and a start without an equilibrium.

mod common;

use common::overcentre as model;

use detune::System;
use detune::statics::continuation::{ContinuationOptions, continue_equilibria};

const THETA1: usize = 2;

#[test]
fn pitchfork_continuation_returns_three_branches_with_the_side_ones_at_acos_l0_over_l() {
    // g = 0, Fs = 0: k (L cos θ1 − L0) tan θ1 = 0, so θ1 = 0 for every L0 and, for
    // L0 < L, θ1 = ±acos(L0/L) (L = L1 = L2 = 2√2); the branch point is L0 = L.
    let l = 2.0 * 2f64.sqrt();
    let m = model(&[("g", "0"), ("theta1_0", "0")]);
    let opts = ContinuationOptions {
        param: "L0".into(),
        from: 2.5,
        to: 3.2,
        step: 0.05,
        max_steps: 500,
    };
    let b = continue_equilibria(&System::new(&m).unwrap(), &opts).unwrap();
    assert_eq!(b.branch_points.len(), 1);
    assert!((b.branch_points[0].value - l).abs() <= 1e-8 * l);
    // the trivial branch: θ1 = 0, unstable below L, stable above
    assert!(b.points.iter().all(|p| p.q[THETA1].abs() < 1e-10));
    assert!(b.points.iter().any(|p| p.stable) && b.points.iter().any(|p| !p.stable));
    for p in &b.points {
        assert_eq!(p.stable, p.value > l, "trivial branch at L0 = {}", p.value);
    }
    // two side branches, one per side of the branch point
    assert_eq!(b.switched.len(), 2, "three branches in all");
    let mut signs = Vec::new();
    for s in &b.switched {
        assert_eq!(s.branch_point, 0);
        assert!(!s.truncated && s.folds.is_empty());
        assert!(s.points.len() > 5, "{} points", s.points.len());
        let sign = s.points[0].q[THETA1].signum();
        signs.push(sign);
        for p in &s.points {
            let want = sign * (p.value / l).acos();
            assert!(
                (p.q[THETA1] - want).abs() <= 1e-10,
                "θ1 = {} vs ±acos(L0/L) = {want} at L0 = {}",
                p.q[THETA1],
                p.value
            );
            assert!(p.value < l && p.stable, "at L0 = {}", p.value);
        }
        // followed to the end of the range
        assert_eq!(s.points.last().unwrap().value, 2.5);
    }
    signs.sort_by(f64::total_cmp);
    assert_eq!(signs, [-1.0, 1.0]);
}

fn detune(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_detune"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

#[test]
fn the_pitchfork_from_the_command_line_writes_every_branch() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("pitchfork.csv");
    let csv = csv.to_str().unwrap();
    let out = detune(&[
        "continue",
        "models/overcentre.toml",
        "--set",
        "g=0",
        "--set",
        "theta1_0=0",
        "--param",
        "L0",
        "--from",
        "2.5",
        "--to",
        "3.2",
        "--step",
        "0.05",
        "-o",
        csv,
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let branches = v["branches"].as_array().unwrap();
    assert_eq!(branches.len(), 3);
    assert_eq!(branches[0]["points"].as_array().unwrap().len(), v["points"]);
    let l = 2.0 * 2f64.sqrt();
    let (header, rows) = common::read_csv(csv);
    assert_eq!(header.last().unwrap(), "branch");
    assert_eq!(header[header.len() - 2], "stable");
    let col = header.iter().position(|h| h == "bar1.theta").unwrap();
    for (k, b) in branches.iter().enumerate() {
        let pts = b["points"].as_array().unwrap();
        let mine: Vec<&Vec<f64>> = rows.iter().filter(|r| r[r.len() - 1] == k as f64).collect();
        assert_eq!(mine.len(), pts.len(), "branch {k}");
        for (r, p) in mine.iter().zip(pts) {
            let th = p["coordinates"]["bar1.theta"].as_f64().unwrap();
            // the CSV's and the JSON's number formats agree to the last bit or two
            assert!(
                (r[col] - th).abs() <= 4.0 * f64::EPSILON * th.abs(),
                "{} vs {th}",
                r[col]
            );
            let want = if k == 0 {
                0.0
            } else {
                th.signum() * (r[0] / l).acos()
            };
            assert!(
                (th - want).abs() <= 1e-10,
                "branch {k}: θ1 = {th} vs {want}"
            );
        }
        if k > 0 {
            assert_eq!(b["from_branch_point"], 0);
        }
    }
    // the primary ends on the end as given
    assert_eq!(
        rows.iter().rfind(|r| r[r.len() - 1] == 0.0).unwrap()[0],
        3.2
    );
}

#[test]
fn a_run_that_turns_at_the_fold_in_stiffness_says_where() {
    // g = 9.81, Fs = 0: k = g / ((L cos θ1 − L0) tan θ1) along the upper well's branch;
    // its least k (the fold) is at cos³θ1 = L0/L. Continued from k = 100 toward 0, the
    // branch turns there and goes back up to k = 100 on the unstable side.
    let (l, l0, g) = (2.0 * 2f64.sqrt(), 2.0, 9.81);
    let th = (l0 / l).cbrt().acos();
    let k_fold = g / ((l * th.cos() - l0) * th.tan());
    let opts = ContinuationOptions {
        param: "k".into(),
        from: 100.0,
        to: 0.0,
        step: 2.0,
        max_steps: 2000,
    };
    let b = continue_equilibria(&System::new(&model(&[])).unwrap(), &opts).unwrap();
    assert_eq!(b.folds.len(), 1);
    assert!(
        (b.folds[0].value - k_fold).abs() <= 1e-8 * k_fold,
        "{} vs {k_fold}",
        b.folds[0].value
    );
    assert!(
        (b.folds[0].q[THETA1] - th).abs() <= 1e-8,
        "{} vs {th}",
        b.folds[0].q[THETA1]
    );
    assert_eq!(b.points.last().unwrap().value, 100.0);

    let out = detune(&[
        "continue",
        "models/overcentre.toml",
        "--param",
        "k",
        "--from",
        "100",
        "--to",
        "0",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let first = text.lines().next().unwrap();
    let (count, rest) = first.split_once(' ').unwrap();
    assert!(count.parse::<usize>().unwrap() > 10, "{first}");
    assert_eq!(
        rest,
        format!(
            "points from k = 100 N/m turned at the fold at k = {k_fold:.6} N/m; ends at k = 100 N/m"
        )
    );
}

#[test]
fn a_start_without_an_equilibrium_fails_at_the_start_without_a_pose() {
    // 1 MN at the tip of bar 1 outweighs the spring near the initial pose: Newton from
    // there finds nothing; the run must stop before its first step, say so, write no file.
    let opts = ContinuationOptions {
        param: "k".into(),
        from: 100.0,
        to: 0.0,
        step: 2.0,
        max_steps: 2000,
    };
    let e =
        continue_equilibria(&System::new(&model(&[("Fs", "1e6")])).unwrap(), &opts).unwrap_err();
    assert!(
        matches!(
            e.failure(),
            Some(detune::failure::Failure::NoStartEquilibrium { value, .. }) if *value == 100.0
        ),
        "{e}"
    );
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("none.csv");
    let out = detune(&[
        "continue",
        "models/overcentre.toml",
        "--set",
        "Fs=1e6",
        "--param",
        "k",
        "--from",
        "100",
        "--to",
        "0",
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains("continuation cannot start at k = 100"),
        "{err}"
    );
    assert!(
        err.contains("the last iterate is not an equilibrium"),
        "{err}"
    );
    assert!(
        !err.contains("bar1.theta =") && !err.contains("pose bar"),
        "{err}"
    );
    assert!(out.stdout.is_empty());
    assert!(!csv.exists());
}

#[test]
fn the_pitchfork_reached_along_a_side_branch_is_a_branch_point_not_a_fold() {
    // From θ1 = 45° (L0 = 2 = L cos 45°), up in L0: the side branch θ1 = acos(L0/L) meets
    // θ1 = 0 at L0 = L, where the run turns onto the other side branch. That is a branch
    // point (the stability does not change there), and θ1 = 0 is switched to.
    let l = 2.0 * 2f64.sqrt();
    let opts = ContinuationOptions {
        param: "L0".into(),
        from: 2.0,
        to: 3.2,
        step: 0.05,
        max_steps: 500,
    };
    let b = continue_equilibria(&System::new(&model(&[("g", "0")])).unwrap(), &opts).unwrap();
    assert!(b.folds.is_empty());
    assert_eq!(b.branch_points.len(), 1);
    assert!((b.branch_points[0].value - l).abs() <= 1e-8 * l);
    for p in &b.points {
        let want = p.q[THETA1].signum() * (p.value / l).acos();
        assert!(
            (p.q[THETA1] - want).abs() <= 1e-10,
            "{} vs {want}",
            p.q[THETA1]
        );
        assert!(p.stable);
    }
    assert_eq!(b.points.last().unwrap().value, 2.0);
    assert!(
        b.points.last().unwrap().q[THETA1] < 0.0,
        "ends on the other side"
    );
    // θ1 = 0 to both sides: stable up to 3.2, unstable down to 2
    assert_eq!(b.switched.len(), 2);
    let mut ends: Vec<(f64, bool)> = b
        .switched
        .iter()
        .map(|s| {
            assert!(s.points.iter().all(|p| p.q[THETA1].abs() < 1e-10));
            assert!(s.points.iter().all(|p| p.stable == (p.value > l)));
            (s.points.last().unwrap().value, s.points[0].stable)
        })
        .collect();
    ends.sort_by(|a, b| a.0.total_cmp(&b.0));
    assert_eq!(ends, [(2.0, false), (3.2, true)]);

    let out = detune(&[
        "continue",
        "models/overcentre.toml",
        "--set",
        "g=0",
        "--param",
        "L0",
        "--from",
        "2",
        "--to",
        "3.2",
        "--step",
        "0.05",
    ]);
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    // the total over every branch first (the CSV's rows), then branch 0's own count
    let total = lines.next().unwrap();
    let n: usize = total.split(' ').next().unwrap().parse().unwrap();
    assert!(
        total.ends_with("points on 3 branches (the CSV's `branch` column: 0 is the start's)"),
        "{total}"
    );
    let first = lines.next().unwrap();
    assert!(first.starts_with("branch 0: "), "{first}");
    assert!(
        first.ends_with(
            "points from L0 = 2 m turned at the branch point at L0 = 2.828427 m; ends at L0 = 2 m"
        ),
        "{first}"
    );
    let counts: usize = text
        .lines()
        .filter_map(|l| {
            let l = l.strip_prefix("branch 0: ").or_else(|| {
                l.starts_with("branch ")
                    .then(|| l.split(": ").nth(1).unwrap_or(""))
            })?;
            l.split(' ').next()?.parse::<usize>().ok()
        })
        .sum();
    assert_eq!(counts, n, "{text}");
}
