//! The file interface (seed §3.2, component 3: "services to save and restore the objects in the
//! databases"), and exchange with other tools.
//!
//! * [`format`] — the model file: header (magic, format version, length, CRC-32), a bincode 2
//!   body or the same content as JSON; [`format::read`] / [`format::write`].
//! * [`model`] — [`SavedModel`]: every object in the keeper's checkpoint form
//!   ([`robosim_instance_space::ObjectData`]) plus the session's Library Space additions; its
//!   validation and the one transaction that loads it ([`LoadMode`]).
//! * [`digest`] — [`ModelDigest`]: SHA-256 of a canonical encoding, independent of ids, order,
//!   process and machine.
//! * [`session`] — against a running session: [`session::save`], [`session::load`],
//!   [`session::info`] (a keeper's start from a file, `robosim space --load`, is the launcher's:
//!   robosim-launcher reads the file with [`format::read`]).
//! * [`gltf`], [`stl`], [`trajectory`] — export: `.glb`, binary STL in world coordinates, the
//!   logged joint trajectory as CSV with units.
//! * [`linkfile`] — ROBOSIM link files (seed Table 2): write, read, DH rows, pseudo-inertia.
//! * [`import`] — STL / OBJ meshes as items placed in the scene ([`stl`], [`obj`] read them).
//! * [`bench`] — save and load of a 10⁶-vertex model against `cp` (`robosim bench files`).
//! * [`urdf`] — a robot as URDF (its DH chain as joint origins and z axes, inertials, limits),
//!   checked against Pinocchio.
//! * [`urdf_import`] — a URDF read as a chain; [`urdf_geometry`] its visual and collision
//!   geometry (meshes loaded lazily, [`package`] resolves `package://` names, [`dae`] reads
//!   Collada visual meshes) and the collision solids of its links — all re-exported from the
//!   `robosim-urdf` crate (core/urdf/), which the Library Space uses for `from_urdf`.
//! * [`cli`] — the commands' argument structs (plain types; the binary parses them, in its
//!   src/cli/file_io.rs) and run functions.

#![forbid(unsafe_code)]

pub mod bench;
pub mod bench_urdf;
pub mod cli;
pub mod digest;
mod error;
pub mod export_geometry;
pub mod format;
pub mod gltf;
pub mod import;
pub mod inertial;
pub mod linkfile;
pub mod mjcf_export;
pub mod model;
pub mod session;
pub mod stl;
pub mod trajectory;
pub mod urdf;
pub mod urdf_session;
mod world;

// The URDF reader and the mesh readers live in `robosim-urdf` (core/urdf/); re-exported under
// their old paths. `stl` stays here: it adds the STL writer to the reader.
pub use robosim_urdf::{dae, mjcf, obj, package, urdf_geometry, urdf_import};

pub use digest::{ModelDigest, digest};
pub use error::{FileError, ModelProblem};
pub use format::{Encoding, FORMAT_VERSION};
pub use model::{LibrarySource, LoadMode, SavedModel};

/// The model of a Library Space declaration (a scene, robot, link or solid, or the built-in
/// `demo`) instantiated with its defaults, without any session — what `robosim render` draws.
/// `library`: files to add to the standard library.
/// The robots of a Library Space scene (or robot) instantiated with its defaults, as the
/// Instance Space holds them (base = the placement in the scene; friction and motor inertia
/// are not part of the Instance Space's joint record, so they are 0 here).
pub fn scene_robots(
    name: &str,
    library: &[std::path::PathBuf],
) -> Result<Vec<robosim_kinematics::Robot>, FileError> {
    let lib = robosim_scene::build_library(library)?;
    let mut store = robosim_instance_space::Store::new();
    for tx in robosim_scene::load_from(&lib, name)? {
        store
            .apply(&tx)
            .map_err(|e| FileError::Usage(format!("scene {name} does not instantiate: {e}")))?;
    }
    Ok(robots_of(&robosim_instance_space::Snapshot::from_store(
        &store,
    )))
}

/// The robots `robosim export urdf|mjcf --scene NAME` writes: a robot declaration's own model
/// (with its friction and motor inertia, which the Instance Space's joint record does not
/// carry), named NAME, else the robots of the scene as instantiated ([`scene_robots`]).
pub fn export_robots(
    name: &str,
    library: &[std::path::PathBuf],
) -> Result<Vec<robosim_kinematics::Robot>, FileError> {
    let lib = robosim_scene::build_library(library)?;
    if let Ok(robosim_library::Evaluated::Robot(r)) =
        lib.evaluate(name, &robosim_library::Params::new())
    {
        let mut robot = r.robot;
        robot.name = name.to_string();
        return Ok(vec![robot]);
    }
    scene_robots(name, library)
}

