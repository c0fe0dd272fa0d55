//! The `hfm` fuzz target's body (`fuzz/src/hfm.rs`) over every file of its corpus
//! (`fuzz/seeds/hfm/`: real inputs, and each input the fuzzer once crashed on), on stable,
//! so `cargo test` re-checks them without nightly. See `docs/fuzzing.md`.

#[path = "../../fuzz/src/hfm.rs"]
mod body;
#[path = "../../fuzz/src/replay.rs"]
mod replay;

use std::path::Path;

#[test]
fn hfm_fuzz_corpus_replays() {
    replay::replay(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz"),
        "hfm",
        body::run,
    );
}
