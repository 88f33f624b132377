//! Modes and the linear frequency response of the overcentre mechanism against the shared
//! references, a closed form, the reduced Lagrange model, and free oscillations from
//! `simulate` (which does not use the linearization code).

mod common;

use common::{overcentre as model, reference};

use common::reduced::Overcentre;
use detune::linear::{frequency_response, modal_analysis};
use detune::statics::Statics;
use detune::{SimOptions, System, assemble, simulate};

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn undamped_and_damped_modes_of_both_wells() {
    let r = reference();
    let eqs = r["baseline (gravity, L0 = 2)"]["equilibria"]
        .as_array()
        .unwrap();
    for (start, want) in [("-0.85", &eqs[0]), ("0.785", &eqs[2])] {
        for (c, key) in [("1", "eig_c1"), ("5", "eig_c5")] {
            let m = model(&[("theta1_0", start), ("c", c)]);
            let a = modal_analysis(&System::new(&m).unwrap(), None).unwrap();
            assert!(a.equilibrium.stable);
            let w = want["omega_rad_s"].as_f64().unwrap();
            assert_eq!(a.undamped_omega2.len(), 1);
            assert!(
                rel(a.undamped_omega2[0].sqrt(), w) <= 1e-8,
                "ω {} vs {w}",
                a.undamped_omega2[0].sqrt()
            );
            let eig = &want[key][0];
            let (re, im) = (eig[0].as_f64().unwrap(), eig[1].as_f64().unwrap());
            assert_eq!(a.modes.len(), 1);
            let mode = &a.modes[0];
            assert!(
                rel(mode.eigenvalue.re, re) <= 1e-8,
                "Re {} vs {re}",
                mode.eigenvalue.re
            );
            assert!(
                rel(mode.eigenvalue.im, im) <= 1e-8,
                "Im {} vs {im}",
                mode.eigenvalue.im
            );
            assert!(rel(mode.omega_n_rad_s, re.hypot(im)) <= 1e-8);
            assert!(rel(mode.damping_ratio, -re / re.hypot(im)) <= 1e-8);
            // shape: normalized to bar1.theta; equal bars give θ2 = π − θ1, so bar2.theta = −1
            let shape = &mode.shape;
            assert!((shape[2].re - 1.0).abs() < 1e-12 && shape[2].im.abs() < 1e-12);
            assert!((shape[5].re + 1.0).abs() < 1e-9 && shape[5].im.abs() < 1e-9);
        }
    }
}

#[test]
fn gravity_free_variant_gives_the_papers_4_083() {
    let m = model(&[
        ("g", "0"),
        ("L0", "2*sqrt(2)/sqrt(3)"),
        ("theta1_0", "-0.9"),
        ("c", "1"),
    ]);
    let a = modal_analysis(&System::new(&m).unwrap(), None).unwrap();
    let w = (50.0f64 / 3.0).sqrt();
    assert!(
        rel(a.undamped_omega2[0].sqrt(), w) <= 1e-8,
        "{}",
        a.undamped_omega2[0].sqrt()
    );
    assert!((w - 4.0824829046).abs() < 1e-10);
    assert!(rel(a.modes[0].eigenvalue.im, 4.0790794168401385) <= 1e-8);
}

#[test]
fn unstable_equilibrium_has_real_eigenvalues() {
    let r = reference();
    let want = &r["baseline (gravity, L0 = 2)"]["equilibria"][1];
    let m = model(&[("c", "1")]);
    let sys = System::new(&m).unwrap();
    let s = assemble(&sys).unwrap();
    let st = Statics::new(&sys, &s.q).unwrap();
    let all = st.all(&s).unwrap();
    let mid = &all[1];
    assert!(!mid.stable);
    assert!(rel(mid.omega2[0], want["omega2"].as_f64().unwrap()) <= 1e-8);
    let lin = detune::linear::Linearization::new(&st, mid);
    let modes = lin.modes(2).unwrap();
    assert_eq!(modes.len(), 2);
    let mut re: Vec<f64> = modes.iter().map(|m| m.eigenvalue.re).collect();
    re.sort_by(f64::total_cmp);
    let (a, b) = (
        want["eig_c1"][0][0].as_f64().unwrap(),
        want["eig_c1"][1][0].as_f64().unwrap(),
    );
    assert!(
        rel(re[0], a.min(b)) <= 1e-8 && rel(re[1], a.max(b)) <= 1e-8,
        "{re:?}"
    );
    assert!(
        modes
            .iter()
            .all(|m| m.eigenvalue.im == 0.0 && m.omega_d_rad_s == 0.0)
    );
}

