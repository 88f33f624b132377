//! The design-review report (`detune report`): one self-contained HTML file and a JSON
//! sidecar holding every number it shows.
//!
//! How it works:
//!
//! * The analyses' results are serialized (serde) into one JSON document, the
//!   [`Sidecar`]; each section adds its part under its own top-level key (`model`,
//!   `equilibrium`, `modes`, `frf`, `environment`, `campbell`, ...).
//! * The page is a [`Document`] of [`Section`]s, each a title and [`Block`]s: prose,
//!   [`Table`]s and [`Figure`]s (inline SVG strings). A numeric table cell is built
//!   *from the sidecar* by its key ([`Sidecar::num`]): a JSON Pointer (RFC 6901) without
//!   the leading `/`, e.g. `modes/0/omega_n_rad_s`. The cell shows the value rounded to
//!   its [`Digits`] and carries the key as `data-key`, so the HTML and the JSON cannot
//!   disagree, and a script (or the test suite) can check every number on the page.
//! * A number in running text (prose, a caption) is keyed the same way:
//!   [`Sidecar::inline`] gives it as a marked span inside the `String` (private-use
//!   characters around the key and the text shown), which the page renders as
//!   `<span class="num" data-key="...">26.531</span>`. So every number the page shows,
//!   in a table or in a sentence, is the sidecar's rounded and names where it is.
//! * [`Document::html`] renders the page with maud (compile-time templates, escaping by
//!   default): CSS inline in a `<style>`, print-friendly (A4 / letter, a page break before
//!   each section), no JavaScript and nothing fetched from the network.
//!
//! [`build`] assembles the report from a model ([`build::ReportInputs`]); sections that
//! come later (margins, sensitivity, tuning) are added by the same means:
//! [`Report::add_data`] puts their results into the sidecar, and a [`Section`] of
//! [`Table`]s keyed into it is pushed onto [`Report::document`].

pub mod build;
pub mod environment;
pub mod figures;
pub mod studies;

pub use build::{ReportInputs, build};
pub use environment::{Environment, ForcingLine, Rotor};

use crate::diag::{Error, Result};
use crate::output::units::FreqUnit;
use maud::{DOCTYPE, Markup, PreEscaped, html};
use serde_json::{Map, Value};

/// How many digits a number is shown with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Digits {
    /// `{:.N}`: N decimals (`26.531`).
    Fixed(usize),
    /// `{:.Ne}`: scientific, N decimals in the mantissa (`1.234e-5`).
    Sci(usize),
    /// N significant digits: fixed for 1e-3 ≤ |x| < 1e6 (`0.1350`), else scientific
    /// (`1.295e5`); shown in one of the two forms above.
    Sig(usize),
}

impl Digits {
    /// `x` as shown; NaN and infinities (null in the sidecar) as `n/a`.
    pub fn format(self, x: f64) -> String {
        if !x.is_finite() {
            return "n/a".into();
        }
        match self {
            Digits::Fixed(n) => format!("{x:.n$}"),
            Digits::Sci(n) => format!("{x:.n$e}"),
            Digits::Sig(n) => {
                let n = n.max(1);
                let a = x.abs();
                if a == 0.0 {
                    format!("{x:.0$}", n - 1)
                } else if (1e-3..1e6).contains(&a) {
                    let e = a.log10().floor() as i64;
                    let decimals = (n as i64 - 1 - e).max(0) as usize;
                    format!("{x:.decimals$}")
                } else {
                    format!("{x:.0$e}", n - 1)
                }
            }
        }
    }
}

/// One table cell.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    Text(String),
    /// A number of the sidecar: its key (JSON Pointer without the leading `/`), its value
    /// (None: null, not a number) and how it is shown.
    Number {
        key: String,
        value: Option<f64>,
        digits: Digits,
        /// Shown in this frequency unit (the value, in rad/s, converted; the page marks
        /// the cell `data-unit`), or as the sidecar holds it (None).
        unit: Option<FreqUnit>,
    },
}

impl Cell {
    pub fn text(s: impl Into<String>) -> Cell {
        Cell::Text(s.into())
    }

    /// The text shown.
    pub fn shown(&self) -> String {
        match self {
            Cell::Text(s) => s.clone(),
            Cell::Number {
                value,
                digits,
                unit,
                ..
            } => {
                let x = value.unwrap_or(f64::NAN);
                digits.format(unit.map_or(x, |u| u.of(x)))
            }
        }
    }
}

