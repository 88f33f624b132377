//! Forcing environments: the shipped files and their lines (rpm · 2π/60 computed here from
//! the sources' rpm and blade counts), name resolution, located errors for bad files, and
//! the tone and random responses of a sine-on-random profile against closed forms.

use detune::environment::{
    Environment, Profile, PsdPoint, RotorKind, Tone, random_rms, resolve, shipped,
    shipped_environments, tone_responses,
};
use detune::model::units::Dim;
use std::f64::consts::{PI, TAU};

/// rad/s of `rpm`, written out independently of the library.
fn rpm(x: f64) -> f64 {
    x * 2.0 * PI / 60.0
}

/// A rotor's rpm and blade count.
type Rotor = (f64, u32);

/// The figures of `../shared/environments/rotors.toml`: id, name, main rotor, tail rotor.
const SOURCES: &[(&str, &str, Rotor, Option<Rotor>)] = &[
    ("UH-60", "UH-60", (258.0, 4), Some((1190.0, 4))),
    ("UH-1N", "UH-1N", (324.0, 2), Some((1662.0, 2))),
    ("H135", "H135 (EC135)", (395.0, 4), None),
    ("AH-64", "AH-64", (288.0, 4), Some((1404.0, 4))),
];

#[test]
fn every_shipped_environment_loads_with_its_rotor_lines() {
    let all = shipped_environments().unwrap();
    assert_eq!(all.len(), SOURCES.len());
    assert_eq!(shipped().len(), SOURCES.len());
    for (id, name, (main_rpm, n), tail) in SOURCES {
        let e = all.iter().find(|e| e.id == *id).unwrap();
        assert_eq!(e.name, *name);
        assert!(e.shipped && !e.source.is_empty());
        assert_eq!(
            e.main_rotor.rpm_range, None,
            "{id}: no source gives a range"
        );
        let lines = e.forcing_lines();
        let mut expected: Vec<(String, f64)> = [1, *n, 2 * n, 3 * n]
            .iter()
            .map(|k| (format!("{k}P"), *k as f64 * rpm(*main_rpm)))
            .collect();
        if let Some((t_rpm, t_n)) = tail {
            expected.push(("1T".into(), rpm(*t_rpm)));
            expected.push((format!("{t_n}T"), *t_n as f64 * rpm(*t_rpm)));
        }
        assert_eq!(lines.len(), expected.len(), "{id}: {lines:?}");
        for (l, (label, w)) in lines.iter().zip(&expected) {
            assert_eq!(&l.label, label, "{id}");
            assert!((l.omega_rad_s - w).abs() < 1e-12 * w, "{id} {label}");
            assert_eq!(
                (l.band_lo_rad_s, l.band_hi_rad_s),
                (l.omega_rad_s, l.omega_rad_s)
            );
            let kind = if label.ends_with('T') {
                RotorKind::Tail
            } else {
                RotorKind::Main
            };
            assert_eq!(l.rotor, Some(kind));
        }
    }
    // the numbers the margins check quotes
    let uh60 = all.iter().find(|e| e.id == "UH-60").unwrap();
    assert!((uh60.forcing_lines()[0].omega_rad_s - 27.0177).abs() < 1e-4);
    let h135 = all.iter().find(|e| e.id == "H135").unwrap();
    assert!(h135.tail_rotor.is_none() && h135.notes.is_some());
}

#[test]
fn the_shipped_files_in_the_repository_are_the_embedded_ones() {
    for (file, text) in shipped() {
        let path = format!("{}/{file}", env!("CARGO_MANIFEST_DIR"));
        assert_eq!(std::fs::read_to_string(&path).unwrap(), *text, "{file}");
        let e = Environment::load(&path).unwrap();
        assert!(!e.shipped);
    }
}

#[test]
fn names_resolve_case_insensitively_and_paths_load() {
    assert_eq!(resolve("h135").unwrap().name, "H135 (EC135)");
    assert_eq!(resolve("H135 (EC135)").unwrap().id, "H135");
    assert_eq!(resolve("uh60").unwrap().id, "UH-60");
    assert_eq!(resolve("Uh-1n").unwrap().id, "UH-1N");
    assert_eq!(resolve("AH-64").unwrap().main_rotor.rpm, 288.0);
    let path = format!("{}/environments/ah-64.toml", env!("CARGO_MANIFEST_DIR"));
    let e = resolve(&path).unwrap();
    assert_eq!((e.id.as_str(), e.shipped), ("AH-64", false));
    let err = resolve("CH-47").unwrap_err().to_string();
    for id in ["UH-60", "UH-1N", "H135", "AH-64"] {
        assert!(err.contains(id), "{err}");
    }
    // a path that does not exist is a file error, not a name lookup
    let err = resolve("nowhere/mine.toml").unwrap_err().to_string();
    assert!(err.contains("nowhere/mine.toml"), "{err}");
}

