//! The raw TOML layout of a model file, exactly as written, with byte spans.
//!
//! Nothing here is checked beyond TOML syntax and field names: the loader
//! ([`super::load`]) turns this into a [`super::Model`] and reports every semantic problem
//! with its location. Values that are numbers or expressions are [`RawValue`]s: a TOML
//! number, or a string holding an expression (`"m1*L1^2/12"`, `"7 mm"`).

use serde::Deserialize;
use serde::de::{self, Deserializer, MapAccess, Visitor};
use std::fmt;
use toml::Spanned;

/// A number or an expression string.
#[derive(Debug, Clone, PartialEq)]
pub enum RawValue {
    Number(f64),
    Text(String),
}

pub type SValue = Spanned<RawValue>;
pub type SString = Spanned<String>;

struct RawValueVisitor;

impl<'de> Visitor<'de> for RawValueVisitor {
    type Value = RawValue;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a number or an expression string such as \"2*L1\" or \"7 mm\"")
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<RawValue, E> {
        Ok(RawValue::Number(v as f64))
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<RawValue, E> {
        Ok(RawValue::Number(v as f64))
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<RawValue, E> {
        Ok(RawValue::Number(v))
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<RawValue, E> {
        Ok(RawValue::Text(v.to_string()))
    }
    fn visit_string<E: de::Error>(self, v: String) -> Result<RawValue, E> {
        Ok(RawValue::Text(v))
    }
}

impl<'de> Deserialize<'de> for RawValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(RawValueVisitor)
    }
}

/// A parameter: `L1 = 2.0`, `L1 = "2*sqrt(2)"`, `L1 = "7 mm"`, or a table
/// `k = { value = "50 N/m", unit = "N/m", description = "..." }` whose `unit` declares the
/// parameter's dimension (checked against its value and against `--set`).
#[derive(Debug, Clone)]
pub struct RawParam {
    pub value: SValue,
    pub unit: Option<SString>,
    pub description: Option<String>,
}

impl<'de> Deserialize<'de> for RawParam {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RawParam;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(
                    "a number, an expression string, or a table { value = ..., unit = \"...\" }",
                )
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<RawParam, A::Error> {
                let mut value = None;
                let mut unit = None;
                let mut description = None;
                while let Some(key) = map.next_key::<String>()? {
                    match key.as_str() {
                        "value" => value = Some(map.next_value::<SValue>()?),
                        "unit" => unit = Some(map.next_value::<SString>()?),
                        "description" => description = Some(map.next_value::<String>()?),
                        other => {
                            return Err(de::Error::unknown_field(
                                other,
                                &["value", "unit", "description"],
                            ));
                        }
                    }
                }
                let value = value.ok_or_else(|| de::Error::missing_field("value"))?;
                Ok(RawParam {
                    value,
                    unit,
                    description,
                })
            }
            // A bare number or string: its span is the one of the enclosing Spanned<RawParam>,
            // which the loader copies in.
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<RawParam, E> {
                Ok(bare(RawValue::Number(v as f64)))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<RawParam, E> {
                Ok(bare(RawValue::Number(v as f64)))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<RawParam, E> {
                Ok(bare(RawValue::Number(v)))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<RawParam, E> {
                Ok(bare(RawValue::Text(v.to_string())))
            }
        }
        fn bare(v: RawValue) -> RawParam {
            RawParam {
                value: Spanned::new(0..0, v),
                unit: None,
                description: None,
            }
        }
        d.deserialize_any(V)
    }
}

/// `[model]`: name and description, for reports.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawHeader {
    pub name: Option<String>,
    pub description: Option<String>,
    /// Name of the parameter that is the angular frequency (rad/s) of the model's
    /// harmonic forcing, e.g. `"omega"`: statics average time-dependent loads over its
    /// period, frequency responses sweep it.
    pub forcing_frequency: Option<SString>,
    /// Name of the parameter that is the amplitude of the model's harmonic forcing, e.g.
    /// `"F0"` (N) or `"D0"` (m): responses per unit of forcing (`frf --per-unit`, the
    /// report's transfer functions, a vibration profile's levels).
    pub forcing_amplitude: Option<SString>,
}

