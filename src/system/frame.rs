//! Frames and points: where a point fixed in a body, or in the (possibly moving) ground,
//! is in the world, how fast it moves, and how a force at it enters the generalized forces.
//!
//! Every element evaluates the frames it needs through [`Frames`], which holds the pose of
//! the ground (evaluated once per evaluation of Φ or f, at time t) and reads each body's
//! pose from q. Planar bodies have `q = (x, y, θ)` of the centre of gravity.

use super::spatial::{Geom3, Pose3};
use crate::model::expr::Compiled;
use crate::scalar::{Env, Scalar};
use num_dual::Dual;

/// A point fixed in a body (or the ground): the body's index and the body-frame
/// position as two coefficient indices (m).
#[derive(Debug, Clone, Copy)]
pub struct SysPoint {
    pub body: Option<usize>,
    pub p: [usize; 2],
}

/// The prescribed motion of the ground frame (planar: x, y, θ as functions of t and the
/// parameters); `None` components stay 0.
#[derive(Debug, Clone, Default)]
pub struct GroundMotion {
    pub x: Option<Compiled>,
    pub y: Option<Compiled>,
    /// Spatial models.
    pub z: Option<Compiled>,
    pub theta: Option<Compiled>,
    /// Spatial models: rotation angles of the ground, R = Rz(rz) Ry(ry) Rx(rx).
    pub rx: Option<Compiled>,
    pub ry: Option<Compiled>,
    pub rz: Option<Compiled>,
    /// Held at this pose (x, y, z, theta, rx, ry, rz), at rest: statics and
    /// linearizations see the ground at its mean over the forcing period.
    pub frozen: Option<[f64; 7]>,
}

impl GroundMotion {
    /// Whether the ground moves at all.
    pub fn is_moving(&self) -> bool {
        self.frozen.is_none()
            && (self.x.is_some()
                || self.y.is_some()
                || self.z.is_some()
                || self.theta.is_some()
                || self.rotates3())
    }

    /// Whether the ground of a spatial model rotates.
    pub fn rotates3(&self) -> bool {
        self.rx.is_some() || self.ry.is_some() || self.rz.is_some()
    }

    fn component<D: Scalar, E: Env<D>>(c: &Option<Compiled>, t: D, env: E) -> (D, D) {
        match c {
            None => (D::from(0.0), D::from(0.0)),
            Some(e) => {
                // value and time rate by one dual pass in t
                let v = e.eval_in(&[], Dual::new(t, D::from(1.0)), Lifted(env));
                (v.re, v.eps)
            }
        }
    }
}

/// An environment of `D` seen as one of `Dual<D>` (constant parts).
#[derive(Clone, Copy)]
struct Lifted<E>(E);

impl<D: Scalar, E: Env<D>> Env<Dual<D>> for Lifted<E> {
    #[inline]
    fn param(self, i: usize) -> Dual<D> {
        Dual::from_re(self.0.param(i))
    }
    #[inline]
    fn coef(self, i: usize) -> Dual<D> {
        Dual::from_re(self.0.coef(i))
    }
    #[inline]
    fn mul_coef(self, i: usize, x: Dual<D>) -> Dual<D> {
        x * self.coef(i)
    }
}

/// The pose and velocity of the ground at one time: position r, rotation (sin, cos),
/// velocity ṙ and angular velocity ω.
#[derive(Debug, Clone, Copy)]
pub struct GroundPose<D> {
    /// Position of the ground origin (planar models: z = 0).
    pub r: [D; 3],
    theta: D,
    sc: Option<(D, D)>,
    /// Velocity of the ground origin.
    pub vel: [D; 3],
    omega: D,
    /// Spatial models with a rotating ground: R (row-major), the world angular velocity
    /// ω, and the angles (rz, ry, rx).
    pub rot3: Option<([[D; 3]; 3], [D; 3], [D; 3])>,
}

