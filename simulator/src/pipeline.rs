//! The per-step pipeline (MuJoCo's `mj_step` shape): a fixed sequence of stage functions over
//! `(&Model, &mut Data)`, each run only when the scene declared its effect (DESIGN.md, "Scenes
//! declare their effects"). An undeclared effect has no model part and no `Data` field — no
//! allocation, no memory, no work per step beyond one untaken branch; the only other per-step
//! work is advancing the clock. Stages are named by what they depend on (MuJoCo's habit).
//!
//! Order ([`Pipeline::step`]): motion source (dynamics, or kinematic motion) → joint limits →
//! link frames → collision → encoder → logging.
//!
//! All state is in [`Data`]: [`Pipeline::data`] saves a step (clone it), [`Pipeline::rewind`]
//! puts a saved one back.
//!
//! **Floating bases** (`Robot::root`, issue 36 item 2): the pipeline holds the robot's whole
//! state — q is `[q_root, q_joints]` (`Robot::nq`: a free-flyer's 7 or a planar root's 4, then
//! one per joint), q̇, q̈ and τ are `[v_root, joints]` (`Robot::nv`) — and the dynamics stage
//! integrates it with the floating model and gravity, the root on its manifold (the core's
//! `Stepper`, as the query protocol's `simulate`; the quaternion stays unit). The joint-level
//! parts act on the joints only: a torque command has one value per joint (the root is not
//! actuated), joint stops, the encoder and the log's columns skip the root. What has no
//! meaning for a free base is refused by name, never simulated wrong: a joint target
//! (computed torque would have to actuate the root), kinematic motion without dynamics, and
//! the collision stage ([`refuse_floating`]). [`Pipeline::root_transform`] is where the base
//! link stands relative to where it started; [`Pipeline::joint_state`] the joints' part.
//!
//! Entry points: [`Pipeline::build`], [`Pipeline::step`], [`Pipeline`]'s `Display` (the printable
//! description), [`Command`].

use crate::model::{BuildError, Model, SceneGeometry, StepError};
use crate::stages::{self, logging::LogHandle, logging::Logging};
use nalgebra::{DVector, Matrix4};
use robosim_collision::robot::Scene;
use robosim_kinematics::{Robot, RootKind, State};
use robosim_model::{Command, Data, Options, OptionsError};
use std::fmt;

/// A scene's simulation: its model, its data, and the log sink if logging is declared.
pub struct Pipeline {
    model: Model,
    data: Data,
    log: Option<(Logging, LogHandle)>,
}

/// One stage as the description prints it.
struct Described {
    name: &'static str,
    settings: String,
    depends_on: &'static str,
}