/// Free oscillation about the lower well from `simulate` (c = 0, offset 0.005 rad):
/// its frequency from zero crossings agrees with the linear ω_n.
#[test]
fn free_oscillation_frequency_agrees_with_omega_n() {
    let eq = -0.865739159594518;
    let offset = 0.005;
    let m = model(&[("c", "0"), ("theta1_0", &format!("{:?}", eq + offset))]);
    let sys = System::new(&m).unwrap();
    let s = assemble(&sys).unwrap();
    let traj = simulate(
        &sys,
        &s,
        &SimOptions {
            t_end: 20.0,
            dt_out: 0.001,
            ..SimOptions::default()
        },
        &mut |_| true,
    )
    .unwrap();
    let th = traj.coordinate("bar1.theta").unwrap();
    let mut crossings = Vec::new();
    for k in 1..th.len() {
        let (a, b) = (th[k - 1] - eq, th[k] - eq);
        if a < 0.0 && b >= 0.0 {
            // cubic-accurate enough: linear interpolation on a 1 ms grid
            crossings.push(traj.t[k - 1] + (traj.t[k] - traj.t[k - 1]) * a / (a - b));
        }
    }
    let periods = crossings.len() - 1;
    let period = (crossings[periods] - crossings[0]) / periods as f64;
    let omega = 2.0 * std::f64::consts::PI / period;
    let a = modal_analysis(
        &System::new(&model(&[("c", "0"), ("theta1_0", "-0.85")])).unwrap(),
        None,
    )
    .unwrap();
    let wn = a.undamped_omega2[0].sqrt();
    assert!(rel(omega, wn) <= 1e-4, "simulated {omega} vs linear {wn}");
}

/// The linear frequency response against the 1-DoF reduced model's closed form
/// X = F / (k − M ω² + i c ω), with k, c from the oracle's generalized force.
#[test]
fn linear_frequency_response_matches_the_reduced_model() {
    let m = model(&[("theta1_0", "-0.85"), ("c", "1"), ("F0", "0.01")]);
    let omegas: Vec<f64> = (0..=75).map(|k| 0.5 + 0.1 * k as f64).collect();
    let fr = frequency_response(
        &System::new(&m).unwrap(),
        "omega",
        &omegas,
        &["bar1.theta".to_string()],
    )
    .unwrap();
    let th = fr.equilibrium.q[2];
    let o = Overcentre {
        c: 1.0,
        f0: 0.01,
        ..Overcentre::baseline()
    };
    let h = 1e-6;
    let k = -(o.generalized_force(th + h, 0.0, 0.0) - o.generalized_force(th - h, 0.0, 0.0))
        / (2.0 * h);
    let c = -(o.generalized_force(th, h, 0.0) - o.generalized_force(th, -h, 0.0)) / (2.0 * h);
    let mass = o.mass(th);
    let f = 0.01 * o.kinematics(th).force_point.d1[1];
    let mut peak = (0.0, 0.0);
    for (w, v) in omegas.iter().zip(&fr.values) {
        let (amp, phase) = v[0];
        let re = k - mass * w * w;
        let im = c * w;
        let want = f / re.hypot(im);
        let want_phase = (-im).atan2(re).to_degrees();
        assert!(rel(amp, want) <= 1e-6, "ω {w}: {amp} vs {want}");
        assert!(
            (phase - want_phase).abs() <= 1e-5,
            "ω {w}: {phase}° vs {want_phase}°"
        );
        if amp > peak.1 {
            peak = (*w, amp);
        }
    }
    // the peak of a force-driven oscillator sits at ω_n √(1 − 2ζ²) = 4.28003 rad/s
    assert!((peak.0 - 4.3).abs() < 0.051);
}

#[test]
fn zero_forcing_is_an_error() {
    let m = model(&[("theta1_0", "-0.85")]);
    let e = frequency_response(
        &System::new(&m).unwrap(),
        "omega",
        &[1.0, 2.0],
        &["bar1.theta".to_string()],
    )
    .unwrap_err();
    assert!(e.to_string().contains("zero forcing"), "{e}");
    let e = frequency_response(
        &System::new(&m).unwrap(),
        "k",
        &[1.0],
        &["bar1.theta".to_string()],
    )
    .unwrap_err();
    assert!(e.to_string().contains("omega"), "{e}");
    let e = frequency_response(
        &System::new(&model(&[("F0", "1")])).unwrap(),
        "omega",
        &[1.0],
        &["bar1.phi".to_string()],
    )
    .unwrap_err();
    assert!(e.to_string().contains("bar1.phi"), "{e}");
}

