//! The compiled equations of a model: constraint function Φ(q, t), its Jacobian A and
//! bias b by automatic differentiation, mass matrix M and impressed forces f(q, v, t).
//!
//! Everything here is generic over the coordinates: a body contributes its coordinates
//! and its kinematics (point positions, velocities, how a point force maps to generalized
//! forces); the constraint function is written once over any [`Scalar`], so
//!
//! * `A = ∂Φ/∂q` comes from one `Dual64` pass per coordinate (column j: seed `q_j + ε`),
//! * `b = −d²/ds² Φ(q + s·v, t + s)|s=0` from one `Dual2_64` pass along the motion.
//!
//! Planar bodies have `q = (x, y, θ)` of the centre of gravity and `v = q̇`.

use crate::diag::{Diagnostic, Error, Result};
use crate::model::expr::{Compiled, ExprError, Slot};
use crate::model::units::Dim;
use crate::model::{
    BodyKind, BodyRef, Field, ForceKind, JointKind, Model, PointRef, expr_diag, suggest,
};
use crate::scalar::Scalar;
use nalgebra::{DMatrix, DVector};
use num_dual::{Dual2_64, Dual64};

/// A compiled body.
#[derive(Debug, Clone)]
pub struct SysBody {
    pub name: String,
    pub kind: BodyKind,
    /// Index of the body's first coordinate in q (and v).
    pub offset: usize,
    /// kg.
    pub mass: f64,
    /// Centroidal moment of inertia, kg·m².
    pub inertia: f64,
}

/// A point fixed in a body (or ground): coordinate offset of the body and body-frame
/// position, m.
#[derive(Debug, Clone, Copy)]
pub struct SysPoint {
    pub body: Option<usize>,
    pub p: [f64; 2],
}

#[derive(Debug, Clone)]
enum SysConstraint {
    /// P1 − P2 = 0 (2 rows).
    Revolute { a: SysPoint, b: SysPoint },
    /// n₂ · (P1 − P2) = 0, n₂ ⟂ axis, both in body 2 (1 row).
    Slot {
        a: SysPoint,
        b: SysPoint,
        normal: [f64; 2],
    },
    /// θ1 − θ2 − angle = 0 (1 row).
    Angle {
        a: Option<usize>,
        b: Option<usize>,
        angle: f64,
    },
    /// A user expression (1 row).
    Custom(Compiled),
}

#[derive(Debug, Clone)]
enum SysForce {
    /// T = k (d − L0) + c ḋ along P1→P2, tension positive.
    Spring {
        a: SysPoint,
        b: SysPoint,
        k: f64,
        c: f64,
        l0: f64,
    },
    /// World-frame force at a point.
    Point { at: SysPoint, f: [Compiled; 2] },
}

/// The initial state as the model gives it (before assembly).
#[derive(Debug, Clone)]
pub struct InitialGuess {
    /// Coordinates (fixed ones exact, the rest guesses).
    pub q: Vec<f64>,
    /// Held during assembly.
    pub fixed: Vec<bool>,
    /// Velocities: given ones (held) or 0.
    pub v: Vec<f64>,
    pub v_given: Vec<bool>,
}

/// Compiled equations of motion of one model with one set of parameter values.
#[derive(Debug, Clone)]
pub struct System {
    /// `<body>.<coordinate>` for each entry of q.
    pub coordinates: Vec<String>,
    /// One name per constraint row (`joint.x`, `constraint2`, ...).
    pub constraint_names: Vec<String>,
    pub bodies: Vec<SysBody>,
    constraints: Vec<SysConstraint>,
    forces: Vec<SysForce>,
    /// Gravitational acceleration, m/s².
    pub gravity: [f64; 2],
    /// Mass matrix M (n × n), constant for planar bodies.
    pub mass_matrix: DMatrix<f64>,
    /// M⁻¹ (n × n).
    pub mass_inv: DMatrix<f64>,
    /// M^-½ (n × n).
    pub mass_inv_sqrt: DMatrix<f64>,
    pub initial: InitialGuess,
    /// Whether any constraint depends on time explicitly.
    pub rheonomic: bool,
    /// Angular frequency of the harmonic forcing, rad/s (`[model] forcing_frequency`).
    pub forcing_frequency: Option<f64>,
}

