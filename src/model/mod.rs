//! The model file: parameters, expressions, units, bodies, joints, forces.
//!
//! [`Model::load`] reads a TOML file, evaluates its parameters (SI), parses every
//! expression and checks names, dimensions and signs, collecting every problem with its
//! location. A [`Model`] is immutable; [`Model::with_overrides`] makes a copy with some
//! parameters replaced (`--set`), re-evaluating the parameters defined from them.
//! `System::new` (module `system`) compiles a model into fast equations (this module does
//! not depend on it: the data flows one way).

pub mod expr;
pub mod file;
mod kinds;
pub mod params;
pub mod units;

use crate::diag::{Diagnostic, Error, Result, SourceFile};
use expr::{Expr, ExprError};
use file::{RawValue, SString, SValue, SVector};
use params::Parameters;
use std::ops::Range;
use std::sync::Arc;
use units::Dim;

/// An expression as written in the model file, with where it came from.
#[derive(Debug, Clone)]
pub struct Field {
    pub expr: Expr,
    /// Byte span of the whole TOML value in the file.
    pub span: Range<usize>,
    /// Byte offset of the expression's first character in the file (inside the quotes).
    pub offset: usize,
    /// Written as a TOML number (its expression text is not in the file).
    pub number: bool,
}

impl Field {
    /// Parse a TOML number or expression string.
    pub fn parse(v: &SValue, text: &str) -> std::result::Result<Field, Diagnostic> {
        let span = v.span();
        match v.get_ref() {
            RawValue::Number(x) => {
                if !x.is_finite() {
                    return Err(Diagnostic::new(format!("`{x}` is not a finite number"))
                        .at(span)
                        .label("not finite")
                        .help("give a finite number"));
                }
                let expr = expr::parse(&format!("{x:?}"))
                    .map_err(|e| Diagnostic::new(e.message).at(span.clone()))?;
                Ok(Field {
                    expr,
                    offset: span.start,
                    span,
                    number: true,
                })
            }
            RawValue::Text(s) => {
                let offset = string_content_offset(text, span.start);
                let expr = expr::parse(s).map_err(|e| expr_diag(&e, offset))?;
                Ok(Field {
                    expr,
                    span,
                    offset,
                    number: false,
                })
            }
        }
    }

    /// A field that is not in the file (a default), e.g. an omitted `theta = 0`.
    pub fn default_value(x: f64, at: Range<usize>) -> Field {
        Field {
            expr: expr::parse(&format!("{x:?}")).expect("a float literal parses"),
            offset: at.start,
            span: at,
            number: true,
        }
    }

    /// File span of an expression-relative span.
    pub fn file_span(&self, s: &expr::Span) -> Range<usize> {
        if self.number {
            return self.span.clone();
        }
        self.offset + s.start..self.offset + s.end
    }
}

/// Where a TOML string's content starts: after `"`, `'`, `"""` or `'''`.
fn string_content_offset(text: &str, start: usize) -> usize {
    let rest = &text.as_bytes()[start.min(text.len())..];
    if rest.starts_with(b"\"\"\"") || rest.starts_with(b"'''") {
        // A newline right after the opening delimiter is trimmed by TOML.
        let after = start + 3;
        if text.as_bytes().get(after) == Some(&b'\n') {
            after + 1
        } else {
            after
        }
    } else if rest.starts_with(b"\"") || rest.starts_with(b"'") {
        start + 1
    } else {
        start
    }
}

/// A diagnostic from an expression error at `offset` in the file.
pub fn expr_diag(e: &ExprError, offset: usize) -> Diagnostic {
    let mut d = Diagnostic::new(e.message.clone())
        .at(offset + e.span.start..offset + e.span.end.max(e.span.start + 1));
    if let Some(h) = &e.help {
        d = d.help(h.clone());
    }
    d
}

/// `did you mean ...?` from a list of candidates.
pub fn suggest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<String> {
    // called once per unknown name over all the model's names: `name` lowered once, the
    // edit distance only where the lengths allow one edit
    let a = name.to_lowercase();
    let mut b = String::new();
    let mut scored: Vec<(f64, &str)> = candidates
        .into_iter()
        .map(|c| {
            b.clear();
            b.extend(c.chars().flat_map(char::to_lowercase));
            let (a, b) = (a.as_str(), b.as_str());
            let score = if a == b {
                1.0
            } else if a.len().abs_diff(b.len()) <= 4 && strsim::osa_distance(a, b) == 1 {
                // one typo, also in short names (`Fz` for `Fs`), or two letters swapped
                // (`rmp` for `rpm`: Jaro–Winkler scores a swap in a short name low)
                0.95
            } else {
                strsim::jaro_winkler(a, b)
            };
            (score, c)
        })
        .filter(|(s, _)| *s > 0.8)
        .collect();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    let best = scored.first()?.0;
    let ties: Vec<String> = scored
        .iter()
        .take_while(|(s, _)| *s == best)
        .map(|(_, c)| format!("`{c}`"))
        .collect();
    Some(format!("did you mean {}?", ties.join(" or ")))
}

/// A rigid body. Planar: coordinates `x`, `y` (centre of gravity, m), `theta` (rad).
/// Spatial: `x`, `y`, `z` (centre of gravity, m) and the named angles of its rotation
/// sequence (rad); its velocities are the coordinates' rates. Free: `x`, `y`, `z` and the
/// unit quaternion `qw`, `qx`, `qy`, `qz`; velocities `vx`, `vy`, `vz` (the CG's, world
/// frame) and `wx`, `wy`, `wz` (the angular velocity in the body frame).
#[derive(Debug, Clone)]
pub struct Body {
    pub name: String,
    pub name_span: Range<usize>,
    pub kind: BodyKind,
    /// kg.
    pub mass: Field,
    /// Planar: the centroidal moment of inertia (1 value). Spatial: the inertia tensor
    /// about the CG in the body frame, `Ixx, Iyy, Izz, Ixy, Ixz, Iyz` (kg·m²).
    pub inertia: Vec<Field>,
    /// Where the inertia is written.
    pub inertia_span: Range<usize>,
    /// Spatial: the CG in the body frame, from the frame's origin (m); planar: empty.
    pub cg: Vec<Field>,
    /// Coordinate names (without the body's prefix), in order.
    pub coords: Vec<String>,
    /// Dimension of each coordinate.
    pub dims: Vec<Dim>,
    /// Velocity names (without the body's prefix), in order: the coordinates' names when
    /// the velocities are their rates.
    pub vels: Vec<String>,
    /// Dimension of each velocity.
    pub vdims: Vec<Dim>,
    /// Initial pose, one per coordinate (in the body kind's coordinate order).
    pub initial: Vec<Field>,
    /// Which coordinates are held at their initial value during assembly (a free body's
    /// four quaternion components together, or none of them).
    pub fixed: Vec<bool>,
    /// Given initial velocities (m/s or rad/s), per velocity.
    pub velocity: Vec<Option<Field>>,
    /// Named points (body frame, from the frame's origin, m).
    pub points: Vec<(String, Vec<Field>)>,
}

/// The kinds of body.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BodyKind {
    Planar,
    /// A spatial body whose orientation is a sequence of rotations about body axes
    /// (0 = x, 1 = y, 2 = z): `R = R_a1(θ1) R_a2(θ2) …`.
    Spatial {
        axes: Vec<usize>,
    },
    /// A spatial body whose orientation is a unit quaternion, moved by its body-frame
    /// angular velocity (no singular pose).
    Free,
}

