//! A family of sweeps over the values of one parameter (`--values F0=0.1,1,2`), or over
//! the grid of several (`--values` repeated: every combination, the first parameter
//! varying slowest): one model and one compiled system per case, every run checked
//! before any is simulated, the sweeps run in sequence (each case looked up in and
//! recorded to a checkpoint, see [`super::checkpoint`]), and the linear natural
//! frequencies of the runs for the response plot.

use super::checkpoint::CaseLog;
use super::{Progress, Sweep, SweepMode, SweepOptions, prepare, sweep_logged_partial};
use crate::diag::{Error, Result};
use crate::linear::{at_frequency, modal_analysis};
use crate::model::Model;
use crate::request::{Argument, Invalid, parameter};
use crate::system::System;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// One run of a study: the model with the varied parameters at one of their values.
#[derive(Debug, Clone)]
pub struct StudyRun {
    /// The varied parameters and their SI values, in the order of the `--values` flags
    /// (empty: the model as given).
    pub values: Vec<(String, f64)>,
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
    /// The varied parameters and their SI values for this sweep, in the order of the
    /// `--values` flags (empty: no family).
    pub values: Vec<(String, f64)>,
    /// The SI unit of the first varied parameter (`m`; empty if dimensionless or
    /// unknown).
    pub unit: String,
    /// The SI unit of each varied parameter.
    pub units: Vec<String>,
    pub sweep: Sweep,
    /// Whether each of the sweep's coordinates is an angle (rad).
    pub angles: Vec<bool>,
}

impl SweepRun {
    /// The first varied parameter and its value, borrowed.
    pub fn tag(&self) -> Option<(&str, f64)> {
        self.values.first().map(|(n, v)| (n.as_str(), *v))
    }

    /// Every varied parameter and its value, borrowed.
    pub fn tags(&self) -> Vec<(&str, f64)> {
        self.values.iter().map(|(n, v)| (n.as_str(), *v)).collect()
    }

    /// `F0 = 2 N, c = 0.5 N s/m` (None: no family).
    pub fn label(&self) -> Option<String> {
        (!self.values.is_empty()).then(|| {
            self.values
                .iter()
                .zip(&self.units)
                .map(|((n, v), u)| format!("{n} = {v} {u}").trim_end().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        })
    }
}

/// `F0 = 2, c = 0.5`: a run's varied parameters without units (empty: none).
pub fn values_label(values: &[(String, f64)]) -> String {
    values
        .iter()
        .map(|(n, v)| format!("{n} = {v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A linear natural frequency to mark on a response plot.
#[derive(Debug, Clone, PartialEq)]
pub struct NaturalFrequency {
    /// rad/s.
    pub omega: f64,
    /// The run it belongs to (`F0 = 2`, see [`values_label`]), when the runs' natural
    /// frequencies differ.
    pub run: Option<String>,
}

/// Where the entry `v` (a piece of `spec`'s list, trimmed) starts in `spec`, in bytes.
fn entry_at(spec: &str, v: &str) -> usize {
    let start = v.as_ptr() as usize - spec.as_ptr() as usize;
    start + (v.len() - v.trim_start().len())
}

/// A `--set NAME=VALUE` message about one entry of a family, quoting the `--values` flag
/// as typed: the `--set` line becomes `--values SPEC`, and a caret line under it moves to
/// the entry (which starts at byte `at` of `spec`).
fn requoted(message: &str, name: &str, value: &str, spec: &str, at: usize) -> String {
    let set = format!("--set {name}={value}");
    let values = format!("--values {spec}");
    let mut out: Vec<String> = Vec::new();
    // columns the entry moves right by in the line just replaced
    let mut moved: Option<isize> = None;
    for line in message.lines() {
        let shift = moved.take();
        let carets = !line.trim().is_empty() && line.trim().chars().all(|c| c == '^');
        if let (Some(shift), true) = (shift, carets) {
            let indent = (line.len() - line.trim_start().len()) as isize;
            let indent = (indent + shift).max(0) as usize;
            out.push(format!("{}{}", " ".repeat(indent), line.trim_start()));
        } else if line.contains(&set) {
            // the value was at column i + len(`--set NAME=`); the entry is at
            // i + len(`--values `) + at
            let old = (set.len() - value.len()) as isize;
            moved = Some("--values ".len() as isize + at as isize - old);
            out.push(line.replacen(&set, &values, 1));
        } else {
            out.push(line.to_string());
        }
    }
    out.join("\n")
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
                    message: requoted(&message, name, v.trim(), spec, entry_at(spec, v)),
                    help,
                },
                other => other.in_run(name, v.trim()),
            })?;
        let value = m.parameters.value(name).unwrap_or(f64::NAN);
        out.push((name.to_string(), value, m));
    }
    Ok(out)
}

