#![no_main]
//! `cargo +nightly fuzz run protocol`: see `fuzz/src/protocol.rs` and `docs/fuzzing.md`.
libfuzzer_sys::fuzz_target!(|data: &[u8]| robosim_fuzz::protocol::run(data));
