//! What can go wrong between the spaces and the cores.

use robosim_instance_space::Id;

/// Why a scene operation failed. Every variant names the input it is about.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// A scene or declaration name the library does not have.
    #[error("unknown scene {name:?}; scenes and robots: {known}")]
    UnknownScene { name: String, known: String },
    /// The Library Space refused (parse or evaluation error, with file:line:col).
    #[error("{0}")]
    Library(String),
    /// The declaration cannot become Instance Space objects.
    #[error("{0}")]
    Instantiate(String),
    /// No instance of that name (an object with an origin record).
    #[error("no instance named {name:?}; instances: {known}")]
    UnknownInstance { name: String, known: String },
    /// An instance's origin record is not readable.
    #[error("instance {name}: unreadable origin record: {reason}")]
    Origin { name: String, reason: String },
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
    /// A session's processes could not be started or stopped.
    #[error("{0}")]
    Launch(String),
    /// The session (shared memory) could not be read or written. The message names the
    /// session already (every `SessionError` and `ReaderError` does), so it is not prefixed.
    #[error("{0}")]
    Session(String),
}

impl From<robosim_instance_space::ReaderError> for SceneError {
    fn from(e: robosim_instance_space::ReaderError) -> Self {
        SceneError::Session(e.to_string())
    }
}

impl From<robosim_instance_space::SessionError> for SceneError {
    fn from(e: robosim_instance_space::SessionError) -> Self {
        SceneError::Session(e.to_string())
    }
}
