//! Spatial bodies, joints and forces.
//!
//! A spatial body has the coordinates `x, y, z` of its centre of gravity (CG) and either
//!
//! * the angles of a sequence of rotations about body axes, `R = R_a1(θ1) R_a2(θ2)
//!   R_a3(θ3)` (active, right-handed: `R p` takes a body-frame vector to the ground
//!   frame), its velocities the rates of its coordinates; or
//! * (a free body, `rotation = "free"`) a unit quaternion `(qw, qx, qy, qz)`, with the
//!   CG's velocity and the angular velocity ω_b **in the body frame** as its velocities:
//!   7 coordinates, 6 velocities. It moves by `q̇ = ½ q ⊗ (0, ω_b)` and is stepped by
//!   the retraction `q ⊕ δ = q ⊗ exp(δ_ω)` (normalized), so it has no singular pose. R is
//!   computed from q/|q| ([`Pose3::from_quat`]).
//!
//! * The world angular velocity is `ω = Σ θ̇_i (R_a1 … R_a(i−1)) e_ai`: the columns
//!   `jw` of [`Pose3`], computed with R. A generalized force from a world torque τ is
//!   `jwᵀ τ`; the derivative of R along angle i is `[jw_i]× R`. For a free body
//!   `jw = R` (ω = R ω_b): a world torque gives the body-frame torque `Rᵀ τ`, and the
//!   derivative along a rotation about body axis k, `R [e_k]× = [R e_k]× R`, is the same
//!   formula. Along the motion `R exp(s [ω_b]×)` (for the bias b), `d/ds R = R [ω_b]×`
//!   and `d²/ds² R = R [ω_b]×²` ([`Pose3::along_free`]).
//! * The kinetic energy is `T = ½ m |ṙ|² + ½ ω_bᵀ I ω_b` with `ω_b = Rᵀ ω` and I the
//!   inertia tensor about the CG in the body frame. The mass matrix of the angles is
//!   `∂²T/∂θ̇² = J_bᵀ I J_b`; the velocity forces `∂T/∂θ − Ṁ θ̇` come from T by dual
//!   numbers ([`velocity_forces`]): no hand-derived velocity terms, for any sequence.
//!   For a free body the body rates are quasi-velocities (not the rates of any
//!   coordinates): with `T = ½ m |ṙ|² + ½ ω_bᵀ I ω_b` its mass matrix is the constant
//!   `diag(m I₃, I)` and its equations are Euler's, `I ω̇_b = Rᵀ τ − ω_b × (I ω_b)`: the
//!   velocity force is the gyroscopic `−ω_b × (I ω_b)` ([`gyroscopic`]).
//!
//! Joints relate point 1 on body 1 to point 2 on body 2 (or the ground), with axes given
//! in each body's frame. Rows that the bodies' own coordinates satisfy identically (a
//! revolute between the ground and a body that can only turn about its axis) are dropped
//! when the model is compiled (`keep`).

use super::frame::Frames;
use crate::model::SpatialJoint;
use crate::scalar::{Env, Scalar};
use num_dual::{Dual, Dual64};

pub type V3<D> = [D; 3];
/// Row-major 3 × 3.
pub type M3<D> = [[D; 3]; 3];