/// A table column: its title and the unit of its numbers (shown in the header as
/// `title [unit]`; empty for none).
#[derive(Debug, Clone)]
pub struct Column {
    pub title: String,
    pub unit: String,
}

impl Column {
    pub fn new(title: impl Into<String>, unit: impl Into<String>) -> Column {
        Column {
            title: title.into(),
            unit: unit.into(),
        }
    }

    fn header(&self) -> String {
        if self.unit.is_empty() {
            self.title.clone()
        } else {
            format!("{} [{}]", self.title, self.unit)
        }
    }
}

/// A table: a caption, columns and rows of cells.
#[derive(Debug, Clone)]
pub struct Table {
    pub caption: String,
    pub columns: Vec<Column>,
    pub rows: Vec<Vec<Cell>>,
}

/// A figure: an inline SVG document and its caption.
#[derive(Debug, Clone)]
pub struct Figure {
    pub caption: String,
    /// The `<svg ...>...</svg>` element (an XML declaration before it is dropped).
    pub svg: String,
}

/// What a section holds, in order.
#[derive(Debug, Clone)]
pub enum Block {
    Prose(String),
    /// A command to copy, shown verbatim (its numbers are arguments, not results).
    Code(String),
    Table(Table),
    Figure(Figure),
}

/// One section of the report.
#[derive(Debug, Clone)]
pub struct Section {
    /// Its HTML id (`modes`, `frf`...), also the anchor of the table of contents.
    pub id: String,
    pub title: String,
    pub blocks: Vec<Block>,
}

impl Section {
    pub fn new(id: &str, title: &str) -> Section {
        Section {
            id: id.into(),
            title: title.into(),
            blocks: Vec::new(),
        }
    }
    pub fn prose(mut self, text: impl Into<String>) -> Section {
        self.blocks.push(Block::Prose(text.into()));
        self
    }
    pub fn code(mut self, text: impl Into<String>) -> Section {
        self.blocks.push(Block::Code(text.into()));
        self
    }
    pub fn table(mut self, t: Table) -> Section {
        self.blocks.push(Block::Table(t));
        self
    }
    pub fn figure(mut self, caption: impl Into<String>, svg: String) -> Section {
        self.blocks.push(Block::Figure(Figure {
            caption: caption.into(),
            svg,
        }));
        self
    }
}

/// The whole page: a title, a subtitle line, the warnings and the sections.
#[derive(Debug, Clone)]
pub struct Document {
    pub title: String,
    pub subtitle: String,
    /// What the reader must know before reading the numbers (a tolerance case that makes
    /// a damping coefficient negative): shown in a box at the top of the page.
    pub warnings: Vec<String>,
    pub sections: Vec<Section>,
}

/// The JSON sidecar: every number the report shows, by key.
#[derive(Debug, Clone, Default)]
pub struct Sidecar(pub Map<String, Value>);

/// A key segment escaped for a JSON Pointer (`~` → `~0`, `/` → `~1`).
pub fn escape_key(segment: &str) -> String {
    segment.replace('~', "~0").replace('/', "~1")
}

impl Sidecar {
    /// Put `value` (serialized) under the top-level `key`.
    pub fn insert(&mut self, key: &str, value: &impl serde::Serialize) -> Result<()> {
        let v = serde_json::to_value(value)
            .map_err(|e| Error::io("report.json", format!("cannot serialize {key}: {e}")))?;
        self.0.insert(key.to_string(), v);
        Ok(())
    }

    /// The value at `key` (a JSON Pointer without the leading `/`).
    pub fn get(&self, key: &str) -> Option<&Value> {
        let (head, rest) = key.split_once('/').unwrap_or((key, ""));
        let v = self.0.get(head)?;
        if rest.is_empty() {
            Some(v)
        } else {
            v.pointer(&format!("/{rest}"))
        }
    }

    /// The numeric cell of `key` shown with `digits`: the number is read from the
    /// sidecar, so the page shows what the JSON holds (a missing or non-numeric value is
    /// shown as `n/a`, as NaN, which JSON writes as null).
    pub fn num(&self, key: impl Into<String>, digits: Digits) -> Cell {
        let key = key.into();
        let value = self.get(&key).and_then(Value::as_f64);
        Cell::Number {
            key,
            value,
            digits,
            unit: None,
        }
    }

