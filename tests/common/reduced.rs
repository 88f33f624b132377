//! Reduced-order (one degree of freedom, θ1 only) Lagrange model of the overcentre
//! mechanism, derived by hand. It is an oracle for the tests: independent of the crate's
//! multibody formulation (no constraints, no multipliers, no automatic differentiation).
//!
//! # Geometry (planar, SI, gravity g along −Y)
//!
//! With θ = θ1, e(φ) = (cos φ, sin φ) and e⊥(φ) = (−sin φ, cos φ):
//!
//! ```text
//! e1 = e(θ),  J = L1 e1,  G1 = (L1/2) e1
//! u  = r sin θ,  r = L1/L2,  w = √(1 − u²)
//! θ2 = π − asin u          (sin θ2 = u, cos θ2 = −w, so B_x = L1 cos θ + L2 w > 0)
//! e2 = e(θ2) = (−w, u)     (unit vector of bar 2 from B toward J)
//! G2 = J − (L2/2) e2
//! P1 = G1 + m e1 = (L1/2 + m) e1
//! P2 = G2 + n e2 = L1 e1 − (L2/2 − n) e2
//! F applied at A + s e1 = s e1, vertically: F(t) = Fs + F0 sin(ω t)
//! ```
//!
//! # Derivatives with respect to θ (primes)
//!
//! ```text
//! u' = r cos θ,  u'' = −r sin θ
//! θ2'  = −u'/w
//! θ2'' = −u''/w − u u'²/w³
//! e1'  = e1⊥,             e1'' = −e1
//! e2'  = θ2' e2⊥,         e2'' = θ2'' e2⊥ − θ2'² e2
//! G1' = (L1/2) e1⊥,       G1'' = −(L1/2) e1
//! G2' = L1 e1⊥ − (L2/2) e2',   G2'' = −L1 e1 − (L2/2) e2''
//! P1' = (L1/2 + m) e1⊥,   P1'' = −(L1/2 + m) e1
//! P2' = L1 e1⊥ − (L2/2 − n) e2',   P2'' = −L1 e1 − (L2/2 − n) e2''
//! Δ = P2 − P1,  d = |Δ|,  d' = Δ·Δ'/d,  d'' = (|Δ'|² + Δ·Δ'' − d'²)/d
//! ```
//!
//! # Lagrangian and equation of motion
//!
//! ```text
//! M(θ)  = m1 |G1'|² + I1 + m2 |G2'|² + I2 θ2'²,   I_i = m_i L_i²/12
//! M'(θ) = 2 m1 G1'·G1'' + 2 m2 G2'·G2'' + 2 I2 θ2' θ2''
//! kinetic energy  T = ½ M θ̇²
//! V_gravity = g (m1 G1y + m2 G2y),   V_spring = ½ k (d − L0)²
//! Q = −g (m1 G1y' + m2 G2y') − T_s d' + F(t) s cos θ
//!     with the tension T_s = k (d − L0) + c ḋ,  ḋ = d' θ̇
//! M θ̈ + ½ M' θ̇² = Q
//! ```
//!
//! The mechanism is singular where w = 0 (bar 2 vertical, |L1 sin θ| = L2); for L1 = L2
//! that is θ = ±π/2, outside every case the tests integrate.

use differential_equations::ode::{ODE, OrdinaryNumericalMethod, solve_ode};
use differential_equations::prelude::*;
use differential_equations::solout::DefaultSolout;

/// Parameters of the overcentre mechanism (names as in `models/overcentre.toml`).
#[derive(Clone, Debug)]
pub struct Overcentre {
    /// Length of bar 1 (m).
    pub l1: f64,
    /// Length of bar 2 (m).
    pub l2: f64,
    /// Mass of bar 1 (kg).
    pub m1: f64,
    /// Mass of bar 2 (kg).
    pub m2: f64,
    /// Spring attachment offset on bar 1, from its CG toward J (m).
    pub m: f64,
    /// Spring attachment offset on bar 2, from its CG toward J (m).
    pub n: f64,
    /// Spring stiffness (N/m).
    pub k: f64,
    /// Dashpot coefficient (N·s/m).
    pub c: f64,
    /// Spring natural length (m).
    pub l0: f64,
    /// Gravity (m/s²), acting along −Y.
    pub g: f64,
    /// Position of the vertical force along bar 1, from A (m).
    pub s: f64,
    /// Static part of the vertical force (N, +Y up).
    pub fs: f64,
    /// Amplitude of the harmonic part of the force (N).
    pub f0: f64,
    /// Forcing frequency (rad/s).
    pub omega: f64,
}

