//! Element-level checks of the compiled equations (`src/system/`): one small model per
//! joint kind (each body–body and body–ground), a custom constraint, joints to a moving
//! ground, and one per force kind, evaluated at deterministic pseudo-random states
//! (q, v, t) that are nowhere near an assembled pose.
//!
//! What is checked against what:
//!
//! * Φ(q, t) against the rows of `docs/model-format.md` written out here (closed form);
//! * A = ∂Φ/∂q (dual numbers) against central differences of Φ in each coordinate;
//! * b (a second-order dual pass) against its definition −d²/ds² Φ(q + s·v, t + s) at
//!   s = 0 by a central second difference, and against −d/ds [A v + Φ_t] along the same
//!   motion by a central first difference (A and Φ_t themselves checked above);
//! * Φ_t against a central difference of Φ in t, and the row names against the
//!   documented `<joint>.x`, `.y`, `.slot`, `.angle`;
//! * gravity and springs (c = 0) against −∇V, V the potential energy, by central
//!   differences; dampers, point forces and a spring–damper to a moving-ground anchor
//!   against closed forms; the damping matrix ∂f/∂v (by differences) symmetric negative
//!   semi-definite, of rank one per damper, with the closed-form trace;
//! * the null space of A at assembled poses: its dimension n − rank against the degrees
//!   of freedom of small mechanisms counted by hand (Grübler).
//!
//! Errors are normalized as |got − want|∞ / (1 + |want|∞): relative for quantities above
//! 1, absolute below (the models' lengths are O(1) m, so 1 is their natural scale, and the
//! rounding errors of a difference scale with |Φ| ~ 1 rather than with the derivative).
//! Each test prints its worst errors (`--nocapture`).

mod common;

use detune::system::Workspace;
use detune::{Model, System, assemble};
use nalgebra::{DMatrix, DVector, SymmetricEigen};
use num_dual::Dual64;
use std::f64::consts::PI;

// ---- shared helpers: states, differences, errors --------------------------------------

/// Step of the central first differences. The truncation error is h²/6·|f'''| ≈ 5e-10
/// for |f'''| ≲ 30 (unit lengths; rates up to 1.5 rad/s from v plus the time rates of the
/// expressions, cubed), the rounding error ε·|f|/h ≈ 1e-10 for |f| ≲ 5: h = 1e-5 is near
/// the optimum ε^(1/3), and the total is ≲ 6e-10.
const H1: f64 = 1e-5;
/// Tolerance of a first difference: 15× the error bound above.
const TOL_D1: f64 = 1e-8;
/// Step of the central second difference. The truncation error is h²/12·|f''''| ≈ 1e-7
/// for |f''''| ≲ 30 (speeds up to 1.5 plus the unit time rate, to the fourth power,
/// times unit lengths), the rounding error 4ε·|f|/h² ≈ 1e-7 for |f| ≲ 5: h = 2e-4 is near
/// the optimum ε^(1/4)·(48|f|/|f''''|)^(1/4), and the total ≈ 2e-7.
const H2: f64 = 2e-4;
/// Tolerance of a second difference: 5× the bound above (the bound is a worst case; the
/// errors seen are an order of magnitude smaller).
const TOL_D2: f64 = 1e-6;
/// Tolerance of a closed form: the same formula evaluated in another order, so only
/// rounding (a few ulps of the largest term, ≲ 1e-14 at these magnitudes) separates them.
const TOL_EXACT: f64 = 1e-12;

/// A deterministic pseudo-random sequence (Knuth's MMIX linear congruential generator).
struct Lcg(u64);

impl Lcg {
    /// Uniform in [lo, hi), from the top 53 bits.
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// A state at which the equations are evaluated.
struct St {
    q: Vec<f64>,
    v: Vec<f64>,
    t: f64,
}

/// Number of states per element test.
const STATES: usize = 16;

/// `STATES` states: positions in [−1, 1] m, angles in [−π, π], velocities in [−1.5, 1.5]
/// (m/s, rad/s), t in [0, 4] s. Not assembled: the derivative checks hold everywhere.
fn states(sys: &System, seed: u64) -> Vec<St> {
    let mut r = Lcg(seed);
    (0..STATES)
        .map(|_| {
            let q = (0..sys.n())
                .map(|i| {
                    if sys.is_angle(i) {
                        r.uniform(-PI, PI)
                    } else {
                        r.uniform(-1.0, 1.0)
                    }
                })
                .collect();
            let v = (0..sys.n()).map(|_| r.uniform(-1.5, 1.5)).collect();
            St {
                q,
                v,
                t: r.uniform(0.0, 4.0),
            }
        })
        .collect()
}

/// x + s·dir.
fn shifted(x: &[f64], dir: &[f64], s: f64) -> Vec<f64> {
    x.iter().zip(dir).map(|(a, d)| a + s * d).collect()
}

/// The j-th unit vector of length n.
fn unit(n: usize, j: usize) -> Vec<f64> {
    let mut e = vec![0.0; n];
    e[j] = 1.0;
    e
}

/// d/ds f(s) at s = 0 by the central first difference (f(h) − f(−h)) / 2h.
fn d1(mut f: impl FnMut(f64) -> DVector<f64>, h: f64) -> DVector<f64> {
    (f(h) - f(-h)) / (2.0 * h)
}

/// d²/ds² f(s) at s = 0 by the central second difference (f(h) − 2f(0) + f(−h)) / h².
fn d2(mut f: impl FnMut(f64) -> DVector<f64>, h: f64) -> DVector<f64> {
    (f(h) - 2.0 * f(0.0) + f(-h)) / (h * h)
}

/// The Jacobian of g at x by central first differences, column by column.
fn jacobian_fd(g: impl Fn(&[f64]) -> DVector<f64>, x: &[f64], h: f64) -> DMatrix<f64> {
    let cols: Vec<DVector<f64>> = (0..x.len())
        .map(|j| d1(|s| g(&shifted(x, &unit(x.len(), j), s)), h))
        .collect();
    DMatrix::from_columns(&cols)
}

/// |got − want|∞ / (1 + |want|∞) (see the module comment).
fn err(got: &[f64], want: &[f64]) -> f64 {
    assert_eq!(got.len(), want.len());
    let diff = got
        .iter()
        .zip(want)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    let scale = want.iter().fold(0.0f64, |m, b| m.max(b.abs()));
    diff / (1.0 + scale)
}

fn model(text: &str) -> Model {
    Model::from_str("element.toml", text).unwrap_or_else(|e| panic!("{e:?}\n{text}"))
}

fn system(text: &str) -> System {
    System::new(&model(text)).unwrap_or_else(|e| panic!("{e:?}\n{text}"))
}

/// Planar bodies `names` (mass 1.5 kg, inertia 0.2 kg·m², at the origin) as TOML.
fn bodies(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!("[[bodies]]\nname = \"{n}\"\nmass = 1.5\ninertia = 0.2\n\n"))
        .collect()
}

/// The generalized forces f(q, v, t).
fn forces(sys: &System, q: &[f64], v: &[f64], t: f64) -> DVector<f64> {
    let mut f = vec![0.0; sys.n()];
    sys.forces(q, v, t, &mut f);
    DVector::from_vec(f)
}

// ---- closed forms: points, frames ----------------------------------------------------

type V2 = [f64; 2];

/// R(θ) p.
fn rot(theta: f64, p: V2) -> V2 {
    let (s, c) = theta.sin_cos();
    [c * p[0] - s * p[1], s * p[0] + c * p[1]]
}

fn sub(a: V2, b: V2) -> V2 {
    [a[0] - b[0], a[1] - b[1]]
}

