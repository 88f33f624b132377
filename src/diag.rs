//! Errors a user can act on.
//!
//! Library code returns [`Error`]; only the command line renders it. A problem in a model
//! file is a [`Diagnostic`] with the byte span of the offending text, a label, and a help
//! line; rendering turns the span into `file:line:col` and shows the source line
//! (ariadne). The loader collects every problem it can find before it gives up, so one
//! run reports them all.

use std::fmt;
use std::ops::Range;
use std::sync::Arc;

/// A model file's text, kept for error messages and provenance.
#[derive(Debug, Clone)]
pub struct SourceFile {
    /// Path as the user gave it.
    pub path: String,
    /// Full text.
    pub text: Arc<str>,
}

impl SourceFile {
    /// 1-based line and column (in characters) of a byte offset.
    pub fn line_col(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.text.len());
        let before = &self.text[..offset];
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        let col = self.text[line_start..offset].chars().count() + 1;
        (line, col)
    }
}

/// One problem in a model file (or in a `--set` value).
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    /// What is wrong, one sentence.
    pub message: String,
    /// Byte range in the source; `None` when no location exists.
    pub span: Option<Range<usize>>,
    /// Short text shown under the span.
    pub label: Option<String>,
    /// What to do about it.
    pub help: Option<String>,
    /// Not a problem but the end of the list: the check stopped after the problems before
    /// it, and more may follow once they are fixed.
    pub stop: bool,
}

impl Diagnostic {
    pub fn new(message: impl Into<String>) -> Self {
        Diagnostic {
            message: message.into(),
            span: None,
            label: None,
            help: None,
            stop: false,
        }
    }
    /// The end of a list that was not checked to its end (`message` says where it stopped).
    pub fn stop(message: impl Into<String>) -> Self {
        Diagnostic {
            stop: true,
            ..Diagnostic::new(message)
        }
    }
    pub fn at(mut self, span: Range<usize>) -> Self {
        self.span = Some(span);
        self
    }
    pub fn label(mut self, label: impl Into<String>) -> Self {
        self.label = Some(label.into());
        self
    }
    pub fn help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }
}

/// Everything that can go wrong, with the numbers a user needs.
#[derive(Debug, Clone)]
pub enum Error {
    /// Problems in a model file, each located in `source`.
    Model {
        source: SourceFile,
        diagnostics: Vec<Diagnostic>,
    },
    /// A bad request, in words (a `--set` value, an output file name); the typed ones are
    /// [`Error::Invalid`].
    Request {
        message: String,
        help: Option<String>,
    },
    /// A computation that could not be completed (no assembly, NaN, step size underflow).
    Numerical {
        message: String,
        help: Option<String>,
    },
    /// A computation that could not be completed, with its numbers (typed: a caller can
    /// tell one from another and add its own advice), and what it was doing (`context`,
    /// outermost first).
    Failed {
        failure: crate::failure::Failure,
        context: Vec<String>,
        /// Where in the model file the failure comes from, when one value is to blame (the
        /// initial velocity that breaks a constraint): rendered like a [`Diagnostic`].
        at: Option<Box<Location>>,
    },
    /// An invalid request (an argument out of its range, a name the model does not have),
    /// with what was asked (typed, naming the argument as the library's API does), and
    /// what the library was doing (`context`, outermost first).
    Invalid {
        invalid: crate::request::Invalid,
        context: Vec<String>,
    },
    /// `error`, in one run of a family over the values of a parameter: `param` at `value`
    /// (as given, or in SI). The front end words which run (the command line quotes its
    /// flag); `context` is what the library was doing around the run, outermost first.
    Run {
        param: String,
        value: String,
        error: Box<Error>,
        context: Vec<String>,
    },
    /// Reading or writing a file.
    Io { path: String, message: String },
}

impl From<crate::request::Invalid> for Error {
    fn from(invalid: crate::request::Invalid) -> Self {
        Error::Invalid {
            invalid,
            context: Vec::new(),
        }
    }
}

