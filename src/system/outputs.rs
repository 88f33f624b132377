//! Responses: what `simulate`, `sweep` and `frf` report besides the coordinates.
//!
//! A response is named as on the command line (`--response NAME`) and resolved once
//! ([`System::output`]) into an [`Output`], which is then evaluated at each sample from
//! (t, q, v) ([`Probe`]: the accelerations v̇ and the constraint multipliers λ are solved
//! once per sample, and only when a response needs them).
//!
//! * a coordinate, `<body>.<coordinate>` (its value, as before);
//! * a force element: a `spring_damper`'s `<name>.tension` (N), `.elongation` (length −
//!   free length, m) and `.rate` (length rate, m/s); a `torsion`'s `<name>.torque` (N·m),
//!   `.twist` (rad: the rotation of body 1 relative to body 2 about the axis) and
//!   `.twist_rate` (rad/s), as the element computes them;
//! * a named point (`points = { grip = [x, y, z] }` in a body): `<body>.<point>.x` (`y`,
//!   `z`) its world position, `.x_rel` its position in the ground frame (the world
//!   position less the ground's translation, turned into the ground's axes if it turns),
//!   and the time derivatives of either: `.x_dot`, `.x_ddot`, `.x_rel_dot`, `.x_rel_ddot`
//!   (`_rel` rates are the rates seen from the ground frame: d/dt of `x_rel`);
//! * a joint's reaction: `<joint>.force_x` (`force_y`, `force_z`), the force the joint
//!   exerts on its body 1, world components (N): body 1's translational columns of the
//!   joint's rows of Aᵀλ, with λ the multipliers of the Udwadia–Kalaba solution
//!   (M v̇ = f + Aᵀλ). A joint whose body 1 is the ground reports the force on the ground,
//!   the opposite of the force on its body 2. With redundant constraints the split of the
//!   total constraint force between joints is not determined; λ is then the least-squares
//!   multipliers of least norm.
//!
//! Every position-level quantity is written once, generic over the number type, so its
//! time derivatives along the motion come from dual numbers (q + s q̇, t + s) and its
//! linearization for the frequency response ([`System::output_gradient`]) from the same
//! code.

use super::System;
use super::forces::Force;
use super::frame::SysPoint;
use super::joints::Constraint;
use super::spatial::{Force3, SysPoint3};
use crate::diag::{Error, Result};
use crate::request::{Argument, Invalid};
use crate::scalar::{Env, Scalar};
use nalgebra::{DMatrix, DVector};
use num_dual::{Dual2_64, Dual64};

/// What a force element's response reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ForceQuantity {
    /// A spring's tension, N (positive pulls the points together).
    Tension,
    /// A spring's length less its free length, m.
    Elongation,
    /// A spring's length rate, m/s.
    Rate,
    /// A torsion's torque, N·m.
    Torque,
    /// A torsion's twist, rad.
    Twist,
    /// A torsion's twist rate, rad/s.
    TwistRate,
}

impl ForceQuantity {
    fn suffix(self) -> &'static str {
        match self {
            ForceQuantity::Tension => "tension",
            ForceQuantity::Elongation => "elongation",
            ForceQuantity::Rate => "rate",
            ForceQuantity::Torque => "torque",
            ForceQuantity::Twist => "twist",
            ForceQuantity::TwistRate => "twist_rate",
        }
    }
}

const SPRING: [ForceQuantity; 3] = [
    ForceQuantity::Tension,
    ForceQuantity::Elongation,
    ForceQuantity::Rate,
];
const TORSION: [ForceQuantity; 3] = [
    ForceQuantity::Torque,
    ForceQuantity::Twist,
    ForceQuantity::TwistRate,
];