impl<D: Scalar> GroundPose<D> {
    /// The ground at rest at the origin.
    pub fn fixed() -> Self {
        let z = D::from(0.0);
        GroundPose {
            r: [z, z, z],
            theta: z,
            sc: None,
            vel: [z, z, z],
            omega: z,
            rot3: None,
        }
    }

    /// The rotation of a spatial model's ground (None: it does not rotate).
    pub fn rotation3(&self) -> Option<&[[D; 3]; 3]> {
        self.rot3.as_ref().map(|r| &r.0)
    }

    /// The world angular velocity of a spatial model's ground.
    pub fn omega3(&self) -> [D; 3] {
        self.rot3.map_or([D::from(0.0); 3], |r| r.1)
    }

    /// The ground's angle (planar).
    pub fn angle(&self) -> D {
        self.theta
    }

    /// Position of the ground origin, its velocity and angular velocity (planar).
    pub fn motion(&self) -> ([D; 2], [D; 2], D) {
        (
            [self.r[0], self.r[1]],
            [self.vel[0], self.vel[1]],
            self.omega,
        )
    }

    /// The ground of `motion` at time t.
    pub fn at<E: Env<D>>(motion: &GroundMotion, t: D, env: E) -> Self {
        if let Some(f) = motion.frozen {
            let mut g = Self::fixed();
            g.r = [D::from(f[0]), D::from(f[1]), D::from(f[2])];
            if motion.theta.is_some() {
                g.theta = D::from(f[3]);
                g.sc = Some(g.theta.sin_cos());
            }
            if motion.rotates3() {
                let angles = [D::from(f[6]), D::from(f[5]), D::from(f[4])];
                let p = Pose3::from_parts(g.r, &angles, &[2, 1, 0]);
                g.rot3 = Some((p.rot, [D::from(0.0); 3], angles));
            }
            return g;
        }
        if !motion.is_moving() {
            return Self::fixed();
        }
        let (x, vx) = GroundMotion::component(&motion.x, t, env);
        let (y, vy) = GroundMotion::component(&motion.y, t, env);
        let (z, vz) = GroundMotion::component(&motion.z, t, env);
        let (theta, omega) = GroundMotion::component(&motion.theta, t, env);
        let sc = motion.theta.as_ref().map(|_| theta.sin_cos());
        let rot3 = if motion.rotates3() {
            let (rx, wx) = GroundMotion::component(&motion.rx, t, env);
            let (ry, wy) = GroundMotion::component(&motion.ry, t, env);
            let (rz, wz) = GroundMotion::component(&motion.rz, t, env);
            // R = Rz Ry Rx; ω = Σ rate_i (R_1 … R_(i−1)) e_(a_i): the sequence's columns
            let angles = [rz, ry, rx];
            let p = Pose3::from_parts([x, y, z], &angles, &[2, 1, 0]);
            let mut w = [D::from(0.0); 3];
            for (col, rate) in p.jw.iter().zip([wz, wy, wx]) {
                for k in 0..3 {
                    w[k] += col[k] * rate;
                }
            }
            Some((p.rot, w, angles))
        } else {
            None
        };
        GroundPose {
            r: [x, y, z],
            theta,
            sc,
            vel: [vx, vy, vz],
            omega,
            rot3,
        }
    }
}

/// A planar body's pose in type D: centre of gravity r, angle θ and its (sin, cos),
/// computed once per evaluation and shared by every element on the body.
#[derive(Debug, Clone, Copy)]
pub struct Pose<D> {
    pub r: [D; 2],
    pub theta: D,
    pub s: D,
    pub c: D,
}

impl<D: Scalar> Pose<D> {
    /// The pose of a planar body whose coordinates start at `q[o]`.
    #[inline]
    pub fn planar(q: &[D], o: usize) -> Self {
        let (s, c) = q[o + 2].sin_cos();
        Pose {
            r: [q[o], q[o + 1]],
            theta: q[o + 2],
            s,
            c,
        }
    }

    pub fn zero() -> Self {
        let z = D::from(0.0);
        Pose {
            r: [z, z],
            theta: z,
            s: z,
            c: z,
        }
    }
}

