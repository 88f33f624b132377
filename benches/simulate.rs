//! The overcentre mechanism's 20 s free case (baseline, c = 5 N·s/m, output every
//! 0.01 s) at rtol = atol = 3e-10, which keeps θ1 within 3e-10 rad of the Lagrange
//! reference (tests/overcentre.rs checks 1e-8 at the defaults):
//!
//! * `detune_free_case`: the general path (Udwadia–Kalaba, A and b by dual numbers,
//!   Cholesky pseudoinverse, projection) through `detune::simulate`;
//! * `detune_free_case_streamed`: the same run with its samples streamed into one flat
//!   buffer (`simulate_with`, the CLI's path) instead of a `Trajectory` (whose t, q and
//!   v are three flat buffers, reserved once as well);
//! * `minimal_free_case`: a hand-written θ1-only Lagrange right-hand side integrated by
//!   the same integrator wrapper (`integrate`: detune's DOP853 stepper, the same as
//!   `detune_free_case` uses) with the same outputs: the price of generality;
//! * `stage_*`: one right-hand side split into its stages, to see where the time goes.
//!
//! Figures are recorded in docs/performance.md. Run: `cargo bench --bench simulate`.

use detune::dynamics::integrator::{IntegratorOptions, integrate};
use detune::dynamics::simulate::simulate_with;
use detune::dynamics::{DynWorkspace, accelerations, pinv_solve};
use detune::{Model, SimOptions, State, System, assemble, simulate};
use differential_equations::ode::ODE;
use nalgebra::{DMatrix, DVector};

const TOL: f64 = 3e-10;

fn main() {
    divan::main();
}

fn overcentre() -> (System, State) {
    let path = format!("{}/models/overcentre.toml", env!("CARGO_MANIFEST_DIR"));
    let model = Model::load(&path).unwrap();
    let sys = System::new(&model).unwrap();
    let state = assemble(&sys).unwrap();
    (sys, state)
}

#[divan::bench(sample_count = 50)]
fn detune_free_case(bencher: divan::Bencher) {
    let (sys, state) = overcentre();
    let opts = SimOptions {
        rtol: TOL,
        atol: TOL,
        ..SimOptions::default()
    };
    bencher.bench_local(|| simulate(&sys, &state, &opts, &mut |_| true).unwrap());
}

/// `detune_free_case` streamed, as the CLI's `simulate` writes its CSV
/// (`simulate_with`): every sample's t, q and v copied into one flat buffer reserved
/// once, where `simulate`'s `Trajectory` copies them into three (t, q, v), each also
/// reserved once: the two should take about the same time.
#[divan::bench(sample_count = 50)]
fn detune_free_case_streamed(bencher: divan::Bencher) {
    let (sys, state) = overcentre();
    let opts = SimOptions {
        rtol: TOL,
        atol: TOL,
        ..SimOptions::default()
    };
    let width = 1 + sys.nq() + sys.nv();
    bencher.bench_local(|| {
        let mut out = Vec::with_capacity(2001 * width);
        simulate_with(
            &sys,
            &state,
            &opts,
            &mut |t, q, v| {
                out.push(t);
                out.extend_from_slice(q);
                out.extend_from_slice(v);
                true
            },
            &mut |_| true,
        )
        .unwrap();
        out
    });
}

/// Baseline overcentre in θ1 alone (L1 = L2 = L, m = n = 0, force at J):
/// M(θ) = m1 L²/3 + m2 L² (1/3 + 2 sin²θ), M' = 4 m2 L² sinθ cosθ,
/// Q = k (L cosθ − L0) L sinθ + c L² sin²θ θ̇ ... (dashpot: T = k(d − L0) + c ḋ,
/// d = L cosθ, ḋ = −L sinθ θ̇, Q_spring = T L sinθ), gravity −g (m1 + m2) L/2 cosθ,
/// force F L cosθ; M θ̈ + ½ M' θ̇² = Q.
struct Minimal {
    l: f64,
    m1: f64,
    m2: f64,
    k: f64,
    c: f64,
    l0: f64,
    g: f64,
}

impl ODE<f64, Vec<f64>> for Minimal {
    fn diff(&self, _t: f64, y: &Vec<f64>, dydt: &mut Vec<f64>) {
        let (th, w) = (y[0], y[1]);
        let (s, c) = th.sin_cos();
        let l2 = self.l * self.l;
        let mass = self.m1 * l2 / 3.0 + self.m2 * l2 * (1.0 / 3.0 + 2.0 * s * s);
        let dmass = 4.0 * self.m2 * l2 * s * c;
        let d = self.l * c;
        let ddot = -self.l * s * w;
        let tension = self.k * (d - self.l0) + self.c * ddot;
        let q = tension * self.l * s - self.g * (self.m1 + self.m2) * self.l / 2.0 * c;
        dydt[0] = w;
        dydt[1] = (q - 0.5 * dmass * w * w) / mass;
    }
}

#[divan::bench(sample_count = 50)]
fn minimal_free_case(bencher: divan::Bencher) {
    let ode = Minimal {
        l: 2.0 * 2f64.sqrt(),
        m1: 1.0,
        m2: 1.0,
        k: 50.0,
        c: 5.0,
        l0: 2.0,
        g: 9.81,
    };
    let opts = IntegratorOptions {
        t0: 0.0,
        t_end: 20.0,
        dt_out: 0.01,
        rtol: TOL,
        atol: TOL,
        max_steps: 10_000_000,
        method: Default::default(),
        dense_prefix: None,
        max_step: f64::INFINITY,
    };
    bencher.bench_local(|| {
        let mut out = Vec::with_capacity(2001);
        integrate(
            &ode,
            &[std::f64::consts::FRAC_PI_4, 0.0],
            &opts,
            &mut |_, y| {
                out.push(y[0]);
                true
            },
            &mut |_, _| false,
            &mut |_| true,
        )
        .unwrap();
        out
    });
}

