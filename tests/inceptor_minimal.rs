//! A second formulation of the inceptor (`models/inceptor.toml`, defined by
//! `tests/data/inceptor/SPEC.md`) inside the tests: a hand-written minimal-coordinate
//! Lagrange model in the generalized coordinates (φ, θg), derived from SPEC alone (no
//! constraints, no multipliers, nothing of detune's code), against which detune's
//! maximal-coordinate Udwadia–Kalaba simulation (17 coordinates, 15 constraints) is
//! compared sample by sample under base excitation.
//!
//! # Kinematics (chassis-relative, D = 0; SPEC §1–§3)
//!
//! ```text
//! S(φ) = Rz(φ) s1,   r1(φ) = Rz(φ) c1                      stick
//! C(δ) = H + Rx(δ) c3,   E(δ) = H + Rx(δ) e3,   r3(δ) = H + Rx(δ) c3g   crank
//! loop closure  f(φ, δ) = |S(φ) − C(δ)|² − l2² = 0           (Newton on δ from 8°)
//! δ' = −f_φ / f_δ,   δ'' = −(f_φφ + 2 f_φδ δ' + f_δδ δ'²) / f_δ   (implicit functions)
//! r2 = (S + C)/2,   u = (C − S)/l2 = (−sin α cos β, cos α cos β, sin β)
//! β = asin u_z,   α = atan2(−u_x, u_y)                         push-rod
//! d = E − F,   L = |d|                                         force sensor
//! ```
//!
//! Every point and angle is carried as a second-order jet in φ (`Dual2_64`: value,
//! d/dφ, d²/dφ²): φ is seeded as (φ, 1, 0) and δ as (δ, δ', δ'') from the implicit
//! function theorem, so the hand-written maps above give their first and second
//! φ-derivatives exactly (to rounding), with no finite differences.
//!
//! # Lagrangian (SPEC §8)
//!
//! ```text
//! T = ½ m11(φ) φ̇² + ½ I4xx θ̇g²
//! m11 = I1zz + m1|r1'|² + m2|r2'|² + I2 (β'² + α'² cos²β) + m3|r3'|² + I3xx δ'²
//!       (rod body rates (β̇, α̇ sin β, α̇ cos β), I2xx = I2zz = I2 = m2 l2²/12, I2yy = 0;
//!        the gearbox CG is on the shaft axis and does not move)
//! V = g (m1 y1 + m2 y2 + m3 y3) + ½ k_fs (L − L0)² + ½ k_t (θg − δ)²
//! m11 φ̈ + ½ m11' φ̇² = Q_φ,    I4xx θ̈g = Q_θ
//! Q_φ = −g Σ m_i y_i' − D̈ Σ m_i x_i' − T_fs L' + τ δ'
//! Q_θ = −τ − c_d θ̇g
//! T_fs = k_fs (L − L0) + c_fs L' φ̇,   τ = k_t (θg − δ) + c_t (θ̇g − δ' φ̇)
//! ```
//!
//! # Base excitation
//!
//! The chassis translates by (D(t), 0, 0) and does not rotate. The coordinates are
//! measured relative to the chassis: every CG is at ρ_i(φ) + (D, 0, 0), so
//! T_inertial = ½ Σ m_i |ρ̇_i + Ḋ e_x|² + (rotational terms, unchanged because the chassis
//! does not rotate). Expanding, ½ Σ m_i Ḋ² does not depend on (φ, φ̇) and drops out of
//! Lagrange's equations, and the cross term Ḋ Σ m_i ρ̇_ix = Ḋ (Σ m_i x_i') φ̇ contributes
//! d/dt(Ḋ Σ m_i x_i') − Ḋ (Σ m_i x_i'') φ̇ = D̈ Σ m_i x_i' to the left-hand side: exactly
//! the virtual work of the d'Alembert force −m_i D̈ e_x at each CG, which is the form
//! used (the chassis-relative one, so that the state is small and the start "at rest
//! relative to the chassis" is simply φ̇ = θ̇g = 0). Gravity acts along Y and does not see
//! D; the sensor's anchor moves with the chassis, so d = E(t) − F(t) = E − F and
//! L̇ = n·(Ė − Ḋ e_x) = L' φ̇; the torsion and the damper involve angles only.

