//! The compiled equations of a model: constraint function Φ(q, t), its Jacobian A and
//! bias b by automatic differentiation, mass matrix M and impressed forces f(q, v, t),
//! with live parameters.
//!
//! Everything here is generic over the number type and over where parameter values come
//! from ([`Env`]): the constraint function is written once over any [`Scalar`], so
//!
//! * `A = ∂Φ/∂q` comes from one `Dual64` pass per coordinate (column j: seed `q_j + ε`;
//!   in general the derivative along tangent direction j, `q ⊕ ε e_j`; a planar joint's
//!   columns are written out in the pass's order of operations, to the same bits:
//!   [`joints::Joint::column`]),
//! * `b = −d²/ds² Φ(q ⊕ s·v, t + s)|s=0` from one `Dual2_64` pass along the motion
//!   (a planar joint's rows with a still ground replay its second parts in f64, to the
//!   same bits: [`joints`]),
//! * `∂Φ/∂p`, `∂f/∂p` from one pass with the parameter seeded ([`System::seeded`]).
//!
//! Parameters stay live: [`System::set_param`] changes one without recompiling (a sweep's
//! frequency, a continuation's parameter), and everything defined from it follows.
//!
//! Planar bodies have `q = (x, y, θ)` of the centre of gravity and `v = q̇`; spatial bodies
//! with a sequence of angles likewise. A free body (a unit quaternion) has 7 coordinates
//! and 6 velocities (see [`spatial`]): q has nq entries, v and the columns of A nv, and
//! every step in q goes through [`System::retract`].
//!
//! Layout: [`compile`] turns a model into a system, [`live`] holds the parameters and
//! element coefficients, [`frame`] the frames and points (and the moving ground),
//! [`joints`] and [`forces`] the elements.

mod compile;
pub mod forces;
pub mod frame;
pub mod inspect;
pub mod joints;
pub mod live;
pub mod outputs;
pub mod spatial;

use crate::diag::{Error, Result, SourceFile};
use crate::model::BodyKind;
use crate::model::units::Dim;
use crate::scalar::{Env, Plain, Scalar};
use frame::{Frames, GroundMotion, GroundPose, Pose, with_poses, with_poses3};
use nalgebra::{DMatrix, DVector};
use num_dual::{Dual2_64, Dual64};
use spatial::{Geom3, Pose3};

/// A compiled body.
#[derive(Debug, Clone)]
pub struct SysBody {
    pub name: String,
    pub kind: BodyKind,
    /// Index of the body's first coordinate in q.
    pub offset: usize,
    /// Index of the body's first velocity in v (= `offset` unless a free body precedes).
    pub voff: usize,
    /// kg (current value).
    pub mass: f64,
    /// Centroidal moment of inertia, kg·m² (current value; planar bodies).
    pub inertia: f64,
    /// Spatial bodies: the inertia tensor about the CG in the body frame, `Ixx, Iyy, Izz,
    /// Ixy, Ixz, Iyz` (kg·m², current values).
    pub tensor: [f64; 6],
    /// Coefficient indices of mass and inertia (planar: 1, spatial: 6).
    mass_coef: usize,
    inertia_coefs: Vec<usize>,
    /// Spatial bodies: the CG in the body frame (coefficients).
    pub cg: Option<[usize; 3]>,
    /// Named points (body frame from the frame's origin; coefficients).
    pub points: Vec<(String, Vec<usize>)>,
}

/// The rows of one constraint element and the coordinates (columns of A) it depends
/// on: A is stored by blocks, so its cost grows with the number of elements, not with
/// its size.
#[derive(Debug, Clone)]
pub struct Block {
    /// First row and number of rows.
    pub row0: usize,
    pub rows: usize,
    /// Columns, ascending.
    pub cols: Vec<usize>,
    /// Index of the block's first value in the values (row-major, rows × cols).
    pub val0: usize,
}

/// Parameters solved so that held coordinates are a static equilibrium (`[trim]`).
#[derive(Debug, Clone)]
pub struct Trim {
    pub params: Vec<usize>,
    pub coords: Vec<usize>,
    /// The parameter given with `--set` that turned the trim off, if any.
    pub off: Option<String>,
    /// Whether the solved parameters hold their trimmed values (set by
    /// `statics::trim::trimmed`).
    pub solved: bool,
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

/// An angle in (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    let r = a.rem_euclid(tau);
    if r > std::f64::consts::PI { r - tau } else { r }
}

/// Compiled equations of motion of one model, with live parameters.
#[derive(Debug, Clone)]
pub struct System {
    /// `<body>.<coordinate>` for each entry of q.
    pub coordinates: Vec<String>,
    /// The dimension of each coordinate (length, or angle and quaternion: none).
    pub coordinate_dims: Vec<Dim>,
    /// `<body>.<velocity>` for each entry of v: the coordinate's name where the velocity
    /// is its rate (planar bodies, angle sequences), `b.vx` ... `b.wz` for a free body.
    pub velocities: Vec<String>,
    /// Whether each velocity is its coordinate's rate (every body but a free one).
    velocity_is_rate: Vec<bool>,
    /// Whether each coordinate is an angle (a quaternion component is not).
    angle_coords: Vec<bool>,
    /// One name per constraint row (`joint.x`, `constraint2`, ...).
    pub constraint_names: Vec<String>,
    pub bodies: Vec<SysBody>,
    /// Velocity offset of each body (its first column of A, its first generalized force;
    /// also its first coordinate in planar models).
    offsets: Vec<usize>,
    /// For each velocity (tangent direction, column of A): its body and direction
    /// (planar: 0 = x, 1 = y, 2 = θ; spatial: 0..3 the CG, then the rotations).
    coord_body: Vec<(usize, usize)>,
    constraints: Vec<joints::Constraint>,
    /// The block of A of each constraint element.
    blocks: Vec<Block>,
    /// Number of values of A stored by blocks.
    nvals: usize,
    forces: Vec<forces::Force>,
    /// The name of each force element (the model's `[[forces]]` other than gravity, in
    /// order), and of the gravity tables.
    pub force_names: Vec<String>,
    pub gravity_names: Vec<String>,
    /// Gravity entries (coefficients, m/s²; planar: the third is 0), summed.
    gravity_coefs: Vec<[usize; 3]>,
    /// Gravitational acceleration, m/s² (current value; planar: z = 0).
    pub gravity: [f64; 3],
    /// Whether the model is spatial.
    pub spatial: bool,
    /// Parameters solved for a datum (`[trim]`).
    pub trim: Option<Trim>,
    /// The name of each constraint element (joint or custom constraint).
    elements: Vec<String>,
    /// Spatial bodies' rotation sequences (empty in planar models).
    geoms3: Vec<Geom3>,
    /// Spatial bodies' number of angles (empty in planar models).
    nrot: Vec<usize>,
    /// The ground's prescribed motion (none: fixed).
    pub ground: GroundMotion,
    /// Mass matrix M (nv × nv), constant for planar bodies (spatial angle sequences: its
    /// diagonal at zero angles, a weighting only; see [`System::mass_matrix_at`]).
    pub mass_matrix: DMatrix<f64>,
    /// M^-½ (nv × nv).
    pub mass_inv_sqrt: DMatrix<f64>,
    /// The inverse of M's diagonal (planar bodies: 1/m, 1/m, 1/I).
    pub mass_inv_diag: Vec<f64>,
    pub initial: InitialGuess,
    /// Coefficients of the initial coordinates and of the given velocities.
    initial_coefs: Vec<usize>,
    velocity_coefs: Vec<Option<usize>>,
    /// Where each given initial velocity is written in the model file (by velocity).
    velocity_spans: Vec<Option<std::ops::Range<usize>>>,
    /// Whether any constraint depends on time explicitly (a custom constraint in `t`, or
    /// a moving ground).
    pub rheonomic: bool,
    /// The parameter that is the harmonic forcing's angular frequency.
    forcing: Option<usize>,
    /// The parameter that is the harmonic forcing's amplitude (`[model] forcing_amplitude`).
    forcing_amplitude: Option<usize>,
    live: live::Live,
    /// The model file, for located messages when a parameter change is refused.
    source: SourceFile,
    /// The user's `--set`s, quoted in such messages.
    overrides: String,
    /// The model's named modes (`[[modes]]`), their shapes by velocity index.
    pub declared_modes: Vec<DeclaredMode>,
    /// Every impressed force element evaluated at rest (see [`System::undamped`]).
    undamped: bool,
}

