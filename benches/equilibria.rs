//! Every equilibrium (`detune equilibrium --all`, [`Statics::all`]), issues 8 and 10: what
//! `simulate` and `sweep` run once to classify their wells.
//!
//! * `inceptor_all`: `models/inceptor.toml` (trimmed), two degrees of freedom searched
//!   from the start and 256 Halton seeds over (stick.phi, gearbox.theta): one equilibrium;
//! * `overcentre_all`: `models/overcentre.toml`, one driving angle swept along its
//!   assembly branch: three equilibria.
//!
//! Figures in docs/performance.md. Run: `cargo bench --bench equilibria`.

use detune::statics::Statics;
use detune::{Model, System};

fn main() {
    divan::main();
}

fn system(file: &str) -> System {
    let path = format!("{}/models/{file}", env!("CARGO_MANIFEST_DIR"));
    let model = Model::load(&path).unwrap();
    detune::statics::trim::trim(&System::new(&model).unwrap())
        .unwrap()
        .0
}

/// The number of equilibria found from the model's rest pose.
fn all(sys: &System) -> usize {
    let start = detune::dynamics::assemble_at_rest(sys).unwrap();
    let st = Statics::new(sys, &start.q).unwrap();
    st.all(&start).unwrap().len()
}

#[divan::bench(sample_count = 10)]
fn inceptor_all(bencher: divan::Bencher) {
    let sys = system("inceptor.toml");
    bencher.bench_local(|| all(&sys));
}

#[divan::bench(sample_count = 50)]
fn overcentre_all(bencher: divan::Bencher) {
    let sys = system("overcentre.toml");
    bencher.bench_local(|| all(&sys));
}
