//! Nonlinear frequency response by continuation of periodic orbits.

use detune::periodic::continuation::{NfrOptions, nfr};
use std::sync::atomic::AtomicBool;

fn model(sets: &[(&str, f64)]) -> detune::System {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/overcentre.toml");
    let model = detune::Model::load(path).unwrap();
    let sets: Vec<(String, String)> = sets
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let model = model.with_overrides(&sets).unwrap();
    detune::System::new(&model).unwrap()
}

#[test]
#[ignore]
fn explore() {
    let sys = model(&[("theta1_0", -0.85), ("c", 1.0), ("F0", 4.0)]);
    let mut opts = NfrOptions::new("omega", 1.5, 5.0, vec!["bar1.theta".into()]);
    opts.max_points = std::env::var("MAXP")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(3000);
    let t = std::time::Instant::now();
    let c = nfr(&sys, &opts, &|_n, _v| {}, &AtomicBool::new(false)).unwrap();
    eprintln!(
        "{:?} points {} periods {} rhs {}",
        t.elapsed(),
        c.points.len(),
        c.periods,
        c.rhs_evaluations
    );
    for p in &c.points {
        eprintln!(
            "{} {:.6} {:.6} {} {:?} {:?}",
            p.branch,
            p.omega,
            p.measures[0].amplitude,
            p.stable,
            p.located,
            p.multipliers
                .iter()
                .map(|m| (m.re, m.im))
                .collect::<Vec<_>>()
        );
    }
    for f in c
        .folds
        .iter()
        .chain(&c.period_doublings)
        .chain(&c.neimark_sacker)
    {
        eprintln!("{:?} {:.9} {:?}", f.kind, f.omega, f.amplitude);
    }
    for b in &c.branches {
        eprintln!("{b:?}");
    }
    for p in &c.peaks {
        eprintln!("peak {:.9} {:.6}", p.omega, p.amplitude);
    }
}