mod common;

use detune::{Model, SimOptions, System, Trajectory, assemble, simulate};
use differential_equations::ode::{ODE, OrdinaryNumericalMethod, solve_ode};
use differential_equations::prelude::*;
use differential_equations::solout::DefaultSolout;
use num_dual::{Dual2_64, DualNum};
use std::time::Instant;

type D2 = Dual2_64;
type V3 = [D2; 3];

/// Rz(a) p for a constant vector p.
fn rz(a: D2, p: [f64; 3]) -> V3 {
    let (s, c) = (a.sin(), a.cos());
    [c * p[0] - s * p[1], s * p[0] + c * p[1], D2::from(p[2])]
}

/// Rx(a) p for a constant vector p.
fn rx(a: D2, p: [f64; 3]) -> V3 {
    let (s, c) = (a.sin(), a.cos());
    [D2::from(p[0]), c * p[1] - s * p[2], s * p[1] + c * p[2]]
}

fn add(a: V3, b: [f64; 3]) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// |p'|² and d/dφ |p'|² = 2 p'·p''.
fn speed2(p: &V3) -> (f64, f64) {
    let s = p.iter().map(|x| x.v1 * x.v1).sum();
    let ds = p.iter().map(|x| 2.0 * x.v1 * x.v2).sum();
    (s, ds)
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The crank branch through δ ≈ 8° (SPEC §9).
const DELTA_GUESS: f64 = 8.0 * std::f64::consts::PI / 180.0;

/// The inceptor with the values of SPEC §1–§5 (written out here, not read from the model
/// file).
#[derive(Clone, Debug)]
struct Inceptor {
    g: f64,
    m1: f64,
    i1zz: f64,
    c1: [f64; 3],
    s1: [f64; 3],
    m2: f64,
    l2: f64,
    m3: f64,
    i3xx: f64,
    c3g: [f64; 3],
    c3: [f64; 3],
    e3: [f64; 3],
    i4xx: f64,
    h: [f64; 3],
    f: [f64; 3],
    k_fs: f64,
    c_fs: f64,
    l0: f64,
    k_t: f64,
    c_t: f64,
    c_d: f64,
    d0: f64,
    omega: f64,
}

/// Positions (and angles) at a stick angle, as jets in φ.
struct Kinematics {
    delta: D2,
    r1: V3,
    r2: V3,
    r3: V3,
    e: V3,
    alpha: D2,
    beta: D2,
    /// Force-sensor length |E − F|.
    len: D2,
    s: V3,
    c: V3,
}

impl Inceptor {
    /// The baseline of SPEC with L0 from the datum equilibrium, no base motion.
    fn baseline() -> Self {
        let mut m = Inceptor {
            g: 9.81,
            m1: 2.45,
            i1zz: 0.098,
            c1: [0.36, 0.014, 0.0],
            s1: [0.05, -0.11, 0.0],
            m2: 0.12,
            l2: 0.135,
            m3: 0.35,
            i3xx: 2.0e-4,
            c3g: [0.0, 0.0, -0.02],
            c3: [0.0, 0.0, -0.07],
            e3: [0.02, 0.0, -0.07],
            i4xx: 0.9,
            h: [0.03, 0.0, 0.14],
            f: [0.05, -0.09, 0.056],
            k_fs: 1.295e5,
            c_fs: 20.0,
            l0: f64::NAN,
            k_t: 374.0,
            c_t: 0.0,
            c_d: 5.649,
            d0: 0.0,
            omega: 0.0,
        };
        m.l0 = m.datum_natural_length();
        m
    }

    fn phi0() -> f64 {
        12f64.to_radians()
    }

    /// Rod inertia about a transverse axis through its CG.
    fn i2(&self) -> f64 {
        self.m2 * self.l2 * self.l2 / 12.0
    }

    /// D̈(t) = −D0 ω² sin ωt.
    fn base_acceleration(&self, t: f64) -> f64 {
        -self.d0 * self.omega * self.omega * (self.omega * t).sin()
    }

    /// f(φ, δ) = |S − C|² − l2² and its first and second partial derivatives
    /// (f, f_φ, f_δ, f_φφ, f_φδ, f_δδ), analytically.
    fn closure(&self, phi: f64, delta: f64) -> [f64; 6] {
        let (sp, cp) = phi.sin_cos();
        let s = [
            cp * self.s1[0] - sp * self.s1[1],
            sp * self.s1[0] + cp * self.s1[1],
            self.s1[2],
        ];
        let s_p = [-s[1], s[0], 0.0]; // e_z × S (S about O)
        let s_pp = [-s[0], -s[1], 0.0];
        let (sd, cd) = delta.sin_cos();
        let rho = [
            self.c3[0],
            cd * self.c3[1] - sd * self.c3[2],
            sd * self.c3[1] + cd * self.c3[2],
        ]; // C − H
        let rho_d = [0.0, -rho[2], rho[1]]; // e_x × ρ
        let rho_dd = [0.0, -rho[1], -rho[2]];
        let c = [self.h[0] + rho[0], self.h[1] + rho[1], self.h[2] + rho[2]];
        let w = sub(s, c);
        [
            dot(w, w) - self.l2 * self.l2,
            2.0 * dot(w, s_p),
            -2.0 * dot(w, rho_d),
            2.0 * (dot(s_p, s_p) + dot(w, s_pp)),
            -2.0 * dot(s_p, rho_d),
            2.0 * (dot(rho_d, rho_d) - dot(w, rho_dd)),
        ]
    }

    /// δ(φ), δ'(φ), δ''(φ) on the branch through 8°: Newton on the closure, then the
    /// implicit function theorem.
    fn crank_angle(&self, phi: f64) -> (f64, f64, f64) {
        let mut delta = DELTA_GUESS;
        let mut converged = false;
        for _ in 0..50 {
            let f = self.closure(phi, delta);
            let step = f[0] / f[2];
            delta -= step;
            if step.abs() <= 1e-15 {
                converged = true;
                break;
            }
        }
        assert!(converged, "loop closure did not converge at φ = {phi}");
        let [f, f_p, f_d, f_pp, f_pd, f_dd] = self.closure(phi, delta);
        assert!(f.abs() <= 1e-15, "closure residual {f:e} at φ = {phi}");
        let d1 = -f_p / f_d;
        let d2 = -(f_pp + 2.0 * f_pd * d1 + f_dd * d1 * d1) / f_d;
        (delta, d1, d2)
    }

    fn kinematics(&self, phi: f64) -> Kinematics {
        let (d, d1, d2) = self.crank_angle(phi);
        let p = D2::new(phi, 1.0, 0.0);
        let delta = D2::new(d, d1, d2);
        let s = rz(p, self.s1);
        let r1 = rz(p, self.c1);
        let c = add(rx(delta, self.c3), self.h);
        let e = add(rx(delta, self.e3), self.h);
        let r3 = add(rx(delta, self.c3g), self.h);
        let r2: V3 = std::array::from_fn(|k| (s[k] + c[k]) * 0.5);
        let u: V3 = std::array::from_fn(|k| (c[k] - s[k]) * (1.0 / self.l2));
        let beta = u[2].asin();
        let alpha = (-u[0]).atan2(u[1]);
        let d: V3 = std::array::from_fn(|k| e[k] - self.f[k]);
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        Kinematics {
            delta,
            r1,
            r2,
            r3,
            e,
            alpha,
            beta,
            len,
            s,
            c,
        }
    }

    /// m11(φ) and dm11/dφ.
    fn mass_and_slope(&self, k: &Kinematics) -> (f64, f64) {
        let (v1, dv1) = speed2(&k.r1);
        let (v2, dv2) = speed2(&k.r2);
        let (v3, dv3) = speed2(&k.r3);
        let (a, b) = (k.alpha, k.beta);
        let cb2 = b.re.cos().powi(2);
        let rod = b.v1 * b.v1 + a.v1 * a.v1 * cb2;
        let rod_slope = 2.0 * b.v1 * b.v2 + 2.0 * a.v1 * a.v2 * cb2
            - a.v1 * a.v1 * 2.0 * b.re.cos() * b.re.sin() * b.v1;
        let dl = k.delta;
        let m = self.i1zz
            + self.m1 * v1
            + self.m2 * v2
            + self.i2() * rod
            + self.m3 * v3
            + self.i3xx * dl.v1 * dl.v1;
        let slope = self.m1 * dv1
            + self.m2 * dv2
            + self.i2() * rod_slope
            + self.m3 * dv3
            + self.i3xx * 2.0 * dl.v1 * dl.v2;
        (m, slope)
    }

    /// Σ m_i x_i'(φ) and Σ m_i y_i'(φ) over the moving CGs (the gearbox CG is fixed).
    fn mass_moments(&self, k: &Kinematics) -> (f64, f64) {
        let mx = self.m1 * k.r1[0].v1 + self.m2 * k.r2[0].v1 + self.m3 * k.r3[0].v1;
        let my = self.m1 * k.r1[1].v1 + self.m2 * k.r2[1].v1 + self.m3 * k.r3[1].v1;
        (mx, my)
    }

    /// Generalized forces (Q_φ, Q_θ) by virtual work at (φ, φ̇, θg, θ̇g, t).
    fn generalized_forces(&self, k: &Kinematics, y: [f64; 4], t: f64) -> (f64, f64) {
        let [_, phi_dot, th, th_dot] = y;
        let (mx, my) = self.mass_moments(k);
        let gravity = -self.g * my;
        let base = -self.base_acceleration(t) * mx;
        let tension = self.k_fs * (k.len.re - self.l0) + self.c_fs * k.len.v1 * phi_dot;
        let dl = k.delta;
        let tau = self.k_t * (th - dl.re) + self.c_t * (th_dot - dl.v1 * phi_dot);
        let q_phi = gravity + base - tension * k.len.v1 + tau * dl.v1;
        let q_th = -tau - self.c_d * th_dot;
        (q_phi, q_th)
    }

    /// (φ̈, θ̈g).
    fn accelerations(&self, y: [f64; 4], t: f64) -> (f64, f64) {
        let k = self.kinematics(y[0]);
        let (m, slope) = self.mass_and_slope(&k);
        let (q_phi, q_th) = self.generalized_forces(&k, y, t);
        ((q_phi - 0.5 * slope * y[1] * y[1]) / m, q_th / self.i4xx)
    }

    /// Potential energy V(φ, θg) as a jet in φ (θg held).
    fn potential(&self, k: &Kinematics, th: f64) -> D2 {
        let stretch = k.len - self.l0;
        let twist = k.delta * (-1.0) + th;
        (k.r1[1] * self.m1 + k.r2[1] * self.m2 + k.r3[1] * self.m3) * self.g
            + stretch * stretch * (0.5 * self.k_fs)
            + twist * twist * (0.5 * self.k_t)
    }

    /// T + V in chassis-relative coordinates.
    fn energy(&self, y: [f64; 4]) -> f64 {
        let k = self.kinematics(y[0]);
        let (m, _) = self.mass_and_slope(&k);
        0.5 * m * y[1] * y[1] + 0.5 * self.i4xx * y[3] * y[3] + self.potential(&k, y[2]).re
    }

    /// L0 such that the datum (φ0, θg = δ0, at rest) is a static equilibrium:
    /// g Σ m_i y_i' + k_fs (L − L0) L' = 0 (the shaft is untwisted).
    fn datum_natural_length(&self) -> f64 {
        let k = self.kinematics(Self::phi0());
        let (_, my) = self.mass_moments(&k);
        k.len.re + self.g * my / (self.k_fs * k.len.v1)
    }

    /// Stiffness matrix ∂²V/∂(φ, θg)² at (φ, θg).
    fn stiffness(&self, phi: f64, th: f64) -> [[f64; 2]; 2] {
        let k = self.kinematics(phi);
        let v = self.potential(&k, th);
        [
            [v.v2, -self.k_t * k.delta.v1],
            [-self.k_t * k.delta.v1, self.k_t],
        ]
    }

    /// Undamped natural frequencies at the datum, ascending: det(K − ω² M) = 0.
    fn natural_frequencies(&self) -> [f64; 2] {
        let phi0 = Self::phi0();
        let k = self.kinematics(phi0);
        let (m11, _) = self.mass_and_slope(&k);
        let kk = self.stiffness(phi0, k.delta.re);
        let m22 = self.i4xx;
        // a λ² − b λ + c = 0, λ = ω²
        let a = m11 * m22;
        let b = kk[0][0] * m22 + kk[1][1] * m11;
        let c = kk[0][0] * kk[1][1] - kk[0][1] * kk[1][0];
        let disc = (b * b - 4.0 * a * c).sqrt();
        let lo = 2.0 * c / (b + disc); // the small root without cancellation
        let hi = (b + disc) / (2.0 * a);
        [lo.sqrt(), hi.sqrt()]
    }

    /// (φ, φ̇, θg, θ̇g) at the requested times (ascending, ≥ 0), from y0 at t = 0. DOP853,
    /// restarted at every requested time so that each output is a step end (no dense
    /// output: the interpolant of differential-equations 0.7.0 is inaccurate, see
    /// `tests/common/reduced.rs`).
    fn simulate(&self, y0: [f64; 4], times: &[f64], rtol: f64, atol: f64) -> Vec<[f64; 4]> {
        let rhs = Rhs(self);
        let mut t = 0.0;
        let mut y = y0;
        let mut h: Option<f64> = None;
        let mut out = Vec::with_capacity(times.len());
        for &t_next in times {
            assert!(t_next >= t, "times must be ascending");
            if t_next > t {
                let mut solver = ExplicitRungeKutta::dop853()
                    .rtol(rtol)
                    .atol(atol)
                    .max_steps(10_000_000);
                if let Some(h) = h {
                    solver = solver.h0(h.min(t_next - t));
                }
                let mut solout = DefaultSolout::new();
                let solution = solve_ode(&mut solver, &rhs, t, t_next, &y, &mut solout)
                    .unwrap_or_else(|e| panic!("minimal model integration failed: {e:?}"));
                let (&t_end, &y_end) = solution.last().expect("at least one step");
                assert!((t_end - t_next).abs() <= 1e-12 * t_next.max(1.0));
                h = Some(solver.h());
                t = t_next;
                y = y_end;
            }
            out.push(y);
        }
        out
    }
}

struct Rhs<'a>(&'a Inceptor);

