//! Argument groups shared by several commands: the model and its `--set`s, the
//! integrator's tolerances, the frequency grid.

use clap::Args;
use detune::Model;
use detune::System;
use detune::diag::{Error, Result};
use detune::model::expr;
use detune::model::units::Dim;

#[derive(Args)]
pub struct ModelArgs {
    /// Model file (TOML), e.g. models/overcentre.toml.
    pub model: String,
    /// Override a parameter: NAME=VALUE, where VALUE is a number (SI), a quantity ("3 mm")
    /// or an expression over other parameters ("L1/2"). Repeatable.
    #[arg(long = "set", value_name = "NAME=VALUE", allow_hyphen_values = true)]
    pub set: Vec<String>,
}

impl ModelArgs {
    /// The model file and the `--set` overrides as shell words for a printed command,
    /// leaving out the overrides of `except` (which the command sets itself).
    pub fn command_words(&self, except: &[&str]) -> String {
        let mut out = detune::output::command::shell_word(&self.model);
        for s in &self.set {
            let name = s.split_once('=').map_or(s.as_str(), |(n, _)| n.trim());
            if !except.contains(&name) {
                out.push_str(" --set ");
                out.push_str(&detune::output::command::shell_word(s));
            }
        }
        out
    }

    /// The model file with the `--set` overrides applied, and compiled (names,
    /// dimensions and values checked).
    pub fn load(&self) -> Result<(Model, System)> {
        let (model, sys) = self.load_untrimmed()?;
        // parameters solved for a datum ([trim]) follow every other change
        let (sys, _) = detune::statics::trim::trim(&sys)?;
        if let Some(p) = sys.trim_off() {
            eprintln!(
                "note: the model's [trim] is off: {p} is given with --set, so the held pose need not be at rest"
            );
        }
        Ok((model, sys))
    }

    /// [`ModelArgs::load`] without solving the model's `[trim]`: for what depends on the
    /// geometry only (`check`, `draw`, `kinematics`), which a trim that fails must not
    /// stop.
    pub fn load_untrimmed(&self) -> Result<(Model, System)> {
        let model = Model::load(&self.model)?;
        let overrides = parse_sets(&self.set)?;
        let model = model.with_overrides(&overrides)?;
        let sys = System::new(&model)?;
        Ok((model, sys))
    }
}

fn parse_sets(sets: &[String]) -> Result<Vec<(String, String)>> {
    sets.iter()
        .map(|s| match s.split_once('=') {
            Some((n, v)) if !n.trim().is_empty() && !v.trim().is_empty() => {
                Ok((n.trim().to_string(), v.trim().to_string()))
            }
            _ => Err(Error::request(
                format!("--set {s}: expected NAME=VALUE"),
                "for example --set Fs=-3 or --set \"L1=2.5 m\"",
            )),
        })
        .collect()
}

/// The integrator and its error tolerances (`simulate`, `sweep`, `sensitivity`, `tune`;
/// `nfr` has its own, looser defaults: `cli::nfr::CurveTolerances`).
#[derive(Args)]
pub struct Tolerances {
    /// Relative error tolerance per step.
    #[arg(
        long,
        default_value_t = 1e-10,
        value_name = "R",
        allow_hyphen_values = true
    )]
    pub rtol: f64,
    /// Absolute error tolerance per step (SI units of each coordinate and velocity).
    #[arg(
        long,
        default_value_t = 1e-12,
        value_name = "A",
        allow_hyphen_values = true
    )]
    pub atol: f64,
    /// The integrator: `dop853` (explicit, the fastest for most models) or `radau`
    /// (Radau IIA, implicit: for stiff models, a very stiff spring or damper on a light
    /// body, which hold DOP853 to tiny steps; detune warns when it finds one).
    #[arg(long, value_enum, default_value_t = IntegratorChoice::Dop853, value_name = "METHOD")]
    pub integrator: IntegratorChoice,
}

/// `--integrator`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum IntegratorChoice {
    Dop853,
    Radau,
}

impl IntegratorChoice {
    /// The library's integration method.
    pub fn method(self) -> detune::dynamics::integrator::Integrator {
        use detune::dynamics::integrator::Integrator;
        match self {
            IntegratorChoice::Dop853 => Integrator::Dop853,
            IntegratorChoice::Radau => Integrator::Radau,
        }
    }
}

