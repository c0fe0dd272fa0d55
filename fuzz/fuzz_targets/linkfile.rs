#![no_main]
//! `cargo +nightly fuzz run linkfile`: see `fuzz/src/linkfile.rs` and `docs/fuzzing.md`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| robosim_fuzz::linkfile::run(data));