/// A response resolved against a compiled system (indices into it: valid for every copy
/// of the system with other parameter values).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Output {
    /// Coordinate `i` of q.
    Coordinate(usize),
    /// Force element `force` (index among the system's impressed forces).
    Force {
        force: usize,
        quantity: ForceQuantity,
    },
    /// Named point `point` of body `body`: component `axis` (0 = x, 1 = y, 2 = z) of its
    /// position (world, or ground frame when `relative`), or of its `order`-th time
    /// derivative.
    Point {
        body: usize,
        point: usize,
        axis: usize,
        relative: bool,
        order: u8,
    },
    /// The force constraint element `element` (a joint) exerts on its body 1, world
    /// component `axis`.
    Reaction { element: usize, axis: usize },
}

impl Output {
    /// Whether the response needs the accelerations v̇ (solved per sample).
    pub fn needs_accelerations(&self) -> bool {
        matches!(
            self,
            Output::Point { order: 2, .. } | Output::Reaction { .. }
        )
    }

    /// Whether the response needs the constraint multipliers λ.
    pub fn needs_multipliers(&self) -> bool {
        matches!(self, Output::Reaction { .. })
    }

    /// Its SI unit.
    pub fn unit(&self, sys: &System) -> &'static str {
        match *self {
            Output::Coordinate(i) => {
                if sys.is_angle(i) {
                    "rad"
                } else {
                    "m"
                }
            }
            Output::Force { quantity, .. } => match quantity {
                ForceQuantity::Tension => "N",
                ForceQuantity::Elongation => "m",
                ForceQuantity::Rate => "m/s",
                ForceQuantity::Torque => "N*m",
                ForceQuantity::Twist => "rad",
                ForceQuantity::TwistRate => "rad/s",
            },
            Output::Point { order, .. } => ["m", "m/s", "m/s^2"][order as usize],
            Output::Reaction { .. } => "N",
        }
    }

    /// For the linear response: how many time derivatives of the position-level quantity
    /// [`System::output_state`] evaluates the response is (points: `order`; others 0).
    pub fn order(&self) -> u8 {
        match *self {
            Output::Point { order, .. } => order,
            _ => 0,
        }
    }
}

/// What a model's names resolve to as responses, and the help for a name it does not have.
struct Catalog {
    entries: Vec<(String, Output)>,
    /// Each kind of response of this model, described for the help.
    kinds: Vec<String>,
    /// Names of bodies, constraint elements and forces, with what they name.
    heads: Vec<(String, &'static str)>,
    /// Elements that have no response: (name, why).
    silent: Vec<(String, String)>,
}

const POINT_SUFFIXES: [(&str, bool, u8); 6] = [
    ("", false, 0),
    ("_rel", true, 0),
    ("_dot", false, 1),
    ("_ddot", false, 2),
    ("_rel_dot", true, 1),
    ("_rel_ddot", true, 2),
];

impl System {
    /// Resolve a response name (see the module docs): a coordinate, a force element's
    /// quantity, a named point's position and its rates, a joint's reaction.
    pub fn output(&self, name: &str) -> Result<Output> {
        if let Some(i) = self.coordinate_index(name) {
            return Ok(Output::Coordinate(i));
        }
        self.catalog().resolve(name)
    }

    /// Resolve several response names (the model's names are gathered once).
    pub fn outputs(&self, names: &[String]) -> Result<Vec<Output>> {
        let coordinates: Option<Vec<usize>> =
            names.iter().map(|n| self.coordinate_index(n)).collect();
        if let Some(i) = coordinates {
            return Ok(i.into_iter().map(Output::Coordinate).collect());
        }
        let catalog = self.catalog();
        names.iter().map(|n| catalog.resolve(n)).collect()
    }

    /// Every response name of the model, in order (coordinates first).
    pub fn output_names(&self) -> Vec<String> {
        self.catalog().entries.into_iter().map(|e| e.0).collect()
    }

