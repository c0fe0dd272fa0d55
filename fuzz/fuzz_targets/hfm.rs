#![no_main]
//! `cargo +nightly fuzz run hfm`: see `fuzz/src/hfm.rs` and `docs/fuzzing.md`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| robosim_fuzz::hfm::run(data));
