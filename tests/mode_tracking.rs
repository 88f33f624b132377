//! Modes that keep their names (`detune::linear::tracking`): the labels follow the modes
//! through a veering and a crossing as the closed form of two coupled pendulums says, hold
//! on the inceptor over the shaft stiffness, and the energy shares agree with the
//! inceptor's 2-coordinate reference model.
//!
//! **Two pendulums, closed form** (`tests/data/veering_pendulums.toml`). Pendulum i is a
//! mass m at distance l_i below its pivot with centroidal inertia I; a torsion spring kc
//! acts on θ1 − θ2. With T = ½ Σ (m l_i² + I) θ̇_i² and V = Σ m g l_i (1 − cos θ_i) +
//! ½ kc (θ1 − θ2)², the linearized equations are M θ̈ + K θ = 0 with
//!
//! ```text
//! M = diag(J1, J2), J_i = m l_i² + I,    K = [m g l1 + kc, −kc; −kc, m g l2 + kc]
//! ω²_∓ = ½ (a + d ∓ √((a − d)² + 4 kc²/(J1 J2))),  a = K11/J1, d = K22/J2
//! shape: θ2/θ1 = (K11 − ω² J1)/kc
//! ```
//!
//! For l2 < l1 pendulum 2 is the faster: the lower mode is pendulum 1 swinging. The two
//! branches never meet when kc > 0 (the square root stays ≥ 2kc/√(J1J2)): the lower
//! branch's shape turns from θ2/θ1 ≈ 0 to θ2/θ1 ≫ 1 across l2 ≈ l1 (a veering), so the
//! label "pendulum 1 swings" must end as the lower mode, in which pendulum 2 swings. With
//! kc = 0 the modes are each pendulum alone and their frequencies cross at l2 = l1.

mod common;

use detune::linear::modal_analysis;
use detune::linear::tracking::{ModeTracking, TrackOptions, describe_modes, track_modes};
use detune::{Model, System};
use nalgebra::{Complex, DMatrix};

const G: f64 = 9.81;
const M: f64 = 1.0;
const I: f64 = 0.001;
const L1: f64 = 1.0;

fn read_json(path: &str) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn pendulums(sets: &[(&str, &str)]) -> System {
    let model = common::with_sets(
        Model::load(&common::data("veering_pendulums.toml")).unwrap(),
        sets,
    );
    System::new(&model).unwrap()
}

/// Closed form: (ω_-, ω_+) in rad/s and the lower mode's θ2/θ1.
fn closed_form(l2: f64, kc: f64) -> (f64, f64, f64) {
    let (j1, j2) = (M * L1 * L1 + I, M * l2 * l2 + I);
    let k11 = M * G * L1 + kc;
    let (a, d) = (k11 / j1, (M * G * l2 + kc) / j2);
    let root = ((a - d).powi(2) + 4.0 * kc * kc / (j1 * j2)).sqrt();
    let (lo, hi) = (0.5 * (a + d - root), 0.5 * (a + d + root));
    (lo.sqrt(), hi.sqrt(), (k11 - lo * j1) / kc)
}

fn label(t: &ModeTracking, name: &str) -> usize {
    t.labels.iter().position(|l| l == name).unwrap()
}

/// θ2/θ1 of label `l`'s shape at step `k`.
fn ratio(sys: &System, t: &ModeTracking, k: usize, l: usize) -> f64 {
    let s = t.steps[k].shapes[l].as_ref().unwrap();
    let (i1, i2) = (
        sys.coordinate_index("p1.theta").unwrap(),
        sys.coordinate_index("p2.theta").unwrap(),
    );
    let (a, b) = (s[i1], s[i2]);
    // real shapes (no damping): the ratio of the real parts
    assert!(a.im.abs() < 1e-9 && b.im.abs() < 1e-9);
    b.re / a.re
}

