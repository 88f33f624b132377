//! detune's allocation-free DOP853 stepper (`detune::dynamics::dop853`) against the crate
//! it replaces, `differential-equations` 0.7.0's `ExplicitRungeKutta::dop853`: the same
//! operations in the same order, so every step (t, y, the next h, accepted or rejected)
//! and every point of the interpolant are the same bits, on problems that exercise
//! rejections, the initial step estimate, restarts with a given step, and more than 100
//! steps (the crate's periodic stiffness test). And its dense output (Hairer's, the
//! crate's corrected) against the closed form of y'' = −y.

use detune::dynamics::dop853::Dop853;
use differential_equations::interpolate::Interpolation;
use differential_equations::methods::Ordinary;
use differential_equations::ode::{ODE, OrdinaryNumericalMethod};
use differential_equations::prelude::ExplicitRungeKutta;
use differential_equations::status::Status;

struct VanDerPol(f64);
impl ODE<f64, Vec<f64>> for VanDerPol {
    fn diff(&self, _t: f64, y: &Vec<f64>, f: &mut Vec<f64>) {
        f[0] = y[1];
        f[1] = self.0 * (1.0 - y[0] * y[0]) * y[1] - y[0];
    }
}

/// A forced, damped pendulum and a second, coupled one (4 states, t-dependent).
struct Pendula;
impl ODE<f64, Vec<f64>> for Pendula {
    fn diff(&self, t: f64, y: &Vec<f64>, f: &mut Vec<f64>) {
        f[0] = y[1];
        f[1] = -9.81 * y[0].sin() - 0.3 * y[1] + 2.0 * (1.7 * t).cos() + 4.0 * (y[2] - y[0]);
        f[2] = y[3];
        f[3] = -9.81 * y[2].sin() - 4.0 * (y[2] - y[0]);
    }
}

struct Harmonic;
impl ODE<f64, Vec<f64>> for Harmonic {
    fn diff(&self, _t: f64, y: &Vec<f64>, f: &mut Vec<f64>) {
        f[0] = y[1];
        f[1] = -y[0];
    }
}

/// Steps both from (t0, y0) to t_end with tolerance `tol` (restarting both with the
/// current step at `restart_at`, as the integrator does after a projection), comparing
/// every step and 7 interpolated points per accepted step bit for bit. Returns the
/// accepted and rejected steps.
fn same_steps<F: ODE<f64, Vec<f64>>>(
    ode: &F,
    y0: &[f64],
    t_end: f64,
    tol: f64,
    restart_at: f64,
) -> (usize, usize) {
    let mut ours = Dop853::new(tol, tol);
    let mut theirs = ExplicitRungeKutta::<Ordinary, _, f64, Vec<f64>, 8, 12, 16>::dop853()
        .rtol(tol)
        .atol(tol)
        .max_steps(usize::MAX);
    ours.init(ode, 0.0, t_end, &y0.to_vec()).unwrap();
    theirs.init(ode, 0.0, t_end, &y0.to_vec()).unwrap();
    let (mut accepted, mut rejected, mut restarted) = (0, 0, false);
    while ours.t() < t_end {
        assert_eq!(
            ours.h().to_bits(),
            theirs.h().to_bits(),
            "h at t = {}",
            ours.t()
        );
        if ours.t() + ours.h() > t_end {
            let h = t_end - ours.t();
            ours.set_h(h);
            theirs.set_h(h);
        }
        let (a, b) = (ours.step(ode), theirs.step(ode));
        assert_eq!(a.is_ok(), b.is_ok());
        let rej = |s: &Status<f64, Vec<f64>>| matches!(s, Status::RejectedStep);
        assert_eq!(rej(ours.status()), rej(theirs.status()));
        if rej(ours.status()) {
            rejected += 1;
            continue;
        }
        accepted += 1;
        assert_eq!(ours.t().to_bits(), theirs.t().to_bits());
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(ours.y()), bits(theirs.y()), "y at t = {}", ours.t());
        let (t0, t1) = (ours.t_prev(), ours.t());
        for i in 0..=6 {
            let t = (t0 + (t1 - t0) * i as f64 / 6.0).min(t1);
            let (p, q) = (ours.interpolate(t).unwrap(), theirs.interpolate(t).unwrap());
            assert_eq!(bits(&p), bits(&q), "interpolant at t = {t}");
        }
        if !restarted && ours.t() >= restart_at {
            restarted = true;
            let (t, y, h) = (ours.t(), ours.y().clone(), ours.h());
            ours.h0 = h;
            theirs.h0 = h;
            ours.init(ode, t, t_end, &y).unwrap();
            theirs.init(ode, t, t_end, &y).unwrap();
        }
    }
    assert!(restarted || restart_at > t_end);
    (accepted, rejected)
}

