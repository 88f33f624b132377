//! Kinematics: the closure Φ(q, 0) = 0 solved along a driven coordinate, and the
//! transmission ratios from its tangent.
//!
//! The path starts at the assembled pose ([`crate::dynamics::assemble`]) and follows the
//! branch through it, stepping from the drive's assembled value towards each end of the
//! range: a tangent predictor, then a Newton corrector with the drive held and
//! minimum-norm corrections (kinetic-energy weighted, as in the assembly) in the other
//! coordinates. A step whose corrector fails, or lands too far from its prediction (the
//! signature of a jump to another branch), or lands on a singular pose, is halved; where
//! the step falls below 1e-9 of the nominal one, the branch ends there
//! ([`Failure::DeadPoint`]). A singular pose is one where the Jacobian of the coordinates
//! other than the drive loses rank: a dead point (the drive cannot move on), or a pose
//! where branches cross (the overcentre with equal bars at θ1 = 90°). A step that
//! passes over a crossing without landing on it continues on the smooth branch.
//!
//! Only the coordinates that the constraint blocks connect to the drive move
//! ("the drive's component"); every other coordinate keeps its assembled value exactly
//! (the gearbox angle of `models/inceptor.toml`, which no constraint reaches). Within the
//! component, a coordinate whose column of A is zero at a pose gets no correction there.
//!
//! The tangent `dq/dd` at a point solves `A_F dq_F = −a_d` (A_F: the columns of the other
//! coordinates of the component, a_d: the drive's column), minimum norm where the drive
//! does not determine every coordinate; the ratio `d<drive>/d<name>` is `1 / (dq_name/dd)`.
//! No finite differences.
//!
//! Coordinates are their own velocities here (planar and spatial bodies with angles:
//! nq = nv), as in the assembly.

use crate::diag::Result;
use crate::failure::Failure;
use crate::linalg::{RANK_TOL, all_finite, amax};
use crate::output::plot::{LinePlot, Series, Style};
use crate::output::{num, write_atomic};
use crate::request::{Argument, Invalid};
use crate::system::{System, Workspace};
use nalgebra::{DMatrix, DVector};

/// The most points of a path.
const MAX_POINTS: usize = 10_000_000;

/// Smallest step, as a fraction of the nominal one, before the branch is declared ended.
const MIN_STEP_FRACTION: f64 = 1e-9;

/// Singular values of the (kinetic-energy weighted) Jacobian of the coordinates other
/// than the drive below this fraction of the largest make a pose singular: the branch
/// ends there. (A corrector that lands on a singular pose stops with the coordinates off
/// by about the square root of its tolerance, where σ_min/σ_max is ~2e-7 on the
/// overcentre: a much smaller fraction would take that pose for a regular one.)
const SINGULAR_TOL: f64 = 1e-6;

/// The most Newton iterations of one corrector.
const MAX_NEWTON: usize = 12;

/// A corrector's displacement must stay below this fraction of its predictor's step.
const MAX_CORRECTION: f64 = 0.5;

/// What a kinematic analysis computes.
#[derive(Debug, Clone, PartialEq)]
pub struct KinematicsOptions {
    /// The driven coordinate, e.g. `stick.phi`.
    pub drive: String,
    /// First value of the drive (SI: rad or m).
    pub from: f64,
    /// Last value (included when the step divides the range); below `from` to go down.
    pub to: f64,
    /// Step of the drive (SI, > 0).
    pub step: f64,
    /// Coordinates whose ratio `d<drive>/d<name>` is reported.
    pub ratios: Vec<String>,
}