/// A mode the model file names (`[[modes]]`): what the analyses match by MAC.
#[derive(Debug, Clone, PartialEq)]
pub struct DeclaredMode {
    pub name: String,
    /// `(velocity index, value)` for each coordinate the shape gives.
    pub shape: Vec<(usize, f64)>,
}

/// Scratch buffers for one thread of evaluation.
#[derive(Debug, Clone)]
pub struct Workspace {
    qd: Vec<Dual64>,
    phid: Vec<Dual64>,
    q2: Vec<Dual2_64>,
    phi2: Vec<Dual2_64>,
    pose_f: Vec<Pose<f64>>,
    pose_d: Vec<Pose<Dual64>>,
    pose_2: Vec<Pose<Dual2_64>>,
    pose3_f: Vec<Pose3<f64>>,
    pose3_d: Vec<Pose3<Dual64>>,
    pose3_2: Vec<Pose3<Dual2_64>>,
    /// The values of A by blocks (see [`System::blocks`]).
    pub vals: Vec<f64>,
}

impl Workspace {
    pub fn new(sys: &System) -> Self {
        let n = sys.nq();
        let m = sys.m();
        let nb = sys.offsets.len();
        let nb3 = sys.geoms3.len();
        Workspace {
            pose3_f: vec![Pose3::zero(); nb3],
            pose3_d: vec![Pose3::zero(); nb3],
            pose3_2: vec![Pose3::zero(); nb3],
            qd: vec![Dual64::from(0.0); n],
            phid: vec![Dual64::from(0.0); m],
            q2: vec![Dual2_64::from(0.0); n],
            phi2: vec![Dual2_64::from(0.0); m],
            pose_f: vec![Pose::zero(); nb - nb3.min(nb)],
            pose_d: vec![Pose::zero(); nb - nb3.min(nb)],
            pose_2: vec![Pose::zero(); nb - nb3.min(nb)],
            vals: vec![0.0; sys.nvals],
        }
    }
}

impl System {
    /// Number of coordinates q (= velocities, unless the model has a free body: see
    /// [`System::nq`], [`System::nv`]).
    pub fn n(&self) -> usize {
        self.coordinates.len()
    }
    /// Number of constraint rows.
    pub fn m(&self) -> usize {
        self.constraint_names.len()
    }

    /// Number of configuration coordinates q.
    pub fn nq(&self) -> usize {
        self.coordinates.len()
    }

    /// Number of velocities v: the dimension of the tangent space, the columns of A. (A
    /// planar body has q = v-rates; a free body, with a unit quaternion, has 7
    /// coordinates and 6 velocities.) Every analysis steps through [`System::retract`],
    /// so it holds for either.
    pub fn nv(&self) -> usize {
        self.velocities.len()
    }

    /// Whether any body is free (a unit quaternion: nq ≠ nv).
    pub fn has_free_bodies(&self) -> bool {
        self.bodies.iter().any(|b| b.kind == BodyKind::Free)
    }

    /// Refuse a model with free bodies in `what`: the analyses that still differentiate
    /// with respect to the coordinates themselves (statics' second derivatives, the
    /// linearization) are not written along the retraction yet.
    pub fn refuse_free_bodies(&self, what: &str) -> Result<()> {
        match self.bodies.iter().find(|b| b.kind == BodyKind::Free) {
            Some(b) => Err(Error::request(
                format!(
                    "{what} of free bodies not supported yet (body `{}` has `rotation = \"free\"`)",
                    b.name
                ),
                "simulate the model, or describe the body's orientation by a rotation sequence (`rotation = [[\"z\", \"a\"], [\"x\", \"b\"], [\"z\", \"c\"]]`) away from its singular poses",
            )),
            None => Ok(()),
        }
    }

    /// q ⊕ s·δ in place: the configuration reached from q along the tangent δ (nv) by
    /// s. Planar bodies and angle sequences: q + s·δ; a free body's quaternion:
    /// `q ⊗ exp(s δ_ω)`, normalized. Newton updates, projections and predictors step
    /// through this, never by adding to q.
    pub fn retract(&self, q: &mut [f64], delta: &[f64], s: f64) {
        for b in &self.bodies {
            let (o, vo) = (b.offset, b.voff);
            match b.kind {
                BodyKind::Planar | BodyKind::Spatial { .. } => {
                    for i in 0..self.body_nv(b) {
                        q[o + i] += s * delta[vo + i];
                    }
                }
                BodyKind::Free => {
                    for i in 0..3 {
                        q[o + i] += s * delta[vo + i];
                    }
                    let d = [0, 1, 2].map(|i| s * delta[vo + 3 + i]);
                    let r = spatial::quat_normalize(spatial::quat_mul(
                        quat_at(q, o + 3),
                        spatial::quat_exp(d),
                    ));
                    q[o + 3..o + 7].copy_from_slice(&r);
                }
            }
        }
    }

    /// The tangent δ (nv) with q0 ⊕ δ = q1, for q1 near q0 (planar bodies: q1 − q0; a
    /// free body's rotation: `log(q0⁻¹ ⊗ q1)`, the shorter way).
    pub fn difference(&self, q1: &[f64], q0: &[f64], out: &mut [f64]) {
        for b in &self.bodies {
            let (o, vo) = (b.offset, b.voff);
            match b.kind {
                BodyKind::Planar | BodyKind::Spatial { .. } => {
                    for i in 0..self.body_nv(b) {
                        out[vo + i] = q1[o + i] - q0[o + i];
                    }
                }
                BodyKind::Free => {
                    for i in 0..3 {
                        out[vo + i] = q1[o + i] - q0[o + i];
                    }
                    let a = spatial::quat_normalize(quat_at(q0, o + 3));
                    let c = spatial::quat_normalize(quat_at(q1, o + 3));
                    let rel = spatial::quat_mul([a[0], -a[1], -a[2], -a[3]], c);
                    out[vo + 3..vo + 6].copy_from_slice(&spatial::quat_log(rel));
                }
            }
        }
    }

