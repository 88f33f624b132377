//! Expressions over parameters, coordinates and time, evaluated generically over
//! [`Scalar`] so that derivatives flow through them.
//!
//! # Grammar
//!
//! ```text
//! expr    := term (("+" | "-") term)*
//! term    := unary (("*" | "/") unary)*
//! unary   := ("-" | "+") unary | power
//! power   := atom ("^" unary)?                 right-associative: 2^3^2 = 2^9
//! atom    := number unit? | "pi" | name | func "(" expr ("," expr)* ")" | "(" expr ")"
//! number  := digits ["." digits] [("e"|"E") ["+"|"-"] digits]  |  "." digits ["e" …]
//! name    := segment ("." segment)*           segment := [A-Za-z_][A-Za-z0-9_]*
//! unit    := uname ["^" ["-"|"+"] digits] (("*" | "/") uname ["^" …])*
//! ```
//!
//! So `^` binds tighter than unary minus (`-x^2` = `-(x^2)`, `2^-1` = 0.5), `*` and `/` are
//! left-associative, and names may contain dots (`bar1.theta`, `stick.phi`).
//! Functions: `sqrt sin cos tan asin acos atan atan2(y, x) exp ln abs`; `pi` is a constant.
//! Function names and `pi` are reserved: they cannot name a variable. `log` is rejected
//! (write `ln`). Implicit multiplication is not supported: write `2*x`, not `2x` or `2 x`.
//!
//! # Units belong to number literals only
//!
//! A number literal followed by a name (with or without a space: `7 mm`, `7mm`) is a
//! *quantity*; the name must be a unit of [`units`](super::units) and the literal is
//! converted to SI (m, kg, s, rad) at parse time. Frequencies are angular: `4.3 Hz` is
//! `4.3·2π` rad/s. The unit is read greedily over `*` and `/` joined unit names, each with
//! an optional integer power, *as long as the next name is a known unit*:
//! `50 lbf*in*s/rad`, `9.81 m/s^2`. A quantity is an atom, so `2*7 mm` is `2 × (7 mm)` and
//! `-3 N` is `-(3 N)`. Because of the greed, `2 m*k` is `(2 m)·k` when `k` is not a unit,
//! but `2 m*s` is two metre-seconds: **write `(2 m)*s` to multiply a quantity by a variable
//! named like a unit** (`s`, `g`, `h`, `m`, `N`, …). A name that does not follow a literal is
//! never a unit: a parameter may be called `m`, `s` or `g`. An unknown name directly after
//! a literal is an error pointing at the name.
//!
//! Plain numbers carry no unit: they are SI values of whatever quantity is expected.
//!
//! # Evaluation
//!
//! [`Expr::compile`] resolves every name once (to a constant, a coordinate index or time,
//! see [`Slot`]), folds every subtree that depends on neither coordinates nor time into one
//! constant, and produces a flat postfix program ([`Compiled`]) evaluated without
//! allocation for any `D: Scalar` (`f64`, `Dual64`, `Dual2_64`, …).

use std::f64::consts::PI;
use std::fmt;

use super::units::{self, Dim};
use crate::scalar::{Env, NO_ENV, Scalar};

/// Byte offsets into the expression source.
pub type Span = std::ops::Range<usize>;

/// A parse or name-resolution error, located in the expression source.
#[derive(Debug, Clone, PartialEq)]
pub struct ExprError {
    /// Byte range of the offending text (empty at the end of the source).
    pub span: Span,
    /// What went wrong.
    pub message: String,
    /// How to fix it, when there is something useful to say.
    pub help: Option<String>,
}

impl ExprError {
    /// An error without help.
    pub fn new(span: Span, message: impl Into<String>) -> ExprError {
        ExprError {
            span,
            message: message.into(),
            help: None,
        }
    }

    /// The same error with a help text.
    pub fn with_help(mut self, help: impl Into<String>) -> ExprError {
        self.help = Some(help.into());
        self
    }

    /// The same error with its span moved by `offset` bytes, for an expression embedded at
    /// `offset` in a larger file.
    pub fn shifted(mut self, offset: usize) -> ExprError {
        self.span = self.span.start + offset..self.span.end + offset;
        self
    }
}

impl fmt::Display for ExprError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)?;
        if let Some(help) = &self.help {
            write!(f, " ({help})")?;
        }
        Ok(())
    }
}

impl std::error::Error for ExprError {}

/// A binary operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    /// `a^b`.
    Pow,
}

impl BinOp {
    /// The operator as written.
    pub fn symbol(self) -> &'static str {
        match self {
            BinOp::Add => "+",
            BinOp::Sub => "-",
            BinOp::Mul => "*",
            BinOp::Div => "/",
            BinOp::Pow => "^",
        }
    }
}

/// A built-in function.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Func {
    Sqrt,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    /// `atan2(y, x)`: the angle of the point (x, y).
    Atan2,
    Exp,
    /// Natural logarithm.
    Ln,
    Abs,
}

impl Func {
    /// Every function, in the order they are listed to users.
    pub const ALL: [Func; 11] = [
        Func::Sqrt,
        Func::Sin,
        Func::Cos,
        Func::Tan,
        Func::Asin,
        Func::Acos,
        Func::Atan,
        Func::Atan2,
        Func::Exp,
        Func::Ln,
        Func::Abs,
    ];

    /// The name as written.
    pub fn name(self) -> &'static str {
        match self {
            Func::Sqrt => "sqrt",
            Func::Sin => "sin",
            Func::Cos => "cos",
            Func::Tan => "tan",
            Func::Asin => "asin",
            Func::Acos => "acos",
            Func::Atan => "atan",
            Func::Atan2 => "atan2",
            Func::Exp => "exp",
            Func::Ln => "ln",
            Func::Abs => "abs",
        }
    }

    /// Number of arguments.
    pub fn arity(self) -> usize {
        match self {
            Func::Atan2 => 2,
            _ => 1,
        }
    }

    /// The function of this name, if any.
    pub fn from_name(name: &str) -> Option<Func> {
        Func::ALL.into_iter().find(|f| f.name() == name)
    }

    /// Apply a one-argument function (`atan2` is handled by the callers).
    #[inline(always)]
    fn apply1<D: Scalar>(self, x: D) -> D {
        match self {
            Func::Sqrt => x.sqrt(),
            Func::Sin => x.sin(),
            Func::Cos => x.cos(),
            Func::Tan => x.tan(),
            Func::Asin => x.asin(),
            Func::Acos => x.acos(),
            Func::Atan => x.atan(),
            Func::Exp => x.exp(),
            Func::Ln => x.ln(),
            Func::Abs => x.abs(),
            Func::Atan2 => unreachable!("atan2 takes two arguments"),
        }
    }
}

/// A parsed expression. Every node keeps the byte span of its source text (the span of a
/// parenthesised expression excludes the parentheses).
#[derive(Debug, Clone)]
pub enum Expr {
    /// A plain number literal (no unit).
    Number { value: f64, span: Span },
    /// The constant `pi`.
    Pi { span: Span },
    /// A number literal with a unit, e.g. `7 mm`.
    Quantity {
        /// The value in SI units (`0.007` for `7 mm`).
        value: f64,
        /// The literal as written (`7`).
        literal: f64,
        /// The unit, normalised (`lbf*in*s/rad`).
        unit: String,
        /// The unit's dimension.
        dim: Dim,
        /// The whole quantity, literal and unit.
        span: Span,
        /// The unit part only.
        unit_span: Span,
    },
    /// A name: a parameter, a coordinate or time, resolved by [`Expr::compile`].
    Var { name: String, span: Span },
    /// Unary minus.
    Neg { arg: Box<Expr>, span: Span },
    /// A binary operation.
    Binary {
        op: BinOp,
        lhs: Box<Expr>,
        rhs: Box<Expr>,
        span: Span,
    },
    /// A function call.
    Call {
        func: Func,
        args: Vec<Expr>,
        span: Span,
    },
}

/// What a name stands for, as decided by the caller of [`Expr::compile`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Slot {
    /// A known value, folded into the program.
    Const(f64),
    /// Live parameter number `i`, read from the [`Env`] at evaluation (so it can change
    /// without recompiling, and carry a derivative).
    Param(usize),
    /// Generalised coordinate number `i`: `q[i]` at evaluation.
    Coord(usize),
    /// Time `t`.
    Time,
}

/// What [`Expr::dim`] knows about a subexpression.
#[derive(Debug, Clone, Copy, PartialEq)]
enum DimInfo {
    /// A definite dimension.
    Known(Dim),
    /// A plain number: a pure scale factor inside a product, "whatever is expected" alone.
    Scale,
    /// Not decidable.
    Unknown,
}

impl Expr {
    /// The source span of this node.
    pub fn span(&self) -> Span {
        match self {
            Expr::Number { span, .. }
            | Expr::Pi { span }
            | Expr::Quantity { span, .. }
            | Expr::Var { span, .. }
            | Expr::Neg { span, .. }
            | Expr::Binary { span, .. }
            | Expr::Call { span, .. } => span.clone(),
        }
    }

