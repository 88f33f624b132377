//! The planar `torsion` element (the same type name as in spatial models): a disc held to
//! the ground by a torsion spring with a free angle, and an arm coupled to the disc by a
//! second one. Closed forms: the equilibrium sits at the free angle; the undamped ω² are
//! the eigenvalues of M⁻¹K with M = diag(I_disc, I_arm), K = [[k + k2, −k2], [−k2, k2]];
//! the twist and torque responses follow the definition.

use std::process::Command;

const MODEL: &str = "tests/data/planar_torsion.toml";

fn json(args: &[&str]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn the_equilibrium_is_at_the_free_angle_and_the_frequencies_are_the_closed_form() {
    let eq = json(&["equilibrium", MODEL, "--json"]);
    for c in ["disc.theta", "arm.theta"] {
        let th = eq["coordinates"][c].as_f64().unwrap();
        assert!((th - 0.1).abs() < 1e-12, "{c} = {th}");
    }
    let modes = json(&["modes", MODEL, "--set", "c=0", "--json"]);
    let (i1, i2, k, k2): (f64, f64, f64, f64) = (0.1, 0.05, 40.0, 10.0);
    // M⁻¹K = [[(k + k2)/i1, −k2/i1], [−k2/i2, k2/i2]]
    let (a, b, c, d) = ((k + k2) / i1, -k2 / i1, -k2 / i2, k2 / i2);
    let (tr, det) = (a + d, a * d - b * c);
    let disc = (tr * tr / 4.0 - det).sqrt();
    let want = [tr / 2.0 - disc, tr / 2.0 + disc];
    let got = modes["undamped_omega2"].as_array().unwrap();
    assert_eq!(got.len(), 2);
    for (g, w) in got.iter().zip(want) {
        let g = g.as_f64().unwrap();
        assert!((g - w).abs() < 1e-9 * w, "ω² = {g}, closed form {w}");
    }
}

#[test]
fn twist_and_torque_responses_follow_the_definition() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("out.csv");
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args([
            "simulate",
            MODEL,
            "--t-end",
            "0.5",
            "--dt-out",
            "0.05",
            "-o",
            csv.to_str().unwrap(),
            "--velocities",
            "--response",
            "spring.twist",
            "--response",
            "spring.torque",
            "--response",
            "coupling.twist_rate",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
    let mut rows = 0;
    for line in lines {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let (th, w) = (v[col("disc.theta")], v[col("disc.theta_dot")]);
        let wa = v[col("arm.theta_dot")];
        assert!((v[col("spring.twist")] - th).abs() < 1e-12);
        // torque = k (twist − free) + c twist_rate
        let want = 40.0 * (th - 0.1) + 0.3 * w;
        assert!(
            (v[col("spring.torque")] - want).abs() < 1e-9,
            "{} vs {want}",
            v[col("spring.torque")]
        );
        assert!((v[col("coupling.twist_rate")] - (wa - w)).abs() < 1e-12);
        rows += 1;
    }
    assert_eq!(rows, 11);
}

/// The planar `torque` (one value, counter-clockwise), which may read velocities: a
/// constant T0 on the disc turns its equilibrium by T0/k from the free angle; a torque
/// −c θ̇ on the disc with the spring's damping off gives the same damped modes as the
/// damping (two formulations of one damper, to 1e-12).
#[test]
fn a_planar_torque_turns_the_equilibrium_and_can_be_a_damper() {
    let base = std::fs::read_to_string(MODEL).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, extra: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, format!("{base}{extra}")).unwrap();
        p.to_str().unwrap().to_string()
    };
    let constant = write(
        "constant.toml",
        "\n[[forces]]\nname = \"motor\"\ntype = \"torque\"\nbody = \"disc\"\ntorque = \"2 N*m\"\n",
    );
    let eq = json(&["equilibrium", &constant, "--json"]);
    let th = eq["coordinates"]["disc.theta"].as_f64().unwrap();
    assert!((th - (0.1 + 2.0 / 40.0)).abs() < 1e-12, "disc.theta = {th}");
    let damper = write(
        "damper.toml",
        "\n[[forces]]\nname = \"brake\"\ntype = \"torque\"\nbody = \"disc\"\ntorque = \"-0.3*disc.theta_dot\"\n",
    );
    let a = json(&["modes", MODEL, "--json"]);
    let b = json(&["modes", &damper, "--set", "c=0", "--json"]);
    for k in 0..2 {
        for part in ["re", "im"] {
            let x = a["modes"][k]["eigenvalue"][part].as_f64().unwrap();
            let y = b["modes"][k]["eigenvalue"][part].as_f64().unwrap();
            assert!(
                (x - y).abs() < 1e-12 * (1.0 + x.abs()),
                "mode {k} {part}: {x} vs {y}"
            );
        }
    }
}

/// A compound pendulum with a torsional spring–damper and a torque at its pivot
/// (`tests/data/torsion_pendulum.toml`): about the hanging pose, ω_n² = (k + m g l)/I_O
/// and ζ = c / (2 √((k + m g l) I_O)), with l = L/2 and I_O = m L²/3; a constant torque
/// T turns it to the angle φ (from hanging) with k φ + m g l sin φ = T.
#[test]
fn a_torsion_pendulum_has_the_closed_form_frequency_damping_and_static_angle() {
    const P: &str = "tests/data/torsion_pendulum.toml";
    let (m, len, g, k, c): (f64, f64, f64, f64, f64) = (1.5, 0.8, 9.81, 12.0, 0.4);
    let (l, io) = (len / 2.0, m * len * len / 3.0);
    let modes = json(&["modes", P, "--json"]);
    let w2 = modes["undamped_omega2"][0].as_f64().unwrap();
    let want = (k + m * g * l) / io;
    assert!(
        (w2 - want).abs() < 1e-10 * want,
        "ω² = {w2}, closed form {want}"
    );
    let zeta = modes["modes"][0]["damping_ratio"].as_f64().unwrap();
    let want_z = c / (2.0 * ((k + m * g * l) * io).sqrt());
    assert!(
        (zeta - want_z).abs() < 1e-10,
        "ζ = {zeta}, closed form {want_z}"
    );
    let t = 3.0;
    let eq = json(&["equilibrium", P, "--set", "T=3", "--json"]);
    let phi = eq["coordinates"]["bar.theta"].as_f64().unwrap() + std::f64::consts::FRAC_PI_2;
    // k φ + m g l sin φ = T by Newton
    let mut x = 0.1;
    for _ in 0..50 {
        x -= (k * x + m * g * l * x.sin() - t) / (k + m * g * l * x.cos());
    }
    assert!(
        (phi - x).abs() < 1e-10,
        "static angle {phi}, closed form {x}"
    );
}

/// Given initial velocities the joints do not allow stop a simulation (with a hint), but
/// not the statics: equilibria do not depend on them.
#[test]
fn statics_do_not_refuse_a_model_for_its_initial_velocities() {
    let text = std::fs::read_to_string(MODEL).unwrap().replacen(
        "mass = 2",
        "mass = 2\nvelocity = { x = 1 }",
        1,
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("v.toml");
    std::fs::write(&path, text).unwrap();
    let p = path.to_str().unwrap();
    let eq = json(&["equilibrium", p, "--json"]);
    assert!((eq["coordinates"]["disc.theta"].as_f64().unwrap() - 0.1).abs() < 1e-12);
    json(&["modes", p, "--json"]);
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args([
            "simulate",
            p,
            "-o",
            dir.path().join("o.csv").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("initial velocities are inconsistent"), "{err}");
}
