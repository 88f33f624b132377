//! Tuning: the smallest change that clears every forcing band, against a closed form on a
//! spring chain, and on the inceptor against the UH-60 (its design re-checked by
//! `margins`).

mod common;
use common::detune;

use detune::System;
use detune::environment::Environment;
use detune::linear::sensitivity::Vary;
use detune::tune::{TuneOptions, tune};

/// `tune --json` of the inceptor against the UH-60 over k_fs 50–200 % and gearbox_scale
/// 80–120 %, with `extra` arguments; it must succeed.
fn inceptor_tune(extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "tune",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--vary",
        "k_fs=50%..200%",
        "--vary",
        "gearbox_scale=80%..120%",
        "--json",
    ];
    args.extend_from_slice(extra);
    let (code, out, err) = detune(&args);
    assert_eq!(code, 0, "{err}");
    serde_json::from_str(&out).unwrap()
}

/// Spring chain (k1 = 1000, k2 = 400, k3 = 700 N/m; m1 = 2, m2 = 1.5 kg): mode 1 at
/// 22.03 rad/s is 4.2 % below a line at 23 rad/s. With k1 free in 50–150 %, the mode can
/// only go down (k1 → 1500 N/m raises it to 24.2 rad/s, short of 23·1.1 = 25.3), so the
/// best design puts ω1 at 23·(1 − 0.1 − 1e-4) exactly: det(K − ω²M) = 0 gives
/// k1 = k2²/(k2 + k3 − m2 ω²) − k2 + m1 ω².
#[test]
fn spring_chain_tuning_matches_the_closed_form() {
    let (sys, env, vary) = spring_chain_k1();
    let t = tune(&sys, &[vary], &env.forcing_lines(), &TuneOptions::default()).unwrap();
    assert!(!t.baseline_passes);
    let d = &t.designs[0];
    let k1 = chain_k1(23.0 * (1.0 - 0.1 - 1e-4), 400.0);
    let got = d.parameters["k1"].as_f64().unwrap();
    assert!((got - k1).abs() < 1e-6 * k1, "k1 = {got}, closed form {k1}");
    assert!((d.cost - (k1 / 1000.0 - 1.0).powi(2)).abs() < 1e-6);
    assert!(d.margins.iter().all(|r| r.pass));
    assert_eq!(t.designs.len(), 1, "the other side is out of reach");
    assert!(
        t.infeasible
            .iter()
            .any(|i| i.reason.contains("mode 1") && i.reason.contains("probe")),
        "{:?}",
        t.infeasible
    );
}

#[test]
fn inceptor_tuned_design_passes_margins() {
    let (code, _, err) = detune(&["margins", "models/inceptor.toml", "--environment", "UH-60"]);
    assert_eq!(code, 3, "the baseline fails: {err}");
    let j = inceptor_tune(&[]);
    let designs = j["designs"].as_array().unwrap();
    assert!(!designs.is_empty());
    let costs: Vec<f64> = designs
        .iter()
        .map(|d| d["cost"].as_f64().unwrap())
        .collect();
    assert!(
        costs.windows(2).all(|w| w[0] <= w[1]),
        "best first: {costs:?}"
    );
    for d in designs {
        let p = d["parameters"].as_object().unwrap();
        let k = p["k_fs"].as_f64().unwrap();
        let g = p["gearbox_scale"].as_f64().unwrap();
        assert!((0.5 * 1.295e5..=2.0 * 1.295e5).contains(&k) && (0.8..=1.2).contains(&g));
        let (sk, sg) = (format!("k_fs={k}"), format!("gearbox_scale={g}"));
        let (code, out, err) = detune(&[
            "margins",
            "models/inceptor.toml",
            "--environment",
            "UH-60",
            "--set",
            &sk,
            "--set",
            &sg,
        ]);
        assert_eq!(code, 0, "design {p:?} must pass margins: {out}{err}");
        // it is at the margin, not far beyond it (the smallest change)
        assert!(d["closest_pct"].as_f64().unwrap() < 10.1);
        // its linear response has both resonance peaks, each near its mode (5 %)
        let peaks = d["frf_peaks_rad_s"].as_array().unwrap();
        assert_eq!(peaks.len(), 2, "{d}");
        for (p, (_, w)) in peaks.iter().zip(d["modes"].as_object().unwrap()) {
            let (p, w) = (p.as_f64().unwrap(), w.as_f64().unwrap());
            assert!((p - w).abs() < 0.05 * w, "peak {p} vs mode {w}");
        }
    }
}

