//! Units of what the commands show: the unit in which printed frequencies are given
//! ([`FreqUnit`], `--freq-unit`), and the `units` map of every `--json` document
//! ([`Units`]: key or CSV column → unit, docs/units.md).
//!
//! CSV files and JSON values stay in SI (rad/s for frequencies, rad for angles): scripts
//! read them. Only printed tables and plot axes follow `--freq-unit`.

use crate::System;
use serde::Serialize;
use serde::ser::{SerializeMap, Serializer};

/// The unit in which a command prints and plots frequencies (`--freq-unit`); the values
/// computed and written to CSV/JSON are in rad/s whatever it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FreqUnit {
    #[default]
    RadPerSecond,
    Hertz,
    Rpm,
}

impl FreqUnit {
    /// `rad/s`, `Hz` or `rpm` (as `--freq-unit` takes them; `hz`, `rad_s` also).
    pub fn parse(text: &str) -> Option<FreqUnit> {
        match text.trim() {
            "rad/s" | "rad_s" | "rad s^-1" => Some(FreqUnit::RadPerSecond),
            "Hz" | "hz" | "HZ" => Some(FreqUnit::Hertz),
            "rpm" | "RPM" | "rev/min" => Some(FreqUnit::Rpm),
            _ => None,
        }
    }

    /// The unit's symbol: `rad/s`, `Hz`, `rpm`.
    pub fn symbol(self) -> &'static str {
        match self {
            FreqUnit::RadPerSecond => "rad/s",
            FreqUnit::Hertz => "Hz",
            FreqUnit::Rpm => "rpm",
        }
    }

    /// A frequency in rad/s expressed in this unit (ω, ω/2π, 60 ω/2π).
    pub fn of(self, rad_s: f64) -> f64 {
        match self {
            FreqUnit::RadPerSecond => rad_s,
            FreqUnit::Hertz => rad_s / std::f64::consts::TAU,
            FreqUnit::Rpm => rad_s * 60.0 / std::f64::consts::TAU,
        }
    }

    /// The unit a table shows beside this one: Hz, or rad/s when this one is Hz (a
    /// column must not repeat its neighbour).
    pub fn companion(self) -> FreqUnit {
        match self {
            FreqUnit::Hertz => FreqUnit::RadPerSecond,
            _ => FreqUnit::Hertz,
        }
    }

    /// The symbol of a frequency shown in this unit: `ω` (an angular frequency) in rad/s,
    /// `f` (a cycle rate) in Hz and rpm, as tables, axes and words name it (`ω_n [rad/s]`,
    /// `f_n [Hz]`; docs/units.md).
    pub fn rate(self) -> &'static str {
        match self {
            FreqUnit::RadPerSecond => "ω",
            FreqUnit::Hertz | FreqUnit::Rpm => "f",
        }
    }

    /// What a frequency parameter `param` (an angular frequency, rad/s) is called once
    /// shown in this unit: `omega` in rad/s, `omega/2π` in Hz and rpm (cycles, not
    /// radians: "omega = 0.4 Hz" would read as an angular frequency).
    pub fn quantity(self, param: &str) -> String {
        match self {
            FreqUnit::RadPerSecond => param.to_string(),
            FreqUnit::Hertz | FreqUnit::Rpm => format!("{param}/2π"),
        }
    }

    /// `rad_s` in this unit with `decimals` decimals and the symbol: `4.1234 Hz`.
    pub fn show(self, rad_s: f64, decimals: usize) -> String {
        format!("{:.decimals$} {}", self.of(rad_s), self.symbol())
    }
}

/// The numbers that free text (an environment's `source` or `notes`) writes in rad/s:
/// each number directly followed by ` rad/s`, as (its byte range in `text`, its value, the
/// decimals it is written with). Words such as `1P` are not numbers.
pub fn rad_s_in_text(text: &str) -> Vec<(std::ops::Range<usize>, f64, usize)> {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    for (at, _) in text.match_indices(" rad/s") {
        // the number ends where " rad/s" starts
        let mut start = at;
        while start > 0 && (bytes[start - 1].is_ascii_digit() || bytes[start - 1] == b'.') {
            start -= 1;
        }
        if start > 0 && bytes[start - 1] == b'-' {
            start -= 1;
        }
        // a number, not the end of a word ("v2 rad/s")
        if start == at || (start > 0 && (bytes[start - 1] as char).is_alphanumeric()) {
            continue;
        }
        let written = &text[start..at];
        if let Ok(v) = written.parse::<f64>() {
            let decimals = written.split_once('.').map_or(0, |(_, d)| d.len());
            out.push((start..at, v, decimals));
        }
    }
    out
}