impl Pose<f64> {
    /// This pose as dual numbers carrying its derivative along tangent direction `d` of
    /// the body (planar: 0 = x, 1 = y, 2 = θ): the seeded pose of a Jacobian column,
    /// without evaluating sin and cos again.
    #[inline]
    pub fn seeded(&self, d: usize) -> Pose<num_dual::Dual64> {
        use num_dual::Dual64 as D1;
        let mut p = self.lift();
        match d {
            0 => p.r[0].eps = 1.0,
            1 => p.r[1].eps = 1.0,
            _ => {
                p.theta.eps = 1.0;
                p.s = D1::new(self.s, self.c);
                p.c = D1::new(self.c, -self.s);
            }
        }
        p
    }

    /// The pose along the motion q + s·v as second-order dual numbers in s (for the bias
    /// b), from this pose and the body's velocities `v[o..o + 3]`: sin and cos by the
    /// chain rule, not evaluated again.
    #[inline]
    pub fn along(&self, v: &[f64], o: usize) -> Pose<num_dual::Dual2_64> {
        use num_dual::Dual2_64 as D2;
        let w = v[o + 2];
        Pose {
            r: [
                D2::new(self.r[0], v[o], 0.0),
                D2::new(self.r[1], v[o + 1], 0.0),
            ],
            theta: D2::new(self.theta, w, 0.0),
            s: D2::new(self.s, self.c * w, -self.s * w * w),
            c: D2::new(self.c, -self.s * w, -self.c * w * w),
        }
    }

    /// This pose as dual numbers with zero derivative.
    #[inline]
    pub fn lift(&self) -> Pose<num_dual::Dual64> {
        use num_dual::Dual64 as D1;
        Pose {
            r: [D1::from(self.r[0]), D1::from(self.r[1])],
            theta: D1::from(self.theta),
            s: D1::from(self.s),
            c: D1::from(self.c),
        }
    }
}

/// Bodies on the stack up to this count when poses are computed for one evaluation.
const INLINE_BODIES: usize = 16;

/// Spatial bodies on a smaller stack buffer up to this count (see [`with_poses3`]).
const FEW_BODIES: usize = 4;

/// Compute the poses of all bodies (coordinate offsets `offsets`) from `q` and call `f`
/// with them, without allocating for up to 16 bodies.
#[inline]
pub fn with_poses<D: Scalar, R>(q: &[D], offsets: &[usize], f: impl FnOnce(&[Pose<D>]) -> R) -> R {
    let nb = offsets.len();
    if nb <= INLINE_BODIES {
        let mut buf = [Pose::zero(); INLINE_BODIES];
        for (p, &o) in buf.iter_mut().zip(offsets) {
            *p = Pose::planar(q, o);
        }
        f(&buf[..nb])
    } else {
        let poses: Vec<Pose<D>> = offsets.iter().map(|&o| Pose::planar(q, o)).collect();
        f(&poses)
    }
}

/// [`with_poses`] for spatial bodies.
#[inline]
pub fn with_poses3<D: Scalar, R>(q: &[D], geoms: &[Geom3], f: impl FnOnce(&[Pose3<D>]) -> R) -> R {
    let nb = geoms.len();
    if nb <= FEW_BODIES {
        // a spatial pose of hyper-dual numbers is 672 bytes: zeroing 16 of them for a
        // four-body mechanism was most of a constraint pass of statics
        let buf: [Pose3<D>; FEW_BODIES] = std::array::from_fn(|k| match geoms.get(k) {
            Some(g) => Pose3::from_q(q, g),
            None => Pose3::zero(),
        });
        f(&buf[..nb])
    } else if nb <= INLINE_BODIES {
        let mut buf = [Pose3::zero(); INLINE_BODIES];
        for (p, g) in buf.iter_mut().zip(geoms) {
            *p = Pose3::from_q(q, g);
        }
        f(&buf[..nb])
    } else {
        let poses: Vec<Pose3<D>> = geoms.iter().map(|g| Pose3::from_q(q, g)).collect();
        f(&poses)
    }
}

