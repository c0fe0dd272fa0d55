//! The commands of the file interface: one argument struct (plain types) and one run function
//! per command; the binary parses the command line into them (src/cli/file_io.rs) and passes
//! `--session`.
//!
//! `robosim save FILE`, `load FILE [--merge|--replace]`, `info [FILE]`, `export [FORMAT] FILE`,
//! `import mesh FILE --as NAME --at x,y,z[,r,p,y]` (`up --load FILE` and `space --load FILE`
//! are the launcher's, robosim-launcher).

use crate::error::FileError;
use crate::format::{self, Encoding};
use crate::model::LoadMode;
use crate::session::{self, Info};
use robosim_instance_space::{Appearance, Kind, Reader, Session};
use std::path::{Path, PathBuf};

type Result<T> = std::result::Result<T, FileError>;

/// `robosim save FILE`
#[derive(Debug)]
pub struct SaveArgs {
    /// The model file: binary (checksummed), or JSON when the name ends in .json.
    pub file: PathBuf,
    /// Write the readable JSON form whatever the name.
    pub json: bool,
}

pub fn save(a: &SaveArgs, session: Option<&str>) -> Result<()> {
    let s = Session::open(session)?;
    let enc = if a.json {
        Encoding::Json
    } else {
        Encoding::from_path(&a.file)
    };
    let r = session::save(&s, &a.file, enc)?;
    println!(
        "saved session {} at version {} to {}: {} objects, {} bytes, digest {}",
        s.name(),
        r.version,
        a.file.display(),
        r.objects,
        r.bytes,
        r.digest
    );
    Ok(())
}

/// `robosim load FILE`
#[derive(Debug)]
pub struct LoadArgs {
    /// A model file written by `robosim save` (binary or JSON, told apart by content).
    pub file: PathBuf,
    /// Add the file's objects beside the session's (new ids) instead of replacing them.
    pub merge: bool,
    /// Delete every object of the session and create the file's (the default).
    pub replace: bool,
}

pub fn load(a: &LoadArgs, session: Option<&str>) -> Result<()> {
    let s = Session::open(session)?;
    let mode = if a.merge {
        LoadMode::Merge
    } else {
        LoadMode::Replace
    };
    let r = session::load(&s, &a.file, mode)?;
    if !r.missing_library.is_empty() {
        eprintln!(
            "robosim load: the file's Library Space files {} are not in session {}'s (a running keeper's library cannot grow); the objects loaded, but `robosim set` cannot re-instantiate instances of their declarations — start the session with `robosim up --load {}` to have them",
            r.missing_library.join(", "),
            s.name(),
            a.file.display()
        );
    }
    println!(
        "loaded {} into session {} ({}): {} objects created, {} deleted, version {}",
        a.file.display(),
        s.name(),
        if a.merge { "merge" } else { "replace" },
        r.created,
        r.deleted,
        r.version
    );
    Ok(())
}

/// `robosim info [FILE]`
#[derive(Debug)]
pub struct InfoArgs {
    /// Describe this model file instead of a session's model.
    pub file: Option<PathBuf>,
}

pub fn info(a: &InfoArgs, session: Option<&str>) -> Result<()> {
    let info = match &a.file {
        Some(f) => Info::of(&format::read(f)?),
        None => session::info(&Session::open(session)?)?,
    };
    print!("{info}");
    Ok(())
}

/// `robosim export [FORMAT] FILE`
#[derive(Debug)]
pub struct ExportArgs {
    /// `[gltf|stl|trajectory|urdf] FILE`; without a format, the file's extension says
    /// (.glb, .stl, .csv, .urdf).
    pub what: Vec<String>,
    /// Export a Library Space declaration instantiated with its defaults, without a session.
    pub scene: Option<String>,
    /// Library files to add to the standard library (with --scene).
    pub library: Vec<PathBuf>,
    /// STL: only this object and what hangs under it (by name).
    pub body: Option<String>,
    /// Trajectory and URDF: the robot (default: the session's or scene's only robot).
    pub robot: Option<String>,
    /// Trajectory: the simulator log to read (default: the session's run/simulator-ROBOT.csv).
    pub log: Option<PathBuf>,
    /// Trajectory: seconds between two log rows, for a log without a time column.
    pub dt: Option<f64>,
    /// URDF and MJCF: `absolute`, `relative` or `file-uri` mesh file names ([`MeshPaths`];
    /// `None`: the format's default).
    pub mesh_paths: Option<String>,
}

