//! Forcing environments: a helicopter's rotor speeds and blade counts, the forcing lines
//! they imply, and an optional sine-on-random profile whose levels the user supplies.
//!
//! An environment file (`environments/*.toml`, format in `docs/environments.md`) gives the
//! main rotor's speed (rpm) and blade count n, optionally the tail rotor's, extra named
//! lines and bands, and a source for every figure. [`Environment::forcing_lines`] turns
//! it into the lines a resonance must clear:
//!
//! ```text
//! Ω = rpm · 2π/60 rad/s        main: 1P = Ω, nP, 2nP, 3nP        tail: 1T, nT
//! ```
//!
//! each with a band [lo, hi] over the rotor's operating range (lo = hi = nominal when the
//! source gives no range). The four shipped environments are embedded in the library
//! ([`shipped`]), so `--environment UH-60` works from any directory; [`resolve`] takes a
//! path or a shipped entry's `id` or `name`.
//!
//! A profile (MIL-STD-810G Method 514.6 style sine-on-random) lists tones (frequency,
//! level) over a random floor (PSD breakpoints, interpolated log-log). Given a response's
//! gain per unit of forcing |H|(ω), [`tone_responses`] gives the amplitude at each tone
//! (|H| × level) and [`random_rms`] the RMS over the floor, √∫|H|²·PSD df, by adaptive
//! Simpson in ln f (written here: no maintained crate integrates a closure adaptively
//! without pulling a heavy dependency; the quadrature is ~40 lines and tested against the
//! closed forms in `tests/environments.rs`).
//!
//! The file is read with toml's span-preserving `DeTable` and checked field by field (not
//! through serde derive) so that every problem is located (file:line:col), unknown fields
//! get a "did you mean", and every problem in a file is reported at once.

use crate::diag::{Diagnostic, Error, Result, SourceFile};
use crate::model::expr;
use crate::model::units::{self, Dim};
use serde::Serialize;
use std::f64::consts::TAU;
use std::ops::Range;
use std::sync::Arc;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// One rotor: speed and blade count.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rotor {
    /// Nominal speed, rpm (revolutions per minute).
    pub rpm: f64,
    /// Operating range [lo, hi], rpm, only where a source gives one.
    pub rpm_range: Option<[f64; 2]>,
    /// Number of blades n (≥ 1).
    pub blades: u32,
}

impl Rotor {
    /// Nominal rotation frequency Ω = rpm · 2π/60, rad/s.
    pub fn omega_rad_s(&self) -> f64 {
        self.rpm * TAU / 60.0
    }
    /// [lo, hi] of Ω over the operating range, rad/s (both nominal without a range).
    pub fn omega_range_rad_s(&self) -> [f64; 2] {
        match self.rpm_range {
            Some([lo, hi]) => [lo * TAU / 60.0, hi * TAU / 60.0],
            None => [self.omega_rad_s(); 2],
        }
    }
}

/// An extra named forcing line (`[[lines]]`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NamedLine {
    pub name: String,
    /// rad/s.
    pub omega_rad_s: f64,
    pub source: Option<String>,
}

/// An extra named forcing band (`[[bands]]`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NamedBand {
    pub name: String,
    /// Lower edge, rad/s.
    pub from_rad_s: f64,
    /// Upper edge, rad/s.
    pub to_rad_s: f64,
    pub source: Option<String>,
}

/// Which rotor a forcing line comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RotorKind {
    Main,
    Tail,
}

/// One forcing line (or band) a resonance must clear.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ForcingLine {
    /// `1P`, `4P`, `8P`, `12P` (main rotor), `1T`, `4T` (tail rotor), or an extra line's
    /// or band's name.
    pub label: String,
    /// The rotor it comes from (none for an extra line or band).
    pub rotor: Option<RotorKind>,
    /// Its multiple of the rotor's speed (none for an extra line or band).
    pub multiple: Option<u32>,
    /// Nominal frequency, rad/s (a band's centre).
    pub omega_rad_s: f64,
    /// Lower edge over the operating range, rad/s (= nominal without a range).
    pub band_lo_rad_s: f64,
    /// Upper edge over the operating range, rad/s.
    pub band_hi_rad_s: f64,
}

/// A tone of a sine-on-random profile.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Tone {
    /// The frequency as written: a line's label (`"4P"`) or a quantity (`"17.2 Hz"`).
    pub label: String,
    /// rad/s.
    pub omega_rad_s: f64,
    /// Amplitude (peak), in the profile's `unit`.
    pub level: f64,
}

/// A breakpoint of the random floor.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PsdPoint {
    /// Hz.
    pub freq_hz: f64,
    /// Power spectral density, (profile unit)²/Hz.
    pub psd: f64,
}

/// A sine-on-random profile (levels supplied by the user, with their source).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Profile {
    /// The unit of the tone levels as written (the PSD is in unit²/Hz): a unit of the
    /// model's forcing amplitude (`"mm"`, `"m"`, `"N"`), or an acceleration (`"g0"`,
    /// `"m/s^2"`) that is converted to a displacement by 1/ω².
    pub unit: String,
    /// SI value of one `unit`.
    pub unit_si: f64,
    /// Dimension of `unit`.
    #[serde(skip)]
    pub dim: Dim,
    pub source: Option<String>,
    pub tones: Vec<Tone>,
    /// Strictly increasing frequencies, positive PSDs (empty: no random floor).
    pub random: Vec<PsdPoint>,
}