const GOOD: &str = r#"name = "Test rotorcraft"
id = "TR-1"
source = "made up for a test"

[main_rotor]
rpm = 300
blades = 3
rpm_range = [285, 315]

[tail_rotor]
rpm = 1500
blades = 2

[[lines]]
name = "engine"
frequency = "100 Hz"

[[bands]]
name = "gearbox"
from = "40 Hz"
to = "45 Hz"

[profile]
unit = "g0"
source = "levels made up for a test"
tones = [{ frequency = "3P", level = 0.5 }, { frequency = "17 Hz", level = 0.2 }]
random = [
  { frequency = "5 Hz", psd = 0.001 },
  { frequency = "50 Hz", psd = 0.01 },
  { frequency = "500 Hz", psd = 0.01 },
]
"#;

#[test]
fn a_user_file_with_a_range_extra_lines_bands_and_a_profile() {
    let e = Environment::from_str("mine.toml", GOOD).unwrap();
    let lines = e.forcing_lines();
    let labels: Vec<&str> = lines.iter().map(|l| l.label.as_str()).collect();
    assert_eq!(
        labels,
        ["1P", "3P", "6P", "9P", "1T", "2T", "engine", "gearbox"]
    );
    // the operating range scales each harmonic's band
    let p3 = &lines[1];
    assert!((p3.omega_rad_s - 3.0 * rpm(300.0)).abs() < 1e-12);
    assert!((p3.band_lo_rad_s - 3.0 * rpm(285.0)).abs() < 1e-12);
    assert!((p3.band_hi_rad_s - 3.0 * rpm(315.0)).abs() < 1e-12);
    assert_eq!(lines[6].omega_rad_s, 100.0 * TAU);
    assert_eq!(
        (lines[7].band_lo_rad_s, lines[7].band_hi_rad_s),
        (40.0 * TAU, 45.0 * TAU)
    );
    let p = e.profile.as_ref().unwrap();
    assert!(p.is_acceleration());
    assert_eq!(p.forcing_dim(), Dim::LENGTH);
    assert_eq!(p.tones[0].label, "3P");
    assert_eq!(p.tones[0].omega_rad_s, lines[1].omega_rad_s);
    assert_eq!(p.tones[1].omega_rad_s, 17.0 * TAU);
    // log-log: halfway (in log f) between 5 and 50 Hz the PSD is the geometric mean
    let f = (5.0f64 * 50.0).sqrt();
    assert!((p.psd_at(f) - (0.001f64 * 0.01).sqrt()).abs() < 1e-15);
    assert_eq!(p.psd_at(4.0), 0.0);
    assert_eq!(p.psd_at(501.0), 0.0);
}

#[test]
fn coinciding_lines_keep_both_labels() {
    let text = GOOD.replace("blades = 3", "blades = 1");
    let e = Environment::from_str("mine.toml", &text).unwrap();
    let l = e.forcing_lines();
    let labels: Vec<&str> = l.iter().take(4).map(|l| l.label.as_str()).collect();
    assert_eq!(labels, ["1P", "1P", "2P", "3P"]);
    assert_eq!(l[0].omega_rad_s, l[1].omega_rad_s);
}

/// `mine.toml:LINE:COL` of the first `needle` in `text` (plus `offset` bytes).
fn location(text: &str, needle: &str, offset: usize) -> String {
    let at = text
        .find(needle)
        .unwrap_or_else(|| panic!("`{needle}` in text"))
        + offset;
    let line = text[..at].matches('\n').count() + 1;
    let col = at - text[..at].rfind('\n').map_or(0, |i| i + 1) + 1;
    format!("mine.toml:{line}:{col}")
}

/// `GOOD` with `from` replaced by `to` must fail with `message` located at `needle`
/// (in the new text), with a help line.
fn bad(from: &str, to: &str, message: &str, needle: &str) -> String {
    assert!(GOOD.contains(from), "`{from}` not in GOOD");
    let text = GOOD.replacen(from, to, 1);
    let err = Environment::from_str("mine.toml", &text)
        .unwrap_err()
        .render(false);
    assert!(err.contains(message), "expected `{message}` in:\n{err}");
    let at = location(&text, needle, 0);
    assert!(err.contains(&at), "expected {at} in:\n{err}");
    assert!(err.to_lowercase().contains("help"), "no help in:\n{err}");
    err
}