/// `[[bodies]]`: a rigid body. `type = "planar"` (the default) has coordinates `x`, `y`
/// (centre of gravity, m) and `theta` (rad); their values here are the initial pose
/// (held fixed during assembly if listed in `fix`, otherwise guesses).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawBody {
    pub name: SString,
    #[serde(rename = "type")]
    pub kind: Option<SString>,
    pub mass: SValue,
    /// Planar: the centroidal moment of inertia (kg·m²). Spatial: the inertia tensor
    /// about the CG in the body frame, `[Ixx, Iyy, Izz]` (principal) or
    /// `[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`.
    pub inertia: Spanned<RawInertia>,
    pub x: Option<SValue>,
    pub y: Option<SValue>,
    /// Spatial bodies: the CG's z (m).
    pub z: Option<SValue>,
    pub theta: Option<SValue>,
    /// Spatial bodies: the orientation, a sequence of rotations about body axes, each
    /// `[axis, name]` (`[["z", "phi"]]`, `[["z", "alpha"], ["x", "beta"]]`), or `"free"`
    /// (a unit quaternion with the body-frame angular velocity).
    pub rotation: Option<Spanned<toml::Value>>,
    /// Spatial bodies: initial values of the named angles (rad), default 0.
    #[serde(default)]
    pub angles: std::collections::BTreeMap<String, SValue>,
    /// Free bodies: the initial orientation as a quaternion `[qw, qx, qy, qz]`
    /// (normalized; default the identity).
    pub orientation: Option<SVector>,
    /// Spatial bodies: the CG in the body frame (m), when the frame's origin is not the
    /// CG. Points are given from the frame's origin.
    pub cg: Option<SVector>,
    /// Named points on the body, body frame (m): for responses and drawings.
    #[serde(default)]
    pub points: std::collections::BTreeMap<String, SVector>,
    #[serde(default)]
    pub fix: Vec<SString>,
    /// Initial velocities by coordinate name (`{ theta = 0.5 }`; a free body's by
    /// velocity name, `{ vx = 1, wz = 2 }`): every velocity given is held; the others are
    /// solved from the velocity constraints (minimum norm).
    #[serde(default)]
    pub velocity: std::collections::BTreeMap<String, SValue>,
}

/// A body's inertia: one value (planar) or a list (spatial).
#[derive(Debug, Clone)]
pub enum RawInertia {
    Value(RawValue),
    Vector(Vec<SValue>),
}

impl<'de> Deserialize<'de> for RawInertia {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RawInertia;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number, an expression string, or a list [Ixx, Iyy, Izz]")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<RawInertia, E> {
                Ok(RawInertia::Value(RawValue::Number(v as f64)))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<RawInertia, E> {
                Ok(RawInertia::Value(RawValue::Number(v as f64)))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<RawInertia, E> {
                Ok(RawInertia::Value(RawValue::Number(v)))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<RawInertia, E> {
                Ok(RawInertia::Value(RawValue::Text(v.to_string())))
            }
            fn visit_seq<A: de::SeqAccess<'de>>(self, mut seq: A) -> Result<RawInertia, A::Error> {
                let mut items = Vec::new();
                while let Some(x) = seq.next_element::<SValue>()? {
                    items.push(x);
                }
                Ok(RawInertia::Vector(items))
            }
        }
        d.deserialize_any(V)
    }
}

/// A value or a list of values (`torque = "T0"` in the plane, `[Tx, Ty, Tz]` in space).
/// The spans are the whole field's, set by [`RawModel::locate`] after parsing.
#[derive(Debug, Clone)]
pub enum RawValueOrVector {
    Value(SValue),
    Vector(SVector),
}

impl<'de> Deserialize<'de> for RawValueOrVector {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let placeholder = |v: RawValue| RawValueOrVector::Value(Spanned::new(0..0, v));
        match RawInertia::deserialize(d)? {
            RawInertia::Value(v) => Ok(placeholder(v)),
            RawInertia::Vector(items) => Ok(RawValueOrVector::Vector(Spanned::new(0..0, items))),
        }
    }
}