impl Profile {
    /// Acceleration levels: converted to displacement amplitudes by 1/ω² (PSDs by 1/ω⁴).
    pub fn is_acceleration(&self) -> bool {
        self.dim == Dim::ACCELERATION
    }

    /// Dimension of the forcing amplitude the levels drive: a length for acceleration
    /// levels, else the unit's own dimension. It must be the dimension of the model's
    /// forcing amplitude parameter (e.g. `D0`, m).
    pub fn forcing_dim(&self) -> Dim {
        if self.is_acceleration() {
            Dim::LENGTH
        } else {
            self.dim
        }
    }

    /// A tone's forcing amplitude in SI: level · unit, divided by ω² for acceleration.
    pub fn tone_forcing(&self, tone: &Tone) -> f64 {
        let a = tone.level * self.unit_si;
        if self.is_acceleration() {
            a / (tone.omega_rad_s * tone.omega_rad_s)
        } else {
            a
        }
    }

    /// The floor's PSD at `f_hz`, in unit²/Hz: log-log interpolation between breakpoints,
    /// 0 outside them.
    pub fn psd_at(&self, f_hz: f64) -> f64 {
        let r = &self.random;
        if r.len() < 2 || f_hz < r[0].freq_hz || f_hz > r[r.len() - 1].freq_hz {
            return 0.0;
        }
        let i = r
            .windows(2)
            .position(|w| f_hz <= w[1].freq_hz)
            .unwrap_or(r.len() - 2);
        let (a, b) = (r[i], r[i + 1]);
        let slope = (b.psd / a.psd).ln() / (b.freq_hz / a.freq_hz).ln();
        a.psd * (f_hz / a.freq_hz).powf(slope)
    }

    /// The forcing's PSD at `f_hz` in SI²/Hz (acceleration converted by 1/ω⁴).
    pub fn forcing_psd(&self, f_hz: f64) -> f64 {
        let p = self.psd_at(f_hz) * self.unit_si * self.unit_si;
        if self.is_acceleration() {
            let w = TAU * f_hz;
            p / (w * w * w * w)
        } else {
            p
        }
    }
}

/// A forcing environment: one helicopter's rotors, extra lines and bands, and an
/// optional sine-on-random profile, each figure with its source.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Environment {
    /// Full name, e.g. `"H135 (EC135)"`.
    pub name: String,
    /// Short id, e.g. `"H135"` (what `--environment` matches, case-insensitively).
    pub id: String,
    /// Where the figures come from.
    pub source: String,
    /// Anything the reader should know (what is missing and why).
    pub notes: Option<String>,
    /// The file it was read from (`environments/uh-60.toml` for a shipped one).
    pub file: String,
    /// Shipped with detune (embedded in the library), not read from disk.
    pub shipped: bool,
    /// SHA-256 of the file's text, hex (provenance).
    pub sha256: String,
    pub main_rotor: Rotor,
    pub tail_rotor: Option<Rotor>,
    pub lines: Vec<NamedLine>,
    pub bands: Vec<NamedBand>,
    pub profile: Option<Profile>,
}

impl Environment {
    /// Every forcing line: main rotor 1P, nP, 2nP, 3nP; tail rotor 1T, nT; the extra lines
    /// and bands, in that order. Lines that coincide are all kept (no deduplication).
    pub fn forcing_lines(&self) -> Vec<ForcingLine> {
        let mut out = Vec::new();
        let mut rotor = |r: &Rotor, kind: RotorKind, letter: char, multiples: &[u32]| {
            let [lo, hi] = r.omega_range_rad_s();
            for &k in multiples {
                let k64 = f64::from(k);
                out.push(ForcingLine {
                    label: format!("{k}{letter}"),
                    rotor: Some(kind),
                    multiple: Some(k),
                    omega_rad_s: k64 * r.omega_rad_s(),
                    band_lo_rad_s: k64 * lo,
                    band_hi_rad_s: k64 * hi,
                });
            }
        };
        let n = self.main_rotor.blades;
        rotor(
            &self.main_rotor,
            RotorKind::Main,
            'P',
            &[1, n, 2 * n, 3 * n],
        );
        if let Some(t) = &self.tail_rotor {
            rotor(t, RotorKind::Tail, 'T', &[1, t.blades]);
        }
        for l in &self.lines {
            out.push(ForcingLine {
                label: l.name.clone(),
                rotor: None,
                multiple: None,
                omega_rad_s: l.omega_rad_s,
                band_lo_rad_s: l.omega_rad_s,
                band_hi_rad_s: l.omega_rad_s,
            });
        }
        for b in &self.bands {
            out.push(ForcingLine {
                label: b.name.clone(),
                rotor: None,
                multiple: None,
                omega_rad_s: 0.5 * (b.from_rad_s + b.to_rad_s),
                band_lo_rad_s: b.from_rad_s,
                band_hi_rad_s: b.to_rad_s,
            });
        }
        out
    }

    /// Read an environment file.
    pub fn load(path: &str) -> Result<Environment> {
        let text = crate::model::read_input(path, "environment file")?;
        Environment::from_str(path, &text)
    }

