//! Invalid requests as typed values that carry what was asked: an argument out of its
//! range, a name the model does not have. The library names the argument as its API does
//! ([`Argument`]); which command-line flag gave it, and the advice in the flags' terms,
//! is the CLI's business (`cli::advice`). [`Invalid::hint`] is the flag-free hint a
//! library user gets. (The numerical failures are [`crate::failure::Failure`].)

use std::fmt;

/// `Argument`, each variant with the words a message names it by, and
/// [`Argument::ALL`]: one list, so that none is left out of either.
macro_rules! arguments {
    ($($(#[$doc:meta])* $name:ident => $words:literal,)*) => {
        /// The argument of a library function (or a field of its options) that a request
        /// got wrong.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum Argument {
            $($(#[$doc])* $name,)*
        }

        impl Argument {
            /// Every argument.
            pub const ALL: &[Argument] = &[$(Argument::$name),*];

            /// The argument in words, as a message names it.
            pub fn describe(self) -> &'static str {
                match self {
                    $(Argument::$name => $words,)*
                }
            }
        }
    };
}

arguments! {
    /// The forcing-frequency parameter of a frequency response or a sweep (`param`).
    FrequencyParameter => "the frequency parameter",
    /// The parameter a continuation varies (`ContinuationOptions::param`).
    ContinuationParameter => "the parameter of a continuation",
    /// A response reported (`responses`): a coordinate, a force element's quantity, a
    /// named point's position or rate, a joint's reaction.
    Response => "the response",
    /// The coordinate the mode shapes are normalized to (`normalize`).
    Normalize => "the shapes' reference coordinate",
    /// The coordinate a branch figure draws against the parameter.
    PlotCoordinate => "the plotted coordinate",
    /// The frequencies of a grid, `from` to `to` ([`crate::linear::grid`]).
    Frequencies => "the frequency range",
    /// The parameter range of a continuation (`from`, `to`).
    ContinuationRange => "the continuation range",
    /// The step of a frequency grid ([`crate::linear::grid`]).
    FrequencyStep => "the frequency step",
    /// The largest arclength step of a continuation (`ContinuationOptions::step`).
    ArclengthStep => "the arclength step",
    /// The most steps of a continuation (`ContinuationOptions::max_steps`).
    MaxSteps => "the most continuation steps",
    /// The resolution to which a sweep locates its peaks (`SweepOptions::refine`).
    Refine => "the refinement resolution",
    /// The most periods simulated per frequency (`SteadyOptions::max_periods`).
    MaxPeriods => "the most periods per frequency",
    /// The fixed number of periods per frequency (`SteadyOptions::fixed_periods`).
    FixedPeriods => "the fixed number of periods per frequency",
    /// The settling tolerance of a steady state (`SteadyOptions::settle_tol`).
    SettleTol => "the settling tolerance",
    /// The length of a simulation, s (`SimOptions::t_end`).
    Duration => "the duration",
    /// The output interval of a simulation, s (`SimOptions::dt_out`).
    OutputInterval => "the output interval",
    /// The integrator's relative tolerance (`rtol`).
    RelativeTolerance => "the relative tolerance",
    /// The integrator's absolute tolerance (`atol`).
    AbsoluteTolerance => "the absolute tolerance",
    /// The coordinate a kinematic analysis drives (`KinematicsOptions::drive`).
    Drive => "the driven coordinate",
    /// A coordinate whose transmission ratio is reported (`KinematicsOptions::ratios`).
    Ratio => "the ratio coordinate",
    /// The range of the driven coordinate (`KinematicsOptions::from`, `to`).
    DriveRange => "the drive range",
    /// The step of the driven coordinate (`KinematicsOptions::step`).
    DriveStep => "the drive step",
    /// A parameter varied by a sensitivity study, a margins check or a tuning
    /// ([`crate::linear::sensitivity::Vary`]).
    Varied => "a varied parameter",
    /// The separation a mode must keep from a forcing line, a fraction
    /// ([`crate::margins::check_margins`]).
    Margin => "the required margin",
    /// The parameter modes are tracked over ([`crate::linear::tracking::track_modes`]).
    TrackedParameter => "the tracked parameter",
    /// The values of the tracked parameter (`values`).
    TrackedValues => "the tracked parameter's values",
    /// The step of the tracked parameter's grid.
    TrackedStep => "the tracked parameter's step",
    /// The number of values of the tracked parameter's grid.
    TrackedPoints => "the number of points",
}

impl fmt::Display for Argument {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.describe())
    }
}

