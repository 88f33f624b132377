//! Drawings of a pose: the bodies, joints, springs and ground of a model at one
//! configuration, as SVG (`detune draw`).
//!
//! [`scene`] collects what is drawn from a [`System`] and a pose q, in world coordinates
//! ([`System::geometry`] evaluates the same frames as the constraints and forces): each
//! body as a polyline through its centre of gravity and every point anything attaches to
//! it, each joint with its points and axis, each force element with its ends, the ground
//! points. [`Scene::points`] lists the drawn points by name (for checks). [`Scene::svg`]
//! draws a scene:
//!
//! * a spatial model in four panels, placed as in a first-angle drawing: front (X–Y, seen
//!   from +Z), beside it the side view (Z–Y, seen from −X), below it the top view (X–Z,
//!   seen from +Y, so +Z points down the page), and an isometric view (seen from
//!   +X +Y +Z, Y up);
//! * a planar model in one panel (X–Y).
//!
//! Each panel has equal scaling on both axes and is scaled to fit on its own (a long
//! part such as a stick would otherwise shrink the views it is seen end-on in); the
//! orthographic ones have axes with ticks in mm (a mechanism under 1 m) or m.
//!
//! The SVG is written directly rather than through plotters (used for the line plots in
//! `output::plot`): a drawing needs per-type joint markers, hatched ground symbols (an SVG
//! pattern), zigzag springs in screen space, text anchored left, right or centred around
//! a point, and a shared scale across panels, none of which plotters' chart API gives,
//! while what it would give (axes with ticks) is a few lines here. The text is plain
//! SVG `<text>` in a generic `sans-serif` family: no font files are read, and the output
//! is the same on every machine.

use crate::diag::Result;
use crate::system::System;
use crate::system::inspect::{ForceGeometry, JointGeometry, JointType, P3};
use std::fmt::Write as _;

/// A body as drawn: the polyline through its points (world, m) in drawing order.
#[derive(Debug, Clone)]
pub struct DrawnBody {
    pub name: String,
    pub cg: P3,
    /// Its distinct points (CG, joint and force points, named points, the frame origin
    /// where a torsion acts), ordered as the shortest open path through them.
    pub path: Vec<P3>,
}

/// A force element as drawn.
#[derive(Debug, Clone)]
pub struct DrawnForce {
    pub name: String,
    pub geometry: ForceGeometry,
    /// Where it is drawn: a spring's two ends, a torsion's anchor (the frame origins of
    /// its bodies, and the symbol between them), a point force's point, a torque's body
    /// CG. The symbol is at `anchors[0]` for a torsion and a torque.
    pub anchors: Vec<P3>,
}

/// Everything drawn, in world coordinates (m).
#[derive(Debug, Clone)]
pub struct Scene {
    pub spatial: bool,
    pub bodies: Vec<DrawnBody>,
    pub joints: Vec<JointGeometry>,
    pub forces: Vec<DrawnForce>,
    /// Points fixed in the ground that something attaches to (hatched symbols), besides
    /// the slots along the ground (drawn hatched with their joints).
    pub ground: Vec<P3>,
    /// Gravitational acceleration, m/s².
    pub gravity: P3,
    /// Named points of the bodies, `body.point`.
    pub named: Vec<(String, P3)>,
}

