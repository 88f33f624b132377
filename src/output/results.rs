//! CSV layouts of the analyses' results (pure functions of result structs), and the rows
//! that the CSV files and the JSON documents ([`super::json`]) share.

use super::{num, write_atomic};
use crate::diag::Result;
use crate::frequency::study::SweepRun;
use crate::linear::FrequencyResponse;
use crate::statics::continuation::Branch;
use serde_json::Value;

/// One field of a result row, written as CSV text or as a JSON value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Cell<'a> {
    Number(f64),
    Count(usize),
    /// 1 or 0 in CSV, true or false in JSON.
    Flag(bool),
    Text(&'a str),
    /// A signed integer (an index, −1 for none).
    Index(isize),
}

impl Cell<'_> {
    /// The CSV field.
    pub fn csv(&self) -> String {
        match *self {
            Cell::Number(x) => num(x),
            Cell::Count(n) => n.to_string(),
            Cell::Flag(b) => u8::from(b).to_string(),
            Cell::Text(s) => s.to_string(),
            Cell::Index(i) => i.to_string(),
        }
    }

    /// The JSON value (a non-finite number is null).
    pub fn json(&self) -> Value {
        match *self {
            Cell::Number(x) => Value::from(x),
            Cell::Count(n) => Value::from(n),
            Cell::Flag(b) => Value::Bool(b),
            Cell::Text(s) => Value::from(s),
            Cell::Index(i) => Value::from(i),
        }
    }
}

/// Write a header and rows of cells as CSV, with `footer` lines (comments) at the end.
pub(crate) fn write_rows(
    path: &str,
    header: &[String],
    rows: &[Vec<Cell>],
    footer: &[&str],
) -> Result<()> {
    write_atomic(path, |w| {
        writeln!(w, "{}", header.join(","))?;
        for row in rows {
            let fields: Vec<String> = row.iter().map(Cell::csv).collect();
            writeln!(w, "{}", fields.join(","))?;
        }
        for line in footer {
            writeln!(w, "{line}")?;
        }
        Ok(())
    })
}

/// CSV of a branch: `<param>,<coordinates>...,stable,branch`: the branch followed from the
/// start (`branch` 0), then the branches switched to at its branch points (1, 2, …).
/// (An interrupted run, `complete = false`, ends with a comment line `# incomplete: ...`.)
pub fn write_branch_csv(path: &str, b: &Branch) -> Result<()> {
    write_atomic(path, |w| {
        // the trim's solved parameters, when the model has one, after the coordinates
        let mut header = b.coordinates.clone();
        header.extend(b.solved.iter().cloned());
        writeln!(w, "{},{},stable,branch", b.param, header.join(","))?;
        for (k, (_, points, ..)) in b.all().into_iter().enumerate() {
            for p in points {
                write!(w, "{}", num(p.value))?;
                for x in p.q.iter().chain(&p.solved) {
                    write!(w, ",{}", num(*x))?;
                }
                writeln!(w, ",{},{k}", u8::from(p.stable))?;
            }
        }
        if !b.complete {
            let last = b
                .all()
                .last()
                .and_then(|(_, p, ..)| p.last())
                .map(|p| p.value);
            writeln!(
                w,
                "# incomplete: interrupted{}; the rows above are the points computed",
                last.map(|v| format!(" at {} = {}", b.param, num(v)))
                    .unwrap_or_default()
            )?;
        }
        Ok(())
    })
}

/// Header of a linear frequency response: `<param>,<name>_amplitude,<name>_phase_deg,...`.
pub fn frf_header(fr: &FrequencyResponse) -> Vec<String> {
    let mut header = vec![fr.param.clone()];
    for r in &fr.responses {
        header.push(format!("{r}_amplitude"));
        header.push(format!("{r}_phase_deg"));
    }
    header
}

/// Rows of a linear frequency response, one per frequency (see [`frf_header`]).
pub fn frf_rows(fr: &FrequencyResponse) -> Vec<Vec<Cell<'_>>> {
    fr.omega
        .iter()
        .zip(&fr.values)
        .map(|(om, vals)| {
            let mut row = vec![Cell::Number(*om)];
            for (a, p) in vals {
                row.extend([Cell::Number(*a), Cell::Number(*p)]);
            }
            row
        })
        .collect()
}

/// CSV of a linear frequency response (see [`frf_header`]).
pub fn write_frf_csv(path: &str, fr: &FrequencyResponse) -> Result<()> {
    write_rows(path, &frf_header(fr), &frf_rows(fr), &[])
}

/// The measures of each response, in their CSV order (`<response>_<measure>`).
pub const MEASURES: [&str; 8] = [
    "amplitude",
    "max",
    "min",
    "mean",
    "h1",
    "phase_deg",
    "h2",
    "thd",
];

pub fn measure_values(m: &crate::frequency::measure::Measures) -> [f64; 8] {
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
}

