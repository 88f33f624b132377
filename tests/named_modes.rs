//! `[[modes]]` in the model file: each bad entry is refused where it is written (file,
//! line, column) with what to do, and the names that cannot be matched at the baseline are
//! refused with their MAC values.

mod common;

use detune::linear::modal_analysis;
use detune::linear::tracking::name_modes;
use detune::{Model, System};

fn text() -> String {
    std::fs::read_to_string(common::data("veering_pendulums.toml")).unwrap()
}

/// The model with its `[[modes]]` replaced by `modes`.
fn with_modes(modes: &str) -> String {
    let t = text();
    let head = &t[..t.find("[[modes]]").unwrap()];
    format!("{head}{modes}")
}

/// The line and column (1-based) of the first `what` in `text`.
fn at(text: &str, what: &str) -> String {
    let i = text.find(what).unwrap_or_else(|| panic!("{what}"));
    let line = text[..i].matches('\n').count() + 1;
    let col = i - text[..i].rfind('\n').map_or(0, |k| k + 1) + 1;
    format!("m.toml:{line}:{col}")
}

/// The error of loading `text`, and that it is located at the first `what`.
fn refused(text: &str, what: &str) -> String {
    let e = Model::from_str("m.toml", text)
        .and_then(|m| System::new(&m).map(|_| m))
        .unwrap_err()
        .to_string();
    let want = at(text, what);
    assert!(e.contains(&want), "{want} not in: {e}");
    e
}

#[test]
fn the_shipped_names_load() {
    let m = Model::from_str("m.toml", &text()).unwrap();
    let names: Vec<&str> = m.modes.iter().map(|d| d.name.as_str()).collect();
    assert_eq!(names, ["pendulum 1 swings", "pendulum 2 swings"]);
    let sys = System::new(&m).unwrap();
    let i = sys.velocity_index("p2.theta").unwrap();
    assert_eq!(sys.declared_modes[1].shape, [(i - 3, 0.0), (i, 1.0)]);
}

#[test]
fn an_unknown_field_is_refused() {
    let t = with_modes("[[modes]]\nname = \"a\"\nshapes = { \"p1.theta\" = 1 }\n");
    let e = refused(&t, "shapes");
    assert!(e.contains("unknown field `shapes`"), "{e}");
}

#[test]
fn an_unknown_coordinate_is_refused_with_a_suggestion() {
    let t = with_modes("[[modes]]\nname = \"a\"\nshape = { \"p1.thta\" = 1 }\n");
    let e = refused(&t, "\"p1.thta\"");
    assert!(e.contains("`p1.thta`, which is not a coordinate"), "{e}");
    assert!(e.contains("did you mean `p1.theta`?"), "{e}");
}

#[test]
fn duplicate_names_are_refused() {
    let t = with_modes(
        "[[modes]]\nname = \"a\"\nshape = { \"p1.theta\" = 1 }\n\
         [[modes]]\nname = \"a\"\nshape = { \"p2.theta\" = 1 }\n",
    );
    let second = t.rfind("\"a\"").unwrap();
    let e = Model::from_str("m.toml", &t).unwrap_err().to_string();
    assert!(e.contains("two modes are named `a`"), "{e}");
    let line = t[..second].matches('\n').count() + 1;
    assert!(e.contains(&format!("m.toml:{line}:8")), "{e}");
}

#[test]
fn empty_and_reserved_names_are_refused() {
    let t = with_modes("[[modes]]\nname = \" \"\nshape = { \"p1.theta\" = 1 }\n");
    let e = refused(&t, "\" \"");
    assert!(e.contains("the mode's `name` is empty"), "{e}");
    let t = with_modes("[[modes]]\nname = \"mode 2\"\nshape = { \"p1.theta\" = 1 }\n");
    let e = refused(&t, "\"mode 2\"");
    assert!(e.contains("the form of an unnamed mode's"), "{e}");
    let t = with_modes("[[modes]]\nname = \"a, b\"\nshape = { \"p1.theta\" = 1 }\n");
    let e = refused(&t, "\"a, b\"");
    assert!(e.contains("has a comma or a quote"), "{e}");
}

#[test]
fn a_zero_or_empty_shape_is_refused() {
    let t =
        with_modes("[[modes]]\nname = \"a\"\nshape = { \"p1.theta\" = 0, \"p2.theta\" = 0.0 }\n");
    let e = refused(&t, "{ \"p1");
    assert!(e.contains("is zero in every coordinate"), "{e}");
    let t = with_modes("[[modes]]\nname = \"a\"\nshape = {}\n");
    let e = refused(&t, "{}");
    assert!(e.contains("gives no coordinate"), "{e}");
}

#[test]
fn a_value_that_is_not_a_number_is_refused() {
    let t = with_modes("[[modes]]\nname = \"a\"\nshape = { \"p1.theta\" = \"1 rad\" }\n");
    let e = refused(&t, "\"1 rad\"");
    assert!(e.contains("not a finite number"), "{e}");
    let t = with_modes("[[modes]]\nname = \"a\"\nshape = { \"p1.theta\" = nan }\n");
    let e = refused(&t, "nan");
    assert!(e.contains("not a finite number"), "{e}");
}

#[test]
fn a_missing_shape_is_refused() {
    let t = with_modes("[[modes]]\nname = \"a\"\n");
    let e = Model::from_str("m.toml", &t).unwrap_err().to_string();
    assert!(e.contains("missing field `shape`"), "{e}");
}

/// The error of naming the modes of the model with `modes`.
fn naming_error(modes: &str) -> detune::Error {
    let m = Model::from_str("m.toml", &with_modes(modes)).unwrap();
    let sys = System::new(&m).unwrap();
    let modal = modal_analysis(&sys, None).unwrap();
    name_modes(&sys, &modal).unwrap_err()
}

#[test]
fn a_shape_that_matches_no_mode_is_refused_with_its_macs() {
    // p1.y does not move in either mode (to first order): MAC 0 with both
    let e = naming_error("[[modes]]\nname = \"bounce\"\nshape = { \"p1.y\" = 1 }\n");
    let s = e.to_string();
    assert!(s.contains("`bounce` matches no mode"), "{s}");
    assert!(s.contains("1: 0.000, 2: 0.000"), "{s}");
}

#[test]
fn two_names_for_one_mode_are_refused() {
    let e = naming_error(
        "[[modes]]\nname = \"a\"\nshape = { \"p1.theta\" = 1, \"p2.theta\" = 0 }\n\
         [[modes]]\nname = \"b\"\nshape = { \"p1.theta\" = 1, \"p2.theta\" = 0.01 }\n",
    );
    let s = e.to_string();
    assert!(
        s.contains("`a` (MAC 0.999) and `b` (MAC 1.000) both match mode 1"),
        "{s}"
    );
}

#[test]
fn a_shape_that_does_not_tell_two_modes_apart_is_refused() {
    // one coordinate: MAC 1 with both modes, in each of which pendulum 1 moves
    let e = naming_error("[[modes]]\nname = \"a\"\nshape = { \"p1.theta\" = 1 }\n");
    let s = e.to_string();
    assert!(
        s.contains("`a` matches modes 1 and 2 about equally (MAC 1.000 and 1.000)"),
        "{s}"
    );
}
