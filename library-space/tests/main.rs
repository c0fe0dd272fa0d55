//! Every file of tests/ is a module of this one test binary (linked once, not once per file):
//! `cargo test -p robosim-library --test library` runs them all,
//! `cargo test -p robosim-library --test library FILE::` the tests of tests/FILE.rs.
//! A new file of tests/ needs its `mod` line here (Cargo.toml: `autotests = false`).

mod api;
mod builtin_tables;
mod checked;
mod errors;
mod expressions;
mod from_mjcf;
mod from_urdf;
mod fuzz_corpus;
mod hostile_urdf;
mod limits;
mod mimic_coupling;
mod props;
mod robot_model;
mod stdlib;