/// Header of a sweep: `<param>,direction[,<values param>...],<response>_<measure>...,
/// settled,periods,period_multiple,refined,well` (`well`: the index of the equilibrium
/// the response oscillates about in the JSON's `equilibria`, −1 across two wells).
pub fn sweep_header(runs: &[SweepRun]) -> Vec<String> {
    let first = &runs[0].sweep;
    let mut h = vec![first.param.clone(), "direction".to_string()];
    for (name, _) in runs[0].tags() {
        h.push(name.to_string());
    }
    for r in &first.responses {
        for m in MEASURES {
            h.push(format!("{r}_{m}"));
        }
    }
    h.extend(["settled", "periods", "period_multiple", "refined", "well"].map(String::from));
    h
}

/// Rows of a sweep, one per frequency, direction and `--values` entry (see
/// [`sweep_header`]).
pub fn sweep_rows(runs: &[SweepRun]) -> Vec<Vec<Cell<'_>>> {
    let mut rows = Vec::new();
    for run in runs {
        for p in &run.sweep.points {
            let mut row = vec![Cell::Number(p.steady.omega), Cell::Text(p.direction.name())];
            for (_, v) in run.tags() {
                row.push(Cell::Number(v));
            }
            for m in &p.steady.measures {
                row.extend(measure_values(m).map(Cell::Number));
            }
            row.extend([
                Cell::Flag(p.steady.settled),
                Cell::Count(p.steady.periods),
                Cell::Count(p.steady.period_multiple),
                Cell::Flag(p.refined),
                Cell::Index(p.well),
            ]);
            rows.push(row);
        }
    }
    rows
}

/// Sweep CSV (see [`sweep_header`]). An incomplete sweep ends with a comment line
/// `# incomplete: ...`: interrupted, or stopped by a failing frequency (which it names,
/// with the reason: [`incomplete_sweep_line`]).
pub fn write_sweep_csv(path: &str, runs: &[SweepRun]) -> Result<()> {
    let footer: Vec<String> = incomplete_sweep_line(runs).into_iter().collect();
    let footer: Vec<&str> = footer.iter().map(String::as_str).collect();
    write_rows(path, &sweep_header(runs), &sweep_rows(runs), &footer)
}

/// The last line of an incomplete sweep's CSV (None: complete):
/// `# incomplete: interrupted; the rows above are the frequencies completed`, or for a
/// sweep stopped by a failure `# incomplete: failed at omega = 1 rad/s (up, the coarse
/// grid[, F0 = 80]): <reason>; the rows above are the frequencies completed before it`.
pub fn incomplete_sweep_line(runs: &[SweepRun]) -> Option<String> {
    if runs.iter().all(|r| r.sweep.complete) {
        return None;
    }
    Some(
        match runs
            .iter()
            .find_map(|r| Some((r, r.sweep.failure.as_ref()?)))
        {
            Some((run, f)) => {
                let tag = crate::frequency::study::values_label(&run.values);
                format!(
                    "# incomplete: failed at {} = {} rad/s ({}, {}{}): {}; the rows above are {}",
                    run.sweep.param,
                    num(f.omega),
                    f.direction.name(),
                    f.stage(),
                    if tag.is_empty() {
                        String::new()
                    } else {
                        format!(", {tag}")
                    },
                    f.reason().replace(['\n', '\r'], " "),
                    f.kept()
                )
            }
            None => {
                "# incomplete: interrupted; the rows above are the frequencies completed".into()
            }
        },
    )
}

/// Header of a mode tracking's CSV: `<param>`, then per label `<label>.omega_n_rad_s`,
/// `<label>.damping_ratio`, `<label>.mac`.
pub fn tracking_header(t: &crate::linear::tracking::ModeTracking) -> Vec<String> {
    let mut h = vec![t.param.clone()];
    for l in &t.labels {
        h.push(format!("{l}.omega_n_rad_s"));
        h.push(format!("{l}.damping_ratio"));
        h.push(format!("{l}.mac"));
    }
    h
}

/// CSV of a mode tracking, one row per requested value (see [`tracking_header`]); a
/// label lost at a value has empty cells there. The MAC is with the previous value
/// solved (an inserted one where the step was halved).
pub fn write_tracking_csv(path: &str, t: &crate::linear::tracking::ModeTracking) -> Result<()> {
    let header = tracking_header(t);
    write_atomic(path, |w| {
        writeln!(w, "{}", header.join(","))?;
        for s in t.steps.iter().filter(|s| s.requested) {
            write!(w, "{}", num(s.value))?;
            for m in &s.modes {
                match m {
                    Some(m) => write!(
                        w,
                        ",{},{},{}",
                        num(m.omega_n_rad_s),
                        num(m.damping_ratio),
                        num(m.mac)
                    )?,
                    None => write!(w, ",,,")?,
                }
            }
            writeln!(w)?;
        }
        Ok(())
    })
}
