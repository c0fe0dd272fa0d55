//! Every file of tests/ is a module of this one test binary (linked once, not once per file):
//! `cargo test -p robosim --test robosim` runs them all,
//! `cargo test -p robosim --test robosim FILE::` the tests of tests/FILE.rs.
//! A new file of tests/ needs its `mod` line here (Cargo.toml: `autotests = false`).

mod common;

mod architecture;
mod bridge;
mod cli_edges;
mod dataflow;
mod demo;
mod display;
mod editor;
mod file_io;
mod first_hour;
mod floating_session;
mod follow;
mod hostile_inputs;
mod library_space;
mod mimic_session;
mod operations;
mod ops;
mod query;
mod query_docs;
mod query_urdf;
mod readme;
mod recording;
mod rules;
mod simulator;
mod space;
mod studies;
mod sweep;
mod test_layout;
