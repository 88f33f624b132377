//! Units of measure: a small hand-written table of engineering units and a parser for
//! compound unit strings such as `lbf*in*s/rad` or `kg*m^2`.
//!
//! No crate fits this job: the dimensional-analysis crates (`uom`, `dimensioned`, …) check
//! units in the type system at compile time, whereas detune reads units as text from a model
//! file at run time, mixes SI with US customary units, and needs its own convention for
//! angles and frequencies (below). The table is short enough to write and review by hand.
//!
//! # Dimensions
//!
//! A [`Dim`] is a vector of integer powers of length, mass and time. Every unit has an SI
//! factor and a `Dim`: `1 lbf = 4.4482216152605 kg·m·s^-2`.
//!
//! # Angles and frequencies
//!
//! Angles are dimensionless: `rad = 1`, `deg = π/180`, `rev = cycle = turn = 2π`. A
//! frequency is therefore an angle per time, and **all frequencies in detune are angular
//! (rad/s) internally**: `Hz` means cycles per second, so `1 Hz = 2π rad/s`, and
//! `1 rpm = 2π/60 rad/s`. Hence `4.3 Hz` and `258 rpm` are both ≈ 27.0177 rad/s, and
//! `rad/s` (or plain `1/s`) is the unit to use for a value that is already angular.
//!
//! # Compound units
//!
//! [`parse_unit`] reads unit names joined by `*` (or `·`) and `/`, each with an optional
//! integer power `^2`, `^-1`. Operators apply strictly **left to right**, with no
//! parentheses: `a/b*c` means `a·c/b` and `a/b/c` means `a/(b·c)`. Whitespace is allowed
//! around operators. A leading `1` is allowed as a dimensionless numerator (`1/s`).
//!
//! Exact definitions are used wherever they exist: `in = 0.0254 m`, `lb = 0.45359237 kg`,
//! standard gravity `g0 = 9.80665 m/s^2`, `lbf = lb·g0`, `kgf = kg·g0`.

use std::f64::consts::{PI, TAU};
use std::fmt;

/// Physical dimension: integer powers of length (m), mass (kg) and time (s).
///
/// Angles are dimensionless (see the [module documentation](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Dim {
    /// Power of length (metre).
    pub length: i8,
    /// Power of mass (kilogram).
    pub mass: i8,
    /// Power of time (second).
    pub time: i8,
}

impl Dim {
    /// Dimensionless (also angles, `rad`).
    pub const NONE: Dim = Dim::new(0, 0, 0);
    /// Length, m.
    pub const LENGTH: Dim = Dim::new(1, 0, 0);
    /// Mass, kg.
    pub const MASS: Dim = Dim::new(0, 1, 0);
    /// Time, s.
    pub const TIME: Dim = Dim::new(0, 0, 1);
    /// Force, N = kg·m·s^-2.
    pub const FORCE: Dim = Dim::new(1, 1, -2);
    /// Linear stiffness, N/m.
    pub const STIFFNESS: Dim = Dim::new(0, 1, -2);
    /// Linear viscous damping, N·s/m.
    pub const DAMPING: Dim = Dim::new(0, 1, -1);
    /// Moment of inertia, kg·m^2.
    pub const INERTIA: Dim = Dim::new(2, 1, 0);
    /// Torque (and energy), N·m.
    pub const TORQUE: Dim = Dim::new(2, 1, -2);
    /// Angular stiffness, N·m/rad = N·m (the radian is dimensionless).
    pub const ANGULAR_STIFFNESS: Dim = Dim::TORQUE;
    /// Angular viscous damping, N·m·s/rad = N·m·s.
    pub const ANGULAR_DAMPING: Dim = Dim::new(2, 1, -1);
    /// Frequency, 1/s (angular: rad/s).
    pub const FREQUENCY: Dim = Dim::new(0, 0, -1);
    /// Velocity, m/s.
    pub const VELOCITY: Dim = Dim::new(1, 0, -1);
    /// Acceleration, m/s^2.
    pub const ACCELERATION: Dim = Dim::new(1, 0, -2);
    /// Energy, J = N·m (same dimension as torque).
    pub const ENERGY: Dim = Dim::TORQUE;
    /// Power, W = N·m/s.
    pub const POWER: Dim = Dim::new(2, 1, -3);
    /// Pressure or stress, Pa = N/m^2.
    pub const PRESSURE: Dim = Dim::new(-1, 1, -2);

