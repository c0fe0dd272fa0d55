//! Every file of tests/ is a module of this one test binary (linked once, not once per file):
//! `cargo test -p robosim-geometry --test geometry` runs them all,
//! `cargo test -p robosim-geometry --test geometry FILE::` the tests of tests/FILE.rs.
//! A new file of tests/ needs its `mod` line here (Cargo.toml: `autotests = false`).

mod mass_reference;
mod shapes;