/// The closure solved along the drive: one point per drive value, from `from` to `to`.
#[derive(Debug, Clone)]
pub struct KinematicPath {
    /// The driven coordinate and its index.
    pub drive: String,
    pub drive_index: usize,
    /// Every coordinate, and whether each is an angle.
    pub coordinates: Vec<String>,
    pub angles: Vec<bool>,
    /// Whether each coordinate moves with the drive (its component of the constraints);
    /// the others keep their assembled values.
    pub moving: Vec<bool>,
    /// The drive's assembled value, where the branch was picked up.
    pub start: f64,
    /// The drive's values (SI), in the order asked.
    pub values: Vec<f64>,
    /// The coordinates at each value (SI).
    pub q: Vec<Vec<f64>>,
    /// The coordinates of the ratios.
    pub ratio_names: Vec<String>,
    pub ratio_indices: Vec<usize>,
    /// `d<drive>/d<name>` at each value, one per ratio coordinate.
    pub ratios: Vec<Vec<f64>>,
}

/// The index of the driven coordinate `name`, or the invalid request.
pub fn drive_index(sys: &System, name: &str) -> Result<usize> {
    Ok(crate::request::coordinate(
        &sys.coordinates,
        name,
        Argument::Drive,
    )?)
}

/// The drive's values from `from` to `to` (either way) by `step`: `to` is included when
/// the step divides the range (to 1e-9 of a step).
pub fn drive_grid(from: f64, to: f64, step: f64) -> Result<Vec<f64>> {
    if !(from.is_finite() && to.is_finite()) {
        return Err(Invalid::Range {
            what: Argument::DriveRange,
            from,
            to,
        }
        .into());
    }
    if !(step > 0.0) || !step.is_finite() {
        return Err(Invalid::NotPositive {
            argument: Argument::DriveStep,
            value: step,
        }
        .into());
    }
    let span = (to - from).abs();
    let n = (span / step + 1e-9).floor();
    if !(n < MAX_POINTS as f64) {
        return Err(Invalid::TooManyPoints {
            argument: Argument::DriveStep,
            value: step,
            points: n,
            limit: MAX_POINTS,
        }
        .into());
    }
    let n = n as usize;
    let dir = if to < from { -1.0 } else { 1.0 };
    let mut values: Vec<f64> = (0..=n).map(|k| from + dir * k as f64 * step).collect();
    // the end exactly when the step divides the range
    if let Some(last) = values.last_mut()
        && (*last - to).abs() <= 1e-9 * step
    {
        *last = to;
    }
    Ok(values)
}

