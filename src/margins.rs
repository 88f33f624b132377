//! Frequency margins: does every resonance clear every forcing line of an environment?
//!
//! For a mode whose natural frequency lies in [a, b] (a = b = ω_n = |λ| for a nominal
//! design; a tolerance interval from a sensitivity study otherwise) and a forcing line or
//! band [lo, hi] (lo = hi = ω_line for a line without an operating range):
//!
//! ```text
//! below = (lo − b) / lo          the mode's top under the line's bottom, relative to it
//! above = (a − hi) / hi          the mode's bottom over the line's top, relative to it
//! separation = max(below, above)              (× 100: %)
//! ```
//!
//! For a point mode and a point line this is |ω_mode − ω_line| / ω_line; for a band it is
//! measured to the nearest edge; for an interval it is the worst point of the interval.
//! When the interval and the band overlap both are ≤ 0 and the separation is 0 or
//! negative (minus the smaller relative shift that would clear it). A row passes when the
//! separation is at least the required margin: the user's choice (default 10 %), not a
//! standard. (A mode required no separation, below, passes wherever it lies.)
//!
//! Damping-aware margin (a heuristic, API 684-style, not a standard): a well damped mode
//! amplifies little at resonance and needs less separation. With the amplification
//! factor AF ≈ 1/(2ζ), the required margin is the user's margin scaled by the shape of
//! API 617/684's separation-margin curve, SM = 17 % · (1 − 1/(AF − 1.5)):
//!
//! ```text
//! required = margin · (1 − 1/(AF − 1.5))   for AF ≥ 2.5 (ζ ≤ 0.2),    0 below
//! ```
//!
//! so the user's margin is the requirement of an undamped mode (AF → ∞, the reference),
//! ζ = 0.05 (AF = 10) needs 88 % of it, ζ = 0.135 (AF = 3.7) 55 %, and a mode with
//! AF < 2.5 (ζ > 0.2) none, as API calls such a mode critically damped.

use crate::diag::Result;
use crate::environment::ForcingLine;
use crate::linear::{ModalAnalysis, Motion};
use crate::request::{Argument, Invalid};
use serde::Serialize;

/// A mode's natural frequency as an interval (a tolerance study), or a point
/// (`min_rad_s = max_rad_s = omega_n_rad_s`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModeInterval {
    /// `"mode 1"`, `"mode 2"`, … by frequency (or a name given by the caller).
    pub name: String,
    /// Nominal ω_n = |λ|, rad/s.
    pub omega_n_rad_s: f64,
    /// Lowest ω_n over the tolerances, rad/s.
    pub min_rad_s: f64,
    /// Highest ω_n over the tolerances, rad/s.
    pub max_rad_s: f64,
    /// ζ = −Re λ / |λ| at the nominal design.
    pub damping_ratio: f64,
}

impl ModeInterval {
    /// A point: the nominal design only.
    pub fn point(name: impl Into<String>, omega_n_rad_s: f64, damping_ratio: f64) -> Self {
        ModeInterval {
            name: name.into(),
            omega_n_rad_s,
            min_rad_s: omega_n_rad_s,
            max_rad_s: omega_n_rad_s,
            damping_ratio,
        }
    }
}

/// A mode left out of the check: a real eigenvalue, which does not oscillate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SkippedMode {
    /// The eigenvalue λ (real), 1/s.
    pub eigenvalue: f64,
    /// Why it is left out.
    pub reason: String,
}

/// A mode that grows: an eigenvalue with Re λ > 0 (a real one: the equilibrium diverges;
/// a complex pair: an oscillation that grows, negative damping). A design with one fails
/// the margins check whatever its separations: its frequencies are not resonances about a
/// steady state, and the mechanism leaves its equilibrium.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UnstableMode {
    /// The mode's name, as in the rows (`mode 1` by frequency, or its declared name).
    pub mode: String,
    /// Re λ, 1/s: the amplitude grows as e^(Re λ · t).
    pub growth_rate_1_s: f64,
    /// |Im λ|, rad/s: 0 for a divergence (a real eigenvalue), else the growing oscillation's
    /// frequency.
    pub omega_d_rad_s: f64,
}

