//! The `check` report: what a model compiles to before any analysis: parameters in SI,
//! coordinates with their assembled initial values, constraints, the constraint rank and
//! the degrees of freedom at the initial pose.

use crate::diag::Result;
use crate::dynamics::{assemble, constraint_rank, residual_norm};
use crate::model::Model;
use crate::model::units::Dim;
use crate::system::System;
use std::fmt;

/// One parameter of the report.
#[derive(Debug, Clone)]
pub struct CheckedParameter {
    pub name: String,
    /// SI value.
    pub value: f64,
    pub dim: Option<Dim>,
    /// The `--set` text that gave it, if any.
    pub set: Option<String>,
    /// The unit the value is shown in: the declared one when it is SI-coherent (`rad/s`,
    /// `N*m/rad`), else the SI unit of the dimension (`rad` for a dimensionless one
    /// declared as an angle).
    pub unit: String,
    /// The declared unit and the value in it, when that unit is not SI (`rpm`, `deg`,
    /// `mm`).
    pub declared: Option<(String, f64)>,
}

/// The initial pose, assembled.
#[derive(Debug, Clone)]
pub struct CheckedAssembly {
    /// Coordinates (n).
    pub q: Vec<f64>,
    /// Rank of the constraint Jacobian at q.
    pub rank: usize,
    /// Degrees of freedom: coordinates less the rank.
    pub dof: usize,
    /// |Φ|∞ at q.
    pub residual: f64,
    /// Per constraint element, in order: its rows, the rank they add to the elements
    /// before it, and the degrees of freedom left after it.
    pub elements: Vec<CheckedElement>,
}

/// One joint or custom constraint at the assembled pose.
#[derive(Debug, Clone)]
pub struct CheckedElement {
    pub name: String,
    /// The element's type (`revolute`, `spherical`, `constraint`...).
    pub kind: String,
    pub rows: usize,
    /// Rank added to the rows of the elements before it.
    pub rank: usize,
    /// Degrees of freedom left after it (coordinates less the rank so far).
    pub dof: usize,
}

/// The incremental rank of each element's rows of A M^-½ at q.
fn element_ranks(model: &Model, sys: &System, q: &[f64]) -> Vec<CheckedElement> {
    use crate::linalg::RANK_TOL;
    let mut ws = crate::dynamics::DynWorkspace::new(sys);
    sys.jacobian(&mut ws.sys, q, 0.0, &mut ws.a);
    let m_half = sys.mass_matrix_at(q).map(|x| x.max(0.0).sqrt());
    // scale columns by M^-½ of the diagonal (unit-consistent rows; rank is unchanged by
    // any column scaling)
    let mut a = ws.a.clone();
    for j in 0..a.ncols() {
        let w = m_half[(j, j)];
        if w > 0.0 {
            a.column_mut(j).scale_mut(1.0 / w);
        }
    }
    let kinds: Vec<String> = model
        .joints
        .iter()
        .map(|j| match &j.kind {
            crate::model::JointKind::Revolute => "revolute".into(),
            crate::model::JointKind::PinInSlot { .. } => "pin_in_slot".into(),
            crate::model::JointKind::Prismatic { .. } => "prismatic".into(),
            crate::model::JointKind::Fixed { .. } => "fixed".into(),
            crate::model::JointKind::Spatial { kind, .. } => format!("{kind:?}").to_lowercase(),
        })
        .chain(model.constraints.iter().map(|_| "constraint".to_string()))
        .collect();
    let rank_of = |rows: usize| -> usize {
        if rows == 0 {
            return 0;
        }
        let sub = a.rows(0, rows).into_owned();
        let sv = crate::linalg::svd_or_nan(sub, false, false).singular_values;
        let smax = sv.max();
        if !smax.is_finite() || smax == 0.0 {
            return 0;
        }
        sv.iter().filter(|&&x| x > RANK_TOL * smax).count()
    };
    let mut out = Vec::new();
    let mut before = 0;
    for (k, (name, r)) in sys.element_rows().into_iter().enumerate() {
        let rank = rank_of(r.end);
        out.push(CheckedElement {
            name,
            kind: kinds.get(k).cloned().unwrap_or_default(),
            rows: r.len(),
            rank: rank - before,
            dof: sys.nv() - rank,
        });
        before = rank;
    }
    out
}