/// A case of a study: the varied parameters with their SI values, and the model.
pub type Case = (Vec<(String, f64)>, Model);

/// The models of a grid of families: every combination of the entries of `specs` (each
/// `PARAM=v1,v2,...`, see [`family`]), the first spec varying slowest. Each spec is
/// checked on its own first (a bad entry is named as with one `--values`); a parameter
/// may be varied by one spec only.
pub fn grid(model: &Model, specs: &[String], swept: &str) -> Result<Vec<Case>> {
    if let [one] = specs {
        return Ok(family(model, one, swept)?
            .into_iter()
            .map(|(name, value, m)| (vec![(name, value)], m))
            .collect());
    }
    let mut axes: Vec<(String, Vec<String>)> = Vec::new();
    for spec in specs {
        family(model, spec, swept)?;
        let (name, list) = spec.split_once('=').expect("checked by family");
        let name = name.trim().to_string();
        if axes.iter().any(|(n, _)| *n == name) {
            return Err(Error::request(
                format!("--values {spec}: {name} is varied by another --values too"),
                "give each parameter's values in one --values NAME=v1,v2,...",
            ));
        }
        axes.push((
            name,
            list.split(',').map(|v| v.trim().to_string()).collect(),
        ));
    }
    let mut combos: Vec<Vec<(String, String)>> = vec![Vec::new()];
    for (name, list) in &axes {
        combos = combos
            .into_iter()
            .flat_map(|c| {
                list.iter().map(move |v| {
                    let mut c = c.clone();
                    c.push((name.clone(), v.clone()));
                    c
                })
            })
            .collect();
    }
    combos
        .into_iter()
        .map(|c| {
            let label = c
                .iter()
                .map(|(n, v)| format!("{n}={v}"))
                .collect::<Vec<_>>()
                .join(", ");
            let m = model
                .with_overrides(&c)
                .and_then(|m| System::check(&m).map(|_| m))
                .map_err(|e| e.in_run("--values", &label))?;
            let values = c
                .iter()
                .map(|(n, _)| (n.clone(), m.parameters.value(n).unwrap_or(f64::NAN)))
                .collect();
            Ok((values, m))
        })
        .collect()
}

