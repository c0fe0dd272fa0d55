//! `robosim lang run|load` with the arguments the binary parsed: a ROBOSIM program into link
//! files (or at once into a session's robot), link files into a session. Each answers the text
//! the command prints (the binary prints it).
//!
//! Entry points: [`LangCmd`], [`run`], [`LangCmdError`].

use crate::cli::{RunError, lang_load, lang_run, lang_run_into};
use robosim_instance_space::{Session, SessionError};
use std::path::PathBuf;

/// One `robosim lang` command.
#[derive(Debug, Clone)]
pub enum LangCmd {
    /// `lang run PROGRAM [--out DIR] [--as NAME]`: the program's links into DIR, or as robot
    /// NAME into the session (and also into DIR when both are given).
    Run {
        program: PathBuf,
        out: Option<PathBuf>,
        name: Option<String>,
    },
    /// `lang load DIR --as NAME [--robot R]`: the link files in DIR as robot NAME.
    Load {
        dir: PathBuf,
        name: String,
        robot: Option<String>,
    },
}

/// Why `robosim lang` failed: the session does not exist, or the command's own error.
#[derive(Debug, thiserror::Error)]
pub enum LangCmdError {
    /// The session the command writes to does not exist (the message names the sessions that
    /// run).
    #[error(transparent)]
    Session(#[from] SessionError),
    /// The program, the link files or the session refused (the message names what and where).
    #[error(transparent)]
    Run(#[from] RunError),
}

/// Runs one `lang` command against the session `session` (one that must exist, for the
/// commands that write to it); the text to print.
pub fn run(cmd: LangCmd, session: Option<&str>) -> Result<String, LangCmdError> {
    match cmd {
        LangCmd::Run { program, out, name } => match (name, out) {
            (Some(name), out) => {
                let s = Session::existing(session)?;
                let m = lang_run_into(&program, out.as_deref(), &name, &s)?;
                Ok(format!("{m}\n"))
            }
            (None, Some(out)) => Ok(lang_run(&program, &out)?),
            (None, None) => {
                Err(RunError::Refused("lang run: give --out DIR or --as NAME".into()).into())
            }
        },
        LangCmd::Load { dir, name, robot } => {
            let s = Session::existing(session)?;
            let m = lang_load(&dir, &name, robot.as_deref(), &s)?;
            Ok(format!("{m}\n"))
        }
    }
}