impl BodyKind {
    pub fn is_spatial(&self) -> bool {
        !matches!(self, BodyKind::Planar)
    }

    /// Whether the velocities are the coordinates' rates (all but free bodies).
    pub fn velocities_are_rates(&self) -> bool {
        !matches!(self, BodyKind::Free)
    }
}

/// A free body's coordinates after x, y, z: the unit quaternion.
pub const QUATERNION: [&str; 4] = ["qw", "qx", "qy", "qz"];

/// A free body's velocities: the CG's (world frame) and the angular velocity (body frame).
pub const FREE_VELOCITIES: [&str; 6] = ["vx", "vy", "vz", "wx", "wy", "wz"];

/// A spatial body's `rotation`, as written.
enum Rotation {
    /// Axes (0 = x, 1 = y, 2 = z) and angle names.
    Sequence(Vec<usize>, Vec<String>),
    Free,
}

/// A body reference: a body index, or the ground.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BodyRef {
    Ground,
    Body(usize),
}

/// A point on a body or on the ground: body-frame coordinates (m).
#[derive(Debug, Clone)]
pub struct PointRef {
    pub body: BodyRef,
    /// 2 components (planar) or 3 (spatial).
    pub point: Vec<Field>,
}

#[derive(Debug, Clone)]
pub enum JointKind {
    /// Point 1 on body 1 coincides with point 2 on body 2 (2 equations).
    Revolute,
    /// Point 1 on body 1 stays on the line through point 2 along `axis`, fixed in body 2
    /// (1 equation).
    PinInSlot { axis: Vec<Field> },
    /// Pin in slot plus a fixed relative angle θ1 − θ2 = angle (2 equations).
    Prismatic { axis: Vec<Field>, angle: Field },
    /// Revolute plus a fixed relative angle θ1 − θ2 = angle (3 equations).
    Fixed { angle: Field },
    /// Spatial joints: axes in body 1's and body 2's frames.
    Spatial {
        kind: SpatialJoint,
        axis: Option<Vec<Field>>,
        axis2: Option<Vec<Field>>,
        length: Option<Field>,
    },
}

/// The spatial joint types.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpatialJoint {
    Revolute,
    Spherical,
    Universal,
    Prismatic,
    Cylindrical,
    Fixed,
    Distance,
}

#[derive(Debug, Clone)]
pub struct Joint {
    pub name: String,
    pub span: Range<usize>,
    pub kind: JointKind,
    pub p1: PointRef,
    pub p2: PointRef,
}

/// A custom constraint `expr = 0`.
#[derive(Debug, Clone)]
pub struct CustomConstraint {
    pub name: String,
    pub expr: Field,
}

#[derive(Debug, Clone)]
pub enum ForceKind {
    /// Uniform gravitational acceleration (m/s²) acting on every body.
    Gravity { acceleration: Vec<Field> },
    /// Linear spring and dashpot between two points, along their line, tension positive:
    /// T = k (d − L0) + c ḋ.
    SpringDamper {
        p1: PointRef,
        p2: PointRef,
        stiffness: Field,
        damping: Field,
        free_length: Field,
        law: LawDef,
    },
    /// A force (N, world frame) at a body point; components may depend on `t`,
    /// parameters and coordinates.
    PointForce { at: PointRef, force: Vec<Field> },
    /// A torsional spring–damper about a common axis (body 1's frame): the torque on
    /// body 1 is −(k (twist − free_angle) + c twist_rate) about the axis, and the
    /// opposite on body 2 (spatial models).
    Torsion {
        body1: BodyRef,
        body2: BodyRef,
        axis: Vec<Field>,
        stiffness: Field,
        damping: Field,
        free_angle: Field,
        law: LawDef,
    },
    /// A torque (N·m, world frame) on a body (spatial models).
    Torque { body: BodyRef, torque: Vec<Field> },
}

/// The law of a `spring_damper`- or `torsion`-like element (docs/model-format.md,
/// "Nonlinear elements"): the linear spring–dashpot, or one of the nonlinear kinds.
#[derive(Debug, Clone)]
pub enum LawDef {
    Linear,
    /// `law`: an expression of `x` (stretch) and `x_dot` (its rate).
    Expr(Field),
    /// `preload` T0, `stiffness2` k2, `smoothing` ε (k1 is `stiffness`).
    Breakout {
        preload: Field,
        stiffness2: Field,
        smoothing: Field,
    },
    /// `gap` b, `smoothing` ε (relative to b).
    Backlash {
        gap: Field,
        smoothing: Field,
    },
    /// `lower`, `upper` limits of the stretch, `smoothing` width (m or rad).
    EndStop {
        lower: Option<Field>,
        upper: Option<Field>,
        smoothing: Field,
    },
    /// `level` (N or N·m), `slip_rate` v0.
    Friction {
        level: Field,
        slip_rate: Field,
    },
}

#[derive(Debug, Clone)]
pub struct ForceDef {
    pub name: String,
    pub span: Range<usize>,
    pub kind: ForceKind,
}

/// The ground frame's prescribed motion (`[ground] motion`): planar x, y (m), theta
/// (rad) as expressions of `t` and the parameters; absent components stay 0.
#[derive(Debug, Clone, Default)]
pub struct GroundDef {
    pub x: Option<Field>,
    pub y: Option<Field>,
    pub z: Option<Field>,
    pub theta: Option<Field>,
    /// Spatial models: rotation angles, R = Rz(rz) Ry(ry) Rx(rx).
    pub rx: Option<Field>,
    pub ry: Option<Field>,
    pub rz: Option<Field>,
}

/// `[trim]`: parameters solved so that the held coordinates' initial values are a static
/// equilibrium.
#[derive(Debug, Clone, Default)]
pub struct TrimDef {
    /// Parameters solved, with where they are named.
    pub solve: Vec<(String, Range<usize>)>,
    /// Coordinates held (full names), with where they are named.
    pub hold: Vec<(String, Range<usize>)>,
    pub span: Range<usize>,
}

/// `[[modes]]`: a mode named by what it is, with the shape it is expected to have.
#[derive(Debug, Clone)]
pub struct ModeDef {
    /// Unique, non-empty, not of the form `mode <number>` (the unnamed modes' names),
    /// without commas or quotes (it heads CSV columns).
    pub name: String,
    /// `(velocity name, value)`: the coordinates given (a body's coordinate, or a free
    /// body's velocity `b.vx` … `b.wz`), by name; not all zero.
    pub shape: Vec<(String, f64)>,
    /// The `[[modes]]` table.
    pub span: Range<usize>,
}

/// A loaded model: immutable; cheap to clone with other parameter values.
#[derive(Debug, Clone)]
pub struct Model {
    pub name: String,
    pub description: Option<String>,
    pub source: SourceFile,
    /// SHA-256 of the file's bytes, hex.
    pub hash: String,
    pub parameters: Arc<Parameters>,
    pub bodies: Arc<Vec<Body>>,
    pub joints: Arc<Vec<Joint>>,
    pub constraints: Arc<Vec<CustomConstraint>>,
    pub forces: Arc<Vec<ForceDef>>,
    /// The ground's prescribed motion (none: fixed).
    pub ground: Arc<GroundDef>,
    /// Whether the model is spatial (its bodies are spatial).
    pub spatial: bool,
    /// Parameters solved for a datum (`[trim]`), if any.
    pub trim: Option<Arc<TrimDef>>,
    /// The `--set` overrides applied, as given (`NAME=VALUE`).
    pub overrides: Vec<(String, String)>,
    /// The parameter that is the forcing's angular frequency (`[model] forcing_frequency`).
    pub forcing_frequency: Option<String>,
    /// The parameter that is the forcing's amplitude (`[model] forcing_amplitude`).
    pub forcing_amplitude: Option<String>,
    /// Named modes (`[[modes]]`), in the file's order.
    pub modes: Arc<Vec<ModeDef>>,
}

