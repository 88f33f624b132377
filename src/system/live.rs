//! Live parameters: the compiled system keeps every parameter as a value it can change
//! without recompiling, and every element coefficient (mass, stiffness, point, free
//! length...) as an expression over the parameters, re-evaluated when one changes.
//!
//! A parameter defined from others (`s = L1`) follows them until it is set itself. The
//! same evaluation runs in any [`Scalar`] type: seeded with a dual part on one parameter it
//! gives the derivative of every coefficient with respect to it ([`Live::seeded`]).
//!
//! Checks that depend on values (a mass must be positive, a coefficient finite) are kept
//! as a list and re-run on every change, so a changed parameter is refused with the same
//! located message as a bad value in the file.

use crate::diag::Diagnostic;
use crate::model::expr::Compiled;
use crate::model::units::Dim;
use crate::scalar::{Scalar, Seeded};
use std::ops::Range;

/// What a coefficient must satisfy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CheckKind {
    Finite,
    Positive,
    NonNegative,
    /// Below the value of another coefficient (an end stop's lower limit below its
    /// upper one).
    Below(usize),
}

/// A value check on one coefficient, with what to say where.
#[derive(Debug, Clone)]
pub struct Check {
    pub coef: usize,
    pub kind: CheckKind,
    /// What the value is ("the mass of `bar1`").
    pub what: String,
    pub dim: Dim,
    /// Where it is written in the model file.
    pub span: Range<usize>,
}

/// Parameter values and the coefficients computed from them.
#[derive(Debug, Clone, Default)]
pub struct Live {
    pub names: Vec<String>,
    /// SI value of each parameter.
    pub values: Vec<f64>,
    /// How each parameter follows others (None: a free value), and the definitions as
    /// written.
    defs: Vec<Option<Compiled>>,
    texts: Vec<String>,
    /// Parameters in dependency order.
    order: Vec<usize>,
    /// Coefficient expressions over the parameters.
    coef_defs: Vec<Compiled>,
    /// Unit normals derived from axis coefficients: (axis, normal) = ([ax, ay], [nx, ny]),
    /// n = (−ay, ax)/|a|.
    normals: Vec<([usize; 2], [usize; 2])>,
    /// Orthonormal frames derived from spatial axes: (axis, [a, u, w]) with a the unit
    /// axis, u ⟂ a (from the coordinate axis least aligned with a) and w = a × u.
    frames: Vec<([usize; 3], [[usize; 3]; 3])>,
    /// Current value of each coefficient.
    pub coefs: Vec<f64>,
    pub checks: Vec<Check>,
    /// Parameters read directly by expressions of coordinates or time, with where.
    pub used: Vec<(usize, Range<usize>)>,
}

impl Live {
    /// Parameters `names` with their current `values`; `defs[i]` (over the parameters)
    /// for those defined from others; `order` lists dependencies first.
    pub fn new(
        names: Vec<String>,
        values: Vec<f64>,
        defs: Vec<Option<Compiled>>,
        texts: Vec<String>,
        order: Vec<usize>,
    ) -> Live {
        Live {
            names,
            values,
            defs,
            texts,
            order,
            ..Live::default()
        }
    }

    /// The definition parameter `i` follows, if any, as text.
    pub fn definition(&self, i: usize) -> Option<String> {
        self.defs[i].as_ref().map(|_| self.texts[i].clone())
    }

    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// Add a coefficient defined by `def`; its index.
    pub fn coef(&mut self, def: Compiled) -> usize {
        self.coef_defs.push(def);
        self.coefs.push(f64::NAN);
        self.coefs.len() - 1
    }

    /// Add the unit normal of the axis (ax, ay): two coefficients, indices returned.
    pub fn normal(&mut self, axis: [usize; 2]) -> [usize; 2] {
        let nx = self.coef(Compiled::constant(f64::NAN));
        let ny = self.coef(Compiled::constant(f64::NAN));
        self.normals.push((axis, [nx, ny]));
        [nx, ny]
    }