    /// A dimension from its powers of length, mass and time.
    pub const fn new(length: i8, mass: i8, time: i8) -> Dim {
        Dim { length, mass, time }
    }

    /// Product of two dimensions (powers add). Panics on `i8` overflow in debug builds;
    /// see [`Dim::checked_mul`].
    #[allow(clippy::should_implement_trait)]
    pub const fn mul(self, other: Dim) -> Dim {
        Dim::new(
            self.length + other.length,
            self.mass + other.mass,
            self.time + other.time,
        )
    }

    /// Quotient of two dimensions (powers subtract).
    #[allow(clippy::should_implement_trait)]
    pub const fn div(self, other: Dim) -> Dim {
        Dim::new(
            self.length - other.length,
            self.mass - other.mass,
            self.time - other.time,
        )
    }

    /// Integer power of a dimension (powers multiply).
    pub const fn powi(self, n: i8) -> Dim {
        Dim::new(self.length * n, self.mass * n, self.time * n)
    }

    /// [`Dim::mul`], or `None` if a power overflows `i8`.
    pub fn checked_mul(self, other: Dim) -> Option<Dim> {
        Some(Dim::new(
            self.length.checked_add(other.length)?,
            self.mass.checked_add(other.mass)?,
            self.time.checked_add(other.time)?,
        ))
    }

    /// [`Dim::div`], or `None` if a power overflows `i8`.
    pub fn checked_div(self, other: Dim) -> Option<Dim> {
        Some(Dim::new(
            self.length.checked_sub(other.length)?,
            self.mass.checked_sub(other.mass)?,
            self.time.checked_sub(other.time)?,
        ))
    }

    /// [`Dim::powi`] with any `i32` power, or `None` if a power overflows `i8`.
    pub fn checked_powi(self, n: i32) -> Option<Dim> {
        let p = |x: i8| i8::try_from(i32::from(x).checked_mul(n)?).ok();
        Some(Dim::new(p(self.length)?, p(self.mass)?, p(self.time)?))
    }

    /// True for [`Dim::NONE`].
    pub const fn is_dimensionless(self) -> bool {
        self.length == 0 && self.mass == 0 && self.time == 0
    }
}

impl std::ops::Mul for Dim {
    type Output = Dim;
    fn mul(self, rhs: Dim) -> Dim {
        Dim::mul(self, rhs)
    }
}

impl std::ops::Div for Dim {
    type Output = Dim;
    fn div(self, rhs: Dim) -> Dim {
        Dim::div(self, rhs)
    }
}

/// Readable names for the common dimensions, tried before the generic form.
const NAMED_DIMS: &[(Dim, &str)] = &[
    (Dim::NONE, "1"),
    (Dim::LENGTH, "m"),
    (Dim::MASS, "kg"),
    (Dim::TIME, "s"),
    (Dim::FORCE, "N"),
    (Dim::STIFFNESS, "N/m"),
    (Dim::DAMPING, "N·s/m"),
    (Dim::INERTIA, "kg·m^2"),
    (Dim::TORQUE, "N·m"),
    (Dim::ANGULAR_DAMPING, "N·m·s"),
    (Dim::FREQUENCY, "1/s"),
    (Dim::new(0, 0, -2), "1/s^2"),
    (Dim::VELOCITY, "m/s"),
    (Dim::ACCELERATION, "m/s^2"),
    (Dim::POWER, "W"),
    (Dim::PRESSURE, "Pa"),
];

