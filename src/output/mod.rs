//! Results to files: CSV, JSON with provenance, SVG plots.
//!
//! Every file is written to a temporary file in the target directory and renamed into
//! place when complete, so an error or an interrupt never leaves a half-written output;
//! a run's outputs are planned before any work and committed together ([`commit`]).

pub mod command;
pub mod commit;
pub mod figures;
pub mod json;
pub mod margins;
pub mod nfr;
pub mod plot;
pub mod results;
pub mod sensitivity;
pub mod style;
pub mod units;

use crate::diag::Result;
use crate::model::Model;
pub use commit::OutputSet;
use std::io::Write;

/// Write `path` atomically: `fill` writes the content into a temporary file, which is
/// put in place only if `fill` succeeds. Under a planned [`OutputSet`] that names `path`,
/// it is put in place by the set's commit, together with the set's other outputs; else at
/// once. See [`commit`].
pub fn write_atomic(
    path: &str,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    commit::render(path, fill)
}

/// Plan a run's outputs before any work ([`OutputSet::plan`] with the model file as the
/// input): each can be written where asked (its directory exists, it is not a directory,
/// not the model file or a link to it, no two outputs are one file), so a run does not
/// fail after minutes of work. The outputs are written by the returned set's
/// [`OutputSet::commit`], all together, or none.
pub fn check_outputs(model_path: &str, outputs: &[Option<&str>]) -> Result<OutputSet> {
    OutputSet::plan(&[("model file", model_path)], outputs)
}

/// Where a result came from: detune version, model file and hash, overrides.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Provenance {
    pub detune_version: String,
    pub model_file: String,
    pub model_sha256: String,
    /// `--set` overrides as given, `NAME=VALUE`.
    pub overrides: Vec<String>,
}

impl Provenance {
    pub fn of(model: &Model) -> Self {
        Provenance {
            detune_version: env!("CARGO_PKG_VERSION").to_string(),
            model_file: model.source.path.clone(),
            model_sha256: model.hash.clone(),
            overrides: model
                .overrides
                .iter()
                .map(|(n, v)| format!("{n}={v}"))
                .collect(),
        }
    }
}

/// Format a float for CSV: the shortest text that reads back to the same value, in
/// plain notation for ordinary magnitudes and scientific notation otherwise.
pub fn num(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || (1e-4..1e15).contains(&a) || !x.is_finite() {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// The header of a trajectory CSV: `t,<coordinates>...[,<velocity columns>...]`, the
/// velocity columns as [`crate::System::velocity_columns`] names them (`<coordinate>_dot`
/// for a coordinate's rate), then one column per requested response (named as requested).
pub fn trajectory_header(
    w: &mut dyn Write,
    coordinates: &[String],
    velocities: Option<&[String]>,
    responses: &[String],
) -> std::io::Result<()> {
    let mut header = vec!["t".to_string()];
    header.extend(coordinates.iter().cloned());
    if let Some(v) = velocities {
        header.extend(v.iter().cloned());
    }
    header.extend(responses.iter().cloned());
    writeln!(w, "{}", header.join(","))
}

/// One row of a trajectory CSV (see [`trajectory_header`]): streamed as the samples come;
/// `responses` are the requested responses' values.
pub fn trajectory_row(
    w: &mut dyn Write,
    t: f64,
    q: &[f64],
    v: &[f64],
    velocities: bool,
    responses: &[f64],
) -> std::io::Result<()> {
    write!(w, "{}", num(t))?;
    for x in q {
        write!(w, ",{}", num(*x))?;
    }
    if velocities {
        for x in v {
            write!(w, ",{}", num(*x))?;
        }
    }
    for x in responses {
        write!(w, ",{}", num(*x))?;
    }
    writeln!(w)
}

/// Write a JSON document atomically, pretty-printed.
pub fn write_json(path: &str, value: &impl serde::Serialize) -> Result<()> {
    write_atomic(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value)?;
        writeln!(w)
    })
}
