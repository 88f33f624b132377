//! `[parameters]`: named values in SI, defined by numbers, quantities with units, or
//! expressions over other parameters, evaluated in dependency order.

use super::expr::{self, Expr, ExprError};
use super::file::{RawParam, RawValue};
use super::units::{self, Dim};
use super::{Field, expr_diag, suggest};
use crate::diag::{Diagnostic, Error, Result, SourceFile};
use std::collections::BTreeMap;
use toml::Spanned;

/// One parameter as written.
#[derive(Debug, Clone)]
pub struct Parameter {
    pub name: String,
    pub field: Field,
    /// Declared unit (`unit = "N/m"`): its text and dimension.
    pub unit: Option<(String, Dim)>,
    pub description: Option<String>,
}

/// All parameters with their values (SI) and, where decidable, dimensions.
#[derive(Debug, Clone, Default)]
pub struct Parameters {
    pub list: Vec<Parameter>,
    /// SI value of each parameter.
    pub values: Vec<f64>,
    /// Dimension of each parameter where known (declared, or from a quantity literal).
    pub dims: Vec<Option<Dim>>,
    /// The expression text given with `--set`, per parameter.
    pub overridden: Vec<Option<String>>,
    /// The parsed `--set` expression in force, per parameter (one that named the
    /// parameter itself is already evaluated to a number).
    pub override_exprs: Vec<Option<Expr>>,
}

const RESERVED: &[&str] = &["t", "pi"];

impl Parameters {
    pub fn index(&self, name: &str) -> Option<usize> {
        self.list.iter().position(|p| p.name == name)
    }

    /// SI value of a parameter.
    pub fn value(&self, name: &str) -> Option<f64> {
        self.index(name).map(|i| self.values[i])
    }