#[inline]
pub fn cross<D: Scalar>(a: V3<D>, b: V3<D>) -> V3<D> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline]
pub fn dot<D: Scalar>(a: V3<D>, b: V3<D>) -> D {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
pub fn sub<D: Scalar>(a: V3<D>, b: V3<D>) -> V3<D> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
pub fn add<D: Scalar>(a: V3<D>, b: V3<D>) -> V3<D> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline]
pub fn mat_vec<D: Scalar>(m: &M3<D>, v: V3<D>) -> V3<D> {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

#[inline]
pub fn mat_t_vec<D: Scalar>(m: &M3<D>, v: V3<D>) -> V3<D> {
    [
        m[0][0] * v[0] + m[1][0] * v[1] + m[2][0] * v[2],
        m[0][1] * v[0] + m[1][1] * v[1] + m[2][1] * v[2],
        m[0][2] * v[0] + m[1][2] * v[1] + m[2][2] * v[2],
    ]
}

/// The rotation of a spatial body: its axes sequence (0 = x, 1 = y, 2 = z), or a unit
/// quaternion (a free body), and where its coordinates and velocities start.
#[derive(Debug, Clone)]
pub struct Geom3 {
    /// The body's first coordinate in q.
    pub offset: usize,
    /// The body's first velocity in v.
    pub voff: usize,
    /// The rotation sequence (empty for a free body).
    pub axes: Vec<usize>,
    /// A free body: q = (x, y, z, qw, qx, qy, qz), v = (ẋ, ẏ, ż, ω_b).
    pub free: bool,
}

impl Geom3 {
    /// Number of coordinates (3 + angles, or 7).
    pub fn nq(&self) -> usize {
        if self.free { 7 } else { 3 + self.axes.len() }
    }

    /// Number of velocities (3 + angles, or 6).
    pub fn nv(&self) -> usize {
        3 + self.nrot()
    }

    /// Number of rotational velocities (angle rates, or the 3 body rates).
    pub fn nrot(&self) -> usize {
        if self.free { 3 } else { self.axes.len() }
    }
}

// ---- quaternions (w, x, y, z), active: R(q) v = q (0, v) q* ----------------------------

pub type Quat = [f64; 4];

/// The Hamilton product a ⊗ b.
#[inline]
pub fn quat_mul(a: Quat, b: Quat) -> Quat {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// q / |q|.
#[inline]
pub fn quat_normalize(q: Quat) -> Quat {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    q.map(|x| x / n)
}

/// exp of a rotation vector φ: the unit quaternion (cos(|φ|/2), sin(|φ|/2) φ/|φ|).
#[inline]
pub fn quat_exp(phi: V3<f64>) -> Quat {
    let a = dot(phi, phi).sqrt();
    let h = 0.5 * a;
    // sin(h)/a, with its series near 0 (h²/6 below 1e-17 there)
    let k = if a < 1e-8 { 0.5 } else { h.sin() / a };
    [h.cos(), k * phi[0], k * phi[1], k * phi[2]]
}

/// The rotation vector φ of a unit quaternion (the inverse of [`quat_exp`] with |φ| ≤ π:
/// q and −q are the same rotation).
#[inline]
pub fn quat_log(q: Quat) -> V3<f64> {
    let q = if q[0] < 0.0 { q.map(|x| -x) } else { q };
    let s = (q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let a = 2.0 * s.atan2(q[0]);
    // a / s, with its limit 2/w at s → 0
    let k = if s < 1e-12 { 2.0 / q[0] } else { a / s };
    [k * q[1], k * q[2], k * q[3]]
}

/// q ⊗ (0, ω) / 2: the quaternion's rate for the body-frame angular velocity ω.
#[inline]
pub fn quat_rate(q: Quat, w: V3<f64>) -> Quat {
    quat_mul(q, [0.0, w[0], w[1], w[2]]).map(|x| 0.5 * x)
}

/// A spatial body's pose in type D: CG r, rotation R (body → world), and the world
/// angular velocity per angle rate (`jw[i]`, for i < the number of angles; a free body:
/// per body rate, R's columns).
#[derive(Debug, Clone, Copy)]
pub struct Pose3<D> {
    pub r: V3<D>,
    pub rot: M3<D>,
    pub jw: [V3<D>; 3],
}

/// `rot ← rot · R_axis(θ)` given sin and cos of θ.
#[inline]
fn post_rotate<D: Scalar>(rot: &mut M3<D>, axis: usize, s: D, c: D) {
    let (i, j) = match axis {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    for row in rot.iter_mut() {
        let (ci, cj) = (row[i], row[j]);
        row[i] = ci * c + cj * s;
        row[j] = cj * c - ci * s;
    }
}

impl<D: Scalar> Pose3<D> {
    pub fn zero() -> Self {
        let z = D::from(0.0);
        Pose3 {
            r: [z; 3],
            rot: [[z; 3]; 3],
            jw: [[z; 3]; 3],
        }
    }

    /// The pose of a spatial body from its coordinates.
    #[inline]
    pub fn from_q(q: &[D], g: &Geom3) -> Self {
        let o = g.offset;
        if g.free {
            return Self::from_quat(
                [q[o], q[o + 1], q[o + 2]],
                [q[o + 3], q[o + 4], q[o + 5], q[o + 6]],
            );
        }
        Self::from_parts(
            [q[o], q[o + 1], q[o + 2]],
            &q[o + 3..o + 3 + g.axes.len()],
            &g.axes,
        )
    }

    /// The pose from the CG and the angles of the sequence `axes`.
    #[inline]
    pub fn from_parts(r: V3<D>, angles: &[D], axes: &[usize]) -> Self {
        let (z, one) = (D::from(0.0), D::from(1.0));
        let mut rot = [[one, z, z], [z, one, z], [z, z, one]];
        let mut jw = [[z; 3]; 3];
        for (i, (&a, &th)) in axes.iter().zip(angles).enumerate() {
            jw[i] = [rot[0][a], rot[1][a], rot[2][a]];
            let (s, c) = th.sin_cos();
            post_rotate(&mut rot, a, s, c);
        }
        Pose3 { r, rot, jw }
    }

    /// The pose from the CG and a quaternion (w, x, y, z): R is the rotation of q/|q|, so
    /// a quaternion off unit norm (between normalizations) still gives a rotation. The
    /// velocities are the body rates: `jw` are R's columns (ω = R ω_b).
    #[inline]
    pub fn from_quat(r: V3<D>, q: [D; 4]) -> Self {
        let [w, x, y, z] = q;
        let s = D::from(2.0) / (w * w + x * x + y * y + z * z);
        let one = D::from(1.0);
        let rot = [
            [
                one - s * (y * y + z * z),
                s * (x * y - w * z),
                s * (x * z + w * y),
            ],
            [
                s * (x * y + w * z),
                one - s * (x * x + z * z),
                s * (y * z - w * x),
            ],
            [
                s * (x * z - w * y),
                s * (y * z + w * x),
                one - s * (x * x + y * y),
            ],
        ];
        Pose3 {
            r,
            rot,
            jw: columns(&rot),
        }
    }

    /// The body-frame angular velocity per angle rate, `J_b = Rᵀ jw` (columns).
    #[inline]
    pub fn body_rates(&self, n: usize) -> [V3<D>; 3] {
        let mut jb = [[D::from(0.0); 3]; 3];
        for i in 0..n {
            jb[i] = mat_t_vec(&self.rot, self.jw[i]);
        }
        jb
    }
}

impl Pose3<f64> {
    /// This pose as dual numbers with zero derivative.
    #[inline]
    pub fn lift(&self) -> Pose3<Dual64> {
        let l = |v: V3<f64>| v.map(Dual64::from);
        Pose3 {
            r: l(self.r),
            rot: self.rot.map(l),
            jw: self.jw.map(l),
        }
    }

    /// This pose carrying its derivative along tangent direction `d` of the body (0..3:
    /// the CG's x, y, z; 3 + i: angle i, or a free body's rotation about body axis i):
    /// `∂R/∂θ_i = [jw_i]× R` (for a free body `R [e_i]× = [R e_i]× R`, the same with
    /// jw_i = R e_i). Only r and R carry the derivative (what constraints read).
    #[inline]
    pub fn seeded(&self, d: usize) -> Pose3<Dual64> {
        let mut p = self.lift();
        self.seed_into(&mut p, d);
        p
    }

    /// [`Pose3::seeded`] in place on this pose's lift `p` (whose derivative parts are
    /// zero): only the derivative parts are written. Undo with [`Pose3::unseed`].
    #[inline]
    pub fn seed_into(&self, p: &mut Pose3<Dual64>, d: usize) {
        if d < 3 {
            p.r[d].eps = 1.0;
        } else {
            let w = self.jw[d - 3];
            for k in 0..3 {
                let col = [self.rot[0][k], self.rot[1][k], self.rot[2][k]];
                let dc = cross(w, col);
                for (row, x) in dc.iter().enumerate() {
                    p.rot[row][k].eps = *x;
                }
            }
        }
    }

    /// Clear the derivative parts [`Pose3::seed_into`] wrote.
    #[inline]
    pub fn unseed(p: &mut Pose3<Dual64>) {
        for x in &mut p.r {
            x.eps = 0.0;
        }
        for row in &mut p.rot {
            for x in row {
                x.eps = 0.0;
            }
        }
    }
}

impl Pose3<f64> {
    /// A free body's pose along the motion `q ⊕ s·v` as second-order dual numbers in s
    /// (for the bias b): r + s ṙ, and `R exp(s [ω]×)`, whose derivatives at s = 0 are
    /// `R [ω]×` and `R [ω]×²`. `v` holds ṙ then ω (body frame).
    #[inline]
    pub fn along_free(&self, v: &[f64]) -> Pose3<num_dual::Dual2_64> {
        use num_dual::Dual2_64 as D2;
        let w = [v[3], v[4], v[5]];
        // a row r of R [ω]× is r [ω]× = r × ω; R [ω]×² = (R [ω]×) [ω]×
        let rw: M3<f64> = self.rot.map(|row| cross(row, w));
        let rw2: M3<f64> = rw.map(|row| cross(row, w));
        let mut rot = [[D2::from(0.0); 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                rot[i][j] = D2::new(self.rot[i][j], rw[i][j], rw2[i][j]);
            }
        }
        Pose3 {
            r: [0, 1, 2].map(|i| D2::new(self.r[i], v[i], 0.0)),
            rot,
            jw: columns(&rot),
        }
    }
}

/// The columns of a matrix.
#[inline]
fn columns<D: Copy>(m: &M3<D>) -> [V3<D>; 3] {
    [0, 1, 2].map(|k| [m[0][k], m[1][k], m[2][k]])
}

/// A point fixed in a spatial body (or the ground): body-frame coordinates from the
/// frame's origin (three coefficients) and the body's CG in its frame (None: the ground,
/// or a body whose frame origin is its CG).
#[derive(Debug, Clone, Copy)]
pub struct SysPoint3 {
    pub body: Option<usize>,
    pub p: [usize; 3],
    pub cg: Option<[usize; 3]>,
}

impl<D: Scalar, E: Env<D>> Frames<'_, D, E> {
    /// R v for a body-frame vector of three coefficients (the ground does not rotate).
    #[inline]
    pub fn rotate3(&self, body: Option<usize>, v: [usize; 3]) -> V3<D> {
        let e = self.env;
        match body {
            Some(k) => {
                let m = &self.poses3[k].rot;
                let mut out = [D::from(0.0); 3];
                for (i, o) in out.iter_mut().enumerate() {
                    *o = e.mul_coef(v[0], m[i][0])
                        + e.mul_coef(v[1], m[i][1])
                        + e.mul_coef(v[2], m[i][2]);
                }
                out
            }
            None => {
                let g = [e.coef(v[0]), e.coef(v[1]), e.coef(v[2])];
                match self.ground.rotation3() {
                    Some(r) => mat_vec(r, g),
                    None => g,
                }
            }
        }
    }

    /// World offset of a point from its body's CG (the ground: from its origin).
    #[inline]
    pub fn arm3(&self, pt: &SysPoint3) -> V3<D> {
        let e = self.env;
        match pt.body {
            Some(k) => {
                let local: V3<D> = match pt.cg {
                    Some(c) => [
                        e.coef(pt.p[0]) - e.coef(c[0]),
                        e.coef(pt.p[1]) - e.coef(c[1]),
                        e.coef(pt.p[2]) - e.coef(c[2]),
                    ],
                    None => [e.coef(pt.p[0]), e.coef(pt.p[1]), e.coef(pt.p[2])],
                };
                mat_vec(&self.poses3[k].rot, local)
            }
            None => self.rotate3(None, pt.p),
        }
    }

    /// World position of a point.
    #[inline]
    pub fn position3(&self, pt: &SysPoint3) -> V3<D> {
        let r = match pt.body {
            Some(k) => self.poses3[k].r,
            None => self.ground.r,
        };
        add(r, self.arm3(pt))
    }

    /// World angular velocity of a body (the ground: 0), with `v` the velocities.
    #[inline]
    pub fn omega3(&self, v: &[D], body: Option<usize>) -> V3<D> {
        let mut w = [D::from(0.0); 3];
        if let Some(k) = body {
            let o = self.offsets[k] + 3;
            let p = &self.poses3[k];
            for i in 0..self.nrot[k] {
                for (c, x) in w.iter_mut().enumerate() {
                    *x += p.jw[i][c] * v[o + i];
                }
            }
            return w;
        }
        self.ground.omega3()
    }

    /// World velocity of a point: ṙ + ω × arm.
    #[inline]
    pub fn velocity3(&self, v: &[D], pt: &SysPoint3) -> V3<D> {
        match pt.body {
            Some(k) => {
                let o = self.offsets[k];
                let w = self.omega3(v, pt.body);
                add([v[o], v[o + 1], v[o + 2]], cross(w, self.arm3(pt)))
            }
            None => match self.ground.rot3 {
                Some((_, w, _)) => add(self.ground.vel, cross(w, self.arm3(pt))),
                None => self.ground.vel,
            },
        }
    }

    /// Add a world torque on a body to the generalized forces: `jwᵀ τ` on its angles.
    #[inline]
    pub fn apply_torque3(&self, body: Option<usize>, tau: V3<D>, out: &mut [D]) {
        if let Some(k) = body {
            let o = self.offsets[k] + 3;
            let p = &self.poses3[k];
            for i in 0..self.nrot[k] {
                out[o + i] += dot(p.jw[i], tau);
            }
        }
    }

    /// Add a world force at a point: F on the CG, (arm × F) as a torque.
    #[inline]
    pub fn apply3(&self, pt: &SysPoint3, f: V3<D>, out: &mut [D]) {
        if let Some(k) = pt.body {
            let o = self.offsets[k];
            for i in 0..3 {
                out[o + i] += f[i];
            }
            let tau = cross(self.arm3(pt), f);
            self.apply_torque3(pt.body, tau, out);
        }
    }
}

/// A spatial joint: its type, its points, the frames (a, u, w) of its axis in body 1's
/// and body 2's frames (coefficients), and which of its rows are kept.
#[derive(Debug, Clone)]
pub struct Joint3 {
    pub kind: SpatialJoint,
    pub a: SysPoint3,
    pub b: SysPoint3,
    /// (a, u, w) in body 1's frame.
    pub f1: Option<[[usize; 3]; 3]>,
    /// (a, u, w) in body 2's frame.
    pub f2: Option<[[usize; 3]; 3]>,
    /// distance: the length (coefficient).
    pub length: Option<usize>,
    /// The rows kept, in order (indices into [`Joint3::all_rows`]).
    pub keep: Vec<usize>,
    /// Coefficients 0 and 1 (the unit vectors of `fixed`).
    pub unit: UnitCoefs,
}

/// Unit vectors of the bodies' own frames (for `fixed`): coefficient indices set at
/// compile time to 0 and 1.
#[derive(Debug, Clone, Copy)]
pub struct UnitCoefs {
    pub zero: usize,
    pub one: usize,
}

impl Joint3 {
    /// The names of every row the type can have, in order.
    pub fn all_rows(kind: SpatialJoint) -> &'static [&'static str] {
        match kind {
            SpatialJoint::Spherical => &["x", "y", "z"],
            SpatialJoint::Revolute => &["x", "y", "z", "axis_u", "axis_w"],
            SpatialJoint::Universal => &["x", "y", "z", "cross"],
            SpatialJoint::Cylindrical => &["slide_u", "slide_w", "axis_u", "axis_w"],
            SpatialJoint::Prismatic => &["slide_u", "slide_w", "axis_u", "axis_w", "twist"],
            SpatialJoint::Fixed => &["x", "y", "z", "rot_x", "rot_y", "rot_z"],
            SpatialJoint::Distance => &["length"],
        }
    }

    /// Row-name suffixes of the rows kept.
    pub fn row_names(&self) -> Vec<&'static str> {
        let all = Self::all_rows(self.kind);
        self.keep.iter().map(|&i| all[i]).collect()
    }

    pub fn rows(&self) -> usize {
        self.keep.len()
    }

    /// The joint's kept rows of Φ into `out`.
    #[inline]
    pub fn phi<D: Scalar, E: Env<D>>(&self, fr: &Frames<'_, D, E>, out: &mut [D]) {
        let mut all = [D::from(0.0); 6];
        self.all_phi(fr, self.unit, &mut all);
        for (o, &i) in out.iter_mut().zip(&self.keep) {
            *o = all[i];
        }
    }

    fn all_phi<D: Scalar, E: Env<D>>(
        &self,
        fr: &Frames<'_, D, E>,
        unit: UnitCoefs,
        out: &mut [D; 6],
    ) {
        let pa = fr.position3(&self.a);
        let pb = fr.position3(&self.b);
        let d = sub(pa, pb);
        let (b1, b2) = (self.a.body, self.b.body);
        let frame = |f: Option<[[usize; 3]; 3]>, body, i: usize| {
            fr.rotate3(body, f.expect("a joint with an axis has its frames")[i])
        };
        match self.kind {
            SpatialJoint::Spherical => out[..3].copy_from_slice(&d),
            SpatialJoint::Revolute => {
                out[..3].copy_from_slice(&d);
                // (the axis rows are often dropped as identical: not computed then)
                if self.keep.len() > 3 {
                    let a1 = frame(self.f1, b1, 0);
                    out[3] = dot(a1, frame(self.f2, b2, 1));
                    out[4] = dot(a1, frame(self.f2, b2, 2));
                }
            }
            SpatialJoint::Universal => {
                out[..3].copy_from_slice(&d);
                // the cross axis is `axis2` itself (the frame's a in body 2)
                out[3] = dot(frame(self.f1, b1, 0), frame(self.f2, b2, 0));
            }
            SpatialJoint::Cylindrical | SpatialJoint::Prismatic => {
                let (u2, w2) = (frame(self.f2, b2, 1), frame(self.f2, b2, 2));
                out[0] = dot(d, u2);
                out[1] = dot(d, w2);
                let a1 = frame(self.f1, b1, 0);
                out[2] = dot(a1, u2);
                out[3] = dot(a1, w2);
                if self.kind == SpatialJoint::Prismatic {
                    out[4] = dot(frame(self.f1, b1, 1), w2);
                }
            }
            SpatialJoint::Fixed => {
                out[..3].copy_from_slice(&d);
                let e = |i: usize| {
                    let mut c = [unit.zero; 3];
                    c[i] = unit.one;
                    c
                };
                let ex1 = fr.rotate3(b1, e(0));
                let ey1 = fr.rotate3(b1, e(1));
                let ez1 = fr.rotate3(b1, e(2));
                let ex2 = fr.rotate3(b2, e(0));
                let ey2 = fr.rotate3(b2, e(1));
                let ez2 = fr.rotate3(b2, e(2));
                out[3] = dot(ey1, ez2);
                out[4] = dot(ez1, ex2);
                out[5] = dot(ex1, ey2);
            }
            SpatialJoint::Distance => {
                let l = fr
                    .env
                    .coef(self.length.expect("a distance joint has a length"));
                out[0] = (dot(d, d) - l * l) / (l + l);
            }
        }
    }
}

/// Impressed forces of spatial models.
#[derive(Debug, Clone)]
pub enum Force3 {
    /// T = k (L − L0) + c L̇ along P1→P2, tension positive.
    Spring {
        a: SysPoint3,
        b: SysPoint3,
        k: usize,
        c: usize,
        l0: usize,
        law: super::forces::Law,
    },
    /// Torsional spring–damper about axis frame (a, u, w) of body 1: torque on body 1
    /// −(k (twist − free) + c rate) a, the opposite on body 2.
    Torsion {
        b1: Option<usize>,
        b2: Option<usize>,
        frame: [[usize; 3]; 3],
        k: usize,
        c: usize,
        free: usize,
        law: super::forces::Law,
    },
    /// A world torque on a body.
    Torque {
        body: usize,
        torque: [crate::model::expr::Compiled; 3],
    },
    /// A world force at a point.
    Point {
        at: SysPoint3,
        f: [crate::model::expr::Compiled; 3],
    },
}

/// What a force element is doing at one state, for responses: the spring's length, rate
/// and tension, or the torsion's twist, rate and torque.
#[derive(Debug, Clone, Copy)]
pub struct ForceState<D> {
    pub stretch: D,
    pub rate: D,
    pub load: D,
    /// The direction the load acts along: the spring's unit vector from point 1 to 2, or
    /// the torsion's world axis.
    pub dir: V3<D>,
}

impl Force3 {
    /// The spring's (length, rate, tension) or the torsion's (twist, rate, torque).
    #[inline]
    pub fn state<D: Scalar, E: Env<D>>(
        &self,
        fr: &Frames<'_, D, E>,
        v: &[D],
    ) -> Option<ForceState<D>> {
        let e = fr.env;
        match self {
            Force3::Spring {
                a,
                b,
                k,
                c,
                l0,
                law,
            } => {
                let d = sub(fr.position3(b), fr.position3(a));
                let len = dot(d, d).sqrt();
                if len.re() == 0.0 {
                    return None;
                }
                let u = d.map(|x| x / len);
                let rate = dot(u, sub(fr.velocity3(v, b), fr.velocity3(v, a)));
                let tension = law.load(len - e.coef(*l0), rate, *k, *c, e);
                Some(ForceState {
                    stretch: len,
                    rate,
                    load: tension,
                    dir: u,
                })
            }
            Force3::Torsion {
                b1,
                b2,
                frame,
                k,
                c,
                free,
                law,
            } => {
                let (twist, axis) = twist(fr, *b1, *b2, frame);
                let rate = dot(sub(fr.omega3(v, *b1), fr.omega3(v, *b2)), axis);
                let torque = law.load(twist - e.coef(*free), rate, *k, *c, e);
                Some(ForceState {
                    stretch: twist,
                    rate,
                    load: torque,
                    dir: axis,
                })
            }
            _ => None,
        }
    }

    /// Add the generalized force to `out`.
    #[inline]
    pub fn add<D: Scalar, E: Env<D>>(&self, fr: &Frames<'_, D, E>, v: &[D], t: D, out: &mut [D]) {
        match self {
            Force3::Spring { a, b, .. } => {
                let Some(s) = self.state(fr, v) else { return };
                let f = s.dir.map(|x| x * s.load);
                fr.apply3(a, f, out);
                fr.apply3(b, f.map(|x| -x), out);
            }
            Force3::Torsion { b1, b2, .. } => {
                let Some(s) = self.state(fr, v) else { return };
                let tau = s.dir.map(|x| -(x * s.load));
                fr.apply_torque3(*b1, tau, out);
                fr.apply_torque3(*b2, tau.map(|x| -x), out);
            }
            Force3::Torque { body, torque } => {
                let tau = [0, 1, 2].map(|i| torque[i].eval_load(fr.q, v, t, fr.env));
                fr.apply_torque3(Some(*body), tau, out);
            }
            Force3::Point { at, f } => {
                let f = [0, 1, 2].map(|i| f[i].eval_load(fr.q, v, t, fr.env));
                fr.apply3(at, f, out);
            }
        }
    }

    pub fn depends_on_time(&self) -> bool {
        match self {
            Force3::Point { f, .. } => f.iter().any(|c| c.depends_on_time()),
            Force3::Torque { torque, .. } => torque.iter().any(|c| c.depends_on_time()),
            _ => false,
        }
    }

    /// Potential energy, J (springs and torsion springs; 0 for the rest).
    pub fn potential<E: Env<f64>>(&self, fr: &Frames<'_, f64, E>) -> f64 {
        let e = fr.env;
        match self {
            Force3::Spring {
                a, b, k, l0, law, ..
            } => {
                let d = sub(fr.position3(b), fr.position3(a));
                law.potential(dot(d, d).sqrt() - e.coef(*l0), e.coef(*k), |i| e.coef(i))
            }
            Force3::Torsion {
                b1,
                b2,
                frame,
                k,
                free,
                law,
                ..
            } => {
                let (tw, _) = twist(fr, *b1, *b2, frame);
                law.potential(tw - e.coef(*free), e.coef(*k), |i| e.coef(i))
            }
            _ => 0.0,
        }
    }
}

/// The rotation of body 1 relative to body 2 about the axis (body 1's frame), in
/// (−π, π], and the world axis: the angle from `R2 u` to `R1 u` about `R1 a`.
#[inline]
fn twist<D: Scalar, E: Env<D>>(
    fr: &Frames<'_, D, E>,
    b1: Option<usize>,
    b2: Option<usize>,
    frame: &[[usize; 3]; 3],
) -> (D, V3<D>) {
    let axis = fr.rotate3(b1, frame[0]);
    let u1 = fr.rotate3(b1, frame[1]);
    let u2 = fr.rotate3(b2, frame[1]);
    (dot(cross(u2, u1), axis).atan2(dot(u1, u2)), axis)
}

/// The inertia tensor about the CG in the body frame from `Ixx, Iyy, Izz, Ixy, Ixz, Iyz`.
#[inline]
pub fn tensor<D: Scalar>(i: [D; 6]) -> M3<D> {
    [[i[0], i[3], i[4]], [i[3], i[1], i[5]], [i[4], i[5], i[2]]]
}

/// Rotational kinetic energy ½ ω_bᵀ I ω_b of a body with angles `th`, rates `w`.
#[inline]
fn rot_energy<D: Scalar>(axes: &[usize], th: &[D], w: &[D], inertia: &M3<D>) -> D {
    let z = D::from(0.0);
    let p = Pose3::from_parts([z; 3], th, axes);
    let jb = p.body_rates(axes.len());
    let mut wb = [z; 3];
    for (i, &wi) in w.iter().enumerate() {
        for c in 0..3 {
            wb[c] += jb[i][c] * wi;
        }
    }
    dot(wb, mat_vec(inertia, wb)) * 0.5
}

/// The mass matrix of a body's angles, `J_bᵀ I J_b` (n × n, row-major in `out`).
#[inline]
pub fn rotational_mass<D: Scalar>(p: &Pose3<D>, n: usize, inertia: &M3<D>, out: &mut [D]) {
    let jb = p.body_rates(n);
    for i in 0..n {
        let ij = mat_vec(inertia, jb[i]);
        for j in 0..n {
            out[j * n + i] = dot(jb[j], ij);
        }
    }
}

/// A free body's velocity forces: with the body-frame angular velocity ω as its
/// velocities (quasi-velocities), `T = ½ ωᵀ I ω` gives Euler's equations
/// `I ω̇ = Rᵀ τ − ω × (I ω)`; this adds `−ω × (I ω)` to `out` (3).
#[inline]
pub fn gyroscopic<D: Scalar>(w: V3<D>, inertia: &M3<D>, out: &mut [D]) {
    let g = cross(w, mat_vec(inertia, w));
    for (o, x) in out.iter_mut().zip(g) {
        *o -= x;
    }
}

/// The velocity forces of a body's angles, `∂T/∂θ − Ṁ θ̇` (so that `M θ̈ = Q + this`),
/// from the kinetic energy by dual numbers: `∂T/∂θ_i` with θ_i seeded, `Ṁ θ̇ =
/// d/ds [M(θ + s θ̇) θ̇]` with the angles seeded along their rates.
pub fn velocity_forces<D: Scalar>(
    axes: &[usize],
    th: &[D],
    w: &[D],
    inertia: &M3<D>,
    out: &mut [D],
) {
    let n = axes.len();
    let lift = |x: D| Dual::from_re(x);
    let i_d: M3<Dual<D>> = inertia.map(|r| r.map(lift));
    let zero = lift(D::from(0.0));
    let mut wd = [zero; 3];
    for (d, &x) in wd.iter_mut().zip(w) {
        *d = lift(x);
    }
    let mut thd = [zero; 3];
    for i in 0..n {
        for (j, (d, &x)) in thd.iter_mut().zip(th).enumerate() {
            *d = if j == i {
                Dual::new(x, D::from(1.0))
            } else {
                lift(x)
            };
        }
        out[i] += rot_energy(axes, &thd[..n], &wd[..n], &i_d).eps;
    }
    // p(s) = M(θ + s θ̇) θ̇ = ∂T/∂θ̇ at θ + s θ̇
    for (d, (&x, &dx)) in thd.iter_mut().zip(th.iter().zip(w)) {
        *d = Dual::new(x, dx);
    }
    let p = Pose3::from_parts([zero; 3], &thd[..n], axes);
    let mut m = [lift(D::from(0.0)); 9];
    rotational_mass(&p, n, &i_d, &mut m);
    for i in 0..n {
        let mut pi = lift(D::from(0.0));
        for j in 0..n {
            pi += m[i * n + j] * wd[j];
        }
        out[i] -= pi.eps;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rx(a: f64) -> M3<f64> {
        let (s, c) = a.sin_cos();
        [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
    }
    fn rz(a: f64) -> M3<f64> {
        let (s, c) = a.sin_cos();
        [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    }
    fn mul(a: &M3<f64>, b: &M3<f64>) -> M3<f64> {
        let mut m = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
            }
        }
        m
    }

    /// The sequence's rotation is the product of the single-axis matrices of SPEC §1.
    #[test]
    fn rotation_sequence_is_the_product() {
        let p = Pose3::from_parts([0.0; 3], &[0.37, 0.55], &[2, 0]);
        let want = mul(&rz(0.37), &rx(0.55));
        for i in 0..3 {
            for j in 0..3 {
                assert!((p.rot[i][j] - want[i][j]).abs() < 1e-15);
            }
        }
        // rod axis u = R (0, 1, 0) = (−sin α cos β, cos α cos β, sin β)
        let u = mat_vec(&p.rot, [0.0, 1.0, 0.0]);
        let (a, b) = (0.37f64, 0.55f64);
        let w = [-a.sin() * b.cos(), a.cos() * b.cos(), b.sin()];
        for k in 0..3 {
            assert!((u[k] - w[k]).abs() < 1e-15);
        }
    }

    /// The rod of SPEC §8: body rates (β̇, α̇ sin β, α̇ cos β), mass diag(Iyy s² + Izz c²,
    /// Ixx) and the velocity forces of its Lagrange equations.
    #[test]
    fn push_rod_velocity_forces_match_lagrange() {
        let (ixx, iyy, izz) = (1.8225e-4, 0.7e-4, 1.8225e-4);
        let inertia = tensor([ixx, iyy, izz, 0.0, 0.0, 0.0]);
        let (a, b, ad, bd) = (0.37, 0.55, 1.3, -2.1);
        let p = Pose3::from_parts([0.0; 3], &[a, b], &[2, 0]);
        let mut m = [0.0; 4];
        rotational_mass(&p, 2, &inertia, &mut m);
        let (s, c) = f64::sin_cos(b);
        assert!((m[0] - (iyy * s * s + izz * c * c)).abs() < 1e-18);
        assert!((m[3] - ixx).abs() < 1e-18);
        assert!(m[1].abs() < 1e-18 && m[2].abs() < 1e-18);
        let mut q = [0.0; 2];
        velocity_forces(&[2, 0], &[a, b], &[ad, bd], &inertia, &mut q);
        let qa = -2.0 * (iyy - izz) * s * c * ad * bd;
        let qb = (iyy - izz) * s * c * ad * ad;
        assert!((q[0] - qa).abs() < 1e-16, "{} {}", q[0], qa);
        assert!((q[1] - qb).abs() < 1e-16, "{} {}", q[1], qb);
    }

    /// ∂R/∂θ_i = [jw_i]× R: the seeded pose against central differences.
    #[test]
    fn seeded_rotation_derivative_matches_differences() {
        let axes = [2, 0, 1];
        let th = [0.3, -0.7, 1.1];
        let p = Pose3::from_parts([0.0; 3], &th, &axes);
        for i in 0..3 {
            let d = p.seeded(3 + i);
            let h = 1e-6;
            let mut tp = th;
            tp[i] += h;
            let mut tm = th;
            tm[i] -= h;
            let rp = Pose3::from_parts([0.0; 3], &tp, &axes).rot;
            let rm = Pose3::from_parts([0.0; 3], &tm, &axes).rot;
            for r in 0..3 {
                for c in 0..3 {
                    let fd = (rp[r][c] - rm[r][c]) / (2.0 * h);
                    assert!((d.rot[r][c].eps - fd).abs() < 1e-9);
                }
            }
        }
    }
}