/// A request the library cannot carry out as asked, with what was asked.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Invalid {
    #[error("{argument} `{name}` is not a parameter of this model")]
    UnknownParameter {
        argument: Argument,
        name: String,
        /// The model's parameters.
        known: Vec<String>,
    },
    #[error("{argument} `{name}` is not a coordinate of this model")]
    UnknownCoordinate {
        argument: Argument,
        name: String,
        /// The model's coordinates.
        known: Vec<String>,
    },
    /// A response name the model does not have (see `System::output`).
    #[error("{argument} `{name}` is not a response of this model")]
    UnknownResponse {
        argument: Argument,
        name: String,
        /// Every response name of the model.
        known: Vec<String>,
        /// Each kind of response of the model, described.
        kinds: Vec<String>,
    },
    /// `name` is not the forcing frequency. `definition`: the forcing frequency's
    /// definition where it is derived from `name` (`omega = w0/4`), None where the
    /// forcing does not depend on `name` at all.
    #[error("{}", not_forcing_frequency(name, forcing, definition.as_deref()))]
    NotForcingFrequency {
        name: String,
        forcing: String,
        definition: Option<String>,
    },
    #[error("the model does not say which parameter is its forcing frequency")]
    NoForcingFrequency,
    /// The forcing frequency is defined from other parameters (`omega = 2*pi*f`): setting
    /// it would detach it from them, and a forcing written in them would not follow.
    #[error(
        "the forcing frequency `{name}` is defined from other parameters ({definition}): a frequency response sets it, and whatever is written in those would not follow"
    )]
    DerivedForcingFrequency { name: String, definition: String },
    /// A frequency ≤ 0 or not finite (`value`), or none at all (`None`).
    #[error("the frequencies of `{param}` must be positive and finite (rad/s){}", match .value {
        Some(v) => format!(", not {v}"),
        None => ": none given".to_string(),
    })]
    BadFrequencies { param: String, value: Option<f64> },
    #[error("{what} {from} to {to} is {}", if .from.is_finite() && .to.is_finite() { "empty" } else { "not finite" })]
    Range { what: Argument, from: f64, to: f64 },
    #[error("{argument} {value} is not positive and finite")]
    NotPositive { argument: Argument, value: f64 },
    #[error("{argument} {value} is negative or not finite")]
    Negative { argument: Argument, value: f64 },
    #[error("{argument} {value} is not between 0 and 1")]
    NotFraction { argument: Argument, value: f64 },
    #[error("{argument} is 0: {}", match .argument {
        Argument::MaxPeriods | Argument::FixedPeriods => "no period would be simulated",
        _ => "nothing would be computed",
    })]
    Zero { argument: Argument },
    /// `points`: how many the request gives, as a float (a step of 1e-300 gives about
    /// 1e300, which no integer holds).
    #[error(
        "{argument} {} gives about {} points, more than {limit}",
        crate::diag::num(*.value),
        crate::diag::about(*.points)
    )]
    TooManyPoints {
        argument: Argument,
        value: f64,
        points: f64,
        limit: usize,
    },
    /// A transmission ratio asked of a coordinate that no constraint couples to the
    /// driven one: it does not move with the drive.
    #[error(
        "`{name}` does not move with the driven coordinate `{drive}` (no constraint couples them): d{drive}/d{name} is undefined"
    )]
    NotDriven { name: String, drive: String },
    /// A driven coordinate that the constraints hold fixed at the assembled pose (a
    /// revolute's centre): it cannot be driven.
    #[error("`{drive}` is fixed by the constraints at the assembled pose: it cannot be driven")]
    FixedDrive { drive: String },
    /// A peak's bracket is its two neighbours, 2 steps wide.
    #[error(
        "the refinement resolution {refine} is not finer than a peak's bracket (2 × the frequency step {step}): nothing would be refined"
    )]
    RefineTooCoarse { refine: f64, step: f64 },
    /// A step too small to change the stepped quantity in double precision
    /// (|step| < 1e-12 · `scale`, `scale` = max(|from|, |to|, 1)).
    #[error(
        "{argument} {step:e} cannot change a value of size {scale:e} in double precision (below 1e-12 of it): nothing would move"
    )]
    StepTooSmall {
        argument: Argument,
        step: f64,
        scale: f64,
    },
    /// A family's values (`PARAM=v1,v2,...`) without `=`.
    #[error("the family of values `{spec}` is not of the form PARAM=v1,v2,...")]
    FamilySyntax { spec: String },
    #[error("the family of values `{spec}` names no parameter before `=`")]
    FamilyUnnamed { spec: String },
    #[error("the family of values `{spec}` varies `{name}`, the swept frequency parameter")]
    FamilyVariesSwept { spec: String, name: String },
    #[error("the family of values `{spec}` has an empty entry")]
    FamilyEmptyEntry { spec: String },
}

