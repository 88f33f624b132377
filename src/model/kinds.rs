//! What each joint and force `type` reads from its table: one table of fields per type.
//!
//! A type's table lists the fields it uses, each [`Rule::Required`] or
//! [`Rule::Optional`] with its default; every other field of `[[joints]]` (or
//! `[[forces]]`, see [`RawElement::FIELDS`]) is not used by the type, and giving it is an
//! error. [`Builder::element`] reads any element by these tables: it reports the unknown
//! `type`, the fields given that the type does not use, the required fields missing and
//! the values that cannot be read, fills in the defaults, and hands the values to the
//! type's constructor. A new type is a table row here and its constructor (and, for a
//! new field, the field in [`super::file`]).

use super::file::{RawElement, RawField};
use super::{
    BodyRef, Builder, Field, ForceKind, JointKind, LawDef, PointRef, SpatialJoint, suggest,
};
use crate::diag::Diagnostic;
use std::ops::Range;

/// One field a type uses.
#[derive(Debug, Clone, Copy)]
pub(super) struct FieldSpec {
    /// The field's name in the file (the name the struct in [`super::file`] gives it).
    pub name: &'static str,
    /// What messages about its value call it: `point` for the point of a `point_force`,
    /// otherwise the name.
    pub called: &'static str,
    pub rule: Rule,
}

