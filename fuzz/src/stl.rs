//! Target `stl`: STL meshes, binary and ASCII (`core/urdf/src/stl.rs` through
//! `robosim_file_io::import::read_mesh`). What must hold: see [`crate::mesh`].

pub fn run(data: &[u8]) {
    crate::mesh::run(data, "stl");
}