impl Model {
    /// The SI unit of parameter `name`'s dimension (`N/m`), empty when it has none or is
    /// not known.
    pub fn param_unit(&self, name: &str) -> String {
        let Some(i) = self.parameters.index(name) else {
            return String::new();
        };
        // the declared unit where the value is in it (an SI unit, kept as written:
        // N·m/rad, not N·m); an angle or an angular speed declared in deg or rpm is held
        // in rad or rad/s
        if let Some((text, dim)) = &self.parameters.list[i].unit
            && let Ok((factor, _)) = units::parse_unit(text)
        {
            if factor == 1.0 && !text.trim().is_empty() && text.trim() != "1" {
                return text.trim().replace('*', "·");
            }
            if *dim == units::Dim::NONE
                && matches!(
                    text.trim(),
                    "deg" | "degree" | "degrees" | "°" | "rev" | "turn"
                )
            {
                return "rad".into();
            }
            if *dim == units::Dim::FREQUENCY {
                return "rad/s".into();
            }
        }
        self.parameters.dims[i]
            .map(|d| d.to_string())
            .filter(|d| d != "1")
            .unwrap_or_default()
    }

    /// Read and check a model file (at most [`MAX_INPUT_BYTES`]; see [`read_input`]).
    pub fn load(path: &str) -> Result<Model> {
        let text = read_input(path, "model file")?;
        Model::from_str(path, &text)
    }

    /// Parse and check model text; `path` is used in messages.
    pub fn from_str(path: &str, text: &str) -> Result<Model> {
        let source = SourceFile {
            path: path.to_string(),
            text: Arc::from(text),
        };
        let raw: file::RawModel = match toml::from_str(text) {
            Ok(mut r) => {
                file::RawModel::locate(&mut r);
                r
            }
            Err(e) => {
                // an unknown `type` first: the fields the table's type would not know are
                // not the problem (serde reports only the first of those)
                let (mut diagnostics, bad) = unknown_types(text);
                let mut d = Diagnostic::new(toml_message(&e)).help(
                    "the model file is TOML: see docs/model-format.md for the sections and fields",
                );
                if let Some(span) = e.span() {
                    d = d.at(span).label("here");
                }
                let in_bad = |d: &Diagnostic| {
                    d.span
                        .as_ref()
                        .is_some_and(|s| bad.iter().any(|b| b.start <= s.start && s.end <= b.end))
                };
                if !in_bad(&d) {
                    diagnostics.push(d);
                }
                return Err(Error::Model {
                    source,
                    diagnostics,
                });
            }
        };
        let mut diags = Vec::new();
        let parameters = Parameters::from_raw(&raw.parameters, text, &mut diags);
        let spatial = raw.bodies.iter().any(|b| b.get_ref().rotation.is_some());
        let mut b = Builder {
            text,
            diags: &mut diags,
            body_names: raw
                .bodies
                .iter()
                .map(|b| b.get_ref().name.get_ref().clone())
                .collect(),
            dim: if spatial { 3 } else { 2 },
        };
        let bodies: Vec<Body> = raw.bodies.iter().filter_map(|r| b.body(r)).collect();
        let joints: Vec<Joint> = raw
            .joints
            .iter()
            .enumerate()
            .filter_map(|(i, r)| b.joint(i, r))
            .collect();
        let constraints: Vec<CustomConstraint> = raw
            .constraints
            .iter()
            .enumerate()
            .filter_map(|(i, r)| {
                let c = r.get_ref();
                let expr = b.field(&c.expr)?;
                Some(CustomConstraint {
                    name: c
                        .name
                        .clone()
                        .unwrap_or_else(|| format!("constraint{}", i + 1)),
                    expr,
                })
            })
            .collect();
        // Constraint rows are named after joints and constraints: names must be unique.
        {
            let mut seen: Vec<&str> = Vec::new();
            let named = joints
                .iter()
                .map(|j| (j.name.as_str(), j.span.clone()))
                .chain(
                    constraints
                        .iter()
                        .map(|c| (c.name.as_str(), c.expr.span.clone())),
                );
            for (name, span) in named {
                if seen.contains(&name) {
                    b.diags.push(
                        Diagnostic::new(format!("two joints or constraints are named `{name}`"))
                            .at(span)
                            .help("give each joint and constraint its own `name` (they name the constraint rows)"),
                    );
                } else {
                    seen.push(name);
                }
            }
        }
        let forces: Vec<ForceDef> = raw
            .forces
            .iter()
            .enumerate()
            .filter_map(|(i, r)| b.force(i, r))
            .collect();
        // Responses name bodies' points, joints and force elements (`sensor.tension`,
        // `J2.force_x`, `stick.grip.x`): a name is one thing across bodies, joints and
        // constraints, and forces.
        {
            let mut seen: Vec<(&str, &str)> = bodies
                .iter()
                .map(|x| (x.name.as_str(), "a body"))
                .chain(joints.iter().map(|j| (j.name.as_str(), "a joint")))
                .chain(
                    constraints
                        .iter()
                        .map(|c| (c.name.as_str(), "a constraint")),
                )
                .collect();
            for f in &forces {
                if let Some((_, what)) = seen.iter().find(|(n, _)| *n == f.name) {
                    b.diags.push(
                        Diagnostic::new(format!("the force `{}` has the name of {what}", f.name))
                            .at(f.span.clone())
                            .help("give each force its own `name`: responses such as `<force>.tension` name it"),
                    );
                } else {
                    seen.push((f.name.as_str(), "another force"));
                }
            }
            let named = joints
                .iter()
                .map(|j| (j.name.as_str(), j.span.clone(), "joint"))
                .chain(
                    constraints
                        .iter()
                        .map(|c| (c.name.as_str(), c.expr.span.clone(), "constraint")),
                )
                .chain(
                    forces
                        .iter()
                        .map(|f| (f.name.as_str(), f.span.clone(), "force")),
                );
            for (name, span, what) in named {
                let clash = if name == "ground" {
                    Some("the ground")
                } else if what != "force" && bodies.iter().any(|x| x.name == name) {
                    Some("a body")
                } else {
                    None
                };
                if let Some(other) = clash {
                    b.diags.push(
                        Diagnostic::new(format!("the {what} `{name}` has the name of {other}"))
                            .at(span)
                            .help(format!("give the {what} its own `name`: responses name it")),
                    );
                }
            }
        }
        let ground = match &raw.ground.motion {
            None => GroundDef::default(),
            Some(m) => {
                let mm = m.get_ref();
                if mm.x.is_none()
                    && mm.y.is_none()
                    && mm.z.is_none()
                    && mm.theta.is_none()
                    && mm.rx.is_none()
                    && mm.ry.is_none()
                    && mm.rz.is_none()
                {
                    b.diags.push(
                        Diagnostic::new("`[ground] motion` gives no component")
                            .at(m.span())
                            .help("give x, y and/or theta as expressions of t, e.g. motion = { x = \"D0*sin(omega*t)\" }"),
                    );
                }
                if spatial && let Some(t) = &mm.theta {
                    b.diags.push(
                        Diagnostic::new("`theta` motion of the ground in a spatial model")
                            .at(t.span())
                            .help("a spatial ground turns by rx, ry, rz (rad, R = Rz(rz) Ry(ry) Rx(rx)); theta is the planar ground's angle"),
                    );
                }
                if !spatial {
                    for r in [&mm.rx, &mm.ry, &mm.rz].into_iter().flatten() {
                        b.diags.push(
                            Diagnostic::new("`rx`/`ry`/`rz` motion of the ground in a planar model")
                                .at(r.span())
                                .help("the planar ground turns by theta; give the model's bodies a `rotation` to make it spatial"),
                        );
                    }
                }
                if !spatial && let Some(z) = &mm.z {
                    b.diags.push(
                        Diagnostic::new("`z` motion of the ground in a planar model")
                            .at(z.span())
                            .help("planar models move in x, y and theta; give bodies a `rotation` to make the model spatial"),
                    );
                }
                GroundDef {
                    x: mm.x.as_ref().and_then(|v| b.field(v)),
                    y: mm.y.as_ref().and_then(|v| b.field(v)),
                    z: mm.z.as_ref().and_then(|v| b.field(v)),
                    theta: mm.theta.as_ref().and_then(|v| b.field(v)),
                    rx: mm.rx.as_ref().and_then(|v| b.field(v)),
                    ry: mm.ry.as_ref().and_then(|v| b.field(v)),
                    rz: mm.rz.as_ref().and_then(|v| b.field(v)),
                }
            }
        };
        let trim = raw.trim.as_ref().map(|t| {
            let tt = t.get_ref();
            Arc::new(TrimDef {
                solve: tt
                    .solve
                    .iter()
                    .map(|s| (s.get_ref().clone(), s.span()))
                    .collect(),
                hold: tt
                    .hold
                    .iter()
                    .map(|s| (s.get_ref().clone(), s.span()))
                    .collect(),
                span: t.span(),
            })
        });
        // (a body that failed to load has no coordinates to check against: its error
        // stands alone)
        if let Some(t) = &trim
            && bodies.len() == raw.bodies.len()
        {
            b.check_trim(t, &bodies, &parameters);
        }
        // (as for the trim: coordinates are known only when every body loaded)
        let modes = if bodies.len() == raw.bodies.len() {
            b.modes(&raw.modes, &bodies)
        } else {
            Vec::new()
        };
        if bodies.is_empty() && diags.is_empty() {
            diags.push(
                Diagnostic::new("the model has no bodies")
                    .help("add a [[bodies]] table with name, mass and inertia"),
            );
        }
        let model = Model {
            name: raw.model.name.clone().unwrap_or_else(|| {
                std::path::Path::new(path)
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default()
            }),
            description: raw.model.description.clone(),
            hash: sha256_hex(text.as_bytes()),
            source: source.clone(),
            parameters: Arc::new(parameters),
            bodies: Arc::new(bodies),
            joints: Arc::new(joints),
            constraints: Arc::new(constraints),
            forces: Arc::new(forces),
            ground: Arc::new(ground),
            spatial,
            trim,
            overrides: Vec::new(),
            forcing_frequency: raw
                .model
                .forcing_frequency
                .as_ref()
                .map(|f| f.get_ref().clone()),
            forcing_amplitude: raw
                .model
                .forcing_amplitude
                .as_ref()
                .map(|f| f.get_ref().clone()),
            modes: Arc::new(modes),
        };
        if let Some(f) = &raw.model.forcing_frequency
            && model.parameters.index(f.get_ref()).is_none()
            && !model.parameters.is_rejected(f.get_ref())
        {
            diags.push(
                Diagnostic::new(format!(
                    "`forcing_frequency` names `{}`, which is not a parameter",
                    f.get_ref()
                ))
                .at(f.span())
                .label("not a parameter")
                .help(
                    suggest(f.get_ref(), model.parameters.names()).unwrap_or_else(|| {
                        "name the parameter that holds the forcing's angular frequency (rad/s)"
                            .into()
                    }),
                ),
            );
        }
        if let Some(f) = &raw.model.forcing_amplitude {
            if model.parameters.is_rejected(f.get_ref()) {
                // its definition is reported already
            } else if model.parameters.index(f.get_ref()).is_none() {
                diags.push(
                    Diagnostic::new(format!(
                        "`forcing_amplitude` names `{}`, which is not a parameter",
                        f.get_ref()
                    ))
                    .at(f.span())
                    .label("not a parameter")
                    .help(suggest(f.get_ref(), model.parameters.names()).unwrap_or_else(|| {
                        "name the parameter that holds the forcing's amplitude (e.g. F0, N, or D0, m)".into()
                    })),
                );
            } else if raw.model.forcing_frequency.is_none() {
                diags.push(
                    Diagnostic::new("`forcing_amplitude` is given without `forcing_frequency`")
                        .at(f.span())
                        .label("amplitude of which forcing?")
                        .help("name the forcing's angular frequency too: forcing_frequency = \"omega\""),
                );
            }
        }
        if diags.is_empty() {
            // Names, dimensions and signs are checked when the model is compiled
            // (`System::new`): this layer knows nothing of the compiled system.
            Ok(model)
        } else {
            Err(Error::Model {
                source,
                diagnostics: diags,
            })
        }
    }