    /// The definition in force of parameter `i`: its `--set` expression, or the file's.
    pub fn definition(&self, i: usize) -> &Expr {
        self.override_exprs[i]
            .as_ref()
            .unwrap_or(&self.list[i].field.expr)
    }

    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.list.iter().map(|p| p.name.as_str())
    }

    /// Parse `[parameters]` and evaluate it; problems go to `diags`.
    pub fn from_raw(
        raw: &BTreeMap<String, Spanned<RawParam>>,
        text: &str,
        diags: &mut Vec<Diagnostic>,
    ) -> Parameters {
        let mut list = Vec::new();
        // Parameters whose definition is already reported: uses of them elsewhere are not
        // reported again as unknown.
        let mut broken: Vec<String> = Vec::new();
        for (name, rp) in raw {
            let outer = rp.span();
            let p = rp.get_ref();
            let value = if p.value.span() == (0..0) {
                Spanned::new(outer.clone(), p.value.get_ref().clone())
            } else {
                p.value.clone()
            };
            let function = expr::Func::ALL.iter().any(|f| f.name() == name.as_str());
            if !is_identifier(name) || RESERVED.contains(&name.as_str()) || function {
                diags.push(
                    Diagnostic::new(format!("`{name}` cannot name a parameter"))
                        .at(outer.clone())
                        .help(
                            "parameter names are letters, digits and `_`, start with a letter, \
                             and are not `t` (time), `pi` or a function name (`sin`, `sqrt`, ...)",
                        ),
                );
                continue;
            }
            let field = match Field::parse(&value, text) {
                Ok(f) => f,
                Err(d) => {
                    diags.push(d);
                    broken.push(name.clone());
                    continue;
                }
            };
            let unit = match &p.unit {
                None => None,
                Some(u) => match units::parse_unit(u.get_ref()) {
                    Ok((factor, dim)) => {
                        // A plain number is SI: with a non-SI declared unit it would be
                        // silently wrong (`value = 7, unit = "mm"` is not 7 mm).
                        let plain = !field.expr.has_units() && field.expr.variables().is_empty();
                        if plain && (factor - 1.0).abs() > 1e-12 {
                            diags.push(
                                Diagnostic::new(format!(
                                    "`{name}` is declared in {} but its value is a plain number, which detune reads as SI ({})",
                                    u.get_ref(),
                                    // rad for deg, rad/s for rpm, N·m/rad for lbf*in/deg
                                    units::si_unit_with_angle(dim, units::angle_power(u.get_ref()))
                                ))
                                .at(field.span.clone())
                                .label("a plain number: SI")
                                .help(format!(
                                    "write the unit with the value, e.g. value = \"{} {}\"",
                                    match value.get_ref() { RawValue::Number(x) => format!("{x}"), RawValue::Text(t) => t.clone() },
                                    u.get_ref()
                                )),
                            );
                            broken.push(name.clone());
                            continue;
                        }
                        Some((u.get_ref().clone(), dim))
                    }
                    Err(e) => {
                        let start = u.span().start + 1 + e.offset;
                        let mut d = Diagnostic::new(e.message)
                            .at(start..start + e.len.max(1))
                            .label("unknown unit");
                        if let Some(h) = e.help {
                            d = d.help(h);
                        }
                        diags.push(d);
                        broken.push(name.clone());
                        continue;
                    }
                },
            };
            list.push(Parameter {
                name: name.clone(),
                field,
                unit,
                description: p.description.clone(),
            });
        }
        let n = list.len();
        let mut params = Parameters {
            list,
            values: vec![f64::NAN; n],
            dims: vec![None; n],
            overridden: vec![None; n],
            override_exprs: vec![None; n],
        };
        let overrides = vec![None; n];
        match evaluate(&params.list, &overrides, &broken) {
            Ok((values, dims)) => {
                params.values = values;
                params.dims = dims;
            }
            Err(problems) => {
                for p in problems {
                    if let Problem::File(d) = p {
                        diags.push(d);
                    }
                }
            }
        }
        params
    }

    /// The index of parameter `name`, or an error saying that `request` (the flag that
    /// named it, e.g. `--param k`) names no parameter, with a suggestion or the list.
    pub fn require(&self, name: &str, request: &str) -> Result<usize> {
        self.index(name).ok_or_else(|| {
            let help = suggest(name, self.names()).unwrap_or_else(|| {
                format!(
                    "parameters of this model: {}",
                    self.names().collect::<Vec<_>>().join(", ")
                )
            });
            Error::request(
                format!("{request}: the model has no parameter `{name}`"),
                help,
            )
        })
    }

    /// A copy with `--set` overrides applied (`name`, expression text).
    pub fn with_overrides(
        &self,
        source: &SourceFile,
        overrides: &[(String, String)],
    ) -> Result<Parameters> {
        // Earlier overrides stay in force.
        let mut exprs: Vec<Option<Expr>> = self.override_exprs.clone();
        let mut texts = self.overridden.clone();
        for (name, value) in overrides {
            let i = self.require(name, &format!("--set {name}={value}"))?;
            let expr = expr::parse(value).map_err(|e| set_error(name, value, &e))?;
            // Dimension check where decidable: against the declared unit, else against the
            // dimension of the value in the file.
            let var_dim = |n: &str| self.index(n).and_then(|j| self.dims[j]);
            let expected = self.list[i].unit.as_ref().map(|u| u.1).or(self.dims[i]);
            if let (Some(exp), Some(got)) = (expected, expr.dim(&var_dim))
                && exp != got
            {
                return Err(Error::request(
                    format!(
                        "--set {name}={value}: `{name}` is a quantity in {exp}, the value given is in {got}"
                    ),
                    format!("give `{name}` in {exp} (or a plain number, read as SI)"),
                ));
            }
            // `--set L1=2*L1`: the parameter's own name means its value before this
            // override, so the expression is evaluated now, from the current values.
            let expr = if expr.variables().iter().any(|(v, _)| *v == name.as_str()) {
                let v = expr::eval_const(&expr, &mut |n, span| {
                    self.value(n)
                        .ok_or_else(|| unknown_name(n, span, &self.list))
                })
                .map_err(|e| set_error(name, value, &e))?;
                expr::parse(&format!("{v:?}")).map_err(|e| set_error(name, value, &e))?
            } else {
                expr
            };
            exprs[i] = Some(expr);
            texts[i] = Some(value.clone());
        }
        match evaluate(&self.list, &exprs, &[]) {
            Ok((values, dims)) => Ok(Parameters {
                list: self.list.clone(),
                values,
                dims,
                overridden: texts,
                override_exprs: exprs,
            }),
            Err(problems) => {
                let mut file = Vec::new();
                for p in problems {
                    match p {
                        Problem::Set { index, error } => {
                            let name = &self.list[index].name;
                            let value = texts[index].clone().unwrap_or_default();
                            return Err(set_error(name, &value, &error));
                        }
                        Problem::File(d) => file.push(d),
                    }
                }
                Err(Error::Model {
                    source: source.clone(),
                    diagnostics: file,
                })
            }
        }
    }
}

fn set_error(name: &str, value: &str, e: &ExprError) -> Error {
    let caret = format!(
        "  --set {name}={value}\n  {}{}",
        " ".repeat(6 + name.len() + 1 + e.span.start),
        "^".repeat(e.span.len().max(1))
    );
    Error::Request {
        message: format!("{}\n{caret}", e.message),
        help: e.help.clone(),
    }
}

pub fn is_identifier(s: &str) -> bool {
    let mut c = s.chars();
    matches!(c.next(), Some(ch) if ch.is_ascii_alphabetic())
        && c.all(|ch| ch.is_ascii_alphanumeric() || ch == '_')
}

enum Problem {
    File(Diagnostic),
    Set { index: usize, error: ExprError },
}

#[derive(Clone, Copy, PartialEq)]
enum State {
    Todo,
    Visiting,
    Done,
    Failed,
}

/// Evaluate every parameter in dependency order (depth first, with cycle detection).
fn evaluate(
    list: &[Parameter],
    overrides: &[Option<Expr>],
    broken: &[String],
) -> std::result::Result<(Vec<f64>, Vec<Option<Dim>>), Vec<Problem>> {
    let mut ev = Evaluator {
        list,
        overrides,
        broken,
        state: vec![State::Todo; list.len()],
        values: vec![f64::NAN; list.len()],
        dims: vec![None; list.len()],
        stack: Vec::new(),
        problems: Vec::new(),
    };
    for i in 0..list.len() {
        ev.visit(i);
    }
    if ev.problems.is_empty() {
        Ok((ev.values, ev.dims))
    } else {
        Err(ev.problems)
    }
}