/// How an exported URDF or MJCF names the mesh files written beside it (docs/file-io.md,
/// "Mesh paths"). Pinocchio 4.1's URDF reader finds a relative name only under its
/// `package_dirs` (not the URDF's folder, not the working directory) and MuJoCo 4.0 opens no
/// `file://` or `package://` name, so no one form opens everywhere with no flags.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshPaths {
    /// The file's absolute path: MuJoCo and Pinocchio open it with no flags (URDF's default).
    Absolute,
    /// The file's name, relative to the export's folder: the folder can be moved; MuJoCo (URDF
    /// and MJCF) and Pinocchio's MJCF reader find it, Pinocchio's URDF reader needs
    /// `package_dirs=[folder]` (MJCF's default).
    Relative,
    /// `file://` and the absolute path (URDF only): ROS's resource retriever and Pinocchio open
    /// it, MuJoCo does not.
    FileUri,
}

impl MeshPaths {
    fn parse(mode: Option<&str>, mjcf: bool) -> Result<MeshPaths> {
        match mode {
            None if mjcf => Ok(MeshPaths::Relative),
            None | Some("absolute") => Ok(MeshPaths::Absolute),
            Some("relative") => Ok(MeshPaths::Relative),
            Some("file-uri") if !mjcf => Ok(MeshPaths::FileUri),
            Some("file-uri") => Err(FileError::Usage(
                "--mesh-paths file-uri is for URDF (MuJoCo opens no file:// mesh name); say absolute or relative".into(),
            )),
            Some(other) => Err(FileError::Usage(format!(
                "--mesh-paths {other:?}: say absolute, relative or file-uri"
            ))),
        }
    }
}

/// The export formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Gltf,
    Stl,
    Trajectory,
    Urdf,
    Mjcf,
}

fn export_format(what: &[String]) -> Result<(Format, PathBuf)> {
    let parse = |f: &str| match f.to_ascii_lowercase().as_str() {
        "gltf" | "glb" => Ok(Format::Gltf),
        "stl" => Ok(Format::Stl),
        "trajectory" | "csv" => Ok(Format::Trajectory),
        "urdf" => Ok(Format::Urdf),
        "mjcf" | "xml" => Ok(Format::Mjcf),
        other => Err(FileError::Usage(format!(
            "unknown export format {other:?}: gltf, stl, trajectory, urdf or mjcf"
        ))),
    };
    match what {
        [f, file] => Ok((parse(f)?, PathBuf::from(file))),
        [file] => {
            let p = PathBuf::from(file);
            let ext = p
                .extension()
                .and_then(|e| e.to_str())
                .unwrap_or("")
                .to_owned();
            Ok((
                parse(&ext).map_err(|_| {
                    FileError::Usage(format!(
                        "{file}: say the format (gltf, stl, trajectory, urdf, mjcf) or use .glb, .stl, .csv, .urdf or .xml"
                    ))
                })?,
                p,
            ))
        }
        _ => Err(FileError::Usage("export [FORMAT] FILE".into())),
    }
}