impl Pipeline {
    /// Builds the pipeline `effects` declares for `robot` starting at rest at `q0`: each
    /// declared effect's model part, checked, and the `Data` its stages fill, sized once.
    pub fn build(
        robot: &Robot,
        q0: &[f64],
        effects: &Options,
        geometry: SceneGeometry,
    ) -> Result<Pipeline, BuildError> {
        let bad = |field: &str, reason: String| {
            BuildError::Options(OptionsError {
                field: field.to_string(),
                reason,
            })
        };
        robot.validate().map_err(|source| BuildError::Robot {
            field: "robot",
            source,
        })?;
        robot.check_q(q0).map_err(|source| BuildError::Robot {
            field: "q0",
            source,
        })?;
        if let Some(root) = &robot.root {
            refuse_floating(root.kind, effects)?;
        }
        let (n, nv) = (robot.dof(), robot.nv());
        let mut data = Data {
            state: State {
                q: DVector::from_column_slice(q0),
                qd: DVector::zeros(nv),
                qdd: DVector::zeros(nv),
                t: 0.0,
            },
            command: Command::Idle,
            tau: DVector::zeros(nv),
            step: 0,
            frames: None,
            q_measured: None,
            contact: None,
            contact_steps: 0,
            q_safe: None,
            integrator: None,
        };
        let mut model = Model {
            robot: robot.clone(),
            kinematics: None,
            dt: effects.dt,
            options: effects.clone(),
            motion: None,
            dynamics: None,
            limits: None,
            collision: None,
            encoder: None,
        };
        if !(model.dt > 0.0 && model.dt.is_finite()) {
            return Err(bad(
                "dt",
                format!("must be a positive number of seconds, got {}", model.dt),
            ));
        }
        match &effects.dynamics {
            Some(d) => {
                let (part, integrator) =
                    stages::dynamics::build(robot, d, effects.joint_friction.as_ref())?;
                model.dt = d.dt;
                model.dynamics = Some(part);
                data.integrator = Some(integrator);
            }
            None if effects.kinematics => {
                if !(effects.max_speed > 0.0 && effects.max_speed.is_finite()) {
                    return Err(bad(
                        "max_speed",
                        format!("must be positive, got {}", effects.max_speed),
                    ));
                }
                model.motion = Some(effects.max_speed);
            }
            None => {}
        }
        if effects.joint_limits {
            model.limits = Some(stages::limits::build(robot)?);
        }
        if effects.kinematics {
            data.frames = Some(vec![Matrix4::identity(); n + 2]);
        }
        if effects.kinematics || effects.collision.as_ref().is_some_and(|c| c.enabled) {
            model.kinematics = Some(robosim_kinematics::KinematicModel::new(robot));
        }
        if let Some(c) = effects.collision.as_ref().filter(|c| c.enabled) {
            model.collision = Some(stages::collision::build(robot, c, geometry)?);
            data.contact = Some(false);
            data.q_safe = Some(DVector::from_column_slice(q0));
        }
        if let Some(e) = &effects.encoder {
            model.encoder = Some(stages::encoder::build(robot, e)?);
            data.q_measured = Some(DVector::zeros(n));
        }
        let log = match &effects.logging {
            Some(l) => {
                let joints: Vec<_> = robot.joints.iter().map(|j| j.joint_type).collect();
                Some(Logging::new(
                    &joints,
                    l,
                    data.q_measured.is_some(),
                    data.contact.is_some(),
                )?)
            }
            None => None,
        };
        Ok(Pipeline { model, data, log })
    }

    /// What the simulation is of (fixed).
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// Where it stands: state, command, the declared stages' outputs and memories. Changed
    /// only by [`Pipeline::step`], [`Pipeline::set_command`], [`Pipeline::teleport`] and
    /// [`Pipeline::rewind`] (checked). Clone it to save the step.
    pub fn data(&self) -> &Data {
        &self.data
    }

    /// Puts a saved [`Data`] back (from [`Pipeline::data`] of this pipeline): the next step
    /// goes on from it exactly as it did the first time. Refused when `saved` does not fit the
    /// pipeline (another robot's size, another set of declared stages). The log is output:
    /// rewound steps are logged again.
    pub fn rewind(&mut self, saved: Data) -> Result<(), StepError> {
        let fits = |a: bool, b: bool| a == b;
        let (nq, nv) = (self.model.robot.nq(), self.model.robot.nv());
        let ok = saved.state.q.len() == nq
            && saved.state.qd.len() == nv
            && saved.tau.len() == nv
            && fits(saved.frames.is_some(), self.data.frames.is_some())
            && fits(saved.q_measured.is_some(), self.data.q_measured.is_some())
            && fits(saved.contact.is_some(), self.data.contact.is_some())
            && fits(saved.q_safe.is_some(), self.data.q_safe.is_some())
            && fits(saved.integrator.is_some(), self.data.integrator.is_some());
        if !ok {
            return Err(StepError::Command(
                "rewind to data that does not fit this pipeline (other joints or stages)".into(),
            ));
        }
        self.data = saved;
        Ok(())
    }

