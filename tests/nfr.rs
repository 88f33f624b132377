//! Nonlinear frequency response by continuation of periodic orbits.

mod common;

use common::detune;
use detune::periodic::continuation::{NfrOptions, nfr};
use std::sync::atomic::AtomicBool;

fn model(sets: &[(&str, f64)]) -> detune::System {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/overcentre.toml");
    let model = detune::Model::load(path).unwrap();
    let sets: Vec<(String, String)> = sets
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let model = model.with_overrides(&sets).unwrap();
    detune::System::new(&model).unwrap()
}

/// The overcentre about its lower well, c = 1, F0 = 4 N, from 3 to 4.5 rad/s (the
/// issue's curve is 1.5..5: `docs/nonlinear-frequency-response.md` has its command).
fn overcentre_curve() -> detune::periodic::continuation::Nfr {
    let sys = model(&[("theta1_0", -0.85), ("c", 1.0), ("F0", 4.0)]);
    let opts = NfrOptions::new("omega", 3.0, 4.5, vec!["bar1.theta".into()]);
    nfr(&sys, &opts, &|_, _| {}, &AtomicBool::new(false)).unwrap()
}

/// Amplitude of the stable points of `branch` at ω: cubic (Lagrange) interpolation in ω
/// over the four neighbours on a stable run of the branch that brackets ω.
fn stable_amplitude(c: &detune::periodic::continuation::Nfr, branch: usize, w: f64) -> Vec<f64> {
    let pts: Vec<_> = c.points.iter().filter(|p| p.branch == branch).collect();
    let mut out = Vec::new();
    for i in 1..pts.len().saturating_sub(2) {
        let run = &pts[i - 1..i + 3];
        if !run.iter().all(|p| p.stable) || (pts[i].omega - w) * (pts[i + 1].omega - w) > 0.0 {
            continue;
        }
        let mut a = 0.0;
        for (j, pj) in run.iter().enumerate() {
            let mut l = 1.0;
            for (k, pk) in run.iter().enumerate() {
                if k != j {
                    l *= (w - pk.omega) / (pj.omega - pk.omega);
                }
            }
            a += l * pj.measures[0].amplitude;
        }
        out.push(a);
    }
    out
}

/// The real multiplier nearest −1 of the periodic orbit at forcing frequency `omega`,
/// by Newton from `x` at fixed ω (central-difference variational columns, rtol 1e-13).
fn pd_multiplier(sys: &detune::System, x: &[f64], omega: f64) -> f64 {
    use detune::periodic::{Shooting, ShootingOptions, multipliers};
    let w = sys.param_names().iter().position(|n| n == "omega").unwrap();
    let opts = ShootingOptions {
        rtol: 1e-13,
        atol: 1e-15,
        central: true,
        ..ShootingOptions::default()
    };
    let mut sh = Shooting::new(sys, w, &[], opts).unwrap();
    sh.set(omega).unwrap();
    let cancel = AtomicBool::new(false);
    let mut x = x.to_vec();
    for _ in 0..6 {
        sh.project(&mut x);
        let tb = sh.tangent_basis(&x);
        let flow = sh.flow(&x, &tb, false, &cancel).unwrap();
        let m = tb.transpose() * &flow.jac;
        let r = tb.transpose() * nalgebra::DVector::from_fn(x.len(), |i, _| flow.end[i] - x[i]);
        let size = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if r.amax() < 1e-12 * size {
            return multipliers(&m)
                .iter()
                .filter(|mu| mu.im.abs() <= 1e-9)
                .map(|mu| mu.re)
                .min_by(|a, b| (a + 1.0).abs().total_cmp(&(b + 1.0).abs()))
                .unwrap();
        }
        let d = m.nrows();
        let step = (m - nalgebra::DMatrix::<f64>::identity(d, d))
            .lu()
            .solve(&(-r))
            .unwrap();
        let dx = &tb * step;
        for (xi, s) in x.iter_mut().zip(dx.iter()) {
            *xi += s;
        }
    }
    panic!("no periodic orbit at ω = {omega}");
}