    /// The model's names as responses.
    fn catalog(&self) -> Catalog {
        let mut entries: Vec<(String, Output)> = Vec::new();
        let mut kinds = Vec::new();
        let mut heads: Vec<(String, &'static str)> = Vec::new();
        let mut silent = Vec::new();
        for (i, c) in self.coordinates.iter().enumerate() {
            entries.push((c.clone(), Output::Coordinate(i)));
        }
        kinds.push(format!("coordinates ({})", self.coordinates.join(", ")));
        for b in &self.bodies {
            heads.push((b.name.clone(), "body"));
        }
        // force elements
        for name in &self.gravity_names {
            heads.push((name.clone(), "force"));
            silent.push((name.clone(), "gravity".to_string()));
        }
        let mut described = Vec::new();
        for (k, (name, force)) in self.force_names.iter().zip(&self.forces).enumerate() {
            heads.push((name.clone(), "force"));
            let what = match force {
                Force::Spring { .. } | Force::Spatial(Force3::Spring { .. }) => Some(&SPRING),
                Force::Torsion { .. } | Force::Spatial(Force3::Torsion { .. }) => Some(&TORSION),
                Force::Point { .. } | Force::Spatial(Force3::Point { .. }) => {
                    silent.push((name.clone(), "point_force".to_string()));
                    None
                }
                Force::Torque { .. } | Force::Spatial(Force3::Torque { .. }) => {
                    silent.push((name.clone(), "torque".to_string()));
                    None
                }
            };
            if let Some(list) = what {
                for &quantity in list {
                    entries.push((
                        format!("{name}.{}", quantity.suffix()),
                        Output::Force { force: k, quantity },
                    ));
                }
                let s: Vec<&str> = list.iter().map(|q| q.suffix()).collect();
                described.push(format!("`{name}.{}`", s.join("|")));
            }
        }
        kinds.push(if described.is_empty() {
            "force elements: none in this model (a spring_damper's `<name>.tension|elongation|rate`, a torsion's `<name>.torque|twist|twist_rate`)".into()
        } else {
            format!("force elements {}", described.join(", "))
        });
        // joint reactions
        let axes = if self.spatial { 3 } else { 2 };
        let suffixes = ["force_x", "force_y", "force_z"];
        let mut joints = Vec::new();
        for (e, (name, c)) in self.elements.iter().zip(&self.constraints).enumerate() {
            heads.push((name.clone(), "constraint"));
            if let Constraint::Custom(_) = c {
                silent.push((name.clone(), "custom constraint".to_string()));
                continue;
            }
            for (axis, s) in suffixes.iter().enumerate().take(axes) {
                entries.push((format!("{name}.{s}"), Output::Reaction { element: e, axis }));
            }
            joints.push(name.as_str());
        }
        let list = suffixes[..axes].join("|");
        kinds.push(if joints.is_empty() {
            format!("joint reactions: none in this model (`<joint>.{list}`)")
        } else {
            format!("joint reactions `<joint>.{list}` ({})", joints.join(", "))
        });
        // named points
        let mut points = Vec::new();
        let components = ["x", "y", "z"];
        for (bi, b) in self.bodies.iter().enumerate() {
            for (pi, (pname, _)) in b.points.iter().enumerate() {
                points.push(format!("{}.{pname}", b.name));
                for (axis, c) in components.iter().enumerate().take(axes) {
                    for (s, relative, order) in POINT_SUFFIXES {
                        entries.push((
                            format!("{}.{pname}.{c}{s}", b.name),
                            Output::Point {
                                body: bi,
                                point: pi,
                                axis,
                                relative,
                                order,
                            },
                        ));
                    }
                }
            }
        }
        let list = components[..axes].join("|");
        kinds.push(if points.is_empty() {
            format!(
                "named points `<body>.<point>.{list}` with `_rel`, `_dot`, `_ddot` (none in this model: `points = {{ tip = [...] }}` in a body names one)"
            )
        } else {
            format!(
                "named points `<body>.<point>.{list}` with `_rel`, `_dot`, `_ddot` ({})",
                points.join(", ")
            )
        });
        Catalog {
            entries,
            kinds,
            heads,
            silent,
        }
    }
}

impl Catalog {
    fn resolve(&self, name: &str) -> Result<Output> {
        let found = self.entries.iter().find(|(n, _)| n == name).map(|e| e.1);
        // a coordinate is what it always was, whatever else shares its body's name
        if let Some(o @ Output::Coordinate(_)) = found {
            return Ok(o);
        }
        let head = name.split('.').next().unwrap_or("");
        let named: Vec<&str> = self
            .heads
            .iter()
            .filter(|(n, _)| n == head)
            .map(|(_, k)| *k)
            .collect();
        if named.len() > 1 {
            let what = if named[0] == named[1] {
                format!("two {}s", named[0])
            } else {
                format!("a {} and a {}", named[0], named[1])
            };
            return Err(Error::request(
                format!(
                    "the response `{name}`: `{head}` names {what} of this model, so responses named after it are ambiguous"
                ),
                "give bodies, joints, constraints and forces different names in the model file",
            ));
        }
        if let Some(o) = found {
            return Ok(o);
        }
        if name.contains('.')
            && let Some((_, why)) = self.silent.iter().find(|(n, _)| n == head)
        {
            return Err(Error::request(
                format!("the response `{name}`: `{head}` is a {why}, which reports no response"),
                "responses of elements: a spring_damper's `<name>.tension|elongation|rate`, a torsion's `<name>.torque|twist|twist_rate`, a joint's `<name>.force_x|force_y|force_z`",
            ));
        }
        Err(Invalid::UnknownResponse {
            argument: Argument::Response,
            name: name.to_string(),
            known: self.entries.iter().map(|e| e.0.clone()).collect(),
            kinds: self.kinds.clone(),
        }
        .into())
    }
}

impl System {
    /// The position-level quantity behind a response as a function of (q, v, t), in any
    /// number type: a point's position (world or ground frame), a force element's
    /// quantity, a coordinate. (A point's rates are its time derivatives, see
    /// [`Output::order`]; a reaction is not a function of the state alone: NaN.)
    pub fn output_state<D: Scalar>(&self, o: &Output, q: &[D], v: &[D], t: D) -> D {
        match *o {
            Output::Coordinate(i) => q[i],
            Output::Force { force, quantity } => self.force_quantity(force, quantity, q, v, t),
            Output::Point {
                body,
                point,
                axis,
                relative,
                ..
            } => self.point_position(body, point, axis, relative, q, t),
            Output::Reaction { .. } => D::from(f64::NAN),
        }
    }

