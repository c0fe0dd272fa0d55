//! Every file of tests/ is a module of this one test binary (linked once, not once per file):
//! `cargo test -p robosim-collision --test collision` runs them all,
//! `cargo test -p robosim-collision --test collision FILE::` the tests of tests/FILE.rs.
//! A new file of tests/ needs its `mod` line here (Cargo.toml: `autotests = false`).

mod compiled_robot;
mod contact_reference;
mod degenerate_solids;
mod hard_cases;
mod properties;
mod reference;
mod robot;