#[test]
fn labels_follow_the_pendulums_through_the_veering() {
    let kc = 0.05;
    let sys = pendulums(&[]);
    let values: Vec<f64> = (0..=9).map(|k| 0.8 + 0.05 * k as f64).collect();
    let t = track_modes(&sys, "l2", &values, &TrackOptions::default()).unwrap();
    let (one, two) = (
        label(&t, "pendulum 1 swings"),
        label(&t, "pendulum 2 swings"),
    );
    // named at the baseline l2 = 0.8: pendulum 1 swings in the lower mode
    assert_eq!(t.labels[0], "pendulum 1 swings");
    assert!(t.warnings.is_empty(), "{:?}", t.warnings);
    for (k, s) in t.steps.iter().enumerate() {
        let l2 = s.value;
        let (lo, hi, lower_ratio) = closed_form(l2, kc);
        let w1 = s.modes[one].as_ref().unwrap().omega_n_rad_s;
        let w2 = s.modes[two].as_ref().unwrap().omega_n_rad_s;
        // the label that started as pendulum 1 stays on the lower branch
        assert!((w1 - lo).abs() < 1e-7 * lo, "l2 = {l2}: {w1} vs {lo}");
        assert!((w2 - hi).abs() < 1e-7 * hi, "l2 = {l2}: {w2} vs {hi}");
        let r = ratio(&sys, &t, k, one);
        assert!(
            (r - lower_ratio).abs() < 1e-6 * (1.0 + lower_ratio.abs()),
            "l2 = {l2}: θ2/θ1 {r} vs {lower_ratio}"
        );
    }
    // after the veering, pendulum 2 carries the label that started as pendulum 1
    let last = t.steps.len() - 1;
    assert!((t.steps[last].value - 1.25).abs() < 1e-12);
    assert!(ratio(&sys, &t, last, one).abs() > 20.0);
    assert!(ratio(&sys, &t, 0, one).abs() < 0.05);
    // step halving was needed and kept every step's MAC above the threshold
    assert!(t.steps.iter().any(|s| !s.requested));
    assert!(t.min_mac.iter().all(|m| *m >= 0.9), "{:?}", t.min_mac);
    // a veering, no crossing, at the closed form's least relative gap
    assert!(t.crossings.is_empty(), "{:?}", t.crossings);
    assert_eq!(t.veerings.len(), 1, "{:?}", t.veerings);
    let v = &t.veerings[0];
    let gap = |l2: f64| {
        let (lo, hi, _) = closed_form(l2, kc);
        (hi - lo) / (0.5 * (hi + lo))
    };
    let fine: Vec<f64> = (0..=45_000).map(|k| 0.8 + 1e-5 * k as f64).collect();
    let at = fine
        .iter()
        .copied()
        .min_by(|a, b| gap(*a).total_cmp(&gap(*b)))
        .unwrap();
    // on the values solved, the least gap is at the solved value nearest the minimum
    let nearest = t
        .steps
        .iter()
        .map(|s| s.value)
        .min_by(|a, b| (a - at).abs().total_cmp(&(b - at).abs()))
        .unwrap();
    assert_eq!(
        v.value, nearest,
        "veering at {} vs closed form {at}",
        v.value
    );
    assert!((v.relative_gap - gap(v.value)).abs() < 1e-7);
}

#[test]
fn without_step_halving_the_veering_is_too_coarse_to_follow() {
    let sys = pendulums(&[]);
    let values: Vec<f64> = (0..=9).map(|k| 0.8 + 0.05 * k as f64).collect();
    let opts = TrackOptions {
        max_halvings: 0,
        ..TrackOptions::default()
    };
    let t = track_modes(&sys, "l2", &values, &opts).unwrap();
    // the MAC between the grid points either side of the veering is poor: said, not hidden
    assert!(!t.warnings.is_empty());
    assert!(t.min_mac.iter().any(|m| *m < 0.9), "{:?}", t.min_mac);
}

#[test]
fn uncoupled_pendulums_cross() {
    let sys = pendulums(&[("kc", "0")]);
    // off the grid point l2 = l1, where the two frequencies are equal
    let values: Vec<f64> = (0..=9).map(|k| 0.81 + 0.05 * k as f64).collect();
    let t = track_modes(&sys, "l2", &values, &TrackOptions::default()).unwrap();
    let (one, two) = (
        label(&t, "pendulum 1 swings"),
        label(&t, "pendulum 2 swings"),
    );
    let alone = |l: f64| (M * G * l / (M * l * l + I)).sqrt();
    for s in &t.steps {
        let w1 = s.modes[one].as_ref().unwrap().omega_n_rad_s;
        let w2 = s.modes[two].as_ref().unwrap().omega_n_rad_s;
        assert!((w1 - alone(L1)).abs() < 1e-7 * w1, "{w1}");
        assert!((w2 - alone(s.value)).abs() < 1e-7 * w2, "{w2}");
    }
    assert!(t.veerings.is_empty(), "{:?}", t.veerings);
    assert_eq!(t.crossings.len(), 1, "{:?}", t.crossings);
    let c = &t.crossings[0];
    // ω of pendulum 2 is interpolated linearly between 0.96 and 1.01 m
    assert!((c.value - L1).abs() < 1e-3, "{}", c.value);
    assert!((c.omega_n_rad_s - alone(L1)).abs() < 1e-3);
}

