//! `detune report`: the HTML page and its JSON sidecar, checked structurally (every
//! section, every keyed number against the sidecar and against `detune modes --json`,
//! no script, no URL, well-formed inline SVG), against closed forms (the interference
//! diagram's crossings), against `detune frf` (the response per unit forcing), and in a
//! real headless browser (Debian's chromium: renders without console errors; the
//! screenshot is kept under `<target>/test-artifacts/`).

use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_detune");

fn model(name: &str) -> String {
    format!("{}/models/{name}.toml", env!("CARGO_MANIFEST_DIR"))
}

fn run(args: &[&str]) -> std::process::Output {
    Command::new(BIN).args(args).output().unwrap()
}

/// The report of `model` (with `extra` arguments) in a fresh directory: (dir, html path,
/// page, sidecar).
fn report(model_name: &str, extra: &[&str]) -> (tempfile::TempDir, PathBuf, String, Value) {
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join(format!("{model_name}-report.html"));
    let m = model(model_name);
    let mut args = vec!["report", m.as_str()];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["-o", html.to_str().unwrap()]);
    let out = run(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let page = std::fs::read_to_string(&html).unwrap();
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(html.with_extension("json")).unwrap())
            .unwrap();
    (dir, html, page, json)
}

fn unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&#39;", "'")
        .replace("&amp;", "&")
}

/// Every keyed number of the page, in order: `<td ... data-key="K">TEXT</td>` in tables,
/// `<span class="num" data-key="K">TEXT</span>` in running text; (key, text).
fn keyed_numbers(page: &str) -> Vec<(String, String)> {
    keyed_numbers_in_units(page)
        .into_iter()
        .map(|(k, _, t)| (k, t))
        .collect()
}

/// [`keyed_numbers`] with the frequency unit each is shown in (`data-unit="Hz"` after
/// the key, `--freq-unit`; None: as the sidecar holds it); (key, unit, text).
fn keyed_numbers_in_units(page: &str) -> Vec<(String, Option<String>, String)> {
    let mut out = Vec::new();
    let mut rest = page;
    while let Some(i) = rest.find("data-key=\"") {
        rest = &rest[i + 10..];
        let end = rest.find('"').unwrap();
        let key = unescape(&rest[..end]);
        let open = rest.find('>').unwrap();
        let unit = rest[end..open]
            .split_once("data-unit=\"")
            .map(|(_, u)| u[..u.find('"').unwrap()].to_string());
        let close = open + rest[open..].find('<').unwrap();
        out.push((key, unit, unescape(&rest[open + 1..close])));
        rest = &rest[close..];
    }
    out
}

/// A value in rad/s in `unit` (rad/s, Hz, rpm): ω, ω/2π, 30ω/π.
fn in_unit(rad_s: f64, unit: Option<&str>) -> f64 {
    match unit {
        None | Some("rad/s") => rad_s,
        Some("Hz") => rad_s / (2.0 * std::f64::consts::PI),
        Some("rpm") => rad_s * 30.0 / std::f64::consts::PI,
        Some(u) => panic!("data-unit {u}"),
    }
}

/// [`keyed_numbers`] by key: key → text (a table cell is keyed once; a number also named
/// in a sentence must be shown alike wherever it is, or the first one is kept).
fn keyed_cells(page: &str) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for (key, text) in keyed_numbers(page) {
        out.entry(key).or_insert(text);
    }
    out
}

/// `s` without every stretch from `open` to the next `close`.
fn strip(s: &str, open: &str, close: &str) -> String {
    let mut out = String::new();
    let mut rest = s;
    while let Some(i) = rest.find(open) {
        out.push_str(&rest[..i]);
        match rest[i..].find(close) {
            Some(j) => rest = &rest[i + j + close.len()..],
            None => return out,
        }
    }
    out + rest
}

/// The numbers with a decimal point or an exponent (results, not counts or names such
/// as `1P`) that the page's sections show outside a keyed element, leaving out the
/// figures (SVG), the commands to copy (`<code>`) and the provenance (version, date).
fn unkeyed_numbers(page: &str) -> Vec<String> {
    let body = &page[page.find("<section").unwrap()..page.find("<footer").unwrap()];
    let mut text = strip(body, "<svg", "</svg>");
    text = strip(&text, "<code>", "</code>");
    text = strip(&text, "<section id=\"provenance\">", "</section>");
    text = strip(&text, " data-key=", "</");
    // the remaining text, tags dropped
    let text = strip(&text, "<", ">");
    let mut found = Vec::new();
    let chars: Vec<char> = text.chars().collect();
    for (i, w) in chars.windows(3).enumerate() {
        let result = w[0].is_ascii_digit()
            && (w[1] == '.' || w[1] == 'e')
            && (w[2].is_ascii_digit() || w[2] == '-');
        if result {
            let from = i.saturating_sub(40);
            let to = (i + 40).min(chars.len());
            found.push(chars[from..to].iter().collect());
        }
    }
    found
}

/// `value` written the way `shown` is written: as many decimals, fixed or scientific.
fn as_shown(value: f64, shown: &str) -> String {
    let decimals = |s: &str| s.split_once('.').map(|(_, d)| d.len()).unwrap_or(0);
    match shown.split_once('e') {
        Some((mantissa, _)) => format!("{value:.0$e}", decimals(mantissa)),
        None => format!("{value:.0$}", decimals(shown)),
    }
}