/// Solve the closure Φ(q, 0) = 0 along the coordinate `opts.drive` over its range, on
/// the branch through the assembled pose, with the ratios `d<drive>/d<name>` from the
/// tangent (see the module's documentation).
pub fn kinematics(sys: &System, opts: &KinematicsOptions) -> Result<KinematicPath> {
    let drive = drive_index(sys, &opts.drive)?;
    let moving = component(sys, drive);
    let mut ratio_indices = Vec::with_capacity(opts.ratios.len());
    for name in &opts.ratios {
        let i = crate::request::coordinate(&sys.coordinates, name, Argument::Ratio)?;
        if !moving[i] {
            return Err(Invalid::NotDriven {
                name: name.clone(),
                drive: opts.drive.clone(),
            }
            .into());
        }
        ratio_indices.push(i);
    }
    let values = drive_grid(opts.from, opts.to, opts.step)?;
    let start = crate::dynamics::assemble_at_rest(sys)?;
    // a drive the constraints fix (its unit vector in the row space of A) cannot move
    {
        let mut ws = crate::dynamics::DynWorkspace::new(sys);
        sys.jacobian(&mut ws.sys, &start.q, 0.0, &mut ws.a);
        if sys.m() > 0 {
            let mut e = nalgebra::DVector::zeros(sys.nv());
            e[drive] = 1.0;
            let at = ws.a.transpose();
            let y = crate::linalg::solve_least_squares(at.clone(), &e);
            if (&at * y - &e).amax() < 1e-8 {
                return Err(Invalid::FixedDrive {
                    drive: opts.drive.clone(),
                }
                .into());
            }
        }
    }
    let mut closure = Closure::new(sys, drive, &moving);
    let d0 = start.q[drive];
    let mut q0 = start.q.clone();
    let dead = |value: f64, target: f64| Failure::DeadPoint {
        drive: opts.drive.clone(),
        value,
        target,
        angle: sys.is_angle(drive),
    };
    // the assembled pose, to the corrector's tolerance (the assembly stops at 1e-9)
    if !closure.correct(&mut q0) {
        return Err(dead(d0, values[0]).into());
    }
    let Some(t0) = closure.tangent(&q0) else {
        return Err(dead(d0, values[0]).into());
    };
    // the grid's values above the start, going up, and below it, going down
    let mut up: Vec<usize> = (0..values.len()).filter(|&k| values[k] >= d0).collect();
    let mut down: Vec<usize> = (0..values.len()).filter(|&k| values[k] < d0).collect();
    up.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    down.sort_by(|&a, &b| values[b].total_cmp(&values[a]));
    let mut points: Vec<Option<(Vec<f64>, Vec<f64>)>> = vec![None; values.len()];
    for targets in [up, down] {
        let mut q = q0.clone();
        let mut t = t0.clone();
        let mut h = opts.step;
        for k in targets {
            closure
                .reach(&mut q, &mut t, &mut h, values[k], opts.step)
                .map_err(|reached| dead(reached, values[k]))?;
            points[k] = Some((q.clone(), t.clone()));
        }
    }
    let mut q = Vec::with_capacity(values.len());
    let mut ratios = Vec::with_capacity(values.len());
    for (qk, tk) in points.into_iter().flatten() {
        ratios.push(ratio_indices.iter().map(|&i| ratio(&tk, i)).collect());
        q.push(qk);
    }
    Ok(KinematicPath {
        drive: opts.drive.clone(),
        drive_index: drive,
        coordinates: sys.coordinates.clone(),
        angles: sys.angles(),
        moving,
        start: d0,
        values,
        q,
        ratio_names: opts.ratios.clone(),
        ratio_indices,
        ratios,
    })
}

/// `d<drive>/d<coordinate i>` from the tangent `t` (dq/d<drive>, so t[drive] = 1):
/// 1/t[i], or +∞ where coordinate i is stationary (|t[i]| within round-off,
/// [`STATIONARY`] of the tangent's largest entry: a dead point of that coordinate, where
/// 1/t[i] would be a number of order 1e15 made of rounding errors).
fn ratio(t: &[f64], i: usize) -> f64 {
    let scale = t.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if t[i].abs() <= STATIONARY * scale {
        f64::INFINITY
    } else {
        1.0 / t[i]
    }
}

/// A tangent entry below this fraction of the tangent's largest is round-off: its
/// coordinate does not move with the drive there (the ratio is infinite).
pub const STATIONARY: f64 = 1e-12;

/// The coordinates that the constraint blocks connect to `drive` (itself included).
fn component(sys: &System, drive: usize) -> Vec<bool> {
    let n = sys.nq();
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for b in sys.blocks() {
        if let Some(&first) = b.cols.first() {
            for &j in &b.cols[1..] {
                let (a, c) = (root(&mut parent, first), root(&mut parent, j));
                parent[a] = c;
            }
        }
    }
    let r = root(&mut parent, drive);
    (0..n).map(|i| root(&mut parent, i) == r).collect()
}

/// The closure restricted to the drive's component, with its scratch space.
struct Closure<'a> {
    sys: &'a System,
    drive: usize,
    /// The component's coordinates other than the drive.
    free: Vec<usize>,
    /// The component's constraint rows.
    rows: Vec<usize>,
    /// Column weights of the minimum-norm solves: M_ii^-½ (kinetic-energy norm).
    weight: Vec<f64>,
    /// The rank of A_F at the start (to [`SINGULAR_TOL`]), once known.
    rank: Option<usize>,
    ws: Workspace,
    a: DMatrix<f64>,
}