/// A planar vector as `[x, y]`.
pub type V2 = [f64; 2];

fn add(a: V2, b: V2) -> V2 {
    [a[0] + b[0], a[1] + b[1]]
}
fn sub(a: V2, b: V2) -> V2 {
    [a[0] - b[0], a[1] - b[1]]
}
fn scale(k: f64, a: V2) -> V2 {
    [k * a[0], k * a[1]]
}
fn dot(a: V2, b: V2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// A point as a function of θ1: its position and first and second derivatives.
#[derive(Clone, Copy, Debug)]
pub struct Point {
    /// Position.
    pub p: V2,
    /// d/dθ1 of the position.
    pub d1: V2,
    /// d²/dθ1² of the position.
    pub d2: V2,
}

/// Everything the equations need at one θ1, with analytic derivatives.
#[derive(Clone, Copy, Debug)]
pub struct Kinematics {
    /// θ2 = π − asin(L1 sin θ1 / L2).
    pub theta2: f64,
    /// dθ2/dθ1 = −u'/w.
    pub theta2_d1: f64,
    /// d²θ2/dθ1² = −u''/w − u u'²/w³.
    pub theta2_d2: f64,
    /// Centre of mass of bar 1.
    pub g1: Point,
    /// Centre of mass of bar 2.
    pub g2: Point,
    /// Spring attachment on bar 1.
    pub p1: Point,
    /// Spring attachment on bar 2.
    pub p2: Point,
    /// Point where the vertical force acts, A + s e1.
    pub force_point: Point,
    /// Spring length d = |P2 − P1|.
    pub d: f64,
    /// dd/dθ1.
    pub d_d1: f64,
    /// d²d/dθ1².
    pub d_d2: f64,
}

/// The equations of motion as a first-order system y = (θ1, θ̇1).
struct Rhs<'a>(&'a Overcentre);

impl ODE<f64, [f64; 2]> for Rhs<'_> {
    fn diff(&self, t: f64, y: &[f64; 2], dydt: &mut [f64; 2]) {
        dydt[0] = y[1];
        dydt[1] = self.0.acceleration(y[0], y[1], t);
    }
}

impl Overcentre {
    /// The baseline case: L1 = L2 = 2√2, m1 = m2 = 1, m = n = 0, k = 50, c = 5, L0 = 2,
    /// g = 9.81, s = L1, no force (Fs = F0 = ω = 0). Start it at rest at θ1 = π/4.
    pub fn baseline() -> Self {
        let l = 2.0 * 2f64.sqrt();
        Self {
            l1: l,
            l2: l,
            m1: 1.0,
            m2: 1.0,
            m: 0.0,
            n: 0.0,
            k: 50.0,
            c: 5.0,
            l0: 2.0,
            g: 9.81,
            s: l,
            fs: 0.0,
            f0: 0.0,
            omega: 0.0,
        }
    }

    /// Centroidal inertia of bar 1, I1 = m1 L1²/12.
    pub fn i1(&self) -> f64 {
        self.m1 * self.l1 * self.l1 / 12.0
    }

    /// Centroidal inertia of bar 2, I2 = m2 L2²/12.
    pub fn i2(&self) -> f64 {
        self.m2 * self.l2 * self.l2 / 12.0
    }

    /// The applied vertical force F(t) = Fs + F0 sin(ω t) (+Y up).
    pub fn force(&self, t: f64) -> f64 {
        self.fs + self.f0 * (self.omega * t).sin()
    }

