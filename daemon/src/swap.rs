//! The swap stage: the scene-level effect `oru_swap` in the daemon. Built only when the scene
//! declares it (a scene that does not pays nothing: no stage, no field in `get`). The plan is
//! `robosim_simulator::swap` — the same code as `robosim study station` — timed from the
//! declared start on the pipelines' clock. After every step of the robots' pipelines (and of
//! the space stage, which it overrides for the parked robot), with t the pipelines' clock:
//!
//! * **servicer**: given the plan's joint values at t + dt as its target, so its pipeline
//!   (kinematic motion, joint limits, collision) takes it there in the next step — the plan
//!   moves far below the speed limit, so it is there exactly unless a stage stops it;
//! * **the robot carrying the ORU**: while the plan has it parked, its target is the service
//!   angle (the space stage's sun tracking resumes when the plan releases it);
//! * **the ORUs**: where the plan's events have put them by t — on the mount (moving with the
//!   carrying robot's link as it is now), in the servicer's grip (moving with its effector as
//!   it is now) or set down. Their poses are published with the robots' link poses on
//!   `state/simulator`, as pose records of the ORU objects relative to their parents, so a
//!   display attached to the session draws them where they are (as it draws the links). The
//!   servicer's collision stage sees them there too (their obstacles are moved with them; in
//!   its grip an ORU is part of the servicer, as in the study, and not its obstacle).
//!   The other robots are its obstacles where their pipelines have them (the daemon moves
//!   them before every step, [`crate::follow`]), the parked array at its service angle; the
//!   ORUs are left out of that (this stage places them). The daemon commits nothing to the Instance Space: the committed model keeps the scene's
//!   placement, as it keeps the committed joints.
//!
//! What `get` reports is [`SwapStage::status`] under the key `"swap"`.

use crate::Sim;
use nalgebra::Isometry3;
use robosim_collision::robot::isometry_from_matrix;
use robosim_instance_space::Snapshot;
use robosim_instance_space::layout::PoseRec;
use robosim_model::Options;
use robosim_model::parts::SceneParts;
use robosim_simulator::swap::{Held, OruState, Plan, Swap, SwapError, servicer_at};
use robosim_simulator::{Command, StepError};
use serde_json::{Value, json};

