//! `detune merge`: the checkpoints of a sharded sweep (`sweep --shard K/N --checkpoint
//! FILE`) joined into the outputs one unsharded run writes, byte for byte: the study is
//! rebuilt from the command stored in the checkpoints (the same model, checked by its
//! hash, the same options, checked by the fingerprint) and run with every case taken
//! from the shards (nothing is simulated: a case missing means a shard is incomplete,
//! refused); whole-curve results (peaks, jumps, hysteresis, wells) are computed then.

use super::sweep::{Source, SweepArgs, execute};
use clap::{Args, Parser};
use detune::diag::{Error, Result};
use detune::frequency::checkpoint::{CaseLog, Checkpoint, Shard};

#[derive(Args)]
pub struct MergeArgs {
    /// The checkpoints of all N shards of one study (`detune sweep ... --shard K/N
    /// --checkpoint FILE`), in any order.
    #[arg(required = true, value_name = "CHECKPOINT")]
    pub shards: Vec<String>,
    /// CSV of the whole study: exactly what one unsharded run writes.
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    pub output: Option<String>,
    /// Print the JSON result (as `sweep --json`).
    #[arg(long)]
    pub json: bool,
    /// SVG: the response plot (as `sweep --plot`).
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<String>,
    /// A labelled frequency drawn on the plot, LABEL=VALUE (as `sweep --mark`).
    #[arg(long, value_name = "LABEL=VALUE")]
    pub mark: Vec<String>,
    /// Also write the shards' cases as one unsharded checkpoint: `sweep` with the same
    /// options, --refine R and this --checkpoint refines the merged curve's peaks without
    /// recomputing it.
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<String>,
}

/// The stored sweep command, parsed as `detune sweep` parses it.
#[derive(Parser)]
#[command(no_binary_name = true, allow_negative_numbers = true)]
struct Stored {
    #[command(flatten)]
    sweep: SweepArgs,
}

pub fn run(m: MergeArgs) -> Result<()> {
    // an output over a shard's checkpoint would destroy it
    let same = detune::output::commit::same_file;
    for out in [&m.output, &m.plot, &m.checkpoint].into_iter().flatten() {
        if let Some(s) = m.shards.iter().find(|s| same(out, s)) {
            return Err(Error::request(
                format!("{out} is the shard checkpoint {s}: merging would overwrite it"),
                "give the merged outputs their own file names",
            ));
        }
    }
    let merged = Checkpoint::merge(&m.shards)?;
    if let Some(study) = &merged.header.study {
        return Err(Error::request(
            format!(
                "{} is the checkpoint of a `detune {study}` study, not of a sharded sweep",
                m.shards[0]
            ),
            format!("resume it with its own command: detune {study} ... --checkpoint FILE"),
        ));
    }
    let command = merged.header.command.clone();
    let mut a = Stored::try_parse_from(&command)
        .map_err(|e| {
            Error::request(
                format!(
                    "the checkpoints' sweep command cannot be read by this detune: detune sweep {}\n{}",
                    command.join(" "),
                    e.render()
                ),
                "merge with the detune version that ran the shards",
            )
        })?
        .sweep;
    // the model path is as the shards were given it, relative to where they ran
    a.model.model = locate_model(&a.model.model, a.checkpoint.as_deref(), &m.shards[0])?;
    a.output = m.output;
    a.json = m.json;
    a.plot = m.plot;
    a.mark = m.mark;
    a.shard = None;
    a.checkpoint = None;
    if let Some(path) = &m.checkpoint {
        let mut header = merged.header.clone();
        header.shard = Shard::ALL;
        let out = Checkpoint::open(path, header, &[])?;
        for (key, s, well) in merged.cases() {
            out.record(&key, &s, well)?;
        }
        eprintln!("wrote {path} ({} steady states)", merged.reused);
    }
    execute(a, Source::Merge(Box::new(merged)))
}

/// The model file of the shards' stored command, `stored` (a path as the shards were
/// given it: relative to the directory they ran in), found from here. Tried in order:
/// the directory the shards ran in, told by where the checkpoint `actual` (the first one
/// given, whose command is stored) is now and the path its command gave it
/// (`stored_checkpoint`: `out/p1.ckpt` now at `../run/out/p1.ckpt` ran in `../run`);
/// the checkpoint's own directory (shards and model moved together); here. The model's
/// hash (checked against the shards') makes sure it is the same file.
fn locate_model(stored: &str, stored_checkpoint: Option<&str>, actual: &str) -> Result<String> {
    use std::path::{Component, Path, PathBuf};
    if Path::new(stored).is_absolute() {
        return Ok(stored.to_string());
    }
    let here = |p: &Path| -> PathBuf {
        if p.as_os_str().is_empty() {
            PathBuf::from(".")
        } else {
            p.to_path_buf()
        }
    };
    let beside = here(Path::new(actual).parent().unwrap_or(Path::new("")));
    let mut dirs: Vec<PathBuf> = Vec::new();
    if let Some(c) = stored_checkpoint.map(Path::new).filter(|c| c.is_relative()) {
        let up = c.parent().unwrap_or(Path::new(""));
        let plain = up.components().all(|k| matches!(k, Component::Normal(_)));
        let depth = up.components().count();
        if plain && (depth == 0 || beside.ends_with(up)) {
            let mut d = beside.clone();
            for _ in 0..depth {
                d = here(d.parent().unwrap_or(Path::new("")));
            }
            dirs.push(d);
        }
    }
    dirs.push(beside);
    dirs.push(PathBuf::from("."));
    let tried: Vec<PathBuf> = dirs.iter().map(|d| d.join(stored)).collect();
    if let Some(found) = tried.iter().find(|p| p.is_file()) {
        let found = found.strip_prefix(".").unwrap_or(found);
        return Ok(found.to_string_lossy().into_owned());
    }
    let mut listed: Vec<String> = tried
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    listed.dedup();
    Err(Error::request(
        format!(
            "the shards' model {stored} (relative to the directory they ran in) is not found: tried {}",
            listed.join(", ")
        ),
        "keep the model file where the shards ran (beside their checkpoints, or as their command named it from that directory), or run detune merge in that directory",
    ))
}
