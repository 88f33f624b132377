//! Checkpoints and shards of a sweep study: every steady state (a *case*: one frequency
//! of one run, computed on the coarse grid, as the jump check of a sequential sweep or by
//! peak refinement) appended to a file as soon as it is computed, so that an interrupted
//! study resumes where it stopped, and a study split over several processes (`--shard
//! K/N`) is joined into exactly the result of one run (`detune merge`).
//!
//! The file is text, one JSON object a line: first a [`Header`] that identifies the
//! study (detune version, model file and hash, a fingerprint of everything that changes
//! a case's result, the command's arguments, the shard), then one line per case. Every
//! number is written as Rust's shortest round-trip decimal text (`{:e}`) in a JSON
//! string, read back with Rust's correctly rounded parser: the same bits, so a resumed or
//! merged study writes byte-identical outputs (serde_json's own float parsing is not
//! correctly rounded without its `float_roundtrip` feature). A case stores what the
//! outputs and the rest of the study read: the measures, the settling counts, the well it
//! was classified in, and its end state (q, v), which a sequential sweep continues from.
//!
//! A line is written with one `write` and `fsync`ed; a crash can only leave the last line
//! torn (no newline), which is ignored and cut off before new lines are appended.
//!
//! Written by hand: a line-oriented append log is a few lines of std; a database crate
//! would add a file format users cannot read.

use super::measure::Measures;
use super::{Direction, SteadyState};
use crate::diag::{Error, Result};
use crate::dynamics::State;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::io::Write;
use std::sync::Mutex;

/// What a case's steady state is of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CaseKind {
    /// A frequency of the coarse grid.
    Coarse,
    /// The step back over a steep edge of a sequential sweep (is it a jump?).
    Back,
    /// A frequency added by peak refinement.
    Refine,
}

/// Identifies a case within a study: the run (`--values` case), what it is, the
/// direction and the frequency (its bits).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CaseKey {
    pub run: usize,
    pub kind: CaseKind,
    pub direction: Direction,
    pub omega: u64,
}

/// Where a sweep looks up and records its cases.
pub trait CaseLog: Sync {
    /// A case known before: `Some` to reuse, `None` to compute it; an error when it may
    /// not be computed here (a merge lacks it).
    fn lookup(&self, key: &CaseKey) -> Result<Option<(SteadyState, isize)>>;
    /// A case just computed, with the well it was classified in.
    fn record(&self, key: &CaseKey, s: &SteadyState, well: isize) -> Result<()>;
    /// Whether this process computes the coarse-grid frequency `index` of run `run` of
    /// an independent sweep (a shard's share).
    fn selected(&self, _run: usize, _index: usize) -> bool {
        true
    }
    /// Whether this process sweeps run `run` at all (a shard of a sequential study).
    fn takes_run(&self, _run: usize) -> bool {
        true
    }
}

/// No checkpoint: every case computed, none recorded.
pub struct NoLog;

impl CaseLog for NoLog {
    fn lookup(&self, _: &CaseKey) -> Result<Option<(SteadyState, isize)>> {
        Ok(None)
    }
    fn record(&self, _: &CaseKey, _: &SteadyState, _: isize) -> Result<()> {
        Ok(())
    }
}

/// `--shard K/N`: shard K of N (1 ≤ K ≤ N). An independent study is split by case (a
/// coarse-grid frequency of a run), round robin over the runs' frequencies in order; a
/// sequential one (`up`, `down`, `both`: each frequency starts from the previous one) by
/// run only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub k: usize,
    pub n: usize,
}

impl Shard {
    /// The whole study.
    pub const ALL: Shard = Shard { k: 1, n: 1 };

    /// `K/N`.
    pub fn parse(text: &str) -> Result<Shard> {
        let bad = || {
            Error::request(
                format!("--shard {text}: expected K/N with 1 ≤ K ≤ N, e.g. --shard 2/8"),
                "K is this process's shard, N the number of shards (in a Slurm array: --shard $SLURM_ARRAY_TASK_ID/N with --array=1-N)",
            )
        };
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let k: usize = k.trim().parse().map_err(|_| bad())?;
        let n: usize = n.trim().parse().map_err(|_| bad())?;
        if k == 0 || n == 0 || k > n {
            return Err(bad());
        }
        Ok(Shard { k, n })
    }

