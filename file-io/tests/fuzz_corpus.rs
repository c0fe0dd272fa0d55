//! The fuzz targets that read file-io's formats (`fuzz/src/{urdf,stl,obj,mesh,dae,model}.rs`;
//! `linkfile` is replayed by the editor's, whose `lang load` it reads through) over every file of their corpora (`fuzz/seeds/TARGET/`: real files of
//! testdata/, hostile ones, and each input the fuzzer once crashed on), on stable, so `cargo
//! test` re-checks them without nightly. See `docs/fuzzing.md`.

#[path = "../../fuzz/src/dae.rs"]
mod dae;
#[path = "../../fuzz/src/mesh.rs"]
pub(crate) mod mesh;
#[path = "../../fuzz/src/model.rs"]
mod model;
#[path = "../../fuzz/src/obj.rs"]
mod obj;
#[path = "../../fuzz/src/replay.rs"]
mod replay;
#[path = "../../fuzz/src/stl.rs"]
mod stl;
#[path = "../../fuzz/src/urdf.rs"]
mod urdf;

use std::path::{Path, PathBuf};

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz")
}

#[test]
fn urdf_fuzz_corpus_replays() {
    replay::replay(&fuzz_dir(), "urdf", urdf::run);
}

#[test]
fn stl_fuzz_corpus_replays() {
    replay::replay(&fuzz_dir(), "stl", stl::run);
}

#[test]
fn obj_fuzz_corpus_replays() {
    replay::replay(&fuzz_dir(), "obj", obj::run);
}

#[test]
fn dae_fuzz_corpus_replays() {
    replay::replay(&fuzz_dir(), "dae", dae::run);
}

#[test]
fn model_fuzz_corpus_replays() {
    replay::replay(&fuzz_dir(), "model", model::run);
}

/// Issue 34 (fuzzing, `stl` target): `import mesh --hull` of a (mutated) panda STL kept a hull
/// sliver triangle that passed the importer's area test but not the keeper's planarity test
/// ("polygon 13 is not planar: vertex 12 lies -9.6e-11 m off its plane"), so the import was
/// refused whole. The importer now drops what the keeper's own polygon check refuses.
#[test]
fn imported_hull_sliver_triangle_is_dropped_not_refused_by_the_keeper() {
    use robosim_file_io::import::{Placement, import_tx, mesh_geometry, read_mesh};
    let path = fuzz_dir().join("seeds/stl/regression-hull-sliver-refused-by-keeper.stl");
    let tris = read_mesh(&path, 1.0).expect("reads");
    for hull in [false, true] {
        let g = mesh_geometry(&tris, hull, &path).expect("geometry");
        let place = Placement {
            name: "m".into(),
            pose: robosim_instance_space::IDENTITY,
            parent: None,
            appearance: robosim_instance_space::Appearance::default(),
        };
        if let Err(e) = robosim_instance_space::Store::new().apply(&import_tx(&g.geometry, &place))
        {
            panic!("hull {hull}: the keeper refuses the imported geometry: {e}");
        }
    }
}
