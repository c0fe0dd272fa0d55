//! Empty: the package has build-dependencies only to pin host-side features (Cargo.toml).
fn main() {}
