//! What can go wrong reading, writing, loading and exchanging model files. Every variant names
//! the file (or the session) and says what was wrong where; none of them leaves a session
//! changed (a load is one transaction: refused whole or applied whole).

use robosim_instance_space::{Id, TxError};
use std::path::PathBuf;

/// A problem with the objects a model file holds (checked before anything is sent).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelProblem {
    #[error("object {index} has id 0 (0 means \"no object\")")]
    ZeroId { index: usize },
    #[error("objects {first} and {second} both have id {id}")]
    DuplicateId { id: Id, first: usize, second: usize },
    #[error("object {id} ({name:?}) names parent {parent}, which is not in the file")]
    MissingParent { id: Id, name: String, parent: Id },
    #[error("object {id} ({name:?}) is its own ancestor (the parent links form a cycle)")]
    Cycle { id: Id, name: String },
}

/// Why a file operation failed.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error(
        "{path}: not a robosim model file (it starts neither with the model file magic nor with a JSON object)"
    )]
    Magic { path: PathBuf },
    #[error(
        "{path}: truncated: the header announces {expected} bytes, the file has {found} (an interrupted copy or write?)"
    )]
    Truncated {
        path: PathBuf,
        expected: u64,
        found: u64,
    },
    #[error(
        "{path}: written in model format version {found}, newer than this build reads (up to {supported}); load it with a newer robosim"
    )]
    FutureFormat {
        path: PathBuf,
        found: u32,
        supported: u32,
    },
    #[error("{path}: model format version {found} does not exist (versions start at 1)")]
    UnknownFormat { path: PathBuf, found: u32 },
    #[error(
        "{path}: checksum mismatch (stored crc32 {stored:08x}, computed {computed:08x}): the file was damaged or edited; the JSON form is the one to edit"
    )]
    Checksum {
        path: PathBuf,
        stored: u32,
        computed: u32,
    },
    #[error("{path}: {reason}")]
    Decode { path: PathBuf, reason: String },
    #[error("{path}: invalid model: {problem}")]
    Model {
        path: PathBuf,
        problem: ModelProblem,
    },
    #[error("{path}: {what} {field} is {value}, which JSON cannot hold; save in the binary form")]
    NotJsonable {
        path: PathBuf,
        what: String,
        field: String,
        value: f64,
    },
    #[error("{path}: session {session} refused the file's object {id} ({name:?}): {source}")]
    Refused {
        path: PathBuf,
        session: String,
        id: Id,
        name: String,
        source: Box<TxError>,
    },
    #[error("{path}: session {session} refused the load: {source}")]
    RefusedWhole {
        path: PathBuf,
        session: String,
        source: Box<TxError>,
    },
    #[error("{path}:{line}: {reason}")]
    Mesh {
        path: PathBuf,
        line: usize,
        reason: String,
    },
    #[error("{0}")]
    Usage(String),
    #[error(transparent)]
    Session(#[from] robosim_instance_space::SessionError),
    #[error(transparent)]
    Reader(#[from] robosim_instance_space::ReaderError),
    #[error(transparent)]
    Client(#[from] robosim_instance_space::ClientError),
    #[error(transparent)]
    Scene(#[from] robosim_scene::SceneError),
    /// A URDF file that cannot be imported (file, line, element and what).
    #[error(transparent)]
    Urdf(#[from] crate::urdf_import::UrdfError),
    /// A URDF robot whose geometry makes no Instance Space objects (`robosim import urdf`).
    #[error(transparent)]
    UrdfTx(#[from] UrdfTxError),
    /// An MJCF file that cannot be imported (file, line, element and what).
    #[error(transparent)]
    Mjcf(#[from] crate::mjcf::MjcfError),
    /// An input file that is not a regular file, or is larger than its limit, or cannot be read
    /// ([`robosim_input::read_file`]).
    #[error(transparent)]
    Input(#[from] robosim_input::InputError),
    /// An output file that was not written: something other than a regular file is at its path
    /// (a link, a FIFO, a device), or a step of the atomic write failed
    /// ([`robosim_input::write_file_atomic`]).
    #[error(transparent)]
    Output(#[from] robosim_input::OutputError),
}

impl From<robosim_urdf::stl::MeshFileError> for FileError {
    fn from(e: robosim_urdf::stl::MeshFileError) -> Self {
        FileError::Mesh {
            path: e.path,
            line: e.line,
            reason: e.reason,
        }
    }
}

/// Why a URDF robot makes no transaction (`urdf_session::urdf_tx`).
#[derive(Debug, thiserror::Error)]
pub enum UrdfTxError {
    /// The URDF: a mesh it names that cannot be read, a primitive that makes no solid, a joint
    /// without its origin — its file, line, element and what.
    #[error(transparent)]
    Urdf(#[from] crate::urdf_import::UrdfError),
    /// A mesh's triangles make no Instance Space geometry (none left once the degenerate ones
    /// are dropped, a flat hull, …): the URDF file, line and element that name the mesh, and
    /// the mesh importer's error (`import::mesh_geometry`, `hull_geometry`).
    #[error("{}:{line}: {element}: {role}: {source}", file.display())]
    MeshGeometry {
        file: std::path::PathBuf,
        line: u32,
        element: String,
        /// What the mesh was being made into: "collision solid" or "visual geometry".
        role: &'static str,
        #[source]
        source: Box<crate::FileError>,
    },
}
