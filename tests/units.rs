//! Units wherever a value is shown (issue 10, points 4 and 6): `--freq-unit` rescales
//! printed tables and plot axes only (CSV and JSON stay in rad/s), angles are printed in
//! degrees beside radians, every `--json` document carries a `units` map naming the unit
//! of its keys and CSV columns, and `frf --per-unit` is the receptance per unit of the
//! forcing amplitude (a single-degree-of-freedom closed form).

mod common;
use common::detune;
use serde_json::Value;
use std::f64::consts::TAU;

/// The run's stdout; it must succeed.
fn ok(args: &[&str]) -> String {
    let (code, out, err) = detune(args);
    assert_eq!(code, 0, "{args:?}: {err}");
    out
}

/// The run's stdout as JSON; it must succeed.
fn json(args: &[&str]) -> Value {
    let out = ok(args);
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("{args:?}: {e}\n{out}"))
}

/// The numbers of a printed line, in order (`2.97316410`, `-0.6`, `1e-3`; a `°` or `%`
/// after a number is fine).
fn numbers(line: &str) -> Vec<f64> {
    line.split(|c: char| c.is_whitespace() || c == '(' || c == ')' || c == ',')
        .filter_map(|w| {
            w.trim_end_matches(['°', '%', 'i'])
                .trim_start_matches('+')
                .parse::<f64>()
                .ok()
        })
        .collect()
}

/// The first line of `text` that starts (after spaces) with `prefix`.
fn line<'a>(text: &'a str, prefix: &str) -> &'a str {
    text.lines()
        .find(|l| l.trim_start().starts_with(prefix))
        .unwrap_or_else(|| panic!("no line starting with {prefix:?} in\n{text}"))
}

#[test]
fn freq_unit_prints_the_modes_table_in_hz_and_rpm() {
    let rad = ok(&["modes", "models/overcentre.toml"]);
    let hz = ok(&["modes", "models/overcentre.toml", "--freq-unit", "Hz"]);
    let rpm = ok(&["modes", "models/overcentre.toml", "--freq-unit", "rpm"]);
    assert!(line(&rad, "mode").contains("ω_n [rad/s]"), "{rad}");
    assert!(line(&hz, "mode").contains("f_n [Hz]"), "{hz}");
    assert!(line(&rpm, "mode").contains("f_d [rpm]"), "{rpm}");
    // mode 1: ω_n, ω_d (8 decimals), f [Hz], ζ, λ
    let r = numbers(line(&rad, "1 "));
    let h = numbers(line(&hz, "1 "));
    let p = numbers(line(&rpm, "1 "));
    for k in [1, 2] {
        // each printed to 8 decimals: the rad/s value's rounding scaled, plus the unit's
        assert!(
            (h[k] - r[k] / TAU).abs() < 1e-8,
            "{} Hz vs {} rad/s",
            h[k],
            r[k]
        );
        assert!(
            (p[k] - r[k] * 60.0 / TAU).abs() < 6e-8,
            "{} rpm vs {} rad/s",
            p[k],
            r[k]
        );
    }
    // the companion column is f [Hz], or ω_n [rad/s] in a table in Hz (no column repeats
    // its neighbour); ζ and the eigenvalue (1/s) do not change
    assert!(line(&hz, "mode").contains("ω_n [rad/s]"), "{hz}");
    assert!((h[3] - r[1]).abs() < 1e-6, "{} vs {}", h[3], r[1]);
    assert_eq!(p[3], r[3]);
    assert_eq!(h[4..], r[4..]);
    assert_eq!(p[4..], r[4..]);
    // the JSON stays in rad/s
    let j = json(&[
        "modes",
        "models/overcentre.toml",
        "--freq-unit",
        "Hz",
        "--json",
    ]);
    let w = j["modes"][0]["omega_n_rad_s"].as_f64().unwrap();
    assert!((w - r[1]).abs() < 1e-8, "{w}");
    // an unknown unit is a usage error naming the choices
    let (code, _, err) = detune(&["modes", "models/overcentre.toml", "--freq-unit", "kHz"]);
    assert_eq!(code, 2);
    assert!(err.contains("rad/s, Hz or rpm"), "{err}");
}

#[test]
fn freq_unit_rescales_the_frf_table_and_plot_but_not_the_csv() {
    let dir = tempfile::tempdir().unwrap();
    let (csv_rad, csv_hz) = (dir.path().join("rad.csv"), dir.path().join("hz.csv"));
    let svg = dir.path().join("hz.svg");
    let grid = [
        "frf",
        "models/overcentre.toml",
        "--set",
        "F0=0.1",
        "--param",
        "omega",
        "--from",
        "1",
        "--to",
        "4",
        "--step",
        "1",
        "--response",
        "bar1.theta",
    ];
    let table = ok(&[&grid[..], &["--freq-unit", "Hz"]].concat());
    // (in Hz the axis is ω/2π: "omega [Hz]" would read as an angular frequency)
    assert!(table.contains("omega/2π [Hz]"), "{table}");
    let rows: Vec<Vec<f64>> = table.lines().skip(1).map(numbers).collect();
    for (k, r) in rows.iter().enumerate() {
        let w = (k + 1) as f64;
        assert!((r[0] - w / TAU).abs() < 5e-6, "{} Hz for {w} rad/s", r[0]);
    }
    ok(&[&grid[..], &["-o", csv_rad.to_str().unwrap()]].concat());
    ok(&[
        &grid[..],
        &[
            "--freq-unit",
            "Hz",
            "-o",
            csv_hz.to_str().unwrap(),
            "--plot",
            svg.to_str().unwrap(),
        ],
    ]
    .concat());
    assert_eq!(
        std::fs::read_to_string(&csv_rad).unwrap(),
        std::fs::read_to_string(&csv_hz).unwrap()
    );
    // the plot's axis and lines in Hz: ω_n = |λ| (2.9732 rad/s) at 0.4732 Hz
    let text = std::fs::read_to_string(&svg).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    let texts: Vec<&str> = doc
        .descendants()
        .filter(|n| n.has_tag_name("text"))
        .filter_map(|n| n.text())
        .map(str::trim)
        .collect();
    assert!(texts.contains(&"omega/2π [Hz]"), "{texts:?}");
    assert!(!texts.iter().any(|t| t.contains("rad/s")), "{texts:?}");
    // (issue 10, point 5: a natural frequency in Hz is f_n, not ω_n)
    assert!(texts.contains(&"f_n = |λ|/2π = 0.4732 Hz"), "{texts:?}");
    assert!(!texts.iter().any(|t| t.contains("ω_n")), "{texts:?}");
}