impl From<crate::failure::Failure> for Error {
    fn from(failure: crate::failure::Failure) -> Self {
        Error::Failed {
            failure,
            context: Vec::new(),
            at: None,
        }
    }
}

/// A span of a model file that a failure is located at, with the label shown under it.
#[derive(Debug, Clone)]
pub struct Location {
    pub source: SourceFile,
    pub span: Range<usize>,
    pub label: String,
}

impl Error {
    /// The failure located at `at` in its model file (see [`Error::Failed`]'s `at`).
    pub fn failed_at(failure: crate::failure::Failure, at: Option<Location>) -> Self {
        Error::Failed {
            failure,
            context: Vec::new(),
            at: at.map(Box::new),
        }
    }

    /// The model-file location of a failure, if it has one.
    pub fn location(&self) -> Option<&Location> {
        match self {
            Error::Failed { at, .. } => at.as_deref(),
            Error::Run { error, .. } => error.location(),
            _ => None,
        }
    }
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    pub fn request(message: impl Into<String>, help: impl Into<String>) -> Self {
        Error::Request {
            message: message.into(),
            help: Some(help.into()),
        }
    }
    /// The same error with `what: ` before its message(s) (an I/O error already says
    /// which file).
    pub fn context(mut self, what: &str) -> Self {
        match &mut self {
            Error::Request { message, .. } | Error::Numerical { message, .. } => {
                *message = format!("{what}: {message}");
            }
            Error::Model { diagnostics, .. } => {
                // the note that a check stopped is not one of the problems in `what`
                for d in diagnostics.iter_mut().filter(|d| !d.stop) {
                    d.message = format!("{what}: {}", d.message);
                }
            }
            Error::Failed { context, .. }
            | Error::Invalid { context, .. }
            | Error::Run { context, .. } => context.insert(0, what.to_string()),
            Error::Io { .. } => {}
        }
        self
    }

    /// The same error, in the run of a family with `param` at `value` ([`Error::Run`]).
    pub fn in_run(self, param: &str, value: impl ToString) -> Self {
        Error::Run {
            param: param.to_string(),
            value: value.to_string(),
            error: Box::new(self),
            context: Vec::new(),
        }
    }

    /// The typed failure, if this is one.
    pub fn failure(&self) -> Option<&crate::failure::Failure> {
        match self {
            Error::Failed { failure, .. } => Some(failure),
            Error::Run { error, .. } => error.failure(),
            _ => None,
        }
    }

    /// What went wrong in one line, without the location or the help: the typed
    /// failure's physics, or the rendered message's first line (for quoting the error
    /// inside another, e.g. "cannot be settled (…)").
    pub fn headline(&self) -> String {
        match self.failure() {
            Some(f) => f.to_string(),
            None => {
                let text = self.render(false);
                let first = text.lines().next().unwrap_or_default();
                first.trim_start_matches("error: ").to_string()
            }
        }
    }

    /// The typed invalid request, if this is one.
    pub fn invalid(&self) -> Option<&crate::request::Invalid> {
        match self {
            Error::Invalid { invalid, .. } => Some(invalid),
            Error::Run { error, .. } => error.invalid(),
            _ => None,
        }
    }

    pub fn numerical(message: impl Into<String>, help: impl Into<String>) -> Self {
        Error::Numerical {
            message: message.into(),
            help: Some(help.into()),
        }
    }
    pub fn io(path: impl Into<String>, err: impl fmt::Display) -> Self {
        Error::Io {
            path: path.into(),
            message: err.to_string(),
        }
    }

    /// The full human-readable report: for model errors, `file:line:col`, the source line
    /// with the span marked, and the help line.
    pub fn render(&self, color: bool) -> String {
        self.render_with(color, &LibraryWording)
    }

