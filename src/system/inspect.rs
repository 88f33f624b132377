//! The world geometry of a pose, for drawing and inspection: where each body's centre of
//! gravity, frame origin and named points are, where each joint's points are and which
//! way its axis points, where each force element acts. Planar models have z = 0.
//!
//! Read-only: it evaluates the same frames as the constraints and forces do
//! ([`Frames::position`], [`Frames::position3`]), so a drawing shows what the equations
//! see.

use super::System;
use super::forces::Force;
use super::frame::{Frames, SysPoint};
use super::joints::{Constraint, Translation};
use super::spatial::{Force3, SysPoint3};
use crate::model::SpatialJoint;
use crate::scalar::Plain;

/// A point in the world frame, m (planar models: z = 0).
pub type P3 = [f64; 3];

/// The type of a joint, planar or spatial.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointType {
    Revolute,
    Spherical,
    Universal,
    Prismatic,
    Cylindrical,
    Fixed,
    Distance,
    PinInSlot,
}

impl JointType {
    /// The name used in model files.
    pub fn name(self) -> &'static str {
        match self {
            JointType::Revolute => "revolute",
            JointType::Spherical => "spherical",
            JointType::Universal => "universal",
            JointType::Prismatic => "prismatic",
            JointType::Cylindrical => "cylindrical",
            JointType::Fixed => "fixed",
            JointType::Distance => "distance",
            JointType::PinInSlot => "pin_in_slot",
        }
    }
}

/// A body at the pose.
#[derive(Debug, Clone)]
pub struct BodyGeometry {
    pub name: String,
    /// Centre of gravity.
    pub cg: P3,
    /// The body frame's origin (planar bodies: the centre of gravity).
    pub origin: P3,
    /// Named points (`points = { ... }` in the model).
    pub points: Vec<(String, P3)>,
}

/// A joint at the pose.
#[derive(Debug, Clone)]
pub struct JointGeometry {
    pub name: String,
    pub kind: JointType,
    /// Body indices (None: the ground).
    pub body1: Option<usize>,
    pub body2: Option<usize>,
    pub p1: P3,
    pub p2: P3,
    /// The joint's axis (unit, world): a revolute's, a slot's or a slider's direction, a
    /// universal joint's first axis; None for spherical, fixed, distance and planar
    /// revolute joints.
    pub axis: Option<P3>,
    /// A universal joint's second (cross) axis, unit, world.
    pub axis2: Option<P3>,
}

/// What a force element is, at the pose.
#[derive(Debug, Clone)]
pub enum ForceGeometry {
    /// A spring–damper between two points.
    Spring {
        body1: Option<usize>,
        body2: Option<usize>,
        p1: P3,
        p2: P3,
        /// Stiffness (N/m) and damping (N·s/m), current values.
        stiffness: f64,
        damping: f64,
    },
    /// A torsional spring–damper about an axis (unit, world) between two bodies: drawn
    /// at the bodies' frame origins.
    Torsion {
        body1: Option<usize>,
        body2: Option<usize>,
        axis: P3,
        stiffness: f64,
        damping: f64,
    },
    /// A force at a point; its value (N, world) at the pose and time t.
    Point {
        body: Option<usize>,
        at: P3,
        force: P3,
    },
    /// A torque on a body.
    Torque { body: usize },
}

/// Everything placed in the world at one pose.
#[derive(Debug, Clone)]
pub struct Geometry {
    pub bodies: Vec<BodyGeometry>,
    pub joints: Vec<JointGeometry>,
    /// The impressed force elements in the model's order, gravity excepted (the system
    /// keeps gravity as an acceleration: [`System::gravity`]).
    pub forces: Vec<ForceGeometry>,
    /// The ground frame's origin at time t (it moves with a prescribed ground motion).
    pub ground: P3,
    /// Gravitational acceleration, m/s².
    pub gravity: P3,
}

fn p2(v: [f64; 2]) -> P3 {
    [v[0], v[1], 0.0]
}

fn unit(v: P3) -> P3 {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if n > 0.0 { v.map(|x| x / n) } else { v }
}

impl System {
    /// The world geometry at pose q and time t (see [`Geometry`]).
    pub fn geometry(&self, q: &[f64], t: f64) -> Geometry {
        let env = self.env();
        self.with_frames(q, t, env, |fr| Geometry {
            bodies: self.body_geometry(fr, q),
            joints: self.joint_geometry(fr),
            forces: self.force_geometry(fr, q, t),
            ground: fr.ground.r,
            gravity: self.gravity,
        })
    }

    fn body_geometry(&self, fr: &Frames<'_, f64, Plain<'_>>, q: &[f64]) -> Vec<BodyGeometry> {
        self.bodies
            .iter()
            .enumerate()
            .map(|(k, b)| {
                let o = b.offset;
                if self.spatial {
                    let cg = [q[o], q[o + 1], q[o + 2]];
                    let at = |p: [usize; 3]| {
                        fr.position3(&SysPoint3 {
                            body: Some(k),
                            p,
                            cg: b.cg,
                        })
                    };
                    let origin = match b.cg {
                        // the frame origin is −cg from the CG, in the body frame
                        Some(g) => {
                            let arm = fr.rotate3(Some(k), g);
                            [cg[0] - arm[0], cg[1] - arm[1], cg[2] - arm[2]]
                        }
                        None => cg,
                    };
                    BodyGeometry {
                        name: b.name.clone(),
                        cg,
                        origin,
                        points: b
                            .points
                            .iter()
                            .map(|(n, p)| (n.clone(), at([p[0], p[1], p[2]])))
                            .collect(),
                    }
                } else {
                    let cg = [q[o], q[o + 1], 0.0];
                    BodyGeometry {
                        name: b.name.clone(),
                        cg,
                        origin: cg,
                        points: b
                            .points
                            .iter()
                            .map(|(n, p)| {
                                let pt = SysPoint {
                                    body: Some(k),
                                    p: [p[0], p[1]],
                                };
                                (n.clone(), p2(fr.position(&pt)))
                            })
                            .collect(),
                    }
                }
            })
            .collect()
    }