/// A robot as `robosim export urdf|mjcf` writes it: its joint tree, the mimic coupling beside
/// it (a `from_urdf`/`from_mjcf` robot's file's `<mimic>` / `<equality><joint>`: without it the
/// export would be another robot) and its geometry — the robot model's
/// ([`robosim_model::GeometryModel`], what the simulator collides; [`export_geometry`] says how
/// the files write it).
#[derive(Debug, Clone)]
pub struct ExportRobot {
    pub robot: robosim_kinematics::Robot,
    /// `None`: no joint mimics another.
    pub coupling: Option<robosim_kinematics::mimic::Coupling>,
    /// `None` where the geometry is not known.
    pub geometry: Option<robosim_model::GeometryModel>,
    /// What the geometry is not (a `from_urdf` file's links not matched with the
    /// declaration's: its library solids instead), one sentence each.
    pub notes: Vec<String>,
}

/// A Library Space robot's geometry as the exports write it: its robot model's
/// (`RobotModel::model`: each placed solid a collision object, drawn as the library draws
/// it), each object named `link<j>_<part>` — the library names parts per link, a file needs
/// names unique in the robot.
pub fn library_geometry(r: &robosim_library::RobotModel) -> robosim_model::GeometryModel {
    let mut g = r.model().geometry;
    for o in &mut g.objects {
        o.name = format!("link{}_{}", o.frame, o.name);
    }
    g
}

/// [`export_robots`] with each robot's geometry ([`export_geometry`]) and coupling: a robot
/// declaration's solids, or for a `from_urdf` robot the URDF's own `<visual>` and
/// `<collision>` elements and its mimic coupling (the file read again; its movable links must
/// be the declaration's, else its solids are used, no coupling, and a note says so); a scene's
/// robots with the solids of the robots it places. Geometry `None` where it is not known (a
/// scene robot not found in the scene's evaluation).
pub fn export_robot_models(
    name: &str,
    library: &[std::path::PathBuf],
) -> Result<Vec<ExportRobot>, FileError> {
    let lib = robosim_scene::build_library(library)?;
    match lib.evaluate(name, &robosim_library::Params::new()) {
        Ok(robosim_library::Evaluated::Robot(r)) => {
            let mut robot = r.robot.clone();
            robot.name = name.to_string();
            let (geometry, coupling, notes) = match lib.robot_file(name) {
                Some(file) => urdf_geometry_of(&file, &r),
                None => (library_geometry(&r), None, Vec::new()),
            };
            Ok(vec![ExportRobot {
                coupling: coupling.map(|c| c.with_root(robot.root_nq(), robot.root_nv())),
                robot,
                geometry: Some(geometry),
                notes,
            }])
        }
        Ok(robosim_library::Evaluated::Scene(scene)) => {
            let robots = scene_robots(name, library)?;
            Ok(robots
                .into_iter()
                .map(|robot| {
                    let geometry = scene
                        .robots
                        .iter()
                        .find(|p| p.name == robot.name)
                        .map(|p| library_geometry(&p.model));
                    ExportRobot {
                        robot,
                        coupling: None,
                        geometry,
                        notes: Vec::new(),
                    }
                })
                .collect())
        }
        _ => Ok(scene_robots(name, library)?
            .into_iter()
            .map(|robot| ExportRobot {
                robot,
                coupling: None,
                geometry: None,
                notes: Vec::new(),
            })
            .collect()),
    }
}

/// The geometry and mimic coupling of a `from_urdf` (or `from_mjcf`) robot from its file (the
/// whole tree, or the chain to the declaration's last link), as its robot model has them
/// ([`robosim_model::Model::from_imported`]: the file's `<visual>` and `<collision>` elements);
/// when neither has the declaration's links, its solids ([`library_geometry`]), no coupling
/// and a note saying so.
fn urdf_geometry_of(
    file: &std::path::Path,
    r: &robosim_library::RobotModel,
) -> (
    robosim_model::GeometryModel,
    Option<robosim_kinematics::mimic::Coupling>,
    Vec<String>,
) {
    let same = |u: &urdf_import::UrdfRobot| {
        u.joints.len() == r.link_names.len()
            && u.joints
                .iter()
                .zip(&r.link_names)
                .all(|(j, n)| j.link == *n)
    };
    // a `from_mjcf` robot's file is MJCF: its reader gives the same UrdfRobot (geoms as geometry)
    let tip = r.link_names.last().map(String::as_str);
    let tree = urdf_import::import_urdf_tree(file)
        .ok()
        .or_else(|| mjcf::import_mjcf_tree(file).ok())
        .filter(same);
    let u = tree.or_else(|| {
        urdf_import::import_urdf(file, tip)
            .ok()
            .or_else(|| mjcf::import_mjcf(file, tip).ok())
            .filter(same)
    });
    match u {
        Some(u) => {
            let model = robosim_model::Model::from_imported(&u);
            (model.geometry, model.coupling, Vec::new())
        }
        None => (
            library_geometry(r),
            None,
            vec![format!(
                "{}: its links could not be matched with the declaration's; its collision solids are exported instead of the file's visuals",
                file.display()
            )],
        ),
    }
}

