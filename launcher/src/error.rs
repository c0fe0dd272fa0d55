//! [`LaunchError`]: why a session could not be started, listed or stopped.

use robosim_instance_space::{ClientError, KeeperError, ReaderError, SessionError, TxError};

/// Why `robosim up / ps / down / space` failed. The message names what and where; the
/// variants that wrap another crate's error print its message unchanged (each already names the
/// session, file or scene).
#[derive(Debug, thiserror::Error)]
pub enum LaunchError {
    /// A session's processes could not be started, waited for or stopped, or the request
    /// contradicts what the session holds (the message says what to do instead).
    #[error("{0}")]
    Process(String),
    /// A process of the session could not be spawned from the running executable.
    #[error("cannot start {role}: {source}")]
    Start {
        role: String,
        #[source]
        source: std::io::Error,
    },
    /// A file the launcher reads or writes itself (the executable, a log, a model file's path).
    #[error("{what}: {source}")]
    Io {
        what: &'static str,
        #[source]
        source: std::io::Error,
    },
    /// An environment variable the keeper reads has a value it cannot use.
    #[error("{0}")]
    Environment(String),
    /// The session's directory, registry or notes.
    #[error(transparent)]
    Session(#[from] SessionError),
    /// The keeper could not start, publish or serve.
    #[error(transparent)]
    Keeper(#[from] KeeperError),
    /// The launcher's own connection to the keeper.
    #[error(transparent)]
    Client(#[from] ClientError),
    /// The launcher's reader of the session's model.
    #[error(transparent)]
    Reader(#[from] ReaderError),
    /// The scene (its library, its name, its instantiation).
    #[error(transparent)]
    Scene(#[from] robosim_scene::SceneError),
    /// The model file a keeper is started from (`--load FILE`).
    #[error(transparent)]
    File(#[from] robosim_file_io::FileError),
    /// A preloaded model that cannot become a transaction on the recovered model.
    #[error("{what}: {source}")]
    Preload {
        what: String,
        #[source]
        source: robosim_file_io::ModelProblem,
    },
    /// The keeper refused the scene's or the file's transaction.
    #[error("{what}: {source}")]
    Refused {
        what: String,
        #[source]
        source: TxError,
    },
}