pub fn export(a: &ExportArgs, session: Option<&str>) -> Result<()> {
    let (fmt, out) = export_format(&a.what)?;
    if fmt == Format::Trajectory {
        return export_trajectory(a, session, &out);
    }
    if matches!(fmt, Format::Urdf | Format::Mjcf) {
        return export_robot(a, session, &out, fmt);
    }
    let (model, what) = match &a.scene {
        Some(name) => (
            crate::scene_model(name, &a.library)?,
            format!("scene {name}"),
        ),
        None => {
            let s = Session::open(session)?;
            (session::read_session(&s)?, format!("session {}", s.name()))
        }
    };
    match fmt {
        Format::Gltf => {
            let (bytes, st) = crate::gltf::to_glb(&model).ok_or_else(|| {
                FileError::Usage(format!("{what}: the model's structure is invalid"))
            })?;
            format::write_atomic(&out, &bytes)?;
            println!(
                "exported {what} to {}: {} nodes, {} meshes, {} triangles, {} materials",
                out.display(),
                st.nodes,
                st.meshes,
                st.triangles,
                st.materials
            );
        }
        Format::Stl => {
            let roots: Option<Vec<u64>> = match &a.body {
                None => None,
                Some(name) => {
                    let ids: Vec<u64> = model
                        .objects
                        .iter()
                        .filter(|o| o.name == *name)
                        .map(|o| o.id)
                        .collect();
                    match ids.len() {
                        0 => {
                            return Err(FileError::Usage(format!("{what} has no object {name:?}")));
                        }
                        1 => Some(ids),
                        n => {
                            return Err(FileError::Usage(format!(
                                "{what} has {n} objects named {name:?} (ids {ids:?}); rename one first"
                            )));
                        }
                    }
                }
            };
            let label = a
                .body
                .as_deref()
                .map_or(what.clone(), |b| format!("{what}, body {b}"));
            let (bytes, n) =
                crate::stl::to_stl(&model, roots.as_deref(), &label).ok_or_else(|| {
                    FileError::Usage(format!("{what}: the model's structure is invalid"))
                })?;
            format::write_atomic(&out, &bytes)?;
            println!(
                "exported {label} to {}: {n} triangles (world frame, m)",
                out.display()
            );
        }
        Format::Trajectory | Format::Urdf | Format::Mjcf => {}
    }
    Ok(())
}