    /// Every variable referenced, with its span, in source order (duplicates allowed).
    pub fn variables(&self) -> Vec<(&str, Span)> {
        fn walk<'e>(e: &'e Expr, out: &mut Vec<(&'e str, Span)>) {
            match e {
                Expr::Number { .. } | Expr::Pi { .. } | Expr::Quantity { .. } => {}
                Expr::Var { name, span } => out.push((name, span.clone())),
                Expr::Neg { arg, .. } => walk(arg, out),
                Expr::Binary { lhs, rhs, .. } => {
                    walk(lhs, out);
                    walk(rhs, out);
                }
                Expr::Call { args, .. } => args.iter().for_each(|a| walk(a, out)),
            }
        }
        let mut out = Vec::new();
        walk(self, &mut out);
        out
    }

    /// The units of its quantity literals, normalised, in source order (`["deg"]` for
    /// `45 deg`).
    pub fn quantity_units(&self) -> Vec<&str> {
        fn walk<'e>(e: &'e Expr, out: &mut Vec<&'e str>) {
            match e {
                Expr::Quantity { unit, .. } => out.push(unit),
                Expr::Number { .. } | Expr::Pi { .. } | Expr::Var { .. } => {}
                Expr::Neg { arg, .. } => walk(arg, out),
                Expr::Binary { lhs, rhs, .. } => {
                    walk(lhs, out);
                    walk(rhs, out);
                }
                Expr::Call { args, .. } => args.iter().for_each(|a| walk(a, out)),
            }
        }
        let mut out = Vec::new();
        walk(self, &mut out);
        out
    }

    /// True if the expression contains any quantity literal with a unit.
    pub fn has_units(&self) -> bool {
        match self {
            Expr::Quantity { .. } => true,
            Expr::Number { .. } | Expr::Pi { .. } | Expr::Var { .. } => false,
            Expr::Neg { arg, .. } => arg.has_units(),
            Expr::Binary { lhs, rhs, .. } => lhs.has_units() || rhs.has_units(),
            Expr::Call { args, .. } => args.iter().any(Expr::has_units),
        }
    }

    /// Dimension when decidable, else `None`.
    ///
    /// * a quantity literal gives its unit's dimension (through `-` and parentheses);
    /// * a variable gives `var_dim(name)`;
    /// * a product or quotient gives the product of its factors' dimensions; plain numbers,
    ///   `pi` and the results of `sin cos tan asin acos atan atan2 exp ln` are pure scale
    ///   factors there (`2*7 mm` and `L*cos(phi)` are lengths);
    /// * `x^n` with an integer literal `n` gives `dim(x)^n`; `sqrt` halves even powers;
    ///   `abs` keeps its argument's dimension;
    /// * a sum or difference of equal dimensions gives that dimension (a plain number in a
    ///   sum is taken in the sum's dimension); mismatched dimensions give `None`;
    /// * a lone plain number (or a function of one) gives `None`: plain numbers are SI
    ///   values of whatever is expected.
    pub fn dim(&self, var_dim: &dyn Fn(&str) -> Option<Dim>) -> Option<Dim> {
        match self.dim_info(var_dim) {
            DimInfo::Known(d) => Some(d),
            DimInfo::Scale | DimInfo::Unknown => None,
        }
    }

    fn dim_info(&self, var_dim: &dyn Fn(&str) -> Option<Dim>) -> DimInfo {
        use DimInfo::{Known, Scale, Unknown};
        match self {
            Expr::Number { .. } | Expr::Pi { .. } => Scale,
            Expr::Quantity { dim, .. } => Known(*dim),
            Expr::Var { name, .. } => var_dim(name).map_or(Unknown, Known),
            Expr::Neg { arg, .. } => arg.dim_info(var_dim),
            Expr::Binary { op, lhs, rhs, .. } => {
                let l = lhs.dim_info(var_dim);
                match op {
                    BinOp::Pow => match l {
                        Scale => Scale,
                        Known(d) if d.is_dimensionless() => Known(d),
                        Known(d) => rhs
                            .plain_constant()
                            .filter(|e| e.fract() == 0.0 && e.abs() <= 127.0)
                            .and_then(|e| d.checked_powi(e as i32))
                            .map_or(Unknown, Known),
                        Unknown => Unknown,
                    },
                    BinOp::Mul | BinOp::Div => {
                        let r = rhs.dim_info(var_dim);
                        let div = *op == BinOp::Div;
                        match (l, r) {
                            (Unknown, _) | (_, Unknown) => Unknown,
                            (Scale, Scale) => Scale,
                            (Known(a), Scale) => Known(a),
                            (Scale, Known(b)) if div => Known(Dim::NONE.div(b)),
                            (Scale, Known(b)) => Known(b),
                            (Known(a), Known(b)) => {
                                let d = if div {
                                    a.checked_div(b)
                                } else {
                                    a.checked_mul(b)
                                };
                                d.map_or(Unknown, Known)
                            }
                        }
                    }
                    BinOp::Add | BinOp::Sub => match (l, rhs.dim_info(var_dim)) {
                        (Known(a), Known(b)) if a == b => Known(a),
                        (Known(a), Scale) | (Scale, Known(a)) => Known(a),
                        (Scale, Scale) => Scale,
                        _ => Unknown,
                    },
                }
            }
            Expr::Call { func, args, .. } => match func {
                Func::Abs => args[0].dim_info(var_dim),
                Func::Sqrt => match args[0].dim_info(var_dim) {
                    Known(d) if d.length % 2 == 0 && d.mass % 2 == 0 && d.time % 2 == 0 => {
                        Known(Dim::new(d.length / 2, d.mass / 2, d.time / 2))
                    }
                    Scale => Scale,
                    _ => Unknown,
                },
                _ => Scale,
            },
        }
    }

    /// Dimensional consistency where decidable: a sum of two quantities of different
    /// dimensions (`2 m + 3 s`), or a quantity with a dimension as the argument of a
    /// function that needs a pure number (`sin(2 m)`, `exp`, `ln`, `asin`, ...), is an error.
    pub fn check_dims(&self, var_dim: &dyn Fn(&str) -> Option<Dim>) -> Result<(), ExprError> {
        match self {
            Expr::Number { .. } | Expr::Pi { .. } | Expr::Quantity { .. } | Expr::Var { .. } => {
                Ok(())
            }
            Expr::Neg { arg, .. } => arg.check_dims(var_dim),
            Expr::Binary { op, lhs, rhs, span } => {
                lhs.check_dims(var_dim)?;
                rhs.check_dims(var_dim)?;
                if matches!(op, BinOp::Add | BinOp::Sub)
                    && let (DimInfo::Known(a), DimInfo::Known(b)) =
                        (lhs.dim_info(var_dim), rhs.dim_info(var_dim))
                    && a != b
                {
                    return Err(ExprError::new(
                        span.clone(),
                        format!("adding or subtracting quantities in {a} and {b}"),
                    )
                    .with_help("both sides of + and − need the same dimension"));
                }
                Ok(())
            }
            Expr::Call { func, args, span } => {
                for a in args {
                    a.check_dims(var_dim)?;
                }
                let pure = matches!(
                    func,
                    Func::Sin
                        | Func::Cos
                        | Func::Tan
                        | Func::Asin
                        | Func::Acos
                        | Func::Atan
                        | Func::Exp
                        | Func::Ln
                );
                if pure
                    && let DimInfo::Known(d) = args[0].dim_info(var_dim)
                    && !d.is_dimensionless()
                {
                    return Err(ExprError::new(
                        span.clone(),
                        format!("{} of a quantity in {d}", func.name()),
                    )
                    .with_help("this function needs a pure number (angles are in rad or deg)"));
                }
                Ok(())
            }
        }
    }

    /// The value of a subexpression made only of plain numbers, `pi` and functions of them.
    fn plain_constant(&self) -> Option<f64> {
        if self.has_units() || !self.variables().is_empty() {
            return None;
        }
        let compiled = self
            .compile(&mut |_, span| Err(ExprError::new(span.clone(), "")))
            .ok()?;
        compiled.as_constant()
    }

    /// Resolve names once: `lookup(name, span)` says what a variable is (errors propagate,
    /// e.g. an unknown parameter). Names are looked up in source order. Every subtree that
    /// depends on neither a coordinate nor time is folded to one constant.
    pub fn compile(
        &self,
        lookup: &mut dyn FnMut(&str, &Span) -> Result<Slot, ExprError>,
    ) -> Result<Compiled, ExprError> {
        Ok(Compiled::from_ops(emit(self, lookup)?.into_ops()))
    }
}

/// Evaluate a whole expression where every variable is a constant (parameters):
/// a convenience over [`Expr::compile`] and [`Compiled::eval`].
pub fn eval_const(
    expr: &Expr,
    lookup: &mut dyn FnMut(&str, &Span) -> Result<f64, ExprError>,
) -> Result<f64, ExprError> {
    let compiled = expr.compile(&mut |name, span| lookup(name, span).map(Slot::Const))?;
    Ok(compiled.eval::<f64>(&[], 0.0))
}

