//! Constraints: one generic planar joint with a mask of locked directions (named
//! constructors for revolute, pin-in-slot, prismatic and fixed, as Rapier builds its
//! joints), and custom constraint expressions.
//!
//! A joint relates point 1 on body 1 to point 2 on body 2, in the frame of body 2 (or the
//! ground, which may move). Its rows, in order:
//!
//! * both translations locked (revolute, fixed): `P1 − P2` in world x and y (2 rows),
//! * only the normal locked (pin-in-slot, prismatic): `n₂ · (P1 − P2)` with n₂ ⟂ the
//!   slot axis, turning with body 2 (1 row),
//! * the angle locked (prismatic, fixed): `θ1 − θ2 − angle` (1 row).
//!
//! Φ is written once, generically over the scalar (f64 or dual numbers: A and b come from
//! dual passes through it). Two pieces of a planar joint are written out by hand, each in
//! its dual pass's order of operations, so that they are the same to the last bit
//! (tests/elements.rs compares them with `to_bits`):
//!
//! * its columns of A ([`Joint::column`]), since a point's derivative along its body's
//!   angle is a quarter turn of its arm. A `Dual64` pass per column cost three times as
//!   much (it builds the frames and both points for one derivative; num-dual's
//!   multi-direction duals were slower still). With it goes which of its entries are zero
//!   at every pose ([`Joint::column_zero`]), so that the constraint solve skips them
//!   (`crate::dynamics`).
//! * its rows of the bias b = −d²/ds² Φ(q + s·v) when the ground does not move (fixed,
//!   or frozen at a pose) ([`Joint::bias`]): num-dual 0.15's `Dual2_64` product rule and
//!   sums replayed on f64 parts, of which a row reads only the second parts and the
//!   value and first parts a product needs (the others are inlined and unused: the
//!   optimizer drops them), where the `Dual2_64` pass carried and stored all three parts
//!   of every point (half the cost of b, a tenth of a right-hand side's). The signed
//!   zeros come out the same too: a constant's zero derivatives are added as `+ 0.0` and
//!   multiplied as `0·x`, as the dual pass does. A moving ground (its pose carries
//!   derivatives in t), spatial joints and custom constraints stay with the dual pass;
//!   each constraint's rows come from its own Φ, so a model mixing joints and custom
//!   constraints takes each row from one or the other.
//!
//! No crate gives the derivatives of these few lines of geometry cheaper than writing
//! them out.

use super::frame::{Frames, SysPoint};
use crate::model::expr::Compiled;
use crate::scalar::{Env, Scalar};

/// Which relative translations a joint locks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Translation {
    /// Both directions: the points coincide.
    Both,
    /// The direction normal to the slot axis (unit normal coefficients in body 2's frame).
    Normal { n: [usize; 2] },
}

/// A planar joint: a mask of locked relative motions between two points.
#[derive(Debug, Clone)]
pub struct Joint {
    pub a: SysPoint,
    pub b: SysPoint,
    pub translation: Translation,
    /// The relative angle θ1 − θ2 held (coefficient index), if the rotation is locked.
    pub angle: Option<usize>,
}

impl Joint {
    /// Point 1 coincides with point 2.
    pub fn revolute(a: SysPoint, b: SysPoint) -> Joint {
        Joint {
            a,
            b,
            translation: Translation::Both,
            angle: None,
        }
    }

    /// Point 1 stays on the line through point 2 along the slot; `n` is the slot's unit
    /// normal in body 2's frame.
    pub fn pin_in_slot(a: SysPoint, b: SysPoint, n: [usize; 2]) -> Joint {
        Joint {
            a,
            b,
            translation: Translation::Normal { n },
            angle: None,
        }
    }

    /// Pin in slot with the relative angle held.
    pub fn prismatic(a: SysPoint, b: SysPoint, n: [usize; 2], angle: usize) -> Joint {
        Joint {
            angle: Some(angle),
            ..Joint::pin_in_slot(a, b, n)
        }
    }