/// The plot method on its own: x, vertical lines and marks rescaled, numbers in rad/s
/// in the labels rewritten with their decimals.
#[test]
fn a_line_plot_is_redrawn_in_another_frequency_unit() {
    use detune::output::plot::{LinePlot, Note, Series, Style};
    use detune::output::units::FreqUnit;
    let plot = LinePlot {
        title: "x: response".into(),
        x_label: "omega [rad/s]".into(),
        y_label: "x amplitude [m]".into(),
        series: vec![Series::new(
            "peak 6.2832 rad/s",
            vec![TAU, 2.0 * TAU],
            vec![1.0, 2.0],
            Style::Markers,
        )],
        vertical: vec![(TAU, "undamped ω_n = 6.2832 rad/s".into())],
        marks: vec![(3.0 * TAU, "1P (18.85 rad/s)".into())],
        notes: vec![Note {
            x: 2.0 * TAU,
            y: 2.0,
            text: "peak 12.5664 rad/s".into(),
        }],
        caption: "at 6.2832 rad/s".into(),
        ..Default::default()
    }
    .in_frequency_unit(FreqUnit::Rpm);
    // the notes (peaks, folds, jumps) and the caption move with the axis
    assert!((plot.notes[0].x - 120.0).abs() < 1e-12);
    assert_eq!(plot.notes[0].text, "peak 120.0003 rpm");
    assert_eq!(plot.caption, "at 60.0001 rpm");
    assert_eq!(plot.x_label, "omega/2π [rpm]");
    assert!((plot.series[0].x[1] - 120.0).abs() < 1e-12);
    assert_eq!(plot.series[0].y, vec![1.0, 2.0]);
    // (the label's rounded 6.2832 rad/s converted: 60.0001 rpm)
    assert_eq!(plot.series[0].label, "peak 60.0001 rpm");
    assert!((plot.vertical[0].0 - 60.0).abs() < 1e-12);
    assert_eq!(plot.vertical[0].1, "undamped f_n = 60.0001 rpm");
    assert!((plot.marks[0].0 - 180.0).abs() < 1e-12);
    assert_eq!(plot.marks[0].1, "1P (180.00 rpm)");
}

/// `<value> rad (<degrees>°)` on every angle line of `text`: the degrees are the
/// radians converted (to the printed decimals); returns how many were checked.
fn degrees_agree(text: &str) -> usize {
    let mut n = 0;
    for l in text.lines() {
        let mut rest = l;
        while let Some(at) = rest.find(" rad (") {
            let before = &rest[..at];
            let rad: f64 = before
                .trim_end()
                .rsplit(|c: char| c.is_whitespace() || c == '=')
                .next()
                .unwrap()
                .parse()
                .unwrap_or_else(|_| panic!("{l}"));
            let after = &rest[at + " rad (".len()..];
            let deg: f64 = after.split('°').next().unwrap().parse().unwrap();
            assert!(
                (deg - rad.to_degrees()).abs() < 1e-5,
                "{deg}° for {rad} rad in {l}"
            );
            n += 1;
            rest = &after[1..];
        }
    }
    n
}

#[test]
fn angles_are_printed_in_degrees_beside_radians() {
    // overcentre: two angles per pose; the sliding block of the sdof model has one
    // (its locked θ) and lengths, which get none
    let m = "models/overcentre.toml";
    // check: the parameter theta1_0 (declared in rad) and the two angle coordinates
    assert_eq!(degrees_agree(&ok(&["check", m])), 3);
    assert_eq!(degrees_agree(&ok(&["equilibrium", m])), 2);
    assert!(degrees_agree(&ok(&["equilibrium", m, "--all"])) >= 4);
    assert_eq!(degrees_agree(&ok(&["modes", m])), 2);
    let cont = ok(&[
        "continue", m, "--param", "Fs", "--from", "-10", "--to", "30",
    ]);
    assert_eq!(degrees_agree(&cont), 4, "{cont}");
    assert!(cont.contains("fold at Fs = "), "{cont}");
    assert!(line(&cont, "fold").contains(" N: bar1.x = "), "{cont}");
    let sdof = ok(&["equilibrium", "tests/data/sdof.toml"]);
    assert!(line(&sdof, "block.x").trim_end().ends_with(" m"), "{sdof}");
    assert_eq!(degrees_agree(&sdof), 1);
}

/// Every key of `object` that holds a number has a unit in `units`.
fn every_number_has_a_unit(object: &Value, units: &Value, what: &str) {
    for (k, v) in object.as_object().unwrap() {
        if v.is_number() {
            assert!(units[k].is_string(), "{what}: no unit for `{k}` in {units}");
        }
    }
}

