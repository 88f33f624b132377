//! The compiled equations of a model: constraint function Φ(q, t), its Jacobian A and
//! bias b by automatic differentiation, mass matrix M and impressed forces f(q, v, t),
//! with live parameters.
//!
//! Everything here is generic over the number type and over where parameter values come
//! from ([`Env`]): the constraint function is written once over any [`Scalar`], so
//!
//! * `A = ∂Φ/∂q` comes from one `Dual64` pass per coordinate (column j: seed `q_j + ε`),
//! * `b = −d²/ds² Φ(q + s·v, t + s)|s=0` from one `Dual2_64` pass along the motion,
//! * `∂Φ/∂p`, `∂f/∂p` from one pass with the parameter seeded ([`System::seeded`]).
//!
//! Parameters stay live: [`System::set_param`] changes one without recompiling (a sweep's
//! frequency, a continuation's parameter), and everything defined from it follows.
//!
//! Planar bodies have `q = (x, y, θ)` of the centre of gravity and `v = q̇`.
//!
//! Layout: [`compile`] turns a model into a system, [`live`] holds the parameters and
//! element coefficients, [`frame`] the frames and points (and the moving ground),
//! [`joints`] and [`forces`] the elements.

mod compile;
pub mod forces;
pub mod frame;
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
    /// Index of the body's first coordinate in q (and v).
    pub offset: usize,
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

/// Compiled equations of motion of one model, with live parameters.
#[derive(Debug, Clone)]
pub struct System {
    /// `<body>.<coordinate>` for each entry of q.
    pub coordinates: Vec<String>,
    /// The dimension of each coordinate (length, or angle: none).
    pub coordinate_dims: Vec<Dim>,
    /// One name per constraint row (`joint.x`, `constraint2`, ...).
    pub constraint_names: Vec<String>,
    pub bodies: Vec<SysBody>,
    /// Coordinate offset of each body.
    offsets: Vec<usize>,
    /// For each coordinate: its body and direction (planar: 0 = x, 1 = y, 2 = θ).
    coord_body: Vec<(usize, usize)>,
    constraints: Vec<joints::Constraint>,
    /// The block of A of each constraint element.
    blocks: Vec<Block>,
    /// Number of values of A stored by blocks.
    nvals: usize,
    forces: Vec<forces::Force>,
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
    /// Mass matrix M (n × n), constant for planar bodies.
    pub mass_matrix: DMatrix<f64>,
    /// M^-½ (n × n).
    pub mass_inv_sqrt: DMatrix<f64>,
    /// The inverse of M's diagonal (planar bodies: 1/m, 1/m, 1/I).
    pub mass_inv_diag: Vec<f64>,
    pub initial: InitialGuess,
    /// Coefficients of the initial coordinates and of the given velocities.
    initial_coefs: Vec<usize>,
    velocity_coefs: Vec<Option<usize>>,
    /// Whether any constraint depends on time explicitly (a custom constraint in `t`, or
    /// a moving ground).
    pub rheonomic: bool,
    /// The parameter that is the harmonic forcing's angular frequency.
    forcing: Option<usize>,
    live: live::Live,
    /// The model file, for located messages when a parameter change is refused.
    source: SourceFile,
    /// The user's `--set`s, quoted in such messages.
    overrides: String,
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
        let n = sys.n();
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
    /// Number of coordinates (= velocities for planar bodies).
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
    /// planar body has q = v-rates; a body with a unit quaternion has 7 coordinates and
    /// 6 velocities.) Every analysis steps through [`System::retract`], so it holds for
    /// either.
    pub fn nv(&self) -> usize {
        self.coordinates.len()
    }

    /// q ⊕ s·δ in place: the configuration reached from q along the tangent δ (nv) by
    /// s. Planar bodies: q + s·δ. Newton updates, projections and predictors step
    /// through this, never by adding to q.
    pub fn retract(&self, q: &mut [f64], delta: &[f64], s: f64) {
        for b in &self.bodies {
            match b.kind {
                BodyKind::Planar | BodyKind::Spatial { .. } => {
                    for i in b.offset..b.offset + self.body_len(b) {
                        q[i] += s * delta[i];
                    }
                }
            }
        }
    }