    /// A named point's position component at (q, t): in the world, or in the ground frame.
    fn point_position<D: Scalar>(
        &self,
        body: usize,
        point: usize,
        axis: usize,
        relative: bool,
        q: &[D],
        t: D,
    ) -> D {
        let b = &self.bodies[body];
        let c = &b.points[point].1;
        self.with_frames(q, t, self.env(), |fr| {
            if self.spatial {
                let pt = SysPoint3 {
                    body: Some(body),
                    p: [c[0], c[1], c[2]],
                    cg: b.cg,
                };
                let p = fr.position3(&pt);
                if !relative {
                    return p[axis];
                }
                // Rᵀ (p − r_g) in the ground's axes (R = I when it does not turn)
                let d = crate::system::spatial::sub(p, fr.ground.r);
                match fr.ground.rotation3() {
                    Some(r) => crate::system::spatial::mat_t_vec(r, d)[axis],
                    None => d[axis],
                }
            } else {
                let pt = SysPoint {
                    body: Some(body),
                    p: [c[0], c[1]],
                };
                let p = fr.position(&pt);
                if !relative {
                    return p[axis];
                }
                let d = [p[0] - fr.ground.r[0], p[1] - fr.ground.r[1]];
                let (s, co) = fr.ground.angle().sin_cos();
                // Rᵀ d
                if axis == 0 {
                    co * d[0] + s * d[1]
                } else {
                    co * d[1] - s * d[0]
                }
            }
        })
    }