#[test]
fn undamped_resonance_is_refused_not_infinite() {
    // c = 0: at ω = ω_n the dynamic stiffness K − ω²M is singular. The response there is
    // unbounded, so the solver must say so instead of returning inf/NaN or a huge number.
    let m = model(&[("theta1_0", "-0.85"), ("c", "0"), ("F0", "0.1")]);
    let ma = modal_analysis(&System::new(&m).unwrap(), None).unwrap();
    let wn = ma.modes[0].omega_n_rad_s;
    let e = frequency_response(
        &System::new(&m).unwrap(),
        "omega",
        &[wn],
        &["bar1.theta".to_string()],
    )
    .unwrap_err();
    assert!(e.to_string().contains("singular"), "{e}");
    // 1 % away the amplitude is finite and matches the single-DoF closed form F/(k(1 − r²)).
    let fr = frequency_response(
        &System::new(&m).unwrap(),
        "omega",
        &[0.99 * wn, 1.01 * wn],
        &["bar1.theta".to_string()],
    )
    .unwrap();
    let (below, above) = (fr.values[0][0], fr.values[1][0]);
    assert!(below.0.is_finite() && above.0.is_finite());
    // Symmetric detuning of an undamped oscillator: |1 − 0.99²| vs |1 − 1.01²|.
    let expected = (1.0f64 - 1.01 * 1.01).abs() / (1.0f64 - 0.99 * 0.99).abs();
    assert!(
        rel(below.0 / above.0, expected) < 1e-6,
        "{below:?} {above:?}"
    );
    // In phase below resonance, in antiphase above.
    assert!(
        below.1.abs() < 1e-6 && (above.1.abs() - 180.0).abs() < 1e-6,
        "{below:?} {above:?}"
    );
}

#[test]
fn frf_linearizes_about_the_mean_load_of_the_forcing_period() {
    // F0·cos(ωt): its mean over a period is 0, but at the model's own ω = 0 it would be a
    // constant F0. The linear response must be about the equilibrium under Fs alone.
    let text = common::overcentre_text().replace("Fs + F0*sin(omega*t)", "Fs + F0*cos(omega*t)");
    let cos = detune::Model::from_str("cos.toml", &text)
        .unwrap()
        .with_overrides(&[
            ("theta1_0".into(), "-0.85".into()),
            ("F0".into(), "3".into()),
        ])
        .unwrap();
    let fr = frequency_response(
        &System::new(&cos).unwrap(),
        "omega",
        &[1.0, 2.0],
        &["bar1.theta".to_string()],
    )
    .unwrap();
    let lower = reference()["baseline (gravity, L0 = 2)"]["equilibria"][0]["theta_rad"]
        .as_f64()
        .unwrap();
    assert!(
        rel(fr.equilibrium.q[2], lower) < 1e-9,
        "{} vs {lower}",
        fr.equilibrium.q[2]
    );
    // Same amplitude as the sine forcing (a phase shift of 90° is all that differs).
    let sin = model(&[("theta1_0", "-0.85"), ("F0", "3")]);
    let fs = frequency_response(
        &System::new(&sin).unwrap(),
        "omega",
        &[1.0, 2.0],
        &["bar1.theta".to_string()],
    )
    .unwrap();
    for k in 0..2 {
        assert!(rel(fr.values[k][0].0, fs.values[k][0].0) < 1e-9);
        let shift = (fr.values[k][0].1 - fs.values[k][0].1).rem_euclid(360.0);
        assert!((shift - 90.0).abs() < 1e-6, "phase shift {shift}");
    }
    // Frequencies must be positive.
    let e = frequency_response(
        &System::new(&sin).unwrap(),
        "omega",
        &[-1.0],
        &["bar1.theta".to_string()],
    )
    .unwrap_err();
    assert!(e.to_string().contains("positive"), "{e}");
}

#[test]
fn frequency_grid_is_written_as_decimals_and_may_be_one_point() {
    let g = detune::linear::grid(0.5, 8.0, 0.1).unwrap();
    assert_eq!(g.len(), 76);
    assert_eq!(g[7], 1.2); // 0.5 + 7·0.1 = 1.2000000000000002 unrounded
    assert_eq!(*g.last().unwrap(), 8.0);
    assert_eq!(detune::linear::grid(3.0, 3.0, 0.1).unwrap(), vec![3.0]);
    // the rounding never moves a requested value noticeably, whatever the step
    assert_eq!(detune::linear::grid(4.3, 4.3, 1e10).unwrap(), vec![4.3]);
    assert_eq!(
        detune::linear::grid(0.0123456789, 2.0, 1.0).unwrap(),
        vec![0.0123456789, 1.0123456789]
    );
    assert!(detune::linear::grid(3.0, 2.0, 0.1).is_err());
}