#[test]
fn infeasible_tuning_names_the_mode_and_the_line() {
    let (code, out, err) = detune(&[
        "tune",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--vary",
        "k_fs=95%..105%",
    ]);
    assert_eq!(code, 3, "{out}{err}");
    assert!(
        out.contains("shaft-twist") && out.contains("1P"),
        "{out}{err}"
    );
    let (code, _, err) = detune(&["tune", "models/inceptor.toml", "--environment", "UH-60"]);
    assert_eq!(code, 1);
    assert!(err.contains("free parameter"), "{err}");
}

/// `--verify sweep`: each design's stepped-sine peaks of the nonlinear model at a small
/// table motion (0.7 mm) equal its linear response peaks to 0.1 %; without a forcing
/// amplitude the sweep is refused with the advice to set one.
#[test]
fn verify_sweep_peaks_equal_the_linear_peaks_at_small_forcing() {
    let (code, out, err) = detune(&[
        "tune",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--set",
        "D0=0.7 mm",
        "--vary",
        "k_fs=50%..200%",
        "--vary",
        "gearbox_scale=80%..120%",
        "--designs",
        "1",
        "--verify",
        "sweep",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    let d = &j["designs"][0];
    let lin = d["frf_peaks_rad_s"].as_array().unwrap();
    let sw = d["sweep_peaks_rad_s"].as_array().unwrap();
    assert_eq!(lin.len(), sw.len());
    for (a, b) in lin.iter().zip(sw) {
        let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
        assert!((a - b).abs() < 1e-3 * a, "linear {a} vs sweep {b}");
    }
    assert_eq!(d["sweep_peaks_clear"], d["frf_peaks_clear"]);
    let (code, _, err) = detune(&[
        "tune",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--vary",
        "k_fs=50%..200%",
        "--verify",
        "sweep",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("--set \"D0=VALUE m\""), "{err}");
}

fn spring_chain_k1() -> (System, Environment, Vary) {
    let model = detune::Model::load(&common::data("spring_chain.toml")).unwrap();
    let sys = System::new(&model).unwrap();
    let env = Environment::load(&common::data("probe_line.toml")).unwrap();
    let i = sys.param_index("k1").unwrap();
    let vary = Vary {
        param: i,
        name: "k1".into(),
        cases: vec![("k1=50%".into(), 500.0), ("k1=150%".into(), 1500.0)],
        range: (500.0, 1500.0),
    };
    (sys, env, vary)
}

/// k1 that puts mode 1 of the spring chain at ω (det(K − ω²M) = 0), for a given k2.
fn chain_k1(omega: f64, k2: f64) -> f64 {
    let w2 = omega * omega;
    k2 * k2 / (k2 + 700.0 - 1.5 * w2) - k2 + 2.0 * w2
}

/// COBYLA alone (the derivative-free fallback) meets the closed form as SLSQP does, and on
/// the inceptor finds both of SLSQP's designs.
#[test]
fn cobyla_alone_finds_the_closed_form_and_slsqps_designs() {
    use detune::tune::Optimizer;
    let (sys, env, vary) = spring_chain_k1();
    let opts = TuneOptions {
        optimizer: Optimizer::Cobyla,
        ..TuneOptions::default()
    };
    let t = tune(&sys, &[vary], &env.forcing_lines(), &opts).unwrap();
    let d = &t.designs[0];
    assert_eq!(d.optimizer, "COBYLA");
    let k1 = chain_k1(23.0 * (1.0 - 0.1 - 1e-4), 400.0);
    let got = d.parameters["k1"].as_f64().unwrap();
    assert!((got - k1).abs() < 1e-6 * k1, "k1 = {got}, closed form {k1}");

    let (s, c) = (
        inceptor_tune(&["--optimizer", "slsqp"]),
        inceptor_tune(&["--optimizer", "cobyla"]),
    );
    let (s, c) = (
        s["designs"].as_array().unwrap(),
        c["designs"].as_array().unwrap(),
    );
    assert_eq!(s.len(), 2);
    assert_eq!(c.len(), 2);
    for (a, b) in s.iter().zip(c) {
        assert_eq!(a["optimizer"], "SLSQP");
        assert_eq!(b["optimizer"], "COBYLA");
        for p in ["k_fs", "gearbox_scale"] {
            let (x, y) = (
                a["parameters"][p].as_f64().unwrap(),
                b["parameters"][p].as_f64().unwrap(),
            );
            assert!((x - y).abs() < 1e-6 * x.abs(), "{p}: {x} vs {y}");
        }
    }
    // each design leaves gearbox_scale at a bound of its range, and says so
    assert_eq!(s[0]["at_bounds"][0]["param"], "gearbox_scale");
    assert_eq!(s[0]["at_bounds"][0]["bound"], "upper");
    assert_eq!(s[1]["at_bounds"][0]["bound"], "lower");
}

/// With tolerances (k1 ±2 %, k2 ±5 %), the design must clear the band over the whole box:
/// mode 1 rises with both stiffnesses, so its highest value is at k1·1.02, k2·1.05, and the
/// best design puts that corner at the band's edge: 1.02·k1 = k1*(ω_edge, 1.05·k2).
#[test]
fn toleranced_spring_chain_design_clears_the_band_over_the_box() {
    use detune::tune::Tolerance;
    let (sys, env, vary) = spring_chain_k1();
    let tol = |name: &str, frac: f64| {
        let i = sys.param_index(name).unwrap();
        let p = sys.param(i);
        Tolerance {
            vary: Vary {
                param: i,
                name: name.into(),
                cases: vec![
                    (format!("{name}-"), p * (1.0 - frac)),
                    (format!("{name}+"), p * (1.0 + frac)),
                ],
                range: (p * (1.0 - frac), p * (1.0 + frac)),
            },
            relative: true,
        }
    };
    let opts = TuneOptions {
        tolerances: vec![tol("k1", 0.02), tol("k2", 0.05)],
        ..TuneOptions::default()
    };
    let t = tune(&sys, &[vary], &env.forcing_lines(), &opts).unwrap();
    let d = &t.designs[0];
    let edge = 23.0 * (1.0 - 0.1 - 1e-4);
    let best = chain_k1(edge, 420.0) / 1.02;
    let got = d.parameters["k1"].as_f64().unwrap();
    // the best design, to 1e-6 (the solves with the spread found about each design
    // converge on it)
    assert!((got - best).abs() < 1e-6 * best, "k1 = {got}, best {best}");
    // the interval is the box's (mode 1 at the corners), and clears the band
    let iv = d.tolerance_intervals.as_ref().unwrap();
    let (lo, hi) = (
        iv["mode 1"][0].as_f64().unwrap(),
        iv["mode 1"][1].as_f64().unwrap(),
    );
    let omega1 = |k1: f64, k2: f64| {
        // the lower root of det(K − ω²M) = 0 for the chain (m1 = 2, m2 = 1.5, k3 = 700)
        let (a, b, c) = (
            2.0 * 1.5,
            -(2.0 * (k2 + 700.0) + 1.5 * (k1 + k2)),
            (k1 + k2) * (k2 + 700.0) - k2 * k2,
        );
        ((-b - (b * b - 4.0 * a * c).sqrt()) / (2.0 * a)).sqrt()
    };
    assert!((hi - omega1(got * 1.02, 420.0)).abs() < 1e-9 * hi);
    assert!((lo - omega1(got * 0.98, 380.0)).abs() < 1e-9 * lo);
    // clear of the margin by at least half the 1e-4 clearance
    assert!(hi <= 23.0 * 0.9 * (1.0 - 0.5e-4), "{hi}");
    assert!(d.margins.iter().all(|r| r.pass));
    assert!(
        d.margins
            .iter()
            .filter(|r| r.mode == "mode 1")
            .all(|r| r.max_rad_s == hi && r.min_rad_s == lo)
    );
}

/// The toleranced tuning of docs/sensitivity-and-tuning.md.
const TOLERANCED: [&str; 12] = [
    "tune",
    "models/inceptor.toml",
    "--environment",
    "UH-60",
    "--vary",
    "k_fs=60%..150%",
    "--vary",
    "gearbox_scale=55%..145%",
    "--tolerance",
    "k_fs=±10%",
    "--tolerance",
    "gearbox_scale=±5%",
];

/// `tune --tolerance` prints a design that `margins --vary` with the same tolerances
/// passes (the check command it prints, run as printed), where the nominal design fails
/// over the same box. The default optimizer's run writes its JSON with `-o` beside the
/// text (one run for both: the toleranced tuning is this file's dearest computation).
#[test]
fn inceptor_toleranced_design_passes_margins_over_the_box() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("design.json");
    let mut args = TOLERANCED.to_vec();
    args.extend(["-o", json.to_str().unwrap()]);
    let (code, out, err) = detune(&args);
    assert_eq!(code, 0, "{err}");
    let check = out
        .lines()
        .find_map(|l| l.trim().strip_prefix("check: detune "))
        .unwrap_or_else(|| panic!("no check command in {out}"));
    assert!(
        check.contains("--vary k_fs=±10% --vary gearbox_scale=±5%"),
        "{check}"
    );
    let args: Vec<&str> = check.split_whitespace().collect();
    let (code, out, err) = detune(&args);
    assert_eq!(code, 0, "{check}: {out}{err}");
    // the nominal design (no tolerances) fails over the same box
    let nominal = [
        "margins",
        "models/inceptor.toml",
        "--environment",
        "UH-60",
        "--set",
        "k_fs=80433.40268528654",
        "--set",
        "gearbox_scale=1.2",
        "--vary",
        "k_fs=±10%",
        "--vary",
        "gearbox_scale=±5%",
    ];
    assert_eq!(detune(&nominal).0, 3);
    // the default optimizer reaches the same minimum as COBYLA alone (SLSQP's gradients
    // leave out the tolerance spread's own change; COBYLA polishes its point)
    let auto = serde_json::from_str::<serde_json::Value>(&std::fs::read_to_string(&json).unwrap())
        .unwrap()["designs"]
        .clone();
    let cobyla = {
        let mut args = TOLERANCED.to_vec();
        args.extend(["--optimizer", "cobyla", "--json"]);
        let (code, out, err) = detune(&args);
        assert_eq!(code, 0, "{err}");
        serde_json::from_str::<serde_json::Value>(&out).unwrap()["designs"].clone()
    };
    assert_eq!(auto.as_array().unwrap().len(), 2);
    for (a, c) in auto
        .as_array()
        .unwrap()
        .iter()
        .zip(cobyla.as_array().unwrap())
    {
        let (x, y) = (a["cost"].as_f64().unwrap(), c["cost"].as_f64().unwrap());
        assert!((x - y).abs() < 1e-6 * y, "cost {x} (auto) vs {y} (COBYLA)");
    }
}

/// A `--vary` range past a fold: the overcentre's upper well ends at k = 37.01 N/m (the
/// fold `continue` locates from k = 50 down), so at k = 50 % = 25 N/m there is no
/// equilibrium near the baseline's. The advice is to narrow that --vary (another initial
/// pose, the statics' generic advice, is no remedy).
#[test]
fn a_vary_range_past_a_fold_is_advised_to_narrow() {
    let (code, out, _) = detune(&[
        "continue",
        "models/overcentre.toml",
        "--param",
        "k",
        "--from",
        "50",
        "--to",
        "25",
        "--step",
        "1",
    ]);
    assert_eq!(code, 0, "{out}");
    assert!(out.contains("fold at k = 37.01492"), "{out}");
    let (code, _, err) = detune(&[
        "tune",
        "models/overcentre.toml",
        "--environment",
        "tests/data/uh60_profile.toml",
        "--vary",
        "k=50%..200%",
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("the case k=50%: no equilibrium found"),
        "{err}"
    );
    assert!(
        err.contains("narrow the range of --vary k") && !err.contains("start closer"),
        "{err}"
    );
}

/// A tolerance box that reaches an unstable design fails the tuning, as `margins --vary`
/// fails it: the overcentre's mode (2.97 rad/s) clears every UH-60 line by 89 %, but
/// c = 5 N·s/m ± 150 % reaches c = −2.5, where the mode grows. The design is refused
/// (exit 3) with the point and its growth rate, which equals Re λ of `modes` run at that
/// point on its own; the nominal design's own check with the same box fails too.
#[test]
fn a_tolerance_box_reaching_an_unstable_design_fails_the_tuning() {
    let base = [
        "models/overcentre.toml",
        "--environment",
        "tests/data/uh60_profile.toml",
    ];
    let mut args = vec!["tune"];
    args.extend(base);
    args.extend(["--vary", "k=80%..120%", "--tolerance", "c=±150%", "--json"]);
    let (code, out, err) = detune(&args);
    assert_eq!(code, 3, "{out}{err}");
    let t: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(t["designs"].as_array().unwrap().is_empty(), "{out}");
    assert_eq!(t["baseline_passes"], false);
    let blocked = &t["infeasible"][0]["blocked"];
    assert_eq!(blocked["kind"], "unstable_over_tolerances", "{out}");
    assert_eq!(blocked["point"], "c=-2.5");
    let (code, out, err) = detune(&[
        "modes",
        "models/overcentre.toml",
        "--set",
        "c=-2.5",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let m: serde_json::Value = serde_json::from_str(&out).unwrap();
    let growth = m["modes"][0]["growth_rate_1_s"].as_f64().unwrap();
    let got = blocked["growth_rate_1_s"].as_f64().unwrap();
    assert!(
        growth > 0.3 && (got - growth).abs() < 1e-9 * growth,
        "{got} vs {growth}"
    );
    // the text names the remedy: the tolerance, not the ranges
    args.pop();
    let (code, out, _) = detune(&args);
    assert_eq!(code, 3);
    assert!(out.contains("narrow the --tolerance"), "{out}");
    let mut margins = vec!["margins"];
    margins.extend(base);
    margins.extend(["--vary", "c=±150%"]);
    assert_eq!(detune(&margins).0, 3);
    // a stiffness tolerance of ±150 % spreads the mode (first order) below 0 rad/s: the
    // box is too wide to tune over, said so (it read "stays at -1.8947 rad/s …, below
    // 0.0000 rad/s: it cannot be raised above  by the margin")
    let mut args = vec!["tune"];
    args.extend(base);
    args.extend(["--vary", "c=80%..120%", "--tolerance", "k=±150%"]);
    let (code, out, err) = detune(&args);
    assert_eq!(code, 3, "{out}{err}");
    assert!(out.contains("(ω_n ≤ 0)"), "{out}");
    assert!(
        out.contains("the tolerance box is too wide to tune over"),
        "{out}"
    );
    assert!(
        !out.contains("stays at") && !out.contains("above  by"),
        "{out}"
    );
    // ±90 %: the box's case k = 5 N/m has no equilibrium near the design's; the remedy
    // is the tolerance too (it said "widen the ranges … or lower the margin")
    let last = args.len() - 1;
    args[last] = "k=±90%";
    let (code, out, err) = detune(&args);
    assert_eq!(code, 3, "{out}{err}");
    assert!(
        out.contains("the tolerance box is too wide to tune over"),
        "{out}"
    );
    assert!(!out.contains("widen the ranges"), "{out}");
}
