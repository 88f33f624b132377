//! The fields of every joint and force type: what each requires, what it does not use,
//! and what it defaults.
//!
//! The error cases are pinned as a transcript, `tests/data/model_kinds.txt`: every case's
//! input and its full rendered error (message, `file:line:col`, the marked source line,
//! label, help, in order). The transcript was generated from the loader as it was before
//! the field tables of `src/model/kinds.rs`; any change to a message, its location or
//! the order of messages fails here. To accept an intended change of messages, run
//! `DETUNE_BLESS=1 cargo test --test model_kinds` and review the diff of the transcript.

use detune::Model;
use detune::model::expr::Expr;
use detune::model::{BodyRef, Field, ForceKind, JointKind, PointRef};

/// Two bodies, a parameter; the element under test is appended.
const BASE: &str = r#"[parameters]
k = 10

[[bodies]]
name = "bar"
mass = 1
inertia = 1

[[bodies]]
name = "arm"
mass = 1
inertia = 1

"#;

/// (case, element tables appended to [`BASE`]); each must fail to load.
const CASES: &[(&str, &str)] = &[
    // --- joints: body1 is required by every type
    ("revolute: no body1", "[[joints]]\ntype = \"revolute\"\n"),
    (
        "pin_in_slot: no body1",
        "[[joints]]\ntype = \"pin_in_slot\"\naxis = [1, 0]\n",
    ),
    (
        "prismatic: no body1",
        "[[joints]]\ntype = \"prismatic\"\naxis = [1, 0]\n",
    ),
    ("fixed: no body1", "[[joints]]\ntype = \"fixed\"\n"),
    // --- joints: axis is required by pin_in_slot and prismatic
    (
        "pin_in_slot: no axis",
        "[[joints]]\ntype = \"pin_in_slot\"\nbody1 = \"bar\"\n",
    ),
    (
        "prismatic: no axis",
        "[[joints]]\ntype = \"prismatic\"\nbody1 = \"bar\"\nangle = 0.5\n",
    ),
    (
        "pin_in_slot: no body1, no axis",
        "[[joints]]\ntype = \"pin_in_slot\"\n",
    ),
    // --- joints: fields the type does not use
    (
        "revolute: axis",
        "[[joints]]\ntype = \"revolute\"\nbody1 = \"bar\"\naxis = [1, 0]\n",
    ),
    (
        "revolute: angle",
        "[[joints]]\ntype = \"revolute\"\nbody1 = \"bar\"\nangle = 0.5\n",
    ),
    (
        "revolute: angle and axis",
        "[[joints]]\ntype = \"revolute\"\nangle = 0.5\nbody1 = \"bar\"\naxis = [1, 0]\n",
    ),
    (
        "revolute: unusable angle",
        "[[joints]]\ntype = \"revolute\"\nbody1 = \"bar\"\nangle = \"2*(\"\n",
    ),
    (
        "pin_in_slot: angle",
        "[[joints]]\ntype = \"pin_in_slot\"\nbody1 = \"bar\"\naxis = [1, 0]\nangle = 0.5\n",
    ),
    (
        "fixed: axis",
        "[[joints]]\ntype = \"fixed\"\nbody1 = \"bar\"\naxis = [1, 0]\n",
    ),
    (
        "fixed: axis, no body1",
        "[[joints]]\ntype = \"fixed\"\naxis = [1, 0]\n",
    ),
    (
        "revolute: unknown bodies and axis",
        "[[joints]]\ntype = \"revolute\"\nbody1 = \"bra\"\nbody2 = \"xyz\"\naxis = [1, 0]\n",
    ),
    // --- joints: values
    (
        "revolute: points of 3 and 1 components",
        "[[joints]]\ntype = \"revolute\"\nbody = \"bar\"\npoint = [1, 2, 3]\nbody2 = \"arm\"\npoint2 = [1]\n",
    ),
    (
        "pin_in_slot: axis of 3 components",
        "[[joints]]\ntype = \"pin_in_slot\"\nbody1 = \"bar\"\naxis = [1, 0, 0]\n",
    ),
    (
        "prismatic: bad axis and bad angle",
        "[[joints]]\ntype = \"prismatic\"\nbody1 = \"bar\"\naxis = [\"2*\", \"(\"]\nangle = \"1 +\"\n",
    ),
    (
        "prismatic: no axis and bad angle",
        "[[joints]]\ntype = \"prismatic\"\nbody1 = \"bar\"\nangle = \"1 +\"\n",
    ),
    (
        "fixed: bad angle and bad point",
        "[[joints]]\ntype = \"fixed\"\nbody1 = \"bar\"\npoint1 = [\"(\", 0]\nangle = \"1 +\"\n",
    ),
    // --- joints: types
    (
        "joint type misspelt",
        "[[joints]]\ntype = \"revolut\"\nbody1 = \"bar\"\n",
    ),
    (
        "joint type unknown, and its body",
        "[[joints]]\nname = \"w\"\ntype = \"weld\"\nbody1 = \"nobody\"\naxis = [1, 0]\n",
    ),
    // --- gravity: acceleration is required, every other field is not used
    (
        "gravity: no acceleration",
        "[[forces]]\ntype = \"gravity\"\n",
    ),
    (
        "gravity: body1",
        "[[forces]]\ntype = \"gravity\"\nacceleration = [0, -9.81]\nbody1 = \"bar\"\n",
    ),
    (
        "gravity: body (alias)",
        "[[forces]]\ntype = \"gravity\"\nacceleration = [0, -9.81]\nbody = \"bar\"\n",
    ),
    (
        "gravity: point1",
        "[[forces]]\ntype = \"gravity\"\nacceleration = [0, -9.81]\npoint1 = [0, 0]\n",
    ),
    (
        "gravity: point (alias)",
        "[[forces]]\ntype = \"gravity\"\nacceleration = [0, -9.81]\npoint = [0, 0]\n",
    ),
    (
        "gravity: body2",
        "[[forces]]\ntype = \"gravity\"\nacceleration = [0, -9.81]\nbody2 = \"bar\"\n",
    ),
    (
        "gravity: point2",
        "[[forces]]\ntype = \"gravity\"\nacceleration = [0, -9.81]\npoint2 = [0, 0]\n",
    ),
    (
        "gravity: stiffness",
        "[[forces]]\ntype = \"gravity\"\nacceleration = [0, -9.81]\nstiffness = 1\n",
    ),
    (
        "gravity: damping",
        "[[forces]]\ntype = \"gravity\"\nacceleration = [0, -9.81]\ndamping = 1\n",
    ),
    (
        "gravity: free_length",
        "[[forces]]\ntype = \"gravity\"\nacceleration = [0, -9.81]\nfree_length = 1\n",
    ),
    (
        "gravity: force",
        "[[forces]]\ntype = \"gravity\"\nacceleration = [0, -9.81]\nforce = [0, 1]\n",
    ),
    (
        "gravity: every other field, no acceleration",
        "[[forces]]\ntype = \"gravity\"\nforce = [0, 1]\nfree_length = 1\ndamping = 1\nstiffness = 1\npoint2 = [0, 0]\nbody2 = \"bar\"\npoint = [0, 0]\nbody = \"nobody\"\n",
    ),
    (
        "gravity: acceleration of 1 component",
        "[[forces]]\ntype = \"gravity\"\nacceleration = [\"-g0\"]\n",
    ),
    // --- spring_damper: body1, stiffness, free_length required; acceleration, force not used
    (
        "spring_damper: no body1",
        "[[forces]]\ntype = \"spring_damper\"\nstiffness = \"k\"\nfree_length = 1\n",
    ),
    (
        "spring_damper: no stiffness",
        "[[forces]]\ntype = \"spring_damper\"\nbody1 = \"bar\"\nfree_length = 1\n",
    ),
    (
        "spring_damper: no free_length",
        "[[forces]]\ntype = \"spring_damper\"\nbody1 = \"bar\"\nstiffness = \"k\"\n",
    ),
    (
        "spring_damper: nothing but its type",
        "[[forces]]\nname = \"s\"\ntype = \"spring_damper\"\n",
    ),
    (
        "spring_damper: acceleration",
        "[[forces]]\ntype = \"spring_damper\"\nbody1 = \"bar\"\nstiffness = \"k\"\nfree_length = 1\nacceleration = [0, 1]\n",
    ),
    (
        "spring_damper: force",
        "[[forces]]\ntype = \"spring_damper\"\nbody1 = \"bar\"\nstiffness = \"k\"\nfree_length = 1\nforce = [0, 1]\n",
    ),
    (
        "spring_damper: force and acceleration, no stiffness",
        "[[forces]]\ntype = \"spring_damper\"\nforce = [0, 1]\nbody1 = \"nobody\"\nacceleration = [0, 1]\n",
    ),
    (
        "spring_damper: bad values everywhere",
        "[[forces]]\ntype = \"spring_damper\"\nbody1 = \"bra\"\npoint1 = [1]\nbody2 = \"amr\"\npoint2 = [1, 2, 3]\nstiffness = \"k +\"\ndamping = \"(\"\nfree_length = \"*\"\n",
    ),
    // --- point_force: body1 and force required; the second end and spring fields not used
    (
        "point_force: no body",
        "[[forces]]\ntype = \"point_force\"\nforce = [0, 1]\n",
    ),
    (
        "point_force: no force",
        "[[forces]]\ntype = \"point_force\"\nbody = \"bar\"\n",
    ),
    (
        "point_force: nothing but its type",
        "[[forces]]\ntype = \"point_force\"\n",
    ),
    (
        "point_force: acceleration",
        "[[forces]]\ntype = \"point_force\"\nbody = \"bar\"\nforce = [0, 1]\nacceleration = [0, 1]\n",
    ),
    (
        "point_force: body2",
        "[[forces]]\ntype = \"point_force\"\nbody = \"bar\"\nforce = [0, 1]\nbody2 = \"arm\"\n",
    ),
    (
        "point_force: point2",
        "[[forces]]\ntype = \"point_force\"\nbody = \"bar\"\nforce = [0, 1]\npoint2 = [0, 0]\n",
    ),
    (
        "point_force: stiffness",
        "[[forces]]\ntype = \"point_force\"\nbody = \"bar\"\nforce = [0, 1]\nstiffness = 1\n",
    ),
    (
        "point_force: damping",
        "[[forces]]\ntype = \"point_force\"\nbody = \"bar\"\nforce = [0, 1]\ndamping = 1\n",
    ),
    (
        "point_force: free_length",
        "[[forces]]\ntype = \"point_force\"\nbody = \"bar\"\nforce = [0, 1]\nfree_length = 1\n",
    ),
    (
        "point_force: every unused field",
        "[[forces]]\ntype = \"point_force\"\nfree_length = 1\ndamping = 1\nstiffness = 1\npoint2 = [0, 0]\nbody2 = \"arm\"\nacceleration = [0, 1]\n",
    ),
    (
        "point_force: on the ground",
        "[[forces]]\ntype = \"point_force\"\nbody = \"ground\"\nforce = [0, 1]\n",
    ),
    (
        "point_force: on the ground, no force",
        "[[forces]]\ntype = \"point_force\"\nbody1 = \"ground\"\n",
    ),
    (
        "point_force: on the ground, bad point",
        "[[forces]]\ntype = \"point_force\"\nbody = \"ground\"\npoint = [1, 2, 3]\nforce = [0, 1]\n",
    ),
    (
        "point_force: point and force of 3 components",
        "[[forces]]\ntype = \"point_force\"\nbody = \"bar\"\npoint = [1, 2, 3]\nforce = [0, 1, 2]\n",
    ),
    (
        "point_force: unknown body, no force",
        "[[forces]]\ntype = \"point_force\"\nbody = \"bra\"\n",
    ),
    // --- force types
    (
        "force type misspelt",
        "[[forces]]\ntype = \"spring_dampr\"\nbody1 = \"nobody\"\n",
    ),
    (
        "force type unknown",
        "[[forces]]\ntype = \"thrust\"\nforce = [1]\n",
    ),
    // --- several elements: every problem, in file order, joints before forces
    (
        "several elements",
        "[[forces]]\ntype = \"gravity\"\nstiffness = 1\n\n[[joints]]\ntype = \"fixed\"\naxis = [1, 0]\n\n[[forces]]\ntype = \"point_force\"\n\n[[joints]]\ntype = \"pin_in_slot\"\nbody1 = \"bar\"\n",
    ),
];

