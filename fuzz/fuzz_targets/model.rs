#![no_main]
//! `cargo +nightly fuzz run model`: see `fuzz/src/model.rs` and `docs/fuzzing.md`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| robosim_fuzz::model::run(data));