/// `robosim export robot.urdf|robot.xml [--robot NAME] (--session S | --scene NAME)`: a robot of
/// a session or of a library scene, at its placement there, as URDF ([`crate::urdf`]) or MJCF
/// ([`crate::mjcf_export`]).
fn export_robot(a: &ExportArgs, session: Option<&str>, out: &Path, fmt: Format) -> Result<()> {
    let robots = match &a.scene {
        Some(name) => crate::export_robot_models(name, &a.library)?,
        None => {
            let s = Session::open(session)?;
            let mut reader = Reader::attach(&s, "file-io")?;
            // the session's Library Space: the declarations its robots were made from
            let library = reader.library_files()?;
            let snap = reader
                .snapshot()
                .ok_or_else(|| FileError::Usage(format!("session {}: no model", s.name())))?;
            crate::session_robot_models(&snap, &library)
        }
    };
    let names: Vec<&str> = robots.iter().map(|r| r.robot.name.as_str()).collect();
    let chosen = match &a.robot {
        Some(want) => robots
            .iter()
            .find(|r| r.robot.name == *want)
            .ok_or_else(|| {
                FileError::Usage(format!(
                    "no robot {want:?} to export; robots: {}",
                    names.join(", ")
                ))
            })?,
        None => match robots.as_slice() {
            [one] => one,
            _ => {
                return Err(FileError::Usage(format!(
                    "say which robot with --robot: {}",
                    names.join(", ")
                )));
            }
        },
    };
    // Mesh files beside the robot's file, named after it: `<stem>_<shape>.stl`.
    let stem = out
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("robot")
        .to_string();
    let dir = out.parent().unwrap_or(Path::new(""));
    let mesh_paths = MeshPaths::parse(a.mesh_paths.as_deref(), fmt == Format::Mjcf)?;
    let prefix = match mesh_paths {
        MeshPaths::Relative => format!("{stem}_"),
        MeshPaths::Absolute | MeshPaths::FileUri => {
            let abs = std::path::absolute(dir.join(format!("{stem}_"))).map_err(|source| {
                FileError::Io {
                    path: dir.to_path_buf(),
                    source,
                }
            })?;
            let abs = abs.to_str().ok_or_else(|| {
                FileError::Usage(format!(
                    "{}: the folder's name is not UTF-8, which a mesh file name in the export must be; use --mesh-paths relative",
                    dir.display()
                ))
            })?;
            match mesh_paths {
                MeshPaths::FileUri => format!("file://{abs}"),
                _ => abs.to_string(),
            }
        }
    };
    let (robot, coupling, geometry) = (
        &chosen.robot,
        chosen.coupling.as_ref(),
        chosen.geometry.as_ref(),
    );
    // The shapes written (an object the writers leave out — a mesh file that cannot be read —
    // is in the notes, not in this count), their mesh files read once, here.
    let export = geometry.map(crate::export_geometry::ExportShapes::of);
    let shapes = export.as_ref().map_or(0, |e| e.shapes.len());
    let (text, notes, meshes) = if fmt == Format::Mjcf {
        crate::mjcf_export::to_mjcf_with_shapes(robot, coupling, export, &prefix)
    } else {
        crate::urdf::to_urdf_with_shapes(robot, coupling, export, &prefix)
    }
    .map_err(FileError::Usage)?;
    for m in &meshes {
        // (an absolute name replaces `dir` in the join)
        let file = m.file.strip_prefix("file://").unwrap_or(&m.file);
        format::write_atomic(&dir.join(file), &m.bytes)?;
    }
    format::write_atomic(out, text.as_bytes())?;
    let general = !robot.is_chain() || robot.joints.iter().any(|j| j.is_general());
    let what = match (fmt, robot.convention) {
        (Format::Mjcf, _) => "as MJCF bodies".to_string(),
        _ if general => "as URDF origins and axes".to_string(),
        (_, robosim_kinematics::Convention::Standard) => {
            "standard convention DH as URDF origins and z axes".to_string()
        }
        (_, robosim_kinematics::Convention::Modified) => {
            "modified convention DH as URDF origins and z axes".to_string()
        }
    };
    let followers = coupling.map_or(0, |c| c.full_dof() - c.reduced_dof());
    println!(
        "exported robot {} to {}: {} joints {what}{}; {shapes} shapes, {} mesh files beside it{}",
        robot.name,
        out.display(),
        robot.dof(),
        if followers > 0 {
            format!(
                " ({followers} mimic {}: {})",
                if followers == 1 { "joint" } else { "joints" },
                if fmt == Format::Mjcf {
                    "<equality><joint>"
                } else {
                    "<mimic>"
                }
            )
        } else {
            String::new()
        },
        meshes.len(),
        if geometry.is_none() {
            " (no library declaration of this robot to take its geometry and friction from)"
        } else {
            ""
        }
    );
    for n in notes.iter().chain(&chosen.notes) {
        println!("  note: {n}");
    }
    Ok(())
}

fn export_trajectory(a: &ExportArgs, session: Option<&str>, out: &Path) -> Result<()> {
    let s = Session::open(session)?;
    let reader = Reader::attach(&s, "file-io")?;
    let snap = reader
        .snapshot()
        .ok_or_else(|| FileError::Usage(format!("session {}: no model", s.name())))?;
    let robot = match &a.robot {
        Some(r) => r.clone(),
        None => {
            let robots = snap.robots();
            match robots.as_slice() {
                [one] => one.name.to_owned(),
                _ => {
                    let names: Vec<&str> = robots.iter().map(|r| r.name).collect();
                    return Err(FileError::Usage(format!(
                        "say which robot with --robot: {}",
                        names.join(", ")
                    )));
                }
            }
        }
    };
    let columns = crate::trajectory::joint_columns(&snap, &robot)?;
    let log = a
        .log
        .clone()
        .unwrap_or_else(|| s.run_dir().join(format!("simulator-{robot}.csv")));
    let rows = crate::trajectory::export(&log, &columns, a.dt, out)?;
    println!(
        "exported {robot}'s trajectory from {} to {}: {rows} samples, columns t_s,{}",
        log.display(),
        out.display(),
        columns.join(",")
    );
    Ok(())
}