/// Every case's input and rendered error.
fn transcript() -> String {
    let mut out = String::new();
    for (case, element) in CASES {
        let text = format!("{BASE}{element}");
        let err = match Model::from_str("k.toml", &text) {
            Ok(_) => panic!("case `{case}` loads, but should not"),
            Err(e) => e.to_string(),
        };
        out.push_str(&format!("=== {case}\n{element}--- error\n{err}\n"));
    }
    out
}

#[test]
fn every_type_reports_missing_and_unused_fields_as_pinned() {
    let path = format!("{}/tests/data/model_kinds.txt", env!("CARGO_MANIFEST_DIR"));
    let got = transcript();
    if std::env::var_os("DETUNE_BLESS").is_some() {
        std::fs::write(&path, &got).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path).unwrap();
    if got != want {
        let line = got
            .lines()
            .zip(want.lines())
            .position(|(g, w)| g != w)
            .unwrap_or_else(|| got.lines().count().min(want.lines().count()));
        let context = |s: &str| {
            s.lines()
                .skip(line.saturating_sub(8))
                .take(16)
                .collect::<Vec<_>>()
                .join("\n")
        };
        panic!(
            "the errors differ from tests/data/model_kinds.txt from line {}:\n--- pinned\n{}\n--- now\n{}",
            line + 1,
            context(&want),
            context(&got)
        );
    }
}

