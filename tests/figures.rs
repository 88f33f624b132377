//! Figures fit for a design review (issue 10, point 5): every plot type rendered through
//! the CLI (and the report's two figures through the library) and checked structurally —
//! each legend sample is drawn with its curve's pen (stroke, width, dash pattern, marker),
//! axis descriptions carry units, no text is smaller than the style's minimum, curves
//! have float coordinates, a caption names the case; PNG output is a PNG of the asked
//! size; a bad extension is refused before any work.

use std::collections::BTreeMap;
mod common;
use common::detune;

use detune::output::style::MIN_TEXT;

/// What a figure's SVG holds, read back with an XML parser.
#[derive(Debug, Default)]
struct Svg {
    /// Every text with its font size.
    texts: Vec<(String, f64)>,
    /// Curves' pens by key: (stroke, width, dash), marker shape.
    curves: BTreeMap<String, (Vec<String>, Option<String>)>,
    legend: BTreeMap<String, (Vec<String>, Option<String>)>,
    /// Every coordinate of the curves' polylines.
    coordinates: Vec<f64>,
}

fn read(svg: &str) -> Svg {
    let doc = roxmltree::Document::parse(svg).expect("well-formed SVG");
    let mut out = Svg::default();
    for n in doc.descendants() {
        let class = n.attribute("class").unwrap_or("");
        let key = n.attribute("data-series").unwrap_or("").to_string();
        match n.tag_name().name() {
            "text" => {
                let size: f64 = n.attribute("font-size").unwrap().parse().unwrap();
                let text: String = n.text().unwrap_or("").trim().to_string();
                out.texts.push((text, size));
            }
            "polyline" if class == "curve" || class == "legend" => {
                let pen = ["stroke", "stroke-width", "stroke-dasharray"]
                    .iter()
                    .map(|a| n.attribute(*a).unwrap_or("").to_string())
                    .collect();
                let map = if class == "curve" {
                    for p in n.attribute("points").unwrap().split_whitespace() {
                        for c in p.split(',') {
                            out.coordinates.push(c.parse().unwrap());
                        }
                    }
                    &mut out.curves
                } else {
                    &mut out.legend
                };
                map.entry(key).or_insert((Vec::new(), None)).0 = pen;
            }
            "path" if class == "curve-marker" || class == "legend-marker" => {
                let shape = n.attribute("data-marker").map(String::from);
                let map = if class == "curve-marker" {
                    &mut out.curves
                } else {
                    &mut out.legend
                };
                map.entry(key).or_insert((Vec::new(), None)).1 = shape;
            }
            _ => {}
        }
    }
    out
}

/// The structural checks every figure passes; returns what was read.
fn check(path: &std::path::Path, min_curves: usize) -> Svg {
    let text = std::fs::read_to_string(path).unwrap();
    let svg = read(&text);
    // no text smaller than the set size
    for (t, size) in &svg.texts {
        assert!(*size >= MIN_TEXT - 1e-9, "`{t}` at {size} px < {MIN_TEXT}");
    }
    // axis descriptions (the label size, 19 px at the default width) carry units
    let labels: Vec<&String> = svg
        .texts
        .iter()
        .filter(|(_, s)| (*s - 19.0).abs() < 1e-9)
        .map(|(t, _)| t)
        .collect();
    assert!(!labels.is_empty(), "no axis description in {path:?}");
    for l in &labels {
        assert!(
            l.contains('[') && l.ends_with(']'),
            "axis `{l}` has no unit"
        );
    }
    // every curve drawn has a legend entry drawn in its pen
    assert!(
        svg.curves.len() >= min_curves,
        "{} curves in {path:?}",
        svg.curves.len()
    );
    for (key, pen) in &svg.curves {
        let Some(legend) = svg.legend.get(key) else {
            panic!("curve {key} has no legend sample")
        };
        if !pen.0.is_empty() {
            assert_eq!(
                pen.0, legend.0,
                "curve {key}: legend line drawn differently"
            );
        }
        assert_eq!(pen.1, legend.1, "curve {key}: legend marker differs");
    }
    // float coordinates: not a staircase of whole pixels
    assert!(
        svg.coordinates.iter().any(|c| c.fract().abs() > 1e-9),
        "all curve coordinates are whole pixels"
    );
    // a caption names the case
    assert!(
        svg.texts.iter().any(|(t, _)| t.starts_with("model ")),
        "no caption naming the model"
    );
    svg
}