/// SI form: a name for common dimensions (`N/m`, `kg`, `1/s`, `N·m·s`), otherwise the
/// base units with powers, e.g. `kg·m^2·s^-3`. The output is accepted by [`parse_unit`].
impl fmt::Display for Dim {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some((_, name)) = NAMED_DIMS.iter().find(|(d, _)| d == self) {
            return f.write_str(name);
        }
        let mut first = true;
        for (unit, power) in [("kg", self.mass), ("m", self.length), ("s", self.time)] {
            if power == 0 {
                continue;
            }
            if !first {
                f.write_str("·")?;
            }
            first = false;
            f.write_str(unit)?;
            if power != 1 {
                write!(f, "^{power}")?;
            }
        }
        Ok(())
    }
}

/// One entry of the unit table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unit {
    /// The name as written in a model file (case-sensitive).
    pub name: &'static str,
    /// Value of one of this unit in SI (m, kg, s, rad).
    pub factor: f64,
    /// Dimension.
    pub dim: Dim,
    /// A short human description.
    pub description: &'static str,
}

const fn unit(name: &'static str, factor: f64, dim: Dim, description: &'static str) -> Unit {
    Unit {
        name,
        factor,
        dim,
        description,
    }
}

/// Standard gravity, m/s^2 (exact).
pub const STANDARD_GRAVITY: f64 = 9.80665;
const INCH: f64 = 0.0254;
const FOOT: f64 = 0.3048;
const POUND: f64 = 0.45359237;
const POUND_FORCE: f64 = POUND * STANDARD_GRAVITY; // 4.4482216152605 N

use Dim as D;

/// The unit table, most common units first (the order of suggestions).
const UNITS: &[Unit] = &[
    // Length.
    unit("m", 1.0, D::LENGTH, "metre"),
    unit("mm", 1e-3, D::LENGTH, "millimetre"),
    unit("cm", 1e-2, D::LENGTH, "centimetre"),
    unit("dm", 1e-1, D::LENGTH, "decimetre"),
    unit("km", 1e3, D::LENGTH, "kilometre"),
    unit("um", 1e-6, D::LENGTH, "micrometre"),
    unit("in", INCH, D::LENGTH, "inch"),
    unit("ft", FOOT, D::LENGTH, "foot"),
    unit("yd", 0.9144, D::LENGTH, "yard"),
    unit("mi", 1609.344, D::LENGTH, "statute mile"),
    unit(
        "thou",
        INCH * 1e-3,
        D::LENGTH,
        "thousandth of an inch (mil)",
    ),
    // Mass.
    unit("kg", 1.0, D::MASS, "kilogram"),
    unit("g", 1e-3, D::MASS, "gram"),
    unit("mg", 1e-6, D::MASS, "milligram"),
    unit("tonne", 1e3, D::MASS, "metric tonne"),
    unit("lb", POUND, D::MASS, "pound (mass)"),
    unit("lbm", POUND, D::MASS, "pound (mass)"),
    unit("oz", POUND / 16.0, D::MASS, "ounce (mass)"),
    unit("slug", POUND_FORCE / FOOT, D::MASS, "slug, lbf·s^2/ft"),
    // Time.
    unit("s", 1.0, D::TIME, "second"),
    unit("ms", 1e-3, D::TIME, "millisecond"),
    unit("us", 1e-6, D::TIME, "microsecond"),
    unit("min", 60.0, D::TIME, "minute"),
    unit("h", 3600.0, D::TIME, "hour"),
    // Force.
    unit("N", 1.0, D::FORCE, "newton"),
    unit("kN", 1e3, D::FORCE, "kilonewton"),
    unit("mN", 1e-3, D::FORCE, "millinewton"),
    unit("MN", 1e6, D::FORCE, "meganewton"),
    unit("lbf", POUND_FORCE, D::FORCE, "pound-force"),
    unit("ozf", POUND_FORCE / 16.0, D::FORCE, "ounce-force"),
    unit("kip", POUND_FORCE * 1e3, D::FORCE, "kilopound-force"),
    unit("kgf", STANDARD_GRAVITY, D::FORCE, "kilogram-force"),
    unit("dyn", 1e-5, D::FORCE, "dyne"),
    // Angle (dimensionless).
    unit("rad", 1.0, D::NONE, "radian"),
    unit("mrad", 1e-3, D::NONE, "milliradian"),
    unit("deg", PI / 180.0, D::NONE, "degree"),
    unit("arcmin", PI / 10800.0, D::NONE, "minute of arc"),
    unit("arcsec", PI / 648000.0, D::NONE, "second of arc"),
    unit("rev", TAU, D::NONE, "revolution, 2π rad"),
    unit("cycle", TAU, D::NONE, "cycle, 2π rad"),
    unit("turn", TAU, D::NONE, "turn, 2π rad"),
    // Frequency (angular internally: rad/s).
    unit("Hz", TAU, D::FREQUENCY, "hertz, 2π rad/s"),
    unit("kHz", TAU * 1e3, D::FREQUENCY, "kilohertz"),
    unit(
        "rpm",
        TAU / 60.0,
        D::FREQUENCY,
        "revolutions per minute, 2π/60 rad/s",
    ),
    unit("rps", TAU, D::FREQUENCY, "revolutions per second, 2π rad/s"),
    // Acceleration.
    unit("g0", STANDARD_GRAVITY, D::ACCELERATION, "standard gravity"),
    unit("gn", STANDARD_GRAVITY, D::ACCELERATION, "standard gravity"),
    // Energy.
    unit("J", 1.0, D::ENERGY, "joule"),
    unit("kJ", 1e3, D::ENERGY, "kilojoule"),
    unit("mJ", 1e-3, D::ENERGY, "millijoule"),
    // Power.
    unit("W", 1.0, D::POWER, "watt"),
    unit("kW", 1e3, D::POWER, "kilowatt"),
    unit(
        "hp",
        550.0 * FOOT * POUND_FORCE,
        D::POWER,
        "mechanical horsepower, 550 ft·lbf/s",
    ),
    // Pressure and stress.
    unit("Pa", 1.0, D::PRESSURE, "pascal"),
    unit("kPa", 1e3, D::PRESSURE, "kilopascal"),
    unit("MPa", 1e6, D::PRESSURE, "megapascal"),
    unit("GPa", 1e9, D::PRESSURE, "gigapascal"),
    unit("bar", 1e5, D::PRESSURE, "bar"),
    unit(
        "psi",
        POUND_FORCE / (INCH * INCH),
        D::PRESSURE,
        "pound-force per square inch",
    ),
    unit(
        "ksi",
        POUND_FORCE * 1e3 / (INCH * INCH),
        D::PRESSURE,
        "kilopound-force per square inch",
    ),
];

