//! Argument groups shared by several commands: the model and its `--set`s, the
//! integrator's tolerances, the frequency grid.

use clap::Args;
use detune::Model;
use detune::System;
use detune::diag::{Error, Result};

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
    /// The model file with the `--set` overrides applied, and compiled (names,
    /// dimensions and values checked).
    pub fn load(&self) -> Result<(Model, System)> {
        let model = Model::load(&self.model)?;
        let overrides = parse_sets(&self.set)?;
        let model = model.with_overrides(&overrides)?;
        let sys = System::new(&model)?;
        // parameters solved for a datum ([trim]) follow every other change
        let (sys, _) = detune::statics::trim::trim(&sys)?;
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

/// The integrator's error tolerances (`simulate`, `sweep`).
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
}

/// The frequencies of `frf` and `sweep`, and what they report.
#[derive(Args)]
pub struct FrequencyGrid {
    /// The forcing's frequency parameter (rad/s).
    #[arg(long, value_name = "NAME")]
    pub param: String,
    /// First frequency, rad/s.
    #[arg(long, value_name = "A", allow_hyphen_values = true)]
    pub from: f64,
    /// Last frequency, rad/s (included when the step divides the range).
    #[arg(long, value_name = "B", allow_hyphen_values = true)]
    pub to: f64,
    /// Frequency step, rad/s.
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    pub step: f64,
    /// Response to report (repeatable) [default: every coordinate]: a coordinate, a force
    /// element's `<name>.tension|elongation|rate` (`.torque|twist|twist_rate`), a named
    /// point's `<body>.<point>.x` (`y`, `z`, with `_rel`, `_dot`, `_ddot`), or (sweep) a
    /// joint's reaction `<joint>.force_x` (`force_y`, `force_z`).
    #[arg(long, value_name = "NAME")]
    pub response: Vec<String>,
}

impl FrequencyGrid {
    /// The frequencies and the reported responses (every coordinate when none is named).
    pub fn resolve(&self, model: &Model) -> Result<(Vec<f64>, Vec<String>)> {
        let values = detune::linear::grid(self.from, self.to, self.step)?;
        let responses = if self.response.is_empty() {
            model.coordinate_names()
        } else {
            self.response.clone()
        };
        Ok((values, responses))
    }
}
