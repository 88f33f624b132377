//! The overcentre's stepped-sine sweep (lower well, c = 1 N·s/m, F0 = 1 N): 0.5–8 rad/s
//! at 0.1 rad/s, independent mode, resonances refined to 1e-3 rad/s; on 1 and 2 threads;
//! and the paper's protocol (a fixed 100 periods per frequency, same grid, no refinement)
//! run by the same code. Figures in docs/performance.md. Run: `cargo bench --bench sweep`.

use detune::Model;
use detune::System;
use detune::frequency::{SteadyOptions, Sweep, SweepMode, SweepOptions, sweep};
use std::sync::atomic::AtomicBool;

fn main() {
    divan::main();
}

fn model() -> Model {
    let path = format!("{}/models/overcentre.toml", env!("CARGO_MANIFEST_DIR"));
    let sets = [("theta1_0", "-0.85"), ("c", "1"), ("F0", "1")];
    let sets: Vec<(String, String)> = sets
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    Model::load(&path).unwrap().with_overrides(&sets).unwrap()
}

fn options(fixed: Option<usize>, refine: Option<f64>) -> SweepOptions {
    SweepOptions {
        param: "omega".into(),
        values: detune::linear::grid(0.5, 8.0, 0.1).unwrap(),
        mode: SweepMode::Independent,
        responses: vec!["bar1.theta".into()],
        refine,
        steady: SteadyOptions {
            fixed_periods: fixed,
            ..SteadyOptions::default()
        },
    }
}

fn run(threads: usize, opts: &SweepOptions) -> Sweep {
    let m = model();
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| {
            sweep(
                &System::new(&m).unwrap(),
                opts,
                &|_| {},
                &AtomicBool::new(false),
            )
            .unwrap()
        })
}

#[divan::bench(sample_count = 5)]
fn detected_refined_1_thread() -> Sweep {
    run(1, &options(None, Some(1e-3)))
}

#[divan::bench(sample_count = 5)]
fn detected_refined_2_threads() -> Sweep {
    run(2, &options(None, Some(1e-3)))
}

#[divan::bench(sample_count = 3)]
fn paper_protocol_100_periods_2_threads() -> Sweep {
    run(2, &options(Some(100), None))
}

#[divan::bench(sample_count = 5)]
fn detected_coarse_only_1_thread() -> Sweep {
    run(1, &options(None, None))
}

#[divan::bench(sample_count = 5)]
fn detected_coarse_only_2_threads() -> Sweep {
    run(2, &options(None, None))
}