// ---------------------------------------------------------------------------------------
// Display
// ---------------------------------------------------------------------------------------

/// Binding strength of a node as printed: 1 `+ -`, 2 `* /`, 3 unary minus, 4 `^`, 5 atoms.
fn precedence(e: &Expr) -> u8 {
    match e {
        Expr::Binary { op, .. } => match op {
            BinOp::Add | BinOp::Sub => 1,
            BinOp::Mul | BinOp::Div => 2,
            BinOp::Pow => 4,
        },
        Expr::Neg { .. } => 3,
        _ => 5,
    }
}

/// Print with the fewest parentheses that parse back to the same tree. Inside an operation,
/// quantities are parenthesised, `(7 mm)*s`, so that a unit never absorbs a variable.
impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fn operand(e: &Expr, min: u8, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            if precedence(e) < min || matches!(e, Expr::Quantity { .. }) {
                write!(f, "({e})")
            } else {
                write!(f, "{e}")
            }
        }
        match self {
            Expr::Number { value, .. } => write!(f, "{value}"),
            Expr::Pi { .. } => f.write_str("pi"),
            Expr::Quantity { literal, unit, .. } => write!(f, "{literal} {unit}"),
            Expr::Var { name, .. } => f.write_str(name),
            Expr::Neg { arg, .. } => {
                f.write_str("-")?;
                if precedence(arg) < 3 {
                    write!(f, "({arg})")
                } else {
                    write!(f, "{arg}")
                }
            }
            Expr::Binary { op, lhs, rhs, .. } => {
                let (l, r, sep) = match op {
                    BinOp::Add | BinOp::Sub => (1, 2, true),
                    BinOp::Mul | BinOp::Div => (2, 3, false),
                    BinOp::Pow => (5, 3, false),
                };
                operand(lhs, l, f)?;
                if sep {
                    write!(f, " {} ", op.symbol())?;
                } else {
                    f.write_str(op.symbol())?;
                }
                operand(rhs, r, f)
            }
            Expr::Call { func, args, .. } => {
                write!(f, "{}(", func.name())?;
                for (i, a) in args.iter().enumerate() {
                    if i > 0 {
                        f.write_str(", ")?;
                    }
                    write!(f, "{a}")?;
                }
                f.write_str(")")
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Lexer
// ---------------------------------------------------------------------------------------

#[derive(Debug, Clone, Copy, PartialEq)]
enum Tok<'a> {
    Num(f64),
    Ident(&'a str),
    /// One of `+ - * / ^ ( ) ,`.
    Op(u8),
    End,
}

#[derive(Debug, Clone)]
struct Token<'a> {
    tok: Tok<'a>,
    span: Span,
}

fn lex(src: &str) -> Result<Vec<Token<'_>>, ExprError> {
    let b = src.as_bytes();
    let digit = |i: usize| b.get(i).is_some_and(u8::is_ascii_digit);
    let ident_start = |i: usize| {
        b.get(i)
            .is_some_and(|c| c.is_ascii_alphabetic() || *c == b'_')
    };
    let ident_char = |i: usize| {
        b.get(i)
            .is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_')
    };
    let mut toks = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        let start = i;
        if c.is_ascii_whitespace() {
            i += 1;
            continue;
        }
        let tok = if digit(i) || (c == b'.' && digit(i + 1)) {
            while digit(i) {
                i += 1;
            }
            if b.get(i) == Some(&b'.') {
                i += 1;
                while digit(i) {
                    i += 1;
                }
            }
            if matches!(b.get(i), Some(b'e' | b'E')) {
                let sign = usize::from(matches!(b.get(i + 1), Some(b'+' | b'-')));
                if digit(i + 1 + sign) {
                    i += 1 + sign;
                    while digit(i) {
                        i += 1;
                    }
                }
            }
            let text = &src[start..i];
            let value: f64 = text
                .parse()
                .map_err(|_| ExprError::new(start..i, format!("invalid number `{text}`")))?;
            if !value.is_finite() {
                return Err(ExprError::new(start..i, "number too large"));
            }
            Tok::Num(value)
        } else if ident_start(i) {
            loop {
                while ident_char(i) {
                    i += 1;
                }
                if b.get(i) == Some(&b'.') && ident_start(i + 1) {
                    i += 1;
                } else {
                    break;
                }
            }
            Tok::Ident(&src[start..i])
        } else if b"+-*/^(),".contains(&c) {
            i += 1;
            Tok::Op(c)
        } else if let Some(dot) = ['·', '⋅'].into_iter().find(|d| src[i..].starts_with(*d)) {
            // the middle dot detune itself writes in units (N·m/rad) multiplies, so that
            // what it prints can be typed back
            i += dot.len_utf8();
            Tok::Op(b'*')
        } else {
            let ch = src[i..].chars().next().unwrap_or('\0');
            let span = i..i + ch.len_utf8();
            let err = ExprError::new(span, format!("unexpected character `{ch}`"));
            return Err(match ch {
                '×' => err.with_help("use `*` to multiply"),
                '÷' => err.with_help("use `/` to divide"),
                '−' | '–' => err.with_help("use `-` (ASCII hyphen-minus)"),
                '[' | ']' | '{' | '}' => err.with_help("use `(` and `)` to group"),
                '.' => err.with_help("a name segment after `.` must start with a letter"),
                _ => err,
            });
        };
        toks.push(Token {
            tok,
            span: start..i,
        });
    }
    toks.push(Token {
        tok: Tok::End,
        span: b.len()..b.len(),
    });
    Ok(toks)
}

// ---------------------------------------------------------------------------------------
// Parser
// ---------------------------------------------------------------------------------------

/// Parse an expression (see the [module documentation](self) for the grammar and units).
pub fn parse(src: &str) -> Result<Expr, ExprError> {
    let toks = lex(src)?;
    if toks.len() == 1 {
        return Err(ExprError::new(0..src.len(), "empty expression"));
    }
    // The tree's height is at most its token count, and every walk of the tree (dimension
    // checks, compilation, printing, dropping) recurses once per level: bounding the length
    // bounds the stack, whatever the shape (a flat sum of 20,000 terms is 20,000 levels).
    if toks.len() > MAX_TOKENS + 1 {
        let mut open = 0usize;
        for t in &toks {
            match t.tok {
                Tok::Op(b'(') => open += 1,
                Tok::Op(b')') => open = open.saturating_sub(1),
                _ => {}
            }
            if open > MAX_DEPTH {
                return Err(nested_too_deep(t.span.clone()));
            }
        }
        return Err(ExprError::new(
            toks[MAX_TOKENS].span.start..src.len(),
            format!(
                "expression longer than {MAX_TOKENS} tokens ({} numbers, names and operators)",
                toks.len() - 1
            ),
        )
        .with_help("split it into parameters that sum or multiply smaller parts"));
    }
    let mut p = Parser {
        src,
        toks,
        pos: 0,
        depth: 0,
    };
    let e = p.expr()?;
    let t = p.peek().clone();
    match t.tok {
        Tok::End => Ok(e),
        Tok::Op(b')') => Err(ExprError::new(t.span, "unmatched `)`")
            .with_help("remove it, or add a matching `(` before it")),
        _ => Err(p.expected_operator(&t, None)),
    }
}

/// Whether `name` spells a non-finite number (`nan`, `inf`, `infinity`, any case): no
/// value detune takes.
pub fn is_non_finite_name(name: &str) -> bool {
    ["nan", "inf", "infinity"]
        .iter()
        .any(|n| name.eq_ignore_ascii_case(n))
}

/// The error for a non-finite number written as a name (`nan`, `inf`), at `span`.
pub fn non_finite_name(name: &str, span: Span) -> ExprError {
    ExprError::new(
        span,
        format!("`{name}` is not finite: every value must be a finite number"),
    )
    .with_help("give a finite number, with its unit where the value has one")
}

/// Deepest nesting of parentheses and unary operators accepted.
pub const MAX_DEPTH: usize = 200;

/// Most tokens (numbers, names, operators, parentheses) in one expression.
pub const MAX_TOKENS: usize = 2000;

struct Parser<'a> {
    src: &'a str,
    toks: Vec<Token<'a>>,
    pos: usize,
    depth: usize,
}

fn describe(t: &Token, src: &str) -> String {
    match t.tok {
        Tok::End => "the end of the expression".to_string(),
        _ => format!("`{}`", &src[t.span.clone()]),
    }
}

fn join(a: &Span, b: &Span) -> Span {
    a.start..b.end
}

