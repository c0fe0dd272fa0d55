//! Every file of tests/ is a module of this one test binary (linked once, not once per file):
//! `cargo test -p robosim-editor --test editor` runs them all,
//! `cargo test -p robosim-editor --test editor FILE::` the tests of tests/FILE.rs.
//! A new file of tests/ needs its `mod` line here (Cargo.toml: `autotests = false`).

mod editor;
mod error_chains;
mod fuzz_corpus;
mod hostile_inputs;
mod lang;
