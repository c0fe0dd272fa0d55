//! `robosim lib …` with or without `--session`: the standard library ([`super::lib::run`]), or
//! a running session's Library Space ([`robosim_scene::cli::session_library`]) where the
//! command names no `--file`.
//!
//! Entry points: [`run`], [`LibSessionError`].

use super::CommandError;
use super::lib::{LibCmd, render_with};
use robosim_scene::SceneError;

/// Why `robosim lib` failed: the session's Library Space could not be read, or the command's
/// own error.
#[derive(Debug, thiserror::Error)]
pub enum LibSessionError {
    /// The session does not exist, or its Library Space could not be read.
    #[error(transparent)]
    Session(#[from] SceneError),
    /// The command failed on the library (the message names what and where).
    #[error(transparent)]
    Command(#[from] CommandError),
}

/// Runs one `lib` command against the standard library (`session` `None`) or the Library Space
/// of the running session `session`, printing to stdout.
pub fn run(cmd: LibCmd, session: Option<&str>) -> Result<(), LibSessionError> {
    match session {
        None => Ok(super::lib::run(cmd)?),
        Some(_) => {
            let lib = robosim_scene::cli::session_library(session)?;
            print!("{}", render_with(cmd, Some(&lib))?);
            Ok(())
        }
    }
}
