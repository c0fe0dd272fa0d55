//! The `hfm` fuzz target's body (`fuzz/src/hfm.rs`) over every file of its corpus
//! (`fuzz/seeds/hfm/`: real inputs, and each input the fuzzer once crashed on), on stable,
//! so `cargo test` re-checks them without nightly. See `docs/fuzzing.md`.

#[path = "../../fuzz/src/hfm.rs"]
mod body;

use std::path::{Path, PathBuf};

fn corpus(target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fuzz/seeds")
        .join(target);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("dir entry").path())
        .collect();
    files.sort();
    assert!(!files.is_empty(), "{}: empty corpus", dir.display());
    files
        .into_iter()
        .map(|p| {
            let b = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            (p, b)
        })
        .collect()
}

#[test]
fn hfm_fuzz_corpus_replays() {
    for (path, data) in corpus("hfm") {
        eprintln!("{}", path.display());
        body::run(&data);
    }
}
