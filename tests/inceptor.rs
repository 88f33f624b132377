//! The candidate collective inceptor (`models/inceptor.toml`, a spatial RSSR four-bar on a
//! shaker table) against the independent reference values of `tests/data/inceptor/`
//! (computed in maximal coordinates with the Udwadia–Kalaba equation and with a
//! 2-coordinate model; see its README): the datum and the solved force-sensor length, the
//! modes, the linear and the stepped-sine frequency responses under 7 mm and 5 mm base
//! motion, and the trim's behaviour when parameters change. Everything runs through the
//! command line, as a user's script would.

use serde_json::Value;
use std::process::Command;

const MODEL: &str = "models/inceptor.toml";

fn detune(args: &[&str]) -> Value {
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args(args)
        .env("RAYON_NUM_THREADS", "2")
        .output()
        .expect("run detune");
    assert!(
        out.status.success(),
        "detune {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON on standard output")
}

fn reference(name: &str) -> Value {
    let text = std::fs::read_to_string(format!("tests/data/inceptor/{name}")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn close(got: f64, want: f64, rel: f64, abs: f64, what: &str) {
    assert!(
        (got - want).abs() <= rel * want.abs() + abs,
        "{what}: {got} vs reference {want} (difference {:.3e})",
        got - want
    );
}

/// SPEC §9: every coordinate of the datum and the solved natural length L0, to 1e-9
/// relative or 1e-12 absolute.
#[test]
fn the_datum_and_the_solved_sensor_length_match_the_reference() {
    let eq = detune(&["equilibrium", MODEL, "--json"]);
    let r = reference("equilibrium.json");
    let names = [
        ("stick.x", "x1"),
        ("stick.y", "y1"),
        ("stick.z", "z1"),
        ("stick.phi", "phi"),
        ("rod.x", "x2"),
        ("rod.y", "y2"),
        ("rod.z", "z2"),
        ("rod.alpha", "alpha2"),
        ("rod.beta", "beta2"),
        ("crank.x", "x3"),
        ("crank.y", "y3"),
        ("crank.z", "z3"),
        ("crank.delta", "delta"),
        ("gearbox.x", "x4"),
        ("gearbox.y", "y4"),
        ("gearbox.z", "z4"),
        ("gearbox.theta", "thg"),
    ];
    for (ours, theirs) in names {
        let got = eq["coordinates"][ours].as_f64().unwrap();
        let want = r["coordinates"][theirs].as_f64().unwrap();
        close(got, want, 1e-9, 1e-12, ours);
    }
    assert_eq!(eq["stable"], true);
    let l0 = eq["solved"]["L0"].as_f64().expect("the trim reports L0");
    let want = r["force_sensor"]["L0_natural_length_m"].as_f64().unwrap();
    close(l0, want, 1e-9, 1e-12, "L0");
}

/// SPEC §10.2: undamped frequencies and damped eigenvalues to 1e-6 relative, mode shapes
/// in (φ, θg) normalised to φ to 1e-5.
#[test]
fn the_modes_match_the_reference() {
    let r = &reference("modes.json")["baseline"]["minimal"];
    let undamped = detune(&[
        "modes", MODEL, "--set", "c_d=0", "--set", "c_fs=0", "--json",
    ]);
    let damped = detune(&["modes", MODEL, "--json"]);
    for k in 0..2 {
        let want = &r["undamped"][k];
        let w2 = undamped["undamped_omega2"][k].as_f64().unwrap();
        close(
            w2.sqrt(),
            want["omega_rad_s"].as_f64().unwrap(),
            1e-6,
            0.0,
            "undamped ω",
        );
        let m = &undamped["modes"][k];
        close(
            m["shape"]["gearbox.theta"]["re"].as_f64().unwrap(),
            want["shape"]["thg"].as_f64().unwrap(),
            0.0,
            1e-5,
            "undamped shape θg/φ",
        );
        close(
            m["shape"]["crank.delta"]["re"].as_f64().unwrap(),
            want["shape"]["delta"].as_f64().unwrap(),
            0.0,
            1e-5,
            "undamped shape δ/φ",
        );
        let want = &r["damped"][k];
        let m = &damped["modes"][k];
        close(
            m["eigenvalue"]["re"].as_f64().unwrap(),
            want["eigenvalue"]["re"].as_f64().unwrap(),
            1e-6,
            0.0,
            "Re λ",
        );
        close(
            m["eigenvalue"]["im"].as_f64().unwrap(),
            want["eigenvalue"]["im"].as_f64().unwrap(),
            1e-6,
            0.0,
            "Im λ",
        );
        close(
            m["damping_ratio"].as_f64().unwrap(),
            want["zeta"].as_f64().unwrap(),
            1e-6,
            0.0,
            "ζ",
        );
        for part in ["re", "im"] {
            close(
                m["shape"]["gearbox.theta"][part].as_f64().unwrap(),
                want["shape"]["thg"][part].as_f64().unwrap(),
                0.0,
                1e-5,
                "damped shape θg/φ",
            );
        }
        assert_eq!(m["shape"]["stick.phi"]["re"].as_f64().unwrap(), 1.0);
    }
}

/// The linear response to 7 mm fore-aft base motion (the rheonomic constraint forcing):
/// the refined peaks of φ at the reference's 13.2015 and 26.7021 rad/s (± 1e-4), with
/// its amplitudes.
#[test]
fn the_linear_response_to_base_motion_peaks_at_the_reference_frequencies() {
    let fr = detune(&[
        "frf",
        MODEL,
        "--set",
        "D0=7 mm",
        "--param",
        "omega",
        "--from",
        "5",
        "--to",
        "40",
        "--step",
        "0.5",
        "--response",
        "stick.phi",
        "--json",
    ]);
    let r = &reference("modes.json")["baseline"]["minimal"]["linear_fr_peaks_7mm"];
    let peaks = fr["peaks"].as_array().unwrap();
    assert_eq!(peaks.len(), 2, "{peaks:?}");
    for (p, want) in peaks.iter().zip(r.as_array().unwrap()) {
        close(
            p["omega"].as_f64().unwrap(),
            want["omega"].as_f64().unwrap(),
            0.0,
            1e-4,
            "peak frequency",
        );
        close(
            p["amplitude"].as_f64().unwrap().to_degrees(),
            want["amp_deg"].as_f64().unwrap(),
            1e-6,
            0.0,
            "peak amplitude (deg)",
        );
    }
}

/// SPEC §10.3: stepped-sine sweeps at 7 mm and 5 mm over 5–40 rad/s find the two
/// resonances at 13.2 and 26.7 rad/s (± 0.05; the paper's 7 mm values), and agree with the
/// linear response within 0.5 % at every grid frequency.
#[test]
fn stepped_sine_sweeps_find_the_two_resonances_and_agree_with_the_linear_response() {
    for d0 in ["7 mm", "5 mm"] {
        let set = format!("D0={d0}");
        let grid = [
            "--param",
            "omega",
            "--from",
            "5",
            "--to",
            "40",
            "--step",
            "0.5",
            "--response",
            "stick.phi",
            "--json",
        ];
        let mut args = vec!["sweep", MODEL, "--set", &set, "--refine", "0.1"];
        args.extend(grid);
        let sweep = detune(&args);
        let mut args = vec!["frf", MODEL, "--set", &set];
        args.extend(grid);
        let linear = detune(&args);
        let peaks = sweep["peaks"].as_array().unwrap();
        assert_eq!(peaks.len(), 2, "{d0}: {peaks:?}");
        for (p, want) in peaks.iter().zip([13.2, 26.7]) {
            close(p["omega"].as_f64().unwrap(), want, 0.0, 0.05, "sweep peak");
        }
        let lin: Vec<(f64, f64)> = linear["points"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| {
                (
                    p["omega"].as_f64().unwrap(),
                    p["stick.phi_amplitude"].as_f64().unwrap(),
                )
            })
            .collect();
        let mut compared = 0;
        for p in sweep["points"].as_array().unwrap() {
            let w = p["omega"].as_f64().unwrap();
            let Some(&(_, a)) = lin.iter().find(|(lw, _)| (lw - w).abs() < 1e-9) else {
                continue; // a refinement point off the coarse grid
            };
            let s = p["stick.phi_amplitude"].as_f64().unwrap();
            assert!(
                (s - a).abs() <= 5e-3 * a,
                "{d0}, ω = {w}: sweep {s} vs linear {a} ({:+.3} %)",
                100.0 * (s / a - 1.0)
            );
            compared += 1;
        }
        assert_eq!(compared, 71, "{d0}: every grid frequency compared");
    }
}

/// The trim keeps the datum when another parameter changes (the paper's sensitivity
/// cases re-choose L0 so that φ0 stays at rest), and `--set L0=...` turns it off.
#[test]
fn the_trim_follows_other_parameters_and_is_off_when_its_parameter_is_given() {
    let r = reference("equilibrium.json");
    let phi0 = r["phi0_rad"].as_f64().unwrap();
    let stiff = detune(&["equilibrium", MODEL, "--set", "k_fs=1.1*129500", "--json"]);
    close(
        stiff["coordinates"]["stick.phi"].as_f64().unwrap(),
        phi0,
        0.0,
        1e-12,
        "φ with k_fs + 10 %",
    );
    // the sensor's static force is unchanged, so k (L − L0) is: L0 moves by T/k
    let l_datum = r["force_sensor"]["L_datum_m"].as_f64().unwrap();
    let tension = r["force_sensor"]["tension_N"].as_f64().unwrap();
    close(
        stiff["solved"]["L0"].as_f64().unwrap(),
        l_datum - tension / (1.1 * 129500.0),
        0.0,
        1e-12,
        "L0 with k_fs + 10 %",
    );
    let fixed = detune(&["equilibrium", MODEL, "--set", "L0=0.103", "--json"]);
    assert!(fixed["solved"].is_null());
    assert!(fixed["trim"].as_str().unwrap().contains("L0"));
    let phi = fixed["coordinates"]["stick.phi"].as_f64().unwrap();
    assert!(
        (phi - phi0).abs() > 1e-3,
        "a shorter sensor moves the stick: {phi}"
    );
}

/// `check`: A is 15 × 17 with full row rank (SPEC §7): the rows the bodies' own
/// coordinates satisfy identically (a revolute's axis alignment) are not emitted.
#[test]
fn the_constraints_are_fifteen_independent_rows() {
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args(["check", MODEL])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(text.contains("coordinates (17)"), "{text}");
    assert!(text.contains("constraints (15 equations)"), "{text}");
    assert!(text.contains("degrees of freedom: 2"), "{text}");
}

/// Loads may read velocities (`crank.delta_dot`): the rotary damper written as a torque
/// `−c_d θ̇g` about X on the gearbox, with the `damper` element off, gives the same damped
/// modes (a second formulation of the same damping, to 1e-12).
#[test]
fn a_torque_that_reads_a_velocity_is_a_damper() {
    let text = std::fs::read_to_string(MODEL).unwrap()
        + r#"
[[forces]]
name = "damper_as_torque"
type = "torque"
body = "gearbox"
torque = ["-5.649*gearbox.theta_dot", 0, 0]
"#;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("inceptor_torque.toml");
    std::fs::write(&path, text).unwrap();
    let a = detune(&["modes", MODEL, "--json"]);
    let b = detune(&["modes", path.to_str().unwrap(), "--set", "c_d=0", "--json"]);
    for k in 0..2 {
        for part in ["re", "im"] {
            let x = a["modes"][k]["eigenvalue"][part].as_f64().unwrap();
            let y = b["modes"][k]["eigenvalue"][part].as_f64().unwrap();
            close(y, x, 1e-12, 1e-12, "eigenvalue with the damper as a torque");
        }
    }
}

/// `frf --plot`: one panel per response with the undamped natural frequencies, the
/// refined peaks and the `--mark` line labelled (the figure of docs/inceptor.md).
#[test]
fn the_linear_response_figure_marks_modes_peaks_and_the_rotor_line() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("frf.svg");
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args([
            "frf",
            MODEL,
            "--set",
            "D0=7 mm",
            "--param",
            "omega",
            "--from",
            "5",
            "--to",
            "40",
            "--step",
            "0.5",
            "--response",
            "stick.phi",
            "--response",
            "gearbox.theta",
            "--mark",
            "UH-60 main rotor 1P=258 rpm",
            "--plot",
            svg.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(svg).unwrap();
    for label in [
        "stick.phi: linear frequency response",
        "gearbox.theta: linear frequency response",
        // ω_n = |λ| of the damped modes, as `modes` and the report give them (not the
        // undamped 12.9748 and 26.7664 rad/s)
        "ω_n = |λ| = 13.0902 rad/s",
        "ω_n = |λ| = 26.5306 rad/s",
        "dash-dot: ω_n = |λ| of the damped modes",
        "peak 13.2 rad/s",
        "peak 26.7 rad/s",
        "UH-60 main rotor 1P (27.0177 rad/s)",
    ] {
        assert!(text.contains(label), "`{label}` not in the figure");
    }
    assert!(!text.contains("undamped"));
}