impl<'a> Parser<'a> {
    fn peek(&self) -> &Token<'a> {
        &self.toks[self.pos]
    }

    fn peek_at(&self, ahead: usize) -> Tok<'a> {
        self.toks.get(self.pos + ahead).map_or(Tok::End, |t| t.tok)
    }

    fn next(&mut self) -> Token<'a> {
        let t = self.toks[self.pos].clone();
        if t.tok != Tok::End {
            self.pos += 1;
        }
        t
    }

    fn nest<T>(
        &mut self,
        f: impl FnOnce(&mut Self) -> Result<T, ExprError>,
    ) -> Result<T, ExprError> {
        if self.depth >= MAX_DEPTH {
            return Err(nested_too_deep(self.peek().span.clone()));
        }
        self.depth += 1;
        let r = f(self);
        self.depth -= 1;
        r
    }

    /// `expr := term (("+" | "-") term)*`
    fn expr(&mut self) -> Result<Expr, ExprError> {
        self.nest(|p| {
            let mut lhs = p.term()?;
            loop {
                let op = match p.peek().tok {
                    Tok::Op(b'+') => BinOp::Add,
                    Tok::Op(b'-') => BinOp::Sub,
                    _ => return Ok(lhs),
                };
                p.next();
                let rhs = p.term()?;
                lhs = binary(op, lhs, rhs);
            }
        })
    }

    /// `term := unary (("*" | "/") unary)*`
    fn term(&mut self) -> Result<Expr, ExprError> {
        let mut lhs = self.unary()?;
        loop {
            let op = match self.peek().tok {
                Tok::Op(b'*') => BinOp::Mul,
                Tok::Op(b'/') => BinOp::Div,
                _ => return Ok(lhs),
            };
            self.next();
            let rhs = self.unary()?;
            lhs = binary(op, lhs, rhs);
        }
    }

    /// `unary := ("-" | "+") unary | power`
    fn unary(&mut self) -> Result<Expr, ExprError> {
        match self.peek().tok {
            Tok::Op(b'-') => {
                let minus = self.next();
                let arg = self.nest(Self::unary)?;
                Ok(Expr::Neg {
                    span: join(&minus.span, &arg.span()),
                    arg: Box::new(arg),
                })
            }
            Tok::Op(b'+') => {
                self.next();
                self.nest(Self::unary)
            }
            _ => self.power(),
        }
    }

    /// `power := atom ("^" unary)?`
    fn power(&mut self) -> Result<Expr, ExprError> {
        let base = self.atom()?;
        if self.peek().tok != Tok::Op(b'^') {
            return Ok(base);
        }
        self.next();
        let exponent = self.nest(Self::unary)?;
        Ok(binary(BinOp::Pow, base, exponent))
    }

    fn atom(&mut self) -> Result<Expr, ExprError> {
        let t = self.peek().clone();
        match t.tok {
            Tok::Num(value) => {
                self.next();
                if let Tok::Ident(_) = self.peek().tok {
                    self.quantity(value, t.span)
                } else {
                    Ok(Expr::Number {
                        value,
                        span: t.span,
                    })
                }
            }
            Tok::Ident(name) => {
                self.next();
                if self.peek().tok == Tok::Op(b'(') {
                    return self.call(name, t.span);
                }
                if name == "pi" {
                    Ok(Expr::Pi { span: t.span })
                } else if Func::from_name(name).is_some() {
                    Err(ExprError::new(
                        t.span,
                        format!("`{name}` is a function and needs an argument"),
                    )
                    .with_help(format!(
                        "write `{name}(…)`; function names cannot be used as variables"
                    )))
                } else {
                    Ok(Expr::Var {
                        name: name.to_string(),
                        span: t.span,
                    })
                }
            }
            Tok::Op(b'(') => {
                let open = self.next();
                if self.peek().tok == Tok::Op(b')') {
                    let close = self.next();
                    return Err(ExprError::new(
                        join(&open.span, &close.span),
                        "empty parentheses",
                    ));
                }
                let inner = self.nest(Self::expr)?;
                let t = self.peek().clone();
                match t.tok {
                    Tok::Op(b')') => {
                        self.next();
                        Ok(inner)
                    }
                    Tok::End => Err(unclosed(open.span)),
                    _ => Err(self.expected_operator(&t, Some("`)`"))),
                }
            }
            _ => Err(self.missing_operand(&t)),
        }
    }

    /// An operand was expected at `t` (which cannot start one).
    fn missing_operand(&self, t: &Token) -> ExprError {
        let prev = self.pos.checked_sub(1).map(|i| self.toks[i].clone());
        let Some(prev) = prev else {
            return ExprError::new(
                t.span.clone(),
                format!("expected an operand, found {}", describe(t, self.src)),
            )
            .with_help(format!(
                "`{}` needs an operand on its left",
                &self.src[t.span.clone()]
            ));
        };
        let prev_text = &self.src[prev.span.clone()];
        match (prev.tok, t.tok) {
            (Tok::Op(b'('), Tok::End) => unclosed(prev.span),
            (Tok::Op(b','), Tok::End | Tok::Op(b')')) => {
                ExprError::new(prev.span, "missing argument after `,`")
            }
            (Tok::Op(b'*'), Tok::Op(b'*')) => {
                ExprError::new(join(&prev.span, &t.span), "`**` is not an operator")
                    .with_help("use `^` for powers, e.g. `x^2`")
            }
            (_, Tok::End | Tok::Op(b')')) => {
                ExprError::new(prev.span, format!("missing operand after `{prev_text}`"))
            }
            (_, Tok::Op(b',')) => ExprError::new(t.span.clone(), "unexpected `,`")
                .with_help("`,` only separates the arguments of `atan2(y, x)`"),
            _ => ExprError::new(
                t.span.clone(),
                format!(
                    "expected an operand after `{prev_text}`, found {}",
                    describe(t, self.src)
                ),
            ),
        }
    }

    /// An operand is complete and `t` follows it, but is not an operator (nor `closing`).
    fn expected_operator(&self, t: &Token, closing: Option<&str>) -> ExprError {
        // `nan N/m`, `inf deg`: a non-finite "number" with a unit (the name is read as a
        // parameter, the unit as what follows it)
        if let Some(prev) = self.pos.checked_sub(1).and_then(|i| self.toks.get(i))
            && let Tok::Ident(name) = prev.tok
            && is_non_finite_name(name)
        {
            return non_finite_name(name, join(&prev.span, &t.span));
        }
        let what = match closing {
            Some(c) => format!("an operator or {c}"),
            None => "an operator".to_string(),
        };
        let e = ExprError::new(
            t.span.clone(),
            format!("expected {what}, found {}", describe(t, self.src)),
        );
        match t.tok {
            Tok::Ident(name) if units::is_unit(name) => e.with_help(format!(
                "join the units of a quantity with `*` or `/`, e.g. `N*{name}`"
            )),
            Tok::Num(_) | Tok::Ident(_) | Tok::Op(b'(') => {
                e.with_help("implicit multiplication is not supported: insert `*`")
            }
            _ => e,
        }
    }

    /// `func "(" expr ("," expr)* ")"` — the name has been read, `(` is next.
    fn call(&mut self, name: &str, name_span: Span) -> Result<Expr, ExprError> {
        let Some(func) = Func::from_name(name) else {
            return Err(unknown_function(name, name_span));
        };
        let open = self.next();
        let mut args = Vec::new();
        let close = if self.peek().tok == Tok::Op(b')') {
            self.next()
        } else {
            loop {
                args.push(self.nest(Self::expr)?);
                let t = self.peek().clone();
                match t.tok {
                    Tok::Op(b',') => {
                        self.next();
                    }
                    Tok::Op(b')') => break self.next(),
                    Tok::End => return Err(unclosed(open.span)),
                    _ => return Err(self.expected_operator(&t, Some("`,` or `)`"))),
                }
            }
        };
        let span = join(&name_span, &close.span);
        if args.len() != func.arity() {
            let expected = match func {
                Func::Atan2 => "2 arguments (y, x)",
                _ => "1 argument",
            };
            return Err(ExprError::new(
                span,
                format!("`{name}` takes {expected}, found {}", args.len()),
            ));
        }
        Ok(Expr::Call { func, args, span })
    }

    /// The unit after a number literal: `uname ["^" int] (("*"|"/") uname ["^" int])*`,
    /// greedy while the name after `*` or `/` is a known unit.
    fn quantity(&mut self, literal: f64, literal_span: Span) -> Result<Expr, ExprError> {
        let mut factor = 1.0_f64;
        let mut dim = Dim::NONE;
        let mut unit = String::new();
        let mut divide = false;
        let unit_start = self.peek().span.start;
        let mut unit_end;
        loop {
            let t = self.next();
            let Tok::Ident(name) = t.tok else {
                unreachable!("quantity() is called with a name next");
            };
            let Some(u) = units::lookup(name) else {
                let literal_text = &self.src[literal_span.clone()];
                let help = match units::suggest(name, units::unit_names()).as_slice() {
                    [] => format!(
                        "`{name}` is not a unit; to multiply by a variable write \
                         `{literal_text}*{name}` ({})",
                        units::unknown_unit_help(name)
                    ),
                    close => units::did_you_mean(close),
                };
                return Err(
                    ExprError::new(t.span, format!("unknown unit `{name}`")).with_help(help)
                );
            };
            unit_end = t.span.end;
            let power = if self.peek().tok == Tok::Op(b'^') {
                let (power, end) = self.unit_power(name)?;
                unit_end = end;
                power
            } else {
                1
            };
            let too_large = || ExprError::new(unit_start..unit_end, "unit power too large");
            let d = u.dim.checked_powi(power).ok_or_else(too_large)?;
            let f = u.factor.powi(power);
            if divide {
                factor /= f;
                dim = dim.checked_div(d).ok_or_else(too_large)?;
            } else {
                factor *= f;
                dim = dim.checked_mul(d).ok_or_else(too_large)?;
            }
            unit.push_str(name);
            if power != 1 {
                unit.push_str(&format!("^{power}"));
            }

            // Continue over `*` or `/` only if a known unit follows.
            let op = self.peek_at(0);
            let continues = matches!(op, Tok::Op(b'*' | b'/'))
                && matches!(self.peek_at(1), Tok::Ident(n) if units::is_unit(n))
                && self.peek_at(2) != Tok::Op(b'(');
            if !continues {
                break;
            }
            divide = op == Tok::Op(b'/');
            unit.push(if divide { '/' } else { '*' });
            self.next();
        }
        Ok(Expr::Quantity {
            value: literal * factor,
            literal,
            unit,
            dim,
            span: literal_span.start..unit_end,
            unit_span: unit_start..unit_end,
        })
    }

    /// `"^" ["-"|"+"] digits` after a unit name; returns the power and the end offset.
    fn unit_power(&mut self, name: &str) -> Result<(i32, usize), ExprError> {
        let caret = self.next();
        let negative = match self.peek().tok {
            Tok::Op(b'-') => {
                self.next();
                true
            }
            Tok::Op(b'+') => {
                self.next();
                false
            }
            _ => false,
        };
        let t = self.peek().clone();
        let text = &self.src[t.span.clone()];
        let power = match t.tok {
            Tok::Num(_) if text.bytes().all(|c| c.is_ascii_digit()) => text.parse::<i32>().ok(),
            _ => None,
        };
        let Some(power) = power else {
            return Err(ExprError::new(
                caret.span.start..t.span.end.max(caret.span.end),
                format!("the power of unit `{name}` must be an integer literal"),
            )
            .with_help(format!(
                "write e.g. `{name}^2` or `{name}^-1`; to raise the whole quantity to a \
                 power, parenthesise it: `(2 {name})^x`"
            )));
        };
        self.next();
        Ok((if negative { -power } else { power }, t.span.end))
    }
}

