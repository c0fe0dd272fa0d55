//! The `library` fuzz target's body (`fuzz/src/library.rs`) over every file of its corpus
//! (`fuzz/seeds/library/`: real inputs, and each input the fuzzer once crashed on), on stable,
//! so `cargo test` re-checks them without nightly. See `docs/fuzzing.md`.

#[path = "../../fuzz/src/library.rs"]
mod body;
#[path = "../../fuzz/src/replay.rs"]
mod replay;

use std::path::Path;

#[test]
fn library_fuzz_corpus_replays() {
    replay::replay(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz"),
        "library",
        body::run,
    );
}
