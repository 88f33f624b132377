//! The report's view of a vibration environment: rotors with their speed range, and the
//! forcing lines they make (1P, nP, 1T, nT: a multiple of a rotor's speed, with the band
//! it sweeps over the operating range).
//!
//! This is the report's input type, independent of where the figures come from. Until
//! the project's environment module lands, [`builtin`] knows one environment, `UH-60`,
//! with hard-coded figures ([`uh60_placeholder`]); that function is the one to replace.

use crate::diag::{Error, Result};
use serde::Serialize;

/// A rotor of the aircraft.
#[derive(Debug, Clone, Serialize)]
pub struct Rotor {
    /// `main`, `tail`.
    pub name: String,
    /// Number of blades.
    pub blades: u32,
    /// Nominal speed (100 % NR), rpm.
    pub rpm: f64,
    /// Operating range [lo, hi], rpm, only where a source gives one.
    pub rpm_range: Option<[f64; 2]>,
}

impl Rotor {
    /// Nominal angular speed Ω = rpm · π/30, rad/s.
    pub fn omega_rad_s(&self) -> f64 {
        self.rpm * std::f64::consts::PI / 30.0
    }

    /// [lo, hi] of the speed, rpm: the operating range, or the nominal speed twice.
    pub fn rpm_bounds(&self) -> [f64; 2] {
        self.rpm_range.unwrap_or([self.rpm; 2])
    }
}

/// One forcing line: `multiple` × a rotor's speed, or a fixed line or band (no rotor).
#[derive(Debug, Clone, Serialize)]
pub struct ForcingLine {
    /// `1P`, `4P`, `1T`..., or a fixed line's name.
    pub label: String,
    /// The rotor's name ([`Rotor::name`]); None for a fixed line or band.
    pub rotor: Option<String>,
    /// Multiple of the rotor's speed (1 for 1P, the blade count for nP); None for a
    /// fixed line or band.
    pub multiple: Option<f64>,
    /// At the nominal rotor speed (a band's centre), rad/s.
    pub omega_rad_s: f64,
    /// Lowest frequency over the operating range, rad/s (= nominal without a range).
    pub band_lo_rad_s: f64,
    /// Highest frequency over the operating range, rad/s (= nominal without a range).
    pub band_hi_rad_s: f64,
}

/// A vibration environment: its rotors (the first is the one the interference diagram's
/// speed axis reads) and forcing lines.
#[derive(Debug, Clone, Serialize)]
pub struct Environment {
    pub name: String,
    /// Where the figures come from.
    pub source: String,
    pub rotors: Vec<Rotor>,
    pub lines: Vec<ForcingLine>,
}

impl Environment {
    /// The rotor a line belongs to.
    pub fn rotor(&self, line: &ForcingLine) -> Option<&Rotor> {
        let name = line.rotor.as_deref()?;
        self.rotors.iter().find(|r| r.name == name)
    }

    /// The lines `multiples` (rotor name, multiple, label) of the rotors, each with its
    /// band over the rotor's operating range.
    pub fn with_lines(
        name: &str,
        source: &str,
        rotors: Vec<Rotor>,
        multiples: &[(&str, f64, &str)],
    ) -> Environment {
        let per_rpm = std::f64::consts::PI / 30.0;
        let lines = multiples
            .iter()
            .filter_map(|(rotor, n, label)| {
                let r = rotors.iter().find(|r| r.name == *rotor)?;
                let [lo, hi] = r.rpm_bounds();
                Some(ForcingLine {
                    label: label.to_string(),
                    rotor: Some(r.name.clone()),
                    multiple: Some(*n),
                    omega_rad_s: n * r.rpm * per_rpm,
                    band_lo_rad_s: n * lo * per_rpm,
                    band_hi_rad_s: n * hi * per_rpm,
                })
            })
            .collect();
        Environment {
            name: name.to_string(),
            source: source.to_string(),
            rotors,
            lines,
        }
    }
}

/// The environment named `name` (case-insensitive). Only `UH-60` is known until the
/// environment module replaces this; any other name or a path is refused with a hint.
pub fn builtin(name: &str) -> Result<Environment> {
    if name.eq_ignore_ascii_case("UH-60") || name.eq_ignore_ascii_case("UH60") {
        return Ok(uh60_placeholder());
    }
    Err(Error::request(
        format!("unknown environment `{name}`"),
        "the known environment is UH-60 (environment files are not read yet)",
    ))
}

/// PLACEHOLDER, to be replaced by the environment module (`src/environment.rs`): the
/// UH-60's rotors with hard-coded figures. Main rotor 258 rpm, 4 blades; tail rotor 1190
/// rpm, 4 blades; no operating range (none is cited, so the lines are points); lines 1P,
/// 4P, 8P, 12P, 1T, 4T.
pub fn uh60_placeholder() -> Environment {
    let rotor = |name: &str, blades, rpm: f64| Rotor {
        name: name.into(),
        blades,
        rpm,
        rpm_range: None,
    };
    Environment::with_lines(
        "UH-60",
        "placeholder figures in detune::report::environment: main rotor 258 rpm, tail rotor 1190 rpm, 4 blades each; no operating range",
        vec![rotor("main", 4, 258.0), rotor("tail", 4, 1190.0)],
        &[
            ("main", 1.0, "1P"),
            ("main", 4.0, "4P"),
            ("main", 8.0, "8P"),
            ("main", 12.0, "12P"),
            ("tail", 1.0, "1T"),
            ("tail", 4.0, "4T"),
        ],
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn uh60_lines_are_multiples_of_the_rotor_speeds() {
        let e = super::builtin("uh-60").unwrap();
        assert_eq!(e.lines.len(), 6);
        // 258 rpm × π/30 = 27.0177 rad/s; 4P = 108.07 rad/s; 1190 rpm × π/30 = 124.6165 rad/s
        assert!((e.lines[0].omega_rad_s - 27.017_696_820_872_22).abs() < 1e-9);
        assert!((e.lines[1].omega_rad_s - 4.0 * 27.017_696_820_872_22).abs() < 1e-9);
        assert!((e.lines[4].omega_rad_s - 124.616_508_592_395_12).abs() < 1e-9);
        // no operating range is cited: every band is its line
        assert!(
            e.lines
                .iter()
                .all(|l| l.band_lo_rad_s == l.omega_rad_s && l.omega_rad_s == l.band_hi_rad_s)
        );
        assert!(super::builtin("CH-47").is_err());
    }
}
