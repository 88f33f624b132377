//! The loader, then trim, equilibrium, modes and a short simulation
//! (`detune::fuzz_harness::analyses`).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    detune::fuzz_harness::analyses(data);
});
