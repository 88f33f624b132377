//! Compilation of a [`Model`] into a [`System`]: names resolved once (parameters stay
//! live, see [`super::live`]), dimensions checked where decidable, elements built, value
//! checks recorded so that a later parameter change is refused with the same messages.

use super::frame::{GroundMotion, SysPoint};
use super::joints::{Constraint, Joint};
use super::live::{Check, CheckKind, Live};
use super::spatial::{Force3, Geom3, Joint3, SysPoint3, UnitCoefs};
use super::{
    InitialGuess, SysBody, System,
    forces::{Force, Law},
};
use crate::diag::{Diagnostic, Error, Result};
use crate::model::expr::{Compiled, ExprError, Slot, Span};
use crate::model::units::Dim;
use crate::model::{
    BodyKind, BodyRef, Field, ForceKind, JointKind, LawDef, Model, PointRef, SpatialJoint,
    expr_diag, suggest,
};
use nalgebra::DMatrix;

impl System {
    /// Check a model (names, dimensions, signs) without keeping the result.
    pub fn check(model: &Model) -> Result<()> {
        System::new(model).map(|_| ())
    }

    /// Compile a model with its current parameter values (which stay live).
    pub fn new(model: &Model) -> Result<System> {
        let velocity_names = model
            .velocity_names()
            .into_iter()
            .zip(
                model
                    .bodies
                    .iter()
                    .flat_map(|b| std::iter::repeat_n(b.kind.velocities_are_rates(), b.vels.len())),
            )
            .map(|(v, rate)| if rate { format!("{v}_dot") } else { v })
            .collect();
        let mut c = Compiler {
            model,
            coordinates: model.coordinate_names(),
            coordinate_dims: model.bodies.iter().flat_map(|b| b.dims.clone()).collect(),
            velocity_dims: model.bodies.iter().flat_map(|b| b.vdims.clone()).collect(),
            velocity_names,
            allow_velocities: false,
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
    /// The velocities' names as expressions read them: `<coordinate>_dot` for a
    /// coordinate's rate, `b.wx` etc. for a free body's.
    velocity_names: Vec<String>,
    /// The dimension of each coordinate (m; angles and quaternion components: none) and
    /// of each velocity (per second of those; a free body's: m/s and 1/s).
    coordinate_dims: Vec<Dim>,
    velocity_dims: Vec<Dim>,
    /// Whether the field being compiled may read velocities (applied forces and torques):
    /// velocity j is slot `Coord(nq + j)`, evaluated over (q, v) concatenated.
    allow_velocities: bool,
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
            let (message, help) = if time {
                (
                    format!(
                        "`{name}` is a coordinate; this value may depend only on time `t` and the parameters"
                    ),
                    "a prescribed motion is a function of t alone: use t and parameters here",
                )
            } else {
                (
                    format!("`{name}` is a coordinate; this value must be constant"),
                    "use parameters only here",
                )
            };
            return Err(ExprError {
                span: span.clone(),
                message,
                help: Some(help.into()),
            });
        }
        if !coords && self.velocity_names.iter().any(|c| c == name) {
            return Err(ExprError {
                span: span.clone(),
                message: if time {
                    format!("`{name}` is a velocity; this value may depend only on time `t` and the parameters")
                } else {
                    format!("`{name}` is a velocity; this value must be constant")
                },
                help: Some("velocities may appear in applied forces and torques (`point_force`, `torque`) only".into()),
            });
        }
        if coords && let Some(j) = self.velocity_names.iter().position(|c| c == name) {
            if self.allow_velocities {
                return Ok(Slot::Coord(self.coordinates.len() + j));
            }
            return Err(ExprError {
                span: span.clone(),
                message: format!("`{name}` is a velocity; this value cannot depend on velocities"),
                help: Some("velocities may appear in applied forces and torques (`point_force`, `torque`), not in constraints".into()),
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
        if crate::model::expr::is_non_finite_name(name) {
            return Err(crate::model::expr::non_finite_name(name, span.clone()));
        }
        let mut cands: Vec<&str> = params.names().collect();
        if coords {
            cands.extend(self.coordinates.iter().map(|s| s.as_str()));
        }
        // where velocities may be read, a misspelt one is suggested as itself
        // (`bar.theta_dto`: `bar.theta_dot`, not `bar.theta`)
        if coords && self.allow_velocities {
            cands.extend(self.velocity_names.iter().map(|s| s.as_str()));
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
        let suggestion = suggest(name, cands.iter().copied());
        // `bar.vx`, `bar.omega` in a load: a velocity asked for by a name it does not
        // have. "did you mean `bar.x`?" would offer a position; say how velocities are
        // named and which the body has (a near miss of a velocity keeps its suggestion)
        let body_velocities: Vec<&str> = self
            .velocity_names
            .iter()
            .filter(|v| v.split('.').next() == Some(body))
            .map(|v| v.as_str())
            .collect();
        if coords
            && self.allow_velocities
            && name.contains('.')
            && !body_velocities.is_empty()
            && !suggestion.as_ref().is_some_and(|s| {
                body_velocities
                    .iter()
                    .any(|v| s.contains(&format!("`{v}`")))
            })
        {
            let body_coordinates: Vec<&str> = self
                .coordinates
                .iter()
                .filter(|c| c.split('.').next() == Some(body))
                .map(|c| c.as_str())
                .collect();
            let how = if body_velocities.iter().all(|v| v.ends_with("_dot")) {
                "forces may use velocities as NAME_dot".to_string()
            } else if body_velocities.iter().any(|v| v.ends_with("_dot")) {
                format!(
                    "forces may use velocities as NAME_dot, and body `{body}`'s own as named here"
                )
            } else {
                format!("forces may use a free body's velocities as `{body}.vx` ... `{body}.wz`")
            };
            return Err(ExprError {
                span: span.clone(),
                message,
                help: Some(format!(
                    "{how}: {} (the coordinates of `{body}` are {})",
                    body_velocities.join(", "),
                    body_coordinates.join(", ")
                )),
            });
        }
        let help = suggestion.unwrap_or_else(|| {
            if coords && self.allow_velocities {
                format!(
                    "names here: parameters ({}), coordinates ({}), velocities ({}) and time `t`",
                    params.names().collect::<Vec<_>>().join(", "),
                    self.coordinates.join(", "),
                    self.velocity_names.join(", ")
                )
            } else if coords {
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

    /// A load's expression (a force or torque component): parameters, time, coordinates
    /// and velocities.
    fn compile_load(&mut self, f: &Field) -> Option<Compiled> {
        self.allow_velocities = true;
        let c = self.compile_field(f, true, true);
        self.allow_velocities = false;
        c
    }

    /// The dimension of a name in an expression, where known: a parameter's (from its
    /// unit or value); where the field may read them (`coords`), a coordinate's and, in a
    /// load, a velocity's.
    fn var_dim(&self, name: &str, coords: bool) -> Option<Dim> {
        let params = &self.model.parameters;
        if let Some(i) = params.index(name) {
            return params.dims[i];
        }
        if !coords {
            return None;
        }
        if let Some(i) = self.coordinates.iter().position(|c| c == name) {
            return self.coordinate_dims.get(i).copied();
        }
        if self.allow_velocities
            && let Some(j) = self.velocity_names.iter().position(|c| c == name)
        {
            return self.velocity_dims.get(j).copied();
        }
        None
    }

    /// Whether `f`'s coordinates and velocities take part in its dimension check: when
    /// the expression has a dimension of its own, from a quantity literal or a parameter
    /// of known dimension. Otherwise its plain numbers are SI and carry what is needed
    /// (`"-5.6*crank.theta_dot"` is a torque of 5.6 N·m·s/rad), as a lone plain number
    /// does.
    fn coords_have_dims(&self, f: &Field, coords: bool) -> bool {
        let params = &self.model.parameters;
        coords
            && (f.expr.has_units()
                || f.expr
                    .variables()
                    .iter()
                    .any(|(n, _)| params.index(n).and_then(|i| params.dims[i]).is_some()))
    }

    fn compile_field(&mut self, f: &Field, coords: bool, time: bool) -> Option<Compiled> {
        let with_coords = self.coords_have_dims(f, coords);
        let var_dim = |n: &str| self.var_dim(n, with_coords);
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
        self.check_dim_in(f, expected, 0, what, false)
    }

    /// [`Compiler::check_dim`] for a load (a force or torque component), whose coordinates
    /// and velocities have their dimensions.
    fn check_load_dim(&mut self, f: &Field, expected: Dim, what: &str) -> bool {
        self.allow_velocities = true;
        let ok = self.check_dim_in(f, expected, 0, what, true);
        self.allow_velocities = false;
        ok
    }

    /// [`Self::check_dim`] of a quantity with `angle` powers of the angle, named so in its
    /// message (`rad`, `N·m/rad`: angles are dimensionless, so `expected` alone would say
    /// `1` or `N·m`).
    fn check_dim_angular(&mut self, f: &Field, expected: Dim, angle: i32, what: &str) -> bool {
        self.check_dim_in(f, expected, angle, what, false)
    }

    /// [`Compiler::check_dim_angular`]; `coords`: the field may read coordinates (see
    /// [`Compiler::var_dim`]).
    fn check_dim_in(
        &mut self,
        f: &Field,
        expected: Dim,
        angle: i32,
        what: &str,
        coords: bool,
    ) -> bool {
        let with_coords = self.coords_have_dims(f, coords);
        let var_dim = |n: &str| self.var_dim(n, with_coords);
        match f.expr.dim(&var_dim) {
            Some(d) if d != expected => {
                let expected = crate::model::units::si_unit_with_angle(expected, angle);
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
        self.checked_angular(f, expected, 0, what, kind)
    }

    /// [`Self::checked`] of a quantity with `angle` powers of the angle (see
    /// [`Self::check_dim_angular`]).
    fn checked_angular(
        &mut self,
        f: &Field,
        expected: Dim,
        angle: i32,
        what: &str,
        kind: CheckKind,
    ) -> Option<usize> {
        if !self.check_dim_angular(f, expected, angle, what) {
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

    /// The law of a spring (`angular`: a torsion) named `name` whose stiffness is
    /// coefficient `k` (written at `stiffness`): its own fields compiled and checked.
    fn law(
        &mut self,
        law: &LawDef,
        angular: bool,
        name: &str,
        stiffness: &Field,
        k: Option<usize>,
    ) -> Option<Law> {
        let (stretch, rate, load) = if angular {
            (Dim::NONE, Dim::FREQUENCY, Dim::TORQUE)
        } else {
            (Dim::LENGTH, Dim::VELOCITY, Dim::FORCE)
        };
        let of = |what: &str| format!("the {what} of `{name}`");
        Some(match law {
            LawDef::Linear => Law::Linear,
            LawDef::Expr(f) => Law::Expr(self.law_expr(f, stretch, rate, load, name)?),
            LawDef::Breakout {
                preload,
                stiffness2,
                smoothing,
            } => {
                // tb = T0/k1: k1 must be positive
                if let Some(k) = k {
                    self.live.checks.push(Check {
                        coef: k,
                        kind: CheckKind::Positive,
                        what: of("stiffness"),
                        dim: Dim::ANGULAR_STIFFNESS,
                        span: stiffness.span.clone(),
                    });
                }
                let t0 = self.checked(preload, Dim::TORQUE, &of("preload"), CheckKind::Positive);
                let k2 = self.constant_angular(
                    stiffness2,
                    Dim::ANGULAR_STIFFNESS,
                    -1,
                    &of("stiffness2"),
                );
                let eps = self.checked(smoothing, Dim::NONE, &of("smoothing"), CheckKind::Positive);
                Law::Breakout {
                    k2: k2?,
                    t0: t0?,
                    eps: eps?,
                }
            }
            LawDef::Backlash { gap, smoothing } => {
                let gap = self.checked(gap, stretch, &of("gap"), CheckKind::Positive);
                let eps = self.checked(smoothing, Dim::NONE, &of("smoothing"), CheckKind::Positive);
                Law::Backlash {
                    gap: gap?,
                    eps: eps?,
                }
            }
            LawDef::EndStop {
                lower,
                upper,
                smoothing,
            } => {
                let lo = lower
                    .as_ref()
                    .map(|l| self.constant(l, stretch, &of("lower limit")));
                let up = upper
                    .as_ref()
                    .map(|u| self.constant(u, stretch, &of("upper limit")));
                let width = self.checked(smoothing, stretch, &of("smoothing"), CheckKind::Positive);
                // a free range between the limits: lower < upper (a located error)
                if let (Some(Some(l)), Some(Some(u)), Some(f)) = (lo, up, lower.as_ref()) {
                    self.live.checks.push(Check {
                        coef: l,
                        kind: CheckKind::Below(u),
                        what: of("lower limit"),
                        dim: stretch,
                        span: f.span.clone(),
                    });
                }
                Law::EndStop {
                    lower: lo.map(|l| l.ok_or(())).transpose().ok()?,
                    upper: up.map(|u| u.ok_or(())).transpose().ok()?,
                    width: width?,
                }
            }
            LawDef::Friction { level, slip_rate } => {
                let level =
                    self.checked(level, load, &of("friction level"), CheckKind::NonNegative);
                let v0 = self.checked(slip_rate, rate, &of("slip rate"), CheckKind::Positive);
                Law::Friction {
                    level: level?,
                    v0: v0?,
                }
            }
        })
    }

    /// A user's law: an expression of `x` (the stretch), `x_dot` (its rate) and the
    /// parameters, of dimension `load`, compiled with `x` as slot 0 and `x_dot` as 1.
    fn law_expr(
        &mut self,
        f: &Field,
        stretch: Dim,
        rate: Dim,
        load: Dim,
        name: &str,
    ) -> Option<Compiled> {
        let params = &self.model.parameters;
        let var_dim = |n: &str| match n {
            "x" => Some(stretch),
            "x_dot" => Some(rate),
            _ => params.index(n).and_then(|i| params.dims[i]),
        };
        let what = format!("the law of `{name}`");
        match f.expr.dim(&var_dim) {
            Some(d) if d != load => {
                self.diags.push(
                    Diagnostic::new(format!("{what} is a quantity in {load}; this value is in {d}"))
                        .at(f.span.clone())
                        .label(format!("in {d}"))
                        .help(format!(
                            "give {what} in {load}: `x` is in {stretch}, `x_dot` in {rate} (plain numbers are SI)"
                        )),
                );
                return None;
            }
            _ => {}
        }
        let mut uses: Vec<(usize, Span)> = Vec::new();
        let r = f.expr.check_dims(&var_dim).and_then(|_| {
            f.expr.compile(&mut |n, span| match n {
                "x" => Ok(Slot::Coord(0)),
                "x_dot" => Ok(Slot::Coord(1)),
                _ => {
                    let s = self.lookup(n, span, false, false).map_err(|e| {
                        e.with_help("a law may use `x` (the stretch), `x_dot` (its rate) and the parameters")
                    })?;
                    if let Slot::Param(i) = s {
                        uses.push((i, span.clone()));
                    }
                    Ok(s)
                }
            })
        });
        match r {
            Ok(c) => {
                for (i, s) in uses {
                    self.live
                        .used
                        .push((i, f.offset + s.start..f.offset + s.end));
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

    /// A finite coefficient.
    fn constant(&mut self, f: &Field, expected: Dim, what: &str) -> Option<usize> {
        self.checked(f, expected, what, CheckKind::Finite)
    }

    /// A finite coefficient with `angle` powers of the angle: an angle (1, rad), a
    /// torsional stiffness (−1, N·m/rad).
    fn constant_angular(
        &mut self,
        f: &Field,
        expected: Dim,
        angle: i32,
        what: &str,
    ) -> Option<usize> {
        self.checked_angular(f, expected, angle, what, CheckKind::Finite)
    }

    /// A point of a spatial model: three coefficients, and its body's CG.
    fn point3(
        &mut self,
        p: &PointRef,
        what: &str,
        cgs: &[Option<[usize; 3]>],
    ) -> Option<SysPoint3> {
        let c: Vec<Option<usize>> = p
            .point
            .iter()
            .map(|f| self.constant(f, Dim::LENGTH, what))
            .collect();
        let body = self.body_of(p);
        Some(SysPoint3 {
            body,
            p: [c[0]?, c[1]?, c[2]?],
            // (a body that failed to compile has no entry: its errors are reported)
            cg: body.and_then(|k| cgs.get(k).copied().flatten()),
        })
    }

    /// A spatial axis (3 dimensionless coefficients), refused if zero.
    fn axis3(&mut self, a: &[Field], what: &str) -> Option<[usize; 3]> {
        let c: Vec<Option<usize>> = a
            .iter()
            .map(|f| self.constant(f, Dim::NONE, what))
            .collect();
        let c = [c[0]?, c[1]?, c[2]?];
        if self.diags.is_empty() && c.iter().all(|&i| self.value_now(i) == 0.0) {
            self.diags.push(
                Diagnostic::new(format!("{what} is zero"))
                    .at(a[0].span.start..a[2].span.end)
                    .help("give a direction such as [1, 0, 0]"),
            );
            return None;
        }
        Some(c)
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
        self.model.bodies[..i].iter().map(|b| b.coords.len()).sum()
    }

    fn body_voffset(&self, i: usize) -> usize {
        self.model.bodies[..i].iter().map(|b| b.vels.len()).sum()
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
            z: component(&g.z, Dim::LENGTH, "the ground's z motion"),
            theta: component(&g.theta, Dim::NONE, "the ground's theta motion"),
            rx: component(&g.rx, Dim::NONE, "the ground's rx motion"),
            ry: component(&g.ry, Dim::NONE, "the ground's ry motion"),
            rz: component(&g.rz, Dim::NONE, "the ground's rz motion"),
            frozen: None,
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
        let mut velocity_spans = Vec::new();
        let mut coordinate_dims = Vec::new();
        let mut angle_coords = Vec::new();
        let mut velocity_is_rate = Vec::new();
        // free bodies: where their quaternion's initial coefficients are
        let mut quaternions = Vec::new();
        let mut cgs: Vec<Option<[usize; 3]>> = Vec::new();
        for (i, b) in model.bodies.iter().enumerate() {
            let mass = self.checked(
                &b.mass,
                Dim::MASS,
                &format!("the mass of `{}`", b.name),
                CheckKind::Positive,
            );
            let inertia: Vec<Option<usize>> = if b.kind.is_spatial() {
                let names = ["Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"];
                b.inertia
                    .iter()
                    .zip(names)
                    .enumerate()
                    .map(|(k, (f, n))| {
                        let what = format!("the inertia {n} of `{}`", b.name);
                        if k < 3 {
                            self.checked(f, Dim::INERTIA, &what, CheckKind::NonNegative)
                        } else {
                            self.constant(f, Dim::INERTIA, &what)
                        }
                    })
                    .collect()
            } else {
                vec![self.checked(
                    &b.inertia[0],
                    Dim::INERTIA,
                    &format!("the inertia of `{}`", b.name),
                    CheckKind::Positive,
                )]
            };
            let cg: Option<Option<[usize; 3]>> = if b.kind.is_spatial() {
                let c: Vec<Option<usize>> =
                    b.cg.iter()
                        .map(|f| self.constant(f, Dim::LENGTH, &format!("the CG of `{}`", b.name)))
                        .collect();
                c.into_iter()
                    .collect::<Option<Vec<usize>>>()
                    .map(|c| Some([c[0], c[1], c[2]]))
            } else {
                Some(None)
            };
            let mut points = Vec::new();
            for (pname, p) in &b.points {
                let c: Option<Vec<usize>> = p
                    .iter()
                    .map(|f| self.constant(f, Dim::LENGTH, &format!("point `{}.{pname}`", b.name)))
                    .collect();
                if let Some(c) = c {
                    points.push((pname.clone(), c));
                }
            }
            for (k, (c, d)) in b.coords.iter().zip(&b.dims).enumerate() {
                let what = format!("`{}.{c}`", b.name);
                coordinate_dims.push(*d);
                angle_coords.push(*d == Dim::NONE && (b.kind != BodyKind::Free || k < 3));
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
            }
            if b.kind == BodyKind::Free {
                let k = initial_coefs.len() - 4;
                quaternions.push((k, b));
            }
            for (k, (c, d)) in b.vels.iter().zip(&b.vdims).enumerate() {
                velocity_is_rate.push(b.kind.velocities_are_rates());
                match &b.velocity[k] {
                    Some(f) => {
                        let what = if b.kind.velocities_are_rates() {
                            format!("`{}.{c}` velocity", b.name)
                        } else {
                            format!("the velocity `{}.{c}`", b.name)
                        };
                        velocity_coefs.push(self.constant(f, *d, &what));
                        initial.v_given.push(true);
                        velocity_spans.push(Some(f.span.clone()));
                    }
                    None => {
                        velocity_coefs.push(None);
                        initial.v_given.push(false);
                        velocity_spans.push(None);
                    }
                }
                initial.v.push(0.0);
            }
            let inertia: Option<Vec<usize>> = inertia.into_iter().collect();
            // by the model's body index (joints and forces look bodies up by it)
            cgs.push(cg.flatten());
            if let (Some(mass_coef), Some(inertia_coefs), Some(cg)) = (mass, inertia, cg) {
                bodies.push(SysBody {
                    name: b.name.clone(),
                    kind: b.kind.clone(),
                    offset: self.body_offset(i),
                    voff: self.body_voffset(i),
                    mass: f64::NAN,
                    inertia: f64::NAN,
                    tensor: [f64::NAN; 6],
                    mass_coef,
                    inertia_coefs,
                    cg,
                    points,
                });
            }
        }
        let zero = self.live.coef(Compiled::constant(0.0));
        let one = self.live.coef(Compiled::constant(1.0));
        let unit = UnitCoefs { zero, one };
        // Constraints.
        let mut constraints = Vec::new();
        let mut names = Vec::new();
        let mut elements: Vec<String> = Vec::new();
        let ground = self.ground();
        let mut rheonomic = ground.is_moving();
        for j in model.joints.iter() {
            if let JointKind::Spatial {
                kind,
                axis,
                axis2,
                length,
            } = &j.kind
            {
                if let Some(joint) = self.joint3(j, *kind, axis, axis2, length, &cgs, unit) {
                    names.extend(joint.row_names().iter().map(|r| format!("{}.{r}", j.name)));
                    elements.push(j.name.clone());
                    constraints.push(Constraint::Spatial(joint));
                }
                continue;
            }
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
                            let Some(angle) =
                                self.constant_angular(angle, Dim::NONE, 1, "the joint angle")
                            else {
                                continue;
                            };
                            Joint::prismatic(a, b, n, angle)
                        }
                        _ => Joint::pin_in_slot(a, b, n),
                    }
                }
                JointKind::Fixed { angle } => {
                    let Some(angle) = self.constant_angular(angle, Dim::NONE, 1, "the joint angle")
                    else {
                        continue;
                    };
                    Joint::fixed(a, b, angle)
                }
                JointKind::Spatial { .. } => unreachable!("spatial joints are compiled above"),
            };
            names.extend(joint.row_names().iter().map(|r| format!("{}.{r}", j.name)));
            elements.push(j.name.clone());
            constraints.push(Constraint::Joint(joint));
        }
        for c in model.constraints.iter() {
            if let Some(e) = self.compile_field(&c.expr, true, true) {
                rheonomic |= e.depends_on_time();
                constraints.push(Constraint::Custom(e));
                names.push(c.name.clone());
                elements.push(c.name.clone());
            }
        }
        // Forces, and their names (each element's, in order; gravity's apart).
        let mut gravity_coefs = Vec::new();
        let mut forces = Vec::new();
        let mut force_names: Vec<String> = Vec::new();
        let mut gravity_names: Vec<String> = Vec::new();
        for f in model.forces.iter() {
            let before = forces.len();
            'element: {
                match &f.kind {
                    ForceKind::Gravity { acceleration } => {
                        let g: Vec<Option<usize>> = acceleration
                            .iter()
                            .map(|f| self.constant(f, Dim::ACCELERATION, "gravity"))
                            .collect();
                        if let Some(g) = g.into_iter().collect::<Option<Vec<usize>>>() {
                            gravity_coefs.push([g[0], g[1], g.get(2).copied().unwrap_or(zero)]);
                        }
                    }
                    ForceKind::SpringDamper {
                        p1,
                        p2,
                        stiffness,
                        damping,
                        free_length,
                        law,
                    } => {
                        let w1 = format!("point1 of `{}`", f.name);
                        let w2 = format!("point2 of `{}`", f.name);
                        let ends3 = model
                            .spatial
                            .then(|| (self.point3(p1, &w1, &cgs), self.point3(p2, &w2, &cgs)));
                        let ends2 =
                            (!model.spatial).then(|| (self.point(p1, &w1), self.point(p2, &w2)));
                        let k = self.constant(stiffness, Dim::STIFFNESS, "the stiffness");
                        let c = self.constant(
                            damping,
                            Dim::DAMPING,
                            &format!("the damping of `{}`", f.name),
                        );
                        let l0 = self.checked(
                            free_length,
                            Dim::LENGTH,
                            "the free length",
                            CheckKind::NonNegative,
                        );
                        let law = self.law(law, false, &f.name, stiffness, k);
                        let (Some(k), Some(c), Some(l0), Some(law)) = (k, c, l0, law) else {
                            break 'element;
                        };
                        match (ends3, ends2) {
                            (Some((Some(a), Some(b))), _) => {
                                forces.push(Force::Spatial(Force3::Spring {
                                    a,
                                    b,
                                    k,
                                    c,
                                    l0,
                                    law,
                                }))
                            }
                            (_, Some((Some(a), Some(b)))) => forces.push(Force::Spring {
                                a,
                                b,
                                k,
                                c,
                                l0,
                                law,
                            }),
                            _ => {}
                        }
                    }
                    ForceKind::PointForce { at, force } => {
                        let what = format!("the point of `{}`", f.name);
                        let at3 = model.spatial.then(|| self.point3(at, &what, &cgs));
                        let at2 = (!model.spatial).then(|| self.point(at, &what));
                        for c in force {
                            self.check_load_dim(c, Dim::FORCE, "a force");
                        }
                        // every component compiled (and its problems reported) before giving up
                        let fs: Vec<Option<Compiled>> =
                            force.iter().map(|c| self.compile_load(c)).collect();
                        let Some(fs) = fs.into_iter().collect::<Option<Vec<_>>>() else {
                            break 'element;
                        };
                        match (at3, at2) {
                            (Some(Some(at)), _) => {
                                if let Ok(f) = <[Compiled; 3]>::try_from(fs) {
                                    forces.push(Force::Spatial(Force3::Point { at, f }));
                                }
                            }
                            (_, Some(Some(at))) => {
                                if let Ok(f) = <[Compiled; 2]>::try_from(fs) {
                                    forces.push(Force::Point { at, f });
                                }
                            }
                            _ => {}
                        }
                    }
                    ForceKind::Torsion {
                        body1,
                        body2,
                        axis,
                        stiffness,
                        damping,
                        free_angle,
                        law,
                    } => {
                        let b1 = self.body_of(&PointRef {
                            body: *body1,
                            point: Vec::new(),
                        });
                        let b2 = self.body_of(&PointRef {
                            body: *body2,
                            point: Vec::new(),
                        });
                        if b1 == b2 {
                            self.diags.push(
                                Diagnostic::new(format!(
                                    "torsion `{}` acts between a body and itself",
                                    f.name
                                ))
                                .at(f.span.clone())
                                .help("name two different bodies (or a body and \"ground\")"),
                            );
                            break 'element;
                        }
                        // planar: about the plane's normal (no axis)
                        let ax = if model.spatial {
                            match self.axis3(axis, &format!("the axis of `{}`", f.name)) {
                                Some(ax) => Some(ax),
                                None => break 'element,
                            }
                        } else {
                            None
                        };
                        let k = self.constant_angular(
                            stiffness,
                            Dim::ANGULAR_STIFFNESS,
                            -1,
                            "the torsional stiffness",
                        );
                        let c = self.constant_angular(
                            damping,
                            Dim::ANGULAR_DAMPING,
                            -1,
                            &format!("the torsional damping of `{}`", f.name),
                        );
                        let free =
                            self.constant_angular(free_angle, Dim::NONE, 1, "the free angle");
                        let law = self.law(law, true, &f.name, stiffness, k);
                        let (Some(k), Some(c), Some(free), Some(law)) = (k, c, free, law) else {
                            break 'element;
                        };
                        forces.push(match ax {
                            Some(ax) => Force::Spatial(Force3::Torsion {
                                b1,
                                b2,
                                frame: self.live.axis_frame(ax),
                                k,
                                c,
                                free,
                                law,
                            }),
                            None => Force::Torsion {
                                b1,
                                b2,
                                k,
                                c,
                                free,
                                law,
                            },
                        });
                    }
                    ForceKind::Torque { body, torque } => {
                        let Some(b) = self.body_of(&PointRef {
                            body: *body,
                            point: Vec::new(),
                        }) else {
                            self.diags.push(
                                Diagnostic::new(format!(
                                    "torque `{}` acts on the ground, so it does nothing",
                                    f.name
                                ))
                                .at(f.span.clone())
                                .help("name the body it acts on in `body`"),
                            );
                            break 'element;
                        };
                        let ts: Vec<Option<Compiled>> = torque
                            .iter()
                            .map(|c| {
                                self.check_load_dim(c, Dim::TORQUE, "a torque");
                                self.compile_load(c)
                            })
                            .collect();
                        let Some(ts) = ts.into_iter().collect::<Option<Vec<_>>>() else {
                            break 'element;
                        };
                        match <[Compiled; 3]>::try_from(ts) {
                            Ok([tx, ty, tz]) => forces.push(Force::Spatial(Force3::Torque {
                                body: b,
                                torque: [tx, ty, tz],
                            })),
                            // planar: one value about the plane's normal (the loader gives
                            // one or three)
                            Err(mut one) => forces.push(Force::Torque {
                                body: b,
                                t: one.remove(0),
                            }),
                        }
                    }
                }
            }
            force_names.extend(std::iter::repeat_n(f.name.clone(), forces.len() - before));
            if let ForceKind::Gravity { .. } = f.kind {
                gravity_names.push(f.name.clone());
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
            (&ground.z, &g.z, "z"),
            (&ground.theta, &g.theta, "theta"),
            (&ground.rx, &g.rx, "rx"),
            (&ground.ry, &g.ry, "ry"),
            (&ground.rz, &g.rz, "rz"),
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
        // A free body's orientation is normalized: it must not be zero.
        for &(k, b) in &quaternions {
            let c: Vec<f64> = initial_coefs[k..k + 4]
                .iter()
                .map(|&i| self.live.coefs[i])
                .collect();
            if c.iter().all(|&x| x == 0.0) {
                let (a, z) = (&b.initial[3].span, &b.initial[6].span);
                failures.push(
                    Diagnostic::new(format!("the orientation of `{}` is zero", b.name))
                        .at(a.start.min(z.start)..a.end.max(z.end))
                        .help("give a quaternion [qw, qx, qy, qz] (normalized when loaded): [1, 0, 0, 0] is the identity"),
                );
            }
        }
        if !failures.is_empty() {
            self.diags = failures;
            return None;
        }
        let nv = model.bodies.iter().map(|b| b.vels.len()).sum();
        // Where each body's velocities start (and its coordinates, in planar models), and
        // the body and direction of each velocity.
        let offsets: Vec<usize> = (0..model.bodies.len())
            .map(|i| self.body_voffset(i))
            .collect();
        let mut coord_body = Vec::with_capacity(nv);
        for (k, b) in model.bodies.iter().enumerate() {
            coord_body.extend((0..b.vels.len()).map(|d| (k, d)));
        }
        let geoms3: Vec<Geom3> = if model.spatial {
            model
                .bodies
                .iter()
                .enumerate()
                .map(|(i, b)| Geom3 {
                    offset: self.body_offset(i),
                    voff: self.body_voffset(i),
                    axes: match &b.kind {
                        BodyKind::Spatial { axes } => axes.clone(),
                        BodyKind::Planar | BodyKind::Free => Vec::new(),
                    },
                    free: b.kind == BodyKind::Free,
                })
                .collect()
        } else {
            Vec::new()
        };
        let nrot = geoms3.iter().map(|g| g.nrot()).collect();
        let trim = self.trim();
        if let Some(t) = trim.as_ref().filter(|t| t.off.is_none()) {
            // the held coordinates are held while the pose is assembled
            for &c in &t.coords {
                initial.fixed[c] = true;
            }
        }
        let mut sys = System {
            spatial: model.spatial,
            geoms3,
            nrot,
            trim,
            elements,
            coordinates: self.coordinates.clone(),
            coordinate_dims,
            velocities: model.velocity_names(),
            velocity_is_rate,
            angle_coords,
            constraint_names: names,
            bodies,
            offsets,
            coord_body,
            constraints,
            blocks: Vec::new(),
            nvals: 0,
            forces,
            force_names,
            gravity_names,
            gravity_coefs,
            gravity: [0.0; 3],
            ground,
            mass_matrix: DMatrix::zeros(nv, nv),
            mass_inv_sqrt: DMatrix::zeros(nv, nv),
            mass_inv_diag: vec![0.0; nv],
            initial,
            initial_coefs,
            velocity_coefs,
            velocity_spans,
            rheonomic,
            forcing: model
                .forcing_frequency
                .as_ref()
                .and_then(|f| model.parameters.index(f)),
            forcing_amplitude: model
                .forcing_amplitude
                .as_ref()
                .and_then(|f| model.parameters.index(f)),
            live: std::mem::take(&mut self.live),
            source: model.source.clone(),
            overrides,
            declared_modes: model
                .modes
                .iter()
                .map(|d| super::DeclaredMode {
                    name: d.name.clone(),
                    shape: d
                        .shape
                        .iter()
                        .filter_map(|(c, x)| {
                            model
                                .velocity_names()
                                .iter()
                                .position(|v| v == c)
                                .map(|i| (i, *x))
                        })
                        .collect(),
                })
                .collect(),
            undamped: false,
        };
        sys.refresh();
        sys.layout();
        if sys.spatial {
            sys.drop_identical_rows();
        }
        if let Some(d) = self.check_inertia(&sys) {
            self.diags.push(d);
            return None;
        }
        Some(sys)
    }

    /// `[trim]` as indices; off (with the parameter that turned it off) when a solved
    /// parameter is given with `--set`.
    fn trim(&self) -> Option<super::Trim> {
        let t = self.model.trim.as_ref()?;
        let params: Vec<usize> = t
            .solve
            .iter()
            .filter_map(|(n, _)| self.model.parameters.index(n))
            .collect();
        let coords: Vec<usize> = t
            .hold
            .iter()
            .filter_map(|(n, _)| self.coordinates.iter().position(|c| c == n))
            .collect();
        let off = t
            .solve
            .iter()
            .find(|(n, _)| self.model.overrides.iter().any(|(o, _)| o == n))
            .map(|(n, _)| n.clone());
        Some(super::Trim {
            params,
            coords,
            off,
            solved: false,
        })
    }

    /// A spatial body's inertia tensor must be positive semi-definite with its principal
    /// values obeying the triangle inequality, and its angles' mass matrix must be
    /// positive definite at the initial guess (a zero principal value is allowed about an
    /// axis the body's angles cannot turn about).
    fn check_inertia(&self, sys: &System) -> Option<Diagnostic> {
        for (b, mb) in sys.bodies.iter().zip(self.model.bodies.iter()) {
            // the number of rotations the body has
            let rotations = match &b.kind {
                BodyKind::Planar => continue,
                BodyKind::Spatial { axes } => axes.len(),
                BodyKind::Free => 3,
            };
            let t = super::spatial::tensor(b.tensor);
            let m = nalgebra::Matrix3::from_fn(|i, j| t[i][j]);
            let ev = m.symmetric_eigenvalues();
            let (mut e0, mut e1, mut e2) = (ev[0], ev[1], ev[2]);
            let scale = e0.abs().max(e1.abs()).max(e2.abs()).max(f64::MIN_POSITIVE);
            let tol = 1e-12 * scale;
            let mut sorted = [e0, e1, e2];
            sorted.sort_by(f64::total_cmp);
            [e0, e1, e2] = sorted;
            let bad = if e0 < -tol {
                Some(format!("has a negative principal value {e0:.6e} kg·m²"))
            } else if rotations == 3 && e0 + e1 < e2 - tol {
                // (a body with fewer angles may be an equivalent element: a gearbox's
                // reflected inertia about its shaft exceeds any rigid body's; its other
                // components do not enter the dynamics)
                Some(format!(
                    "violates the triangle inequality: principal values {e0:.6e}, {e1:.6e}, {e2:.6e} kg·m² (the two smaller must add up to at least the largest)"
                ))
            } else {
                None
            };
            if let Some(why) = bad {
                return Some(
                    Diagnostic::new(format!("the inertia tensor of `{}` {why}", b.name))
                        .at(mb.inertia_span.clone())
                        .help("give the inertia about the CG in the body frame: principal values [Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]"),
                );
            }
            let n = rotations;
            let g = &sys.geoms3[sys.bodies.iter().position(|x| x.name == b.name)?];
            let mut q = sys.initial.q.clone();
            for x in &mut q {
                if !x.is_finite() {
                    *x = 0.0;
                }
            }
            let mut blk = [0.0; 9];
            sys.rotational_mass(b, g, &q, &mut blk);
            let mm = DMatrix::from_row_slice(n, n, &blk[..n * n]);
            let ev = mm.symmetric_eigenvalues();
            let (lo, hi) = ev.iter().fold((f64::INFINITY, 0.0f64), |(l, h), &x| {
                (l.min(x), h.max(x.abs()))
            });
            if !(lo > 1e-12 * hi.max(f64::MIN_POSITIVE)) || hi == 0.0 {
                return Some(
                    Diagnostic::new(format!(
                        "body `{}` has no inertia about an axis its angles turn about (the mass matrix of its angles has eigenvalue {lo:.3e} kg·m² at the initial pose)",
                        b.name
                    ))
                    .at(mb.inertia_span.clone())
                    .help("a zero principal value is allowed only about an axis the body cannot turn about: give that axis some inertia, or drop the angle from `rotation`"),
                );
            }
        }
        None
    }

    /// A spatial joint, its rows all kept (identical ones are dropped later).
    #[allow(clippy::too_many_arguments)]
    fn joint3(
        &mut self,
        j: &crate::model::Joint,
        kind: SpatialJoint,
        axis: &Option<Vec<Field>>,
        axis2: &Option<Vec<Field>>,
        length: &Option<Field>,
        cgs: &[Option<[usize; 3]>],
        unit: UnitCoefs,
    ) -> Option<Joint3> {
        if j.p1.body == j.p2.body {
            let what = if j.p1.body == BodyRef::Ground {
                "the ground to itself".to_string()
            } else {
                "a body to itself".to_string()
            };
            self.diags.push(
                Diagnostic::new(format!("joint `{}` connects {what}", j.name))
                    .at(j.span.clone())
                    .help(
                        "name two different bodies (or a body and \"ground\") in body1 and body2",
                    ),
            );
            return None;
        }
        let a = self.point3(&j.p1, &format!("point1 of joint `{}`", j.name), cgs);
        let b = self.point3(&j.p2, &format!("point2 of joint `{}`", j.name), cgs);
        let f1 = match axis {
            Some(ax) => Some(self.axis3(ax, &format!("the axis of joint `{}`", j.name))?),
            None => None,
        };
        let f2 = match (axis2, f1) {
            (Some(ax), _) => Some(self.axis3(ax, &format!("axis2 of joint `{}`", j.name))?),
            (None, f1) => f1,
        };
        let len = match length {
            Some(l) => Some(self.checked(
                l,
                Dim::LENGTH,
                &format!("the length of joint `{}`", j.name),
                CheckKind::Positive,
            )?),
            None => None,
        };
        let f1 = f1.map(|ax| self.live.axis_frame(ax));
        let f2 = f2.map(|ax| self.live.axis_frame(ax));
        Some(Joint3 {
            kind,
            a: a?,
            b: b?,
            f1,
            f2,
            length: len,
            keep: (0..Joint3::all_rows(kind).len()).collect(),
            unit,
        })
    }
}

impl System {
    /// Constraint row names and the block of A of each constraint element, from the
    /// elements' rows.
    fn layout(&mut self) {
        let mut blocks = Vec::with_capacity(self.constraints.len());
        let mut names = Vec::new();
        let (mut row0, mut val0) = (0, 0);
        for (c, name) in self.constraints.iter().zip(&self.elements) {
            let mut cols: Vec<usize> = c
                .coordinates()
                .into_iter()
                .flat_map(|i| self.coordinate_columns(i))
                .collect();
            for k in c.bodies() {
                cols.extend(self.offsets[k]..self.offsets[k] + self.body_nv(&self.bodies[k]));
            }
            cols.sort_unstable();
            cols.dedup();
            let rows = c.rows();
            match c {
                Constraint::Joint(j) => {
                    names.extend(j.row_names().iter().map(|r| format!("{name}.{r}")))
                }
                Constraint::Spatial(j) => {
                    names.extend(j.row_names().iter().map(|r| format!("{name}.{r}")))
                }
                Constraint::Custom(_) => names.push(name.clone()),
            }
            blocks.push(super::Block {
                row0,
                rows,
                val0,
                cols,
            });
            row0 += rows;
            val0 += rows * blocks.last().map_or(0, |b: &super::Block| b.cols.len());
        }
        self.blocks = blocks;
        self.nvals = val0;
        self.constraint_names = names;
    }

    /// The velocities (columns of A) along which coordinate `i` moves: its rate, or a
    /// free body's three rotations for a quaternion component.
    fn coordinate_columns(&self, i: usize) -> std::ops::Range<usize> {
        let b = self
            .bodies
            .iter()
            .rfind(|b| b.offset <= i)
            .expect("a coordinate belongs to a body");
        let d = i - b.offset;
        if b.kind == BodyKind::Free && d >= 3 {
            b.voff + 3..b.voff + 6
        } else {
            b.voff + d..b.voff + d + 1
        }
    }

    /// Drop the rows of spatial joints that the bodies' own coordinates satisfy
    /// identically: zero, with a zero gradient, at several scattered poses and times (a
    /// revolute between the ground and a body that only turns about its axis keeps its 3
    /// position rows).
    fn drop_identical_rows(&mut self) {
        let n = self.nq();
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut rand = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let samples: Vec<(Vec<f64>, f64)> = (0..4)
            .map(|_| {
                let q: Vec<f64> = (0..n)
                    .map(|i| {
                        if self.is_angle(i) {
                            3.0 * rand()
                        } else {
                            rand()
                        }
                    })
                    .collect();
                (q, 0.37 + rand())
            })
            .collect();
        let mut ws = super::Workspace::new(self);
        let mut identical = vec![true; self.m()];
        for (q, t) in &samples {
            let phi = self.residual(q, *t);
            self.jacobian_blocks(&mut ws, q, *t);
            for b in &self.blocks {
                let nc = b.cols.len();
                for r in 0..b.rows {
                    let row = &ws.vals[b.val0 + r * nc..b.val0 + (r + 1) * nc];
                    let scale = 1.0 + row.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                    if phi[b.row0 + r].abs() > 1e-12 * scale || row.iter().any(|x| x.abs() > 1e-12)
                    {
                        identical[b.row0 + r] = false;
                    }
                }
            }
        }
        let mut changed = false;
        for (c, b) in self.constraints.iter_mut().zip(&self.blocks) {
            if let Constraint::Spatial(j) = c {
                let keep: Vec<usize> = j
                    .keep
                    .iter()
                    .enumerate()
                    .filter(|(r, _)| !identical[b.row0 + r])
                    .map(|(_, &k)| k)
                    .collect();
                changed |= keep.len() != j.keep.len();
                j.keep = keep;
            }
        }
        if changed {
            self.layout();
        }
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
