//! Stepped-sine sweeps of the overcentre mechanism (lower well, c = 1): the linear limit,
//! the paper's Figures 8–9 as properties, determinism across threads, hysteresis.

use detune::Model;
use detune::System;
use detune::frequency::{Direction, SteadyOptions, Sweep, SweepMode, SweepOptions, sweep};
use detune::linear::{frequency_response, modal_analysis};
use std::sync::atomic::AtomicBool;

mod common;

/// The overcentre in its lower well with c = 1, and `sets`.
fn model(sets: &[(&str, &str)]) -> Model {
    let mut all = vec![("theta1_0", "-0.85"), ("c", "1")];
    all.extend_from_slice(sets);
    common::overcentre(&all)
}

fn grid(from: f64, to: f64, step: f64) -> Vec<f64> {
    detune::linear::grid(from, to, step).unwrap()
}

fn run(m: &Model, values: Vec<f64>, mode: SweepMode, refine: Option<f64>) -> Sweep {
    let opts = SweepOptions {
        param: "omega".into(),
        values,
        mode,
        responses: vec!["bar1.theta".into()],
        refine,
        steady: SteadyOptions::default(),
    };
    sweep(
        &System::new(&m).unwrap(),
        &opts,
        &|_| {},
        &AtomicBool::new(false),
    )
    .unwrap()
}

fn amplitude(s: &Sweep, dir: Direction, omega: f64) -> f64 {
    s.points
        .iter()
        .find(|p| p.direction == dir && (p.steady.omega - omega).abs() < 1e-9 && !p.refined)
        .unwrap_or_else(|| panic!("no point at {omega}"))
        .steady
        .measures[0]
        .amplitude
}

#[test]
fn small_forcing_reproduces_the_linear_resonance() {
    let m = model(&[("F0", "0.01")]);
    let values = grid(0.5, 8.0, 0.25);
    let s = run(&m, values.clone(), SweepMode::Independent, Some(1e-4));
    assert!(
        s.complete
            && s.points
                .iter()
                .all(|p| p.steady.settled && p.steady.period_multiple == 1)
    );
    // the peak of a force-driven linear oscillator: ω_n √(1 − 2ζ²)
    let modal = modal_analysis(&System::new(&m).unwrap(), None).unwrap();
    let (wn, zeta) = (modal.modes[0].omega_n_rad_s, modal.modes[0].damping_ratio);
    let expected = wn * (1.0 - 2.0 * zeta * zeta).sqrt();
    assert!((expected - 4.28003).abs() < 1e-5);
    assert_eq!(s.peaks.len(), 1);
    let p = &s.peaks[0];
    assert!(p.uncertainty <= 1e-4);
    assert!(
        (p.omega - expected).abs() <= p.uncertainty + 1e-5,
        "peak {} vs {expected} ± {}",
        p.omega,
        p.uncertainty
    );
    // amplitudes within 1 % of the linear frequency response; first harmonic and phase too
    let lin = frequency_response(
        &System::new(&m).unwrap(),
        "omega",
        &values,
        &["bar1.theta".to_string()],
    )
    .unwrap();
    for (k, w) in values.iter().enumerate() {
        let (amp, phase) = lin.values[k][0];
        let pt = s.points.iter().find(|p| p.steady.omega == *w).unwrap();
        let me = &pt.steady.measures[0];
        assert!(
            (me.amplitude - amp).abs() <= 0.01 * amp,
            "ω {w}: {} vs linear {amp}",
            me.amplitude
        );
        assert!((me.h1 - amp).abs() <= 0.01 * amp);
        let dphi = (me.phase_deg - phase + 540.0) % 360.0 - 180.0;
        assert!(dphi.abs() < 1.0, "ω {w}: phase {} vs {phase}", me.phase_deg);
        assert!((me.mean - modal.equilibrium.q[2]).abs() < 0.01 * amp + 1e-9);
    }
}

