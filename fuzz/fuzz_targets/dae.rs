#![no_main]
//! `cargo +nightly fuzz run dae`: see `fuzz/src/dae.rs` and `docs/fuzzing.md`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| robosim_fuzz::dae::run(data));
