//! Every file of tests/ is a module of this one test binary (linked once, not once per file):
//! `cargo test -p robosim-automation --test automation` runs them all,
//! `cargo test -p robosim-automation --test automation FILE::` the tests of tests/FILE.rs.
//! A new file of tests/ needs its `mod` line here (Cargo.toml: `autotests = false`).

mod dataflow;
mod diag;
mod fuzz_corpus;
mod hostile_inputs;
mod kernel;
mod kernel_props;
mod model;
mod reference;
