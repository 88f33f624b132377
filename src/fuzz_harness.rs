//! The fuzzing harness: what the cargo-fuzz targets in `fuzz/` run on each input, and what
//! the stable test suite replays on the committed corpus (`tests/fuzz_corpus.rs`), so a
//! regression fails CI without nightly. See docs/reliability.md.
//!
//! An input is a model file's text. [`loader`] reads and compiles it and assembles its
//! initial pose; [`analyses`] goes on to the `[trim]`, the equilibrium and its modes, and a
//! short simulation with a step budget (so no input can run long). Errors are the expected
//! outcome for most inputs; the harness panics only where detune would lie: a result
//! returned as a success that holds a non-finite number.

use crate::dynamics::simulate::{SimOptions, simulate};
use crate::model::Model;
use crate::system::System;

/// Inputs longer than this are skipped (the loader refuses files of 16 MiB and more; the
/// fuzzer's time is better spent on short inputs).
pub const MAX_INPUT: usize = 64 * 1024;

/// Read, compile and assemble a model from `data`.
pub fn loader(data: &[u8]) {
    let _ = compile(data);
}

/// How far [`analyses`] got with an input.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Reached {
    pub compiled: bool,
    pub modes: bool,
    pub simulated: bool,
}

/// [`loader`], then the trim, the equilibrium and modes, and 0.05 s of simulation in at
/// most 2000 steps.
pub fn analyses(data: &[u8]) -> Reached {
    let mut reached = Reached::default();
    let Some(sys) = compile(data) else {
        return reached;
    };
    reached.compiled = true;
    let Ok((sys, _)) = crate::statics::trim::trim(&sys) else {
        return reached;
    };
    if let Ok(m) = crate::linear::modal_analysis(&sys, None) {
        reached.modes = true;
        for q in &m.equilibrium.q {
            assert!(
                q.is_finite(),
                "an equilibrium returned with a non-finite coordinate"
            );
        }
        for mode in &m.modes {
            assert!(
                mode.omega_n_rad_s.is_finite() && mode.damping_ratio.is_finite(),
                "a mode returned with a non-finite frequency or damping: {mode:?}"
            );
        }
    }
    let Ok(start) = crate::dynamics::assemble(&sys) else {
        return reached;
    };
    let opts = SimOptions {
        t_end: 0.05,
        dt_out: 0.01,
        max_steps: 2000,
        ..SimOptions::default()
    };
    if let Ok(tr) = simulate(&sys, &start, &opts, &mut |_| true) {
        for q in tr.qs().chain(tr.vs()) {
            assert!(
                q.iter().all(|x| x.is_finite()),
                "a simulation returned with a non-finite sample"
            );
        }
        reached.simulated = true;
    }
    reached
}

fn compile(data: &[u8]) -> Option<System> {
    if data.len() > MAX_INPUT {
        return None;
    }
    let text = std::str::from_utf8(data).ok()?;
    let model = Model::from_str("fuzz.toml", text).ok()?;
    let sys = System::new(&model).ok()?;
    let _ = crate::dynamics::assemble(&sys);
    Some(sys)
}