fn dot(a: V2, b: V2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// The z component of a × b.
fn cross(a: V2, b: V2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// World position r + R(θ) p of body point p, the body's coordinates at offset o.
fn at(q: &[f64], o: usize, p: V2) -> V2 {
    let a = rot(q[o + 2], p);
    [q[o] + a[0], q[o + 1] + a[1]]
}

/// World velocity ṙ + ω × R(θ) p of body point p.
fn vel(q: &[f64], v: &[f64], o: usize, p: V2) -> V2 {
    let a = rot(q[o + 2], p);
    [v[o] - v[o + 2] * a[1], v[o + 1] + v[o + 2] * a[0]]
}

/// The slot normal (−ay, ax)/|a| of an axis, in the frame of body 2.
fn normal(axis: V2) -> V2 {
    let l = axis[0].hypot(axis[1]);
    [-axis[1] / l, axis[0] / l]
}

/// Generalized force of a world force F at body point p: (Fx, Fy, (R p) × F).
fn apply(q: &[f64], o: usize, p: V2, f: V2, out: &mut [f64]) {
    let a = rot(q[o + 2], p);
    out[o] += f[0];
    out[o + 1] += f[1];
    out[o + 2] += cross(a, f);
}

// The moving ground of the moving-ground tests:
// x = X0 sin ωt, y = Y0 (1 − cos 2ωt), θ = TH0 sin(ωt + 0.3).
const GROUND_MOTION: &str = r#"
[ground]
motion = { x = "X0*sin(w*t)", y = "Y0*(1 - cos(2*w*t))", theta = "TH0*sin(w*t + 0.3)" }
"#;
const X0: f64 = 0.3;
const Y0: f64 = 0.2;
const TH0: f64 = 0.5;
const W: f64 = 1.7;
const GROUND_PARAMETERS: &str = "X0 = 0.3\nY0 = 0.2\nTH0 = 0.5\nw = 1.7\n";

/// The ground's origin and angle at t.
fn ground_pose(t: f64) -> (V2, f64) {
    (
        [X0 * (W * t).sin(), Y0 * (1.0 - (2.0 * W * t).cos())],
        TH0 * (W * t + 0.3).sin(),
    )
}

/// The ground's velocity and angular velocity at t (the derivatives of `ground_pose`).
fn ground_rate(t: f64) -> (V2, f64) {
    (
        [X0 * W * (W * t).cos(), 2.0 * Y0 * W * (2.0 * W * t).sin()],
        TH0 * W * (W * t + 0.3).cos(),
    )
}

/// World position of ground point p at t.
fn ground_at(t: f64, p: V2) -> V2 {
    let (r, th) = ground_pose(t);
    let a = rot(th, p);
    [r[0] + a[0], r[1] + a[1]]
}

/// World velocity of ground point p at t.
fn ground_vel(t: f64, p: V2) -> V2 {
    let (_, th) = ground_pose(t);
    let (rv, w) = ground_rate(t);
    let a = rot(th, p);
    [rv[0] - w * a[1], rv[1] + w * a[0]]
}

// ---- the constraint checks, written once ---------------------------------------------

/// Worst normalized errors of one system's constraint equations.
#[derive(Debug, Default)]
struct Worst {
    phi: f64,
    a: f64,
    b_def: f64,
    b_av: f64,
    phi_t: f64,
}

/// Checks Φ against `closed` (Φ by the documented rows), A, b and Φ_t against
/// differences, at `STATES` states from `seed`; panics on the first failure, prints the
/// worst errors.
fn check_constraints(
    label: &str,
    sys: &System,
    closed: impl Fn(&[f64], f64) -> Vec<f64>,
    seed: u64,
) {
    let (n, m) = (sys.n(), sys.m());
    let mut ws = Workspace::new(sys);
    let mut a = DMatrix::zeros(m, n);
    let mut b = DVector::zeros(m);
    let mut phi_t = DVector::zeros(m);
    let mut w = Worst::default();
    for (k, s) in states(sys, seed).iter().enumerate() {
        let (q, v, t) = (&s.q[..], &s.v[..], s.t);
        let at_state = format!("{label}, state {k}: q = {q:?}, v = {v:?}, t = {t}");

        let phi = sys.residual(q, t);
        let want = closed(q, t);
        let e = err(phi.as_slice(), &want);
        assert!(
            e <= TOL_EXACT,
            "{at_state}\nΦ {phi} vs closed form {want:?} ({e:e})"
        );
        w.phi = w.phi.max(e);

        sys.jacobian(&mut ws, q, t, &mut a);
        let a_fd = jacobian_fd(|x| sys.residual(x, t), q, H1);
        let e = err(a.as_slice(), a_fd.as_slice());
        assert!(
            e <= TOL_D1,
            "{at_state}\nA {a} vs differences {a_fd} ({e:e})"
        );
        w.a = w.a.max(e);

        // the hand-written planar joint columns against one Dual64 pass through Φ per
        // coordinate: the same numbers, to the last bit
        if !sys.spatial {
            for j in 0..n {
                let qd: Vec<Dual64> = (0..n)
                    .map(|i| Dual64::new(q[i], if i == j { 1.0 } else { 0.0 }))
                    .collect();
                let mut out = vec![Dual64::from(0.0); m];
                sys.phi(&qd, Dual64::from(t), &mut out);
                let col: Vec<f64> = out.iter().map(|x| x.eps).collect();
                assert!(
                    a.column(j).iter().zip(&col).all(|(x, y)| x == y),
                    "{at_state}\nA column {j} {} vs dual numbers {col:?}",
                    a.column(j)
                );
                // the entries the constraint solve skips as zero at every pose are
                // zero here too, by the dual pass
                for &(r, jj) in &sys.structural_zeros() {
                    if jj == j {
                        assert!(
                            col[r] == 0.0,
                            "{at_state}\nA[{r}, {j}] = {} is not a structural zero",
                            col[r]
                        );
                    }
                }
            }
        }

        sys.phi_t(&mut ws, q, t, &mut phi_t);
        let pt_fd = d1(|s| sys.residual(q, t + s), H1);
        let e = err(phi_t.as_slice(), pt_fd.as_slice());
        assert!(
            e <= TOL_D1,
            "{at_state}\nΦ_t {phi_t} vs differences {pt_fd} ({e:e})"
        );
        w.phi_t = w.phi_t.max(e);

        // b = −d²/ds² Φ(q + s v, t + s): the definition, by a second difference
        sys.bias(&mut ws, q, v, t, &mut b);
        let b_def = -d2(|s| sys.residual(&shifted(q, v, s), t + s), H2);
        let e = err(b.as_slice(), b_def.as_slice());
        assert!(
            e <= TOL_D2,
            "{at_state}\nb {b} vs −Φ'' by differences {b_def} ({e:e})"
        );
        w.b_def = w.b_def.max(e);

        // b = −d/ds [A(q + s v, t + s) v + Φ_t(q + s v, t + s)]: the velocity constraint
        // differentiated along the motion, by a first difference of A and Φ_t
        let mut ah = DMatrix::zeros(m, n);
        let mut pth = DVector::zeros(m);
        let vv = DVector::from_column_slice(v);
        let b_av = -d1(
            |s| {
                let qs = shifted(q, v, s);
                sys.jacobian(&mut ws, &qs, t + s, &mut ah);
                sys.phi_t(&mut ws, &qs, t + s, &mut pth);
                &ah * &vv + &pth
            },
            H1,
        );
        let e = err(b.as_slice(), b_av.as_slice());
        assert!(
            e <= TOL_D1,
            "{at_state}\nb {b} vs −d(A v + Φ_t)/ds by differences {b_av} ({e:e})"
        );
        w.b_av = w.b_av.max(e);
    }
    eprintln!("{label}: worst errors {w:?}");
}

fn names(sys: &System) -> Vec<&str> {
    sys.constraint_names.iter().map(|s| s.as_str()).collect()
}

// ---- joints ----------------------------------------------------------------------------

#[test]
fn revolute_body_ground_and_body_body() {
    let text = format!(
        r#"
[parameters]
a = 0.4
{}
[[joints]]
name = "g"
type = "revolute"
body1 = "b1"
point1 = ["a", -0.2]
body2 = "ground"
point2 = [0.1, 0.3]

[[joints]]
name = "bb"
type = "revolute"
body1 = "b2"
point1 = [-0.3, 0.25]
body2 = "b1"
point2 = ["-a", 0.15]
"#,
        bodies(&["b1", "b2"])
    );
    let sys = system(&text);
    assert_eq!(names(&sys), ["g.x", "g.y", "bb.x", "bb.y"]);
    assert!(!sys.rheonomic);
    check_constraints(
        "revolute",
        &sys,
        |q, _| {
            let g = sub(at(q, 0, [0.4, -0.2]), [0.1, 0.3]);
            let bb = sub(at(q, 3, [-0.3, 0.25]), at(q, 0, [-0.4, 0.15]));
            vec![g[0], g[1], bb[0], bb[1]]
        },
        1,
    );
}

#[test]
fn pin_in_slot_with_oblique_axes_to_ground_and_between_bodies() {
    // body2 = ground (fixed normal), body–body (the normal turns with b1), and ground as
    // body1 (the normal turns with b2; the ground point slides in b2's slot)
    let text = format!(
        r#"
[parameters]
ax = 3
{}
[[joints]]
name = "g"
type = "pin_in_slot"
body1 = "b1"
point1 = [0.35, -0.1]
body2 = "ground"
point2 = [0.2, -0.4]
axis = [1, 2]

[[joints]]
name = "bb"
type = "pin_in_slot"
body1 = "b2"
point1 = [-0.3, 0.2]
body2 = "b1"
point2 = [0.1, 0.45]
axis = ["ax", -1]

[[joints]]
name = "gb"
type = "pin_in_slot"
body1 = "ground"
point1 = [0.5, 0.25]
body2 = "b2"
point2 = [0.15, -0.3]
axis = [-0.6, 0.8]
"#,
        bodies(&["b1", "b2"])
    );
    let sys = system(&text);
    assert_eq!(names(&sys), ["g.slot", "bb.slot", "gb.slot"]);
    check_constraints(
        "pin_in_slot",
        &sys,
        |q, _| {
            let g = dot(normal([1.0, 2.0]), sub(at(q, 0, [0.35, -0.1]), [0.2, -0.4]));
            let n = rot(q[2], normal([3.0, -1.0]));
            let bb = dot(n, sub(at(q, 3, [-0.3, 0.2]), at(q, 0, [0.1, 0.45])));
            let n = rot(q[5], normal([-0.6, 0.8]));
            let gb = dot(n, sub([0.5, 0.25], at(q, 3, [0.15, -0.3])));
            vec![g, bb, gb]
        },
        2,
    );
}

#[test]
fn prismatic_to_ground_and_between_bodies() {
    let text = format!(
        r#"
[parameters]
alpha = 0.3
{}
[[joints]]
name = "g"
type = "prismatic"
body1 = "b1"
point1 = [0.35, -0.1]
body2 = "ground"
point2 = [0.2, -0.4]
axis = [2, -1]
angle = "alpha"

[[joints]]
name = "bb"
type = "prismatic"
body1 = "b2"
point1 = [-0.3, 0.2]
body2 = "b1"
point2 = [0.1, 0.45]
axis = [1, 1]
angle = -0.7

[[joints]]
name = "gb"
type = "prismatic"
body1 = "ground"
point1 = [0.5, 0.25]
body2 = "b2"
point2 = [0.15, -0.3]
axis = [0.3, 1]
angle = 1.1
"#,
        bodies(&["b1", "b2"])
    );
    let sys = system(&text);
    assert_eq!(
        names(&sys),
        [
            "g.slot", "g.angle", "bb.slot", "bb.angle", "gb.slot", "gb.angle"
        ]
    );
    check_constraints(
        "prismatic",
        &sys,
        |q, _| {
            let g = dot(
                normal([2.0, -1.0]),
                sub(at(q, 0, [0.35, -0.1]), [0.2, -0.4]),
            );
            let n = rot(q[2], normal([1.0, 1.0]));
            let bb = dot(n, sub(at(q, 3, [-0.3, 0.2]), at(q, 0, [0.1, 0.45])));
            let n = rot(q[5], normal([0.3, 1.0]));
            let gb = dot(n, sub([0.5, 0.25], at(q, 3, [0.15, -0.3])));
            vec![g, q[2] - 0.3, bb, q[5] - q[2] + 0.7, gb, -q[5] - 1.1]
        },
        3,
    );
}

#[test]
fn fixed_at_an_angle_to_ground_and_between_bodies() {
    // the body–body joint is unnamed: its rows are `joint2.*`
    let text = format!(
        r#"
[parameters]
px = -0.25
{}
[[joints]]
name = "g"
type = "fixed"
body1 = "b1"
point1 = ["px", 0.3]
body2 = "ground"
point2 = [0.6, -0.2]
angle = 0.5

[[joints]]
type = "fixed"
body1 = "b1"
point1 = [0.4, 0.1]
body2 = "b2"
point2 = [-0.2, "px"]
angle = "-1.2 rad"
"#,
        bodies(&["b1", "b2"])
    );
    let sys = system(&text);
    assert_eq!(
        names(&sys),
        [
            "g.x",
            "g.y",
            "g.angle",
            "joint2.x",
            "joint2.y",
            "joint2.angle"
        ]
    );
    check_constraints(
        "fixed",
        &sys,
        |q, _| {
            let g = sub(at(q, 0, [-0.25, 0.3]), [0.6, -0.2]);
            let bb = sub(at(q, 0, [0.4, 0.1]), at(q, 3, [-0.2, -0.25]));
            vec![g[0], g[1], q[2] - 0.5, bb[0], bb[1], q[2] - q[5] + 1.2]
        },
        4,
    );
}

#[test]
fn custom_constraints_in_coordinates_parameters_and_time() {
    let text = format!(
        r#"
[parameters]
a = 0.7
w = 2.3
L = 0.4
{}
[[constraints]]
name = "drive"
expr = "b1.x*cos(b2.theta) - a*b2.y^2 + sin(w*t)*b1.theta - L"

[[constraints]]
expr = "b1.y*b2.x - exp(-t/2)*cos(b1.theta + w*t)"
"#,
        bodies(&["b1", "b2"])
    );
    let sys = system(&text);
    assert_eq!(names(&sys), ["drive", "constraint2"]);
    assert!(sys.rheonomic);
    check_constraints(
        "custom",
        &sys,
        |q, t| {
            vec![
                q[0] * q[5].cos() - 0.7 * q[4] * q[4] + (2.3 * t).sin() * q[2] - 0.4,
                q[1] * q[3] - (-t / 2.0).exp() * (q[2] + 2.3 * t).cos(),
            ]
        },
        5,
    );
}

/// Four bodies jointed to a ground moving in x, y and θ: a revolute, a pin-in-slot (the
/// slot turns with the ground), a prismatic with the ground as body 1, a fixed joint.
fn moving_ground_joints() -> String {
    format!(
        r#"
[parameters]
{GROUND_PARAMETERS}
{GROUND_MOTION}
{}
[[joints]]
name = "rev"
type = "revolute"
body1 = "b1"
point1 = [0.2, -0.1]
body2 = "ground"
point2 = [0.4, 0.1]

[[joints]]
name = "slot"
type = "pin_in_slot"
body1 = "b2"
point1 = [0.1, 0.2]
body2 = "ground"
point2 = [-0.3, 0.2]
axis = [1, 2]

[[joints]]
name = "pri"
type = "prismatic"
body1 = "ground"
point1 = [0.5, -0.2]
body2 = "b3"
point2 = [0.1, 0]
axis = [2, -1]
angle = 0.3

[[joints]]
name = "fix"
type = "fixed"
body1 = "b4"
point1 = [0.2, 0.3]
body2 = "ground"
point2 = [0, -0.5]
angle = -0.4
"#,
        bodies(&["b1", "b2", "b3", "b4"])
    )
}

#[test]
fn joints_to_a_ground_moving_in_x_y_and_theta() {
    let sys = system(&moving_ground_joints());
    assert_eq!(
        names(&sys),
        [
            "rev.x",
            "rev.y",
            "slot.slot",
            "pri.slot",
            "pri.angle",
            "fix.x",
            "fix.y",
            "fix.angle"
        ]
    );
    assert!(sys.rheonomic);
    check_constraints(
        "moving ground",
        &sys,
        |q, t| {
            let th_g = ground_pose(t).1;
            let rev = sub(at(q, 0, [0.2, -0.1]), ground_at(t, [0.4, 0.1]));
            let n = rot(th_g, normal([1.0, 2.0]));
            let slot = dot(n, sub(at(q, 3, [0.1, 0.2]), ground_at(t, [-0.3, 0.2])));
            let n = rot(q[8], normal([2.0, -1.0]));
            let pri = dot(n, sub(ground_at(t, [0.5, -0.2]), at(q, 6, [0.1, 0.0])));
            let fix = sub(at(q, 9, [0.2, 0.3]), ground_at(t, [0.0, -0.5]));
            vec![
                rev[0],
                rev[1],
                slot,
                pri,
                th_g - q[8] - 0.3,
                fix[0],
                fix[1],
                q[11] - th_g + 0.4,
            ]
        },
        6,
    );
    // Φ_t is not identically 0 here (else its check above could not fail): at rest
    // relative to the world, the rows move with the ground.
    let mut ws = Workspace::new(&sys);
    let mut pt = DVector::zeros(sys.m());
    sys.phi_t(&mut ws, &[0.1; 12], 0.7, &mut pt);
    assert!(pt.amax() > 0.1, "Φ_t = {pt}");

    // A body carried rigidly by the ground (`ground_velocity`) turns every row with the
    // ground: A v_g + Φ_t = ω × (P1 − P2) = (−ω Φ_y, ω Φ_x) on position rows, and 0 on slot
    // rows (n and P1 − P2 turn together) and angle rows (both sides turn at ω).
    let mut a = DMatrix::zeros(sys.m(), sys.n());
    let mut worst = 0.0f64;
    for (k, s) in states(&sys, 12).iter().enumerate() {
        let (q, t) = (&s.q[..], s.t);
        let vg = DVector::from_vec(sys.ground_velocity(q, t));
        sys.jacobian(&mut ws, q, t, &mut a);
        sys.phi_t(&mut ws, q, t, &mut pt);
        let rate = &a * &vg + &pt;
        let phi = sys.residual(q, t);
        let w = ground_rate(t).1;
        let want = [
            -w * phi[1],
            w * phi[0],
            0.0,
            0.0,
            0.0,
            -w * phi[6],
            w * phi[5],
            0.0,
        ];
        let e = err(rate.as_slice(), &want);
        assert!(
            e <= TOL_EXACT,
            "state {k}: A v_g + Φ_t = {rate} vs {want:?} ({e:e})"
        );
        worst = worst.max(e);
    }
    eprintln!("moving ground: worst error of A v_g + Φ_t vs ω × Φ {worst:e}");
}

// ---- forces ----------------------------------------------------------------------------

// ---- b by hand against the dual pass, bit for bit -------------------------------------

/// Every planar joint type, each between two bodies and with the ground as body 1 and as
/// body 2, with zero coefficients (a point at a frame's origin, axes along x and y, so
/// normals with a zero component), beside a custom constraint.
fn every_planar_joint() -> String {
    bodies(&["b1", "b2", "b3"])
        + &joints(&[
            [
                "r1",
                "revolute",
                "b1",
                "[0.2, -0.1]",
                "ground",
                "[0.4, 0.1]",
                "",
            ],
            ["r2", "revolute", "b2", "[0, 0]", "b1", "[-0.3, 0]", ""],
            [
                "r3",
                "revolute",
                "ground",
                "[0, 0]",
                "b3",
                "[0.1, 0.25]",
                "",
            ],
            [
                "s1",
                "pin_in_slot",
                "b1",
                "[0.1, 0.2]",
                "ground",
                "[0, 0]",
                "axis = [1, 0]",
            ],
            [
                "s2",
                "pin_in_slot",
                "b3",
                "[0, 0.3]",
                "b2",
                "[0.2, -0.1]",
                "axis = [1, 2]",
            ],
            [
                "s3",
                "pin_in_slot",
                "ground",
                "[0.5, -0.2]",
                "b2",
                "[0, 0]",
                "axis = [0, 1]",
            ],
            [
                "p1",
                "prismatic",
                "b2",
                "[0.1, 0]",
                "ground",
                "[-0.3, 0.2]",
                "axis = [2, -1]\nangle = 0.3",
            ],
            [
                "p2",
                "prismatic",
                "b1",
                "[0, 0]",
                "b3",
                "[0.15, -0.3]",
                "axis = [0, 1]\nangle = 0",
            ],
            [
                "p3",
                "prismatic",
                "ground",
                "[0, 0]",
                "b3",
                "[0.1, 0]",
                "axis = [1, 0]\nangle = -1.1",
            ],
            [
                "f1",
                "fixed",
                "b3",
                "[0.2, 0.3]",
                "ground",
                "[0, -0.5]",
                "angle = -0.4",
            ],
            [
                "f2",
                "fixed",
                "b1",
                "[0.4, 0.1]",
                "b2",
                "[0, 0]",
                "angle = 0",
            ],
            [
                "f3",
                "fixed",
                "ground",
                "[0, 0]",
                "b1",
                "[0, 0]",
                "angle = 0.7",
            ],
        ])
        + "[[constraints]]\nname = \"c\"\nexpr = \"b1.x*b2.theta - b3.y + sin(t)\"\n"
}

/// The states of [`states`] and some where zeros meet: bodies at rest, not turning
/// (ω = +0 and −0), at angles 0, ±π/2, π and −0, at the origin.
fn states_with_zeros(sys: &System, seed: u64) -> Vec<St> {
    let mut all = states(sys, seed);
    let n = sys.n();
    let angles: Vec<usize> = (0..n).filter(|&i| sys.is_angle(i)).collect();
    let special = [0.0, -0.0, PI / 2.0, -PI / 2.0, PI, -PI];
    for (k, mut s) in states(sys, seed + 100).into_iter().enumerate() {
        match k % 4 {
            // at rest
            0 => {
                s.v.iter_mut()
                    .for_each(|x| *x = if k % 8 == 0 { 0.0 } else { -0.0 })
            }
            // translating only
            1 => angles
                .iter()
                .for_each(|&i| s.v[i] = if k % 8 == 1 { 0.0 } else { -0.0 }),
            // at special angles, some not turning
            2 => {
                for (j, &i) in angles.iter().enumerate() {
                    s.q[i] = special[(k + j) % special.len()];
                    if j % 2 == 0 {
                        s.v[i] = 0.0;
                    }
                }
            }
            // everything at zero but one body's velocity
            _ => {
                s.q.iter_mut().for_each(|x| *x = 0.0);
                s.v.iter_mut().skip(3).for_each(|x| *x = 0.0);
            }
        }
        all.push(s);
    }
    all
}

#[test]
fn bias_of_planar_joints_by_hand_is_the_dual_pass_to_the_bit() {
    // a still ground (fixed), frozen at a turned pose (x, y and θ), frozen translated
    // only (θ not prescribed: an unrotated frame), and moving (the dual pass for all)
    let fixed = system(&every_planar_joint());
    let moving = system(&format!(
        "[parameters]\n{GROUND_PARAMETERS}\n{GROUND_MOTION}\n{}",
        every_planar_joint()
    ));
    let times: Vec<f64> = (0..7).map(|k| 0.3 * k as f64).collect();
    let frozen = moving.with_ground_at_mean(&times);
    let shaken = system(&format!(
        "[parameters]\n{GROUND_PARAMETERS}\n[ground]\nmotion = {{ x = \"X0*sin(w*t)\" }}\n\
         {}",
        every_planar_joint()
    ));
    let frozen_x = shaken.with_ground_at_mean(&times);
    let mut checked = 0;
    for (label, sys) in [
        ("fixed ground", &fixed),
        ("frozen ground", &frozen),
        ("frozen unrotated ground", &frozen_x),
        ("moving ground", &moving),
    ] {
        assert_eq!(sys.m(), 25, "{label}");
        let mut ws = Workspace::new(sys);
        let (mut b, mut b_dual) = (DVector::zeros(sys.m()), DVector::zeros(sys.m()));
        let all = (21..25).flat_map(|seed| states_with_zeros(sys, seed));
        for (k, s) in all.enumerate() {
            let (q, v, t) = (&s.q[..], &s.v[..], s.t);
            sys.bias(&mut ws, q, v, t, &mut b);
            sys.bias_dual(&mut ws, q, v, t, &mut b_dual);
            for i in 0..sys.m() {
                assert!(
                    b[i].to_bits() == b_dual[i].to_bits(),
                    "{label}, state {k}: q = {q:?}, v = {v:?}, t = {t}\n\
                     b[{i}] ({}) = {:e} by hand vs {:e} by the dual pass",
                    sys.constraint_names[i],
                    b[i],
                    b_dual[i]
                );
                checked += 1;
            }
        }
    }
    eprintln!("b by hand vs the dual pass: {checked} entries, all the same bits");
}

/// −∇V by central differences of the potential energy at time t.
fn minus_grad_potential(sys: &System, q: &[f64], t: f64) -> DVector<f64> {
    let g = jacobian_fd(
        |x| DVector::from_element(1, sys.potential_energy(x, t)),
        q,
        H1,
    );
    -g.row(0).transpose()
}

#[test]
fn gravity_is_minus_the_gradient_of_its_potential() {
    // two entries add up; bodies of different masses
    let text = r#"
[parameters]
g = 9.81

[[bodies]]
name = "b1"
mass = 2
inertia = 0.3

[[bodies]]
name = "b2"
mass = 0.5
inertia = 0.1

[[forces]]
type = "gravity"
acceleration = [0.3, "-g"]

[[forces]]
type = "gravity"
acceleration = ["-0.1 m/s^2", 0]
"#;
    let sys = system(text);
    let mut worst = (0.0f64, 0.0f64);
    for (k, s) in states(&sys, 7).iter().enumerate() {
        let f = forces(&sys, &s.q, &[0.0; 6], s.t);
        // V is linear in q: the difference has no truncation error, only rounding
        // ε|V|/h ≈ 1e-10
        let fd = minus_grad_potential(&sys, &s.q, s.t);
        let e = err(f.as_slice(), fd.as_slice());
        assert!(e <= TOL_D1, "state {k}: f {f} vs −∇V {fd} ({e:e})");
        worst.0 = worst.0.max(e);
        // closed form m (gx, gy), no moment about the CG
        let want = [0.4, -19.62, 0.0, 0.1, -4.905, 0.0];
        let e = err(f.as_slice(), &want);
        assert!(e <= TOL_EXACT, "state {k}: f {f} vs m g {want:?} ({e:e})");
        worst.1 = worst.1.max(e);
    }
    eprintln!(
        "gravity: worst error vs −∇V {:e}, vs m g {:e}",
        worst.0, worst.1
    );
}

/// Spring geometry shared by the spring and damper tests: b1 [0.3, 0.1] to b2 [−0.2, 0.4],
/// and b2 [0.25, −0.15] to the ground point [1.2, −0.5].
fn springs(k: &str, c: &str) -> String {
    format!(
        r#"
[parameters]
k = {k}
c = {c}
L0 = 0.6
{}
[[forces]]
name = "s12"
type = "spring_damper"
body1 = "b1"
point1 = [0.3, 0.1]
body2 = "b2"
point2 = [-0.2, 0.4]
stiffness = "k"
damping = "c"
free_length = "L0"

[[forces]]
name = "s2g"
type = "spring_damper"
body1 = "b2"
point1 = [0.25, -0.15]
body2 = "ground"
point2 = [1.2, -0.5]
stiffness = "k"
damping = "c"
free_length = "L0"
"#,
        bodies(&["b1", "b2"])
    )
}

/// The two springs' ends: (body offset or None for the ground, body-frame point).
const SPRING_ENDS: [[(Option<usize>, V2); 2]; 2] = [
    [(Some(0), [0.3, 0.1]), (Some(3), [-0.2, 0.4])],
    [(Some(3), [0.25, -0.15]), (None, [1.2, -0.5])],
];

/// The closed-form generalized force of `SPRING_ENDS` with tension k (d − L0) + c ḋ.
fn springs_closed(q: &[f64], v: &[f64], k: f64, c: f64, l0: f64) -> Vec<f64> {
    let mut f = vec![0.0; q.len()];
    for ends in SPRING_ENDS {
        let pos = |(o, p): (Option<usize>, V2)| o.map_or(p, |o| at(q, o, p));
        let vel = |(o, p): (Option<usize>, V2)| o.map_or([0.0, 0.0], |o| vel(q, v, o, p));
        let d = sub(pos(ends[1]), pos(ends[0]));
        let len = d[0].hypot(d[1]);
        let u = [d[0] / len, d[1] / len];
        let rate = dot(u, sub(vel(ends[1]), vel(ends[0])));
        let tension = k * (len - l0) + c * rate;
        for (end, sign) in [(ends[0], 1.0), (ends[1], -1.0)] {
            if let (Some(o), p) = end {
                apply(
                    q,
                    o,
                    p,
                    [sign * tension * u[0], sign * tension * u[1]],
                    &mut f,
                );
            }
        }
    }
    f
}

/// The shortest spring length at q (the differences need d well away from 0).
fn shortest_spring(q: &[f64]) -> f64 {
    SPRING_ENDS
        .iter()
        .map(|ends| {
            let pos = |(o, p): (Option<usize>, V2)| o.map_or(p, |o| at(q, o, p));
            let d = sub(pos(ends[1]), pos(ends[0]));
            d[0].hypot(d[1])
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn spring_is_minus_the_gradient_of_its_potential() {
    let sys = system(&springs("30", "0"));
    let mut worst = (0.0f64, 0.0f64);
    let mut checked = 0;
    for (k, s) in states(&sys, 8).iter().enumerate() {
        // V = ½k(d − L0)² has third derivatives ~ k/d² (≲ 500 for d ≥ 0.25 m): the
        // truncation error h²/6·|V'''| ≲ 1e-8 stays ≲ 1e-9 after normalization by
        // 1 + |f|, |f| ~ k·|d − L0| ≳ 10; shorter springs (rare here) are skipped
        if shortest_spring(&s.q) < 0.25 {
            continue;
        }
        checked += 1;
        let f = forces(&sys, &s.q, &[0.0; 6], s.t);
        let fd = minus_grad_potential(&sys, &s.q, s.t);
        let e = err(f.as_slice(), fd.as_slice());
        assert!(e <= TOL_D1, "state {k}: f {f} vs −∇V {fd} ({e:e})");
        worst.0 = worst.0.max(e);
        // with c = 0 the force does not depend on v (same operations up to the c ḋ term,
        // which is 0·ḋ: equal to the last bit)
        let fv = forces(&sys, &s.q, &s.v, s.t);
        assert_eq!(f, fv, "state {k}: a spring with c = 0 depends on v");
        // and it is the closed form
        let want = springs_closed(&s.q, &s.v, 30.0, 0.0, 0.6);
        let e = err(f.as_slice(), &want);
        assert!(e <= TOL_EXACT, "state {k}: f {f} vs {want:?} ({e:e})");
        worst.1 = worst.1.max(e);
    }
    assert!(checked >= STATES / 2, "only {checked} states checked");
    eprintln!(
        "spring: worst error vs −∇V {:e}, vs closed form {:e} ({checked} states)",
        worst.0, worst.1
    );
}

/// ∂f/∂v by central differences. f is linear in v, so the difference has no truncation
/// error at any step; h = 0.1 keeps the rounding error ε|f|/h ≈ 1e-14.
fn damping_matrix(sys: &System, s: &St) -> DMatrix<f64> {
    jacobian_fd(|v| forces(sys, &s.q, v, s.t), &s.v, 0.1)
}

#[test]
fn damper_force_is_c_times_the_stretch_rate_along_the_line() {
    // the simplest geometry by hand: the CG at (1, 0), the anchor at the origin, so
    // u = P2 − P1 over d = (−1, 0), ḋ = ẋ, T = c ẋ, and f = (−c ẋ, 0, 0) whatever θ, ẏ, ω
    let text = format!(
        r#"
{}
[[forces]]
type = "spring_damper"
body1 = "b"
stiffness = 0
damping = 3
free_length = 0.5
"#,
        bodies(&["b"])
    );
    let sys = system(&text);
    let f = forces(&sys, &[1.0, 0.0, 0.7], &[0.5, -0.2, 1.3], 0.0);
    assert_eq!(f.as_slice(), [-1.5, 0.0, 0.0]);

    // two dampers (body–body and body–ground), k = 0, at random states
    let sys = system(&springs("0", "3"));
    let (mut worst_f, mut worst_sym, mut worst_nsd, mut worst_tr) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (k, s) in states(&sys, 9).iter().enumerate() {
        let f = forces(&sys, &s.q, &s.v, s.t);
        let want = springs_closed(&s.q, &s.v, 0.0, 3.0, 0.6);
        let e = err(f.as_slice(), &want);
        assert!(
            e <= TOL_EXACT,
            "state {k}: f {f} vs closed form {want:?} ({e:e})"
        );
        worst_f = worst_f.max(e);
        // at rest a damper without a spring exerts nothing
        let f0 = forces(&sys, &s.q, &[0.0; 6], s.t);
        assert!(f0.amax() == 0.0, "state {k}: f(v = 0) = {f0}");

        // D = ∂f/∂v = −c Σ jⱼ jⱼᵀ, jⱼ = ∂ḋⱼ/∂v: symmetric, negative semi-definite, rank
        // one per damper, trace −c Σ |jⱼ|² with |j|² = Σ over body ends (1 + (R p × u)²)
        let d = damping_matrix(&sys, s);
        let scale = 1.0 + d.amax();
        let e = (&d - d.transpose()).amax() / scale;
        // rounding of the differences only (ε|f|/h ≈ 1e-14): 1e-12
        assert!(
            e <= TOL_EXACT,
            "state {k}: D − Dᵀ = {} ({e:e})",
            &d - d.transpose()
        );
        worst_sym = worst_sym.max(e);
        // the zero eigenvalues are rounding (≲ 1e-15 of |D|), the two negative ones are
        // of the order of −c|j|², |j|² ≥ 1: 1e-12 and −1e-9 of |D| separate them with room either way
        let eig = SymmetricEigen::new((&d + d.transpose()) / 2.0).eigenvalues;
        let top = eig.max() / scale;
        assert!(top <= TOL_EXACT, "state {k}: eigenvalues of D {eig}");
        worst_nsd = worst_nsd.max(top);
        let negative = eig.iter().filter(|&&x| x < -1e-9 * scale).count();
        assert_eq!(negative, 2, "state {k}: rank of D ≠ 2 dampers: {eig}");
        let mut trace = 0.0;
        for ends in SPRING_ENDS {
            let pos = |(o, p): (Option<usize>, V2)| o.map_or(p, |o| at(&s.q, o, p));
            let dd = sub(pos(ends[1]), pos(ends[0]));
            let len = dd[0].hypot(dd[1]);
            let u = [dd[0] / len, dd[1] / len];
            for (o, p) in ends {
                if let Some(o) = o {
                    trace += 1.0 + cross(rot(s.q[o + 2], p), u).powi(2);
                }
            }
        }
        let e = err(&[d.trace()], &[-3.0 * trace]);
        assert!(
            e <= TOL_EXACT,
            "state {k}: tr D {} vs {} ({e:e})",
            d.trace(),
            -3.0 * trace
        );
        worst_tr = worst_tr.max(e);
    }
    eprintln!(
        "damper: worst error of f vs closed form {worst_f:e}; D: asymmetry {worst_sym:e}, \
         largest eigenvalue {worst_nsd:e}, trace {worst_tr:e}"
    );
}

#[test]
fn point_force_is_f_and_its_moment_about_the_cg() {
    let text = format!(
        r#"
[parameters]
F0 = 3
omega = 2.5
P = 1.7
{}
[[forces]]
type = "point_force"
body = "b1"
point = [0.3, -0.2]
force = ["F0*cos(omega*t)", "-2"]

[[forces]]
type = "point_force"
body = "b2"
point = [-0.1, 0.4]
force = ["-P*sin(b2.theta)", "P*cos(b2.theta) + b1.x"]
"#,
        bodies(&["b1", "b2"])
    );
    let sys = system(&text);
    let mut worst = 0.0f64;
    for (k, s) in states(&sys, 10).iter().enumerate() {
        let q = &s.q;
        let f = forces(&sys, q, &s.v, s.t);
        let mut want = vec![0.0; 6];
        apply(
            q,
            0,
            [0.3, -0.2],
            [3.0 * (2.5 * s.t).cos(), -2.0],
            &mut want,
        );
        let follower = [-1.7 * q[5].sin(), 1.7 * q[5].cos() + q[0]];
        apply(q, 3, [-0.1, 0.4], follower, &mut want);
        let e = err(f.as_slice(), &want);
        assert!(
            e <= TOL_EXACT,
            "state {k}: f {f} vs closed form {want:?} ({e:e})"
        );
        worst = worst.max(e);
    }
    eprintln!("point force: worst error vs closed form {worst:e}");
}

#[test]
fn spring_damper_to_a_moving_anchor_uses_the_anchors_position_and_velocity() {
    let text = format!(
        r#"
[parameters]
{GROUND_PARAMETERS}
{GROUND_MOTION}
{}
[[forces]]
type = "spring_damper"
body1 = "b"
point1 = [0.2, 0.1]
body2 = "ground"
point2 = [0.6, -0.3]
stiffness = 20
damping = 1.5
free_length = 0.4
"#,
        bodies(&["b"])
    );
    let sys = system(&text);
    assert!(sys.forces_depend_on_time());
    let (p1, p2) = ([0.2, 0.1], [0.6, -0.3]);
    let closed = |q: &[f64], v: &[f64], t: f64, anchor_vel: V2| {
        let d = sub(ground_at(t, p2), at(q, 0, p1));
        let len = d[0].hypot(d[1]);
        let u = [d[0] / len, d[1] / len];
        let tension = 20.0 * (len - 0.4) + 1.5 * dot(u, sub(anchor_vel, vel(q, v, 0, p1)));
        let mut f = vec![0.0; 3];
        apply(q, 0, p1, [tension * u[0], tension * u[1]], &mut f);
        f
    };
    let (mut worst, mut smallest_gap) = (0.0f64, f64::INFINITY);
    let mut largest_gap = 0.0f64;
    for (k, s) in states(&sys, 11).iter().enumerate() {
        let f = forces(&sys, &s.q, &s.v, s.t);
        let want = closed(&s.q, &s.v, s.t, ground_vel(s.t, p2));
        let e = err(f.as_slice(), &want);
        assert!(
            e <= TOL_EXACT,
            "state {k}: f {f} vs closed form {want:?} ({e:e})"
        );
        worst = worst.max(e);
        // the same with the anchor taken at rest: how far a damper that ignored the
        // anchor's velocity would be (so that the check above can tell)
        let at_rest = closed(&s.q, &s.v, s.t, [0.0, 0.0]);
        let gap = err(f.as_slice(), &at_rest);
        smallest_gap = smallest_gap.min(gap);
        largest_gap = largest_gap.max(gap);
    }
    assert!(
        largest_gap > 1e6 * TOL_EXACT,
        "the anchor's velocity never mattered: {largest_gap:e}"
    );
    eprintln!(
        "moving anchor: worst error vs closed form {worst:e} (an anchor taken at rest \
         would be off by {smallest_gap:.1e}..{largest_gap:.1e})"
    );
}

#[test]
fn spring_to_a_moving_anchor_is_minus_the_gradient_of_its_potential() {
    let text = format!(
        r#"
[parameters]
{GROUND_PARAMETERS}
{GROUND_MOTION}
{}
[[forces]]
type = "spring_damper"
body1 = "b"
point1 = [0.2, 0.1]
body2 = "ground"
point2 = [0.6, -0.3]
stiffness = 20
free_length = 0.4
"#,
        bodies(&["b"])
    );
    let sys = system(&text);
    let length = |q: &[f64], t: f64| {
        let d = sub(ground_at(t, [0.6, -0.3]), at(q, 0, [0.2, 0.1]));
        d[0].hypot(d[1])
    };
    // the potential at time t is that of the anchor where the ground has carried it
    for t in [0.0, 1.0] {
        for (k, s) in states(&sys, 13).iter().enumerate() {
            if length(&s.q, t) < 0.25 {
                continue; // as in the fixed-ground test
            }
            let f = forces(&sys, &s.q, &[0.0; 3], t);
            let fd = minus_grad_potential(&sys, &s.q, t);
            let e = err(f.as_slice(), fd.as_slice());
            assert!(e <= TOL_D1, "state {k}, t = {t}: f {f} vs −∇V {fd} ({e:e})");
        }
    }
}

// ---- degrees of freedom ------------------------------------------------------------------

/// The dimension of the null space of A (n − rank), and the singular-value gap: the
/// largest singular value counted as zero and the smallest counted as non-zero, relative
/// to the largest.
fn null_space(sys: &System, q: &[f64], t: f64) -> (usize, f64, f64) {
    let mut ws = Workspace::new(sys);
    let mut a = DMatrix::zeros(sys.m(), sys.n());
    sys.jacobian(&mut ws, q, t, &mut a);
    let sv = a.svd(false, false).singular_values;
    let top = sv.max();
    // At an assembled pose A is exact to rounding, so a dependent row leaves a singular
    // value ≈ ε·|A| ≈ 1e-16·top; independent rows of these O(1) mechanisms leave ≥ 1e-2.
    // 1e-8 splits the two by many orders either way; the gap is asserted below.
    let rank = sv.iter().filter(|&&s| s > 1e-8 * top).count();
    let zero = sv
        .iter()
        .filter(|&&s| s <= 1e-8 * top)
        .fold(0.0f64, |m, &s| m.max(s / top));
    let nonzero = sv
        .iter()
        .filter(|&&s| s > 1e-8 * top)
        .fold(f64::INFINITY, |m, &s| m.min(s / top));
    (sys.n() - rank, zero, nonzero)
}

/// Bodies `[name, x, y, theta]` (guesses for assembly; mass 1 kg, inertia 0.1 kg·m²).
fn bodies_at(rows: &[[&str; 4]]) -> String {
    rows.iter()
        .map(|[n, x, y, th]| {
            format!(
                "[[bodies]]\nname = \"{n}\"\nmass = 1\ninertia = 0.1\n\
                 x = \"{x}\"\ny = \"{y}\"\ntheta = \"{th}\"\n\n"
            )
        })
        .collect()
}

/// Joints `[name, type, body1, point1, body2, point2, further fields]`.
fn joints(rows: &[[&str; 7]]) -> String {
    rows.iter()
        .map(|[n, kind, b1, p1, b2, p2, extra]| {
            format!(
                "[[joints]]\nname = \"{n}\"\ntype = \"{kind}\"\nbody1 = \"{b1}\"\n\
                 point1 = {p1}\nbody2 = \"{b2}\"\npoint2 = {p2}\n{extra}\n\n"
            )
        })
        .collect()
}

#[test]
fn null_space_of_a_has_the_dimension_of_the_degrees_of_freedom() {
    let pendulum = bodies_at(&[["b", "0.1", "-0.4", "0.2"]])
        + &joints(&[["O", "revolute", "b", "[0, 0.5]", "ground", "[0, 0]", ""]]);
    // crank 1 at 60° from (0, 0), rocker 1.2 at 100° from (2, 0), the coupler between
    let four_bar = r#"
[parameters]
cr = 1.0
ro = 1.2
d = 2.0
th1 = "pi/3"
th3 = "5*pi/9"
ax = "cr*cos(th1)"
ay = "cr*sin(th1)"
bx = "d + ro*cos(th3)"
by = "ro*sin(th3)"
lc = "sqrt((bx - ax)^2 + (by - ay)^2)"
"#
    .to_string()
        + &bodies_at(&[
            ["crank", "ax/2", "ay/2", "th1"],
            [
                "coupler",
                "(ax + bx)/2",
                "(ay + by)/2",
                "atan2(by - ay, bx - ax)",
            ],
            ["rocker", "(d + bx)/2", "by/2", "th3"],
        ])
        + &joints(&[
            [
                "O",
                "revolute",
                "crank",
                r#"["-cr/2", 0]"#,
                "ground",
                "[0, 0]",
                "",
            ],
            [
                "A",
                "revolute",
                "crank",
                r#"["cr/2", 0]"#,
                "coupler",
                r#"["-lc/2", 0]"#,
                "",
            ],
            [
                "B",
                "revolute",
                "coupler",
                r#"["lc/2", 0]"#,
                "rocker",
                r#"["ro/2", 0]"#,
                "",
            ],
            [
                "D",
                "revolute",
                "rocker",
                r#"["-ro/2", 0]"#,
                "ground",
                r#"["d", 0]"#,
                "",
            ],
        ]);
    // crank 0.5 at 45°, rod 1.5, the slider on the x axis (its guess off by a little)
    let slider_crank = r#"
[parameters]
r = 0.5
l = 1.5
th = "pi/4"
ax = "r*cos(th)"
ay = "r*sin(th)"
sx = "ax + sqrt(l^2 - ay^2)"
"#
    .to_string()
        + &bodies_at(&[
            ["crank", "ax/2", "ay/2", "th"],
            ["rod", "(ax + sx)/2", "ay/2", "atan2(-ay, sx - ax)"],
            ["slider", "sx + 0.05", "0.02", "0.03"],
        ])
        + &joints(&[
            [
                "O",
                "revolute",
                "crank",
                r#"["-r/2", 0]"#,
                "ground",
                "[0, 0]",
                "",
            ],
            [
                "A",
                "revolute",
                "crank",
                r#"["r/2", 0]"#,
                "rod",
                r#"["-l/2", 0]"#,
                "",
            ],
            [
                "B",
                "revolute",
                "rod",
                r#"["l/2", 0]"#,
                "slider",
                "[0, 0]",
                "",
            ],
            [
                "S",
                "prismatic",
                "slider",
                "[0, 0]",
                "ground",
                "[0, 0]",
                "axis = [1, 0]",
            ],
        ]);
    let one = |body: [&str; 4], joint: [&str; 7]| bodies_at(&[body]) + &joints(&[joint]);
    let cases: Vec<(&str, String, usize)> = vec![
        ("pendulum: 3 − 2", pendulum.clone(), 1),
        (
            "pin in an oblique slot to ground: 3 − 1",
            one(
                ["b", "0", "0", "0.3"],
                [
                    "S",
                    "pin_in_slot",
                    "b",
                    "[0.2, 0]",
                    "ground",
                    "[0, 0]",
                    "axis = [1, 2]",
                ],
            ),
            2,
        ),
        (
            "prismatic to ground: 3 − 2",
            one(
                ["b", "0", "0", "0.3"],
                [
                    "S",
                    "prismatic",
                    "b",
                    "[0.2, 0]",
                    "ground",
                    "[0, 0]",
                    "axis = [1, 2]",
                ],
            ),
            1,
        ),
        (
            "fixed to ground at an angle: 3 − 3",
            one(
                ["b", "0", "0", "0"],
                [
                    "F",
                    "fixed",
                    "b",
                    "[0.2, 0]",
                    "ground",
                    "[0.1, 0.1]",
                    "angle = 0.5",
                ],
            ),
            0,
        ),
        (
            "double pendulum: 6 − 4",
            pendulum.clone()
                + &one(
                    ["c", "0.3", "-1.2", "1"],
                    ["J", "revolute", "c", "[-0.3, 0.1]", "b", "[0, -0.5]", ""],
                ),
            2,
        ),
        (
            "a pin in the slot of a body fixed to ground: 6 − 3 − 1",
            one(
                ["b", "0", "0", "0.5"],
                [
                    "F",
                    "fixed",
                    "b",
                    "[0, 0]",
                    "ground",
                    "[0, 0]",
                    "angle = 0.5",
                ],
            ) + &one(
                ["c", "0.5", "0.5", "0"],
                [
                    "S",
                    "pin_in_slot",
                    "c",
                    "[0.1, 0]",
                    "b",
                    "[0.2, 0.1]",
                    "axis = [1, -1]",
                ],
            ),
            2,
        ),
        (
            "a prismatic slider on a pendulum: 6 − 2 − 2",
            pendulum.clone()
                + &one(
                    ["c", "0.3", "-0.6", "0.3"],
                    [
                        "P",
                        "prismatic",
                        "c",
                        "[0, 0]",
                        "b",
                        "[0, 0]",
                        "axis = [0, 1]\nangle = 0.1",
                    ],
                ),
            2,
        ),
        ("four-bar: 9 − 8", four_bar, 1),
        ("slider-crank: 9 − 8", slider_crank, 1),
        ("overcentre: 6 − 5", common::overcentre_text(), 1),
        (
            "pendulum with a custom row repeating O.x: 3 − rank 2 of 3 rows",
            pendulum.clone() + "[[constraints]]\nexpr = \"b.x - 0.5*sin(b.theta)\"\n",
            1,
        ),
        (
            "pendulum driven by a custom row in t: 3 − 3",
            pendulum.clone() + "[[constraints]]\nexpr = \"b.theta - 0.2 - 0.3*sin(2*t)\"\n",
            0,
        ),
        (
            "four bodies jointed to the moving ground: 12 − 8",
            moving_ground_joints(),
            4,
        ),
    ];
    let (mut worst_zero, mut worst_nonzero) = (0.0f64, f64::INFINITY);
    for (label, text, dof) in &cases {
        let sys = system(text);
        let s = assemble(&sys).unwrap_or_else(|e| panic!("{label}: {e:?}"));
        let r = sys.residual(&s.q, s.t).amax();
        assert!(r <= 1e-9, "{label}: not assembled, |Φ| = {r:e}");
        let (dim, zero, nonzero) = null_space(&sys, &s.q, s.t);
        assert_eq!(dim, *dof, "{label}: null space of A at {:?}", s.q);
        // an unambiguous rank: nothing between 1e-12 and 1e-3 of the largest
        assert!(
            zero <= 1e-12 && nonzero >= 1e-3,
            "{label}: singular values {zero:e} (zero) and {nonzero:e} (non-zero) too close"
        );
        worst_zero = worst_zero.max(zero);
        worst_nonzero = worst_nonzero.min(nonzero);
    }
    eprintln!(
        "null space: {} mechanisms; largest 'zero' singular value {worst_zero:.1e}·σmax, \
         smallest non-zero {worst_nonzero:.1e}·σmax",
        cases.len()
    );
}

// ---- configuration and tangent --------------------------------------------------------

/// The retraction q ⊕ s·δ is the motion with velocities δ to second order: its rate at
/// s = 0 is q̇ = N(q) δ (`qdot`), its second derivative that of q̇ along the motion (zero
/// for planar bodies, whose q̇ does not depend on q), and `difference` inverts it. Checked
/// by differences in s, so a body kind whose ⊕ is not + is held to the same.
#[test]
fn retraction_is_the_motion_to_second_order() {
    let sys = system(&bodies(&["a", "b"]));
    let h = 1e-4;
    let mut worst = [0.0f64; 3];
    for s in states(&sys, 29) {
        let at = |x: f64| {
            let mut q = s.q.clone();
            sys.retract(&mut q, &s.v, x);
            q
        };
        let (qp, q0, qm) = (at(h), at(0.0), at(-h));
        assert_eq!(q0, s.q, "q ⊕ 0 = q");
        let mut qdot = vec![0.0; sys.nq()];
        sys.qdot(&s.q, &s.v, &mut qdot);
        let rate: Vec<f64> = (0..sys.nq()).map(|i| (qp[i] - qm[i]) / (2.0 * h)).collect();
        let curv: Vec<f64> = (0..sys.nq())
            .map(|i| (qp[i] - 2.0 * q0[i] + qm[i]) / (h * h))
            .collect();
        worst[0] = worst[0].max(err(&rate, &qdot));
        // (a planar q̇ is constant along the motion: the second derivative is zero)
        worst[1] = worst[1].max(err(&curv, &vec![0.0; sys.nq()]));
        let mut back = vec![0.0; sys.nv()];
        sys.difference(&at(1.0), &s.q, &mut back);
        worst[2] = worst[2].max(err(&back, &s.v));
    }
    // central differences of a motion linear in s: rounding only, ε|q|/h ≈ 1e-12
    assert!(worst[0] <= 1e-9, "d/ds (q ⊕ sδ) vs q̇: {:e}", worst[0]);
    // second difference: ε|q|/h² ≈ 1e-8
    assert!(worst[1] <= 1e-6, "d²/ds² (q ⊕ sδ): {:e}", worst[1]);
    assert!(worst[2] <= 1e-15, "(q ⊕ δ) ⊖ q vs δ: {:e}", worst[2]);
}