impl<'a> Closure<'a> {
    fn new(sys: &'a System, drive: usize, moving: &[bool]) -> Closure<'a> {
        let free = (0..sys.nq()).filter(|&i| moving[i] && i != drive).collect();
        let mut rows = Vec::new();
        for b in sys.blocks() {
            if b.cols.iter().any(|&j| moving[j]) {
                rows.extend(b.row0..b.row0 + b.rows);
            }
        }
        let weight = sys.mass_weights();
        Closure {
            sys,
            drive,
            free,
            rows,
            weight,
            rank: None,
            ws: Workspace::new(sys),
            a: DMatrix::zeros(sys.m(), sys.nv()),
        }
    }

    /// The component's rows of Φ(q, 0).
    fn residual(&self, q: &[f64]) -> DVector<f64> {
        let phi = self.sys.residual(q, 0.0);
        DVector::from_iterator(self.rows.len(), self.rows.iter().map(|&r| phi[r]))
    }

    /// The tolerance on |Φ|∞ at q.
    fn tol(q: &[f64]) -> f64 {
        1e-13 * (1.0 + amax(q))
    }

    /// A at q (into `self.a`).
    fn jacobian(&mut self, q: &[f64]) {
        self.sys.jacobian(&mut self.ws, q, 0.0, &mut self.a);
    }

    /// The weighted minimum-norm solution x (nv, zero outside the free coordinates and
    /// in the columns of A that are zero) of `A_F x = rhs` over the component's rows,
    /// with the numerical ranks of A_F and of [A_F a_d] (singular values below `tol` of
    /// the largest count as zero, in the ranks only); `None` if not finite.
    fn solve(&self, rhs: &DVector<f64>, tol: f64) -> Option<(Vec<f64>, usize, usize)> {
        let mut x = vec![0.0; self.sys.nv()];
        let cols: Vec<usize> = self
            .free
            .iter()
            .copied()
            .filter(|&j| self.rows.iter().any(|&r| self.a[(r, j)] != 0.0))
            .collect();
        if self.rows.is_empty() || cols.is_empty() {
            return Some((x, 0, 0));
        }
        let af = DMatrix::from_fn(self.rows.len(), cols.len(), |i, k| {
            self.a[(self.rows[i], cols[k])] * self.weight[cols[k]]
        });
        if !all_finite(af.as_slice()) || !all_finite(rhs.as_slice()) {
            return None;
        }
        let ad = DMatrix::from_fn(self.rows.len(), 1, |i, _| {
            self.a[(self.rows[i], self.drive)] * self.weight[self.drive]
        });
        let augmented = DMatrix::from_fn(self.rows.len(), cols.len() + 1, |i, k| {
            if k < cols.len() {
                af[(i, k)]
            } else {
                ad[(i, 0)]
            }
        });
        let rank_full = rank(&augmented, tol);
        let svd = crate::linalg::svd_or_nan(af, true, true);
        let smax = svd.singular_values.max().max(f64::MIN_POSITIVE);
        let rank_f = svd.rank(tol * smax);
        let y = svd.solve(rhs, RANK_TOL * smax).ok()?;
        for (k, &j) in cols.iter().enumerate() {
            x[j] = y[k] * self.weight[j];
        }
        all_finite(&x).then_some((x, rank_f, rank_full))
    }

    /// Newton's method on the component's rows with the drive held, in place: whether
    /// |Φ|∞ reached the tolerance.
    fn correct(&mut self, q: &mut [f64]) -> bool {
        let tol = Self::tol(q);
        let mut phi = self.residual(q);
        let mut norm = amax(phi.as_slice());
        for _ in 0..MAX_NEWTON {
            if norm <= tol {
                return true;
            }
            if !norm.is_finite() {
                return false;
            }
            self.jacobian(q);
            let Some((dx, _, _)) = self.solve(&phi, RANK_TOL) else {
                return false;
            };
            self.sys.retract(q, &dx, -1.0);
            let new_phi = self.residual(q);
            let new_norm = amax(new_phi.as_slice());
            if !(new_norm < norm) {
                return new_norm <= tol;
            }
            phi = new_phi;
            norm = new_norm;
        }
        norm <= tol
    }

    /// The tangent dq/dd at q (nv, 1 at the drive, 0 outside the component), or `None`
    /// where the other coordinates' Jacobian A_F is singular: its rank (to
    /// [`SINGULAR_TOL`]) falls below that of [A_F a_d] (a dead point: the drive cannot
    /// move there) or below its rank at the start (a singular pose, where branches
    /// cross). The first call sets the rank at the start.
    fn tangent(&mut self, q: &[f64]) -> Option<Vec<f64>> {
        self.jacobian(q);
        let rhs = DVector::from_iterator(
            self.rows.len(),
            self.rows.iter().map(|&r| -self.a[(r, self.drive)]),
        );
        let (mut t, rank_f, rank_full) = self.solve(&rhs, SINGULAR_TOL)?;
        let generic = *self.rank.get_or_insert(rank_f);
        if rank_f < rank_full || rank_f < generic {
            return None;
        }
        t[self.drive] = 1.0;
        Some(t)
    }

    /// Follow the branch from (q, t) to the drive value `target` in steps of at most
    /// `nominal`, halving a step that fails and doubling it again after a success (`h`
    /// carries the step between calls). On success q and t are at the target; else the
    /// drive value reached (the branch ends there).
    fn reach(
        &mut self,
        q: &mut Vec<f64>,
        t: &mut Vec<f64>,
        h: &mut f64,
        target: f64,
        nominal: f64,
    ) -> std::result::Result<(), f64> {
        let h_min = MIN_STEP_FRACTION * nominal;
        loop {
            let d = q[self.drive];
            let remaining = target - d;
            if remaining == 0.0 {
                return Ok(());
            }
            let lands = remaining.abs() <= *h;
            let s = if lands {
                remaining
            } else {
                h.copysign(remaining)
            };
            let mut trial = q.clone();
            self.sys.retract(&mut trial, t, s);
            if lands {
                trial[self.drive] = target;
            }
            let predicted = trial.clone();
            // (the slack: the corrector's own tolerance, for a last step of a few ulps)
            let slack = 1e-10 * (1.0 + amax(q));
            let accepted = self.correct(&mut trial)
                && distance(&trial, &predicted) <= MAX_CORRECTION * distance(&predicted, q) + slack
                && match self.tangent(&trial) {
                    // the same branch: the tangent keeps its direction
                    Some(tn) if dot(&tn, t) > 0.0 => {
                        *t = tn;
                        true
                    }
                    _ => false,
                };
            if accepted {
                *q = trial;
                *h = (*h * 2.0).min(nominal);
            } else {
                *h *= 0.5;
                if *h < h_min {
                    return Err(d);
                }
            }
        }
    }
}

/// Numerical rank: singular values above `tol` of the largest.
fn rank(m: &DMatrix<f64>, tol: f64) -> usize {
    let s = crate::linalg::svd_or_nan(m.clone(), false, false).singular_values;
    let eps = tol * s.max().max(f64::MIN_POSITIVE);
    s.iter().filter(|&&x| x > eps).count()
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

// ---- output ------------------------------------------------------------------------------

impl KinematicPath {
    /// The CSV header: the drive (named as the coordinate), every coordinate, then
    /// `d<drive>/d<name>` per ratio. The drive's name appears twice (first, and among the
    /// coordinates, with the same values): the layout issue 9 specifies and scripts rely
    /// on (the drive first, then every coordinate in the model's order).
    pub fn header(&self) -> Vec<String> {
        let mut h = vec![self.drive.clone()];
        h.extend(self.coordinates.iter().cloned());
        h.extend(
            self.ratio_names
                .iter()
                .map(|n| format!("d{}/d{n}", self.drive)),
        );
        h
    }

    /// The CSV: one row per drive value, in SI (angles in rad, as every CSV of detune).
    pub fn write_csv(&self, path: &str) -> Result<()> {
        write_atomic(path, |w| {
            writeln!(w, "{}", self.header().join(","))?;
            for (k, d) in self.values.iter().enumerate() {
                write!(w, "{}", num(*d))?;
                for x in &self.q[k] {
                    write!(w, ",{}", num(*x))?;
                }
                for r in &self.ratios[k] {
                    write!(w, ",{}", num(*r))?;
                }
                writeln!(w)?;
            }
            Ok(())
        })
    }

    /// A value of coordinate `i` as drawn: degrees for an angle, else SI.
    fn shown(&self, i: usize, x: f64) -> f64 {
        if self.angles[i] { x.to_degrees() } else { x }
    }

    /// The unit a coordinate is drawn in.
    fn shown_unit(&self, i: usize) -> &'static str {
        if self.angles[i] { "deg" } else { "m" }
    }

    /// The unit of the ratio `d<drive>/d<coordinate i>` (SI).
    pub fn ratio_unit(&self, i: usize) -> &'static str {
        match (self.angles[self.drive_index], self.angles[i]) {
            (true, true) => "rad/rad",
            (true, false) => "rad/m",
            (false, true) => "m/rad",
            (false, false) => "m/m",
        }
    }

