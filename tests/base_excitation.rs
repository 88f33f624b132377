//! Base excitation through a moving ground, against closed forms: a compound pendulum
//! whose pivot is shaken horizontally, x_g = D0 sin ωt, with a horizontal dashpot from a
//! point l_d below the pivot to an anchor moving with the ground (tests/data/
//! shaken_pendulum.toml). Linearized:
//!
//! ```text
//! I_O θ'' + c l_d² θ' + m g l θ = m l ω² D0 sin ωt,   I_O = I_G + m l²
//! Θ/D0 = m l ω² / (m g l − I_O ω² + i c l_d² ω)
//! ```

mod common;

use detune::frequency::{SteadyOptions, SweepMode, SweepOptions, sweep};
use detune::linear::{frequency_response, modal_analysis};
use detune::statics::Statics;
use detune::{Model, SimOptions, System, assemble, simulate};
use nalgebra::Complex;
use std::sync::atomic::AtomicBool;

const M: f64 = 2.0;
const L: f64 = 0.5;
const IG: f64 = 0.1;
const LD: f64 = 0.8;
const C: f64 = 0.4;
const G: f64 = 9.81;

fn io() -> f64 {
    IG + M * L * L
}

fn omega_n() -> f64 {
    (M * G * L / io()).sqrt()
}

/// Θ / D0 at ω (θ = Im[Θ e^{iωt}]).
fn closed_form(w: f64) -> Complex<f64> {
    Complex::new(M * L * w * w, 0.0) / Complex::new(M * G * L - io() * w * w, C * LD * LD * w)
}

fn text() -> String {
    std::fs::read_to_string(common::data("shaken_pendulum.toml")).unwrap()
}

fn model(text: &str, sets: &[(&str, &str)]) -> Model {
    common::from_text("shaken_pendulum.toml", text, sets)
}

fn pendulum(sets: &[(&str, &str)]) -> System {
    System::new(&model(&text(), sets)).unwrap()
}

#[test]
fn frf_of_the_shaken_pendulum_is_the_closed_form() {
    let sys = pendulum(&[]);
    let d0 = 1e-3;
    let wn = omega_n();
    let values: Vec<f64> = (0..=56).map(|k| wn * (0.2 + 0.05 * k as f64)).collect();
    let fr = frequency_response(&sys, "omega", &values, &["bob.theta".into()]).unwrap();
    let mut worst = 0.0f64;
    for (w, v) in values.iter().zip(&fr.values) {
        let (amp, phase) = v[0];
        let got = Complex::from_polar(amp, phase.to_radians());
        let want = closed_form(*w) * d0;
        worst = worst.max((got - want).norm() / want.norm());
    }
    assert!(worst <= 1e-9, "worst relative error {worst:e}");
}

#[test]
fn frf_is_linear_in_the_base_amplitude_and_zero_without_it() {
    let w = 3.0;
    let a = frequency_response(
        &pendulum(&[("D0", "2 mm")]),
        "omega",
        &[w],
        &["bob.theta".into()],
    )
    .unwrap();
    let want = (closed_form(w) * 2e-3).norm();
    assert!((a.values[0][0].0 - want).abs() <= 1e-9 * want);
    // no base motion and no other forcing: refused as zero forcing, not a curve of zeros
    let e = frequency_response(
        &pendulum(&[("D0", "0")]),
        "omega",
        &[w],
        &["bob.theta".into()],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("zero forcing"), "{e}");
}

#[test]
fn equilibrium_and_modes_are_those_of_the_fixed_pendulum() {
    for sets in [vec![], vec![("D0", "0")]] {
        let sys = pendulum(&sets);
        let s = assemble(&sys).unwrap();
        let eq = Statics::new(&sys, &s.q).unwrap().solve(&s.q).unwrap();
        // pivot at the ground origin (the shaking's mean), hanging straight down
        assert!(eq.q[0].abs() <= 1e-12 && (eq.q[1] + L).abs() <= 1e-12 && eq.q[2].abs() <= 1e-12);
        assert!(eq.stable);
        let a = modal_analysis(&sys, None).unwrap();
        assert_eq!(a.modes.len(), 1);
        // I_O s² + c l_d² s + m g l = 0
        let (b, k) = (C * LD * LD, M * G * L);
        let re = -b / (2.0 * io());
        let im = (k / io() - re * re).sqrt();
        let mode = &a.modes[0];
        assert!((mode.omega_n_rad_s - omega_n()).abs() <= 1e-12 * omega_n());
        assert!((mode.eigenvalue.re - re).abs() <= 1e-12 * omega_n());
        assert!((mode.eigenvalue.im - im).abs() <= 1e-12 * omega_n());
    }
}

