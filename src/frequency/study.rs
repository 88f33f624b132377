//! A family of sweeps over the values of one parameter (`--values F0=0.1,1,2`): one
//! model and one compiled system per value, every run checked before any is simulated,
//! the sweeps run in sequence, and the linear natural frequencies of the runs for the
//! response plot.

use super::{Sweep, SweepMode, SweepOptions, prepare, sweep};
use crate::diag::{Error, Result};
use crate::linear::{at_frequency, modal_analysis};
use crate::model::Model;
use crate::request::{Argument, Invalid, parameter};
use crate::system::System;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// One run of a study: the model with the varied parameter at one of its values.
#[derive(Debug, Clone)]
pub struct StudyRun {
    /// The varied parameter and its SI value (None: the model as given).
    pub value: Option<(String, f64)>,
    pub model: Model,
    pub system: System,
}

/// The sweep of one model, or of a family over the values of a parameter.
#[derive(Debug, Clone)]
pub struct SweepStudy {
    pub options: SweepOptions,
    pub runs: Vec<StudyRun>,
}

/// One completed sweep of a study.
#[derive(Debug, Clone)]
pub struct SweepRun {
    /// The varied parameter and its SI value for this sweep (None: no family).
    pub value: Option<(String, f64)>,
    /// The SI unit of the varied parameter (`m`; empty if dimensionless or unknown).
    pub unit: String,
    pub sweep: Sweep,
    /// Whether each of the sweep's coordinates is an angle (rad).
    pub angles: Vec<bool>,
}

impl SweepRun {
    /// The varied parameter and its value, borrowed.
    pub fn tag(&self) -> Option<(&str, f64)> {
        self.value.as_ref().map(|(n, v)| (n.as_str(), *v))
    }
}

/// A linear natural frequency to mark on a response plot.
#[derive(Debug, Clone, PartialEq)]
pub struct NaturalFrequency {
    /// rad/s.
    pub omega: f64,
    /// The run it belongs to, when the runs' natural frequencies differ.
    pub run: Option<(String, f64)>,
}

/// The models of a family: `spec` is `PARAM=v1,v2,...` (the `--values` flag), each value
/// a number (SI), a quantity or an expression, as with `--set`; `swept` is the swept
/// parameter, which the family may not vary.
pub fn family(model: &Model, spec: &str, swept: &str) -> Result<Vec<(String, f64, Model)>> {
    let (name, list) = spec
        .split_once('=')
        .ok_or_else(|| Invalid::FamilySyntax { spec: spec.into() })?;
    let name = name.trim();
    if name.is_empty() {
        return Err(Invalid::FamilyUnnamed { spec: spec.into() }.into());
    }
    if name == swept {
        return Err(Invalid::FamilyVariesSwept {
            spec: spec.into(),
            name: name.to_string(),
        }
        .into());
    }
    let mut out = Vec::new();
    for v in list.split(',') {
        if v.trim().is_empty() {
            return Err(Invalid::FamilyEmptyEntry { spec: spec.into() }.into());
        }
        let m = model
            .with_overrides(&[(name.to_string(), v.trim().to_string())])
            .and_then(|m| System::check(&m).map(|_| m))
            .map_err(|e| match e {
                // a bad value quotes the override it was given as (`--set NAME=VALUE`):
                // here, the family's entry
                Error::Request { message, help } => Error::Request {
                    message: message.replace("--set ", "--values "),
                    help,
                },
                other => other.in_run(name, v.trim()),
            })?;
        let value = m.parameters.value(name).unwrap_or(f64::NAN);
        out.push((name.to_string(), value, m));
    }
    Ok(out)
}

