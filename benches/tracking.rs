//! Modes that keep their names on the inceptor (`models/inceptor.toml`):
//!
//! * `describe_modes`: the names (MAC against the `[[modes]]` shapes) and the energy
//!   shares (each force element's stiffness by dual numbers, the reactions' by hyper-dual
//!   passes) of the modes at the baseline, given the modal analysis;
//! * `track_k_t`: the modes tracked over k_t = 200 … 3000 N·m/rad in steps of 100 (29
//!   values, each with the trim re-solved, the equilibrium continued, the linearization
//!   and the modes): the command
//!   `detune modes models/inceptor.toml --param k_t --from 200 --to 3000 --step 100`.
//!
//! Figures in docs/performance.md. Run: `cargo bench --bench tracking`.

use detune::linear::modal_analysis;
use detune::linear::tracking::{TrackOptions, describe_modes, track_modes};
use detune::{Model, System};

fn main() {
    divan::main();
}

fn inceptor() -> System {
    let path = format!("{}/models/inceptor.toml", env!("CARGO_MANIFEST_DIR"));
    let sys = System::new(&Model::load(&path).unwrap()).unwrap();
    detune::statics::trim::trim(&sys).unwrap().0
}

#[divan::bench(sample_count = 100)]
fn describe(bencher: divan::Bencher) {
    let sys = inceptor();
    let modal = modal_analysis(&sys, None).unwrap();
    bencher.bench_local(|| describe_modes(&sys, &modal).unwrap().len());
}

#[divan::bench(sample_count = 30)]
fn track_k_t(bencher: divan::Bencher) {
    let sys = inceptor();
    let values: Vec<f64> = (0..=28).map(|k| 200.0 + 100.0 * k as f64).collect();
    bencher.bench_local(|| {
        track_modes(&sys, "k_t", &values, &TrackOptions::default())
            .unwrap()
            .steps
            .len()
    });
}