/// The whole unit table.
pub fn units() -> &'static [Unit] {
    UNITS
}

/// The power of the angle in a unit string that [`parse_unit`] accepts: angles are
/// dimensionless, so `N*m/deg` and `N*m` have the same [`Dim`]; this says which one is
/// meant (−1 for `N*m/deg`, +1 for `deg`, `rpm` and `Hz`, which are angles per time,
/// 0 for `N*m`). Angle units: `rad mrad deg arcmin arcsec rev cycle turn`; frequency
/// units: `Hz kHz rpm rps`. Operators apply left to right, as in [`parse_unit`].
pub fn angle_power(s: &str) -> i32 {
    let mut total = 0;
    let mut sign = 1;
    for token in s.replace('·', "*").split_inclusive(['*', '/']) {
        let (body, next_sign) = match token.strip_suffix('/') {
            Some(b) => (b, -1),
            None => (token.strip_suffix('*').unwrap_or(token), 1),
        };
        let (name, power) = match body.split_once('^') {
            Some((n, p)) => (n.trim(), p.trim().parse::<i32>().unwrap_or(1)),
            None => (body.trim(), 1),
        };
        let angle = match name {
            "rad" | "mrad" | "deg" | "arcmin" | "arcsec" | "rev" | "cycle" | "turn" => 1,
            "Hz" | "kHz" | "rpm" | "rps" => 1,
            _ => 0,
        };
        total += sign * power * angle;
        sign = next_sign;
    }
    total
}