    /// The shard that computes coarse frequency `index` of run `run` (a study of `grid`
    /// frequencies per run; sequential: by run).
    pub fn owner(n: usize, sequential: bool, grid: usize, run: usize, index: usize) -> usize {
        if sequential {
            run % n + 1
        } else {
            (run * grid + index) % n + 1
        }
    }
}

/// The first line of a checkpoint: what study it is of.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// `detune-sweep-checkpoint`.
    pub format: String,
    pub format_version: u32,
    pub detune_version: String,
    pub model_file: String,
    pub model_sha256: String,
    /// `--set` overrides as given.
    pub overrides: Vec<String>,
    /// SHA-256 of everything that changes a case's result (see
    /// [`super::study::SweepStudy::fingerprint`]).
    pub fingerprint: String,
    /// The sweep's arguments (after `sweep`), as given: what `detune merge` rebuilds the
    /// study from.
    pub command: Vec<String>,
    pub shard: Shard,
    /// Independent: shards split runs × frequencies; sequential: runs.
    pub sequential: bool,
    /// Coarse-grid frequencies per run, and runs.
    pub grid: usize,
    pub runs: usize,
    /// The command whose study it is when not `sweep`: `sensitivity` (its sweeps' cases,
    /// one run per case of the study). Absent for a sweep.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub study: Option<String>,
}

pub const FORMAT: &str = "detune-sweep-checkpoint";
pub const FORMAT_VERSION: u32 = 1;

/// One case as a line of the file.
#[derive(Serialize, Deserialize)]
struct Line {
    run: usize,
    kind: CaseKind,
    direction: Direction,
    omega: String,
    settled: bool,
    periods: usize,
    period_multiple: usize,
    well: isize,
    /// Per response: amplitude, max, min, mean, h1, phase_deg, h2, thd.
    measures: Vec<[String; 8]>,
    q: Vec<String>,
    v: Vec<String>,
}

fn text(x: f64) -> String {
    format!("{x:e}")
}

fn number(s: &str) -> std::result::Result<f64, String> {
    s.parse::<f64>().map_err(|_| format!("not a number: {s:?}"))
}

fn numbers(v: &[String]) -> std::result::Result<Vec<f64>, String> {
    v.iter().map(|s| number(s)).collect()
}

impl Line {
    fn of(key: &CaseKey, s: &SteadyState, well: isize) -> Line {
        Line {
            run: key.run,
            kind: key.kind,
            direction: key.direction,
            omega: text(f64::from_bits(key.omega)),
            settled: s.settled,
            periods: s.periods,
            period_multiple: s.period_multiple,
            well,
            measures: s
                .measures
                .iter()
                .map(|m| {
                    [
                        m.amplitude,
                        m.max,
                        m.min,
                        m.mean,
                        m.h1,
                        m.phase_deg,
                        m.h2,
                        m.thd,
                    ]
                    .map(text)
                })
                .collect(),
            q: s.end.q.iter().copied().map(text).collect(),
            v: s.end.v.iter().copied().map(text).collect(),
        }
    }

    fn case(&self) -> std::result::Result<(CaseKey, SteadyState, isize), String> {
        let omega = number(&self.omega)?;
        let measures = self
            .measures
            .iter()
            .map(|m| {
                let x = numbers(m)?;
                Ok(Measures {
                    amplitude: x[0],
                    max: x[1],
                    min: x[2],
                    mean: x[3],
                    h1: x[4],
                    phase_deg: x[5],
                    h2: x[6],
                    thd: x[7],
                })
            })
            .collect::<std::result::Result<Vec<_>, String>>()?;
        let key = CaseKey {
            run: self.run,
            kind: self.kind,
            direction: self.direction,
            omega: omega.to_bits(),
        };
        let s = SteadyState {
            omega,
            settled: self.settled,
            periods: self.periods,
            period_multiple: self.period_multiple,
            measures,
            end: State {
                t: 0.0,
                q: numbers(&self.q)?,
                v: numbers(&self.v)?,
            },
            // the well is stored: the orbit is only read to classify it
            orbit: Vec::new(),
            rhs_evaluations: 0,
        };
        Ok((key, s, self.well))
    }
}

