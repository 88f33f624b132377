//! Compilation of a [`Model`] into a [`System`]: names resolved once (parameters stay
//! live, see [`super::live`]), dimensions checked where decidable, elements built, value
//! checks recorded so that a later parameter change is refused with the same messages.

use super::frame::{GroundMotion, SysPoint};
use super::joints::{Constraint, Joint};
use super::live::{Check, CheckKind, Live};
use super::{InitialGuess, SysBody, System, forces::Force};
use crate::diag::{Diagnostic, Error, Result};
use crate::model::expr::{Compiled, ExprError, Slot, Span};
use crate::model::units::Dim;
use crate::model::{BodyRef, Field, ForceKind, JointKind, Model, PointRef, expr_diag, suggest};
use nalgebra::DMatrix;

impl System {
    /// Check a model (names, dimensions, signs) without keeping the result.
    pub fn check(model: &Model) -> Result<()> {
        System::new(model).map(|_| ())
    }

    /// Compile a model with its current parameter values (which stay live).
    pub fn new(model: &Model) -> Result<System> {
        let mut c = Compiler {
            model,
            coordinates: model.coordinate_names(),
            diags: Vec::new(),
            live: live_parameters(model),
        };
        let sys = c.compile();
        match sys {
            Some(s) if c.diags.is_empty() => Ok(s),
            _ => Err(model.error(c.diags)),
        }
    }
}

/// The model's parameters as live values: each follows its definition in force (the
/// `--set` expression or the file's) over the others, in dependency order.
fn live_parameters(model: &Model) -> Live {
    let params = &model.parameters;
    let n = params.list.len();
    let defs: Vec<Option<Compiled>> = (0..n)
        .map(|i| {
            params
                .definition(i)
                .compile(&mut |name, span| match params.index(name) {
                    Some(j) => Ok(Slot::Param(j)),
                    None => Err(ExprError::new(span.clone(), "unknown parameter")),
                })
                .ok()
                .filter(|c| c.as_constant().is_none())
        })
        .collect();
    // dependencies first (the model loader has refused cycles)
    let mut order = Vec::with_capacity(n);
    let mut state = vec![0u8; n];
    fn visit(i: usize, defs: &[Option<Compiled>], state: &mut [u8], order: &mut Vec<usize>) {
        if state[i] != 0 {
            return;
        }
        state[i] = 1;
        if let Some(d) = &defs[i] {
            for j in d.parameters() {
                visit(j, defs, state, order);
            }
        }
        state[i] = 2;
        order.push(i);
    }
    for i in 0..n {
        visit(i, &defs, &mut state, &mut order);
    }
    let texts = (0..n).map(|i| params.definition(i).to_string()).collect();
    Live::new(
        params.names().map(String::from).collect(),
        params.values.clone(),
        defs,
        texts,
        order,
    )
}

/// Turns a [`Model`] into a [`System`], collecting diagnostics.
struct Compiler<'a> {
    model: &'a Model,
    coordinates: Vec<String>,
    diags: Vec<Diagnostic>,
    live: Live,
}

