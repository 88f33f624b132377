//! Impressed forces: spring–dashpots between two points and point forces given by
//! expressions (gravity is applied per body by the system).

use super::frame::{Frames, SysPoint};
use crate::model::expr::Compiled;
use crate::scalar::{Env, Scalar};

#[derive(Debug, Clone)]
pub enum Force {
    /// T = k (d − L0) + c ḋ along P1→P2, tension positive (coefficient indices).
    Spring {
        a: SysPoint,
        b: SysPoint,
        k: usize,
        c: usize,
        l0: usize,
    },
    /// World-frame force at a point.
    Point { at: SysPoint, f: [Compiled; 2] },
    /// A force of a spatial model.
    Spatial(super::spatial::Force3),
    /// A planar torque on a body (N·m, counter-clockwise), an expression of t, parameters,
    /// coordinates and velocities.
    Torque { body: usize, t: Compiled },
    /// Planar torsional spring–damper: twist θ1 − θ2 (a body or the ground, whose angle
    /// may move), torque on body 1 −(k (twist − free) + c twist_rate), the opposite on
    /// body 2 (coefficient indices).
    Torsion {
        b1: Option<usize>,
        b2: Option<usize>,
        k: usize,
        c: usize,
        free: usize,
    },
}

impl Force {
    /// Add the generalized force to `out`.
    #[inline]
    pub fn add<D: Scalar, E: Env<D>>(&self, fr: &Frames<'_, D, E>, v: &[D], t: D, out: &mut [D]) {
        match self {
            Force::Spring { a, b, .. } => {
                let Some((_, _, tension, u)) = self.spring_state(fr, v) else {
                    return;
                };
                fr.apply(a, [tension * u[0], tension * u[1]], out);
                fr.apply(b, [-(tension * u[0]), -(tension * u[1])], out);
            }
            Force::Point { at, f } => {
                let fx = f[0].eval_load(fr.q, v, t, fr.env);
                let fy = f[1].eval_load(fr.q, v, t, fr.env);
                fr.apply(at, [fx, fy], out);
            }
            Force::Spatial(f) => f.add(fr, v, t, out),
            Force::Torque { body, t: e } => {
                out[fr.offsets[*body] + 2] += e.eval_load(fr.q, v, t, fr.env);
            }
            Force::Torsion { b1, b2, .. } => {
                let Some(s) = self.torsion_state(fr, v) else {
                    return;
                };
                for (b, sign) in [(b1, -1.0), (b2, 1.0)] {
                    if let Some(k) = b {
                        out[fr.offsets[*k] + 2] += s.2 * sign;
                    }
                }
            }
        }
    }

    /// A planar spring's (length, length rate, tension, unit vector from point 1 to 2);
    /// None where its points coincide.
    #[inline]
    pub fn spring_state<D: Scalar, E: Env<D>>(
        &self,
        fr: &Frames<'_, D, E>,
        v: &[D],
    ) -> Option<(D, D, D, [D; 2])> {
        let Force::Spring { a, b, k, c, l0 } = self else {
            return None;
        };
        let pa = fr.position(a);
        let pb = fr.position(b);
        let d = [pb[0] - pa[0], pb[1] - pa[1]];
        let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
        if len.re() == 0.0 {
            return None;
        }
        let u = [d[0] / len, d[1] / len];
        let va = fr.velocity(v, a);
        let vb = fr.velocity(v, b);
        let rate = u[0] * (vb[0] - va[0]) + u[1] * (vb[1] - va[1]);
        let tension = (len - fr.env.coef(*l0)) * fr.env.coef(*k) + rate * fr.env.coef(*c);
        Some((len, rate, tension, u))
    }

    /// A planar torsion's (twist, twist rate, torque).
    #[inline]
    pub fn torsion_state<D: Scalar, E: Env<D>>(
        &self,
        fr: &Frames<'_, D, E>,
        v: &[D],
    ) -> Option<(D, D, D)> {
        let Force::Torsion { b1, b2, k, c, free } = self else {
            return None;
        };
        let rate_of = |b: &Option<usize>| match b {
            Some(k) => v[fr.offsets[*k] + 2],
            None => fr.ground.motion().2,
        };
        let twist = fr.angle(*b1) - fr.angle(*b2);
        let rate = rate_of(b1) - rate_of(b2);
        let e = fr.env;
        let torque = (twist - e.coef(*free)) * e.coef(*k) + rate * e.coef(*c);
        Some((twist, rate, torque))
    }

    /// Whether the force depends on time explicitly (not through a moving ground).
    pub fn depends_on_time(&self) -> bool {
        match self {
            Force::Point { f, .. } => f.iter().any(|c| c.depends_on_time()),
            Force::Spring { .. } => false,
            Force::Spatial(f) => f.depends_on_time(),
            Force::Torsion { .. } => false,
            Force::Torque { t, .. } => t.depends_on_time(),
        }
    }

    /// Potential energy, J (springs; 0 for the rest).
    pub fn potential<E: Env<f64>>(&self, fr: &Frames<'_, f64, E>) -> f64 {
        match self {
            Force::Spring { a, b, k, l0, .. } => {
                let pa = fr.position(a);
                let pb = fr.position(b);
                let len = (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
                0.5 * fr.env.coef(*k) * (len - fr.env.coef(*l0)).powi(2)
            }
            Force::Point { .. } | Force::Torque { .. } => 0.0,
            Force::Spatial(f) => f.potential(fr),
            Force::Torsion {
                b1, b2, k, free, ..
            } => {
                let twist = fr.angle(*b1) - fr.angle(*b2);
                0.5 * fr.env.coef(*k) * (twist - fr.env.coef(*free)).powi(2)
            }
        }
    }
}