#[test]
fn the_start_is_at_rest_relative_to_the_moving_ground() {
    // x_g = D0 sin ωt moves at D0·ω at t = 0: the bob moves with it, without swinging
    let sys = pendulum(&[("D0", "0.01"), ("omega", "3")]);
    let s = assemble(&sys).unwrap();
    assert!((s.v[0] - 0.03).abs() <= 1e-14, "{:?}", s.v);
    assert!(s.v[1].abs() <= 1e-14 && s.v[2].abs() <= 1e-14, "{:?}", s.v);
}

#[test]
fn stepped_sine_at_small_amplitude_agrees_with_frf() {
    let sys = pendulum(&[("D0", "0.1 mm")]);
    let wn = omega_n();
    let values: Vec<f64> = (0..=14)
        .map(|k| detune::linear::round_to_step(wn * (0.2 + 0.2 * k as f64), 1e-3))
        .collect();
    let opts = SweepOptions {
        param: "omega".into(),
        values: values.clone(),
        mode: SweepMode::Independent,
        responses: vec!["bob.theta".into()],
        refine: None,
        steady: SteadyOptions::default(),
    };
    let s = sweep(&sys, &opts, &|_| {}, &AtomicBool::new(false)).unwrap();
    let lin = frequency_response(&sys, "omega", &values, &["bob.theta".into()]).unwrap();
    for (p, l) in s.points.iter().zip(&lin.values) {
        assert!(p.steady.settled, "ω = {} did not settle", p.steady.omega);
        let (got, want) = (p.steady.measures[0].amplitude, l[0].0);
        assert!(
            (got - want).abs() <= 0.005 * want,
            "ω = {}: sweep {got:e} vs frf {want:e}",
            p.steady.omega
        );
    }
}

#[test]
fn a_moving_ground_equals_the_same_motion_written_as_a_custom_constraint() {
    // The same pendulum with its pivot written as two time-dependent custom constraints
    // on a fixed ground; no dashpot (its anchor would not move there). θ' is given so both
    // start from the same state.
    let base = text().replace("c = { value = 0.4,", "c = { value = 0,") + "";
    let moving = base.replace(
        "x = 0\ny = \"-l\"\ntheta = 0",
        "x = 0\ny = \"-l\"\ntheta = 0\nvelocity = { theta = 0.3 }",
    );
    let start = moving.find("[[joints]]").unwrap();
    let end = moving.find("[[forces]]").unwrap();
    let custom = format!(
        "{}{}{}",
        &moving[..start],
        "[[constraints]]\nname = \"px\"\nexpr = \"bob.x - l*sin(bob.theta) - D0*sin(omega*t)\"\n\n\
         [[constraints]]\nname = \"py\"\nexpr = \"bob.y + l*cos(bob.theta)\"\n\n",
        &moving[end..]
    )
    .replace("[ground]\nmotion = { x = \"D0*sin(omega*t)\" }\n", "");
    assert!(!custom.contains("[ground]") && custom.contains("velocity"));
    let sets = [("D0", "0.05"), ("omega", "3")];
    let run = |text: &str| {
        let sys = System::new(&model(text, &sets)).unwrap();
        let s = assemble(&sys).unwrap();
        let opts = SimOptions {
            t_end: 5.0,
            ..SimOptions::default()
        };
        simulate(&sys, &s, &opts, &mut |_| true).unwrap()
    };
    let a = run(&moving);
    let b = run(&custom);
    let (ta, tb) = (
        a.coordinate("bob.theta").unwrap(),
        b.coordinate("bob.theta").unwrap(),
    );
    assert_eq!(ta.len(), tb.len());
    let worst = ta
        .iter()
        .zip(&tb)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    let swing = ta.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(swing > 0.05, "the pendulum swings ({swing})");
    assert!(worst <= 1e-10, "θ(t) differs by {worst:e} rad");
}