    /// The figure: the ratios against the drive (degrees for an angle); without ratios,
    /// every other coordinate against the drive, angles (degrees) and lengths (m) in
    /// two panels. `name` is the model's.
    pub fn figures(&self, name: &str) -> Vec<LinePlot> {
        let d = self.drive_index;
        let x: Vec<f64> = self.values.iter().map(|&v| self.shown(d, v)).collect();
        let x_label = format!("{} [{}]", self.drive, self.shown_unit(d));
        if !self.ratio_names.is_empty() {
            let units: Vec<&str> = self
                .ratio_indices
                .iter()
                .map(|&i| self.ratio_unit(i))
                .collect();
            let y_label = if self.ratio_names.len() == 1 {
                format!("d{}/d{} [{}]", self.drive, self.ratio_names[0], units[0])
            } else if units.iter().all(|u| *u == units[0]) {
                format!("d{}/d(coordinate) [{}]", self.drive, units[0])
            } else {
                format!("d{}/d(coordinate) [SI]", self.drive)
            };
            return vec![LinePlot {
                title: format!("{name}: transmission ratio, driven by {}", self.drive),
                x_label,
                y_label,
                series: self
                    .ratio_names
                    .iter()
                    .enumerate()
                    .map(|(r, n)| Series {
                        label: format!("d{}/d{n} [{}]", self.drive, units[r]),
                        x: x.clone(),
                        y: self.ratios.iter().map(|row| row[r]).collect(),
                        style: Style::Solid,
                        color: None,
                    })
                    .collect(),
                ..LinePlot::default()
            }];
        }
        let mut plots = Vec::new();
        for (angle, y_label) in [(true, "angle [deg]"), (false, "length [m]")] {
            let series: Vec<Series> = (0..self.coordinates.len())
                .filter(|&i| i != d && self.angles[i] == angle)
                .map(|i| Series {
                    label: format!(
                        "{} [{}]",
                        self.coordinates[i],
                        if angle { "deg" } else { "m" }
                    ),
                    x: x.clone(),
                    y: self.q.iter().map(|q| self.shown(i, q[i])).collect(),
                    style: Style::Solid,
                    color: None,
                })
                .collect();
            if !series.is_empty() {
                plots.push(LinePlot {
                    title: format!("{name}: coordinates, driven by {}", self.drive),
                    x_label: x_label.clone(),
                    y_label: y_label.into(),
                    series,
                    ..LinePlot::default()
                });
            }
        }
        plots
    }
}
