//! Issue 12, Speed (the short case): the overcentre's lower-well curve at F0 = 4 N, c = 1,
//! over 3.9–4.1 rad/s (its fold at 4.0241 rad/s located) by continuation, and the stepped
//! sine over the same range (`--mode both`, 0.1 rad/s grid, `--refine 1e-4`). The full
//! 2.5–5 rad/s comparison (with the jumps bisected to 1e-4 rad/s) is the ignored test
//! `tests/nfr_speed.rs`; both in docs/performance.md. Run: `cargo bench --bench nfr`.

use detune::System;
use detune::frequency::{SteadyOptions, Sweep, SweepMode, SweepOptions, sweep};
use detune::periodic::continuation::{Nfr, NfrOptions, nfr};
use std::sync::atomic::AtomicBool;

fn main() {
    divan::main();
}

fn system() -> System {
    let path = format!("{}/models/overcentre.toml", env!("CARGO_MANIFEST_DIR"));
    let sets: Vec<(String, String)> = [("theta1_0", "-0.85"), ("c", "1"), ("F0", "4")]
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    System::new(
        &detune::Model::load(&path)
            .unwrap()
            .with_overrides(&sets)
            .unwrap(),
    )
    .unwrap()
}

#[divan::bench(sample_count = 3, sample_size = 1)]
fn nfr_overcentre_fold(b: divan::Bencher) {
    let sys = system();
    let opts = NfrOptions::new("omega", 3.9, 4.1, vec!["bar1.theta".into()]);
    b.bench(|| -> Nfr {
        let c = nfr(&sys, &opts, &|_, _| {}, &AtomicBool::new(false)).unwrap();
        assert_eq!(c.folds.len(), 1);
        c
    });
}

#[divan::bench(sample_count = 3, sample_size = 1)]
fn sweep_both_overcentre_fold(b: divan::Bencher) {
    let sys = system();
    let opts = SweepOptions {
        param: "omega".into(),
        values: detune::linear::grid(3.9, 4.1, 0.1).unwrap(),
        mode: SweepMode::Both,
        responses: vec!["bar1.theta".into()],
        refine: Some(1e-4),
        steady: SteadyOptions::default(),
    };
    b.bench(|| -> Sweep { sweep(&sys, &opts, &|_| {}, &AtomicBool::new(false)).unwrap() });
}