    /// Add the orthonormal frame (a, u, w) of a spatial axis: nine coefficients.
    pub fn axis_frame(&mut self, axis: [usize; 3]) -> [[usize; 3]; 3] {
        let mut f = [[0; 3]; 3];
        for v in &mut f {
            for c in v.iter_mut() {
                *c = self.coef(Compiled::constant(f64::NAN));
            }
        }
        self.frames.push((axis, f));
        f
    }

    /// Parameters and coefficients in type D, every parameter lifted by `lift`, with
    /// parameter `free` (if any) held at its lifted value instead of following its
    /// definition.
    pub fn evaluate<D: Scalar>(
        &self,
        lift: impl Fn(usize, f64) -> D,
        free: Option<usize>,
    ) -> (Vec<D>, Vec<D>) {
        self.evaluate_holding(lift, free.as_slice())
    }

    /// [`Live::evaluate`] with every parameter of `free` held at its lifted value.
    fn evaluate_holding<D: Scalar>(
        &self,
        lift: impl Fn(usize, f64) -> D,
        free: &[usize],
    ) -> (Vec<D>, Vec<D>) {
        let mut p: Vec<D> = self
            .values
            .iter()
            .enumerate()
            .map(|(i, &v)| lift(i, v))
            .collect();
        let zero = D::from(0.0);
        for &i in &self.order {
            if free.contains(&i) {
                continue;
            }
            if let Some(d) = &self.defs[i] {
                let v = d.eval_in(
                    &[],
                    zero,
                    Seeded {
                        params: &p,
                        coefs: &[],
                    },
                );
                p[i] = v;
            }
        }
        let env = Seeded {
            params: &p,
            coefs: &[],
        };
        let mut c: Vec<D> = self
            .coef_defs
            .iter()
            .map(|d| d.eval_in(&[], zero, env))
            .collect();
        for (a, n) in &self.normals {
            let (ax, ay) = (c[a[0]], c[a[1]]);
            let len = (ax * ax + ay * ay).sqrt();
            c[n[0]] = -ay / len;
            c[n[1]] = ax / len;
        }
        for (a, f) in &self.frames {
            let v = [c[a[0]], c[a[1]], c[a[2]]];
            let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            let a = [v[0] / len, v[1] / len, v[2] / len];
            // the coordinate axis least aligned with a
            let k = (0..3)
                .min_by(|&i, &j| a[i].re().abs().total_cmp(&a[j].re().abs()))
                .unwrap_or(0);
            let mut u = [D::from(0.0); 3];
            u[k] = D::from(1.0);
            let d = a[k];
            for i in 0..3 {
                u[i] -= d * a[i];
            }
            let ul = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
            for x in &mut u {
                *x /= ul;
            }
            let w = [
                a[1] * u[2] - a[2] * u[1],
                a[2] * u[0] - a[0] * u[2],
                a[0] * u[1] - a[1] * u[0],
            ];
            for (idx, vals) in f.iter().zip([a, u, w]) {
                for (i, x) in idx.iter().zip(vals) {
                    c[*i] = x;
                }
            }
        }
        (p, c)
    }

    /// Parameters and coefficients carrying ∂/∂p_i in their dual part: parameter `i` is
    /// `value` (its dual part the seed) and the rest follow.
    pub fn seeded<D: Scalar>(&self, i: usize, value: D) -> (Vec<D>, Vec<D>) {
        self.evaluate(|j, v| if j == i { value } else { D::from(v) }, Some(i))
    }

    /// Parameters and coefficients with several parameters given in type D (`seeds`:
    /// index and value, e.g. dual parts along a direction in parameter space); each
    /// seeded parameter is held at its value, the rest follow.
    pub fn seeded_many<D: Scalar>(&self, seeds: &[(usize, D)]) -> (Vec<D>, Vec<D>) {
        let mut lifted: Vec<D> = self.values.iter().map(|&v| D::from(v)).collect();
        for &(i, d) in seeds {
            lifted[i] = d;
        }
        let held: Vec<usize> = seeds.iter().map(|s| s.0).collect();
        self.evaluate_holding(|j, _| lifted[j], &held)
    }