impl SweepStudy {
    /// The sweep of `model`, or with `values` (each `PARAM=v1,v2,...`, see [`family`] and
    /// [`grid`]) one sweep per value, or per combination of values. Every run is compiled
    /// and checked here ([`prepare`]), before any is simulated: a bad entry fails at
    /// once, named.
    pub fn new(model: &Model, values: &[String], options: SweepOptions) -> Result<SweepStudy> {
        let models: Vec<(Vec<(String, f64)>, Model)> = if values.is_empty() {
            vec![(Vec::new(), model.clone())]
        } else {
            grid(model, values, &options.param)?
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
            .map(|((values, model), system)| StudyRun {
                values,
                model,
                system,
            })
            .collect();
        for run in &runs {
            prepare(&run.system, &options).map_err(|e| match run.values.as_slice() {
                [] => e,
                [(name, v)] => e.in_run(name, v),
                more => e.in_run("--values", values_label(more)),
            })?;
        }
        Ok(SweepStudy { options, runs })
    }

    /// The frequencies the runs compute on the coarse grid (refinement adds more).
    pub fn frequencies(&self) -> usize {
        self.frequencies_of(&super::checkpoint::NoLog)
    }

    /// Whether the sweeps are sequential (`up`, `down`, `both`).
    pub fn sequential(&self) -> bool {
        self.options.mode != SweepMode::Independent
    }

    /// The coarse-grid frequencies this process computes with `log` (a shard's share).
    pub fn frequencies_of(&self, log: &dyn CaseLog) -> usize {
        let directions = if self.options.mode == SweepMode::Both {
            2
        } else {
            1
        };
        (0..self.runs.len())
            .filter(|&r| log.takes_run(r))
            .map(|r| {
                (0..self.options.values.len())
                    .filter(|&i| self.sequential() || log.selected(r, i))
                    .count()
                    * directions
            })
            .sum()
    }

    /// The independent cases a study can be sharded into: runs × coarse frequencies, or
    /// runs for sequential sweeps.
    pub fn shardable_cases(&self) -> usize {
        if self.sequential() {
            self.runs.len()
        } else {
            self.runs.len() * self.options.values.len()
        }
    }

    /// SHA-256 (hex) of everything that changes a case's result: the detune version, the
    /// model file's hash, every parameter value of every run (`--set`, `--values`), and
    /// the options (their `Debug` text, so an option added later is covered without
    /// listing it here) except the refinement resolution, which changes which cases are
    /// computed but not any case's result (a coarse sweep's checkpoint can be refined).
    pub fn fingerprint(&self) -> String {
        use sha2::{Digest, Sha256};
        let mut text = format!("detune {}\n", env!("CARGO_PKG_VERSION"));
        for run in &self.runs {
            text.push_str(&format!(
                "model {} parameters {:?} values {:?}\n",
                run.model.hash, run.model.parameters.values, run.values
            ));
        }
        let options = SweepOptions {
            refine: None,
            ..self.options.clone()
        };
        text.push_str(&format!("options {options:?}\n"));
        Sha256::digest(text.as_bytes())
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect()
    }

    /// Run the sweeps in sequence. `progress` is called with the coarse-grid frequencies
    /// done in all runs so far and the refinement of the run in progress; `cancel` stops
    /// the run in progress, which is returned incomplete and is the last. Each case is
    /// looked up in and recorded to `log`; the runs it does not take are left out (a
    /// shard of a sequential study). A failing frequency is an error
    /// ([`super::sweep_logged`]); [`SweepStudy::run_partial`] keeps what was finished.
    pub fn run(
        &self,
        progress: &(dyn Fn(Progress) + Sync),
        cancel: &AtomicBool,
        log: &dyn CaseLog,
        stiff: super::StiffHook,
    ) -> Result<Vec<SweepRun>> {
        let runs = self.run_partial(progress, cancel, log, stiff)?;
        match runs.iter().find_map(|r| r.sweep.failure.clone()) {
            Some(f) => Err(f.error),
            None => Ok(runs),
        }
    }

    /// [`SweepStudy::run`], keeping what a failing sweep finished
    /// ([`super::sweep_logged_partial`]): the failing run is the last, with
    /// `sweep.failure` set.
    pub fn run_partial(
        &self,
        progress: &(dyn Fn(Progress) + Sync),
        cancel: &AtomicBool,
        log: &dyn CaseLog,
        stiff: super::StiffHook,
    ) -> Result<Vec<SweepRun>> {
        let done = AtomicUsize::new(0);
        let mut out = Vec::new();
        for (index, run) in self.runs.iter().enumerate() {
            if !log.takes_run(index) {
                continue;
            }
            let base = done.load(Ordering::SeqCst);
            let s = sweep_logged_partial(
                &run.system,
                &self.options,
                &|p| {
                    done.store(base + p.grid, Ordering::SeqCst);
                    progress(Progress {
                        grid: base + p.grid,
                        ..p
                    });
                },
                cancel,
                log,
                index,
                stiff,
            )?;
            let complete = s.complete;
            let units: Vec<String> = run
                .values
                .iter()
                .map(|(n, _)| {
                    run.model
                        .parameters
                        .index(n)
                        .and_then(|i| run.model.parameters.dims[i])
                        .filter(|d| !d.is_dimensionless())
                        .map(|d| d.to_string())
                        .unwrap_or_default()
                })
                .collect();
            out.push(SweepRun {
                values: run.values.clone(),
                unit: units.first().cloned().unwrap_or_default(),
                units,
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
                            run: (!run.values.is_empty()).then(|| values_label(&run.values)),
                        });
                    }
                }
            }
        }
        Ok(out)
    }
}