fn inceptor(sets: &[(&str, &str)]) -> System {
    let model = common::with_sets(Model::load("models/inceptor.toml").unwrap(), sets);
    let sys = System::new(&model).unwrap();
    detune::statics::trim::trim(&sys).unwrap().0
}

/// The 2-coordinate reference model (φ, θ_g) of `tests/data/inceptor/modes.json` at
/// shaft stiffness `kt`: M, C from the file; K's shaft part k_t [r², −r; −r, 1] (r =
/// δ/φ, the crank's ratio) scaled to `kt`, the rest (the sensor's, the reactions') as
/// at the baseline (the shaft is untwisted at rest: the pose does not change).
fn minimal(kt: f64) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>, f64) {
    let v = read_json("tests/data/inceptor/modes.json");
    let lm = &v["baseline"]["minimal"]["linear_matrices"];
    let m = |k: &str| DMatrix::from_fn(2, 2, |i, j| lm[k][i][j].as_f64().unwrap());
    let (mass, damping, k0) = (m("M"), m("C"), m("K"));
    let r = v["baseline"]["minimal"]["undamped"][0]["shape"]["delta"]
        .as_f64()
        .unwrap();
    let kt0 = 374.0;
    let shaft = DMatrix::from_row_slice(2, 2, &[r * r, -r, -r, 1.0]);
    (mass, damping, k0 + shaft * (kt - kt0), r)
}

/// The damped eigenvalues (Im ≥ 0) of the 2-coordinate model.
fn minimal_eigenvalues(kt: f64) -> Vec<Complex<f64>> {
    let (m, c, k, _) = minimal(kt);
    let minv = m.try_inverse().unwrap();
    let mut s = DMatrix::zeros(4, 4);
    s.view_mut((0, 2), (2, 2))
        .copy_from(&DMatrix::identity(2, 2));
    s.view_mut((2, 0), (2, 2)).copy_from(&(-&minv * k));
    s.view_mut((2, 2), (2, 2)).copy_from(&(-&minv * c));
    s.complex_eigenvalues()
        .iter()
        .copied()
        .filter(|l| l.im > 0.0)
        .collect()
}

#[test]
fn inceptor_labels_hold_over_the_shaft_stiffness() {
    let sys = inceptor(&[]);
    let values: Vec<f64> = (0..=28).map(|k| 200.0 + 100.0 * k as f64).collect();
    let t = track_modes(&sys, "k_t", &values, &TrackOptions::default()).unwrap();
    assert_eq!(t.labels, ["in-phase", "shaft-twist"]);
    assert!(t.warnings.is_empty(), "{:?}", t.warnings);
    assert_eq!(t.steps.len(), values.len(), "no step needed halving");
    for (l, name) in t.labels.iter().enumerate() {
        for s in &t.steps {
            let m = s.modes[l].as_ref().unwrap();
            assert!(m.mac >= 0.95, "{name} at k_t = {}: MAC {}", s.value, m.mac);
        }
        assert!(t.min_mac[l] >= 0.95);
    }
    assert!(t.crossings.is_empty() && t.veerings.is_empty());
    // each label on the branch of the second formulation: in-phase the lower at every k_t
    for s in t.steps.iter().step_by(7) {
        let mut want = minimal_eigenvalues(s.value);
        want.sort_by(|a, b| a.norm().total_cmp(&b.norm()));
        for (l, w) in want.iter().enumerate() {
            let e = s.modes[l].as_ref().unwrap().eigenvalue;
            let got = Complex::new(e.re, e.im);
            assert!(
                (got - w).norm() < 1e-6 * w.norm(),
                "{} at k_t = {}: λ = {got} vs the 2-coordinate model's {w}",
                t.labels[l],
                s.value
            );
        }
    }
}