    /// Revolute with the relative angle held.
    pub fn fixed(a: SysPoint, b: SysPoint, angle: usize) -> Joint {
        Joint {
            angle: Some(angle),
            ..Joint::revolute(a, b)
        }
    }

    /// Row-name suffixes, in row order.
    pub fn row_names(&self) -> Vec<&'static str> {
        let mut r = match self.translation {
            Translation::Both => vec!["x", "y"],
            Translation::Normal { .. } => vec!["slot"],
        };
        if self.angle.is_some() {
            r.push("angle");
        }
        r
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        let t = match self.translation {
            Translation::Both => 2,
            Translation::Normal { .. } => 1,
        };
        t + usize::from(self.angle.is_some())
    }

    /// Write the joint's rows of Φ into `out` (its length is [`Joint::rows`]).
    #[inline]
    pub fn phi<D: Scalar, E: Env<D>>(&self, fr: &Frames<'_, D, E>, out: &mut [D]) {
        let pa = fr.position(&self.a);
        let pb = fr.position(&self.b);
        let r = match self.translation {
            Translation::Both => {
                out[0] = pa[0] - pb[0];
                out[1] = pa[1] - pb[1];
                2
            }
            Translation::Normal { n } => {
                let n = fr.rotate_coefs(self.b.body, n);
                out[0] = (pa[0] - pb[0]) * n[0] + (pa[1] - pb[1]) * n[1];
                1
            }
        };
        if let Some(angle) = self.angle {
            out[r] = fr.angle(self.a.body) - fr.angle(self.b.body) - fr.env.coef(angle);
        }
    }
}

impl Joint {
    /// The column of A = ∂Φ/∂q of this joint's rows along tangent direction `d` (0 = x,
    /// 1 = y, 2 = θ) of body `k`, in f64 from the frames' poses (the ground's motion does
    /// not depend on q). Written out by hand from Φ because a planar point's derivative is
    /// a quarter turn of its arm, `∂(r + R p)/∂θ = (−(R p)_y, (R p)_x)`: the same numbers, in
    /// the same order of operations, as a `Dual64` pass through [`Joint::phi`] with the
    /// pose seeded along (k, d) (tests/elements.rs compares them), at a fraction of its
    /// cost. The envelope of a column: `out` has [`Joint::rows`] entries.
    #[inline]
    pub fn column<E: Env<f64>>(
        &self,
        fr: &Frames<'_, f64, E>,
        k: usize,
        d: usize,
        out: &mut [f64],
    ) {
        let dpos = |pt: &SysPoint| -> [f64; 2] {
            if pt.body != Some(k) {
                return [0.0, 0.0];
            }
            match d {
                0 => [1.0, 0.0],
                1 => [0.0, 1.0],
                _ => {
                    let a = fr.arm(pt);
                    [-a[1], a[0]]
                }
            }
        };
        let (da, db) = (dpos(&self.a), dpos(&self.b));
        let r = match self.translation {
            Translation::Both => {
                out[0] = da[0] - db[0];
                out[1] = da[1] - db[1];
                2
            }
            Translation::Normal { n } => {
                let (pa, pb) = (fr.position(&self.a), fr.position(&self.b));
                let nw = fr.rotate_coefs(self.b.body, n);
                let dn = if self.b.body == Some(k) && d == 2 {
                    [-nw[1], nw[0]]
                } else {
                    [0.0, 0.0]
                };
                let (x, y) = (pa[0] - pb[0], pa[1] - pb[1]);
                let (dx, dy) = (da[0] - db[0], da[1] - db[1]);
                // d(x n0 + y n1) as a dual product writes it: ẋ n0 + ṅ0 x, …
                out[0] = (dx * nw[0] + dn[0] * x) + (dy * nw[1] + dn[1] * y);
                1
            }
        };
        if self.angle.is_some() {
            let turn = |body: Option<usize>| if body == Some(k) && d == 2 { 1.0 } else { 0.0 };
            out[r] = turn(self.a.body) - turn(self.b.body);
        }
    }
}

