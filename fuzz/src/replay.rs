//! Replays one fuzz target's seed corpus on stable: every file of `fuzz/seeds/<target>/`, in
//! name order, through the target's body. Included with `#[path]` by each owning crate's
//! `tests/fuzz_corpus.rs`, so `cargo test --workspace` re-checks every seed and every input the
//! fuzzer once crashed on, without nightly (docs/fuzzing.md).

use std::path::Path;

/// Runs `body` over every file of `<fuzz_dir>/seeds/<target>/`, printing each path before it
/// (a failure names its input). An empty or missing corpus fails: a replay that checks nothing
/// must not pass.
pub fn replay(fuzz_dir: &Path, target: &str, body: impl Fn(&[u8])) {
    let dir = fuzz_dir.join("seeds").join(target);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("dir entry").path())
        .collect();
    files.sort();
    assert!(!files.is_empty(), "{}: empty corpus", dir.display());
    for p in files {
        eprintln!("{}", p.display());
        body(&std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display())));
    }
}