#[test]
fn inceptor_names_match_the_shapes_they_describe() {
    let sys = inceptor(&[]);
    let modal = modal_analysis(&sys, None).unwrap();
    let named = describe_modes(&sys, &modal).unwrap();
    let names: Vec<&str> = named.iter().map(|n| n.name.name.as_str()).collect();
    assert_eq!(names, ["in-phase", "shaft-twist"]);
    let g = sys.coordinate_index("gearbox.theta").unwrap();
    let phi = sys.coordinate_index("stick.phi").unwrap();
    // in-phase: the gearbox turns with the stick (and the crank); shaft-twist: against it
    assert!(modal.modes[0].shape[g].re / modal.modes[0].shape[phi].re > 0.5);
    assert!(modal.modes[1].shape[g].re / modal.modes[1].shape[phi].re < -0.5);
    assert!(named.iter().all(|n| n.name.declared_mac.unwrap() > 0.95));
}

/// The kinetic share of the gearbox and the strain share of the shaft in the
/// 2-coordinate model's mode of shape (φ = 1, θ_g = x): the gearbox holds 0.9 |x|² of
/// φ̇ᴴ M φ̇ (M = diag(M_φ, 0.9)); the shaft's strain energy is k_t |x − r|² of
/// Re(ξᴴ K ξ), δ = r φ the crank's angle.
fn minimal_shares(x: Complex<f64>, kt: f64) -> (f64, f64) {
    let (m, _, k, r) = minimal(kt);
    let xi = [Complex::new(1.0, 0.0), x];
    let quad = |a: &DMatrix<f64>| {
        let mut s = Complex::new(0.0, 0.0);
        for i in 0..2 {
            for j in 0..2 {
                s += xi[i].conj() * a[(i, j)] * xi[j];
            }
        }
        s.re
    };
    let gearbox = m[(1, 1)] * x.norm_sqr() / quad(&m);
    let shaft = kt * (x - r).norm_sqr() / quad(&k);
    (gearbox, shaft)
}

#[test]
fn inceptor_energy_shares_agree_with_the_two_coordinate_model() {
    let v = read_json("tests/data/inceptor/modes.json");
    // damped (the model as it is): against the reference's damped shapes
    let sys = inceptor(&[]);
    let modal = modal_analysis(&sys, None).unwrap();
    let named = describe_modes(&sys, &modal).unwrap();
    for (k, n) in named.iter().enumerate() {
        let s = &v["baseline"]["minimal"]["damped"][k]["shape"]["thg"];
        let x = Complex::new(s["re"].as_f64().unwrap(), s["im"].as_f64().unwrap());
        let (gearbox, shaft) = minimal_shares(x, 374.0);
        // the reference's matrices are central differences (~1e-8) and its shapes agree
        // with ours to ~1e-7: 1e-6 on a fraction
        let ke = n.energy.kinetic.get("gearbox").unwrap();
        let se = n.energy.strain.get("shaft").unwrap();
        assert!(
            (ke - gearbox).abs() < 1e-6,
            "{}: {ke} vs {gearbox}",
            n.name.name
        );
        assert!(
            (se - shaft).abs() < 1e-6,
            "{}: {se} vs {shaft}",
            n.name.name
        );
    }
    assert_eq!(named[0].dominant_body.as_ref().unwrap().body, "gearbox");
    // undamped (c_d = c_fs = 0): the figures of the issue, 55 % and 78 %
    let sys = inceptor(&[("c_d", "0"), ("c_fs", "0")]);
    let modal = modal_analysis(&sys, None).unwrap();
    let named = describe_modes(&sys, &modal).unwrap();
    for (k, n) in named.iter().enumerate() {
        let x = v["baseline"]["minimal"]["undamped"][k]["shape"]["thg"]
            .as_f64()
            .unwrap();
        let (gearbox, shaft) = minimal_shares(Complex::new(x, 0.0), 374.0);
        let ke = n.energy.kinetic.get("gearbox").unwrap();
        let se = n.energy.strain.get("shaft").unwrap();
        assert!(
            (ke - gearbox).abs() < 1e-6,
            "{}: {ke} vs {gearbox}",
            n.name.name
        );
        assert!(
            (se - shaft).abs() < 1e-6,
            "{}: {se} vs {shaft}",
            n.name.name
        );
    }
    let in_phase = named[0].energy.kinetic.get("gearbox").unwrap();
    let twist = named[1].energy.strain.get("shaft").unwrap();
    assert_eq!((100.0 * in_phase).round(), 55.0, "{in_phase}");
    assert_eq!((100.0 * twist).round(), 78.0, "{twist}");
}