#[test]
fn every_json_document_has_a_units_map() {
    let m = "models/overcentre.toml";
    // equilibrium (one and all): the coordinates and the numbers
    for extra in [&[][..], &["--all"][..]] {
        let j = json(&[&["equilibrium", m, "--json"], extra].concat());
        let u = &j["units"];
        assert_eq!(u["bar1.theta"], "rad");
        assert_eq!(u["bar2.x"], "m");
        assert_eq!(u["undamped_omega2"], "rad^2/s^2");
        assert!(u["residual"].is_string());
    }
    // continue: the parameter in its unit
    let j = json(&[
        "continue", m, "--param", "Fs", "--from", "-10", "--to", "30", "--json",
    ]);
    assert_eq!(j["units"]["Fs"], "N");
    assert_eq!(j["units"]["value"], "N");
    assert_eq!(j["units"]["bar1.theta"], "rad");
    // modes: the mode keys
    let j = json(&["modes", m, "--json"]);
    every_number_has_a_unit(&j["modes"][0], &j["units"], "modes");
    assert_eq!(j["units"]["omega_n_rad_s"], "rad/s");
    assert_eq!(j["units"]["freq_hz"], "Hz");
    assert_eq!(j["units"]["eigenvalue"], "1/s");
    // modes --param: the parameter and the CSV's columns
    let j = json(&[
        "modes",
        "models/inceptor.toml",
        "--param",
        "k_t",
        "--from",
        "200",
        "--to",
        "3000",
        "--points",
        "3",
        "--json",
    ]);
    assert_eq!(j["units"]["k_t"], "N*m/rad");
    assert_eq!(j["units"]["in-phase.omega_n_rad_s"], "rad/s");
    assert_eq!(j["units"]["in-phase.mac"], "1");
    // frf: every column of the CSV (a point's keys)
    let j = json(&[
        "frf",
        m,
        "--set",
        "F0=0.1",
        "--param",
        "omega",
        "--from",
        "1",
        "--to",
        "3",
        "--step",
        "1",
        "--response",
        "bar1.theta",
        "--response",
        "bar2.x",
        "--json",
    ]);
    every_number_has_a_unit(&j["points"][0], &j["units"], "frf");
    assert_eq!(j["units"]["omega"], "rad/s");
    assert_eq!(j["units"]["bar1.theta_amplitude"], "rad");
    assert_eq!(j["units"]["bar2.x_amplitude"], "m");
    assert_eq!(j["units"]["bar1.theta_phase_deg"], "deg");
    // sweep: every column of the CSV, and the peaks' keys
    let j = json(&[
        "sweep",
        m,
        "--set",
        "F0=0.1",
        "--param",
        "omega",
        "--from",
        "2",
        "--to",
        "3",
        "--step",
        "1",
        "--response",
        "bar1.theta",
        "--json",
    ]);
    every_number_has_a_unit(&j["points"][0], &j["units"], "sweep");
    assert_eq!(j["units"]["bar1.theta_mean"], "rad");
    assert_eq!(j["units"]["bar1.theta_thd"], "1");
    assert_eq!(j["units"]["uncertainty"], "rad/s");
    // simulate: every column of the CSV
    let dir = tempfile::tempdir().unwrap();
    let (csv, sum) = (dir.path().join("s.csv"), dir.path().join("s.json"));
    ok(&[
        "simulate",
        m,
        "--t-end",
        "0.1",
        "--velocities",
        "--response",
        "spring.tension",
        "-o",
        csv.to_str().unwrap(),
        "--json",
        sum.to_str().unwrap(),
    ]);
    let j: Value = serde_json::from_str(&std::fs::read_to_string(&sum).unwrap()).unwrap();
    assert_eq!(j["complete"], true);
    let header = std::fs::read_to_string(&csv).unwrap();
    for col in header.lines().next().unwrap().split(',') {
        assert!(j["units"][col].is_string(), "simulate: no unit for {col}");
    }
    assert_eq!(j["units"]["bar1.theta_dot"], "rad/s");
    assert_eq!(j["units"]["bar2.x_dot"], "m/s");
    assert_eq!(j["units"]["spring.tension"], "N");
    // margins and tune: the rows' keys
    let inc = "models/inceptor.toml";
    let (_, out, err) = detune(&["margins", inc, "--environment", "UH-60", "--json"]);
    let j: Value = serde_json::from_str(&out).unwrap_or_else(|e| panic!("{e}: {err}"));
    every_number_has_a_unit(&j["rows"][0], &j["units"], "margins");
    let j = json(&[
        "tune",
        inc,
        "--environment",
        "UH-60",
        "--vary",
        "k_fs=50%..200%",
        "--json",
    ]);
    assert_eq!(j["units"]["k_fs"], "N/m");
    every_number_has_a_unit(&j["designs"][0], &j["units"], "tune");
    every_number_has_a_unit(&j["designs"][0]["modes"], &j["units"], "tune modes");
    // sensitivity (its map predates this issue)
    let j = json(&["sensitivity", inc, "--vary", "k_fs=±10%", "--json"]);
    assert_eq!(j["units"]["omega_n_rad_s"], "rad/s");
}