impl SweepStudy {
    /// The sweep of `model`, or with `values` (`PARAM=v1,v2,...`, see [`family`]) one
    /// sweep per value. Every run is compiled and checked here ([`prepare`]), before any
    /// is simulated: a bad entry fails at once, named.
    pub fn new(model: &Model, values: Option<&str>, options: SweepOptions) -> Result<SweepStudy> {
        let models: Vec<(Option<(String, f64)>, Model)> = match values {
            None => vec![(None, model.clone())],
            Some(spec) => family(model, spec, &options.param)?
                .into_iter()
                .map(|(name, value, m)| (Some((name, value)), m))
                .collect(),
        };
        let settle = options.steady.settle_tol;
        if !(settle > 0.0 && settle < 1.0) {
            return Err(Invalid::NotFraction {
                argument: Argument::SettleTol,
                value: settle,
            }
            .into());
        }
        // One compiled system per run, its trim solved for the run's parameters.
        let systems: Vec<System> = models
            .iter()
            .map(|(_, m)| System::new(m).and_then(|s| crate::statics::trim::trim(&s).map(|t| t.0)))
            .collect::<Result<_>>()?;
        let runs: Vec<StudyRun> = models
            .into_iter()
            .zip(systems)
            .map(|((value, model), system)| StudyRun {
                value,
                model,
                system,
            })
            .collect();
        for run in &runs {
            prepare(&run.system, &options).map_err(|e| match &run.value {
                Some((name, v)) => e.in_run(name, v),
                None => e,
            })?;
        }
        Ok(SweepStudy { options, runs })
    }

    /// The frequencies the runs compute on the coarse grid (refinement adds more).
    pub fn frequencies(&self) -> usize {
        let directions = if self.options.mode == SweepMode::Both {
            2
        } else {
            1
        };
        self.options.values.len() * directions * self.runs.len()
    }

    /// Run the sweeps in sequence. `progress` is called with the number of frequencies
    /// done in all runs so far; `cancel` stops the run in progress, which is returned
    /// incomplete and is the last.
    pub fn run(
        &self,
        progress: &(dyn Fn(usize) + Sync),
        cancel: &AtomicBool,
    ) -> Result<Vec<SweepRun>> {
        let done = AtomicUsize::new(0);
        let mut out = Vec::new();
        for run in &self.runs {
            let base = done.load(Ordering::SeqCst);
            let s = sweep(
                &run.system,
                &self.options,
                &|k| {
                    done.store(base + k, Ordering::SeqCst);
                    progress(base + k);
                },
                cancel,
            )?;
            let complete = s.complete;
            let unit = run
                .value
                .as_ref()
                .and_then(|(n, _)| run.model.parameters.index(n))
                .and_then(|i| run.model.parameters.dims[i])
                .filter(|d| !d.is_dimensionless())
                .map(|d| d.to_string())
                .unwrap_or_default();
            out.push(SweepRun {
                value: run.value.clone(),
                unit,
                sweep: s,
                angles: run.system.angles(),
            });
            if !complete {
                break;
            }
        }
        Ok(out)
    }

    /// The linear natural frequencies (rad/s) of the first `count` runs, about their
    /// equilibria at the first frequency (a static load in the family moves them; an
    /// amplitude does not): one set without a run when every run has the same, else each
    /// distinct one with the first run that has it. A run whose modes cannot be found
    /// adds none.
    pub fn natural_frequencies(&self, count: usize) -> Result<Vec<NaturalFrequency>> {
        let mut per_run: Vec<(Vec<f64>, &StudyRun)> = Vec::new();
        for run in self.runs.iter().take(count) {
            let index = parameter(
                run.system.param_names(),
                &self.options.param,
                Argument::FrequencyParameter,
            )?;
            let at = at_frequency(&run.system, index, self.options.values[0])?;
            let Ok(ma) = modal_analysis(&at, None) else {
                continue;
            };
            let w: Vec<f64> = ma
                .undamped_omega2
                .iter()
                .filter(|w| **w > 0.0)
                .map(|w| w.sqrt())
                .collect();
            per_run.push((w, run));
        }
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-6 * x.abs().max(y.abs());
        let same = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| close(*x, *y))
        };
        let mut out: Vec<NaturalFrequency> = Vec::new();
        if per_run.iter().all(|(w, _)| same(w, &per_run[0].0)) {
            if let Some((w, _)) = per_run.first() {
                out = w
                    .iter()
                    .map(|x| NaturalFrequency {
                        omega: *x,
                        run: None,
                    })
                    .collect();
            }
        } else {
            for (w, run) in &per_run {
                for x in w {
                    if !out.iter().any(|y| close(*x, y.omega)) {
                        out.push(NaturalFrequency {
                            omega: *x,
                            run: run.value.clone(),
                        });
                    }
                }
            }
        }
        Ok(out)
    }
}