impl Tolerances {
    /// The library's integration method.
    pub fn integrator(&self) -> detune::dynamics::integrator::Integrator {
        self.integrator.method()
    }

    /// The steady-state settings of a sweep with these tolerances and integrator (the
    /// rest at their defaults).
    pub fn steady(&self) -> detune::frequency::SteadyOptions {
        detune::frequency::SteadyOptions {
            rtol: self.rtol,
            atol: self.atol,
            integrator: self.integrator(),
            ..Default::default()
        }
    }
}

/// The frequencies of `frf` and `sweep`, and what they report.
#[derive(Args)]
pub struct FrequencyGrid {
    /// The forcing's frequency parameter (rad/s).
    #[arg(long, value_name = "NAME")]
    pub param: String,
    /// First frequency: rad/s, or a quantity ("0.5 Hz", "30 rpm").
    #[arg(long, value_name = "A", allow_hyphen_values = true)]
    pub from: String,
    /// Last frequency, rad/s or a quantity (included when the step divides the range).
    #[arg(long, value_name = "B", allow_hyphen_values = true)]
    pub to: String,
    /// Frequency step, rad/s or a quantity ("0.1 Hz").
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub step: String,
    /// Response to report (repeatable) [default: every coordinate]: a coordinate, a force
    /// element's `<name>.tension|elongation|rate` (`.torque|twist|twist_rate`), a named
    /// point's `<body>.<point>.x` (`y`, `z`, with `_rel`, `_dot`, `_ddot`), or a joint's
    /// reaction `<joint>.force_x` (`force_y`, `force_z`).
    #[arg(long, value_name = "NAME")]
    pub response: Vec<String>,
}

impl FrequencyGrid {
    /// The frequencies and the reported responses (every coordinate when none is named).
    pub fn resolve(&self, model: &Model) -> Result<(Vec<f64>, Vec<String>)> {
        let values = detune::linear::grid(
            frequency_value("--from", &self.from)?,
            frequency_value("--to", &self.to)?,
            frequency_value("--step", &self.step)?,
        )?;
        let responses = if self.response.is_empty() {
            model.coordinate_names()
        } else {
            self.response.clone()
        };
        Ok((values, responses))
    }
}

/// A value of the drive as given to `flag`: a number (SI) or a quantity with a unit of
/// the drive's dimension ("-15 deg", "3 mm"), or an expression of them ("-15 deg + 1
/// deg"); no parameters.
pub fn quantity(flag: &str, text: &str, drive: &str, dim: Dim) -> Result<f64> {
    let example = if dim == Dim::NONE {
        "\"-15 deg\" or -0.26 (rad)".to_string()
    } else if dim == Dim::FREQUENCY {
        "\"4.3 Hz\", \"258 rpm\" or 27.0 (rad/s)".to_string()
    } else if dim == Dim::LENGTH {
        "\"3 mm\" or 0.003 (m)".to_string()
    } else {
        format!("\"2.5 {dim}\" or 2.5 ({dim})")
    };
    let bad = |message: String, help: Option<String>| Error::Request {
        message: format!("{flag} {text}: {message}"),
        help: Some(
            help.unwrap_or_else(|| format!("give a number (SI) or a quantity, e.g. {example}")),
        ),
    };
    // `nan`, `inf` (and an expression such as 1e400 below) are no value, not a unit
    let not_finite = || bad("not finite".into(), None);
    if text.trim().parse::<f64>().is_ok_and(|x| !x.is_finite()) {
        return Err(not_finite());
    }
    // the same with a unit: `nan deg`, `inf Hz`, `1e400 rad/s` (the expression parser
    // would take `nan` for a name and ask for an operator before the unit)
    let number = text
        .trim()
        .split(|c: char| c.is_whitespace() || c == '*')
        .next()
        .unwrap_or_default();
    if number.parse::<f64>().is_ok_and(|x| !x.is_finite()) {
        return Err(not_finite());
    }
    let e = expr::parse(text).map_err(|e| bad(e.message.clone(), e.help.clone()))?;
    if let Some((name, _)) = e.variables().first() {
        return Err(bad(
            format!("`{name}` is not a unit here (a value of {drive} is a number or a quantity)"),
            None,
        ));
    }
    e.check_dims(&|_| None)
        .map_err(|e| bad(e.message.clone(), e.help.clone()))?;
    if let Some(got) = e.dim(&|_| None)
        && got != dim
    {
        let given = if got == Dim::NONE {
            "an angle".to_string()
        } else if got == Dim::FREQUENCY {
            "a frequency".to_string()
        } else if got == Dim::TIME {
            "a time".to_string()
        } else {
            format!("in {got}")
        };
        // a flag that takes a frequency or a time (`--from` of a sweep) names itself; a
        // value of a named parameter or coordinate names it
        let message = if drive.starts_with("--") {
            format!(
                "{drive} takes {}; the value given is {given}",
                dim_words(dim)
            )
        } else {
            format!(
                "`{drive}` is {}, the value given is {given}",
                dim_words(dim)
            )
        };
        return Err(bad(message, None));
    }
    let x = expr::eval_const(&e, &mut |n, span| {
        Err(expr::ExprError::new(
            span.clone(),
            format!("unknown name `{n}`"),
        ))
    })
    .map_err(|e| bad(e.message.clone(), e.help.clone()))?;
    if !x.is_finite() {
        return Err(not_finite());
    }
    Ok(x)
}