/// The proof: the up jump of `sweep --mode both` is a fold of the small branch
/// at 4.024 rad/s, the down jump a period doubling of the large branch at 3.203 rad/s
/// (no fold there), and the stable parts agree with the stepped sine within 0.1 %.
#[test]
fn overcentre_fold_and_period_doubling() {
    let c = overcentre_curve();
    assert!(c.complete, "{:?}", c.branches);
    assert_eq!(c.dof, 1);
    assert!(c.points.iter().all(|p| p.multipliers.len() == 2));
    // the cost (docs/performance.md): 408 963 evaluations with the chords after a full
    // Newton period near the orbit and the period doubling's search stopped at its
    // bracket (464 445 with the search's earlier rule); 1.15 times that at most
    assert!(
        c.rhs_evaluations <= 470_000,
        "{} right-hand-side evaluations",
        c.rhs_evaluations
    );
    assert_eq!(c.folds.len(), 1, "folds {:?}", c.folds);
    let fold = &c.folds[0];
    assert!((fold.omega - 4.024).abs() < 1e-3, "fold at {}", fold.omega);
    // a multiplier is 1 at a fold
    assert!(
        (fold.multipliers[0].re - 1.0).abs() < 1e-6,
        "{:?}",
        fold.multipliers
    );
    assert!(fold.stable_before);
    assert_eq!(c.period_doublings.len(), 1, "{:?}", c.period_doublings);
    let pd = &c.period_doublings[0];
    assert!(
        (pd.omega - 3.203).abs() < 1e-3,
        "period doubling at {}",
        pd.omega
    );
    assert!(
        (pd.multipliers[0].re + 1.0).abs() < 1e-4,
        "{:?}",
        pd.multipliers
    );
    // Its stated uncertainty against an independent determination: orbits at fixed ω
    // either side of it (Newton in ω-fixed shooting, no arclength, no test-function
    // search), integrated 10 times tighter than the located points (rtol 1e-13), have
    // their multiplier nearest −1 on either side of −1.
    let at = c
        .points
        .iter()
        .find(|p| p.located == Some(detune::periodic::continuation::Located::PeriodDoubling))
        .expect("the located orbit");
    let sys = model(&[("theta1_0", -0.85), ("c", 1.0), ("F0", 4.0)]);
    let below = pd_multiplier(&sys, &at.x, pd.omega - pd.uncertainty);
    let above = pd_multiplier(&sys, &at.x, pd.omega + pd.uncertainty);
    assert!(
        pd.refined && pd.uncertainty <= 1e-7 * pd.omega,
        "± {}",
        pd.uncertainty
    );
    assert!(
        (below + 1.0) * (above + 1.0) < 0.0,
        "μ {below} at ω − {u}, {above} at ω + {u}",
        u = pd.uncertainty
    );
    // the large branch has no fold near the down jump
    assert!(c.folds.iter().all(|f| (f.omega - 3.203).abs() > 0.3));
    assert!(c.neimark_sacker.is_empty());
    // the words a user reads: which sweep jumps where
    use detune::output::nfr::jump_words;
    assert!(jump_words(&c, fold).contains("a sweep up in omega jumps"));
    assert!(jump_words(&c, pd).contains("a sweep down in omega jumps"));
    // the stepped sine, up and down, on the stable parts
    let sys = model(&[("theta1_0", -0.85), ("c", 1.0), ("F0", 4.0)]);
    let values: Vec<f64> = vec![3.1, 3.3, 3.5, 3.7, 3.9, 4.2, 4.4];
    let sw = detune::frequency::sweep(
        &sys,
        &detune::frequency::SweepOptions {
            param: "omega".into(),
            values,
            mode: detune::frequency::SweepMode::Both,
            responses: vec!["bar1.theta".into()],
            refine: None,
            steady: Default::default(),
        },
        &|_| {},
        &AtomicBool::new(false),
    )
    .unwrap();
    let mut compared = 0;
    for p in &sw.points {
        assert!(p.steady.settled);
        let a = p.steady.measures[0].amplitude;
        let on: Vec<f64> = [0, 1]
            .iter()
            .flat_map(|&b| stable_amplitude(&c, b, p.steady.omega))
            .collect();
        let best = on
            .iter()
            .map(|x| (x - a).abs() / a)
            .fold(f64::INFINITY, f64::min);
        assert!(
            best < 1e-3,
            "sweep {:?} at {}: amplitude {a}, the curve's stable amplitudes there {on:?}",
            p.direction,
            p.steady.omega
        );
        compared += 1;
    }
    assert_eq!(compared, 14);
}

/// At F0 = 0.01 N the curve is the linear response: equal to `frf` within 0.1 %.
#[test]
fn small_forcing_equals_frf() {
    linear_at(0.01, 2.5);
}

/// So it is at F0 = 1e-4 N over 1.5–5 rad/s, where the orbit (1e-6 rad at 1.5 rad/s) is
/// small against the bars' coordinates (up to 4 m; the displacement's norm 7.6e-7 of
/// them, `Nfr::motion`): the shooting's tolerances are fitted to the motion (before, the
/// curve stalled near 3 rad/s in the integration's error, and at 1e-5 N mistook noise for
/// a fold). At 1e-5 N (7.6e-8) a period's rounding approaches the Newton tolerance: the
/// curve stops short, and `nfr` says why (below 5e-7).
#[test]
fn tiny_forcing_equals_frf() {
    linear_at(1e-4, 1.5);
    let sys = model(&[("theta1_0", -0.85), ("c", 1.0), ("F0", 1e-5)]);
    let opts = NfrOptions::new("omega", 1.5, 5.0, vec!["bar1.theta".into()]);
    let c = nfr(&sys, &opts, &|_, _| {}, &AtomicBool::new(false)).unwrap();
    assert!((c.motion - 7.59e-8).abs() < 1e-10, "motion {:e}", c.motion);
    assert!(c.folds.is_empty() && c.period_doublings.is_empty());
}

/// The overcentre's lower well at c = 1 and forcing `f0` from `from` to 5 rad/s: the
/// curve equals `frf` within 0.1 %, its peak the linear one.
fn linear_at(f0: f64, from: f64) {
    let sys = model(&[("theta1_0", -0.85), ("c", 1.0), ("F0", f0)]);
    let opts = NfrOptions::new("omega", from, 5.0, vec!["bar1.theta".into()]);
    let c = nfr(&sys, &opts, &|_, _| {}, &AtomicBool::new(false)).unwrap();
    assert!(c.motion > 5e-7, "motion {:e}", c.motion);
    assert!(c.complete);
    assert!(c.folds.is_empty() && c.period_doublings.is_empty());
    assert!(c.points.iter().all(|p| p.stable));
    let w: Vec<f64> = c.points.iter().map(|p| p.omega).collect();
    let fr = detune::linear::frequency_response(&sys, "omega", &w, &["bar1.theta".into()]).unwrap();
    for (p, lin) in c.points.iter().zip(&fr.values) {
        let (a, l) = (p.measures[0].amplitude, lin[0].0);
        assert!(
            (a - l).abs() < 1e-3 * l,
            "at {} rad/s: {a} vs frf {l}",
            p.omega
        );
    }
    // the linear peak (ω_n of the lower well, lightly damped) is the curve's peak
    assert_eq!(c.peaks.len(), 1, "{:?}", c.peaks);
    let fp = fr.peaks.first().expect("frf peak");
    assert!(
        (c.peaks[0].omega - fp.omega).abs() < 2e-3,
        "{:?} vs {:?}",
        c.peaks,
        fp
    );
}

