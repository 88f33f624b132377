//! The candidate inceptor (`models/inceptor.toml`: 4 spatial bodies, 17 coordinates, 15
//! constraint rows) under 7 mm fore-aft base motion:
//!
//! * `rhs`: one right-hand side of the Udwadia–Kalaba equation at the datum with
//!   non-zero velocities (forces, velocity forces from T, A by blocks, b, M⁻¹ by blocks,
//!   the sparse solve);
//! * `simulate_1s`: 1 s of base-excited motion at ω = 26.7 rad/s (defaults: rtol 1e-10);
//! * `sweep_2_threads`: the stepped-sine sweep of SPEC §10.3's grid, 5–40 rad/s in
//!   0.5 rad/s steps with refinement to 0.1 rad/s around the peaks, detune's own
//!   steady-state detection, on 2 threads: the command
//!   `RAYON_NUM_THREADS=2 detune sweep models/inceptor.toml --param omega --from 5 --to 40
//!   --step 0.5 --refine 0.1 --response stick.phi --set D0=0.007`;
//! * `report_uh60`: the design-review report with the UH-60 environment (`detune report`
//!   without the file writes).
//!
//! Figures in docs/performance.md. Run: `cargo bench --bench inceptor`.

use detune::dynamics::{DynWorkspace, accelerations};
use detune::frequency::{SteadyOptions, Sweep, SweepMode, SweepOptions, sweep};
use detune::{Model, SimOptions, State, System, assemble, simulate};
use std::sync::atomic::AtomicBool;

fn main() {
    divan::main();
}

fn inceptor(sets: &[(&str, &str)]) -> System {
    let path = format!("{}/models/inceptor.toml", env!("CARGO_MANIFEST_DIR"));
    let sets: Vec<(String, String)> = sets
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    let model = Model::load(&path).unwrap().with_overrides(&sets).unwrap();
    let sys = System::new(&model).unwrap();
    detune::statics::trim::trim(&sys).unwrap().0
}

#[divan::bench(sample_count = 200)]
fn rhs(bencher: divan::Bencher) {
    let sys = inceptor(&[("D0", "0.007"), ("omega", "26.7")]);
    let s = assemble(&sys).unwrap();
    // a consistent state with motion: the velocities of a small stick rate
    let mut ws = DynWorkspace::new(&sys);
    let mut v = s.v.clone();
    let phi = sys.coordinate_index("stick.phi").unwrap();
    v[phi] = 0.3;
    detune::dynamics::project_velocity(&sys, &mut ws, &s.q, &mut v, 0.1);
    let mut vdot = vec![0.0; sys.nv()];
    bencher.bench_local(|| {
        accelerations(&sys, &mut ws, &s.q, &v, 0.1, &mut vdot);
        vdot[phi]
    });
}

#[divan::bench(sample_count = 30)]
fn simulate_1s(bencher: divan::Bencher) {
    let sys = inceptor(&[("D0", "0.007"), ("omega", "26.7")]);
    let start: State = assemble(&sys).unwrap();
    let opts = SimOptions {
        t_end: 1.0,
        dt_out: 0.001,
        ..SimOptions::default()
    };
    bencher.bench_local(|| simulate(&sys, &start, &opts, &mut |_| true).unwrap());
}

#[divan::bench(sample_count = 3)]
fn sweep_2_threads() -> Sweep {
    let sys = inceptor(&[("D0", "0.007")]);
    let opts = SweepOptions {
        param: "omega".into(),
        values: detune::linear::grid(5.0, 40.0, 0.5).unwrap(),
        mode: SweepMode::Independent,
        responses: vec!["stick.phi".into()],
        refine: Some(0.1),
        steady: SteadyOptions::default(),
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
        .install(|| sweep(&sys, &opts, &|_| {}, &AtomicBool::new(false)).unwrap())
}

/// `detune report models/inceptor.toml --environment UH-60` without the file writes: the
/// modes with their names, the 400-point linear response with its peaks refined, the
/// figures, the sensitivity section (each design parameter ±10 %, its cases, analytic
/// derivatives and their finite-difference checks, the tolerance box) and the margins
/// section, the page and its sidecar: the whole report the command makes (no sweep).
#[divan::bench(sample_count = 20)]
fn report_uh60() -> usize {
    let path = format!("{}/models/inceptor.toml", env!("CARGO_MANIFEST_DIR"));
    let model = Model::load(&path).unwrap();
    let sys = detune::statics::trim::trim(&System::new(&model).unwrap())
        .unwrap()
        .0;
    let full_env = detune::environment::resolve("UH-60").unwrap();
    let env = detune::report::environment::from_environment(&full_env);
    let extras = detune::report::build::ModeExtras::of(&sys);
    let mut report = detune::report::build(&detune::report::ReportInputs {
        model: &model,
        sys: &sys,
        environment: Some(&env),
        mode_extras: extras.as_ref(),
        generated_utc: "2026-11-23T00:00:00Z".into(),
        freq_unit: Default::default(),
    })
    .unwrap();
    let (varies, dropped) = detune::report::studies::default_varies(&sys, None);
    let unit = |name: &str| -> String { model.param_unit(name) };
    detune::report::studies::add_studies(
        &mut report,
        &detune::report::studies::Studies {
            sys: &sys,
            varies: &varies,
            given: false,
            dropped: &dropped,
            environment: Some(&full_env),
            margin: 0.1,
            tune: false,
            tune_varies: &[],
            units: &unit,
            vary_texts: &[],
            command_words: &|_: &[&str]| String::from("models/inceptor.toml"),
        },
    )
    .unwrap();
    report.document.html().len() + report.sidecar.to_json().len()
}