    /// Parse and check environment text; `path` is used in messages and kept in `file`.
    pub fn from_str(path: &str, text: &str) -> Result<Environment> {
        let source = SourceFile {
            path: path.to_string(),
            text: Arc::from(text),
        };
        let root = match DeTable::parse(text) {
            Ok(t) => t,
            Err(e) => {
                let mut d = Diagnostic::new(e.message().trim().to_string())
                    .help("an environment file is TOML: see docs/environments.md for its fields");
                if let Some(span) = e.span() {
                    d = d.at(span).label("here");
                }
                return Err(Error::Model {
                    source,
                    diagnostics: vec![d],
                });
            }
        };
        let mut r = Reader {
            diags: Vec::new(),
            text,
        };
        let env = r.environment(path, root.get_ref());
        let mut diags = r.diags;
        match env {
            Some(env) if diags.is_empty() => Ok(env),
            _ => {
                diags.sort_by_key(|d| d.span.as_ref().map_or(0, |s| s.start));
                Err(Error::Model {
                    source,
                    diagnostics: diags,
                })
            }
        }
    }
}

/// The shipped environments: (file name in the repository, text).
pub fn shipped() -> &'static [(&'static str, &'static str)] {
    &[
        (
            "environments/uh-60.toml",
            include_str!("../environments/uh-60.toml"),
        ),
        (
            "environments/uh-1n.toml",
            include_str!("../environments/uh-1n.toml"),
        ),
        (
            "environments/h135.toml",
            include_str!("../environments/h135.toml"),
        ),
        (
            "environments/ah-64.toml",
            include_str!("../environments/ah-64.toml"),
        ),
    ]
}

/// Every shipped environment, loaded.
pub fn shipped_environments() -> Result<Vec<Environment>> {
    shipped()
        .iter()
        .map(|(file, text)| {
            Environment::from_str(file, text).map(|e| Environment { shipped: true, ..e })
        })
        .collect()
}

/// `name_or_path` as `--environment` takes it: a file if it exists or ends in `.toml`,
/// else the shipped entry whose `id` or `name` matches case-insensitively (hyphens and
/// spaces ignored: `uh60` is `UH-60`). An unknown name lists the shipped ones.
pub fn resolve(name_or_path: &str) -> Result<Environment> {
    let given = name_or_path.trim();
    let path = std::path::Path::new(given);
    if path.is_file() || (path.exists() && given.to_lowercase().ends_with(".toml")) {
        return Environment::load(given);
    }
    let key = |s: &str| -> String {
        s.chars()
            .filter(|c| !matches!(c, '-' | ' ' | '_'))
            .flat_map(char::to_lowercase)
            .collect()
    };
    let all = shipped_environments()?;
    let wanted = key(given);
    if let Some(e) = all
        .iter()
        .find(|e| key(&e.id) == wanted || key(&e.name) == wanted)
    {
        return Ok(e.clone());
    }
    let list: Vec<String> = all
        .iter()
        .map(|e| {
            if e.name == e.id {
                e.id.clone()
            } else {
                format!("{} [{}]", e.id, e.name)
            }
        })
        .collect();
    let message = if given.to_lowercase().ends_with(".toml") {
        format!("{given}: no such environment file")
    } else {
        format!("no environment `{given}`: it is neither a file nor a shipped environment")
    };
    Err(Error::request(
        message,
        format!(
            "give a shipped one: {}; or the path of your own environment file (docs/environments.md)",
            list.join(", ")
        ),
    ))
}

/// The amplitude of a response at one tone of a profile.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ToneResponse {
    /// The tone's label as written (`"4P"`, `"17.2 Hz"`).
    pub tone: String,
    /// rad/s.
    pub omega_rad_s: f64,
    /// The tone's level, in the profile's unit.
    pub level: f64,
    /// The forcing amplitude it drives, SI (displacement for acceleration levels).
    pub forcing_si: f64,
    /// |H|(ω): response per unit of forcing (SI).
    pub gain: f64,
    /// |H| × forcing: the response's amplitude (its SI unit).
    pub amplitude: f64,
}

/// The response amplitude at each tone: |H|(ω_tone) × the tone's forcing amplitude.
/// `gain` is |H| as a function of ω (rad/s), per unit (SI) of the forcing amplitude.
pub fn tone_responses(profile: &Profile, gain: impl Fn(f64) -> f64) -> Vec<ToneResponse> {
    profile
        .tones
        .iter()
        .map(|t| {
            let forcing_si = profile.tone_forcing(t);
            let g = gain(t.omega_rad_s);
            ToneResponse {
                tone: t.label.clone(),
                omega_rad_s: t.omega_rad_s,
                level: t.level,
                forcing_si,
                gain: g,
                amplitude: g * forcing_si,
            }
        })
        .collect()
}