/// The largest Floquet multiplier of a stable orbit is the decay of a small perturbation
/// per period, as a simulation shows it (within 1 %).
#[test]
fn multiplier_is_the_decay_of_a_perturbation() {
    let c = overcentre_curve();
    // a stable orbit with real multipliers, perturbed along the largest one's eigenvector
    let p = c
        .points
        .iter()
        .filter(|p| p.stable && p.located.is_none())
        .filter(|p| p.multipliers.iter().all(|m| m.im == 0.0))
        .filter(|p| p.multipliers[0].norm() < 0.95)
        .max_by(|a, b| a.multipliers[0].norm().total_cmp(&b.multipliers[0].norm()))
        .expect("a stable point with real multipliers");
    let mu = p.multipliers[0].re;
    assert!(mu.abs() > 0.5 && mu.abs() < 0.99, "{mu}");
    let sys = model(&[("theta1_0", -0.85), ("c", 1.0), ("F0", 4.0)]);
    let w = sys.param_index("omega").unwrap();
    let outs = sys.outputs(&["bar1.theta".to_string()]).unwrap();
    let mut sh = detune::periodic::Shooting::new(&sys, w, &outs, Default::default()).unwrap();
    sh.set(p.omega).unwrap();
    let tb = sh.tangent_basis(&p.x);
    let f = sh.flow(&p.x, &tb, false, &AtomicBool::new(false)).unwrap();
    let m = tb.transpose() * &f.jac;
    let eig = m.clone().complex_eigenvalues();
    let largest = eig
        .iter()
        .map(|e| e.re)
        .fold(0.0f64, |a, b| if b.abs() > a.abs() { b } else { a });
    // its own multipliers, or, checked light (`stale`), its last full Newton iterate's:
    // off by that step, at most 1e-4 of the orbit (docs/nonlinear-frequency-response.md)
    let tol = if p.stale { 1e-4 } else { 1e-5 };
    assert!((largest - mu).abs() < tol, "{largest} vs {mu}");
    // eigenvector of μ: null vector of M − μI (2 × 2)
    let (a, b) = (m[(0, 0)] - mu, m[(0, 1)]);
    let v = if b.abs() > 1e-12 || a.abs() > 1e-12 {
        nalgebra::DVector::from_vec(vec![-b, a])
    } else {
        nalgebra::DVector::from_vec(vec![m[(1, 1)] - mu, -m[(1, 0)]])
    };
    let dir = &tb * v.normalize();
    let eps = 1e-6 * p.x.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let mut x: Vec<f64> =
        p.x.iter()
            .zip(dir.iter())
            .map(|(a, d)| a + eps * d)
            .collect();
    sh.project(&mut x);
    let n = p.x.len() / 2;
    let start = detune::State {
        t: 0.0,
        q: x[..n].to_vec(),
        v: x[n..].to_vec(),
    };
    let periods = 8;
    let t = 2.0 * std::f64::consts::PI / p.omega;
    let opts = detune::SimOptions {
        t_end: periods as f64 * t,
        dt_out: t,
        ..Default::default()
    };
    let traj = detune::simulate(
        &sys.with_param(w, p.omega).unwrap(),
        &start,
        &opts,
        &mut |_| true,
    )
    .unwrap();
    let dev = |k: usize| -> f64 {
        let y: Vec<f64> = traj.q(k).iter().chain(traj.v(k)).copied().collect();
        y.iter()
            .zip(&p.x)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let observed = (dev(periods) / dev(0)).powf(1.0 / periods as f64);
    assert!(
        (observed - mu.abs()).abs() < 1e-2 * mu.abs(),
        "decay per period {observed} vs |μ| = {}",
        mu.abs()
    );
}

/// The command: the JSON keys scripts rely on (the names), units on them, the
/// CSV's header; and bad input refused with a hint before any work.
#[test]
fn command_outputs_and_bad_input() {
    let dir = std::env::temp_dir().join(format!("detune-nfr-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("curve.csv");
    let (code, out, err) = overcentre_nfr(&[
        "--set",
        "F0=4",
        "--param",
        "omega",
        "--from",
        "3.6",
        "--to",
        "4.2",
        "--json",
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    for k in [
        "param",
        "complete",
        "points",
        "folds",
        "period_doublings",
        "neimark_sacker",
        "peaks",
        "branches",
        "units",
    ] {
        assert!(
            j.get(k).is_some(),
            "no `{k}` in {}",
            &out[..out.len().min(400)]
        );
    }
    assert_eq!(j["param"], "omega");
    assert_eq!(j["complete"], true);
    let fold = &j["folds"][0];
    for k in ["value", "omega", "amplitude", "multipliers"] {
        assert!(fold.get(k).is_some(), "fold without `{k}`");
    }
    assert!((fold["omega"].as_f64().unwrap() - 4.024).abs() < 1e-3);
    assert!(fold["amplitude"]["bar1.theta"].as_f64().unwrap() > 0.3);
    let p0 = &j["points"][0];
    for k in [
        "omega",
        "bar1.theta_amplitude",
        "bar1.theta_max",
        "bar1.theta_min",
        "bar1.theta_mean",
        "bar1.theta_h1",
        "bar1.theta_phase_deg",
        "stable",
        "mu1_re",
        "mu2_im",
    ] {
        assert!(p0.get(k).is_some(), "point without `{k}`");
    }
    assert_eq!(j["units"]["bar1.theta_amplitude"], "rad");
    assert_eq!(j["units"]["omega"], "rad/s");
    // the located points' uncertainty and the branches' ends are in the parameter's unit
    assert_eq!(j["units"]["uncertainty"], "rad/s");
    assert_eq!(j["units"]["from"], "rad/s");
    // how each branch ended, with the value's unit (`reached omega = 4.2 rad/s`), in SI
    // whatever --freq-unit (it named the cycles form `omega/2π` with the value in rad/s)
    for b in j["branches"].as_array().unwrap() {
        let end = b["end"].as_str().unwrap();
        assert!(
            end.ends_with(" rad/s"),
            "a branch's end without its unit: {end}"
        );
    }
    let (code, out, err) = overcentre_nfr(&[
        "--set",
        "F0=4",
        "--param",
        "omega",
        "--from",
        "3.6",
        "--to",
        "3.7",
        "--freq-unit",
        "Hz",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let in_hz: serde_json::Value = serde_json::from_str(&out).unwrap();
    let end = in_hz["branches"][0]["end"].as_str().unwrap();
    assert!(
        end.contains("omega = 3.7 rad/s") && !end.contains('π'),
        "{end}"
    );
    assert!(j["folds"][0]["uncertainty"].as_f64().unwrap() < 1e-8);
    assert_eq!(j["folds"][0]["refined"], true);
    let head = std::fs::read_to_string(&csv).unwrap();
    assert!(
        head.starts_with("omega,branch,bar1.theta_amplitude,"),
        "{}",
        &head[..80]
    );
    assert!(
        head.lines()
            .next()
            .unwrap()
            .ends_with(",stable,floquet_max,mu1_re,mu1_im,mu2_re,mu2_im,located")
    );
    // a relative tolerance outside 1e-15..1e-3 (orbits are converged to ~100·rtol of
    // their amplitude: --rtol 0.5 gave a period doubling 65 times its stated uncertainty
    // off): refused, in the form it was given
    for (rtol, shown) in [("0.5", "--rtol 0.5:"), ("1e-20", "--rtol 1e-20:")] {
        let (code, _, err) = overcentre_nfr(&[
            "--set", "F0=4", "--param", "omega", "--from", "3", "--to", "4", "--rtol", rtol,
        ]);
        assert_eq!(code, 1, "{err}");
        assert!(
            err.contains(shown) && err.contains("from 1e-15 to 1e-3"),
            "{err}"
        );
    }
    // no forcing: a clear error with a hint
    let (code, _, err) = detune(&[
        "nfr",
        "models/overcentre.toml",
        "--set",
        "theta1_0=-0.85",
        "--param",
        "omega",
        "--from",
        "3",
        "--to",
        "4",
    ]);
    assert_eq!(code, 1);
    assert!(
        err.contains("zero forcing") && err.contains("help:"),
        "{err}"
    );
    // an empty range, and a backbone against another parameter
    let (code, _, err) = detune(&[
        "nfr",
        "models/overcentre.toml",
        "--set",
        "F0=1",
        "--param",
        "omega",
        "--from",
        "3",
        "--to",
        "3",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("empty"), "{err}");
    // a range that is not finite is not "empty"
    let (code, _, err) = detune(&[
        "nfr",
        "models/overcentre.toml",
        "--set",
        "F0=1",
        "--param",
        "omega",
        "--from",
        "nan",
        "--to",
        "3",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("--from NaN --to 3: not finite"), "{err}");
    let (code, _, err) = detune(&[
        "nfr",
        "models/overcentre.toml",
        "--set",
        "F0=1",
        "--set",
        "omega=3",
        "--param",
        "c",
        "--from",
        "1",
        "--to",
        "2",
        "--backbone",
        "1",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("--backbone") && err.contains("help:"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The command's wording and requests (a fresh-eyes review): values of another parameter
/// with units, printed in its unit to sensible digits; requests that did nothing said so
/// (--backbone without --plot, a --max-points too small to make a curve, F0 from
/// 0) before any work; Ctrl-C says the continuation was interrupted, and the branch's
/// end is printed in the --freq-unit.
#[test]
fn command_wording_and_requests() {
    let oc = overcentre_nfr;
    // F0 = 2..2.2 N at 3 rad/s, given with units, printed with the unit (it was "2.2")
    let (code, out, err) = oc(&[
        "--set", "omega=3", "--param", "F0", "--from", "2 N", "--to", "2.2 N",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("branch 0: from F0 = 2.000000 N,") && out.contains("reached F0 = 2.200000 N"),
        "{out}"
    );
    // refused before any work, each with what to give
    for (more, says) in [
        (
            &[
                "--set",
                "F0=4",
                "--param",
                "omega",
                "--from",
                "3",
                "--to",
                "4",
                "--backbone",
                "1",
            ][..],
            "--plot",
        ),
        (
            &[
                "--set",
                "F0=4",
                "--param",
                "omega",
                "--from",
                "3",
                "--to",
                "4",
                "--max-points",
                "1",
            ],
            "the least useful value is 26",
        ),
        (
            &[
                "--set",
                "F0=4",
                "--param",
                "omega",
                "--from",
                "3",
                "--to",
                "4",
                "--max-step",
                "2",
            ],
            "--max-step 2: larger than the whole curve",
        ),
        (
            &[
                "--set", "F0=4", "--param", "omega", "--from", "3 Hz", "--to", "3 Hz",
            ],
            "--from \"3 Hz\" --to \"3 Hz\": the range of omega is empty (both 18.8495",
        ),
        (
            &[
                "--set", "omega=3", "--param", "F0", "--from", "0", "--to", "2",
            ],
            "--from \"0.002 N\"",
        ),
        (
            &[
                "--set", "omega=3", "--param", "F0", "--from", "3 kg", "--to", "2",
            ],
            "`F0` is a quantity in N, the value given is in kg",
        ),
    ] {
        let (code, _, err) = oc(more);
        assert_eq!(code, 1, "{more:?}: {err}");
        assert!(
            err.contains(says) && err.contains("help:"),
            "{more:?}: {err}"
        );
        assert!(!err.contains("zero forcing"), "{err}");
    }
    // Ctrl-C: what was computed is printed, the branch's end in Hz, exit 130
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_detune"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "nfr",
            "models/overcentre.toml",
            "--set",
            "theta1_0=-0.85",
            "--set",
            "c=1",
            "--set",
            "F0=4",
            "--param",
            "omega",
            "--from",
            "3",
            "--to",
            "4.5",
            "--response",
            "bar1.theta",
            "--freq-unit",
            "Hz",
            // 100 times tighter and steps 20 times shorter: the curve takes far longer
            // than the signal's 1.5 s (at the default steps it ended in 1.44 s once)
            "--rtol",
            "1e-12",
            "--atol",
            "1e-14",
            "--max-step",
            "0.002",
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let killed = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let o = child.wait_with_output().unwrap();
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert_eq!(o.status.code(), Some(130), "{out}{err}");
    assert!(
        err.contains("the continuation was interrupted") && !err.contains("sweep"),
        "{err}"
    );
    // 3 rad/s = 0.477465 Hz (omega/2π: cycles); the end "interrupted at omega/2π =
    // 0.6... Hz", not in rad/s
    assert!(
        out.lines()
            .any(|l| l.starts_with("branch 0: from omega/2π = 0.477465 Hz,")),
        "{out}"
    );
    let interrupted = out
        .lines()
        .find(|l| l.starts_with("branch ") && l.contains("interrupted"))
        .unwrap_or("");
    assert!(
        interrupted.contains("interrupted at omega/2π = 0.") && interrupted.ends_with(" Hz"),
        "{out}"
    );
}

/// The range given downward (4.5 to 3) finds what the upward one finds: the first branch
/// comes down the large branch to 3, and the far end's start (the small branch) is traced
/// too, with its fold; every point stays inside the range (a branch that turns back ends
/// at the range's end exactly, or at its last orbit inside). A forcing-amplitude continuation scales its steps by the
/// largest linear orbit across the range, not the one at its start.
#[test]
fn either_direction_and_another_parameter() {
    let sys = model(&[("theta1_0", -0.85), ("c", 1.0), ("F0", 4.0)]);
    let down = NfrOptions::new("omega", 4.5, 3.0, vec!["bar1.theta".into()]);
    let c = nfr(&sys, &down, &|_, _| {}, &AtomicBool::new(false)).unwrap();
    assert!(c.complete, "{:?}", c.branches);
    assert_eq!(c.folds.len(), 1, "{:?}", c.folds);
    assert!((c.folds[0].omega - 4.024061575).abs() < 1e-8);
    assert!(c.folds[0].refined && c.folds[0].uncertainty < 1e-8);
    assert_eq!(c.period_doublings.len(), 1, "{:?}", c.period_doublings);
    assert!((c.period_doublings[0].omega - 3.2027417).abs() < 1e-6);
    assert!(
        c.points
            .iter()
            .all(|p| p.omega >= 3.0 - 1e-12 && p.omega <= 4.5 + 1e-12),
        "a point outside the range"
    );
    // both branches end at the range's ends exactly
    assert!(
        c.branches
            .iter()
            .all(|b| !b.short_of_end && (b.to == 3.0 || b.to == 4.5)),
        "{:?}",
        c.branches
    );
    // F0 from 0.01 to 2 N at 4 rad/s: the orbit grows 200 times along the range
    let sys = model(&[("theta1_0", -0.85), ("c", 1.0), ("omega", 4.0)]);
    let f0 = NfrOptions::new("F0", 0.01, 2.0, vec!["bar1.theta".into()]);
    let c = nfr(&sys, &f0, &|_, _| {}, &AtomicBool::new(false)).unwrap();
    assert!(c.complete, "{:?}", c.branches);
    assert!(c.points.len() < 100, "{} points", c.points.len());
    assert_eq!(
        c.branches[0].ended,
        detune::periodic::continuation::BranchEnd::Reached
    );
    // down to 0 N at 3 rad/s: the orbit at zero forcing (the equilibrium) cannot be
    // corrected, and the branch ends at its last orbit inside the range, none beyond it
    // (it ended at F0 = -0.000344 N)
    let sys = model(&[("theta1_0", -0.85), ("c", 1.0), ("omega", 3.0)]);
    let to0 = NfrOptions::new("F0", 1.0, 0.0, vec!["bar1.theta".into()]);
    let c = nfr(&sys, &to0, &|_, _| {}, &AtomicBool::new(false)).unwrap();
    assert!(
        c.points.iter().all(|p| p.value >= 0.0 && p.value <= 1.0),
        "a point outside 0..1 N: {:?}",
        c.branches
    );
    assert!(c.branches[0].to < 0.05, "{:?}", c.branches);
    assert!(c.branches[0].short_of_end, "{:?}", c.branches);
    assert!(c.branches[0].end.contains("could not be corrected"));
}

/// `detune nfr` on the overcentre about its lower well with c = 1 N·s/m and the response
/// bar1.theta, and `more`.
fn overcentre_nfr(more: &[&str]) -> (i32, String, String) {
    let mut args = vec![
        "nfr",
        "models/overcentre.toml",
        "--set",
        "theta1_0=-0.85",
        "--set",
        "c=1",
        "--response",
        "bar1.theta",
    ];
    args.extend_from_slice(more);
    detune(&args)
}

/// The variational parameter column dP/dω (the period's dependence included) against a
/// central difference of whole periods at ω ± 1e-4 rad/s integrated at rtol 1e-13 (measured:
/// forward 3e-7, central 5e-9 of the column): forward
/// columns to 1e-5, central to 1e-7 of the column. (The column is one directional
/// difference of the right-hand side in (state, parameter) where its state step allows;
/// a wrong scale of either part fails this.)
#[test]
fn the_parameter_column_is_the_derivative_of_the_period_map() {
    use detune::periodic::{Shooting, ShootingOptions};
    let sys = model(&[("theta1_0", -0.85), ("c", 1.0), ("F0", 4.0)]);
    let w = sys.forcing_param().unwrap();
    let start = detune::assemble(&sys).unwrap();
    let x: Vec<f64> = start.q.iter().chain(&start.v).copied().collect();
    let never = AtomicBool::new(false);
    let tight = ShootingOptions {
        rtol: 1e-13,
        atol: 1e-15,
        ..ShootingOptions::default()
    };
    let mut sh = Shooting::new(&sys, w, &[], tight.clone()).unwrap();
    sh.set(3.5).unwrap();
    let none = nalgebra::DMatrix::zeros(x.len(), 0);
    let h = 1e-4;
    let mut ends = Vec::new();
    for p in [3.5 + h, 3.5 - h] {
        sh.set(p).unwrap();
        let mut xp = x.clone();
        sh.project(&mut xp);
        ends.push(sh.flow(&xp, &none, false, &never).unwrap().end);
    }
    let fd: Vec<f64> = (0..x.len())
        .map(|i| (ends[0][i] - ends[1][i]) / (2.0 * h))
        .collect();
    let size = fd.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(size > 0.1, "{size}");
    for (central, tol) in [(false, 1e-5), (true, 1e-7)] {
        let opts = ShootingOptions {
            central,
            rtol: 1e-12,
            atol: 1e-14,
            ..ShootingOptions::default()
        };
        let mut sh = Shooting::new(&sys, w, &[], opts).unwrap();
        sh.set(3.5).unwrap();
        let mut x0 = x.clone();
        sh.project(&mut x0);
        let dirs = sh.tangent_basis(&x0);
        let col = sh.flow(&x0, &dirs, true, &never).unwrap().p_column();
        let err = (0..x.len()).fold(0.0f64, |m, i| m.max((col[i] - fd[i]).abs()));
        assert!(err <= tol * size, "central {central}: {err:e} of {size:e}");
    }
}

/// A base-driven mechanism (tests/data/shaken_pendulum.toml: the pivot shaken
/// horizontally, D0 = 1 mm): the start state moves with ω (the ground's velocity at t = 0
/// is D0·ω), and the corrector's arclength row must carry that move. Without it the
/// arclength condition converged only linearly (about 50 times a step), each point took
/// 4 to 5 periods instead of 2 to 3 (373 periods for 79 points on 2–6 rad/s; now 234 for
/// 79 on 1–12), and the inceptor's 7 mm curve 1.02 M evaluations instead of 0.63 M. The peak is
/// the linear closed form's, I_O θ'' + c l_d² θ' + m g l θ = m l ω² D0 sin ωt (at 1 mm the
/// pendulum's own softening moves it by about ω_n·θ²/16 = 6e-5 rad/s).
#[test]
fn base_driven_curve_converges_in_few_periods() {
    let path = common::data("shaken_pendulum.toml");
    let sets = vec![("D0".to_string(), "1 mm".to_string())];
    let m = detune::Model::load(&path)
        .unwrap()
        .with_overrides(&sets)
        .unwrap();
    let sys = detune::System::new(&m).unwrap();
    // 1–12 rad/s: the ambient tangent is not of unit length here (0.95 over this range),
    // and the sharp-turn test once took its dot product for a cosine, halving every
    // step until the curve stalled at 1.53 rad/s after 3001 points (2–6 rad/s passed)
    let mut opts = NfrOptions::new("omega", 1.0, 12.0, vec!["bob.theta".into()]);
    opts.max_points = 400;
    let c = nfr(&sys, &opts, &|_, _| {}, &AtomicBool::new(false)).unwrap();
    assert!(c.complete, "{:?}", c.branches);
    let per_point = c.periods as f64 / c.points.len() as f64;
    assert!(
        per_point < 3.5,
        "{} periods for {} points",
        c.periods,
        c.points.len()
    );
    // the linear closed form's peak of |Θ| = m l ω² D0 / |m g l − I_O ω² + i c l_d² ω|
    let (m, l, ig, ld, cd, g, d0) = (2.0, 0.5, 0.1, 0.8, 0.4, 9.81, 1e-3);
    let io: f64 = ig + m * l * l;
    let amp = |w: f64| {
        let re = m * g * l - io * w * w;
        let im = cd * ld * ld * w;
        m * l * w * w * d0 / (re * re + im * im).sqrt()
    };
    let (mut a, mut b) = (3.0f64, 5.0f64);
    for _ in 0..200 {
        let (x1, x2) = (a + 0.382 * (b - a), b - 0.382 * (b - a));
        if amp(x1) < amp(x2) { a = x1 } else { b = x2 }
    }
    let w_lin = 0.5 * (a + b);
    assert_eq!(c.peaks.len(), 1, "{:?}", c.peaks);
    let p = &c.peaks[0];
    assert!(
        (p.omega - w_lin).abs() < 3e-4 && (p.amplitude - amp(w_lin)).abs() < 1e-4 * amp(w_lin),
        "peak {} rad/s, {} rad; linear {w_lin} rad/s, {} rad",
        p.omega,
        p.amplitude,
        amp(w_lin)
    );
}

/// `max_points` caps the points of the curve, every one counted: each branch's start,
/// its steps, its located folds and bifurcations, and the refined peaks' orbits (a peak
/// is reported either way; its orbit joins the points while the limit leaves room).
/// Before, the starts, the located points and the peaks' orbits came on top (28 points
/// for a limit of 26; 541 for 540). A limit cuts the curve short (incomplete) only if the
/// branches need more: the overcentre over 1.9–2.5 rad/s (its secondary peak, its fold)
/// is complete with its branches' points alone, and a step that left the range without
/// a point there does not count.
#[test]
fn the_point_limit_counts_every_point() {
    use detune::periodic::continuation::Located;
    let sys = model(&[("c", 1.0), ("F0", 4.0)]);
    let curve = |n: usize| {
        let mut opts = NfrOptions::new("omega", 1.9, 2.5, vec!["bar1.theta".into()]);
        opts.max_points = n;
        nfr(&sys, &opts, &|_, _| {}, &AtomicBool::new(false)).unwrap()
    };
    let whole = curve(3000);
    assert!(whole.complete);
    assert!(
        whole.folds.len() == 1 && whole.peaks.len() == 2,
        "{:?}",
        whole.peaks
    );
    let all = whole.points.len();
    let on_branches = whole
        .points
        .iter()
        .filter(|p| p.located != Some(Located::Peak))
        .count();
    assert_eq!(all - on_branches, 2);
    for n in [40, on_branches - 1] {
        let c = curve(n);
        assert!(
            c.points.len() <= n && c.points.len() + 2 >= n && !c.complete,
            "limit {n}: {} points, complete {}",
            c.points.len(),
            c.complete
        );
    }
    let c = curve(on_branches);
    assert!(c.complete && c.points.len() == on_branches && c.peaks.len() == 2);
    // the first branch turns at its fold and leaves through 1.9 rad/s: a limit it spends
    // exactly leaves no room to look for a branch at 2.5 rad/s, and the curve is not
    // complete (it was called complete, without the far branch and its peak)
    let first = &whole.branches[0];
    assert_eq!(
        first.ended,
        detune::periodic::continuation::BranchEnd::Returned
    );
    let c = curve(first.points);
    assert!(!c.complete && c.branches.len() == 1, "{:?}", c.branches);
}

/// The curve of `tests/data/<file>` at forcing amplitude `f0` (N) over 19–21 rad/s,
/// measured at `responses`, complete; and its system.
fn data_curve(
    file: &str,
    f0: &str,
    responses: &[&str],
) -> (detune::System, detune::periodic::continuation::Nfr) {
    let m = common::with_sets(
        detune::Model::load(&common::data(file)).unwrap(),
        &[("F0", f0)],
    );
    let sys = detune::System::new(&m).unwrap();
    let responses = responses.iter().map(|r| r.to_string()).collect();
    let opts = NfrOptions::new("omega", 19.0, 21.0, responses);
    let c = nfr(&sys, &opts, &|_, _| {}, &AtomicBool::new(false)).unwrap();
    assert!(c.complete, "{file}: {:?}", c.branches);
    (sys, c)
}

/// A response whose motion is below what the integration resolves against its value has
/// no peaks: tests/data/weak_pair.toml's block2 sits at x = 3 m and moves 8e-10 m at
/// F0 = 1 N, under noise spikes of 4e-9 m (rtol × 3 m). Before, `nfr` reported 9 peaks of
/// it between 19.69 and 20.89 rad/s (the system is linear: one resonance, block's).
#[test]
fn a_response_under_the_noise_has_no_peaks() {
    let (_, c) = data_curve("weak_pair.toml", "1", &["block2.x", "block.x"]);
    let got: Vec<&str> = c.peaks.iter().map(|p| p.response.as_str()).collect();
    assert_eq!(got, ["block.x"], "{:?}", c.peaks);
    // and it is said, with why
    let said: Vec<&str> = c.no_peaks.iter().map(|n| n.response.as_str()).collect();
    assert_eq!(said, ["block2.x"], "{:?}", c.no_peaks);
    let why = &c.no_peaks[0].why;
    assert!(
        why.amplitude < why.noise || why.change < why.noise,
        "{why:?}"
    );
    assert!((c.peaks[0].omega - 19.887).abs() < 1e-3, "{:?}", c.peaks);
}

/// A linear resonance whose amplitude is tiny against the integration's absolute
/// tolerance (sdof at F0 = 3e-7 N: 2.5e-9 m, below 30 × the default atol 1e-10 m) keeps
/// its peak: the noise a still response is judged against is that of the tolerances the
/// orbits were integrated with, fitted to the small motion. (Judged against the
/// default atol, it was dropped.)
#[test]
fn a_tiny_resonance_keeps_its_peak() {
    let (sys, c) = data_curve("sdof.toml", "3e-7", &["block.x"]);
    assert_eq!(c.peaks.len(), 1, "{:?}", c.peaks);
    let w: Vec<f64> = (0..=2000).map(|k| 19.0 + 0.001 * k as f64).collect();
    let fr = detune::linear::frequency_response(&sys, "omega", &w, &["block.x".into()]).unwrap();
    let fp = fr.peaks.first().expect("frf peak");
    // Refined: its trials' periods used to hit their step limit (an absolute tolerance
    // of 2e-20 m, far below the rounding of the block's 1 m coordinate), and the peak
    // was the continuation's own point, ± 0.048 rad/s. Its orbits are converged to the
    // rounding's 1e-5 of their amplitude (the curve's points came out within 5e-6 of
    // frf, the refined peak's 3.7e-5), so its place is known to a few 1e-3 rad/s.
    let p = &c.peaks[0];
    assert!(p.refined, "{:?}", c.peaks);
    assert!(
        (p.omega - fp.omega).abs() <= p.uncertainty
            && p.uncertainty < 0.01
            && (p.amplitude - fp.amplitude).abs() < 1e-4 * fp.amplitude,
        "{:?} vs {fp:?}",
        c.peaks
    );
}

/// Undamped (c = 0), the forced overcentre's orbits keep their phase-space volume (|det
/// M| = Π|μ| = 1, Liouville): their complex multipliers stay on the unit circle, so there
/// is no Neimark–Sacker point, and an orbit is stable (elliptic) unless a real multiplier
/// lies outside it. Before, round-off moved the pairs across the circle: ten
/// Neimark–Sacker points on 3–4.5 rad/s, and `stable` flipping with |μ|max = 1 ± 4e-7.
#[test]
fn undamped_orbits_are_conservative() {
    let sys = model(&[("theta1_0", -0.85), ("c", 0.0), ("F0", 4.0)]);
    let opts = NfrOptions::new("omega", 3.0, 4.5, vec!["bar1.theta".into()]);
    let c = nfr(&sys, &opts, &|_, _| {}, &AtomicBool::new(false)).unwrap();
    assert!(c.complete, "{:?}", c.branches);
    assert!(c.neimark_sacker.is_empty(), "{:?}", c.neimark_sacker);
    assert!(!c.folds.is_empty());
    let (mut stable, mut unstable) = (0, 0);
    for p in &c.points {
        // (where a real multiplier is large its reciprocal partner is poorly resolved:
        // |det M| = 0.99977 at |μ|max = 5.6)
        let det: f64 = p.multipliers.iter().map(|m| m.norm()).product();
        let big = p.multipliers.iter().map(|m| m.norm()).fold(0.0, f64::max);
        assert!(
            big > 2.0 || (det - 1.0).abs() < 1e-4,
            "|det M| = {det} at {}",
            p.omega
        );
        let out = p.multipliers.iter().any(|m| m.norm() > 1.0 + 1e-4);
        assert_eq!(p.stable, !out, "{} rad/s: {:?}", p.omega, p.multipliers);
        if p.stable { stable += 1 } else { unstable += 1 }
    }
    assert!(
        stable > 10 && unstable > 10,
        "{stable} stable, {unstable} unstable"
    );
    // the model decides, not the multipliers: slightly negatively damped, |det M| is
    // 1 + 9e-5 (within the monodromy's error of 1), yet every orbit is unstable (a first
    // version that judged by |det M| called eight of them stable)
    let sys = model(&[("theta1_0", -0.85), ("c", -2.5e-4), ("F0", 4.0)]);
    let c = nfr(&sys, &opts, &|_, _| {}, &AtomicBool::new(false)).unwrap();
    assert!(c.points.iter().all(|p| !p.stable));
}

/// The shaken pendulum continued in its table amplitude (1–300 mm at 4 rad/s): one
/// branch. The far end's start lies about θ = −2π, the same orbits as the first branch's
/// about 0; compared without the angles' wrap it was traced a second time (31 points,
/// every amplitude the same, the mean 2π lower).
#[test]
fn an_orbit_a_turn_away_is_the_same_orbit() {
    let m = detune::Model::load(&common::data("shaken_pendulum.toml")).unwrap();
    let sys = detune::System::new(&common::with_sets(m, &[("omega", "4")])).unwrap();
    let opts = NfrOptions::new("D0", 1e-3, 0.3, vec!["bob.theta".into()]);
    let c = nfr(&sys, &opts, &|_, _| {}, &AtomicBool::new(false)).unwrap();
    assert!(c.complete, "{:?}", c.branches);
    assert_eq!(c.branches.len(), 1, "{:?}", c.branches);
}

/// A mode the orbit hardly excites keeps its multipliers: tests/data/weak_pair.toml's
/// second block (1 kg on 1e5 N/m, 1 N·s/m: 316 rad/s, its pair's modulus e^(−0.5 T))
/// beside block's forced 20 rad/s (e^(−1.5 T)); the coupling (0.01 N/m) moves neither
/// by more than 1e-6. The steps of a period were chosen by the state's error alone, which
/// this mode hardly enters, so it was crossed near DOP853's stability limit (h·λ ≈ 5.8):
/// the pair's modulus came out anywhere from 0.05 to 121, with points called unstable and
/// a Neimark–Sacker point at 20.44 rad/s on a linear model. Now the periods that carry
/// the columns take h·λ ≤ 2 (`COLUMN_STEP_RESOLUTION`).
#[test]
fn a_mode_the_orbit_hardly_excites_keeps_its_multipliers() {
    let (_, c) = data_curve("weak_pair.toml", "1", &["block.x"]);
    assert!(c.neimark_sacker.is_empty(), "{:?}", c.neimark_sacker);
    assert!(c.period_doublings.is_empty() && c.folds.is_empty());
    let mut worst = [0.0f64; 2];
    for p in &c.points {
        assert!(p.stable, "{} rad/s: {:?}", p.omega, p.multipliers);
        let period = 2.0 * std::f64::consts::PI / p.omega;
        for (k, sigma) in [1.5, 0.5].into_iter().enumerate() {
            let exact = (-sigma * period).exp();
            let nearest = p
                .multipliers
                .iter()
                .map(|m| (m.norm() / exact - 1.0).abs())
                .fold(f64::INFINITY, f64::min);
            worst[k] = worst[k].max(nearest);
        }
    }
    // block's pair as before; block2's within 0.5 % (measured 0.14 %)
    assert!(worst[0] < 1e-5, "block's pair: {:.3e}", worst[0]);
    assert!(worst[1] < 5e-3, "block2's pair: {:.3e}", worst[1]);
}

/// The same along a parameter that stiffens the fast mode: k2 from 1e5 to 1e6 N/m at
/// ω = 20 rad/s (block2's ω_n from 316 to 1000 rad/s, its pair still e^(−0.5 T)). The
/// step limit taken from the start's linearization alone let the far end's periods
/// step at h·λ up to 6: 27 % off, points called unstable and a false Neimark–Sacker
/// point. It is now taken from the fastest mode along the range.
#[test]
fn a_stiffening_parameter_keeps_the_fast_multipliers() {
    let m = common::with_sets(
        detune::Model::load(&common::data("weak_pair.toml")).unwrap(),
        &[("F0", "1"), ("omega", "20")],
    );
    let sys = detune::System::new(&m).unwrap();
    let opts = NfrOptions::new("k2", 1e5, 1e6, vec!["block.x".into()]);
    let c = nfr(&sys, &opts, &|_, _| {}, &AtomicBool::new(false)).unwrap();
    assert!(c.complete, "{:?}", c.branches);
    assert!(c.neimark_sacker.is_empty(), "{:?}", c.neimark_sacker);
    let exact = (-0.5 * 2.0 * std::f64::consts::PI / 20.0).exp();
    for p in &c.points {
        assert!(p.stable, "k2 = {}: {:?}", p.value, p.multipliers);
        let nearest = p
            .multipliers
            .iter()
            .map(|m| (m.norm() / exact - 1.0).abs())
            .fold(f64::INFINITY, f64::min);
        // measured 0.36 %
        assert!(nearest < 1e-2, "k2 = {}: {nearest:.3e}", p.value);
    }
}