/// `text` with each number it writes in rad/s ([`rad_s_in_text`]) shown in `unit`, the
/// rad/s after it in parentheses: `27 rad/s` → `4.3 Hz (27 rad/s)` (a decimal more in
/// Hz, one fewer in rpm, as the report's numbers); unchanged in rad/s.
pub fn text_in_unit(text: &str, unit: FreqUnit) -> String {
    if unit == FreqUnit::RadPerSecond {
        return text.to_string();
    }
    let mut out = String::new();
    let mut last = 0;
    for (range, v, decimals) in rad_s_in_text(text) {
        let d = match unit {
            FreqUnit::Hertz => decimals + 1,
            _ => decimals.saturating_sub(1),
        };
        let end = range.end + " rad/s".len();
        out.push_str(&text[last..range.start]);
        out.push_str(&format!(
            "{} ({})",
            unit.show(v, d),
            &text[range.start..end]
        ));
        last = end;
    }
    out.push_str(&text[last..]);
    out
}

impl std::str::FromStr for FreqUnit {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        FreqUnit::parse(s)
            .ok_or_else(|| format!("`{s}` is not a frequency unit: give rad/s, Hz or rpm"))
    }
}

impl std::fmt::Display for FreqUnit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.symbol())
    }
}

/// A JSON document's `units`: each key (a JSON key holding numbers, or a CSV column the
/// document repeats, such as a coordinate's name) → the unit of its values, in the order
/// added; a key added twice keeps its first unit. `"1"` marks a dimensionless number.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Units(Vec<(String, String)>);

impl Units {
    pub fn new() -> Self {
        Units::default()
    }

    /// With `key` → `unit` (unless `key` is there already).
    pub fn with(mut self, key: impl Into<String>, unit: impl Into<String>) -> Self {
        self.add(key, unit);
        self
    }

    /// Add `key` → `unit` (unless `key` is there already).
    pub fn add(&mut self, key: impl Into<String>, unit: impl Into<String>) {
        let key = key.into();
        if !self.0.iter().any(|(k, _)| *k == key) {
            self.0.push((key, unit.into()));
        }
    }

    /// With every pair of `pairs`.
    pub fn with_all<'a>(mut self, pairs: impl IntoIterator<Item = (&'a str, &'a str)>) -> Self {
        for (k, u) in pairs {
            self.add(k, u);
        }
        self
    }

    /// With each coordinate of `sys` → its unit ([`coordinate_unit`]).
    pub fn coordinates(mut self, sys: &System) -> Self {
        for (i, c) in sys.coordinates.iter().enumerate() {
            self.add(c.clone(), coordinate_unit(sys, i));
        }
        self
    }

    /// With each velocity column of `sys` (`<coordinate>_dot`, a free body's `b.vx`,
    /// `b.wx`) → its unit.
    pub fn velocities(mut self, sys: &System) -> Self {
        for c in sys.velocity_columns() {
            let unit = velocity_unit(sys, &c);
            self.add(c, unit);
        }
        self
    }

    /// With each response of `names` → its unit (a coordinate, a force element's tension,
    /// a point's position, a reaction: [`crate::system::outputs::Output::unit`]); a name
    /// the model does not know is left out.
    pub fn responses(mut self, sys: &System, names: &[String]) -> Self {
        for n in names {
            if let Ok(o) = sys.output(n) {
                self.add(n.clone(), o.unit(sys));
            }
        }
        self
    }

    /// The unit of `key`, if it has one here.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.0
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, u)| u.as_str())
    }

    /// The keys and units, in order.
    pub fn pairs(&self) -> &[(String, String)] {
        &self.0
    }
}

impl Serialize for Units {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(self.0.len()))?;
        for (k, u) in &self.0 {
            map.serialize_entry(k, u)?;
        }
        map.end()
    }
}

/// A coordinate's unit: `rad` for an angle, `m` for a length, `1` for a quaternion
/// component.
pub fn coordinate_unit(sys: &System, i: usize) -> &'static str {
    if sys.is_angle(i) {
        "rad"
    } else if sys.coordinate_dims[i] == crate::model::units::Dim::LENGTH {
        "m"
    } else {
        "1"
    }
}

/// A velocity column's unit: its coordinate's unit per second (`<coordinate>_dot`), or a
/// free body's `m/s` (`b.vx`) and `rad/s` (`b.wx`).
pub fn velocity_unit(sys: &System, column: &str) -> &'static str {
    if let Some(i) = column
        .strip_suffix("_dot")
        .and_then(|c| sys.coordinate_index(c))
    {
        return match coordinate_unit(sys, i) {
            "rad" => "rad/s",
            "m" => "m/s",
            _ => "1/s",
        };
    }
    match column.rsplit('.').next().and_then(|l| l.chars().next()) {
        Some('w') => "rad/s",
        _ => "m/s",
    }
}