    /// The value checks that fail for `values`/`coefs`; `overrides` (the user's `--set`)
    /// are quoted in sign errors.
    pub fn failures(&self, params: &[f64], coefs: &[f64], overrides: &str) -> Vec<Diagnostic> {
        let mut diags = Vec::new();
        for (i, span) in &self.used {
            let v = params[*i];
            if !v.is_finite() {
                diags.push(
                    Diagnostic::new(format!("`{}` evaluates to {v}", self.names[*i]))
                        .at(span.clone())
                        .help("a parameter used by the model must be a finite number: check for a division by zero, the root or logarithm of a negative number, or asin/acos beyond ±1"),
                );
            }
        }
        for c in &self.checks {
            let v = coefs[c.coef];
            let what = &c.what;
            if !v.is_finite() {
                diags.push(
                    Diagnostic::new(format!("{what} evaluates to {v}"))
                        .at(c.span.clone())
                        .help("check the parameters it uses"),
                );
                continue;
            }
            if let CheckKind::Below(upper) = c.kind {
                let u = coefs[upper];
                // (a non-finite upper limit has its own check)
                if u.is_finite() && !(v < u) {
                    // an end stop's limits: m, or an angle (dimensionless) in rad
                    let unit = if c.dim.is_dimensionless() {
                        "rad".to_string()
                    } else {
                        c.dim.to_string()
                    };
                    let mut msg = format!(
                        "{what} must be below the upper limit: it is {v} {unit}, the upper limit {u} {unit}"
                    );
                    if !overrides.is_empty() {
                        msg.push_str(&format!(" (with --set {overrides})"));
                    }
                    diags.push(
                        Diagnostic::new(msg)
                            .at(c.span.clone())
                            .label(if v == u { "equal to the upper limit" } else { "above the upper limit" })
                            .help("the stop pushes back below `lower` and above `upper`, the coordinate moves freely between them: give `lower` < `upper` (swap them if they are reversed; leave one out for a stop on one side only)"),
                    );
                }
                continue;
            }
            let strict = match c.kind {
                CheckKind::Finite | CheckKind::Below(_) => continue,
                CheckKind::Positive => true,
                CheckKind::NonNegative => false,
            };
            if v < 0.0 || (strict && v == 0.0) {
                let kind = if strict {
                    "positive"
                } else {
                    "zero or positive"
                };
                let mut msg = format!("{what} must be {kind}, it is {v} {}", c.dim);
                if !overrides.is_empty() {
                    msg.push_str(&format!(" (with --set {overrides})"));
                }
                diags.push(
                    Diagnostic::new(msg)
                        .at(c.span.clone())
                        .label(if strict { "not positive" } else { "negative" })
                        .help(format!(
                            "give {what} a value {} 0",
                            if strict { ">" } else { "≥" }
                        )),
                );
            }
        }
        diags
    }

    /// Set parameter `i` to `v` (it no longer follows its definition); the others and the
    /// coefficients follow. On a failed check nothing changes and the messages are returned.
    pub fn set(&mut self, i: usize, v: f64, overrides: &str) -> Result<(), Vec<Diagnostic>> {
        let (p, c) = self.evaluate(|j, x| if j == i { v } else { x }, Some(i));
        let diags = self.failures(&p, &c, overrides);
        if !diags.is_empty() {
            return Err(diags);
        }
        self.defs[i] = None;
        self.values = p;
        self.coefs = c;
        Ok(())
    }

    /// Evaluate the coefficients at the current values (after compilation).
    pub fn refresh(&mut self) {
        let (p, c) = self.evaluate(|_, x| x, None);
        self.values = p;
        self.coefs = c;
    }
}