    /// A copy with parameters replaced: each `(name, value)` is an expression such as
    /// `"3"`, `"-3"`, `"2 mm"`, `"L1/2"` (plain numbers are SI). Parameters defined from
    /// others are re-evaluated.
    pub fn with_overrides(&self, overrides: &[(String, String)]) -> Result<Model> {
        if overrides.is_empty() {
            return Ok(self.clone());
        }
        let parameters = self.parameters.with_overrides(&self.source, overrides)?;
        let mut m = self.clone();
        m.parameters = Arc::new(parameters);
        m.overrides.extend(overrides.iter().cloned());
        Ok(m)
    }

    /// Error in this model's file.
    pub fn error(&self, diagnostics: Vec<Diagnostic>) -> Error {
        Error::Model {
            source: self.source.clone(),
            diagnostics,
        }
    }

    /// Coordinate names `<body>.<coordinate>` in order.
    pub fn coordinate_names(&self) -> Vec<String> {
        self.bodies
            .iter()
            .flat_map(|b| b.coords.iter().map(move |c| format!("{}.{}", b.name, c)))
            .collect()
    }

    /// `<body>.<velocity>` for each velocity (the coordinates' names where the
    /// velocities are their rates).
    pub fn velocity_names(&self) -> Vec<String> {
        self.bodies
            .iter()
            .flat_map(|b| b.vels.iter().map(move |c| format!("{}.{}", b.name, c)))
            .collect()
    }
}

/// A body's `type`s.
const BODY_TYPES: [&str; 2] = ["planar", "spatial"];