/// A vector of values, e.g. a point `["-L1/2", 0]`.
pub type SVector = Spanned<Vec<SValue>>;

/// A field of a `[[joints]]` or `[[forces]]` table, as given.
#[derive(Debug, Clone, Copy)]
pub enum RawField<'a> {
    /// A body name, or `"ground"`.
    Body(&'a SString),
    /// A vector, e.g. a point or an axis.
    Vector(&'a SVector),
    /// A number or an expression.
    Value(&'a SValue),
}

impl RawField<'_> {
    /// Byte span of the value in the file.
    pub fn span(&self) -> std::ops::Range<usize> {
        match self {
            RawField::Body(b) => b.span(),
            RawField::Vector(v) => v.span(),
            RawField::Value(v) => v.span(),
        }
    }
}

/// A `[[joints]]` or `[[forces]]` table: its `type`, its `name`, and its other fields by
/// name. What each `type` does with them is in the tables of `src/model/kinds.rs`.
pub trait RawElement {
    /// The table, for messages about the program itself: `[[joints]]`.
    const TABLE: &'static str;
    /// Every field besides `type` and `name`, in the order of the struct (the order in
    /// which fields that a `type` does not use are reported).
    const FIELDS: &'static [&'static str];
    fn kind(&self) -> &SString;
    fn name(&self) -> Option<&str>;
    fn ends(&self) -> RawEnds<'_>;
    /// Set the spans of values read without one (see [`RawModel::locate`]).
    fn locate(&mut self) {}
    /// A field that is not one of the ends: `None` if `key` is not such a field,
    /// `Some(None)` if it is but is not given.
    fn own_field(&self, key: &str) -> Option<Option<RawField<'_>>>;
    /// The field `key` (one of [`RawElement::FIELDS`]) if it is given.
    ///
    /// # Panics
    /// If `key` is not one of [`RawElement::FIELDS`].
    fn field(&self, key: &str) -> Option<RawField<'_>> {
        self.own_field(key)
            .or_else(|| self.ends().field(key))
            .unwrap_or_else(|| panic!("`{key}` is not a field of {}", Self::TABLE))
    }
}

/// The two ends that joints and forces share: `body1` (alias `body`), `point1` (alias
/// `point`), `body2`, `point2`. [`RawJoint`] and [`RawForce`] each declare these fields
/// themselves (with `#[serde(flatten)]` a shared struct would lose the spans of
/// `toml::Spanned`) and read them through this view.
#[derive(Debug, Clone, Copy)]
pub struct RawEnds<'a> {
    pub body1: &'a Option<SString>,
    pub point1: &'a Option<SVector>,
    pub body2: &'a Option<SString>,
    pub point2: &'a Option<SVector>,
}

impl<'a> RawEnds<'a> {
    /// The field `key` if it is one of the ends: `None` if it is not, `Some(None)` if it
    /// is but is not given.
    pub fn field(&self, key: &str) -> Option<Option<RawField<'a>>> {
        Some(match key {
            "body1" => self.body1.as_ref().map(RawField::Body),
            "point1" => self.point1.as_ref().map(RawField::Vector),
            "body2" => self.body2.as_ref().map(RawField::Body),
            "point2" => self.point2.as_ref().map(RawField::Vector),
            _ => return None,
        })
    }
}

/// The methods of [`RawElement`] that read `type`, `name` and the ends: the same for
/// every table that declares these fields.
macro_rules! type_name_and_ends {
    () => {
        fn kind(&self) -> &SString {
            &self.kind
        }
        fn name(&self) -> Option<&str> {
            self.name.as_deref()
        }
        fn ends(&self) -> RawEnds<'_> {
            RawEnds {
                body1: &self.body1,
                point1: &self.point1,
                body2: &self.body2,
                point2: &self.point2,
            }
        }
    };
}

