//! `robosim save`, `load`, `info`, `export` and `import`: the clap arguments of
//! robosim-file-io's commands (`robosim_file_io::cli`), each converted to the library's plain argument type.

use std::path::PathBuf;

/// `robosim save FILE`
#[derive(clap::Args, Debug)]
pub struct SaveArgs {
    /// The model file: binary (checksummed), or JSON when the name ends in .json.
    pub file: PathBuf,
    /// Write the readable JSON form whatever the name.
    #[arg(long)]
    pub json: bool,
}

/// `robosim load FILE`
#[derive(clap::Args, Debug)]
pub struct LoadArgs {
    /// A model file written by `robosim save` (binary or JSON, told apart by content).
    pub file: PathBuf,
    /// Add the file's objects beside the session's (new ids) instead of replacing them.
    #[arg(long, conflicts_with = "replace")]
    pub merge: bool,
    /// Delete every object of the session and create the file's (the default).
    #[arg(long)]
    pub replace: bool,
}

/// `robosim info [FILE]`
#[derive(clap::Args, Debug)]
pub struct InfoArgs {
    /// Describe this model file instead of a session's model.
    pub file: Option<PathBuf>,
}

/// `robosim export [FORMAT] FILE`
#[derive(clap::Args, Debug)]
pub struct ExportArgs {
    /// `[gltf|stl|trajectory|urdf] FILE`; without a format, the file's extension says
    /// (.glb, .stl, .csv, .urdf).
    #[arg(num_args = 1..=2, value_names = ["FORMAT", "FILE"], required = true)]
    pub what: Vec<String>,
    /// Export a Library Space declaration instantiated with its defaults, without a session.
    #[arg(long)]
    pub scene: Option<String>,
    /// Library files to add to the standard library (with --scene).
    #[arg(long)]
    pub library: Vec<PathBuf>,
    /// STL: only this object and what hangs under it (by name).
    #[arg(long)]
    pub body: Option<String>,
    /// Trajectory and URDF: the robot (default: the session's or scene's only robot).
    #[arg(long)]
    pub robot: Option<String>,
    /// Trajectory: the simulator log to read (default: the session's run/simulator-ROBOT.csv).
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Trajectory: seconds between two log rows, for a log without a time column.
    #[arg(long)]
    pub dt: Option<f64>,
    /// URDF and MJCF: how the mesh files beside the export are named in it — `absolute` (URDF's
    /// default: Pinocchio and MuJoCo open it with no flags), `relative` (MJCF's default; a URDF
    /// folder that can be moved, Pinocchio then needs package_dirs) or `file-uri` (URDF only,
    /// `file://` for ROS; MuJoCo refuses it). docs/file-io.md, "Mesh paths".
    #[arg(long, value_name = "MODE")]
    pub mesh_paths: Option<String>,
}

/// `robosim import …`
#[derive(clap::Subcommand, Debug)]
pub enum ImportCmd {
    /// An STL (binary or ASCII) or OBJ mesh as an item placed in the scene (one transaction).
    Mesh(ImportMeshArgs),
    /// A URDF robot — its whole tree, general joints, inertials, visuals and collision shapes
    /// (meshes as convex hulls) — as a robot placed in the scene (one transaction;
    /// docs/file-io.md, "URDF into a session").
    Urdf(ImportUrdfArgs),
    /// An MJCF (MuJoCo) robot — its hinge and slide joints, inertials and geoms — as a robot
    /// placed in the scene (one transaction; docs/file-io.md, "MJCF import"). Ball and free
    /// joints are refused; what is not read (actuators, sensors, …) is printed as notes.
    Mjcf(ImportMjcfArgs),
}

#[derive(clap::Args, Debug)]
pub struct ImportMjcfArgs {
    /// The MJCF file (meshes are found under its <compiler meshdir>).
    pub file: PathBuf,
    /// The robot's name in the session (default: the file's `<mujoco model>`).
    #[arg(long = "as")]
    pub name: Option<String>,
    /// Position (m) and optionally roll, pitch, yaw (deg) of the world body in the parent's frame.
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true)]
    pub at: String,
    /// The scene to place it in (default: the session's first scene).
    #[arg(long)]
    pub parent: Option<String>,
    /// Leave the visual-only geoms out (the collision geoms are drawn).
    #[arg(long)]
    pub no_visuals: bool,
}