    /// Positions and analytic first and second θ1-derivatives (formulas in the module docs).
    pub fn kinematics(&self, theta: f64) -> Kinematics {
        let (sn, cs) = theta.sin_cos();
        let r = self.l1 / self.l2;
        let u = r * sn;
        let u1 = r * cs;
        let u2 = -r * sn;
        let w = (1.0 - u * u).sqrt();
        let theta2 = std::f64::consts::PI - u.asin();
        let theta2_d1 = -u1 / w;
        let theta2_d2 = -u2 / w - u * u1 * u1 / (w * w * w);

        let e1 = [cs, sn];
        let e1p = [-sn, cs]; // e1' = e1⊥
        let e1pp = scale(-1.0, e1); // e1'' = −e1
        let e2 = [-w, u]; // (cos θ2, sin θ2)
        let e2perp = [-u, -w]; // (−sin θ2, cos θ2)
        let e2p = scale(theta2_d1, e2perp);
        let e2pp = sub(scale(theta2_d2, e2perp), scale(theta2_d1 * theta2_d1, e2));

        // a point a e1 + b e2 (a, b constant along the motion)
        let on_bars = |a: f64, b: f64| Point {
            p: add(scale(a, e1), scale(b, e2)),
            d1: add(scale(a, e1p), scale(b, e2p)),
            d2: add(scale(a, e1pp), scale(b, e2pp)),
        };
        let l1 = self.l1;
        let l2 = self.l2;
        let g1 = on_bars(l1 / 2.0, 0.0);
        let g2 = on_bars(l1, -l2 / 2.0);
        let p1 = on_bars(l1 / 2.0 + self.m, 0.0);
        let p2 = on_bars(l1, -(l2 / 2.0 - self.n));
        let force_point = on_bars(self.s, 0.0);

        let delta = sub(p2.p, p1.p);
        let delta1 = sub(p2.d1, p1.d1);
        let delta2 = sub(p2.d2, p1.d2);
        let d = dot(delta, delta).sqrt();
        let d_d1 = dot(delta, delta1) / d;
        let d_d2 = (dot(delta1, delta1) + dot(delta, delta2) - d_d1 * d_d1) / d;

        Kinematics {
            theta2,
            theta2_d1,
            theta2_d2,
            g1,
            g2,
            p1,
            p2,
            force_point,
            d,
            d_d1,
            d_d2,
        }
    }

    /// Generalized mass M(θ1) = m1|G1'|² + I1 + m2|G2'|² + I2 θ2'².
    pub fn mass(&self, theta: f64) -> f64 {
        self.mass_and_slope(&self.kinematics(theta)).0
    }

    /// dM/dθ1 = 2 m1 G1'·G1'' + 2 m2 G2'·G2'' + 2 I2 θ2' θ2''.
    pub fn mass_slope(&self, theta: f64) -> f64 {
        self.mass_and_slope(&self.kinematics(theta)).1
    }

    fn mass_and_slope(&self, k: &Kinematics) -> (f64, f64) {
        let mass = self.m1 * dot(k.g1.d1, k.g1.d1)
            + self.i1()
            + self.m2 * dot(k.g2.d1, k.g2.d1)
            + self.i2() * k.theta2_d1 * k.theta2_d1;
        let slope = 2.0 * self.m1 * dot(k.g1.d1, k.g1.d2)
            + 2.0 * self.m2 * dot(k.g2.d1, k.g2.d2)
            + 2.0 * self.i2() * k.theta2_d1 * k.theta2_d2;
        (mass, slope)
    }

    /// Generalized gravity force −g (m1 G1y' + m2 G2y') = −dV_gravity/dθ1.
    pub fn gravity_force(&self, theta: f64) -> f64 {
        let k = self.kinematics(theta);
        -self.g * (self.m1 * k.g1.d1[1] + self.m2 * k.g2.d1[1])
    }

    /// Spring–dashpot tension T = k (d − L0) + c ḋ with ḋ = d' θ̇ (positive pulls P1, P2 together).
    pub fn tension(&self, theta: f64, theta_dot: f64) -> f64 {
        let k = self.kinematics(theta);
        self.k * (k.d - self.l0) + self.c * k.d_d1 * theta_dot
    }

    /// Total generalized force Q(θ1, θ̇1, t) = −g (m1 G1y' + m2 G2y') − T d' + F(t) s cos θ1.
    pub fn generalized_force(&self, theta: f64, theta_dot: f64, t: f64) -> f64 {
        self.generalized_force_at(&self.kinematics(theta), theta_dot, self.force(t))
    }

    fn generalized_force_at(&self, k: &Kinematics, theta_dot: f64, force: f64) -> f64 {
        let gravity = -self.g * (self.m1 * k.g1.d1[1] + self.m2 * k.g2.d1[1]);
        let tension = self.k * (k.d - self.l0) + self.c * k.d_d1 * theta_dot;
        gravity - tension * k.d_d1 + force * k.force_point.d1[1]
    }

    /// Static generalized force balance Q(θ1, 0) with the force held at Fs (zero at an
    /// equilibrium of the static problem).
    pub fn static_residual(&self, theta: f64) -> f64 {
        self.generalized_force_at(&self.kinematics(theta), 0.0, self.fs)
    }

