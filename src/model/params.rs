//! `[parameters]`: named values in SI, defined by numbers, quantities with units, or
//! expressions over other parameters, evaluated in dependency order.

use super::expr::{self, Expr, ExprError};
use super::file::{RawParam, RawValue};
use super::units::{self, Dim};
use super::{Field, expr_diag, suggest};
use crate::diag::{Diagnostic, Error, Result, SourceFile};
use std::collections::{BTreeMap, HashMap};
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
    /// Name → index into `list` (a model may have many parameters: no linear search).
    by_name: HashMap<String, usize>,
    /// Names in `[parameters]` whose definitions were refused (already reported) and are
    /// therefore not in `list`: a use of one elsewhere is not reported again.
    pub rejected: Vec<String>,
}

const RESERVED: &[&str] = &["t", "pi"];

impl Parameters {
    pub fn index(&self, name: &str) -> Option<usize> {
        self.by_name.get(name).copied()
    }

    /// Whether `name` is a parameter of the file whose definition was refused (and
    /// reported): a use of it elsewhere is not an unknown name.
    pub fn is_rejected(&self, name: &str) -> bool {
        self.rejected.iter().any(|b| b == name)
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
        let by_name = name_index(&list);
        let mut params = Parameters {
            list,
            values: vec![f64::NAN; n],
            dims: vec![None; n],
            overridden: vec![None; n],
            override_exprs: vec![None; n],
            by_name,
            rejected: Vec::new(),
        };
        let overrides = vec![None; n];
        let evaluated = evaluate(&params.list, &params.by_name, &overrides, &broken);
        params.rejected = broken;
        match evaluated {
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
        match evaluate(&self.list, &self.by_name, &exprs, &[]) {
            Ok((values, dims)) => Ok(Parameters {
                list: self.list.clone(),
                values,
                dims,
                overridden: texts,
                override_exprs: exprs,
                by_name: self.by_name.clone(),
                rejected: self.rejected.clone(),
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

fn name_index(list: &[Parameter]) -> HashMap<String, usize> {
    let mut map = HashMap::with_capacity(list.len());
    for (i, p) in list.iter().enumerate() {
        map.entry(p.name.clone()).or_insert(i);
    }
    map
}

/// The problems found in `[parameters]` before evaluation stops (as many as an error
/// shows): a file with 100,000 broken definitions gets the first ones, fast (each unknown name's suggestion searches
/// every name).
const MAX_PROBLEMS: usize = 30;

/// Evaluate every parameter in dependency order: a depth-first walk with cycle detection,
/// on an explicit stack (a chain `p_i = p_{i-1}` of any length needs no deeper call
/// stack), each parameter evaluated once all it uses are.
fn evaluate(
    list: &[Parameter],
    by_name: &HashMap<String, usize>,
    overrides: &[Option<Expr>],
    broken: &[String],
) -> std::result::Result<(Vec<f64>, Vec<Option<Dim>>), Vec<Problem>> {
    let mut ev = Evaluator {
        list,
        by_name,
        overrides,
        broken,
        state: vec![State::Todo; list.len()],
        values: vec![f64::NAN; list.len()],
        dims: vec![None; list.len()],
        problems: Vec::new(),
        cut: false,
    };
    for i in 0..list.len() {
        if ev.problems.len() >= MAX_PROBLEMS {
            ev.cut |= ev.state[i..].contains(&State::Todo);
            break;
        }
        ev.walk(i);
    }
    // say so: the count is of the problems found, not of all
    if ev.cut {
        ev.problems.push(Problem::File(Diagnostic::stop(format!(
            "the evaluation of [parameters] stopped at its {MAX_PROBLEMS}th problem"
        ))));
    }
    if ev.problems.is_empty() {
        Ok((ev.values, ev.dims))
    } else {
        Err(ev.problems)
    }
}

struct Evaluator<'a> {
    list: &'a [Parameter],
    by_name: &'a HashMap<String, usize>,
    overrides: &'a [Option<Expr>],
    /// Names whose definitions failed to parse (already reported).
    broken: &'a [String],
    state: Vec<State>,
    values: Vec<f64>,
    dims: Vec<Option<Dim>>,
    problems: Vec<Problem>,
    /// Parameters were left unchecked at `MAX_PROBLEMS`.
    cut: bool,
}

impl<'a> Evaluator<'a> {
    /// The definition in force of parameter `i` and whether it came from `--set`.
    fn definition(&self, i: usize) -> (&'a Expr, bool) {
        let overrides: &'a [Option<Expr>] = self.overrides;
        let list: &'a [Parameter] = self.list;
        match &overrides[i] {
            Some(e) => (e, true),
            None => (&list[i].field.expr, false),
        }
    }

    /// The parameters that the definition of `i` uses, in source order.
    fn uses(&self, i: usize) -> Vec<usize> {
        let (expr, _) = self.definition(i);
        expr.variables()
            .iter()
            .filter_map(|(n, _)| self.by_name.get(*n).copied())
            .collect()
    }

    /// Evaluate `i` and everything it uses (iteratively: stack frames are (parameter,
    /// its uses, next use to look at)).
    fn walk(&mut self, root: usize) {
        if self.state[root] != State::Todo {
            return;
        }
        let mut stack: Vec<(usize, Vec<usize>, usize)> = Vec::new();
        self.state[root] = State::Visiting;
        stack.push((root, self.uses(root), 0));
        while let Some(top) = stack.last_mut() {
            let (i, next) = (top.0, top.1.get(top.2).copied());
            if self.state[i] == State::Failed {
                // In a cycle, reported: what else it uses is walked from the top.
                stack.pop();
                continue;
            }
            let Some(j) = next else {
                stack.pop();
                if self.state[i] == State::Visiting {
                    self.finish(i);
                }
                continue;
            };
            top.2 += 1;
            match self.state[j] {
                State::Done | State::Failed => {}
                State::Todo => {
                    self.state[j] = State::Visiting;
                    let uses = self.uses(j);
                    stack.push((j, uses, 0));
                }
                State::Visiting => {
                    // A cycle (or a parameter using itself): j is on the stack.
                    let from = stack.iter().position(|f| f.0 == j).unwrap_or(0);
                    let mut path: Vec<&str> = stack[from..]
                        .iter()
                        .map(|f| self.list[f.0].name.as_str())
                        .collect();
                    path.push(&self.list[j].name);
                    // a long cycle is shown by its ends
                    let shown = if path.len() > 12 {
                        let more = format!("… {} more …", path.len() - 10);
                        let mut short: Vec<&str> = path[..5].to_vec();
                        short.push(&more);
                        short.extend(&path[path.len() - 5..]);
                        short.join(" → ")
                    } else {
                        path.join(" → ")
                    };
                    let p = &self.list[j];
                    self.problems.push(Problem::File(
                        Diagnostic::new(format!("parameter cycle: {shown}"))
                            .at(p.field.span.clone())
                            .label("defined from itself")
                            .help("define one of these parameters by a number"),
                    ));
                    for f in &stack[from..] {
                        self.state[f.0] = State::Failed;
                    }
                }
            }
        }
    }

    /// Evaluate parameter `i`, all it uses being evaluated (or failed).
    fn finish(&mut self, i: usize) {
        if self.problems.len() >= MAX_PROBLEMS {
            // enough to fix first: the rest is not evaluated (nor its help searched for)
            self.state[i] = State::Failed;
            self.cut = true;
            return;
        }
        let list: &'a [Parameter] = self.list;
        let (expr, from_set) = self.definition(i);
        let mut failed_dep = false;
        let result = expr::eval_const(expr, &mut |name, span| match self.by_name.get(name) {
            Some(&j) if self.state[j] == State::Done => Ok(self.values[j]),
            Some(_) => {
                failed_dep = true;
                Err(ExprError {
                    span: span.clone(),
                    message: String::new(),
                    help: None,
                })
            }
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
        match result {
            Ok(v) => {
                let var_dim = |n: &str| self.by_name.get(n).and_then(|&j| self.dims[j]);
                if let Err(e) = expr.check_dims(&var_dim) {
                    self.fail(i, from_set, e);
                    return;
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
                    return;
                }
                self.dims[i] = p.unit.as_ref().map(|u| u.1).or(found);
                self.values[i] = v;
                self.state[i] = State::Done;
            }
            Err(e) => {
                if failed_dep {
                    self.state[i] = State::Failed; // reported where it failed
                } else {
                    self.fail(i, from_set, e);
                }
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
        // the names, unless there are too many to read
        const LISTED: usize = 30;
        let names: Vec<&str> = list.iter().take(LISTED).map(|p| p.name.as_str()).collect();
        Some(if list.len() > LISTED {
            format!(
                "parameters are: {}, … ({} in all, in [parameters])",
                names.join(", "),
                list.len()
            )
        } else {
            format!("parameters are: {}", names.join(", "))
        })
    });
    ExprError {
        span: span.clone(),
        message,
        help,
    }
}