/// The bodies', joints' and forces' `type`s that name no type, each reported as the
/// loader does ("unknown force type `torsionn`", with a "did you mean"), and the spans of
/// their tables. Read leniently (other fields ignored): for a file that the full reading
/// refuses, so that a misspelt type is reported rather than the fields it would not know.
fn unknown_types(text: &str) -> (Vec<Diagnostic>, Vec<Range<usize>>) {
    let Ok(raw) = toml::from_str::<file::RawTypes>(text) else {
        return (Vec::new(), Vec::new());
    };
    let spatial = raw.bodies.iter().any(|b| b.get_ref().rotation.is_some());
    let (joints, forces) = if spatial {
        (&kinds::JOINTS3, &kinds::FORCES3)
    } else {
        (&kinds::JOINTS, &kinds::FORCES)
    };
    let joints: Vec<&str> = joints.kinds.iter().map(|k| k.name).collect();
    let forces: Vec<&str> = forces.kinds.iter().map(|k| k.name).collect();
    let families: [(&str, &[toml::Spanned<file::RawTyped>], Vec<&str>); 3] = [
        ("body", &raw.bodies, BODY_TYPES.to_vec()),
        ("joint", &raw.joints, joints),
        ("force", &raw.forces, forces),
    ];
    let mut diags = Vec::new();
    let mut spans = Vec::new();
    for (what, tables, known) in families {
        for t in tables {
            let Some(kind) = &t.get_ref().kind else {
                continue;
            };
            let Some(name) = kind.get_ref().as_str() else {
                continue;
            };
            if known.contains(&name) {
                continue;
            }
            let help = suggest(name, known.iter().copied())
                .unwrap_or_else(|| format!("{what} types: {}", known.join(", ")));
            diags.push(
                Diagnostic::new(format!("unknown {what} type `{name}`"))
                    .at(kind.span())
                    .help(help),
            );
            let start = t.span().start;
            spans.push(start..table_end(text, start));
        }
    }
    (diags, spans)
}

/// Where the table whose header is at `start` ends: at the next table header (a line
/// `[name]` or `[[name]]` of bare keys), or at the end of the text.
fn table_end(text: &str, start: usize) -> usize {
    let is_header = |line: &str| {
        let l = line.split('#').next().unwrap_or("").trim();
        let inner = l
            .strip_prefix('[')
            .and_then(|l| l.strip_suffix(']'))
            .map(|l| l.trim_start_matches('[').trim_end_matches(']').trim());
        inner.is_some_and(|k| {
            !k.is_empty()
                && k.chars()
                    .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.' | ' '))
        })
    };
    let mut at = start;
    let mut first = true;
    for line in text[start.min(text.len())..].split_inclusive('\n') {
        // the table's own header (the span may start at it or in its body)
        if !first && is_header(line) {
            return at;
        }
        first = false;
        at += line.len();
    }
    text.len()
}

/// `toml`'s message without its own location excerpt (we print ours).
fn toml_message(e: &toml::de::Error) -> String {
    e.message().trim().to_string()
}

fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::{Digest, Sha256};
    let digest = Sha256::digest(bytes);
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// Turns raw tables into checked definitions, collecting problems.
struct Builder<'a> {
    text: &'a str,
    diags: &'a mut Vec<Diagnostic>,
    body_names: Vec<String>,
    /// Components of points and vectors: 2 (planar) or 3 (spatial).
    dim: usize,
}