fn sub(a: P3, b: P3) -> P3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dist(a: P3, b: P3) -> f64 {
    let d = sub(a, b);
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}
fn dot(a: P3, b: P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The scene of pose q (at t = 0, where the model's initial pose is assembled). Force
/// elements are named by their type and number until [`Scene::name_forces`] names them.
pub fn scene(sys: &System, q: &[f64]) -> Scene {
    let g = sys.geometry(q, 0.0);
    let nb = g.bodies.len();
    let mut attached: Vec<Vec<P3>> = g.bodies.iter().map(|b| vec![b.cg]).collect();
    let mut attach = |body: Option<usize>, p: P3| {
        if let Some(k) = body {
            attached[k].push(p);
        }
    };
    let mut ground: Vec<P3> = Vec::new();
    for j in &g.joints {
        attach(j.body1, j.p1);
        attach(j.body2, j.p2);
        let slot = matches!(
            j.kind,
            JointType::PinInSlot | JointType::Prismatic | JointType::Cylindrical
        );
        if !slot {
            if j.body1.is_none() {
                ground.push(j.p1);
            } else if j.body2.is_none() {
                ground.push(if j.kind == JointType::Distance {
                    j.p2
                } else {
                    j.p1
                });
            }
        }
    }
    let mut forces = Vec::new();
    for (i, f) in g.forces.iter().enumerate() {
        let (kind, anchors) = match f {
            ForceGeometry::Spring {
                body1,
                body2,
                p1,
                p2,
                ..
            } => {
                attach(*body1, *p1);
                attach(*body2, *p2);
                for (b, p) in [(body1, p1), (body2, p2)] {
                    if b.is_none() {
                        ground.push(*p);
                    }
                }
                ("spring_damper", vec![*p1, *p2])
            }
            ForceGeometry::Torsion { body1, body2, .. } => {
                let origin = |b: &Option<usize>| b.map(|k| g.bodies[k].origin);
                let ends: Vec<P3> = [origin(body1), origin(body2)]
                    .into_iter()
                    .flatten()
                    .collect();
                for k in [body1, body2].into_iter().flatten() {
                    attach(Some(*k), g.bodies[*k].origin);
                }
                let mut anchors = Vec::new();
                match ends.as_slice() {
                    [a, b] if dist(*a, *b) > 0.0 => {
                        anchors.push([0, 1, 2].map(|c| 0.5 * (a[c] + b[c])));
                        anchors.extend([*a, *b]);
                    }
                    [a, ..] => anchors.push(*a),
                    [] => anchors.push(g.ground),
                }
                ("torsion", anchors)
            }
            ForceGeometry::Point { body, at, .. } => {
                attach(*body, *at);
                ("point_force", vec![*at])
            }
            ForceGeometry::Torque { body } => ("torque", vec![g.bodies[*body].cg]),
        };
        forces.push(DrawnForce {
            name: format!("{kind}{}", i + 1),
            geometry: f.clone(),
            anchors,
        });
    }
    let mut named = Vec::new();
    for (k, b) in g.bodies.iter().enumerate() {
        for (n, p) in &b.points {
            attach(Some(k), *p);
            named.push((format!("{}.{n}", b.name), *p));
        }
    }
    // what "the same point" means: a millionth of the drawing's size
    let all: Vec<P3> = attached.iter().flatten().copied().collect();
    let tol = 1e-6 * extent(&all).max(1e-9);
    dedup(&mut ground, tol);
    let bodies = (0..nb)
        .map(|k| {
            let mut pts = attached[k].clone();
            dedup(&mut pts, tol);
            DrawnBody {
                name: g.bodies[k].name.clone(),
                cg: g.bodies[k].cg,
                path: shortest_path(pts),
            }
        })
        .collect();
    Scene {
        spatial: sys.spatial,
        bodies,
        joints: g.joints,
        forces,
        ground,
        gravity: g.gravity,
        named,
    }
}

/// The largest extent of a set of points along X, Y or Z.
fn extent(pts: &[P3]) -> f64 {
    (0..3)
        .map(|c| {
            let lo = pts.iter().map(|p| p[c]).fold(f64::INFINITY, f64::min);
            let hi = pts.iter().map(|p| p[c]).fold(f64::NEG_INFINITY, f64::max);
            if hi >= lo { hi - lo } else { 0.0 }
        })
        .fold(0.0, f64::max)
}

fn dedup(pts: &mut Vec<P3>, tol: f64) {
    let mut out: Vec<P3> = Vec::with_capacity(pts.len());
    for p in pts.iter() {
        if !out.iter().any(|o| dist(*o, *p) <= tol) {
            out.push(*p);
        }
    }
    *pts = out;
}

/// The points in the order of the shortest open path through them: every order for up
/// to 8 points, else nearest neighbours from an end of the longest span.
fn shortest_path(pts: Vec<P3>) -> Vec<P3> {
    let n = pts.len();
    if n <= 2 {
        return pts;
    }
    let len =
        |order: &[usize]| -> f64 { order.windows(2).map(|w| dist(pts[w[0]], pts[w[1]])).sum() };
    if n <= 8 {
        let mut best: Vec<usize> = (0..n).collect();
        let mut best_len = len(&best);
        let mut perm: Vec<usize> = (0..n).collect();
        // Heap's algorithm over every order (a path and its reverse are both seen)
        let mut c = vec![0usize; n];
        let mut i = 0;
        while i < n {
            if c[i] < i {
                if i % 2 == 0 {
                    perm.swap(0, i);
                } else {
                    perm.swap(c[i], i);
                }
                let l = len(&perm);
                if l < best_len - 1e-15 * best_len.abs() {
                    best_len = l;
                    best = perm.clone();
                }
                c[i] += 1;
                i = 0;
            } else {
                c[i] = 0;
                i += 1;
            }
        }
        return best.into_iter().map(|k| pts[k]).collect();
    }
    // start at one end of the farthest pair
    let mut start = 0;
    let mut far = -1.0;
    for a in 0..n {
        for b in 0..n {
            let d = dist(pts[a], pts[b]);
            if d > far {
                far = d;
                start = a;
            }
        }
    }
    let mut order = vec![start];
    let mut left: Vec<usize> = (0..n).filter(|&k| k != start).collect();
    while !left.is_empty() {
        let last = pts[*order.last().expect("not empty")];
        let (pos, _) = left
            .iter()
            .enumerate()
            .map(|(i, &k)| (i, dist(last, pts[k])))
            .fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
        order.push(left.remove(pos));
    }
    order.into_iter().map(|k| pts[k]).collect()
}

impl Scene {
    /// Names the force elements (the model's names, in order: `System::force_names`); a
    /// list of another length leaves them as they are.
    pub fn name_forces(mut self, names: &[String]) -> Scene {
        if names.len() == self.forces.len() {
            for (f, n) in self.forces.iter_mut().zip(names) {
                f.name = n.clone();
            }
        }
        self
    }

    /// Every drawn point by name (world, m): `body.cg` and `body.<point>` for each body
    /// and its named points, `joint` (point 1, the joint centre) and `joint.point2`,
    /// `spring.point1` and `spring.point2`, `force` for a point force, a torsion's or a
    /// torque's symbol.
    pub fn points(&self) -> Vec<(String, P3)> {
        let mut out = Vec::new();
        for b in &self.bodies {
            out.push((format!("{}.cg", b.name), b.cg));
        }
        out.extend(self.named.iter().cloned());
        for j in &self.joints {
            out.push((j.name.clone(), j.p1));
            out.push((format!("{}.point2", j.name), j.p2));
        }
        for f in &self.forces {
            match f.geometry {
                ForceGeometry::Spring { p1, p2, .. } => {
                    out.push((format!("{}.point1", f.name), p1));
                    out.push((format!("{}.point2", f.name), p2));
                }
                _ => out.push((f.name.clone(), f.anchors[0])),
            }
        }
        out
    }

    /// Every world point the drawing must show.
    fn all_points(&self) -> Vec<P3> {
        let mut pts: Vec<P3> = self.bodies.iter().flat_map(|b| b.path.clone()).collect();
        for j in &self.joints {
            pts.extend([j.p1, j.p2]);
        }
        for f in &self.forces {
            pts.extend(f.anchors.iter().copied());
        }
        pts.extend(self.ground.iter().copied());
        pts
    }

    /// The views drawn: four for a spatial model, the X–Y plane for a planar one.
    pub fn views(&self) -> Vec<View> {
        if self.spatial {
            vec![View::FRONT, View::SIDE, View::TOP, View::ISO]
        } else {
            vec![View::PLANE]
        }
    }

    /// The drawing as an SVG document; `title` heads it (the model's name).
    pub fn svg(&self, title: &str) -> String {
        Drawing::new(self).render(title)
    }
}

/// One view: the world directions of the page's right and up, and which world axes the
/// ticks read (None for the isometric view).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// Used in element ids: `front`, `side`, `top`, `iso`, `plane`.
    pub key: &'static str,
    pub title: &'static str,
    pub right: P3,
    pub up: P3,
    /// The world axis (0 = X, 1 = Y, 2 = Z) of the horizontal and vertical ticks, and
    /// whether the vertical one increases down the page.
    pub axes: Option<(usize, usize, bool)>,
}

const S2: f64 = std::f64::consts::FRAC_1_SQRT_2;
const S6: f64 = 0.408_248_290_463_863; // 1/√6

impl View {
    pub const FRONT: View = View {
        key: "front",
        title: "front (X–Y, seen from +Z)",
        right: [1.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        axes: Some((0, 1, false)),
    };
    pub const SIDE: View = View {
        key: "side",
        title: "side (Z–Y, seen from −X)",
        right: [0.0, 0.0, 1.0],
        up: [0.0, 1.0, 0.0],
        axes: Some((2, 1, false)),
    };
    pub const TOP: View = View {
        key: "top",
        title: "top (X–Z, seen from +Y)",
        right: [1.0, 0.0, 0.0],
        up: [0.0, 0.0, -1.0],
        axes: Some((0, 2, true)),
    };
    pub const ISO: View = View {
        key: "iso",
        title: "isometric (seen from +X +Y +Z)",
        right: [S2, 0.0, -S2],
        up: [-S6, 2.0 * S6, -S6],
        axes: None,
    };
    pub const PLANE: View = View {
        key: "plane",
        title: "X–Y plane",
        right: [1.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        axes: Some((0, 1, false)),
    };

    /// (right, up) coordinates of a world point on the page, m.
    pub fn project(&self, p: P3) -> (f64, f64) {
        (dot(p, self.right), dot(p, self.up))
    }

    /// Distance toward the viewer.
    fn depth(&self, p: P3) -> f64 {
        let r = self.right;
        let u = self.up;
        let toward = [
            r[1] * u[2] - r[2] * u[1],
            r[2] * u[0] - r[0] * u[2],
            r[0] * u[1] - r[1] * u[0],
        ];
        dot(p, toward)
    }
}

// ---- rendering -----------------------------------------------------------------------

const FONT: &str = "sans-serif";
const LABEL_SIZE: f64 = 12.0;
const BODY_COLORS: [&str; 6] = [
    "#1f77b4", "#2ca02c", "#9467bd", "#8c564b", "#17becf", "#7f7f7f",
];
const SPRING_COLOR: &str = "#d62728";
const TORSION_COLOR: &str = "#ff7f0e";
const FORCE_COLOR: &str = "#e377c2";
/// Marker radius, px.
const R: f64 = 5.5;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A pixel rectangle (x0, y0, x1, y1).
#[derive(Debug, Clone, Copy)]
struct Rect(f64, f64, f64, f64);

impl Rect {
    fn overlaps(&self, o: &Rect) -> bool {
        self.0 < o.2 && o.0 < self.2 && self.1 < o.3 && o.1 < self.3
    }
    fn inside(&self, o: &Rect) -> bool {
        self.0 >= o.0 && self.2 <= o.2 && self.1 >= o.1 && self.3 <= o.3
    }
    /// Whether a segment crosses the rectangle (by sampling: labels are small).
    fn hit_by(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        let n = 24;
        (0..=n).any(|i| {
            let t = i as f64 / n as f64;
            let (x, y) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
            x > self.0 && x < self.2 && y > self.1 && y < self.3
        })
    }
}

/// A panel on the page: a view, its plot area, and the map from world to pixels.
struct Panel {
    view: View,
    /// The whole panel and its plot area, px.
    outer: Rect,
    plot: Rect,
    /// px per m.
    scale: f64,
    /// The view coordinates (m) at the plot area's centre.
    centre: (f64, f64),
}

impl Panel {
    fn px(&self, p: P3) -> (f64, f64) {
        let (h, v) = self.view.project(p);
        let cx = 0.5 * (self.plot.0 + self.plot.2);
        let cy = 0.5 * (self.plot.1 + self.plot.3);
        (
            cx + self.scale * (h - self.centre.0),
            cy - self.scale * (v - self.centre.1),
        )
    }

    /// A world direction's on-page direction (px per m along it, y down).
    fn dir(&self, d: P3) -> (f64, f64) {
        let (h, v) = self.view.project(d);
        (self.scale * h, -self.scale * v)
    }
}

/// Obstacles for labels, and the labels placed.
struct Labels {
    boxes: Vec<Rect>,
    segments: Vec<((f64, f64), (f64, f64))>,
    area: Rect,
    svg: String,
}

impl Labels {
    fn text_box(x: f64, y: f64, anchor: &str, w: f64, size: f64) -> Rect {
        let x0 = match anchor {
            "end" => x - w,
            "middle" => x - 0.5 * w,
            _ => x,
        };
        Rect(x0, y - 0.8 * size, x0 + w, y + 0.25 * size)
    }

    /// Place `text` near (x, y) (a marker of radius r) where it overlaps the least: in
    /// one of 8 directions, next to the marker or, when that is crowded, farther out with
    /// a leader line; `prefer` (a page direction) is tried first (away from a line).
    fn place(&mut self, x: f64, y: f64, r: f64, text: &str, color: &str, prefer: (f64, f64)) {
        let size = LABEL_SIZE;
        let w = 0.6 * size * text.chars().count() as f64 + 2.0;
        let mut dirs: Vec<f64> = (0..8).map(|k| k as f64 * 45f64.to_radians()).collect();
        // right, upper right, above... (page y is down: angle measured upward)
        let pref = if prefer == (0.0, 0.0) {
            (1.0, 0.0)
        } else {
            (prefer.0, -prefer.1)
        };
        let off = |a: f64| -(a.cos() * pref.0 + a.sin() * pref.1);
        dirs.sort_by(|a, b| off(*a).total_cmp(&off(*b)));
        // (cost, text x, baseline y, anchor, leader end, ring)
        type Candidate<'s> = (f64, f64, f64, &'s str, (f64, f64), usize);
        let mut best: Option<Candidate> = None;
        for (ring, gap) in [3.0, 16.0, 30.0].into_iter().enumerate() {
            for (i, a) in dirs.iter().enumerate() {
                let (c, sn) = (a.cos(), a.sin());
                let d = r + gap;
                let (px, py) = (x + d * c, y - d * sn);
                let anchor = if c > 0.35 {
                    "start"
                } else if c < -0.35 {
                    "end"
                } else {
                    "middle"
                };
                let ty = if sn > 0.35 {
                    py
                } else if sn < -0.35 {
                    py + 0.8 * size
                } else {
                    py + 0.35 * size
                };
                let b = Self::text_box(px, ty, anchor, w, size);
                let mut cost = 10.0 * self.boxes.iter().filter(|o| o.overlaps(&b)).count() as f64;
                cost += 3.0
                    * self
                        .segments
                        .iter()
                        .filter(|(p, q)| b.hit_by(*p, *q))
                        .count() as f64;
                if !b.inside(&self.area) {
                    cost += 20.0;
                }
                cost += 1.6 * ring as f64 + 0.01 * i as f64;
                if best.is_none_or(|bb| cost < bb.0) {
                    best = Some((cost, px, ty, anchor, (px, py), ring));
                }
            }
        }
        let (_, tx, ty, anchor, end, ring) = best.expect("candidates");
        if ring > 0 {
            let (dx, dy) = (end.0 - x, end.1 - y);
            let l = dx.hypot(dy).max(1e-9);
            let _ = writeln!(
                self.svg,
                r##"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="#888" stroke-width="0.8"/>"##,
                x + (r + 1.0) * dx / l,
                y + (r + 1.0) * dy / l,
                end.0 - 2.0 * dx / l,
                end.1 - 2.0 * dy / l
            );
        }
        self.boxes.push(Self::text_box(tx, ty, anchor, w, size));
        let _ = writeln!(
            self.svg,
            r#"<text x="{tx:.2}" y="{ty:.2}" text-anchor="{anchor}" fill="{color}" class="label">{}</text>"#,
            esc(text)
        );
    }
}

struct Drawing<'a> {
    scene: &'a Scene,
    /// mm (true) or m.
    mm: bool,
}

/// A step of 1, 2 or 5 × 10^k near `span / 6`.
fn nice_step(span: f64) -> f64 {
    let raw = (span / 6.0).max(1e-12);
    let p = 10f64.powf(raw.log10().floor());
    let m = raw / p;
    let k = if m < 1.5 {
        1.0
    } else if m < 3.5 {
        2.0
    } else if m < 7.5 {
        5.0
    } else {
        10.0
    };
    k * p
}

fn fmt_tick(v: f64, step: f64) -> String {
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
    };
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s.replace('-', "−")
    }
}

