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
            })
            .collect();
        let assembly = assemble(sys).map(|s| {
            let rank = constraint_rank(sys, &s.q, 0.0);
            CheckedAssembly {
                rank,
                dof: sys.nv() - rank,
                residual: residual_norm(sys, &s.q, 0.0),
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
            constraints: sys.constraint_names.clone(),
            ground_motion: {
                let g = &model.ground;
                [("x", &g.x), ("y", &g.y), ("theta", &g.theta)]
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
            let dim = par.dim.map(|d| format!(" {d}")).unwrap_or_default();
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
                    writeln!(f, "  {c:<16} initial {:>22.15}{fixed}", a.q[i])?;
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
        writeln!(f, "degrees of freedom: {}", a.dof)?;
        writeln!(f, "initial constraint residual: {:.3e}", a.residual)
    }
}
