//! What is measured of a settled response: peak values and Fourier coefficients over
//! whole periods of the forcing.

/// Measures of one coordinate over its settled period(s). SI units, absolute values.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Measures {
    /// Half peak-to-peak.
    pub amplitude: f64,
    pub max: f64,
    pub min: f64,
    /// Mean over the period(s): the datum shift is `mean − equilibrium`.
    pub mean: f64,
    /// First-harmonic amplitude at the forcing frequency.
    pub h1: f64,
    /// Its phase, degrees: response ≈ mean + h1·sin(ωt + φ).
    pub phase_deg: f64,
    /// Second-harmonic amplitude.
    pub h2: f64,
    /// Total harmonic distortion: rms of everything but the mean and the first harmonic,
    /// over the rms of the first harmonic.
    pub thd: f64,
}

impl Measures {
    /// From `samples` equally spaced over `k` whole periods of the forcing (the endpoint
    /// excluded), t = 0 at forcing phase 0.
    pub fn of(samples: &[f64], k: usize) -> Measures {
        let n = samples.len();
        let mean = samples.iter().sum::<f64>() / n as f64;
        let (imax, imin) = extremes(samples);
        let max = refine_extreme(samples, imax);
        let min = refine_extreme(samples, imin);
        // Fourier projection at harmonic h of the forcing = index h·k over k periods
        let coef = |h: usize| {
            let (mut a, mut b) = (0.0, 0.0);
            for (j, x) in samples.iter().enumerate() {
                let phase = 2.0 * std::f64::consts::PI * (h * k * j) as f64 / n as f64;
                a += (x - mean) * phase.sin();
                b += (x - mean) * phase.cos();
            }
            (2.0 * a / n as f64, 2.0 * b / n as f64)
        };
        let (a1, b1) = coef(1);
        let (a2, b2) = coef(2);
        let h1 = a1.hypot(b1);
        // Parseval: total AC power = Σ |X_h|²/2 over all components
        let ac = samples.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        let rest = (2.0 * ac - h1 * h1).max(0.0);
        Measures {
            amplitude: 0.5 * (max - min),
            max,
            min,
            mean,
            h1,
            phase_deg: b1.atan2(a1).to_degrees(),
            h2: a2.hypot(b2),
            thd: if h1 > 0.0 { rest.sqrt() / h1 } else { 0.0 },
        }
    }
}

fn extremes(x: &[f64]) -> (usize, usize) {
    let mut imax = 0;
    let mut imin = 0;
    for i in 1..x.len() {
        if x[i] > x[imax] {
            imax = i;
        }
        if x[i] < x[imin] {
            imin = i;
        }
    }
    (imax, imin)
}

/// Value at the vertex of the parabola through the extreme sample and its (periodic)
/// neighbours: third-order accurate, so 128 samples per period give ~1e-7 relative.
fn refine_extreme(x: &[f64], i: usize) -> f64 {
    let n = x.len();
    if n < 3 {
        return x[i];
    }
    let (ym, y0, yp) = (x[(i + n - 1) % n], x[i], x[(i + 1) % n]);
    let denom = ym - 2.0 * y0 + yp;
    if denom == 0.0 {
        return y0;
    }
    let delta = 0.5 * (ym - yp) / denom;
    y0 - 0.25 * (ym - yp) * delta
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pure_sine_with_offset_and_second_harmonic() {
        let n = 128;
        let phi = 0.7f64;
        let s: Vec<f64> = (0..n)
            .map(|j| {
                let t = 2.0 * std::f64::consts::PI * j as f64 / n as f64;
                0.3 + 2.0 * (t + phi).sin() + 0.1 * (2.0 * t).cos()
            })
            .collect();
        let m = Measures::of(&s, 1);
        assert!((m.mean - 0.3).abs() < 1e-14);
        assert!((m.h1 - 2.0).abs() < 1e-13);
        assert!((m.phase_deg - phi.to_degrees()).abs() < 1e-10);
        assert!((m.h2 - 0.1).abs() < 1e-13);
        assert!((m.thd - 0.05).abs() < 1e-10);
        // peak values: sampled on 128 points and refined by a parabola
        let exact_max = {
            let mut best = f64::MIN;
            for j in 0..100_000 {
                let t = 2.0 * std::f64::consts::PI * j as f64 / 100_000.0;
                best = best.max(0.3 + 2.0 * (t + phi).sin() + 0.1 * (2.0 * t).cos());
            }
            best
        };
        assert!((m.max - exact_max).abs() < 1e-5, "{} vs {exact_max}", m.max);
    }

    #[test]
    fn period_two_response_measured_over_two_periods() {
        // forcing period = 64 samples; response has a subharmonic at half the frequency
        let n = 128;
        let s: Vec<f64> = (0..n)
            .map(|j| {
                let t = 2.0 * std::f64::consts::PI * j as f64 / 64.0;
                (t).sin() + 0.5 * (0.5 * t).sin()
            })
            .collect();
        let m = Measures::of(&s, 2);
        assert!((m.h1 - 1.0).abs() < 1e-12);
        assert!((m.thd - 0.5).abs() < 1e-12);
    }
}

