//! Every file of tests/ is a module of this one test binary (linked once, not once per file):
//! `cargo test -p robosim-kinematics --test kinematics` runs them all,
//! `cargo test -p robosim-kinematics --test kinematics FILE::` the tests of tests/FILE.rs.
//! A new file of tests/ needs its `mod` line here (Cargo.toml: `autotests = false`).

mod compiled_callers;
mod hard_cases;
mod peers;
mod properties;
mod reference;