/// The keyed cells whose text is not the sidecar's value written as shown (`n/a` for a
/// value that is not a number), converted to the cell's `data-unit` where it has one.
fn mismatches(page: &str, json: &Value) -> Vec<String> {
    keyed_numbers_in_units(page)
        .into_iter()
        .filter_map(|(key, unit, text)| {
            let v = at(json, &key);
            let want = v
                .as_f64()
                .map(|x| as_shown(in_unit(x, unit.as_deref()), &text))
                .unwrap_or("n/a".into());
            (text != want).then(|| format!("{key} [{unit:?}]: page {text}, sidecar {v}"))
        })
        .collect()
}

/// The value at a cell's key: the key is a JSON Pointer without its leading `/`.
fn at<'a>(json: &'a Value, key: &str) -> &'a Value {
    json.pointer(&format!("/{key}"))
        .unwrap_or_else(|| panic!("the sidecar has no {key}"))
}

const SECTIONS: [&str; 8] = [
    "provenance",
    "model",
    "pose",
    "equilibrium",
    "modes",
    "frf",
    "environment",
    "campbell",
];

#[test]
fn every_number_on_the_page_is_the_sidecars_rounded() {
    let (_dir, _, page, json) = report("inceptor", &["--environment", "UH-60"]);
    for s in SECTIONS {
        assert!(
            page.contains(&format!("<section id=\"{s}\">")),
            "section {s} missing"
        );
    }
    let cells = keyed_cells(&page);
    assert!(cells.len() > 100, "{} keyed cells", cells.len());
    let bad = mismatches(&page, &json);
    assert!(bad.is_empty(), "{}", bad.join("\n"));
    // the check catches a page whose number differs in its last digit shown
    let shown = &cells["modes/1/omega_n_rad_s"];
    let tampered = page.replace(
        &format!("data-key=\"modes/1/omega_n_rad_s\">{shown}<"),
        "data-key=\"modes/1/omega_n_rad_s\">26.532<",
    );
    assert_ne!(tampered, page);
    assert_eq!(mismatches(&tampered, &json).len(), 1);
    // numbers of each kind are keyed
    for key in [
        "model/dof",
        "equilibrium/coordinates/3/degrees",
        "modes/1/omega_n_rad_s",
        "modes/0/shape/stick.phi/re",
        "frf/peaks/0/omega",
        "environment/lines/0/omega_rad_s",
        "campbell/crossings/0/rotor_rpm",
    ] {
        assert!(cells.contains_key(key), "no cell keyed {key}");
    }
    assert_eq!(cells["model/dof"], "2");
    assert_eq!(cells["equilibrium/coordinates/3/degrees"], "12.0000"); // phi0 = 12 deg
    let p = &json["provenance"];
    assert_eq!(p["detune_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(p["model_sha256"].as_str().unwrap().len(), 64);
    assert!(page.contains(p["model_sha256"].as_str().unwrap()));
}

#[test]
fn the_modes_are_those_of_detune_modes() {
    let (_dir, _, page, json) = report("inceptor", &["--environment", "UH-60"]);
    let out = run(&["modes", &model("inceptor"), "--json"]);
    assert!(out.status.success());
    let modes: Value = serde_json::from_slice(&out.stdout).unwrap();
    let cells = keyed_cells(&page);
    let list = modes["modes"].as_array().unwrap();
    assert_eq!(list.len(), 2);
    assert_eq!(json["modes"].as_array().unwrap().len(), 2);
    for (k, m) in list.iter().enumerate() {
        for field in ["omega_n_rad_s", "freq_hz", "damping_ratio", "omega_d_rad_s"] {
            let shown = &cells[&format!("modes/{k}/{field}")];
            assert_eq!(
                shown,
                &as_shown(m[field].as_f64().unwrap(), shown),
                "{k} {field}"
            );
        }
        let rpm = m["omega_n_rad_s"].as_f64().unwrap() * 30.0 / std::f64::consts::PI;
        let shown = &cells[&format!("modes/{k}/rpm")];
        assert_eq!(shown, &as_shown(rpm, shown));
        for (c, z) in m["shape"].as_object().unwrap() {
            for part in ["re", "im"] {
                let shown = &cells[&format!("modes/{k}/shape/{c}/{part}")];
                assert_eq!(
                    shown,
                    &as_shown(z[part].as_f64().unwrap(), shown),
                    "{k} {c}"
                );
            }
        }
    }
    // the shipped inceptor's damped modes (docs/inceptor.md)
    assert_eq!(cells["modes/0/omega_n_rad_s"], "13.090");
    assert_eq!(cells["modes/1/omega_n_rad_s"], "26.531");
}

#[test]
fn crossings_are_where_the_lines_meet_the_modes() {
    let (_dir, _, page, json) = report("inceptor", &["--environment", "UH-60"]);
    let pi = std::f64::consts::PI;
    let modes = json["modes"].as_array().unwrap();
    let crossings = json["campbell"]["crossings"].as_array().unwrap();
    // UH-60: main rotor 258 rpm, tail 1190 rpm; lines 1P 4P 8P 12P 1T 4T (tail geared to
    // the main rotor); no operating range, so the speed axis ends at 1.2 × 258 rpm
    let lines = [
        ("1P", 1.0),
        ("4P", 4.0),
        ("8P", 8.0),
        ("12P", 12.0),
        ("1T", 1190.0 / 258.0),
        ("4T", 4.0 * 1190.0 / 258.0),
    ];
    let mut expected = 0;
    for (k, m) in modes.iter().enumerate() {
        let w = m["omega_n_rad_s"].as_f64().unwrap();
        for (label, n) in lines {
            // ω = n Ω π/30  ⇒  Ω = 30 ω / (n π)
            let omega_rpm = 30.0 * w / (n * pi);
            if omega_rpm > 1.2 * 258.0 {
                continue;
            }
            expected += 1;
            let c = crossings
                .iter()
                .find(|c| c["mode"] == k + 1 && c["line"] == label)
                .unwrap_or_else(|| panic!("no crossing of mode {} with {label}", k + 1));
            assert!((c["rotor_rpm"].as_f64().unwrap() - omega_rpm).abs() < 1e-9 * omega_rpm);
            let percent = c["percent_nominal"].as_f64().unwrap();
            assert!((percent - 100.0 * omega_rpm / 258.0).abs() < 1e-9);
            // no range given: not judged
            assert!(c["in_operating_range"].is_null());
        }
    }
    assert_eq!(crossings.len(), expected);
    assert!(json["campbell"]["rpm_range"].is_null());
    // the inceptor's second mode (26.53 rad/s) meets 1P at 253.3 rpm, 98.2 % of nominal:
    // the crossing nearest the nominal speed, which the page's prose names
    let nearest = crossings
        .iter()
        .min_by(|a, b| {
            let d = |c: &Value| (c["percent_nominal"].as_f64().unwrap() - 100.0).abs();
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    assert_eq!(
        (nearest["mode"].as_u64(), nearest["line"].as_str()),
        (Some(2), Some("1P"))
    );
    assert!(
        strip(&page, "<", ">").contains("shaft-twist with 1P at 253.3 rpm (98.2 % of nominal)")
    );
    // the UH-60 gives no operating range: the figure's legend does not call a crossing
    // outside it
    assert!(page.contains("not judged in or out"));
    assert!(!page.contains("crossing outside it"));
    assert_eq!(nearest["mode_name"], "shaft-twist");
}

#[test]
fn the_response_is_detune_frfs_per_unit_table_motion() {
    let (_dir, _, _, json) = report("inceptor", &["--environment", "UH-60"]);
    let frf = &json["frf"];
    // the shipped inceptor has D0 = 0: the report's response is per metre of D0
    assert_eq!(frf["unit_forcing"]["param"], "D0");
    assert_eq!(frf["responses"][0]["unit"], "rad/m");
    let omega = frf["omega_rad_s"].as_array().unwrap();
    // log-spaced from 0.2 × the lowest to 2.5 × the highest natural frequency
    let w0 = json["modes"][0]["omega_n_rad_s"].as_f64().unwrap();
    let w1 = json["modes"][1]["omega_n_rad_s"].as_f64().unwrap();
    assert!((omega[0].as_f64().unwrap() - 0.2 * w0).abs() < 1e-9);
    assert!((omega.last().unwrap().as_f64().unwrap() - 2.5 * w1).abs() < 1e-9);
    // one grid point against `detune frf` with D0 = 7 mm, divided by 7 mm (linear)
    let k = 150;
    let w = omega[k].as_f64().unwrap();
    let ws = format!("{w}");
    let out = run(&[
        "frf",
        &model("inceptor"),
        "--set",
        "D0=7 mm",
        "--param",
        "omega",
        "--from",
        &ws,
        "--to",
        &ws,
        "--step",
        "1",
        "--response",
        "stick.phi",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let f: Value = serde_json::from_slice(&out.stdout).unwrap();
    let point = &f["points"][0];
    let w_frf = point["omega"].as_f64().unwrap();
    assert!((w_frf - w).abs() < 1e-8 * w, "{w_frf} vs {w}");
    let amp = point["stick.phi_amplitude"].as_f64().unwrap() / 0.007;
    let r = &frf["responses"][0];
    assert_eq!(r["name"], "stick.phi");
    let ours = r["amplitude"][k].as_f64().unwrap();
    assert!((ours - amp).abs() < 1e-6 * amp, "{ours} vs {amp}");
    // each refined stick.phi peak sits near a mode (light damping: ζ < 0.14)
    let peaks: Vec<f64> = frf["peaks"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| p["response"] == "stick.phi")
        .map(|p| p["omega"].as_f64().unwrap())
        .collect();
    assert_eq!(peaks.len(), 2);
    assert!((peaks[0] / w0 - 1.0).abs() < 0.05, "{peaks:?}");
    assert!((peaks[1] / w1 - 1.0).abs() < 0.05, "{peaks:?}");
}

#[test]
fn the_page_is_self_contained_and_its_svgs_are_well_formed() {
    let (_dir, _, page, _) = report("inceptor", &["--environment", "UH-60"]);
    assert!(!page.to_lowercase().contains("<script"));
    assert!(!page.contains("http://") && !page.contains("https://"));
    assert!(!page.contains("<link") && !page.contains("@import"));
    let mut figures = 0;
    let mut rest = page.as_str();
    while let Some(i) = rest.find("<figure>") {
        rest = &rest[i + 8..];
        let end = rest.find("<figcaption>").unwrap();
        let svg = &rest[..end];
        let doc =
            roxmltree::Document::parse(svg).unwrap_or_else(|e| panic!("figure {figures}: {e}"));
        assert_eq!(doc.root_element().tag_name().name(), "svg");
        figures += 1;
    }
    assert_eq!(figures, 4, "pose, response, interference diagram, tornado");
}

#[test]
fn a_planar_model_without_environment() {
    let (_dir, _, page, json) = report("overcentre", &["--set", "c=3"]);
    // the override is in the provenance and in the parameters table
    assert_eq!(json["provenance"]["overrides"], serde_json::json!(["c=3"]));
    let params = json["model"]["parameters"].as_array().unwrap();
    let c = params.iter().position(|p| p["name"] == "c").unwrap();
    assert_eq!(params[c]["value"], 3.0);
    assert_eq!(params[c]["set"], "3");
    for s in [
        "provenance",
        "model",
        "pose",
        "equilibrium",
        "modes",
        "frf",
        "campbell",
    ] {
        assert!(page.contains(&format!("<section id=\"{s}\">")), "{s}");
    }
    assert!(!page.contains("<section id=\"environment\">"));
    assert!(page.contains("No vibration environment given"));
    // one mode, the force amplitude F0 (zero in the file) taken as 1 N
    assert_eq!(json["modes"].as_array().unwrap().len(), 1);
    assert_eq!(json["frf"]["unit_forcing"]["param"], "F0");
    assert!(json.get("campbell").is_none());
    let cells = keyed_cells(&page);
    assert_eq!(cells[&format!("model/parameters/{c}/value")], "3.00000");
    // c only damps: ω_n is the undamped 2.9732 rad/s of docs/overcentre.md, ζ = c / 5 ×
    // the baseline's 0.2186
    assert_eq!(cells["modes/0/omega_n_rad_s"], "2.973");
    let zeta = json["modes"][0]["damping_ratio"].as_f64().unwrap();
    assert!((zeta - 0.6 * 0.218576).abs() < 1e-5, "{zeta}");
}

#[test]
fn bad_requests_are_refused_before_any_output() {
    let dir = tempfile::tempdir().unwrap();
    let m = model("inceptor");
    let txt = dir.path().join("report.txt");
    let out = run(&["report", &m, "-o", txt.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("report.txt") && err.contains(".html"), "{err}");
    let html = dir.path().join("r.html");
    let out = run(&[
        "report",
        &m,
        "--environment",
        "CH-47",
        "-o",
        html.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("UH-60"));
    let missing = dir.path().join("no/such/dir/r.html");
    let out = run(&["report", &m, "-o", missing.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("does not exist"));
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "nothing written"
    );
}

// ---- the headless browser ------------------------------------------------------------

/// The page's console messages in chromium's `--enable-logging=stderr` log. Chromium
/// logs every message a page sends to its console as `...:CONSOLE:<line>] "<message>",
/// source: <url> (<line>)` (older versions: `CONSOLE(<line>)`), at level INFO whatever
/// the message's own level, and an uncaught exception as `"Uncaught ..."`. The report has
/// no script, so any console message from it is an error.
fn console_errors(stderr: &str) -> Vec<&str> {
    stderr
        .lines()
        .filter(|l| l.contains(":CONSOLE") || l.contains("CONSOLE(") || l.contains("Uncaught"))
        .collect()
}

/// The chromium binary, if installed.
fn chromium() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    for name in ["chromium", "chromium-browser"] {
        for dir in std::env::split_paths(&path) {
            let p = dir.join(name);
            if p.is_file() {
                return Some(p);
            }
        }
    }
    None
}

/// Render `page` (a file) in headless chromium, screenshot to `png` at `w` × `h`: the
/// log chromium wrote on stderr. Panics after 120 s.
fn render(chromium: &Path, page: &Path, png: &Path, w: u32, h: u32) -> String {
    let profile = tempfile::tempdir().unwrap();
    let log = profile.path().join("stderr.log");
    let mut child = Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
        ])
        .arg(format!(
            "--user-data-dir={}",
            profile.path().join("profile").display()
        ))
        .args(["--enable-logging=stderr", "--v=0"])
        .arg(format!("--screenshot={}", png.display()))
        .arg(format!("--window-size={w},{h}"))
        .arg(format!("file://{}", page.canonicalize().unwrap().display()))
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("chromium did not finish within 120 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    std::fs::read_to_string(&log).unwrap_or_default()
}

/// Width and height of a PNG file (its IHDR chunk).
fn png_size(png: &Path) -> (u32, u32) {
    let b = std::fs::read(png).unwrap();
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    (be(16), be(20))
}

/// chromium, or None after a loud message outside CI; fails under CI.
fn browser_or_skip(test: &str) -> Option<PathBuf> {
    let found = chromium();
    if found.is_none() {
        let ci = std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0");
        assert!(
            !ci,
            "CI is set but chromium is not installed: .ci/run installs it (apt-get install -y --no-install-recommends chromium)"
        );
        eprintln!(
            "\n**************** SKIPPED {test}: chromium is not installed ****************\n\
             install it with: apt-get install -y --no-install-recommends chromium\n"
        );
    }
    found
}

/// Where the screenshots are kept: `<target dir>/test-artifacts/`.
fn artifacts() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .unwrap()
        .join("test-artifacts");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn the_console_check_catches_a_page_error() {
    let Some(chromium) = browser_or_skip("the_console_check_catches_a_page_error") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("bad.html");
    std::fs::write(
        &page,
        "<!DOCTYPE html><html><head><title>bad</title></head><body><p>deliberate</p>\
         <script>undefinedFunction();</script></body></html>",
    )
    .unwrap();
    let png = dir.path().join("bad.png");
    let log = render(&chromium, &page, &png, 400, 300);
    let errors = console_errors(&log);
    assert!(
        errors.iter().any(|l| l.contains("undefinedFunction")),
        "the checker missed the deliberate error; log:\n{log}"
    );
    // and the same page without the script is clean
    std::fs::write(
        &page,
        "<!DOCTYPE html><html><body><p>fine</p></body></html>",
    )
    .unwrap();
    let log = render(&chromium, &page, &png, 400, 300);
    assert!(console_errors(&log).is_empty(), "{log}");
}

#[test]
fn the_report_renders_in_a_headless_browser() {
    let Some(chromium) = browser_or_skip("the_report_renders_in_a_headless_browser") else {
        return;
    };
    let (_dir, html, _, _) = report("inceptor", &["--environment", "UH-60"]);
    let png = artifacts().join("inceptor-report.png");
    let _ = std::fs::remove_file(&png);
    let log = render(&chromium, &html, &png, 1280, 4000);
    assert!(png.is_file(), "no screenshot; chromium's log:\n{log}");
    assert_eq!(png_size(&png), (1280, 4000));
    let errors = console_errors(&log);
    assert!(errors.is_empty(), "console errors:\n{}", errors.join("\n"));
    eprintln!("screenshot kept at {}", png.display());
}

/// The design sections: the sensitivity equals `detune sensitivity --json`'s for the same
/// --vary, the margins flag the baseline's mode 2 against the UH-60 1P as `margins` does,
/// and the tuning proposal is `detune tune`'s first design with the --vary as its
/// tolerances, whose printed check command passes `margins`.
#[test]
fn sensitivity_margins_and_tuning_sections() {
    let vary = ["--vary", "k_fs=±10%", "--vary", "gearbox_scale=±5%"];
    let ranges = ["k_fs=60%..150%", "gearbox_scale=55%..145%"];
    let mut extra = vec!["--environment", "UH-60", "--tune"];
    extra.extend(vary);
    extra.extend(["--tune-vary", ranges[0], "--tune-vary", ranges[1]]);
    let (_dir, _, page, json) = report("inceptor", &extra);
    for id in ["sensitivity", "margins", "tuning"] {
        assert!(page.contains(&format!("id=\"{id}\"")), "section {id}");
    }
    let m = model("inceptor");
    let mut args = vec!["sensitivity", m.as_str(), "--json"];
    args.extend(vary);
    let out = run(&args);
    let s: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["sensitivity"]["modes"], s["modes"]);
    assert_eq!(json["margins"]["pass"], false);
    let fails: Vec<&Value> = json["margins"]["rows"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["pass"] == false)
        .collect();
    assert_eq!(fails.len(), 1);
    assert_eq!(fails[0]["mode"], "shaft-twist");
    assert_eq!(fails[0]["line"], "1P");
    let mut args = vec!["tune", m.as_str(), "--environment", "UH-60", "--json"];
    args.extend(["--vary", ranges[0], "--vary", ranges[1]]);
    args.extend([
        "--tolerance",
        "k_fs=±10%",
        "--tolerance",
        "gearbox_scale=±5%",
    ]);
    let out = run(&args);
    let t: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        json["tuning"]["designs"][0]["parameters"],
        t["designs"][0]["parameters"]
    );
    assert!(json["tuning"]["designs"][0]["tolerance_intervals"].is_object());
    // every number on the page, in tables and in sentences, is the sidecar's rounded
    let bad = mismatches(&page, &json);
    assert!(bad.is_empty(), "{}", bad.join("\n"));
    let unkeyed = unkeyed_numbers(&page);
    assert!(
        unkeyed.is_empty(),
        "numbers without a key:\n{}",
        unkeyed.join("\n")
    );
    for key in [
        "equilibrium/residual",
        "margins/margin_pct",
        "sensitivity/modes/1/worst_case/max_rad_s",
        "tuning/designs/0/cost",
    ] {
        assert!(
            page.contains(&format!("<span class=\"num\" data-key=\"{key}\">")),
            "{key} not in a sentence"
        );
    }
    // the check command the report prints, run as printed, passes
    let text = page.replace("&#39;", "'");
    let at = text.find("Check design 1:").expect("a check command");
    let at = at + text[at..].find("<code>detune ").unwrap();
    let command = &text[at + "<code>detune ".len()..];
    let command = &command[..command.find('<').unwrap()];
    assert!(
        command.contains("--vary k_fs=±10% --vary gearbox_scale=±5%"),
        "{command}"
    );
    let words: Vec<&str> = command.split_whitespace().collect();
    let out = run(&words);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{command}: {}",
        String::from_utf8_lossy(&out.stdout)
    );
}

/// The README's first command is the inceptor report, and it runs as written (its output
/// redirected to a temporary directory).
#[test]
fn the_readmes_first_command_writes_the_report() {
    let readme =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).unwrap();
    let first = readme
        .lines()
        .skip_while(|l| !l.starts_with("```"))
        .nth(1)
        .unwrap()
        .to_string();
    let args = first
        .strip_prefix("cargo run --release -- ")
        .unwrap_or_else(|| panic!("README's first command: {first}"));
    assert!(
        args.starts_with("report models/inceptor.toml --environment UH-60 -o "),
        "{args}"
    );
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("inceptor-report.html");
    let mut argv: Vec<String> = args.split_whitespace().map(String::from).collect();
    let o = argv.iter().position(|a| a == "-o").unwrap();
    argv[o + 1] = html.to_str().unwrap().to_string();
    let argv: Vec<&str> = argv.iter().map(|s| s.as_str()).collect();
    let out = run(&argv);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("inceptor-report.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(
        json["margins"]["pass"], false,
        "the candidate's mode 2 is 1.8 % below 1P"
    );
    assert!(json["sensitivity"]["modes"].as_array().unwrap().len() == 2);
}

/// An environment with a sine-on-random profile (levels made up for the test): each
/// tone's amplitude is |H| × level with |H| = `detune frf --set D0=1`'s at the tone, and
/// the RMS over the flat 2–6 Hz floor equals √∫|H|²·PSD df by the trapezoid rule on
/// `detune frf`'s dense grid (0.2 %).
#[test]
fn the_profile_section_states_tone_amplitudes_and_random_rms() {
    let env = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/uh60_profile.toml");
    let (_dir, _, page, json) = report("inceptor", &["--environment", env]);
    assert!(page.contains("id=\"profile\""));
    let p = &json["profile"];
    assert_eq!(p["amplitude_parameter"], "D0");
    let r = p["responses"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["response"] == "stick.phi")
        .unwrap();
    let m = model("inceptor");
    let frf = |from: f64, to: f64, step: f64| -> Vec<(f64, f64)> {
        let (f, t, st) = (from.to_string(), to.to_string(), step.to_string());
        let out = run(&[
            "frf",
            m.as_str(),
            "--set",
            "D0=1",
            "--param",
            "omega",
            "--from",
            &f,
            "--to",
            &t,
            "--step",
            &st,
            "--response",
            "stick.phi",
            "--json",
        ]);
        let j: Value = serde_json::from_slice(&out.stdout).unwrap();
        j["points"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| {
                (
                    r["omega"].as_f64().unwrap(),
                    r["stick.phi_amplitude"].as_f64().unwrap(),
                )
            })
            .collect()
    };
    let one_p = 258.0 * std::f64::consts::TAU / 60.0;
    for (tone, w, level_mm) in [("1P", one_p, 0.5), ("4P", 4.0 * one_p, 0.1)] {
        let t = r["tones"]
            .as_array()
            .unwrap()
            .iter()
            .find(|t| t["tone"] == tone)
            .unwrap();
        let h = frf(w, w, 1.0)[0].1;
        let got = t["amplitude"].as_f64().unwrap();
        assert!(
            (got - h * level_mm * 1e-3).abs() < 1e-9 * got,
            "{tone}: {got} vs {}",
            h * level_mm * 1e-3
        );
    }
    let (lo, hi) = (2.0 * std::f64::consts::TAU, 6.0 * std::f64::consts::TAU);
    let pts = frf(lo, hi, (hi - lo) / 4000.0);
    let psd = 0.01e-6; // m²/Hz
    let mut integral = 0.0;
    for k in 1..pts.len() {
        let df = (pts[k].0 - pts[k - 1].0) / std::f64::consts::TAU;
        integral += 0.5 * (pts[k].1.powi(2) + pts[k - 1].1.powi(2)) * psd * df;
    }
    let rms = r["random_rms"].as_f64().unwrap();
    assert!(
        (rms - integral.sqrt()).abs() < 2e-3 * rms,
        "{rms} vs {}",
        integral.sqrt()
    );
}

/// `--tune` without what it needs is a usage error (exit 2) naming the missing flag, and
/// writes nothing.
#[test]
fn tune_without_its_arguments_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("r.html");
    let m = model("inceptor");
    for (extra, missing) in [
        (vec!["--environment", "UH-60", "--tune"], "--tune-vary"),
        (
            vec!["--tune", "--tune-vary", "k_fs=50%..200%"],
            "--environment",
        ),
    ] {
        let mut args = vec!["report", m.as_str()];
        args.extend(extra);
        args.extend(["-o", html.to_str().unwrap()]);
        let out = run(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains(missing), "{err}");
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// A bad `--tune-vary` is named as the user typed it (it said `--vary k_fz: ...`, a
/// flag `report` does not have); so is `tune --tolerance`.
#[test]
fn a_bad_tune_vary_or_tolerance_names_its_own_flag() {
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("r.html");
    let m = model("inceptor");
    for (extra, said) in [
        (
            vec![
                "report",
                m.as_str(),
                "--environment",
                "UH-60",
                "--tune",
                "--tune-vary",
                "k_fz=50%..200%",
            ],
            "--tune-vary k_fz: the model has no parameter `k_fz`",
        ),
        (
            vec![
                "report",
                m.as_str(),
                "--environment",
                "UH-60",
                "--tune",
                "--tune-vary",
                "k_fs=50%..200%",
                "--tune-vary",
                "k_fs=60%..100%",
            ],
            "--tune-vary k_fs=60%..100%: `k_fs` is varied twice",
        ),
        (
            vec![
                "tune",
                m.as_str(),
                "--environment",
                "UH-60",
                "--vary",
                "k_fs=50%..200%",
                "--tolerance",
                "kfs=±5%",
            ],
            "--tolerance kfs: the model has no parameter `kfs`",
        ),
        // a tuning range the trim cannot hold: the advice names --tune-vary, not the
        // tolerances' --vary
        (
            vec![
                "report",
                m.as_str(),
                "--environment",
                "UH-60",
                "--tune",
                "--tune-vary",
                "l2=±80%",
            ],
            "narrow the range of --tune-vary l2",
        ),
    ] {
        let mut args = extra.clone();
        args.extend(["-o", html.to_str().unwrap()]);
        let out = run(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(err.contains(said) && err.contains("help:"), "{err}");
        assert!(
            !err.contains("--vary k_f") && !err.contains("one --vary"),
            "{err}"
        );
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn freq_unit_shows_the_pages_frequencies_in_the_unit_with_rad_s_beside() {
    let (_d, _, base_page, base) = report("inceptor", &["--environment", "UH-60"]);
    for (unit, scale) in [
        ("Hz", 1.0 / std::f64::consts::TAU),
        ("rpm", 30.0 / std::f64::consts::PI),
    ] {
        let (_dir, _, page, json) =
            report("inceptor", &["--environment", "UH-60", "--freq-unit", unit]);
        // the sidecar is the same document (rad/s), only the time it was made differs
        let strip = |j: &Value| {
            let mut j = j.clone();
            j["provenance"]["generated_utc"] = Value::Null;
            j
        };
        assert_eq!(strip(&json), strip(&base), "{unit}: the sidecar changed");
        // every number is the sidecar's, converted where the page says data-unit
        let bad = mismatches(&page, &json);
        assert!(bad.is_empty(), "{unit}: {}", bad.join("\n"));
        let unkeyed = unkeyed_numbers(&page);
        assert!(unkeyed.is_empty(), "{unit}: {}", unkeyed.join("\n"));
        let cells = keyed_numbers_in_units(&page);
        let converted: Vec<_> = cells.iter().filter(|c| c.1.is_some()).collect();
        assert!(
            converted.len() > 50,
            "{unit}: {} converted",
            converted.len()
        );
        for (key, u, text) in &converted {
            assert_eq!(u.as_deref(), Some(unit));
            // its rad/s companion is on the page, unconverted
            assert!(
                cells.iter().any(|c| c.0 == *key && c.1.is_none()),
                "{unit}: {key} ({text}) has no rad/s companion"
            );
        }
        // an independent check of one number: mode 2's ω_d in the unit
        let wd = json["modes"][1]["omega_d_rad_s"].as_f64().unwrap();
        let shown = &converted
            .iter()
            .find(|c| c.0 == "modes/1/omega_d_rad_s")
            .unwrap()
            .2;
        let x: f64 = shown.parse().unwrap();
        assert!(
            (x - wd * scale).abs() < 1e-3 * wd * scale,
            "{shown} vs {wd} rad/s"
        );
        // headers: the unit (the cycle rate named f, as the CLI's tables), rad/s beside
        // it; the sentences too
        assert!(
            !page.contains(&format!("ω_d [{unit}]")),
            "{unit}: ω_d in {unit}"
        );
        for h in [
            "f_d [UNIT]",
            "ω_d [rad/s]",
            "band low [UNIT]",
            "band low [rad/s]",
        ] {
            assert!(
                page.contains(&h.replace("UNIT", unit)),
                "{unit}: no header {h}"
            );
        }
        let worst =
            format!("data-key=\"sensitivity/modes/1/worst_case/max_rad_s\" data-unit=\"{unit}\">");
        assert!(page.contains(&worst), "{unit}: worst case not in {unit}");
        assert!(
            page.contains(&format!(" {unit} (<span class=\"num\"")),
            "{unit}: no companion"
        );
        // the figures' frequency axes in the unit, no rad/s left in them
        let svgs: Vec<&str> = page
            .split("<svg")
            .skip(1)
            .map(|s| &s[..s.find("</svg>").unwrap()])
            .collect();
        let frf = svgs
            .iter()
            .find(|s| s.contains("linear response to"))
            .unwrap();
        assert!(
            frf.contains(&format!("f [{unit}]"))
                && !frf.contains(&format!("ω [{unit}]"))
                && !frf.contains("rad/s"),
            "{unit}: FRF axis"
        );
        let campbell = svgs
            .iter()
            .find(|s| s.contains("Interference diagram"))
            .unwrap();
        assert!(
            campbell.contains(&format!("frequency [{unit}]")) && !campbell.contains("rad/s"),
            "{unit}: Campbell axis"
        );
        assert!(campbell.contains("rotor speed [rpm]"));
    }
    // the default page is unchanged: rad/s, no data-unit
    assert!(!base_page.contains("data-unit"));
}

/// The interference diagram's line labels (1P, 4P, 8P, 12P, 1T, 4T of the UH-60) do not
/// overlap: lines that leave the plot through its top close together (4T, 12P, 8P) had
/// their labels written side by side as one string. Read from the SVG: each label's box
/// (0.7 em per character, 1.2 em high, from its x, y) is apart from every other by a
/// quarter em at least.
#[test]
fn the_interference_diagrams_line_labels_do_not_overlap() {
    let (_dir, _, page, _) = report("inceptor", &["--environment", "UH-60"]);
    let at = page.find("Interference diagram (").unwrap();
    let svg = &page[page[..at].rfind("<svg").unwrap()..at + page[at..].find("</svg>").unwrap()];
    let width: f64 = {
        let w = &svg[svg.find("width=\"").unwrap() + 7..];
        w[..w.find('"').unwrap()].parse().unwrap()
    };
    let names = ["1P", "4P", "8P", "12P", "1T", "4T"];
    let mut boxes = Vec::new();
    for part in svg.split("<text").skip(1) {
        let attr = |name: &str| -> f64 {
            let a = &part[part.find(&format!(" {name}=\"")).unwrap() + name.len() + 3..];
            a[..a.find('"').unwrap()].parse().unwrap()
        };
        let text = part[part.find('>').unwrap() + 1..part.find("</text>").unwrap()].trim();
        if names.contains(&text) {
            let (x, y, em) = (attr("x"), attr("y"), attr("font-size"));
            boxes.push((
                text,
                x,
                y,
                x + 0.7 * em * text.len() as f64,
                y + 1.2 * em,
                em,
            ));
        }
    }
    assert_eq!(boxes.len(), names.len(), "{boxes:?}");
    for (i, a) in boxes.iter().enumerate() {
        assert!(
            a.1 >= 0.0 && a.3 <= width,
            "{} outside the figure: {a:?}",
            a.0
        );
        for b in &boxes[i + 1..] {
            let gap = 0.25 * a.5;
            let apart = a.3 + gap <= b.1 || b.3 + gap <= a.1 || a.4 <= b.2 || b.4 <= a.2;
            assert!(apart, "labels {} and {} overlap: {a:?} {b:?}", a.0, b.0);
        }
    }
}

/// Issues 10/11, leftovers: a --vary case that makes a damping coefficient negative is
/// warned of on the page itself, in a box at its top (it was in the sidecar's `warnings`
/// only); the environment's source text, which writes the UH-60's main rotor as
/// 27 rad/s, follows --freq-unit with rad/s beside it (27/2π = 4.297 Hz).
#[test]
fn warnings_and_the_environments_source_on_the_page() {
    let (_d, _, page, json) = report(
        "overcentre",
        &[
            "--environment",
            "UH-60",
            "--vary",
            "c=±200%",
            "--freq-unit",
            "Hz",
        ],
    );
    let w = json["warnings"][0]["message"].as_str().unwrap();
    assert!(w.contains("c = -5 N·s/m"), "{w}");
    let at = page
        .find("<aside class=\"warnings\"")
        .expect("no warnings box");
    let boxed = &page[at..at + page[at..].find("</aside>").unwrap()];
    assert!(boxed.contains(&w.replace('<', "&lt;")), "{boxed}");
    assert!(at < page.find("<section").unwrap(), "the box is not on top");
    assert_eq!(json["environment"]["source_rad_s"][0].as_f64(), Some(27.0));
    assert!(
        page.contains(r#"main rotor <span class="num" data-key="environment/source_rad_s/0" data-unit="Hz">4.3</span> Hz (<span class="num" data-key="environment/source_rad_s/0">27</span> rad/s)"#),
        "{}",
        &page[page.find("Forcing lines of").unwrap()..][..300]
    );
    assert!(mismatches(&page, &json).is_empty());
    // no warning, no box; in rad/s the source reads as written
    let (_d, _, page, _) = report("overcentre", &["--environment", "UH-60"]);
    assert!(!page.contains("<aside"));
    assert!(page.contains(
        r#"main rotor <span class="num" data-key="environment/source_rad_s/0">27</span> rad/s with 4 blades"#
    ));
}

/// Issue 10, point 4: the report's mode table shows a divergent mode (the overcentre about
/// its unstable middle equilibrium, undamped) as a growth rate and time constant, not as
/// a frequency with ζ = −1; the sidecar has them, with null ω_n, f, rpm and ζ. Undamped,
/// the rate is √(−ω²) of the equilibrium's negative undamped eigenvalue.
#[test]
fn a_divergent_mode_is_a_growth_rate_in_the_report() {
    let (_dir, _, page, json) = report("overcentre", &["--set", "theta1_0=0.26", "--set", "c=0"]);
    let rate = (-json["equilibrium"]["undamped_omega2"][0].as_f64().unwrap()).sqrt();
    let modes = json["modes"].as_array().unwrap();
    let k = modes.iter().position(|m| m["divergent"] == true).unwrap();
    let d = &modes[k];
    assert!((d["growth_rate_1_s"].as_f64().unwrap() - rate).abs() < 1e-9 * rate);
    assert!((d["time_constant_s"].as_f64().unwrap() - 1.0 / rate).abs() < 1e-9 / rate);
    for key in ["omega_n_rad_s", "freq_hz", "rpm", "damping_ratio"] {
        assert!(d[key].is_null(), "{key}: {}", d[key]);
        assert!(
            !page.contains(&format!("data-key=\"modes/{k}/{key}\"")),
            "{key} shown"
        );
    }
    let row = format!(
        "<td>divergent: grows as e^(+<span class=\"num\" data-key=\"modes/{k}/growth_rate_1_s\">{rate:.3}</span> t) (1/s), time constant <span class=\"num\" data-key=\"modes/{k}/time_constant_s\">{:.4}</span> s</td>",
        1.0 / rate
    );
    assert!(page.contains(&row), "no {row} in the page");
    let bad = mismatches(&page, &json);
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The linear response plots the coordinates the modes move: on the single-DoF slider
/// (tests/data/sdof.toml: m = 2 kg, k = 800 N/m, c = 6 N·s/m) that is `block.x`, not the
/// block's angle, which the prismatic joint holds at 0 (it plotted a line of zeros with no
/// peak). Its peak is the closed form's √(k/m − c²/(2m²)) within its stated ±.
#[test]
fn the_frf_section_plots_the_coordinates_the_modes_move() {
    let dir = tempfile::tempdir().unwrap();
    let html = dir.path().join("sdof.html");
    let m = format!("{}/tests/data/sdof.toml", env!("CARGO_MANIFEST_DIR"));
    let out = run(&["report", &m, "-o", html.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(html.with_extension("json")).unwrap())
            .unwrap();
    let responses: Vec<&str> = json["frf"]["responses"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["name"].as_str().unwrap())
        .collect();
    assert_eq!(responses, ["block.x"]);
    let peak = &json["frf"]["peaks"][0];
    let (m, k, c) = (2.0f64, 800.0f64, 6.0f64);
    let truth = (k / m - c * c / (2.0 * m * m)).sqrt();
    let got = peak["omega"].as_f64().unwrap();
    let u = peak["uncertainty"].as_f64().unwrap();
    assert!((got - truth).abs() <= u, "{got} vs {truth} (± {u})");
}
