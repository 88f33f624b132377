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
        law: Law,
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
        law: Law,
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
        let Force::Spring {
            a,
            b,
            k,
            c,
            l0,
            law,
        } = self
        else {
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
        let tension = law.load(len - fr.env.coef(*l0), rate, *k, *c, fr.env);
        Some((len, rate, tension, u))
    }

    /// A planar torsion's (twist, twist rate, torque).
    #[inline]
    pub fn torsion_state<D: Scalar, E: Env<D>>(
        &self,
        fr: &Frames<'_, D, E>,
        v: &[D],
    ) -> Option<(D, D, D)> {
        let Force::Torsion {
            b1,
            b2,
            k,
            c,
            free,
            law,
        } = self
        else {
            return None;
        };
        let rate_of = |b: &Option<usize>| match b {
            Some(k) => v[fr.offsets[*k] + 2],
            None => fr.ground.motion().2,
        };
        let twist = fr.angle(*b1) - fr.angle(*b2);
        let rate = rate_of(b1) - rate_of(b2);
        let e = fr.env;
        let torque = law.load(twist - e.coef(*free), rate, *k, *c, e);
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
            Force::Spring {
                a, b, k, l0, law, ..
            } => {
                let pa = fr.position(a);
                let pb = fr.position(b);
                let len = (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
                law.potential(len - fr.env.coef(*l0), fr.env.coef(*k), |i| fr.env.coef(i))
            }
            Force::Point { .. } | Force::Torque { .. } => 0.0,
            Force::Spatial(f) => f.potential(fr),
            Force::Torsion {
                b1,
                b2,
                k,
                free,
                law,
                ..
            } => {
                let twist = fr.angle(*b1) - fr.angle(*b2);
                law.potential(twist - fr.env.coef(*free), fr.env.coef(*k), |i| {
                    fr.env.coef(i)
                })
            }
        }
    }
}

/// The law of a two-ended element (a spring between two points, a torsion between two
/// bodies): its load (tension, or torque resisting the twist) from the stretch
/// `s` (elongation d − L0, or twist − free angle, m or rad) and its rate `r`, with the
/// element's stiffness `k` and damping `c` (coefficient indices).
///
/// The non-smooth laws are regularized so that the integrator and Newton's method see a
/// smooth (C∞) force: the smoothed clip `sclip(x) = ½(√((x+1)² + ε²) − √((x−1)² + ε²))`
/// (breakout, backlash), the smoothed ramp `ramp(p) = ½(p + √(p² + w²))` (end stops) and
/// `tanh` (friction). Hand-written: these few closed forms are the whole of it.
#[derive(Debug, Clone)]
pub enum Law {
    /// k·s + c·r (`spring_damper`, `torsion`).
    Linear,
    /// The user's law, `law` = f(x, x_dot) the force pushing the ends apart (the torque
    /// on body 1 in the twist's direction): load −f(s, r). Compiled with `x` as slot 0
    /// and `x_dot` as slot 1.
    Expr(Compiled),
    /// Preloaded breakout, k = k1: k2·s + (k1 − k2)·tb·sclip(s/tb), tb = T0/k1, plus c·r.
    Breakout { k2: usize, t0: usize, eps: usize },
    /// Backlash ±b: k·(s − b·sclip(s/b)) + c·r·(1 − sclip′(s/b)) (the dashpot acts in
    /// contact only).
    Backlash { gap: usize, eps: usize },
    /// End stops: k·(ramp(s − upper) − ramp(lower − s)) + c·r·(ramp′(s − upper) +
    /// ramp′(lower − s)).
    EndStop {
        lower: Option<usize>,
        upper: Option<usize>,
        width: usize,
    },
    /// Regularized Coulomb friction: level·tanh(r/v0).
    Friction { level: usize, v0: usize },
}

/// The smoothed clip of x to [−1, 1], corner width ε.
#[inline]
pub fn sclip<D: Scalar>(x: D, eps: D) -> D {
    let e2 = eps * eps;
    let a = x + 1.0;
    let b = x - 1.0;
    ((a * a + e2).sqrt() - (b * b + e2).sqrt()) * 0.5
}

/// d sclip / dx.
#[inline]
pub fn sclip_slope<D: Scalar>(x: D, eps: D) -> D {
    let e2 = eps * eps;
    let a = x + 1.0;
    let b = x - 1.0;
    (a / (a * a + e2).sqrt() - b / (b * b + e2).sqrt()) * 0.5
}