    /// One step (MuJoCo's `mj_step`): every declared stage in the fixed order, then the clock.
    /// Time advances by `model.dt`.
    pub fn step(&mut self) -> Result<(), StepError> {
        let (m, d) = (&self.model, &mut self.data);
        // the motion source: depends on q, q̇ and the command
        if let Some(dy) = &m.dynamics {
            stages::dynamics::run(m, dy, d)?;
        } else if let Some(max_speed) = m.motion {
            stages::motion::run(m, max_speed, d);
        }
        // depends on q, q̇
        if let Some(limits) = &m.limits {
            stages::limits::run(limits, d);
        }
        // depend only on q
        if m.options.kinematics {
            stages::frames::run(m, d)?;
        }
        if let Some(c) = &m.collision {
            stages::collision::run(m, c, d)?;
        }
        if let Some(e) = &m.encoder {
            stages::encoder::run(e, d);
        }
        // depends on all of the above
        if let Some((log, _)) = &mut self.log {
            log.run(m, d)?;
        }
        d.step += 1;
        // the clock is kept as step · dt so that it does not drift by summation
        d.state.t = d.step as f64 * m.dt;
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
                if let Some(root) = &self.model.robot.root {
                    return Err(StepError::Command(format!(
                        "a joint target for a robot on a {} base: the simulator's joint-target \
                         controller (computed torque) would need to actuate the floating root, \
                         which no motor does; command joint torques (`torque`, one per joint) \
                         instead",
                        root.kind.name()
                    )));
                }
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
                if self.model.dynamics.is_none() {
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
    /// Instance Space). The command stays. Checked: length and finite values. A floating
    /// robot's `q` holds its root first ([`Robot::nq`] values; the session's committed q has
    /// the root at the identity, which puts the base back where the robot object stands).
    pub fn teleport(&mut self, q: &[f64]) -> Result<(), StepError> {
        let n = self.model.robot.nq();
        if q.len() != n {
            return Err(StepError::Command(format!(
                "teleport to {} values but the robot has {n} coordinates",
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
        if let Some(q_safe) = self.data.q_safe.as_mut() {
            q_safe.copy_from(&q);
        }
        Ok(())
    }

    /// A floating robot's root motion `M(q_root)` now (link frame 0 = `robot.base · M`), `None`
    /// for a fixed base: where the simulated base link stands relative to where it started.
    pub fn root_transform(&self) -> Option<Matrix4<f64>> {
        let root = self.model.robot.root.as_ref()?;
        let nq = root.kind.nq();
        Some(root.kind.transform(&self.data.state.q.as_slice()[..nq]))
    }

    /// The joints' part of the state: (q, q̇, τ) without a floating root's coordinates
    /// (`n` values each; the whole vectors for a fixed base).
    pub fn joint_state(&self) -> (&[f64], &[f64], &[f64]) {
        let r = &self.model.robot;
        let (nq, nv) = (r.root_nq(), r.root_nv());
        let d = &self.data;
        (
            &d.state.q.as_slice()[nq..],
            &d.state.qd.as_slice()[nv..],
            &d.tau.as_slice()[nv..],
        )
    }

    /// The collision stage's obstacles (`None` when collision is not declared), to move an
    /// obstacle in place (`Scene::set_pose`) instead of rebuilding the pipeline.
    pub fn obstacles_mut(&mut self) -> Option<&mut Scene> {
        self.model.collision.as_mut().map(|c| &mut c.scene)
    }

    /// Writes out the rows the logging stage buffers, so a reader of its CSV file sees every
    /// step taken so far (the file is also flushed when the pipeline is dropped).
    pub fn flush_log(&mut self) -> Result<(), StepError> {
        match &mut self.log {
            Some((log, _)) => log.flush(),
            None => Ok(()),
        }
    }

    /// The declared stages in the order [`Pipeline::step`] runs them.
    fn described(&self) -> Vec<Described> {
        use stages::*;
        let m = &self.model;
        let one = |name, settings, depends_on| Described {
            name,
            settings,
            depends_on,
        };
        let mut out = Vec::new();
        if let Some(dy) = &m.dynamics {
            out.push(one(
                dynamics::NAME,
                dynamics::describe(dy),
                dynamics::DEPENDS_ON,
            ));
        } else if let Some(max_speed) = m.motion {
            out.push(one(
                motion::NAME,
                motion::describe(max_speed),
                motion::DEPENDS_ON,
            ));
        }
        if m.limits.is_some() {
            out.push(one(limits::NAME, limits::describe(), limits::DEPENDS_ON));
        }
        if self.data.frames.is_some() {
            out.push(one(frames::NAME, frames::describe(), frames::DEPENDS_ON));
        }
        if let Some(c) = &m.collision {
            out.push(one(
                collision::NAME,
                collision::describe(c),
                collision::DEPENDS_ON,
            ));
        }
        if let Some(e) = &m.encoder {
            out.push(one(
                encoder::NAME,
                encoder::describe(e),
                encoder::DEPENDS_ON,
            ));
        }
        if let Some((log, _)) = &self.log {
            out.push(one(logging::NAME, log.describe(), logging::DEPENDS_ON));
        }
        out
    }

    /// The effects the scene did not declare (or declared off), for the description.
    fn left_out(&self) -> Vec<&'static str> {
        let m = &self.model;
        let mut out = Vec::new();
        for (name, declared) in [
            ("dynamics", m.dynamics.is_some()),
            ("joint_limits", m.limits.is_some()),
            ("kinematics", self.data.frames.is_some()),
            ("collision", m.collision.is_some()),
            ("encoder", m.encoder.is_some()),
            ("logging", self.log.is_some()),
        ] {
            if !declared {
                out.push(name);
            }
        }
        out
    }

    /// The names of the stages, in order.
    pub fn stage_names(&self) -> Vec<&'static str> {
        self.described().iter().map(|s| s.name).collect()
    }

    /// The rows logged in memory so far (`t_s`, then the `signals` columns as declared; empty
    /// when logging is not declared or writes to a file).
    pub fn log(&self) -> Vec<Vec<f64>> {
        self.log.as_ref().map(|(_, h)| h.rows()).unwrap_or_default()
    }

    /// The CSV header of the log, if logging is declared: `t_s`, then one column per signal and
    /// joint named with its unit (`q1_rad`, `q3_m`, `qd1_rad_s`, `tau1_Nm`, `contact`).
    pub fn log_header(&self) -> Option<Vec<String>> {
        self.log.as_ref().map(|(_, h)| h.header())
    }
}

/// What a floating robot's pipeline cannot have, refused by name (module docs of
/// [`crate::pipeline`], "Floating bases"): its motion must come from the dynamics effect
/// (kinematic motion moves joints towards targets and has no law for a free base), and the
/// collision stage's sweep and its `on_contact` responses act on one coordinate per joint.
fn refuse_floating(kind: RootKind, effects: &Options) -> Result<(), OptionsError> {
    let root = kind.name();
    if effects.dynamics.is_none() && effects.kinematics {
        return Err(OptionsError {
            field: "dynamics".into(),
            reason: format!(
                "the robot has a {root} base, which kinematic motion (kinematics without \
                 dynamics) does not move: declare the dynamics effect to simulate it"
            ),
        });
    }
    if effects.collision.as_ref().is_some_and(|c| c.enabled) {
        return Err(OptionsError {
            field: "collision".into(),
            reason: format!(
                "the robot has a {root} base: the simulator's collision stage (its swept check \
                 and its on_contact response) acts on joint coordinates only and does not \
                 handle a floating root; leave collision out of the effects to simulate it"
            ),
        });
    }
    Ok(())
}

impl fmt::Display for Pipeline {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = if self.model.robot.name.is_empty() {
            "robot"
        } else {
            &self.model.robot.name
        };
        let root = match &self.model.robot.root {
            Some(r) => format!(" on a {} base", r.kind.name()),
            None => String::new(),
        };
        writeln!(
            f,
            "pipeline for {name} ({} joints{root}), step {} s:",
            self.model.robot.dof(),
            self.model.dt
        )?;
        let stages = self.described();
        if stages.is_empty() {
            writeln!(f, "  (no stages: the robot stands still)")?;
        }
        for (i, s) in stages.iter().enumerate() {
            writeln!(
                f,
                "  {}. {:<13} {:<58} depends on {}",
                i + 1,
                s.name,
                s.settings,
                s.depends_on
            )?;
        }
        let left_out = self.left_out();
        if !left_out.is_empty() {
            writeln!(
                f,
                "  not declared (not in the pipeline, no cost): {}",
                left_out.join(", ")
            )?;
        }
        Ok(())
    }
}