/// The index of parameter `name` among a model's parameter `names` (in index order), or
/// the invalid request: `argument` names no parameter.
pub fn parameter(names: &[String], name: &str, argument: Argument) -> Result<usize, Invalid> {
    names
        .iter()
        .position(|n| n == name)
        .ok_or_else(|| Invalid::UnknownParameter {
            argument,
            name: name.to_string(),
            known: names.to_vec(),
        })
}

/// The index of coordinate `name` among a model's coordinate `names`, or the invalid
/// request: `argument` names no coordinate.
pub fn coordinate(names: &[String], name: &str, argument: Argument) -> Result<usize, Invalid> {
    names
        .iter()
        .position(|n| n == name)
        .ok_or_else(|| Invalid::UnknownCoordinate {
            argument,
            name: name.to_string(),
            known: names.to_vec(),
        })
}

impl Invalid {
    /// What to do about it, without naming any command-line flag.
    pub fn hint(&self) -> String {
        use Argument as A;
        use Invalid::*;
        match self {
            UnknownParameter { name, known, .. } => {
                crate::model::suggest(name, known.iter().map(|s| s.as_str()))
                    .unwrap_or_else(|| format!("parameters of this model: {}", known.join(", ")))
            }
            UnknownCoordinate { name, known, .. } => {
                crate::model::suggest(name, known.iter().map(|s| s.as_str()))
                    .unwrap_or_else(|| format!("coordinates: {}", known.join(", ")))
            }
            UnknownResponse {
                name, known, kinds, ..
            } => match crate::model::suggest(name, known.iter().map(|s| s.as_str())) {
                Some(s) => format!("{s} responses: {}", kinds.join("; ")),
                None => format!("responses: {}", kinds.join("; ")),
            },
            NotForcingFrequency {
                name,
                forcing,
                definition: Some(_),
            } => format!(
                "step `{forcing}` itself (a value of its own), or follow `{name}` by continuation of the periodic orbits"
            ),
            NotForcingFrequency { forcing, .. } => format!("use `{forcing}`"),
            NoForcingFrequency => "add `forcing_frequency = \"omega\"` to [model]".into(),
            DerivedForcingFrequency { name, .. } => format!(
                "give `{name}` a value of its own and define the others from it (e.g. f = {name}/(2*pi))"
            ),
            BadFrequencies { .. } => "give frequencies > 0".into(),
            Range {
                what: A::Frequencies,
                ..
            } => "give a start below the end (or equal to it for one frequency)".into(),
            Range {
                what: A::DriveRange,
                ..
            } => "give finite values".into(),
            Range { .. } => "give two different finite values".into(),
            NotPositive { argument, .. } => match argument {
                A::FrequencyStep => "give a positive step",
                A::DriveStep => "give a positive step, e.g. 0.5 deg",
                A::ArclengthStep => "give a positive arclength step",
                A::Refine => "give a positive resolution, e.g. 1e-3",
                A::OutputInterval => "give an output interval > 0 s",
                A::AbsoluteTolerance => "give an absolute tolerance > 0, e.g. 1e-12",
                _ => "give a positive value",
            }
            .into(),
            Negative { argument, .. } => match argument {
                A::Duration => "give a duration ≥ 0 s",
                _ => "give a value ≥ 0",
            }
            .into(),
            NotFraction { argument, .. } => match argument {
                A::RelativeTolerance => "give a relative tolerance between 0 and 1, e.g. 1e-10",
                A::SettleTol => "give a fraction such as 1e-8",
                A::Margin => "give a fraction above 0 and below 1, e.g. 0.1 (10 %)",
                _ => "give a value between 0 and 1",
            }
            .into(),
            Zero { argument } => match argument {
                A::MaxPeriods => "give at least 1 (the default is 600)",
                A::FixedPeriods => "give at least 1, or None to detect the steady state",
                _ => "give at least 1",
            }
            .into(),
            TooManyPoints { argument, .. } => match argument {
                A::OutputInterval => "use a larger output interval",
                _ => "give a larger step",
            }
            .into(),
            StepTooSmall { .. } => "give a step above 1e-12 of the range's magnitude".into(),
            RefineTooCoarse { .. } => {
                "give a resolution below the frequency step (e.g. the step / 100), or none".into()
            }
            NotDriven { drive, .. } => {
                format!("name a coordinate that the constraints move with `{drive}`")
            }
            FixedDrive { .. } => {
                "drive a coordinate the mechanism can move (an angle of a degree of freedom, e.g. the stick's angle)".into()
            }
            FamilySyntax { .. } | FamilyUnnamed { .. } => "for example F0=0.1,1,2,3,4".into(),
            FamilyVariesSwept { .. } => {
                "vary a different parameter, e.g. the forcing amplitude F0".into()
            }
            FamilyEmptyEntry { .. } => "separate the values by single commas: F0=0.1,1,2".into(),
        }
    }
}