    /// [`Error::render`], with `advice` wording the typed errors in the front end's terms
    /// (the command line names its flags): the help line of a failure, the message and
    /// help line of an invalid request; where it gives none, the library's own.
    pub fn render_with(&self, color: bool, advice: &dyn Advice) -> String {
        match self {
            Error::Failed {
                failure,
                context,
                at,
            } => {
                let help = advice
                    .failure_in(failure, context)
                    .unwrap_or_else(|| failure.hint());
                match at {
                    // as a located problem of the model file: file:line:col and the line
                    Some(at) => {
                        let mut message = String::new();
                        for c in context {
                            message.push_str(c);
                            message.push_str(": ");
                        }
                        message.push_str(&failure.to_string());
                        let d = Diagnostic::new(message)
                            .at(at.span.clone())
                            .label(at.label.clone())
                            .help(help);
                        render_diagnostic(&at.source, &d, color)
                    }
                    None => report(context, &failure.to_string(), &help),
                }
            }
            Error::Invalid { invalid, context } => {
                let Wording { message, help } =
                    advice.invalid(invalid).unwrap_or_else(|| Wording {
                        message: invalid.to_string(),
                        help: invalid.hint(),
                    });
                report(context, &message, &help)
            }
            Error::Run {
                param,
                value,
                error,
                context,
            } => {
                // the run's words, then the context around it, applied now that the
                // front end has chosen them
                let run = advice
                    .run(param, value)
                    .unwrap_or_else(|| format!("with {param} = {value}"));
                let mut e = error.as_ref().clone().context(&run);
                for c in context.iter().rev() {
                    e = e.context(c);
                }
                e.render_with(color, advice)
            }
            Error::Model {
                source,
                diagnostics,
            } => {
                let mut out = String::new();
                // the first ones: each excerpt indexes the whole file, and thousands of
                // problems are fixed from the first few anyway
                const SHOWN: usize = 30;
                let problems: Vec<&Diagnostic> = diagnostics.iter().filter(|d| !d.stop).collect();
                let stop = diagnostics.iter().find(|d| d.stop);
                for d in problems.iter().take(SHOWN) {
                    out.push_str(&render_diagnostic(source, d, color));
                }
                if problems.len() > SHOWN {
                    out.push_str(&format!(
                        "… {} more problems not shown: fix these first\n",
                        problems.len() - SHOWN
                    ));
                }
                if problems.len() > 1 || stop.is_some() {
                    out.push_str(&format!("{} problems in {}", problems.len(), source.path));
                    match stop {
                        Some(d) => out.push_str(&format!(
                            " ({}: more may follow once these are fixed)\n",
                            d.message
                        )),
                        None => out.push('\n'),
                    }
                }
                out
            }
            Error::Request { message, help } | Error::Numerical { message, help } => {
                let mut out = format!("error: {message}\n");
                if let Some(h) = help {
                    out.push_str(&format!("help: {h}\n"));
                }
                out
            }
            Error::Io { path, message } => format!("error: {path}: {message}\n"),
        }
    }
}

/// `error:` with the context (outermost first) and the message, then `help:`.
fn report(context: &[String], message: &str, help: &str) -> String {
    let mut out = String::from("error: ");
    for c in context {
        out.push_str(c);
        out.push_str(": ");
    }
    format!("{out}{message}\nhelp: {help}\n")
}

/// How a front end words what the library reports, in its own terms (a command line
/// names its flags). `None`: the library's own, flag-free wording.
pub trait Advice {
    /// The help line of a failure.
    fn failure(&self, _failure: &crate::failure::Failure) -> Option<String> {
        None
    }
    /// The help line of a failure in its context (the outermost first: `k_fs: the case
    /// k_fs+10%`); by default [`Advice::failure`].
    fn failure_in(&self, failure: &crate::failure::Failure, _context: &[String]) -> Option<String> {
        self.failure(failure)
    }
    /// The message and help line of an invalid request.
    fn invalid(&self, _invalid: &crate::request::Invalid) -> Option<Wording> {
        None
    }
    /// Which run of a family an error belongs to: `param` at `value`.
    fn run(&self, _param: &str, _value: &str) -> Option<String> {
        None
    }
}

