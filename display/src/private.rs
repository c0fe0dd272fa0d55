//! Files and directories of a session's display, private to the user (mode 0600 / 0700), as
//! everything a session writes is (README; the Instance Space's `Session` does the same for
//! `data/`, `run/` and `iox2/`).
//!
//! Entry points: [`private_dir`], [`create_file`], [`append_file`]; PNGs go through
//! [`crate::RgbaImage::save_png_private`].

use crate::{DisplayError, Result};
use std::fs::{self, File, OpenOptions};
use std::os::unix::fs::{DirBuilderExt, OpenOptionsExt, PermissionsExt};
use std::path::Path;

/// Mode of every file the session display writes.
pub const FILE_MODE: u32 = 0o600;
/// Mode of every directory the session display creates.
pub const DIR_MODE: u32 = 0o700;

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> DisplayError + '_ {
    move |source| DisplayError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Creates `path` and any missing parents with mode 0700. With `tighten`, an existing `path`
/// is set to 0700 too (the session's own directories: an older version made them 0755); a
/// directory the user chose keeps its mode.
pub fn private_dir(path: &Path, tighten: bool) -> Result<()> {
    fs::DirBuilder::new()
        .recursive(true)
        .mode(DIR_MODE)
        .create(path)
        .map_err(io(path))?;
    if tighten {
        fs::set_permissions(path, fs::Permissions::from_mode(DIR_MODE)).map_err(io(path))?;
    }
    Ok(())
}

/// Opens `path` with `opts` and mode 0600: a new file is created so, an existing one is
/// tightened to it (its mode would otherwise survive the open).
fn open_private(path: &Path, opts: &mut OpenOptions) -> Result<File> {
    let f = opts.mode(FILE_MODE).open(path).map_err(io(path))?;
    let mode = f.metadata().map_err(io(path))?.permissions().mode();
    if mode & 0o777 != FILE_MODE {
        f.set_permissions(fs::Permissions::from_mode(FILE_MODE))
            .map_err(io(path))?;
    }
    Ok(f)
}

/// Creates (or truncates) `path` for writing, mode 0600.
pub fn create_file(path: &Path) -> Result<File> {
    open_private(
        path,
        OpenOptions::new().write(true).create(true).truncate(true),
    )
}

/// Opens `path` for appending (created if missing), mode 0600.
pub fn append_file(path: &Path) -> Result<File> {
    open_private(path, OpenOptions::new().create(true).append(true))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mode(p: &Path) -> u32 {
        fs::metadata(p).expect("metadata").permissions().mode() & 0o777
    }

    #[test]
    fn new_and_existing_files_and_directories_end_up_private() {
        let d = tempfile::tempdir().expect("tempdir");
        let dir = d.path().join("a/b");
        private_dir(&dir, false).expect("dir");
        assert_eq!((mode(&d.path().join("a")), mode(&dir)), (0o700, 0o700));
        // An existing wide directory: kept unless asked to tighten.
        let wide = d.path().join("wide");
        fs::create_dir(&wide).expect("mkdir");
        fs::set_permissions(&wide, fs::Permissions::from_mode(0o755)).expect("chmod");
        private_dir(&wide, false).expect("dir");
        assert_eq!(mode(&wide), 0o755);
        private_dir(&wide, true).expect("dir");
        assert_eq!(mode(&wide), 0o700);

        let f = dir.join("f");
        create_file(&f).expect("file");
        assert_eq!(mode(&f), 0o600);
        fs::set_permissions(&f, fs::Permissions::from_mode(0o644)).expect("chmod");
        append_file(&f).expect("append");
        assert_eq!(mode(&f), 0o600);
        fs::set_permissions(&f, fs::Permissions::from_mode(0o666)).expect("chmod");
        create_file(&f).expect("file");
        assert_eq!(mode(&f), 0o600);
    }
}
