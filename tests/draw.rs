//! `detune draw`: the assembled pose as SVG, through the binary, and the drawn points
//! where the model's geometry puts them.

mod common;
use common::detune;
use detune::draw::{View, scene};
use detune::{Model, System, assemble};

/// Draw a model into a temporary directory and return the SVG text.
fn draw(model: &str, extra: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pose.svg");
    let mut args = vec!["draw", model, "-o", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    let (code, _, err) = detune(&args);
    assert_eq!(code, 0, "{err}");
    let svg = std::fs::read_to_string(&out).unwrap();
    let t = svg.trim();
    assert!(t.starts_with("<svg"), "{}", &t[..t.len().min(200)]);
    assert!(t.ends_with("</svg>"));
    // every element opened is closed (enough of a parse to catch a broken document)
    assert_eq!(svg.matches("<g").count(), svg.matches("</g>").count());
    assert_eq!(svg.matches("<text").count(), svg.matches("</text>").count());
    svg
}

fn model(path: &str) -> (Model, System, Vec<f64>) {
    let m = Model::load(&format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let sys = System::new(&m).unwrap();
    let q = assemble(&sys).unwrap().q;
    (m, sys, q)
}

fn point(points: &[(String, [f64; 3])], name: &str) -> [f64; 3] {
    points
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no point {name} in {points:?}"))
        .1
}

fn assert_at(p: [f64; 3], want: [f64; 3], tol: f64, what: &str) {
    for k in 0..3 {
        assert!(
            (p[k] - want[k]).abs() <= tol,
            "{what}: {p:?}, expected {want:?}"
        );
    }
}

/// The translate(x y) of the group with this id: where a joint marker is on the page.
fn marker(svg: &str, id: &str) -> (f64, f64) {
    let at = svg
        .find(&format!("id=\"{id}\""))
        .unwrap_or_else(|| panic!("no {id}"));
    let rest = &svg[at..];
    let t = rest.find("translate(").unwrap() + "translate(".len();
    let end = rest[t..].find(')').unwrap();
    let mut it = rest[t..t + end]
        .split_whitespace()
        .map(|v| v.parse::<f64>().unwrap());
    (it.next().unwrap(), it.next().unwrap())
}

#[test]
fn inceptor_is_drawn_in_four_views_with_every_name() {
    let svg = draw("models/inceptor.toml", &[]);
    for view in ["front", "side", "top", "iso"] {
        assert!(svg.contains(&format!("id=\"view-{view}\"")), "{view}");
    }
    for name in [
        "stick", "rod", "crank", "gearbox", "J1", "J2", "J3", "J4", "J5", "sensor", "shaft",
        "damper",
    ] {
        assert!(svg.contains(&format!(">{name}</text>")), "{name}");
    }
    assert!(svg.contains("inceptor: assembled pose"));
    assert!(svg.contains("X [mm]") && svg.contains("Z [mm]") && svg.contains("Y [mm]"));
    assert!(svg.contains("class=\"joint spherical\"") && svg.contains("class=\"joint revolute\""));
}

/// SPEC §9's joint centres at the datum, and where the views put them: Y up in the
/// front and side views, +Z down the page in the top view, equal scales on both axes.
#[test]
fn inceptor_joint_centres_are_the_datum_and_project_correctly() {
    let (_, sys, q) = model("models/inceptor.toml");
    let sc = scene(&sys, &q).name_forces(&sys.force_names);
    let pts = sc.points();
    let s = [0.071778, -0.097201, 0.0];
    let c = [0.03, 0.009943, 0.070710];
    let e = [0.05, 0.009943, 0.070710];
    assert_at(point(&pts, "J2"), s, 1e-6, "S (J2)");
    assert_at(point(&pts, "stick.S"), s, 1e-6, "stick.S");
    assert_at(point(&pts, "J3"), c, 1e-6, "C (J3)");
    assert_at(point(&pts, "crank.C"), c, 1e-6, "crank.C");
    assert_at(point(&pts, "sensor.point1"), e, 1e-6, "E");
    assert_at(
        point(&pts, "sensor.point2"),
        [0.05, -0.09, 0.056],
        1e-15,
        "F",
    );
    assert_at(point(&pts, "J1"), [0.0; 3], 1e-12, "O (J1)");
    assert_at(point(&pts, "J4"), [0.03, 0.0, 0.14], 1e-12, "H (J4)");
    assert_at(point(&pts, "J5"), [-0.07, 0.0, 0.14], 1e-12, "G (J5)");
    // the shaft's symbol between G and H
    assert_at(point(&pts, "shaft"), [-0.02, 0.0, 0.14], 1e-12, "shaft");

    let svg = draw("models/inceptor.toml", &[]);
    // front (X right, Y up): O → S on the page is (+Sx, −Sy)·scale
    let o = marker(&svg, "front-joint-J1");
    let p = marker(&svg, "front-joint-J2");
    let (kx, ky) = ((p.0 - o.0) / s[0], (o.1 - p.1) / s[1]);
    assert!(kx > 0.0 && (kx - ky).abs() < 1e-3 * kx, "front {kx} {ky}");
    // side (Z right, Y up): H → C is (Cz − Hz, −(Cy − Hy))·scale
    let h = marker(&svg, "side-joint-J4");
    let p = marker(&svg, "side-joint-J3");
    let (kz, ky) = ((p.0 - h.0) / (c[2] - 0.14), (h.1 - p.1) / c[1]);
    assert!(kz > 0.0 && (kz - ky).abs() < 1e-3 * kz, "side {kz} {ky}");
    // top (X right, Z down the page): O → C is (Cx, +Cz)·scale
    let o = marker(&svg, "top-joint-J1");
    let p = marker(&svg, "top-joint-J3");
    let (kx, kz) = ((p.0 - o.0) / c[0], (p.1 - o.1) / c[2]);
    assert!(kx > 0.0 && (kx - kz).abs() < 1e-3 * kx, "top {kx} {kz}");
    // isometric: Y up, and the projections of X and Z go down to either side
    let o = marker(&svg, "iso-joint-J1");
    let g = marker(&svg, "iso-joint-J5");
    let want = View::ISO.project([-0.07, 0.0, 0.14]);
    let k = (g.0 - o.0) / want.0;
    assert!(
        k > 0.0 && ((o.1 - g.1) / want.1 - k).abs() < 1e-3 * k,
        "iso"
    );
}

#[test]
fn overcentre_is_drawn_in_the_plane_with_j_at_its_closed_form() {
    let svg = draw("models/overcentre.toml", &[]);
    assert!(svg.contains("id=\"view-plane\"") && !svg.contains("id=\"view-iso\""));
    for name in ["bar1", "bar2", "A", "J", "B", "spring", "F"] {
        assert!(svg.contains(&format!(">{name}</text>")), "{name}");
    }
    assert!(svg.contains("X [m]") && svg.contains("Y [m]"));
    assert!(svg.contains("class=\"joint pin_in_slot\""));
    // bar 1 at theta1_0 = 45° from A at the origin: J = L1 (cos, sin) = (2, 2); B on
    // y = 0 at 2 + sqrt(L2² − 2²) = 4
    let (_, sys, q) = model("models/overcentre.toml");
    let pts = scene(&sys, &q).name_forces(&sys.force_names).points();
    assert_at(point(&pts, "J"), [2.0, 2.0, 0.0], 1e-12, "J");
    assert_at(
        point(&pts, "J.point2"),
        [2.0, 2.0, 0.0],
        1e-12,
        "J on bar 2",
    );
    assert_at(point(&pts, "B"), [4.0, 0.0, 0.0], 1e-12, "B");
    assert_at(point(&pts, "A"), [0.0; 3], 1e-12, "A");
    assert_at(point(&pts, "F"), [2.0, 2.0, 0.0], 1e-12, "F at s = L1");
    let a = marker(&svg, "plane-joint-A");
    let j = marker(&svg, "plane-joint-J");
    assert!(
        j.0 > a.0 && ((j.0 - a.0) - (a.1 - j.1)).abs() < 1e-2,
        "{a:?} {j:?}"
    );
    // --set moves the drawing: theta1_0 = 30° puts J at L1 (cos 30°, sin 30°)
    let svg30 = draw("models/overcentre.toml", &["--set", "theta1_0=30 deg"]);
    let j30 = marker(&svg30, "plane-joint-J");
    assert!(j30 != j);
}

#[test]
fn a_pose_that_does_not_assemble_is_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pose.svg");
    // bar 2 too short to reach the ground line from J at height 2
    let (code, _, err) = detune(&[
        "draw",
        "models/overcentre.toml",
        "--set",
        "L2=1",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("cannot be assembled"), "{err}");
    assert!(!out.exists());
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "no temporary left"
    );
    // a push-rod too short to close the inceptor's loop: Newton does not converge
    let (code, _, err) = detune(&[
        "draw",
        "models/inceptor.toml",
        "--set",
        "l2=0.01",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_ne!(code, 0);
    assert!(
        err.contains("cannot be assembled: constraint residual"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn an_output_that_cannot_be_written_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("missing").join("pose.svg");
    let (code, _, err) = detune(&["draw", "models/inceptor.toml", "-o", out.to_str().unwrap()]);
    assert_ne!(code, 0);
    assert!(err.contains("does not exist"), "{err}");
    let (code, _, err) = detune(&[
        "draw",
        "models/inceptor.toml",
        "-o",
        dir.path().to_str().unwrap(),
    ]);
    assert_ne!(code, 0);
    assert!(err.contains("is a directory"), "{err}");
    let (code, _, err) = detune(&["draw", "models/inceptor.toml"]);
    assert_ne!(code, 0);
    assert!(err.contains("--output"), "{err}");
}

/// A spatial model with one joint of each other type, a point force and a torque.
const SPATIAL_KINDS: &str = r#"
[model]
name = "joint-kinds"

[parameters]
g = { value = 9.81, unit = "m/s^2" }

[[bodies]]
name = "b1"
rotation = [["z", "a"], ["x", "b"]]
mass = 1
inertia = [0.01, 0.01, 0.01]
x = 0
y = -0.2
z = 0
points = { top = [0, 0.2, 0] }

[[bodies]]
name = "b2"
rotation = [["z", "a"]]
mass = 1
inertia = [0.01, 0.01, 0.01]
x = 0.5
y = 0
z = 0

[[bodies]]
name = "b3"
rotation = [["z", "a"]]
mass = 1
inertia = [0.01, 0.01, 0.01]
x = 1.0
y = 0
z = 0.2

[[bodies]]
name = "b4"
rotation = [["z", "a"]]
mass = 1
inertia = [0.01, 0.01, 0.01]
x = 1.5
y = 0.1
z = 0

[[bodies]]
name = "b5"
rotation = [["z", "a"]]
mass = 1
inertia = [0.01, 0.01, 0.01]
x = 0.3
y = 0.6
z = 0.1

[[joints]]
name = "U"
type = "universal"
body1 = "b1"
point1 = [0, 0.2, 0]
body2 = "ground"
point2 = [0, 0, 0]
axis = [1, 0, 0]
axis2 = [0, 0, 1]

[[joints]]
name = "P"
type = "prismatic"
body1 = "b2"
point1 = [0, 0, 0]
body2 = "ground"
point2 = [0.5, 0, 0]
axis = [0, 1, 0]

[[joints]]
name = "Cy"
type = "cylindrical"
body1 = "b3"
point1 = [0, 0, 0]
body2 = "ground"
point2 = [1.0, 0, 0.2]
axis = [0, 0, 1]

[[joints]]
name = "Fx"
type = "fixed"
body1 = "b4"
point1 = [-0.1, 0, 0]
body2 = "ground"
point2 = [1.4, 0.1, 0]

[[joints]]
name = "D"
type = "distance"
body1 = "b5"
point1 = [0, 0, 0]
body2 = "b1"
point2 = [0, 0, 0]
length = 0.85

[[forces]]
name = "gravity"
type = "gravity"
acceleration = [0, "-g", 0]

[[forces]]
name = "push"
type = "point_force"
body1 = "b4"
point = [0.1, 0, 0]
force = [0, -10, 0]

[[forces]]
name = "twist"
type = "torque"
body1 = "b5"
torque = [0, 0, 1]
"#;

/// A planar model with a prismatic and a fixed joint.
const PLANAR_KINDS: &str = r#"
[model]
name = "planar-kinds"

[[bodies]]
name = "slider"
mass = 1
inertia = 0.1
x = 1
y = 0.5
theta = 0.3

[[bodies]]
name = "bracket"
mass = 1
inertia = 0.1
x = 0.2
y = 1
theta = 0

[[joints]]
name = "P"
type = "prismatic"
body1 = "slider"
point1 = [0, 0]
body2 = "ground"
point2 = [0, 0.5]
axis = [1, 0]
angle = 0.3

[[joints]]
name = "W"
type = "fixed"
body1 = "bracket"
point1 = [-0.2, 0]
body2 = "ground"
point2 = [0, 1]
"#;

#[test]
fn every_joint_type_has_its_marker() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text, kinds) in [
        (
            "spatial.toml",
            SPATIAL_KINDS,
            &["universal", "prismatic", "cylindrical", "fixed", "distance"][..],
        ),
        ("planar.toml", PLANAR_KINDS, &["prismatic", "fixed"][..]),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let svg = draw(path.to_str().unwrap(), &[]);
        for k in kinds {
            assert!(svg.contains(&format!("class=\"joint {k}\"")), "{name}: {k}");
            // and in the legend
            assert!(svg.contains(&format!(">{k}</text>")), "{name}: legend {k}");
        }
    }
    let path = dir.path().join("spatial.toml");
    let svg = draw(path.to_str().unwrap(), &[]);
    for name in ["U", "P", "Cy", "Fx", "D", "push", "twist", "b1", "b5"] {
        assert!(svg.contains(&format!(">{name}</text>")), "{name}");
    }
}

/// `draw` writes SVG only: `.png`, `.pdf` or `.csv` is refused before any work, no file
/// written (it wrote SVG under those names, exit 0), with the flag and what to name it.
#[test]
fn a_drawing_not_named_svg_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["pose.png", "pose.pdf", "pose.csv", "pose"] {
        let out = dir.path().join(name);
        let (code, _, err) = detune(&[
            "draw",
            "models/overcentre.toml",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert_eq!(code, 1, "{name}: {err}");
        assert!(err.contains("-o ") && err.contains(".svg"), "{name}: {err}");
        assert!(!out.exists(), "{name} was written");
    }
}

/// `draw -o /dev/stdout` writes the drawing alone to standard output (whatever it is
/// redirected to: a file, here), the "wrote" line on standard error.
#[test]
fn a_drawing_to_standard_output_is_the_svg_alone() {
    let (code, out, err) = detune(&["draw", "models/overcentre.toml", "-o", "/dev/stdout"]);
    assert_eq!(code, 0, "{err}");
    let t = out.trim();
    assert!(
        t.starts_with("<svg") && t.ends_with("</svg>"),
        "{}",
        &t[t.len().saturating_sub(200)..]
    );
    assert!(err.contains("wrote /dev/stdout"), "{err}");
}
