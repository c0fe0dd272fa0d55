//! The per-step pipeline: an ordered list of the stages a scene declared, nothing else
//! (DESIGN.md, "Scenes declare their effects"). An undeclared effect has no stage, so it costs no
//! branch, no allocation and no memory per step; the only per-step work besides the stages is
//! advancing the clock. Stages are named by what they depend on (MuJoCo's habit).
//!
//! Order: motion source (dynamics, or kinematic motion) → joint limits → link frames → collision
//! → encoder → logging.
//!
//! Entry points: [`Pipeline::build`], [`Pipeline::step`], [`Pipeline`]'s `Display` (the printable
//! description), [`Command`].

use crate::effects::{EffectsError, SceneEffects};
use crate::stages;
use nalgebra::{DVector, Matrix4};
use robosim_collision::robot::{LinkSolids, Scene};
use robosim_kinematics::{Robot, State};
use std::fmt;

/// What the robot is told to do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// No command: zero joint torque under dynamics, standing still under kinematic motion.
    Idle,
    /// Joint targets (rad or m): kinematic motion at `max_speed`, or the dynamics stage's
    /// gravity-compensated PD controller.
    Target(DVector<f64>),
    /// Joint torques (N·m or N); dynamics only.
    Torque(DVector<f64>),
}

/// What the simulation is of, fixed once the pipeline is built (MuJoCo's `mjModel`): the robot
/// and the step. Stages read it; nothing writes it after [`Pipeline::build`]. A stage's own
/// model part (the dynamics model, the collision solids) lives in the stage.
#[derive(Debug, Clone)]
pub struct Model {
    pub robot: Robot,
    /// The pipeline step (s).
    pub dt: f64,
}

/// What changes as the simulation runs (MuJoCo's `mjData`): the state, the command, and the
/// outputs of declared stages (`None` when the stage that fills them is not in the pipeline).
/// Sized once by [`Pipeline::build`]; a step allocates nothing in it.
#[derive(Debug, Clone)]
pub struct Data {
    pub state: State,
    pub command: Command,
    /// The torques applied in the last step (dynamics only; zeros otherwise).
    pub tau: DVector<f64>,
    /// Steps taken.
    pub step: u64,
    /// Link frames `base, 1..n, tool` in the world (link-frames stage).
    pub frames: Option<Vec<Matrix4<f64>>>,
    /// Quantised joint readings (encoder stage).
    pub q_measured: Option<DVector<f64>>,
    /// Whether the last collision check found a contact (collision stage).
    pub contact: Option<bool>,
    /// Steps whose collision check found a contact (collision stage; 0 otherwise).
    pub contact_steps: u64,
}

/// Why a step failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StepError {
    #[error("dynamics: {0}")]
    Dynamics(#[from] robosim_dynamics::DynamicsError),
    #[error("collision: {0}")]
    Collision(String),
    #[error("logging: {0}")]
    Logging(String),
    #[error("command: {0}")]
    Command(String),
}

/// One stage of the pipeline.
pub trait Stage: Send {
    /// Short name (`dynamics`, `joint_limits`, …).
    fn name(&self) -> &'static str;
    /// What its result depends on (`q`, `q, qd, tau`, …).
    fn depends_on(&self) -> &'static str;
    /// Its settings, for the printable description.
    fn describe(&self) -> String;
    /// Runs the stage for the current step: reads `m`, reads and writes `d`.
    fn run(&mut self, m: &Model, d: &mut Data) -> Result<(), StepError>;
    /// The robot was put at `q` from outside the pipeline (a writer moved its joints in the
    /// Instance Space): forget anything remembered about the old configuration.
    fn teleported(&mut self, _q: &DVector<f64>) {}
    /// Writes out what the stage buffers (the logging stage's CSV rows).
    fn flush(&mut self) -> Result<(), StepError> {
        Ok(())
    }
    /// The obstacles this stage checks against, if it has any (to move them in place).
    fn obstacles_mut(&mut self) -> Option<&mut Scene> {
        None
    }
}

/// A scene's simulation: its model, its data and the stages it declared.
pub struct Pipeline {
    model: Model,
    data: Data,
    stages: Vec<Box<dyn Stage>>,
    /// Effects the scene did not declare (or declared off), for the description.
    left_out: Vec<&'static str>,
    /// Logging stage index, if declared (to hand out its rows).
    log_stage: Option<usize>,
    logged: Option<stages::logging::LogHandle>,
}