/// `robosim import …`
#[derive(Debug)]
pub enum ImportCmd {
    /// An STL (binary or ASCII) or OBJ mesh as an item placed in the scene (one transaction).
    Mesh(ImportMeshArgs),
    /// A URDF robot — its whole tree, general joints, inertials, visuals and collision shapes
    /// (meshes as convex hulls) — as a robot placed in the scene (one transaction;
    /// docs/file-io.md, "URDF into a session").
    Urdf(ImportUrdfArgs),
    /// An MJCF (MuJoCo) robot — its hinge and slide joints, inertials, geoms — the same way
    /// (docs/file-io.md, "MJCF import"); the arguments are the URDF import's.
    Mjcf(ImportUrdfArgs),
}

#[derive(Debug)]
pub struct ImportUrdfArgs {
    /// The URDF file (`package://` meshes are found through ROS_PACKAGE_PATH and the file's
    /// ancestors; xacro files are refused: run xacro first).
    pub file: PathBuf,
    /// The robot's name in the session (default: the URDF's `<robot name>`).
    pub name: Option<String>,
    /// Position (m) and optionally roll, pitch, yaw (deg) of the root link in the parent's frame.
    pub at: String,
    /// The scene to place it in (default: the session's first scene).
    pub parent: Option<String>,
    /// Leave the `<visual>`s out (their meshes are not read; the collision solids are drawn).
    pub no_visuals: bool,
    /// A floating base: `free_flyer` or `planar` root joint between the scene and the root
    /// link (Pinocchio's `buildModel(urdf, JointModelFreeFlyer())`); `None`: fixed, unless
    /// the file's root joint is itself floating or planar. URDF only.
    pub floating: Option<robosim_kinematics::RootKind>,
    /// `<mimic>` followers as mimic joints: the session robot's coordinates are the reduced
    /// ones ([`crate::urdf_session::UrdfPlacement::mimic`]). URDF only.
    pub mimic: bool,
}

#[derive(Debug)]
pub struct ImportMeshArgs {
    /// The mesh file (.stl or .obj).
    pub file: PathBuf,
    /// The item's name (its solid is NAME-mesh).
    pub name: String,
    /// Position (m) and optionally roll, pitch, yaw (deg) in the parent's frame.
    pub at: String,
    /// File units to metres (e.g. 0.001 for a file in millimetres).
    pub scale: f64,
    /// Keep the convex hull instead of the mesh.
    pub hull: bool,
    /// r,g,b[,a] in 0..1.
    pub color: Option<String>,
    /// The scene to place it in (default: the session's first scene).
    pub parent: Option<String>,
}

pub fn import(cmd: &ImportCmd, session: Option<&str>) -> Result<()> {
    match cmd {
        ImportCmd::Mesh(a) => import_mesh(a, session),
        ImportCmd::Urdf(a) => import_urdf(a, session),
        ImportCmd::Mjcf(a) => import_mjcf(a, session),
    }
}

/// The scene an import goes into: the one named `parent`, else the session's first scene
/// (`None`: the session has no scene, the import is a root object).
fn import_parent(s: &Session, parent: Option<&str>) -> Result<Option<u64>> {
    let reader = Reader::attach(s, "file-io")?;
    let snap = reader
        .snapshot()
        .ok_or_else(|| FileError::Usage(format!("session {}: no model", s.name())))?;
    let scenes: Vec<usize> = (0..snap.len())
        .filter(|&i| snap.object(i).kind() == Some(Kind::Scene))
        .collect();
    Ok(match parent {
        Some(p) => Some(
            scenes
                .iter()
                .find(|&&i| snap.name(i) == p)
                .map(|&i| snap.rec(i).id)
                .ok_or_else(|| {
                    FileError::Usage(format!("session {} has no scene {p:?}", s.name()))
                })?,
        ),
        None => scenes.first().map(|&i| snap.rec(i).id),
    })
}

