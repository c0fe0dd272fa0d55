//! The command-line surface of the interface side, wired into the `robosim` binary:
//!
//! * [`query`] — `robosim query` (the JSON-lines transport); [`QueryArgs`] and [`run`] are
//!   re-exported here;
//! * [`lib`] — `robosim lib list|show|check` ([`lib::LibCmd`], [`lib::run`], [`lib::render_with`]);
//! * [`diag`] — `robosim diag check|simulate|run|analyze` ([`diag::DiagCmd`], [`diag::run`],
//!   [`diag::execute`]);
//! * [`sim`] — `robosim sim` ([`sim::SimArgs`], [`sim::run`]).

pub mod diag;
pub mod lib;
pub mod lib_session;
pub mod query;
pub mod sim;

pub use query::{QueryArgs, run};

use std::path::PathBuf;

/// Why a `robosim lib|diag|sim|query` command failed. Its message names what and where; a
/// variant that wraps a lower error keeps it typed (`source()` reaches it, and the binary
/// prints the chain with `robosim_instance_space::error_chain`).
#[derive(Debug, thiserror::Error)]
pub enum CommandError {
    /// The command's own refusal (a malformed argument, an inconsistent model, an unknown
    /// name): the message itself.
    #[error("{0}")]
    Refused(String),
    /// An input file could not be read (the error names the file).
    #[error(transparent)]
    Read(#[from] robosim_input::InputError),
    /// An output file could not be written (the error names the file).
    #[error(transparent)]
    Write(#[from] robosim_input::OutputError),
    /// The library refused a file or a declaration (file:line:col and the reason).
    #[error(transparent)]
    Library(#[from] robosim_library::Error),
    /// A fault model could not be loaded (file:line:col and the reason).
    #[error(transparent)]
    FaultModel(#[from] robosim_automation::model::ModelError),
    /// The diagnoser refused an alarm.
    #[error(transparent)]
    Alarm(#[from] robosim_automation::diag::AlarmError),
    /// A query op refused the request (its message; the kind is the protocol's).
    #[error("{}", .0.message)]
    Protocol(#[from] crate::ProtocolError),
    /// A JSON file is not JSON (file:line:column).
    #[error("{}:{}:{}: {source}", path.display(), source.line(), source.column())]
    Json {
        path: PathBuf,
        source: serde_json::Error,
    },
    /// An answer could not be written as JSON.
    #[error(transparent)]
    Encode(#[from] serde_json::Error),
    /// A robot file's JSON is not a robot (the file, then the field path).
    #[error("{}: {source}", path.display())]
    Robot {
        path: PathBuf,
        source: crate::robot_json::JsonError,
    },
    /// A scene's inline effects declaration was refused.
    #[error(transparent)]
    Effects(#[from] robosim_simulator::OptionsError),
    /// An effects file's declaration was refused.
    #[error("{path}: {source}")]
    EffectsFile {
        path: String,
        source: robosim_simulator::OptionsError,
    },
    /// The declared effects build no pipeline for the robot (the simulator's refusal).
    #[error(transparent)]
    Pipeline(#[from] robosim_simulator::BuildError),
    /// A headless simulation step failed.
    #[error("step {step}: {source}")]
    Step {
        step: u64,
        source: robosim_simulator::StepError,
    },
    /// `query`'s input file could not be opened.
    #[error("query: cannot open {}: {source}", path.display())]
    Open {
        path: PathBuf,
        source: std::io::Error,
    },
    /// `query`'s streams failed.
    #[error("query: {0}")]
    Io(#[source] std::io::Error),
}

impl From<String> for CommandError {
    fn from(message: String) -> Self {
        CommandError::Refused(message)
    }
}