type Case = (CaseKey, SteadyState, isize);

/// This build of detune: a hash of its sources (`src/`, `Cargo.toml`, `Cargo.lock`, made
/// by `build.rs`), so that it changes whenever the code does, also in a build from a
/// source archive without git.
pub const BUILD_ID: &str = env!("DETUNE_BUILD_ID");

/// The version a checkpoint records and requires: the crate's version and [`BUILD_ID`]
/// as semver build metadata (`0.1.0+1a2b3c4d5e6f7a8b`). A checkpoint's cases are reused
/// only by the build that computed them: another build may compute them differently.
pub fn detune_version() -> String {
    format!("{}+{BUILD_ID}", env!("CARGO_PKG_VERSION"))
}

/// A checkpoint file's header and cases (a torn last line ignored), and the length of
/// its whole lines (where new lines go).
pub fn read(path: &str) -> Result<(Header, Vec<Case>, u64)> {
    let bytes = crate::model::read_bounded(
        path,
        &crate::model::Bounded {
            what: "sweep checkpoint",
            limit: crate::model::MAX_DATA_BYTES,
            // appended to in place: a pipe or a device is never a checkpoint
            pipes: false,
            give: "give the checkpoint files the runs wrote (--checkpoint FILE): regular files",
            shorter: "give the checkpoint files the runs wrote (--checkpoint FILE)",
        },
    )
    .map_err(|e| match e {
        Error::Io { message, .. } => Error::request(
            format!("cannot read the checkpoint {path}: {message}"),
            "give the checkpoint files the shards wrote (--checkpoint FILE)",
        ),
        e => e,
    })?;
    let not_ours = |why: String| {
        Error::request(
            format!("{path} is not a detune sweep checkpoint ({why})"),
            "a checkpoint is written by `detune sweep --checkpoint FILE`; give another file name (an existing file that is not a checkpoint is never overwritten)",
        )
    };
    let Some(first) = bytes.iter().position(|b| *b == b'\n') else {
        return Err(not_ours("no header line".into()));
    };
    let header: Header = std::str::from_utf8(&bytes[..first])
        .ok()
        .and_then(|t| serde_json::from_str(t).ok())
        .ok_or_else(|| not_ours("its first line is not a checkpoint header".into()))?;
    if header.format != FORMAT {
        return Err(not_ours(format!("format {:?}", header.format)));
    }
    if header.format_version != FORMAT_VERSION {
        return Err(Error::request(
            format!(
                "the checkpoint {path} has format version {}; this detune {} reads version {FORMAT_VERSION}",
                header.format_version,
                env!("CARGO_PKG_VERSION")
            ),
            "run the study afresh with another --checkpoint FILE",
        ));
    }
    // whole lines only: a crash can leave the last one torn
    let end = bytes.iter().rposition(|b| *b == b'\n').unwrap_or(first) + 1;
    let mut cases = Vec::new();
    for (i, line) in bytes[first + 1..end].split(|b| *b == b'\n').enumerate() {
        if line.is_empty() {
            continue;
        }
        let case = std::str::from_utf8(line)
            .map_err(|e| e.to_string())
            .and_then(|t| serde_json::from_str::<Line>(t).map_err(|e| e.to_string()))
            .and_then(|l| l.case());
        match case {
            Ok(c) => cases.push(c),
            Err(e) => {
                return Err(Error::request(
                    format!("the checkpoint {path} is damaged at line {}: {e}", i + 2),
                    "the lines before it are kept if you cut the file there (or run afresh with another --checkpoint FILE)",
                ));
            }
        }
    }
    Ok((header, cases, end as u64))
}

/// A study's checkpoint: the cases known (read from the file, or from the shards of a
/// merge) and, unless merging, the file new cases are appended to.
pub struct Checkpoint {
    pub header: Header,
    file: Option<Mutex<std::fs::File>>,
    path: String,
    known: Mutex<HashMap<CaseKey, (SteadyState, isize)>>,
    /// Cases read from the file(s).
    pub reused: usize,
    /// The `[--values]` case of each run, for messages.
    pub run_labels: Vec<String>,
    grid: Vec<f64>,
    merging: bool,
}

