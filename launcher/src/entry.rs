//! `robosim up` and `robosim space` with their parsed arguments: which of the launcher's entry
//! points the arguments ask for (a model file, a scene, or the session's saved model resumed).

use crate::LaunchError;
use std::path::{Path, PathBuf};

/// `robosim space [--scene SCENE | --load FILE]`: the keeper process, on a model file or a scene.
pub fn space(
    session: Option<&str>,
    scene: Option<&str>,
    load: Option<&Path>,
    library: &[PathBuf],
    durable: bool,
    journal_copies: u8,
) -> Result<(), LaunchError> {
    match load {
        Some(file) => crate::space_load(file, session, library, durable, journal_copies),
        None => crate::run_space(session, scene, library, durable, journal_copies),
    }
}

/// `robosim up [SCENE | --load FILE] …`: a model file, a scene, or (neither) the session's
/// saved model resumed; `--fresh` without a scene is refused (it starts a scene over).
pub fn up(
    session: Option<&str>,
    scene: Option<&str>,
    load: Option<&Path>,
    with: &[String],
    library: &[PathBuf],
    fresh: bool,
    sim_mode: Option<&str>,
) -> Result<(), LaunchError> {
    match (scene, load) {
        (_, Some(file)) => crate::up_load(file, with, session, library, sim_mode),
        (None, None) if fresh => Err(LaunchError::Process(
            "--fresh starts a scene over: name it (`robosim up SCENE --fresh`)".into(),
        )),
        (None, None) => crate::up_resume(with, session, library, sim_mode),
        (Some(scene), None) => {
            crate::up_with_library(scene, with, session, library, fresh, sim_mode)
        }
    }
}