/// `--mark LABEL=VALUE`: a labelled frequency to draw on a response plot (a rotor's 1P
/// line: `--mark "UH-60 1P=258 rpm"`); VALUE a number (rad/s) or a frequency quantity.
pub fn frequency_mark(text: &str) -> Result<(String, f64)> {
    let Some((label, value)) = text.rsplit_once('=') else {
        return Err(Error::request(
            format!("--mark {text}: expected LABEL=VALUE"),
            "for example --mark \"UH-60 main rotor 1P=258 rpm\" or --mark \"1P=27.0\" (rad/s)",
        ));
    };
    let v = value.trim();
    let w = match v.parse::<f64>() {
        Ok(x) => x,
        Err(_) => quantity("--mark", v, "--mark", detune::model::units::Dim::FREQUENCY)?,
    };
    if !(w.is_finite() && w > 0.0) {
        return Err(Error::request(
            format!("--mark {text}: the frequency must be positive and finite, it is {w} rad/s"),
            "give a forcing frequency, e.g. 27.0 (rad/s), \"4.3 Hz\" or \"258 rpm\"",
        ));
    }
    Ok((label.trim().to_string(), w))
}

/// The `--mark`s of a frequency plot over `values`: each parsed (checked before any
/// work), those outside the range left off with a note when a plot is drawn.
pub fn frequency_marks(marks: &[String], values: &[f64], plot: bool) -> Result<Vec<(String, f64)>> {
    let marks: Vec<(String, f64)> = marks
        .iter()
        .map(|m| frequency_mark(m))
        .collect::<Result<_>>()?;
    let (lo, hi) = match (values.first(), values.last()) {
        (Some(&lo), Some(&hi)) => (lo, hi),
        _ => return Ok(marks),
    };
    Ok(marks
        .into_iter()
        .filter(|(label, w)| {
            let inside = *w >= lo && *w <= hi;
            if !inside && plot {
                eprintln!(
                    "note: --mark {label} at {w:.4} rad/s is outside the swept {lo}–{hi} rad/s: not drawn"
                );
            }
            inside
        })
        .collect())
}

/// A value of parameter `param` given to `flag`: a number (SI) or a quantity in the
/// parameter's dimension (`--from "-10 deg"`, `--to "1.4e5 N/m"`).
pub fn param_value(model: &Model, param: &str, flag: &str, text: &str) -> Result<f64> {
    if let Ok(x) = text.trim().parse::<f64>() {
        return Ok(x);
    }
    let dim = model
        .parameters
        .index(param)
        .and_then(|i| model.parameters.dims[i])
        .unwrap_or(Dim::NONE);
    quantity(flag, text, param, dim)
}