impl ODE<f64, [f64; 4]> for Rhs<'_> {
    fn diff(&self, t: f64, y: &[f64; 4], dydt: &mut [f64; 4]) {
        let (phi_dd, th_dd) = self.0.accelerations(*y, t);
        *dydt = [y[1], phi_dd, y[3], th_dd];
    }
}

fn reference(name: &str) -> serde_json::Value {
    let path = common::data(&format!("inceptor/{name}"));
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn num(v: &serde_json::Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

// ---------------------------------------------------------------------------------------
// The static pieces against the reference data

#[test]
fn datum_is_the_reference_equilibrium() {
    let eq = reference("equilibrium.json");
    let m = Inceptor::baseline();
    let phi0 = Inceptor::phi0();
    assert_eq!(phi0, num(&eq["phi0_rad"]));
    let k = m.kinematics(phi0);
    let coords = &eq["coordinates"];
    let want = |name: &str| num(&coords[name]);
    let mut worst: f64 = 0.0;
    let mut check = |name: &str, got: f64| {
        let err = (got - want(name)).abs();
        worst = worst.max(err);
        assert!(err <= 1e-13, "{name}: {got} vs {}", want(name));
    };
    check("delta", k.delta.re);
    for (i, axis) in ["x", "y", "z"].iter().enumerate() {
        check(&format!("{axis}1"), k.r1[i].re);
        check(&format!("{axis}2"), k.r2[i].re);
        check(&format!("{axis}3"), k.r3[i].re);
    }
    check("alpha2", k.alpha.re);
    check("beta2", k.beta.re);
    let points = &eq["points_at_datum"];
    for (name, p) in [("S", k.s), ("C", k.c), ("E", k.e)] {
        for i in 0..3 {
            let err = (p[i].re - num(&points[name][i])).abs();
            worst = worst.max(err);
            assert!(err <= 1e-13, "{name}[{i}]");
        }
    }
    // the rod's joints are l2 apart and its axis is the SPEC's u(α, β)
    let u: [f64; 3] = std::array::from_fn(|i| (k.c[i].re - k.s[i].re) / m.l2);
    let (a, b) = (k.alpha.re, k.beta.re);
    let u_ab = [-a.sin() * b.cos(), a.cos() * b.cos(), b.sin()];
    for i in 0..3 {
        assert!((u[i] - u_ab[i]).abs() <= 1e-15);
    }
    assert!((dot(u, u) - 1.0).abs() <= 1e-14);

    // the natural length that makes the datum an equilibrium, and the sensor there
    let fs = &eq["force_sensor"];
    let l0_ref = num(&fs["L0_natural_length_m"]);
    eprintln!(
        "datum: max |coordinate − reference| = {worst:.2e}; L0 = {:.17} (reference {l0_ref:.17}, Δ {:.1e} m)",
        m.l0,
        m.l0 - l0_ref
    );
    assert!((m.l0 - l0_ref).abs() <= 1e-14, "L0 = {}", m.l0);
    assert!((k.len.re - num(&fs["L_datum_m"])).abs() <= 1e-14);
    let tension = m.k_fs * (k.len.re - m.l0);
    assert!(
        (tension - num(&fs["tension_N"])).abs() <= 1e-8,
        "T = {tension}"
    );

    // at the datum at rest both accelerations vanish
    let (a_phi, a_th) = m.accelerations([phi0, 0.0, k.delta.re, 0.0], 0.0);
    assert!(
        a_phi.abs() <= 1e-9 && a_th == 0.0,
        "datum accelerations {a_phi:e}, {a_th:e}"
    );
}

#[test]
fn static_ratio_matches_the_reference_table() {
    let (header, rows) = common::read_csv(common::data("inceptor/static_ratio.csv"));
    assert_eq!(header, ["phi_deg", "delta_deg", "dphi_ddelta"]);
    assert_eq!(rows.len(), 101);
    let m = Inceptor::baseline();
    let (mut worst_delta, mut worst_ratio): (f64, f64) = (0.0, 0.0);
    for r in &rows {
        let (delta, d1, _) = m.crank_angle(r[0].to_radians());
        // the table has 10 decimals
        worst_delta = worst_delta.max((delta.to_degrees() - r[1]).abs());
        worst_ratio = worst_ratio.max((1.0 / d1 - r[2]).abs());
    }
    eprintln!("static ratio: max |Δδ| = {worst_delta:.1e} deg, max |Δ dφ/dδ| = {worst_ratio:.1e}");
    assert!(worst_delta <= 6e-11 && worst_ratio <= 6e-11);
}

#[test]
fn implicit_derivatives_match_central_differences() {
    // Only a check of the analytic implicit-function derivatives and of the jets (the
    // model itself uses no differences).
    let m = Inceptor::baseline();
    let h = 1e-5;
    let mut worst: f64 = 0.0;
    for deg in [-15.0, -1.5, 12.0, 20.0, 35.0] {
        let phi = f64::to_radians(deg);
        let k = m.kinematics(phi);
        let (kp, km) = (m.kinematics(phi + h), m.kinematics(phi - h));
        let mut close = |what: &str, a: f64, fd: f64| {
            let err = (a - fd).abs() / (1.0 + a.abs());
            worst = worst.max(err);
            assert!(err <= 1e-8, "{what} at {deg}°: {a} vs {fd}");
        };
        let cd = |f: &dyn Fn(&Kinematics) -> f64| (f(&kp) - f(&km)) / (2.0 * h);
        close("δ'", k.delta.v1, cd(&|k| k.delta.re));
        close("δ''", k.delta.v2, cd(&|k| k.delta.v1));
        close("α'", k.alpha.v1, cd(&|k| k.alpha.re));
        close("β''", k.beta.v2, cd(&|k| k.beta.v1));
        close("L''", k.len.v2, cd(&|k| k.len.v1));
        for i in 0..3 {
            close("r2'", k.r2[i].v1, cd(&|k| k.r2[i].re));
            close("r2''", k.r2[i].v2, cd(&|k| k.r2[i].v1));
        }
        let mass = |k: &Kinematics| m.mass_and_slope(k).0;
        close("m11'", m.mass_and_slope(&k).1, cd(&mass));
        // the rod's rotational term equals ½ I2 |u̇|² (Iyy = 0, Ixx = Izz)
        let u2: f64 = (0..3)
            .map(|i| ((k.c[i].v1 - k.s[i].v1) / m.l2).powi(2))
            .sum();
        let ab = k.beta.v1.powi(2) + (k.alpha.v1 * k.beta.re.cos()).powi(2);
        assert!((u2 - ab).abs() <= 1e-13 * u2, "rod rate: {u2} vs {ab}");
        // conservative part of Q_φ is −∂V/∂φ
        let (q_phi, _) = m.generalized_forces(&k, [phi, 0.0, 0.1, 0.0], 0.0);
        close("Q_φ", q_phi, -m.potential(&k, 0.1).v1);
    }
    eprintln!("implicit derivatives vs central differences: max relative error {worst:.1e}");
}

#[test]
fn natural_frequencies_match_the_reference() {
    let modes = reference("modes.json");
    let min = &modes["baseline"]["minimal"];
    let m = Inceptor {
        c_fs: 0.0,
        c_d: 0.0,
        c_t: 0.0,
        ..Inceptor::baseline()
    };
    let w = m.natural_frequencies();
    let lin = &min["linear_matrices"];
    let k = m.kinematics(Inceptor::phi0());
    let (m11, _) = m.mass_and_slope(&k);
    let kk = m.stiffness(Inceptor::phi0(), k.delta.re);
    let (mx, _) = m.mass_moments(&k);
    eprintln!(
        "minimal model at the datum: ω = {:.15}, {:.15} rad/s; m11 = {m11:.16}, K = {kk:?}, B = {:.16}",
        w[0], w[1], -mx
    );
    assert!(rel(m11, num(&lin["M"][0][0])) <= 1e-13);
    // the reference K is by central differences: agreement to its accuracy only
    for i in 0..2 {
        for j in 0..2 {
            assert!(rel(kk[i][j], num(&lin["K"][i][j])) <= 1e-9, "K[{i}][{j}]");
        }
    }
    // generalized force per unit base acceleration: −Σ m_i x_i'
    assert!(rel(-mx, num(&lin["B_per_unit_base_accel"][0])) <= 1e-13);
    for (i, mode) in min["undamped"].as_array().unwrap().iter().enumerate() {
        let want = num(&mode["omega_rad_s"]);
        eprintln!(
            "mode {i}: {:.15} vs {want:.15} (rel {:.1e})",
            w[i],
            rel(w[i], want)
        );
        assert!(rel(w[i], want) <= 1e-7, "ω{i} = {} vs {want}", w[i]);
    }
}

#[test]
fn minimal_model_conserves_energy_without_damping() {
    let m = Inceptor {
        c_fs: 0.0,
        c_d: 0.0,
        c_t: 0.0,
        ..Inceptor::baseline()
    };
    let phi0 = Inceptor::phi0();
    let y0 = [phi0 + 0.01, 0.0, m.crank_angle(phi0).0 - 0.02, 0.3];
    let times: Vec<f64> = (0..=200).map(|k| k as f64 * 0.01).collect();
    let traj = m.simulate(y0, &times, 1e-13, 1e-15);
    let e0 = m.energy(y0);
    let drift = traj
        .iter()
        .map(|y| (m.energy(*y) - e0).abs())
        .fold(0.0, f64::max);
    let swing = traj.iter().map(|y| (y[0] - phi0).abs()).fold(0.0, f64::max);
    eprintln!("undamped minimal model, 2 s: energy {e0:.9} J, drift {drift:.1e} J");
    assert!(swing > 0.005);
    assert!(
        drift <= 1e-10 * e0.abs().max(1.0),
        "energy drift {drift:e} J"
    );
}

// ---------------------------------------------------------------------------------------
// The main assertion: detune's base-excited simulation against the minimal model

fn detune_run(d0: &str, omega: &str) -> (System, Trajectory) {
    let path = format!("{}/models/inceptor.toml", env!("CARGO_MANIFEST_DIR"));
    let model = common::with_sets(Model::load(&path).unwrap(), &[("D0", d0), ("omega", omega)]);
    let sys = System::new(&model).unwrap();
    let mut start = assemble(&sys).unwrap();
    let idx = |name: &str| {
        sys.coordinate_index(name)
            .unwrap_or_else(|| panic!("no coordinate {name} in {:?}", sys.coordinates))
    };
    // The gearbox angle appears in no constraint: assembly keeps the file's guess
    // (0.1425). The datum has the shaft untwisted, θg = δ0.
    start.q[idx("gearbox.theta")] = start.q[idx("crank.delta")];
    let opts = SimOptions {
        t_end: 2.0,
        dt_out: 1e-3,
        rtol: 1e-12,
        atol: 1e-14,
        ..SimOptions::default()
    };
    let traj = simulate(&sys, &start, &opts, &mut |_| true).unwrap();
    (sys, traj)
}

fn compare_under_base_excitation(omega: f64) {
    let d0 = 0.007;
    let t0 = Instant::now();
    let (sys, traj) = detune_run(&d0.to_string(), &omega.to_string());
    let t_detune = t0.elapsed();
    let idx = |name: &str| sys.coordinate_index(name).unwrap();
    let (iphi, ith, idl) = (idx("stick.phi"), idx("gearbox.theta"), idx("crank.delta"));

    let m = Inceptor {
        d0,
        omega,
        ..Inceptor::baseline()
    };
    // detune's trimmed natural length is the minimal model's datum one
    let l0 = sys.param(sys.param_index("L0").unwrap());
    assert!(
        (l0 - m.l0).abs() <= 1e-14,
        "L0: detune {l0}, minimal {}",
        m.l0
    );

    // the same start: the datum, at rest relative to the chassis (SPEC §10.3)
    let (q0, v0) = (traj.q(0), traj.v(0));
    let phi0 = Inceptor::phi0();
    let delta0 = m.crank_angle(phi0).0;
    assert!((q0[iphi] - phi0).abs() <= 1e-15 && (q0[ith] - delta0).abs() <= 1e-14);
    for (i, c) in sys.coordinates.iter().enumerate() {
        let want = if c.ends_with(".x") { d0 * omega } else { 0.0 };
        assert!((v0[i] - want).abs() <= 1e-13, "{c}: v = {} at t = 0", v0[i]);
    }

    let t1 = Instant::now();
    let y = m.simulate([phi0, 0.0, delta0, 0.0], &traj.t, 1e-13, 1e-15);
    let t_minimal = t1.elapsed();
    let (mut dphi, mut dth, mut ddl): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let (mut swing_phi, mut swing_th): (f64, f64) = (0.0, 0.0);
    for (q, y) in traj.qs().zip(&y) {
        dphi = dphi.max((q[iphi] - y[0]).abs());
        dth = dth.max((q[ith] - y[2]).abs());
        ddl = ddl.max((q[idl] - m.crank_angle(y[0]).0).abs());
        swing_phi = swing_phi.max((y[0] - phi0).abs());
        swing_th = swing_th.max((y[2] - delta0).abs());
    }
    eprintln!(
        "D0 = {d0} m, ω = {omega} rad/s, 2 s, {} samples: max |Δφ| = {dphi:.2e} rad, \
         max |Δθg| = {dth:.2e} rad, max |Δδ| = {ddl:.2e} rad (swing φ {swing_phi:.4} rad, \
         θg {swing_th:.4} rad); detune {:.2} s ({} steps), minimal {:.2} s",
        traj.t.len(),
        t_detune.as_secs_f64(),
        traj.stats.accepted_steps,
        t_minimal.as_secs_f64()
    );
    assert_eq!(traj.t.len(), 2001);
    assert!(swing_phi > 1e-3 && swing_th > 1e-3, "the mechanism moves");
    assert!(dphi <= 1e-8, "max |φ_detune − φ_min| = {dphi:e} rad");
    assert!(dth <= 1e-8, "max |θg_detune − θg_min| = {dth:e} rad");
}

#[test]
fn base_excitation_at_the_second_resonance_matches_the_minimal_model() {
    compare_under_base_excitation(26.7);
}

#[test]
fn base_excitation_at_the_first_resonance_matches_the_minimal_model() {
    compare_under_base_excitation(13.2);
}