fn binary(op: BinOp, lhs: Expr, rhs: Expr) -> Expr {
    Expr::Binary {
        op,
        span: join(&lhs.span(), &rhs.span()),
        lhs: Box::new(lhs),
        rhs: Box::new(rhs),
    }
}

fn nested_too_deep(at: Span) -> ExprError {
    ExprError::new(
        at,
        format!("expression nested deeper than {MAX_DEPTH} levels"),
    )
    .with_help("remove redundant parentheses or signs, or split it into parameters")
}

fn unclosed(open: Span) -> ExprError {
    ExprError::new(open, "unclosed `(`").with_help("add a matching `)`")
}

fn unknown_function(name: &str, span: Span) -> ExprError {
    let err = ExprError::new(span.clone(), format!("unknown function `{name}`"));
    let known = Func::ALL.map(Func::name).join(", ");
    match name {
        "pi" => ExprError::new(span, "`pi` is a constant, not a function")
            .with_help("to multiply, write `pi*(…)`"),
        "log" => err.with_help("use `ln` for the natural logarithm"),
        "log10" => err.with_help("write `ln(x)/ln(10)`"),
        "log2" => err.with_help("write `ln(x)/ln(2)`"),
        "pow" => err.with_help("use `^` for powers, e.g. `x^2`"),
        _ => match units::suggest(name, Func::ALL.map(Func::name)).as_slice() {
            [] => err.with_help(format!(
                "known functions: {known}; to multiply, write `{name}*(…)`"
            )),
            close => err.with_help(units::did_you_mean(close)),
        },
    }
}

// ---------------------------------------------------------------------------------------
// Compilation and evaluation
// ---------------------------------------------------------------------------------------

/// One instruction of a [`Compiled`] postfix program, acting on a value stack.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Op {
    Const(f64),
    Coord(usize),
    Param(usize),
    Time,
    Neg,
    Add,
    Sub,
    Mul,
    Div,
    /// `a^b` with a variable exponent.
    Powd,
    /// `atan2(y, x)` with `y` pushed first.
    Atan2,
    /// `x + c` (also `c + x` and `x - (-c)`).
    AddC(f64),
    /// `x * c` (also `c * x`).
    MulC(f64),
    /// `x / c`.
    DivC(f64),
    /// `c - x`.
    CSub(f64),
    /// `c / x`.
    CDiv(f64),
    /// `x^n`, integer constant exponent.
    Powi(i32),
    /// `x^e`, non-integer constant exponent.
    Powf(f64),
    /// A one-argument function.
    Call(Func),
}

impl Op {
    /// Change of the stack depth.
    fn stack_delta(self) -> isize {
        match self {
            Op::Const(_) | Op::Coord(_) | Op::Param(_) | Op::Time => 1,
            Op::Add | Op::Sub | Op::Mul | Op::Div | Op::Powd | Op::Atan2 => -1,
            _ => 0,
        }
    }
}

/// A subtree during compilation: folded to a constant, or code pushing one value.
enum Piece {
    Const(f64),
    Code(Vec<Op>),
}

impl Piece {
    fn into_ops(self) -> Vec<Op> {
        match self {
            Piece::Const(c) => vec![Op::Const(c)],
            Piece::Code(ops) => ops,
        }
    }

    fn then(self, op: Op) -> Piece {
        let mut ops = self.into_ops();
        ops.push(op);
        Piece::Code(ops)
    }
}

/// The exponent as an `i32` if it is an integer.
fn int_exponent(e: f64) -> Option<i32> {
    (e.fract() == 0.0 && e.abs() <= f64::from(i32::MAX)).then_some(e as i32)
}

/// `x^e` with a constant exponent: `powi` for integers, else `powf`.
#[inline]
fn pow_const<D: Scalar>(x: D, e: f64) -> D {
    match int_exponent(e) {
        Some(n) => x.powi(n),
        None => x.powf(e),
    }
}

fn fold(op: BinOp, a: f64, b: f64) -> f64 {
    match op {
        BinOp::Add => a + b,
        BinOp::Sub => a - b,
        BinOp::Mul => a * b,
        BinOp::Div => a / b,
        BinOp::Pow => pow_const(a, b),
    }
}

fn emit(
    e: &Expr,
    lookup: &mut dyn FnMut(&str, &Span) -> Result<Slot, ExprError>,
) -> Result<Piece, ExprError> {
    Ok(match e {
        Expr::Number { value, .. } | Expr::Quantity { value, .. } => Piece::Const(*value),
        Expr::Pi { .. } => Piece::Const(PI),
        Expr::Var { name, span } => match lookup(name, span)? {
            Slot::Const(c) => Piece::Const(c),
            Slot::Coord(i) => Piece::Code(vec![Op::Coord(i)]),
            Slot::Param(i) => Piece::Code(vec![Op::Param(i)]),
            Slot::Time => Piece::Code(vec![Op::Time]),
        },
        Expr::Neg { arg, .. } => match emit(arg, lookup)? {
            Piece::Const(c) => Piece::Const(-c),
            code => code.then(Op::Neg),
        },
        Expr::Binary { op, lhs, rhs, .. } => {
            let l = emit(lhs, lookup)?;
            let r = emit(rhs, lookup)?;
            use Piece::{Code, Const};
            match (op, l, r) {
                (op, Const(a), Const(b)) => Const(fold(*op, a, b)),
                (BinOp::Pow, l @ Code(_), Const(e)) => match int_exponent(e) {
                    Some(n) => l.then(Op::Powi(n)),
                    None => l.then(Op::Powf(e)),
                },
                (BinOp::Add, l @ Code(_), Const(c)) | (BinOp::Add, Const(c), l @ Code(_)) => {
                    l.then(Op::AddC(c))
                }
                (BinOp::Sub, l @ Code(_), Const(c)) => l.then(Op::AddC(-c)),
                (BinOp::Sub, Const(c), r @ Code(_)) => r.then(Op::CSub(c)),
                (BinOp::Mul, l @ Code(_), Const(c)) | (BinOp::Mul, Const(c), l @ Code(_)) => {
                    l.then(Op::MulC(c))
                }
                (BinOp::Div, l @ Code(_), Const(c)) => l.then(Op::DivC(c)),
                (BinOp::Div, Const(c), r @ Code(_)) => r.then(Op::CDiv(c)),
                (op, l, r) => {
                    let mut ops = l.into_ops();
                    ops.extend(r.into_ops());
                    ops.push(match op {
                        BinOp::Add => Op::Add,
                        BinOp::Sub => Op::Sub,
                        BinOp::Mul => Op::Mul,
                        BinOp::Div => Op::Div,
                        BinOp::Pow => Op::Powd,
                    });
                    Code(ops)
                }
            }
        }
        Expr::Call { func, args, .. } => {
            let mut pieces = Vec::with_capacity(args.len());
            for a in args {
                pieces.push(emit(a, lookup)?);
            }
            match (func, pieces.as_slice()) {
                (Func::Atan2, [Piece::Const(y), Piece::Const(x)]) => Piece::Const(y.atan2(*x)),
                (Func::Atan2, _) => {
                    let mut ops = Vec::new();
                    for p in pieces {
                        ops.extend(p.into_ops());
                    }
                    ops.push(Op::Atan2);
                    Piece::Code(ops)
                }
                (f, [Piece::Const(x)]) => Piece::Const(f.apply1(*x)),
                (f, _) => {
                    let arg = pieces.pop().expect("one argument");
                    arg.then(Op::Call(*f))
                }
            }
        }
    })
}

