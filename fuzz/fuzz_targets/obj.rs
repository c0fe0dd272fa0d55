#![no_main]
//! `cargo +nightly fuzz run obj`: see `fuzz/src/obj.rs` and `docs/fuzzing.md`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| robosim_fuzz::obj::run(data));
