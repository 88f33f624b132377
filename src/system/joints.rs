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
