//! The seed's case studies as runnable programs: each starts (or uses) a session, does the
//! study's work through the real crates, processes and shared memory, and writes what it found
//! to a writer — the `robosim demo` and `robosim study` commands print it.
//!
//! * [`surgical`] — seed §2.7: the kinematic surgical positioner beside the patient's head (IK,
//!   collision, MOVEJI, the encoder study, dynamics, an ECLSS diagnosis), `robosim demo`.
//!
//! * [`welding`] — seed §2.2/§2.7: the downhand welding cell, `robosim study welding`.
//! * [`station`] — seed chapter 4: the Space Station's orbit, sun-tracking arrays, power and
//!   an ORU swap by the servicer, `robosim study station`; [`orbit`] is its orbit model and
//!   `robosim_simulator::power` its arrays, tracking, power and battery (both shared with the
//!   simulator daemon's space stage).
//! * [`operations`] — issue 38 item 7: the operational station as separate processes on one
//!   session (simulator, rules, dataflow, automation), `robosim study operations`.
//! * [`sweep`] — `robosim sweep STUDY --param … --workers N`: a parameter study over worker
//!   processes, gathered into one CSV; a dead worker's job is redone.
//! * [`common`] — bodies, clearances, trajectory files, CSV and frames the two share.
//!
//! Entry points: [`surgical::run`], [`welding::run`], [`station::run`], [`StudyError`].

pub mod cli;
pub mod common;
pub mod operations;
/// The orbit model (the `orbit` effect), shared with the simulator daemon.
pub use robosim_simulator::orbit;
pub mod station;
pub mod surgical;
pub mod sweep;
pub mod welding;

/// Why a study stopped: what failed and where. A failure of another crate keeps its type (the
/// variant's `source()` or, when transparent, the error itself); the conditions a study
/// describes itself are [`StudyError::Message`].
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// A condition the study describes itself (`bail!`): a refused parameter, a missing part.
    #[error("{0}")]
    Message(String),
    /// Writing a line of the study's report (`say!`) failed.
    #[error("writing the study report: {0}")]
    Report(#[source] std::io::Error),
    /// Starting or reaching the session failed (the error itself; boxed, it is large).
    #[error(transparent)]
    Launch(Box<robosim_launcher::LaunchError>),
    /// The session's shared memory failed (the error itself).
    #[error(transparent)]
    Session(#[from] robosim_instance_space::SessionError),
    /// The session's state failed (the error itself).
    #[error(transparent)]
    State(#[from] robosim_instance_space::state::StateError),
    /// Reading the session's snapshot failed (the error itself).
    #[error(transparent)]
    Reader(#[from] robosim_instance_space::ReaderError),
    /// A transaction on the session failed (the error itself).
    #[error(transparent)]
    Client(#[from] robosim_instance_space::ClientError),
    /// A high-level interface request failed (the error itself).
    #[error(transparent)]
    Protocol(#[from] robosim_hl_interface::ProtocolError),
    /// A collision check failed (the error itself).
    #[error(transparent)]
    Collision(#[from] robosim_collision::robot::CheckError),
    /// The dynamics model failed (the error itself).
    #[error(transparent)]
    Dynamics(#[from] robosim_dynamics::DynamicsError),
    /// Inverse kinematics failed (the error itself).
    #[error(transparent)]
    Ik(#[from] robosim_kinematics::ik::IkError),
    /// A joint-space move failed (the error itself).
    #[error(transparent)]
    MoveJ(#[from] robosim_kinematics::MoveJError),
    /// The encoder study failed (the error itself).
    #[error(transparent)]
    Encoder(#[from] robosim_kinematics::encoder::EncoderErrorError),
    /// The orbit model failed (the error itself).
    #[error(transparent)]
    Orbit(#[from] robosim_simulator::orbit::OrbitError),
    /// The attitude model failed (the error itself).
    #[error(transparent)]
    Attitude(#[from] robosim_simulator::attitude::AttitudeError),
    /// Planning the ORU swap failed (the error itself).
    #[error(transparent)]
    Swap(#[from] robosim_simulator::swap::SwapError),
    /// The diagnoser's alarms failed (the error itself).
    #[error(transparent)]
    Alarm(#[from] robosim_automation::diag::AlarmError),
    /// Loading an automation model failed (the error itself).
    #[error(transparent)]
    Model(#[from] robosim_automation::model::ModelError),
    /// Writing an output file failed (the error itself).
    #[error(transparent)]
    Output(#[from] robosim_input::OutputError),
    /// Writing a report or plot failed (the error itself).
    #[error(transparent)]
    Plot(#[from] robosim_report::ReportError),
    /// Reading, writing or making the file or directory `path`.
    #[error("{}: {source}", path.display())]
    Io {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Another crate's failure at a step the study names (`what`: the robot, rule base, time).
    #[error("{what}: {source}")]
    At {
        what: String,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync + 'static>,
    },
}

impl From<robosim_launcher::LaunchError> for StudyError {
    fn from(e: robosim_launcher::LaunchError) -> Self {
        StudyError::Launch(Box::new(e))
    }
}

impl StudyError {
    /// `source` failing on the file or directory `path`.
    pub(crate) fn io(path: &std::path::Path, source: std::io::Error) -> Self {
        StudyError::Io {
            path: path.to_owned(),
            source,
        }
    }

    /// `source` failing at the step `what` names.
    pub(crate) fn at(
        what: impl Into<String>,
        source: impl std::error::Error + Send + Sync + 'static,
    ) -> Self {
        StudyError::At {
            what: what.into(),
            source: Box::new(source),
        }
    }
}

pub type Result<T> = std::result::Result<T, StudyError>;

macro_rules! bail {
    ($($t:tt)*) => { return Err($crate::StudyError::Message(format!($($t)*))) };
}
pub(crate) use bail;

/// `writeln!` to a study's report writer; a failed write ends the study.
macro_rules! say {
    ($out:expr) => { writeln!($out).map_err($crate::StudyError::Report)? };
    ($out:expr, $($t:tt)*) => { writeln!($out, $($t)*).map_err($crate::StudyError::Report)? };
}
pub(crate) use say;
