#![no_main]
//! `cargo +nightly fuzz run library`: see `fuzz/src/library.rs` and `docs/fuzzing.md`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| robosim_fuzz::library::run(data));
