//! Resolving the mesh file names of a URDF (`<mesh filename="…">`) to paths on this machine.
//!
//! * `package://NAME/REST` — the directory of ROS package NAME, then REST. NAME is looked for,
//!   in order, (1) in each directory of `ROS_PACKAGE_PATH` (`:`-separated): the directory itself
//!   when its last component is NAME, else its subdirectory NAME; (2) among the URDF file's
//!   ancestors (its own directory first, up to the file system root): an ancestor named NAME,
//!   or an ancestor's subdirectory NAME. The first directory found is the package (ROS's
//!   `package.xml` is not required, and no recursive crawl is made). A package found whose REST
//!   does not exist is [`Resolved::Missing`], not a search for another package of that name.
//! * `file:///abs/path` — that absolute path (`file://` followed by a relative path is taken
//!   relative to the URDF's directory, as urdfdom's resource retrievers do for bare paths).
//! * a bare path — relative to the URDF's directory (absolute stays absolute).
//! * any other scheme (`http://`, `model://`, …) is refused.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

/// Why a mesh file name does not name a file (see the module docs).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ResolveError {
    #[error("package {package:?} not found (searched ROS_PACKAGE_PATH and the URDF's ancestors: {})", searched.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "))]
    UnknownPackage {
        package: String,
        searched: Vec<PathBuf>,
    },
    #[error("{0:?}: a package:// URI needs a package name and a path (package://NAME/PATH)")]
    BadPackageUri(String),
    #[error("URI scheme of {0:?} is not supported (package://, file:// and plain paths are)")]
    UnsupportedScheme(String),
}

/// Resolves `uri` for the URDF at `urdf`, with `ros_package_path` the value of
/// `ROS_PACKAGE_PATH` (`None`: not set). The path returned may not exist (the caller reports it).
pub fn resolve(
    uri: &str,
    urdf: &Path,
    ros_package_path: Option<&OsStr>,
) -> Result<PathBuf, ResolveError> {
    let dir = urdf
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    let dir = if dir.as_os_str().is_empty() {
        PathBuf::from(".")
    } else {
        dir
    };
    if let Some(rest) = uri.strip_prefix("package://") {
        let (name, tail) = rest
            .split_once('/')
            .filter(|(n, t)| !n.is_empty() && !t.is_empty())
            .ok_or_else(|| ResolveError::BadPackageUri(uri.to_string()))?;
        let mut searched = Vec::new();
        if let Some(rpp) = ros_package_path {
            for d in std::env::split_paths(rpp).filter(|d| !d.as_os_str().is_empty()) {
                if let Some(p) = package_at(&d, name) {
                    return Ok(p.join(tail));
                }
                searched.push(d);
            }
        }
        let start = std::fs::canonicalize(&dir).unwrap_or(dir);
        for a in start.ancestors() {
            if let Some(p) = package_at(a, name) {
                return Ok(p.join(tail));
            }
            searched.push(a.to_path_buf());
        }
        return Err(ResolveError::UnknownPackage {
            package: name.to_string(),
            searched,
        });
    }
    if let Some(rest) = uri.strip_prefix("file://") {
        let p = Path::new(rest);
        return Ok(if p.is_absolute() {
            p.to_path_buf()
        } else {
            dir.join(p)
        });
    }
    if let Some((scheme, _)) = uri.split_once("://")
        && !scheme.is_empty()
        && scheme
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '+' || c == '-' || c == '.')
    {
        return Err(ResolveError::UnsupportedScheme(uri.to_string()));
    }
    let p = Path::new(uri);
    Ok(if p.is_absolute() {
        p.to_path_buf()
    } else {
        dir.join(p)
    })
}

/// `d` itself when it is named `name`, else `d/name`, when that is a directory.
fn package_at(d: &Path, name: &str) -> Option<PathBuf> {
    if d.file_name() == Some(OsStr::new(name)) && d.is_dir() {
        return Some(d.to_path_buf());
    }
    let sub = d.join(name);
    sub.is_dir().then_some(sub)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn package_file_and_relative_uris_resolve() {
        let tmp = tempfile::tempdir().expect("tmp");
        let root = tmp.path();
        std::fs::create_dir_all(root.join("ws/src/my_pkg/meshes")).expect("mkdir");
        std::fs::create_dir_all(root.join("ws/src/my_pkg/urdf")).expect("mkdir");
        std::fs::create_dir_all(root.join("other/pkg_b")).expect("mkdir");
        let urdf = root.join("ws/src/my_pkg/urdf/r.urdf");
        // Ancestor named like the package.
        let p = resolve("package://my_pkg/meshes/a.stl", &urdf, None).expect("found");
        assert!(p.ends_with("my_pkg/meshes/a.stl"), "{p:?}");
        // A sibling of an ancestor (ancestor's subdirectory).
        let p = resolve("package://my_pkg/x.stl", &root.join("ws/r.urdf"), None);
        assert!(
            matches!(p, Err(ResolveError::UnknownPackage { .. })),
            "{p:?}"
        );
        let p = resolve("package://src/my_pkg/x.stl", &root.join("ws/r.urdf"), None)
            .expect("ws/src found as a subdirectory of the urdf's directory");
        assert!(p.ends_with("ws/src/my_pkg/x.stl"));
        // ROS_PACKAGE_PATH: a directory holding the package, and the package directory itself.
        let rpp = std::env::join_paths([root.join("nothing"), root.join("other")]).expect("join");
        let p = resolve("package://pkg_b/m.obj", &urdf, Some(&rpp)).expect("found");
        assert_eq!(p, root.join("other/pkg_b/m.obj"));
        let rpp = root.join("other/pkg_b").into_os_string();
        let p = resolve("package://pkg_b/m.obj", &urdf, Some(&rpp)).expect("found");
        assert_eq!(p, root.join("other/pkg_b/m.obj"));
        // Unknown package: an error listing where it looked.
        match resolve("package://nope/m.stl", &urdf, Some(&rpp)) {
            Err(ResolveError::UnknownPackage { package, searched }) => {
                assert_eq!(package, "nope");
                assert_eq!(searched[0], root.join("other/pkg_b"));
                assert!(searched.len() > 3);
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            resolve("package://nope", &urdf, None),
            Err(ResolveError::BadPackageUri(_))
        ));
        // file:// and plain paths.
        assert_eq!(
            resolve("file:///abs/m.stl", &urdf, None).expect("ok"),
            PathBuf::from("/abs/m.stl")
        );
        assert_eq!(
            resolve("../meshes/m.stl", &urdf, None).expect("ok"),
            root.join("ws/src/my_pkg/urdf/../meshes/m.stl")
        );
        assert_eq!(
            resolve("m.stl", Path::new("r.urdf"), None).expect("ok"),
            PathBuf::from("./m.stl")
        );
        assert!(matches!(
            resolve("http://example.com/m.stl", &urdf, None),
            Err(ResolveError::UnsupportedScheme(_))
        ));
    }
}