    /// The tangent δ (nv) with q0 ⊕ δ = q1, for q1 near q0 (planar bodies: q1 − q0).
    pub fn difference(&self, q1: &[f64], q0: &[f64], out: &mut [f64]) {
        for b in &self.bodies {
            match b.kind {
                BodyKind::Planar | BodyKind::Spatial { .. } => {
                    for i in b.offset..b.offset + self.body_len(b) {
                        out[i] = q1[i] - q0[i];
                    }
                }
            }
        }
    }

    /// q̇ = N(q) v (nq): how the coordinates move with the velocities (planar: q̇ = v).
    pub fn qdot(&self, _q: &[f64], v: &[f64], out: &mut [f64]) {
        for b in &self.bodies {
            match b.kind {
                BodyKind::Planar | BodyKind::Spatial { .. } => {
                    let r = b.offset..b.offset + self.body_len(b);
                    out[r.clone()].copy_from_slice(&v[r]);
                }
            }
        }
    }

    /// Number of coordinates of a body.
    fn body_len(&self, b: &SysBody) -> usize {
        match &b.kind {
            BodyKind::Planar => 3,
            BodyKind::Spatial { axes } => 3 + axes.len(),
        }
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

    /// Whether coordinate `i` is an angle (rad).
    pub fn is_angle(&self, i: usize) -> bool {
        self.coordinate_dims[i] == Dim::NONE
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

    /// The forcing frequency's parameter index (`[model] forcing_frequency`).
    pub fn forcing_param(&self) -> Option<usize> {
        self.forcing
    }

    /// A copy whose ground is held at its mean pose over `times` (at rest): what statics
    /// and linearizations see of a moving ground, so that a linear response is the limit
    /// of small excitation (the stiffness is not averaged over the excitation's swing).
    pub fn with_ground_at_mean(&self, times: &[f64]) -> System {
        let mut s = self.clone();
        if !self.ground.is_moving() || times.is_empty() {
            return s;
        }
        let mut mean = [0.0; 4];
        for &t in times {
            let g = GroundPose::<f64>::at(&self.ground, t, self.env());
            for k in 0..3 {
                mean[k] += g.r[k] / times.len() as f64;
            }
            mean[3] += g.angle() / times.len() as f64;
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

    /// Recompute what depends on the coefficients: masses, gravity, initial guess.
    fn refresh(&mut self) {
        let c = &self.live.coefs;
        let n = self.n();
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
                BodyKind::Spatial { axes } => {
                    for (k, &i) in b.inertia_coefs.iter().enumerate() {
                        b.tensor[k] = c[i];
                    }
                    for i in 0..3 {
                        mdiag[b.offset + i] = b.mass;
                    }
                    // the angles' mass depends on the pose: see `mass_matrix_at`; here
                    // its value at zero angles
                    let p = Pose3::from_parts([0.0; 3], &[0.0; 3][..axes.len()], axes);
                    let na = axes.len();
                    let mut m = [0.0; 9];
                    spatial::rotational_mass(&p, na, &spatial::tensor(b.tensor), &mut m);
                    for i in 0..na {
                        mdiag[b.offset + 3 + i] = m[i * na + i];
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

    /// A = ∂Φ/∂q by blocks into `ws.vals`: each element is differentiated over the
    /// coordinates it touches only (a joint: its two bodies), with each body's pose
    /// computed once and its derivative along a coordinate seeded without evaluating sin
    /// and cos again. The cost grows linearly with the number of elements.
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

    /// [`System::jacobian_blocks`] with the poses already in the workspace.
    fn jacobian_posed(&self, ws: &mut Workspace, q: &[f64], t: f64) {
        if self.spatial {
            return self.jacobian_posed3(ws, q, t);
        }
        let env = self.env();
        for k in 0..self.offsets.len() {
            ws.pose_d[k] = ws.pose_f[k].lift();
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
                ws.pose3_d[k] = ws.pose3_f[k].seeded(d);
                ws.qd[j].eps = 1.0;
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
                ws.qd[j].eps = 0.0;
                ws.pose3_d[k] = ws.pose3_f[k].lift();
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

    /// Constraint Jacobian A = ∂Φ/∂q (m × n), dense (from [`System::jacobian_blocks`]).
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

    /// [`System::bias`] with the poses already in the workspace: one `Dual2_64` pass along
    /// the motion, each body's pose along it from its f64 pose by the chain rule.
    fn bias_posed(&self, ws: &mut Workspace, q: &[f64], v: &[f64], t: f64, b: &mut DVector<f64>) {
        for ((d, &x), &dx) in ws.q2.iter_mut().zip(q).zip(v) {
            *d = Dual2_64::new(x, dx, 0.0);
        }
        if self.spatial {
            for (k, g) in self.geoms3.iter().enumerate() {
                ws.pose3_2[k] = Pose3::from_q(&ws.q2, g);
            }
        } else {
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
            c.phi(&fr, td, &mut ws.phi2[blk.row0..blk.row0 + blk.rows]);
        }
        for i in 0..self.m() {
            b[i] = -ws.phi2[i].v2;
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
                    f[b.offset + k] += m * g[k];
                }
            }
        }
    }

    /// Add the spatial bodies' velocity forces `∂T/∂θ − Ṁ θ̇` (see [`spatial`]).
    #[inline]
    fn velocity_forces_in<D: Scalar, E: Env<D>>(&self, q: &[D], v: &[D], env: E, f: &mut [D]) {
        for (b, g) in self.bodies.iter().zip(&self.geoms3) {
            let n = g.axes.len();
            let o = g.offset + 3;
            // quadratic in the rates: at rest it and its first derivatives vanish
            if v[o..o + n].iter().all(|w| w.re() == 0.0) {
                continue;
            }
            let mut i6 = [D::from(0.0); 6];
            for (x, &c) in i6.iter_mut().zip(&b.inertia_coefs) {
                *x = env.coef(c);
            }
            spatial::velocity_forces(
                &g.axes,
                &q[o..o + n],
                &v[o..o + n],
                &spatial::tensor(i6),
                &mut f[o..o + n],
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
        self.with_frames(q, t, env, |fr| {
            for force in &self.forces {
                force.add(fr, v, t, f);
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
        let mut v = vec![0.0; self.n()];
        if !self.ground.is_moving() {
            return v;
        }
        let g = GroundPose::<f64>::at(&self.ground, t, self.env());
        if self.spatial {
            // the ground translates (it does not rotate in spatial models)
            for b in &self.bodies {
                v[b.offset..b.offset + 3].copy_from_slice(&g.vel);
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

    /// The mass matrix M(q) (nv × nv): constant for planar bodies; for spatial bodies,
    /// block-diagonal with the angles' block `J_bᵀ I J_b` at the pose.
    pub fn mass_matrix_at(&self, q: &[f64]) -> DMatrix<f64> {
        if !self.spatial {
            return self.mass_matrix.clone();
        }
        let mut m = DMatrix::zeros(self.nv(), self.nv());
        for (b, g) in self.bodies.iter().zip(&self.geoms3) {
            for i in 0..3 {
                m[(g.offset + i, g.offset + i)] = b.mass;
            }
            let n = g.axes.len();
            let mut blk = [0.0; 9];
            self.rotational_mass(b, g, q, &mut blk);
            for i in 0..n {
                for j in 0..n {
                    m[(g.offset + 3 + i, g.offset + 3 + j)] = blk[i * n + j];
                }
            }
        }
        m
    }

    /// The mass matrix of a spatial body's angles at q (n × n row-major into `out`).
    pub fn rotational_mass(&self, b: &SysBody, g: &Geom3, q: &[f64], out: &mut [f64]) {
        let n = g.axes.len();
        let p = Pose3::from_parts([0.0; 3], &q[g.offset + 3..g.offset + 3 + n], &g.axes);
        spatial::rotational_mass(&p, n, &spatial::tensor(b.tensor), out);
    }
}