impl Checkpoint {
    /// Open `path` for the study `header` describes: resumed if the file is a checkpoint
    /// of the same study (anything else refused, with the reason: the file is never
    /// overwritten), else created with the header.
    pub fn open(path: &str, mut header: Header, grid: &[f64]) -> Result<Checkpoint> {
        header.detune_version = detune_version();
        let meta = std::fs::metadata(path).ok();
        if let Some(m) = &meta
            && !m.is_file()
        {
            // a FIFO would block the open, a device swallow the lines
            return Err(Error::request(
                format!(
                    "the checkpoint {path} is not a regular file: a checkpoint is a file read back and appended to"
                ),
                "give a --checkpoint FILE that does not exist yet (it is created) or a checkpoint written before",
            ));
        }
        let exists = meta.map(|m| m.len() > 0).unwrap_or(false);
        let (cases, file) = if exists {
            let (old, cases, end) = read(path)?;
            refuse_other(path, &old, &header)?;
            let file = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(|e| io(path, e))?;
            lock(path, &file)?;
            // cut a torn last line before appending
            file.set_len(end).map_err(|e| io(path, e))?;
            (cases, file)
        } else {
            // created without truncating: locked first, so a run that just created it
            // is not cut short
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .create(true)
                .truncate(false)
                .open(path)
                .map_err(|e| io(path, e))?;
            lock(path, &f)?;
            if f.metadata().map(|m| m.len() > 0).unwrap_or(false) {
                return Err(Error::request(
                    format!("the checkpoint {path} was just created by another detune run"),
                    "give each shard or run its own --checkpoint FILE",
                ));
            }
            let line = serde_json::to_string(&header).expect("a header serializes");
            f.write_all(format!("{line}\n").as_bytes())
                .and_then(|_| f.sync_data())
                .map_err(|e| io(path, e))?;
            (Vec::new(), f)
        };
        let mut file = file;
        use std::io::Seek;
        file.seek(std::io::SeekFrom::End(0))
            .map_err(|e| io(path, e))?;
        let reused = cases.len();
        Ok(Checkpoint {
            header,
            file: Some(Mutex::new(file)),
            path: path.to_string(),
            known: Mutex::new(cases.into_iter().map(|(k, s, w)| (k, (s, w))).collect()),
            reused,
            run_labels: Vec::new(),
            grid: grid.to_vec(),
            merging: false,
        })
    }