/// The unit a parameter's SI value is shown in (see [`CheckedParameter::unit`]): the
/// declared unit when it is SI-coherent (`N*m/rad` as written), else the SI unit of the
/// dimension with the angle the declared unit carries (`deg` → `rad`, `rpm` and `Hz` →
/// `rad/s`, `lbf*in/deg` → `N·m/rad`). Undeclared, the angle of its quantity literals of
/// the same dimension (`45 deg` → `rad`, `2 Hz` → `rad/s`); a frequency is rad/s anyway
/// (all frequencies in detune are angular).
fn shown_unit(
    declared: Option<&(String, Dim)>,
    dim: Option<Dim>,
    expr: &crate::model::expr::Expr,
) -> String {
    use crate::model::units::{angle_power, parse_unit, si_unit_with_angle};
    if let Some((text, d)) = declared
        && let Ok((factor, _)) = parse_unit(text)
    {
        if factor == 1.0 && !text.trim().is_empty() && text.trim() != "1" {
            return text.clone();
        }
        return si_unit_with_angle(*d, angle_power(text));
    }
    let Some(dim) = dim else {
        return String::new();
    };
    let angle = expr
        .quantity_units()
        .into_iter()
        .find(|u| parse_unit(u).is_ok_and(|(_, d)| d == dim) && angle_power(u) != 0)
        .map(angle_power)
        .unwrap_or(if dim == Dim::FREQUENCY { 1 } else { 0 });
    si_unit_with_angle(dim, angle)
}

/// The declared unit and the value in it, when it is not the SI unit shown (`rpm`, `deg`,
/// `mm`): shown beside the SI value.
fn in_declared(declared: Option<&(String, Dim)>, value: f64) -> Option<(String, f64)> {
    let (text, _) = declared?;
    let (factor, _) = crate::model::units::parse_unit(text).ok()?;
    (factor != 1.0).then(|| (text.trim().to_string(), value / factor))
}

/// What `detune check` reports; [`fmt::Display`] gives its text.
#[derive(Debug)]
pub struct CheckReport {
    pub name: String,
    pub path: String,
    pub description: Option<String>,
    pub parameters: Vec<CheckedParameter>,
    pub coordinates: Vec<String>,
    /// Coordinates held during assembly.
    pub fixed: Vec<bool>,
    /// Whether each coordinate is an angle (rad; shown in degrees too) or a length (m).
    pub angles: Vec<bool>,
    pub lengths: Vec<bool>,
    pub constraints: Vec<String>,
    /// The ground's prescribed motion as written (`x = ...`), if it moves.
    pub ground_motion: Vec<String>,
    /// The assembled initial pose, or why it could not be assembled (the rest of the
    /// report stands without it).
    pub assembly: Result<CheckedAssembly>,
}

impl CheckReport {
    pub fn new(model: &Model, sys: &System) -> CheckReport {
        let p = &model.parameters;
        let parameters = p
            .list
            .iter()
            .enumerate()
            .map(|(i, par)| CheckedParameter {
                name: par.name.clone(),
                value: p.values[i],
                dim: p.dims[i],
                set: p.overridden[i].clone(),
                unit: shown_unit(par.unit.as_ref(), p.dims[i], &par.field.expr),
                declared: in_declared(par.unit.as_ref(), p.values[i]),
            })
            .collect();
        let assembly = assemble(sys).map(|s| {
            let rank = constraint_rank(sys, &s.q, 0.0);
            CheckedAssembly {
                rank,
                dof: sys.nv() - rank,
                residual: residual_norm(sys, &s.q, 0.0),
                elements: element_ranks(model, sys, &s.q),
                q: s.q,
            }
        });
        CheckReport {
            name: model.name.clone(),
            path: model.source.path.clone(),
            description: model.description.clone(),
            parameters,
            coordinates: sys.coordinates.clone(),
            fixed: sys.initial.fixed.clone(),
            angles: sys.angles(),
            lengths: sys
                .coordinate_dims
                .iter()
                .map(|d| *d == Dim::LENGTH)
                .collect(),
            constraints: sys.constraint_names.clone(),
            ground_motion: {
                let g = &model.ground;
                [
                    ("x", &g.x),
                    ("y", &g.y),
                    ("z", &g.z),
                    ("theta", &g.theta),
                    ("rx", &g.rx),
                    ("ry", &g.ry),
                    ("rz", &g.rz),
                ]
                .into_iter()
                .filter_map(|(c, f)| f.as_ref().map(|f| format!("{c} = {}", f.expr)))
                .collect()
            },
            assembly,
        }
    }
}