/// The scene around the robot, for collision: obstacles and the robot's link solids
/// (`None`: simple DH-segment solids of the declared `link_radius`).
#[derive(Default)]
pub struct SceneGeometry {
    pub obstacles: Scene,
    pub link_solids: Option<LinkSolids>,
}

impl Pipeline {
    /// Builds the pipeline `effects` declares for `robot` starting at rest at `q0`.
    pub fn build(
        robot: &Robot,
        q0: &[f64],
        effects: &SceneEffects,
        geometry: SceneGeometry,
    ) -> Result<Pipeline, EffectsError> {
        let bad = |field: &str, reason: String| EffectsError {
            field: field.to_string(),
            reason,
        };
        robot.validate().map_err(|e| bad("robot", e.to_string()))?;
        robot.check_q(q0).map_err(|e| bad("q0", e.to_string()))?;
        let n = robot.dof();
        let mut stages: Vec<Box<dyn Stage>> = Vec::new();
        let mut left_out = Vec::new();
        let mut dt = effects.dt;
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(bad(
                "dt",
                format!("must be a positive number of seconds, got {dt}"),
            ));
        }
        match &effects.dynamics {
            Some(d) => {
                let stage = stages::dynamics::DynamicsStage::new(robot, d)?;
                dt = d.dt;
                stages.push(Box::new(stage));
            }
            None => {
                left_out.push("dynamics");
                if effects.kinematics {
                    if !(effects.max_speed > 0.0 && effects.max_speed.is_finite()) {
                        return Err(bad(
                            "max_speed",
                            format!("must be positive, got {}", effects.max_speed),
                        ));
                    }
                    stages.push(Box::new(stages::motion::KinematicMotion::new(
                        effects.max_speed,
                    )));
                }
            }
        }
        if effects.joint_limits {
            stages.push(Box::new(stages::limits::JointLimits::new(robot)?));
        } else {
            left_out.push("joint_limits");
        }
        let mut frames = None;
        if effects.kinematics {
            frames = Some(vec![Matrix4::identity(); n + 2]);
            stages.push(Box::new(stages::frames::LinkFrames));
        } else {
            left_out.push("kinematics");
        }
        let mut contact = None;
        match &effects.collision {
            Some(c) if c.enabled => {
                contact = Some(false);
                stages.push(Box::new(stages::collision::CollisionStage::new(
                    robot, q0, c, geometry,
                )?));
            }
            _ => left_out.push("collision"),
        }
        let mut q_measured = None;
        match &effects.encoder {
            Some(e) => {
                q_measured = Some(DVector::zeros(n));
                stages.push(Box::new(stages::encoder::Encoder::new(robot, e)?));
            }
            None => left_out.push("encoder"),
        }
        let mut log_stage = None;
        let mut logged = None;
        match &effects.logging {
            Some(l) => {
                let joints: Vec<_> = robot.joints.iter().map(|j| j.joint_type).collect();
                let (stage, handle) = stages::logging::Logging::new(
                    &joints,
                    l,
                    q_measured.is_some(),
                    contact.is_some(),
                )?;
                log_stage = Some(stages.len());
                logged = Some(handle);
                stages.push(Box::new(stage));
            }
            None => left_out.push("logging"),
        }
        let state = State {
            q: DVector::from_column_slice(q0),
            qd: DVector::zeros(n),
            qdd: DVector::zeros(n),
            t: 0.0,
        };
        let model = Model {
            robot: robot.clone(),
            dt,
        };
        let data = Data {
            state,
            command: Command::Idle,
            tau: DVector::zeros(n),
            step: 0,
            frames,
            q_measured,
            contact,
            contact_steps: 0,
        };
        Ok(Pipeline {
            model,
            data,
            stages,
            left_out,
            log_stage,
            logged,
        })
    }

    /// What the simulation is of (fixed).
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// Where it stands: state, command, the declared stages' outputs. Changed only by
    /// [`Pipeline::step`], [`Pipeline::set_command`] and [`Pipeline::teleport`] (checked).
    pub fn data(&self) -> &Data {
        &self.data
    }

    /// One step: every declared stage in order, then the clock. Time advances by `model.dt`.
    pub fn step(&mut self) -> Result<(), StepError> {
        for stage in &mut self.stages {
            stage.run(&self.model, &mut self.data)?;
        }
        self.data.step += 1;
        // the clock is kept as step · dt so that it does not drift by summation
        self.data.state.t = self.data.step as f64 * self.model.dt;
        Ok(())
    }

    /// Sets the command, checked against the robot like a transaction: length, finite values,
    /// a target inside the joint limits, torques only with the dynamics effect. A refused
    /// command leaves the current one in place.
    pub fn set_command(&mut self, command: Command) -> Result<(), StepError> {
        let n = self.model.robot.dof();
        let check = |v: &DVector<f64>, what: &str| {
            if v.len() != n {
                return Err(StepError::Command(format!(
                    "{what} has {} values but the robot has {n} joints",
                    v.len()
                )));
            }
            match v.iter().position(|x| !x.is_finite()) {
                Some(i) => Err(StepError::Command(format!("{what}[{i}] is not finite"))),
                None => Ok(()),
            }
        };
        match &command {
            Command::Idle => {}
            Command::Target(q) => {
                check(q, "target")?;
                if let Some((j, v, [lo, hi])) = self.model.robot.outside_limits(q.as_slice()) {
                    return Err(StepError::Command(format!(
                        "target[{j}] = {v:?} is outside joint {}'s limits [{lo:?}, {hi:?}]",
                        j + 1
                    )));
                }
            }
            Command::Torque(t) => {
                check(t, "torque")?;
                if !self.stages.iter().any(|s| s.name() == "dynamics") {
                    return Err(StepError::Command(
                        "torque commands need the dynamics effect".into(),
                    ));
                }
            }
        }
        self.data.command = command;
        Ok(())
    }

    /// Puts the robot at `q`, at rest, without stepping (a writer moved its joints in the
    /// Instance Space). The command stays. Checked: length and finite values.
    pub fn teleport(&mut self, q: &[f64]) -> Result<(), StepError> {
        let n = self.model.robot.dof();
        if q.len() != n {
            return Err(StepError::Command(format!(
                "teleport to {} values but the robot has {n} joints",
                q.len()
            )));
        }
        if let Some(i) = q.iter().position(|x| !x.is_finite()) {
            return Err(StepError::Command(format!("teleport q[{i}] is not finite")));
        }
        let q = DVector::from_column_slice(q);
        self.data.state.q.copy_from(&q);
        self.data.state.qd.fill(0.0);
        self.data.state.qdd.fill(0.0);
        for s in &mut self.stages {
            s.teleported(&q);
        }
        Ok(())
    }

    /// The collision stage's obstacles (`None` when collision is not declared), to move an
    /// obstacle in place (`Scene::set_pose`) instead of rebuilding the pipeline.
    pub fn obstacles_mut(&mut self) -> Option<&mut Scene> {
        self.stages.iter_mut().find_map(|s| s.obstacles_mut())
    }

    /// Writes out the rows the logging stage buffers, so a reader of its CSV file sees every
    /// step taken so far (the file is also flushed when the pipeline is dropped).
    pub fn flush_log(&mut self) -> Result<(), StepError> {
        self.stages.iter_mut().try_for_each(|s| s.flush())
    }

    /// The names of the stages, in order.
    pub fn stage_names(&self) -> Vec<&'static str> {
        self.stages.iter().map(|s| s.name()).collect()
    }

    /// The rows logged in memory so far (`t_s`, then the `signals` columns as declared; empty
    /// when logging is not declared or writes to a file).
    pub fn log(&self) -> Vec<Vec<f64>> {
        let _ = self.log_stage;
        self.logged.as_ref().map(|h| h.rows()).unwrap_or_default()
    }

    /// The CSV header of the log, if logging is declared: `t_s`, then one column per signal and
    /// joint named with its unit (`q1_rad`, `q3_m`, `qd1_rad_s`, `tau1_Nm`, `contact`).
    pub fn log_header(&self) -> Option<Vec<String>> {
        self.logged.as_ref().map(|h| h.header())
    }
}

impl fmt::Display for Pipeline {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = if self.model.robot.name.is_empty() {
            "robot"
        } else {
            &self.model.robot.name
        };
        writeln!(
            f,
            "pipeline for {name} ({} joints), step {} s:",
            self.model.robot.dof(),
            self.model.dt
        )?;
        if self.stages.is_empty() {
            writeln!(f, "  (no stages: the robot stands still)")?;
        }
        for (i, s) in self.stages.iter().enumerate() {
            writeln!(
                f,
                "  {}. {:<13} {:<58} depends on {}",
                i + 1,
                s.name(),
                s.describe(),
                s.depends_on()
            )?;
        }
        if !self.left_out.is_empty() {
            writeln!(
                f,
                "  not declared (not in the pipeline, no cost): {}",
                self.left_out.join(", ")
            )?;
        }
        Ok(())
    }
}