/// Scratch buffers for one thread of evaluation.
#[derive(Debug, Clone)]
pub struct Workspace {
    qd: Vec<Dual64>,
    phid: Vec<Dual64>,
    q2: Vec<Dual2_64>,
    phi2: Vec<Dual2_64>,
}

impl Workspace {
    pub fn new(sys: &System) -> Self {
        let n = sys.n();
        let m = sys.m();
        Workspace {
            qd: vec![Dual64::from(0.0); n],
            phid: vec![Dual64::from(0.0); m],
            q2: vec![Dual2_64::from(0.0); n],
            phi2: vec![Dual2_64::from(0.0); m],
        }
    }
}

/// World position of a body point for planar coordinates: r + R(θ)·p.
#[inline]
fn position<D: Scalar>(q: &[D], pt: &SysPoint) -> [D; 2] {
    match pt.body {
        None => [D::from(pt.p[0]), D::from(pt.p[1])],
        Some(o) => {
            let (s, c) = q[o + 2].sin_cos();
            [
                q[o] + c * pt.p[0] - s * pt.p[1],
                q[o + 1] + s * pt.p[0] + c * pt.p[1],
            ]
        }
    }
}

/// World offset R(θ)·p of a body point from the centre of gravity.
#[inline]
fn arm<D: Scalar>(q: &[D], pt: &SysPoint) -> [D; 2] {
    match pt.body {
        None => [D::from(0.0), D::from(0.0)],
        Some(o) => {
            let (s, c) = q[o + 2].sin_cos();
            [c * pt.p[0] - s * pt.p[1], s * pt.p[0] + c * pt.p[1]]
        }
    }
}

/// World velocity of a body point: ṙ + ω × (R p).
#[inline]
fn velocity<D: Scalar>(q: &[D], v: &[D], pt: &SysPoint) -> [D; 2] {
    match pt.body {
        None => [D::from(0.0), D::from(0.0)],
        Some(o) => {
            let r = arm(q, pt);
            [v[o] - v[o + 2] * r[1], v[o + 1] + v[o + 2] * r[0]]
        }
    }
}

/// Add a world force F at a body point to the generalized forces: (Fx, Fy, (R p) × F).
#[inline]
fn apply<D: Scalar>(q: &[D], pt: &SysPoint, f: [D; 2], out: &mut [D]) {
    if let Some(o) = pt.body {
        let r = arm(q, pt);
        out[o] += f[0];
        out[o + 1] += f[1];
        out[o + 2] += r[0] * f[1] - r[1] * f[0];
    }
}

impl System {
    /// Number of coordinates (= velocities for planar bodies).
    pub fn n(&self) -> usize {
        self.coordinates.len()
    }
    /// Number of constraint rows.
    pub fn m(&self) -> usize {
        self.constraint_names.len()
    }

    /// Index of a coordinate by name.
    pub fn coordinate_index(&self, name: &str) -> Option<usize> {
        self.coordinates.iter().position(|c| c == name)
    }

    /// Check a model (names, dimensions, signs) without keeping the result.
    pub fn check(model: &Model) -> Result<()> {
        System::new(model).map(|_| ())
    }

    /// Compile a model with its current parameter values.
    pub fn new(model: &Model) -> Result<System> {
        let mut c = Compiler {
            model,
            coordinates: model.coordinate_names(),
            diags: Vec::new(),
        };
        let sys = c.compile();
        match sys {
            Some(s) if c.diags.is_empty() => Ok(s),
            _ => Err(model.error(c.diags)),
        }
    }

