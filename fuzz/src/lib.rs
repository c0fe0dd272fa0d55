//! The bodies of the fuzz targets, one module per target (see `docs/fuzzing.md`).
//!
//! Each `run(data)` feeds arbitrary bytes to one reader of untrusted input and checks what must
//! hold whatever the bytes are: no panic, no stack overflow, bounded time and memory, and the
//! reader's own contract (one answer line per request, a parsed model that re-checks, …).
//!
//! The same module files are compiled three ways:
//! * by `fuzz_targets/*.rs` here, under libFuzzer (`cargo +nightly fuzz run TARGET`);
//! * by `tests/fuzz_corpus.rs` of the crate each target reads (`#[path]` includes of these
//!   files and of `replay.rs`, the one corpus walk), so `cargo test --workspace` on stable
//!   re-checks every file of `fuzz/seeds/TARGET/`, crashes included.
//!
//! Targets: [`library`] (Library Space language: lex, parse, check, evaluate; a parameter
//! expression), [`protocol`] (query protocol: line → request → answer, without a session),
//! [`trajectory`] (the display's joint trajectory files), [`hfm`] (HPM/HFM model files),
//! [`journal`] (Instance Space recovery: checkpoint + journal records), [`urdf`] (URDF as a
//! chain and as a tree, collision solids), [`stl`] and [`obj`] (mesh import, through
//! [`mesh`]), [`dae`] (Collada), [`model`] (model files, binary and JSON, and their load
//! transaction), [`linkfile`] (link files and `lang load`), [`program`] (ROBOSIM programs and
//! `lang run`), [`edit`] (the editor's command lines).

pub mod dae;
pub mod edit;
pub mod hfm;
pub mod journal;
pub mod library;
pub mod linkfile;
pub mod mesh;
pub mod model;
pub mod obj;
pub mod program;
pub mod protocol;
pub mod stl;
pub mod trajectory;
pub mod urdf;

/// The display's trajectory reader, compiled from its source file: depending on
/// `robosim-display` would build wgpu and winit under the sanitizer, minutes of the CI budget
/// for a 100-line text parser. The file needs only `crate::{DisplayError, Result}`, given here
/// with the same variants and messages.
#[path = "../../display/src/trajectory.rs"]
#[expect(
    dead_code,
    reason = "the target reads text; `Trajectory::load` (files) is the display's"
)]
mod display_trajectory;

/// What the `trajectory` body reads the format with (the display's own tests give it
/// `robosim_display::trajectory` under the same name).
mod traj {
    pub use super::display_trajectory::{Trajectory, to_si};
}

/// The two variants of `robosim_display::DisplayError` the trajectory reader returns.
#[derive(Debug, thiserror::Error)]
pub enum DisplayError {
    #[error("{path}: {source}")]
    Io {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
    #[error("{path}:{line}: {what}")]
    Trajectory {
        path: std::path::PathBuf,
        line: usize,
        what: String,
    },
}

pub type Result<T> = std::result::Result<T, DisplayError>;