fn has(svg: &Svg, text: &str) -> bool {
    svg.texts.iter().any(|(t, _)| t.contains(text))
}

#[test]
fn simulation_figure_with_chosen_coordinates_and_without_a_csv() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("sim.svg");
    let (code, _, err) = detune(&[
        "simulate",
        "models/overcentre.toml",
        "--set",
        "F0=3",
        "--t-end",
        "3",
        "--plot",
        svg.to_str().unwrap(),
        "--plot-coordinate",
        "bar2.theta",
        "--plot-coordinate",
        "bar1.x",
    ]);
    assert_eq!(code, 0, "{err}");
    let s = check(&svg, 2);
    // an angle panel and a length panel, legend entries with units, the override named
    assert!(has(&s, "bar2.theta [rad]") && has(&s, "bar1.x [m]"));
    assert!(!has(&s, "bar1.theta [rad]"));
    assert!(has(&s, "--set F0=3"));
    // no CSV was asked for, none written
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn branch_figure_stable_solid_unstable_dashed_folds_labelled() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("s.svg");
    let (code, _, err) = detune(&[
        "continue",
        "models/overcentre.toml",
        "--param",
        "Fs",
        "--from",
        "-10",
        "--to",
        "30",
        "--step",
        "0.5",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let s = check(&svg, 3);
    let pens: Vec<&(Vec<String>, Option<String>)> = s.legend.values().collect();
    // stable: one colour, solid; unstable: the same colour, dashed; folds: diamonds
    let solid = pens
        .iter()
        .filter(|p| !p.0.is_empty() && p.0[2].is_empty())
        .count();
    let dashed = pens
        .iter()
        .filter(|p| !p.0.is_empty() && !p.0[2].is_empty())
        .count();
    assert_eq!((solid, dashed), (1, 1), "{pens:?}");
    assert!(pens.iter().any(|p| p.1.as_deref() == Some("diamond")));
    // both folds labelled with their parameter value (23.0614… N)
    assert!(has(&s, "fold Fs = 23.06 N"), "{:?}", s.texts);
    assert!(has(&s, "Fs [N]"));
}

/// `continue --plot-coordinate` repeated: one panel per coordinate (as sweep's
/// --response), each with its axis and both folds; an unknown one is refused before any
/// file is written.
#[test]
fn branch_figure_draws_each_plot_coordinate() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("b.svg");
    let base = [
        "continue",
        "models/overcentre.toml",
        "--param",
        "Fs",
        "--from",
        "-10",
        "--to",
        "30",
        "--step",
        "0.5",
    ];
    let args = [
        &base[..],
        &[
            "--plot",
            svg.to_str().unwrap(),
            "--plot-coordinate",
            "bar1.theta",
            "--plot-coordinate",
            "bar2.x",
        ],
    ]
    .concat();
    let (code, _, err) = detune(&args);
    assert_eq!(code, 0, "{err}");
    let s = check(&svg, 6);
    for axis in ["bar1.theta [rad]", "bar2.x [m]"] {
        assert_eq!(
            s.texts.iter().filter(|(t, _)| t == axis).count(),
            1,
            "{axis}: {:?}",
            s.texts
        );
    }
    let folds = s
        .texts
        .iter()
        .filter(|(t, _)| t == "fold Fs = 23.06 N")
        .count();
    assert_eq!(folds, 2, "one fold label per panel: {:?}", s.texts);
    assert_eq!(
        s.texts
            .iter()
            .filter(|(t, _)| t == "equilibria against Fs")
            .count(),
        2
    );
    // a coordinate the model lacks: refused, nothing written
    let bad = dir.path().join("c.svg");
    let args = [
        &base[..],
        &[
            "--plot",
            bad.to_str().unwrap(),
            "--plot-coordinate",
            "bar1.theta",
            "--plot-coordinate",
            "bar9.x",
        ],
    ]
    .concat();
    let (code, _, err) = detune(&args);
    assert_ne!(code, 0);
    assert!(err.contains("bar9.x"), "{err}");
    assert!(!bad.exists());
}