#[derive(clap::Args, Debug)]
pub struct ImportUrdfArgs {
    /// The URDF file (`package://` meshes are found through ROS_PACKAGE_PATH and the file's
    /// ancestors; xacro files are refused: run xacro first).
    pub file: PathBuf,
    /// The robot's name in the session (default: the URDF's `<robot name>`).
    #[arg(long = "as")]
    pub name: Option<String>,
    /// Position (m) and optionally roll, pitch, yaw (deg) of the root link in the parent's frame.
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true)]
    pub at: String,
    /// The scene to place it in (default: the session's first scene).
    #[arg(long)]
    pub parent: Option<String>,
    /// Leave the `<visual>`s out (their meshes are not read; the collision solids are drawn).
    #[arg(long)]
    pub no_visuals: bool,
    /// A floating base for the root link: `--floating` (a free-flyer, 7 q / 6 v) or
    /// `--floating planar` (x, y, yaw); the robot object is then the base link (docs/file-io.md).
    #[arg(long, num_args = 0..=1, default_missing_value = "free_flyer", value_parser = ["free_flyer", "planar"])]
    pub floating: Option<String>,
    /// `<mimic>` followers follow their leaders: the session robot's coordinates are the
    /// reduced ones (Pinocchio's `mimic=True`; docs/query.md). Without it every movable joint
    /// is a coordinate of its own (Pinocchio's default), which IK to a tip and the simulator serve.
    #[arg(long)]
    pub mimic: bool,
}

#[derive(clap::Args, Debug)]
pub struct ImportMeshArgs {
    /// The mesh file (.stl or .obj).
    pub file: PathBuf,
    /// The item's name (its solid is NAME-mesh).
    #[arg(long = "as")]
    pub name: String,
    /// Position (m) and optionally roll, pitch, yaw (deg) in the parent's frame.
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true)]
    pub at: String,
    /// File units to metres (e.g. 0.001 for a file in millimetres).
    #[arg(long, default_value_t = 1.0)]
    pub scale: f64,
    /// Keep the convex hull instead of the mesh.
    #[arg(long)]
    pub hull: bool,
    /// r,g,b[,a] in 0..1.
    #[arg(long)]
    pub color: Option<String>,
    /// The scene to place it in (default: the session's first scene).
    #[arg(long)]
    pub parent: Option<String>,
}

impl From<SaveArgs> for robosim_file_io::cli::SaveArgs {
    fn from(a: SaveArgs) -> Self {
        robosim_file_io::cli::SaveArgs {
            file: a.file,
            json: a.json,
        }
    }
}

impl From<LoadArgs> for robosim_file_io::cli::LoadArgs {
    fn from(a: LoadArgs) -> Self {
        robosim_file_io::cli::LoadArgs {
            file: a.file,
            merge: a.merge,
            replace: a.replace,
        }
    }
}

impl From<InfoArgs> for robosim_file_io::cli::InfoArgs {
    fn from(a: InfoArgs) -> Self {
        robosim_file_io::cli::InfoArgs { file: a.file }
    }
}

impl From<ExportArgs> for robosim_file_io::cli::ExportArgs {
    fn from(a: ExportArgs) -> Self {
        robosim_file_io::cli::ExportArgs {
            what: a.what,
            scene: a.scene,
            library: a.library,
            body: a.body,
            robot: a.robot,
            log: a.log,
            dt: a.dt,
            mesh_paths: a.mesh_paths,
        }
    }
}

impl From<ImportCmd> for robosim_file_io::cli::ImportCmd {
    fn from(a: ImportCmd) -> Self {
        match a {
            ImportCmd::Mesh(x) => robosim_file_io::cli::ImportCmd::Mesh(x.into()),
            ImportCmd::Urdf(x) => robosim_file_io::cli::ImportCmd::Urdf(x.into()),
            ImportCmd::Mjcf(x) => {
                robosim_file_io::cli::ImportCmd::Mjcf(robosim_file_io::cli::ImportUrdfArgs {
                    file: x.file,
                    name: x.name,
                    at: x.at,
                    parent: x.parent,
                    no_visuals: x.no_visuals,
                    floating: None,
                    mimic: false,
                })
            }
        }
    }
}

impl From<ImportUrdfArgs> for robosim_file_io::cli::ImportUrdfArgs {
    fn from(a: ImportUrdfArgs) -> Self {
        robosim_file_io::cli::ImportUrdfArgs {
            file: a.file,
            name: a.name,
            at: a.at,
            parent: a.parent,
            no_visuals: a.no_visuals,
            floating: a
                .floating
                .as_deref()
                .and_then(robosim_kinematics::RootKind::from_name),
            mimic: a.mimic,
        }
    }
}

impl From<ImportMeshArgs> for robosim_file_io::cli::ImportMeshArgs {
    fn from(a: ImportMeshArgs) -> Self {
        robosim_file_io::cli::ImportMeshArgs {
            file: a.file,
            name: a.name,
            at: a.at,
            scale: a.scale,
            hull: a.hull,
            color: a.color,
            parent: a.parent,
        }
    }
}