#[test]
fn missing_fields_are_located() {
    bad(
        "rpm = 300\n",
        "",
        "[main_rotor] has no `rpm`",
        "[main_rotor]",
    );
    bad(
        "blades = 2\n",
        "",
        "[tail_rotor] has no `blades`",
        "[tail_rotor]",
    );
    bad("id = \"TR-1\"\n", "", "has no `id`", "name");
    bad(
        "frequency = \"100 Hz\"\n",
        "",
        "a [[lines]] entry has no `frequency`",
        "[[lines]]",
    );
    bad(
        "to = \"45 Hz\"\n",
        "",
        "a [[bands]] entry has no `to`",
        "[[bands]]",
    );
    bad(
        "unit = \"g0\"\n",
        "",
        "[profile] has no `unit`",
        "[profile]",
    );
    bad(
        "[main_rotor]\nrpm = 300\nblades = 3\nrpm_range = [285, 315]\n",
        "",
        "has no `main_rotor`",
        "name",
    );
}

#[test]
fn bad_rotor_figures_are_located() {
    bad(
        "rpm = 300",
        "rpm = -300",
        "`rpm` of [main_rotor] is -300: a rotor speed must be positive",
        "-300",
    );
    bad("rpm = 1500", "rpm = 0", "must be positive", "0\nblades = 2");
    bad(
        "blades = 3",
        "blades = 0",
        "`blades` of [main_rotor] is 0",
        "0\nrpm_range",
    );
    bad("blades = 2", "blades = 2.5", "a whole number", "2.5");
    bad(
        "blades = 3",
        "blades = \"3\"",
        "must be a number, it is a string",
        "\"3\"",
    );
    bad(
        "rpm_range = [285, 315]",
        "rpm_range = [315, 285]",
        "must be positive and low to high",
        "[315",
    );
    bad(
        "rpm_range = [285, 315]",
        "rpm_range = [310, 320]",
        "does not contain the nominal 300 rpm",
        "[310",
    );
}

#[test]
fn unknown_fields_get_a_did_you_mean() {
    let e = bad(
        "blades = 2",
        "blads = 2",
        "unknown field `blads` in [tail_rotor]",
        "blads",
    );
    assert!(e.contains("did you mean `blades`?"), "{e}");
    let e = bad(
        "source = \"made",
        "sorce = \"made",
        "unknown field `sorce`",
        "sorce",
    );
    assert!(e.contains("did you mean `source`?"), "{e}");
    let e = bad("psd = 0.01 }", "psf = 0.01 }", "unknown field `psf`", "psf");
    assert!(e.contains("did you mean `psd`?"), "{e}");
}

#[test]
fn bands_and_quantities_are_checked() {
    bad(
        "from = \"40 Hz\"",
        "from = \"50 Hz\"",
        "band `gearbox` runs from",
        "\"45 Hz\"",
    );
    bad(
        "frequency = \"100 Hz\"",
        "frequency = \"100 mm\"",
        "is in",
        "\"100 mm\"",
    );
    let e = bad(
        "frequency = \"100 Hz\"",
        "frequency = 100",
        "must be a frequency with its unit",
        "100\n",
    );
    assert!(e.contains("Hz and rad/s differ"), "{e}");
    bad(
        "to = \"45 Hz\"",
        "to = \"45 Hzz\"",
        "unknown unit",
        "\"45 Hzz\"",
    );
    bad(
        "frequency = \"17 Hz\"",
        "frequency = \"17 N\"",
        "not a frequency",
        "\"17 N\"",
    );
}

#[test]
fn bad_profiles_are_located() {
    bad(
        "{ frequency = \"50 Hz\", psd = 0.01 }",
        "{ frequency = \"50 Hz\", psd = 0 }",
        "`psd` is 0: a breakpoint's PSD must be positive",
        "0 }",
    );
    bad(
        "{ frequency = \"50 Hz\", psd = 0.01 }",
        "{ frequency = \"50 Hz\", psd = -0.01 }",
        "must be positive",
        "-0.01",
    );
    bad(
        "{ frequency = \"500 Hz\", psd = 0.01 }",
        "{ frequency = \"20 Hz\", psd = 0.01 }",
        "not in increasing frequency: 20.000000 Hz follows 50.000000 Hz",
        "{ frequency = \"20 Hz\"",
    );
    let e = bad(
        "unit = \"g0\"",
        "unit = \"g\"",
        "is a mass (`g` is the gram)",
        "\"g\"",
    );
    assert!(e.contains("g0"), "{e}");
    bad(
        "level = 0.5",
        "level = -0.5",
        "an amplitude is not negative",
        "-0.5",
    );
    let e = bad("\"3P\"", "\"5P\"", "`frequency` of a tone", "\"5P\"");
    assert!(e.contains("1P, 3P, 6P, 9P, 1T, 2T, engine, gearbox"), "{e}");
}