#[test]
fn figures_8_and_9_softening_and_the_secondary_peak() {
    let forces = [0.1, 1.0, 2.0, 3.0, 4.0];
    let mut main_peaks = Vec::new();
    for f in forces {
        let m = model(&[("F0", &f.to_string())]);
        let s = run(&m, grid(1.5, 5.5, 0.1), SweepMode::Independent, Some(1e-3));
        assert!(s.points.iter().all(|p| p.steady.settled));
        let main = s
            .peaks
            .iter()
            .filter(|p| p.omega > 3.5)
            .max_by(|a, b| a.amplitude.total_cmp(&b.amplitude))
            .unwrap()
            .clone();
        // the secondary peak near half the natural frequency: a local maximum whose
        // second harmonic is large (2ω meets ω_n)
        if f >= 3.0 {
            let sec = s
                .peaks
                .iter()
                .find(|p| p.omega > 1.9 && p.omega < 2.4)
                .expect("secondary peak");
            let pt = s
                .points
                .iter()
                .min_by(|a, b| {
                    (a.steady.omega - sec.omega)
                        .abs()
                        .total_cmp(&(b.steady.omega - sec.omega).abs())
                })
                .unwrap();
            assert!(
                pt.steady.measures[0].h2 > 0.1 * pt.steady.measures[0].h1,
                "h2 at the secondary peak"
            );
            assert!((2.0 * sec.omega - 4.2859).abs() < 0.3);
        }
        main_peaks.push((f, main.omega, main.amplitude));
    }
    for w in main_peaks.windows(2) {
        let ((f0, w0, a0), (f1, w1, a1)) = (w[0], w[1]);
        assert!(
            w1 < w0,
            "softening: the peak moves down with the force ({f0}: {w0}, {f1}: {w1})"
        );
        assert!(
            a1 / f1 > a0 / f0,
            "non-proportional: peak/force grows ({f0}: {}, {f1}: {})",
            a0 / f0,
            a1 / f1
        );
    }
    // F0 = 0.1: already below the linear peak by ~7.5e-5 rad/s
    assert!(main_peaks[0].1 < 4.28003 && main_peaks[0].1 > 4.2797);
}

#[test]
fn independent_sweeps_are_identical_for_one_and_two_threads() {
    let m = model(&[("F0", "2")]);
    let pool = |n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
    };
    let a = pool(1).install(|| run(&m, grid(3.0, 5.0, 0.2), SweepMode::Independent, Some(1e-2)));
    let b = pool(2).install(|| run(&m, grid(3.0, 5.0, 0.2), SweepMode::Independent, Some(1e-2)));
    assert_eq!(a.points.len(), b.points.len());
    for (p, q) in a.points.iter().zip(&b.points) {
        assert_eq!(p.steady.omega.to_bits(), q.steady.omega.to_bits());
        assert_eq!(p.steady.periods, q.steady.periods);
        assert_eq!(p.steady.measures, q.steady.measures);
    }
    assert_eq!(a.peaks.len(), b.peaks.len());
    for (p, q) in a.peaks.iter().zip(&b.peaks) {
        assert_eq!(p.omega.to_bits(), q.omega.to_bits());
    }
}

#[test]
fn up_and_down_sweeps_show_the_hysteresis_at_4_n_only() {
    let m = model(&[("F0", "4")]);
    let s = run(&m, grid(3.0, 4.5, 0.1), SweepMode::Both, None);
    // sweeping up: small response until a jump between 4.0 and 4.1
    assert!(amplitude(&s, Direction::Up, 4.1) > 1.5 * amplitude(&s, Direction::Up, 4.0));
    assert!(amplitude(&s, Direction::Up, 3.9) < 0.25);
    // sweeping down: the large branch holds to about 3.3, then the response drops
    assert!(amplitude(&s, Direction::Down, 3.3) > 0.5);
    assert!(amplitude(&s, Direction::Down, 3.0) < 0.2);
    assert_eq!(s.hysteresis.len(), 1);
    let h = &s.hysteresis[0];
    assert!(
        (3.1..=3.4).contains(&h.from) && (h.to - 4.0).abs() < 0.05,
        "{h:?}"
    );
    // at 3 N up and down agree
    let m3 = model(&[("F0", "3")]);
    let s3 = run(&m3, grid(3.0, 4.5, 0.1), SweepMode::Both, None);
    assert!(s3.hysteresis.is_empty(), "{:?}", s3.hysteresis);
}