impl<'a> Drawing<'a> {
    fn new(scene: &'a Scene) -> Self {
        let ext = extent(&scene.all_points());
        Drawing {
            scene,
            mm: ext < 1.0,
        }
    }

    fn unit(&self) -> &'static str {
        if self.mm { "mm" } else { "m" }
    }

    fn render(&self, title: &str) -> String {
        let views = self.scene.views();
        let (pw, ph) = if self.scene.spatial {
            (700.0, 540.0)
        } else {
            (900.0, 640.0)
        };
        let cols = if views.len() > 1 { 2 } else { 1 };
        let rows = views.len().div_ceil(cols);
        let top = 44.0;
        let legend_h = 34.0;
        let width = pw * cols as f64;
        let height = top + ph * rows as f64 + legend_h;
        let mut panels: Vec<Panel> = views
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let (c, r) = ((i % cols) as f64, (i / cols) as f64);
                let outer = Rect(c * pw, top + r * ph, (c + 1.0) * pw, top + (r + 1.0) * ph);
                let plot = Rect(
                    outer.0 + 72.0,
                    outer.1 + 30.0,
                    outer.2 - 18.0,
                    outer.3 - 48.0,
                );
                Panel {
                    view: *v,
                    outer,
                    plot,
                    scale: 1.0,
                    centre: (0.0, 0.0),
                }
            })
            .collect();
        self.fit(&mut panels);
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="{FONT}" font-size="{LABEL_SIZE}">"#
        );
        let _ = writeln!(
            s,
            r##"<defs><pattern id="hatch" patternUnits="userSpaceOnUse" width="5" height="5"><path d="M-1,1 l2,-2 M0,5 l5,-5 M4,6 l2,-2" stroke="#333" stroke-width="1"/></pattern></defs>"##
        );
        let _ = writeln!(
            s,
            r#"<style>.label{{paint-order:stroke;stroke:#fff;stroke-width:3px;stroke-linejoin:round}}</style>"#
        );
        let _ = writeln!(
            s,
            r##"<rect x="0" y="0" width="{width}" height="{height}" fill="#fff"/>"##
        );
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="28" text-anchor="middle" font-size="20" font-weight="bold">{}: assembled pose</text>"#,
            width / 2.0,
            esc(title)
        );
        for p in &panels {
            self.panel(&mut s, p);
        }
        self.legend(&mut s, Rect(0.0, height - legend_h, width, height));
        s.push_str("</svg>\n");
        s
    }

    /// Each panel's scale and centre: the largest scale at which everything fits.
    fn fit(&self, panels: &mut [Panel]) {
        let pts = self.scene.all_points();
        let ext = extent(&pts).max(1e-6);
        let pad = 0.05 * ext;
        let range = |f: &dyn Fn(P3) -> f64| {
            let lo = pts.iter().map(|p| f(*p)).fold(f64::INFINITY, f64::min);
            let hi = pts.iter().map(|p| f(*p)).fold(f64::NEG_INFINITY, f64::max);
            (lo - pad, hi + pad)
        };
        for p in panels.iter_mut() {
            let v = p.view;
            let (h0, h1) = range(&|q| v.project(q).0);
            let (v0, v1) = range(&|q| v.project(q).1);
            p.scale = ((p.plot.2 - p.plot.0) / (h1 - h0)).min((p.plot.3 - p.plot.1) / (v1 - v0));
            p.centre = (0.5 * (h0 + h1), 0.5 * (v0 + v1));
        }
    }

    fn panel(&self, s: &mut String, p: &Panel) {
        let key = p.view.key;
        let _ = writeln!(s, r#"<g id="view-{key}">"#);
        let o = p.outer;
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="14" font-weight="bold">{}</text>"#,
            0.5 * (o.0 + o.2),
            o.1 + 20.0,
            p.view.title
        );
        self.axes(s, p);
        let mut labels = Labels {
            boxes: Vec::new(),
            segments: Vec::new(),
            area: p.plot,
            svg: String::new(),
        };
        // ground symbols under everything
        for g in &self.scene.ground {
            let (x, y) = p.px(*g);
            ground_triangle(s, x, y);
            labels.boxes.push(Rect(x - 10.0, y, x + 10.0, y + 16.0));
        }
        // springs and torsion shafts
        for f in &self.scene.forces {
            match f.geometry {
                ForceGeometry::Spring { p1, p2, .. } => {
                    let (a, b) = (p.px(p1), p.px(p2));
                    zigzag(s, a, b, &f.name);
                    labels.segments.push((a, b));
                }
                ForceGeometry::Torsion { .. } if f.anchors.len() == 3 => {
                    let (a, b) = (p.px(f.anchors[1]), p.px(f.anchors[2]));
                    let _ = writeln!(
                        s,
                        r#"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="{TORSION_COLOR}" stroke-width="2" stroke-dasharray="6 3"/>"#,
                        a.0, a.1, b.0, b.1
                    );
                    labels.segments.push((a, b));
                }
                _ => {}
            }
        }
        // bodies, far ones first
        let mut order: Vec<usize> = (0..self.scene.bodies.len()).collect();
        let depth = |k: usize| {
            let b = &self.scene.bodies[k];
            b.path.iter().map(|q| p.view.depth(*q)).sum::<f64>() / b.path.len().max(1) as f64
        };
        order.sort_by(|a, b| depth(*a).total_cmp(&depth(*b)));
        for &k in &order {
            let b = &self.scene.bodies[k];
            let color = BODY_COLORS[k % BODY_COLORS.len()];
            let pts: Vec<(f64, f64)> = b.path.iter().map(|q| p.px(*q)).collect();
            let _ = write!(s, r#"<g id="{key}-body-{}">"#, esc(&b.name));
            if pts.len() == 1
                || pts
                    .windows(2)
                    .all(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1) < 1.0)
            {
                let _ = write!(
                    s,
                    r#"<circle cx="{:.2}" cy="{:.2}" r="9" fill="{color}" fill-opacity="0.35" stroke="{color}" stroke-width="2"/>"#,
                    pts[0].0, pts[0].1
                );
            } else {
                let d: Vec<String> = pts.iter().map(|(x, y)| format!("{x:.2},{y:.2}")).collect();
                let _ = write!(
                    s,
                    r#"<polyline points="{}" fill="none" stroke="{color}" stroke-width="4" stroke-linecap="round" stroke-linejoin="round" stroke-opacity="0.85"/>"#,
                    d.join(" ")
                );
            }
            let (cx, cy) = p.px(b.cg);
            cg_symbol(s, cx, cy);
            let _ = writeln!(s, "</g>");
            for w in pts.windows(2) {
                labels.segments.push((w[0], w[1]));
            }
        }
        // joints
        for j in &self.scene.joints {
            self.joint(s, p, j, &mut labels);
        }
        // force symbols
        for f in &self.scene.forces {
            self.force_symbol(s, p, f, &mut labels);
        }
        self.gravity(s, p);
        if p.view.axes.is_none() {
            self.triad(s, p);
        }
        // labels: joints, then bodies, then forces
        for j in &self.scene.joints {
            let (x, y) = p.px(j.p1);
            labels.place(x, y, R + 4.0, &j.name, "#000", (0.0, 0.0));
        }
        for (k, b) in self.scene.bodies.iter().enumerate() {
            let color = BODY_COLORS[k % BODY_COLORS.len()];
            let pts: Vec<(f64, f64)> = b.path.iter().map(|q| p.px(*q)).collect();
            // the middle of the longest segment on the page, away from it
            let (mut at, mut normal, mut longest) = (pts[0], (0.0, -1.0), -1.0);
            for w in pts.windows(2) {
                let (dx, dy) = (w[1].0 - w[0].0, w[1].1 - w[0].1);
                let l = dx.hypot(dy);
                if l > longest {
                    longest = l;
                    at = (0.5 * (w[0].0 + w[1].0), 0.5 * (w[0].1 + w[1].1));
                    normal = if l > 0.0 {
                        (dy / l, -dx / l)
                    } else {
                        (0.0, -1.0)
                    };
                    if normal.1 > 0.0 {
                        normal = (-normal.0, -normal.1);
                    }
                }
            }
            let r = if longest > 1.0 { 3.0 } else { 9.0 };
            labels.place(at.0, at.1, r, &b.name, color, normal);
        }
        for f in &self.scene.forces {
            let (color, at, r) = match f.geometry {
                ForceGeometry::Spring { p1, p2, .. } => {
                    let (a, b) = (p.px(p1), p.px(p2));
                    (SPRING_COLOR, (0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1)), 9.0)
                }
                ForceGeometry::Torsion { .. } => (TORSION_COLOR, p.px(f.anchors[0]), 11.0),
                _ => (FORCE_COLOR, p.px(f.anchors[0]), 8.0),
            };
            labels.place(at.0, at.1, r, &f.name, color, (0.0, 0.0));
        }
        s.push_str(&labels.svg);
        let _ = writeln!(s, "</g>");
    }

    /// The plot frame, ticks and axis labels of an orthographic view; the isometric view
    /// has a frame only.
    fn axes(&self, s: &mut String, p: &Panel) {
        let r = p.plot;
        let _ = writeln!(
            s,
            r##"<rect x="{:.2}" y="{:.2}" width="{:.2}" height="{:.2}" fill="none" stroke="#999" stroke-width="1"/>"##,
            r.0,
            r.1,
            r.2 - r.0,
            r.3 - r.1
        );
        let Some((ha, va, down)) = p.view.axes else {
            return;
        };
        let k = if self.mm { 1000.0 } else { 1.0 };
        let names = ["X", "Y", "Z"];
        let cx = 0.5 * (r.0 + r.2);
        let cy = 0.5 * (r.1 + r.3);
        // horizontal: world coordinate at pixel x
        let h_at = |x: f64| (p.centre.0 + (x - cx) / p.scale) * k;
        let (h0, h1) = (h_at(r.0), h_at(r.2));
        let step = nice_step(h1 - h0);
        let mut t = (h0 / step).ceil() * step;
        while t <= h1 + 1e-9 * step {
            let x = cx + (t / k - p.centre.0) * p.scale;
            let _ = writeln!(
                s,
                r##"<line x1="{x:.2}" y1="{:.2}" x2="{x:.2}" y2="{:.2}" stroke="#999"/><text x="{x:.2}" y="{:.2}" text-anchor="middle" font-size="11" fill="#333">{}</text>"##,
                r.3,
                r.3 + 5.0,
                r.3 + 18.0,
                fmt_tick(t, step)
            );
            t += step;
        }
        // vertical: the view's up coordinate at pixel y; the world value is its negative
        // when the axis increases down the page
        let sign = if down { -1.0 } else { 1.0 };
        let v_at = |y: f64| sign * (p.centre.1 - (y - cy) / p.scale) * k;
        let (a, b) = (v_at(r.3), v_at(r.1));
        let (v0, v1) = (a.min(b), a.max(b));
        let step = nice_step(v1 - v0);
        let mut t = (v0 / step).ceil() * step;
        while t <= v1 + 1e-9 * step {
            let y = cy - (sign * t / k - p.centre.1) * p.scale;
            let _ = writeln!(
                s,
                r##"<line x1="{:.2}" y1="{y:.2}" x2="{:.2}" y2="{y:.2}" stroke="#999"/><text x="{:.2}" y="{:.2}" text-anchor="end" font-size="11" fill="#333">{}</text>"##,
                r.0 - 5.0,
                r.0,
                r.0 - 8.0,
                y + 4.0,
                fmt_tick(t, step)
            );
            t += step;
        }
        let unit = self.unit();
        let _ = writeln!(
            s,
            r#"<text x="{cx:.2}" y="{:.2}" text-anchor="middle" font-size="13">{} [{unit}]</text>"#,
            r.3 + 36.0,
            names[ha]
        );
        let arrow = if down { " (down)" } else { "" };
        let _ = writeln!(
            s,
            r#"<text x="{:.2}" y="{cy:.2}" text-anchor="middle" font-size="13" transform="rotate(-90 {:.2} {cy:.2})">{} [{unit}]{arrow}</text>"#,
            r.0 - 52.0,
            r.0 - 52.0,
            names[va]
        );
    }

    fn joint(&self, s: &mut String, p: &Panel, j: &JointGeometry, labels: &mut Labels) {
        let key = p.view.key;
        let (x, y) = p.px(j.p1);
        let _ = write!(
            s,
            r#"<g id="{key}-joint-{}" class="joint {}">"#,
            esc(&j.name),
            j.kind.name()
        );
        // the axis, 24 px of it when it lies in the page
        let axis_line = |s: &mut String, a: P3, half: f64, extra: &str| {
            let (dx, dy) = p.dir(a);
            let f = half / p.scale;
            let (ex, ey) = (dx * f, dy * f);
            if ex.hypot(ey) > 1.0 {
                let _ = write!(
                    s,
                    r##"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="#000" stroke-width="1" stroke-dasharray="7 2 2 2"{extra}/>"##,
                    x - ex,
                    y - ey,
                    x + ex,
                    y + ey
                );
            }
        };
        let slot = matches!(
            j.kind,
            JointType::PinInSlot | JointType::Prismatic | JointType::Cylindrical
        );
        if slot {
            if let Some(a) = j.axis {
                let (dx, dy) = p.dir(a);
                let l = dx.hypot(dy);
                if l > 1e-9 * p.scale {
                    let (ux, uy) = (dx / l, dy / l);
                    // in-page length shrinks with the axis' tilt out of the page
                    let half = 30.0 * l / p.scale;
                    let (nx, ny) = (-uy, ux);
                    for side in [-1.0, 1.0] {
                        let (ox, oy) = (side * 4.5 * nx, side * 4.5 * ny);
                        let _ = write!(
                            s,
                            r##"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="#000" stroke-width="1.5"/>"##,
                            x - half * ux + ox,
                            y - half * uy + oy,
                            x + half * ux + ox,
                            y + half * uy + oy
                        );
                    }
                    labels.segments.push((
                        (x - half * ux, y - half * uy),
                        (x + half * ux, y + half * uy),
                    ));
                    if j.body2.is_none() {
                        // the ground side: hatch below the lower line
                        let side = if ny > 0.0 { 1.0 } else { -1.0 };
                        let (ox, oy) = (side * 4.5 * nx, side * 4.5 * ny);
                        let (hx, hy) = (side * 7.0 * nx, side * 7.0 * ny);
                        let n = (2.0 * half / 6.0).floor().max(1.0) as usize;
                        for i in 0..=n {
                            let t = -half + 2.0 * half * i as f64 / n as f64;
                            let (bx, by) = (x + t * ux + ox, y + t * uy + oy);
                            let _ = write!(
                                s,
                                r##"<line x1="{bx:.2}" y1="{by:.2}" x2="{:.2}" y2="{:.2}" stroke="#333" stroke-width="1"/>"##,
                                bx + hx - 4.0 * ux,
                                by + hy - 4.0 * uy
                            );
                        }
                    }
                }
            }
        } else if let Some(a) = j.axis {
            axis_line(s, a, 24.0, "");
        }
        if let Some(a) = j.axis2 {
            axis_line(s, a, 16.0, "");
        }
        let _ = write!(s, r#"<g transform="translate({x:.2} {y:.2})">"#);
        let white = r##"fill="#fff" stroke="#000" stroke-width="1.6""##;
        match j.kind {
            JointType::Revolute => {
                let _ = write!(s, r#"<circle r="{R}" {white}/>"#);
            }
            JointType::PinInSlot => {
                let _ = write!(s, r#"<circle r="{:.1}" {white}/>"#, R - 1.0);
            }
            JointType::Spherical => {
                let _ = write!(
                    s,
                    r##"<circle r="{R}" fill="#888" stroke="#000" stroke-width="1.6"/><circle cx="-1.8" cy="-1.8" r="1.6" fill="#fff"/>"##
                );
            }
            JointType::Universal => {
                let c = R * S2;
                let _ = write!(
                    s,
                    r##"<circle r="{R}" {white}/><path d="M{:.2},{:.2} L{c:.2},{c:.2} M{:.2},{c:.2} L{c:.2},{:.2}" stroke="#000" stroke-width="1.4"/>"##,
                    -c, -c, -c, -c
                );
            }
            JointType::Prismatic => {
                let _ = write!(
                    s,
                    r#"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" {white}/>"#,
                    -R,
                    -R,
                    2.0 * R,
                    2.0 * R
                );
            }
            JointType::Cylindrical => {
                let _ = write!(
                    s,
                    r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" {white}/><circle r="{:.1}" fill="none" stroke="#000" stroke-width="1.2"/>"##,
                    -R,
                    -R,
                    2.0 * R,
                    2.0 * R,
                    R - 2.0
                );
            }
            JointType::Fixed => {
                let _ = write!(
                    s,
                    r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="#000"/>"##,
                    -R + 0.5,
                    -R + 0.5,
                    2.0 * R - 1.0,
                    2.0 * R - 1.0
                );
            }
            JointType::Distance => {
                let _ = write!(s, r#"<circle r="3.5" {white}/>"#);
            }
        }
        let _ = write!(s, "</g>");
        if j.kind == JointType::Distance {
            let (x2, y2) = p.px(j.p2);
            let _ = write!(
                s,
                r##"<line x1="{x:.2}" y1="{y:.2}" x2="{x2:.2}" y2="{y2:.2}" stroke="#000" stroke-width="1.5" stroke-dasharray="8 3 2 3"/><circle cx="{x2:.2}" cy="{y2:.2}" r="3.5" {white}/>"##
            );
            labels.segments.push(((x, y), (x2, y2)));
        }
        let _ = writeln!(s, "</g>");
        labels
            .boxes
            .push(Rect(x - R - 1.0, y - R - 1.0, x + R + 1.0, y + R + 1.0));
    }

    fn force_symbol(&self, s: &mut String, p: &Panel, f: &DrawnForce, labels: &mut Labels) {
        let key = p.view.key;
        match f.geometry {
            ForceGeometry::Torsion { .. } => {
                let (x, y) = p.px(f.anchors[0]);
                let _ = write!(s, r#"<g id="{key}-force-{}">"#, esc(&f.name));
                rotation_arrow(s, x, y, 11.0, TORSION_COLOR);
                let _ = writeln!(s, "</g>");
                labels
                    .boxes
                    .push(Rect(x - 12.0, y - 12.0, x + 12.0, y + 12.0));
            }
            ForceGeometry::Torque { .. } => {
                let (x, y) = p.px(f.anchors[0]);
                let _ = write!(s, r#"<g id="{key}-force-{}">"#, esc(&f.name));
                rotation_arrow(s, x, y, 14.0, FORCE_COLOR);
                let _ = writeln!(s, "</g>");
            }
            ForceGeometry::Point { force, .. } => {
                let (x, y) = p.px(f.anchors[0]);
                let (dx, dy) = p.dir(force);
                let l = dx.hypot(dy);
                let _ = write!(s, r#"<g id="{key}-force-{}">"#, esc(&f.name));
                if l > 1e-12 {
                    // an arrow of 32 px on the page toward the force, ending at the point
                    let (ux, uy) = (dx / l, dy / l);
                    let (x0, y0) = (x - 32.0 * ux, y - 32.0 * uy);
                    arrow(s, (x0, y0), (x - R * ux, y - R * uy), FORCE_COLOR, 2.0);
                    labels.segments.push(((x0, y0), (x, y)));
                } else if dot(force, force) > 0.0 {
                    // along the line of sight: into or out of the page
                    sight(s, x, y, 8.0, p.view.depth(force) < 0.0, FORCE_COLOR);
                    labels.boxes.push(Rect(x - 9.0, y - 9.0, x + 9.0, y + 9.0));
                } else {
                    // zero at this time: a diamond on the point
                    let _ = write!(
                        s,
                        r##"<path d="M{:.2},{y:.2} L{x:.2},{:.2} L{:.2},{y:.2} L{x:.2},{:.2} Z" fill="none" stroke="{FORCE_COLOR}" stroke-width="2"/>"##,
                        x - 8.0,
                        y - 8.0,
                        x + 8.0,
                        y + 8.0
                    );
                    labels.boxes.push(Rect(x - 9.0, y - 9.0, x + 9.0, y + 9.0));
                }
                let _ = writeln!(s, "</g>");
            }
            ForceGeometry::Spring { .. } => {}
        }
    }

    /// The gravity arrow in the panel's top right corner, or ⊗/⊙ when gravity is along
    /// the line of sight.
    fn gravity(&self, s: &mut String, p: &Panel) {
        let g = self.scene.gravity;
        let gn = dot(g, g).sqrt();
        if gn == 0.0 {
            return;
        }
        let (x, y) = (p.plot.2 - 26.0, p.plot.1 + 14.0);
        let (h, v) = p.view.project(g);
        let (dx, dy) = (h / gn, -v / gn);
        let l = dx.hypot(dy);
        let _ = write!(s, r#"<g id="{}-gravity">"#, p.view.key);
        if l > 0.2 {
            let (ux, uy) = (dx / l, dy / l);
            let (cx, cy) = (x, y + 14.0);
            let len = 26.0 * l;
            arrow(
                s,
                (cx - 0.5 * len * ux, cy - 0.5 * len * uy),
                (cx + 0.5 * len * ux, cy + 0.5 * len * uy),
                "#444",
                1.5,
            );
            let _ = write!(
                s,
                r##"<text x="{:.2}" y="{:.2}" font-style="italic" fill="#444">g</text>"##,
                cx + 7.0,
                cy + 4.0
            );
        } else {
            sight(s, x, y + 14.0, 6.0, p.view.depth(g) < 0.0, "#444");
            let _ = write!(
                s,
                r##"<text x="{:.2}" y="{:.2}" font-style="italic" fill="#444">g</text>"##,
                x + 9.0,
                y + 18.0
            );
        }
        let _ = writeln!(s, "</g>");
    }

    /// X, Y, Z arrows in the isometric panel's lower left corner.
    fn triad(&self, s: &mut String, p: &Panel) {
        let (x, y) = (p.plot.0 + 40.0, p.plot.3 - 40.0);
        for (i, name) in ["X", "Y", "Z"].iter().enumerate() {
            let mut e = [0.0; 3];
            e[i] = 1.0;
            let (h, v) = p.view.project(e);
            let (ex, ey) = (x + 28.0 * h, y - 28.0 * v);
            arrow(s, (x, y), (ex, ey), "#444", 1.3);
            let _ = write!(
                s,
                r##"<text x="{:.2}" y="{:.2}" text-anchor="middle" font-size="11" fill="#444">{name}</text>"##,
                x + 38.0 * h,
                y - 38.0 * v + 4.0
            );
        }
        let _ = writeln!(s);
    }

    /// The symbols used, along the bottom.
    fn legend(&self, s: &mut String, area: Rect) {
        let sc = self.scene;
        let mut kinds: Vec<JointType> = Vec::new();
        for j in &sc.joints {
            if !kinds.contains(&j.kind) {
                kinds.push(j.kind);
            }
        }
        let y = 0.5 * (area.1 + area.3);
        let mut x = area.0 + 16.0;
        let _ = writeln!(s, r#"<g id="legend" font-size="12">"#);
        let item = |s: &mut String, x: &mut f64, text: &str, draw: &dyn Fn(&mut String, f64)| {
            draw(s, *x + 8.0);
            let _ = write!(
                s,
                r##"<text x="{:.2}" y="{:.2}" fill="#333">{}</text>"##,
                *x + 24.0,
                y + 4.0,
                esc(text)
            );
            *x += 32.0 + 6.6 * text.chars().count() as f64;
        };
        item(s, &mut x, "body and its CG", &|s, x| {
            let _ = write!(
                s,
                r#"<line x1="{:.2}" y1="{y:.2}" x2="{:.2}" y2="{y:.2}" stroke="{}" stroke-width="4" stroke-linecap="round"/>"#,
                x - 8.0,
                x + 8.0,
                BODY_COLORS[0]
            );
            cg_symbol(s, x, y);
        });
        for k in kinds {
            item(s, &mut x, k.name(), &|s, x| {
                let j = JointGeometry {
                    name: String::new(),
                    kind: k,
                    body1: Some(0),
                    body2: Some(0),
                    p1: [0.0; 3],
                    p2: [0.0; 3],
                    axis: matches!(
                        k,
                        JointType::PinInSlot | JointType::Prismatic | JointType::Cylindrical
                    )
                    .then_some([0.3, 0.0, 0.0]),
                    axis2: None,
                };
                marker_only(s, x, y, &j);
            });
        }
        if sc
            .forces
            .iter()
            .any(|f| matches!(f.geometry, ForceGeometry::Spring { .. }))
        {
            item(s, &mut x, "spring–damper", &|s, x| {
                zigzag(s, (x - 9.0, y), (x + 9.0, y), "");
            });
        }
        if sc
            .forces
            .iter()
            .any(|f| matches!(f.geometry, ForceGeometry::Torsion { .. }))
        {
            item(s, &mut x, "torsion spring–damper", &|s, x| {
                rotation_arrow(s, x, y, 7.0, TORSION_COLOR);
            });
        }
        if !sc.ground.is_empty()
            || sc
                .joints
                .iter()
                .any(|j| j.body1.is_none() || j.body2.is_none())
        {
            item(s, &mut x, "ground", &|s, x| {
                ground_triangle(s, x, y - 7.0);
            });
        }
        let _ = writeln!(s, "</g>");
    }
}

/// A joint's marker alone (for the legend).
fn marker_only(s: &mut String, x: f64, y: f64, j: &JointGeometry) {
    let scene = Scene {
        spatial: false,
        bodies: Vec::new(),
        joints: Vec::new(),
        forces: Vec::new(),
        ground: Vec::new(),
        gravity: [0.0; 3],
        named: Vec::new(),
    };
    let d = Drawing {
        scene: &scene,
        mm: false,
    };
    let p = Panel {
        view: View::PLANE,
        outer: Rect(0.0, 0.0, 0.0, 0.0),
        plot: Rect(0.0, 0.0, 0.0, 0.0),
        scale: 1.0,
        centre: (-x, y),
    };
    let mut labels = Labels {
        boxes: Vec::new(),
        segments: Vec::new(),
        area: p.plot,
        svg: String::new(),
    };
    let mut j = j.clone();
    if j.kind == JointType::Distance {
        j.p1 = [-6.0, 0.0, 0.0];
        j.p2 = [8.0, 0.0, 0.0];
    }
    d.joint(s, &p, &j, &mut labels);
}

/// A vector along the line of sight: ⊗ into the page, ⊙ out of it.
fn sight(s: &mut String, x: f64, y: f64, r: f64, into: bool, color: &str) {
    let _ = write!(
        s,
        r#"<circle cx="{x:.2}" cy="{y:.2}" r="{r}" fill="none" stroke="{color}" stroke-width="1.5"/>"#
    );
    if into {
        let c = r * S2;
        let _ = write!(
            s,
            r#"<path d="M{:.2},{:.2} l{:.2},{:.2} M{:.2},{:.2} l{:.2},{:.2}" stroke="{color}" stroke-width="1.5"/>"#,
            x - c,
            y - c,
            2.0 * c,
            2.0 * c,
            x - c,
            y + c,
            2.0 * c,
            -2.0 * c
        );
    } else {
        let _ = write!(
            s,
            r#"<circle cx="{x:.2}" cy="{y:.2}" r="{:.2}" fill="{color}"/>"#,
            0.3 * r
        );
    }
}

/// The centre-of-gravity symbol: a circle with two opposite quarters filled.
fn cg_symbol(s: &mut String, x: f64, y: f64) {
    let r = 4.0;
    let _ = write!(
        s,
        r##"<circle cx="{x:.2}" cy="{y:.2}" r="{r}" fill="#fff" stroke="#000" stroke-width="1"/><path d="M{x:.2},{y:.2} L{:.2},{y:.2} A{r},{r} 0 0 0 {x:.2},{:.2} Z M{x:.2},{y:.2} L{:.2},{y:.2} A{r},{r} 0 0 0 {x:.2},{:.2} Z" fill="#000"/>"##,
        x + r,
        y - r,
        x - r,
        y + r
    );
}

/// A hatched ground triangle under (x, y), its apex at the point.
fn ground_triangle(s: &mut String, x: f64, y: f64) {
    let _ = writeln!(
        s,
        r##"<path class="ground" d="M{x:.2},{y:.2} L{:.2},{:.2} L{:.2},{:.2} Z" fill="url(#hatch)" stroke="#333" stroke-width="1.2"/><line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="#333" stroke-width="2"/>"##,
        x - 9.0,
        y + 14.0,
        x + 9.0,
        y + 14.0,
        x - 12.0,
        y + 14.0,
        x + 12.0,
        y + 14.0
    );
}

/// A spring as a zigzag between two page points (straight leads at both ends); a short
/// one (seen end on) as a small circle.
fn zigzag(s: &mut String, a: (f64, f64), b: (f64, f64), name: &str) {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let l = dx.hypot(dy);
    let id = if name.is_empty() {
        String::new()
    } else {
        format!(r#" class="spring" data-name="{}""#, esc(name))
    };
    if l < 6.0 {
        let _ = writeln!(
            s,
            r#"<circle{id} cx="{:.2}" cy="{:.2}" r="4" fill="none" stroke="{SPRING_COLOR}" stroke-width="1.5"/>"#,
            a.0, a.1
        );
        return;
    }
    let (ux, uy) = (dx / l, dy / l);
    let (nx, ny) = (-uy, ux);
    let lead = (0.15 * l).min(12.0);
    let n = ((l - 2.0 * lead) / 5.0).round().clamp(4.0, 14.0) as usize;
    let amp = 5.0;
    let mut pts = vec![a, (a.0 + lead * ux, a.1 + lead * uy)];
    for i in 0..n {
        let t = lead + (l - 2.0 * lead) * (i as f64 + 0.5) / n as f64;
        let side = if i % 2 == 0 { amp } else { -amp };
        pts.push((a.0 + t * ux + side * nx, a.1 + t * uy + side * ny));
    }
    pts.push((b.0 - lead * ux, b.1 - lead * uy));
    pts.push(b);
    let d: Vec<String> = pts.iter().map(|(x, y)| format!("{x:.2},{y:.2}")).collect();
    let _ = writeln!(
        s,
        r#"<polyline{id} points="{}" fill="none" stroke="{SPRING_COLOR}" stroke-width="1.5" stroke-linejoin="round"/>"#,
        d.join(" ")
    );
}

/// An arrow from a to b (head at b).
fn arrow(s: &mut String, a: (f64, f64), b: (f64, f64), color: &str, width: f64) {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let l = dx.hypot(dy).max(1e-9);
    let (ux, uy) = (dx / l, dy / l);
    let h = 7.0;
    let w = 3.5;
    let _ = write!(
        s,
        r#"<line x1="{:.2}" y1="{:.2}" x2="{:.2}" y2="{:.2}" stroke="{color}" stroke-width="{width}"/><path d="M{:.2},{:.2} L{:.2},{:.2} L{:.2},{:.2} Z" fill="{color}"/>"#,
        a.0,
        a.1,
        b.0 - h * ux,
        b.1 - h * uy,
        b.0,
        b.1,
        b.0 - h * ux - w * uy,
        b.1 - h * uy + w * ux,
        b.0 - h * ux + w * uy,
        b.1 - h * uy - w * ux
    );
}

/// A rotation symbol: an open circular arc of radius r around (x, y) with an arrowhead.
fn rotation_arrow(s: &mut String, x: f64, y: f64, r: f64, color: &str) {
    let a0 = 60f64.to_radians();
    let a1 = 330f64.to_radians();
    let (x0, y0) = (x + r * a0.cos(), y - r * a0.sin());
    let (x1, y1) = (x + r * a1.cos(), y - r * a1.sin());
    let _ = write!(
        s,
        r#"<path d="M{x0:.2},{y0:.2} A{r},{r} 0 1 0 {x1:.2},{y1:.2}" fill="none" stroke="{color}" stroke-width="2"/>"#
    );
    // the head at the end, along the arc's direction there (counter-clockwise on the page)
    let (tx, ty) = (-a1.sin(), -a1.cos());
    let (nx, ny) = (a1.cos(), -a1.sin());
    let h = 6.0;
    let _ = write!(
        s,
        r#"<path d="M{:.2},{:.2} L{:.2},{:.2} L{:.2},{:.2} Z" fill="{color}"/>"#,
        x1 + 0.6 * h * tx,
        y1 + 0.6 * h * ty,
        x1 - 0.6 * h * tx + 0.5 * h * nx,
        y1 - 0.6 * h * ty + 0.5 * h * ny,
        x1 - 0.6 * h * tx - 0.5 * h * nx,
        y1 - 0.6 * h * ty - 0.5 * h * ny
    );
}

/// Draw pose q of a system (assembled: [`crate::assemble`]) and write it to `path` as SVG
/// (atomically); `title` is the model's name, `force_names` the names of its force
/// elements (`System::force_names`).
pub fn write_pose_svg(
    path: &str,
    sys: &System,
    q: &[f64],
    title: &str,
    force_names: &[String],
) -> Result<()> {
    let svg = scene(sys, q).name_forces(force_names).svg(title);
    crate::output::write_atomic(path, |w| w.write_all(svg.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shortest_path_orders_points_along_a_bell_crank() {
        // the stick of the inceptor: pivot O, CG, grip and the arm S below the pivot;
        // O–S–CG–grip (0.617 m) is shorter than S–O–CG–grip (0.643 m)
        let o = [0.0, 0.0, 0.0];
        let cg = [0.36, 0.014, 0.0];
        let grip = [0.52, 0.04, 0.0];
        let s = [0.05, -0.11, 0.0];
        let path = shortest_path(vec![cg, grip, o, s]);
        let fwd = vec![o, s, cg, grip];
        let mut back = fwd.clone();
        back.reverse();
        assert!(path == fwd || path == back, "{path:?}");
    }

    #[test]
    fn views_are_right_handed_and_y_is_up() {
        for v in [View::FRONT, View::SIDE, View::TOP, View::ISO] {
            assert!(dot(v.right, v.up).abs() < 1e-15);
            assert!((dot(v.right, v.right) - 1.0).abs() < 1e-15);
            assert!((dot(v.up, v.up) - 1.0).abs() < 1e-15);
        }
        // Y up in front, side and isometric views
        for v in [View::FRONT, View::SIDE, View::ISO] {
            assert!(v.project([0.0, 1.0, 0.0]).1 > 0.0);
        }
        // seen from +Z, −X, +Y and (+1, +1, +1)
        assert!(View::FRONT.depth([0.0, 0.0, 1.0]) > 0.0);
        assert!(View::SIDE.depth([-1.0, 0.0, 0.0]) > 0.0);
        assert!(View::TOP.depth([0.0, 1.0, 0.0]) > 0.0);
        assert!((View::ISO.depth([1.0, 1.0, 1.0]) - 3f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn ticks_are_round() {
        assert_eq!(nice_step(600.0), 100.0);
        assert_eq!(nice_step(0.6), 0.1);
        assert_eq!(nice_step(13.0), 2.0);
        assert_eq!(fmt_tick(-0.0, 0.1), "0.0");
        assert_eq!(fmt_tick(-50.0, 50.0), "−50");
    }
}
