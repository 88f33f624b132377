//! Spatial bodies against closed forms: free bodies (`rotation = "free"`, a unit
//! quaternion with the body-frame angular velocity) and bodies with a sequence of angles,
//! side by side.
//!
//! * a rigid conical pendulum (a rod on a spherical joint) and a heavy symmetric top on
//!   its tip, started in steady precession: the cone angle stays put and the azimuth
//!   advances at the closed-form rate;
//! * a torque-free asymmetric body spinning near its intermediate axis: the period of its
//!   flips against the Jacobi elliptic solution, 4K(k)/λ;
//! * energy and the vertical angular momentum of a nutating top over 20 s, and the
//!   quaternion's norm;
//! * an angle sequence driven into gimbal lock stops with a typed failure;
//! * element level: A and b of every spatial joint, and the spatial spring and torsion
//!   against −∇V, by differences along the retraction q ⊕ s·δ.
//!
//! Gravity is −z (9.81 m/s²) throughout; no damping. The simulations run with rtol
//! [`RTOL`] and atol [`ATOL`] (tighter than the defaults, for the closed forms' 1e-9).
//! Each test prints its measured errors (`--nocapture`).

use detune::failure::Failure;
use detune::system::Workspace;
use detune::{Error, Model, SimOptions, System, Trajectory, assemble, simulate};
use nalgebra::{DMatrix, DVector};
use std::f64::consts::PI;

const G: f64 = 9.81;
/// Integration tolerances of the closed-form runs.
const RTOL: f64 = 1e-12;
const ATOL: f64 = 1e-14;

fn system(text: &str) -> System {
    let model = Model::from_str("spatial.toml", text).unwrap_or_else(|e| panic!("{e:?}\n{text}"));
    System::new(&model).unwrap_or_else(|e| panic!("{e:?}\n{text}"))
}

fn run(sys: &System, t_end: f64, dt_out: f64) -> Trajectory {
    let start = assemble(sys).unwrap_or_else(|e| panic!("{e:?}"));
    let opts = SimOptions {
        t_end,
        dt_out,
        rtol: RTOL,
        atol: ATOL,
        ..SimOptions::default()
    };
    simulate(sys, &start, &opts, &mut |_| true).unwrap_or_else(|e| panic!("{e:?}"))
}

// ---- small 3-D algebra ---------------------------------------------------------------

type V3 = [f64; 3];
type M3 = [[f64; 3]; 3];
type Quat = [f64; 4];

fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn mat_vec(m: &M3, v: V3) -> V3 {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

fn mat_t_vec(m: &M3, v: V3) -> V3 {
    [0, 1, 2].map(|j| m[0][j] * v[0] + m[1][j] * v[1] + m[2][j] * v[2])
}

fn mul(a: &M3, b: &M3) -> M3 {
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

/// The active rotation about coordinate axis `axis` (0 = x, 1 = y, 2 = z) by `a`.
fn axis_rot(axis: usize, a: f64) -> M3 {
    let (s, c) = a.sin_cos();
    match axis {
        0 => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        1 => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        _ => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
    }
}

/// R of a quaternion (w, x, y, z), normalized.
fn quat_rot(q: Quat) -> M3 {
    let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    let [w, x, y, z] = q.map(|c| c / n);
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

/// The inertia tensor diag(i) as TOML.
fn principal(i: V3) -> String {
    format!("[{:?}, {:?}, {:?}]", i[0], i[1], i[2])
}

// ---- steady precession: the conical pendulum and the heavy top ------------------------

/// A body's CG at each sample.
fn cg_history(sys: &System, traj: &Trajectory, body: &str) -> Vec<V3> {
    let idx = ["x", "y", "z"].map(|c| sys.coordinate_index(&format!("{body}.{c}")).unwrap());
    traj.qs().map(|q| idx.map(|i| q[i])).collect()
}

/// The worst errors of the cone angle (from the vertical, `up` or down) and of the
/// azimuth against θ0 and φ0 + Ω t, from the CG (the pivot at the origin).
fn precession_errors(
    sys: &System,
    traj: &Trajectory,
    body: &str,
    up: bool,
    theta0: f64,
    omega: f64,
) -> (f64, f64) {
    let cg = cg_history(sys, traj, body);
    let (mut e_theta, mut e_phi) = (0.0f64, 0.0f64);
    let phi0 = cg[0][1].atan2(cg[0][0]);
    let mut turns = 0.0;
    let mut prev = phi0;
    for (t, r) in traj.t.iter().zip(&cg) {
        let vert = if up { r[2] } else { -r[2] };
        let theta = r[0].hypot(r[1]).atan2(vert);
        let phi = r[1].atan2(r[0]);
        // unwrap
        if phi - prev > PI {
            turns -= 2.0 * PI;
        } else if phi - prev < -PI {
            turns += 2.0 * PI;
        }
        prev = phi;
        e_theta = e_theta.max((theta - theta0).abs());
        e_phi = e_phi.max((phi + turns - phi0 - omega * t).abs());
    }
    (e_theta, e_phi)
}

/// A uniform rod (angle sequence: slender, I_axial = 0) or a solid cylinder of radius
/// 0.05 m (free body; its axial inertia makes the free body's tensor definite) of length
/// L = 1 m, mass 2 kg, on a spherical joint at its top end, in steady precession at cone
/// angle `theta` from the downward vertical: Ω² = m g l / ((I_⊥O − I_axial) cos θ).
/// Returns the model and Ω.
fn conical_pendulum(free: bool, theta: f64) -> (String, f64) {
    let (m, len, rho) = (2.0, 1.0, 0.05);
    let l = len / 2.0;
    let (ip, ia) = if free {
        (
            m * (3.0 * rho * rho + len * len) / 12.0,
            m * rho * rho / 2.0,
        )
    } else {
        (m * len * len / 12.0, 0.0)
    };
    let omega = (m * G * l / ((ip + m * l * l - ia) * theta.cos())).sqrt();
    if !free {
        // the uniform rod's closed form, 3g / (2 L cos θ)
        let want = (3.0 * G / (2.0 * len * theta.cos())).sqrt();
        assert!((omega - want).abs() < 1e-14 * want);
    }
    // at azimuth 0: R = Rz(0) Rx(θ), the rod's axis R e_z = (0, −sin θ, cos θ), the CG
    // l below the pivot along it, moving at Ω ẑ × r
    let (s, c) = theta.sin_cos();
    let r = [0.0, l * s, -l * c];
    let vx = -omega * r[1];
    let rotation = if free {
        let (hs, hc) = (theta / 2.0).sin_cos();
        format!(
            "rotation = \"free\"\norientation = [{hc:?}, {hs:?}, 0, 0]\nfix = [\"orientation\"]\n\
             velocity = {{ vx = {vx:?}, vy = 0, vz = 0, wx = 0, wy = {:?}, wz = {:?} }}",
            omega * s,
            omega * c
        )
    } else {
        format!(
            "rotation = [[\"z\", \"psi\"], [\"x\", \"th\"]]\nangles = {{ psi = 0, th = {theta:?} }}\n\
             fix = [\"psi\", \"th\"]\nvelocity = {{ x = {vx:?}, y = 0, z = 0, psi = {omega:?}, th = 0 }}"
        )
    };
    let text = format!(
        r#"
[[bodies]]
name = "rod"
mass = {m:?}
inertia = {inertia}
x = 0
y = {y:?}
z = {z:?}
{rotation}

[[joints]]
name = "pivot"
type = "spherical"
body1 = "rod"
point1 = [0, 0, {l:?}]
body2 = "ground"
point2 = [0, 0, 0]

[[forces]]
name = "gravity"
type = "gravity"
acceleration = [0, 0, {mg:?}]
"#,
        inertia = principal([ip, ip, ia]),
        y = r[1],
        z = r[2],
        mg = -G,
    );
    (text, omega)
}

/// The heavy symmetric top of the tests: m = 1 kg, CG l = 0.1 m from its tip, I₁ = 0.004,
/// I₃ = 0.006 kg·m² about the CG.
const TOP: (f64, f64, f64, f64) = (1.0, 0.1, 0.004, 0.006);

/// The heavy symmetric top on its tip at the origin, θ from the upward vertical, spin
/// component ω₃ about its axis and precession rate Ω (ZXZ Euler angles, or a free body).
fn top(free: bool, theta: f64, omega3: f64, omega: f64, theta_rate: f64) -> String {
    let (m, l, i1, i3) = TOP;
    let (s, c) = theta.sin_cos();
    // R = Rz(0) Rx(θ) Rz(0): the axis R e_z = (0, −sin θ, cos θ), the CG l along it
    let r = [0.0, -l * s, l * c];
    // ω = Ω ẑ + θ̇ x̂ + spin R e_z; the CG moves at ω × r
    let w_world = [
        theta_rate,
        -(omega3 - omega * c) * s,
        omega + (omega3 - omega * c) * c,
    ];
    let vel = cross(w_world, r);
    let rotation = if free {
        let (hs, hc) = (theta / 2.0).sin_cos();
        // body rates Rᵀ ω = (θ̇, Ω sin θ, ω₃)
        format!(
            "rotation = \"free\"\norientation = [{hc:?}, {hs:?}, 0, 0]\nfix = [\"orientation\"]\n\
             velocity = {{ vx = {:?}, vy = {:?}, vz = {:?}, wx = {theta_rate:?}, wy = {:?}, wz = {omega3:?} }}",
            vel[0],
            vel[1],
            vel[2],
            omega * s,
        )
    } else {
        format!(
            "rotation = [[\"z\", \"psi\"], [\"x\", \"th\"], [\"z\", \"phi\"]]\n\
             angles = {{ psi = 0, th = {theta:?}, phi = 0 }}\nfix = [\"psi\", \"th\", \"phi\"]\n\
             velocity = {{ x = {:?}, y = {:?}, z = {:?}, psi = {omega:?}, th = {theta_rate:?}, phi = {:?} }}",
            vel[0],
            vel[1],
            vel[2],
            omega3 - omega * c,
        )
    };
    format!(
        r#"
[[bodies]]
name = "top"
mass = {m:?}
inertia = {inertia}
x = 0
y = {y:?}
z = {z:?}
{rotation}

[[joints]]
name = "tip"
type = "spherical"
body1 = "top"
point1 = [0, 0, {tip:?}]
body2 = "ground"
point2 = [0, 0, 0]

[[forces]]
name = "gravity"
type = "gravity"
acceleration = [0, 0, {mg:?}]
"#,
        inertia = principal([i1, i1, i3]),
        y = r[1],
        z = r[2],
        tip = -l,
        mg = -G,
    )
}

/// The slow root of m g l = Ω (I₃ ω₃ − I₁O Ω cos θ).
fn slow_precession(theta: f64, omega3: f64) -> f64 {
    let (m, l, i1, i3) = TOP;
    let i1o = i1 + m * l * l;
    let (a, b, c) = (i1o * theta.cos(), -i3 * omega3, m * G * l);
    let disc = b * b - 4.0 * a * c;
    assert!(disc > 0.0, "no steady precession at this spin");
    // the smaller root, written without cancellation
    2.0 * c / (-b + disc.sqrt())
}

#[test]
fn conical_pendulum_precesses_at_the_closed_form_rate() {
    let theta = 0.6;
    for free in [false, true] {
        let (text, omega) = conical_pendulum(free, theta);
        let sys = system(&text);
        let t_end = 5.0 * 2.0 * PI / omega;
        let traj = run(&sys, t_end, 0.01);
        let (e_theta, e_phi) = precession_errors(&sys, &traj, "rod", false, theta, omega);
        println!(
            "conical pendulum ({}): Ω = {omega:.12} rad/s, 5 revolutions ({t_end:.3} s): cone angle error {e_theta:.3e} rad, azimuth error {e_phi:.3e} rad",
            if free { "free body" } else { "angles z, x" }
        );
        assert!(e_theta < 1e-9, "cone angle error {e_theta:e}");
        assert!(e_phi < 1e-8, "azimuth error {e_phi:e}");
    }
}

#[test]
fn heavy_top_precesses_at_the_slow_root() {
    let (theta, omega3) = (0.5, 40.0);
    let omega = slow_precession(theta, omega3);
    for free in [false, true] {
        let sys = system(&top(free, theta, omega3, omega, 0.0));
        let t_end = 4.0 * 2.0 * PI / omega;
        let traj = run(&sys, t_end, 0.01);
        let (e_theta, e_phi) = precession_errors(&sys, &traj, "top", true, theta, omega);
        println!(
            "heavy top ({}): ω₃ = {omega3}, Ω = {omega:.12} rad/s, 4 revolutions ({t_end:.3} s): cone angle error {e_theta:.3e} rad, azimuth error {e_phi:.3e} rad",
            if free {
                "free body"
            } else {
                "Euler angles z, x, z"
            }
        );
        assert!(e_theta < 1e-9, "cone angle error {e_theta:e}");
        assert!(e_phi < 1e-8, "azimuth error {e_phi:e}");
    }
}

// ---- the intermediate-axis flip --------------------------------------------------------

/// The complete elliptic integral of the first kind K(k) = π / (2 AGM(1, √(1 − k²))).
fn elliptic_k(k: f64) -> f64 {
    let (mut a, mut b) = (1.0f64, (1.0 - k * k).sqrt());
    while (a - b).abs() > 1e-16 * a {
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    PI / (2.0 * a)
}

/// The period of a torque-free body's rotation (principal moments i1 < i2 < i3, body
/// rates w): with 2E = Σ Iᵢωᵢ² and M² = Σ Iᵢ²ωᵢ², for M² > 2E I₂ (Landau & Lifshitz §37)
///
/// ```text
/// ω₂ = √((2E I₃ − M²) / (I₂ (I₃ − I₂))) sn(λ t),   λ² = (I₃ − I₂)(M² − 2E I₁) / (I₁ I₂ I₃),
/// k² = (I₂ − I₁)(2E I₃ − M²) / ((I₃ − I₂)(M² − 2E I₁))
/// ```
///
/// (ω₁ ∝ cn, ω₃ ∝ dn), and with I₁ and I₃ exchanged for M² < 2E I₂. sn has period 4K(k):
/// the period is 4K(k)/λ, and ω₂ changes sign every 2K(k)/λ.
fn flip_period(i: V3, w: V3) -> f64 {
    let e2: f64 = (0..3).map(|k| i[k] * w[k] * w[k]).sum();
    let m2: f64 = (0..3).map(|k| (i[k] * w[k]).powi(2)).sum();
    let (i1, i2, i3) = if m2 > e2 * i[1] {
        (i[0], i[1], i[2])
    } else {
        (i[2], i[1], i[0])
    };
    let lambda = ((i3 - i2) * (m2 - e2 * i1) / (i1 * i2 * i3)).sqrt();
    let k2 = (i2 - i1) * (e2 * i3 - m2) / ((i3 - i2) * (m2 - e2 * i1));
    assert!((0.0..1.0).contains(&k2), "k² = {k2}");
    4.0 * elliptic_k(k2.sqrt()) / lambda
}

/// The times where ω₂ changes sign, each refined by the cubic through the samples on
/// either side with the slopes of Euler's equations (I₂ ω̇₂ = (I₃ − I₁) ω₃ ω₁).
fn sign_changes(traj: &Trajectory, i: V3) -> Vec<f64> {
    let w: Vec<V3> = traj.vs().map(|v| [v[3], v[4], v[5]]).collect::<Vec<_>>();
    let slope = |w: V3| (i[2] - i[0]) * w[2] * w[0] / i[1];
    let mut out = Vec::new();
    for k in 1..w.len() {
        let (y0, y1) = (w[k - 1][1], w[k][1]);
        if (y0 < 0.0) == (y1 < 0.0) {
            continue;
        }
        let (t0, h) = (traj.t[k - 1], traj.t[k] - traj.t[k - 1]);
        let (d0, d1) = (slope(w[k - 1]) * h, slope(w[k]) * h);
        // cubic Hermite on s ∈ [0, 1], its root by bisection
        let p = |s: f64| {
            let (s2, s3) = (s * s, s * s * s);
            (2.0 * s3 - 3.0 * s2 + 1.0) * y0
                + (s3 - 2.0 * s2 + s) * d0
                + (-2.0 * s3 + 3.0 * s2) * y1
                + (s3 - s2) * d1
        };
        let (mut a, mut b) = (0.0, 1.0);
        for _ in 0..60 {
            let m = 0.5 * (a + b);
            if (p(m) < 0.0) == (y0 < 0.0) {
                a = m;
            } else {
                b = m;
            }
        }
        out.push(t0 + 0.5 * (a + b) * h);
    }
    out
}

#[test]
fn intermediate_axis_flips_with_the_elliptic_period() {
    let i = [1.0, 2.0, 2.5];
    let w0 = [0.02, 3.0, 0.03];
    let period = flip_period(i, w0);
    let text = format!(
        r#"
[[bodies]]
name = "b"
rotation = "free"
mass = 1
inertia = {inertia}
velocity = {{ wx = {:?}, wy = {:?}, wz = {:?} }}
"#,
        w0[0],
        w0[1],
        w0[2],
        inertia = principal(i),
    );
    let sys = system(&text);
    let traj = run(&sys, 3.2 * period, 0.005);
    let flips = sign_changes(&traj, i);
    assert!(flips.len() >= 5, "{} sign changes", flips.len());
    // every two sign changes are one period
    let mut worst = 0.0f64;
    for k in 2..flips.len() {
        let e = ((flips[k] - flips[k - 2]) - period).abs() / period;
        worst = worst.max(e);
    }
    println!(
        "intermediate axis: I = {i:?}, ω0 = {w0:?}: period 4K/λ = {period:.12} s, {} sign changes of ω₂, worst relative period error {worst:.3e}",
        flips.len()
    );
    assert!(worst < 1e-6, "relative period error {worst:e}");
}

// ---- conservation ----------------------------------------------------------------------

/// R and the world angular velocity of the top at a sample, from its own coordinates:
/// ZXZ Euler angles (ω = ψ̇ ẑ + θ̇ Rz(ψ) x̂ + φ̇ R ẑ), or a quaternion (ω = R ω_b).
fn top_rotation(sys: &System, free: bool, q: &[f64], v: &[f64]) -> (M3, V3) {
    let c = |n: &str| sys.coordinate_index(&format!("top.{n}")).unwrap();
    let vi = |n: &str| sys.velocity_index(&format!("top.{n}")).unwrap();
    if free {
        let r = quat_rot([q[c("qw")], q[c("qx")], q[c("qy")], q[c("qz")]]);
        let w = mat_vec(&r, [v[vi("wx")], v[vi("wy")], v[vi("wz")]]);
        (r, w)
    } else {
        let (psi, th, phi) = (q[c("psi")], q[c("th")], q[c("phi")]);
        let rz = axis_rot(2, psi);
        let r = mul(&mul(&rz, &axis_rot(0, th)), &axis_rot(2, phi));
        let nodes = mat_vec(&rz, [1.0, 0.0, 0.0]);
        let axis = mat_vec(&r, [0.0, 0.0, 1.0]);
        let w = [0, 1, 2].map(|k| {
            v[vi("psi")] * [0.0, 0.0, 1.0][k] + v[vi("th")] * nodes[k] + v[vi("phi")] * axis[k]
        });
        (r, w)
    }
}

#[test]
fn nutating_top_conserves_energy_and_vertical_momentum() {
    let (m, _, i1, i3) = TOP;
    // released with spin and a small precession and tilt rate: it nutates
    let (theta, omega3) = (0.5, 30.0);
    for free in [false, true] {
        let sys = system(&top(free, theta, omega3, 0.5, 0.3));
        let traj = run(&sys, 20.0, 0.01);
        let idx = ["x", "y", "z"].map(|c| sys.coordinate_index(&format!("top.{c}")).unwrap());
        let vidx = ["x", "y", "z"].map(|c| {
            let name = if free {
                format!("top.v{c}")
            } else {
                format!("top.{c}")
            };
            sys.velocity_index(&name).unwrap()
        });
        let invariants = |q: &[f64], v: &[f64]| {
            let energy = sys.kinetic_energy(q, v) + sys.potential_energy(q, 0.0);
            // H_O = m r × ṙ + R I Rᵀ ω about the tip (the origin)
            let (r, w) = top_rotation(&sys, free, q, v);
            let wb = mat_t_vec(&r, w);
            let h = mat_vec(&r, [i1 * wb[0], i1 * wb[1], i3 * wb[2]]);
            let (x, xd) = (idx.map(|i| q[i]), vidx.map(|i| v[i]));
            let orbital = cross(x, xd);
            (energy, m * orbital[2] + h[2])
        };
        let (e0, h0) = invariants(traj.q(0), traj.v(0));
        let (mut de, mut dh, mut dn, mut th_min, mut th_max) =
            (0.0f64, 0.0f64, 0.0f64, f64::INFINITY, 0.0f64);
        for (q, v) in traj.qs().zip(traj.vs()) {
            let (e, h) = invariants(q, v);
            de = de.max((e - e0).abs() / e0.abs());
            dh = dh.max((h - h0).abs() / h0.abs());
            let x = idx.map(|i| q[i]);
            let th = x[0].hypot(x[1]).atan2(x[2]);
            th_min = th_min.min(th);
            th_max = th_max.max(th);
            if free {
                let o = sys.coordinate_index("top.qw").unwrap();
                let n = q[o..o + 4].iter().map(|x| x * x).sum::<f64>().sqrt();
                dn = dn.max((n - 1.0).abs());
            }
        }
        println!(
            "nutating top ({}), 20 s: θ in [{th_min:.4}, {th_max:.4}] rad, energy {e0:.6} J relative drift {de:.3e}, H_z {h0:.6} relative drift {dh:.3e}, |q| − 1 up to {dn:.1e}; {} steps",
            if free {
                "free body"
            } else {
                "Euler angles z, x, z"
            },
            traj.stats.accepted_steps
        );
        assert!(th_max - th_min > 0.01, "the top should nutate");
        assert!(de < 1e-9, "energy drift {de:e}");
        assert!(dh < 1e-9, "vertical angular momentum drift {dh:e}");
        assert!(dn < 1e-12, "quaternion norm off by {dn:e}");
    }
}

// ---- gimbal lock -----------------------------------------------------------------------

/// SPEC's push-rod body (R = Rz(a) Rx(b), inertia [I, 0, I]: no inertia about its own
/// axis, body y) turning about z and driven to b = 90° by a prescribed b(t) = t: there its
/// angles' mass matrix diag(I cos² b, I) is singular, and a = p_a / (I cos² b) blows up.
#[test]
fn angle_sequence_driven_into_gimbal_lock_stops_with_a_typed_failure() {
    let text = r#"
[[bodies]]
name = "rod"
rotation = [["z", "a"], ["x", "b"]]
mass = 0.12
inertia = [1.8225e-4, 0, 1.8225e-4]
velocity = { a = 1.0 }

[[constraints]]
name = "drive"
expr = "rod.b - t"
"#;
    let sys = system(text);
    let start = assemble(&sys).unwrap();
    let err = simulate(&sys, &start, &SimOptions::default(), &mut |_| true)
        .expect_err("the run must stop at gimbal lock");
    let Error::Failed {
        failure: Failure::SingularMass { t, body, rcond },
        ..
    } = &err
    else {
        panic!("{err:?}");
    };
    println!(
        "gimbal lock: stopped at t = {t:.9} s (b = 90° at {:.9} s), body `{body}`, rcond {rcond:.3e}: {err}",
        PI / 2.0
    );
    assert_eq!(body, "rod");
    assert!(*rcond < 1e-8 && *rcond >= 0.0);
    assert!((t - PI / 2.0).abs() < 1e-3);
    let hint = err.to_string()
        + &Failure::SingularMass {
            t: *t,
            body: body.clone(),
            rcond: *rcond,
        }
        .hint();
    assert!(hint.contains("rotation = \"free\""), "{hint}");
}

// ---- element level: joints and forces along the retraction -----------------------------

/// A deterministic pseudo-random sequence (Knuth's MMIX linear congruential generator).
struct Lcg(u64);

impl Lcg {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// A random state: positions in [−1, 1] m, angles in [−π, π], a random unit quaternion,
/// velocities in [−1.5, 1.5].
fn random_state(sys: &System, r: &mut Lcg) -> (Vec<f64>, Vec<f64>) {
    let mut q: Vec<f64> = (0..sys.nq())
        .map(|i| {
            if sys.is_angle(i) {
                r.uniform(-PI, PI)
            } else {
                r.uniform(-1.0, 1.0)
            }
        })
        .collect();
    sys.normalize(&mut q);
    let v = (0..sys.nv()).map(|_| r.uniform(-1.5, 1.5)).collect();
    (q, v)
}

/// q ⊕ s·d.
fn retracted(sys: &System, q: &[f64], d: &[f64], s: f64) -> Vec<f64> {
    let mut out = q.to_vec();
    sys.retract(&mut out, d, s);
    out
}

fn unit(n: usize, j: usize) -> Vec<f64> {
    let mut e = vec![0.0; n];
    e[j] = 1.0;
    e
}

/// |got − want|∞ / (1 + |want|∞).
fn err(got: &[f64], want: &[f64]) -> f64 {
    let diff = got
        .iter()
        .zip(want)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    diff / (1.0 + want.iter().fold(0.0f64, |m, b| m.max(b.abs())))
}

const H: f64 = 1e-5;
/// Central first differences with h = 1e-5 of quantities of order 1: truncation and
/// rounding near 1e-10.
const TOL: f64 = 1e-7;

/// Two bodies: `a` free (its frame origin 0.1 m off its CG), `b` with three angles.
const TWO_BODIES: &str = r#"
[[bodies]]
name = "a"
rotation = "free"
mass = 1.3
inertia = [0.2, 0.3, 0.4, 0.01, -0.02, 0.03]
cg = [0.1, -0.05, 0.02]

[[bodies]]
name = "b"
rotation = [["z", "p"], ["y", "r"], ["x", "s"]]
mass = 0.7
inertia = [0.05, 0.06, 0.07]
"#;

/// A and b of `sys`'s constraints against differences along the retraction at random
/// states: A's column j against (Φ(q ⊕ h e_j) − Φ(q ⊕ −h e_j)) / 2h, and b against
/// −d/ds [A(q ⊕ s v) v] (the body rates are constant along q ⊕ s v, so A v is dΦ/ds).
fn check_joint(label: &str, sys: &System, seed: u64) -> (f64, f64) {
    let (m, nv) = (sys.m(), sys.nv());
    assert!(m > 0, "{label}: no rows");
    let mut ws = Workspace::new(sys);
    let mut a = DMatrix::zeros(m, nv);
    let mut b = DVector::zeros(m);
    let mut r = Lcg(seed);
    let (mut ea, mut eb) = (0.0f64, 0.0f64);
    for _ in 0..8 {
        let (q, v) = random_state(sys, &mut r);
        sys.jacobian(&mut ws, &q, 0.0, &mut a);
        let cols: Vec<DVector<f64>> = (0..nv)
            .map(|j| {
                let e = unit(nv, j);
                (sys.residual(&retracted(sys, &q, &e, H), 0.0)
                    - sys.residual(&retracted(sys, &q, &e, -H), 0.0))
                    / (2.0 * H)
            })
            .collect();
        let a_fd = DMatrix::from_columns(&cols);
        let e = err(a.as_slice(), a_fd.as_slice());
        assert!(e < TOL, "{label}: A {a} vs differences {a_fd} ({e:e})");
        ea = ea.max(e);

        sys.bias(&mut ws, &q, &v, 0.0, &mut b);
        let vv = DVector::from_column_slice(&v);
        let av = |s: f64| {
            let mut ah = DMatrix::zeros(m, nv);
            sys.jacobian(&mut ws.clone(), &retracted(sys, &q, &v, s), 0.0, &mut ah);
            ah * &vv
        };
        let b_fd = -(av(H) - av(-H)) / (2.0 * H);
        let e = err(b.as_slice(), b_fd.as_slice());
        assert!(e < TOL, "{label}: b {b} vs differences {b_fd} ({e:e})");
        eb = eb.max(e);
    }
    (ea, eb)
}

#[test]
fn spatial_joints_jacobian_and_bias_along_the_retraction() {
    let kinds: [(&str, &str); 7] = [
        (
            "revolute",
            "axis = [0.3, -0.5, 0.8]\naxis2 = [0.1, 0.9, -0.2]",
        ),
        ("spherical", ""),
        ("universal", "axis = [1, 0.2, 0]\naxis2 = [0, 0.3, 1]"),
        (
            "prismatic",
            "axis = [0.3, -0.5, 0.8]\naxis2 = [0.1, 0.9, -0.2]",
        ),
        ("cylindrical", "axis = [0.3, -0.5, 0.8]"),
        ("fixed", ""),
        ("distance", "length = 0.7"),
    ];
    let pairs = [("a", "b"), ("b", "a"), ("a", "ground"), ("b", "ground")];
    let mut seed = 1;
    for (kind, fields) in kinds {
        let (mut ea, mut eb) = (0.0f64, 0.0f64);
        for (b1, b2) in pairs {
            let text = format!(
                "{TWO_BODIES}\n[[joints]]\nname = \"J\"\ntype = \"{kind}\"\nbody1 = \"{b1}\"\n\
                 point1 = [0.2, -0.1, 0.3]\nbody2 = \"{b2}\"\npoint2 = [-0.3, 0.25, 0.1]\n{fields}\n"
            );
            let sys = system(&text);
            seed += 1;
            let (a, b) = check_joint(&format!("{kind} {b1}–{b2}"), &sys, seed);
            ea = ea.max(a);
            eb = eb.max(b);
        }
        println!("{kind:<12} worst A error {ea:.2e}, b error {eb:.2e}");
    }
    // a custom constraint reading a free body's quaternion and another body's angle: its
    // columns are the free body's rotations (and the angle's)
    let text = format!(
        "{TWO_BODIES}\n[[constraints]]\nname = \"C\"\nexpr = \"a.qx*a.qy + a.z*a.qw - b.r*a.qz\"\n"
    );
    let sys = system(&text);
    let (ea, eb) = check_joint("custom", &sys, 99);
    println!("{:<12} worst A error {ea:.2e}, b error {eb:.2e}", "custom");
}

#[test]
fn spatial_forces_are_minus_the_gradient_of_their_potential() {
    // A torsion spring's torque acts about body 1's axis: it is the gradient of its
    // potential where the two bodies' axes coincide (its use: on a joint's axis), so its
    // states turn the bodies about that axis only (a free `a`: exp(θ â); `b`: its first
    // angle, about z). The spring is checked at any state.
    let axis = [0.3, -0.5, 0.8];
    let elements: [(&str, String, Option<V3>); 4] = [
        (
            "spring_damper",
            "body1 = \"a\"\npoint1 = [0.2, -0.1, 0.3]\nbody2 = \"b\"\npoint2 = [-0.3, 0.25, 0.1]\nstiffness = 300\nfree_length = 0.4".into(),
            None,
        ),
        (
            "spring_damper",
            "body1 = \"b\"\npoint1 = [0.2, -0.1, 0.3]\nbody2 = \"ground\"\npoint2 = [-0.3, 0.25, 0.1]\nstiffness = 300\nfree_length = 0.4".into(),
            None,
        ),
        (
            "torsion",
            format!(
                "body1 = \"a\"\nbody2 = \"ground\"\naxis = [{:?}, {:?}, {:?}]\nstiffness = 40\nfree_angle = 0.3",
                axis[0], axis[1], axis[2]
            ),
            Some(axis),
        ),
        (
            "torsion",
            "body1 = \"b\"\nbody2 = \"a\"\naxis = [0, 0, 1]\nstiffness = 40\nfree_angle = -0.2".into(),
            Some([0.0, 0.0, 1.0]),
        ),
    ];
    for (seed, (kind, fields, aligned)) in elements.into_iter().enumerate() {
        let text = format!("{TWO_BODIES}\n[[forces]]\nname = \"F\"\ntype = \"{kind}\"\n{fields}\n");
        let sys = system(&text);
        let nv = sys.nv();
        let mut r = Lcg(100 + seed as u64);
        let mut worst = 0.0f64;
        for _ in 0..8 {
            let (mut q, _) = random_state(&sys, &mut r);
            if let Some(n) = aligned {
                let l = dot(n, n).sqrt();
                let (s, c) = (0.5 * r.uniform(-PI, PI)).sin_cos();
                let o = sys.coordinate_index("a.qw").unwrap();
                q[o..o + 4].copy_from_slice(&[c, s * n[0] / l, s * n[1] / l, s * n[2] / l]);
                for name in ["b.r", "b.s"] {
                    q[sys.coordinate_index(name).unwrap()] = 0.0;
                }
            }
            let mut f = vec![0.0; nv];
            sys.forces(&q, &vec![0.0; nv], 0.0, &mut f);
            let grad: Vec<f64> = (0..nv)
                .map(|j| {
                    let e = unit(nv, j);
                    -(sys.potential_energy(&retracted(&sys, &q, &e, H), 0.0)
                        - sys.potential_energy(&retracted(&sys, &q, &e, -H), 0.0))
                        / (2.0 * H)
                })
                .collect();
            let e = err(&f, &grad);
            assert!(e < TOL, "{kind}: f {f:?} vs −∇V {grad:?} ({e:e})");
            worst = worst.max(e);
        }
        println!("{kind:<14} worst error against −∇V {worst:.2e}");
    }
}

// ---- free bodies in the model file ------------------------------------------------------

#[test]
fn free_body_fields_and_refusals() {
    let body = |extra: &str| {
        format!(
            "[[bodies]]\nname = \"b\"\nrotation = \"free\"\nmass = 1\ninertia = [1, 2, 2.5]\n{extra}\n"
        )
    };
    // the orientation is normalized on load; the names of q and v
    let sys = system(&body("orientation = [2, 0, 0, 2]\nvelocity = { wz = 3 }"));
    let h = 0.5f64.sqrt();
    assert!(err(&sys.initial.q[3..], &[h, 0.0, 0.0, h]) < 1e-15);
    assert_eq!((sys.nq(), sys.nv()), (7, 6));
    assert_eq!(sys.coordinates[3..], ["b.qw", "b.qx", "b.qy", "b.qz"]);
    assert_eq!(
        sys.velocities,
        ["b.vx", "b.vy", "b.vz", "b.wx", "b.wy", "b.wz"]
    );
    assert_eq!(sys.velocity_columns()[3], "b.wx");
    assert!(!sys.is_angle(3));
    // statics (and everything built on it) refuses free bodies, for now
    let start = assemble(&sys).unwrap();
    let e = detune::statics::Statics::new(&sys, &start.q)
        .err()
        .expect("statics of a free body is refused");
    assert!(e.to_string().contains("not supported yet"), "{e}");
    // located refusals
    for (extra, says) in [
        ("orientation = [1, 0, 0]", "needs 4 components"),
        ("orientation = [0, 0, 0, 0]", "is zero"),
        ("fix = [\"qw\"]", "cannot fix `qw`"),
        ("angles = { a = 1 }", "`angles` of free body"),
        ("velocity = { x = 1 }", "not a velocity of free body"),
        ("theta = 1", "a unit quaternion"),
    ] {
        let text = body(extra);
        let e = Model::from_str("free.toml", &text)
            .and_then(|m| System::new(&m))
            .err()
            .unwrap_or_else(|| panic!("accepted: {extra}"));
        let shown = format!("{e}");
        assert!(shown.contains(says), "{extra}: {shown}");
    }
    // a sequence body has no quaternion
    let e = Model::from_str(
        "seq.toml",
        "[[bodies]]\nname = \"b\"\nrotation = [[\"z\", \"a\"]]\nmass = 1\ninertia = [1, 1, 1]\norientation = [1, 0, 0, 0]\n",
    )
    .err()
    .expect("orientation of a sequence body is refused");
    assert!(format!("{e}").contains("`orientation` of body `b`"), "{e}");
}