/// `--vary NAME=CHANGE`: the cases and the range of one varied parameter.
///
/// CHANGE is a relative change `±10%` (ASCII `+-10%`; or one-sided `+10%`, `-5%`), an
/// absolute one `±0.5 N/m` (a number is SI), a range of levels `80%..120%` (p0·80/100 …
/// p0·120/100), or a list of values `1.1e5,1.4e5` (numbers SI, or quantities). Labels are
/// `k_fs+10%`, `k_fs-10%`, `k_fs+0.5 N/m`, `k_fs=80%`, `k_fs=1.1e5`. Each value is tried on
/// a copy of the system so that one the model cannot take (a negative mass) is refused
/// here, with the model's located message, before any work.
pub fn vary(model: &Model, sys: &System, text: &str) -> Result<detune::linear::sensitivity::Vary> {
    let bad = |message: String| {
        Error::request(
            format!("--vary {text}: {message}"),
            "write NAME=±10% (or +-10%), NAME=±0.5 N/m, NAME=80%..120%, or NAME=1.1e5,1.4e5",
        )
    };
    let Some((name, change)) = text.split_once('=') else {
        return Err(bad("expected NAME=CHANGE".into()));
    };
    let (name, change) = (name.trim(), change.trim());
    let param =
        detune::request::parameter(sys.param_names(), name, detune::request::Argument::Varied)
            .map_err(|e| detune::diag::Error::Invalid {
                invalid: e,
                context: Vec::new(),
            })?;
    if let Some(t) = &sys.trim
        && t.off.is_none()
        && t.params.contains(&param)
    {
        return Err(Error::request(
            format!(
                "--vary {text}: `{name}` is solved by the model's [trim] at every change, so varying it has no effect"
            ),
            format!(
                "vary another parameter (the trim re-solves `{name}` for it), or fix `{name}` with --set {name}=VALUE, which turns the trim off"
            ),
        ));
    }
    let p0 = sys.param(param);
    let dim = model
        .parameters
        .index(name)
        .and_then(|i| model.parameters.dims[i])
        .unwrap_or(Dim::NONE);
    let value = |t: &str| -> Result<f64> {
        match t.trim().parse::<f64>() {
            Ok(x) => Ok(x),
            Err(_) => quantity("--vary", t.trim(), name, dim).map_err(|e| match e {
                Error::Request { message, .. } => Error::request(
                    format!(
                        "--vary {text}: {}",
                        message.split_once(": ").map_or(message.as_str(), |m| m.1)
                    ),
                    format!(
                        "give a relative change (±10%) or a number in SI{}, or a quantity of that dimension",
                        if dim == Dim::NONE { String::new() } else { format!(" ({dim})") }
                    ),
                ),
                other => other,
            }),
        }
    };
    let percent =
        |t: &str| -> Option<f64> { t.trim().strip_suffix('%')?.trim().parse::<f64>().ok() };
    let relative = |frac: f64| -> Result<f64> {
        if p0 == 0.0 {
            return Err(Error::request(
                format!("--vary {text}: `{name}` is 0, so a relative change of it is 0"),
                format!("give an absolute change, e.g. --vary \"{name}=±0.1 {}\"", {
                    // the parameter's declared unit (rad/s, not the SI 1/s)
                    let u = model.param_unit(name);
                    if u.is_empty() { dim_unit(dim) } else { u }
                }),
            ));
        }
        Ok(p0 * frac)
    };
    let (plusminus, rest) = if let Some(r) = change.strip_prefix('±') {
        (true, r)
    } else if let Some(r) = change.strip_prefix("+-") {
        (true, r)
    } else {
        (false, change)
    };
    let mut cases: Vec<(String, f64)> = Vec::new();
    if plusminus {
        if let Some(pc) = percent(rest) {
            if !(pc > 0.0) {
                return Err(bad(format!(
                    "a change of ±{pc}% varies nothing: give a change > 0"
                )));
            }
            let d = relative(pc / 100.0)?;
            let r = rest.trim();
            cases.push((format!("{name}+{r}"), p0 + d));
            cases.push((format!("{name}-{r}"), p0 - d));
        } else {
            let d = value(rest)?;
            let r = rest.trim();
            if !d.is_finite() {
                return Err(bad(format!("the change ±{r} is not finite")));
            }
            if d == 0.0 {
                return Err(bad(format!(
                    "a change of ±{r} varies nothing: give a change > 0"
                )));
            }
            if d < 0.0 {
                return Err(bad(format!(
                    "a change of ±{r} is negative: ± already gives both signs, write ±{}",
                    rest.trim().trim_start_matches('-').trim()
                )));
            }
            cases.push((format!("{name}+{r}"), p0 + d));
            cases.push((format!("{name}-{r}"), p0 - d));
        }
    } else if let Some((a, b)) = change.split_once("..") {
        let (Some(a), Some(b)) = (percent(a), percent(b)) else {
            return Err(bad(
                "a range of levels is written a%..b%, e.g. 80%..120%".into()
            ));
        };
        if a == b {
            return Err(bad(format!(
                "the range {a}%..{b}% has one level: give two different levels, lower first (e.g. 80%..120%)"
            )));
        }
        if a > b {
            return Err(bad(format!(
                "the range {a}%..{b}% is reversed: give the lower level first ({b}%..{a}%)"
            )));
        }
        if a <= 0.0 {
            return Err(bad(format!(
                "a level of {a}% makes `{name}` zero or of the opposite sign: levels are percentages of its value, e.g. 50%..200%"
            )));
        }
        cases.push((
            format!("{name}={}%", detune::diag::num(a)),
            relative(a / 100.0)?,
        ));
        cases.push((
            format!("{name}={}%", detune::diag::num(b)),
            relative(b / 100.0)?,
        ));
    } else if (change.starts_with('+') || change.starts_with('-')) && percent(change).is_some() {
        let pc = percent(change).unwrap_or(0.0);
        cases.push((format!("{name}{change}"), p0 + relative(pc / 100.0)?));
    } else if let Some(pc) = percent(change) {
        return Err(bad(format!(
            "`{change}` is a change without a sign: write ±{pc}% (both sides), +{pc}% or -{pc}% (one), or a range of levels such as {}%..{}%",
            100.0 - pc,
            100.0 + pc
        )));
    } else {
        for v in change.split(',') {
            if v.trim().is_empty() {
                return Err(bad("an empty value in the list".into()));
            }
            cases.push((format!("{name}={}", v.trim()), value(v)?));
        }
    }
    for (label, v) in &cases {
        if !v.is_finite() {
            return Err(bad(format!("{label} gives {name} = {v}")));
        }
        let mut s = sys.clone();
        s.set_param(param, *v).map_err(|e| {
            let unit = model.param_unit(name);
            e.context(&format!(
                "--vary {text}: the case {label} ({name} = {})",
                format!("{} {unit}", detune::diag::num(*v)).trim_end()
            ))
        })?;
    }
    let lo = cases.iter().map(|c| c.1).fold(p0, f64::min);
    let hi = cases.iter().map(|c| c.1).fold(p0, f64::max);
    Ok(detune::linear::sensitivity::Vary {
        param,
        name: name.to_string(),
        cases,
        range: (lo, hi),
    })
}