/// `[[joints]]`: `type` = `revolute`, `pin_in_slot`, `prismatic`, `fixed`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawJoint {
    #[serde(rename = "type")]
    pub kind: SString,
    pub name: Option<String>,
    #[serde(alias = "body")]
    pub body1: Option<SString>,
    #[serde(alias = "point")]
    pub point1: Option<SVector>,
    pub body2: Option<SString>,
    pub point2: Option<SVector>,
    /// Slot direction in body 2's frame (pin_in_slot, prismatic).
    pub axis: Option<SVector>,
    /// Relative angle θ1 − θ2 held by prismatic and fixed joints, rad (default 0).
    pub angle: Option<SValue>,
    /// Spatial joints: the axis in body 2's frame (default: `axis`'s components).
    pub axis2: Option<SVector>,
    /// distance: the length held between the points, m.
    pub length: Option<SValue>,
}

impl RawElement for RawJoint {
    const TABLE: &'static str = "[[joints]]";
    const FIELDS: &'static [&'static str] = &[
        "body1", "point1", "body2", "point2", "axis", "angle", "axis2", "length",
    ];
    type_name_and_ends!();
    fn own_field(&self, key: &str) -> Option<Option<RawField<'_>>> {
        Some(match key {
            "axis" => self.axis.as_ref().map(RawField::Vector),
            "angle" => self.angle.as_ref().map(RawField::Value),
            "axis2" => self.axis2.as_ref().map(RawField::Vector),
            "length" => self.length.as_ref().map(RawField::Value),
            _ => return None,
        })
    }
}

/// `[[constraints]]`: a custom constraint equation `expr = 0` over coordinates,
/// parameters and time `t`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawConstraint {
    pub name: Option<String>,
    pub expr: SValue,
}

/// `[[forces]]`: `type` = `gravity`, `spring_damper`, `point_force`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawForce {
    #[serde(rename = "type")]
    pub kind: SString,
    pub name: Option<String>,
    /// gravity: acceleration vector, m/s².
    pub acceleration: Option<SVector>,
    #[serde(alias = "body")]
    pub body1: Option<SString>,
    #[serde(alias = "point")]
    pub point1: Option<SVector>,
    pub body2: Option<SString>,
    pub point2: Option<SVector>,
    /// spring_damper: N/m.
    pub stiffness: Option<SValue>,
    /// spring_damper: N·s/m.
    pub damping: Option<SValue>,
    /// spring_damper: m.
    pub free_length: Option<SValue>,
    /// point_force: world-frame components, N (expressions of t, parameters, coordinates).
    pub force: Option<SVector>,
    /// torsion: the common axis in body 1's frame.
    pub axis: Option<SVector>,
    /// torsion: the twist at which the torque is zero, rad.
    pub free_angle: Option<SValue>,
    /// torque: one value about the plane's normal (planar) or world-frame components
    /// `[Tx, Ty, Tz]` (spatial), N·m (expressions).
    pub torque: Option<Spanned<RawValueOrVector>>,
    /// spring, torsion_spring: the force (torque) as an expression of `x` and `x_dot`.
    pub law: Option<SValue>,
    /// breakout: the preload torque T0, N·m.
    pub preload: Option<SValue>,
    /// breakout: the stiffness beyond the breakout, N·m/rad.
    pub stiffness2: Option<SValue>,
    /// breakout, backlash, end stops: the smoothing (relative ε, or a width).
    pub smoothing: Option<SValue>,
    /// backlash: the half-width b of the dead band, m or rad.
    pub gap: Option<SValue>,
    /// end stops: the limits, m or rad.
    pub lower: Option<SValue>,
    pub upper: Option<SValue>,
    /// friction: the friction force (torque), N (N·m).
    pub level: Option<SValue>,
    /// friction: the regularization rate v0, m/s (rad/s).
    pub slip_rate: Option<SValue>,
}

