//! Model text → compiled system → assembled initial pose (`detune::fuzz_harness::loader`).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| detune::fuzz_harness::loader(data));