/// A message and its help line.
#[derive(Debug, Clone, PartialEq)]
pub struct Wording {
    pub message: String,
    pub help: String,
}

/// The library's own wording: the typed errors' messages and hints.
pub struct LibraryWording;

impl Advice for LibraryWording {}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.render(false))
    }
}

impl std::error::Error for Error {}

/// `error: message` / `--> file:line:col` header, then ariadne's source excerpt.
fn render_diagnostic(source: &SourceFile, d: &Diagnostic, color: bool) -> String {
    use ariadne::{Config, IndexType, Label, Report, ReportKind, Source};
    let Some(span) = d.span.clone() else {
        let mut out = format!("error: {}\n  --> {}\n", d.message, source.path);
        if let Some(h) = &d.help {
            out.push_str(&format!("help: {h}\n"));
        }
        return out;
    };
    let (line, col) = source.line_col(span.start);
    let header = format!("{}:{}:{}: {}", source.path, line, col, d.message);
    let id = source.path.as_str();
    let label = Label::new((id, span.clone())).with_message(d.label.as_deref().unwrap_or("here"));
    let mut report = Report::build(ReportKind::Error, (id, span))
        .with_config(
            Config::default()
                .with_color(color)
                .with_index_type(IndexType::Byte),
        )
        .with_message(&header)
        .with_label(label);
    if let Some(h) = &d.help {
        report = report.with_help(h);
    }
    let mut buf = Vec::new();
    let written = report
        .finish()
        .write((id, Source::from(source.text.as_ref())), &mut buf);
    match written {
        // "error:" as in every other message of detune (ariadne writes "Error:").
        Ok(()) => String::from_utf8_lossy(&buf).replacen("Error:", "error:", 1),
        Err(_) => format!("error: {header}\n"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::request::{Argument, Invalid};

    /// A context names where the problems are; the note that a check stopped early keeps
    /// its own words.
    #[test]
    fn context_prefixes_the_problems_not_the_stop_note() {
        let e = Error::Model {
            source: SourceFile {
                path: "m.toml".into(),
                text: "".into(),
            },
            diagnostics: vec![
                Diagnostic::new("unknown name `x`"),
                Diagnostic::stop("the evaluation of [parameters] stopped at its 30th problem"),
            ],
        }
        .context("--set k=x");
        let Error::Model { diagnostics, .. } = e else {
            panic!("a model error");
        };
        assert_eq!(diagnostics[0].message, "--set k=x: unknown name `x`");
        assert_eq!(
            diagnostics[1].message,
            "the evaluation of [parameters] stopped at its 30th problem"
        );
    }

    #[test]
    fn numbers_for_messages_are_short_at_any_magnitude() {
        // ordinary magnitudes as before: shortest round trip, or `{:.6}`
        assert_eq!(num(0.01), "0.01");
        assert_eq!(num(4.3e-5), "0.000043");
        assert_eq!(num(1e300), "1e300");
        assert_eq!(fixed(0.25, 6), "0.250000");
        assert_eq!(fixed(0.0, 6), "0.000000");
        assert_eq!(fixed(-3.5, 9), "-3.500000000");
        // computed huge and tiny values: a few digits, not 300 (2π/1e-199, 2π·1e-193)
        assert_eq!(num(std::f64::consts::TAU / 1e-199 / 4.0), "1.570796e199");
        assert_eq!(num(std::f64::consts::TAU * 1e-193), "6.283185e-193");
        assert_eq!(num(3.0000000000000004e306), "3e306");
        assert_eq!(fixed(1e308, 6), "1e308");
        assert_eq!(fixed(2.3999999999999998e307, 9), "2.4e307");
        assert_eq!(fixed(-1.25e20, 6), "-1.25e20");
        assert_eq!(fixed(3.2e-9, 6), "3.2e-9");
        assert_eq!(fixed(f64::NAN, 6), "NaN");
    }

    /// Words a run as a command line might.
    struct Flags;
    impl Advice for Flags {
        fn invalid(&self, i: &Invalid) -> Option<Wording> {
            Some(Wording {
                message: format!("FLAG: {i}"),
                help: "HELP".into(),
            })
        }
        fn run(&self, param: &str, value: &str) -> Option<String> {
            Some(format!("--values {param}={value}"))
        }
    }

    #[test]
    fn an_invalid_request_keeps_its_context_and_its_run_is_worded_by_the_front_end() {
        let e = Error::from(Invalid::Zero {
            argument: Argument::MaxPeriods,
        })
        .context("inner")
        .in_run("F0", 0.5)
        .context("outer");
        assert_eq!(
            e.invalid(),
            Some(&Invalid::Zero {
                argument: Argument::MaxPeriods
            })
        );
        assert_eq!(
            e.render(false),
            "error: outer: with F0 = 0.5: inner: the most periods per frequency is 0: no period would be simulated\nhelp: give at least 1 (the default is 600)\n"
        );
        assert_eq!(
            e.render_with(false, &Flags),
            "error: outer: --values F0=0.5: inner: FLAG: the most periods per frequency is 0: no period would be simulated\nhelp: HELP\n"
        );
        // an untyped error takes the run's words as context too
        let e = Error::request("zero forcing", "give an amplitude").in_run("F0", "0");
        assert_eq!(
            e.render_with(false, &Flags),
            "error: --values F0=0: zero forcing\nhelp: give an amplitude\n"
        );
    }
}

/// A number for a message: shortest round-trip decimal for ordinary magnitudes
/// (`0.01`, `4.3e-5` as `0.000043`), and the shortest round-trip scientific form outside
/// 1e-6 ≤ |x| < 1e15, so that `1e300` prints as `1e300`, not as 301 digits.
///
/// A scientific form with more than seven significant digits (a computed value such as
/// 2π/1e-199 = 6.283185307179587e199) is rounded to seven (`6.283185e199`).
pub fn num(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || !x.is_finite() || (1e-6..1e15).contains(&a) {
        format!("{x}")
    } else {
        let s = format!("{x:e}");
        let mantissa = s.split('e').next().unwrap_or_default();
        if mantissa.chars().filter(|c| c.is_ascii_digit()).count() > 7 {
            trim_exp(&format!("{x:.6e}"))
        } else {
            s
        }
    }
}

/// A number for a message with `decimals` places, as `format!("{x:.6}")` gives for an
/// ordinary magnitude (`t = 0.250000 s`), and in scientific form with `decimals`
/// significant places, trailing zeros dropped, outside 1e-4 ≤ |x| < 1e15: `1e300`, not a
/// 301-digit decimal; `2.4e307`; `3.2e-9`, not `0.000000`.
pub fn fixed(x: f64, decimals: usize) -> String {
    let a = x.abs();
    if x == 0.0 || !x.is_finite() || (1e-4..1e15).contains(&a) {
        format!("{x:.decimals$}")
    } else {
        trim_exp(&format!("{x:.decimals$e}"))
    }
}

/// `2.400000e307` as `2.4e307`, `1.000e-9` as `1e-9`.
fn trim_exp(s: &str) -> String {
    match s.split_once('e') {
        Some((m, e)) if m.contains('.') => {
            let m = m.trim_end_matches('0').trim_end_matches('.');
            format!("{m}e{e}")
        }
        _ => s.to_string(),
    }
}

/// An estimate for a message ("about 1e300 points"): [`num`] of `x` rounded to three
/// significant digits, so that 1e-300's 9.999999999999999e299 reads `1e300` and
/// 128000000000 stays whole.
pub fn about(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return num(x);
    }
    num(format!("{x:.2e}").parse().unwrap_or(x))
}