/// Every `--vary`, each parameter at most once; a case that makes a damping coefficient
/// negative is warned of on standard error ([`damping_warnings`]).
pub fn varies(
    model: &Model,
    sys: &System,
    texts: &[String],
) -> Result<Vec<detune::linear::sensitivity::Vary>> {
    let out = varies_quietly(model, sys, texts)?;
    for w in damping_warnings(model, sys, &out) {
        eprintln!("warning: {w}");
    }
    Ok(out)
}

/// [`varies`] for another flag that takes `--vary`'s NAME=CHANGE (`--tolerance`,
/// `--tune-vary`): its errors name that flag, not `--vary`, which the user did not type.
pub fn varies_as(
    model: &Model,
    sys: &System,
    texts: &[String],
    flag: &str,
) -> Result<Vec<detune::linear::sensitivity::Vary>> {
    let renamed = |message: String, help: Option<String>| Error::Request {
        message: match message.strip_prefix("--vary ") {
            Some(rest) => format!("{flag} {rest}"),
            None => format!("{flag}: {message}"),
        },
        help: help.map(|h| h.replace("one --vary", &format!("one {flag}"))),
    };
    varies(model, sys, texts).map_err(|e| match e {
        Error::Request { message, help } => renamed(message, help),
        Error::Invalid { invalid, context } => match super::advice::wording(&invalid) {
            Some(w) => renamed(w.message, Some(w.help)),
            None => Error::Invalid { invalid, context }.context(flag),
        },
        other => other.context(flag),
    })
}

