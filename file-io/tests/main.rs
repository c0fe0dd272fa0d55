//! Every file of tests/ is a module of this one test binary (linked once, not once per file):
//! `cargo test -p robosim-file-io --test file_io` runs them all,
//! `cargo test -p robosim-file-io --test file_io FILE::` the tests of tests/FILE.rs.
//! A new file of tests/ needs its `mod` line here (Cargo.toml: `autotests = false`).

mod reference;

mod exchange;
mod export_geometry;
mod export_mimic;
mod fuzz_corpus;
mod hostile_inputs;
mod linkfile_mass;
mod mjcf_export;
mod mjcf_import;
mod model_files;
mod urdf_bad_input;
mod urdf_export;
mod urdf_geometry;
mod urdf_ik;
mod urdf_import;
mod urdf_session;

// fuzz/src/stl.rs and obj.rs (compiled into fuzz_corpus) call `crate::mesh::run`, where the fuzz
// crate has it.
use fuzz_corpus::mesh;