/// `frf --per-unit` on a linear single-degree-of-freedom oscillator (m = 2 kg, k = 800
/// N/m, c = 6 N·s/m): the receptance |H| = 1/sqrt((k − m ω²)² + (c ω)²) m/N, lagging by
/// atan2(c ω, k − m ω²); the CSV columns unchanged; the amplitude at F0 = 3 N is 3 |H|.
#[test]
fn frf_per_unit_is_the_closed_form_receptance() {
    let (m, k, c) = (2.0, 800.0, 6.0);
    let grid = [
        "frf",
        "tests/data/sdof.toml",
        "--param",
        "omega",
        "--from",
        "2",
        "--to",
        "40",
        "--step",
        "2",
        "--response",
        "block.x",
        "--json",
    ];
    let per_unit = json(&[&grid[..], &["--per-unit"]].concat());
    let at_3n = json(&[&grid[..], &["--set", "F0=3"]].concat());
    let points = per_unit["points"].as_array().unwrap();
    assert_eq!(points.len(), 20);
    for (p, q) in points.iter().zip(at_3n["points"].as_array().unwrap()) {
        let w = p["omega"].as_f64().unwrap();
        let (re, im) = (k - m * w * w, c * w);
        let h = 1.0 / re.hypot(im);
        let amp = p["block.x_amplitude"].as_f64().unwrap();
        assert!(
            (amp - h).abs() < 1e-10 * h,
            "ω = {w}: {amp} m/N, closed form {h}"
        );
        let lag = im.atan2(re).to_degrees();
        let phase = p["block.x_phase_deg"].as_f64().unwrap();
        assert!(
            (phase + lag).abs() < 1e-8,
            "ω = {w}: {phase}°, closed form −{lag}°"
        );
        let amp3 = q["block.x_amplitude"].as_f64().unwrap();
        assert!(
            (amp3 - 3.0 * h).abs() < 1e-10 * h,
            "ω = {w}: {amp3} m at 3 N"
        );
    }
    // the keys are the CSV's, the amplitude's unit is per newton
    assert_eq!(per_unit["units"]["block.x_amplitude"], "m/N");
    assert_eq!(at_3n["units"]["block.x_amplitude"], "m");
    let table = ok(&[&grid[..grid.len() - 1], &["--per-unit"]].concat());
    assert!(table.contains("block.x amp [m/N]"), "{table}");
}

/// `frf --per-unit` of the inceptor on its shaker table, every coordinate: the two
/// resonances are peaks of the stick's angle; a coordinate that follows the table rigidly
/// (|H| = 1 m/m to the last digit: crank.x, gearbox.x) or that the forcing does not move
/// (stick.z, round-off of 1e-16 m/m) has no peak.
#[test]
fn frf_peaks_are_not_read_from_flat_or_round_off_curves() {
    let j = json(&[
        "frf",
        "models/inceptor.toml",
        "--param",
        "omega",
        "--from",
        "5",
        "--to",
        "40",
        "--step",
        "1",
        "--per-unit",
        "--json",
    ]);
    let peaks = j["peaks"].as_array().unwrap();
    let of = |name: &str| -> Vec<f64> {
        peaks
            .iter()
            .filter(|p| p["response"] == name)
            .map(|p| p["omega"].as_f64().unwrap())
            .collect()
    };
    let phi = of("stick.phi");
    assert_eq!(phi.len(), 2, "{phi:?}");
    assert!(
        (phi[0] - 13.2015).abs() < 1e-3 && (phi[1] - 26.7021).abs() < 1e-3,
        "{phi:?}"
    );
    for flat in ["crank.x", "gearbox.x", "stick.z"] {
        assert!(of(flat).is_empty(), "{flat}: {:?}", of(flat));
    }
}

/// The overcentre with a downward force mr·spin² on bar 1 (spin in rad/s): a parameter
/// that is a frequency, whose fold is where mr·spin² equals the fold load of `Fs`,
/// 3.4414126719 N (the `continue --param Fs` snapshot), so spin = √3.4414126719 rad/s.
fn spinning_overcentre(dir: &std::path::Path) -> String {
    let text = std::fs::read_to_string("models/overcentre.toml").unwrap();
    let text = text
        .replacen(
            "omega = {",
            "spin = { value = 0, unit = \"rad/s\" }\nmr = { value = 1, unit = \"kg*m\" }\nomega = {",
            1,
        )
        .replacen("\"Fs + F0*sin", "\"Fs - mr*spin^2 + F0*sin", 1);
    assert!(text.contains("mr*spin^2"));
    let path = dir.join("spin.toml");
    std::fs::write(&path, text).unwrap();
    path.to_string_lossy().into_owned()
}

