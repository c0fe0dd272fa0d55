//! Every file of tests/ is a module of this one test binary (linked once, not once per file):
//! `cargo test -p robosim-dynamics --test dynamics` runs them all,
//! `cargo test -p robosim-dynamics --test dynamics FILE::` the tests of tests/FILE.rs.
//! A new file of tests/ needs its `mod` line here (Cargo.toml: `autotests = false`).

mod common;

mod ball;

mod floating;
mod friction;
mod hard_cases;
mod properties;
mod reference_pinocchio;
mod urdf_corpus;
mod urdf_energy;
mod urdf_mimic;