/// Root-mean-square response over the random floor: √∫ |H|(2πf)² · PSD(f) df over the
/// breakpoints' range (f in Hz; the PSD in SI²/Hz, acceleration converted to displacement).
///
/// Adaptive Simpson in u = ln f (df = f du) on panels of at most 1/64 decade, split also
/// at each of `hints_rad_s` (e.g. the modes' ω_n, where |H| peaks), to a relative
/// tolerance of 1e-10 of the whole. Returns 0 for a profile without a floor.
pub fn random_rms(profile: &Profile, gain: impl Fn(f64) -> f64, hints_rad_s: &[f64]) -> f64 {
    let r = &profile.random;
    if r.len() < 2 {
        return 0.0;
    }
    let integrand = |u: f64| {
        let f = u.exp();
        let g = gain(TAU * f);
        g * g * profile.forcing_psd(f) * f
    };
    // panel edges: every breakpoint, every hint inside the range, ≤ 1/64 decade apart
    let mut edges: Vec<f64> = r.iter().map(|p| p.freq_hz.ln()).collect();
    let (u0, u1) = (edges[0], edges[edges.len() - 1]);
    edges.extend(
        hints_rad_s
            .iter()
            .map(|w| (w / TAU).ln())
            .filter(|u| u.is_finite() && *u > u0 && *u < u1),
    );
    edges.sort_by(f64::total_cmp);
    edges.dedup();
    let max_panel = std::f64::consts::LN_10 / 64.0;
    let mut panels = Vec::new();
    for w in edges.windows(2) {
        let k = ((w[1] - w[0]) / max_panel).ceil().max(1.0) as usize;
        let h = (w[1] - w[0]) / k as f64;
        panels.extend((0..k).map(|i| (w[0] + i as f64 * h, w[0] + (i + 1) as f64 * h)));
    }
    // a first estimate of the whole sets the absolute tolerance of each panel
    let coarse: Vec<[f64; 3]> = panels
        .iter()
        .map(|&(a, b)| [integrand(a), integrand(0.5 * (a + b)), integrand(b)])
        .collect();
    let whole: f64 = panels
        .iter()
        .zip(&coarse)
        .map(|(&(a, b), f)| (b - a) / 6.0 * (f[0] + 4.0 * f[1] + f[2]))
        .sum();
    let tol = 1e-10 * whole.abs().max(f64::MIN_POSITIVE) / panels.len() as f64;
    let total: f64 = panels
        .iter()
        .zip(&coarse)
        .map(|(&(a, b), f)| simpson(&integrand, a, b, f[0], f[1], f[2], tol, 40))
        .sum();
    total.max(0.0).sqrt()
}

/// Adaptive Simpson on [a, b] with f(a), f(m), f(b) known; Richardson-corrected.
#[allow(clippy::too_many_arguments)]
fn simpson(
    f: &dyn Fn(f64) -> f64,
    a: f64,
    b: f64,
    fa: f64,
    fm: f64,
    fb: f64,
    tol: f64,
    depth: u32,
) -> f64 {
    let m = 0.5 * (a + b);
    let (l, r) = (0.5 * (a + m), 0.5 * (m + b));
    let (fl, fr) = (f(l), f(r));
    let whole = (b - a) / 6.0 * (fa + 4.0 * fm + fb);
    let left = (m - a) / 6.0 * (fa + 4.0 * fl + fm);
    let right = (b - m) / 6.0 * (fm + 4.0 * fr + fb);
    let err = left + right - whole;
    if depth == 0 || err.abs() <= 15.0 * tol {
        return left + right + err / 15.0;
    }
    simpson(f, a, m, fa, fl, fm, 0.5 * tol, depth - 1)
        + simpson(f, m, b, fm, fr, fb, 0.5 * tol, depth - 1)
}

// ---------------------------------------------------------------------------------------
// Reading the file
// ---------------------------------------------------------------------------------------

type Value<'i> = Spanned<DeValue<'i>>;

const ROOT_KEYS: &[&str] = &[
    "name",
    "id",
    "source",
    "notes",
    "main_rotor",
    "tail_rotor",
    "lines",
    "bands",
    "profile",
];
const ROTOR_KEYS: &[&str] = &["rpm", "blades", "rpm_range", "source"];
const LINE_KEYS: &[&str] = &["name", "frequency", "source"];
const BAND_KEYS: &[&str] = &["name", "from", "to", "source"];
const PROFILE_KEYS: &[&str] = &["unit", "source", "tones", "random"];
const TONE_KEYS: &[&str] = &["frequency", "level"];
const RANDOM_KEYS: &[&str] = &["frequency", "psd"];

/// Collects every problem of a file while reading it.
struct Reader<'t> {
    diags: Vec<Diagnostic>,
    text: &'t str,
}

