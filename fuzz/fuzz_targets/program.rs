#![no_main]
//! `cargo +nightly fuzz run program`: see `fuzz/src/program.rs` and `docs/fuzzing.md`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| robosim_fuzz::program::run(data));
