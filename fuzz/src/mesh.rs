//! The shared body of targets `stl` and `obj`: a mesh file as `robosim import mesh` reads it
//! (`file-io/src/import.rs` `read_mesh`: the reader of `core/urdf/src/{stl,obj}.rs`, then
//! the finite check after scaling), then made Instance Space geometry both ways (`mesh_geometry`:
//! welded triangles, and with `--hull` the convex hull).
//!
//! Whatever the bytes: triangles or a `FileError::Mesh` naming the file given and a line inside
//! it; never a panic or unbounded time. Memory is bounded by the input: a triangle takes at
//! least [`MIN_BYTES_PER_TRIANGLE`] bytes of file (a binary STL's 50, an ASCII facet's three
//! `vertex` lines, an OBJ face's indices may be shared: see [`MIN_BYTES_PER_TRIANGLE`]), so the
//! reader itself never allocates more than a small multiple of the input. Every coordinate of an
//! accepted mesh is finite, and so is every vertex of its geometry, and the keeper's checks
//! (an in-memory `Store`) accept the transaction `import mesh` would send.
//!
//! The bytes are written to a file of the process's scratch directory (`read_mesh` takes a path,
//! as the command does); the file is rewritten for each input.

use robosim_file_io::FileError;
use robosim_file_io::import::{Placement, import_tx, mesh_geometry, read_mesh};
use robosim_instance_space::{Appearance, IDENTITY, Store};
use std::path::{Path, PathBuf};

/// Bytes of input per triangle read, at least: an OBJ face `f 1 2 3 4 …` adds one triangle per
/// index after the second, two bytes each (`4 `).
pub const MIN_BYTES_PER_TRIANGLE: usize = 2;

fn scratch(ext: &str) -> PathBuf {
    thread_local! {
        static DIR: Option<tempfile::TempDir> = tempfile::Builder::new()
            .prefix("robosim-fuzz-mesh-")
            .tempdir_in(if Path::new("/dev/shm").is_dir() { Path::new("/dev/shm") } else { Path::new("/tmp") })
            .ok();
    }
    DIR.with(|d| {
        d.as_ref()
            .expect("a scratch directory for the mesh file")
            .path()
            .join(format!("fuzz.{ext}"))
    })
}

/// `ext`: `stl` or `obj` (how `read_mesh` chooses the reader).
pub fn run(data: &[u8], ext: &str) {
    let path = scratch(ext);
    std::fs::write(&path, data).expect("write the scratch mesh file");
    let lines = data.iter().filter(|&&b| b == b'\n').count() + 1;
    match read_mesh(&path, 1.0) {
        Ok(tris) => {
            assert!(
                tris.len() <= data.len() / MIN_BYTES_PER_TRIANGLE + 1,
                "{} triangles from {} bytes",
                tris.len(),
                data.len()
            );
            assert!(
                tris.iter().flatten().flatten().all(|c| c.is_finite()),
                "read_mesh accepted a coordinate that is not finite"
            );
            for hull in [false, true] {
                match mesh_geometry(&tris, hull, &path) {
                    Ok(g) => {
                        assert!(
                            g.geometry.vertices.iter().flatten().all(|c| c.is_finite()),
                            "mesh geometry (hull: {hull}) has a vertex that is not finite"
                        );
                        // What `robosim import mesh` commits: the keeper's checks on an
                        // in-memory store (import.rs: no triangle kept is refused by them).
                        let place = Placement {
                            name: "fuzz".into(),
                            pose: IDENTITY,
                            parent: None,
                            appearance: Appearance::default(),
                        };
                        if let Err(e) = Store::new().apply(&import_tx(&g.geometry, &place)) {
                            panic!("the keeper refuses imported geometry (hull: {hull}): {e}");
                        }
                    }
                    Err(e) => check_error(&e, &path, lines),
                }
            }
        }
        Err(e) => check_error(&e, &path, lines),
    }
}

fn check_error(e: &FileError, path: &Path, lines: usize) {
    match e {
        FileError::Mesh { path: p, line, .. } => {
            assert_eq!(p, path, "error names another file: {e}");
            assert!(
                *line <= lines,
                "error at line {line} of a {lines}-line file: {e}"
            );
        }
        other => panic!("not a mesh error: {other}"),
    }
    let _ = e.to_string();
}