/// The SI unit of a quantity of dimension `dim` with `angle` powers of the angle
/// ([`angle_power`]): `rad`, `rad/s`, `N·m/rad`, `N·m·s/rad`, or `dim`'s own for none.
pub fn si_unit_with_angle(dim: Dim, angle: i32) -> String {
    let d = dim.to_string();
    match angle {
        0 => d,
        _ if dim == Dim::NONE => {
            if angle == 1 {
                "rad".into()
            } else {
                format!("rad^{angle}")
            }
        }
        1 => match d.strip_prefix('1') {
            Some(rest) if rest.starts_with('/') => format!("rad{rest}"),
            _ => format!("{d}·rad"),
        },
        -1 => format!("{d}/rad"),
        _ => format!("{d}·rad^{angle}"),
    }
}

/// The table entry for a single unit name (case-sensitive), if any.
pub fn lookup(name: &str) -> Option<&'static Unit> {
    UNITS.iter().find(|u| u.name == name)
}

/// Every unit name in the table.
pub fn unit_names() -> impl Iterator<Item = &'static str> {
    UNITS.iter().map(|u| u.name)
}

/// True if `name` is a single unit of the table (not a compound unit).
pub fn is_unit(name: &str) -> bool {
    lookup(name).is_some()
}

/// A unit string that could not be read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnitError {
    /// What went wrong, e.g. "unknown unit `mmm`".
    pub message: String,
    /// Byte offset of the offending part in the unit string.
    pub offset: usize,
    /// Byte length of the offending part (0 at the end of the string).
    pub len: usize,
    /// A suggestion, e.g. "did you mean `mm`?".
    pub help: Option<String>,
}

impl fmt::Display for UnitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)?;
        if let Some(help) = &self.help {
            write!(f, " ({help})")?;
        }
        Ok(())
    }
}

impl std::error::Error for UnitError {}

/// Read a compound unit string: unit names joined by `*` (or `·`) and `/`, each with an
/// optional integer power (`^2`, `^-1`), applied left to right (`a/b*c` = `a·c/b`). A
/// leading `1` is a dimensionless numerator (`1/s`). Returns the SI factor and dimension.
///
/// ```
/// use detune::model::units::{parse_unit, Dim};
/// let (factor, dim) = parse_unit("lbf*in*s/rad").unwrap();
/// assert!((factor - 4.4482216152605 * 0.0254).abs() < 1e-15);
/// assert_eq!(dim, Dim::ANGULAR_DAMPING);
/// ```
pub fn parse_unit(s: &str) -> Result<(f64, Dim), UnitError> {
    let bytes = s.as_bytes();
    let skip_ws = |mut i: usize| {
        while i < bytes.len() && bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        i
    };
    let err = |message: String, offset: usize, len: usize, help: Option<String>| UnitError {
        message,
        offset,
        len,
        help,
    };
    let char_len = |i: usize| s[i..].chars().next().map_or(0, char::len_utf8);

    let mut i = skip_ws(0);
    if i == bytes.len() {
        return Err(err(
            "empty unit".into(),
            0,
            s.len(),
            Some(known_units_help()),
        ));
    }
    let mut factor = 1.0_f64;
    let mut dim = Dim::NONE;
    let mut divide = false;
    let mut first = true;
    loop {
        // A unit name (or a leading `1`).
        let start = i;
        let (unit_factor, unit_dim) = if first && bytes.get(i) == Some(&b'1') {
            i += 1;
            (1.0, Dim::NONE)
        } else if bytes.get(i).is_some_and(u8::is_ascii_alphabetic) {
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            let name = &s[start..i];
            match lookup(name) {
                Some(u) => (u.factor, u.dim),
                None => {
                    return Err(err(
                        format!("unknown unit `{name}`"),
                        start,
                        i - start,
                        Some(unknown_unit_help(name)),
                    ));
                }
            }
        } else if i == bytes.len() {
            return Err(err(
                "expected a unit name after the operator".into(),
                i,
                0,
                None,
            ));
        } else {
            return Err(err(
                format!("expected a unit name, found `{}`", &s[i..i + char_len(i)]),
                i,
                char_len(i),
                None,
            ));
        };
        first = false;

        // An optional integer power.
        let mut power = 1_i32;
        let after_name = i;
        i = skip_ws(i);
        if bytes.get(i) == Some(&b'^') {
            let caret = i;
            i = skip_ws(i + 1);
            let negative = match bytes.get(i) {
                Some(b'-') => {
                    i += 1;
                    true
                }
                Some(b'+') => {
                    i += 1;
                    false
                }
                _ => false,
            };
            let digits = i;
            while i < bytes.len() && bytes[i].is_ascii_digit() {
                i += 1;
            }
            let parsed: Option<i32> = s[digits..i].parse().ok();
            let Some(p) = parsed else {
                return Err(err(
                    "expected an integer power after `^`".into(),
                    caret,
                    i.max(caret + 1) - caret,
                    Some("unit powers are integers, e.g. `m^2` or `s^-1`".into()),
                ));
            };
            power = if negative { -p } else { p };
        } else {
            i = after_name;
        }

        // Combine.
        let too_large = || err("unit power too large".into(), start, i - start, None);
        let d = unit_dim.checked_powi(power).ok_or_else(too_large)?;
        let f = unit_factor.powi(power);
        if divide {
            factor /= f;
            dim = dim.checked_div(d).ok_or_else(too_large)?;
        } else {
            factor *= f;
            dim = dim.checked_mul(d).ok_or_else(too_large)?;
        }

        // An operator or the end.
        i = skip_ws(i);
        if i == bytes.len() {
            return Ok((factor, dim));
        }
        if bytes[i] == b'*' {
            divide = false;
            i += 1;
        } else if bytes[i] == b'/' {
            divide = true;
            i += 1;
        } else if s[i..].starts_with('·') {
            divide = false;
            i += '·'.len_utf8();
        } else {
            let len = char_len(i);
            let help = bytes[i]
                .is_ascii_alphabetic()
                .then(|| "join units with `*` or `/`, e.g. `N*m`".to_string());
            return Err(err(
                format!(
                    "expected `*`, `/` or the end of the unit, found `{}`",
                    &s[i..i + len]
                ),
                i,
                len,
                help,
            ));
        }
        i = skip_ws(i);
    }
}