#[derive(Debug, Clone, Copy)]
pub(super) enum Rule {
    /// Must be given. `help` is the hint when it is missing; without one the message
    /// points at the table ("no `stiffness` here") and says to add it.
    Required { help: Option<&'static str> },
    /// May be omitted; then it has this value, located at the element's table.
    Optional(Omitted),
}

/// The value of an optional field that is not given.
#[derive(Debug, Clone, Copy)]
pub(super) enum Omitted {
    /// The body `"ground"`.
    Ground,
    /// The number 0.
    Zero,
    /// The point `[0, 0]` (or `[0, 0, 0]`).
    Origin,
    /// Nothing: the constructor decides.
    Absent,
    /// This number (SI).
    Number(f64),
}

impl FieldSpec {
    const fn required(name: &'static str, help: Option<&'static str>) -> FieldSpec {
        FieldSpec {
            name,
            called: name,
            rule: Rule::Required { help },
        }
    }
    const fn optional(name: &'static str, omitted: Omitted) -> FieldSpec {
        FieldSpec {
            name,
            called: name,
            rule: Rule::Optional(omitted),
        }
    }
    const fn called(self, called: &'static str) -> FieldSpec {
        FieldSpec { called, ..self }
    }
}

/// A `type`: the fields it uses, and what it builds from their values.
pub(super) struct Kind<K> {
    pub name: &'static str,
    pub fields: &'static [FieldSpec],
    /// Builds the element from the values of `fields`, which have been read (and their
    /// problems reported). A value that could not be read is `None`: give up (`?`).
    pub build: fn(&mut Builder<'_>, &mut Values) -> Option<K>,
}

/// The types of one kind of element (joints, forces).
pub(super) struct Family<K: 'static> {
    /// `joint`, `force`: in messages and default names (`joint1`).
    pub what: &'static str,
    /// Fields every type uses, read before the `type` is looked at (also when it is
    /// unknown).
    pub common: &'static [FieldSpec],
    pub kinds: &'static [Kind<K>],
    /// Stop reading a type's own fields at the first that fails (joints: a prismatic
    /// joint whose `axis` fails says nothing about its `angle`), or read them all and
    /// report every problem (forces). Both as the loader has always done.
    pub stop_at_first_failure: bool,
}

// The two ends: every joint and a spring_damper have both, a point_force the first.
const BODY1: FieldSpec = FieldSpec::required("body1", Some("name a body, or \"ground\""));
const POINT1: FieldSpec = FieldSpec::optional("point1", Omitted::Origin); // m
const BODY2: FieldSpec = FieldSpec::optional("body2", Omitted::Ground);
const POINT2: FieldSpec = FieldSpec::optional("point2", Omitted::Origin); // m

/// Slot direction in body 2's frame, dimensionless.
const AXIS: FieldSpec = FieldSpec::required(
    "axis",
    Some("add `axis = [1, 0]` (direction of the slot in body2's frame)"),
);
/// Relative angle θ1 − θ2, rad.
const ANGLE: FieldSpec = FieldSpec::optional("angle", Omitted::Zero);

/// `[[joints]]`: every joint joins point 1 on body 1 to point 2 on body 2.
pub(super) const JOINTS: Family<JointKind> = Family {
    what: "joint",
    common: &[BODY1, POINT1, BODY2, POINT2],
    stop_at_first_failure: true,
    kinds: &[
        Kind {
            name: "revolute",
            fields: &[],
            build: |_, _| Some(JointKind::Revolute),
        },
        Kind {
            name: "pin_in_slot",
            fields: &[AXIS],
            build: |_, v| {
                Some(JointKind::PinInSlot {
                    axis: v.vector("axis")?,
                })
            },
        },
        Kind {
            name: "prismatic",
            fields: &[AXIS, ANGLE],
            build: |_, v| {
                Some(JointKind::Prismatic {
                    axis: v.vector("axis")?,
                    angle: v.scalar("angle")?,
                })
            },
        },
        Kind {
            name: "fixed",
            fields: &[ANGLE],
            build: |_, v| {
                Some(JointKind::Fixed {
                    angle: v.scalar("angle")?,
                })
            },
        },
    ],
};

/// A spatial joint's axis in body 1's frame, dimensionless.
const AXIS3: FieldSpec = FieldSpec::required(
    "axis",
    Some("add `axis = [0, 0, 1]` (the joint's axis in body1's frame)"),
);
/// The axis in body 2's frame (default: the same components as `axis`).
const AXIS2: FieldSpec = FieldSpec::optional("axis2", Omitted::Absent);

fn spatial(kind: SpatialJoint, v: &mut Values, axes: bool) -> Option<JointKind> {
    let (axis, axis2) = if axes {
        (Some(v.vector("axis")?), v.optional_vector("axis2"))
    } else {
        (None, None)
    };
    Some(JointKind::Spatial {
        kind,
        axis,
        axis2,
        length: None,
    })
}

/// `[[joints]]` of a spatial model.
pub(super) const JOINTS3: Family<JointKind> = Family {
    what: "joint",
    common: &[BODY1, POINT1, BODY2, POINT2],
    stop_at_first_failure: true,
    kinds: &[
        Kind {
            name: "revolute",
            fields: &[AXIS3, AXIS2],
            build: |_, v| spatial(SpatialJoint::Revolute, v, true),
        },
        Kind {
            name: "spherical",
            fields: &[],
            build: |_, v| spatial(SpatialJoint::Spherical, v, false),
        },
        Kind {
            name: "universal",
            fields: &[
                AXIS3,
                FieldSpec::required(
                    "axis2",
                    Some(
                        "add `axis2 = [...]`: the cross axis in body2's frame, perpendicular to `axis`",
                    ),
                ),
            ],
            build: |_, v| spatial(SpatialJoint::Universal, v, true),
        },
        Kind {
            name: "prismatic",
            fields: &[AXIS3, AXIS2],
            build: |_, v| spatial(SpatialJoint::Prismatic, v, true),
        },
        Kind {
            name: "cylindrical",
            fields: &[AXIS3, AXIS2],
            build: |_, v| spatial(SpatialJoint::Cylindrical, v, true),
        },
        Kind {
            name: "fixed",
            fields: &[],
            build: |_, v| spatial(SpatialJoint::Fixed, v, false),
        },
        Kind {
            name: "distance",
            fields: &[FieldSpec::required(
                "length",
                Some("add `length = ...` (m): the distance held between the points"),
            )],
            build: |_, v| {
                Some(JointKind::Spatial {
                    kind: SpatialJoint::Distance,
                    axis: None,
                    axis2: None,
                    length: Some(v.scalar("length")?),
                })
            },
        },
    ],
};

/// `[[forces]]` of a spatial model: the planar ones in 3-D, torsion and torque.
pub(super) const FORCES3: Family<ForceKind> = Family {
    what: "force",
    common: &[],
    stop_at_first_failure: false,
    kinds: &[
        Kind {
            name: "gravity",
            fields: &[FieldSpec::required(
                "acceleration", // m/s²
                Some("add `acceleration = [0, \"-g\", 0]` (m/s²)"),
            )],
            build: |_, v| {
                Some(ForceKind::Gravity {
                    acceleration: v.vector("acceleration")?,
                })
            },
        },
        SPRING_DAMPER,
        SPRING,
        BACKLASH,
        END_STOP,
        FRICTION,
        Kind {
            name: "torsion_spring",
            fields: &[BODY1, BODY2, AXIS3, FREE_ANGLE, LAW],
            build: |_, v| nonlinear_torsion(v, true, law_expr),
        },
        Kind {
            name: "breakout",
            fields: &[
                BODY1, BODY2, AXIS3, K1, PRELOAD, K2, DAMPING_T, FREE_ANGLE, EPS,
            ],
            build: |_, v| nonlinear_torsion(v, true, law_breakout),
        },
        Kind {
            name: "torsion_backlash",
            fields: &[BODY1, BODY2, AXIS3, K1, DAMPING_T, FREE_ANGLE, GAP, EPS],
            build: |_, v| nonlinear_torsion(v, true, law_backlash),
        },
        Kind {
            name: "torsion_end_stop",
            fields: &[BODY1, BODY2, AXIS3, K1, DAMPING_T, LOWER, UPPER, WIDTH],
            build: |b, v| end_stop_torsion(b, v, true),
        },
        Kind {
            name: "torsion_friction",
            fields: &[BODY1, BODY2, AXIS3, LEVEL, SLIP_RATE],
            build: |_, v| nonlinear_torsion(v, true, law_friction),
        },
        Kind {
            name: "point_force",
            fields: &[
                BODY1,
                POINT1.called("point"),
                FieldSpec::required("force", Some("add `force = [Fx, Fy, Fz]` (N, world frame)")),
            ],
            build: point_force,
        },
        Kind {
            name: "torsion",
            fields: &[BODY1, BODY2, AXIS3, STIFFNESS_T, DAMPING_T, FREE_ANGLE],
            build: |_, v| torsion(v, true),
        },
        Kind {
            name: "torque",
            fields: &[
                BODY1,
                FieldSpec::required(
                    "torque",
                    Some("add `torque = [Tx, Ty, Tz]` (N·m, world frame)"),
                ),
            ],
            build: |b, v| torque(b, v, true),
        },
    ],
};

const STIFFNESS_T: FieldSpec = FieldSpec::optional("stiffness", Omitted::Zero); // N·m/rad
const DAMPING_T: FieldSpec = FieldSpec::optional("damping", Omitted::Zero); // N·m·s/rad
const FREE_ANGLE: FieldSpec = FieldSpec::optional("free_angle", Omitted::Zero); // rad

/// A torsion spring–damper; spatial ones have an axis.
fn torsion(v: &mut Values, spatial: bool) -> Option<ForceKind> {
    let body1 = v.body("body1");
    let body2 = v.body("body2");
    let axis = if spatial {
        v.vector("axis")
    } else {
        Some(Vec::new())
    };
    Some(ForceKind::Torsion {
        body1: body1?,
        body2: body2?,
        axis: axis?,
        stiffness: v.scalar("stiffness")?,
        damping: v.scalar("damping")?,
        free_angle: v.scalar("free_angle")?,
        law: LawDef::Linear,
    })
}

/// A torque on a body: one value about the plane's normal (planar) or world components
/// `[Tx, Ty, Tz]` (spatial); the other form is refused where it is written.
fn torque(b: &mut Builder<'_>, v: &mut Values, spatial: bool) -> Option<ForceKind> {
    let body = v.body("body1")?;
    if body == BodyRef::Ground {
        b.diags.push(
            Diagnostic::new(format!(
                "{} acts on the ground, so it does nothing",
                v.owner
            ))
            .at(v.span.clone())
            .help("name the body it acts on in `body`"),
        );
        return None;
    }
    let torque = match (v.take("torque")?, spatial) {
        (Value::Vector(t), true) => t,
        (Value::Scalar(t), false) => vec![t],
        (Value::Scalar(t), true) => {
            b.diags.push(
                Diagnostic::new(format!(
                    "{}: a spatial torque has three components",
                    v.owner
                ))
                .at(t.span.clone())
                .help("write `torque = [Tx, Ty, Tz]` (N·m, world frame)"),
            );
            return None;
        }
        (Value::Vector(t), false) => {
            let at = t.first().map_or(v.span.clone(), |f| f.span.clone());
            b.diags.push(
                Diagnostic::new(format!("{}: a planar torque is one value", v.owner))
                    .at(at)
                    .help("write `torque = \"T0*sin(omega*t)\"` (N·m, about the plane's normal, counter-clockwise)"),
            );
            return None;
        }
        _ => return None,
    };
    Some(ForceKind::Torque { body, torque })
}

const SPRING_DAMPER: Kind<ForceKind> = Kind {
    name: "spring_damper",
    fields: &[
        BODY1,
        POINT1,
        BODY2,
        POINT2,
        FieldSpec::required("stiffness", None),        // N/m
        FieldSpec::optional("damping", Omitted::Zero), // N·s/m
        FieldSpec::required("free_length", None),      // m
    ],
    build: |_, v| {
        let [p1, p2] = v.ends()?;
        Some(ForceKind::SpringDamper {
            p1,
            p2,
            stiffness: v.scalar("stiffness")?,
            damping: v.scalar("damping")?,
            free_length: v.scalar("free_length")?,
            law: LawDef::Linear,
        })
    },
};

// The nonlinear elements (docs/model-format.md, "Nonlinear elements"): a spring or a
// torsion whose law is not linear. Units: m or rad (N or N·m) by the element's motion.
const LAW: FieldSpec = FieldSpec::required(
    "law",
    Some(
        "add `law = \"-k*x - c*x_dot\"`: the force (torque) as an expression of the stretch `x` and its rate `x_dot`",
    ),
);
const K1: FieldSpec = FieldSpec::required("stiffness", None); // N/m or N·m/rad
const K2: FieldSpec = FieldSpec::required(
    "stiffness2",
    Some("add `stiffness2 = ...` (N·m/rad): the stiffness once the preload is passed"),
);
const PRELOAD: FieldSpec = FieldSpec::required(
    "preload",
    Some("add `preload = ...` (N·m): the torque at which the stiffness changes"),
);
/// Relative corner width ε of the smoothed clip.
const EPS: FieldSpec = FieldSpec::optional("smoothing", Omitted::Number(0.02));
/// Absolute smoothing width of an end stop, m or rad.
const WIDTH: FieldSpec = FieldSpec::optional("smoothing", Omitted::Number(1e-4));
const GAP: FieldSpec = FieldSpec::required(
    "gap",
    Some("add `gap = ...` (m or rad): the half-width b of the dead band ±b"),
);
const LOWER: FieldSpec = FieldSpec::optional("lower", Omitted::Absent);
const UPPER: FieldSpec = FieldSpec::optional("upper", Omitted::Absent);
const LEVEL: FieldSpec = FieldSpec::required(
    "level",
    Some("add `level = ...` (N, or N·m for a torsion): the friction force while sliding"),
);
/// The regularization rate v0 of tanh(v/v0), m/s or rad/s.
const SLIP_RATE: FieldSpec = FieldSpec::optional("slip_rate", Omitted::Number(1e-3));
const FREE_LENGTH: FieldSpec = FieldSpec::required("free_length", None);
const DAMPING: FieldSpec = FieldSpec::optional("damping", Omitted::Zero);

fn law_expr(v: &mut Values) -> Option<LawDef> {
    Some(LawDef::Expr(v.scalar("law")?))
}
fn law_breakout(v: &mut Values) -> Option<LawDef> {
    Some(LawDef::Breakout {
        preload: v.scalar("preload")?,
        stiffness2: v.scalar("stiffness2")?,
        smoothing: v.scalar("smoothing")?,
    })
}
fn law_backlash(v: &mut Values) -> Option<LawDef> {
    Some(LawDef::Backlash {
        gap: v.scalar("gap")?,
        smoothing: v.scalar("smoothing")?,
    })
}
fn law_friction(v: &mut Values) -> Option<LawDef> {
    Some(LawDef::Friction {
        level: v.scalar("level")?,
        slip_rate: v.scalar("slip_rate")?,
    })
}
/// End stops: at least one limit.
fn law_end_stop(b: &mut Builder<'_>, v: &mut Values) -> Option<LawDef> {
    let lower = v.optional_scalar("lower")?;
    let upper = v.optional_scalar("upper")?;
    if lower.is_none() && upper.is_none() {
        b.diags.push(
            Diagnostic::new(format!("{} has no limit", v.owner))
                .at(v.span.clone())
                .help("add `lower = ...` and/or `upper = ...` (m or rad): where the stop begins"),
        );
        return None;
    }
    Some(LawDef::EndStop {
        lower,
        upper,
        smoothing: v.scalar("smoothing")?,
    })
}

/// A field the law does not use: 0 (the damping of a `spring`, say).
fn zero_or(v: &mut Values, name: &str, has: bool) -> Option<Field> {
    if has {
        v.scalar(name)
    } else {
        Some(Field::default_value(0.0, v.span.clone()))
    }
}

/// A torsion-like element with a nonlinear law.
fn nonlinear_torsion(
    v: &mut Values,
    spatial: bool,
    law: fn(&mut Values) -> Option<LawDef>,
) -> Option<ForceKind> {
    let has = |n: &str| v.read.iter().any(|(f, _)| *f == n);
    let (k, c, free) = (has("stiffness"), has("damping"), has("free_angle"));
    let body1 = v.body("body1");
    let body2 = v.body("body2");
    let axis = if spatial {
        v.vector("axis")
    } else {
        Some(Vec::new())
    };
    let stiffness = zero_or(v, "stiffness", k);
    let damping = zero_or(v, "damping", c);
    let free_angle = zero_or(v, "free_angle", free);
    let law = law(v);
    Some(ForceKind::Torsion {
        body1: body1?,
        body2: body2?,
        axis: axis?,
        stiffness: stiffness?,
        damping: damping?,
        free_angle: free_angle?,
        law: law?,
    })
}

fn end_stop_torsion(b: &mut Builder<'_>, v: &mut Values, spatial: bool) -> Option<ForceKind> {
    let law = law_end_stop(b, v);
    let mut kind = nonlinear_torsion(v, spatial, |_| Some(LawDef::Linear))?;
    if let ForceKind::Torsion { law: l, .. } = &mut kind {
        *l = law?;
    }
    Some(kind)
}

/// A spring-like element (between two points, along their line) with a nonlinear law.
fn nonlinear_spring(
    v: &mut Values,
    law: impl FnOnce(&mut Values) -> Option<LawDef>,
) -> Option<ForceKind> {
    let has = |n: &str| v.read.iter().any(|(f, _)| *f == n);
    let (k, c, l0) = (has("stiffness"), has("damping"), has("free_length"));
    let ends = v.ends();
    let stiffness = zero_or(v, "stiffness", k);
    let damping = zero_or(v, "damping", c);
    let free_length = zero_or(v, "free_length", l0);
    let law = law(v);
    let [p1, p2] = ends?;
    Some(ForceKind::SpringDamper {
        p1,
        p2,
        stiffness: stiffness?,
        damping: damping?,
        free_length: free_length?,
        law: law?,
    })
}

const SPRING: Kind<ForceKind> = Kind {
    name: "spring",
    fields: &[BODY1, POINT1, BODY2, POINT2, FREE_LENGTH, LAW],
    build: |_, v| nonlinear_spring(v, law_expr),
};
const BACKLASH: Kind<ForceKind> = Kind {
    name: "backlash",
    fields: &[
        BODY1,
        POINT1,
        BODY2,
        POINT2,
        K1,
        DAMPING,
        FREE_LENGTH,
        GAP,
        EPS,
    ],
    build: |_, v| nonlinear_spring(v, law_backlash),
};
/// The stretch of an end stop between two points is their distance (free length 0).
const END_STOP: Kind<ForceKind> = Kind {
    name: "end_stop",
    fields: &[
        BODY1, POINT1, BODY2, POINT2, K1, DAMPING, LOWER, UPPER, WIDTH,
    ],
    build: |b, v| {
        let law = law_end_stop(b, v);
        nonlinear_spring(v, |_| law)
    },
};
const FRICTION: Kind<ForceKind> = Kind {
    name: "friction",
    fields: &[BODY1, POINT1, BODY2, POINT2, LEVEL, SLIP_RATE],
    build: |_, v| nonlinear_spring(v, law_friction),
};

/// `[[forces]]`.
pub(super) const FORCES: Family<ForceKind> = Family {
    what: "force",
    common: &[],
    stop_at_first_failure: false,
    kinds: &[
        Kind {
            name: "gravity",
            fields: &[FieldSpec::required(
                "acceleration", // m/s²
                Some("add `acceleration = [0, \"-g\"]` (m/s²)"),
            )],
            build: |_, v| {
                Some(ForceKind::Gravity {
                    acceleration: v.vector("acceleration")?,
                })
            },
        },
        SPRING_DAMPER,
        SPRING,
        BACKLASH,
        END_STOP,
        FRICTION,
        Kind {
            name: "torsion_spring",
            fields: &[BODY1, BODY2, FREE_ANGLE, LAW],
            build: |_, v| nonlinear_torsion(v, false, law_expr),
        },
        Kind {
            name: "breakout",
            fields: &[BODY1, BODY2, K1, PRELOAD, K2, DAMPING_T, FREE_ANGLE, EPS],
            build: |_, v| nonlinear_torsion(v, false, law_breakout),
        },
        Kind {
            name: "torsion_backlash",
            fields: &[BODY1, BODY2, K1, DAMPING_T, FREE_ANGLE, GAP, EPS],
            build: |_, v| nonlinear_torsion(v, false, law_backlash),
        },
        Kind {
            name: "torsion_end_stop",
            fields: &[BODY1, BODY2, K1, DAMPING_T, LOWER, UPPER, WIDTH],
            build: |b, v| end_stop_torsion(b, v, false),
        },
        Kind {
            name: "torsion_friction",
            fields: &[BODY1, BODY2, LEVEL, SLIP_RATE],
            build: |_, v| nonlinear_torsion(v, false, law_friction),
        },
        Kind {
            name: "point_force",
            fields: &[
                BODY1,
                POINT1.called("point"),
                FieldSpec::required("force", Some("add `force = [Fx, Fy]` (N, world frame)")),
            ],
            build: point_force,
        },
        // planar: about the plane's normal; the twist is θ1 − θ2
        Kind {
            name: "torsion",
            fields: &[BODY1, BODY2, STIFFNESS_T, DAMPING_T, FREE_ANGLE],
            build: |_, v| torsion(v, false),
        },
        Kind {
            name: "torque",
            fields: &[
                BODY1,
                FieldSpec::required(
                    "torque",
                    Some("add `torque = \"T0*sin(omega*t)\"` (N·m, counter-clockwise)"),
                ),
            ],
            build: |b, v| torque(b, v, false),
        },
    ],
};

fn point_force(b: &mut Builder<'_>, v: &mut Values) -> Option<ForceKind> {
    let at = v.point("body1", "point1")?;
    if at.body == BodyRef::Ground {
        b.diags.push(
            Diagnostic::new(format!(
                "{} acts on the ground, so it does nothing",
                v.owner
            ))
            .at(v.span.clone())
            .help("name the body it acts on in `body`"),
        );
        return None;
    }
    Some(ForceKind::PointForce {
        at,
        force: v.vector("force")?,
    })
}

/// A field's value, read.
#[derive(Debug)]
pub(super) enum Value {
    Body(BodyRef),
    Vector(Vec<Field>),
    Scalar(Field),
    Absent,
}

/// The values of an element's fields, by name.
#[derive(Debug)]
pub(super) struct Values {
    /// The element, in messages: joint `A` (revolute).
    pub owner: String,
    /// The element's table in the file.
    pub span: Range<usize>,
    /// Every field of the type's tables: `None` if it could not be read, or was not
    /// read.
    read: Vec<(&'static str, Option<Value>)>,
}

impl Values {
    /// # Panics
    /// If `name` is not in the type's tables (a mistake in a constructor).
    fn take(&mut self, name: &str) -> Option<Value> {
        let (_, v) = self
            .read
            .iter_mut()
            .find(|(n, _)| *n == name)
            .unwrap_or_else(|| panic!("`{name}` is not in the type's table"));
        v.take()
    }
    pub fn scalar(&mut self, name: &str) -> Option<Field> {
        match self.take(name)? {
            Value::Scalar(f) => Some(f),
            other => panic!("`{name}` is not a number: {other:?}"),
        }
    }
    pub fn vector(&mut self, name: &str) -> Option<Vec<Field>> {
        match self.take(name)? {
            Value::Vector(v) => Some(v),
            other => panic!("`{name}` is not a vector: {other:?}"),
        }
    }
    /// An optional number: `Some(None)` if absent, `None` if not readable.
    pub fn optional_scalar(&mut self, name: &str) -> Option<Option<Field>> {
        match self.take(name)? {
            Value::Scalar(f) => Some(Some(f)),
            Value::Absent => Some(None),
            other => panic!("`{name}` is not a number: {other:?}"),
        }
    }
    /// An optional vector: `None` if absent (or not readable).
    pub fn optional_vector(&mut self, name: &str) -> Option<Vec<Field>> {
        match self.take(name)? {
            Value::Vector(v) => Some(v),
            _ => None,
        }
    }
    pub fn body(&mut self, name: &str) -> Option<BodyRef> {
        match self.take(name)? {
            Value::Body(b) => Some(b),
            other => panic!("`{name}` is not a body: {other:?}"),
        }
    }
    /// The point `point` on the body `body`.
    pub fn point(&mut self, body: &str, point: &str) -> Option<PointRef> {
        let body = self.body(body);
        let point = self.vector(point);
        Some(PointRef {
            body: body?,
            point: point?,
        })
    }
    /// The two ends, `body1`/`point1` and `body2`/`point2`.
    pub fn ends(&mut self) -> Option<[PointRef; 2]> {
        let p1 = self.point("body1", "point1");
        let p2 = self.point("body2", "point2");
        Some([p1?, p2?])
    }
}

/// An element read by its type's table.
pub(super) struct Element<K> {
    pub name: String,
    pub kind: K,
    /// The values the constructor did not take (a joint's ends).
    pub values: Values,
}

impl Builder<'_> {
    /// Read the `i`-th element of a family (0-based) from its table at `span`, reporting
    /// every problem: see the module's description.
    pub(super) fn element<K, R: RawElement>(
        &mut self,
        family: &Family<K>,
        i: usize,
        raw: &R,
        span: Range<usize>,
    ) -> Option<Element<K>> {
        let kind_name = raw.kind().get_ref().as_str();
        let name = raw
            .name()
            .map_or_else(|| format!("{}{}", family.what, i + 1), str::to_string);
        let mut values = Values {
            owner: format!("{} `{name}` ({kind_name})", family.what),
            span,
            read: Vec::new(),
        };
        self.read(family.common, raw, &mut values, false);
        let Some(kind) = family.kinds.iter().find(|k| k.name == kind_name) else {
            let names = family.kinds.iter().map(|k| k.name);
            let help = suggest(kind_name, names.clone()).unwrap_or_else(|| {
                format!(
                    "{} types: {}",
                    family.what,
                    names.collect::<Vec<_>>().join(", ")
                )
            });
            self.diags.push(
                Diagnostic::new(format!("unknown {} type `{kind_name}`", family.what))
                    .at(raw.kind().span())
                    .help(help),
            );
            return None;
        };
        let uses = |f: &str| family.common.iter().chain(kind.fields).any(|s| s.name == f);
        let mut unused = false;
        for f in R::FIELDS.iter().filter(|f| !uses(f)) {
            if let Some(given) = raw.field(f) {
                self.diags.push(
                    Diagnostic::new(format!("`{f}` is not a field of a `{kind_name}`"))
                        .at(given.span())
                        .label("not used by this type")
                        .help(format!("remove `{f}`, or change `type`")),
                );
                unused = true;
            }
        }
        if unused {
            return None;
        }
        self.read(kind.fields, raw, &mut values, family.stop_at_first_failure);
        let kind = (kind.build)(self, &mut values)?;
        Some(Element { name, kind, values })
    }