    /// The checkpoints of every shard of a study, joined: refused when one is missing or
    /// given twice, or when they are not of one study. Every case a merge needs must be
    /// in them (see [`CaseLog::lookup`]): nothing is computed.
    pub fn merge(paths: &[String]) -> Result<Checkpoint> {
        let mut parts = Vec::new();
        for p in paths {
            let (h, cases, _) = read(p)?;
            parts.push((p.clone(), h, cases));
        }
        let Some((p0, h0, _)) = parts.first() else {
            return Err(Error::request(
                "no checkpoint to merge",
                "detune merge SHARD1.ckpt SHARD2.ckpt ... -o all.csv",
            ));
        };
        let (p0, h0) = (p0.clone(), h0.clone());
        let this = detune_version();
        // every part, whatever its order: one of another build is that, not "another study"
        if let Some((p, h, _)) = parts.iter().find(|(_, h, _)| h.detune_version != this) {
            return Err(Error::request(
                format!(
                    "{p} was written by detune {}; this is detune {this} (another build): its cases may differ",
                    h.detune_version
                ),
                "merge with the detune that ran the shards, or run the shards again with this one",
            ));
        }
        let n = h0.shard.n;
        let mut seen: Vec<Option<String>> = vec![None; n];
        for (p, h, _) in &parts {
            // (every part is of this build: checked above)
            let differs = if h.model_sha256 != h0.model_sha256 || h.model_file != h0.model_file {
                Some(format!(
                    "{p} is of model {} (sha256 {}), {p0} of {} (sha256 {})",
                    h.model_file,
                    short(&h.model_sha256),
                    h0.model_file,
                    short(&h0.model_sha256)
                ))
            } else if h.fingerprint != h0.fingerprint {
                Some(format!(
                    "{p} and {p0} were run with other options, --set or --values:\n  {p}: detune sweep {}\n  {p0}: detune sweep {}",
                    h.command.join(" "),
                    h0.command.join(" ")
                ))
            } else if h.shard.n != n {
                Some(format!(
                    "{p} is shard {}/{}, {p0} is shard {}/{n}",
                    h.shard.k, h.shard.n, h0.shard.k
                ))
            } else {
                None
            };
            if let Some(why) = differs {
                return Err(Error::request(
                    format!("the shards are not of one study: {why}"),
                    "merge the shards of one study: the same sweep command with --shard 1/N … N/N",
                ));
            }
            if let Some(other) = &seen[h.shard.k - 1] {
                return Err(Error::request(
                    format!("shard {}/{n} is given twice: {other} and {p}", h.shard.k),
                    "give each shard's checkpoint once",
                ));
            }
            seen[h.shard.k - 1] = Some(p.clone());
        }
        let missing: Vec<String> = seen
            .iter()
            .enumerate()
            .filter(|(_, s)| s.is_none())
            .map(|(k, _)| format!("{}/{n}", k + 1))
            .collect();
        if !missing.is_empty() {
            return Err(Error::request(
                format!(
                    "shard {} of the study is missing ({} of {n} given)",
                    missing.join(", "),
                    n - missing.len()
                ),
                format!(
                    "run the missing shard(s) with the same command and --shard K/{n}, then merge all {n} checkpoints"
                ),
            ));
        }
        let mut known = HashMap::new();
        let mut reused = 0;
        for (_, _, cases) in parts {
            reused += cases.len();
            known.extend(cases.into_iter().map(|(k, s, w)| (k, (s, w))));
        }
        Ok(Checkpoint {
            header: h0,
            file: None,
            path: paths.join(", "),
            known: Mutex::new(known),
            reused,
            run_labels: Vec::new(),
            grid: Vec::new(),
            merging: true,
        })
    }

    /// The coarse grid (for messages naming the shard that computes a case).
    pub fn set_grid(&mut self, grid: &[f64]) {
        self.grid = grid.to_vec();
    }

    fn shard(&self) -> Shard {
        self.header.shard
    }
}

/// One run writes a checkpoint at a time: an exclusive advisory lock (`flock`), held
/// until the file is closed (the process ends), so two runs given one file name do not
/// interleave their lines.
fn lock(path: &str, file: &std::fs::File) -> Result<()> {
    #[cfg(unix)]
    {
        use std::os::fd::AsRawFd;
        // SAFETY: flock on the descriptor of a file this function borrows (open).
        let r = unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) };
        if r != 0 {
            return Err(Error::request(
                format!("the checkpoint {path} is in use by another detune run"),
                "give each shard or run its own --checkpoint FILE",
            ));
        }
    }
    #[cfg(not(unix))]
    let _ = (path, file);
    Ok(())
}

fn short(hash: &str) -> &str {
    &hash[..hash.len().min(12)]
}

fn io(path: &str, e: std::io::Error) -> Error {
    Error::request(
        format!("cannot write the checkpoint {path}: {e}"),
        "give a --checkpoint FILE in a writable directory",
    )
}

/// A checkpoint of another study than `want` is refused, with the reason.
fn refuse_other(path: &str, old: &Header, want: &Header) -> Result<()> {
    let afresh = "to start afresh, remove it or give another --checkpoint FILE";
    let command = |h: &Header| h.study.clone().unwrap_or_else(|| "sweep".into());
    if old.study != want.study {
        return Err(Error::request(
            format!(
                "the checkpoint {path} is of a `detune {}` study, not of this `detune {}`",
                command(old),
                command(want)
            ),
            afresh,
        ));
    }
    if old.detune_version != want.detune_version {
        return Err(Error::request(
            format!(
                "the checkpoint {path} was written by detune {}; this is detune {} (another build): its cases may differ",
                old.detune_version, want.detune_version
            ),
            afresh,
        ));
    }
    if old.model_sha256 != want.model_sha256 {
        return Err(Error::request(
            format!(
                "the checkpoint {path} is of another model: {} with sha256 {} there, {} with sha256 {} now",
                old.model_file,
                short(&old.model_sha256),
                want.model_file,
                short(&want.model_sha256)
            ),
            format!("the model file changed since the checkpoint was written; {afresh}"),
        ));
    }
    if old.fingerprint != want.fingerprint {
        return Err(Error::request(
            format!(
                "the checkpoint {path} is of a {} with other options{}: it was written by\n  detune {} {}",
                if old.study.is_some() {
                    "study"
                } else {
                    "sweep"
                },
                // `--values` is the sweep's; the studies (sensitivity, tune) vary by --vary
                if old.study.is_some() {
                    " or --set"
                } else {
                    ", --set or --values"
                },
                command(old),
                old.command.join(" ")
            ),
            format!("resume it with that command; {afresh}"),
        ));
    }
    if old.shard != want.shard {
        return Err(Error::request(
            format!(
                "the checkpoint {path} is of shard {}/{}; this run is shard {}/{}",
                old.shard.k, old.shard.n, want.shard.k, want.shard.n
            ),
            format!("resume each shard with its own checkpoint; {afresh}"),
        ));
    }
    Ok(())
}