    /// Constraint function Φ(q, t) (m).
    pub fn phi<D: Scalar>(&self, q: &[D], t: D, out: &mut [D]) {
        let mut r = 0;
        for c in &self.constraints {
            match c {
                SysConstraint::Revolute { a, b } => {
                    let pa = position(q, a);
                    let pb = position(q, b);
                    out[r] = pa[0] - pb[0];
                    out[r + 1] = pa[1] - pb[1];
                    r += 2;
                }
                SysConstraint::Slot { a, b, normal } => {
                    let pa = position(q, a);
                    let pb = position(q, b);
                    // normal turns with body 2
                    let (nx, ny) = match b.body {
                        None => (D::from(normal[0]), D::from(normal[1])),
                        Some(o) => {
                            let (s, c) = q[o + 2].sin_cos();
                            (c * normal[0] - s * normal[1], s * normal[0] + c * normal[1])
                        }
                    };
                    out[r] = (pa[0] - pb[0]) * nx + (pa[1] - pb[1]) * ny;
                    r += 1;
                }
                SysConstraint::Angle { a, b, angle } => {
                    let ta = a.map_or(D::from(0.0), |o| q[o + 2]);
                    let tb = b.map_or(D::from(0.0), |o| q[o + 2]);
                    out[r] = ta - tb - *angle;
                    r += 1;
                }
                SysConstraint::Custom(e) => {
                    out[r] = e.eval(q, t);
                    r += 1;
                }
            }
        }
    }

    /// Φ(q, t) in f64.
    pub fn residual(&self, q: &[f64], t: f64) -> DVector<f64> {
        let mut out = DVector::zeros(self.m());
        self.phi(q, t, out.as_mut_slice());
        out
    }

    /// Constraint Jacobian A = ∂Φ/∂q (m × n), one dual pass per column.
    pub fn jacobian(&self, ws: &mut Workspace, q: &[f64], t: f64, a: &mut DMatrix<f64>) {
        for (d, &x) in ws.qd.iter_mut().zip(q) {
            *d = Dual64::from(x);
        }
        let td = Dual64::from(t);
        for j in 0..self.n() {
            ws.qd[j].eps = 1.0;
            self.phi(&ws.qd, td, &mut ws.phid);
            ws.qd[j].eps = 0.0;
            for i in 0..self.m() {
                a[(i, j)] = ws.phid[i].eps;
            }
        }
    }

    /// ∂Φ/∂t (m): the explicit time rate of the constraints.
    pub fn phi_t(&self, ws: &mut Workspace, q: &[f64], t: f64, out: &mut DVector<f64>) {
        if !self.rheonomic {
            out.fill(0.0);
            return;
        }
        for (d, &x) in ws.qd.iter_mut().zip(q) {
            *d = Dual64::from(x);
        }
        self.phi(&ws.qd, Dual64::new(t, 1.0), &mut ws.phid);
        for i in 0..self.m() {
            out[i] = ws.phid[i].eps;
        }
    }

    /// Bias b = −d²/ds² Φ(q + s·v, t + s)|s=0 (m), so that A v̇ = b.
    pub fn bias(&self, ws: &mut Workspace, q: &[f64], v: &[f64], t: f64, b: &mut DVector<f64>) {
        for ((d, &x), &dx) in ws.q2.iter_mut().zip(q).zip(v) {
            *d = Dual2_64::new(x, dx, 0.0);
        }
        let td = Dual2_64::new(t, 1.0, 0.0);
        self.phi(&ws.q2, td, &mut ws.phi2);
        for i in 0..self.m() {
            b[i] = -ws.phi2[i].v2;
        }
    }

    /// Impressed generalized forces f(q, v, t) (n): gravity, springs, dampers, point
    /// forces. Generic, so that stiffness ∂f/∂q and damping ∂f/∂v come from dual numbers.
    pub fn forces<D: Scalar>(&self, q: &[D], v: &[D], t: D, f: &mut [D]) {
        f.fill(D::from(0.0));
        for b in &self.bodies {
            f[b.offset] += D::from(b.mass * self.gravity[0]);
            f[b.offset + 1] += D::from(b.mass * self.gravity[1]);
        }
        for force in &self.forces {
            match force {
                SysForce::Spring { a, b, k, c, l0 } => {
                    let pa = position(q, a);
                    let pb = position(q, b);
                    let d = [pb[0] - pa[0], pb[1] - pa[1]];
                    let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
                    if len.re() == 0.0 {
                        continue;
                    }
                    let u = [d[0] / len, d[1] / len];
                    let va = velocity(q, v, a);
                    let vb = velocity(q, v, b);
                    let rate = u[0] * (vb[0] - va[0]) + u[1] * (vb[1] - va[1]);
                    let tension = (len - *l0) * *k + rate * *c;
                    apply(q, a, [tension * u[0], tension * u[1]], f);
                    apply(q, b, [-(tension * u[0]), -(tension * u[1])], f);
                }
                SysForce::Point { at, f: comp } => {
                    let fx = comp[0].eval(q, t);
                    let fy = comp[1].eval(q, t);
                    apply(q, at, [fx, fy], f);
                }
            }
        }
    }