#[test]
fn pendulum_strain_energy_is_the_reactions_and_the_spring() {
    // A pendulum's gravity stiffness m g l is the pivot's reaction's: with the coupling
    // spring, the strain shares are kc |θ1 − θ2|² and m g l_i θ_i² of the total.
    let sys = pendulums(&[]);
    let modal = modal_analysis(&sys, None).unwrap();
    let named = describe_modes(&sys, &modal).unwrap();
    let (i1, i2) = (
        sys.coordinate_index("p1.theta").unwrap(),
        sys.coordinate_index("p2.theta").unwrap(),
    );
    let (kc, l2) = (0.05, 0.8);
    for (m, n) in modal.modes.iter().zip(&named) {
        let (a, b) = (m.shape[i1].re, m.shape[i2].re);
        let spring = kc * (a - b).powi(2);
        let gravity = M * G * L1 * a * a + M * G * l2 * b * b;
        let want = spring / (spring + gravity);
        let got = n.energy.strain.get("coupling").unwrap();
        assert!((got - want).abs() < 1e-9, "{got} vs {want}");
        let reactions = n.energy.strain.get("constraint reactions").unwrap();
        assert!((reactions - gravity / (spring + gravity)).abs() < 1e-9);
        // kinetic: J_i θ_i² (the CG's translation and the rotation about it)
        let (j1, j2) = (M * L1 * L1 + I, M * l2 * l2 + I);
        let ke1 = j1 * a * a / (j1 * a * a + j2 * b * b);
        assert!((n.energy.kinetic.get("p1").unwrap() - ke1).abs() < 1e-9);
    }
}

#[test]
fn labels_are_carried_one_step_for_callers_with_their_own_path() {
    use detune::linear::tracking::{Solved, carry_labels};
    let sys = inceptor(&[]);
    let modal = modal_analysis(&sys, None).unwrap();
    let last = Solved {
        value: 374.0,
        modes: vec![Some(0), Some(1)],
        macs: vec![1.0, 1.0],
        modal: modal.clone(),
    };
    let opts = TrackOptions::default();
    // to itself: each label its own mode, MAC 1
    let (modes, macs, poor) = carry_labels(&last, &modal, &[None, None], &opts);
    assert_eq!(modes, [Some(0), Some(1)]);
    assert!(macs.iter().all(|m| (m - 1.0).abs() < 1e-12) && !poor);
    // one step of 100 N·m/rad: as the tracking's step; one of 2626: the same labels, with
    // the shapes changed more (the gearbox locks to the crank as the shaft stiffens)
    let k = sys.param_index("k_t").unwrap();
    let near = modal_analysis(&sys.with_param(k, 474.0).unwrap(), None).unwrap();
    let (modes, near_macs, poor) = carry_labels(&last, &near, &[None, None], &opts);
    assert_eq!(modes, [Some(0), Some(1)]);
    assert!(
        near_macs.iter().all(|m| *m > 0.95) && !poor,
        "{near_macs:?}"
    );
    let far = modal_analysis(&sys.with_param(k, 3000.0).unwrap(), None).unwrap();
    let (modes, macs, _) = carry_labels(&last, &far, &[None, None], &opts);
    assert_eq!(modes, [Some(0), Some(1)]);
    assert!(macs[0] < near_macs[0] && macs[1] < near_macs[1], "{macs:?}");
}

#[test]
fn element_stiffnesses_add_up_to_the_linearization() {
    // Σ K_e + K_reactions = K (the linearization's, computed in one pass of all forces):
    // what makes the strain shares sum to 1. The overcentre has a preloaded spring, a
    // point force and gravity; the inceptor a sensor, a shaft, a damper and gravity.
    use detune::linear::tracking::element_stiffnesses;
    let overcentre = System::new(&common::overcentre(&[("Fs", "3")])).unwrap();
    for sys in [inceptor(&[]), overcentre] {
        let modal = modal_analysis(&sys, None).unwrap();
        let eq = &modal.equilibrium;
        let parts = element_stiffnesses(&sys, &eq.q, &eq.lambda, &modal.rows).unwrap();
        let k = &modal.linearization.full_stiffness;
        let sum = parts
            .iter()
            .fold(DMatrix::zeros(k.nrows(), k.ncols()), |a, (_, m)| a + m);
        let scale = k.amax();
        assert!((&sum - k).amax() < 1e-12 * scale, "{}", (&sum - k).amax());
        // and each element's is its own: the reactions' alone is not K
        let reactions = &parts.last().unwrap().1;
        assert!((reactions - k).amax() > 1e-3 * scale);
    }
}