/// Help for an unknown unit name: "did you mean `mm`?" when a table entry is close
/// (same letters in another case, or a small edit distance), else a list of common units.
pub fn unknown_unit_help(name: &str) -> String {
    match suggest(name, unit_names()).as_slice() {
        [] => known_units_help(),
        close => did_you_mean(close),
    }
}

fn known_units_help() -> String {
    "known units include m, mm, in, kg, lb, s, N, lbf, rad, deg, rev, Hz, rpm, J, W, Pa, psi \
     (join them with `*` and `/`, powers with `^`)"
        .to_string()
}

/// "did you mean `a`?" / "did you mean `a` or `b`?" / "did you mean `a`, `b` or `c`?"
pub(crate) fn did_you_mean(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
    match quoted.split_last() {
        None => String::new(),
        Some((last, [])) => format!("did you mean {last}?"),
        Some((last, rest)) => format!("did you mean {} or {last}?", rest.join(", ")),
    }
}

/// The candidates closest to `name`: those equal ignoring ASCII case if any, else those at
/// the smallest edit distance if it is small (0 for one character, 1 for names up to 3
/// characters, 2 beyond).
/// At most three, in candidate order.
pub(crate) fn suggest<'a>(
    name: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Vec<&'a str> {
    let candidates: Vec<&'a str> = candidates.into_iter().collect();
    let same_case: Vec<&'a str> = candidates
        .iter()
        .copied()
        .filter(|c| c.eq_ignore_ascii_case(name))
        .take(3)
        .collect();
    if !same_case.is_empty() {
        return same_case;
    }
    let limit = match name.chars().count() {
        0 | 1 => 0,
        2 | 3 => 1,
        _ => 2,
    };
    let scored: Vec<(usize, &'a str)> = candidates
        .iter()
        .map(|&c| (edit_distance(name, c), c))
        .filter(|&(d, _)| d <= limit)
        .collect();
    let Some(best) = scored.iter().map(|&(d, _)| d).min() else {
        return Vec::new();
    };
    scored
        .into_iter()
        .filter(|&(d, _)| d == best)
        .map(|(_, c)| c)
        .take(3)
        .collect()
}