/// Below this fraction of the largest amplitude among the responses of its unit, a
/// response's amplitude is round-off (see [`stillness`]): the inceptor's stick.z is 1e-13 of
/// stick.y; a real small motion (a lateral one 1e-7 of the main) is well above it.
const ROUND_OFF: f64 = 1e-9;

/// How far above the integration's absolute tolerance, and above its relative tolerance
/// of the amplitude itself, the noise of a settled amplitude may reach (see [`stillness`]).
const NOISE_REACH: f64 = 30.0;

/// Why a response has no peaks to find (see [`stillness`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StillKind {
    /// Its largest amplitude is round-off beside the largest motion of its unit.
    RoundOff,
    /// Its largest amplitude is below the integration's noise.
    BelowNoise,
    /// Its amplitude changes along the curve by less than the noise: constant (a body
    /// carried by the moving ground), or a motion too small against its coordinate's
    /// value for the tolerances to resolve its changes.
    Unchanging,
}

/// A response with no peaks to find, and the numbers that say so (SI, the response's
/// unit).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Still {
    pub kind: StillKind,
    /// Its largest amplitude along the curve.
    pub amplitude: f64,
    /// Its largest amplitude less its smallest.
    pub change: f64,
    /// The noise of its amplitude: 30 atol + rtol · (its largest |value|).
    pub noise: f64,
    /// Its largest |value| along the curve (the rtol term's reference).
    pub size: f64,
    /// The absolute tolerance's term (30 atol) is the larger part of the noise: a
    /// tighter --atol, not --rtol, lowers it.
    pub absolute: bool,
}

/// Which responses of a frequency-response curve have no peaks (nor jumps) to find, and
/// why, with the numbers (None for one whose peaks are sought), given each
/// one's measures at every point (`curves[r]`), its unit, and the tolerances the motion
/// was integrated with. The noise of a response's amplitude is taken as
/// `30 atol + rtol · |x|`, x its largest value (the integration's error control is
/// relative to the coordinates' values, not to their motion):
///
/// * Those that do not move: their largest amplitude below that noise, or below
///   [`ROUND_OFF`] of the largest among the responses of the same unit (the inceptor's
///   stick.z, 1e-17 m beside stick.y's 1e-4 m; gearbox.y, 0 m;
///   tests/data/weak_pair.toml's block2 at x = 3 m in `nfr`, 8e-10 m of motion under
///   noise spikes of 4e-9 m at rtol 4e-9).
/// * Those whose amplitude does not change along the curve by more than that noise and
///   30 rtol of itself: a body carried by the moving ground, as the inceptor's gearbox.x,
///   D0 at every frequency to 5e-11 of itself in a stepped sine (rtol 1e-10) and 1.6e-8
///   along `nfr`'s orbits (rtol 1e-8).
///
/// Their local maxima are noise: `nfr` on the inceptor at 0.1 mm reported 207 of them as
/// peaks besides the real ones. A real peak changes the amplitude by more than the noise
/// over any range that shows it as a maximum.
pub fn stillness(
    curves: &[Vec<Measures>],
    units: &[&str],
    atol: f64,
    rtol: f64,
) -> Vec<Option<Still>> {
    let most: Vec<f64> = curves
        .iter()
        .map(|c| c.iter().map(|m| m.amplitude).fold(0.0, f64::max))
        .collect();
    (0..units.len())
        .map(|r| {
            let of_unit = (0..units.len())
                .filter(|&k| units[k] == units[r])
                .map(|k| most[k])
                .fold(0.0, f64::max);
            let least = curves[r]
                .iter()
                .map(|m| m.amplitude)
                .fold(f64::INFINITY, f64::min);
            let size = curves[r]
                .iter()
                .map(|m| m.max.abs().max(m.min.abs()))
                .fold(0.0, f64::max);
            let noise = NOISE_REACH * atol + rtol * size;
            let change = most[r] - least;
            let kind = if !(most[r] > ROUND_OFF * of_unit) {
                StillKind::RoundOff
            } else if !(most[r] > noise) {
                StillKind::BelowNoise
            } else if !(change > noise + NOISE_REACH * rtol * most[r]) {
                StillKind::Unchanging
            } else {
                return None;
            };
            Some(Still {
                kind,
                amplitude: most[r],
                change,
                noise,
                size,
                absolute: NOISE_REACH * atol > rtol * size,
            })
        })
        .collect()
}