    /// The number at `key` shown with `digits` inside running text (prose, a caption): a
    /// marked span that the page renders with its `data-key` (see the module doc).
    pub fn inline(&self, key: impl Into<String>, digits: Digits) -> String {
        let cell = self.num(key, digits);
        let shown = cell.shown();
        match cell {
            Cell::Number { key, .. } => {
                format!("{INLINE_OPEN}{key}{INLINE_MID}{shown}{INLINE_CLOSE}")
            }
            Cell::Text(t) => t,
        }
    }

    /// The text at `key` (a string, or any other value as JSON), for a text cell.
    pub fn text(&self, key: &str) -> Cell {
        Cell::Text(match self.get(key) {
            Some(Value::String(s)) => s.clone(),
            Some(v) => v.to_string(),
            None => String::new(),
        })
    }

    /// The whole document, pretty-printed.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(&self.0).unwrap_or_default()
    }
}

/// The report: the page and its sidecar.
#[derive(Debug, Clone)]
pub struct Report {
    pub document: Document,
    pub sidecar: Sidecar,
}

impl Report {
    /// A warning shown in the box at the top of the page (put it in the sidecar's
    /// `warnings` too, for scripts).
    pub fn warn(&mut self, text: impl Into<String>) {
        self.document.warnings.push(text.into());
    }

    /// Put a section's results into the sidecar under `key` (to be shown by cells keyed
    /// `key/...`).
    pub fn add_data(&mut self, key: &str, value: &impl serde::Serialize) -> Result<()> {
        self.sidecar.insert(key, value)
    }

    /// Write the HTML page to `html_path` and the sidecar to `json_path`, both or
    /// neither: each is rendered to a temporary file first and the two are committed
    /// together ([`crate::output::OutputSet`]).
    pub fn write(&self, html_path: &str, json_path: &str) -> Result<()> {
        let page = self.document.html();
        let json = self.sidecar.to_json();
        let outputs = crate::output::OutputSet::plan(&[], &[Some(html_path), Some(json_path)])?;
        crate::output::write_atomic(html_path, |w| w.write_all(page.as_bytes()))?;
        crate::output::write_atomic(json_path, |w| {
            w.write_all(json.as_bytes())?;
            w.write_all(b"\n")
        })?;
        outputs.commit()
    }
}

// ---- --freq-unit --------------------------------------------------------------------------

/// `digits` for a frequency shown in `unit` instead of rad/s, to about as many
/// significant digits: a decimal more in Hz (÷ 2π), one fewer in rpm (× 9.55).
fn digits_in(digits: Digits, unit: FreqUnit) -> Digits {
    match (digits, unit) {
        (Digits::Fixed(n), FreqUnit::Hertz) => Digits::Fixed(n + 1),
        (Digits::Fixed(n), FreqUnit::Rpm) => Digits::Fixed(n.saturating_sub(1)),
        (d, _) => d,
    }
}

/// The digits a shown number was written with (`26.531` → Fixed(3), `1.2e-5` → Sci(1)).
fn digits_of(shown: &str) -> Digits {
    let decimals = |s: &str| s.split_once('.').map_or(0, |(_, d)| d.len());
    match shown.split_once('e') {
        Some((m, _)) => Digits::Sci(decimals(m)),
        None => Digits::Fixed(decimals(shown)),
    }
}

impl Report {
    /// The page with its frequencies shown in `unit` (`--freq-unit`), rad/s beside them;
    /// the sidecar is unchanged (rad/s), and each converted number is marked `data-unit`
    /// so that a script can check it against the sidecar:
    ///
    /// * a table column in rad/s (or `rad/s per unit`) becomes two, the unit's (the
    ///   sidecar's numbers converted) and rad/s beside it, unless one of the next two
    ///   columns is already in the unit (the modes table's `f_n [Hz]`, `f_n [rpm]`); a
    ///   row whose unit cell says `rad/s` (the tuning table) shows its numbers in the
    ///   unit, the unit cell naming the rad/s values;
    /// * in prose, captions and text cells a keyed number (or a range `a–b`, `a to b`)
    ///   followed by ` rad/s` is shown in the unit, the rad/s text in parentheses after it.
    ///
    /// Rotor speeds (rpm columns of the environment and the interference diagram) are
    /// speeds, not converted.
    pub fn in_frequency_unit(&mut self, unit: FreqUnit) {
        if unit == FreqUnit::RadPerSecond {
            return;
        }
        let data = &self.sidecar;
        for section in &mut self.document.sections {
            for block in &mut section.blocks {
                match block {
                    Block::Prose(p) => *p = text_in(data, p, unit),
                    Block::Figure(f) => f.caption = text_in(data, &f.caption, unit),
                    Block::Code(_) => {}
                    Block::Table(t) => table_in(data, t, unit),
                }
            }
        }
    }
}

