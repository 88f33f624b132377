//! Frames and points: where a point fixed in a body, or in the (possibly moving) ground,
//! is in the world, how fast it moves, and how a force at it enters the generalized forces.
//!
//! Every element evaluates the frames it needs through [`Frames`], which holds the pose of
//! the ground (evaluated once per evaluation of Φ or f, at time t) and reads each body's
//! pose from q. Planar bodies have `q = (x, y, θ)` of the centre of gravity.

use crate::model::expr::Compiled;
use crate::scalar::{Env, Scalar};
use num_dual::Dual;

/// A point fixed in a body (or the ground): the body's coordinate offset and the
/// body-frame position as two coefficient indices (m).
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
    pub theta: Option<Compiled>,
}

impl GroundMotion {
    /// Whether the ground moves at all.
    pub fn is_moving(&self) -> bool {
        self.x.is_some() || self.y.is_some() || self.theta.is_some()
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
}

/// The pose and velocity of the ground at one time: position r, rotation (sin, cos),
/// velocity ṙ and angular velocity ω.
#[derive(Debug, Clone, Copy)]
pub struct GroundPose<D> {
    r: [D; 2],
    theta: D,
    sc: Option<(D, D)>,
    vel: [D; 2],
    omega: D,
}

impl<D: Scalar> GroundPose<D> {
    /// The ground at rest at the origin.
    pub fn fixed() -> Self {
        let z = D::from(0.0);
        GroundPose {
            r: [z, z],
            theta: z,
            sc: None,
            vel: [z, z],
            omega: z,
        }
    }

    /// Position of the ground origin, its velocity and angular velocity.
    pub fn motion(&self) -> ([D; 2], [D; 2], D) {
        (self.r, self.vel, self.omega)
    }

    /// The ground of `motion` at time t.
    pub fn at<E: Env<D>>(motion: &GroundMotion, t: D, env: E) -> Self {
        if !motion.is_moving() {
            return Self::fixed();
        }
        let (x, vx) = GroundMotion::component(&motion.x, t, env);
        let (y, vy) = GroundMotion::component(&motion.y, t, env);
        let (theta, omega) = GroundMotion::component(&motion.theta, t, env);
        let sc = motion.theta.as_ref().map(|_| theta.sin_cos());
        GroundPose {
            r: [x, y],
            theta,
            sc,
            vel: [vx, vy],
            omega,
        }
    }
}

/// The frames of one evaluation: the ground's pose, the coordinates and the coefficients.
#[derive(Clone, Copy)]
pub struct Frames<'a, D, E> {
    pub q: &'a [D],
    pub ground: GroundPose<D>,
    pub env: E,
}

impl<D: Scalar, E: Env<D>> Frames<'_, D, E> {
    /// sin θ, cos θ of a body (None: the ground, possibly unrotated).
    #[inline]
    pub fn rotation(&self, body: Option<usize>) -> Option<(D, D)> {
        match body {
            Some(o) => Some(self.q[o + 2].sin_cos()),
            None => self.ground.sc,
        }
    }

    /// R v for a body-frame vector v.
    #[inline]
    pub fn rotate(&self, body: Option<usize>, v: [D; 2]) -> [D; 2] {
        match self.rotation(body) {
            Some((s, c)) => [c * v[0] - s * v[1], s * v[0] + c * v[1]],
            None => v,
        }
    }

    /// The body-frame position of a point.
    #[inline]
    pub fn local(&self, pt: &SysPoint) -> [D; 2] {
        [self.env.coef(pt.p[0]), self.env.coef(pt.p[1])]
    }

    /// World offset R p of a point from its frame's origin.
    #[inline]
    pub fn arm(&self, pt: &SysPoint) -> [D; 2] {
        self.rotate(pt.body, self.local(pt))
    }

    /// World position r + R p.
    #[inline]
    pub fn position(&self, pt: &SysPoint) -> [D; 2] {
        let p = self.local(pt);
        let r = match pt.body {
            Some(o) => [self.q[o], self.q[o + 1]],
            None => self.ground.r,
        };
        match self.rotation(pt.body) {
            Some((s, c)) => [r[0] + c * p[0] - s * p[1], r[1] + s * p[0] + c * p[1]],
            None => [r[0] + p[0], r[1] + p[1]],
        }
    }

    /// World velocity ṙ + ω × (R p), with `v` the velocities.
    #[inline]
    pub fn velocity(&self, v: &[D], pt: &SysPoint) -> [D; 2] {
        let r = self.arm(pt);
        let (vel, w) = match pt.body {
            Some(o) => ([v[o], v[o + 1]], v[o + 2]),
            None => (self.ground.vel, self.ground.omega),
        };
        [vel[0] - w * r[1], vel[1] + w * r[0]]
    }

    /// Add a world force F at a point to the generalized forces: (Fx, Fy, (R p) × F).
    /// A force on the ground does nothing.
    #[inline]
    pub fn apply(&self, pt: &SysPoint, f: [D; 2], out: &mut [D]) {
        if let Some(o) = pt.body {
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
            Some(o) => self.q[o + 2],
            None => self.ground.theta,
        }
    }
}