    /// Whether any impressed force depends on time explicitly.
    pub fn forces_depend_on_time(&self) -> bool {
        self.forces.iter().any(|f| match f {
            SysForce::Point { f, .. } => f.iter().any(|c| c.depends_on_time()),
            SysForce::Spring { .. } => false,
        })
    }

    /// Potential energy of gravity and springs, J (for energy checks).
    pub fn potential_energy(&self, q: &[f64]) -> f64 {
        let mut e = 0.0;
        for b in &self.bodies {
            e -= b.mass * (self.gravity[0] * q[b.offset] + self.gravity[1] * q[b.offset + 1]);
        }
        for force in &self.forces {
            if let SysForce::Spring { a, b, k, l0, .. } = force {
                let pa = position(q, a);
                let pb = position(q, b);
                let len = (pb[0] - pa[0]).hypot(pb[1] - pa[1]);
                e += 0.5 * k * (len - l0).powi(2);
            }
        }
        e
    }

    /// Kinetic energy ½ vᵀ M v, J.
    pub fn kinetic_energy(&self, v: &[f64]) -> f64 {
        let v = DVector::from_column_slice(v);
        0.5 * (v.transpose() * &self.mass_matrix * &v)[(0, 0)]
    }
}

/// Turns a [`Model`] into a [`System`], collecting diagnostics.
struct Compiler<'a> {
    model: &'a Model,
    coordinates: Vec<String>,
    diags: Vec<Diagnostic>,
}