impl RawElement for RawForce {
    const TABLE: &'static str = "[[forces]]";
    fn locate(&mut self) {
        RawForce::locate(self)
    }
    const FIELDS: &'static [&'static str] = &[
        "acceleration",
        "body1",
        "point1",
        "body2",
        "point2",
        "stiffness",
        "damping",
        "free_length",
        "force",
        "axis",
        "free_angle",
        "torque",
        "law",
        "preload",
        "stiffness2",
        "smoothing",
        "gap",
        "lower",
        "upper",
        "level",
        "slip_rate",
    ];
    type_name_and_ends!();
    fn own_field(&self, key: &str) -> Option<Option<RawField<'_>>> {
        Some(match key {
            "acceleration" => self.acceleration.as_ref().map(RawField::Vector),
            "stiffness" => self.stiffness.as_ref().map(RawField::Value),
            "damping" => self.damping.as_ref().map(RawField::Value),
            "free_length" => self.free_length.as_ref().map(RawField::Value),
            "force" => self.force.as_ref().map(RawField::Vector),
            "axis" => self.axis.as_ref().map(RawField::Vector),
            "free_angle" => self.free_angle.as_ref().map(RawField::Value),
            "law" => self.law.as_ref().map(RawField::Value),
            "preload" => self.preload.as_ref().map(RawField::Value),
            "stiffness2" => self.stiffness2.as_ref().map(RawField::Value),
            "smoothing" => self.smoothing.as_ref().map(RawField::Value),
            "gap" => self.gap.as_ref().map(RawField::Value),
            "lower" => self.lower.as_ref().map(RawField::Value),
            "upper" => self.upper.as_ref().map(RawField::Value),
            "level" => self.level.as_ref().map(RawField::Value),
            "slip_rate" => self.slip_rate.as_ref().map(RawField::Value),
            "torque" => self.torque.as_ref().map(|t| match t.get_ref() {
                RawValueOrVector::Value(v) => RawField::Value(v),
                RawValueOrVector::Vector(v) => RawField::Vector(v),
            }),
            _ => return None,
        })
    }
}

/// `[ground]`: the ground frame. `motion = { x = "D0*sin(omega*t)" }` prescribes its
/// motion (x, y in m, theta in rad, as expressions of `t` and the parameters): every
/// ground point moves with it (base excitation).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawGround {
    pub motion: Option<Spanned<RawMotion>>,
}

/// `[ground] motion`: planar components, each optional (0 when absent).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawMotion {
    pub x: Option<SValue>,
    pub y: Option<SValue>,
    /// Spatial models: the ground's z translation, m.
    pub z: Option<SValue>,
    pub theta: Option<SValue>,
    /// Spatial models: the ground's rotation angles (rad), R = Rz(rz) Ry(ry) Rx(rx).
    pub rx: Option<SValue>,
    pub ry: Option<SValue>,
    pub rz: Option<SValue>,
}

/// The whole file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawModel {
    #[serde(default)]
    pub model: RawHeader,
    #[serde(default)]
    pub ground: RawGround,
    #[serde(default)]
    pub parameters: std::collections::BTreeMap<String, Spanned<RawParam>>,
    #[serde(default)]
    pub bodies: Vec<Spanned<RawBody>>,
    #[serde(default)]
    pub joints: Vec<Spanned<RawJoint>>,
    #[serde(default)]
    pub constraints: Vec<Spanned<RawConstraint>>,
    #[serde(default)]
    pub forces: Vec<Spanned<RawForce>>,
    /// Parameters solved so that held coordinates are a static equilibrium.
    pub trim: Option<Spanned<RawTrim>>,
    /// Named modes (`[[modes]]`).
    #[serde(default)]
    pub modes: Vec<Spanned<RawMode>>,
}

/// The `type` of each body, joint and force, read whatever the other fields are (no
/// `deny_unknown_fields`): so that an unknown type is reported before the fields it would
/// not know (`type = "torsionn"` with `stifness = 3` is a misspelt type first).
#[derive(Debug, Clone, Default, Deserialize)]
pub struct RawTypes {
    #[serde(default)]
    pub bodies: Vec<Spanned<RawTyped>>,
    #[serde(default)]
    pub joints: Vec<Spanned<RawTyped>>,
    #[serde(default)]
    pub forces: Vec<Spanned<RawTyped>>,
}