impl Builder<'_> {
    fn field(&mut self, v: &SValue) -> Option<Field> {
        match Field::parse(v, self.text) {
            Ok(f) => Some(f),
            Err(d) => {
                self.diags.push(d);
                None
            }
        }
    }

    /// A vector of the model's dimension (2 planar, 3 spatial).
    fn vector(&mut self, v: &SVector, what: &str) -> Option<Vec<Field>> {
        self.vector_n(v, what, self.dim)
    }

    fn vector_n(&mut self, v: &SVector, what: &str, n: usize) -> Option<Vec<Field>> {
        let items = v.get_ref();
        if items.len() != n {
            let (kind, example) = if n == 3 {
                ("spatial", "[x, y, z]")
            } else {
                ("planar", "[x, y]")
            };
            self.diags.push(
                Diagnostic::new(format!(
                    "`{what}` needs {n} components ({kind}), found {}",
                    items.len()
                ))
                .at(v.span())
                .help(format!("write `{what} = {example}`")),
            );
            return None;
        }
        let fields: Vec<Option<Field>> = items.iter().map(|x| self.field(x)).collect();
        fields.into_iter().collect()
    }

    /// `[trim]`: names that exist, as many conditions as unknowns.
    /// `[[modes]]`: names unique, non-empty and not `mode <number>`; shapes of known
    /// coordinates (velocity names), finite numbers, not all zero.
    fn modes(&mut self, raw: &[toml::Spanned<file::RawMode>], bodies: &[Body]) -> Vec<ModeDef> {
        let names: Vec<String> = bodies
            .iter()
            .flat_map(|b| b.vels.iter().map(move |c| format!("{}.{c}", b.name)))
            .collect();
        let mut out: Vec<ModeDef> = Vec::new();
        for r in raw {
            let m = r.get_ref();
            let name = m.name.get_ref().trim().to_string();
            let mut ok = true;
            let numbered = name
                .strip_prefix("mode ")
                .is_some_and(|d| !d.is_empty() && d.chars().all(|c| c.is_ascii_digit()));
            if name.is_empty() || numbered {
                self.diags.push(
                    Diagnostic::new(if numbered {
                        format!("the mode name `{name}` is the form of an unnamed mode's")
                    } else {
                        "the mode's `name` is empty".to_string()
                    })
                    .at(m.name.span())
                    .label("here")
                    .help("name the mode by what it is, e.g. name = \"in-phase\" (unnamed modes are called `mode 1`, `mode 2`, … by frequency)"),
                );
                ok = false;
            } else if name.contains([',', '"']) {
                self.diags.push(
                    Diagnostic::new(format!("the mode name `{name}` has a comma or a quote"))
                        .at(m.name.span())
                        .label("here")
                        .help("a mode's name heads CSV columns (`<name>.omega_n_rad_s`): leave out commas and quotes"),
                );
                ok = false;
            } else if out.iter().any(|o| o.name == name) {
                self.diags.push(
                    Diagnostic::new(format!("two modes are named `{name}`"))
                        .at(m.name.span())
                        .label("second use")
                        .help("give each [[modes]] table its own `name`"),
                );
                ok = false;
            }
            let mut shape = Vec::new();
            for (coord, value) in m.shape.get_ref() {
                if !names.contains(coord.get_ref()) {
                    self.diags.push(
                        Diagnostic::new(format!(
                            "the shape of mode `{name}` names `{}`, which is not a coordinate",
                            coord.get_ref()
                        ))
                        .at(coord.span())
                        .label("not a coordinate")
                        .help(
                            suggest(coord.get_ref(), names.iter().map(|s| s.as_str()))
                                .unwrap_or_else(|| format!("coordinates: {}", names.join(", "))),
                        ),
                    );
                    ok = false;
                    continue;
                }
                match value.get_ref() {
                    RawValue::Number(x) if x.is_finite() => {
                        shape.push((coord.get_ref().clone(), *x))
                    }
                    _ => {
                        self.diags.push(
                            Diagnostic::new(format!(
                                "the shape of mode `{name}` gives `{}` a value that is not a finite number",
                                coord.get_ref()
                            ))
                            .at(value.span())
                            .label("not a number")
                            .help("a shape entry is a plain real number (the coordinate's relative amplitude, SI), e.g. 0.75"),
                        );
                        ok = false;
                    }
                }
            }
            if ok && shape.iter().all(|(_, x)| *x == 0.0) {
                self.diags.push(
                    Diagnostic::new(if shape.is_empty() {
                        format!("the shape of mode `{name}` gives no coordinate")
                    } else {
                        format!("the shape of mode `{name}` is zero in every coordinate")
                    })
                    .at(m.shape.span())
                    .label("here")
                    .help("give the coordinates' relative amplitudes in this mode, e.g. shape = { \"stick.phi\" = 1, \"gearbox.theta\" = 0.75 }, at least one not zero"),
                );
                ok = false;
            }
            if ok {
                out.push(ModeDef {
                    name,
                    shape,
                    span: r.span(),
                });
            }
        }
        out
    }

    fn check_trim(&mut self, t: &TrimDef, bodies: &[Body], params: &Parameters) {
        for (name, span) in &t.solve {
            if params.index(name).is_none() && !params.is_rejected(name) {
                self.diags.push(
                    Diagnostic::new(format!(
                        "`[trim] solve` names `{name}`, which is not a parameter"
                    ))
                    .at(span.clone())
                    .help(
                        suggest(name, params.names())
                            .unwrap_or_else(|| "name parameters of this model".into()),
                    ),
                );
            }
        }
        let coords: Vec<String> = bodies
            .iter()
            .flat_map(|b| b.coords.iter().map(move |c| format!("{}.{c}", b.name)))
            .collect();
        for (name, span) in &t.hold {
            if !coords.contains(name) {
                self.diags.push(
                    Diagnostic::new(format!(
                        "`[trim] hold` names `{name}`, which is not a coordinate"
                    ))
                    .at(span.clone())
                    .help(
                        suggest(name, coords.iter().map(|s| s.as_str()))
                            .unwrap_or_else(|| format!("coordinates: {}", coords.join(", "))),
                    ),
                );
            }
        }
        if t.solve.len() != t.hold.len() || t.solve.is_empty() {
            self.diags.push(
                Diagnostic::new(format!(
                    "`[trim]` solves {} parameter(s) for {} held coordinate(s)",
                    t.solve.len(),
                    t.hold.len()
                ))
                .at(t.span.clone())
                .help("each solved parameter needs one held coordinate (its condition): give as many in `hold` as in `solve`"),
            );
        }
    }

    fn body_ref(&mut self, name: &SString) -> Option<BodyRef> {
        let n = name.get_ref();
        if n == "ground" {
            return Some(BodyRef::Ground);
        }
        if let Some(i) = self.body_names.iter().position(|b| b == n) {
            return Some(BodyRef::Body(i));
        }
        let help = suggest(
            n,
            self.body_names.iter().map(|s| s.as_str()).chain(["ground"]),
        )
        .unwrap_or_else(|| format!("bodies are: {}, ground", self.body_names.join(", ")));
        self.diags.push(
            Diagnostic::new(format!("unknown body `{n}`"))
                .at(name.span())
                .label("not a body of this model")
                .help(help),
        );
        None
    }

    fn body(&mut self, r: &toml::Spanned<file::RawBody>) -> Option<Body> {
        let raw = r.get_ref();
        let span = r.span();
        let name = raw.name.get_ref().clone();
        let mut ok = true;
        if name == "ground" || !params::is_identifier(&name) {
            self.diags.push(
                Diagnostic::new(format!("`{name}` cannot name a body"))
                    .at(raw.name.span())
                    .help("body names are letters, digits and `_`, start with a letter (they prefix coordinate names such as `bar1.theta`), and are not `ground`"),
            );
            ok = false;
        } else if self.body_names.iter().filter(|n| **n == name).count() > 1 {
            self.diags.push(
                Diagnostic::new(format!("two bodies are named `{name}`"))
                    .at(raw.name.span())
                    .help("give each body its own name"),
            );
            ok = false;
        }
        let spatial = self.dim == 3;
        if let Some(k) = &raw.kind {
            let want = if spatial { "spatial" } else { "planar" };
            let other = k.get_ref().as_str();
            if other != want {
                // as the unknown types of a file with unknown fields are (`unknown_types`)
                let (message, help) = if other == "spatial" || other == "planar" {
                    (format!("body type `{other}` in a {want} model"), "a model's bodies are all planar or all spatial: a spatial body has `rotation = [[\"z\", \"theta\"]]` (and z); a planar body has none".to_string())
                } else {
                    (
                        format!("unknown body type `{other}`"),
                        suggest(other, BODY_TYPES).unwrap_or_else(|| {
                            "body types: planar, spatial (a body with `rotation` is spatial)"
                                .to_string()
                        }),
                    )
                };
                self.diags
                    .push(Diagnostic::new(message).at(k.span()).help(help));
                return None;
            }
        }
        let mass = self.field(&raw.mass);
        let inertia_span = raw.inertia.span();
        let (kind, coords, dims, inertia, cg) = if spatial {
            let Some(rot) = &raw.rotation else {
                self.diags.push(
                    Diagnostic::new(format!("body `{name}` has no `rotation` in a spatial model"))
                        .at(raw.name.span())
                        .help("a model's bodies are all planar or all spatial: give it `rotation = [[\"z\", \"angle_name\"]]` (a sequence of rotations about body axes) or `rotation = \"free\"`"),
                );
                return None;
            };
            let mut coords: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
            let mut dims = vec![Dim::LENGTH; 3];
            let kind = match self.rotation(rot, &name)? {
                Rotation::Free => {
                    coords.extend(QUATERNION.iter().map(|s| s.to_string()));
                    dims.extend([Dim::NONE; 4]);
                    BodyKind::Free
                }
                Rotation::Sequence(axes, angle_names) => {
                    coords.extend(angle_names);
                    dims.extend(std::iter::repeat_n(Dim::NONE, axes.len()));
                    BodyKind::Spatial { axes }
                }
            };
            let inertia = match raw.inertia.get_ref() {
                file::RawInertia::Vector(v) if v.len() == 3 || v.len() == 6 => {
                    let mut f: Vec<Option<Field>> = v.iter().map(|x| self.field(x)).collect();
                    while f.len() < 6 {
                        f.push(Some(Field::default_value(0.0, inertia_span.clone())));
                    }
                    f.into_iter().collect::<Option<Vec<Field>>>()
                }
                _ => {
                    self.diags.push(
                        Diagnostic::new(format!("the inertia of spatial body `{name}` is a tensor"))
                            .at(inertia_span.clone())
                            .help("give the principal values `inertia = [Ixx, Iyy, Izz]` or six components `[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]` (kg·m², about the CG, body frame)"),
                    );
                    None
                }
            };
            let cg = match &raw.cg {
                Some(v) => self.vector_n(v, "cg", 3),
                None => Some(vec![Field::default_value(0.0, raw.name.span()); 3]),
            };
            (kind, coords, dims, inertia, cg)
        } else {
            for (f, what) in [(raw.z.as_ref(), "z"), (None, "")] {
                if let Some(f) = f {
                    self.diags.push(
                        Diagnostic::new(format!("`{what}` of a planar body"))
                            .at(f.span())
                            .help("planar bodies have x, y and theta; give the model's bodies a `rotation` to make it spatial"),
                    );
                    return None;
                }
            }
            if let Some(c) = &raw.cg {
                self.diags.push(
                    Diagnostic::new("`cg` of a planar body")
                        .at(c.span())
                        .help("a planar body's x and y are its centre of gravity and its points are given from it"),
                );
                return None;
            }
            let inertia = match raw.inertia.get_ref() {
                file::RawInertia::Value(v) => self
                    .field(&toml::Spanned::new(inertia_span.clone(), v.clone()))
                    .map(|f| vec![f]),
                file::RawInertia::Vector(_) => {
                    self.diags.push(
                        Diagnostic::new(format!("the inertia of planar body `{name}` is one value"))
                            .at(inertia_span.clone())
                            .help("give the centroidal moment of inertia about the plane's normal, e.g. `inertia = \"m1*L1^2/12\"`"),
                    );
                    None
                }
            };
            let coords = ["x", "y", "theta"].iter().map(|s| s.to_string()).collect();
            (
                BodyKind::Planar,
                coords,
                vec![Dim::LENGTH, Dim::LENGTH, Dim::NONE],
                inertia,
                Some(Vec::new()),
            )
        };
        let free = kind == BodyKind::Free;
        let mut initial = Vec::new();
        for c in coords.iter().take(if free { 3 } else { coords.len() }) {
            let given = match c.as_str() {
                "x" => raw.x.as_ref(),
                "y" => raw.y.as_ref(),
                "z" => raw.z.as_ref(),
                "theta" if !spatial => raw.theta.as_ref(),
                other => raw.angles.get(other),
            };
            match given {
                Some(v) => initial.push(self.field(v)),
                None => initial.push(Some(Field::default_value(0.0, raw.name.span()))),
            }
        }
        if free {
            match &raw.orientation {
                Some(o) if o.get_ref().len() == 4 => {
                    initial.extend(o.get_ref().iter().map(|x| self.field(x)));
                }
                Some(o) => {
                    self.diags.push(
                        Diagnostic::new(format!(
                            "the orientation of `{name}` needs 4 components (a quaternion), found {}",
                            o.get_ref().len()
                        ))
                        .at(o.span())
                        .help("write `orientation = [qw, qx, qy, qz]` (normalized when loaded; the identity is [1, 0, 0, 0])"),
                    );
                    ok = false;
                }
                None => {
                    for x in [1.0, 0.0, 0.0, 0.0] {
                        initial.push(Some(Field::default_value(x, raw.name.span())));
                    }
                }
            }
            if let Some((a, v)) = raw.angles.iter().next() {
                self.diags.push(
                    Diagnostic::new(format!("`angles` of free body `{name}` (`{a}`)"))
                        .at(v.span())
                        .help("a free body's orientation is a unit quaternion: give `orientation = [qw, qx, qy, qz]`"),
                );
                ok = false;
            }
        } else if let Some(o) = &raw.orientation {
            self.diags.push(
                Diagnostic::new(format!("`orientation` of body `{name}`"))
                    .at(o.span())
                    .help(if spatial {
                        "only a free body (`rotation = \"free\"`) has a quaternion orientation; give the initial angles in `angles = { name = value }`"
                    } else {
                        "a planar body's orientation is `theta`"
                    }),
            );
            ok = false;
        }
        if spatial {
            if let Some(t) = &raw.theta {
                self.diags.push(
                    Diagnostic::new(format!("`theta` of spatial body `{name}`"))
                        .at(t.span())
                        .help(if free {
                            "a free body's orientation is a unit quaternion: give `orientation = [qw, qx, qy, qz]`"
                        } else {
                            "a spatial body's angles are named in `rotation`; give their initial values in `angles = { name = value }`"
                        }),
                );
                ok = false;
            }
            for (a, v) in raw.angles.iter().filter(|_| !free) {
                if !coords[3..].contains(a) {
                    self.diags.push(
                        Diagnostic::new(format!("`{a}` is not an angle of body `{name}`"))
                            .at(v.span())
                            .help(format!("its angles: {}", coords[3..].join(", "))),
                    );
                    ok = false;
                }
            }
        } else if !raw.angles.is_empty() {
            self.diags.push(
                Diagnostic::new(format!("`angles` of planar body `{name}`"))
                    .at(raw.name.span())
                    .help("a planar body's angle is `theta`"),
            );
            ok = false;
        }
        let kind_name = match kind {
            BodyKind::Planar => "planar",
            BodyKind::Spatial { .. } => "spatial",
            BodyKind::Free => "free",
        };
        // what `fix` can name: the coordinates, or a free body's position and its
        // orientation as a whole
        let fixable: Vec<&str> = if free {
            vec!["x", "y", "z", "orientation"]
        } else {
            coords.iter().map(|c| c.as_str()).collect()
        };
        let mut fixed = vec![false; coords.len()];
        for f in &raw.fix {
            match fixable.iter().position(|c| c == f.get_ref()) {
                Some(3) if free => fixed[3..].fill(true),
                Some(i) => fixed[i] = true,
                None => {
                    let message = if free {
                        format!("free body `{name}` cannot fix `{}`", f.get_ref())
                    } else {
                        format!(
                            "`{}` is not a coordinate of {kind_name} body `{name}`",
                            f.get_ref()
                        )
                    };
                    self.diags
                        .push(Diagnostic::new(message).at(f.span()).help(if free {
                        "a free body fixes `x`, `y`, `z` or `orientation` (its whole quaternion)"
                            .to_string()
                    } else {
                        format!("coordinates: {}", coords.join(", "))
                    }));
                    ok = false;
                }
            }
        }
        let (vels, vdims): (Vec<String>, Vec<Dim>) = if free {
            let rate = Dim::NONE.div(Dim::TIME);
            (
                FREE_VELOCITIES.iter().map(|s| s.to_string()).collect(),
                [Dim::LENGTH.div(Dim::TIME); 3]
                    .into_iter()
                    .chain([rate; 3])
                    .collect(),
            )
        } else {
            (
                coords.clone(),
                dims.iter().map(|d| d.div(Dim::TIME)).collect(),
            )
        };
        let mut velocity: Vec<Option<Field>> = vec![None; vels.len()];
        for (c, v) in &raw.velocity {
            match vels.iter().position(|k| k == c) {
                Some(i) => velocity[i] = self.field(v),
                None => {
                    let (what, list) = if free {
                        ("velocity", "velocities")
                    } else {
                        ("coordinate", "coordinates")
                    };
                    self.diags.push(
                        Diagnostic::new(format!(
                            "`{c}` is not a {what} of {kind_name} body `{name}`"
                        ))
                        .at(v.span())
                        .help(format!("{list}: {}", vels.join(", "))),
                    );
                    ok = false;
                }
            }
        }
        let mut points = Vec::new();
        for (pname, v) in &raw.points {
            if !params::is_identifier(pname) || coords.contains(pname) || vels.contains(pname) {
                self.diags.push(
                    Diagnostic::new(format!("`{pname}` cannot name a point of body `{name}`"))
                        .at(v.span())
                        .help("point names are identifiers, distinct from the body's coordinates"),
                );
                ok = false;
                continue;
            }
            if let Some(p) = self.vector(v, pname) {
                points.push((pname.clone(), p));
            } else {
                ok = false;
            }
        }
        let initial: Option<Vec<Field>> = initial.into_iter().collect();
        if !ok {
            return None;
        }
        Some(Body {
            name,
            name_span: raw.name.span(),
            kind,
            mass: mass?,
            inertia: inertia?,
            inertia_span,
            cg: cg?,
            coords,
            dims,
            vels,
            vdims,
            initial: initial?,
            fixed,
            velocity,
            points,
        })
        .filter(|_| span.end >= span.start)
    }

    /// A spatial body's `rotation = [["z", "phi"], ...]` (the axes and angle names) or
    /// `rotation = "free"`.
    fn rotation(&mut self, rot: &toml::Spanned<toml::Value>, body: &str) -> Option<Rotation> {
        let bad = |msg: String| {
            Diagnostic::new(msg)
                .at(rot.span())
                .help("write `rotation = [[\"z\", \"phi\"]]`, or a sequence of two or three such pairs (`[[\"z\", \"alpha\"], [\"x\", \"beta\"]]`: R = Rz(alpha) Rx(beta)); axes are x, y or z of the body; or `rotation = \"free\"` (a unit quaternion)")
        };
        if let Some(word) = rot.get_ref().as_str() {
            if word == "free" {
                return Some(Rotation::Free);
            }
            self.diags.push(bad(format!(
                "unknown rotation `{word}` of `{body}` (the named one is \"free\")"
            )));
            return None;
        }
        let Some(list) = rot.get_ref().as_array() else {
            self.diags.push(bad(format!(
                "the rotation of `{body}` is not a list of [axis, angle] pairs"
            )));
            return None;
        };
        if list.is_empty() || list.len() > 3 {
            self.diags.push(bad(format!(
                "the rotation of `{body}` has {} rotations; it takes 1 to 3",
                list.len()
            )));
            return None;
        }
        let mut axes = Vec::new();
        let mut names: Vec<String> = Vec::new();
        for item in list {
            let pair = item.as_array().filter(|p| p.len() == 2);
            let (Some(a), Some(n)) = (
                pair.and_then(|p| p[0].as_str()),
                pair.and_then(|p| p[1].as_str()),
            ) else {
                self.diags.push(bad(format!(
                    "a rotation of `{body}` is not an [axis, angle] pair of strings"
                )));
                return None;
            };
            let axis = match a {
                "x" | "X" => 0,
                "y" | "Y" => 1,
                "z" | "Z" => 2,
                other => {
                    self.diags.push(bad(format!(
                        "unknown rotation axis `{other}` of `{body}` (axes: x, y, z)"
                    )));
                    return None;
                }
            };
            if !params::is_identifier(n) || ["x", "y", "z"].contains(&n) || QUATERNION.contains(&n)
            {
                self.diags
                    .push(bad(format!("`{n}` cannot name an angle of `{body}`")));
                return None;
            }
            if names.iter().any(|m| m == n) {
                self.diags
                    .push(bad(format!("the angle `{n}` of `{body}` is named twice")));
                return None;
            }
            if let Some(&prev) = axes.last()
                && prev == axis
            {
                self.diags.push(bad(format!(
                    "two successive rotations of `{body}` about the same axis `{a}` are one rotation"
                )));
                return None;
            }
            axes.push(axis);
            names.push(n.to_string());
        }
        Some(Rotation::Sequence(axes, names))
    }

    /// A `[[joints]]` table, read by its type's table of fields ([`kinds::JOINTS`]).
    fn joint(&mut self, i: usize, r: &toml::Spanned<file::RawJoint>) -> Option<Joint> {
        let span = r.span();
        let family = if self.dim == 3 {
            &kinds::JOINTS3
        } else {
            &kinds::JOINTS
        };
        let mut e = self.element(family, i, r.get_ref(), span.clone())?;
        let [p1, p2] = e.values.ends()?;
        Some(Joint {
            name: e.name,
            span,
            kind: e.kind,
            p1,
            p2,
        })
    }

    /// A `[[forces]]` table, read by its type's table of fields ([`kinds::FORCES`]).
    fn force(&mut self, i: usize, r: &toml::Spanned<file::RawForce>) -> Option<ForceDef> {
        let span = r.span();
        let family = if self.dim == 3 {
            &kinds::FORCES3
        } else {
            &kinds::FORCES
        };
        let e = self.element(family, i, r.get_ref(), span.clone())?;
        Some(ForceDef {
            name: e.name,
            span,
            kind: e.kind,
        })
    }
}