impl Compiler<'_> {
    fn lookup(
        &self,
        name: &str,
        span: &crate::model::expr::Span,
        coords: bool,
        time: bool,
    ) -> std::result::Result<Slot, ExprError> {
        let params = &self.model.parameters;
        if let Some(v) = params.value(name) {
            if !v.is_finite() {
                // 0/0, 1/0, sqrt(-1)...: refused where the model uses it (an unused
                // parameter such as T = 2*pi/omega at omega = 0 may stay undefined).
                let i = params.index(name).expect("has a value");
                let def = match &params.overridden[i] {
                    Some(text) => format!("--set {name}={text}"),
                    None => {
                        let sp = &params.list[i].field.span;
                        let text = self.model.source.text.get(sp.clone()).unwrap_or("");
                        format!("{name} = {text}")
                    }
                };
                return Err(ExprError {
                    span: span.clone(),
                    message: format!("`{name}` evaluates to {v} ({def})"),
                    help: Some(
                        "a parameter used by the model must be a finite number: check for a division by zero, the root or logarithm of a negative number, or asin/acos beyond ±1".into(),
                    ),
                });
            }
            return Ok(Slot::Const(v));
        }
        if let Some(i) = self.coordinates.iter().position(|c| c == name) {
            if coords {
                return Ok(Slot::Coord(i));
            }
            return Err(ExprError {
                span: span.clone(),
                message: format!("`{name}` is a coordinate; this value must be constant"),
                help: Some("use parameters only here".into()),
            });
        }
        if name == "t" {
            if time {
                return Ok(Slot::Time);
            }
            return Err(ExprError {
                span: span.clone(),
                message: "this value cannot depend on time `t`".into(),
                help: Some("use parameters only here".into()),
            });
        }
        let mut cands: Vec<&str> = params.names().collect();
        if coords {
            cands.extend(self.coordinates.iter().map(|s| s.as_str()));
        }
        let body = name.split('.').next().unwrap_or("");
        let message = if name.contains('.') {
            if self.model.bodies.iter().any(|b| b.name == body) {
                format!("unknown coordinate `{name}`")
            } else {
                format!("unknown body `{body}` in `{name}`")
            }
        } else {
            format!("unknown parameter `{name}`")
        };
        let help = suggest(name, cands.iter().copied()).unwrap_or_else(|| {
            if coords {
                format!(
                    "names here: parameters ({}), coordinates ({}) and time `t`",
                    params.names().collect::<Vec<_>>().join(", "),
                    self.coordinates.join(", ")
                )
            } else {
                format!(
                    "parameters: {}",
                    params.names().collect::<Vec<_>>().join(", ")
                )
            }
        });
        Err(ExprError {
            span: span.clone(),
            message,
            help: Some(help),
        })
    }

    fn compile_field(&mut self, f: &Field, coords: bool, time: bool) -> Option<Compiled> {
        let params = &self.model.parameters;
        let var_dim = |n: &str| params.index(n).and_then(|i| params.dims[i]);
        let r = f.expr.check_dims(&var_dim).and_then(|_| {
            f.expr
                .compile(&mut |name, span| self.lookup(name, span, coords, time))
        });
        match r {
            Ok(c) => Some(c),
            Err(e) => {
                let mut d = expr_diag(&e, f.offset);
                if f.number {
                    d.span = Some(f.span.clone());
                }
                self.diags.push(d);
                None
            }
        }
    }

    /// Dimension check where decidable (a quantity literal or a parameter of known
    /// dimension).
    fn check_dim(&mut self, f: &Field, expected: Dim, what: &str) -> bool {
        let params = &self.model.parameters;
        let var_dim = |n: &str| params.index(n).and_then(|i| params.dims[i]);
        match f.expr.dim(&var_dim) {
            Some(d) if d != expected => {
                self.diags.push(
                    Diagnostic::new(format!(
                        "{what} is a quantity in {expected}; this value is in {d}"
                    ))
                    .at(f.span.clone())
                    .label(format!("in {d}"))
                    .help(format!("give {what} in {expected} (plain numbers are SI)")),
                );
                false
            }
            _ => true,
        }
    }

    /// A constant (parameters only), dimension-checked.
    fn constant(&mut self, f: &Field, expected: Dim, what: &str) -> Option<f64> {
        if !self.check_dim(f, expected, what) {
            return None;
        }
        let c = self.compile_field(f, false, false)?;
        let v = c.eval::<f64>(&[], 0.0);
        if !v.is_finite() {
            self.diags.push(
                Diagnostic::new(format!("{what} evaluates to {v}"))
                    .at(f.span.clone())
                    .help("check the parameters it uses"),
            );
            return None;
        }
        Some(v)
    }

    fn positive(&mut self, f: &Field, expected: Dim, what: &str) -> Option<f64> {
        self.at_least_zero(f, expected, what, true)
    }

    /// A constant > 0 (`strict`) or ≥ 0.
    fn at_least_zero(&mut self, f: &Field, expected: Dim, what: &str, strict: bool) -> Option<f64> {
        let v = self.constant(f, expected, what)?;
        if v < 0.0 || (strict && v == 0.0) {
            let kind = if strict {
                "positive"
            } else {
                "zero or positive"
            };
            let mut msg = format!("{what} must be {kind}, it is {v} {expected}");
            let set: Vec<String> = self
                .model
                .overrides
                .iter()
                .map(|(n, v)| format!("{n}={v}"))
                .collect();
            if !set.is_empty() {
                msg.push_str(&format!(" (with --set {})", set.join(" ")));
            }
            self.diags.push(
                Diagnostic::new(msg)
                    .at(f.span.clone())
                    .label(if strict { "not positive" } else { "negative" })
                    .help(format!(
                        "give {what} a value {} 0",
                        if strict { ">" } else { "≥" }
                    )),
            );
            return None;
        }
        Some(v)
    }

    fn point(&mut self, p: &PointRef, what: &str) -> Option<SysPoint> {
        let x = self.constant(&p.point[0], Dim::LENGTH, what);
        let y = self.constant(&p.point[1], Dim::LENGTH, what);
        let body = match p.body {
            BodyRef::Ground => None,
            BodyRef::Body(i) => Some(self.body_offset(i)),
        };
        Some(SysPoint { body, p: [x?, y?] })
    }

    fn body_offset(&self, i: usize) -> usize {
        self.model.bodies[..i]
            .iter()
            .map(|b| b.kind.coordinates().len())
            .sum()
    }

    fn compile(&mut self) -> Option<System> {
        let model = self.model;
        // Bodies, mass matrix, initial guess.
        let mut bodies = Vec::new();
        let mut initial = InitialGuess {
            q: Vec::new(),
            fixed: Vec::new(),
            v: Vec::new(),
            v_given: Vec::new(),
        };
        for (i, b) in model.bodies.iter().enumerate() {
            let mass = self.positive(&b.mass, Dim::MASS, &format!("the mass of `{}`", b.name));
            let inertia = self.positive(
                &b.inertia,
                Dim::INERTIA,
                &format!("the inertia of `{}`", b.name),
            );
            for (k, (c, d)) in b
                .kind
                .coordinates()
                .iter()
                .zip(b.kind.coordinate_dims())
                .enumerate()
            {
                let what = format!("`{}.{c}`", b.name);
                // A guess may be undefined (NaN) for some parameters: assembly reports it.
                let q0 = if b.fixed[k] {
                    self.constant(&b.initial[k], *d, &what).unwrap_or(f64::NAN)
                } else if self.check_dim(&b.initial[k], *d, &what) {
                    self.compile_field(&b.initial[k], false, false)
                        .map_or(f64::NAN, |c| c.eval::<f64>(&[], 0.0))
                } else {
                    f64::NAN
                };
                initial.q.push(q0);
                initial.fixed.push(b.fixed[k]);
                match &b.velocity[k] {
                    Some(f) => {
                        let rate = d.div(Dim::TIME);
                        initial.v.push(
                            self.constant(f, rate, &format!("{what} velocity"))
                                .unwrap_or(f64::NAN),
                        );
                        initial.v_given.push(true);
                    }
                    None => {
                        initial.v.push(0.0);
                        initial.v_given.push(false);
                    }
                }
            }
            if let (Some(mass), Some(inertia)) = (mass, inertia) {
                bodies.push(SysBody {
                    name: b.name.clone(),
                    kind: b.kind,
                    offset: self.body_offset(i),
                    mass,
                    inertia,
                });
            }
        }
        // Constraints.
        let mut constraints = Vec::new();
        let mut names = Vec::new();
        let mut rheonomic = false;
        for j in model.joints.iter() {
            let a = self.point(&j.p1, &format!("point1 of joint `{}`", j.name));
            let b = self.point(&j.p2, &format!("point2 of joint `{}`", j.name));
            let (Some(a), Some(b)) = (a, b) else { continue };
            let body_of = |p: &PointRef| match p.body {
                BodyRef::Ground => None,
                BodyRef::Body(i) => Some(self.body_offset(i)),
            };
            let (ba, bb) = (body_of(&j.p1), body_of(&j.p2));
            if ba.is_none() && bb.is_none() {
                self.diags.push(
                    Diagnostic::new(format!("joint `{}` connects the ground to itself", j.name))
                        .at(j.span.clone())
                        .help("name a body in body1 or body2"),
                );
                continue;
            }
            match &j.kind {
                JointKind::Revolute => {
                    constraints.push(SysConstraint::Revolute { a, b });
                    names.push(format!("{}.x", j.name));
                    names.push(format!("{}.y", j.name));
                }
                JointKind::PinInSlot { axis } | JointKind::Prismatic { axis, .. } => {
                    let ax = self.constant(&axis[0], Dim::NONE, "the slot axis");
                    let ay = self.constant(&axis[1], Dim::NONE, "the slot axis");
                    let (Some(ax), Some(ay)) = (ax, ay) else {
                        continue;
                    };
                    let len = ax.hypot(ay);
                    if len == 0.0 {
                        self.diags.push(
                            Diagnostic::new(format!("joint `{}`: the slot axis is zero", j.name))
                                .at(axis[0].span.start..axis[1].span.end)
                                .help("give a direction such as [1, 0]"),
                        );
                        continue;
                    }
                    constraints.push(SysConstraint::Slot {
                        a,
                        b,
                        normal: [-ay / len, ax / len],
                    });
                    names.push(format!("{}.slot", j.name));
                    if let JointKind::Prismatic { angle, .. } = &j.kind {
                        let angle = self.constant(&angle.clone(), Dim::NONE, "the joint angle")?;
                        constraints.push(SysConstraint::Angle {
                            a: ba,
                            b: bb,
                            angle,
                        });
                        names.push(format!("{}.angle", j.name));
                    }
                }
                JointKind::Fixed { angle } => {
                    let angle = self.constant(&angle.clone(), Dim::NONE, "the joint angle")?;
                    constraints.push(SysConstraint::Revolute { a, b });
                    constraints.push(SysConstraint::Angle {
                        a: ba,
                        b: bb,
                        angle,
                    });
                    names.push(format!("{}.x", j.name));
                    names.push(format!("{}.y", j.name));
                    names.push(format!("{}.angle", j.name));
                }
            }
        }
        for c in model.constraints.iter() {
            if let Some(e) = self.compile_field(&c.expr, true, true) {
                rheonomic |= e.depends_on_time();
                constraints.push(SysConstraint::Custom(e));
                names.push(c.name.clone());
            }
        }
        // Forces.
        let mut gravity = [0.0, 0.0];
        let mut forces = Vec::new();
        for f in model.forces.iter() {
            match &f.kind {
                ForceKind::Gravity { acceleration } => {
                    let gx = self.constant(&acceleration[0], Dim::ACCELERATION, "gravity");
                    let gy = self.constant(&acceleration[1], Dim::ACCELERATION, "gravity");
                    gravity[0] += gx.unwrap_or(0.0);
                    gravity[1] += gy.unwrap_or(0.0);
                }
                ForceKind::SpringDamper {
                    p1,
                    p2,
                    stiffness,
                    damping,
                    free_length,
                } => {
                    let a = self.point(p1, &format!("point1 of `{}`", f.name));
                    let b = self.point(p2, &format!("point2 of `{}`", f.name));
                    let k = self.constant(stiffness, Dim::STIFFNESS, "the stiffness");
                    let c = self.constant(damping, Dim::DAMPING, "the damping");
                    let l0 = self.at_least_zero(free_length, Dim::LENGTH, "the free length", false);
                    if let (Some(a), Some(b), Some(k), Some(c), Some(l0)) = (a, b, k, c, l0) {
                        forces.push(SysForce::Spring { a, b, k, c, l0 });
                    }
                }
                ForceKind::PointForce { at, force } => {
                    let p = self.point(at, &format!("the point of `{}`", f.name));
                    self.check_dim(&force[0], Dim::FORCE, "a force");
                    self.check_dim(&force[1], Dim::FORCE, "a force");
                    let fx = self.compile_field(&force[0], true, true);
                    let fy = self.compile_field(&force[1], true, true);
                    if let (Some(at), Some(fx), Some(fy)) = (p, fx, fy) {
                        forces.push(SysForce::Point { at, f: [fx, fy] });
                    }
                }
            }
        }
        if !self.diags.is_empty() {
            return None;
        }
        let n = self.coordinates.len();
        let mut mdiag = DVector::zeros(n);
        for b in &bodies {
            mdiag[b.offset] = b.mass;
            mdiag[b.offset + 1] = b.mass;
            mdiag[b.offset + 2] = b.inertia;
        }
        let mass_matrix = DMatrix::from_diagonal(&mdiag);
        let mass_inv = DMatrix::from_diagonal(&mdiag.map(|x| 1.0 / x));
        let mass_inv_sqrt = DMatrix::from_diagonal(&mdiag.map(|x| 1.0 / x.sqrt()));
        Some(System {
            coordinates: self.coordinates.clone(),
            constraint_names: names,
            bodies,
            constraints,
            forces,
            gravity,
            mass_matrix,
            mass_inv,
            mass_inv_sqrt,
            initial,
            rheonomic,
            forcing_frequency: model
                .forcing_frequency
                .as_ref()
                .and_then(|f| model.parameters.value(f)),
        })
    }
}

impl From<ExprError> for Error {
    fn from(e: ExprError) -> Self {
        Error::Request {
            message: e.message,
            help: e.help,
        }
    }
}