/// [`varies`] without the warnings (parsed again for a document's `warnings`).
pub fn varies_quietly(
    model: &Model,
    sys: &System,
    texts: &[String],
) -> Result<Vec<detune::linear::sensitivity::Vary>> {
    let mut out: Vec<detune::linear::sensitivity::Vary> = Vec::new();
    for t in texts {
        let v = vary(model, sys, t)?;
        if out.iter().any(|o| o.param == v.param) {
            return Err(Error::request(
                format!("--vary {t}: `{}` is varied twice", v.name),
                "give each parameter one --vary (a list of values goes in one: NAME=a,b,c)",
            ));
        }
        out.push(v);
    }
    Ok(out)
}

/// The warnings of the cases of `vs` that make a damping coefficient negative (for the
/// The damping warnings as the JSON's `warnings` entries: `{"kind": "negative_damping",
/// "message": ...}`, like the other warnings (a stiff integration's).
pub fn damping_warning_values(texts: &[String]) -> Vec<serde_json::Value> {
    texts
        .iter()
        .map(|t| serde_json::json!({"kind": "negative_damping", "message": t}))
        .collect()
}

/// JSON documents' `warnings`; [`varies`] prints them on standard error).
pub fn damping_warnings(
    model: &Model,
    sys: &System,
    vs: &[detune::linear::sensitivity::Vary],
) -> Vec<String> {
    detune::linear::sensitivity::negative_dampings(sys, vs)
        .iter()
        .map(|w| w.message(&model.param_unit(&w.param)))
        .collect()
}

/// How to give the model a forcing to sweep, for a hint: its own forcing amplitude
/// (`[model] forcing_amplitude`) in its declared unit, `set the forcing amplitude F0, e.g.
/// --set "F0=VALUE N"`, or, for a model that names none, a generic parameter.
pub fn set_forcing_amplitude(model: &Model, sys: &System) -> String {
    match sys.forcing_amplitude_param() {
        Some(i) => {
            let name = &sys.param_names()[i];
            let unit = model.param_unit(name);
            format!(
                "set the forcing amplitude `{name}`, e.g. --set \"{name}=VALUE{}{unit}\"",
                if unit.is_empty() { "" } else { " " }
            )
        }
        None => "set the parameter that scales the forcing, e.g. --set \"NAME=VALUE\" (the model names no `forcing_amplitude` in [model])".into(),
    }
}

/// What a value of dimension `dim` is, in words, with the units it may be given in:
/// "a frequency (rad/s, Hz or rpm)", not "a quantity in 1/s".
fn dim_words(dim: Dim) -> String {
    if dim == Dim::NONE {
        "an angle (rad or deg)".to_string()
    } else if dim == Dim::FREQUENCY {
        "a frequency (rad/s, Hz or rpm)".to_string()
    } else if dim == Dim::TIME {
        "a time (s, ms or min)".to_string()
    } else {
        format!("a quantity in {dim}")
    }
}

/// An SI unit to suggest for a dimension in a hint.
fn dim_unit(dim: Dim) -> String {
    if dim == Dim::NONE {
        String::new()
    } else {
        format!("{dim}")
    }
}

/// A frequency given to `flag`: a number (rad/s) or a quantity of frequency ("0.5 Hz",
/// "258 rpm", "27 rad/s").
pub fn frequency_value(flag: &str, text: &str) -> Result<f64> {
    match text.trim().parse::<f64>() {
        Ok(x) => Ok(x),
        Err(_) => quantity(flag, text.trim(), flag, Dim::FREQUENCY),
    }
}

/// A time given to `flag`: a number (s) or a quantity of time ("500 ms", "2 min").
pub fn time_value(flag: &str, text: &str) -> Result<f64> {
    match text.trim().parse::<f64>() {
        Ok(x) => Ok(x),
        Err(_) => quantity(flag, text.trim(), flag, Dim::TIME),
    }
}

/// `--plot-size WxH`: shared by every command with `--plot`.
#[derive(Args, Clone, Default)]
pub struct PlotSize {
    /// Figure size in pixels, WxH (e.g. 1600x1000; each side 300–8000). Text and lines
    /// scale with the width [default: 900 wide, 520 per panel].
    #[arg(long = "plot-size", value_name = "WxH")]
    pub plot_size: Option<String>,
}