/// A document with a `units` map after its own keys: `--json` output of every command
/// (`{...the document's keys..., "units": {key: unit}}`).
#[derive(Debug, Clone, Serialize)]
pub struct WithUnits<'a, T> {
    #[serde(flatten)]
    pub doc: T,
    pub units: &'a Units,
}

#[cfg(test)]
mod tests {

    #[test]
    fn rad_s_in_free_text_is_shown_in_the_unit() {
        let src = "UH-60A: main rotor 27 rad/s with 4 blades; 1P, tail 124.6 rad/s; v2 rad/s";
        let found = super::rad_s_in_text(src);
        assert_eq!(found.len(), 2, "{found:?}");
        assert_eq!((found[0].1, found[0].2), (27.0, 0));
        assert_eq!((found[1].1, found[1].2), (124.6, 1));
        assert_eq!(
            super::text_in_unit(src, FreqUnit::Hertz),
            "UH-60A: main rotor 4.3 Hz (27 rad/s) with 4 blades; 1P, tail 19.83 Hz (124.6 rad/s); v2 rad/s"
        );
        assert_eq!(
            super::text_in_unit(src, FreqUnit::Rpm),
            "UH-60A: main rotor 258 rpm (27 rad/s) with 4 blades; 1P, tail 1190 rpm (124.6 rad/s); v2 rad/s"
        );
        assert_eq!(super::text_in_unit(src, FreqUnit::RadPerSecond), src);
    }

    use super::*;

    #[test]
    fn frequency_units_convert_from_rad_s() {
        let w = 2.0 * std::f64::consts::PI * 3.0;
        assert_eq!(FreqUnit::parse("Hz"), Some(FreqUnit::Hertz));
        assert!((FreqUnit::Hertz.of(w) - 3.0).abs() < 1e-12);
        assert!((FreqUnit::Rpm.of(w) - 180.0).abs() < 1e-12);
        assert_eq!(FreqUnit::RadPerSecond.of(w), w);
        assert_eq!(FreqUnit::Hertz.show(w, 2), "3.00 Hz");
        assert!("kHz".parse::<FreqUnit>().is_err());
    }

    #[test]
    fn a_key_keeps_its_first_unit_and_the_order_is_kept() {
        let u = Units::new()
            .with("omega", "rad/s")
            .with("bar1.theta", "rad")
            .with("omega", "Hz");
        assert_eq!(u.get("omega"), Some("rad/s"));
        let text = serde_json::to_string(&u).unwrap();
        assert_eq!(text, r#"{"omega":"rad/s","bar1.theta":"rad"}"#);
    }
}

/// `x` to `digits` significant digits, in plain notation from 1e-4 to 1e7 (`2.968161`,
/// `1371.071`), in scientific notation outside it.
pub fn significant(x: f64, digits: usize) -> String {
    let a = x.abs();
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    if !(1e-4..1e7).contains(&a) {
        return format!("{x:.*e}", digits.saturating_sub(1));
    }
    let magnitude = a.log10().floor() as i64;
    let decimals = (digits as i64 - 1 - magnitude).max(0) as usize;
    format!("{x:.decimals$}")
}

/// A located value (a peak, a fold) and how well it is known, both in `unit` (already
/// converted): `2.828427125 rad/s (± 2.4e-10 rad/s)`, the value to the digits its
/// uncertainty supports (at least 7 significant, at most 15), the uncertainty to two.
/// `not_refined` names what the uncertainty is when the value was not refined (`the grid's
/// step`): `0.4774648 Hz (not refined: ± 0.080 Hz, the grid's step)`. The one format of
/// the peak lines of `frf`, `sweep` and `nfr`.
pub fn located(value: f64, uncertainty: f64, unit: &str, not_refined: Option<&str>) -> String {
    let digits = if uncertainty > 0.0 && value != 0.0 && uncertainty.is_finite() {
        ((value.abs() / uncertainty).log10().ceil() as i64 + 1).clamp(7, 15) as usize
    } else {
        7
    };
    let with_unit = |text: String| format!("{text} {unit}").trim_end().to_string();
    let u = with_unit(significant(uncertainty, 2));
    let how = match not_refined {
        None => format!("± {u}"),
        Some(what) => format!("not refined: ± {u}, {what}"),
    };
    format!("{} ({how})", with_unit(significant(value, digits)))
}

#[cfg(test)]
mod significant_tests {
    use super::significant;

    #[test]
    fn significant_digits() {
        assert_eq!(significant(1.371070973412056, 7), "1.371071");
        assert_eq!(significant(-1371.070973412056, 7), "-1371.071");
        assert_eq!(significant(2.5e-7, 3), "2.50e-7");
    }
}