/// `sensitivity` follows each label from the baseline to a case past the veering (step
/// halving along the way), so the case's frequency is the one `track_modes` and the closed
/// form give the label there; matching the case's shapes to the baseline's directly would
/// have swapped the two (the MAC with the baseline's shape is near 0).
#[test]
fn sensitivity_cases_follow_the_labels_through_the_veering() {
    use detune::linear::sensitivity::{Vary, sensitivity};
    let sys = pendulums(&[]);
    let i = sys.param_index("l2").unwrap();
    let vary = Vary {
        param: i,
        name: "l2".into(),
        cases: vec![("l2=1.25".into(), 1.25), ("l2=0.85".into(), 0.85)],
        range: (0.8, 1.25),
    };
    let s = sensitivity(&sys, &[vary], None, None).unwrap();
    let one = s
        .modes
        .iter()
        .find(|m| m.name == "pendulum 1 swings")
        .unwrap();
    let two = s
        .modes
        .iter()
        .find(|m| m.name == "pendulum 2 swings")
        .unwrap();
    for (case, l2) in [(0, 1.25), (1, 0.85)] {
        let (lo, hi, _) = closed_form(l2, 0.05);
        let (w1, w2) = (one.cases[case].omega_n_rad_s, two.cases[case].omega_n_rad_s);
        assert!((w1 - lo).abs() < 1e-7 * lo, "l2 = {l2}: {w1} vs {lo}");
        assert!((w2 - hi).abs() < 1e-7 * hi, "l2 = {l2}: {w2} vs {hi}");
    }
    // past the veering the label's shape has become pendulum 2's: far from its baseline
    assert!(one.cases[0].mac < 0.1, "{}", one.cases[0].mac);
    // before it, the same shape
    assert!(one.cases[1].mac > 0.9, "{}", one.cases[1].mac);
    // the tolerance interval holds the lower branch only
    let (lo_end, _, _) = closed_form(1.25, 0.05);
    let (lo_start, hi_start, _) = closed_form(0.8, 0.05);
    assert!((one.worst_case.min_rad_s - lo_end.min(lo_start)).abs() < 1e-7);
    assert!(one.worst_case.max_rad_s < hi_start);
}

/// Over the push-rod length l2 (its `[trim]` re-solving L0 at every step) the tracking
/// used to stop at the first step ("no equilibrium found" from the last step's pose): it
/// now starts each step from the trimmed datum, as the sensitivity cases do. Each step's
/// eigenvalues equal the model built afresh at that l2 and trimmed (a second path:
/// file → system → trim → modes), to 1e-9.
#[test]
fn inceptor_tracks_over_the_push_rod_length() {
    let sys = inceptor(&[]);
    let values = [0.12, 0.12375, 0.13, 0.14, 0.15];
    let t = track_modes(&sys, "l2", &values, &TrackOptions::default()).unwrap();
    assert_eq!(t.labels, ["in-phase", "shaft-twist"]);
    for s in t.steps.iter().filter(|s| s.requested) {
        let fresh = inceptor(&[("l2", &s.value.to_string())]);
        let want = modal_analysis(&fresh, None).unwrap();
        for (l, w) in want.modes.iter().enumerate() {
            let e = s.modes[l].as_ref().unwrap().eigenvalue;
            let (got, w) = (
                Complex::new(e.re, e.im),
                Complex::new(w.eigenvalue.re, w.eigenvalue.im),
            );
            assert!(
                (got - w).norm() < 1e-9 * w.norm(),
                "{} at l2 = {}: λ = {got} vs {w}",
                t.labels[l],
                s.value
            );
        }
    }
    assert_eq!(t.steps.iter().filter(|s| s.requested).count(), values.len());
}