/// The most an input file (model, environment) may hold: 16 MiB. A model is a few kB;
/// the limit keeps `detune check /dev/zero` or a wrong file from eating the memory.
pub const MAX_INPUT_BYTES: u64 = 16 * 1024 * 1024;

/// The most a data file detune reads back (a sweep checkpoint, the CSV of
/// `--refine-from`) may hold: 256 MiB, some hundred thousand steady states.
pub const MAX_DATA_BYTES: u64 = 256 * 1024 * 1024;

/// Read an input file (`what`: "model file", "environment file") as UTF-8 text: a
/// regular file or a pipe (`-` is not special, but `/dev/stdin` and `<(…)` work), at most
/// [`MAX_INPUT_BYTES`]. A directory, a character or block device (`/dev/zero`) or a
/// socket is refused before reading, a longer file when the limit is passed; each error
/// names the file and says what to give instead.
pub fn read_input(path: &str, what: &str) -> Result<String> {
    let bytes = read_bounded(
        path,
        &Bounded {
            what,
            limit: MAX_INPUT_BYTES,
            pipes: true,
            give: &format!(
                "give the path of a {what} (TOML text); a pipe such as <(...) works too"
            ),
            shorter: &format!("give the right file: a {what} is TOML text of a few kB"),
        },
    )?;
    utf8(path, what, bytes)
}