    /// A force element's quantity at (q, v, t) (NaN where it is undefined: a spring of
    /// zero length).
    fn force_quantity<D: Scalar>(
        &self,
        force: usize,
        quantity: ForceQuantity,
        q: &[D],
        v: &[D],
        t: D,
    ) -> D {
        let env = self.env();
        // an undamped system's loads are those at rest (the rates stay the motion's)
        let load_only = matches!(quantity, ForceQuantity::Tension | ForceQuantity::Torque);
        let still = if self.is_undamped() && load_only {
            vec![D::from(0.0); v.len()]
        } else {
            Vec::new()
        };
        let v = if still.is_empty() { v } else { &still[..] };
        self.with_frames(q, t, env, |fr| {
            let nan = D::from(f64::NAN);
            let e = fr.env;
            let (stretch, rate, load, free) = match &self.forces[force] {
                Force::Spring { l0, .. } => {
                    let Some((len, rate, tension, _)) = self.forces[force].spring_state(fr, v)
                    else {
                        return nan;
                    };
                    (len, rate, tension, e.coef(*l0))
                }
                Force::Spatial(f) => {
                    let Some(s) = f.state(fr, v) else {
                        return nan;
                    };
                    let free = match f {
                        Force3::Spring { l0, .. } => Env::<D>::coef(e, *l0),
                        _ => D::from(0.0),
                    };
                    (s.stretch, s.rate, s.load, free)
                }
                Force::Torsion { .. } => {
                    let Some((twist, rate, torque)) = self.forces[force].torsion_state(fr, v)
                    else {
                        return nan;
                    };
                    (twist, rate, torque, D::from(0.0))
                }
                Force::Point { .. } | Force::Torque { .. } => return nan,
            };
            match quantity {
                ForceQuantity::Tension | ForceQuantity::Torque => load,
                ForceQuantity::Elongation => stretch - free,
                ForceQuantity::Twist => stretch,
                ForceQuantity::Rate | ForceQuantity::TwistRate => rate,
            }
        })
    }

    /// The linearization of a response's position-level quantity
    /// ([`System::output_state`]) at (q, v = 0, t): (∂h/∂q, ∂h/∂v), by dual numbers.
    pub fn output_gradient(&self, o: &Output, q: &[f64], t: f64) -> (Vec<f64>, Vec<f64>) {
        let n = self.nq();
        let mut qd: Vec<Dual64> = q.iter().map(|&x| Dual64::from(x)).collect();
        let mut vd = vec![Dual64::from(0.0); self.nv()];
        let td = Dual64::from(t);
        let mut hq = vec![0.0; n];
        let mut hv = vec![0.0; self.nv()];
        for j in 0..n {
            qd[j].eps = 1.0;
            hq[j] = self.output_state(o, &qd, &vd, td).eps;
            qd[j].eps = 0.0;
        }
        if matches!(o, Output::Force { .. }) {
            for j in 0..self.nv() {
                vd[j].eps = 1.0;
                hv[j] = self.output_state(o, &qd, &vd, td).eps;
                vd[j].eps = 0.0;
            }
        }
        (hq, hv)
    }

    /// A response's value at (t, q, v), with the accelerations v̇ and the total constraint
    /// force per element where it needs them (see [`Probe`], which solves them).
    pub fn output_value(
        &self,
        o: &Output,
        t: f64,
        q: &[f64],
        v: &[f64],
        vdot: Option<&[f64]>,
        multipliers: Option<&[f64]>,
    ) -> f64 {
        match *o {
            Output::Point { order: 0, .. } | Output::Force { .. } | Output::Coordinate(_) => {
                self.output_state(o, q, v, t)
            }
            Output::Point { order: 1, .. } => {
                // d/dt along the motion: q + s q̇, t + s
                let mut qdot = vec![0.0; self.nq()];
                self.qdot(q, v, &mut qdot);
                let qd: Vec<Dual64> = q
                    .iter()
                    .zip(&qdot)
                    .map(|(&x, &d)| Dual64::new(x, d))
                    .collect();
                let vd: Vec<Dual64> = v.iter().map(|&x| Dual64::from(x)).collect();
                self.output_state(o, &qd, &vd, Dual64::new(t, 1.0)).eps
            }
            Output::Point { .. } => {
                // d²/dt² along the motion: q + s q̇ + s²/2 q̈ (q̇ = v for every body kind
                // so far, so q̈ = v̇)
                let Some(vdot) = vdot else {
                    return f64::NAN;
                };
                let mut qdot = vec![0.0; self.nq()];
                self.qdot(q, v, &mut qdot);
                let q2: Vec<Dual2_64> = q
                    .iter()
                    .zip(&qdot)
                    .zip(vdot)
                    .map(|((&x, &d), &a)| Dual2_64::new(x, d, a))
                    .collect();
                let v2: Vec<Dual2_64> = v.iter().map(|&x| Dual2_64::from(x)).collect();
                self.output_state(o, &q2, &v2, Dual2_64::new(t, 1.0, 0.0))
                    .v2
            }
            Output::Reaction { element, axis } => {
                let Some(lambda) = multipliers else {
                    return f64::NAN;
                };
                self.reaction(element, axis, q, t, lambda)
            }
        }
    }

