//! `kinematics`: the closure solved along a driven coordinate, against the inceptor's
//! reference transmission ratio (`tests/data/inceptor/static_ratio.csv`, computed two
//! independent ways), the overcentre's closed form, and its dead point.

mod common;
use common::detune;

use detune::failure::Failure;
use detune::kinematics::{KinematicPath, KinematicsOptions, kinematics};
use detune::request::{Argument, Invalid};
use detune::{System, assemble};
use std::f64::consts::PI;

fn inceptor() -> System {
    let model = detune::Model::load(&format!(
        "{}/models/inceptor.toml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    System::new(&model).unwrap()
}

fn overcentre(sets: &[(&str, &str)]) -> System {
    System::new(&common::overcentre(sets)).unwrap()
}

fn opts(drive: &str, from: f64, to: f64, step: f64, ratios: &[&str]) -> KinematicsOptions {
    KinematicsOptions {
        drive: drive.into(),
        from,
        to,
        step,
        ratios: ratios.iter().map(|s| s.to_string()).collect(),
    }
}

/// The reference rows: φ (deg), δ (deg), dφ/dδ.
fn static_ratio() -> Vec<[f64; 3]> {
    let (header, rows) = common::read_csv(common::data("inceptor/static_ratio.csv"));
    assert_eq!(header, ["phi_deg", "delta_deg", "dphi_ddelta"]);
    rows.iter().map(|r| [r[0], r[1], r[2]]).collect()
}

/// Largest |δ − δ_ref| (deg) and |dφ/dδ − ref| over the reference rows, given φ (rad),
/// δ (rad) and dφ/dδ per row.
fn worst_against_reference(rows: &[(f64, f64, f64)]) -> (f64, f64) {
    let reference = static_ratio();
    assert_eq!(rows.len(), reference.len(), "one row per reference angle");
    assert_eq!(reference.len(), 101);
    let (mut dd, mut dr) = (0.0f64, 0.0f64);
    for (&(phi, delta, ratio), r) in rows.iter().zip(&reference) {
        assert!(
            (phi.to_degrees() - r[0]).abs() < 1e-9,
            "φ {phi} vs {}°",
            r[0]
        );
        dd = dd.max((delta.to_degrees() - r[1]).abs());
        dr = dr.max((ratio - r[2]).abs());
    }
    (dd, dr)
}

fn inceptor_path() -> KinematicPath {
    let sys = inceptor();
    kinematics(
        &sys,
        &opts(
            "stick.phi",
            (-15.0f64).to_radians(),
            35f64.to_radians(),
            0.5f64.to_radians(),
            &["crank.delta"],
        ),
    )
    .unwrap()
}

#[test]
fn inceptor_ratio_matches_the_reference_through_the_library() {
    let path = inceptor_path();
    let sys = inceptor();
    let delta = sys.coordinate_index("crank.delta").unwrap();
    let rows: Vec<(f64, f64, f64)> = (0..path.values.len())
        .map(|k| (path.values[k], path.q[k][delta], path.ratios[k][0]))
        .collect();
    let (dd, dr) = worst_against_reference(&rows);
    // the reference has 10 decimals: 5e-11 is its rounding
    assert!(dd <= 1e-9, "max |δ error| = {dd:e}°");
    assert!(dr <= 1e-9, "max |dφ/dδ error| = {dr:e}");
    // the drive column is the driven coordinate
    for (k, v) in path.values.iter().enumerate() {
        assert_eq!(path.q[k][path.drive_index], *v);
    }
    // every point closes the loop
    for q in &path.q {
        let phi = sys.residual(q, 0.0);
        assert!(phi.amax() <= 1e-12, "|Φ| = {:e}", phi.amax());
    }
}

#[test]
fn the_gearbox_keeps_its_assembled_values() {
    let sys = inceptor();
    let start = assemble(&sys).unwrap();
    let path = inceptor_path();
    for name in ["gearbox.x", "gearbox.y", "gearbox.z", "gearbox.theta"] {
        let i = sys.coordinate_index(name).unwrap();
        assert!(!path.moving[i], "{name} moves with the stick");
        for q in &path.q {
            assert_eq!(q[i], start.q[i], "{name}");
        }
    }
    for name in ["rod.alpha", "crank.delta", "stick.x"] {
        assert!(path.moving[sys.coordinate_index(name).unwrap()], "{name}");
    }
    // a ratio to the gearbox is undefined: it does not move with the stick
    let e = kinematics(&sys, &opts("stick.phi", 0.0, 0.1, 0.05, &["gearbox.theta"])).unwrap_err();
    assert_eq!(
        e.invalid(),
        Some(&Invalid::NotDriven {
            name: "gearbox.theta".into(),
            drive: "stick.phi".into()
        })
    );
}

#[test]
fn inceptor_ratio_matches_the_reference_through_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("ratio.csv");
    let svg = dir.path().join("ratio.svg");
    let (code, out, err) = detune(&[
        "kinematics",
        "models/inceptor.toml",
        "--drive",
        "stick.phi",
        "--from",
        "-15 deg",
        "--to",
        "35 deg",
        "--step",
        "0.5 deg",
        "--ratio",
        "crank.delta",
        "-o",
        csv.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("101 points"), "{out}");
    let (header, rows) = common::read_csv(&csv);
    let sys = inceptor();
    let mut expected = vec!["stick.phi".to_string()];
    expected.extend(sys.coordinates.iter().cloned());
    expected.push("dstick.phi/dcrank.delta".into());
    assert_eq!(header, expected);
    let delta = 1 + sys.coordinate_index("crank.delta").unwrap();
    let last = header.len() - 1;
    let rows: Vec<(f64, f64, f64)> = rows.iter().map(|r| (r[0], r[delta], r[last])).collect();
    let (dd, dr) = worst_against_reference(&rows);
    assert!(dd <= 1e-9, "max |δ error| = {dd:e}°");
    assert!(dr <= 1e-9, "max |dφ/dδ error| = {dr:e}");
    let svg = std::fs::read_to_string(svg).unwrap();
    assert!(svg.contains("stick.phi [deg]") && svg.contains("dstick.phi/dcrank.delta"));
}

/// The overcentre's closure, B on y = 0: L1 sin θ1 = L2 sin θ2 with bar 2 from B to J,
/// θ2 = π − asin(u), u = (L1/L2) sin θ1 (B to the right of A).
#[test]
fn overcentre_follows_its_closed_form() {
    let (l1, l2) = (2.0 * 2f64.sqrt(), 2.5);
    let sys = overcentre(&[("L2", "2.5"), ("theta1_0", "20 deg")]);
    let (from, to, step) = (
        (-30f64).to_radians(),
        60f64.to_radians(),
        2.5f64.to_radians(),
    );
    let o = opts("bar1.theta", from, to, step, &["bar2.theta", "bar2.x"]);
    let path = kinematics(&sys, &o).unwrap();
    assert_eq!(path.values.len(), 37);
    let ix = |n: &str| sys.coordinate_index(n).unwrap();
    let r = l1 / l2;
    for (k, &th) in path.values.iter().enumerate() {
        let u = r * th.sin();
        let w = (1.0 - u * u).sqrt();
        let q = &path.q[k];
        let close = |got: f64, want: f64, what: &str| {
            assert!(
                (got - want).abs() <= 1e-10,
                "{what} at θ1 = {th}: {got} vs {want}"
            );
        };
        close(q[ix("bar1.x")], l1 / 2.0 * th.cos(), "bar1.x");
        close(q[ix("bar1.y")], l1 / 2.0 * th.sin(), "bar1.y");
        close(q[ix("bar2.theta")], PI - u.asin(), "bar2.theta");
        close(q[ix("bar2.x")], l1 * th.cos() + l2 / 2.0 * w, "bar2.x");
        close(q[ix("bar2.y")], l1 / 2.0 * th.sin(), "bar2.y");
        // the tangent: dθ2/dθ1 = −u'/w, dx2/dθ1 = −L1 sin θ1 − (L2/2) u u'/w,
        // u' = r cos θ1 (compared as 1/ratio: dx2/dθ1 vanishes at θ1 = 0)
        let du = r * th.cos();
        close(1.0 / path.ratios[k][0], -du / w, "dθ2/dθ1");
        close(
            1.0 / path.ratios[k][1],
            -l1 * th.sin() - l2 / 2.0 * u * du / w,
            "dx2/dθ1",
        );
    }
    // the same path downwards: the same points in the other order
    let down = kinematics(&sys, &opts("bar1.theta", to, from, step, &["bar2.theta"])).unwrap();
    assert_eq!(down.values.len(), path.values.len());
    for (k, qd) in down.q.iter().enumerate() {
        let qu = &path.q[path.q.len() - 1 - k];
        for (a, b) in qd.iter().zip(qu) {
            assert!((a - b).abs() <= 1e-12, "{a} vs {b}");
        }
    }
}

/// With L2 < L1, bar 2 cannot reach the slot beyond sin θ1 = L2/L1: with L2 = 2,
/// L1 = 2√2, θ1 = 45°.
#[test]
fn a_dead_point_ends_the_branch_with_the_drive_value_reached() {
    let sys = overcentre(&[("L2", "2"), ("theta1_0", "30 deg")]);
    let e = kinematics(
        &sys,
        &opts(
            "bar1.theta",
            0.0,
            60f64.to_radians(),
            4f64.to_radians(),
            &[],
        ),
    )
    .unwrap_err();
    let Some(Failure::DeadPoint {
        drive,
        value,
        target,
        angle,
    }) = e.failure()
    else {
        panic!("{e}");
    };
    assert_eq!(drive, "bar1.theta");
    assert!(*angle);
    assert!((value - PI / 4.0).abs() < 1e-6, "ended at {value}");
    assert!(*value < PI / 4.0);
    assert!(
        (target - 48f64.to_radians()).abs() < 1e-12,
        "target {target}"
    );

    // with equal bars, B reaches A at θ1 = 90°, where the branches cross: a step that
    // lands there ends the branch just before it
    let sys = overcentre(&[]);
    let e = kinematics(
        &sys,
        &opts(
            "bar1.theta",
            80f64.to_radians(),
            100f64.to_radians(),
            10f64.to_radians(),
            &[],
        ),
    )
    .unwrap_err();
    let Some(Failure::DeadPoint { value, target, .. }) = e.failure() else {
        panic!("{e}");
    };
    assert!(
        *value < PI / 2.0 && *value > PI / 2.0 - 1e-4,
        "ended at {value}"
    );
    assert!((target - PI / 2.0).abs() < 1e-12, "target {target}");

    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("dead.csv");
    let (code, _, err) = detune(&[
        "kinematics",
        "models/overcentre.toml",
        "--set",
        "L2=2",
        "--set",
        "theta1_0=30 deg",
        "--drive",
        "bar1.theta",
        "--from",
        "0",
        "--to",
        "60 deg",
        "--step",
        "4 deg",
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(code, 1);
    assert!(
        err.contains("the branch ends at bar1.theta = 0.785398") && err.contains("45.0000"),
        "{err}"
    );
    assert!(
        err.contains("help:") && err.contains("--from/--to"),
        "{err}"
    );
    assert!(!csv.exists(), "no CSV for a failed run");
}

#[test]
fn invalid_requests_are_typed_and_worded_with_the_flags() {
    let sys = overcentre(&[]);
    let invalid = |o: KinematicsOptions| kinematics(&sys, &o).unwrap_err().invalid().cloned();
    match invalid(opts("bar1.thet", 0.0, 1.0, 0.1, &[])) {
        Some(
            i @ Invalid::UnknownCoordinate {
                argument: Argument::Drive,
                ..
            },
        ) => {
            assert!(i.hint().contains("bar1.theta"), "{}", i.hint());
        }
        other => panic!("{other:?}"),
    }
    // a parameter is not a coordinate
    assert!(matches!(
        invalid(opts("L1", 0.0, 1.0, 0.1, &[])),
        Some(Invalid::UnknownCoordinate {
            argument: Argument::Drive,
            ..
        })
    ));
    assert!(matches!(
        invalid(opts("bar1.theta", 0.0, 1.0, 0.1, &["bar3.theta"])),
        Some(Invalid::UnknownCoordinate {
            argument: Argument::Ratio,
            ..
        })
    ));
    for step in [0.0, -0.1, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            invalid(opts("bar1.theta", 0.0, 1.0, step, &[])),
            Some(Invalid::NotPositive {
                argument: Argument::DriveStep,
                ..
            })
        ));
    }
    for (from, to) in [(f64::NAN, 1.0), (0.0, f64::INFINITY)] {
        assert!(matches!(
            invalid(opts("bar1.theta", from, to, 0.1, &[])),
            Some(Invalid::Range {
                what: Argument::DriveRange,
                ..
            })
        ));
    }

    let run = |extra: &[&str]| {
        let mut args = vec!["kinematics", "models/overcentre.toml"];
        args.extend_from_slice(extra);
        detune(&args)
    };
    let (code, _, err) = run(&[
        "--drive",
        "bar1.thet",
        "--from",
        "0",
        "--to",
        "1",
        "--step",
        "0.1",
    ]);
    assert_eq!(code, 1);
    assert!(
        err.contains("--drive bar1.thet: the model has no coordinate `bar1.thet`")
            && err.contains("bar1.theta"),
        "{err}"
    );
    let (code, _, err) = run(&[
        "--drive",
        "bar1.theta",
        "--from",
        "0",
        "--to",
        "1",
        "--step",
        "0.1",
        "--ratio",
        "bar9.x",
    ]);
    assert_eq!(code, 1);
    assert!(
        err.contains("--ratio bar9.x: the model has no coordinate"),
        "{err}"
    );
    let (code, _, err) = run(&[
        "--drive",
        "bar1.theta",
        "--from",
        "0",
        "--to",
        "1",
        "--step",
        "0 deg",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("--step 0 is not valid"), "{err}");
    let (code, _, err) = run(&[
        "--drive",
        "bar1.theta",
        "--from",
        "3 mm",
        "--to",
        "1",
        "--step",
        "0.1",
    ]);
    assert_eq!(code, 1);
    assert!(
        err.contains("--from 3 mm") && err.contains("an angle"),
        "{err}"
    );
    let (code, _, err) = run(&[
        "--drive",
        "bar1.theta",
        "--from",
        "-15 dgr",
        "--to",
        "1",
        "--step",
        "0.1",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("--from -15 dgr"), "{err}");
    let (code, _, err) = run(&[
        "--drive",
        "bar1.theta",
        "--from",
        "L1",
        "--to",
        "1",
        "--step",
        "0.1",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("--from L1"), "{err}");
    let (code, _, err) = run(&[
        "--drive", "bar1.x", "--from", "0.5", "--to", "1", "--step", "10 deg",
    ]);
    assert_eq!(code, 1);
    assert!(
        err.contains("--step 10 deg") && err.contains("in m"),
        "{err}"
    );
    let (code, _, err) = run(&[
        "--drive",
        "bar1.theta",
        "--from",
        "1/0",
        "--to",
        "1",
        "--step",
        "0.1",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("not finite"), "{err}");
    // `nan` is a value that is not finite, not an unknown unit
    let (code, _, err) = run(&[
        "--drive",
        "bar1.theta",
        "--from",
        "nan",
        "--to",
        "1",
        "--step",
        "0.1",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("--from nan: not finite"), "{err}");
}

#[test]
fn a_length_drive_and_the_table_without_an_output() {
    // bar 1's CG abscissa drives the overcentre down from its assembled 1.0 m
    let (code, out, err) = detune(&[
        "kinematics",
        "models/overcentre.toml",
        "--drive",
        "bar1.x",
        "--from",
        "1.2 m",
        "--to",
        "800 mm",
        "--step",
        "10 cm",
    ]);
    assert_eq!(code, 0, "{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 6, "{out}");
    assert!(lines[0].contains("bar1.x [m]") && lines[0].contains("bar1.theta [deg]"));
    // θ1 = acos(2 x1 / L1)
    let l1 = 2.0 * 2f64.sqrt();
    for (line, x) in lines[1..].iter().zip([1.2, 1.1, 1.0, 0.9, 0.8]) {
        let cells: Vec<f64> = line
            .split_whitespace()
            .map(|c| c.parse().unwrap())
            .collect();
        assert!((cells[0] - x).abs() < 1e-9, "{line}");
        let theta = (2.0 * x / l1).acos().to_degrees();
        assert!((cells[2] - theta).abs() < 1e-8, "{line}: θ1 {theta}");
    }
}

/// Where the ratio's coordinate is stationary (the overcentre's bar 2 at θ1 = 0: x2 =
/// 1.5 L1 cos θ1 is extremal) the ratio is infinite, not 1/round-off; elsewhere it is
/// dθ1/dx2 = −1/(1.5 L1 sin θ1). The table gives each ratio its unit.
#[test]
fn a_stationary_coordinate_has_an_infinite_ratio_and_the_table_units() {
    let l1 = 2.0 * 2f64.sqrt();
    let sys = overcentre(&[]);
    let o = opts(
        "bar1.theta",
        0.0,
        40f64.to_radians(),
        20f64.to_radians(),
        &["bar2.x"],
    );
    let path = kinematics(&sys, &o).unwrap();
    assert_eq!(path.ratios[0][0], f64::INFINITY);
    for k in 1..3 {
        let th = path.values[k];
        let want = -1.0 / (1.5 * l1 * th.sin());
        assert!((path.ratios[k][0] - want).abs() <= 1e-9 * want.abs());
    }
    let (code, out, err) = detune(&[
        "kinematics",
        "models/overcentre.toml",
        "--drive",
        "bar1.theta",
        "--from",
        "0 deg",
        "--to",
        "40 deg",
        "--step",
        "20 deg",
        "--ratio",
        "bar2.x",
    ]);
    assert_eq!(code, 0, "{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert!(lines[0].contains("dbar1.theta/dbar2.x [rad/m]"), "{out}");
    assert!(lines[1].trim_end().ends_with("inf"), "{out}");
    assert!(
        err.contains("dbar1.theta/dbar2.x is infinite at bar1.theta = 0.000000°"),
        "{err}"
    );
}