#[test]
fn bad_sweep_requests_are_refused() {
    let m = model(&[("F0", "1")]);
    let opts = |param: &str, values: Vec<f64>| SweepOptions {
        param: param.into(),
        values,
        mode: SweepMode::Independent,
        responses: vec!["bar1.theta".into()],
        refine: None,
        steady: SteadyOptions::default(),
    };
    let no = AtomicBool::new(false);
    let e = sweep(
        &System::new(&m).unwrap(),
        &opts("k", vec![1.0]),
        &|_| {},
        &no,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("does not depend on `k`") && e.contains("help"),
        "{e}"
    );
    // the forcing frequency derived from it: not "does not depend on" (false), but what
    // a frequency response steps
    let e = sweep(
        &System::new(&model(&[("F0", "1"), ("omega", "sqrt(k/m1)/4")])).unwrap(),
        &opts("k", vec![1.0]),
        &|_| {},
        &no,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("`omega` is defined from `k` (omega = sqrt(k/m1)/4)") && e.contains("help"),
        "{e}"
    );
    let e = sweep(
        &System::new(&m).unwrap(),
        &opts("omegaa", vec![1.0]),
        &|_| {},
        &no,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("`omega`"), "{e}");
    let e = sweep(
        &System::new(&model(&[])).unwrap(),
        &opts("omega", vec![1.0]),
        &|_| {},
        &no,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("zero forcing"), "{e}");
    let mut o = opts("omega", vec![1.0]);
    o.responses = vec!["bar3.theta".into()];
    let e = sweep(&System::new(&m).unwrap(), &o, &|_| {}, &no)
        .unwrap_err()
        .to_string();
    assert!(e.contains("bar3.theta"), "{e}");
    let mut o = opts("omega", vec![3.0, 3.5, 4.0]);
    o.steady.max_periods = 0;
    let e = sweep(&System::new(&m).unwrap(), &o, &|_| {}, &no)
        .unwrap_err()
        .to_string();
    assert!(e.contains("the most periods per frequency is 0"), "{e}");
    let mut o = opts("omega", vec![3.0, 3.5, 4.0]);
    o.refine = Some(1.0);
    let e = sweep(&System::new(&m).unwrap(), &o, &|_| {}, &no)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not finer than a peak's bracket"), "{e}");
}

/// `sweep --json` of the inceptor at D0 = 1 mm over 25.5–27.5 rad/s (0.25 rad/s steps),
/// with `more` (its responses, its mode), checked to succeed.
fn inceptor_at_1mm(more: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "sweep",
        "models/inceptor.toml",
        "--set",
        "D0=1 mm",
        "--param",
        "omega",
        "--from",
        "25.5",
        "--to",
        "27.5",
        "--step",
        "0.25",
        "--json",
    ];
    args.extend_from_slice(more);
    let (code, out, err) = common::detune(&args);
    assert_eq!(code, 0, "{err}");
    serde_json::from_str(&out).unwrap()
}

/// Nor jumps: the inceptor's stick.z (round-off, 1e-16 m) "jumped" at seven edges of a
/// sweep up and down (its relative changes are noise: 7e-16 → 2e-16 m), and each
/// candidate edge cost a steady state stepped back. stick.y's resonance has no jump
/// either way.
#[test]
fn still_responses_have_no_jumps() {
    let j = inceptor_at_1mm(&[
        "--mode",
        "both",
        "--response",
        "stick.y",
        "--response",
        "stick.z",
    ]);
    assert_eq!(j["jumps"].as_array().unwrap().len(), 0, "{}", j["jumps"]);
    assert_eq!(j["peaks"].as_array().unwrap().len(), 2, "{}", j["peaks"]);
}

