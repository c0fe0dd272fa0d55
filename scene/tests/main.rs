//! Every file of tests/ is a module of this one test binary (linked once, not once per file):
//! `cargo test -p robosim-scene --test scene` runs them all,
//! `cargo test -p robosim-scene --test scene FILE::` the tests of tests/FILE.rs.
//! A new file of tests/ needs its `mod` line here (Cargo.toml: `autotests = false`).

mod compiled;
mod from_urdf;