/// Stack size evaluated without allocation; deeper programs use a `Vec`.
const INLINE_STACK: usize = 16;

/// A resolved expression: names replaced by constants, coordinate indices or time, constant
/// subtrees folded, as a flat postfix program. Cheap to clone and fast to evaluate.
#[derive(Debug, Clone, PartialEq)]
pub struct Compiled {
    ops: Vec<Op>,
    /// Largest stack depth reached.
    depth: usize,
    time: bool,
    coords: bool,
    params: bool,
    /// The largest coordinate index read.
    max_coord: Option<usize>,
}

impl Compiled {
    fn from_ops(ops: Vec<Op>) -> Compiled {
        let mut n: isize = 0;
        let mut depth: isize = 0;
        for op in &ops {
            n += op.stack_delta();
            depth = depth.max(n);
        }
        debug_assert_eq!(n, 1, "a program leaves one value");
        Compiled {
            time: ops.iter().any(|op| matches!(op, Op::Time)),
            coords: ops.iter().any(|op| matches!(op, Op::Coord(_))),
            params: ops.iter().any(|op| matches!(op, Op::Param(_))),
            max_coord: ops
                .iter()
                .filter_map(|op| match op {
                    Op::Coord(i) => Some(*i),
                    _ => None,
                })
                .max(),
            depth: depth as usize,
            ops,
        }
    }

    /// The constant `c`.
    pub fn constant(c: f64) -> Compiled {
        Compiled::from_ops(vec![Op::Const(c)])
    }

    /// True if the value depends on neither coordinates, time nor live parameters.
    pub fn is_constant(&self) -> bool {
        !self.time && !self.coords && !self.params
    }

    /// The live parameters the value reads, in program order (repeats possible).
    pub fn parameters(&self) -> impl Iterator<Item = usize> + '_ {
        self.ops.iter().filter_map(|op| match op {
            Op::Param(i) => Some(*i),
            _ => None,
        })
    }

    /// The value, if constant.
    pub fn as_constant(&self) -> Option<f64> {
        match self.ops.as_slice() {
            [Op::Const(c)] => Some(*c),
            _ => None,
        }
    }

    /// True if the value depends on time.
    pub fn depends_on_time(&self) -> bool {
        self.time
    }

    /// True if the value depends on any coordinate.
    pub fn depends_on_coords(&self) -> bool {
        self.coords
    }

    /// The coordinates read, in program order (repeats possible).
    pub fn coordinates(&self) -> impl Iterator<Item = usize> + '_ {
        self.ops.iter().filter_map(|op| match op {
            Op::Coord(i) => Some(*i),
            _ => None,
        })
    }

    /// The largest coordinate index used, if any (`q` passed to [`Compiled::eval`] must be
    /// longer than this).
    pub fn max_coord(&self) -> Option<usize> {
        self.max_coord
    }

    /// Evaluate a load (a force or torque component), which may read velocities: slot
    /// `q.len() + j` is velocity j of `v` (see the compiler). Without velocities it is
    /// [`Compiled::eval_in`] over q.
    #[inline]
    pub fn eval_load<D: Scalar, E: Env<D>>(&self, q: &[D], v: &[D], t: D, env: E) -> D {
        match self.max_coord {
            Some(m) if m >= q.len() => {
                let qv: Vec<D> = q.iter().chain(v).copied().collect();
                self.eval_in(&qv, t, env)
            }
            _ => self.eval_in(q, t, env),
        }
    }

    /// Evaluate with coordinates `q` (indexed by [`Slot::Coord`]) and time `t`.
    ///
    /// Does not allocate unless the expression needs a stack deeper than 16. Division by
    /// zero, `sqrt` of a negative number etc. give infinities or NaN. Panics if a coordinate
    /// index is out of range of `q`.
    /// Panics if it reads a live parameter: use [`Compiled::eval_in`] for those.
    #[inline]
    pub fn eval<D: Scalar>(&self, q: &[D], t: D) -> D {
        self.eval_in(q, t, NO_ENV)
    }

    /// Evaluate with coordinates `q`, time `t` and live parameters from `env`.
    #[inline]
    pub fn eval_in<D: Scalar, E: Env<D>>(&self, q: &[D], t: D, env: E) -> D {
        match self.ops.as_slice() {
            [Op::Const(c)] => D::from(*c),
            [Op::Coord(i)] => q[*i],
            [Op::Param(i)] => env.param(*i),
            [Op::Time] => t,
            ops if self.depth <= 4 => run(ops, q, t, env, &mut [D::from(0.0); 4]),
            ops if self.depth <= INLINE_STACK => {
                run(ops, q, t, env, &mut [D::from(0.0); INLINE_STACK])
            }
            ops => run(ops, q, t, env, &mut vec![D::from(0.0); self.depth]),
        }
    }
}

