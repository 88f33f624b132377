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
//! dual passes through it). One piece is hand-written: a planar joint's columns of A
//! ([`Joint::column`]), since a point's derivative along its body's angle is a quarter
//! turn of its arm. A `Dual64` pass per column cost three times as much (it builds the
//! frames and both points for one derivative; num-dual's multi-direction duals were
//! slower still), and no crate gives the Jacobian of these few lines of geometry cheaper
//! than writing them out. The column is written in the dual pass's order of operations,
//! so it is the same to the last bit (tests/elements.rs). With it goes which of its
//! entries are zero at every pose ([`Joint::column_zero`]), so that the constraint solve
//! skips them (`crate::dynamics`).

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
