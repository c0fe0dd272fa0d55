//! Writing a user-named output file: a regular file, replaced whole or not at all.

use crate::read::FileKind;
use std::fs::OpenOptions;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// An output file that was not written: the path and why. The path is left as it was.
#[derive(Debug, thiserror::Error)]
#[error("cannot write `{}`: {problem}", path.display())]
pub struct OutputError {
    pub path: PathBuf,
    #[source]
    pub problem: OutputProblem,
}

/// Why an output file was not written.
#[derive(Debug, thiserror::Error)]
pub enum OutputProblem {
    /// A device, FIFO, directory or socket is at the path: it is not replaced by a file.
    #[error(
        "it is {0}, not a regular file; robosim writes regular files only and left it as it is"
    )]
    NotRegular(FileKind),
    /// A symbolic link is at the path: neither the link nor what it points to is replaced.
    #[error(
        "it is a symbolic link (to `{}`); robosim does not write through links: name the file itself",
        target.display()
    )]
    Symlink { target: PathBuf },
    /// The path ends in `..` or is a root.
    #[error("it names no file")]
    NoFileName,
    /// A step of the write failed (`stage`: "create the temporary file", "rename", …).
    #[error("{stage}: {source}")]
    Io {
        stage: &'static str,
        source: std::io::Error,
    },
}

/// Writes `bytes` to `path` as a regular file, atomically: to a new temporary file in the same
/// directory, synced, renamed over `path`, and the directory synced, so a crash leaves the old
/// file or the new one, never part of one. Refused, with nothing changed, when something other
/// than a regular file is at `path`: a symbolic link (not followed: writing through it would
/// replace a file the user did not name), a FIFO, a device (`/dev/null`), a directory, a
/// socket. An existing file's permissions are kept.
pub fn write_file_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    use std::os::unix::fs::{OpenOptionsExt, PermissionsExt};
    let fail = |problem| OutputError {
        path: path.to_path_buf(),
        problem,
    };
    let io = |stage| move |source| fail(OutputProblem::Io { stage, source });
    let existing = check_target(path).map_err(fail)?;
    let name = path.file_name().ok_or(fail(OutputProblem::NoFileName))?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let tmp = dir.join(format!(
        ".{}.tmp-{}-{}",
        name.to_string_lossy(),
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let mode = existing.map_or(0o666, |m| m & 0o7777);
    let written = (|| {
        let mut f = OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(mode)
            .open(&tmp)
            .map_err(io("create the temporary file"))?;
        f.write_all(bytes).map_err(io("write"))?;
        if existing.is_some() {
            // The umask applied to the create; an existing file keeps exactly its mode.
            f.set_permissions(std::fs::Permissions::from_mode(mode))
                .map_err(io("set the permissions"))?;
        }
        f.sync_all().map_err(io("sync"))?;
        drop(f);
        // Checked again just before the rename: a special file put there meanwhile stays.
        check_target(path).map_err(fail)?;
        std::fs::rename(&tmp, path).map_err(io("rename the temporary file over it"))
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    std::fs::File::open(dir)
        .and_then(|d| d.sync_all())
        .map_err(io("sync its directory"))
}

/// Refuses `path` as an output file, as [`write_file_atomic`] would, when something other than
/// a regular file is there (a link, a FIFO, a device, a directory, a socket); nothing there or a
/// regular file is fine. For writers that must check several outputs before writing any.
pub fn check_output_path(path: &Path) -> Result<(), OutputError> {
    check_target(path)
        .map(|_| ())
        .map_err(|problem| OutputError {
            path: path.to_path_buf(),
            problem,
        })
}

/// What is at `path`, not following a link: nothing (`None`), a regular file (its mode), or an
/// error for anything else.
fn check_target(path: &Path) -> Result<Option<u32>, OutputProblem> {
    use std::os::unix::fs::PermissionsExt;
    match std::fs::symlink_metadata(path) {
        Ok(meta) => match FileKind::of(meta.file_type()) {
            None => Ok(Some(meta.permissions().mode())),
            Some(FileKind::Symlink) => Err(OutputProblem::Symlink {
                target: std::fs::read_link(path).unwrap_or_default(),
            }),
            Some(kind) => Err(OutputProblem::NotRegular(kind)),
        },
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(OutputProblem::Io {
            stage: "look at what is there",
            source,
        }),
    }
}