#[test]
fn the_same_bits_as_the_crates_dop853() {
    // Van der Pol with μ = 5: relaxation oscillations, many rejections
    let (a, r) = same_steps(&VanDerPol(5.0), &[2.0, 0.0], 30.0, 1e-9, 11.0);
    assert!(a > 100 && r > 5, "{a} accepted, {r} rejected");
    let (a, r) = same_steps(&Pendula, &[1.0, 0.0, -0.5, 0.3], 20.0, 3e-10, 7.3);
    assert!(a > 100 && r > 0, "{a} accepted, {r} rejected");
    // at rest at the start (the initial step estimate's other branch)
    same_steps(&Harmonic, &[0.0, 0.0], 5.0, 1e-6, 10.0);
    same_steps(&Harmonic, &[1.0, 0.0], 50.0, 1e-12, 25.0);
}

/// Hairer's dense output (`dense_into`) of y'' = −y, y(0) = 1: cos t to 1e-11 between the
/// steps over 20 s at rtol = atol = 1e-12 (the step ends' own global error is of that
/// order; the crate's own interpolant is off by more than 100 times as much).
#[test]
fn dense_output_follows_the_cosine() {
    let mut s = Dop853::new(1e-12, 1e-12);
    let t_end = 20.0;
    s.init(&Harmonic, 0.0, t_end, &vec![1.0, 0.0]).unwrap();
    let (mut worst, mut worst_crate) = (0.0f64, 0.0f64);
    let mut y = Vec::new();
    while s.t() < t_end {
        if s.t() + s.h() > t_end {
            s.set_h(t_end - s.t());
        }
        s.step(&Harmonic).unwrap();
        if matches!(s.status(), Status::RejectedStep) {
            continue;
        }
        let (t0, t1) = (s.t_prev(), s.t());
        for i in 1..10 {
            let t = t0 + (t1 - t0) * i as f64 / 10.0;
            s.dense_into(t, &mut y);
            worst = worst.max((y[0] - t.cos()).abs());
            worst_crate = worst_crate.max((s.interpolate(t).unwrap()[0] - t.cos()).abs());
        }
    }
    eprintln!("dense output off by {worst:e}, the crate's interpolant by {worst_crate:e}");
    assert!(worst < 1e-11, "dense output off by {worst:e}");
    assert!(
        worst_crate > 1e2 * worst,
        "{worst_crate:e} against {worst:e}"
    );
}

/// `Pendula` with its tangent flow beside it (the linearized equations along one
/// direction, as a shooting's variational columns), counting its calls by state length.
/// Called with the first four components alone it gives their derivatives only.
struct PendulaTangent {
    full: std::cell::Cell<usize>,
    short: std::cell::Cell<usize>,
}
impl ODE<f64, Vec<f64>> for PendulaTangent {
    fn diff(&self, t: f64, y: &Vec<f64>, f: &mut Vec<f64>) {
        Pendula.diff(t, y, f);
        if y.len() == 4 {
            self.short.set(self.short.get() + 1);
            return;
        }
        self.full.set(self.full.get() + 1);
        let (x, d) = (&y[..4], &y[4..]);
        f[4] = d[1];
        f[5] = -9.81 * x[0].cos() * d[0] - 0.3 * d[1] + 4.0 * (d[2] - d[0]);
        f[6] = d[3];
        f[7] = -9.81 * x[2].cos() * d[2] - 4.0 * (d[2] - d[0]);
    }
}