/// A number cell shown in `unit`.
fn cell_in(cell: &Cell, unit: FreqUnit) -> Cell {
    match cell {
        Cell::Number {
            key,
            value,
            digits,
            unit: None,
        } => Cell::Number {
            key: key.clone(),
            value: *value,
            digits: digits_in(*digits, unit),
            unit: Some(unit),
        },
        c => c.clone(),
    }
}

fn table_in(data: &Sidecar, t: &mut Table, unit: FreqUnit) {
    t.caption = text_in(data, &t.caption, unit);
    for row in &mut t.rows {
        for c in row.iter_mut() {
            if let Cell::Text(s) = c {
                *s = text_in(data, s, unit);
            }
        }
    }
    // rows whose unit cell says rad/s (the tuning table: parameter, baseline, design, unit)
    for row in &mut t.rows {
        let Some(u) = row
            .iter()
            .position(|c| matches!(c, Cell::Text(s) if s == "rad/s"))
        else {
            continue;
        };
        // the numbers of columns without a unit of their own
        let numbers: Vec<usize> = (0..row.len())
            .filter(|&i| matches!(row[i], Cell::Number { unit: None, .. }))
            .filter(|&i| t.columns.get(i).is_none_or(|c| c.unit.is_empty()))
            .collect();
        if numbers.is_empty() {
            continue;
        }
        let companion: Vec<String> = numbers
            .iter()
            .map(|&i| match &row[i] {
                Cell::Number { key, digits, .. } => data.inline(key.clone(), *digits),
                _ => String::new(),
            })
            .collect();
        for &i in &numbers {
            row[i] = cell_in(&row[i], unit);
        }
        row[u] = Cell::Text(format!(
            "{} ({} rad/s)",
            unit.symbol(),
            companion.join(", ")
        ));
    }
    // columns in rad/s: the unit's, then rad/s
    let mut i = 0;
    while i < t.columns.len() {
        let c = &t.columns[i];
        let per = c.unit.strip_prefix("rad/s");
        let shown_beside = t.columns[i + 1..]
            .iter()
            .take(2)
            .any(|n| n.unit == unit.symbol());
        match per {
            Some(rest) if !shown_beside => {
                // the converted column names the cycle rate it shows (f_n in Hz, as the
                // CLI's tables: `ω_n` → `f_n`, `dω_n/dp` → `df_n/dp`)
                let converted = Column::new(
                    c.title.replace('ω', unit.rate()),
                    format!("{}{rest}", unit.symbol()),
                );
                t.columns.insert(i, converted);
                for row in &mut t.rows {
                    if let Some(cell) = row.get(i) {
                        let new = cell_in(cell, unit);
                        row.insert(i, new);
                    }
                }
                i += 2;
            }
            _ => i += 1,
        }
    }
}

