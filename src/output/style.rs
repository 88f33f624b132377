//! The one style policy of every figure (line plots, the report's figures, the tornado
//! chart): font sizes, the colour palette, line styles and markers, and the embedded font.
//!
//! * **Fonts** are sized for a figure shown at half a slide's width: at the default
//!   900 px width no text is smaller than [`MIN_TEXT`] px; a larger `--plot-size` scales
//!   every size with the width and the panel height, whichever grows less
//!   ([`Fonts::for_panel`]), so a figure looks the same at any size and a wide, low one
//!   keeps room for its plot. The font is DejaVu Sans, embedded in the binary (`assets/fonts/`, Bitstream Vera
//!   licence): PNG output needs no system font library and SVG names the same family.
//! * **Colours** are the Okabe–Ito palette (colour-blind safe). Each curve also carries a
//!   marker shape of its own ([`MARKERS`]), so curves stay apart in greyscale print.
//! * **Fixed meanings of line style**: solid = a stable equilibrium or a computed response
//!   (a sweep up, or from rest); dashed = unstable; dotted = a sweep down; thin grey
//!   dash-dot = a linear reference (ω_n); solid [`FORCING`] orange = a forcing frequency
//!   (a rotor's line or band). Events (peaks, folds, branch points, jumps) are black-edged
//!   markers ([`EVENT_MARKERS`]) with a label beside them.

use plotters::style::{FontStyle, RGBColor};

/// Smallest text size, px, at the default width.
pub const MIN_TEXT: f64 = 16.0;
/// The default figure width, px.
pub const BASE_WIDTH: u32 = 900;
/// The default height of a panel, px.
pub const PANEL_HEIGHT: f64 = 520.0;
/// The font family every figure uses (registered from the embedded font).
pub const FAMILY: &str = "sans-serif";
/// The embedded font: DejaVu Sans (assets/fonts/LICENSE-DejaVu.txt).
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Register the embedded font with plotters (once): every figure calls this first.
pub fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        for family in [FAMILY, "DejaVu Sans"] {
            for style in [FontStyle::Normal, FontStyle::Bold] {
                // the font is ours and valid: a failure would leave plotters' error
                let _ = plotters::style::register_font(family, style, FONT);
            }
        }
    });
}

/// Plotters' text size for a font size of `em` px: plotters sizes text by its line
/// height, 1.24 em (its SVG backend writes `font-size` = size / 1.24).
pub const PLOTTERS_PER_EM: f64 = 1.24;

/// The figures' font at `em` px (the SVG `font-size`).
pub fn font(em: f64) -> plotters::style::FontDesc<'static> {
    use plotters::style::IntoFont;
    (FAMILY, em * PLOTTERS_PER_EM).into_font()
}

/// Text sizes of a figure, px (em: the SVG `font-size`).
#[derive(Debug, Clone, Copy)]
pub struct Fonts {
    pub title: f64,
    /// The caption under the title (the case: model, overrides, well).
    pub caption: f64,
    /// Axis descriptions.
    pub label: f64,
    /// Tick labels.
    pub tick: f64,
    pub legend: f64,
    /// Labels of marked events.
    pub note: f64,
    /// Width / [`BASE_WIDTH`] (at least 1): multiplies line widths and markers too.
    pub scale: f64,
}

impl Fonts {
    pub fn for_width(width: u32) -> Fonts {
        Fonts::scaled((width as f64 / BASE_WIDTH as f64).max(1.0))
    }

    /// The text of a figure `width` px wide whose panels are `panel_height` px tall,
    /// drawn `zoom` times larger than asked (a supersampled PNG: 3): text scales with the
    /// width and with the panel height, whichever is smaller (a wide, low panel keeps room
    /// for its plot), never below the default size.
    pub fn for_panel(width: u32, panel_height: f64, zoom: f64) -> Fonts {
        let zoom = zoom.max(1.0);
        let by_width = width as f64 / zoom / BASE_WIDTH as f64;
        let by_height = panel_height / zoom / PANEL_HEIGHT;
        Fonts::scaled(zoom * by_width.min(by_height).max(1.0))
    }

    fn scaled(s: f64) -> Fonts {
        Fonts {
            title: 22.0 * s,
            caption: 17.0 * s,
            label: 19.0 * s,
            tick: MIN_TEXT * s,
            legend: MIN_TEXT * s,
            note: MIN_TEXT * s,
            scale: s,
        }
    }
}

/// Okabe–Ito: blue, vermillion, bluish green, reddish purple, sky blue, black.
pub const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];
/// Forcing frequencies (a rotor's lines and bands): Okabe–Ito orange.
pub const FORCING: RGBColor = RGBColor(230, 159, 0);
/// Linear references (natural frequencies), thin dash-dot.
pub const REFERENCE: RGBColor = RGBColor(80, 80, 80);
/// Event markers' edge and label colour.
pub const EVENT: RGBColor = RGBColor(0, 0, 0);
/// Grid lines.
pub const GRID: RGBColor = RGBColor(225, 225, 225);

/// A marker shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    Circle,
    Square,
    TriangleUp,
    Diamond,
    TriangleDown,
    Cross,
}

impl Marker {
    pub fn name(self) -> &'static str {
        match self {
            Marker::Circle => "circle",
            Marker::Square => "square",
            Marker::TriangleUp => "triangle-up",
            Marker::Diamond => "diamond",
            Marker::TriangleDown => "triangle-down",
            Marker::Cross => "cross",
        }
    }
}

/// The marker of palette slot k (drawn sparsely along its curve).
pub const MARKERS: [Marker; 6] = [
    Marker::Circle,
    Marker::Square,
    Marker::TriangleUp,
    Marker::Diamond,
    Marker::TriangleDown,
    Marker::Cross,
];
/// Markers of event series, in order of appearance in a panel.
pub const EVENT_MARKERS: [Marker; 5] = [
    Marker::Diamond,
    Marker::Square,
    Marker::TriangleDown,
    Marker::TriangleUp,
    Marker::Circle,
];

/// The marker of an event series by its kind (the label's first word: peak, fold,
/// branch point, jump, crossing), else the `j`-th of [`EVENT_MARKERS`].
pub fn event_marker(label: &str, j: usize) -> Marker {
    let l = label.trim_start().to_ascii_lowercase();
    if l.starts_with("peak") || l.starts_with("refined peak") {
        Marker::TriangleDown
    } else if l.starts_with("fold") {
        Marker::Diamond
    } else if l.starts_with("branch") {
        Marker::Square
    } else if l.starts_with("jump") {
        Marker::TriangleUp
    } else if l.starts_with("crossing") {
        Marker::Circle
    } else {
        EVENT_MARKERS[j % EVENT_MARKERS.len()]
    }
}

/// Dash patterns (px at scale 1): dashed, dotted, dash-dot.
pub const DASHED: [f64; 2] = [9.0, 5.0];
pub const DOTTED: [f64; 2] = [2.0, 4.0];
pub const DASH_DOT: [f64; 4] = [10.0, 4.0, 2.0, 4.0];
/// Line widths (px at scale 1): curves, references.
pub const CURVE_WIDTH: f64 = 2.5;
pub const REFERENCE_WIDTH: f64 = 1.5;
/// Marker radius (px at scale 1): along curves, events.
pub const CURVE_MARKER: f64 = 4.5;
pub const EVENT_MARKER: f64 = 7.0;
/// Spacing of the markers along a curve, px at scale 1.
pub const MARKER_SPACING: f64 = 120.0;

/// `#rrggbb`.
pub fn hex(c: RGBColor) -> String {
    format!("#{:02x}{:02x}{:02x}", c.0, c.1, c.2)
}
