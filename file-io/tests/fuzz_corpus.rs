//! The fuzz targets that read file-io's formats (`fuzz/src/{urdf,stl,obj,mesh,dae,model}.rs`;
//! `linkfile` is replayed by the editor's, whose `lang load` it reads through) over every file of their corpora (`fuzz/seeds/TARGET/`: real files of
//! testdata/, hostile ones, and each input the fuzzer once crashed on), on stable, so `cargo
//! test` re-checks them without nightly. See `docs/fuzzing.md`.

#[path = "../../fuzz/src/dae.rs"]
mod dae;
#[path = "../../fuzz/src/mesh.rs"]
mod mesh;
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