impl Compiler<'_> {
    fn lookup(
        &self,
        name: &str,
        span: &Span,
        coords: bool,
        time: bool,
    ) -> std::result::Result<Slot, ExprError> {
        let params = &self.model.parameters;
        if let Some(i) = params.index(name) {
            let v = params.values[i];
            if !v.is_finite() {
                // 0/0, 1/0, sqrt(-1)...: refused where the model uses it (an unused
                // parameter such as T = 2*pi/omega at omega = 0 may stay undefined).
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
            return Ok(Slot::Param(i));
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
        let mut uses: Vec<(usize, Span)> = Vec::new();
        let r = f.expr.check_dims(&var_dim).and_then(|_| {
            f.expr.compile(&mut |name, span| {
                let s = self.lookup(name, span, coords, time)?;
                if let Slot::Param(i) = s {
                    uses.push((i, span.clone()));
                }
                Ok(s)
            })
        });
        match r {
            Ok(c) => {
                if coords || time {
                    // read while the model runs: a later change to a non-finite value is
                    // refused where it is used
                    for (i, s) in uses {
                        let at = if f.number {
                            f.span.clone()
                        } else {
                            f.offset + s.start..f.offset + s.end
                        };
                        self.live.used.push((i, at));
                    }
                }
                Some(c)
            }
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

    /// A coefficient (parameters only), dimension-checked, with a value check.
    fn checked(&mut self, f: &Field, expected: Dim, what: &str, kind: CheckKind) -> Option<usize> {
        if !self.check_dim(f, expected, what) {
            return None;
        }
        let c = self.compile_field(f, false, false)?;
        let coef = self.live.coef(c);
        self.live.checks.push(Check {
            coef,
            kind,
            what: what.to_string(),
            dim: expected,
            span: f.span.clone(),
        });
        Some(coef)
    }

    /// A finite coefficient.
    fn constant(&mut self, f: &Field, expected: Dim, what: &str) -> Option<usize> {
        self.checked(f, expected, what, CheckKind::Finite)
    }

    fn point(&mut self, p: &PointRef, what: &str) -> Option<SysPoint> {
        let x = self.constant(&p.point[0], Dim::LENGTH, what);
        let y = self.constant(&p.point[1], Dim::LENGTH, what);
        Some(SysPoint {
            body: self.body_of(p),
            p: [x?, y?],
        })
    }

    fn body_of(&self, p: &PointRef) -> Option<usize> {
        match p.body {
            BodyRef::Ground => None,
            BodyRef::Body(i) => Some(i),
        }
    }

    fn body_offset(&self, i: usize) -> usize {
        self.model.bodies[..i]
            .iter()
            .map(|b| b.kind.coordinates().len())
            .sum()
    }

    /// The current value of a compiled coefficient expression.
    fn value_now(&self, c: usize) -> f64 {
        let (p, coefs) = self.live.evaluate(|_, x| x, None);
        let _ = p;
        coefs[c]
    }

    fn ground(&mut self) -> GroundMotion {
        let g = self.model.ground.clone();
        let mut component = |f: &Option<Field>, dim: Dim, what: &str| -> Option<Compiled> {
            let f = f.as_ref()?;
            if !self.check_dim(f, dim, what) {
                return None;
            }
            self.compile_field(f, false, true)
        };
        GroundMotion {
            x: component(&g.x, Dim::LENGTH, "the ground's x motion"),
            y: component(&g.y, Dim::LENGTH, "the ground's y motion"),
            theta: component(&g.theta, Dim::NONE, "the ground's theta motion"),
        }
    }

    fn compile(&mut self) -> Option<System> {
        let model = self.model;
        // Bodies, initial guess.
        let mut bodies = Vec::new();
        let mut initial = InitialGuess {
            q: Vec::new(),
            fixed: Vec::new(),
            v: Vec::new(),
            v_given: Vec::new(),
        };
        let mut initial_coefs = Vec::new();
        let mut velocity_coefs = Vec::new();
        let mut coordinate_dims = Vec::new();
        for (i, b) in model.bodies.iter().enumerate() {
            let mass = self.checked(
                &b.mass,
                Dim::MASS,
                &format!("the mass of `{}`", b.name),
                CheckKind::Positive,
            );
            let inertia = self.checked(
                &b.inertia,
                Dim::INERTIA,
                &format!("the inertia of `{}`", b.name),
                CheckKind::Positive,
            );
            for (k, (c, d)) in b
                .kind
                .coordinates()
                .iter()
                .zip(b.kind.coordinate_dims())
                .enumerate()
            {
                let what = format!("`{}.{c}`", b.name);
                coordinate_dims.push(*d);
                // A guess may be undefined (NaN) for some parameters: assembly reports it.
                let q0 = if b.fixed[k] {
                    self.constant(&b.initial[k], *d, &what)
                } else if self.check_dim(&b.initial[k], *d, &what) {
                    self.compile_field(&b.initial[k], false, false)
                        .map(|c| self.live.coef(c))
                } else {
                    None
                };
                let q0 = q0.unwrap_or_else(|| self.live.coef(Compiled::constant(f64::NAN)));
                initial_coefs.push(q0);
                initial.q.push(f64::NAN);
                initial.fixed.push(b.fixed[k]);
                match &b.velocity[k] {
                    Some(f) => {
                        let rate = d.div(Dim::TIME);
                        velocity_coefs.push(self.constant(f, rate, &format!("{what} velocity")));
                        initial.v_given.push(true);
                    }
                    None => {
                        velocity_coefs.push(None);
                        initial.v_given.push(false);
                    }
                }
                initial.v.push(0.0);
            }
            if let (Some(mass_coef), Some(inertia_coef)) = (mass, inertia) {
                bodies.push(SysBody {
                    name: b.name.clone(),
                    kind: b.kind,
                    offset: self.body_offset(i),
                    mass: f64::NAN,
                    inertia: f64::NAN,
                    mass_coef,
                    inertia_coef,
                });
            }
        }
        // Constraints.
        let mut constraints = Vec::new();
        let mut names = Vec::new();
        let ground = self.ground();
        let mut rheonomic = ground.is_moving();
        for j in model.joints.iter() {
            let a = self.point(&j.p1, &format!("point1 of joint `{}`", j.name));
            let b = self.point(&j.p2, &format!("point2 of joint `{}`", j.name));
            let (Some(a), Some(b)) = (a, b) else { continue };
            if a.body.is_none() && b.body.is_none() {
                self.diags.push(
                    Diagnostic::new(format!("joint `{}` connects the ground to itself", j.name))
                        .at(j.span.clone())
                        .help("name a body in body1 or body2"),
                );
                continue;
            }
            let joint = match &j.kind {
                JointKind::Revolute => Joint::revolute(a, b),
                JointKind::PinInSlot { axis } | JointKind::Prismatic { axis, .. } => {
                    let ax = self.constant(&axis[0], Dim::NONE, "the slot axis");
                    let ay = self.constant(&axis[1], Dim::NONE, "the slot axis");
                    let (Some(ax), Some(ay)) = (ax, ay) else {
                        continue;
                    };
                    if self.diags.is_empty() && self.value_now(ax).hypot(self.value_now(ay)) == 0.0
                    {
                        self.diags.push(
                            Diagnostic::new(format!("joint `{}`: the slot axis is zero", j.name))
                                .at(axis[0].span.start..axis[1].span.end)
                                .help("give a direction such as [1, 0]"),
                        );
                        continue;
                    }
                    let n = self.live.normal([ax, ay]);
                    for c in n {
                        self.live.checks.push(Check {
                            coef: c,
                            kind: CheckKind::Finite,
                            what: format!("the slot axis of joint `{}`", j.name),
                            dim: Dim::NONE,
                            span: axis[0].span.start..axis[1].span.end,
                        });
                    }
                    match &j.kind {
                        JointKind::Prismatic { angle, .. } => {
                            let Some(angle) = self.constant(angle, Dim::NONE, "the joint angle")
                            else {
                                continue;
                            };
                            Joint::prismatic(a, b, n, angle)
                        }
                        _ => Joint::pin_in_slot(a, b, n),
                    }
                }
                JointKind::Fixed { angle } => {
                    let Some(angle) = self.constant(angle, Dim::NONE, "the joint angle") else {
                        continue;
                    };
                    Joint::fixed(a, b, angle)
                }
            };
            names.extend(joint.row_names().iter().map(|r| format!("{}.{r}", j.name)));
            constraints.push(Constraint::Joint(joint));
        }
        for c in model.constraints.iter() {
            if let Some(e) = self.compile_field(&c.expr, true, true) {
                rheonomic |= e.depends_on_time();
                constraints.push(Constraint::Custom(e));
                names.push(c.name.clone());
            }
        }
        // Forces.
        let mut gravity_coefs = Vec::new();
        let mut forces = Vec::new();
        for f in model.forces.iter() {
            match &f.kind {
                ForceKind::Gravity { acceleration } => {
                    let gx = self.constant(&acceleration[0], Dim::ACCELERATION, "gravity");
                    let gy = self.constant(&acceleration[1], Dim::ACCELERATION, "gravity");
                    if let (Some(gx), Some(gy)) = (gx, gy) {
                        gravity_coefs.push([gx, gy]);
                    }
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
                    let l0 = self.checked(
                        free_length,
                        Dim::LENGTH,
                        "the free length",
                        CheckKind::NonNegative,
                    );
                    if let (Some(a), Some(b), Some(k), Some(c), Some(l0)) = (a, b, k, c, l0) {
                        forces.push(Force::Spring { a, b, k, c, l0 });
                    }
                }
                ForceKind::PointForce { at, force } => {
                    let p = self.point(at, &format!("the point of `{}`", f.name));
                    self.check_dim(&force[0], Dim::FORCE, "a force");
                    self.check_dim(&force[1], Dim::FORCE, "a force");
                    let fx = self.compile_field(&force[0], true, true);
                    let fy = self.compile_field(&force[1], true, true);
                    if let (Some(at), Some(fx), Some(fy)) = (p, fx, fy) {
                        forces.push(Force::Point { at, f: [fx, fy] });
                    }
                }
            }
        }
        if !self.diags.is_empty() {
            return None;
        }
        // Values, and the checks on them.
        self.live.refresh();
        let overrides: String = model
            .overrides
            .iter()
            .map(|(n, v)| format!("{n}={v}"))
            .collect::<Vec<_>>()
            .join(" ");
        let mut failures = self
            .live
            .failures(&self.live.values, &self.live.coefs, &overrides);
        // The ground's motion must be defined where the motion starts (a NaN there would
        // surface as an undefined joint, far from its cause).
        let g = model.ground.clone();
        let env = crate::scalar::Plain {
            params: &self.live.values,
            coefs: &self.live.coefs,
        };
        for (c, f, what) in [
            (&ground.x, &g.x, "x"),
            (&ground.y, &g.y, "y"),
            (&ground.theta, &g.theta, "theta"),
        ] {
            if let (Some(c), Some(f)) = (c, f) {
                let v: f64 = c.eval_in(&[], 0.0, env);
                if !v.is_finite() {
                    failures.push(
                        Diagnostic::new(format!("the ground's {what} motion evaluates to {v} at t = 0"))
                            .at(f.span.clone())
                            .label("not finite")
                            .help("check the expression and the parameters it uses (a division by zero, sqrt or ln of a negative number)"),
                    );
                }
            }
        }
        if !failures.is_empty() {
            self.diags = failures;
            return None;
        }
        let n = self.coordinates.len();
        // Where each coordinate lives, and the block of A of each constraint.
        let offsets: Vec<usize> = (0..model.bodies.len())
            .map(|i| self.body_offset(i))
            .collect();
        let mut coord_body = Vec::with_capacity(n);
        for (k, b) in model.bodies.iter().enumerate() {
            coord_body.extend((0..b.kind.coordinates().len()).map(|d| (k, d)));
        }
        let mut blocks = Vec::with_capacity(constraints.len());
        let (mut row0, mut val0) = (0, 0);
        for c in &constraints {
            let mut cols = c.coordinates();
            for k in c.bodies() {
                cols.extend(offsets[k]..offsets[k] + model.bodies[k].kind.coordinates().len());
            }
            cols.sort_unstable();
            cols.dedup();
            let rows = c.rows();
            blocks.push(super::Block {
                row0,
                rows,
                val0,
                cols: cols.clone(),
            });
            row0 += rows;
            val0 += rows * cols.len();
        }
        let mut sys = System {
            coordinates: self.coordinates.clone(),
            coordinate_dims,
            constraint_names: names,
            bodies,
            offsets,
            coord_body,
            constraints,
            blocks,
            nvals: val0,
            forces,
            gravity_coefs,
            gravity: [0.0, 0.0],
            ground,
            mass_matrix: DMatrix::zeros(n, n),
            mass_inv_sqrt: DMatrix::zeros(n, n),
            mass_inv_diag: vec![0.0; n],
            initial,
            initial_coefs,
            velocity_coefs,
            rheonomic,
            forcing: model
                .forcing_frequency
                .as_ref()
                .and_then(|f| model.parameters.index(f)),
            live: std::mem::take(&mut self.live),
            source: model.source.clone(),
            overrides,
        };
        sys.refresh();
        Some(sys)
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