#[test]
fn sweep_figure_splits_wells_and_marks_the_case() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("snap.svg");
    let (code, _, err) = detune(&[
        "sweep",
        "models/overcentre.toml",
        "--set",
        "F0=10",
        "--param",
        "omega",
        "--from",
        "0.5",
        "--to",
        "6",
        "--step",
        "0.25",
        "--response",
        "bar1.theta",
        "--response",
        "bar2.theta",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let s = check(&svg, 4);
    // one panel per response, each well its own curve with its own colour
    assert!(has(&s, "bar1.theta: stepped-sine amplitude"));
    assert!(has(&s, "bar2.theta: stepped-sine amplitude"));
    assert!(has(&s, "well 0 (bar1.theta = -0.866 rad)"));
    assert!(has(&s, "well 2 (bar1.theta = 0.644 rad)"));
    let strokes: std::collections::BTreeSet<&String> = s
        .legend
        .values()
        .filter(|p| !p.0.is_empty())
        .map(|p| &p.0[0])
        .collect();
    assert!(
        strokes.len() >= 3,
        "wells and references apart: {strokes:?}"
    );
    assert!(has(&s, "--set F0=10") && has(&s, "starting in well 2"));
    // no family over the forcing amplitude: no normalized panel
    assert!(!has(&s, "amplitude / F0"));
}

#[test]
fn frf_figure_has_amplitude_and_phase_in_db() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("frf.svg");
    let (code, _, err) = detune(&[
        "frf",
        "models/overcentre.toml",
        "--set",
        "F0=1",
        "--param",
        "omega",
        "--from",
        "0.5",
        "--to",
        "6",
        "--step",
        "0.05",
        "--response",
        "bar1.theta",
        "--plot",
        svg.to_str().unwrap(),
        "--plot-scale",
        "db",
    ]);
    assert_eq!(code, 0, "{err}");
    let s = check(&svg, 2);
    assert!(has(&s, "bar1.theta amplitude [dB re 1 rad]"));
    assert!(has(&s, "bar1.theta phase [deg]"));
    // the refined peak marked and labelled, its amplitude in dB: 20 log10(0.05398) = −25.36
    assert!(
        has(&s, "peak 2.828 rad/s, -25.36 dB re 1 rad"),
        "{:?}",
        s.texts
    );
    assert!(
        s.legend
            .values()
            .any(|p| p.1.as_deref() == Some("triangle-down")),
        "peaks legend"
    );
}

