//! Results to files: CSV, JSON with provenance, SVG plots.
//!
//! Every file is written to a temporary file in the target directory and renamed into
//! place when complete, so an error or an interrupt never leaves a half-written output.

pub mod command;
pub mod figures;
pub mod json;
pub mod margins;
pub mod plot;
pub mod results;
pub mod sensitivity;

use crate::diag::{Error, Result};
use crate::model::Model;
use std::io::Write;
use std::path::Path;

/// Write `path` atomically: `fill` writes the content into a temporary file next to it,
/// which is renamed to `path` only if `fill` succeeds.
pub fn write_atomic(
    path: &str,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    let p = Path::new(path);
    let dir = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut tmp = tempfile::Builder::new()
        .prefix(".detune-")
        .tempfile_in(dir)
        .map_err(|e| {
            Error::io(
                path,
                format!("cannot create a file in {}: {e}", dir.display()),
            )
        })?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        fill(&mut w).map_err(|e| Error::io(path, e))?;
        w.flush().map_err(|e| Error::io(path, e))?;
    }
    // tempfile creates 0600; an output file gets the ordinary 0644 (less the umask).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let _ = std::fs::set_permissions(tmp.path(), std::fs::Permissions::from_mode(0o644));
    }
    tmp.persist(p).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

/// Check, before any work, that every output can be written where asked: its directory
/// exists, it is not a directory, no two outputs share a path, and none overwrites the
/// model file. A run then does not fail after minutes of work, or after writing one of
/// its files but not another.
pub fn check_outputs(model_path: &str, outputs: &[Option<&str>]) -> Result<()> {
    let key = |p: &str| -> std::path::PathBuf {
        let p = Path::new(p);
        let dir = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
        dir.join(p.file_name().unwrap_or_default())
    };
    let model = key(model_path);
    let mut seen: Vec<(std::path::PathBuf, &str)> = Vec::new();
    for path in outputs.iter().flatten() {
        let p = Path::new(path);
        let dir = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !dir.is_dir() {
            return Err(Error::request(
                format!("{path}: the directory {} does not exist", dir.display()),
                "create it first, or write the output elsewhere",
            ));
        }
        if p.is_dir() || p.file_name().is_none() {
            return Err(Error::request(
                format!("{path}: is a directory, not a file name"),
                "give a file name, e.g. out.csv",
            ));
        }
        let k = key(path);
        if k == model {
            return Err(Error::request(
                format!("{path}: this would overwrite the model file"),
                "give the output another name",
            ));
        }
        if let Some((_, other)) = seen.iter().find(|(s, _)| *s == k) {
            return Err(Error::request(
                format!("{path}: the same file as the output {other}"),
                "give each output its own name",
            ));
        }
        seen.push((k, path));
    }
    Ok(())
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
