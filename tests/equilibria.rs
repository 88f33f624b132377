//! `equilibrium --all` lists every equilibrium once: poses equal modulo 2π in their angles
//! are one. A slider-crank (tests/data/slider_crank.toml: crank r pinned at the origin, rod
//! l whose far end slides on y = 0, gravity −y) revolves, so the sweep of its crank angle
//! reaches each equilibrium twice; its potential is (m1 + m2) g (r/2) sin θ whatever l,
//! so the equilibria are θ = −π/2 (stable) and +π/2 (unstable), and nothing else.

use std::process::Command;

#[test]
fn a_revolving_crank_has_each_equilibrium_once() {
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args([
            "equilibrium",
            "tests/data/slider_crank.toml",
            "--all",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let list = v["equilibria"].as_array().unwrap();
    assert_eq!(list.len(), 2, "{list:#?}");
    let half_pi = std::f64::consts::FRAC_PI_2;
    for (e, (want, stable)) in list.iter().zip([(-half_pi, true), (half_pi, false)]) {
        let th = e["coordinates"]["crank.theta"].as_f64().unwrap();
        assert!((th - want).abs() < 1e-10, "crank.theta = {th}, want {want}");
        assert_eq!(e["stable"].as_bool(), Some(stable));
    }
}

/// An unstable equilibrium's divergent mode is shown as a growth rate and time constant,
/// not as a frequency with ζ = −1: undamped, its rate is √(−ω²) of the stiffness's negative
/// eigenvalue.
#[test]
fn a_divergent_mode_is_shown_as_a_growth_rate() {
    let args = [
        "modes",
        "models/overcentre.toml",
        "--set",
        "theta1_0=0.26",
        "--set",
        "c=0",
    ];
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args(args)
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let out = Command::new(env!("CARGO_BIN_EXE_detune"))
        .args(args)
        .arg("--json")
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let w2 = v["undamped_omega2"][0].as_f64().unwrap();
    assert!(w2 < 0.0);
    let rate = (-w2).sqrt();
    let line = text
        .lines()
        .find(|l| l.contains("DIVERGENT"))
        .unwrap_or_else(|| panic!("no divergent mode in:\n{text}"));
    let number_after = |key: &str| -> f64 {
        let rest = &line[line.find(key).unwrap_or_else(|| panic!("{key} in {line}")) + key.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    assert!(
        (number_after("rate ") - rate).abs() < 1e-7,
        "{line} (rate {rate})"
    );
    assert!(
        (number_after("time constant ") - 1.0 / rate).abs() < 1e-5,
        "{line}"
    );
}