/// `Dop853::dense_prefix`: the dense output's three extra stages on the state alone.
/// Steps, step ends and the state's samples are the same bits as with the whole dense
/// output; the tangent's samples are the straight line between the step ends (exact at
/// both); each accepted step calls the whole right-hand side 3 times fewer.
#[test]
fn dense_output_of_a_prefix() {
    let ode = |_: ()| PendulaTangent {
        full: std::cell::Cell::new(0),
        short: std::cell::Cell::new(0),
    };
    let (whole, prefix) = (ode(()), ode(()));
    let y0 = vec![1.0, 0.0, -0.5, 0.3, 1e-3, 0.0, 0.0, 0.0];
    let t_end = 10.0;
    let (mut a, mut b) = (Dop853::new(1e-9, 1e-9), Dop853::new(1e-9, 1e-9));
    b.dense_prefix(4);
    a.init(&whole, 0.0, t_end, &y0).unwrap();
    b.init(&prefix, 0.0, t_end, &y0).unwrap();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let (mut accepted, mut rejected) = (0, 0);
    let (mut ya, mut yb) = (Vec::new(), Vec::new());
    while a.t() < t_end {
        if a.t() + a.h() > t_end {
            let h = t_end - a.t();
            a.set_h(h);
            b.set_h(h);
        }
        a.step(&whole).unwrap();
        b.step(&prefix).unwrap();
        assert_eq!(a.h().to_bits(), b.h().to_bits());
        if matches!(a.status(), Status::RejectedStep) {
            assert!(matches!(b.status(), Status::RejectedStep));
            rejected += 1;
            continue;
        }
        accepted += 1;
        assert_eq!(bits(a.y()), bits(b.y()), "y at t = {}", a.t());
        let (t0, t1) = (a.t_prev(), a.t());
        for i in 0..=5 {
            let th = i as f64 / 5.0;
            let t = if i == 5 { t1 } else { t0 + (t1 - t0) * th };
            a.dense_into(t, &mut ya);
            b.dense_into(t, &mut yb);
            // the crate's interpolation trait: the same straight line past the prefix
            let yi = b.interpolate(t).unwrap();
            assert_eq!(bits(&ya[..4]), bits(&yb[..4]), "state at t = {t}");
            for k in 4..8 {
                let line = (1.0 - th) * a.y_prev()[k] + th * a.y()[k];
                let size = a.y_prev()[k].abs().max(a.y()[k].abs());
                assert!((yb[k] - line).abs() <= 1e-13 * size, "tangent at t = {t}");
                assert!(
                    (yi[k] - line).abs() <= 1e-13 * size,
                    "interpolate at t = {t}"
                );
            }
        }
        assert_eq!(
            bits(&yb[4..]),
            bits(&b.y()[4..]),
            "the tangent at the step's end"
        );
    }
    assert!(
        accepted > 50 && rejected > 0,
        "{accepted} accepted, {rejected} rejected"
    );
    assert_eq!(whole.short.get(), 0);
    assert_eq!(prefix.short.get(), 3 * accepted);
    assert_eq!(whole.full.get() - prefix.full.get(), 3 * accepted);
}

/// `Dop853::max_step`: no step (the first included) is longer than the limit, and the
/// solution is still y = cos t to the tolerance; unlimited, the same problem takes steps
/// several times longer.
#[test]
fn a_step_limit_holds() {
    let y0 = vec![1.0, 0.0];
    let t_end = 20.0;
    let longest = |limit: f64| {
        let mut s = Dop853::new(1e-10, 1e-10);
        s.max_step(limit);
        s.init(&Harmonic, 0.0, t_end, &y0).unwrap();
        let mut longest = 0.0f64;
        while s.t() < t_end {
            if s.t() + s.h() > t_end {
                let h = t_end - s.t();
                s.set_h(h);
            }
            assert!(s.h() <= limit, "a step of {} past {limit}", s.h());
            s.step(&Harmonic).unwrap();
            if !matches!(s.status(), Status::RejectedStep) {
                longest = longest.max(s.t() - s.t_prev());
                assert!((s.y()[0] - s.t().cos()).abs() < 1e-8, "t = {}", s.t());
            }
        }
        longest
    };
    let free = longest(f64::INFINITY);
    let held = longest(0.05);
    // (t − t_prev differs from the step by the rounding of t)
    assert!(
        held <= 0.05 * (1.0 + 1e-12) && free > 4.0 * held,
        "{free} vs {held}"
    );
}
