//! `robosim rules FILE --session S`: the command with the arguments the binary parsed — the
//! build checked for CLIPS first, then the session, then the limits, then [`crate::run`].
//!
//! Entry points: [`Args`], [`run`], [`CommandError`].

use crate::RulesError;
use crate::clips::Limits;
use robosim_instance_space::{Session, SessionError};
use std::path::Path;

/// The arguments of `robosim rules`.
#[derive(Debug, Clone, Copy)]
pub struct Args<'a> {
    /// The rule file (.clp).
    pub file: &'a Path,
    /// CLIPS watch items traced on stdout ([`crate::WATCH_ITEMS`]).
    pub watch: &'a [String],
    /// Rule execution time allowed per pass, seconds.
    pub time_limit: f64,
    /// Nested deffunction and generic function calls allowed.
    pub max_depth: u32,
    /// Memory CLIPS may hold, MiB.
    pub max_memory: usize,
}

/// Why `robosim rules` did not start or stopped: the session's, the limits' or the rules' own
/// error, each in its own words.
#[derive(Debug, thiserror::Error)]
pub enum CommandError {
    /// No CLIPS in this build, or the rules failed or went past a limit.
    #[error(transparent)]
    Rules(#[from] RulesError),
    /// The session does not exist (the message names the sessions that run).
    #[error(transparent)]
    Session(#[from] SessionError),
    /// `--time-limit` is not a positive number of seconds.
    #[error("--time-limit {0}: not a positive number of seconds")]
    TimeLimit(f64),
}

/// `robosim rules`: a build without CLIPS says what to install before anything else; a session
/// that must exist; then the rule base runs within its time, depth and memory limits
/// (`time_limit` s, `max_memory` MiB).
pub fn run(args: &Args<'_>, session: Option<&str>) -> Result<(), CommandError> {
    crate::available()?;
    Session::existing(session)?;
    let time = std::time::Duration::try_from_secs_f64(args.time_limit)
        .ok()
        .filter(|t| !t.is_zero())
        .ok_or(CommandError::TimeLimit(args.time_limit))?;
    let limits = Limits {
        time,
        depth: args.max_depth,
        memory: args.max_memory.saturating_mul(1 << 20),
    };
    Ok(crate::run(args.file, session, args.watch, &limits)?)
}