impl CaseLog for Checkpoint {
    fn lookup(&self, key: &CaseKey) -> Result<Option<(SteadyState, isize)>> {
        if let Some(c) = self.known.lock().expect("not poisoned").get(key) {
            return Ok(Some(c.clone()));
        }
        if !self.merging {
            return Ok(None);
        }
        let run = self
            .run_labels
            .get(key.run)
            .filter(|l| !l.is_empty())
            .map(|l| format!(" [{l}]"))
            .unwrap_or_default();
        let omega = f64::from_bits(key.omega);
        let h = &self.header;
        let owner = match key.kind {
            CaseKind::Coarse => self
                .grid
                .iter()
                .position(|w| w.to_bits() == key.omega)
                .map(|i| Shard::owner(h.shard.n, h.sequential, h.grid, key.run, i)),
            _ if h.sequential => Some(key.run % h.shard.n + 1),
            _ => None,
        };
        let what = match key.kind {
            CaseKind::Coarse => "the frequency",
            CaseKind::Back => "the jump check at",
            CaseKind::Refine => "the refined frequency",
        };
        Err(Error::request(
            format!(
                "the checkpoints lack {what} {omega} rad/s ({}){run}{}",
                key.direction.name(),
                owner
                    .map(|k| format!(", which shard {k}/{} computes: it is incomplete", h.shard.n))
                    .unwrap_or_default()
            ),
            "re-run that shard with its command (it resumes from its checkpoint), then merge again",
        ))
    }

    fn record(&self, key: &CaseKey, s: &SteadyState, well: isize) -> Result<()> {
        if let Some(file) = &self.file {
            let mut line =
                serde_json::to_string(&Line::of(key, s, well)).expect("a case serializes");
            line.push('\n');
            let mut f = file.lock().expect("not poisoned");
            f.write_all(line.as_bytes())
                .and_then(|_| f.sync_data())
                .map_err(|e| io(&self.path, e))?;
        }
        let mut kept = s.clone();
        kept.orbit = Vec::new();
        self.known
            .lock()
            .expect("not poisoned")
            .insert(*key, (kept, well));
        Ok(())
    }

    fn selected(&self, run: usize, index: usize) -> bool {
        let s = self.shard();
        self.merging
            || Shard::owner(s.n, self.header.sequential, self.header.grid, run, index) == s.k
    }

    fn takes_run(&self, run: usize) -> bool {
        let s = self.shard();
        self.merging || !self.header.sequential || run % s.n + 1 == s.k
    }
}

impl Checkpoint {
    /// Every case known, in a fixed order (run, kind, direction, frequency).
    pub fn cases(&self) -> Vec<(CaseKey, SteadyState, isize)> {
        let known = self.known.lock().expect("not poisoned");
        let mut out: Vec<_> = known
            .iter()
            .map(|(k, (s, w))| (*k, s.clone(), *w))
            .collect();
        out.sort_by(|a, b| {
            (a.0.run, a.0.kind as u8, a.0.direction as u8)
                .cmp(&(b.0.run, b.0.kind as u8, b.0.direction as u8))
                .then(f64::from_bits(a.0.omega).total_cmp(&f64::from_bits(b.0.omega)))
        });
        out
    }
}