impl Joint {
    /// This joint's rows of the bias b = −d²/ds² Φ(q + s·v) along the motion, for a
    /// ground that does not move (fixed, or frozen at a pose: Φ does not depend on t), in
    /// f64 from the frames' poses and the velocities `v`. Written out by hand from
    /// [`Joint::phi`]: the same numbers, in the same order of operations, as the second
    /// parts (`v2`) of the `Dual2_64` pass of `System::bias` through it (tests/elements.rs
    /// compares them bit for bit). A row reads only the second parts of the points, and a
    /// slot row the value and first parts its products need: the other parts are inlined
    /// and unused, for the optimizer to drop.
    /// `out` has [`Joint::rows`] entries.
    #[inline]
    pub fn bias<E: Env<f64>>(&self, fr: &Frames<'_, f64, E>, v: &[f64], out: &mut [f64]) {
        let r = match self.translation {
            Translation::Both => {
                let (pa, pb) = (position2(fr, v, &self.a), position2(fr, v, &self.b));
                out[0] = -(pa[0][2] - pb[0][2]);
                out[1] = -(pa[1][2] - pb[1][2]);
                2
            }
            Translation::Normal { n } => {
                let (pa, pb) = (position2(fr, v, &self.a), position2(fr, v, &self.b));
                let nw = rotate2(fr, v, self.b.body, n);
                let x = [0, 1, 2].map(|i| pa[0][i] - pb[0][i]);
                let y = [0, 1, 2].map(|i| pa[1][i] - pb[1][i]);
                out[0] = -(product2(x, nw[0]) + product2(y, nw[1]));
                1
            }
        };
        if self.angle.is_some() {
            // θ1 − θ2 − angle: a body's angle is linear in s and the ground's is held, so
            // every second part is +0 and the row's is (0 − 0) − 0 = +0, negated
            out[r] = -0.0;
        }
    }
}

/// The parts of a `Dual2_64` number in s (value, first and second derivative: `re`,
/// `v1`, `v2`), as f64.
type Parts = [f64; 3];

/// A frame's origin and (sin θ, cos θ) along the motion q + s·v as the dual pass of
/// `System::bias` has them: a body's from [`super::frame::Pose::along`]; the still ground's
/// from `GroundPose::at` — its origin a constant, its rotation (a frozen θ) the `sin_cos`
/// of a constant dual number, whose zero derivatives `0·cos θ`, `0·cos θ + 0·0·(−sin θ)`
/// carry signs that a sum may keep.
#[inline(always)]
fn frame2<E: Env<f64>>(
    fr: &Frames<'_, f64, E>,
    v: &[f64],
    body: Option<usize>,
) -> ([Parts; 2], Option<(Parts, Parts)>) {
    match body {
        Some(k) => {
            let p = &fr.poses[k];
            let o = fr.offsets[k];
            let w = v[o + 2];
            (
                [[p.r[0], v[o], 0.0], [p.r[1], v[o + 1], 0.0]],
                Some(([p.s, p.c * w, -p.s * w * w], [p.c, -p.s * w, -p.c * w * w])),
            )
        }
        None => {
            let g = fr.ground.r;
            let sc = fr.rotation(None).map(|(s, c)| {
                (
                    [s, 0.0 * c, 0.0 * c + 0.0 * 0.0 * -s],
                    [c, 0.0 * -s, 0.0 * -s + 0.0 * 0.0 * -c],
                )
            });
            ([[g[0], 0.0, 0.0], [g[1], 0.0, 0.0]], sc)
        }
    }
}

/// [`Frames::position`] along the motion: r + R p part by part (a coefficient's parts
/// are (p, 0, 0), and a dual number times an f64 multiplies each part).
#[inline(always)]
fn position2<E: Env<f64>>(fr: &Frames<'_, f64, E>, v: &[f64], pt: &SysPoint) -> [Parts; 2] {
    let (r, sc) = frame2(fr, v, pt.body);
    let (p0, p1) = (fr.env.coef(pt.p[0]), fr.env.coef(pt.p[1]));
    match sc {
        Some((s, c)) => [
            [0, 1, 2].map(|i| r[0][i] + c[i] * p0 - s[i] * p1),
            [0, 1, 2].map(|i| r[1][i] + s[i] * p0 + c[i] * p1),
        ],
        None => [
            [r[0][0] + p0, r[0][1] + 0.0, r[0][2] + 0.0],
            [r[1][0] + p1, r[1][1] + 0.0, r[1][2] + 0.0],
        ],
    }
}

