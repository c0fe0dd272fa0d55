#![no_main]
//! `cargo +nightly fuzz run journal`: see `fuzz/src/journal.rs` and `docs/fuzzing.md`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| robosim_fuzz::journal::run(data));