#[test]
fn freq_unit_prints_and_plots_a_continued_frequency() {
    let dir = tempfile::tempdir().unwrap();
    let model = spinning_overcentre(dir.path());
    let fold = 3.4414126719f64.sqrt(); // rad/s
    let base = [
        "continue", &model, "--param", "spin", "--from", "0", "--to", "3", "--step", "0.05",
    ];
    // rad/s by default, as before
    let rad = ok(&base);
    let f = numbers(line(&rad, "fold at spin ="))[0];
    assert!((f - fold).abs() < 1e-8, "{rad}");
    assert!(line(&rad, "fold at").starts_with("fold at spin = 1.8551044908 rad/s:"));
    for (unit, scale) in [("Hz", 1.0 / TAU), ("rpm", 60.0 / TAU)] {
        let svg = dir.path().join(format!("{unit}.svg"));
        let csv = dir.path().join(format!("{unit}.csv"));
        let args = [
            &base[..],
            &[
                "--freq-unit",
                unit,
                "--plot",
                svg.to_str().unwrap(),
                "-o",
                csv.to_str().unwrap(),
            ],
        ]
        .concat();
        let out = ok(&args);
        // in Hz and rpm the frequency is spin/2π (cycles), in the lines and on the axis
        let fl = line(&out, "fold at spin/2π =");
        assert!(fl.contains(&format!(" {unit}: ")), "{fl}");
        assert!((numbers(fl)[0] - fold * scale).abs() < 1e-8, "{fl}");
        let first = line(&out, "83 points from spin/2π = 0.000000");
        assert!(
            first.contains(&format!(
                "turned at the fold at spin/2π = {:.6} {unit}",
                fold * scale
            )),
            "{first}"
        );
        // the plot's axis and fold label in the unit; the CSV stays in rad/s
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(
            text.contains(&format!("spin/2π [{unit}]")),
            "axis in {unit}"
        );
        assert!(!text.contains("rad/s"));
        let (h, rows) = common::read_csv(&csv);
        assert_eq!(h[0], "spin");
        let top = rows.iter().map(|r| r[0]).fold(0.0, f64::max);
        assert!((top - fold).abs() < 1e-3, "CSV in rad/s: {top}");
    }
    // a parameter that is no frequency: shown as it is, with a note
    let (code, out, err) = detune(&[
        "continue",
        &model,
        "--param",
        "Fs",
        "--from",
        "0",
        "--to",
        "5",
        "--freq-unit",
        "Hz",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains(" points from Fs = 0 N to 5 N"), "{out}");
    assert!(
        err.contains("--freq-unit Hz changes frequencies only; Fs is not one"),
        "{err}"
    );
}

#[test]
fn the_sweeps_well_summary_follows_freq_unit() {
    // the F0 = 10 N overcentre from its upper well snaps into the lower one up to 4 rad/s
    // (tests/wells.rs); here 3.5..4 rad/s of 3.5..4.5
    let base = [
        "sweep",
        "models/overcentre.toml",
        "--set",
        "F0=10",
        "--param",
        "omega",
        "--from",
        "3.5",
        "--to",
        "4.5",
        "--step",
        "0.25",
        "--response",
        "bar1.theta",
    ];
    let rad = ok(&base);
    assert!(
        rad.contains("at 3 of 5 frequencies (independent): 3.5–4 rad/s in well"),
        "{rad}"
    );
    let hz = ok(&[&base[..], &["--freq-unit", "Hz"]].concat());
    let expect = format!(
        "at 3 of 5 frequencies (independent): {:.6}–{:.6} Hz in well",
        3.5 / TAU,
        4.0 / TAU
    );
    assert!(hz.contains(&expect), "{hz}");
    assert!(!hz.contains("rad/s in well"), "{hz}");
}

/// Issue 10, point 4: `check` echoes each parameter's unit: a frequency in rad/s (not 1/s)
/// whether declared in Hz or rpm or written as "2 Hz" undeclared, an angle in rad with its
/// degrees (not 1) whether declared in deg or written as "45 deg", an angular stiffness in
/// lbf·in/deg as N·m/rad; a value declared in a unit other than SI beside, in it. The
/// SI values are the closed forms (2 Hz = 120 rpm = 4π rad/s, 45° = π/4 rad, 1 lbf·in/deg
/// = 4.4482216152605 · 0.0254 · 180/π N·m/rad). The messages about angles name rad and
/// N·m/rad too.
#[test]
fn check_shows_each_parameters_angular_unit() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("units.toml");
    let params = r#"[parameters]
w = { value = "120 rpm", unit = "rpm" }
f = { value = "2 Hz", unit = "Hz" }
v = "2 Hz"
u = "45 deg"
d = { value = "30 deg", unit = "deg" }
ks = { value = "3 lbf*in/deg", unit = "lbf*in/deg" }
r = { value = "1 mm", unit = "mm" }
"#;
    // (the compound pendulum's bodies and its own parameters, k = 12 N*m/rad among them)
    let torsion = std::fs::read_to_string(common::data("torsion_pendulum.toml")).unwrap();
    assert!(torsion.contains("[parameters]\n") && torsion.contains("unit = \"N*m/rad\""));
    std::fs::write(&file, torsion.replacen("[parameters]\n", params, 1)).unwrap();
    let out = ok(&["check", file.to_str().unwrap()]);
    let line = |name: &str| -> &str {
        out.lines()
            .find(|l| l.trim_start().starts_with(&format!("{name} ")))
            .unwrap_or_else(|| panic!("no {name} in\n{out}"))
    };
    let four_pi = 2.0 * TAU;
    let ks = 3.0 * 4.4482216152605 * 0.0254 * 180.0 / std::f64::consts::PI;
    for (name, value, tail) in [
        ("w", four_pi, "rad/s (120 rpm)"),
        ("f", four_pi, "rad/s (2 Hz)"),
        ("v", four_pi, "rad/s"),
        ("u", std::f64::consts::FRAC_PI_4, "rad (45.000000°)"),
        ("d", std::f64::consts::PI / 6.0, "rad (30.000000°)"),
        ("ks", ks, "N·m/rad (3 lbf*in/deg)"),
        ("r", 0.001, "m (1 mm)"),
        ("k", 12.0, "N*m/rad"),
    ] {
        let l = line(name);
        let shown: f64 = l
            .split('=')
            .nth(1)
            .unwrap()
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!((shown - value).abs() <= 1e-12 * value, "{l}: want {value}");
        assert!(
            l.trim_end().ends_with(tail),
            "{l}: want it to end with {tail}"
        );
    }
    assert!(!out.contains(" 1/s"), "{out}");
    // the messages: a plain number declared in deg is SI, rad; a torsional stiffness and
    // a free angle of the wrong dimension are named in N·m/rad and rad
    let bad = |text: &str| -> String {
        std::fs::write(&file, text).unwrap();
        let (code, _, err) = detune(&["check", file.to_str().unwrap()]);
        assert_ne!(code, 0, "{text}");
        err
    };
    let err = bad("[parameters]\na = { value = 0.5, unit = \"deg\" }\n");
    assert!(err.contains("which detune reads as SI (rad)"), "{err}");
    let err = bad("[parameters]\na = { value = \"3 m\", unit = \"deg\" }\n");
    assert!(
        err.contains("`a` is declared in deg (rad) but its value is in m"),
        "{err}"
    );
    assert!(torsion.contains("stiffness = \"k\"") && torsion.contains("free_angle = \"-pi/2\""));
    let err = bad(&torsion.replace("stiffness = \"k\"", "stiffness = \"3 N\""));
    assert!(
        err.contains("the torsional stiffness is a quantity in N·m/rad; this value is in N"),
        "{err}"
    );
    let err = bad(&torsion.replace("free_angle = \"-pi/2\"", "free_angle = \"2 m\""));
    assert!(
        err.contains("the free angle is a quantity in rad; this value is in m"),
        "{err}"
    );
}

