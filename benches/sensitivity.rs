//! Sensitivity, margins and tuning on the candidate inceptor (`models/inceptor.toml`):
//!
//! * `sensitivity_table`: the paper's Tables 2–3 with analytic derivatives for 2
//!   parameters (k_fs ±10 %, gearbox_scale ±5 %): the baseline, the 4 cases, the
//!   derivatives, their 8 finite-difference re-solves and the 4 corners of the box, on
//!   2 threads: `detune sensitivity models/inceptor.toml --vary k_fs=±10%
//!   --vary gearbox_scale=±5%` in-process;
//! * `derivatives_one_parameter`: the analytic derivatives of both modes with respect to
//!   one parameter at a solved baseline (equilibrium shift, matrix derivatives by AD,
//!   eigenvector formula);
//! * `modes_one_case`: one case's modes (trim, equilibrium from the baseline's, modes):
//!   the unit of the paper's method, which re-ran a stepped-sine sweep (0.77 s) instead;
//! * `tune_uh60`: `detune tune models/inceptor.toml --environment UH-60
//!   --vary k_fs=50%..200% --vary gearbox_scale=80%..120%` in-process.
//!
//! Figures in docs/performance.md. Run: `cargo bench --bench sensitivity`.

use detune::linear::modal_analysis;
use detune::linear::sensitivity::{Vary, mode_derivatives, modes_at, sensitivity};
use detune::{Model, System};

fn main() {
    divan::main();
}

fn inceptor() -> System {
    let path = format!("{}/models/inceptor.toml", env!("CARGO_MANIFEST_DIR"));
    let sys = System::new(&Model::load(&path).unwrap()).unwrap();
    detune::statics::trim::trim(&sys).unwrap().0
}

fn vary(sys: &System, name: &str, lo: f64, hi: f64) -> Vary {
    let i = sys.param_index(name).unwrap();
    let p = sys.param(i);
    Vary {
        param: i,
        name: name.into(),
        cases: vec![("+".into(), p * hi), ("-".into(), p * lo)],
        range: (p * lo, p * hi),
    }
}

#[divan::bench(sample_count = 50)]
fn sensitivity_table(bencher: divan::Bencher) {
    let sys = inceptor();
    let v = [
        vary(&sys, "k_fs", 0.9, 1.1),
        vary(&sys, "gearbox_scale", 0.95, 1.05),
    ];
    bencher.bench_local(|| sensitivity(&sys, &v, None, None).unwrap().modes.len());
}

#[divan::bench(sample_count = 100)]
fn derivatives_one_parameter(bencher: divan::Bencher) {
    let sys = inceptor();
    let ma = modal_analysis(&sys, None).unwrap();
    let i = sys.param_index("k_fs").unwrap();
    bencher.bench_local(|| mode_derivatives(&sys, &ma, i, true).unwrap()[1].domega_n);
}

#[divan::bench(sample_count = 100)]
fn modes_one_case(bencher: divan::Bencher) {
    let sys = inceptor();
    let ma = modal_analysis(&sys, None).unwrap();
    let i = sys.param_index("k_fs").unwrap();
    let v = sys.param(i) * 1.1;
    bencher.bench_local(|| {
        modes_at(&sys, &[(i, v)], None, Some(&ma))
            .unwrap()
            .1
            .modes
            .len()
    });
}

#[divan::bench(sample_count = 10)]
fn tune_uh60(bencher: divan::Bencher) {
    let sys = inceptor();
    let v = [
        vary(&sys, "k_fs", 0.5, 2.0),
        vary(&sys, "gearbox_scale", 0.8, 1.2),
    ];
    let env = detune::environment::resolve("UH-60").unwrap();
    let lines = env.forcing_lines();
    bencher.bench_local(|| {
        detune::tune::tune(&sys, &v, &lines, &detune::tune::TuneOptions::default())
            .unwrap()
            .designs
            .len()
    });
}

/// The toleranced tuning of docs/sensitivity-and-tuning.md: ranges k_fs 60–150 %,
/// gearbox_scale 55–145 %, tolerances ±10 % / ±5 % (each design checked over its box).
#[divan::bench(sample_count = 5)]
fn tune_uh60_toleranced(bencher: divan::Bencher) {
    let sys = inceptor();
    let v = [
        vary(&sys, "k_fs", 0.6, 1.5),
        vary(&sys, "gearbox_scale", 0.55, 1.45),
    ];
    let tolerances = vec![
        detune::tune::Tolerance {
            vary: vary(&sys, "k_fs", 0.9, 1.1),
            relative: true,
        },
        detune::tune::Tolerance {
            vary: vary(&sys, "gearbox_scale", 0.95, 1.05),
            relative: true,
        },
    ];
    let env = detune::environment::resolve("UH-60").unwrap();
    let lines = env.forcing_lines();
    let opts = detune::tune::TuneOptions {
        tolerances,
        ..Default::default()
    };
    bencher.bench_local(|| {
        detune::tune::tune(&sys, &v, &lines, &opts)
            .unwrap()
            .designs
            .len()
    });
}
