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
    let mut scored: Vec<(f64, &str)> = candidates
        .into_iter()
        .map(|c| {
            let (a, b) = (name.to_lowercase(), c.to_lowercase());
            let score = if a == b {
                1.0
            } else if strsim::levenshtein(&a, &b) == 1 {
                // one typo, also in short names (`Fz` for `Fs`)
                0.95
            } else {
                strsim::jaro_winkler(&a, &b)
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

/// A planar rigid body: coordinates `x`, `y` (centre of gravity, m), `theta` (rad).
#[derive(Debug, Clone)]
pub struct Body {
    pub name: String,
    pub name_span: Range<usize>,
    pub kind: BodyKind,
    /// kg.
    pub mass: Field,
    /// Centroidal moment of inertia, kg·m².
    pub inertia: Field,
    /// Initial pose, one per coordinate (in the body kind's coordinate order).
    pub initial: Vec<Field>,
    /// Which coordinates are held at their initial value during assembly.
    pub fixed: Vec<bool>,
    /// Given initial velocities (m/s or rad/s), per coordinate.
    pub velocity: Vec<Option<Field>>,
}

/// The kinds of body; each names its own coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BodyKind {
    Planar,
}

impl BodyKind {
    /// Coordinate names, in order.
    pub fn coordinates(self) -> &'static [&'static str] {
        match self {
            BodyKind::Planar => &["x", "y", "theta"],
        }
    }
    /// Dimension of each coordinate.
    pub fn coordinate_dims(self) -> &'static [Dim] {
        match self {
            BodyKind::Planar => &[Dim::LENGTH, Dim::LENGTH, Dim::NONE],
        }
    }
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
    pub point: [Field; 2],
}

#[derive(Debug, Clone)]
pub enum JointKind {
    /// Point 1 on body 1 coincides with point 2 on body 2 (2 equations).
    Revolute,
    /// Point 1 on body 1 stays on the line through point 2 along `axis`, fixed in body 2
    /// (1 equation).
    PinInSlot { axis: [Field; 2] },
    /// Pin in slot plus a fixed relative angle θ1 − θ2 = angle (2 equations).
    Prismatic { axis: [Field; 2], angle: Field },
    /// Revolute plus a fixed relative angle θ1 − θ2 = angle (3 equations).
    Fixed { angle: Field },
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
    Gravity { acceleration: [Field; 2] },
    /// Linear spring and dashpot between two points, along their line, tension positive:
    /// T = k (d − L0) + c ḋ.
    SpringDamper {
        p1: PointRef,
        p2: PointRef,
        stiffness: Field,
        damping: Field,
        free_length: Field,
    },
    /// A force (N, world frame) at a body point; components may depend on `t`,
    /// parameters and coordinates.
    PointForce { at: PointRef, force: [Field; 2] },
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
    pub theta: Option<Field>,
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
    /// The `--set` overrides applied, as given (`NAME=VALUE`).
    pub overrides: Vec<(String, String)>,
    /// The parameter that is the forcing's angular frequency (`[model] forcing_frequency`).
    pub forcing_frequency: Option<String>,
}