/// Sends an import's one transaction; a refusal names the file and the object.
fn import_commit(
    s: &Session,
    tx: &robosim_instance_space::Transaction,
    file: &Path,
    name: &str,
) -> Result<robosim_instance_space::Applied> {
    let mut c = robosim_instance_space::Client::connect(s, "file-io")?;
    c.transact(tx).map_err(|e| match e {
        robosim_instance_space::ClientError::Refused(source) => FileError::Refused {
            path: file.to_owned(),
            session: s.name().to_owned(),
            id: 0,
            name: name.to_owned(),
            source: Box::new(source),
        },
        e => e.into(),
    })
}

fn import_mesh(a: &ImportMeshArgs, session: Option<&str>) -> Result<()> {
    let pose = crate::import::parse_at(&a.at)?;
    let mut appearance = Appearance::default();
    if let Some(c) = &a.color {
        appearance.color = crate::import::parse_color(c)?;
    }
    let tris = crate::import::read_mesh(&a.file, a.scale)?;
    let g = crate::import::mesh_geometry(&tris, a.hull, &a.file)?;
    let s = Session::open(session)?;
    let parent = import_parent(&s, a.parent.as_deref())?;
    let place = crate::import::Placement {
        name: a.name.clone(),
        pose,
        parent,
        appearance,
    };
    let tx = crate::import::import_tx(&g.geometry, &place);
    let applied = import_commit(&s, &tx, &a.file, &a.name)?;
    println!(
        "imported {} as {}: {} triangles read, {} dropped (zero area), {} vertices, {} polygons{}, version {}",
        a.file.display(),
        a.name,
        g.read,
        g.dropped,
        g.geometry.vertices.len(),
        g.geometry.polygons.len(),
        if a.hull { " (convex hull)" } else { "" },
        applied.version
    );
    Ok(())
}

fn import_urdf(a: &ImportUrdfArgs, session: Option<&str>) -> Result<()> {
    let pose = crate::import::parse_at(&a.at)?;
    // Everything that can be wrong with the file is found before the session is touched.
    let u = match a.floating {
        None => crate::urdf_import::import_urdf_tree(&a.file)?,
        Some(kind) => crate::urdf_import::import_urdf_tree_floating(&a.file, kind)?,
    };
    import_robot(a, session, pose, &u)
}

/// `robosim import mjcf FILE`: the whole tree of an MJCF model ([`crate::mjcf`]), placed as a
/// URDF robot is; what the file has that is not read is printed as notes.
fn import_mjcf(a: &ImportUrdfArgs, session: Option<&str>) -> Result<()> {
    let pose = crate::import::parse_at(&a.at)?;
    let u = crate::mjcf::import_mjcf_tree(&a.file)?;
    import_robot(a, session, pose, &u)
}

/// A robot read from a description file into the session (one transaction).
fn import_robot(
    a: &ImportUrdfArgs,
    session: Option<&str>,
    pose: robosim_instance_space::Pose,
    u: &crate::urdf_import::UrdfRobot,
) -> Result<()> {
    let name = a.name.clone().unwrap_or_else(|| u.robot.name.clone());
    let s = Session::open(session)?;
    let parent = import_parent(&s, a.parent.as_deref())?;
    let place = crate::urdf_session::UrdfPlacement {
        name: name.clone(),
        pose,
        parent,
        visuals: !a.no_visuals,
        mimic: a.mimic,
    };
    let imp = crate::urdf_session::urdf_tx(u, &place)?;
    let applied = import_commit(&s, &imp.tx, &a.file, &name)?;
    println!(
        "imported {} as robot {name}: {}{} joints ({}), {} visuals, {} collision solids ({} meshes decomposed: hull far from the mesh), {} mesh triangles read, version {}",
        a.file.display(),
        u.robot
            .root
            .as_ref()
            .map_or(String::new(), |r| format!("a {} base and ", r.kind.name())),
        imp.joints,
        if u.robot.parents.is_empty() {
            "a chain"
        } else {
            "a tree"
        },
        imp.visuals,
        imp.solids,
        imp.decomposed,
        imp.triangles,
        applied.version
    );
    for n in &u.notes {
        println!("  note: {n}");
    }
    Ok(())
}