/// One table's `type` (any TOML value: only a string is checked), and whether it has a
/// `rotation` (a body's: the model is spatial).
#[derive(Debug, Clone, Deserialize)]
pub struct RawTyped {
    #[serde(rename = "type")]
    pub kind: Option<Spanned<toml::Value>>,
    pub rotation: Option<de::IgnoredAny>,
}

impl RawModel {
    /// Give the values read without their own span (see [`RawValueOrVector`]) the span
    /// of their field.
    pub fn locate(&mut self) {
        for f in &mut self.forces {
            f.get_mut().locate();
        }
    }
}

impl RawForce {
    /// See [`RawModel::locate`].
    pub fn locate(&mut self) {
        {
            if let Some(t) = &mut self.torque {
                let span = t.span();
                *t.get_mut() = match t.get_ref() {
                    RawValueOrVector::Value(v) => {
                        RawValueOrVector::Value(Spanned::new(span, v.get_ref().clone()))
                    }
                    RawValueOrVector::Vector(v) => {
                        RawValueOrVector::Vector(Spanned::new(span, v.get_ref().clone()))
                    }
                };
            }
        }
    }
}

/// `[trim]`: `solve = ["L0"]` parameters found so that the pose with the coordinates
/// `hold = ["stick.phi"]` at their initial values is a static equilibrium.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawTrim {
    pub solve: Vec<SString>,
    pub hold: Vec<SString>,
}

/// `[[modes]]`: a mode named by what it is, `name = "in-phase"` and its expected shape
/// `shape = { "stick.phi" = 1, "gearbox.theta" = 0.75 }` (coordinate → number), matched
/// to the computed modes by MAC at the baseline ([`crate::linear::tracking`]).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawMode {
    pub name: SString,
    pub shape: Spanned<std::collections::BTreeMap<SString, SValue>>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::de::DeserializeOwned;

    /// `R::FIELDS` are the struct's fields besides `type` and `name` (as serde lists them
    /// when it refuses an unknown one), and in `text`, which gives every field a value
    /// that contains its name, `field` finds each where it is.
    fn check_raw<R: RawElement + DeserializeOwned>(aliases: &[&str], text: &str) {
        let e = toml::from_str::<R>("type = \"x\"\nzzz = 1")
            .err()
            .unwrap()
            .to_string();
        let listed = e.split("expected one of ").nth(1).unwrap();
        let mut got: Vec<&str> = listed
            .split(',')
            .map(|f| f.trim().trim_matches('`'))
            .collect();
        let mut want = vec!["type", "name"];
        want.extend(R::FIELDS);
        want.extend(aliases);
        got.sort();
        want.sort();
        assert_eq!(got, want, "{e}");
        let mut raw: R = toml::from_str(text).unwrap();
        raw.locate();
        for f in R::FIELDS {
            let span = raw.field(f).unwrap_or_else(|| panic!("{f}")).span();
            assert!(text[span].contains(&format!("\"{f}\"")), "{f}");
        }
    }

    #[test]
    fn the_raw_tables_give_each_field_by_its_name() {
        check_raw::<RawJoint>(
            &["body", "point"],
            r#"type = "x"
               body1 = "body1"
               point1 = ["point1", 0]
               body2 = "body2"
               point2 = ["point2", 0]
               axis = ["axis", 0]
               angle = "angle"
               axis2 = ["axis2", 0]
               length = "length""#,
        );
        check_raw::<RawForce>(
            &["body", "point"],
            r#"type = "x"
               acceleration = ["acceleration", 0]
               body1 = "body1"
               point1 = ["point1", 0]
               body2 = "body2"
               point2 = ["point2", 0]
               stiffness = "stiffness"
               damping = "damping"
               free_length = "free_length"
               force = ["force", 0]
               axis = ["axis", 0]
               free_angle = "free_angle"
               torque = "torque"
               law = "law"
               preload = "preload"
               stiffness2 = "stiffness2"
               smoothing = "smoothing"
               gap = "gap"
               lower = "lower"
               upper = "upper"
               level = "level"
               slip_rate = "slip_rate""#,
        );
    }
}
