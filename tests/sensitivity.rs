//! Sensitivity of the modes: analytic eigenvalue derivatives against central finite
//! differences of the same quantities (re-solved equilibrium, trim and modes).

mod common;

use detune::System;
use detune::linear::sensitivity::{mode_derivatives, modes_at};

/// A fourth-order central difference of every mode's (ω_n, ζ, undamped ω) in `param`.
fn fd(sys: &System, param: usize, h: f64) -> Vec<(f64, f64, f64)> {
    let p0 = sys.param(param);
    let at = |k: f64| {
        let (_, ma) = modes_at(sys, &[(param, p0 + k * h)], None).unwrap();
        let w2 = ma.undamped_omega2.clone();
        ma.modes
            .iter()
            .enumerate()
            .map(|(i, m)| (m.omega_n_rad_s, m.damping_ratio, w2.get(i).map_or(0.0, |x| x.sqrt())))
            .collect::<Vec<_>>()
    };
    let (m2, m1, p1, p2) = (at(-2.0), at(-1.0), at(1.0), at(2.0));
    let d = |a: f64, b: f64, c: f64, e: f64| (a - 8.0 * b + 8.0 * c - e) / (12.0 * h);
    (0..m1.len())
        .map(|i| {
            (
                d(m2[i].0, m1[i].0, p1[i].0, p2[i].0),
                d(m2[i].1, m1[i].1, p1[i].1, p2[i].1),
                d(m2[i].2, m1[i].2, p1[i].2, p2[i].2),
            )
        })
        .collect()
}

fn check(sys: &System, name: &str, rel_h: f64, shift: bool) -> Vec<(f64, f64)> {
    let i = sys.param_index(name).unwrap();
    let (s, ma) = modes_at(sys, &[], None).unwrap();
    let an = mode_derivatives(&s, &ma, i, shift).unwrap();
    let h = rel_h * s.param(i).abs().max(1e-3);
    let f = fd(&s, i, h);
    let mut out = Vec::new();
    for (a, b) in an.iter().zip(&f) {
        eprintln!(
            "{name}: dωn {:.12e} fd {:.12e} | dζ {:.12e} fd {:.12e} | dω0 {:?} fd {:.12e}",
            a.domega_n, b.0, a.dzeta, b.1, a.dundamped, b.2
        );
        out.push((a.domega_n, b.0));
    }
    out
}

#[test]
fn overcentre_derivatives_equal_finite_differences() {
    let model = common::overcentre(&[("Fs", "-3"), ("c", "2")]);
    let sys = System::new(&model).unwrap();
    for p in ["k", "c", "m1", "L0", "Fs", "g", "L1"] {
        check(&sys, p, 1e-3, true);
        check(&sys, p, 1e-4, true);
    }
}