/// The robots of a session's snapshot for `robosim export urdf|mjcf --session`: each as the
/// Instance Space holds it ([`robots_of`]) and, where the robot — or the instance holding it (a
/// scene) — was made from a library declaration (its origin record), that declaration's
/// viscous and Coulomb friction and motor inertia (the Instance Space's joint record carries
/// none of them) and its geometry. A robot with no origin, or whose declaration no longer has
/// its number of joints (edited in the session), keeps zero friction and has no geometry.
/// `library`: the session's Library Space files.
pub fn session_robot_models(
    snap: &robosim_instance_space::Snapshot,
    library: &[(String, String)],
) -> Vec<ExportRobot> {
    let lib = robosim_scene::instantiate::build_library_from(&[], library).ok();
    let compiled = robosim_scene::CompiledScene::of(snap);
    // a robot with mimic joints (`robosim import urdf` of a file with `<mimic>`): the coupling
    // its records hold, so the export writes the `<mimic>` again
    let held = |robot: &robosim_kinematics::Robot| {
        let view = snap.robot(&robot.name)?;
        robosim_scene::robot_coupling(&view, robot).ok().flatten()
    };
    let bare = |robot| ExportRobot {
        coupling: held(&robot),
        robot,
        geometry: None,
        notes: Vec::new(),
    };
    compiled
        .robots()
        .iter()
        .map(|cr| {
            let mut robot = cr.robot.clone();
            let Some(lib) = &lib else {
                return bare(robot);
            };
            let Some((decl, model)) = declared_model(snap, lib, cr.index) else {
                return bare(robot);
            };
            if model.robot.dof() != robot.dof() {
                return bare(robot);
            }
            for (j, d) in robot.joints.iter_mut().zip(&model.robot.joints) {
                j.viscous = d.viscous;
                j.coulomb = d.coulomb;
                j.motor_inertia = d.motor_inertia;
            }
            let (geometry, coupling, notes) = match decl.as_deref().and_then(|d| lib.robot_file(d))
            {
                Some(file) => urdf_geometry_of(&file, &model),
                None => (library_geometry(&model), None, Vec::new()),
            };
            // (a session's floating robot: the file's coupling with the root's coordinates)
            ExportRobot {
                coupling: coupling
                    .map(|c| c.with_root(robot.root_nq(), robot.root_nv()))
                    .or_else(|| held(&robot)),
                robot,
                geometry: Some(geometry),
                notes,
            }
        })
        .collect()
}

/// The library model of the robot at snapshot index `i`: from the origin record of the robot
/// object or of its nearest ancestor that has one (a robot declaration, or a scene placing a
/// robot of that name), with the robot declaration's name when known.
fn declared_model(
    snap: &robosim_instance_space::Snapshot,
    lib: &robosim_library::Library,
    i: usize,
) -> Option<(Option<String>, robosim_library::RobotModel)> {
    let name = snap.name(i).to_string();
    let mut at = i;
    for _ in 0..snap.len() {
        let text = snap.origin(at);
        if !text.is_empty() {
            let origin = robosim_scene::Origin::from_record(text).ok()?;
            return match origin.evaluate(lib).ok()? {
                robosim_library::Evaluated::Robot(r) => Some((Some(origin.declaration), r)),
                robosim_library::Evaluated::Scene(s) => s
                    .robots
                    .into_iter()
                    .find(|p| p.name == name)
                    .map(|p| (p.declaration, p.model)),
                _ => None,
            };
        }
        let parent = snap.rec(at).parent;
        if parent == 0 {
            return None;
        }
        at = snap.index_of(parent)?;
    }
    None
}

/// The robots of a snapshot as kinematic (and dynamic) models.
pub fn robots_of(snap: &robosim_instance_space::Snapshot) -> Vec<robosim_kinematics::Robot> {
    robosim_scene::CompiledScene::of(snap)
        .robots()
        .iter()
        .map(|r| r.robot.clone())
        .collect()
}

pub fn scene_model(name: &str, library: &[std::path::PathBuf]) -> Result<SavedModel, FileError> {
    let lib = robosim_scene::build_library(library)?;
    let mut store = robosim_instance_space::Store::new();
    for tx in robosim_scene::load_from(&lib, name)? {
        store
            .apply(&tx)
            .map_err(|e| FileError::Usage(format!("scene {name} does not instantiate: {e}")))?;
    }
    let snap = robosim_instance_space::Snapshot::from_store(&store);
    Ok(SavedModel::from_snapshot(&snap, &lib.sources()))
}
