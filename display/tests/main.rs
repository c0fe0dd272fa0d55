//! Every file of tests/ is a module of this one test binary (linked once, not once per file):
//! `cargo test -p robosim-display --test display` runs them all,
//! `cargo test -p robosim-display --test display FILE::` the tests of tests/FILE.rs.
//! A new file of tests/ needs its `mod` line here (Cargo.toml: `autotests = false`).

mod arena;
mod fuzz_corpus;
mod render;