/// The frames of one evaluation: body poses, the ground's pose, the coordinates (for
/// custom expressions) and where parameters come from.
#[derive(Clone, Copy)]
pub struct Frames<'a, D, E> {
    pub q: &'a [D],
    /// Planar bodies' poses (empty in spatial models).
    pub poses: &'a [Pose<D>],
    /// Spatial bodies' poses (empty in planar models).
    pub poses3: &'a [Pose3<D>],
    /// Number of rotational velocities of each spatial body (its angles, or a free
    /// body's 3 body rates).
    pub nrot: &'a [usize],
    /// Velocity offset of each body (where its velocities and generalized forces start;
    /// its coordinates too, unless a free body precedes it).
    pub offsets: &'a [usize],
    pub ground: GroundPose<D>,
    pub env: E,
}

impl<D: Scalar, E: Env<D>> Frames<'_, D, E> {
    /// sin θ, cos θ of a body (None: the ground, possibly unrotated).
    #[inline]
    pub fn rotation(&self, body: Option<usize>) -> Option<(D, D)> {
        match body {
            Some(k) => {
                let p = &self.poses[k];
                Some((p.s, p.c))
            }
            None => self.ground.sc,
        }
    }

    /// R v for a body-frame vector given by two coefficients (a point, a slot normal):
    /// products with the coefficients' values, not dual-by-dual.
    #[inline]
    pub fn rotate_coefs(&self, body: Option<usize>, v: [usize; 2]) -> [D; 2] {
        let e = self.env;
        match self.rotation(body) {
            Some((s, c)) => [
                e.mul_coef(v[0], c) - e.mul_coef(v[1], s),
                e.mul_coef(v[0], s) + e.mul_coef(v[1], c),
            ],
            None => [e.coef(v[0]), e.coef(v[1])],
        }
    }

    /// World offset R p of a point from its frame's origin.
    #[inline]
    pub fn arm(&self, pt: &SysPoint) -> [D; 2] {
        self.rotate_coefs(pt.body, pt.p)
    }

    /// World position r + R p.
    #[inline]
    pub fn position(&self, pt: &SysPoint) -> [D; 2] {
        let r = match pt.body {
            Some(k) => self.poses[k].r,
            None => [self.ground.r[0], self.ground.r[1]],
        };
        let e = self.env;
        let p = pt.p;
        match self.rotation(pt.body) {
            Some((s, c)) => [
                r[0] + e.mul_coef(p[0], c) - e.mul_coef(p[1], s),
                r[1] + e.mul_coef(p[0], s) + e.mul_coef(p[1], c),
            ],
            None => [r[0] + e.coef(p[0]), r[1] + e.coef(p[1])],
        }
    }

    /// World velocity ṙ + ω × (R p), with `v` the velocities.
    #[inline]
    pub fn velocity(&self, v: &[D], pt: &SysPoint) -> [D; 2] {
        let r = self.arm(pt);
        let (vel, w) = match pt.body {
            Some(k) => {
                let o = self.offsets[k];
                ([v[o], v[o + 1]], v[o + 2])
            }
            None => ([self.ground.vel[0], self.ground.vel[1]], self.ground.omega),
        };
        [vel[0] - w * r[1], vel[1] + w * r[0]]
    }

    /// Add a world force F at a point to the generalized forces: (Fx, Fy, (R p) × F).
    /// A force on the ground does nothing.
    #[inline]
    pub fn apply(&self, pt: &SysPoint, f: [D; 2], out: &mut [D]) {
        if let Some(k) = pt.body {
            let o = self.offsets[k];
            let r = self.arm(pt);
            out[o] += f[0];
            out[o + 1] += f[1];
            out[o + 2] += r[0] * f[1] - r[1] * f[0];
        }
    }

    /// The orientation angle of a frame (the ground's is its prescribed θ(t), or 0).
    #[inline]
    pub fn angle(&self, body: Option<usize>) -> D {
        match body {
            Some(k) => self.poses[k].theta,
            None => self.ground.theta,
        }
    }
}