fn load(elements: &str) -> Model {
    Model::from_str("k.toml", &format!("{BASE}{elements}")).unwrap_or_else(|e| panic!("{e}"))
}

/// A default: the number `value`, not written in the file, located at the element.
fn assert_default(f: &Field, value: f64, element: &std::ops::Range<usize>) {
    assert!(f.number, "{f:?}");
    assert_eq!(&f.span, element, "{f:?}");
    match f.expr {
        Expr::Number { value: v, .. } => assert_eq!(v, value),
        ref other => panic!("not a number: {other:?}"),
    }
}

fn assert_origin(p: &PointRef, element: &std::ops::Range<usize>) {
    assert_default(&p.point[0], 0.0, element);
    assert_default(&p.point[1], 0.0, element);
}

/// A field as written: a number in the file at `at`.
fn assert_written(f: &Field, value: f64, text: &str, at: &str) {
    assert!(f.number);
    assert_eq!(&text[f.span.clone()], at);
    match f.expr {
        Expr::Number { value: v, .. } => assert_eq!(v, value),
        ref other => panic!("not a number: {other:?}"),
    }
}

#[test]
fn joints_default_body2_to_ground_points_to_the_origin_and_angle_to_zero() {
    let m = load(
        "[[joints]]\ntype = \"revolute\"\nbody1 = \"bar\"\n\n\
         [[joints]]\ntype = \"pin_in_slot\"\nbody = \"arm\"\naxis = [1, 0]\n\n\
         [[joints]]\ntype = \"prismatic\"\nbody1 = \"bar\"\naxis = [0, 1]\n\n\
         [[joints]]\ntype = \"fixed\"\nbody1 = \"arm\"\n",
    );
    let names: Vec<&str> = m.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(names, ["joint1", "joint2", "joint3", "joint4"]);
    for (j, body1) in m.joints.iter().zip([0, 1, 0, 1]) {
        assert_eq!(j.p1.body, BodyRef::Body(body1), "{}", j.name);
        assert_eq!(j.p2.body, BodyRef::Ground, "{}", j.name);
        assert_origin(&j.p1, &j.span);
        assert_origin(&j.p2, &j.span);
    }
    assert!(matches!(m.joints[0].kind, JointKind::Revolute));
    assert!(matches!(m.joints[1].kind, JointKind::PinInSlot { .. }));
    match &m.joints[2].kind {
        JointKind::Prismatic { angle, .. } => assert_default(angle, 0.0, &m.joints[2].span),
        other => panic!("{other:?}"),
    }
    match &m.joints[3].kind {
        JointKind::Fixed { angle } => assert_default(angle, 0.0, &m.joints[3].span),
        other => panic!("{other:?}"),
    }
}