/// Why the swap stage could not be built or stopped: the plan's error, the robot or object
/// missing (named), or a robot's pipeline refusing the target (its error kept).
#[derive(Debug, thiserror::Error)]
pub enum SwapStageError {
    /// The declaration cannot be planned (the plan's words: what and where).
    #[error(transparent)]
    Plan(#[from] SwapError),
    /// A robot the swap names has no pipeline.
    #[error("robot {0} is not simulated (no pipeline of that name)")]
    NotSimulated(String),
    /// A robot the swap moves is held at its committed joints (`Sim::held`: never stepped),
    /// so the swap could not move it; `why` is the hold's reason.
    #[error("robot {robot} is held ({why}): the ORU swap needs it stepped")]
    HeldRobot { robot: String, why: String },
    /// An ORU object the swap names is not in the Instance Space (its path).
    #[error("no object {0} in the Instance Space")]
    NoObject(String),
    /// A robot's pipeline refused the target the plan gave it (`role`: servicer, or parking for
    /// the carrying robot; the pipeline's error kept).
    #[error("{role} {robot}: {source}")]
    Command {
        role: &'static str,
        robot: String,
        source: StepError,
    },
}

/// One ORU object of the Instance Space: its id, what its pose is relative to, its frame in
/// the ORU frame.
struct Object {
    path: String,
    id: u64,
    /// Its parent is the carrying robot's link (the failed ORU): the pose is relative to the
    /// link as it is now. Else the parent's world pose (fixed).
    on_link: bool,
    parent_world: Isometry3<f64>,
    in_oru: Isometry3<f64>,
    joint: f64,
    /// The servicer's collision obstacles that are this ORU's geometry: (index in its scene,
    /// pose relative to the ORU object).
    obstacles: Vec<(usize, Isometry3<f64>)>,
}

/// The declared swap, its plan and where the ORUs are (module docs).
pub(crate) struct SwapStage {
    swap: Swap,
    plan: Plan,
    servicer: usize,
    array: usize,
    objects: Vec<Object>,
    t: f64,
    state: OruState,
    /// The ORU frames in the world (failed, spare) and the objects' world poses, at `t`.
    frames: [Isometry3<f64>; 2],
    records: Vec<PoseRec>,
}

fn rows(m: &Isometry3<f64>) -> [f64; 12] {
    let h = m.to_homogeneous();
    let mut out = [0.0; 12];
    for r in 0..3 {
        for c in 0..4 {
            out[r * 4 + c] = h[(r, c)];
        }
    }
    out
}

fn iso(p: &[f64; 12]) -> Isometry3<f64> {
    let mut m = nalgebra::Matrix4::identity();
    for r in 0..3 {
        for c in 0..4 {
            m[(r, c)] = p[r * 4 + c];
        }
    }
    isometry_from_matrix(&m)
}

impl SwapStage {
    /// The stage the scene's declaration asks for, or `None` (no `oru_swap` declared).
    pub(crate) fn build(
        effects: &Options,
        scene: &SceneParts,
        sims: &mut [Sim],
        snap: &Snapshot,
    ) -> Result<Option<SwapStage>, SwapStageError> {
        let Some(fx) = &effects.oru_swap else {
            return Ok(None);
        };
        let swap = Swap::from_scene(scene, fx)?;
        let sim_of = |i: usize| {
            let name = &scene.robots[i].name;
            let k = sims
                .iter()
                .position(|s| &s.name == name)
                .ok_or_else(|| SwapStageError::NotSimulated(name.clone()))?;
            match &sims[k].held {
                Some(why) => Err(SwapStageError::HeldRobot {
                    robot: name.clone(),
                    why: why.clone(),
                }),
                None => Ok(k),
            }
        };
        let (servicer, array) = (sim_of(swap.servicer)?, sim_of(swap.array)?);
        let plan = swap.schedule(fx.start_s)?;
        let mut objects = Vec::new();
        for (path, in_oru) in &swap.objects {
            let i = snap
                .find_path(path)
                .ok_or_else(|| SwapStageError::NoObject(path.clone()))?;
            let o = snap.rec(i);
            let link_id = sims[array].links.get(swap.link.wrapping_sub(1)).copied();
            let parent_world = match snap.index_of(o.parent) {
                Some(p) => iso(&snap.world_pose(p)),
                None => Isometry3::identity(),
            };
            // the ORU's geometry among the servicer's obstacles (the object or its parts,
            // named by path): they move with it, so the servicer does not meet the ghost of an
            // ORU it has moved
            let world = iso(&snap.world_pose(i));
            let mut obstacles = Vec::new();
            if let Some(scene) = sims[servicer].pipeline.obstacles_mut() {
                for (j, ob) in scene.objects().iter().enumerate() {
                    let n = &ob.name;
                    if n == path
                        || n.ends_with(&format!("/{path}"))
                        || n.contains(&format!("{path}/"))
                    {
                        obstacles.push((j, world.inverse() * ob.pose));
                    }
                }
            }
            objects.push(Object {
                path: path.clone(),
                id: o.id,
                on_link: link_id == Some(o.parent),
                parent_world,
                in_oru: *in_oru,
                joint: snap.pose(i).joint,
                obstacles,
            });
        }
        let state = swap.state(&plan, 0.0);
        let mut stage = SwapStage {
            swap,
            plan,
            servicer,
            array,
            objects,
            t: 0.0,
            state,
            frames: [Isometry3::identity(); 2],
            records: Vec::new(),
        };
        stage.update(sims, 0.0, sims[servicer].pipeline.model().dt)?;
        Ok(Some(stage))
    }

    /// For the daemon's start-up line.
    pub(crate) fn describe(&self, sims: &[Sim]) -> String {
        let end = self.plan.points.last().map_or(0.0, |p| p.0);
        format!(
            "oru_swap by {} on {}'s ORU, {:.1} to {:.1} min ({} waypoints, {} events)",
            sims[self.servicer].name,
            sims[self.array].name,
            self.swap.start_s / 60.0,
            end / 60.0,
            self.plan.points.len(),
            self.plan.events.len()
        )
    }

