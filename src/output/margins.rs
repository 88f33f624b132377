//! The `margins` documents: the JSON report ([`MarginsReport`]) and the CSV
//! ([`write_margins_csv`]), one row per mode × forcing line, the same columns in both.

use super::{Provenance, num, write_atomic};
use crate::diag::Result;
use crate::environment::{Environment, ForcingLine, Profile, Rotor};
use crate::margins::{MarginCheck, MarginRow, Requirement, SkippedMode, UnstableMode};
use serde::Serialize;

/// The environment as a report shows it: what the file says and the lines it implies.
#[derive(Debug, Clone, Serialize)]
pub struct EnvironmentReport<'a> {
    pub name: &'a str,
    pub id: &'a str,
    pub source: &'a str,
    pub notes: Option<&'a str>,
    pub file: &'a str,
    /// Shipped with detune (embedded), not read from disk.
    pub shipped: bool,
    /// SHA-256 of the environment file's text, hex.
    pub sha256: &'a str,
    pub main_rotor: &'a Rotor,
    pub tail_rotor: Option<&'a Rotor>,
    /// Every forcing line and band checked, in order (rotor harmonics, extras, bands).
    pub lines: Vec<ForcingLine>,
    pub profile: Option<&'a Profile>,
}

impl<'a> EnvironmentReport<'a> {
    pub fn new(env: &'a Environment) -> Self {
        EnvironmentReport {
            name: &env.name,
            id: &env.id,
            source: &env.source,
            notes: env.notes.as_deref(),
            file: &env.file,
            shipped: env.shipped,
            sha256: &env.sha256,
            main_rotor: &env.main_rotor,
            tail_rotor: env.tail_rotor.as_ref(),
            lines: env.forcing_lines(),
            profile: env.profile.as_ref(),
        }
    }
}

/// `detune margins --json`.
#[derive(Debug, Clone, Serialize)]
pub struct MarginsReport<'a> {
    pub provenance: &'a Provenance,
    pub environment: EnvironmentReport<'a>,
    /// The required margin, % (the user's choice, not a standard).
    pub margin_pct: f64,
    /// `fixed`, or `damping_aware` (a heuristic, API 684-style).
    pub requirement: Requirement,
    pub rows: &'a [MarginRow],
    /// Every row passes and no mode is unstable.
    pub pass: bool,
    /// Real eigenvalues: not oscillatory, left out of the check.
    pub skipped_modes: &'a [SkippedMode],
    /// The modes with Re λ > 0 (`mode`, `growth_rate_1_s` = Re λ, `omega_d_rad_s` = 0 for
    /// a divergence): any fails the check.
    pub unstable: &'a [UnstableMode],
    /// With `--vary`: the corners (and interior samples) of the tolerance box whose
    /// equilibrium is unstable (`label` = their values, `growth_rate_1_s`,
    /// `omega_d_rad_s`): any fails the check.
    pub unstable_corners: &'a [crate::linear::sensitivity::UnstableCorner],
}

impl<'a> MarginsReport<'a> {
    pub fn new(
        check: &'a MarginCheck,
        env: &'a Environment,
        skipped: &'a [SkippedMode],
        provenance: &'a Provenance,
    ) -> Self {
        MarginsReport {
            provenance,
            environment: EnvironmentReport::new(env),
            margin_pct: check.margin_pct,
            requirement: check.requirement,
            rows: &check.rows,
            pass: check.pass,
            skipped_modes: skipped,
            unstable: &check.unstable,
            unstable_corners: &check.unstable_corners,
        }
    }
}

/// The CSV columns, as the JSON rows' keys.
pub const MARGINS_HEADER: [&str; 13] = [
    "mode",
    "omega_n_rad_s",
    "min_rad_s",
    "max_rad_s",
    "damping_ratio",
    "line",
    "line_rad_s",
    "band_lo_rad_s",
    "band_hi_rad_s",
    "separation_pct",
    "side",
    "required_pct",
    "pass",
];

/// A name in a CSV field: quoted when it holds a comma or a quote.
fn text(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Write the rows of a margin check as CSV (atomically).
pub fn write_margins_csv(path: &str, check: &MarginCheck) -> Result<()> {
    write_atomic(path, |w| {
        writeln!(w, "{}", MARGINS_HEADER.join(","))?;
        for r in &check.rows {
            writeln!(
                w,
                "{},{},{},{},{},{},{},{},{},{},{},{},{}",
                text(&r.mode),
                num(r.omega_n_rad_s),
                num(r.min_rad_s),
                num(r.max_rad_s),
                num(r.damping_ratio),
                text(&r.line),
                num(r.line_rad_s),
                num(r.band_lo_rad_s),
                num(r.band_hi_rad_s),
                num(r.separation_pct),
                r.side.as_str(),
                num(r.required_pct),
                r.pass
            )?;
        }
        Ok(())
    })
}
