#![no_main]
//! `cargo +nightly fuzz run edit`: see `fuzz/src/edit.rs` and `docs/fuzzing.md`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| robosim_fuzz::edit::run(data));