/// `text` with each keyed number (or range of two, `a–b`, `a to b`) followed by ` rad/s`
/// shown in `unit`, the rad/s text after it in parentheses.
fn text_in(data: &Sidecar, text: &str, unit: FreqUnit) -> String {
    // the text as pieces: plain text and keyed numbers (key, shown)
    enum Piece<'a> {
        Plain(&'a str),
        Num(&'a str, &'a str),
    }
    let mut pieces = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find(INLINE_OPEN) {
        let after = &rest[i + INLINE_OPEN.len_utf8()..];
        let (Some(m), Some(c)) = (after.find(INLINE_MID), after.find(INLINE_CLOSE)) else {
            break;
        };
        pieces.push(Piece::Plain(&rest[..i]));
        pieces.push(Piece::Num(
            &after[..m],
            &after[m + INLINE_MID.len_utf8()..c],
        ));
        rest = &after[c + INLINE_CLOSE.len_utf8()..];
    }
    pieces.push(Piece::Plain(rest));
    let span =
        |key: &str, shown: &str| format!("{INLINE_OPEN}{key}{INLINE_MID}{shown}{INLINE_CLOSE}");
    let converted = |key: &str, shown: &str| -> String {
        if key.contains(INLINE_UNIT) {
            return span(key, shown);
        }
        let cell = data.num(key, digits_of(shown));
        let cell = cell_in(&cell, unit);
        format!(
            "{INLINE_OPEN}{key}{INLINE_UNIT}{}{INLINE_MID}{}{INLINE_CLOSE}",
            unit.symbol(),
            cell.shown()
        )
    };
    let mut out = String::new();
    let mut k = 0;
    while k < pieces.len() {
        match pieces[k] {
            Piece::Plain(p) => {
                out.push_str(p);
                k += 1;
            }
            Piece::Num(key, shown) => {
                // a range: number, `–` or ` to `, number
                let range = match (pieces.get(k + 1), pieces.get(k + 2)) {
                    (Some(Piece::Plain(sep)), Some(Piece::Num(k2, s2)))
                        if *sep == "–" || *sep == " to " =>
                    {
                        Some((*sep, *k2, *s2))
                    }
                    _ => None,
                };
                let next = k + if range.is_some() { 3 } else { 1 };
                match pieces.get(next) {
                    Some(Piece::Plain(p)) if p.starts_with(" rad/s") => {
                        let tail = &p[" rad/s".len()..];
                        let (new, old) = match range {
                            Some((sep, k2, s2)) => (
                                format!("{}{sep}{}", converted(key, shown), converted(k2, s2)),
                                format!("{}{sep}{}", span(key, shown), span(k2, s2)),
                            ),
                            None => (converted(key, shown), span(key, shown)),
                        };
                        out.push_str(&format!("{new} {} ({old} rad/s){tail}", unit.symbol()));
                        k = next + 1;
                    }
                    _ => {
                        out.push_str(&span(key, shown));
                        k += 1;
                    }
                }
            }
        }
    }
    out
}

/// The marks of a keyed number in running text ([`Sidecar::inline`]): Unicode private-use
/// characters, which no model name or message contains.
const INLINE_OPEN: char = '\u{E000}';
const INLINE_MID: char = '\u{E001}';
const INLINE_CLOSE: char = '\u{E002}';
/// Between a keyed number's key and the frequency unit it is shown in (`data-unit`).
const INLINE_UNIT: char = '\u{E003}';

/// Running text with its keyed numbers ([`Sidecar::inline`]) as
/// `<span class="num" data-key=...>`; the rest escaped.
fn rich(text: &str) -> Markup {
    let mut parts: Vec<(Option<&str>, &str)> = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find(INLINE_OPEN) {
        parts.push((None, &rest[..i]));
        let after = &rest[i + INLINE_OPEN.len_utf8()..];
        let (Some(m), Some(c)) = (after.find(INLINE_MID), after.find(INLINE_CLOSE)) else {
            break;
        };
        parts.push((Some(&after[..m]), &after[m + INLINE_MID.len_utf8()..c]));
        rest = &after[c + INLINE_CLOSE.len_utf8()..];
    }
    parts.push((None, rest));
    html! {
        @for (key, text) in parts {
            @match key.map(|k| k.split_once(INLINE_UNIT).map_or((k, None), |(k, u)| (k, Some(u)))) {
                Some((k, Some(u))) => span class="num" data-key=(k) data-unit=(u) { (text) },
                Some((k, None)) => span class="num" data-key=(k) { (text) },
                None => (text),
            }
        }
    }
}

