//! The `trajectory` fuzz target's body (`fuzz/src/trajectory.rs`) over every file of its
//! corpus (`fuzz/seeds/trajectory/`: real trajectories, and each input the fuzzer once crashed
//! on), on stable, so `cargo test` re-checks them without nightly. See `docs/fuzzing.md`.

/// What the body reads the trajectory format with: here, the display's own reader.
mod traj {
    pub use robosim_display::trajectory::{Trajectory, to_si};
}

#[path = "../../fuzz/src/trajectory.rs"]
mod body;
#[path = "../../fuzz/src/replay.rs"]
mod replay;

use std::path::Path;

#[test]
fn trajectory_fuzz_corpus_replays() {
    replay::replay(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz"),
        "trajectory",
        body::run,
    );
}
