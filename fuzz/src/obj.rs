//! Target `obj`: Wavefront OBJ meshes (`core/urdf/src/obj.rs` through
//! `robosim_file_io::import::read_mesh`). What must hold: see [`crate::mesh`].

pub fn run(data: &[u8]) {
    crate::mesh::run(data, "obj");
}
