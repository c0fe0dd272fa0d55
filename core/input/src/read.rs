//! Reading a user-named file: a regular file only, at most a limit's bytes.

use crate::limit::{Limit, LimitError, format_bytes};
use std::fs::{File, FileType};
use std::io::Read;
use std::path::{Path, PathBuf};

/// What a path is when it is not a regular file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileKind {
    Directory,
    /// A named pipe: opening it for reading blocks until a writer comes.
    Fifo,
    /// `/dev/zero`, `/dev/null`, a terminal: endless or empty, never a file's contents.
    CharDevice,
    BlockDevice,
    Socket,
    /// Only seen without following links (the writer's check, [`crate::write_file_atomic`]).
    Symlink,
    Other,
}

impl FileKind {
    /// `None` for a regular file.
    pub fn of(t: FileType) -> Option<FileKind> {
        use std::os::unix::fs::FileTypeExt;
        Some(if t.is_file() {
            return None;
        } else if t.is_dir() {
            FileKind::Directory
        } else if t.is_fifo() {
            FileKind::Fifo
        } else if t.is_char_device() {
            FileKind::CharDevice
        } else if t.is_block_device() {
            FileKind::BlockDevice
        } else if t.is_socket() {
            FileKind::Socket
        } else if t.is_symlink() {
            FileKind::Symlink
        } else {
            FileKind::Other
        })
    }
}

impl std::fmt::Display for FileKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FileKind::Directory => "a directory",
            FileKind::Fifo => "a FIFO (named pipe)",
            FileKind::CharDevice => "a character device",
            FileKind::BlockDevice => "a block device",
            FileKind::Socket => "a socket",
            FileKind::Symlink => "a symbolic link",
            FileKind::Other => "neither a file nor a directory",
        })
    }
}

/// A file that could not be read: the path, what it was to be (`"a URDF file"`) and why.
#[derive(Debug, thiserror::Error)]
#[error("cannot read {what} `{}`: {problem}", path.display())]
pub struct InputError {
    pub path: PathBuf,
    pub what: &'static str,
    #[source]
    pub problem: InputProblem,
}

/// Why a file could not be read (the sentence follows "cannot read … `path`: ").
#[derive(Debug, thiserror::Error)]
pub enum InputProblem {
    /// The open or a read failed (no such file, no permission, an I/O error).
    #[error("{0}")]
    Io(std::io::Error),
    /// A directory, FIFO, device or socket.
    #[error("it is {0}, not a regular file")]
    NotRegular(FileKind),
    /// Larger than the limit: `size` is the file's size when it was known before reading (a
    /// file that grew while read has none).
    #[error("{}", too_large(*size, *limit, what, *env))]
    TooLarge {
        size: Option<u64>,
        limit: u64,
        what: &'static str,
        env: Option<&'static str>,
    },
    /// [`read_to_string`] of bytes that are not UTF-8.
    #[error("it is not UTF-8 text (invalid byte at offset {0})")]
    NotUtf8(usize),
    /// The limit's environment variable does not hold a size.
    #[error(transparent)]
    Limit(LimitError),
}

fn too_large(size: Option<u64>, limit: u64, what: &str, env: Option<&str>) -> String {
    let mut s = format!(
        "it is larger than {}, the limit for {what}",
        format_bytes(limit)
    );
    let mut notes = Vec::new();
    if let Some(size) = size {
        notes.push(format!("it has {size} bytes"));
    }
    if let Some(var) = env {
        notes.push(format!("set {var} to raise the limit"));
    }
    if !notes.is_empty() {
        s.push_str(&format!(" ({})", notes.join("; ")));
    }
    s
}

impl InputError {
    /// The reason alone, for callers whose own error already names the path.
    pub fn reason(&self) -> String {
        self.problem.to_string()
    }
}

/// Opens `path` for reading if it is a regular file (symbolic links followed), and returns it
/// with its size. The type is checked before the open — a FIFO's open would block until a
/// writer comes, a device's open may act on the device — and again on the opened file, which
/// is opened non-blocking, so a path swapped for a FIFO in between is refused too.
pub fn open_regular(path: &Path, what: &'static str) -> Result<(File, u64), InputError> {
    use std::os::unix::fs::OpenOptionsExt;
    let fail = |problem| InputError {
        path: path.to_path_buf(),
        what,
        problem,
    };
    let meta = std::fs::metadata(path).map_err(|e| fail(InputProblem::Io(e)))?;
    if let Some(kind) = FileKind::of(meta.file_type()) {
        return Err(fail(InputProblem::NotRegular(kind)));
    }
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY)
        .open(path)
        .map_err(|e| fail(InputProblem::Io(e)))?;
    let meta = file.metadata().map_err(|e| fail(InputProblem::Io(e)))?;
    if let Some(kind) = FileKind::of(meta.file_type()) {
        return Err(fail(InputProblem::NotRegular(kind)));
    }
    Ok((file, meta.len()))
}

/// Reads the regular file at `path` whole, refusing it when it is larger than `limit` (a file
/// that grows while read is cut one byte past the limit and refused: at most `limit + 1` bytes
/// are ever held). `what` names the input in errors: `"a URDF file"`, `"a mesh file"`.
pub fn read_file(path: &Path, what: &'static str, limit: Limit) -> Result<Vec<u8>, InputError> {
    let fail = |problem| InputError {
        path: path.to_path_buf(),
        what,
        problem,
    };
    let max = limit.bytes().map_err(|e| fail(InputProblem::Limit(e)))?;
    let too_large = |size| {
        fail(InputProblem::TooLarge {
            size,
            limit: max,
            what,
            env: limit.env,
        })
    };
    let (file, len) = open_regular(path, what)?;
    if len > max {
        return Err(too_large(Some(len)));
    }
    // The size is a hint (the file may change); the take is the bound.
    let mut bytes = Vec::with_capacity(usize::try_from(len).unwrap_or(0).saturating_add(1));
    file.take(max.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| fail(InputProblem::Io(e)))?;
    if bytes.len() as u64 > max {
        return Err(too_large(None));
    }
    Ok(bytes)
}

/// [`read_file`] of UTF-8 text.
pub fn read_to_string(path: &Path, what: &'static str, limit: Limit) -> Result<String, InputError> {
    let bytes = read_file(path, what, limit)?;
    String::from_utf8(bytes).map_err(|e| InputError {
        path: path.to_path_buf(),
        what,
        problem: InputProblem::NotUtf8(e.utf8_error().valid_up_to()),
    })
}