#[test]
fn tracking_kinematics_and_tornado_figures() {
    let dir = tempfile::tempdir().unwrap();
    let track = dir.path().join("track.svg");
    let (code, _, err) = detune(&[
        "modes",
        "models/inceptor.toml",
        "--param",
        "k_t",
        "--from",
        "200",
        "--to",
        "3000",
        "--points",
        "5",
        "--plot",
        track.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let s = check(&track, 2);
    assert!(has(&s, "k_t [N*m/rad]") && has(&s, "in-phase ω_n [rad/s]"));
    let kin = dir.path().join("kin.svg");
    let (code, _, err) = detune(&[
        "kinematics",
        "models/inceptor.toml",
        "--drive",
        "stick.phi",
        "--from",
        "-15 deg",
        "--to",
        "35 deg",
        "--step",
        "1 deg",
        "--ratio",
        "crank.delta",
        "--plot",
        kin.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let s = check(&kin, 1);
    assert!(has(&s, "dstick.phi/dcrank.delta [rad/rad]"));
    // the tornado (bars, no curves): text sizes and the PNG route
    let png = dir.path().join("tornado.png");
    let (code, _, err) = detune(&[
        "sensitivity",
        "models/inceptor.toml",
        "--vary",
        "k_fs=±10%",
        "--plot",
        png.to_str().unwrap(),
        "--plot-size",
        "1200x700",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(png_size(&png), (1200, 700));
}

/// Width and height from a PNG's IHDR chunk (after checking the signature).
fn png_size(path: &std::path::Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    assert_eq!(&b[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    (be(16), be(20))
}

#[test]
fn png_output_is_a_png_of_the_requested_size() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("sim.PNG");
    let (code, _, err) = detune(&[
        "simulate",
        "models/overcentre.toml",
        "--t-end",
        "1",
        "--plot",
        png.to_str().unwrap(),
        "--plot-size",
        "1600x1000",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(png_size(&png), (1600, 1000));
    // it decodes, and is not blank: the curves' blue is in it
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (1600, 1000));
    let blue = buf[..info.buffer_size()]
        .chunks(3)
        .filter(|p| p == &[0, 114, 178])
        .count();
    assert!(blue > 500, "{blue} pixels of the first curve's colour");
}

#[test]
fn bad_extensions_and_sizes_are_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("x.csv");
    let cases: [(&[&str], &str); 5] = [
        (
            &["--plot", "x.pdf"],
            "--plot x.pdf: a figure is written as .svg or .png",
        ),
        (&["--plot", "figure"], "a name without extension"),
        (
            &["--plot", "x.svg", "--plot-size", "20x20"],
            "--plot-size 20x20",
        ),
        (
            &["--plot", "x.svg", "--plot-size", "big"],
            "expected WIDTHxHEIGHT",
        ),
        (&["--plot-size", "900x600"], "without --plot"),
    ];
    for (extra, want) in cases {
        let mut args = vec![
            "simulate",
            "models/overcentre.toml",
            "--t-end",
            "200",
            "-o",
            csv.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let (code, _, err) = detune(&args);
        assert_ne!(code, 0, "{extra:?} accepted");
        assert!(err.contains(want), "{extra:?}: {err}");
        assert!(!csv.exists(), "{extra:?}: a CSV was written");
    }
    // a CSV is never written into a file named like a figure
    let svg = dir.path().join("fr.svg");
    let (code, _, err) = detune(&[
        "sweep",
        "models/overcentre.toml",
        "--param",
        "omega",
        "--from",
        "1",
        "--to",
        "2",
        "--step",
        "0.5",
        "-o",
        svg.to_str().unwrap(),
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("-o writes the CSV table"), "{err}");
    assert!(!svg.exists());
    // a size whose panels (one per response) have no room for a plot is refused before
    // the sweep, not after it: no case reaches the checkpoint
    let ckpt = dir.path().join("s.ckpt");
    let (code, _, err) = detune(&[
        "sweep",
        "models/overcentre.toml",
        "--set",
        "F0=1",
        "--param",
        "omega",
        "--from",
        "2",
        "--to",
        "4",
        "--step",
        "0.5",
        "--response",
        "bar1.theta",
        "--response",
        "bar2.theta",
        "--plot",
        dir.path().join("s.svg").to_str().unwrap(),
        "--plot-size",
        "3000x400",
        "-o",
        csv.to_str().unwrap(),
        "--checkpoint",
        ckpt.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("--plot-size 3000x400: the figure has no room for its plot")
            && err.contains("e.g. --plot-size 3000x"),
        "{err}"
    );
    assert!(
        !ckpt.exists() && !csv.exists(),
        "the sweep ran before the refusal"
    );
}

#[test]
fn report_figures_share_the_style() {
    use detune::report::figures::{
        Band, CampbellLine, CampbellPlot, FrfPlot, campbell_svg, frf_svg,
    };
    let omega: Vec<f64> = (0..200).map(|k| 1.0 * 1.02f64.powi(k)).collect();
    let amp: Vec<f64> = omega
        .iter()
        .map(|w| 1.0 / ((100.0 - w * w).powi(2) + (0.2 * w).powi(2)).sqrt())
        .collect();
    let frf = FrfPlot {
        title: "model test: linear response".into(),
        omega,
        curves: vec![("stick.phi".into(), amp)],
        unit: "rad".into(),
        resonances: vec![("mode 1".into(), 10.0)],
        peaks: vec![(10.0, 0.5)],
        bands: vec![Band {
            label: "1P".into(),
            lo: 20.0,
            nominal: 25.0,
            hi: 30.0,
        }],
        freq_unit: Default::default(),
    };
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("frf.svg");
    std::fs::write(&p, frf_svg(&frf).unwrap()).unwrap();
    let s = check(&p, 1);
    assert!(has(&s, "stick.phi [rad]"));
    let c = CampbellPlot {
        title: "model test: interference diagram".into(),
        rotor: "main".into(),
        rpm_nominal: 258.0,
        rpm_range: Some([240.0, 270.0]),
        modes: vec![("mode 1".into(), 13.0)],
        lines: vec![CampbellLine {
            label: "1P".into(),
            slope: std::f64::consts::TAU / 60.0,
        }],
        crossings: vec![(124.1, 13.0, false)],
        rpm_end: 400.0,
        omega_end: 40.0,
        freq_unit: Default::default(),
    };
    let p = dir.path().join("campbell.svg");
    std::fs::write(&p, campbell_svg(&c).unwrap()).unwrap();
    let s = check(&p, 1);
    assert!(has(&s, "mode 1: ω_n = 13.00 rad/s"));
}

/// The nonlinear frequency response and the backbone pass the checks every figure does:
/// text sizes, axes with units, legend samples in their curves' pens (stable solid,
/// unstable dashed), float coordinates, a caption naming the case; the fold marked.
#[test]
fn nfr_and_backbone_figures() {
    let dir = tempfile::tempdir().unwrap();
    let nfr = dir.path().join("nfr.svg");
    let (code, _, err) = detune(&[
        "nfr",
        "models/overcentre.toml",
        "--set",
        "theta1_0=-0.85",
        "--set",
        "c=1",
        "--set",
        "F0=4",
        "--param",
        "omega",
        "--from",
        "3.9",
        "--to",
        "4.1",
        "--response",
        "bar1.theta",
        "--plot",
        nfr.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let s = check(&nfr, 2);
    assert!(has(&s, "omega [rad/s]"), "{:?}", s.texts);
    assert!(has(&s, "fold"), "{:?}", s.texts);
    let pens: Vec<&Vec<String>> = s.curves.values().map(|p| &p.0).collect();
    assert!(pens.iter().any(|p| p[2].is_empty()) && pens.iter().any(|p| !p[2].is_empty()));
    let bb = dir.path().join("backbone.svg");
    let (code, _, err) = detune(&[
        "backbone",
        "models/overcentre.toml",
        "--set",
        "theta1_0=-0.85",
        "--of-mode",
        "1",
        "--to-amplitude",
        "0.3",
        "--plot",
        bb.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let s = check(&bb, 1);
    assert!(has(&s, "[rad/s]"), "{:?}", s.texts);
}

/// A PNG's curves are smoothed (drawn 3× larger and reduced by averaging): the pixels
/// along a curve take intermediate shades between its colour and the white behind it.
/// Drawn directly, plotters' bitmap backend sets whole pixels: the curves' own colours
/// and white, with the text's shades the only others.
#[test]
fn png_curves_are_anti_aliased() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("sim.png");
    let (code, _, err) = detune(&[
        "simulate",
        "models/overcentre.toml",
        "--t-end",
        "5",
        "--plot",
        png.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    // shades of the first curve's blue (0, 114, 178) over white: r/255 = g−114 over
    // 141 = b−178 over 77, the same coverage in each channel, strictly between 0 and 1
    let mut partial = 0;
    for px in buf[..info.buffer_size()].chunks(3) {
        let (r, g, b) = (px[0] as f64, px[1] as f64, px[2] as f64);
        let a = 1.0 - r / 255.0;
        if a > 0.1 && a < 0.9 {
            let (g0, b0) = (255.0 - a * 141.0, 255.0 - a * 77.0);
            if (g - g0).abs() <= 3.0 && (b - b0).abs() <= 3.0 {
                partial += 1;
            }
        }
    }
    assert!(partial > 500, "{partial} pixels of partial coverage");
}

/// With two `--values` every peak note names both values of its run (`F0 = 1 N` alone
/// names two curves), and in Hz the parameter's axis is `omega/2π [Hz]`: the sweep's
/// peak of F0 = 1 N, c = 5 N·s/m sits at 3 rad/s = 0.477 Hz on the 0.5 rad/s grid.
#[test]
fn grid_peaks_name_every_value_and_the_hz_axis_is_omega_over_two_pi() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("grid.svg");
    let (code, out, err) = detune(&[
        "sweep",
        "models/overcentre.toml",
        "--param",
        "omega",
        "--from",
        "2.5",
        "--to",
        "4",
        "--step",
        "0.5",
        "--values",
        "F0=1,2",
        "--values",
        "c=5,8",
        "--response",
        "bar1.theta",
        "--freq-unit",
        "Hz",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains(
            "peak [F0 = 1 N, c = 5 N·s/m] bar1.theta (independent): omega/2π = 0.4774648 Hz (not refined: ± 0.080 Hz, the grid's step)"
        ),
        "{out}"
    );
    let s = check(&svg, 4);
    assert!(has(&s, "omega/2π [Hz]"), "{:?}", s.texts);
    assert!(has(&s, "(F0 = 1 N, c = 5 N·s/m)"), "{:?}", s.texts);
    assert!(
        !s.texts
            .iter()
            .any(|(t, _)| t.starts_with("peak") && t.ends_with("(F0 = 1 N)")),
        "{:?}",
        s.texts
    );
}

/// The y coordinates of every curve polyline of an SVG (px).
fn curve_ys(svg: &str) -> Vec<f64> {
    let doc = roxmltree::Document::parse(svg).expect("well-formed SVG");
    let mut ys = Vec::new();
    for n in doc.descendants() {
        if n.tag_name().name() == "polyline" && n.attribute("class") == Some("curve") {
            for p in n.attribute("points").unwrap().split_whitespace() {
                ys.push(p.split(',').nth(1).unwrap().parse::<f64>().unwrap());
            }
        }
    }
    ys
}

/// The numbers of `text` (`jump up 0.6366→0.6525 Hz`: 0.6366, 0.6525).
fn numbers(text: &str) -> Vec<f64> {
    text.split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .filter_map(|w| w.parse().ok())
        .collect()
}

/// Issue 10 acceptance F1: `--freq-unit Hz` on a sweep with jumps (a `→` in the label)
/// draws, and every frequency its labels write is the rad/s value over 2π to four
/// significant digits, both ends of a jump included (it panicked, and a peak at 4 rad/s
/// read "peak 1 Hz"). The jumps and the peak are grid frequencies, so their Hz values
/// are known exactly: 4.0/2π, 4.1/2π, 3.2/2π, 3.1/2π.
#[test]
fn frequency_labels_in_hz_name_the_right_values() {
    let tau = std::f64::consts::TAU;
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("hz.svg");
    let csv = dir.path().join("hz.csv");
    let base = [
        "sweep",
        "models/overcentre.toml",
        "--set",
        "theta1_0=-0.85",
        "--set",
        "c=1",
        "--set",
        "F0=4",
        "--param",
        "omega",
        "--from",
        "2.5",
        "--to",
        "5",
        "--step",
        "0.1",
        "--response",
        "bar1.theta",
        "--freq-unit",
        "Hz",
    ];
    let mut args = base.to_vec();
    args.extend(["--mode", "both", "--plot", svg.to_str().unwrap()]);
    args.extend(["-o", csv.to_str().unwrap()]);
    let (code, _, err) = detune(&args);
    assert_eq!(code, 0, "{err}");
    assert!(csv.exists(), "the results are written");
    let s = read(&std::fs::read_to_string(&svg).unwrap());
    let jump = |dir: &str| -> Vec<f64> {
        let t = s
            .texts
            .iter()
            .find(|(t, _)| t.starts_with(&format!("jump {dir} ")))
            .unwrap_or_else(|| panic!("no jump {dir} in {:?}", s.texts));
        assert!(t.0.ends_with(" Hz") && t.0.contains('→'), "{}", t.0);
        numbers(&t.0)
    };
    let close = |got: f64, want: f64| (got - want).abs() <= 5e-5 + 1e-4 * want;
    let up = jump("up");
    assert!(close(up[0], 4.0 / tau) && close(up[1], 4.1 / tau), "{up:?}");
    let down = jump("down");
    assert!(
        close(down[0], 3.2 / tau) && close(down[1], 3.1 / tau),
        "{down:?}"
    );
    assert!(!has(&s, "rad/s") && !has(&s, "ω_n"), "{:?}", s.texts);
    // the linear natural frequency as f_n, its Hz value that of the rad/s one
    let f_n = s
        .texts
        .iter()
        .find(|(t, _)| t.starts_with("linear f_n = "))
        .map(|(t, _)| numbers(t)[0])
        .expect("f_n in the legend");
    let mut args = base[..base.len() - 2].to_vec();
    args.extend(["--mode", "up", "--plot", svg.to_str().unwrap()]);
    let (code, _, err) = detune(&args);
    assert_eq!(code, 0, "{err}");
    let s = read(&std::fs::read_to_string(&svg).unwrap());
    let omega_n = s
        .texts
        .iter()
        .find(|(t, _)| t.starts_with("linear ω_n = "))
        .map(|(t, _)| numbers(t)[0])
        .expect("ω_n in the rad/s legend");
    assert!(close(f_n, omega_n / tau), "{f_n} Hz for {omega_n} rad/s");
    // the peak of well 0 at F0=10, the grid's 4 rad/s: 0.6366 Hz (it read "peak 1 Hz")
    let (code, _, err) = detune(&[
        "sweep",
        "models/overcentre.toml",
        "--set",
        "F0=10",
        "--param",
        "omega",
        "--from",
        "0.5",
        "--to",
        "6",
        "--step",
        "0.25",
        "--response",
        "bar1.theta",
        "--mode",
        "up",
        "--freq-unit",
        "Hz",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let s = read(&std::fs::read_to_string(&svg).unwrap());
    let peak = s
        .texts
        .iter()
        .find(|(t, _)| t.starts_with("peak "))
        .map(|(t, _)| t.clone())
        .expect("a peak note");
    assert!(peak.contains(" Hz, "), "{peak}");
    assert!(close(numbers(&peak)[0], 4.0 / tau), "{peak}");
}

/// Issue 10 acceptance F2: a `--plot-size` of any shape either draws a plot area (the
/// curves span more than a line) or is refused naming the flag and a size that works,
/// and that size then draws. 8000x300 panicked; 1500x300 drew the plot as a line.
#[test]
fn every_plot_size_draws_a_plot_or_is_refused_with_one_that_does() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("size.svg");
    let path = svg.to_str().unwrap();
    let simulate = |size: &str| {
        detune(&[
            "simulate",
            "models/overcentre.toml",
            "--t-end",
            "1",
            "--plot-size",
            size,
            "--plot",
            path,
        ])
    };
    let span = || {
        let ys = curve_ys(&std::fs::read_to_string(&svg).unwrap());
        ys.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - ys.iter().cloned().fold(f64::INFINITY, f64::min)
    };
    // the size a refusal suggests
    let suggested = |err: &str| -> String {
        err.split("e.g. --plot-size ")
            .nth(1)
            .and_then(|t| t.split([',', ' ', '\n']).next())
            .unwrap_or_else(|| panic!("no size suggested: {err}"))
            .to_string()
    };
    for size in ["8000x300", "4000x300", "1500x300"] {
        let (code, _, err) = simulate(size);
        assert_eq!(code, 0, "{size}: {err}");
        // the two angles apart by most of the plot area, at least 90 px tall
        assert!(span() > 60.0, "{size}: the curves span {} px", span());
    }
    // the smallest size: its title and caption wrap to two lines each and its legend
    // to two rows, which leaves no plot area: refused, with a size that draws
    let (code, _, err) = simulate("300x300");
    assert_ne!(code, 0);
    assert!(
        err.contains("--plot-size 300x300") && !err.contains("panicked"),
        "{err}"
    );
    let (code, _, err) = simulate(&suggested(&err));
    assert_eq!(code, 0, "{err}");
    assert!(span() > 60.0, "the curves span {} px", span());
    // four panels (two responses, their amplitudes per unit of F0) in 1000 px: refused
    let sweep = |size: &str| {
        detune(&[
            "sweep",
            "models/overcentre.toml",
            "--param",
            "omega",
            "--from",
            "2",
            "--to",
            "4",
            "--step",
            "1",
            "--values",
            "F0=0.5,1",
            "--response",
            "bar1.theta",
            "--response",
            "bar2.theta",
            "--plot-size",
            size,
            "--plot",
            path,
        ])
    };
    let (code, _, err) = sweep("1600x1000");
    assert_ne!(code, 0);
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains("--plot-size 1600x1000"), "{err}");
    let (code, _, err) = sweep(&suggested(&err));
    assert_eq!(code, 0, "{err}");
    assert!(span() > 60.0, "the curves span {} px", span());
}

/// Issue 10 acceptance F3: a sweep whose every point is in well 0 though it starts in
/// well 2 names the well its curve is in and marks that well's ω_n (the square root of
/// `equilibrium --all`'s undamped ω² for it), not the starting well's.
#[test]
fn a_sweep_that_leaves_its_starting_well_marks_the_well_it_is_in() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("up.svg");
    let (code, out, err) = detune(&[
        "sweep",
        "models/overcentre.toml",
        "--set",
        "F0=10",
        "--param",
        "omega",
        "--from",
        "0.5",
        "--to",
        "6",
        "--step",
        "0.25",
        "--response",
        "bar1.theta",
        "--mode",
        "up",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("at 23 of 23 frequencies (up): 0.5–6 rad/s in well 0"),
        "{out}"
    );
    let (code, json, err) = detune(&[
        "equilibrium",
        "models/overcentre.toml",
        "--set",
        "F0=10",
        "--all",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let j: serde_json::Value = serde_json::from_str(&json).unwrap();
    let eq = j["equilibria"].as_array().unwrap();
    let omega_n = |k: usize| eq[k]["undamped_omega2"][0].as_f64().unwrap().sqrt();
    let s = check(&svg, 1);
    assert!(
        has(&s, "(up), well 0 (bar1.theta = -0.866 rad)"),
        "{:?}",
        s.texts
    );
    assert!(has(&s, "starting in well 2"), "{:?}", s.texts);
    let mark = format!("linear ω_n = {:.4} rad/s (well 0)", omega_n(0));
    assert!(has(&s, &mark), "{mark} not in {:?}", s.texts);
    let start = format!("{:.4} rad/s", omega_n(2));
    assert!(!has(&s, &start), "well 2's {start} marked: {:?}", s.texts);
}

/// Issue 10 acceptance D5: a long caption wraps to the figure's width instead of being
/// cut: every override is drawn whole.
#[test]
fn a_long_caption_wraps() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("wrap.svg");
    let sets = [
        "theta1_0=0.800000",
        "c=4.000000",
        "k=51.000000",
        "m1=1.100000",
        "m2=0.900000",
        "L0=2.010000",
        "g=9.800000",
    ];
    let mut args = vec!["simulate", "models/overcentre.toml", "--t-end", "0.5"];
    for s in &sets {
        args.extend(["--set", s]);
    }
    args.extend(["--plot", svg.to_str().unwrap()]);
    let (code, _, err) = detune(&args);
    assert_eq!(code, 0, "{err}");
    let s = check(&svg, 1);
    let caption: Vec<&str> = s
        .texts
        .iter()
        .filter(|(_, size)| (*size - 17.0).abs() < 1e-9)
        .map(|(t, _)| t.as_str())
        .collect();
    assert!(caption.len() >= 2, "one line: {caption:?}");
    let words: Vec<&str> = caption.iter().flat_map(|l| l.split(' ')).collect();
    for set in &sets {
        assert!(words.contains(set), "{set} not drawn whole: {caption:?}");
    }
}