impl fmt::Display for CheckReport {
    /// The report as `detune check` prints it; without an assembled pose, it ends after
    /// the constraints.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "model {} ({})", self.name, self.path)?;
        if let Some(d) = &self.description {
            writeln!(f, "  {d}")?;
        }
        writeln!(f, "\nparameters (SI):")?;
        for par in &self.parameters {
            // an angle's value in degrees beside its radians (the unit says which
            // parameters are angles)
            // and a value declared in another unit (rpm, mm) in it too
            let dim = if par.unit.is_empty() {
                String::new()
            } else if par.unit == "rad" {
                format!(" rad ({:.6}°)", par.value.to_degrees())
            } else if let Some((u, v)) = &par.declared {
                // to 9 decimals, trailing zeros dropped (120 rpm, not 120.00000000000001)
                let v = format!("{v:.9}");
                let v = v.trim_end_matches('0').trim_end_matches('.');
                format!(" {} ({v} {u})", par.unit)
            } else {
                format!(" {}", par.unit)
            };
            let set = par
                .set
                .as_ref()
                .map(|s| format!("   (--set {s})"))
                .unwrap_or_default();
            writeln!(f, "  {:<12} = {:<22}{dim}{set}", par.name, par.value)?;
        }
        writeln!(f, "\ncoordinates ({}):", self.coordinates.len())?;
        match &self.assembly {
            Ok(a) => {
                for (i, c) in self.coordinates.iter().enumerate() {
                    let fixed = if self.fixed[i] { "  (fixed)" } else { "" };
                    let deg = if self.angles.get(i).copied().unwrap_or(false) {
                        format!(" rad ({:.6}°)", a.q[i].to_degrees())
                    } else if self.lengths.get(i).copied().unwrap_or(false) {
                        " m".to_string()
                    } else {
                        String::new()
                    };
                    writeln!(f, "  {c:<16} initial {:>22.15}{deg}{fixed}", a.q[i])?;
                }
            }
            Err(_) => {
                for c in &self.coordinates {
                    writeln!(f, "  {c}")?;
                }
            }
        }
        let m = self.constraints.len();
        writeln!(f, "\nconstraints ({m} equations):")?;
        for c in &self.constraints {
            writeln!(f, "  {c}")?;
        }
        if !self.ground_motion.is_empty() {
            writeln!(f, "\nground motion: {}", self.ground_motion.join(", "))?;
        }
        let Ok(a) = &self.assembly else {
            return Ok(());
        };
        writeln!(
            f,
            "\nconstraint rank at the initial pose: {} of {m} equations",
            a.rank
        )?;
        if a.rank < m {
            writeln!(
                f,
                "  ({} redundant or singular; the pseudoinverse handles them)",
                m - a.rank
            )?;
        }
        writeln!(
            f,
            "  {:<16} {:<12} {:>4} {:>6} {:>9}",
            "element", "type", "rows", "rank", "DoF left"
        )?;
        for e in &a.elements {
            writeln!(
                f,
                "  {:<16} {:<12} {:>4} {:>6} {:>9}",
                e.name, e.kind, e.rows, e.rank, e.dof
            )?;
        }
        writeln!(f, "degrees of freedom: {}", a.dof)?;
        writeln!(
            f,
            "initial constraint residual: {:.3e} (m or rad)",
            a.residual
        )
    }
}