/// `bytes` read from `path` as UTF-8 text, or an error naming the first byte that is not.
pub fn utf8(path: &str, what: &str, bytes: Vec<u8>) -> Result<String> {
    String::from_utf8(bytes).map_err(|e| {
        Error::io(
            path,
            format!(
                "not UTF-8 text (byte {}): is this a {what}?",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// What [`read_bounded`] accepts and how it advises.
pub struct Bounded<'a> {
    /// What the file should be ("model file", "sweep checkpoint").
    pub what: &'a str,
    /// The most it may hold (bytes).
    pub limit: u64,
    /// Whether a pipe (FIFO, `<(…)`) is read; if not, only a regular file is.
    pub pipes: bool,
    /// Help when the file is of the wrong kind (a directory, a device, ...).
    pub give: &'a str,
    /// Help when it is longer than `limit`.
    pub shorter: &'a str,
}

/// The bytes of an input file, at most `b.limit` of them (reading stops there: an
/// endless pipe cannot exhaust the memory); a directory, a device or a socket is refused
/// before it is opened (opening or reading one may block or never end), a pipe too unless
/// `b.pipes`.
pub fn read_bounded(path: &str, b: &Bounded) -> Result<Vec<u8>> {
    use std::io::Read;
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    let kind = {
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileTypeExt;
            let t = meta.file_type();
            if t.is_char_device() {
                Some("a character device")
            } else if t.is_block_device() {
                Some("a block device")
            } else if t.is_socket() {
                Some("a socket")
            } else if t.is_fifo() && !b.pipes {
                Some("a pipe (FIFO)")
            } else {
                None
            }
        }
        #[cfg(not(unix))]
        None::<&str>
    };
    let kind = kind.or(meta.is_dir().then_some("a directory"));
    let what = b.what;
    if let Some(kind) = kind {
        return Err(Error::request(
            format!("{path}: is {kind}, not a {what}"),
            b.give,
        ));
    }
    let too_long = || {
        let mib = b.limit / (1024 * 1024);
        Error::request(
            format!("{path}: longer than the {mib} MiB a {what} may have (reading stopped there)"),
            b.shorter,
        )
    };
    if meta.is_file() && meta.len() > b.limit {
        return Err(too_long());
    }
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut bytes = Vec::new();
    file.take(b.limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > b.limit {
        return Err(too_long());
    }
    Ok(bytes)
}