    fn joint_geometry(&self, fr: &Frames<'_, f64, Plain<'_>>) -> Vec<JointGeometry> {
        let mut out = Vec::new();
        for (c, name) in self.constraints.iter().zip(&self.elements) {
            match c {
                Constraint::Joint(j) => {
                    let kind = match (j.translation, j.angle.is_some()) {
                        (Translation::Both, false) => JointType::Revolute,
                        (Translation::Both, true) => JointType::Fixed,
                        (Translation::Normal { .. }, false) => JointType::PinInSlot,
                        (Translation::Normal { .. }, true) => JointType::Prismatic,
                    };
                    let axis = match j.translation {
                        Translation::Normal { n } => {
                            let n = fr.rotate_coefs(j.b.body, n);
                            Some(unit([-n[1], n[0], 0.0]))
                        }
                        Translation::Both => None,
                    };
                    out.push(JointGeometry {
                        name: name.clone(),
                        kind,
                        body1: j.a.body,
                        body2: j.b.body,
                        p1: p2(fr.position(&j.a)),
                        p2: p2(fr.position(&j.b)),
                        axis,
                        axis2: None,
                    });
                }
                Constraint::Spatial(j) => {
                    let kind = match j.kind {
                        SpatialJoint::Revolute => JointType::Revolute,
                        SpatialJoint::Spherical => JointType::Spherical,
                        SpatialJoint::Universal => JointType::Universal,
                        SpatialJoint::Prismatic => JointType::Prismatic,
                        SpatialJoint::Cylindrical => JointType::Cylindrical,
                        SpatialJoint::Fixed => JointType::Fixed,
                        SpatialJoint::Distance => JointType::Distance,
                    };
                    let axis = j.f1.map(|f| unit(fr.rotate3(j.a.body, f[0])));
                    let axis2 = match kind {
                        JointType::Universal => j.f2.map(|f| unit(fr.rotate3(j.b.body, f[0]))),
                        _ => None,
                    };
                    out.push(JointGeometry {
                        name: name.clone(),
                        kind,
                        body1: j.a.body,
                        body2: j.b.body,
                        p1: fr.position3(&j.a),
                        p2: fr.position3(&j.b),
                        axis,
                        axis2,
                    });
                }
                Constraint::Custom(_) => {}
            }
        }
        out
    }

    fn force_geometry(
        &self,
        fr: &Frames<'_, f64, Plain<'_>>,
        q: &[f64],
        t: f64,
    ) -> Vec<ForceGeometry> {
        let c = &self.live.coefs;
        // drawn at rest: a load that reads velocities reads zeros
        let rest = vec![0.0; self.nv()];
        self.forces
            .iter()
            .map(|f| match f {
                Force::Spring { a, b, k, c: d, .. } => ForceGeometry::Spring {
                    body1: a.body,
                    body2: b.body,
                    p1: p2(fr.position(a)),
                    p2: p2(fr.position(b)),
                    stiffness: c[*k],
                    damping: c[*d],
                },
                Force::Point { at, f } => ForceGeometry::Point {
                    body: at.body,
                    at: p2(fr.position(at)),
                    force: [
                        f[0].eval_load(q, &rest, t, fr.env),
                        f[1].eval_load(q, &rest, t, fr.env),
                        0.0,
                    ],
                },
                Force::Spatial(Force3::Spring { a, b, k, c: d, .. }) => ForceGeometry::Spring {
                    body1: a.body,
                    body2: b.body,
                    p1: fr.position3(a),
                    p2: fr.position3(b),
                    stiffness: c[*k],
                    damping: c[*d],
                },
                Force::Spatial(Force3::Torsion {
                    b1,
                    b2,
                    frame,
                    k,
                    c: d,
                    ..
                }) => ForceGeometry::Torsion {
                    body1: *b1,
                    body2: *b2,
                    axis: unit(fr.rotate3(*b1, frame[0])),
                    stiffness: c[*k],
                    damping: c[*d],
                },
                Force::Spatial(Force3::Point { at, f }) => ForceGeometry::Point {
                    body: at.body,
                    at: fr.position3(at),
                    force: [0, 1, 2].map(|i| f[i].eval_load(q, &rest, t, fr.env)),
                },
                Force::Spatial(Force3::Torque { body, .. }) | Force::Torque { body, .. } => {
                    ForceGeometry::Torque { body: *body }
                }
                Force::Torsion {
                    b1, b2, k, c: d, ..
                } => ForceGeometry::Torsion {
                    body1: *b1,
                    body2: *b2,
                    axis: [0.0, 0.0, 1.0],
                    stiffness: c[*k],
                    damping: c[*d],
                },
            })
            .collect()
    }
}
