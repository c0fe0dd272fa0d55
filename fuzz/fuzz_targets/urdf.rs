#![no_main]
//! `cargo +nightly fuzz run urdf`: see `fuzz/src/urdf.rs` and `docs/fuzzing.md`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| robosim_fuzz::urdf::run(data));
