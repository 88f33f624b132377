//! The report's view of a vibration environment: rotors with their speed range, and the
//! forcing lines they make (1P, nP, 1T, nT: a multiple of a rotor's speed, with the band
//! it sweeps over the operating range).
//!
//! This is the report's input type, made from an environment of [`crate::environment`]
//! (shipped, or a user's file) by [`from_environment`].

use crate::diag::Result;
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

/// The report's view of an environment of `crate::environment`: its rotors (main first)
/// and every forcing line, with the bands over the operating ranges where a source gives
/// them.
pub fn from_environment(e: &crate::environment::Environment) -> Environment {
    let rotor = |name: &str, r: &crate::environment::Rotor| Rotor {
        name: name.into(),
        blades: r.blades,
        rpm: r.rpm,
        rpm_range: r.rpm_range,
    };
    let mut rotors = vec![rotor("main", &e.main_rotor)];
    if let Some(t) = &e.tail_rotor {
        rotors.push(rotor("tail", t));
    }
    let lines = e
        .forcing_lines()
        .into_iter()
        .map(|l| ForcingLine {
            label: l.label,
            rotor: l.rotor.map(|k| match k {
                crate::environment::RotorKind::Main => "main".to_string(),
                crate::environment::RotorKind::Tail => "tail".to_string(),
            }),
            multiple: l.multiple.map(f64::from),
            omega_rad_s: l.omega_rad_s,
            band_lo_rad_s: l.band_lo_rad_s,
            band_hi_rad_s: l.band_hi_rad_s,
        })
        .collect();
    Environment {
        name: e.name.clone(),
        source: e.source.clone(),
        rotors,
        lines,
    }
}

/// The environment `name_or_path` (a shipped one's id or name, or a file), as the report
/// reads it.
pub fn resolve(name_or_path: &str) -> Result<Environment> {
    Ok(from_environment(&crate::environment::resolve(
        name_or_path,
    )?))
}