/// ∫₀ˣ sclip: ½(G(x+1) − G(x−1)) − G(1), G(u) = ½(u√(u² + ε²) + ε² asinh(u/ε)).
pub fn sclip_integral(x: f64, eps: f64) -> f64 {
    let g = |u: f64| 0.5 * (u * (u * u + eps * eps).sqrt() + eps * eps * (u / eps).asinh());
    0.5 * (g(x + 1.0) - g(x - 1.0)) - g(1.0)
}

/// The smoothed ramp max(p, 0), width w.
#[inline]
pub fn ramp<D: Scalar>(p: D, w: D) -> D {
    (p + (p * p + w * w).sqrt()) * 0.5
}

/// d ramp / dp, in (0, 1).
#[inline]
pub fn ramp_slope<D: Scalar>(p: D, w: D) -> D {
    (p / (p * p + w * w).sqrt() + 1.0) * 0.5
}

/// ∫₀ᵖ ramp = ¼(p² + p√(p² + w²) + w² asinh(p/w)). (Its limit as p → −∞ is not finite:
/// the smoothed ramp's tail w²/(4|p|) integrates to a logarithm; the energy is referred to
/// the limit, p = 0.)
pub fn ramp_integral(p: f64, w: f64) -> f64 {
    0.25 * (p * p + p * (p * p + w * w).sqrt() + w * w * (p / w).asinh())
}

impl Law {
    /// The load from the stretch `s` and rate `r` (see the variants).
    #[inline]
    pub fn load<D: Scalar, E: Env<D>>(&self, s: D, r: D, k: usize, c: usize, e: E) -> D {
        match self {
            Law::Linear => s * e.coef(k) + r * e.coef(c),
            Law::Expr(f) => -f.eval_in(&[s, r], D::from(0.0), e),
            Law::Breakout { k2, t0, eps } => {
                let (k1, k2) = (e.coef(k), e.coef(*k2));
                let tb = e.coef(*t0) / k1;
                s * k2 + r * e.coef(c) + (k1 - k2) * tb * sclip(s / tb, e.coef(*eps))
            }
            Law::Backlash { gap, eps } => {
                let (b, eps) = (e.coef(*gap), e.coef(*eps));
                let x = s / b;
                (s - b * sclip(x, eps)) * e.coef(k) + r * e.coef(c) * (-sclip_slope(x, eps) + 1.0)
            }
            Law::EndStop {
                lower,
                upper,
                width,
            } => {
                let w = e.coef(*width);
                let (mut f, mut g) = (D::from(0.0), D::from(0.0));
                if let Some(u) = upper {
                    let p = s - e.coef(*u);
                    f += ramp(p, w);
                    g += ramp_slope(p, w);
                }
                if let Some(l) = lower {
                    let p = e.coef(*l) - s;
                    f -= ramp(p, w);
                    g += ramp_slope(p, w);
                }
                f * e.coef(k) + r * e.coef(c) * g
            }
            Law::Friction { level, v0 } => e.coef(*level) * (r / e.coef(*v0)).tanh(),
        }
    }

    /// The potential energy of the elastic part at stretch `s`, J (0 at s = 0 for the
    /// spring laws; 0 for friction and for a user's law, which has no known potential).
    pub fn potential(&self, s: f64, k: f64, coef: impl Fn(usize) -> f64) -> f64 {
        match self {
            Law::Linear => 0.5 * k * s * s,
            Law::Expr(_) | Law::Friction { .. } => 0.0,
            Law::Breakout { k2, t0, eps } => {
                let k2 = coef(*k2);
                let tb = coef(*t0) / k;
                0.5 * k2 * s.powi(2) + (k - k2) * tb * tb * sclip_integral(s / tb, coef(*eps))
            }
            Law::Backlash { gap, eps } => {
                let b = coef(*gap);
                k * (0.5 * s * s - b * b * sclip_integral(s / b, coef(*eps)))
            }
            Law::EndStop {
                lower,
                upper,
                width,
            } => {
                let w = coef(*width);
                let mut u = 0.0;
                if let Some(up) = upper {
                    u += ramp_integral(s - coef(*up), w);
                }
                if let Some(l) = lower {
                    u += ramp_integral(coef(*l) - s, w);
                }
                k * u
            }
        }
    }
}