impl Reader<'_> {
    fn err(&mut self, span: Range<usize>, message: impl Into<String>, help: impl Into<String>) {
        // a table without a header (the file's root) has an empty span: point at its first
        // character (none in an empty file: then the message names the file only)
        let d = Diagnostic::new(message).help(help);
        let span = if span.is_empty() {
            let end = self.text[span.start.min(self.text.len())..]
                .chars()
                .next()
                .map(|c| span.start + c.len_utf8());
            end.map(|e| span.start..e)
        } else {
            Some(span)
        };
        self.diags.push(match span {
            Some(s) => d.at(s).label("here"),
            None => d,
        });
    }

    /// Unknown keys of `table` (with a "did you mean").
    fn check_keys(&mut self, table: &DeTable<'_>, allowed: &[&str], what: &str) {
        for (k, _) in table.iter() {
            let key: &str = k.get_ref();
            if !allowed.contains(&key) {
                let help = match crate::model::suggest(key, allowed.iter().copied()) {
                    Some(s) => format!("{s} ({what} has the fields {})", allowed.join(", ")),
                    None => format!("{what} has the fields {}", allowed.join(", ")),
                };
                self.err(k.span(), format!("unknown field `{key}` in {what}"), help);
            }
        }
    }

    fn get<'a, 'i>(table: &'a DeTable<'i>, key: &str) -> Option<&'a Value<'i>> {
        table
            .iter()
            .find(|(k, _)| {
                let k: &str = k.get_ref();
                k == key
            })
            .map(|(_, v)| v)
    }

    fn missing(&mut self, at: Range<usize>, key: &str, what: &str, example: &str) {
        self.err(
            at,
            format!("{what} has no `{key}`"),
            format!("add it, e.g. {example}"),
        );
    }

    fn string(
        &mut self,
        table: &DeTable<'_>,
        at: &Range<usize>,
        key: &str,
        what: &str,
        example: Option<&str>,
    ) -> Option<String> {
        match Self::get(table, key) {
            None => {
                if let Some(ex) = example {
                    self.missing(at.clone(), key, what, ex);
                }
                None
            }
            Some(v) => match v.get_ref().as_str() {
                Some(s) if !s.trim().is_empty() => Some(s.to_string()),
                Some(_) => {
                    self.err(
                        v.span(),
                        format!("`{key}` of {what} is empty"),
                        "write some text",
                    );
                    None
                }
                None => {
                    self.err(
                        v.span(),
                        format!(
                            "`{key}` of {what} must be a string, it is {}",
                            a_type(v.get_ref())
                        ),
                        format!("quote it, e.g. {}", example.unwrap_or("key = \"...\"")),
                    );
                    None
                }
            },
        }
    }

    /// A TOML number (integer or float), finite.
    fn number(&mut self, v: &Value<'_>, what: &str, example: &str) -> Option<f64> {
        let x = match v.get_ref() {
            DeValue::Integer(i) => i64::from_str_radix(&i.as_str().replace('_', ""), i.radix())
                .ok()
                .map(|x| x as f64),
            DeValue::Float(f) => f.as_str().replace('_', "").parse::<f64>().ok(),
            _ => None,
        };
        match x {
            Some(x) if x.is_finite() => Some(x),
            Some(x) => {
                self.err(
                    v.span(),
                    format!("{what} is {x}, not a finite number"),
                    format!("give a finite number, e.g. {example}"),
                );
                None
            }
            None => {
                self.err(
                    v.span(),
                    format!("{what} must be a number, it is {}", a_type(v.get_ref())),
                    format!("e.g. {example}"),
                );
                None
            }
        }
    }

    /// A frequency written as a quantity string ("12 Hz", "27 rad/s", "258 rpm"), rad/s,
    /// positive. A bare number is refused: Hz or rad/s would be a guess.
    fn frequency(&mut self, v: &Value<'_>, what: &str) -> Option<f64> {
        let example = "\"12 Hz\", \"75.4 rad/s\" or \"258 rpm\"";
        let Some(text) = v.get_ref().as_str() else {
            let help = if matches!(v.get_ref(), DeValue::Integer(_) | DeValue::Float(_)) {
                format!("write the unit in a string (Hz and rad/s differ by 2π), e.g. {example}")
            } else {
                format!("e.g. {example}")
            };
            self.err(
                v.span(),
                format!("{what} must be a frequency with its unit, a string"),
                help,
            );
            return None;
        };
        let w = match parse_frequency(text) {
            Ok(w) => w,
            Err((message, help)) => {
                self.err(
                    v.span(),
                    format!("{what}: {message}"),
                    help.unwrap_or_else(|| format!("give a frequency, e.g. {example}")),
                );
                return None;
            }
        };
        if !(w.is_finite() && w > 0.0) {
            self.err(
                v.span(),
                format!("{what} is {w} rad/s: a frequency must be positive"),
                format!("give a positive frequency, e.g. {example}"),
            );
            return None;
        }
        Some(w)
    }

    fn table<'a, 'i>(
        &mut self,
        v: &'a Value<'i>,
        what: &str,
        example: &str,
    ) -> Option<&'a DeTable<'i>> {
        match v.get_ref() {
            DeValue::Table(t) => Some(t),
            other => {
                self.err(
                    v.span(),
                    format!("{what} must be a table, it is {}", a_type(other)),
                    format!("write it as {example}"),
                );
                None
            }
        }
    }

    /// An array of tables (`[[lines]]` or `[{...}, {...}]`).
    fn tables<'a, 'i>(
        &mut self,
        v: &'a Value<'i>,
        what: &str,
        example: &str,
    ) -> Vec<(&'a DeTable<'i>, Range<usize>)> {
        let DeValue::Array(items) = v.get_ref() else {
            self.err(
                v.span(),
                format!(
                    "{what} must be a list of tables, it is {}",
                    a_type(v.get_ref())
                ),
                format!("write it as {example}"),
            );
            return Vec::new();
        };
        items
            .iter()
            .filter_map(|item| self.table(item, what, example).map(|t| (t, item.span())))
            .collect()
    }

    fn environment(&mut self, path: &str, root: &DeTable<'_>) -> Option<Environment> {
        let at = 0..0;
        self.check_keys(root, ROOT_KEYS, "an environment file");
        let name = self.string(
            root,
            &at,
            "name",
            "the environment",
            Some("name = \"UH-60\""),
        );
        let id = self.string(root, &at, "id", "the environment", Some("id = \"UH-60\""));
        let source = self.string(
            root,
            &at,
            "source",
            "the environment",
            Some("source = \"where the rotor figures come from\""),
        );
        let notes = self.string(root, &at, "notes", "the environment", None);
        let main_rotor = match Self::get(root, "main_rotor") {
            Some(v) => self.rotor(v, "[main_rotor]"),
            None => {
                self.missing(
                    at.clone(),
                    "main_rotor",
                    "the environment",
                    "[main_rotor] with rpm = 258 and blades = 4",
                );
                None
            }
        };
        let tail_rotor = Self::get(root, "tail_rotor").and_then(|v| self.rotor(v, "[tail_rotor]"));
        let lines = Self::get(root, "lines")
            .map(|v| self.lines(v))
            .unwrap_or_default();
        let bands = Self::get(root, "bands")
            .map(|v| self.bands(v))
            .unwrap_or_default();
        // the profile is read even when the rest failed, so that all problems are reported
        // at once; its tones may name the lines, known only when the rotors are
        let profile = Self::get(root, "profile").map(|v| {
            let known = main_rotor.as_ref().map(|m| {
                let partial = Environment {
                    name: String::new(),
                    id: String::new(),
                    source: String::new(),
                    notes: None,
                    file: String::new(),
                    shipped: false,
                    sha256: String::new(),
                    main_rotor: m.clone(),
                    tail_rotor: tail_rotor.clone(),
                    lines: lines.clone(),
                    bands: bands.clone(),
                    profile: None,
                };
                partial.forcing_lines()
            });
            self.profile(v, known.as_deref())
        });
        Some(Environment {
            name: name?,
            id: id?,
            source: source?,
            notes,
            file: path.to_string(),
            shipped: false,
            sha256: sha256_hex(self.text.as_bytes()),
            main_rotor: main_rotor?,
            tail_rotor,
            lines,
            bands,
            profile: match profile {
                None => None,
                Some(p) => Some(p?),
            },
        })
    }

    fn rotor(&mut self, v: &Value<'_>, what: &str) -> Option<Rotor> {
        let t = self.table(v, what, &format!("{what} with rpm = 258 and blades = 4"))?;
        let at = v.span();
        self.check_keys(t, ROTOR_KEYS, what);
        let rpm = match Self::get(t, "rpm") {
            Some(r) => self
                .number(r, &format!("`rpm` of {what}"), "rpm = 258")
                .and_then(|x| {
                    if x > 0.0 {
                        Some(x)
                    } else {
                        self.err(
                            r.span(),
                            format!("`rpm` of {what} is {x}: a rotor speed must be positive"),
                            "give the nominal speed in revolutions per minute, e.g. rpm = 258",
                        );
                        None
                    }
                }),
            None => {
                self.missing(
                    at.clone(),
                    "rpm",
                    what,
                    "rpm = 258 (revolutions per minute)",
                );
                None
            }
        };
        let blades = match Self::get(t, "blades") {
            Some(b) => {
                let x = self.number(b, &format!("`blades` of {what}"), "blades = 4");
                match x {
                    Some(x) if x >= 1.0 && x.fract() == 0.0 && x <= 1000.0 => Some(x as u32),
                    Some(x) => {
                        self.err(
                            b.span(),
                            format!("`blades` of {what} is {x}: a blade count is a whole number, at least 1"),
                            "give the number of blades, e.g. blades = 4",
                        );
                        None
                    }
                    None => None,
                }
            }
            None => {
                self.missing(at.clone(), "blades", what, "blades = 4");
                None
            }
        };
        let range = match Self::get(t, "rpm_range") {
            None => Some(None),
            Some(r) => self.rpm_range(r, what, rpm),
        };
        Some(Rotor {
            rpm: rpm?,
            rpm_range: range?,
            blades: blades?,
        })
    }

    /// `rpm_range = [lo, hi]`, 0 < lo ≤ rpm ≤ hi. `Some(None)`: nothing to read.
    fn rpm_range(
        &mut self,
        v: &Value<'_>,
        what: &str,
        rpm: Option<f64>,
    ) -> Option<Option<[f64; 2]>> {
        let help = "give the operating range a source states, rpm = [lo, hi], e.g. rpm_range = [250, 265]; leave it out when no source gives one";
        let DeValue::Array(items) = v.get_ref() else {
            self.err(
                v.span(),
                format!("`rpm_range` of {what} must be a list [lo, hi]"),
                help,
            );
            return None;
        };
        if items.len() != 2 {
            self.err(
                v.span(),
                format!("`rpm_range` of {what} has {} values, not 2", items.len()),
                help,
            );
            return None;
        }
        let lo = self.number(
            &items[0],
            &format!("the low end of `rpm_range` of {what}"),
            "250",
        )?;
        let hi = self.number(
            &items[1],
            &format!("the high end of `rpm_range` of {what}"),
            "265",
        )?;
        if !(lo > 0.0 && lo <= hi) {
            self.err(
                v.span(),
                format!(
                    "`rpm_range` of {what} is [{lo}, {hi}] rpm: it must be positive and low to high"
                ),
                help,
            );
            return None;
        }
        if let Some(r) = rpm
            && !(lo <= r && r <= hi)
        {
            self.err(
                v.span(),
                format!("`rpm_range` of {what} is [{lo}, {hi}] rpm and does not contain the nominal {r} rpm"),
                help,
            );
            return None;
        }
        Some(Some([lo, hi]))
    }

    fn lines(&mut self, v: &Value<'_>) -> Vec<NamedLine> {
        let example = "[[lines]] with name = \"engine\" and frequency = \"100 Hz\"";
        self.tables(v, "`lines`", example)
            .into_iter()
            .filter_map(|(t, at)| {
                self.check_keys(t, LINE_KEYS, "a [[lines]] entry");
                let name = self.string(
                    t,
                    &at,
                    "name",
                    "a [[lines]] entry",
                    Some("name = \"engine\""),
                );
                let source = self.string(t, &at, "source", "a [[lines]] entry", None);
                let w = match Self::get(t, "frequency") {
                    Some(f) => self.frequency(f, "`frequency` of a [[lines]] entry"),
                    None => {
                        self.missing(
                            at,
                            "frequency",
                            "a [[lines]] entry",
                            "frequency = \"100 Hz\"",
                        );
                        None
                    }
                };
                Some(NamedLine {
                    name: name?,
                    omega_rad_s: w?,
                    source,
                })
            })
            .collect()
    }

    fn bands(&mut self, v: &Value<'_>) -> Vec<NamedBand> {
        let example = "[[bands]] with name = \"gearbox\", from = \"40 Hz\" and to = \"45 Hz\"";
        self.tables(v, "`bands`", example)
            .into_iter()
            .filter_map(|(t, at)| {
                let what = "a [[bands]] entry";
                self.check_keys(t, BAND_KEYS, what);
                let name = self.string(t, &at, "name", what, Some("name = \"gearbox\""));
                let source = self.string(t, &at, "source", what, None);
                let mut edge = |key: &str, ex: &str| match Self::get(t, key) {
                    Some(f) => self.frequency(f, &format!("`{key}` of {what}")).map(|w| (w, f.span())),
                    None => {
                        self.missing(at.clone(), key, what, ex);
                        None
                    }
                };
                let from = edge("from", "from = \"40 Hz\"");
                let to = edge("to", "to = \"45 Hz\"");
                let ((from, _), (to, to_span)) = (from?, to?);
                if from > to {
                    self.err(
                        to_span,
                        format!(
                            "band `{}` runs from {from:.6} rad/s down to {to:.6} rad/s: `from` must not be above `to`",
                            name.as_deref().unwrap_or("?")
                        ),
                        "swap `from` and `to`",
                    );
                    return None;
                }
                Some(NamedBand {
                    name: name?,
                    from_rad_s: from,
                    to_rad_s: to,
                    source,
                })
            })
            .collect()
    }

    /// `[profile]`; `lines`: the environment's forcing lines, for tones that name one
    /// (`None` when the rotors could not be read: such a tone is then not reported).
    fn profile(&mut self, v: &Value<'_>, lines: Option<&[ForcingLine]>) -> Option<Profile> {
        let what = "[profile]";
        let t = self.table(v, what, "[profile] with unit, tones and random")?;
        let at = v.span();
        self.check_keys(t, PROFILE_KEYS, what);
        let source = self.string(t, &at, "source", what, None);
        let unit_text = self.string(
            t,
            &at,
            "unit",
            what,
            Some("unit = \"g0\" (the tone levels' unit; the PSD is in unit²/Hz)"),
        );
        let unit = unit_text.as_ref().and_then(|u| {
            let span = Self::get(t, "unit").map(|v| v.span()).unwrap_or(at.clone());
            match units::parse_unit(u) {
                Ok((_, d)) if d == Dim::MASS => {
                    self.err(
                        span,
                        format!("unit `{u}` of {what} is a mass (`g` is the gram)"),
                        "for standard gravity write \"g0\" (or \"gn\"); for a displacement \"mm\" or \"m\"",
                    );
                    None
                }
                Ok((f, d)) if f > 0.0 && f.is_finite() => Some((f, d)),
                Ok(_) => {
                    self.err(span, format!("unit `{u}` of {what} has no positive size"), "give a unit such as \"g0\", \"m/s^2\", \"mm\" or \"N\"");
                    None
                }
                Err(e) => {
                    self.err(
                        span,
                        format!("unit `{u}` of {what}: {}", e.message),
                        e.help.unwrap_or_else(|| "give a unit such as \"g0\", \"m/s^2\", \"mm\" or \"N\"".into()),
                    );
                    None
                }
            }
        });
        let tones: Vec<Tone> = match Self::get(t, "tones") {
            None => Vec::new(),
            Some(v) => self
                .tables(v, "`tones` of [profile]", "tones = [{ frequency = \"4P\", level = 0.5 }]")
                .into_iter()
                .filter_map(|(tt, at)| {
                    let what = "a tone of [profile]";
                    self.check_keys(tt, TONE_KEYS, what);
                    let w = match Self::get(tt, "frequency") {
                        None => {
                            self.missing(at.clone(), "frequency", what, "frequency = \"4P\" (a line's label) or \"17.2 Hz\"");
                            None
                        }
                        Some(f) => match f.get_ref().as_str().map(|s| {
                            lines.map(|ls| ls.iter().find(|l| l.label.eq_ignore_ascii_case(s.trim())))
                        }) {
                            Some(Some(Some(l))) => Some((l.label.clone(), l.omega_rad_s)),
                            // the lines are unknown and this is no quantity: already an error
                            Some(None) if f.get_ref().as_str().is_some_and(|s| parse_frequency(s).is_err()) => None,
                            _ => {
                                let w = self.frequency(f, "`frequency` of a tone (a forcing line's label, or a quantity)");
                                if w.is_none()
                                    && let (Some(ls), Some(d)) = (lines, self.diags.last_mut())
                                {
                                    let labels: Vec<&str> = ls.iter().map(|l| l.label.as_str()).collect();
                                    d.help = Some(format!(
                                        "give one of this environment's lines ({}) or a frequency with its unit, e.g. \"17.2 Hz\"",
                                        labels.join(", ")
                                    ));
                                }
                                w.map(|w| (f.get_ref().as_str().unwrap_or_default().to_string(), w))
                            }
                        },
                    };
                    let level = match Self::get(tt, "level") {
                        None => {
                            self.missing(at, "level", what, "level = 0.5 (in the profile's unit)");
                            None
                        }
                        Some(l) => self.number(l, "`level` of a tone", "level = 0.5").and_then(|x| {
                            if x >= 0.0 {
                                Some(x)
                            } else {
                                self.err(l.span(), format!("`level` of a tone is {x}: an amplitude is not negative"), "give the tone's amplitude (peak) in the profile's unit");
                                None
                            }
                        }),
                    };
                    let (label, omega_rad_s) = w?;
                    Some(Tone { label, omega_rad_s, level: level? })
                })
                .collect(),
        };
        let random: Vec<(PsdPoint, Range<usize>)> = match Self::get(t, "random") {
            None => Vec::new(),
            Some(v) => self
                .tables(v, "`random` of [profile]", "random = [{ frequency = \"5 Hz\", psd = 0.001 }, { frequency = \"500 Hz\", psd = 0.001 }]")
                .into_iter()
                .filter_map(|(tt, at)| {
                    let what = "a `random` breakpoint of [profile]";
                    self.check_keys(tt, RANDOM_KEYS, what);
                    let w = match Self::get(tt, "frequency") {
                        None => {
                            self.missing(at.clone(), "frequency", what, "frequency = \"5 Hz\"");
                            None
                        }
                        Some(f) => self.frequency(f, &format!("`frequency` of {what}")),
                    };
                    let psd = match Self::get(tt, "psd") {
                        None => {
                            self.missing(at.clone(), "psd", what, "psd = 0.001 (unit²/Hz)");
                            None
                        }
                        Some(p) => self.number(p, "`psd`", "psd = 0.001").and_then(|x| {
                            if x > 0.0 {
                                Some(x)
                            } else {
                                self.err(p.span(), format!("`psd` is {x}: a breakpoint's PSD must be positive (it is interpolated log-log)"), "give a positive PSD in unit²/Hz; end the floor at the last breakpoint instead of a zero");
                                None
                            }
                        }),
                    };
                    Some((PsdPoint { freq_hz: w? / TAU, psd: psd? }, at))
                })
                .collect(),
        };
        let mut ok = true;
        for w in random.windows(2) {
            if w[1].0.freq_hz <= w[0].0.freq_hz {
                self.err(
                    w[1].1.clone(),
                    format!(
                        "the random breakpoints are not in increasing frequency: {:.6} Hz follows {:.6} Hz",
                        w[1].0.freq_hz, w[0].0.freq_hz
                    ),
                    "list the breakpoints from the lowest frequency to the highest, each once",
                );
                ok = false;
            }
        }
        if random.len() == 1 {
            self.err(
                random[0].1.clone(),
                "the random floor has one breakpoint: it needs at least two (a range)",
                "add a second breakpoint, e.g. the same PSD at the upper frequency",
            );
            ok = false;
        }
        let (unit_si, dim) = unit?;
        if !ok {
            return None;
        }
        Some(Profile {
            unit: unit_text?,
            unit_si,
            dim,
            source,
            tones,
            random: random.into_iter().map(|(p, _)| p).collect(),
        })
    }
}

fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::{Digest, Sha256};
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// A TOML value's type with its article: "an integer", "a string".
fn a_type(v: &DeValue<'_>) -> String {
    let t = v.type_str();
    let article = if t.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "an"
    } else {
        "a"
    };
    format!("{article} {t}")
}

/// A frequency quantity ("12 Hz", "27 rad/s", "258 rpm", "2*27 rad/s"), rad/s; an error
/// as (message, help).
pub fn parse_frequency(text: &str) -> std::result::Result<f64, (String, Option<String>)> {
    let e = expr::parse(text).map_err(|e| (e.message.clone(), e.help.clone()))?;
    if let Some((name, _)) = e.variables().first() {
        return Err((
            format!("`{name}` is not a unit (a frequency here is a number with its unit)"),
            None,
        ));
    }
    e.check_dims(&|_| None)
        .map_err(|e| (e.message.clone(), e.help.clone()))?;
    match e.dim(&|_| None) {
        Some(d) if d == Dim::FREQUENCY => {}
        Some(d) => {
            let given = if d == Dim::NONE {
                "has no unit (or an angle's)".to_string()
            } else {
                format!("is in {d}")
            };
            return Err((
                format!("`{text}` {given}, not a frequency"),
                Some("write the unit: \"12 Hz\", \"75.4 rad/s\" or \"258 rpm\"".into()),
            ));
        }
        None => {}
    }
    expr::eval_const(&e, &mut |n, span| {
        Err(expr::ExprError::new(
            span.clone(),
            format!("unknown name `{n}`"),
        ))
    })
    .map_err(|e| (e.message.clone(), e.help.clone()))
}
