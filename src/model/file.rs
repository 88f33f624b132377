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
    pub inertia: SValue,
    pub x: Option<SValue>,
    pub y: Option<SValue>,
    pub theta: Option<SValue>,
    #[serde(default)]
    pub fix: Vec<SString>,
    /// Initial velocities by coordinate name (`{ theta = 0.5 }`): every velocity given
    /// is held; the others are solved from the velocity constraints (minimum norm).
    #[serde(default)]
    pub velocity: std::collections::BTreeMap<String, SValue>,
}

/// A vector of values, e.g. a point `["-L1/2", 0]`.
pub type SVector = Spanned<Vec<SValue>>;

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
    pub theta: Option<SValue>,
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
}