#[test]
fn every_problem_of_a_file_is_reported_at_once() {
    let text = GOOD
        .replacen("rpm = 300", "rpm = -1", 1)
        .replacen("blades = 2", "blads = 2", 1)
        .replacen("psd = 0.001", "psd = 0", 1);
    let err = Environment::from_str("mine.toml", &text)
        .unwrap_err()
        .render(false);
    assert!(err.contains("4 problems in mine.toml"), "{err}");
    // in file order
    let a = err.find("rpm` of [main_rotor]").unwrap();
    let b = err.find("[tail_rotor] has no `blades`").unwrap();
    let c = err.find("unknown field `blads`").unwrap();
    let d = err.find("`psd` is 0").unwrap();
    assert!(a < b && b < c && c < d, "{err}");
}

#[test]
fn an_empty_file_names_what_is_missing_without_panicking() {
    // regression: the root table has an empty span, which an empty file cannot mark
    let err = Environment::from_str("mine.toml", "")
        .unwrap_err()
        .render(false);
    assert!(err.contains("--> mine.toml"), "{err}");
    assert!(err.contains("the environment has no `main_rotor`"), "{err}");
    assert!(err.contains("4 problems in mine.toml"), "{err}");
    // the first character is marked whole, even when it is not ASCII
    let err = Environment::from_str("mine.toml", "# é\n")
        .unwrap_err()
        .render(false);
    assert!(
        err.contains("mine.toml:1:1: the environment has no `name`"),
        "{err}"
    );
    let err = Environment::from_str("mine.toml", "é = 1")
        .unwrap_err()
        .render(false);
    assert!(err.contains("mine.toml:1:1"), "{err}");
    let err = Environment::from_str(
        "mine.toml",
        &GOOD.replacen(
            "[main_rotor]\nrpm = 300\nblades = 3\nrpm_range = [285, 315]\n",
            "main_rotor = 5\n",
            1,
        ),
    )
    .unwrap_err()
    .render(false);
    assert!(
        err.contains("[main_rotor] must be a table, it is an integer"),
        "{err}"
    );
}

#[test]
fn toml_syntax_errors_are_located() {
    let text = GOOD.replacen("[tail_rotor]", "[tail_rotor", 1);
    let err = Environment::from_str("mine.toml", &text)
        .unwrap_err()
        .render(false);
    assert!(err.contains("mine.toml:10:"), "{err}");
}

/// A profile in `unit` with the given tones and breakpoints.
fn profile(unit: &str, tones: &[(f64, f64)], random: &[(f64, f64)]) -> Profile {
    let (unit_si, dim) = detune::model::units::parse_unit(unit).unwrap();
    Profile {
        unit: unit.into(),
        unit_si,
        dim,
        source: None,
        tones: tones
            .iter()
            .map(|&(w, level)| Tone {
                label: format!("{w} rad/s"),
                omega_rad_s: w,
                level,
            })
            .collect(),
        random: random
            .iter()
            .map(|&(freq_hz, psd)| PsdPoint { freq_hz, psd })
            .collect(),
    }
}

#[test]
fn tone_amplitudes_are_gain_times_level_and_acceleration_is_divided_by_omega_squared() {
    // displacement levels in mm: amplitude = |H| · level · 1e-3
    let p = profile("mm", &[(27.0, 7.0), (108.0, 1.0)], &[]);
    let gain = |w: f64| 2.0 + w / 100.0;
    let t = tone_responses(&p, gain);
    assert_eq!(t.len(), 2);
    assert!((t[0].amplitude - (2.27 * 7.0e-3)).abs() < 1e-15);
    assert!((t[1].amplitude - (3.08 * 1.0e-3)).abs() < 1e-15);
    // acceleration levels in g0: the displacement amplitude is level·g0/ω²
    let p = profile("g0", &[(30.0, 0.5)], &[]);
    let t = tone_responses(&p, |_| 1.0);
    let x = 0.5 * 9.80665 / 900.0;
    assert!((t[0].forcing_si - x).abs() < 1e-15);
    assert!((t[0].amplitude - x).abs() < 1e-15);
    assert!(
        random_rms(&p, |_| 1.0, &[]) == 0.0,
        "no floor: no random RMS"
    );
}