/// The texts of an SVG file.
fn svg_texts(path: &std::path::Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    doc.descendants()
        .filter(|n| n.has_tag_name("text"))
        .filter_map(|n| n.text())
        .map(|t| t.trim().to_string())
        .collect()
}

/// Issue 10, point 5: a sweep's peak markers are "refined peaks" only when `--refine`
/// refined them, "peaks" (the grid's maxima) otherwise; in Hz the linear natural frequency
/// is labelled f_n (tests/data/sdof.toml: ω_n = √(k/m) = 20 rad/s, f_n = 10/π Hz =
/// 3.1831 Hz).
#[test]
fn sweep_peaks_are_refined_only_when_refined_and_f_n_is_in_hz() {
    let dir = tempfile::tempdir().unwrap();
    let sdof = common::data("sdof.toml");
    let run = |name: &str, extra: &[&str]| -> Vec<String> {
        let svg = dir.path().join(name);
        let mut args = vec![
            "sweep",
            &sdof,
            "--set",
            "F0=1",
            "--param",
            "omega",
            "--from",
            "15",
            "--to",
            "25",
            "--step",
            "1",
            "--response",
            "block.x",
            "--plot",
            svg.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        ok(&args);
        svg_texts(&svg)
    };
    let plain = run("plain.svg", &[]);
    assert!(plain.iter().any(|t| t == "peaks"), "{plain:?}");
    assert!(!plain.iter().any(|t| t.contains("refined")), "{plain:?}");
    assert!(
        plain.iter().any(|t| t == "linear ω_n = 20.0000 rad/s"),
        "{plain:?}"
    );
    let refined = run("refined.svg", &["--refine", "0.01", "--freq-unit", "Hz"]);
    assert!(refined.iter().any(|t| t == "refined peaks"), "{refined:?}");
    assert_eq!(format!("{:.4}", 10.0 / std::f64::consts::PI), "3.1831");
    assert!(
        refined.iter().any(|t| t == "linear f_n = 3.1831 Hz"),
        "{refined:?}"
    );
    assert!(!refined.iter().any(|t| t.contains("ω_n")), "{refined:?}");
}

/// Issue 10, point 4: `backbone --freq-unit Hz` prints its table and draws its axis in Hz
/// (f = ω/2π; the Duffing oscillator of tests/data/duffing.toml has the linear ω_n = 2
/// rad/s, f_n = 1/π Hz), while its CSV and JSON stay in rad/s, identical to a run in rad/s.
#[test]
fn backbone_shows_its_frequencies_in_the_freq_unit() {
    let dir = tempfile::tempdir().unwrap();
    let duffing = common::data("duffing.toml");
    let base = [
        "backbone",
        duffing.as_str(),
        "--of-mode",
        "1",
        "--to-amplitude",
        "100 mm",
    ];
    let csv_rad = dir.path().join("rad.csv");
    let csv_hz = dir.path().join("hz.csv");
    let svg = dir.path().join("hz.svg");
    ok(&[&base[..], &["-o", csv_rad.to_str().unwrap()]].concat());
    ok(&[
        &base[..],
        &[
            "--freq-unit",
            "Hz",
            "-o",
            csv_hz.to_str().unwrap(),
            "--plot",
            svg.to_str().unwrap(),
        ],
    ]
    .concat());
    assert_eq!(
        std::fs::read_to_string(&csv_rad).unwrap(),
        std::fs::read_to_string(&csv_hz).unwrap()
    );
    let j = json(&[&base[..], &["--freq-unit", "Hz", "--json"]].concat());
    assert!((j["omega_linear"].as_f64().unwrap() - 2.0).abs() < 1e-9);
    assert_eq!(j["units"]["omega"], "rad/s");
    let texts = svg_texts(&svg);
    assert!(texts.iter().any(|t| t == "f [Hz]"), "{texts:?}");
    assert!(
        texts.iter().any(|t| t == "linear f_n = 0.3183 Hz"),
        "{texts:?}"
    );
    assert!(!texts.iter().any(|t| t.contains("rad/s")), "{texts:?}");
    // the printed table: each row's frequency is the JSON's ω/2π
    let out = ok(&[&base[..], &["--freq-unit", "Hz"]].concat());
    assert!(
        out.lines()
            .next()
            .unwrap()
            .contains("linear f_n = 0.31830989 Hz (2.00000000 rad/s)"),
        "{out}"
    );
    let head = out.lines().nth(1).unwrap();
    assert!(head.contains("f [Hz]") && !head.contains("rad/s"), "{head}");
    let points = j["points"].as_array().unwrap();
    let rows: Vec<&str> = out.lines().skip(2).collect();
    assert_eq!(rows.len(), points.len());
    for (row, p) in rows.iter().zip(points) {
        let f: f64 = row.split_whitespace().nth(1).unwrap().parse().unwrap();
        let want = p["omega"].as_f64().unwrap() / TAU;
        assert!((f - want).abs() < 1e-9, "{row}: want {want}");
    }
}

/// In Hz or rpm a natural frequency is f_n, a damped one f_d (re-audit of issues 10/11):
/// the tables of `modes`, `margins` and `sensitivity` say so (ω in rad/s). The block of
/// tests/data/sdof.toml: ω_n = √(k/m) = 20 rad/s, f_n = 10/π Hz.
#[test]
fn tables_in_hz_say_f_n() {
    let hz = ok(&["modes", "tests/data/sdof.toml", "--freq-unit", "Hz"]);
    let head = line(&hz, "mode");
    assert!(
        head.contains("f_n [Hz]") && head.contains("f_d [Hz]"),
        "{head}"
    );
    assert!(
        head.contains("ω_n [rad/s]") && !head.contains("ω_n [Hz]"),
        "{head}"
    );
    let r = numbers(line(&hz, "1 "));
    assert!((r[1] - 20.0 / TAU).abs() < 1e-8, "{r:?}");
    assert!((r[3] - 20.0).abs() < 1e-6, "{r:?}");
    let rad = ok(&["modes", "tests/data/sdof.toml"]);
    assert!(line(&rad, "mode").contains("ω_d [rad/s]"), "{rad}");

    let m = ok(&[
        "margins",
        "tests/data/sdof.toml",
        "--environment",
        "UH-60",
        "--freq-unit",
        "rpm",
    ]);
    let head = line(&m, "mode ");
    assert!(
        head.contains("f_n [rpm]") && head.contains("f [rpm]") && !head.contains("ω_n [rpm]"),
        "{head}"
    );
    let r = numbers(line(&m, "mode 1 "));
    assert!((r[1] - 20.0 * 60.0 / TAU).abs() < 1e-3, "{r:?}");

    let s = ok(&[
        "sensitivity",
        "tests/data/sdof.toml",
        "--vary",
        "k=±10%",
        "--freq-unit",
        "Hz",
    ]);
    let first = line(&s, "mode 1:");
    assert!(first.starts_with("mode 1: f_n = 3.183099 Hz"), "{first}");
    assert!(first.contains("undamped f = 3.183099 Hz"), "{first}");
    let head = line(&s, "case");
    assert!(
        head.contains("f_n [Hz]") && head.contains("undamped f [Hz]"),
        "{head}"
    );
}

/// `modes --param --freq-unit Hz --plot`: the curves, their legend, the axis and the
/// crossing's marker and note all in f_n [Hz]. Two uncoupled pendulums (kc = 0) of
/// tests/data/veering_pendulums.toml cross at l2 = l1 = 1 m, at ω = √(m g l/(m l² + I)) =
/// √(9.81/1.001) rad/s; in rad/s the note would sit far above the Hz axis, off the plot.
#[test]
fn the_tracking_plot_in_hz_says_f_n_and_places_its_crossing() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("m.svg");
    let out = ok(&[
        "modes",
        "tests/data/veering_pendulums.toml",
        "--set",
        "kc=0",
        "--param",
        "l2",
        "--from",
        "0.81",
        "--to",
        "1.26",
        "--points",
        "10",
        "--freq-unit",
        "Hz",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    let f = (9.81f64 / 1.001).sqrt() / TAU;
    let crossing = line(&out, "pendulum 1 swings and pendulum 2 swings at l2");
    let x = numbers(crossing.split("f_n =").nth(1).unwrap());
    assert!((x[0] - f).abs() < 2e-4, "{crossing} vs {f}");
    assert!(line(&out, "modes against").contains("f_n in Hz"), "{out}");
    let texts = svg_texts(&svg);
    for want in [
        "f_n [Hz]",
        "pendulum 1 swings f_n [Hz]",
        "pendulum 2 swings f_n [Hz]",
        "crossing l2 = 1 m",
    ] {
        assert!(texts.iter().any(|t| t == want), "no {want:?} in {texts:?}");
    }
    assert!(!texts.iter().any(|t| t.contains("ω_n")), "{texts:?}");
}

/// Issue 10/13 leftovers (presentation): a plot's title names what its axis shows. An
/// nfr panel "… amplitude against omega" over an `omega/2π [Hz]` axis says `omega/2π`;
/// `against ω` over `f [Hz]` says `against f`; a name that only begins with the
/// parameter's (`omega_r`) is left alone.
#[test]
fn a_title_names_the_quantity_its_axis_shows() {
    use detune::output::plot::LinePlot;
    use detune::output::units::FreqUnit;
    let plot = |title: &str, x: &str| LinePlot {
        title: title.into(),
        x_label: x.into(),
        ..Default::default()
    };
    let p = plot("bar1.theta amplitude against omega", "omega [rad/s]")
        .in_frequency_unit(FreqUnit::Hertz);
    assert_eq!(p.x_label, "omega/2π [Hz]");
    assert_eq!(p.title, "bar1.theta amplitude against omega/2π");
    let p = plot("natural frequencies against ω", "ω [rad/s]").in_frequency_unit(FreqUnit::Rpm);
    assert_eq!(p.x_label, "f [rpm]");
    assert_eq!(p.title, "natural frequencies against f");
    let p = plot("x against omega_r, at omega", "omega [rad/s]").in_frequency_unit(FreqUnit::Hertz);
    assert_eq!(p.title, "x against omega_r, at omega");
    // rad/s: unchanged
    let p = plot("x against omega", "omega [rad/s]").in_frequency_unit(FreqUnit::RadPerSecond);
    assert_eq!(p.title, "x against omega");
}

/// One format for a located value (the peak lines of frf, sweep and nfr): the value to
/// the digits its uncertainty supports (7 to 15 significant), the uncertainty to two,
/// each with its unit; an unrefined one says what its ± is.
#[test]
fn a_located_value_has_one_format() {
    use detune::output::units::located;
    assert_eq!(
        located(2.8284271247461903, 4.2e-8, "rad/s", None),
        "2.82842712 rad/s (± 4.2e-8 rad/s)"
    );
    assert_eq!(
        located(0.477464829275686, 0.0796, "Hz", Some("the grid's step")),
        "0.4774648 Hz (not refined: ± 0.080 Hz, the grid's step)"
    );
    assert_eq!(located(1371.07, 0.0, "N", None), "1371.070 N (± 0 N)");
}

/// `frf`'s peak lines in the shared format, and the uncertainty they give holds: the six
/// responses of the overcentre's one mode peak at one frequency, to within their stated
/// ± (the located maximum of a flat peak moves with the amplitudes' round-off, √(2δ/κ):
/// the half-bracket alone, 1.2e-10 rad/s, said less than the 1.3e-8 rad/s they differ).
#[test]
fn frf_peaks_agree_within_their_uncertainty() {
    let (code, _, err) = detune(&[
        "frf",
        "models/overcentre.toml",
        "--set",
        "F0=1",
        "--param",
        "omega",
        "--from",
        "1",
        "--to",
        "6",
        "--step",
        "0.5",
    ]);
    assert_eq!(code, 0, "{err}");
    let peaks: Vec<(f64, f64)> = err
        .lines()
        .filter(|l| l.starts_with("peak "))
        .map(|l| {
            assert!(
                l.contains(" rad/s (± ") && l.contains(" rad/s), amplitude "),
                "{l}"
            );
            let n = numbers(l.split_once(" = ").unwrap().1);
            (n[0], n[1])
        })
        .collect();
    assert_eq!(peaks.len(), 6, "{err}");
    for (w, u) in &peaks {
        assert!(*u < 1e-6, "{u}");
        for (v, t) in &peaks {
            assert!((w - v).abs() <= u + t, "{w} ± {u} vs {v} ± {t}");
        }
    }
}

/// A non-finite number with a unit is "not finite", as without one (it was "expected an
/// operator, found `deg`").
#[test]
fn a_non_finite_quantity_is_not_finite() {
    for (args, flag) in [
        (
            vec![
                "sweep",
                "models/overcentre.toml",
                "--param",
                "omega",
                "--from",
                "nan rad/s",
                "--to",
                "3",
                "--step",
                "0.5",
            ],
            "--from nan rad/s: not finite",
        ),
        (
            vec![
                "kinematics",
                "models/overcentre.toml",
                "--drive",
                "bar1.theta",
                "--from",
                "0",
                "--to",
                "-inf deg",
                "--step",
                "0.1",
            ],
            "--to -inf deg: not finite",
        ),
        (
            vec![
                "simulate",
                "models/overcentre.toml",
                "--t-end",
                "1e400 s",
                "-o",
                "never.csv",
            ],
            "--t-end 1e400 s: not finite",
        ),
    ] {
        let (code, out, err) = detune(&args);
        assert_eq!(code, 1, "{args:?}: {err}");
        assert!(err.contains(flag), "{args:?}: {err}");
        assert!(!err.contains("operator"), "{err}");
        assert!(out.is_empty());
    }
}

/// The same in an expression (`--set`, `--values`, a model file's value): `nan` and `inf`
/// read as names were "unknown parameter `nan`" alone and "expected an operator, found
/// `N`" with a unit; each is now "not finite", located.
#[test]
fn a_non_finite_value_in_an_expression_is_not_finite() {
    for (args, word) in [
        (
            vec!["modes", "models/overcentre.toml", "--set", "k=nan"],
            "`nan`",
        ),
        (
            vec!["modes", "models/overcentre.toml", "--set", "k=inf N/m"],
            "`inf`",
        ),
        (
            vec!["modes", "models/overcentre.toml", "--set", "k=-Infinity*2"],
            "`Infinity`",
        ),
        (
            vec![
                "sweep",
                "models/overcentre.toml",
                "--values",
                "F0=nan N",
                "--param",
                "omega",
                "--from",
                "1",
                "--to",
                "2",
                "--step",
                "0.5",
            ],
            "`nan`",
        ),
    ] {
        let (code, out, err) = detune(&args);
        assert_eq!(code, 1, "{args:?}: {err}");
        assert!(
            err.contains(&format!("{word} is not finite")),
            "{args:?}: {err}"
        );
        assert!(
            !err.contains("operator") && !err.contains("unknown parameter"),
            "{err}"
        );
        assert!(err.contains('^'), "not located: {err}");
        assert!(out.is_empty());
    }
}

/// In a model file's element expressions too (`mass = "nan"`, `stiffness = "k*inf"`): each
/// is "not finite" at its line and column (it was "unknown parameter `nan`").
#[test]
fn a_non_finite_value_in_a_model_file_is_not_finite() {
    let (code, _, err) = detune(&["check", "tests/data/non_finite_values.toml"]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("non_finite_values.toml:6:9: `nan` is not finite"),
        "{err}"
    );
    assert!(
        err.contains("non_finite_values.toml:22:16: `inf` is not finite"),
        "{err}"
    );
    assert!(!err.contains("unknown parameter"), "{err}");
}

/// A flag's value in a wrong dimension names the flag and what it takes, in the units it
/// may be given in (a frequency in rad/s, Hz or rpm, not "1/s"); a named parameter's or
/// coordinate's value names it.
#[test]
fn a_flag_value_in_a_wrong_dimension_says_what_the_flag_takes() {
    let refused = |args: &[&str], says: &str| {
        let (code, _, err) = detune(args);
        assert_eq!(code, 1, "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(
            !err.contains("1/s") && !err.contains("`a "),
            "{args:?}: {err}"
        );
    };
    let oc = "models/overcentre.toml";
    refused(
        &[
            "frf", oc, "--set", "F0=1", "--param", "omega", "--from", "3 kg", "--to", "2",
            "--step", "0.1",
        ],
        "--from 3 kg: --from takes a frequency (rad/s, Hz or rpm); the value given is in kg",
    );
    refused(
        &[
            "sweep", oc, "--param", "omega", "--from", "1", "--to", "2", "--step", "0.5 s",
        ],
        "--step 0.5 s: --step takes a frequency (rad/s, Hz or rpm); the value given is a time",
    );
    refused(
        &["simulate", oc, "--t-end", "2 Hz", "-o", "s.csv"],
        "--t-end 2 Hz: --t-end takes a time (s, ms or min); the value given is a frequency",
    );
    refused(
        &[
            "kinematics",
            oc,
            "--drive",
            "bar1.theta",
            "--from",
            "3 kg",
            "--to",
            "1",
            "--step",
            "0.1",
            "-o",
            "q.csv",
        ],
        "--from 3 kg: `bar1.theta` is an angle (rad or deg), the value given is in kg",
    );
}