#[test]
fn check_reports_the_ground_motion() {
    let m = model(&text(), &[]);
    let sys = System::new(&m).unwrap();
    let report = detune::check::CheckReport::new(&m, &sys).to_string();
    assert!(
        report.contains("ground motion: x = D0*sin(omega*t)"),
        "{report}"
    );
    // and says nothing of one where the ground is fixed
    let fixed = common::overcentre(&[]);
    let report = detune::check::CheckReport::new(&fixed, &System::new(&fixed).unwrap()).to_string();
    assert!(!report.contains("ground motion"), "{report}");
}

#[test]
fn a_ground_motion_undefined_during_the_period_is_a_clean_error() {
    // sqrt(1 - t) is NaN for t > 1 s, inside the 2.09 s period statics averages over:
    // a clear failure, not a panic in an SVD of NaN
    let text = text().replace("D0*sin(omega*t)", "D0*sqrt(1-t)");
    let sys = System::new(&model(&text, &[])).unwrap();
    let s = assemble(&sys).unwrap();
    let e = Statics::new(&sys, &s.q)
        .and_then(|st| st.solve(&s.q))
        .unwrap_err();
    assert!(
        matches!(
            e.failure(),
            Some(detune::failure::Failure::UndefinedEquilibrium { .. })
        ),
        "{e}"
    );
    let e = modal_analysis(&sys, None).unwrap_err().to_string();
    assert!(e.contains("undefined (NaN)"), "{e}");
}

#[test]
fn each_frequency_of_a_sweep_starts_at_rest_relative_to_its_own_shaking() {
    // Regression: every frequency started with the ground velocity D0·ω of the first
    // one, so an undamped sweep's answer at ω depended on the grid.
    let sys = pendulum(&[("c", "0")]);
    let run = |values: Vec<f64>| {
        let opts = SweepOptions {
            param: "omega".into(),
            values,
            mode: SweepMode::Independent,
            responses: vec!["bob.theta".into()],
            refine: None,
            steady: SteadyOptions::default(),
        };
        let s = sweep(&sys, &opts, &|_| {}, &AtomicBool::new(false)).unwrap();
        s.points.last().unwrap().steady.measures[0].amplitude
    };
    let alone = run(vec![6.0]);
    let after = run(vec![3.0, 6.0]);
    assert_eq!(alone, after);
    // and a down sweep with a large base motion, whose Poincaré extrapolation can leave
    // the constraints, settles instead of failing
    let sys = pendulum(&[("D0", "0.05"), ("c", "0.1")]);
    let opts = SweepOptions {
        param: "omega".into(),
        values: vec![4.0, 4.2, 4.4],
        mode: SweepMode::Down,
        responses: vec!["bob.theta".into()],
        refine: None,
        steady: SteadyOptions::default(),
    };
    let s = sweep(&sys, &opts, &|_| {}, &AtomicBool::new(false)).unwrap();
    assert!(s.points.iter().all(|p| p.steady.settled));
}

#[test]
fn a_ground_motion_undefined_at_the_start_is_named_where_it_is_written() {
    // it used to surface as "the constraint `pivot.x` is undefined", far from its cause
    let text = text().replace("D0*sin(omega*t)", "D0/0*sin(omega*t)");
    let m = Model::from_str("shaken.toml", &text).unwrap();
    let e = System::new(&m).unwrap_err().to_string();
    assert!(
        e.contains("shaken.toml:22:16: the ground's x motion evaluates to NaN at t = 0"),
        "{e}"
    );
}

#[test]
fn a_forcing_frequency_defined_from_another_parameter_is_refused() {
    // omega = 2*pi*f with the motion written in f: setting omega for a frequency response
    // would leave the motion at f's frequency (a silently wrong curve)
    let text = text()
        .replace(
            "omega = { value = 3, unit = \"rad/s\" }",
            "f = { value = 0.5 }\nomega = { value = \"2*pi*f\", unit = \"rad/s\" }",
        )
        .replace("D0*sin(omega*t)", "D0*sin(2*pi*f*t)");
    let sys = System::new(&model(&text, &[])).unwrap();
    let e = frequency_response(&sys, "omega", &[1.0], &["bob.theta".into()])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("is defined from other parameters (2*pi*f)"),
        "{e}"
    );
    // given a value of its own, omega is accepted
    let sys = System::new(&model(&text, &[("omega", "3")])).unwrap();
    frequency_response(&sys, "omega", &[1.0], &["bob.theta".into()]).unwrap();
}