struct Evaluator<'a> {
    list: &'a [Parameter],
    overrides: &'a [Option<Expr>],
    /// Names whose definitions failed to parse (already reported).
    broken: &'a [String],
    state: Vec<State>,
    values: Vec<f64>,
    dims: Vec<Option<Dim>>,
    stack: Vec<usize>,
    problems: Vec<Problem>,
}

impl<'a> Evaluator<'a> {
    /// Value of parameter `i`, or None if it (or something it uses) failed.
    fn visit(&mut self, i: usize) -> Option<f64> {
        match self.state[i] {
            State::Done => return Some(self.values[i]),
            State::Failed => return None,
            State::Visiting => {
                let from = self.stack.iter().position(|&j| j == i).unwrap_or(0);
                let mut path: Vec<&str> = self.stack[from..]
                    .iter()
                    .map(|&j| self.list[j].name.as_str())
                    .collect();
                path.push(&self.list[i].name);
                let p = &self.list[i];
                self.problems.push(Problem::File(
                    Diagnostic::new(format!("parameter cycle: {}", path.join(" → ")))
                        .at(p.field.span.clone())
                        .label("defined from itself")
                        .help("define one of these parameters by a number"),
                ));
                for &j in &self.stack[from..] {
                    self.state[j] = State::Failed;
                }
                return None;
            }
            State::Todo => {}
        }
        self.state[i] = State::Visiting;
        self.stack.push(i);
        let list: &'a [Parameter] = self.list;
        let overrides: &'a [Option<Expr>] = self.overrides;
        let (expr, from_set) = match &overrides[i] {
            Some(e) => (e, true),
            None => (&list[i].field.expr, false),
        };
        let mut failed_dep = false;
        let result = expr::eval_const(expr, &mut |name, span| match list
            .iter()
            .position(|p| p.name == name)
        {
            Some(j) => match self.visit(j) {
                Some(v) => Ok(v),
                None => {
                    failed_dep = true;
                    Err(ExprError {
                        span: span.clone(),
                        message: String::new(),
                        help: None,
                    })
                }
            },
            None if self.broken.iter().any(|b| b == name) => {
                failed_dep = true;
                Err(ExprError {
                    span: span.clone(),
                    message: String::new(),
                    help: None,
                })
            }
            None => Err(unknown_name(name, span, list)),
        });
        self.stack.pop();
        if self.state[i] == State::Failed {
            return None;
        }
        match result {
            Ok(v) => {
                let var_dim = |n: &str| {
                    list.iter()
                        .position(|p| p.name == n)
                        .and_then(|j| self.dims[j])
                };
                if let Err(e) = expr.check_dims(&var_dim) {
                    self.fail(i, from_set, e);
                    return None;
                }
                let found = expr.dim(&var_dim);
                let p = &list[i];
                if let (Some((unit, declared)), Some(found), false) = (&p.unit, found, from_set)
                    && *declared != found
                {
                    // rad for deg, N·m/rad for lbf*in/deg
                    let si = units::si_unit_with_angle(*declared, units::angle_power(unit));
                    self.problems.push(Problem::File(
                        Diagnostic::new(format!(
                            "`{}` is declared in {unit} ({si}) but its value is in {found}",
                            p.name,
                        ))
                        .at(p.field.span.clone())
                        .help(format!("give the value in {si}, or change `unit`")),
                    ));
                    self.state[i] = State::Failed;
                    return None;
                }
                self.dims[i] = p.unit.as_ref().map(|u| u.1).or(found);
                self.values[i] = v;
                self.state[i] = State::Done;
                Some(v)
            }
            Err(e) => {
                if failed_dep {
                    self.state[i] = State::Failed; // reported where it failed
                } else {
                    self.fail(i, from_set, e);
                }
                None
            }
        }
    }

    /// Parameter `i` failed with `e`: reported against `--set` or the file.
    fn fail(&mut self, i: usize, from_set: bool, e: ExprError) {
        self.state[i] = State::Failed;
        if from_set {
            self.problems.push(Problem::Set { index: i, error: e });
        } else {
            let offset = self.list[i].field.offset;
            self.problems.push(Problem::File(expr_diag(&e, offset)));
        }
    }
}

fn unknown_name(name: &str, span: &expr::Span, list: &[Parameter]) -> ExprError {
    if expr::is_non_finite_name(name) {
        return expr::non_finite_name(name, span.clone());
    }
    let message = if name == "t" {
        "a parameter cannot depend on time `t`".to_string()
    } else if name.contains('.') {
        format!("a parameter cannot depend on the coordinate `{name}`")
    } else {
        format!("unknown parameter `{name}`")
    };
    let help = suggest(name, list.iter().map(|p| p.name.as_str())).or_else(|| {
        Some(format!(
            "parameters are: {}",
            list.iter()
                .map(|p| p.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ))
    });
    ExprError {
        span: span.clone(),
        message,
        help,
    }
}