impl PlotSize {
    /// Check the figure request before any work: `--plot` named `.svg` or `.png`, a valid
    /// `--plot-size` (which needs `--plot`), and `-o` not named like a figure (it is CSV).
    /// Returns the size asked for.
    pub fn check(&self, plot: Option<&str>, csv: Option<&str>) -> Result<Option<(u32, u32)>> {
        if let Some(p) = plot
            && detune::output::commit::is_stdout(p)
        {
            return Err(Error::request(
                format!(
                    "--plot {p}: this command prints its results on standard output, where they would mix with the figure"
                ),
                "write the figure to a file (--plot figure.svg) or another stream (a FIFO, /dev/stderr); `simulate` and `draw` can write theirs to standard output",
            ));
        }
        self.check_streamed(plot, csv)
    }

    /// [`PlotSize::check`] for a command that writes nothing else on standard output when
    /// its figure goes there (`simulate`: its summary then goes to stderr).
    pub fn check_streamed(
        &self,
        plot: Option<&str>,
        csv: Option<&str>,
    ) -> Result<Option<(u32, u32)>> {
        if let Some(o) = csv {
            csv_output(o)?;
        }
        if let Some(p) = plot {
            detune::output::plot::Format::of("--plot", p)?;
        }
        match (&self.plot_size, plot) {
            (None, _) => Ok(None),
            (Some(s), Some(_)) => detune::output::plot::parse_size(s).map(Some),
            (Some(s), None) => Err(Error::request(
                format!("--plot-size {s} without --plot: there is no figure to size"),
                "add --plot FIGURE.svg (or .png), or leave out --plot-size",
            )),
        }
    }
}

/// Before a long run (a sweep): a figure of `panels` stacked panels at `size` must have
/// room for a plot in each, or the run's results would be lost with the figure refused at
/// the end. Checked on stand-in panels (a one-line title, the caption, a short legend
/// entry per curve and the ω_n line: a lower bound; the figure itself is checked again
/// when it is drawn, with its own titles and legends).
pub fn check_panels(size: Option<(u32, u32)>, panels: usize, curves: usize) -> Result<()> {
    use detune::output::plot::{LinePlot, Panels, Series, Style};
    let Some(size) = size else { return Ok(()) };
    let plots: Vec<LinePlot> = (0..panels.max(1))
        .map(|_| {
            let mut p = LinePlot::new("a response", "omega [rad/s]", "amplitude");
            // the caption naming the model, and the linear ω_n's legend line
            p.caption = "model (model.toml)".into();
            p.vertical = vec![(0.5, "linear ω_n = 1 rad/s".into())];
            // a legend entry per curve (per --values run), as the figure will have
            p.series = (0..curves.max(1))
                .map(|k| {
                    Series::new(
                        format!("r{k} [rad]"),
                        vec![0.0, 1.0],
                        vec![0.0, 1.0],
                        Style::Solid,
                    )
                })
                .collect();
            p
        })
        .collect();
    Panels::new(&plots, size).check()
}

/// `-o`: a CSV is never written into a file named like a figure.
pub fn csv_output(path: &str) -> Result<()> {
    let ext = std::path::Path::new(path)
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    if let Some(e @ ("svg" | "png")) = ext.as_deref() {
        return Err(Error::request(
            format!("-o {path}: -o writes the CSV table, not a `.{e}` figure"),
            format!("name the table .csv; the figure is --plot {path}"),
        ));
    }
    Ok(())
}

/// `--freq-unit`: the unit of the frequencies a command prints and plots.
#[derive(Args, Clone, Copy)]
pub struct FreqUnitArg {
    /// Unit of the frequencies printed and plotted: rad/s, Hz or rpm. CSV and JSON stay
    /// in SI (rad/s) whatever it is.
    #[arg(
        long = "freq-unit",
        value_name = "UNIT",
        default_value = "rad/s",
        value_parser = parse_freq_unit
    )]
    pub freq_unit: detune::output::units::FreqUnit,
}

fn parse_freq_unit(text: &str) -> std::result::Result<detune::output::units::FreqUnit, String> {
    text.parse()
}
