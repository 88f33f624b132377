//! The nonlinear force elements (docs/model-format.md, "Nonlinear elements"), on one-body
//! models: a mass on a slider (x, m) and a disc turning about the plane's normal
//! (theta, rad).
//!
//! * the general `spring` as the Duffing oscillator of issue 12 (1 kg on a slider, the
//!   spring anchored 1 m away with free length 1 m, so its elongation is x and its force
//!   −(ω0² x + β x³)): the equilibrium, the linear ω_n = ω0 by `detune modes`, the force
//!   against its closed form and its work against the quadrature of the closed form, and
//!   the energy ½ẋ² + ω0² x²/2 + β x⁴/4 conserved by `simulate` to 1e-9;
//! * `breakout`, `torsion_backlash`, `backlash`, `end_stop` and `torsion_end_stop`
//!   against −∇ of their potential (central differences), and against the sharp law away
//!   from its corners;
//! * `torsion_friction` against its closed form level·tanh(ω/v0), and its power ≤ 0;
//! * nonsense parameters refused where they are written.

use detune::{Model, SimOptions, System, assemble, simulate};

const SLIDER: &str = r#"
[parameters]
k = { value = 4, unit = "N/m", description = "w0^2 with the 1 kg mass" }
k3 = { value = 0.5, description = "beta (N/m^3)" }

[[bodies]]
name = "mass"
mass = 1
inertia = 0.1
x = 0.3

[[joints]]
name = "slider"
type = "prismatic"
body1 = "mass"
body2 = "ground"
axis = [1, 0]
"#;

const DISC: &str = r#"
[[bodies]]
name = "disc"
mass = 1
inertia = 0.5

[[joints]]
name = "pin"
type = "revolute"
body1 = "disc"
body2 = "ground"
"#;

fn system(base: &str, force: &str) -> System {
    let text = format!("{base}\n[[forces]]\nname = \"e\"\n{force}\n");
    let model = Model::from_str("test", &text).unwrap_or_else(|e| panic!("{e:?}\n{text}"));
    System::new(&model).unwrap_or_else(|e| panic!("{e:?}\n{text}"))
}

fn error_of(base: &str, force: &str) -> String {
    let text = format!("{base}\n[[forces]]\nname = \"e\"\n{force}\n");
    match Model::from_str("test", &text).and_then(|m| System::new(&m)) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => format!("{e:?}"),
    }
}

const DUFFING: &str = r#"type = "spring"
body1 = "mass"
body2 = "ground"
point2 = [-1, 0]
free_length = 1
law = "-(k*x + k3*x^3)"
"#;

/// The generalized force on coordinate `i` at q, v.
fn force(sys: &System, q: &[f64], v: &[f64], i: usize) -> f64 {
    let mut f = vec![0.0; sys.n()];
    sys.forces(q, v, 0.0, &mut f);
    f[i]
}

/// −dV/dq_i by a central difference (h = 1e-6).
fn minus_dv(sys: &System, q: &[f64], i: usize) -> f64 {
    let h = 1e-6;
    let (mut a, mut b) = (q.to_vec(), q.to_vec());
    a[i] += h;
    b[i] -= h;
    -(sys.potential_energy(&a, 0.0) - sys.potential_energy(&b, 0.0)) / (2.0 * h)
}

