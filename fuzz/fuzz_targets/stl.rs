#![no_main]
//! `cargo +nightly fuzz run stl`: see `fuzz/src/stl.rs` and `docs/fuzzing.md`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| robosim_fuzz::stl::run(data));
