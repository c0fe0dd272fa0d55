#![no_main]
//! `cargo +nightly fuzz run trajectory`: see `fuzz/src/trajectory.rs` and `docs/fuzzing.md`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| robosim_fuzz::trajectory::run(data));