#[test]
fn duffing_spring_force_and_its_work() {
    let sys = system(SLIDER, DUFFING);
    for x in [-0.7, -0.2, 0.0, 0.05, 0.4, 0.9] {
        for xd in [-1.0, 0.0, 2.0] {
            let f = force(&sys, &[x, 0.0, 0.0], &[xd, 0.0, 0.0], 0);
            let want = -(4.0 * x + 0.5 * x * x * x);
            assert!(
                (f - want).abs() <= 1e-12 * (1.0 + want.abs()),
                "x {x}: {f} vs {want}"
            );
            // no force across the slider
            assert!(force(&sys, &[x, 0.0, 0.0], &[xd, 0.0, 0.0], 1).abs() < 1e-14);
        }
        // its work from 0 to x (Simpson, 200 panels) is −(2x² + x⁴/8)
        let n = 200;
        let h = x / n as f64;
        let mut w = 0.0;
        for j in 0..=n {
            let s = j as f64 * h;
            let c = if j == 0 || j == n {
                1.0
            } else if j % 2 == 1 {
                4.0
            } else {
                2.0
            };
            w += c * force(&sys, &[s, 0.0, 0.0], &[0.0; 3], 0);
        }
        w *= h / 3.0;
        let want = -(2.0 * x * x + x.powi(4) / 8.0);
        assert!((w - want).abs() < 1e-12, "x {x}: work {w} vs {want}");
    }
}

