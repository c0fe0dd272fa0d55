//! What a simulation is of, fixed once the pipeline is built (MuJoCo's `mjModel`): the robot, the
//! step, the declared effects, and one compiled part per declared stage (the dynamics model and
//! its controller, the joint stops, the collision solids and obstacles, the encoder
//! resolutions). A stage that is not declared has no part: `None`, nothing allocated. The stage
//! functions read it; only [`crate::Pipeline::obstacles_mut`] changes it after the build (to
//! move an obstacle in place).
//!
//! The stage parts are defined here and filled by each stage's `build` (`crate::stages`), so
//! the stages depend on this file and this file on none of them. Also here, because every
//! stage and the pipeline share them: [`StepError`], [`BuildError`] and [`SceneGeometry`].

use robosim_collision::ccd::SweepOptions;
use robosim_collision::robot::{CollisionSettings, LinkSolids, Scene};
use robosim_kinematics::{KinematicModel, Robot};
use robosim_model::{OnContact, Options};
use std::path::PathBuf;

/// The compiled simulation: read by every stage, written by none.
#[derive(Debug, Clone)]
pub struct Model {
    pub robot: Robot,
    /// `robot` compiled for forward kinematics (Pinocchio's `Model`): built once with the
    /// pipeline when a stage that needs link frames is declared (kinematics or collision),
    /// read by the link-frames and collision stages every step.
    pub(crate) kinematics: Option<KinematicModel>,
    /// The pipeline step (s): the dynamics effect's, else the kinematic one.
    pub dt: f64,
    /// What the scene declared.
    pub options: Options,
    /// Kinematic motion's speed limit (rad/s or m/s), when kinematics is declared without
    /// dynamics.
    pub(crate) motion: Option<f64>,
    pub(crate) dynamics: Option<DynamicsModel>,
    /// The joint-stop model (limits checked at build).
    pub(crate) limits: Option<robosim_dynamics::Model>,
    pub(crate) collision: Option<CollisionModel>,
    pub(crate) encoder: Option<EncoderModel>,
}

impl Model {
    /// The compiled kinematic model, when a stage that needs link frames is declared.
    pub fn kinematics(&self) -> Option<&KinematicModel> {
        self.kinematics.as_ref()
    }
}

/// Why a step failed.
#[derive(Debug, thiserror::Error)]
pub enum StepError {
    #[error("dynamics: {0}")]
    Dynamics(#[from] robosim_dynamics::DynamicsError),
    /// The collision check could not run (the collision crate's error, kept).
    #[error("collision: {0}")]
    Collision(#[from] robosim_collision::robot::CheckError),
    /// The logging stage could not write its CSV file (the I/O error, kept).
    #[error("logging: {path}: {source}")]
    Logging {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The in-memory log's buffer was poisoned (a reader panicked holding it).
    #[error("logging: log buffer poisoned")]
    LogBufferPoisoned,
    #[error("command: {0}")]
    Command(String),
    /// A declared stage's step found its model part or its `Data` field missing (`stage`
    /// names the stage, `what` the part). The pipeline's build fills both whenever it declares
    /// the stage, and [`crate::Pipeline::rewind`] refuses data without them, so this is data
    /// that was not made for this model: the stage refuses it rather than skip its effect.
    #[error("{stage}: the stage is declared but {what} is missing (data not made for this model)")]
    Missing {
        stage: &'static str,
        what: &'static str,
    },
}

/// Why a pipeline cannot be built from a scene's declaration. Each variant's message is the
/// declaration's (`scene effects, `field`: reason`), naming the field the build refused; a
/// variant built from a library's refusal keeps that error as its source.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// A declared value is refused by the declaration's own checks (a step that is not
    /// positive, a signal nothing computes, a floating root under kinematic motion).
    #[error(transparent)]
    Options(#[from] robosim_model::OptionsError),
    /// The robot itself, or its start q, is refused by the kinematic model (`field`: `robot`,
    /// `q0`).
    #[error("scene effects, `{field}`: {source}")]
    Robot {
        field: &'static str,
        #[source]
        source: robosim_kinematics::ModelError,
    },
    /// The dynamics model of a declared stage cannot be had (`field`: `dynamics.robot`,
    /// `dynamics.integrator`, `joint_friction`, `joint_limits`).
    #[error("scene effects, `{field}`: {source}")]
    Dynamics {
        field: &'static str,
        #[source]
        source: robosim_dynamics::DynamicsError,
    },
    /// The collision stage's link solids cannot be built from the declared `link_radius`.
    #[error("scene effects, `collision.link_radius`: {source}")]
    LinkSolids {
        #[source]
        source: robosim_collision::robot::CheckError,
    },
}

impl BuildError {
    /// The declaration's field the build refused (`dynamics.dt`, `q0`, `collision.link_radius`).
    pub fn field(&self) -> &str {
        match self {
            BuildError::Options(e) => &e.field,
            BuildError::Robot { field, .. } | BuildError::Dynamics { field, .. } => field,
            BuildError::LinkSolids { .. } => "collision.link_radius",
        }
    }
}

/// The scene around the robot, for collision: obstacles and the robot's link solids
/// (`None`: simple DH-segment solids of the declared `link_radius`).
#[derive(Default)]
pub struct SceneGeometry {
    pub obstacles: Scene,
    pub link_solids: Option<LinkSolids>,
}

/// The dynamics stage's compiled part (`stages::dynamics`): the dynamics model (gravity as
/// declared), the controller's gains, the printable summary.
#[derive(Debug, Clone)]
pub struct DynamicsModel {
    pub(crate) model: robosim_dynamics::Model,
    pub(crate) kp: f64,
    pub(crate) kd: f64,
    pub(crate) summary: String,
}

/// The collision stage's compiled part (`stages::collision`): the robot's link solids, the
/// obstacles, the settings.
#[derive(Debug, Clone)]
pub struct CollisionModel {
    pub(crate) links: LinkSolids,
    pub(crate) scene: Scene,
    pub(crate) settings: CollisionSettings,
    pub(crate) on_contact: OnContact,
    pub(crate) sweep: SweepOptions,
}

/// The encoder stage's compiled part (`stages::encoder`): its bits and each joint's
/// resolution (rad or m).
#[derive(Debug, Clone)]
pub struct EncoderModel {
    pub(crate) bits: u32,
    pub(crate) resolution: Vec<f64>,
}