/// [`Frames::rotate_coefs`] along the motion, part by part.
#[inline(always)]
fn rotate2<E: Env<f64>>(
    fr: &Frames<'_, f64, E>,
    v: &[f64],
    body: Option<usize>,
    n: [usize; 2],
) -> [Parts; 2] {
    let (n0, n1) = (fr.env.coef(n[0]), fr.env.coef(n[1]));
    match frame2(fr, v, body).1 {
        Some((s, c)) => [
            [0, 1, 2].map(|i| c[i] * n0 - s[i] * n1),
            [0, 1, 2].map(|i| s[i] * n0 + c[i] * n1),
        ],
        None => [[n0, 0.0, 0.0], [n1, 0.0, 0.0]],
    }
}

/// The second part of the dual product x·y, as num-dual 0.15's product rule writes it:
/// y″ x + x′ y′ + y′ x′ + x″ y.
#[inline(always)]
fn product2(x: Parts, y: Parts) -> f64 {
    y[2] * x[0] + x[1] * y[1] + y[1] * x[1] + x[2] * y[0]
}

impl Joint {
    /// Whether row `row` of this joint's column along tangent direction `d` (0 = x,
    /// 1 = y, 2 = θ) of one of its bodies is zero at every pose: [`Joint::column`] writes
    /// `0.0 − 0.0` there (a translation row along the other axis, the angle row along a
    /// translation). The constraint solve skips these entries (`crate::dynamics`): its
    /// sums start at +0 and adding ±0 to them changes nothing, so the numbers stay the same.
    pub fn column_zero(&self, d: usize, row: usize) -> bool {
        match self.translation {
            Translation::Both if row < 2 => d < 2 && row != d,
            Translation::Normal { .. } if row < 1 => false,
            // the angle row
            _ => d < 2,
        }
    }
}

/// A constraint of the model: a joint, or a user expression `expr = 0` (1 row).
#[derive(Debug, Clone)]
pub enum Constraint {
    Joint(Joint),
    Spatial(super::spatial::Joint3),
    Custom(Compiled),
}

impl Constraint {
    /// The bodies whose poses the constraint reads (a custom constraint reads
    /// coordinates directly: see [`Constraint::coordinates`]).
    pub fn bodies(&self) -> Vec<usize> {
        match self {
            Constraint::Joint(j) => [j.a.body, j.b.body].into_iter().flatten().collect(),
            Constraint::Spatial(j) => [j.a.body, j.b.body].into_iter().flatten().collect(),
            Constraint::Custom(_) => Vec::new(),
        }
    }

    /// The coordinates a custom constraint reads, sorted, without repeats.
    pub fn coordinates(&self) -> Vec<usize> {
        match self {
            Constraint::Joint(_) | Constraint::Spatial(_) => Vec::new(),
            Constraint::Custom(e) => {
                let mut c: Vec<usize> = e.coordinates().collect();
                c.sort_unstable();
                c.dedup();
                c
            }
        }
    }

    pub fn rows(&self) -> usize {
        match self {
            Constraint::Joint(j) => j.rows(),
            Constraint::Spatial(j) => j.rows(),
            Constraint::Custom(_) => 1,
        }
    }

    #[inline]
    pub fn phi<D: Scalar, E: Env<D>>(&self, fr: &Frames<'_, D, E>, t: D, out: &mut [D]) {
        match self {
            Constraint::Joint(j) => j.phi(fr, out),
            Constraint::Spatial(j) => j.phi(fr, out),
            Constraint::Custom(e) => out[0] = e.eval_in(fr.q, t, fr.env),
        }
    }
}