    /// The static force Fs that holds the mechanism in equilibrium at θ1 (F0 ignored):
    /// Fs = −Q(θ1, 0 | F = 0) / (s cos θ1).
    pub fn static_force(&self, theta: f64) -> f64 {
        let k = self.kinematics(theta);
        -self.generalized_force_at(&k, 0.0, 0.0) / k.force_point.d1[1]
    }

    /// θ̈1 = (Q − ½ M' θ̇1²) / M.
    pub fn acceleration(&self, theta: f64, theta_dot: f64, t: f64) -> f64 {
        let k = self.kinematics(theta);
        let (mass, slope) = self.mass_and_slope(&k);
        let q = self.generalized_force_at(&k, theta_dot, self.force(t));
        (q - 0.5 * slope * theta_dot * theta_dot) / mass
    }

    /// Kinetic energy ½ M(θ1) θ̇1².
    pub fn kinetic_energy(&self, theta: f64, theta_dot: f64) -> f64 {
        0.5 * self.mass(theta) * theta_dot * theta_dot
    }

    /// Potential energy g (m1 G1y + m2 G2y) + ½ k (d − L0)² (the applied force is not included).
    pub fn potential_energy(&self, theta: f64) -> f64 {
        let k = self.kinematics(theta);
        let stretch = k.d - self.l0;
        self.g * (self.m1 * k.g1.p[1] + self.m2 * k.g2.p[1]) + 0.5 * self.k * stretch * stretch
    }

    /// Total energy T + V_gravity + V_spring; conserved when c = 0 and F ≡ 0.
    pub fn energy(&self, theta: f64, theta_dot: f64) -> f64 {
        self.kinetic_energy(theta, theta_dot) + self.potential_energy(theta)
    }

    /// θ1(t) at the requested times, starting from rest at `theta0` at t = 0
    /// (times ascending and ≥ 0; the first may be 0).
    pub fn simulate(&self, theta0: f64, times: &[f64], rtol: f64, atol: f64) -> Vec<f64> {
        self.simulate_with_rate(theta0, 0.0, times, rtol, atol)
            .into_iter()
            .map(|(th, _)| th)
            .collect()
    }

    /// (θ1, θ̇1) at the requested times, starting from (`theta0`, `theta_dot0`) at t = 0
    /// (times ascending and ≥ 0; the first may be 0). DOP853 (rtol, atol).
    ///
    /// The integration is restarted at every requested time, so each output is a step end
    /// point and no dense output is used: the DOP853 interpolant of `differential-equations`
    /// 0.7.0 evaluates the higher-order part of Hairer's `contd8` polynomial with the
    /// factors s and 1 − s swapped, which costs accuracy far above these tolerances. The
    /// step size proposed at the end of a segment (clipped to the next segment) seeds the
    /// next one.
    pub fn simulate_with_rate(
        &self,
        theta0: f64,
        theta_dot0: f64,
        times: &[f64],
        rtol: f64,
        atol: f64,
    ) -> Vec<(f64, f64)> {
        assert!(
            times.windows(2).all(|w| w[0] <= w[1]),
            "times must be ascending"
        );
        assert!(times.first().is_none_or(|&t| t >= 0.0), "times must be ≥ 0");
        let rhs = Rhs(self);
        let mut t = 0.0;
        let mut y = [theta0, theta_dot0];
        let mut h: Option<f64> = None;
        let mut out = Vec::with_capacity(times.len());
        for &t_next in times {
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
                    .unwrap_or_else(|e| panic!("reduced model integration failed: {e:?}"));
                let (&t_end, &y_end) = solution.last().expect("at least one step");
                assert!(
                    (t_end - t_next).abs() <= 1e-12 * t_next.max(1.0),
                    "segment ends at {t_end}, not {t_next}"
                );
                h = Some(solver.h());
                t = t_next;
                y = y_end;
            }
            out.push((y[0], y[1]));
        }
        out
    }
}

impl Overcentre {
    /// The oracle with the parameters of a loaded overcentre model.
    pub fn from_model(model: &detune::Model) -> Self {
        let p = |n: &str| model.parameters.value(n).unwrap();
        Overcentre {
            l1: p("L1"),
            l2: p("L2"),
            m1: p("m1"),
            m2: p("m2"),
            m: p("m"),
            n: p("n"),
            k: p("k"),
            c: p("c"),
            l0: p("L0"),
            g: p("g"),
            s: p("s"),
            fs: p("Fs"),
            f0: p("F0"),
            omega: p("omega"),
        }
    }
}