/// Levenshtein distance over characters (insertions, deletions, substitutions).
pub(crate) fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let substitute = diagonal + usize::from(ca != cb);
            diagonal = row[j + 1];
            row[j + 1] = substitute.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    #[test]
    fn angle_powers_and_their_si_units() {
        for (unit, power, si) in [
            ("deg", 1, "rad"),
            ("rev", 1, "rad"),
            ("1", 0, "1"),
            ("Hz", 1, "rad/s"),
            ("rpm", 1, "rad/s"),
            ("1/s", 0, "1/s"),
            ("N*m/deg", -1, "N·m/rad"),
            ("lbf*in/rad", -1, "N·m/rad"),
            ("N·m·s/rad", -1, "N·m·s/rad"),
            ("lbf*in*s/rad", -1, "N·m·s/rad"),
            ("deg/s^2", 1, "rad/s^2"),
            ("rad^2", 2, "rad^2"),
            ("N*m", 0, "N·m"),
            ("mm", 0, "m"),
        ] {
            let (_, dim) = parse_unit(unit).unwrap();
            assert_eq!(angle_power(unit), power, "{unit}");
            assert_eq!(si_unit_with_angle(dim, power), si, "{unit}");
        }
    }

    use super::*;

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * b.abs().max(f64::MIN_POSITIVE)
    }

    #[test]
    fn table_is_consistent() {
        let names: Vec<&str> = unit_names().collect();
        assert!(names.len() >= 55, "{} units", names.len());
        for (i, n) in names.iter().enumerate() {
            assert!(!names[..i].contains(n), "duplicate unit {n}");
            assert!(is_unit(n));
        }
        assert!(!is_unit("mmm"));
        assert!(!is_unit("t"));
    }

    #[test]
    fn exact_definitions() {
        assert_eq!(lookup("in").unwrap().factor, 0.0254);
        assert_eq!(lookup("lb").unwrap().factor, 0.45359237);
        assert!(close(lookup("lbf").unwrap().factor, 4.4482216152605, 1e-15));
        assert_eq!(lookup("kgf").unwrap().factor, 9.80665);
        assert!(close(
            lookup("psi").unwrap().factor,
            6894.757293168361,
            1e-14
        ));
        assert!(close(
            lookup("hp").unwrap().factor,
            745.6998715822702,
            1e-14
        ));
        assert!(close(
            lookup("slug").unwrap().factor,
            14.593902937206364,
            1e-14
        ));
    }

    #[test]
    fn frequencies_are_angular() {
        let (hz, dim) = parse_unit("Hz").unwrap();
        assert_eq!(dim, Dim::FREQUENCY);
        assert!(close(4.3 * hz, 4.3 * 2.0 * PI, 1e-15));
        let (rpm, dim) = parse_unit("rpm").unwrap();
        assert_eq!(dim, Dim::FREQUENCY);
        assert!(close(258.0 * rpm, 258.0 * 2.0 * PI / 60.0, 1e-12));
        assert!(close(258.0 * rpm, 27.0177, 1e-5));
        assert!(close(4.3 * hz, 258.0 * rpm, 1e-12));
        assert_eq!(parse_unit("rad/s").unwrap(), (1.0, Dim::FREQUENCY));
        assert_eq!(parse_unit("deg").unwrap(), (PI / 180.0, Dim::NONE));
        assert_eq!(parse_unit("rev").unwrap(), (2.0 * PI, Dim::NONE));
    }

    #[test]
    fn compound_units() {
        let (f, d) = parse_unit("lbf*in*s/rad").unwrap();
        assert!(close(f, 4.4482216152605 * 0.0254, 1e-15));
        assert_eq!(d, Dim::ANGULAR_DAMPING);
        assert_eq!(parse_unit("N/m").unwrap(), (1.0, Dim::STIFFNESS));
        assert_eq!(parse_unit("kg*m^2").unwrap(), (1.0, Dim::INERTIA));
        assert_eq!(parse_unit("m/s^2").unwrap(), (1.0, Dim::ACCELERATION));
        assert_eq!(parse_unit(" N * s / m ").unwrap(), (1.0, Dim::DAMPING));
        assert_eq!(parse_unit("s^-1").unwrap(), (1.0, Dim::FREQUENCY));
        assert_eq!(parse_unit("1/s").unwrap(), (1.0, Dim::FREQUENCY));
        // Left to right: a/b*c = a*c/b.
        assert_eq!(parse_unit("N/m*s").unwrap(), (1.0, Dim::DAMPING));
        let (f, d) = parse_unit("lbf/in").unwrap();
        assert!(close(f, 4.4482216152605 / 0.0254, 1e-15));
        assert_eq!(d, Dim::STIFFNESS);
        let (f, d) = parse_unit("mm^2").unwrap();
        assert!(close(f, 1e-6, 1e-15));
        assert_eq!(d, Dim::new(2, 0, 0));
        assert_eq!(parse_unit("N·m·s").unwrap(), (1.0, Dim::ANGULAR_DAMPING));
    }

    #[test]
    fn display_round_trips() {
        assert_eq!(Dim::STIFFNESS.to_string(), "N/m");
        assert_eq!(Dim::MASS.to_string(), "kg");
        assert_eq!(Dim::LENGTH.to_string(), "m");
        assert_eq!(Dim::FREQUENCY.to_string(), "1/s");
        assert_eq!(Dim::ANGULAR_DAMPING.to_string(), "N·m·s");
        assert_eq!(Dim::NONE.to_string(), "1");
        assert_eq!(Dim::new(2, 1, -4).to_string(), "kg·m^2·s^-4");
        assert_eq!(Dim::new(-1, 0, 0).to_string(), "m^-1");
        for l in -3..=3 {
            for m in -2..=2 {
                for t in -4..=2 {
                    let d = Dim::new(l, m, t);
                    assert_eq!(parse_unit(&d.to_string()).unwrap(), (1.0, d), "{d}");
                }
            }
        }
    }

    #[test]
    fn dim_arithmetic() {
        assert_eq!(Dim::FORCE.div(Dim::LENGTH), Dim::STIFFNESS);
        assert_eq!(Dim::FORCE * Dim::LENGTH, Dim::TORQUE);
        assert_eq!(Dim::TORQUE / Dim::FREQUENCY, Dim::ANGULAR_DAMPING);
        assert_eq!(Dim::LENGTH.powi(2).mul(Dim::MASS), Dim::INERTIA);
        assert_eq!(Dim::LENGTH.checked_powi(200), None);
        assert_eq!(Dim::MASS.mul(Dim::ACCELERATION), Dim::FORCE);
        assert_eq!(Dim::VELOCITY.div(Dim::TIME), Dim::ACCELERATION);
    }

    #[test]
    fn errors() {
        let e = parse_unit("mmm").unwrap_err();
        assert_eq!((e.offset, e.len), (0, 3));
        assert!(e.message.contains("mmm"));
        assert_eq!(e.help.as_deref(), Some("did you mean `mm`?"));

        let e = parse_unit("N/mmm").unwrap_err();
        assert_eq!((e.offset, e.len), (2, 3));

        let e = parse_unit("hz").unwrap_err();
        assert_eq!(e.help.as_deref(), Some("did you mean `Hz`?"));

        let e = parse_unit("furlong").unwrap_err();
        assert!(e.help.unwrap().contains("known units include"));

        let e = parse_unit("N*").unwrap_err();
        assert_eq!((e.offset, e.len), (2, 0));

        let e = parse_unit("m^x").unwrap_err();
        assert_eq!(e.offset, 1);

        let e = parse_unit("N m").unwrap_err();
        assert_eq!((e.offset, e.len), (2, 1));
        assert!(e.help.is_some());

        assert!(parse_unit("").is_err());
        assert!(parse_unit("m^200").is_err());
    }

    #[test]
    fn edit_distances() {
        assert_eq!(edit_distance("mmm", "mm"), 1);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(suggest("sinn", ["sin", "cos", "sign"]), vec!["sin", "sign"]);
    }
}
