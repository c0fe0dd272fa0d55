//! What can go wrong between the spaces and the cores.

use robosim_instance_space::{ClientError, Id, ReaderError, SessionError};
use robosim_library::LibError;
use std::sync::Arc;

/// Why a scene operation failed. Every variant names the input it is about; a variant that
/// wraps another error keeps it as its source (shared, so that the error stays `Clone`).
#[derive(Debug, Clone, thiserror::Error)]
pub enum SceneError {
    /// A scene or declaration name the library does not have.
    #[error("unknown scene {name:?}; scenes and robots: {known}")]
    UnknownScene { name: String, known: String },
    /// The Library Space refused (parse or evaluation error, with file:line:col).
    #[error("{0}")]
    Library(#[from] robosim_library::Error),
    /// The session's published Library Space does not parse.
    #[error("the session's Library Space: {0}")]
    SessionLibrary(#[source] LibError),
    /// The declaration cannot become Instance Space objects.
    #[error("{0}")]
    Instantiate(String),
    /// No instance of that name (an object with an origin record).
    #[error("no instance named {name:?}; instances: {known}")]
    UnknownInstance { name: String, known: String },
    /// An instance's origin record is not readable.
    #[error("instance {name}: unreadable origin record: {source}")]
    Origin {
        name: String,
        #[source]
        source: Arc<serde_json::Error>,
    },
    /// A `NAME=EXPR` parameter without `=`.
    #[error("parameter {0:?} is not NAME=EXPR")]
    Param(String),
    /// No robot of that name in the snapshot.
    #[error("no robot named {name:?} in the session; robots: {known}")]
    UnknownRobot { name: String, known: String },
    /// The robot has no link with a joint record.
    #[error("robot {0:?} has no joints")]
    NoJoints(String),
    /// A link of a robot's chain that the DH model cannot represent (a fixed joint record).
    #[error(
        "robot {robot:?}: link {link} (object {id}) has a fixed joint record; a DH chain holds revolute and prismatic joints only"
    )]
    FixedJoint { robot: String, link: String, id: Id },
    /// The robot's kinematic data is not a valid model (e.g. reversed limits).
    #[error("robot {robot:?}: {reason}")]
    BadRobot { robot: String, reason: String },
    /// The robot's geometry makes no collision solids (which object, on which frame, why).
    #[error("robot {robot:?}: {source}")]
    Geometry {
        robot: String,
        #[source]
        source: robosim_model::GeometryError,
    },
    /// The session's keeper has published no snapshot yet.
    #[error("the session has no snapshot yet (is its keeper starting?)")]
    NoSnapshot,
    /// A session's processes could not be started or stopped.
    #[error("{0}")]
    Launch(String),
    /// The session (shared memory) could not be read or written. The message names the
    /// session already (every `SessionError` and `ReaderError` does), so it is not prefixed.
    #[error(transparent)]
    Session(SessionFailure),
}

/// Why a session could not be read or written: the Instance Space's own error, kept whole.
#[derive(Debug, Clone, thiserror::Error)]
pub enum SessionFailure {
    #[error(transparent)]
    Reader(Arc<ReaderError>),
    #[error(transparent)]
    Session(Arc<SessionError>),
    #[error(transparent)]
    Client(Arc<ClientError>),
}

impl From<LibError> for SceneError {
    fn from(e: LibError) -> Self {
        SceneError::Library(robosim_library::Error::Source(e))
    }
}

impl From<ReaderError> for SceneError {
    fn from(e: ReaderError) -> Self {
        SceneError::Session(SessionFailure::Reader(Arc::new(e)))
    }
}

impl From<ClientError> for SceneError {
    fn from(e: ClientError) -> Self {
        SceneError::Session(SessionFailure::Client(Arc::new(e)))
    }
}

impl From<SessionError> for SceneError {
    fn from(e: SessionError) -> Self {
        SceneError::Session(SessionFailure::Session(Arc::new(e)))
    }
}