#[test]
fn random_rms_of_a_constant_gain_over_a_flat_floor() {
    // √(|H|² · W · (f2 − f1))
    let p = profile("m", &[], &[(10.0, 2e-6), (2000.0, 2e-6)]);
    let rms = random_rms(&p, |_| 3.0, &[]);
    let exact = 3.0 * (2e-6f64 * 1990.0).sqrt();
    assert!((rms - exact).abs() < 1e-12 * exact, "{rms} vs {exact}");
}

#[test]
fn random_rms_of_a_sloped_floor_is_the_power_law_integral() {
    // PSD = P1 (f/f1)^s between breakpoints: ∫ = P1 f1/(s+1) ((f2/f1)^(s+1) − 1)
    let (f1, f2, f3, p1, p2) = (5.0, 80.0, 400.0, 1e-4, 4e-3);
    let p = profile("N", &[], &[(f1, p1), (f2, p2), (f3, p2)]);
    let s = (p2 / p1).ln() / (f2 / f1).ln();
    let exact = p1 * f1 / (s + 1.0) * ((f2 / f1).powf(s + 1.0) - 1.0) + p2 * (f3 - f2);
    let rms = random_rms(&p, |_| 1.0, &[]);
    assert!((rms * rms - exact).abs() < 1e-10 * exact);
}

#[test]
fn random_rms_of_a_single_degree_of_freedom_oscillator_is_miles() {
    // |H|² = 1/((1 − r²)² + (2ζr)²), r = f/fn, over a flat W: ∫₀^∞ |H|² df = fn·π/(4ζ), so
    // RMS = √(π/2 · fn · Q · W), Q = 1/(2ζ) (Miles). The floor here is 1e-4·fn to 1e4·fn:
    // the part below is ≈ fn·r1 (|H| ≈ 1), the part above ≈ fn/(3 r2³).
    for (fn_hz, zeta) in [(30.0, 0.05), (4.2, 0.01), (100.0, 0.2)] {
        let w = 0.02;
        let (r1, r2) = (1e-4, 1e4);
        let p = profile("g0", &[], &[]);
        let p = Profile {
            dim: Dim::FORCE, // not an acceleration: no 1/ω⁴
            unit_si: 1.0,
            random: vec![
                PsdPoint {
                    freq_hz: r1 * fn_hz,
                    psd: w,
                },
                PsdPoint {
                    freq_hz: r2 * fn_hz,
                    psd: w,
                },
            ],
            ..p
        };
        let wn = TAU * fn_hz;
        let gain = |omega: f64| {
            let r = omega / wn;
            1.0 / ((1.0 - r * r).powi(2) + (2.0 * zeta * r).powi(2)).sqrt()
        };
        let q = 1.0 / (2.0 * zeta);
        let miles = (PI / 2.0 * fn_hz * q * w).sqrt();
        let exact = (w * fn_hz * (PI / (4.0 * zeta) - r1 - 1.0 / (3.0 * r2.powi(3)))).sqrt();
        let rms = random_rms(&p, gain, &[wn]);
        assert!(
            (rms - exact).abs() < 1e-8 * exact,
            "fn {fn_hz} ζ {zeta}: {rms} vs {exact}"
        );
        assert!((rms - miles).abs() < 1e-4 * miles);
        // without the hint at the peak the panels still find it
        let rms = random_rms(&p, gain, &[]);
        assert!(
            (rms - exact).abs() < 1e-6 * exact,
            "no hint: {rms} vs {exact}"
        );
    }
}

#[test]
fn acceleration_psd_is_converted_to_displacement() {
    // a flat acceleration PSD A (g0²/Hz) is a displacement PSD A·g0²/(2πf)⁴:
    // ∫ f^-4 df = (f1^-3 − f2^-3)/3
    let (f1, f2, a) = (10.0, 100.0, 0.01);
    let p = profile("g0", &[], &[(f1, a), (f2, a)]);
    let g0 = 9.80665;
    let exact = a * g0 * g0 / TAU.powi(4) * (f1.powi(-3) - f2.powi(-3)) / 3.0;
    let rms = random_rms(&p, |_| 1.0, &[]);
    assert!((rms * rms - exact).abs() < 1e-10 * exact);
}

/// Two letters swapped (`rmp` for `rpm`) is one typo: suggested, not only listed.
#[test]
fn a_swapped_pair_of_letters_gets_a_did_you_mean() {
    let e = bad(
        "rpm = 300",
        "rmp = 300",
        "unknown field `rmp` in [main_rotor]",
        "rmp",
    );
    assert!(e.contains("did you mean `rpm`?"), "{e}");
}