    /// Read `fields` in order into `values`.
    fn read<R: RawElement>(
        &mut self,
        fields: &[FieldSpec],
        raw: &R,
        values: &mut Values,
        stop_at_first_failure: bool,
    ) {
        let mut failed = false;
        for spec in fields {
            let value = if failed && stop_at_first_failure {
                None
            } else {
                self.read_field(spec, raw.field(spec.name), values)
            };
            failed |= value.is_none();
            values.read.push((spec.name, value));
        }
    }

    fn read_field(
        &mut self,
        spec: &FieldSpec,
        given: Option<RawField<'_>>,
        values: &Values,
    ) -> Option<Value> {
        match (given, spec.rule) {
            (Some(RawField::Body(b)), _) => self.body_ref(b).map(Value::Body),
            (Some(RawField::Vector(v)), _) => self.vector(v, spec.called).map(Value::Vector),
            (Some(RawField::Value(v)), _) => self.field(v).map(Value::Scalar),
            (None, Rule::Optional(omitted)) => Some(match omitted {
                Omitted::Ground => Value::Body(BodyRef::Ground),
                Omitted::Zero => Value::Scalar(Field::default_value(0.0, values.span.clone())),
                Omitted::Origin => {
                    Value::Vector(vec![
                        Field::default_value(0.0, values.span.clone());
                        self.dim
                    ])
                }
                Omitted::Absent => Value::Absent,
                Omitted::Number(x) => Value::Scalar(Field::default_value(x, values.span.clone())),
            }),
            (None, Rule::Required { help }) => {
                let (owner, called) = (&values.owner, spec.called);
                let d =
                    Diagnostic::new(format!("{owner} needs `{called}`")).at(values.span.clone());
                self.diags.push(match help {
                    Some(help) => d.help(help),
                    None => d
                        .label(format!("no `{called}` here"))
                        .help(format!("add `{called} = ...`")),
                });
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::file::{RawForce, RawJoint};

    /// Every field of every type's table is a field of the raw table, and each type's
    /// fields and the types' names are distinct.
    fn check_tables<K, R: RawElement>(family: &Family<K>) {
        for kind in family.kinds {
            let fields: Vec<&str> = family
                .common
                .iter()
                .chain(kind.fields)
                .map(|f| f.name)
                .collect();
            for (i, f) in fields.iter().enumerate() {
                assert!(R::FIELDS.contains(f), "{}: `{f}`", kind.name);
                assert!(!fields[..i].contains(f), "{}: `{f}` twice", kind.name);
            }
        }
        let names: Vec<&str> = family.kinds.iter().map(|k| k.name).collect();
        for (i, n) in names.iter().enumerate() {
            assert!(!names[..i].contains(n), "type `{n}` twice");
        }
    }

    #[test]
    fn the_tables_name_fields_of_the_raw_tables() {
        check_tables::<_, RawJoint>(&JOINTS);
        check_tables::<_, RawForce>(&FORCES);
        check_tables::<_, RawJoint>(&JOINTS3);
        check_tables::<_, RawForce>(&FORCES3);
    }
}
