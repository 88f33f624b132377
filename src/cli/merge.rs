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
    let same = |a: &str, b: &str| {
        a == b
            || matches!(
                (std::fs::canonicalize(a), std::fs::canonicalize(b)),
                (Ok(x), Ok(y)) if x == y
            )
    };
    for out in [&m.output, &m.plot, &m.checkpoint].into_iter().flatten() {
        if let Some(s) = m.shards.iter().find(|s| same(out, s)) {
            return Err(Error::request(
                format!("{out} is the shard checkpoint {s}: merging would overwrite it"),
                "give the merged outputs their own file names",
            ));
        }
    }
    let merged = Checkpoint::merge(&m.shards)?;
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
