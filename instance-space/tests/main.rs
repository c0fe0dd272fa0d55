//! Every file of tests/ is a module of this one test binary (linked once, not once per file):
//! `cargo test -p robosim-instance-space --test instance_space` runs them all,
//! `cargo test -p robosim-instance-space --test instance_space FILE::` the tests of tests/FILE.rs.
//! A new file of tests/ needs its `mod` line here (Cargo.toml: `autotests = false`).

mod fuzz_corpus;
mod journal;
mod preconditions;
mod readers;
mod transactions;