/// Every mode of `modal` that grows ([`ModalAnalysis::growing`]: Re λ above round-off,
/// [`crate::linear::ModalAnalysis::threshold`], real or complex), named as in [`mode_points_named`] (`names`
/// in `modal.modes` order; `mode k` where missing).
pub fn unstable_modes(modal: &ModalAnalysis, names: &[String]) -> Vec<UnstableMode> {
    modal
        .growing()
        .into_iter()
        .map(|k| {
            let m = &modal.modes[k];
            UnstableMode {
                mode: names
                    .get(k)
                    .cloned()
                    .unwrap_or_else(|| format!("mode {}", k + 1)),
                growth_rate_1_s: m.eigenvalue.re,
                omega_d_rad_s: m.omega_d_rad_s,
            }
        })
        .collect()
}

/// The oscillatory modes of a modal analysis, as points named `mode 1`, `mode 2`, … by
/// frequency (ω_n = |λ|), and the real eigenvalues left out (non-oscillatory: nothing to
/// resonate with a forcing line).
pub fn mode_points(modal: &ModalAnalysis) -> (Vec<ModeInterval>, Vec<SkippedMode>) {
    let names: Vec<String> = (0..modal.modes.len())
        .map(|k| format!("mode {}", k + 1))
        .collect();
    mode_points_named(modal, &names)
}

/// [`mode_points`] with the modes' names (one per mode of `modal`, in its order: the
/// model's declared names, `crate::linear::sensitivity::mode_names`).
pub fn mode_points_named(
    modal: &ModalAnalysis,
    names: &[String],
) -> (Vec<ModeInterval>, Vec<SkippedMode>) {
    let mut modes = Vec::new();
    let mut skipped = Vec::new();
    for (k, m) in modal.modes.iter().enumerate() {
        let motion = modal.motion(k);
        if motion.is_real() {
            let l = m.eigenvalue.re;
            skipped.push(SkippedMode {
                eigenvalue: l,
                reason: match motion {
                    Motion::Divergent => "real eigenvalue, divergent: the equilibrium is unstable, it does not oscillate",
                    Motion::Decaying => "real eigenvalue: non-oscillatory (an overdamped decay, or the decaying partner of a divergence), no resonance",
                    _ => "real eigenvalue: non-oscillatory (a neutral direction at λ = 0), no resonance",
                }
                .into(),
            });
        } else {
            modes.push(ModeInterval::point(
                names
                    .get(k)
                    .cloned()
                    .unwrap_or_else(|| format!("mode {}", k + 1)),
                m.omega_n_rad_s,
                m.damping_ratio,
            ));
        }
    }
    (modes, skipped)
}

/// The points of a tolerance box whose equilibrium is unstable, from its sensitivity
/// study over `varies`: the corners and interior samples it evaluated, and the `--vary`
/// cases inside the box (a case at an end of a single parameter's range is one of the
/// corners already listed, so it is not listed again). Any of them fails a margins check
/// over the box ([`MarginCheck::with_unstable_corners`]), as an unstable nominal design
/// does: `margins --vary`, `tune --tolerance` and the report check the same points.
/// A box with points that could not be solved (no equilibrium near the nominal one) is
/// refused: its intervals and stability would be no guarantee.
pub fn box_unstable_points(
    study: &crate::linear::sensitivity::Sensitivity,
    varies: &[crate::linear::sensitivity::Vary],
) -> Result<Vec<crate::linear::sensitivity::UnstableCorner>> {
    let failed: usize = study
        .modes
        .first()
        .map_or(0, |m| m.worst_case.corners_failed);
    if failed > 0 {
        return Err(crate::diag::Error::request(
            format!(
                "the tolerance box cannot be verified: at {failed} of its corners or samples no equilibrium was found near the nominal one (the ranges reach past a fold, or a linkage that no longer closes)"
            ),
            "narrow the --vary ranges (detune sensitivity with the same --vary shows the box), or check the failing values with --set",
        ));
    }
    Ok(unstable_points(study, varies))
}

/// [`box_unstable_points`] without the check that every point of the box was solved.
fn unstable_points(
    study: &crate::linear::sensitivity::Sensitivity,
    varies: &[crate::linear::sensitivity::Vary],
) -> Vec<crate::linear::sensitivity::UnstableCorner> {
    let mut unstable = study.unstable_corners.clone();
    for c in &study.unstable_cases {
        let at_end = varies.len() == 1
            && varies
                .iter()
                .any(|v| v.name == c.param && (c.value == v.range.0 || c.value == v.range.1));
        if !at_end {
            unstable.push(crate::linear::sensitivity::UnstableCorner {
                label: c.label.clone(),
                corner: false,
                growth_rate_1_s: c.growth_rate_1_s,
                omega_d_rad_s: c.omega_d_rad_s,
            });
        }
    }
    unstable
}