    /// The force constraint element `e` exerts on its body 1 (world component `axis`) for
    /// multipliers λ: body 1's translational columns of the element's rows of Aᵀλ (the
    /// opposite of body 2's when body 1 is the ground).
    pub fn reaction(&self, e: usize, axis: usize, q: &[f64], t: f64, lambda: &[f64]) -> f64 {
        let Some((col, sign)) = self.reaction_column(e, axis) else {
            return f64::NAN;
        };
        let blk = &self.blocks[e];
        // ∂Φ_rows/∂q_col by one dual pass of the element alone
        let mut qd: Vec<Dual64> = q.iter().map(|&x| Dual64::from(x)).collect();
        qd[col].eps = 1.0;
        let mut out = vec![Dual64::from(0.0); blk.rows];
        let c = &self.constraints[e];
        self.with_frames(&qd, Dual64::from(t), self.env(), |fr| {
            c.phi(fr, Dual64::from(t), &mut out)
        });
        sign * (0..blk.rows)
            .map(|r| out[r].eps * lambda[blk.row0 + r])
            .sum::<f64>()
    }
}

impl System {
    /// The column of A along which joint `e`'s reaction (world component `axis`) is
    /// measured, body 1's translation, and its sign (−1 when body 1 is the ground: the
    /// force on body 2, reversed). None for a custom constraint.
    fn reaction_column(&self, e: usize, axis: usize) -> Option<(usize, f64)> {
        let (b1, b2) = match &self.constraints[e] {
            Constraint::Joint(j) => (j.a.body, j.b.body),
            Constraint::Spatial(j) => (j.a.body, j.b.body),
            Constraint::Custom(_) => return None,
        };
        let (body, sign) = match (b1, b2) {
            (Some(k), _) => (k, 1.0),
            (None, Some(k)) => (k, -1.0),
            (None, None) => return None,
        };
        Some((self.bodies[body].offset + axis, sign))
    }

    /// The first-order change of a joint reaction ([`System::reaction`]) for changes δλ of
    /// the multipliers (all m rows) and δq of the coordinates: Bᵀ δλ + (∂B/∂q · δq)ᵀ λ, B
    /// the element's rows' derivatives along body 1's translation, by hyper-dual numbers
    /// (ε₁ on the translation, ε₂ along δq). Linear in (δλ, δq): a complex amplitude is
    /// its real and imaginary parts, each through this.
    #[allow(clippy::too_many_arguments)]
    pub fn reaction_variation(
        &self,
        e: usize,
        axis: usize,
        q: &[f64],
        t: f64,
        lambda: &[f64],
        dlambda: &[f64],
        dq: &[f64],
    ) -> f64 {
        use num_dual::HyperDual64;
        let Some((col, sign)) = self.reaction_column(e, axis) else {
            return f64::NAN;
        };
        let blk = &self.blocks[e];
        let qh: Vec<HyperDual64> = q
            .iter()
            .enumerate()
            .map(|(j, &x)| HyperDual64::new(x, if j == col { 1.0 } else { 0.0 }, dq[j], 0.0))
            .collect();
        let mut out = vec![HyperDual64::from(0.0); blk.rows];
        let c = &self.constraints[e];
        let th = HyperDual64::from(t);
        self.with_frames(&qh, th, self.env(), |fr| c.phi(fr, th, &mut out));
        sign * (0..blk.rows)
            .map(|r| out[r].eps1 * dlambda[blk.row0 + r] + out[r].eps1eps2 * lambda[blk.row0 + r])
            .sum::<f64>()
    }
}

/// Evaluates responses at samples (t, q, v): solves the accelerations and the constraint
/// multipliers once per sample, only when a response needs them.
#[derive(Debug, Clone)]
pub struct Probe {
    outputs: Vec<Output>,
    /// Every response a coordinate: read from q.
    coordinates: Option<Vec<usize>>,
    dynamics: Option<Box<crate::dynamics::DynWorkspace>>,
    vdot: Vec<f64>,
    lambda: Vec<f64>,
}

impl Probe {
    pub fn new(sys: &System, outputs: Vec<Output>) -> Probe {
        let coordinates = outputs
            .iter()
            .map(|o| match o {
                Output::Coordinate(i) => Some(*i),
                _ => None,
            })
            .collect();
        let dynamics = outputs
            .iter()
            .any(|o| o.needs_accelerations())
            .then(|| Box::new(crate::dynamics::DynWorkspace::new(sys)));
        Probe {
            outputs,
            coordinates,
            dynamics,
            vdot: vec![0.0; sys.nv()],
            lambda: vec![0.0; sys.m()],
        }
    }