#[test]
fn duffing_equilibrium_and_linear_frequency() {
    let dir = std::env::temp_dir().join(format!("detune-duffing-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("duffing.toml");
    std::fs::write(
        &path,
        format!("{SLIDER}\n[[forces]]\nname = \"spring\"\n{DUFFING}"),
    )
    .unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_detune"))
        .args(["modes", path.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let x = j["equilibrium"]["mass.x"].as_f64().unwrap();
    assert!(x.abs() < 1e-12, "equilibrium x = {x}");
    let w2 = j["undamped_omega2"][0].as_f64().unwrap();
    assert!((w2 - 4.0).abs() < 1e-9 * 4.0, "ω_n² = {w2}, want ω0² = 4");
    let wn = j["modes"][0]["omega_n_rad_s"].as_f64().unwrap();
    assert!((wn - 2.0).abs() < 1e-9, "ω_n = {wn}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn duffing_conserves_its_energy_in_simulate() {
    let sys = system(SLIDER, DUFFING);
    let start = assemble(&sys).unwrap();
    let opts = SimOptions {
        t_end: 10.0,
        dt_out: 0.05,
        rtol: 1e-12,
        atol: 1e-14,
        ..SimOptions::default()
    };
    let traj = simulate(&sys, &start, &opts, &mut |_| true).unwrap();
    let energy = |k: usize| {
        let (x, xd) = (traj.q(k)[0], traj.v(k)[0]);
        0.5 * xd * xd + 2.0 * x * x + 0.5 * x.powi(4) / 4.0
    };
    let e0 = energy(0);
    assert!(
        (e0 - (2.0 * 0.09 + 0.0081 / 8.0)).abs() < 1e-12,
        "E0 = {e0}"
    );
    let worst = (0..traj.t.len())
        .map(|k| (energy(k) - e0).abs())
        .fold(0.0, f64::max);
    // it moves: through the equilibrium and back
    let xs: Vec<f64> = traj.qs().map(|q| q[0]).collect();
    assert!(xs.iter().cloned().fold(0.0, f64::min) < -0.29);
    assert!(worst <= 1e-9 * e0, "energy drift {worst:e} J of {e0} J");
}

/// The force of a disc's torsion element at twist θ against −dV/dθ and against `sharp`
/// where |θ − corner| > `away` for every corner.
fn check_torsion(kind: &str, sharp: impl Fn(f64) -> f64, corners: &[f64], away: f64, tol: f64) {
    let sys = system(DISC, kind);
    for j in 0..=80 {
        let th = -0.2 + 0.4 * j as f64 / 80.0;
        let q = [0.0, 0.0, th];
        let f = force(&sys, &q, &[0.0; 3], 2);
        let g = minus_dv(&sys, &q, 2);
        // central difference, h = 1e-6: truncation h²/6·|f''| ≲ 1e-6 at the end stop's
        // corner (curvature ~ k/w² = 1e10)
        assert!(
            (f - g).abs() <= 2e-6 * (1.0 + f.abs()),
            "{kind}\nθ {th}: {f} vs −dV/dθ {g}"
        );
        if corners.iter().all(|c| (th - c).abs() > away) {
            let s = sharp(th);
            assert!(
                (f - s).abs() <= tol * (1.0 + s.abs()),
                "{kind}\nθ {th}: {f} vs sharp {s}"
            );
        }
    }
}

#[test]
fn breakout_is_minus_the_gradient_of_its_potential_and_bilinear_away_from_the_knee() {
    // k1 = 403, T0 = 5.5, k2 = 250: tb = 0.013648 rad
    let (k1, t0, k2) = (403.0, 5.5, 250.0);
    let tb = t0 / k1;
    let sharp = move |th: f64| {
        let tau = if th.abs() <= tb {
            k1 * th
        } else {
            k2 * th + (k1 - k2) * tb * th.signum()
        };
        -tau
    };
    check_torsion(
        "type = \"breakout\"\nbody1 = \"disc\"\nstiffness = 403\npreload = 5.5\nstiffness2 = 250",
        sharp,
        &[-tb, tb],
        3.0 * tb * 0.02 * 5.0,
        // the smoothed clip differs from the clip by ε²/(8 d²)·… ≲ 1e-3 of the load
        // 0.3·tb beyond a corner
        2e-3,
    );
}

#[test]
fn backlash_and_end_stops_are_minus_the_gradient_of_their_potential() {
    let b = 0.05;
    check_torsion(
        "type = \"torsion_backlash\"\nbody1 = \"disc\"\nstiffness = 100\ngap = 0.05",
        move |th: f64| -100.0 * (th - th.clamp(-b, b)),
        &[-b, b],
        0.3 * b,
        2e-3,
    );
    check_torsion(
        "type = \"torsion_end_stop\"\nbody1 = \"disc\"\nstiffness = 1e4\nlower = -0.1\nupper = 0.15\nsmoothing = 1e-3",
        |th: f64| -1e4 * ((th - 0.15).max(0.0) - (-0.1 - th).max(0.0)),
        &[-0.1, 0.15],
        0.02,
        // ramp − max(p, 0) = w²/(4|p|)·(1 + O(w²/p²)): 1.25e-5 rad·1e4 = 0.125 N·m at 0.02
        0.15,
    );
    // the axial forms, on the slider: the stretch is the elongation (backlash) or the
    // distance (end stop) from an anchor 1 m away
    let sys = system(
        SLIDER,
        "type = \"backlash\"\nbody1 = \"mass\"\npoint2 = [-1, 0]\nfree_length = 1\nstiffness = 50\ngap = 0.1",
    );
    let stop = system(
        SLIDER,
        "type = \"end_stop\"\nbody1 = \"mass\"\npoint2 = [-1, 0]\nstiffness = 1e3\nupper = 1.3\nsmoothing = 1e-3",
    );
    for j in 0..=40 {
        let x = -0.5 + j as f64 / 40.0;
        let q = [x, 0.0, 0.0];
        for s in [&sys, &stop] {
            let (f, g) = (force(s, &q, &[0.0; 3], 0), minus_dv(s, &q, 0));
            assert!((f - g).abs() <= 1e-7 * (1.0 + f.abs()), "x {x}: {f} vs {g}");
        }
        if (x.abs() - 0.1).abs() > 0.03 {
            let want = -50.0 * (x - x.clamp(-0.1, 0.1));
            let f = force(&sys, &q, &[0.0; 3], 0);
            assert!(
                (f - want).abs() < 2e-3 * (1.0 + want.abs()),
                "x {x}: {f} vs {want}"
            );
        }
        if (x - 0.3).abs() > 0.02 {
            let want = -1e3 * (x - 0.3).max(0.0);
            let f = force(&stop, &q, &[0.0; 3], 0);
            assert!((f - want).abs() < 0.02, "x {x}: {f} vs {want}");
        }
    }
}

#[test]
fn damping_of_backlash_acts_in_contact_only() {
    let sys = system(
        DISC,
        "type = \"torsion_backlash\"\nbody1 = \"disc\"\nstiffness = 100\ndamping = 2\ngap = 0.05",
    );
    // inside the gap: no spring, and of the dashpot only the smoothing's leftover
    // c·ω·(1 − sclip'(0)) = c·ω·(1 − 1/√(1 + ε²)) ≈ c·ω·ε²/2
    let inside = force(&sys, &[0.0, 0.0, 0.0], &[0.0, 0.0, 3.0], 2);
    let leftover = -2.0 * 3.0 * (1.0 - 1.0 / (1.0f64 + 0.02 * 0.02).sqrt());
    assert!((inside - leftover).abs() < 1e-12, "{inside} vs {leftover}");
    // in contact: −k(θ − b) − c ω
    let f = force(&sys, &[0.0, 0.0, 0.2], &[0.0, 0.0, 3.0], 2);
    let want = -100.0 * 0.15 - 2.0 * 3.0;
    assert!((f - want).abs() < 1e-2, "{f} vs {want}");
}

#[test]
fn friction_is_its_closed_form_and_dissipates() {
    let sys = system(
        DISC,
        "type = \"torsion_friction\"\nbody1 = \"disc\"\nlevel = 0.8\nslip_rate = 0.01",
    );
    for w in [-2.0, -0.013, -0.001, 0.0, 0.004, 0.02, 1.5] {
        let f = force(&sys, &[0.0, 0.0, 0.3], &[0.0, 0.0, w], 2);
        let want = -0.8 * (w / 0.01f64).tanh();
        assert!((f - want).abs() < 1e-14, "ω {w}: {f} vs {want}");
        assert!(f * w <= 0.0, "power {}", f * w);
        if w.abs() > 0.05 {
            // the sharp Coulomb law beyond 5 v0, to 2e-4 of the level
            assert!((f + 0.8 * w.signum()).abs() < 0.8 * 2e-4);
        }
    }
    assert_eq!(sys.potential_energy(&[0.0, 0.0, 0.3], 0.0), 0.0);
}

#[test]
fn nonsense_parameters_are_refused_where_they_are_written() {
    let e = error_of(
        DISC,
        "type = \"breakout\"\nbody1 = \"disc\"\nstiffness = 403\npreload = -5.5\nstiffness2 = 250",
    );
    assert!(e.contains("the preload of `e` must be positive"), "{e}");
    let e = error_of(
        DISC,
        "type = \"breakout\"\nbody1 = \"disc\"\nstiffness = 403\npreload = 5.5\nstiffness2 = 250\nsmoothing = 0",
    );
    assert!(e.contains("the smoothing of `e` must be positive"), "{e}");
    let e = error_of(
        DISC,
        "type = \"torsion_backlash\"\nbody1 = \"disc\"\nstiffness = 1\ngap = 0",
    );
    assert!(e.contains("the gap of `e` must be positive"), "{e}");
    let e = error_of(
        DISC,
        "type = \"torsion_end_stop\"\nbody1 = \"disc\"\nstiffness = 1",
    );
    assert!(e.contains("has no limit"), "{e}");
    // dimensions: a torque where a force is meant, a law in the wrong unit
    let e = error_of(
        DISC,
        "type = \"breakout\"\nbody1 = \"disc\"\nstiffness = 403\npreload = \"5 N\"\nstiffness2 = 250",
    );
    assert!(e.contains("is a quantity in"), "{e}");
    let e = error_of(
        SLIDER,
        "type = \"spring\"\nbody1 = \"mass\"\nfree_length = 1\nlaw = \"-k\"",
    );
    assert!(e.contains("the law of `e` is a quantity in"), "{e}");
    let e = error_of(
        SLIDER,
        "type = \"spring\"\nbody1 = \"mass\"\nfree_length = 1\nlaw = \"-k*mass.x\"",
    );
    assert!(e.contains("mass.x"), "{e}");
    let e = error_of(
        DISC,
        "type = \"breakout\"\nbody1 = \"disc\"\nstiffness = 403\nstiffness2 = 250",
    );
    assert!(e.contains("needs `preload`"), "{e}");
}