/// `points` widened to each mode's interval over a sensitivity study's tolerance box (its
/// worst case, matched by name; a mode the study does not have stays a point).
pub fn with_intervals(
    points: Vec<ModeInterval>,
    study: &crate::linear::sensitivity::Sensitivity,
) -> Vec<ModeInterval> {
    points
        .into_iter()
        .map(|p| match study.modes.iter().find(|m| m.name == p.name) {
            Some(m) => ModeInterval {
                min_rad_s: m.worst_case.min_rad_s.min(p.omega_n_rad_s),
                max_rad_s: m.worst_case.max_rad_s.max(p.omega_n_rad_s),
                ..p
            },
            None => p,
        })
        .collect()
}

/// Which side of the line the mode lies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Side {
    /// The mode (its whole interval) is below the line or band.
    Below,
    /// The mode is above it.
    Above,
    /// The mode's interval meets the line or band.
    Overlap,
}

impl Side {
    pub fn as_str(self) -> &'static str {
        match self {
            Side::Below => "below",
            Side::Above => "above",
            Side::Overlap => "overlap",
        }
    }
}

/// How the required separation is set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "rule")]
pub enum Requirement {
    /// The same margin for every mode.
    Fixed,
    /// The margin scaled by the API 684-style curve of the mode's amplification factor
    /// 1/(2ζ) (a heuristic; see the module doc).
    DampingAware,
}

/// One mode against one forcing line or band.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MarginRow {
    pub mode: String,
    /// rad/s.
    pub omega_n_rad_s: f64,
    /// rad/s.
    pub min_rad_s: f64,
    /// rad/s.
    pub max_rad_s: f64,
    pub damping_ratio: f64,
    /// The line's label (`1P`, `4T`, an extra's name).
    pub line: String,
    /// Nominal line frequency (a band's centre), rad/s.
    pub line_rad_s: f64,
    /// rad/s.
    pub band_lo_rad_s: f64,
    /// rad/s.
    pub band_hi_rad_s: f64,
    /// Relative separation, % (see the module doc; ≤ 0 when they overlap).
    pub separation_pct: f64,
    pub side: Side,
    /// The separation this mode needs, %.
    pub required_pct: f64,
    pub pass: bool,
}

/// Every mode against every line.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MarginCheck {
    /// The margin asked for, % (the user's choice, not a standard).
    pub margin_pct: f64,
    pub requirement: Requirement,
    /// One row per mode × line, modes outer, lines in the environment's order.
    pub rows: Vec<MarginRow>,
    /// Every row passes, no mode is unstable, and no point of the tolerance box is.
    pub pass: bool,
    /// The modes that grow (Re λ > 0): any fails the check ([`MarginCheck::with_unstable`]).
    pub unstable: Vec<UnstableMode>,
    /// With tolerances: the points of the tolerance box whose equilibrium is unstable;
    /// any fails the check, as an unstable nominal design does
    /// ([`MarginCheck::with_unstable_corners`]).
    pub unstable_corners: Vec<crate::linear::sensitivity::UnstableCorner>,
}

impl MarginCheck {
    /// The check with the design's unstable modes ([`unstable_modes`]): any fails it.
    pub fn with_unstable(mut self, unstable: Vec<UnstableMode>) -> Self {
        if !unstable.is_empty() {
            self.pass = false;
        }
        self.unstable = unstable;
        self
    }
    /// The check with the tolerance box's unstable points (a sensitivity study's
    /// `unstable_corners`): any fails it, as an unstable nominal design does.
    pub fn with_unstable_corners(
        mut self,
        corners: Vec<crate::linear::sensitivity::UnstableCorner>,
    ) -> Self {
        if !corners.is_empty() {
            self.pass = false;
        }
        self.unstable_corners = corners;
        self
    }
    /// The failing rows, worst (least separated relative to its requirement) first.
    pub fn failures(&self) -> Vec<&MarginRow> {
        let mut f: Vec<&MarginRow> = self.rows.iter().filter(|r| !r.pass).collect();
        f.sort_by(|a, b| {
            (a.separation_pct - a.required_pct).total_cmp(&(b.separation_pct - b.required_pct))
        });
        f
    }
    /// The row with the least separation, if any.
    pub fn closest(&self) -> Option<&MarginRow> {
        self.rows
            .iter()
            .min_by(|a, b| a.separation_pct.total_cmp(&b.separation_pct))
    }
}