#[test]
fn inceptor_derivatives_equal_finite_differences() {
    let model = detune::Model::load(&format!("{}/models/inceptor.toml", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let sys = System::new(&model).unwrap();
    let (sys, _) = detune::statics::trim::trim(&sys).unwrap();
    for p in ["k_fs", "gearbox_scale", "k_t", "c_d", "m1"] {
        check(&sys, p, 1e-3, true);
        check(&sys, p, 1e-4, true);
    }
}

#[test]
fn debug_matrix_derivatives() {
    use detune::linear::sensitivity::{equilibrium_shift, matrix_derivatives};
    use detune::statics::Statics;
    let model = common::overcentre(&[("Fs", "-3"), ("c", "2")]);
    let sys = System::new(&model).unwrap();
    let (s, ma) = modes_at(&sys, &[], None).unwrap();
    for name in ["L0", "Fs", "L1"] {
        let i = s.param_index(name).unwrap();
        let eq = &ma.equilibrium;
        let d = equilibrium_shift(&s, eq, &ma.rows, i, true).unwrap();
        let st = Statics::with_rows(&s, ma.rows.clone()).unwrap();
        let dm = matrix_derivatives(&st, &eq.q, &eq.lambda, &d);
        let h = 1e-6;
        let at = |k: f64| {
            let mut s2 = s.clone();
            for &(p, c) in &d.dparams { s2.set_param(p, s.param(p) + k * h * c).unwrap(); }
            let q: Vec<f64> = eq.q.iter().zip(&d.dq).map(|(a, b)| a + k * h * b).collect();
            let l: Vec<f64> = eq.lambda.iter().zip(&d.dlambda).map(|(a, b)| a + k * h * b).collect();
            let st2 = Statics::with_rows(&s2, ma.rows.clone()).unwrap();
            let mut x = q.clone(); x.extend(&l);
            (st2.stiffness(&q, &l), st2.jacobian_rows(&q), st2.residual(&x))
        };
        let (kp, ap, rp) = at(1.0);
        let (km, am, rm) = at(-1.0);
        let fdk = (kp - km) / (2.0 * h);
        let fda = (ap - am) / (2.0 * h);
        eprintln!("{name}: dK err {:e} (|dK| {:e}), dA err {:e}, dR along d {:e}", (&fdk - &dm.stiffness).amax(), fdk.amax(), (&fda - &dm.jacobian_rows).amax(), ((rp - rm) / (2.0 * h)).amax());
        eprintln!("dq {:?} dl {:?} dp {:?}", d.dq, d.dlambda, d.dparams);
    }
}

#[test]
fn debug_inceptor_c() {
    use detune::linear::sensitivity::{equilibrium_shift, matrix_derivatives};
    use detune::statics::Statics;
    let model = detune::Model::load(&format!("{}/models/inceptor.toml", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let sys = System::new(&model).unwrap();
    let (s, ma) = modes_at(&sys, &[], None).unwrap();
    for name in ["c_d", "k_fs"] {
        let i = s.param_index(name).unwrap();
        let eq = &ma.equilibrium;
        let d = equilibrium_shift(&s, eq, &ma.rows, i, true).unwrap();
        let st = Statics::with_rows(&s, ma.rows.clone()).unwrap();
        let dm = matrix_derivatives(&st, &eq.q, &eq.lambda, &d);
        let h = 1e-6 * s.param(i);
        let at = |k: f64| {
            let mut s2 = s.clone();
            for &(p, c) in &d.dparams { s2.set_param(p, s.param(p) + k * h * c).unwrap(); }
            let q: Vec<f64> = eq.q.iter().zip(&d.dq).map(|(a, b)| a + k * h * b).collect();
            let l: Vec<f64> = eq.lambda.iter().zip(&d.dlambda).map(|(a, b)| a + k * h * b).collect();
            let st2 = Statics::with_rows(&s2, ma.rows.clone()).unwrap();
            let e2 = detune::statics::Equilibrium { q: q.clone(), lambda: l.clone(), ..eq.clone() };
            let lin = detune::linear::Linearization::new(&st2, &e2);
            (lin.full_damping, lin.full_mass, lin.full_stiffness)
        };
        let (cp, mp, kp) = at(1.0);
        let (cm, mm, km) = at(-1.0);
        let fdc = (cp - cm) / (2.0 * h);
        let fdm = (mp - mm) / (2.0 * h);
        let fdk = (kp - km) / (2.0 * h);
        eprintln!("{name}: dC err {:e} (|dC| {:e}) dM err {:e} |dM| {:e} dK err {:e} |dK| {:e}", (&fdc - &dm.damping).amax(), fdc.amax(), (&fdm - &dm.mass).amax(), fdm.amax(), (&fdk - &dm.stiffness).amax(), fdk.amax());
    }
}

#[test]
fn debug_pencil() {
    use nalgebra::{Complex, DMatrix};
    let model = detune::Model::load(&format!("{}/models/inceptor.toml", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let sys = System::new(&model).unwrap();
    let (_s, ma) = modes_at(&sys, &[], None).unwrap();
    let lin = &ma.linearization;
    let k = lin.dof();
    let eigs = |c: &DMatrix<f64>| {
        let minv = lin.mass.clone().try_inverse().unwrap();
        let mut s = DMatrix::zeros(2 * k, 2 * k);
        s.view_mut((0, k), (k, k)).copy_from(&DMatrix::identity(k, k));
        s.view_mut((k, 0), (k, k)).copy_from(&(-&minv * &lin.stiffness));
        s.view_mut((k, k), (k, k)).copy_from(&(-&minv * c));
        let mut e: Vec<Complex<f64>> = s.complex_eigenvalues().iter().copied().filter(|z| z.im > 0.0).collect();
        e.sort_by(|a, b| a.norm().total_cmp(&b.norm()));
        e
    };
    // perturb C_r in the direction of N^T dC N for c_d: a unit damper on gearbox
    let i = _s.param_index("c_d").unwrap();
    let h = 1e-6;
    let mut s2 = _s.clone();
    s2.set_param(i, _s.param(i) + h).unwrap();
    let st2 = detune::statics::Statics::with_rows(&s2, ma.rows.clone()).unwrap();
    let lin2 = detune::linear::Linearization::new(&st2, &ma.equilibrium);
    let dcr = (&lin2.damping - &lin.damping) / h;
    let e0 = eigs(&lin.damping);
    let e1 = eigs(&(&lin.damping + &dcr * h));
    for (a, b) in e0.iter().zip(&e1) { eprintln!("fd dλ {:?}", (b - a) / h); }
    let an = detune::linear::sensitivity::mode_derivatives(&_s, &ma, i, true).unwrap();
    for a in &an { eprintln!("an dλ {:?}", a.dlambda); }
    eprintln!("basis same? {:e}", (&lin2.basis - &lin.basis).amax());
    for m in &ma.modes { eprintln!("mode λ {:?}", m.eigenvalue); }
}