/// The words of [`Invalid::NotForcingFrequency`].
fn not_forcing_frequency(name: &str, forcing: &str, definition: Option<&str>) -> String {
    match definition {
        Some(d) => format!(
            "the forcing frequency `{forcing}` is defined from `{name}` ({forcing} = {d}): a frequency response steps the forcing frequency itself, not a parameter it is derived from"
        ),
        None => format!(
            "the forcing of this model does not depend on `{name}` (the frequency parameter); it turns at `{forcing}`"
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every kind of invalid request, with every argument where it carries one.
    fn all() -> Vec<Invalid> {
        use Invalid::*;
        let known = vec!["F0".to_string(), "Fs".into(), "omega".into()];
        let mut all = vec![
            NotForcingFrequency {
                name: "k".into(),
                forcing: "omega".into(),
                definition: None,
            },
            NotForcingFrequency {
                name: "w0".into(),
                forcing: "omega".into(),
                definition: Some("w0/4".into()),
            },
            NoForcingFrequency,
            DerivedForcingFrequency {
                name: "omega".into(),
                definition: "2*pi*f".into(),
            },
            BadFrequencies {
                param: "omega".into(),
                value: Some(-1.0),
            },
            BadFrequencies {
                param: "omega".into(),
                value: None,
            },
            RefineTooCoarse {
                refine: 1.0,
                step: 0.5,
            },
            StepTooSmall {
                argument: Argument::ArclengthStep,
                step: 1e-300,
                scale: 10.0,
            },
            FamilySyntax { spec: "F0".into() },
            FamilyUnnamed { spec: "=1".into() },
            FamilyVariesSwept {
                spec: "omega=1".into(),
                name: "omega".into(),
            },
            FamilyEmptyEntry {
                spec: "F0=1,,2".into(),
            },
            NotDriven {
                name: "gearbox.theta".into(),
                drive: "stick.phi".into(),
            },
            FixedDrive {
                drive: "gearbox.x".into(),
            },
        ];
        for &argument in Argument::ALL {
            for name in ["Fz", "zzz"] {
                all.push(UnknownParameter {
                    argument,
                    name: name.into(),
                    known: known.clone(),
                });
                all.push(UnknownCoordinate {
                    argument,
                    name: name.into(),
                    known: known.clone(),
                });
                all.push(UnknownResponse {
                    argument,
                    name: name.into(),
                    known: known.clone(),
                    kinds: vec!["coordinates (bar1.x)".into()],
                });
            }
            for (from, to) in [(3.0, 1.0), (f64::INFINITY, 1.0)] {
                all.push(Range {
                    what: argument,
                    from,
                    to,
                });
            }
            all.extend([
                NotPositive {
                    argument,
                    value: -1.0,
                },
                Negative {
                    argument,
                    value: -1.0,
                },
                NotFraction {
                    argument,
                    value: 2.0,
                },
                Zero { argument },
                TooManyPoints {
                    argument,
                    value: 1e-9,
                    points: 1e11,
                    limit: 10_000_000,
                },
            ]);
        }
        all
    }

    #[test]
    fn library_messages_and_hints_name_no_flag() {
        for i in all() {
            let (m, h) = (i.to_string(), i.hint());
            assert!(!m.contains("--") && !h.contains("--"), "{m} / {h}");
            assert!(!m.is_empty() && !h.is_empty());
        }
    }

    #[test]
    fn messages_carry_the_values_and_name_the_argument() {
        let i = Invalid::Range {
            what: Argument::Frequencies,
            from: 3.0,
            to: 1.0,
        };
        assert_eq!(i.to_string(), "the frequency range 3 to 1 is empty");
        let i = Invalid::UnknownParameter {
            argument: Argument::ContinuationParameter,
            name: "Fz".into(),
            known: vec!["F0".into(), "Fs".into(), "k".into()],
        };
        assert_eq!(
            i.to_string(),
            "the parameter of a continuation `Fz` is not a parameter of this model"
        );
        assert_eq!(i.hint(), "did you mean `F0` or `Fs`?");
        let i = Invalid::UnknownCoordinate {
            argument: Argument::Response,
            name: "xyz".into(),
            known: vec!["bar1.x".into(), "bar1.theta".into()],
        };
        assert_eq!(i.hint(), "coordinates: bar1.x, bar1.theta");
        let i = Invalid::NotPositive {
            argument: Argument::FrequencyStep,
            value: f64::NAN,
        };
        assert_eq!(
            i.to_string(),
            "the frequency step NaN is not positive and finite"
        );
    }
}