    /// A tangent (a [`System::difference`]) with its angle components taken modulo 2π
    /// into (−π, π]: the angles of planar bodies and of spatial bodies turning by a
    /// sequence of angles (their tangent components are their coordinates' differences);
    /// a free body's rotation vector is already the shortest (the quaternion logarithm).
    pub fn wrap_angles(&self, d: &mut [f64]) {
        for b in &self.bodies {
            if let BodyKind::Planar | BodyKind::Spatial { .. } = b.kind {
                for i in 0..self.body_nv(b) {
                    if self.is_angle(b.offset + i) {
                        d[b.voff + i] = wrap_angle(d[b.voff + i]);
                    }
                }
            }
        }
    }

    /// q̇ = N(q) v (nq): how the coordinates move with the velocities (planar: q̇ = v; a
    /// free body's quaternion: `q̇ = ½ q ⊗ (0, ω_b)`).
    pub fn qdot(&self, q: &[f64], v: &[f64], out: &mut [f64]) {
        for b in &self.bodies {
            let (o, vo) = (b.offset, b.voff);
            match b.kind {
                BodyKind::Planar | BodyKind::Spatial { .. } => {
                    let n = self.body_nv(b);
                    out[o..o + n].copy_from_slice(&v[vo..vo + n]);
                }
                BodyKind::Free => {
                    out[o..o + 3].copy_from_slice(&v[vo..vo + 3]);
                    let w = [v[vo + 3], v[vo + 4], v[vo + 5]];
                    out[o + 3..o + 7].copy_from_slice(&spatial::quat_rate(quat_at(q, o + 3), w));
                }
            }
        }
    }

    /// The largest |1 − |q|| of the free bodies' quaternions in q (0 without any).
    pub fn norm_drift(&self, q: &[f64]) -> f64 {
        let mut worst = 0.0f64;
        for b in self.bodies.iter().filter(|b| b.kind == BodyKind::Free) {
            let o = b.offset + 3;
            let n = q[o..o + 4].iter().map(|x| x * x).sum::<f64>().sqrt();
            worst = crate::linalg::amax(&[worst, 1.0 - n]);
        }
        worst
    }

    /// Normalize every free body's quaternion in q; returns the largest |1 − |q|| found
    /// (0 without free bodies). R does not depend on the norm (see
    /// [`spatial::Pose3::from_quat`]): this only keeps the coordinates tidy.
    pub fn normalize(&self, q: &mut [f64]) -> f64 {
        let mut worst = 0.0f64;
        for b in self.bodies.iter().filter(|b| b.kind == BodyKind::Free) {
            let o = b.offset + 3;
            let n = q[o..o + 4].iter().map(|x| x * x).sum::<f64>().sqrt();
            worst = crate::linalg::amax(&[worst, 1.0 - n]);
            for x in &mut q[o..o + 4] {
                *x /= n;
            }
        }
        worst
    }

    /// The coordinates (indices into q) that are held during assembly, and the tangent
    /// directions (indices into v) they hold: a free body's orientation holds its three
    /// rotations (and its four quaternion components).
    pub fn held(&self) -> (Vec<usize>, Vec<bool>) {
        let fixed = &self.initial.fixed;
        let coords = (0..self.nq()).filter(|&i| fixed[i]).collect();
        let mut tangent = vec![false; self.nv()];
        for b in &self.bodies {
            match b.kind {
                BodyKind::Planar | BodyKind::Spatial { .. } => {
                    for i in 0..self.body_nv(b) {
                        tangent[b.voff + i] = fixed[b.offset + i];
                    }
                }
                BodyKind::Free => {
                    for i in 0..3 {
                        tangent[b.voff + i] = fixed[b.offset + i];
                    }
                    tangent[b.voff + 3..b.voff + 6].fill(fixed[b.offset + 3]);
                }
            }
        }
        (coords, tangent)
    }

    /// Number of coordinates of a body.
    fn body_nq(&self, b: &SysBody) -> usize {
        match &b.kind {
            BodyKind::Planar => 3,
            BodyKind::Spatial { axes } => 3 + axes.len(),
            BodyKind::Free => 7,
        }
    }

    /// Number of velocities of a body.
    fn body_nv(&self, b: &SysBody) -> usize {
        match &b.kind {
            BodyKind::Free => 6,
            _ => self.body_nq(b),
        }
    }

    /// Index of a velocity by name.
    pub fn velocity_index(&self, name: &str) -> Option<usize> {
        self.velocities.iter().position(|c| c == name)
    }

    /// The trajectory CSV's velocity columns: `<coordinate>_dot` for a coordinate's
    /// rate, the velocity's name otherwise (`b.wx`).
    pub fn velocity_columns(&self) -> Vec<String> {
        self.velocities
            .iter()
            .zip(&self.velocity_is_rate)
            .map(|(c, &rate)| if rate { format!("{c}_dot") } else { c.clone() })
            .collect()
    }

    /// The spatial bodies' rotation sequences (empty in planar models).
    pub fn geoms3(&self) -> &[Geom3] {
        &self.geoms3
    }

    /// Index of a coordinate by name.
    pub fn coordinate_index(&self, name: &str) -> Option<usize> {
        self.coordinates.iter().position(|c| c == name)
    }

    /// Per coordinate, whether it is an angle (rad).
    pub fn angles(&self) -> Vec<bool> {
        (0..self.nq()).map(|i| self.is_angle(i)).collect()
    }

    /// Whether coordinate `i` is an angle (rad; a quaternion component is not).
    pub fn is_angle(&self, i: usize) -> bool {
        self.angle_coords[i]
    }