impl Model {
    /// Read and check a model file.
    pub fn load(path: &str) -> Result<Model> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Model::from_str(path, &text)
    }

    /// Parse and check model text; `path` is used in messages.
    pub fn from_str(path: &str, text: &str) -> Result<Model> {
        let source = SourceFile {
            path: path.to_string(),
            text: Arc::from(text),
        };
        let raw: file::RawModel = match toml::from_str(text) {
            Ok(r) => r,
            Err(e) => {
                let mut d = Diagnostic::new(toml_message(&e)).help(
                    "the model file is TOML: see docs/model-format.md for the sections and fields",
                );
                if let Some(span) = e.span() {
                    d = d.at(span).label("here");
                }
                return Err(Error::Model {
                    source,
                    diagnostics: vec![d],
                });
            }
        };
        let mut diags = Vec::new();
        let parameters = Parameters::from_raw(&raw.parameters, text, &mut diags);
        let mut b = Builder {
            text,
            diags: &mut diags,
            body_names: raw
                .bodies
                .iter()
                .map(|b| b.get_ref().name.get_ref().clone())
                .collect(),
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
        let ground = match &raw.ground.motion {
            None => GroundDef::default(),
            Some(m) => {
                let mm = m.get_ref();
                if mm.x.is_none() && mm.y.is_none() && mm.theta.is_none() {
                    b.diags.push(
                        Diagnostic::new("`[ground] motion` gives no component")
                            .at(m.span())
                            .help("give x, y and/or theta as expressions of t, e.g. motion = { x = \"D0*sin(omega*t)\" }"),
                    );
                }
                GroundDef {
                    x: mm.x.as_ref().and_then(|v| b.field(v)),
                    y: mm.y.as_ref().and_then(|v| b.field(v)),
                    theta: mm.theta.as_ref().and_then(|v| b.field(v)),
                }
            }
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
            overrides: Vec::new(),
            forcing_frequency: raw
                .model
                .forcing_frequency
                .as_ref()
                .map(|f| f.get_ref().clone()),
        };
        if let Some(f) = &raw.model.forcing_frequency
            && model.parameters.index(f.get_ref()).is_none()
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
            .flat_map(|b| {
                b.kind
                    .coordinates()
                    .iter()
                    .map(move |c| format!("{}.{}", b.name, c))
            })
            .collect()
    }
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

    fn vector2(&mut self, v: &SVector, what: &str) -> Option<[Field; 2]> {
        let items = v.get_ref();
        if items.len() != 2 {
            self.diags.push(
                Diagnostic::new(format!(
                    "`{what}` needs 2 components (planar), found {}",
                    items.len()
                ))
                .at(v.span())
                .help(format!("write `{what} = [x, y]`")),
            );
            return None;
        }
        let a = self.field(&items[0]);
        let b = self.field(&items[1]);
        Some([a?, b?])
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
        let kind = match raw.kind.as_ref().map(|k| k.get_ref().as_str()) {
            None | Some("planar") => BodyKind::Planar,
            Some(other) => {
                let k = raw.kind.as_ref().unwrap();
                self.diags.push(
                    Diagnostic::new(format!("unknown body type `{other}`"))
                        .at(k.span())
                        .help("body types: planar"),
                );
                return None;
            }
        };
        let mass = self.field(&raw.mass);
        let inertia = self.field(&raw.inertia);
        let coords = kind.coordinates();
        let given = [&raw.x, &raw.y, &raw.theta];
        let mut initial = Vec::new();
        for (c, g) in coords.iter().zip(given) {
            match g {
                Some(v) => initial.push(self.field(v)),
                None => {
                    let _ = c;
                    initial.push(Some(Field::default_value(0.0, raw.name.span())))
                }
            }
        }
        let mut fixed = vec![false; coords.len()];
        for f in &raw.fix {
            match coords.iter().position(|c| c == f.get_ref()) {
                Some(i) => fixed[i] = true,
                None => {
                    self.diags.push(
                        Diagnostic::new(format!(
                            "`{}` is not a coordinate of a {:?} body",
                            f.get_ref(),
                            kind
                        ))
                        .at(f.span())
                        .help(format!("coordinates: {}", coords.join(", "))),
                    );
                    ok = false;
                }
            }
        }
        let mut velocity: Vec<Option<Field>> = vec![None; coords.len()];
        for (c, v) in &raw.velocity {
            match coords.iter().position(|k| k == c) {
                Some(i) => velocity[i] = self.field(v),
                None => {
                    self.diags.push(
                        Diagnostic::new(format!("`{c}` is not a coordinate of a {kind:?} body"))
                            .at(v.span())
                            .help(format!("coordinates: {}", coords.join(", "))),
                    );
                    ok = false;
                }
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
            initial: initial?,
            fixed,
            velocity,
        })
        .filter(|_| span.end >= span.start)
    }

    /// A `[[joints]]` table, read by its type's table of fields ([`kinds::JOINTS`]).
    fn joint(&mut self, i: usize, r: &toml::Spanned<file::RawJoint>) -> Option<Joint> {
        let span = r.span();
        let mut e = self.element(&kinds::JOINTS, i, r.get_ref(), span.clone())?;
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
        let e = self.element(&kinds::FORCES, i, r.get_ref(), span.clone())?;
        Some(ForceDef {
            name: e.name,
            span,
            kind: e.kind,
        })
    }
}