/// Run a postfix program on a stack large enough for it.
#[inline]
fn run<D: Scalar, E: Env<D>>(ops: &[Op], q: &[D], t: D, env: E, s: &mut [D]) -> D {
    let mut n = 0; // number of values on the stack
    for op in ops {
        match *op {
            Op::Const(c) => {
                s[n] = D::from(c);
                n += 1;
            }
            Op::Coord(i) => {
                s[n] = q[i];
                n += 1;
            }
            Op::Param(i) => {
                s[n] = env.param(i);
                n += 1;
            }
            Op::Time => {
                s[n] = t;
                n += 1;
            }
            Op::Neg => s[n - 1] = -s[n - 1],
            Op::Add => {
                n -= 1;
                let b = s[n];
                s[n - 1] += b;
            }
            Op::Sub => {
                n -= 1;
                let b = s[n];
                s[n - 1] -= b;
            }
            Op::Mul => {
                n -= 1;
                let b = s[n];
                s[n - 1] *= b;
            }
            Op::Div => {
                n -= 1;
                let b = s[n];
                s[n - 1] /= b;
            }
            Op::Powd => {
                n -= 1;
                s[n - 1] = s[n - 1].powd(s[n]);
            }
            Op::Atan2 => {
                n -= 1;
                s[n - 1] = s[n - 1].atan2(s[n]);
            }
            Op::AddC(c) => s[n - 1] += c,
            Op::MulC(c) => s[n - 1] *= c,
            Op::DivC(c) => s[n - 1] /= c,
            Op::CSub(c) => s[n - 1] = D::from(c) - s[n - 1],
            Op::CDiv(c) => s[n - 1] = D::from(c) / s[n - 1],
            Op::Powi(k) => s[n - 1] = s[n - 1].powi(k),
            Op::Powf(e) => s[n - 1] = s[n - 1].powf(e),
            Op::Call(f) => s[n - 1] = f.apply1(s[n - 1]),
        }
    }
    s[0]
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::{Dual2_64, Dual64};

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * b.abs().max(1e-300)
    }

    /// Parse and evaluate with no variables.
    fn val(src: &str) -> f64 {
        let e = parse(src).unwrap_or_else(|e| panic!("{src}: {e:?}"));
        eval_const(&e, &mut |n, s| {
            Err(ExprError::new(s.clone(), format!("no {n}")))
        })
        .unwrap_or_else(|e| panic!("{src}: {e:?}"))
    }

    fn err(src: &str) -> ExprError {
        match parse(src) {
            Ok(e) => panic!("{src} parsed as {e:?}"),
            Err(e) => e,
        }
    }

    fn quantity_dim(src: &str) -> Option<Dim> {
        parse(src).unwrap().dim(&|_| None)
    }

    #[test]
    fn long_and_deep_expressions_are_refused_without_recursion() {
        // a flat sum of 20,000 terms: refused at the first token past the bound
        let sum = vec!["1"; 20_000].join("+");
        let e = err(&sum);
        assert!(
            e.message.contains("longer than 2000 tokens"),
            "{}",
            e.message
        );
        assert_eq!(e.span.start, MAX_TOKENS); // token 2000 (from 0) is at byte 2000
        let product = vec!["x"; 20_000].join("*");
        assert!(err(&product).message.contains("longer than"));
        // 100,000 parentheses: the nesting message, at the 201st `(`
        let deep = format!("{}1{}", "(".repeat(100_000), ")".repeat(100_000));
        let e = err(&deep);
        assert!(
            e.message.contains("nested deeper than 200 levels"),
            "{}",
            e.message
        );
        assert_eq!(e.span.start, MAX_DEPTH);
        let e = err(&format!("{}1", "-".repeat(100_000)));
        assert!(e.message.contains("longer than"), "{}", e.message);
        // short but deep: the parser's own depth limit, located
        let e = err(&format!("{}1", "-".repeat(300)));
        assert!(
            e.message.contains("nested deeper than 200 levels"),
            "{}",
            e.message
        );
        let e = err(&format!("{}1{}", "sqrt(".repeat(250), ")".repeat(250)));
        assert!(e.message.contains("nested deeper"), "{}", e.message);
        // the largest sum accepted evaluates exactly: 1000 ones
        let sum = vec!["1"; 1000].join("+");
        assert_eq!(val(&sum), 1000.0);
        let alt = vec!["2"; 1000].join("-");
        assert_eq!(val(&alt), 2.0 - 999.0 * 2.0);
    }

    #[test]
    fn quantities_with_units() {
        assert!(close(val("4.3 Hz"), 4.3 * 2.0 * PI, 1e-15));
        assert!(close(val("258 rpm"), 258.0 * 2.0 * PI / 60.0, 1e-12));
        assert!(close(val("258 rpm"), 27.0177, 1e-5));
        assert!(close(val("4.3 Hz"), val("258 rpm"), 1e-12));
        assert!(close(
            val("50 lbf*in*s/rad"),
            50.0 * 4.4482216152605 * 0.0254,
            1e-14
        ));
        assert_eq!(quantity_dim("50 lbf*in*s/rad"), Some(Dim::ANGULAR_DAMPING));
        assert_eq!(Dim::ANGULAR_DAMPING.to_string(), "N·m·s");
        assert!(close(val("7 mm"), 0.007, 1e-15));
        assert_eq!(quantity_dim("7 mm"), Some(Dim::LENGTH));
        assert!(close(val("7mm"), 0.007, 1e-15));
        assert!(close(val("45 deg"), PI / 4.0, 1e-15));
        assert_eq!(quantity_dim("45 deg"), Some(Dim::NONE));
        assert_eq!(val("-3 N"), -3.0);
        assert_eq!(quantity_dim("-3 N"), Some(Dim::FORCE));
        assert_eq!(quantity_dim("(-(3 N))"), Some(Dim::FORCE));
        assert!(close(val("2*7 mm"), 0.014, 1e-15));
        assert!(close(val("9.81 m/s^2"), 9.81, 1e-15));
        assert_eq!(quantity_dim("9.81 m / s^2"), Some(Dim::ACCELERATION));
        assert!(close(val("2 mm^2"), 2e-6, 1e-15));
        assert!(close(val("1e3 N/mm"), 1e6, 1e-15));
        assert_eq!(quantity_dim("1e3 N/mm"), Some(Dim::STIFFNESS));
        assert!(close(val("3 s^-1"), 3.0, 1e-15));
        assert!(close(val("7 mm + 3 mm"), 0.01, 1e-15));
        // Two quantities divided: the unit stops at the next literal.
        assert!(close(val("6 m / 2 s"), 3.0, 1e-15));
        assert_eq!(quantity_dim("6 m / 2 s"), Some(Dim::VELOCITY));
    }

    #[test]
    fn unit_is_greedy_only_over_units() {
        let e = parse("2 m*k").unwrap();
        let v = eval_const(&e, &mut |n, _| {
            assert_eq!(n, "k");
            Ok(5.0)
        })
        .unwrap();
        assert_eq!(v, 10.0);
        assert_eq!(e.variables().len(), 1);
        // `s` is a unit: absorbed.
        let e = parse("2 m*s").unwrap();
        assert!(e.variables().is_empty());
        assert_eq!(e.dim(&|_| None), Some(Dim::new(1, 0, 1)));
        // Parenthesised: a variable.
        let e = parse("(2 m)*s").unwrap();
        assert_eq!(e.variables()[0].0, "s");
        // Names not after a literal are never units.
        let e = parse("m*g + s").unwrap();
        let names: Vec<&str> = e.variables().iter().map(|v| v.0).collect();
        assert_eq!(names, ["m", "g", "s"]);
        assert!(!e.has_units());
        assert!(parse("2 kg").unwrap().has_units());
        assert!(parse("-(3 + sin(2 deg))").unwrap().has_units());
    }

    #[test]
    fn precedence_and_numbers() {
        assert_eq!(val("2+3*4^2"), 50.0);
        assert_eq!(val("-2^2"), -4.0);
        assert_eq!(val("2^3^2"), 512.0);
        assert_eq!(val("2^-1"), 0.5);
        assert_eq!(val("(2+3)*4"), 20.0);
        assert_eq!(val("10-4-3"), 3.0);
        assert_eq!(val("64/4/2"), 8.0);
        assert_eq!(val("-(-3)"), 3.0);
        assert_eq!(val("+4 - -2"), 6.0);
        assert_eq!(val("2*-3"), -6.0);
        assert_eq!(val("1e-3"), 1e-3);
        assert_eq!(val("2.5E+4"), 2.5e4);
        assert_eq!(val(".5"), 0.5);
        assert_eq!(val("pi"), PI);
        assert!(close(val("atan2(1, -1)"), 0.75 * PI, 1e-15));
        assert!(close(val("sqrt(2)^2"), 2.0, 1e-15));
        assert!(close(val("exp(ln(3))"), 3.0, 1e-15));
        assert_eq!(val("abs(-2)"), 2.0);
        assert!(close(val("cos(pi/3) + sin(pi/6) + tan(0)"), 1.0, 1e-15));
        assert!(close(val("asin(1) + acos(1) + atan(1)"), 0.75 * PI, 1e-15));
        assert!(val("1/0").is_infinite());
        assert!(val("sqrt(-1)").is_nan());
    }

    #[test]
    fn variables_resolved_by_lookup() {
        let e = parse("m*g").unwrap();
        let v = eval_const(&e, &mut |name, _| match name {
            "m" => Ok(2.0),
            "g" => Ok(9.80665),
            _ => unreachable!(),
        })
        .unwrap();
        assert_eq!(v, 2.0 * 9.80665);
        let vars = e.variables();
        assert_eq!(vars, vec![("m", 0..1), ("g", 2..3)]);

        let e = parse("bar1.theta + 2*stick.phi_2 - bar1.theta").unwrap();
        let vars = e.variables();
        assert_eq!(vars[0], ("bar1.theta", 0..10));
        assert_eq!(vars[1], ("stick.phi_2", 15..26));
        assert_eq!(vars.len(), 3);

        // A lookup error propagates with its span.
        let e = parse("1 + nope").unwrap();
        let r = eval_const(&e, &mut |n, s| {
            Err(ExprError::new(
                s.clone(),
                format!("unknown parameter `{n}`"),
            ))
        });
        assert_eq!(r.unwrap_err().span, 4..8);
    }

    #[test]
    fn compiled_with_coords_and_time() {
        let e = parse("k*(x - 2 mm) + c*sin(w*t) + x^y").unwrap();
        let c = e
            .compile(&mut |name, _| {
                Ok(match name {
                    "k" => Slot::Const(1000.0),
                    "c" => Slot::Const(3.0),
                    "w" => Slot::Const(2.0),
                    "x" => Slot::Coord(1),
                    "y" => Slot::Coord(0),
                    "t" => Slot::Time,
                    _ => unreachable!(),
                })
            })
            .unwrap();
        assert!(c.depends_on_time() && c.depends_on_coords() && !c.is_constant());
        assert_eq!(c.max_coord(), Some(1));
        let (x, y, t) = (0.5_f64, 1.5_f64, 0.25_f64);
        let expected = 1000.0 * (x - 0.002) + 3.0 * (2.0 * t).sin() + x.powf(y);
        assert!(close(c.eval(&[y, x], t), expected, 1e-14));

        // Constant subtrees fold.
        let e = parse("2*k + sqrt(k)*pi").unwrap();
        let c = e.compile(&mut |_, _| Ok(Slot::Const(4.0))).unwrap();
        assert!(c.is_constant());
        assert_eq!(c.as_constant(), Some(8.0 + 2.0 * PI));
        assert_eq!(c.ops.len(), 1);
        let e = parse("(1 + 2*3)*x").unwrap();
        let c = e.compile(&mut |_, _| Ok(Slot::Coord(0))).unwrap();
        assert_eq!(c.ops, vec![Op::Coord(0), Op::MulC(7.0)]);
        let c = parse("x^2")
            .unwrap()
            .compile(&mut |_, _| Ok(Slot::Coord(0)))
            .unwrap();
        assert_eq!(c.ops, vec![Op::Coord(0), Op::Powi(2)]);
        let c = parse("x^0.5")
            .unwrap()
            .compile(&mut |_, _| Ok(Slot::Coord(0)))
            .unwrap();
        assert_eq!(c.ops, vec![Op::Coord(0), Op::Powf(0.5)]);
        let c = parse("2^x")
            .unwrap()
            .compile(&mut |_, _| Ok(Slot::Coord(0)))
            .unwrap();
        assert_eq!(c.ops, vec![Op::Const(2.0), Op::Coord(0), Op::Powd]);
        assert_eq!(c.eval(&[3.0], 0.0), 8.0);
        assert_eq!(Compiled::constant(1.5).eval(&[] as &[f64], 0.0), 1.5);
        assert!(Compiled::constant(1.5).is_constant());

        // Constant-on-one-side operations.
        let c = parse("(1 - x) + (8 / x) - (x / 4) - 3")
            .unwrap()
            .compile(&mut |_, _| Ok(Slot::Coord(0)))
            .unwrap();
        assert_eq!(
            c.eval(&[2.0], 0.0),
            (1.0 - 2.0) + 8.0 / 2.0 - 2.0 / 4.0 - 3.0
        );
        let c = parse("atan2(x, -1)")
            .unwrap()
            .compile(&mut |_, _| Ok(Slot::Coord(0)))
            .unwrap();
        assert_eq!(c.eval(&[1.0], 0.0), 1.0_f64.atan2(-1.0));
    }

    #[test]
    fn deep_stack_falls_back_to_vec() {
        // Right-nested sums need one stack slot per level.
        let src = (0..40).map(|_| "x+(").collect::<String>() + "x" + &")".repeat(40);
        let c = parse(&src)
            .unwrap()
            .compile(&mut |_, _| Ok(Slot::Coord(0)))
            .unwrap();
        assert!(c.depth > INLINE_STACK);
        assert_eq!(c.eval(&[1.5], 0.0), 41.0 * 1.5);
        // Pathological nesting is an error, not a stack overflow.
        let src = "(".repeat(10_000) + "1" + &")".repeat(10_000);
        assert!(parse(&src).unwrap_err().message.contains("nested"));
    }

    #[test]
    fn derivatives_flow() {
        let coord = |_: &str, _: &Span| Ok(Slot::Coord(0));
        let c = parse("sin(x)^2").unwrap().compile(&mut { coord }).unwrap();
        let d = c.eval(&[Dual64::new(0.3, 1.0)], Dual64::new(0.0, 0.0));
        assert!(close(d.re, 0.3_f64.sin().powi(2), 1e-15));
        assert!(close(d.eps, 0.6_f64.sin(), 1e-14));

        let c = parse("x^3").unwrap().compile(&mut { coord }).unwrap();
        let x = 0.7;
        let d = c.eval(&[Dual2_64::new(x, 1.0, 0.0)], Dual2_64::new(0.0, 0.0, 0.0));
        assert!(close(d.re, x * x * x, 1e-15));
        assert!(close(d.v1, 3.0 * x * x, 1e-14));
        assert!(close(d.v2, 6.0 * x, 1e-14));

        // Variable exponent (powd) and time.
        let c = parse("x^t")
            .unwrap()
            .compile(&mut |n, _| Ok(if n == "t" { Slot::Time } else { Slot::Coord(0) }))
            .unwrap();
        let d = c.eval(&[Dual64::new(2.0, 0.0)], Dual64::new(3.0, 1.0));
        assert!(close(d.re, 8.0, 1e-14));
        assert!(close(d.eps, 8.0 * 2.0_f64.ln(), 1e-14));

        // atan2(y, x) derivative along y: x / (x^2 + y^2).
        let c = parse("atan2(y, x)")
            .unwrap()
            .compile(&mut |n, _| Ok(Slot::Coord(usize::from(n == "x"))))
            .unwrap();
        let d = c.eval(
            &[Dual64::new(1.0, 1.0), Dual64::new(2.0, 0.0)],
            Dual64::from(0.0),
        );
        assert!(close(d.re, 1.0_f64.atan2(2.0), 1e-15));
        assert!(close(d.eps, 2.0 / 5.0, 1e-14));
    }

    #[test]
    fn dimensions() {
        let var_dim = |n: &str| match n {
            "L" => Some(Dim::LENGTH),
            "m" => Some(Dim::MASS),
            "g" => Some(Dim::ACCELERATION),
            "phi" => Some(Dim::NONE),
            _ => None,
        };
        let dim = |s: &str| parse(s).unwrap().dim(&var_dim);
        assert_eq!(dim("L"), Some(Dim::LENGTH));
        assert_eq!(dim("m*g"), Some(Dim::FORCE));
        assert_eq!(dim("m*g/L"), Some(Dim::STIFFNESS));
        assert_eq!(dim("0.5*m*L^2"), Some(Dim::INERTIA));
        assert_eq!(dim("L*cos(phi)"), Some(Dim::LENGTH));
        assert_eq!(dim("sqrt(L/g)"), Some(Dim::TIME));
        assert_eq!(dim("1/(2 s)"), Some(Dim::FREQUENCY));
        assert_eq!(dim("L + 3 mm"), Some(Dim::LENGTH));
        assert_eq!(dim("3"), None);
        assert_eq!(dim("2*pi"), None);
        assert_eq!(dim("unknown*L"), None);
        assert_eq!(dim("L + m"), None);
        assert_eq!(dim("L^x"), None);
    }

    #[test]
    fn display_round_trips() {
        for src in [
            "2 + 3*4^2",
            "-x^2",
            "(-x)^2",
            "2^3^2",
            "(2^3)^2",
            "a - (b - c)",
            "a/(b*c)",
            "-(a + b)*c",
            "(2 m)*s",
            "50 lbf * in*s/rad + atan2(y, -x)",
            "-3 N",
            "7mm^2",
            "bar1.theta*pi",
        ] {
            let once = parse(src).unwrap().to_string();
            let twice = parse(&once).unwrap().to_string();
            assert_eq!(once, twice, "{src}");
        }
        assert_eq!(parse("(2 m)*s").unwrap().to_string(), "(2 m)*s");
        assert_eq!(parse("-(x^2)").unwrap().to_string(), "-x^2");
        assert_eq!(parse("a-(b-c)").unwrap().to_string(), "a - (b - c)");
    }

    #[test]
    fn error_spans_and_help() {
        let e = err("2 * (3 + x");
        assert_eq!(e.span, 4..5);
        assert!(e.message.contains("unclosed"));

        let e = err("sinn(x)");
        assert_eq!(e.span, 0..4);
        assert!(e.help.unwrap().contains("`sin`"));

        let e = err("7 mmm");
        assert_eq!(e.span, 2..5);
        assert!(e.message.contains("mmm"));
        assert_eq!(e.help.as_deref(), Some("did you mean `mm`?"));

        let e = err("1 +");
        assert_eq!(e.span, 2..3);
        assert!(e.message.contains("missing operand"));

        let e = err("");
        assert_eq!(e.message, "empty expression");
        assert_eq!(err("   ").message, "empty expression");

        let e = err("log(x)");
        assert!(e.help.unwrap().contains("ln"));
        let e = err("atan2(x)");
        assert_eq!(e.span, 0..8);
        assert!(e.message.contains("2 arguments"));
        let e = err("sin(x, y)");
        assert!(e.message.contains("1 argument"));
        let e = err("sin()");
        assert!(e.message.contains("found 0"));

        let e = err("2 $ 3");
        assert_eq!(e.span, 2..3);
        assert!(e.message.contains("unexpected character"));
        let e = err("2 × 3");
        assert_eq!(e.span, 2..4);
        assert!(e.help.unwrap().contains('*'));
        // the middle dot of printed units multiplies
        assert_eq!(val("2 · 3"), 6.0);
        assert_eq!(val("2⋅3"), 6.0);

        let e = err("(1 + 2))");
        assert_eq!(e.span, 7..8);
        assert!(e.message.contains("unmatched"));
        let e = err("sin(x");
        assert_eq!(e.span, 3..4);
        let e = err("(");
        assert_eq!(e.span, 0..1);
        let e = err("()");
        assert_eq!(e.span, 0..2);
        let e = err("* 2");
        assert_eq!(e.span, 0..1);
        let e = err("x ** 2");
        assert_eq!(e.span, 2..4);
        assert!(e.help.unwrap().contains('^'));
        let e = err("2 x");
        assert_eq!(e.span, 2..3);
        assert!(e.help.unwrap().contains("2*x"));
        let e = err("2 m kg");
        assert_eq!(e.span, 4..6);
        let e = err("a b");
        assert!(e.help.unwrap().contains("implicit multiplication"));
        let e = err("k(x + 1)");
        assert!(e.help.unwrap().contains("k*("));
        let e = err("sin + 1");
        assert_eq!(e.span, 0..3);
        let e = err("2 m^x");
        assert_eq!(e.span, 3..5);
        let e = err("2 m^1.5");
        assert!(e.message.contains("integer"));
        let e = err("atan2(1, )");
        assert_eq!(e.span, 7..8);
        let e = err("1e999");
        assert!(e.message.contains("too large"));
        assert_eq!(err("7 mmm").shifted(10).span, 12..15);
    }
}