    /// The current values of the parameters and coefficients.
    #[inline]
    pub fn env(&self) -> Plain<'_> {
        Plain {
            params: &self.live.values,
            coefs: &self.live.coefs,
        }
    }

    // ---- parameters ------------------------------------------------------------------

    /// Parameter names, in index order.
    pub fn param_names(&self) -> &[String] {
        &self.live.names
    }

    /// Index of a parameter by name.
    pub fn param_index(&self, name: &str) -> Option<usize> {
        self.live.index(name)
    }

    /// How parameter `i` follows others, if it does (`2*pi*f`), as written.
    pub fn param_definition(&self, i: usize) -> Option<String> {
        self.live.definition(i)
    }

    /// Current SI value of parameter `i`.
    pub fn param(&self, i: usize) -> f64 {
        self.live.values[i]
    }

    /// Current SI values of all parameters.
    pub fn params(&self) -> &[f64] {
        &self.live.values
    }

    /// The forcing amplitude's parameter index (`[model] forcing_amplitude`).
    pub fn forcing_amplitude_param(&self) -> Option<usize> {
        self.forcing_amplitude
    }

    /// The forcing frequency's parameter index (`[model] forcing_frequency`).
    pub fn forcing_param(&self) -> Option<usize> {
        self.forcing
    }

    /// A copy without its velocity-dependent loads: every impressed force element (spring
    /// and torsion laws, dampers, friction, point forces and torques) is evaluated with
    /// the velocities at zero, f_u(q, v, t) = gravity + Σ f_e(q, 0, t) + the inertial
    /// velocity terms of spatial bodies (kept: they are not loads). A linear
    /// spring–damper keeps k·s and loses c·ṡ, friction F·tanh(ṡ/v0) vanishes, a user's
    /// law f(x, x_dot) becomes f(x, 0). With the forcing amplitude at 0 this is the
    /// conservative system whose free oscillations the backbone curve follows
    /// (`periodic::backbone`). The switch is the system's, not a change of coefficients,
    /// so `set_param` keeps it and nothing else changes.
    pub fn undamped(&self) -> System {
        let mut s = self.clone();
        s.undamped = true;
        s
    }

    /// Whether the velocity-dependent loads are switched off ([`System::undamped`]).
    pub fn is_undamped(&self) -> bool {
        self.undamped
    }

    /// A copy whose ground is held at its mean pose over `times` (at rest): what statics
    /// and linearizations see of a moving ground, so that a linear response is the limit
    /// of small excitation (the stiffness is not averaged over the excitation's swing).
    pub fn with_ground_at_mean(&self, times: &[f64]) -> System {
        let mut s = self.clone();
        if !self.ground.is_moving() || times.is_empty() {
            return s;
        }
        let mut mean = [0.0; 7];
        for &t in times {
            let g = GroundPose::<f64>::at(&self.ground, t, self.env());
            let w = 1.0 / times.len() as f64;
            for k in 0..3 {
                mean[k] += g.r[k] * w;
            }
            mean[3] += g.angle() * w;
            if let Some((_, _, a)) = g.rot3 {
                // angles (rz, ry, rx) → stored as rx, ry, rz
                mean[4] += a[2] * w;
                mean[5] += a[1] * w;
                mean[6] += a[0] * w;
            }
        }
        s.ground.frozen = Some(mean);
        s.rheonomic = self.constraints.iter().any(|c| match c {
            joints::Constraint::Custom(e) => e.depends_on_time(),
            _ => false,
        });
        s
    }

    /// The `[trim]` parameters and their solved values, when the trim has been solved.
    pub fn trim_solved(&self) -> Option<Vec<(String, f64)>> {
        let t = self.trim.as_ref().filter(|t| t.solved && t.off.is_none())?;
        Some(
            t.params
                .iter()
                .map(|&i| (self.live.names[i].clone(), self.live.values[i]))
                .collect(),
        )
    }

    /// ∂p_of/∂p_wrt: how parameter `of` moves with parameter `wrt` through the
    /// parameters' expressions (1 for itself, 0 where it does not depend on it), by dual
    /// numbers.
    pub fn param_rate(&self, of: usize, wrt: usize) -> f64 {
        let (p, _) = self.seeded(wrt, Dual64::new(self.param(wrt), 1.0));
        p[of].eps
    }

    /// ∂q₀/∂p_i: how the initial pose the model gives (fixed coordinates exact, the rest
    /// guesses) moves with parameter `i`, by dual numbers.
    pub fn initial_dp(&self, i: usize) -> Vec<f64> {
        let (_, c) = self.seeded(i, Dual64::new(self.param(i), 1.0));
        self.initial_coefs.iter().map(|&k| c[k].eps).collect()
    }

    /// Where the model file gives velocity `i`'s initial value (its `velocity` field's
    /// entry), for a message that blames it; `None` when the model does not give it.
    pub fn initial_velocity_location(&self, i: usize) -> Option<crate::diag::Location> {
        let span = self.velocity_spans.get(i)?.clone()?;
        Some(crate::diag::Location {
            source: self.source.clone(),
            span,
            label: "this initial velocity".into(),
        })
    }

    /// The parameter given by the user that turned the `[trim]` off, if any.
    pub fn trim_off(&self) -> Option<&str> {
        self.trim.as_ref().and_then(|t| t.off.as_deref())
    }

    /// Angular frequency of the harmonic forcing, rad/s (`[model] forcing_frequency`).
    pub fn forcing_frequency(&self) -> Option<f64> {
        self.forcing.map(|i| self.live.values[i])
    }

    /// Set parameter `i` to `value` (SI): every parameter defined from it, every element
    /// coefficient, the mass matrix and the initial guess follow; no recompilation. The
    /// parameter no longer follows its own definition. A value the model cannot take (a
    /// mass ≤ 0, a coefficient that is not finite) is refused with the model's located
    /// message and leaves the system unchanged.
    pub fn set_param(&mut self, i: usize, value: f64) -> Result<()> {
        self.live
            .set(i, value, &self.overrides)
            .map_err(|diagnostics| Error::Model {
                source: self.source.clone(),
                diagnostics,
            })?;
        self.refresh();
        Ok(())
    }

    /// The damping coefficients (of spring–dampers and torsions) that are negative at the
    /// current parameter values: (what, e.g. "the damping of `spring`", value in SI, its
    /// dimension). The model may hold one (nothing refuses it: an element that feeds
    /// energy in); a study that varies a parameter warns when a case makes one negative
    /// ([`crate::linear::sensitivity::negative_dampings`]).
    pub fn negative_dampings(&self) -> Vec<(String, f64, crate::model::units::Dim)> {
        use crate::model::units::Dim;
        self.live
            .checks
            .iter()
            .filter(|c| c.dim == Dim::DAMPING || c.dim == Dim::ANGULAR_DAMPING)
            .filter(|c| self.live.coefs[c.coef] < 0.0)
            .map(|c| (c.what.clone(), self.live.coefs[c.coef], c.dim))
            .collect()
    }

    /// A copy with parameter `name` at `value` (see [`System::set_param`]).
    pub fn with_param(&self, i: usize, value: f64) -> Result<System> {
        let mut s = self.clone();
        s.set_param(i, value)?;
        Ok(s)
    }

    /// Parameters and coefficients carrying a derivative with respect to parameter `i`:
    /// `value` is the parameter in type D (its dual part the seed). Evaluate with
    /// [`System::phi_in`], [`System::forces_in`] and `Seeded { params, coefs }`.
    pub fn seeded<D: Scalar>(&self, i: usize, value: D) -> (Vec<D>, Vec<D>) {
        self.live.seeded(i, value)
    }

    /// [`System::seeded`] for several parameters at once (a direction in parameter space:
    /// each `(index, value)` with its dual part the direction's component).
    pub fn seeded_many<D: Scalar>(&self, seeds: &[(usize, D)]) -> (Vec<D>, Vec<D>) {
        self.live.seeded_many(seeds)
    }

    /// Recompute what depends on the coefficients: masses, gravity, initial guess.
    fn refresh(&mut self) {
        let c = &self.live.coefs;
        let n = self.nv();
        let mut mdiag = DVector::zeros(n);
        for b in &mut self.bodies {
            b.mass = c[b.mass_coef];
            match &b.kind {
                BodyKind::Planar => {
                    b.inertia = c[b.inertia_coefs[0]];
                    mdiag[b.offset] = b.mass;
                    mdiag[b.offset + 1] = b.mass;
                    mdiag[b.offset + 2] = b.inertia;
                }
                BodyKind::Free => {
                    for (k, &i) in b.inertia_coefs.iter().enumerate() {
                        b.tensor[k] = c[i];
                    }
                    for i in 0..3 {
                        mdiag[b.voff + i] = b.mass;
                        mdiag[b.voff + 3 + i] = b.tensor[i];
                    }
                }
                BodyKind::Spatial { axes } => {
                    for (k, &i) in b.inertia_coefs.iter().enumerate() {
                        b.tensor[k] = c[i];
                    }
                    for i in 0..3 {
                        mdiag[b.voff + i] = b.mass;
                    }
                    // the angles' mass depends on the pose: see `mass_matrix_at`; here
                    // its value at zero angles
                    let p = Pose3::from_parts([0.0; 3], &[0.0; 3][..axes.len()], axes);
                    let na = axes.len();
                    let mut m = [0.0; 9];
                    spatial::rotational_mass(&p, na, &spatial::tensor(b.tensor), &mut m);
                    for i in 0..na {
                        mdiag[b.voff + 3 + i] = m[i * na + i];
                    }
                }
            }
        }
        self.mass_inv_diag = mdiag.iter().map(|x| 1.0 / x).collect();
        self.mass_matrix = DMatrix::from_diagonal(&mdiag);
        self.mass_inv_sqrt = DMatrix::from_diagonal(&mdiag.map(|x| 1.0 / x.sqrt()));
        self.gravity = [0.0, 0.0, 0.0];
        for g in &self.gravity_coefs {
            for k in 0..3 {
                self.gravity[k] += c[g[k]];
            }
        }
        for (k, &i) in self.initial_coefs.iter().enumerate() {
            self.initial.q[k] = c[i];
        }
        // a free body's orientation is normalized (a zero one becomes NaN: an undefined
        // guess, reported by the assembly)
        let mut q = std::mem::take(&mut self.initial.q);
        self.normalize(&mut q);
        self.initial.q = q;
        for (k, v) in self.velocity_coefs.iter().enumerate() {
            self.initial.v[k] = v.map_or(0.0, |i| c[i]);
        }
    }

    // ---- equations -------------------------------------------------------------------

    /// Constraint function Φ(q, t) (m) at the current parameters.
    #[inline]
    pub fn phi<D: Scalar>(&self, q: &[D], t: D, out: &mut [D]) {
        self.phi_in(q, t, self.env(), out)
    }

    /// Call `f` with the frames at (q, t): the ground's pose and every body's pose,
    /// computed once for all the elements that read them.
    fn with_frames<D: Scalar, E: Env<D>, R>(
        &self,
        q: &[D],
        t: D,
        env: E,
        f: impl FnOnce(&Frames<'_, D, E>) -> R,
    ) -> R {
        let ground = GroundPose::at(&self.ground, t, env);
        if self.spatial {
            return with_poses3(q, &self.geoms3, |poses3| {
                f(&Frames {
                    q,
                    poses: &[],
                    poses3,
                    nrot: &self.nrot,
                    offsets: &self.offsets,
                    ground,
                    env,
                })
            });
        }
        with_poses(q, &self.offsets, |poses| {
            f(&Frames {
                q,
                poses,
                poses3: &[],
                nrot: &[],
                offsets: &self.offsets,
                ground,
                env,
            })
        })
    }

    /// Constraint function Φ(q, t) with parameters from `env`.
    pub fn phi_in<D: Scalar, E: Env<D>>(&self, q: &[D], t: D, env: E, out: &mut [D]) {
        self.with_frames(q, t, env, |fr| {
            for (c, b) in self.constraints.iter().zip(&self.blocks) {
                c.phi(fr, t, &mut out[b.row0..b.row0 + b.rows]);
            }
        })
    }

    /// Each constraint element (joint or custom constraint, in model order): its name and
    /// its rows of Φ.
    pub fn element_rows(&self) -> Vec<(String, std::ops::Range<usize>)> {
        self.elements
            .iter()
            .zip(&self.blocks)
            .map(|(n, b)| (n.clone(), b.row0..b.row0 + b.rows))
            .collect()
    }

    /// The blocks of A: one per constraint element (see [`System::jacobian_blocks`]).
    pub fn blocks(&self) -> &[Block] {
        &self.blocks
    }

    /// The entries of A, as (row, column), that are zero at every pose: in planar joints'
    /// blocks, those [`joints::Joint::column_zero`] names (a revolute's x row along y, …).
    pub fn structural_zeros(&self) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        if self.spatial {
            return out;
        }
        for (c, b) in self.constraints.iter().zip(&self.blocks) {
            let joints::Constraint::Joint(joint) = c else {
                continue;
            };
            for r in 0..b.rows {
                for &j in &b.cols {
                    if joint.column_zero(self.coord_body[j].1, r) {
                        out.push((b.row0 + r, j));
                    }
                }
            }
        }
        out
    }

    /// A = ∂Φ/∂q by blocks into `ws.vals`: each element is differentiated over the
    /// coordinates it touches only (a joint: its two bodies), with each body's pose
    /// computed once and its derivative along a coordinate seeded without evaluating sin
    /// and cos again (planar joints: their columns written out, [`joints::Joint::column`]).
    /// The cost grows linearly with the number of elements.
    pub fn jacobian_blocks(&self, ws: &mut Workspace, q: &[f64], t: f64) {
        self.poses_into(ws, q);
        self.jacobian_posed(ws, q, t);
    }

    /// Every body's pose at q into the workspace (once per right-hand side).
    fn poses_into(&self, ws: &mut Workspace, q: &[f64]) {
        if self.spatial {
            for (k, g) in self.geoms3.iter().enumerate() {
                ws.pose3_f[k] = Pose3::from_q(q, g);
            }
            return;
        }
        for (k, &o) in self.offsets.iter().enumerate() {
            ws.pose_f[k] = Pose::planar(q, o);
        }
    }

    /// The frames of a planar model at (q, t) in f64, from its bodies' poses.
    fn planar_frames<'a>(
        &'a self,
        q: &'a [f64],
        poses: &'a [Pose<f64>],
        t: f64,
    ) -> Frames<'a, f64, Plain<'a>> {
        let env = self.env();
        Frames {
            q,
            poses,
            poses3: &[],
            nrot: &[],
            offsets: &self.offsets,
            ground: GroundPose::at(&self.ground, t, env),
            env,
        }
    }

    /// [`System::jacobian_blocks`] with the poses already in the workspace.
    fn jacobian_posed(&self, ws: &mut Workspace, q: &[f64], t: f64) {
        if self.spatial {
            return self.jacobian_posed3(ws, q, t);
        }
        let env = self.env();
        // planar joints by their hand-written columns (`Joint::column`), from f64 poses
        let fr = self.planar_frames(q, &ws.pose_f, t);
        for (c, b) in self.constraints.iter().zip(&self.blocks) {
            let joints::Constraint::Joint(joint) = c else {
                continue;
            };
            let ncols = b.cols.len();
            for (ci, &j) in b.cols.iter().enumerate() {
                let (k, d) = self.coord_body[j];
                let mut col = [0.0; 3];
                joint.column(&fr, k, d, &mut col);
                for r in 0..b.rows {
                    ws.vals[b.val0 + r * ncols + ci] = col[r];
                }
            }
        }
        // the rest (custom constraints, which read q) by one dual pass per column
        if self
            .constraints
            .iter()
            .all(|c| matches!(c, joints::Constraint::Joint(_)))
        {
            return;
        }
        for k in 0..self.offsets.len() {
            ws.pose_d[k] = ws.pose_f[k].lift();
        }
        for (d, &x) in ws.qd.iter_mut().zip(q) {
            *d = Dual64::from(x);
        }
        let td = Dual64::from(t);
        let ground = GroundPose::at(&self.ground, td, env);
        // the rest (custom constraints) by one dual pass per column
        for (c, b) in self.constraints.iter().zip(&self.blocks) {
            if matches!(c, joints::Constraint::Joint(_)) {
                continue;
            }
            let ncols = b.cols.len();
            for (ci, &j) in b.cols.iter().enumerate() {
                let (k, d) = self.coord_body[j];
                ws.pose_d[k] = ws.pose_f[k].seeded(d);
                ws.qd[j].eps = 1.0;
                let fr = Frames {
                    q: &ws.qd,
                    poses: &ws.pose_d,
                    poses3: &[],
                    nrot: &[],
                    offsets: &self.offsets,
                    ground,
                    env,
                };
                c.phi(&fr, td, &mut ws.phid[..b.rows]);
                ws.qd[j].eps = 0.0;
                ws.pose_d[k] = ws.pose_f[k].lift();
                for r in 0..b.rows {
                    ws.vals[b.val0 + r * ncols + ci] = ws.phid[r].eps;
                }
            }
        }
    }

    /// [`System::jacobian_posed`] for spatial bodies: the seeded pose of a column carries
    /// ∂R/∂θ = [jw]× R, without evaluating sin and cos again.
    fn jacobian_posed3(&self, ws: &mut Workspace, q: &[f64], t: f64) {
        let env = self.env();
        for k in 0..self.geoms3.len() {
            ws.pose3_d[k] = ws.pose3_f[k].lift();
        }
        for (d, &x) in ws.qd.iter_mut().zip(q) {
            *d = Dual64::from(x);
        }
        let td = Dual64::from(t);
        let ground = GroundPose::at(&self.ground, td, env);
        for (c, b) in self.constraints.iter().zip(&self.blocks) {
            let ncols = b.cols.len();
            for (ci, &j) in b.cols.iter().enumerate() {
                let (k, d) = self.coord_body[j];
                ws.pose3_f[k].seed_into(&mut ws.pose3_d[k], d);
                let g = &self.geoms3[k];
                // the coordinates' derivative along the tangent direction (for custom
                // constraints, which read q): e_j, or a quaternion's ½ q ⊗ (0, e_i)
                let seeded = if g.free && d >= 3 {
                    let mut e = [0.0; 3];
                    e[d - 3] = 1.0;
                    let qq = spatial::quat_normalize(quat_at(q, g.offset + 3));
                    let dq = spatial::quat_rate(qq, e);
                    for (i, x) in dq.iter().enumerate() {
                        ws.qd[g.offset + 3 + i].eps = *x;
                    }
                    g.offset + 3..g.offset + 7
                } else {
                    ws.qd[g.offset + d].eps = 1.0;
                    g.offset + d..g.offset + d + 1
                };
                let fr = Frames {
                    q: &ws.qd,
                    poses: &[],
                    poses3: &ws.pose3_d,
                    nrot: &self.nrot,
                    offsets: &self.offsets,
                    ground,
                    env,
                };
                c.phi(&fr, td, &mut ws.phid[..b.rows]);
                for x in &mut ws.qd[seeded] {
                    x.eps = 0.0;
                }
                Pose3::unseed(&mut ws.pose3_d[k]);
                for r in 0..b.rows {
                    ws.vals[b.val0 + r * ncols + ci] = ws.phid[r].eps;
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

    /// Constraint Jacobian A = ∂Φ/∂q (m × nv, along the tangent directions), dense (from
    /// [`System::jacobian_blocks`]).
    pub fn jacobian(&self, ws: &mut Workspace, q: &[f64], t: f64, a: &mut DMatrix<f64>) {
        self.jacobian_blocks(ws, q, t);
        self.blocks_to_dense(ws, a);
    }

    /// The blocks of A in `ws.vals` (from [`System::jacobian_blocks`]) as a dense m × n A.
    pub fn blocks_to_dense(&self, ws: &Workspace, a: &mut DMatrix<f64>) {
        a.fill(0.0);
        for b in &self.blocks {
            let ncols = b.cols.len();
            for r in 0..b.rows {
                for (ci, &j) in b.cols.iter().enumerate() {
                    a[(b.row0 + r, j)] = ws.vals[b.val0 + r * ncols + ci];
                }
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
        self.poses_into(ws, q);
        self.bias_posed(ws, q, v, t, b);
    }

    /// [`System::bias`] with the poses already in the workspace. With a ground that does
    /// not move (fixed, or frozen at a pose), a planar joint's rows are written out by
    /// hand ([`joints::Joint::bias`], the same bits as the dual pass); the rest (spatial
    /// models, custom constraints, a moving ground) by [`System::bias_dual_posed`].
    fn bias_posed(&self, ws: &mut Workspace, q: &[f64], v: &[f64], t: f64, b: &mut DVector<f64>) {
        if self.spatial || self.ground.is_moving() {
            return self.bias_dual_posed(ws, q, v, t, b, false);
        }
        let fr = self.planar_frames(q, &ws.pose_f, t);
        let mut custom = false;
        for (c, blk) in self.constraints.iter().zip(&self.blocks) {
            match c {
                joints::Constraint::Joint(j) => {
                    j.bias(&fr, v, &mut b.as_mut_slice()[blk.row0..blk.row0 + blk.rows])
                }
                _ => custom = true,
            }
        }
        if custom {
            self.bias_dual_posed(ws, q, v, t, b, true);
        }
    }

    /// b by the `Dual2_64` pass alone ([`System::bias`] writes planar joints' rows by
    /// hand): what those rows are checked against, bit for bit (tests/elements.rs).
    #[doc(hidden)]
    pub fn bias_dual(
        &self,
        ws: &mut Workspace,
        q: &[f64],
        v: &[f64],
        t: f64,
        b: &mut DVector<f64>,
    ) {
        self.poses_into(ws, q);
        self.bias_dual_posed(ws, q, v, t, b, false);
    }

    /// b with the poses already in the workspace by one `Dual2_64` pass along the motion,
    /// each body's pose along it from its f64 pose by the chain rule. Each constraint's
    /// rows depend on its own Φ only: with `skip_joints`, the rows of planar joints
    /// (written by hand) are left as they are.
    fn bias_dual_posed(
        &self,
        ws: &mut Workspace,
        q: &[f64],
        v: &[f64],
        t: f64,
        b: &mut DVector<f64>,
        skip_joints: bool,
    ) {
        if self.spatial {
            // q ⊕ s·v body by body: angles along q + s·v, a free body's quaternion along
            // q ⊗ exp(s ω/2) (rate ½ q ⊗ (0, ω), second derivative −¼ |ω|² q)
            for (k, g) in self.geoms3.iter().enumerate() {
                let (o, vo) = (g.offset, g.voff);
                if g.free {
                    for i in 0..3 {
                        ws.q2[o + i] = Dual2_64::new(q[o + i], v[vo + i], 0.0);
                    }
                    let qq = spatial::quat_normalize(quat_at(q, o + 3));
                    let w = [v[vo + 3], v[vo + 4], v[vo + 5]];
                    let rate = spatial::quat_rate(qq, w);
                    let w2 = -0.25 * spatial::dot(w, w);
                    for i in 0..4 {
                        ws.q2[o + 3 + i] = Dual2_64::new(qq[i], rate[i], w2 * qq[i]);
                    }
                    ws.pose3_2[k] = ws.pose3_f[k].along_free(&v[vo..vo + 6]);
                } else {
                    for i in 0..g.nq() {
                        ws.q2[o + i] = Dual2_64::new(q[o + i], v[vo + i], 0.0);
                    }
                    ws.pose3_2[k] = Pose3::from_q(&ws.q2, g);
                }
            }
        } else {
            for ((d, &x), &dx) in ws.q2.iter_mut().zip(q).zip(v) {
                *d = Dual2_64::new(x, dx, 0.0);
            }
            for (k, &o) in self.offsets.iter().enumerate() {
                ws.pose_2[k] = ws.pose_f[k].along(v, o);
            }
        }
        let env = self.env();
        let td = Dual2_64::new(t, 1.0, 0.0);
        let fr = Frames {
            q: &ws.q2,
            poses: &ws.pose_2,
            poses3: &ws.pose3_2,
            nrot: &self.nrot,
            offsets: &self.offsets,
            ground: GroundPose::at(&self.ground, td, env),
            env,
        };
        for (c, blk) in self.constraints.iter().zip(&self.blocks) {
            if skip_joints && matches!(c, joints::Constraint::Joint(_)) {
                continue;
            }
            let rows = blk.row0..blk.row0 + blk.rows;
            c.phi(&fr, td, &mut ws.phi2[rows.clone()]);
            for i in rows {
                b[i] = -ws.phi2[i].v2;
            }
        }
    }

    /// What one right-hand side needs, sharing each body's pose: the forces f (n), A by
    /// blocks (into `ws.vals`) and b (m). The same values as [`System::forces`],
    /// [`System::jacobian_blocks`] and [`System::bias`], with sin and cos evaluated once
    /// per body instead of once per evaluation.
    pub fn rhs_terms(
        &self,
        ws: &mut Workspace,
        q: &[f64],
        v: &[f64],
        t: f64,
        f: &mut [f64],
        b: &mut DVector<f64>,
    ) {
        self.poses_into(ws, q);
        let env = self.env();
        self.gravity_in(env, f);
        if !self.forces.is_empty() {
            let still;
            let v = if self.undamped {
                still = vec![0.0; v.len()];
                &still[..]
            } else {
                v
            };
            let fr = Frames {
                q,
                poses: &ws.pose_f,
                poses3: &ws.pose3_f,
                nrot: &self.nrot,
                offsets: &self.offsets,
                ground: GroundPose::at(&self.ground, t, env),
                env,
            };
            for force in &self.forces {
                force.add(&fr, v, t, f);
            }
        }
        self.velocity_forces_in(q, v, env, f);
        if self.m() == 0 {
            return;
        }
        self.jacobian_posed(ws, q, t);
        self.bias_posed(ws, q, v, t, b);
    }

    /// f = gravity (the forces' first term).
    #[inline]
    fn gravity_in<D: Scalar, E: Env<D>>(&self, env: E, f: &mut [D]) {
        f.fill(D::from(0.0));
        if !self.gravity_coefs.is_empty() {
            let mut g = [D::from(0.0); 3];
            for c in &self.gravity_coefs {
                for k in 0..3 {
                    g[k] += env.coef(c[k]);
                }
            }
            let dims = if self.spatial { 3 } else { 2 };
            for b in &self.bodies {
                let m = env.coef(b.mass_coef);
                for k in 0..dims {
                    f[b.voff + k] += m * g[k];
                }
            }
        }
    }

    /// Add the spatial bodies' velocity forces: `∂T/∂θ − Ṁ θ̇` of an angle sequence, the
    /// gyroscopic `−ω × (I ω)` of a free body (see [`spatial`]).
    #[inline]
    fn velocity_forces_in<D: Scalar, E: Env<D>>(&self, q: &[D], v: &[D], env: E, f: &mut [D]) {
        for (b, g) in self.bodies.iter().zip(&self.geoms3) {
            let n = g.nrot();
            let (o, vo) = (g.offset + 3, g.voff + 3);
            // quadratic in the rates: at rest it and its first derivatives vanish; a body
            // turning about one axis has a constant mass (T = ½ I θ̇²): none
            if (!g.free && n == 1) || v[vo..vo + n].iter().all(|w| w.re() == 0.0) {
                continue;
            }
            let mut i6 = [D::from(0.0); 6];
            for (x, &c) in i6.iter_mut().zip(&b.inertia_coefs) {
                *x = env.coef(c);
            }
            let inertia = spatial::tensor(i6);
            if g.free {
                let w = [v[vo], v[vo + 1], v[vo + 2]];
                spatial::gyroscopic(w, &inertia, &mut f[vo..vo + 3]);
                continue;
            }
            spatial::velocity_forces(
                &g.axes,
                &q[o..o + n],
                &v[vo..vo + n],
                &inertia,
                &mut f[vo..vo + n],
            );
        }
    }

    /// Impressed generalized forces f(q, v, t) (n): gravity, springs, dampers, point
    /// forces. Generic, so that stiffness ∂f/∂q and damping ∂f/∂v come from dual numbers.
    #[inline]
    pub fn forces<D: Scalar>(&self, q: &[D], v: &[D], t: D, f: &mut [D]) {
        self.forces_in(q, v, t, self.env(), f)
    }

    /// f(q, v, t) with parameters from `env`.
    pub fn forces_in<D: Scalar, E: Env<D>>(&self, q: &[D], v: &[D], t: D, env: E, f: &mut [D]) {
        self.gravity_in(env, f);
        self.velocity_forces_in(q, v, env, f);
        if self.forces.is_empty() {
            return;
        }
        let still;
        let v = if self.undamped {
            still = vec![D::from(0.0); v.len()];
            &still[..]
        } else {
            v
        };
        self.with_frames(q, t, env, |fr| {
            for force in &self.forces {
                force.add(fr, v, t, f);
            }
        })
    }

    /// The generalized force of the force elements named `name` (one `[[forces]]` table,
    /// which may compile to several elements) alone, at (q, v, t) with parameters from
    /// `env` (n): a force element's share of f, for its own stiffness −∂f_e/∂q. Gravity
    /// tables give nothing here (their force does not depend on the coordinates).
    pub fn element_forces_in<D: Scalar, E: Env<D>>(
        &self,
        name: &str,
        q: &[D],
        v: &[D],
        t: D,
        env: E,
        f: &mut [D],
    ) {
        f.fill(D::from(0.0));
        if !self.force_names.iter().any(|n| n == name) {
            return;
        }
        let still;
        let v = if self.undamped {
            still = vec![D::from(0.0); v.len()];
            &still[..]
        } else {
            v
        };
        self.with_frames(q, t, env, |fr| {
            for (force, n) in self.forces.iter().zip(&self.force_names) {
                if n == name {
                    force.add(fr, v, t, f);
                }
            }
        })
    }

    /// Whether any impressed force depends on time explicitly, or through the motion of
    /// the ground (a damper to a moving anchor).
    pub fn forces_depend_on_time(&self) -> bool {
        self.forces.iter().any(|f| f.depends_on_time())
            || (self.ground.is_moving() && !self.forces.is_empty())
    }

    /// Whether the model's constraints or loads depend on time (a forcing, a moving ground).
    pub fn depends_on_time(&self) -> bool {
        self.rheonomic || self.forces_depend_on_time()
    }

    /// The velocity of the ground frame carried to each body's centre of gravity at pose q
    /// and time t (n): what a body at rest relative to the moving ground has.
    pub fn ground_velocity(&self, q: &[f64], t: f64) -> Vec<f64> {
        let mut v = vec![0.0; self.nv()];
        if !self.ground.is_moving() {
            return v;
        }
        let g = GroundPose::<f64>::at(&self.ground, t, self.env());
        if self.spatial {
            // v_CG = v_g + ω_g × (r − r_g); the angle rates that turn with ω_g (least
            // squares through the body's angular-velocity columns; a free body's body-frame
            // rate is Rᵀ ω_g)
            let w = g.omega3();
            for (b, geom) in self.bodies.iter().zip(&self.geoms3) {
                let r = [q[b.offset], q[b.offset + 1], q[b.offset + 2]];
                let arm = spatial::sub(r, g.r);
                let vc = spatial::add(g.vel, spatial::cross(w, arm));
                v[b.voff..b.voff + 3].copy_from_slice(&vc);
                if w == [0.0; 3] {
                    continue;
                }
                let p = Pose3::from_q(q, geom);
                let n = geom.nrot();
                if geom.free {
                    let wb = spatial::mat_t_vec(&p.rot, w);
                    v[b.voff + 3..b.voff + 6].copy_from_slice(&wb);
                } else if n > 0 {
                    let jw = DMatrix::from_fn(3, n, |i, k| p.jw[k][i]);
                    let rates =
                        crate::linalg::solve_least_squares(jw, &DVector::from_row_slice(&w));
                    for k in 0..n {
                        v[b.voff + 3 + k] = rates[k];
                    }
                }
            }
            return v;
        }
        let (r, vel, w) = g.motion();
        for b in &self.bodies {
            let o = b.offset;
            v[o] = vel[0] - w * (q[o + 1] - r[1]);
            v[o + 1] = vel[1] + w * (q[o] - r[0]);
            v[o + 2] = w;
        }
        v
    }

    /// Potential energy of gravity and springs at time t, J (for energy checks; a spring
    /// to a moving ground is taken with its anchor where the ground is at t).
    pub fn potential_energy(&self, q: &[f64], t: f64) -> f64 {
        let mut e = 0.0;
        let dims = if self.spatial { 3 } else { 2 };
        for b in &self.bodies {
            for k in 0..dims {
                e -= b.mass * self.gravity[k] * q[b.offset + k];
            }
        }
        self.with_frames(q, t, self.env(), |fr| {
            for force in &self.forces {
                e += force.potential(fr);
            }
        });
        e
    }

    /// Kinetic energy ½ vᵀ M(q) v, J.
    pub fn kinetic_energy(&self, q: &[f64], v: &[f64]) -> f64 {
        let v = DVector::from_column_slice(v);
        0.5 * (v.transpose() * &self.mass_matrix_at(q) * &v)[(0, 0)]
    }

    /// 1/√M_ii per velocity: the weights that make minimum-norm corrections independent
    /// of units (assembly, kinematics). For spatial angles, the diagonal at zero angles (a
    /// weighting only); 1 where it is not positive.
    pub fn mass_weights(&self) -> Vec<f64> {
        (0..self.nv())
            .map(|i| {
                let m = self.mass_matrix[(i, i)];
                if m > 0.0 && m.is_finite() {
                    1.0 / m.sqrt()
                } else {
                    1.0
                }
            })
            .collect()
    }

    /// The mass matrix M(q) (nv × nv): constant for planar bodies; for spatial bodies,
    /// block-diagonal with the angles' block `J_bᵀ I J_b` at the pose (a free body's: its
    /// inertia tensor, constant).
    pub fn mass_matrix_at(&self, q: &[f64]) -> DMatrix<f64> {
        if !self.spatial {
            return self.mass_matrix.clone();
        }
        let mut m = DMatrix::zeros(self.nv(), self.nv());
        for (b, g) in self.bodies.iter().zip(&self.geoms3) {
            let o = g.voff;
            for i in 0..3 {
                m[(o + i, o + i)] = b.mass;
            }
            let n = g.nrot();
            let mut blk = [0.0; 9];
            self.rotational_mass(b, g, q, &mut blk);
            for i in 0..n {
                for j in 0..n {
                    m[(o + 3 + i, o + 3 + j)] = blk[i * n + j];
                }
            }
        }
        m
    }

    /// The mass matrix M(q) (nv × nv, row-major) in any scalar type, with the masses and
    /// inertias read from `env`: what [`System::mass_matrix_at`] gives, differentiable
    /// with respect to the coordinates and the parameters.
    pub fn mass_matrix_in<D: Scalar, E: Env<D>>(&self, q: &[D], env: E) -> Vec<D> {
        let nv = self.nv();
        let mut m = vec![D::from(0.0); nv * nv];
        for (k, b) in self.bodies.iter().enumerate() {
            let o = b.voff;
            let mass = env.coef(b.mass_coef);
            match &b.kind {
                BodyKind::Planar => {
                    m[o * nv + o] = mass;
                    m[(o + 1) * nv + o + 1] = mass;
                    m[(o + 2) * nv + o + 2] = env.coef(b.inertia_coefs[0]);
                }
                _ => {
                    let g = &self.geoms3[k];
                    for i in 0..3 {
                        m[(o + i) * nv + o + i] = mass;
                    }
                    let mut t = [D::from(0.0); 6];
                    for (x, &c) in t.iter_mut().zip(&b.inertia_coefs) {
                        *x = env.coef(c);
                    }
                    let t = spatial::tensor(t);
                    let n = g.nrot();
                    let mut blk = [D::from(0.0); 9];
                    if g.free {
                        for i in 0..3 {
                            blk[i * 3..i * 3 + 3].copy_from_slice(&t[i]);
                        }
                    } else {
                        let z = D::from(0.0);
                        let p =
                            Pose3::from_parts([z; 3], &q[g.offset + 3..g.offset + 3 + n], &g.axes);
                        spatial::rotational_mass(&p, n, &t, &mut blk);
                    }
                    for i in 0..n {
                        for j in 0..n {
                            m[(o + 3 + i) * nv + o + 3 + j] = blk[i * n + j];
                        }
                    }
                }
            }
        }
        m
    }

    /// The mass matrix of a spatial body's rotational velocities at q (n × n row-major
    /// into `out`): `J_bᵀ I J_b` for an angle sequence, I for a free body.
    pub fn rotational_mass(&self, b: &SysBody, g: &Geom3, q: &[f64], out: &mut [f64]) {
        if g.free {
            let t = spatial::tensor(b.tensor);
            for i in 0..3 {
                out[i * 3..i * 3 + 3].copy_from_slice(&t[i]);
            }
            return;
        }
        let n = g.axes.len();
        if n == 1 {
            // about one body axis: the tensor's diagonal entry, whatever the angle
            let a = g.axes[0];
            out[0] = spatial::tensor(b.tensor)[a][a];
            return;
        }
        let p = Pose3::from_parts([0.0; 3], &q[g.offset + 3..g.offset + 3 + n], &g.axes);
        spatial::rotational_mass(&p, n, &spatial::tensor(b.tensor), out);
    }
}

/// The quaternion at `q[o..o + 4]`.
#[inline]
fn quat_at(q: &[f64], o: usize) -> spatial::Quat {
    [q[o], q[o + 1], q[o + 2], q[o + 3]]
}