    /// After a step of every pipeline (and the space stage): the targets for the next step,
    /// the ORUs' poses at the pipelines' clock `t` (s); `dt` is the step.
    pub(crate) fn update(
        &mut self,
        sims: &mut [Sim],
        t: f64,
        dt: f64,
    ) -> Result<(), SwapStageError> {
        let next = t + dt;
        let (q, _) = servicer_at(&self.plan.points, next);
        let s = &mut sims[self.servicer];
        s.pipeline
            .set_command(Command::Target(nalgebra::DVector::from_vec(q)))
            .map_err(|source| SwapStageError::Command {
                role: "servicer",
                robot: s.name.clone(),
                source,
            })?;
        if self.swap.state(&self.plan, next).parked {
            let a = &mut sims[self.array];
            a.pipeline
                .set_command(Command::Target(nalgebra::DVector::from_vec(
                    self.swap.service_q.clone(),
                )))
                .map_err(|source| SwapStageError::Command {
                    role: "parking",
                    robot: a.name.clone(),
                    source,
                })?;
        }
        // where the ORUs are now
        self.t = t;
        self.state = self.swap.state(&self.plan, t);
        let qs = sims[self.servicer]
            .pipeline
            .data()
            .state
            .q
            .as_slice()
            .to_vec();
        let a = &sims[self.array];
        let qa = a.pipeline.data().state.q.as_slice();
        let link = isometry_from_matrix(
            &robosim_kinematics::fk::link_frames(&a.pipeline.model().robot, qa)[self.swap.link],
        );
        self.records.clear();
        let mut moved = Vec::new();
        for (i, h) in [self.state.failed, self.state.spare]
            .into_iter()
            .enumerate()
        {
            let f = self.swap.frame(h, qa, &qs);
            self.frames[i] = f;
            let o = &self.objects[i];
            let parent = if o.on_link { link } else { o.parent_world };
            self.records.push(PoseRec {
                id: o.id,
                pose: rows(&(parent.inverse() * f * o.in_oru)),
                joint: o.joint,
            });
            // in the grip the ORU is part of the servicer (as in the study), not its obstacle
            let carried = matches!(h, Held::Carried(_));
            moved.extend(
                o.obstacles
                    .iter()
                    .map(|(j, rel)| (*j, f * o.in_oru * rel, carried)),
            );
        }
        if let Some(scene) = sims[self.servicer].pipeline.obstacles_mut() {
            for (j, pose, carried) in moved {
                let in_use = scene.objects().get(j).is_some_and(|o| o.in_use);
                if carried && in_use {
                    scene.dont_use(j);
                } else if !carried {
                    scene.set_pose(j, pose);
                    if !in_use {
                        scene.use_object(j);
                    }
                }
            }
        }
        Ok(())
    }

    /// The ORU objects' ids: the stage places them (and their parts) in the servicer's
    /// obstacle scene itself, so the daemon does not move them with the carrying robot.
    pub(crate) fn object_ids(&self) -> impl Iterator<Item = u64> + '_ {
        self.objects.iter().map(|o| o.id)
    }

    /// The ORU objects' pose records (relative to their parents) at the last update, published
    /// with the link poses.
    pub(crate) fn records(&self) -> &[PoseRec] {
        &self.records
    }

    /// The `"swap"` object of `get`: the plan's activity at t, whether the carrying robot is
    /// parked, the events so far, each ORU's state, its frame's position (the grapple: centre
    /// of the top face) and its object's world pose.
    pub(crate) fn status(&self, sims: &[Sim]) -> Value {
        let held = |h: Held| match h {
            Held::OnArray => "on_mount",
            Held::Carried(_) => "carried",
            Held::Fixed(_) => "set_down",
        };
        let orus: Vec<Value> = [("failed", self.state.failed), ("spare", self.state.spare)]
            .iter()
            .enumerate()
            .map(|(i, (name, h))| {
                let p = self.frames[i].translation.vector;
                json!({
                    "oru": name,
                    "object": self.objects[i].path,
                    "held": held(*h),
                    "position_m": [p.x, p.y, p.z],
                    "object_world": rows(&(self.frames[i] * self.objects[i].in_oru)),
                })
            })
            .collect();
        let events: Vec<Value> = self
            .plan
            .events
            .iter()
            .filter(|(te, _)| *te <= self.t)
            .map(|(te, e)| json!({"t_s": te, "event": format!("{e:?}")}))
            .collect();
        json!({
            "t_s": self.t,
            "servicer": sims[self.servicer].name,
            "robot": sims[self.array].name,
            "start_s": self.swap.start_s,
            "end_s": self.plan.points.last().map_or(0.0, |p| p.0),
            "activity": servicer_at(&self.plan.points, self.t).1,
            "parked": self.state.parked,
            "events": events,
            "orus": orus,
        })
    }
}