/// The relative separation of [a, b] from [lo, hi] (a fraction; see the module doc).
pub fn separation(a: f64, b: f64, lo: f64, hi: f64) -> (f64, Side) {
    let below = (lo - b) / lo;
    let above = (a - hi) / hi;
    let side = if below > 0.0 {
        Side::Below
    } else if above > 0.0 {
        Side::Above
    } else {
        Side::Overlap
    };
    (below.max(above), side)
}

/// The separation (fraction) required of a mode with damping ratio ζ: `margin`, or
/// (damping-aware) `margin · (1 − 1/(AF − 1.5))` with AF = 1/(2ζ), 0 for AF < 2.5.
pub fn required(margin: f64, damping_ratio: f64, rule: Requirement) -> f64 {
    match rule {
        Requirement::Fixed => margin,
        Requirement::DampingAware => {
            if damping_ratio <= 0.0 {
                return margin; // undamped (or unstable): the full margin
            }
            let af = 1.0 / (2.0 * damping_ratio);
            if af < 2.5 {
                0.0
            } else {
                margin * (1.0 - 1.0 / (af - 1.5))
            }
        }
    }
}

/// Check every mode against every line: `margin` is a fraction (0.1 = 10 %), in (0, 1).
/// The separations only: a design is checked with its unstable modes too, by
/// [`MarginCheck::with_unstable`] ([`check_design`] does both).
///
/// ```
/// use detune::margins::{Requirement, check_margins, mode_points};
/// let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/inceptor.toml");
/// let sys = detune::System::new(&detune::Model::load(path).unwrap()).unwrap();
/// let (sys, _) = detune::statics::trim::trim(&sys).unwrap();
/// let modal = detune::linear::modal_analysis(&sys, None).unwrap();
/// let (modes, skipped) = mode_points(&modal);
/// assert!(skipped.is_empty());
/// let uh60 = detune::environment::resolve("UH-60").unwrap();
/// let check = check_margins(&modes, &uh60.forcing_lines(), 0.10, Requirement::Fixed).unwrap();
/// let worst = check.failures()[0];
/// assert_eq!((worst.mode.as_str(), worst.line.as_str()), ("mode 2", "1P"));
/// assert!((worst.separation_pct - 1.803).abs() < 1e-3); // 26.53 vs 27.02 rad/s
/// assert!(!check.pass);
/// ```
pub fn check_margins(
    modes: &[ModeInterval],
    lines: &[ForcingLine],
    margin: f64,
    rule: Requirement,
) -> Result<MarginCheck> {
    if !(margin > 0.0 && margin < 1.0) {
        return Err(Invalid::NotFraction {
            argument: Argument::Margin,
            value: margin,
        }
        .into());
    }
    let mut rows = Vec::with_capacity(modes.len() * lines.len());
    for m in modes {
        for l in lines {
            let (sep, side) =
                separation(m.min_rad_s, m.max_rad_s, l.band_lo_rad_s, l.band_hi_rad_s);
            let req = required(margin, m.damping_ratio, rule);
            rows.push(MarginRow {
                mode: m.name.clone(),
                omega_n_rad_s: m.omega_n_rad_s,
                min_rad_s: m.min_rad_s,
                max_rad_s: m.max_rad_s,
                damping_ratio: m.damping_ratio,
                line: l.label.clone(),
                line_rad_s: l.omega_rad_s,
                band_lo_rad_s: l.band_lo_rad_s,
                band_hi_rad_s: l.band_hi_rad_s,
                separation_pct: 100.0 * sep,
                side,
                required_pct: 100.0 * req,
                // no separation required: passes even on the line (API's critically damped)
                pass: req == 0.0 || sep >= req,
            });
        }
    }
    let pass = rows.iter().all(|r| r.pass);
    Ok(MarginCheck {
        margin_pct: 100.0 * margin,
        requirement: rule,
        rows,
        pass,
        unstable: Vec::new(),
        unstable_corners: Vec::new(),
    })
}

/// A design's full check: every oscillatory mode of `modal` (named `names`, in its order;
/// widened by the caller to intervals, or points) against every line, and any unstable
/// mode of `modal` failing it ([`unstable_modes`]).
pub fn check_design(
    modal: &ModalAnalysis,
    names: &[String],
    modes: &[ModeInterval],
    lines: &[ForcingLine],
    margin: f64,
    rule: Requirement,
) -> Result<MarginCheck> {
    Ok(check_margins(modes, lines, margin, rule)?.with_unstable(unstable_modes(modal, names)))
}