/// The page's style: readable system fonts, tables with right-aligned numbers, figures
/// scaled to the page width, A4 / letter print with a page break before each section.
const CSS: &str = r#"
:root { color-scheme: light; }
body { font-family: "Helvetica Neue", Helvetica, Arial, "Liberation Sans", "DejaVu Sans", sans-serif;
  font-size: 11pt; line-height: 1.45; color: #1a1a1a; max-width: 60rem; margin: 1.5rem auto; padding: 0 1rem; }
h1 { font-size: 1.7em; margin-bottom: 0.2em; }
h2 { font-size: 1.3em; border-bottom: 1px solid #888; padding-bottom: 0.15em; margin-top: 2em; }
.subtitle { color: #444; margin-top: 0; }
nav ol { columns: 2; font-size: 0.95em; }
table { border-collapse: collapse; margin: 0.8em 0 1.2em; font-size: 0.92em; }
caption { caption-side: top; text-align: left; font-weight: bold; padding-bottom: 0.3em; }
th, td { border: 1px solid #bbb; padding: 0.2em 0.55em; vertical-align: top; }
th { background: #eef1f5; text-align: left; }
span.num { font-variant-numeric: tabular-nums; }
pre { white-space: pre-wrap; word-break: break-all; font-size: 0.88em; background: #f4f5f7; padding: 0.4em 0.6em; }
td.num { text-align: right; font-variant-numeric: tabular-nums; font-family: "DejaVu Sans Mono", "Liberation Mono", Menlo, Consolas, monospace; }
figure { margin: 1em 0; page-break-inside: avoid; break-inside: avoid; }
figure svg { max-width: 100%; height: auto; display: block; }
figcaption { font-size: 0.92em; color: #333; margin-top: 0.3em; }
.pass { color: #176b1d; font-weight: bold; }
aside.warnings { border: 2px solid #b35806; border-left-width: 0.5em; background: #fff3e0; padding: 0.4em 1em; margin: 1em 0; }
aside.warnings .warnings-title { font-weight: bold; color: #8a3c00; margin: 0.2em 0; }
aside.warnings ul { margin: 0.2em 0; padding-left: 1.2em; }
.fail { color: #a4161a; font-weight: bold; }
footer { margin-top: 3em; font-size: 0.85em; color: #555; }
@page { size: A4; margin: 15mm; }
@media print {
  body { max-width: none; margin: 0; padding: 0; font-size: 10pt; }
  section { break-before: page; page-break-before: always; }
  nav { display: none; }
  table, figure { break-inside: avoid; page-break-inside: avoid; }
}
"#;

/// `svg` from its `<svg` element on (drops an XML declaration or doctype, which an HTML
/// page must not contain inline), without the SVG namespace declaration (an HTML parser
/// puts `<svg>` in it anyway), so that the page names no URL at all.
fn inline_svg(svg: &str) -> String {
    let s = svg.find("<svg").map(|i| &svg[i..]).unwrap_or("");
    s.replacen(r#" xmlns="http://www.w3.org/2000/svg""#, "", 1)
}

fn render_table(t: &Table) -> Markup {
    html! {
        table {
            @if !t.caption.is_empty() { caption { (rich(&t.caption)) } }
            thead { tr { @for c in &t.columns { th { (c.header()) } } } }
            tbody {
                @for row in &t.rows {
                    tr {
                        @for cell in row {
                            @match cell {
                                Cell::Text(s) => td { (rich(s)) },
                                Cell::Number { key, unit: Some(u), .. } => td class="num" data-key=(key) data-unit=(u.symbol()) { (cell.shown()) },
                                Cell::Number { key, .. } => td class="num" data-key=(key) { (cell.shown()) },
                            }
                        }
                    }
                }
            }
        }
    }
}

impl Document {
    /// The page as one self-contained HTML document.
    pub fn html(&self) -> String {
        let page = html! {
            (DOCTYPE)
            html lang="en" {
                head {
                    meta charset="utf-8";
                    meta name="viewport" content="width=device-width, initial-scale=1";
                    meta name="generator" content=(format!("detune {}", env!("CARGO_PKG_VERSION")));
                    title { (self.title) }
                    style { (PreEscaped(CSS)) }
                }
                body {
                    header {
                        h1 { (self.title) }
                        p.subtitle { (self.subtitle) }
                    }
                    @if !self.warnings.is_empty() {
                        aside.warnings role="note" {
                            p.warnings-title { "Warning" @if self.warnings.len() > 1 { "s" } }
                            ul { @for w in &self.warnings { li { (w) } } }
                        }
                    }
                    nav {
                        ol { @for s in &self.sections { li { a href=(format!("#{}", s.id)) { (s.title) } } } }
                    }
                    @for s in &self.sections {
                        section id=(s.id) {
                            h2 { (s.title) }
                            @for b in &s.blocks {
                                @match b {
                                    Block::Prose(p) => p { (rich(p)) },
                                    Block::Code(c) => pre { code { (c) } },
                                    Block::Table(t) => (render_table(t)),
                                    Block::Figure(f) => figure {
                                        (PreEscaped(inline_svg(&f.svg)))
                                        figcaption { (rich(&f.caption)) }
                                    },
                                }
                            }
                        }
                    }
                    footer {
                        "Every number computed for this page carries its key into the JSON sidecar (data-key). Made by detune "
                        (env!("CARGO_PKG_VERSION")) "."
                    }
                }
            }
        };
        page.into_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_show_the_sidecar_value_rounded() {
        let mut s = Sidecar::default();
        s.insert(
            "modes",
            &vec![serde_json::json!({"omega_n_rad_s": 26.530560})],
        )
        .unwrap();
        let c = s.num("modes/0/omega_n_rad_s", Digits::Fixed(2));
        assert_eq!(c.shown(), "26.53");
        assert_eq!(s.num("modes/0/missing", Digits::Fixed(2)).shown(), "n/a");
        assert_eq!(Digits::Sci(3).format(1.23456e-5), "1.235e-5");
        assert_eq!(escape_key("a/b~c"), "a~1b~0c");
        assert_eq!(Digits::Sig(4).format(0.135), "0.1350");
        assert_eq!(Digits::Sig(4).format(129500.0), "129500");
        assert_eq!(Digits::Sig(4).format(1.295e6), "1.295e6");
        assert_eq!(Digits::Sig(3).format(-0.0002), "-2.00e-4");
    }

    #[test]
    fn a_page_escapes_text_and_keeps_keys() {
        let mut s = Sidecar::default();
        s.insert("x", &serde_json::json!({"v": 1.5})).unwrap();
        let doc = Document {
            title: "a <b> & c".into(),
            subtitle: String::new(),
            warnings: Vec::new(),
            sections: vec![Section::new("one", "One").table(Table {
                caption: "t".into(),
                columns: vec![Column::new("v", "m")],
                rows: vec![vec![s.num("x/v", Digits::Fixed(1))]],
            })],
        };
        let page = doc.html();
        assert!(page.contains("a &lt;b&gt; &amp; c"));
        assert!(page.contains(r#"<td class="num" data-key="x/v">1.5</td>"#));
        assert!(page.contains("v [m]"));
    }

    #[test]
    fn freq_unit_converts_rad_s_columns_rows_and_sentences() {
        let mut s = Sidecar::default();
        s.insert("m", &serde_json::json!({"w": 6.283185307179586, "r": 2.0}))
            .unwrap();
        let sentence = format!(
            "at {} rad/s; ratio {}",
            s.inline("m/w", Digits::Fixed(3)),
            s.inline("m/r", Digits::Fixed(1))
        );
        let mut report = Report {
            document: Document {
                title: String::new(),
                subtitle: String::new(),
                warnings: Vec::new(),
                sections: vec![Section::new("x", "X").prose(sentence).table(Table {
                    caption: String::new(),
                    columns: vec![
                        Column::new("ω", "rad/s"),
                        Column::new("what", ""),
                        Column::new("v", ""),
                        Column::new("unit", ""),
                    ],
                    rows: vec![vec![
                        s.num("m/w", Digits::Fixed(3)),
                        Cell::text("mode ω_n"),
                        s.num("m/w", Digits::Fixed(4)),
                        Cell::text("rad/s"),
                    ]],
                })],
            },
            sidecar: s,
        };
        report.in_frequency_unit(FreqUnit::Hertz);
        let page = report.document.html();
        // the column: Hz then rad/s; the row with a rad/s unit cell: Hz, rad/s named
        assert!(page.contains("f [Hz]</th><th>ω [rad/s]"), "{page}");
        assert!(page.contains(r#"<td class="num" data-key="m/w" data-unit="Hz">1.0000</td><td class="num" data-key="m/w">6.283</td>"#), "{page}");
        assert!(page.contains(r#"<td class="num" data-key="m/w" data-unit="Hz">1.00000</td><td>Hz (<span class="num" data-key="m/w">6.2832</span> rad/s)</td>"#), "{page}");
        // the sentence: the number followed by rad/s, not the ratio
        assert!(page.contains(r#"at <span class="num" data-key="m/w" data-unit="Hz">1.0000</span> Hz (<span class="num" data-key="m/w">6.283</span> rad/s); ratio <span class="num" data-key="m/r">2.0</span>"#), "{page}");
    }
}