/// A state in the middle of the motion.
fn mid_state() -> (System, DynWorkspace, Vec<f64>, Vec<f64>) {
    let (sys, state) = overcentre();
    let traj = simulate(
        &sys,
        &state,
        &SimOptions {
            t_end: 0.37,
            ..SimOptions::default()
        },
        &mut |_| true,
    )
    .unwrap();
    let ws = DynWorkspace::new(&sys);
    let (q, v) = (
        traj.qs().next_back().unwrap().to_vec(),
        traj.vs().next_back().unwrap().to_vec(),
    );
    (sys, ws, q, v)
}

#[divan::bench]
fn stage_rhs_total(bencher: divan::Bencher) {
    let (sys, mut ws, q, v) = mid_state();
    let mut out = vec![0.0; sys.n()];
    bencher.bench_local(|| accelerations(&sys, &mut ws, &q, &v, 0.37, &mut out));
}

#[divan::bench]
fn stage_jacobian_a(bencher: divan::Bencher) {
    let (sys, mut ws, q, _) = mid_state();
    bencher.bench_local(|| sys.jacobian_blocks(&mut ws.sys, &q, 0.37));
}

#[divan::bench]
fn stage_jacobian_a_dense(bencher: divan::Bencher) {
    let (sys, mut ws, q, _) = mid_state();
    let mut a = DMatrix::zeros(sys.m(), sys.n());
    bencher.bench_local(|| sys.jacobian(&mut ws.sys, &q, 0.37, &mut a));
}

/// A planar chain of `n` uniform bars (1 m, 1 kg) pinned in series to the ground and to
/// each other, under gravity, as a model file.
fn chain_model(n: usize) -> String {
    let mut t = String::from("[model]\nname = \"chain\"\n\n");
    for i in 0..n {
        t += &format!(
            "[[bodies]]\nname = \"bar{i}\"\nmass = 1\ninertia = \"1/12\"\nx = {}\ny = 0\ntheta = 0\n\n",
            i as f64 + 0.5
        );
    }
    t += "[[joints]]\nname = \"j0\"\ntype = \"revolute\"\nbody1 = \"bar0\"\npoint1 = [-0.5, 0]\nbody2 = \"ground\"\n\n";
    for i in 1..n {
        t += &format!(
            "[[joints]]\nname = \"j{i}\"\ntype = \"revolute\"\nbody1 = \"bar{i}\"\npoint1 = [-0.5, 0]\nbody2 = \"bar{}\"\npoint2 = [0.5, 0]\n\n",
            i - 1
        );
    }
    t + "[[forces]]\ntype = \"gravity\"\nacceleration = [0, -9.81]\n"
}

/// One right-hand side of an N-link chain (A, b, f, the constraint solve), at a swinging
/// state: the cost should grow linearly with N.
#[divan::bench(args = [4, 8, 16, 32, 64])]
fn chain_rhs(bencher: divan::Bencher, n: usize) {
    let model = Model::from_str("chain.toml", &chain_model(n)).unwrap();
    let sys = System::new(&model).unwrap();
    let start = assemble(&sys).unwrap();
    let traj = simulate(
        &sys,
        &start,
        &SimOptions {
            t_end: 0.2,
            ..SimOptions::default()
        },
        &mut |_| true,
    )
    .unwrap();
    let (q, v) = (
        traj.qs().next_back().unwrap().to_vec(),
        traj.vs().next_back().unwrap().to_vec(),
    );
    let mut ws = DynWorkspace::new(&sys);
    let mut out = vec![0.0; sys.n()];
    bencher.bench_local(|| accelerations(&sys, &mut ws, &q, &v, 0.2, &mut out));
}

#[divan::bench]
fn stage_bias_b(bencher: divan::Bencher) {
    let (sys, mut ws, q, v) = mid_state();
    let mut b = DVector::zeros(sys.m());
    bencher.bench_local(|| sys.bias(&mut ws.sys, &q, &v, 0.37, &mut b));
}

#[divan::bench]
fn stage_forces(bencher: divan::Bencher) {
    let (sys, _, q, v) = mid_state();
    let mut f = vec![0.0; sys.n()];
    bencher.bench_local(|| sys.forces(&q, &v, 0.37, &mut f));
}

#[divan::bench]
fn stage_pseudoinverse_cholesky(bencher: divan::Bencher) {
    let (sys, mut ws, q, _) = mid_state();
    sys.jacobian(&mut ws.sys, &q, 0.37, &mut ws.a);
    let bm = &ws.a * &sys.mass_inv_sqrt;
    let r = DVector::from_element(sys.m(), 1.0);
    let mut gram = DMatrix::zeros(sys.m(), sys.m());
    let mut count = 0;
    bencher.bench_local(|| pinv_solve(&bm, &r, &mut gram, &mut count));
}

#[divan::bench]
fn stage_pseudoinverse_svd(bencher: divan::Bencher) {
    let (sys, mut ws, q, _) = mid_state();
    sys.jacobian(&mut ws.sys, &q, 0.37, &mut ws.a);
    let bm = &ws.a * &sys.mass_inv_sqrt;
    let r = DVector::from_element(sys.m(), 1.0);
    bencher.bench_local(|| {
        let svd = bm.clone().svd(true, true);
        svd.solve(&r, 1e-10).unwrap()
    });
}