    pub fn outputs(&self) -> &[Output] {
        &self.outputs
    }

    /// The responses at (t, q, v) into `out` (one per output).
    pub fn eval(&mut self, sys: &System, t: f64, q: &[f64], v: &[f64], out: &mut [f64]) {
        if let Some(c) = &self.coordinates {
            for (o, &i) in out.iter_mut().zip(c) {
                *o = q[i];
            }
            return;
        }
        let mut vdot = None;
        let mut lambda = None;
        if let Some(ws) = self.dynamics.as_deref_mut() {
            crate::dynamics::accelerations(sys, ws, q, v, t, &mut self.vdot);
            vdot = Some(&self.vdot[..]);
            if self.outputs.iter().any(|o| o.needs_multipliers()) {
                multipliers(sys, ws, t, q, v, &self.vdot, &mut self.lambda);
                lambda = Some(&self.lambda[..]);
            }
        }
        for (x, o) in out.iter_mut().zip(&self.outputs) {
            *x = sys.output_value(o, t, q, v, vdot, lambda);
        }
    }

    /// The responses at (t, q, v).
    pub fn values(&mut self, sys: &System, t: f64, q: &[f64], v: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.outputs.len()];
        self.eval(sys, t, q, v, &mut out);
        out
    }
}

/// The multipliers λ (m) with Aᵀλ = M v̇ − f (the total constraint force), least squares
/// of least norm: unique when A has full row rank.
fn multipliers(
    sys: &System,
    ws: &mut crate::dynamics::DynWorkspace,
    t: f64,
    q: &[f64],
    v: &[f64],
    vdot: &[f64],
    lambda: &mut [f64],
) {
    if sys.m() == 0 {
        return;
    }
    sys.jacobian(&mut ws.sys, q, t, &mut ws.a);
    let mut f = vec![0.0; sys.nv()];
    sys.forces(q, v, t, &mut f);
    let qc = sys.mass_matrix_at(q) * DVector::from_column_slice(vdot) - DVector::from_vec(f);
    let a: &DMatrix<f64> = &ws.a;
    let gram = a * a.transpose();
    let scale = gram.diagonal().max();
    let rhs = a * &qc;
    if let Some(ch) = gram.clone().cholesky() {
        let l = ch.l_dirty();
        let min_pivot = (0..gram.nrows())
            .map(|i| l[(i, i)] * l[(i, i)])
            .fold(f64::INFINITY, f64::min);
        if min_pivot > crate::linalg::CHOL_TOL * scale {
            lambda.copy_from_slice(ch.solve(&rhs).as_slice());
            return;
        }
    }
    let l = crate::linalg::solve_least_squares(a.transpose(), &qc);
    lambda.copy_from_slice(l.as_slice());
}