/// Responses that do not move (stick.z: round-off, 2e-16 m; gearbox.y: 0 m) or whose
/// amplitude does not change (gearbox.x, carried by the table: D0 at every frequency)
/// have no peaks: before, the inceptor's stepped sine at 1 mm over 25.5–27.5 rad/s
/// reported stick.z's round-off at 26.5 and 27 rad/s and gearbox.x's at 27 rad/s as
/// peaks beside stick.y's resonance (and `--refine` refined them, each with settled
/// simulations).
#[test]
fn still_responses_have_no_peaks() {
    let j = inceptor_at_1mm(&[
        "--response",
        "stick.y",
        "--response",
        "stick.z",
        "--response",
        "gearbox.x",
        "--response",
        "gearbox.y",
    ]);
    let peaks = j["peaks"].as_array().unwrap();
    assert_eq!(peaks.len(), 1, "{peaks:?}");
    assert_eq!(peaks[0]["response"], "stick.y");
    assert_eq!(peaks[0]["omega"], 26.75);
    // and each of the others is said, with why
    let why: Vec<(String, String)> = j["no_peaks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| {
            (
                n["response"].as_str().unwrap().to_string(),
                n["kind"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    let said = |r: &str, k: &str| (r.to_string(), k.to_string());
    assert_eq!(
        why,
        [
            said("stick.z", "round_off"),
            said("gearbox.x", "unchanging"),
            said("gearbox.y", "round_off")
        ]
    );
    assert_eq!(j["units"]["noise"], "the response's unit");
    // a response that moves, however little beside another of its unit, keeps its peak:
    // block2 at 1e-7 of block's motion (a first version called it still beside block)
    let peaks_of = |args: &[&str]| -> Vec<(String, f64)> {
        let (code, out, err) = common::detune(args);
        assert_eq!(code, 0, "{err}");
        let j: serde_json::Value = serde_json::from_str(&out).unwrap();
        j["peaks"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| {
                (
                    p["response"].as_str().unwrap().to_string(),
                    p["omega"].as_f64().unwrap(),
                )
            })
            .collect()
    };
    // tests/data/weak_pair.toml over 19–21 rad/s, both blocks, with more arguments
    let weak_pair = |more: &[&'static str]| -> Vec<&'static str> {
        let mut args = vec![
            "sweep",
            "tests/data/weak_pair.toml",
            "--param",
            "omega",
            "--from",
            "19",
            "--to",
            "21",
            "--step",
            "0.25",
            "--response",
            "block2.x",
            "--response",
            "block.x",
        ];
        args.extend_from_slice(more);
        args
    };
    let weak = peaks_of(&weak_pair(&["--json"]));
    assert_eq!(
        weak,
        [
            ("block2.x".to_string(), 20.0),
            ("block.x".to_string(), 20.0)
        ]
    );
    // at F0 = 1 N block2 moves 8e-10 m at x = 3 m, its amplitude's changes within the
    // noise of the default tolerances (3.3e-10 m): no peak sought, and said so with the
    // numbers (before, nothing was said); at --rtol 1e-12 its peak is found, at block's
    let (code, out, err) = common::detune(&weak_pair(&["--set", "F0=1"]));
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("no peaks sought for block2.x (independent): its amplitude")
            && out.contains("tighten --rtol"),
        "{out}"
    );
    // where the absolute tolerance's term is the larger part of the noise, the advice
    // names --atol (tightening --rtol alone left the noise at 30 atol)
    let (code, out, err) = common::detune(&weak_pair(&["--set", "F0=1", "--atol", "1.5e-11"]));
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("tighten --atol to resolve it"), "{out}");
    let tight = peaks_of(&weak_pair(&["--set", "F0=1", "--rtol", "1e-12", "--json"]));
    assert_eq!(
        tight,
        [
            ("block2.x".to_string(), 20.0),
            ("block.x".to_string(), 20.0)
        ]
    );
    // and a narrow range about a broad resonance, whose amplitude changes by 3e-7 across
    // it, keeps its maximum (the amplitude's noise in a stepped sine is about 5e-11)
    let narrow = peaks_of(&[
        "sweep",
        "tests/data/sdof.toml",
        "--set",
        "F0=1",
        "--param",
        "omega",
        "--from",
        "19.886",
        "--to",
        "19.888",
        "--step",
        "0.001",
        "--response",
        "block.x",
        "--json",
    ]);
    assert_eq!(narrow, [("block.x".to_string(), 19.887)]);
}