#[test]
fn joints_read_what_is_given() {
    let text = format!(
        "{BASE}[[joints]]\nname = \"p\"\ntype = \"prismatic\"\nbody = \"bar\"\npoint = [1.5, 2.5]\n\
         body2 = \"arm\"\npoint2 = [3.5, 4.5]\naxis = [5.5, 6.5]\nangle = 7.5\n"
    );
    let m = Model::from_str("k.toml", &text).unwrap();
    let j = &m.joints[0];
    assert_eq!(j.name, "p");
    assert_eq!((j.p1.body, j.p2.body), (BodyRef::Body(0), BodyRef::Body(1)));
    assert_written(&j.p1.point[0], 1.5, &text, "1.5");
    assert_written(&j.p1.point[1], 2.5, &text, "2.5");
    assert_written(&j.p2.point[0], 3.5, &text, "3.5");
    assert_written(&j.p2.point[1], 4.5, &text, "4.5");
    match &j.kind {
        JointKind::Prismatic { axis, angle } => {
            assert_written(&axis[0], 5.5, &text, "5.5");
            assert_written(&axis[1], 6.5, &text, "6.5");
            assert_written(angle, 7.5, &text, "7.5");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn forces_default_damping_to_zero_body2_to_ground_and_points_to_the_origin() {
    let m = load(
        "[[forces]]\ntype = \"gravity\"\nacceleration = [0, -9.81]\n\n\
         [[forces]]\ntype = \"spring_damper\"\nbody = \"bar\"\nstiffness = \"k\"\nfree_length = 1\n\n\
         [[forces]]\ntype = \"point_force\"\nbody1 = \"arm\"\nforce = [0, 1]\n",
    );
    let names: Vec<&str> = m.forces.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["force1", "force2", "force3"]);
    assert!(matches!(m.forces[0].kind, ForceKind::Gravity { .. }));
    let span = &m.forces[1].span;
    match &m.forces[1].kind {
        ForceKind::SpringDamper {
            p1, p2, damping, ..
        } => {
            assert_eq!(p1.body, BodyRef::Body(0));
            assert_eq!(p2.body, BodyRef::Ground);
            assert_origin(p1, span);
            assert_origin(p2, span);
            assert_default(damping, 0.0, span);
        }
        other => panic!("{other:?}"),
    }
    match &m.forces[2].kind {
        ForceKind::PointForce { at, .. } => {
            assert_eq!(at.body, BodyRef::Body(1));
            assert_origin(at, &m.forces[2].span);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn forces_read_what_is_given() {
    let text = format!(
        "{BASE}[[forces]]\nname = \"s\"\ntype = \"spring_damper\"\nbody1 = \"bar\"\npoint1 = [1.5, 2.5]\n\
         body2 = \"arm\"\npoint2 = [3.5, 4.5]\nstiffness = 5.5\ndamping = 6.5\nfree_length = 7.5\n\n\
         [[forces]]\ntype = \"point_force\"\nbody = \"arm\"\npoint = [8.5, 9.5]\nforce = [10.5, 11.5]\n\n\
         [[forces]]\ntype = \"gravity\"\nacceleration = [12.5, 13.5]\n"
    );
    let m = Model::from_str("k.toml", &text).unwrap();
    match &m.forces[0].kind {
        ForceKind::SpringDamper {
            p1,
            p2,
            stiffness,
            damping,
            free_length,
            law,
        } => {
            assert_eq!(format!("{law:?}"), "Linear");
            assert_eq!((p1.body, p2.body), (BodyRef::Body(0), BodyRef::Body(1)));
            assert_written(&p1.point[0], 1.5, &text, "1.5");
            assert_written(&p1.point[1], 2.5, &text, "2.5");
            assert_written(&p2.point[0], 3.5, &text, "3.5");
            assert_written(&p2.point[1], 4.5, &text, "4.5");
            assert_written(stiffness, 5.5, &text, "5.5");
            assert_written(damping, 6.5, &text, "6.5");
            assert_written(free_length, 7.5, &text, "7.5");
        }
        other => panic!("{other:?}"),
    }
    match &m.forces[1].kind {
        ForceKind::PointForce { at, force } => {
            assert_eq!(at.body, BodyRef::Body(1));
            assert_written(&at.point[0], 8.5, &text, "8.5");
            assert_written(&at.point[1], 9.5, &text, "9.5");
            assert_written(&force[0], 10.5, &text, "10.5");
            assert_written(&force[1], 11.5, &text, "11.5");
        }
        other => panic!("{other:?}"),
    }
    match &m.forces[2].kind {
        ForceKind::Gravity { acceleration } => {
            assert_written(&acceleration[0], 12.5, &text, "12.5");
            assert_written(&acceleration[1], 13.5, &text, "13.5");
        }
        other => panic!("{other:?}"),
    }
}
