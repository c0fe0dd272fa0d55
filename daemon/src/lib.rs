//! `robosim simulator`: the headless simulator daemon of a session.
//!
//! For every robot of the Instance Space it builds the per-step pipeline the scene declares
//! (`robosim_simulator::Pipeline`: dynamics with its integrator, joint limits, collision with
//! its mode, encoder quantisation, logging — only what is declared) and steps it:
//! * `--mode realtime` (default): one step per `dt` of wall time while running (steps asked for
//!   while paused are taken at once);
//! * `--mode fast`: as fast as possible;
//! * `--mode lockstep`: only when a client says `step`.
//!
//! It owns the high-rate state and publishes it on `state/simulator` (joint q, qd, τ, link
//! poses, time), every record naming the Instance Space version it applies to. Other processes
//! command it on `state/simulator/commands` with JSON lines (`robosim simctl`, [`ctl`]):
//! `{"cmd": "target", "robot": NAME, "q": [...]}`, `{"cmd": "torque", "robot", "tau"}`,
//! `{"cmd": "pause"}`, `{"cmd": "resume"}`, `{"cmd": "step", "n": N}`, `{"cmd": "reset"}`, and
//! `{"cmd": "get"}`, answered with the simulator's state as JSON ([`status`]). Every command is
//! validated like a transaction, and a refused one changes nothing: `n` is an integer in
//! 1..=[`MAX_STEPS_PER_COMMAND`], a target lies inside the joint limits
//! ([`Pipeline::set_command`]).
//!
//! What a run leaves: the CSV signal log the scene declares (`<session>/run/simulator-<robot>.csv`,
//! time `t_s` first, every column with its unit; flushed whenever the daemon is idle) and, with
//! `--record FILE`, an MCAP recording of joint states, link poses, contacts and events
//! ([`recording`]).
//!
//! The scene's effects come from `--effects FILE.json` (the simulator's JSON form), else from
//! the Library Space declaration the scene was instantiated from (converted type to type,
//! [`declared_effects`]), else kinematics only. The scene-level effects `orbit`,
//! `sun_tracking` and `power` run as the space stage after every step of the robots'
//! pipelines ([`space`]; only when declared): the orbit clock and sun vector, the arrays'
//! gimbals given sun-facing targets, power and battery in `get`'s `"space"` object. A declared
//! effect the daemon does not simulate is named on stderr at start ([`not_simulated`]), never
//! dropped silently.
//!
//! **Work follows the change.** The robots and obstacles come from a [`CompiledScene`]: a new
//! structure version (or a keeper restart) compiles the scene and rebuilds the pipelines; the
//! Library Space is parsed only when its sources differ from the last parse. A joint- or
//! pose-only change (MOVEJ, MOVEJI, a planner's set_joints, an obstacle moved) updates in place:
//! a robot whose committed joints changed is put there at rest ([`Pipeline::teleport`]), a
//! moved obstacle is moved in the collision stage's scene, a moved robot base rebuilds that
//! robot's pipeline only. Robots that were not touched keep simulating undisturbed.
//!
//! **Robots see each other where they are simulated.** Each pipeline's obstacles include the
//! other robots' links; before every step the daemon moves them to the other robots'
//! simulated joints (only robots whose q changed; placements, nothing re-tessellated), so
//! every pipeline checks against the others at the start of the step, independently of the
//! order the pipelines step in ([`follow`]).
//!
//! **Floating robots** (`robosim import urdf FILE --floating [planar]`, issue 36 item 2): the
//! robot object is the base link, and the session's q holds the root at the identity. The
//! robot's pipeline holds its whole state, `[q_root, q_joints]` / `[v_root, joints]`, and the
//! dynamics stage integrates it with the floating model and gravity, root on its manifold (the
//! core `Stepper`, as the query protocol's `simulate`; `Pipeline` module docs). Every published
//! state gives the joints' q, q̇, τ (the root left out) and the links relative to the base
//! link, **plus the robot object's pose**: its committed pose (relative to its parent) composed
//! with the simulated root motion, so a display or reader of `state/simulator` sees the body
//! move; `get` adds the root's coordinates and the base link's world pose (`status`). The
//! recording's base is the moved one. Nothing is committed to the Instance Space (the object's
//! committed pose stays where it was written). **Another writer** moving the robot object's
//! pose *re-bases* the robot: as for a fixed robot whose base moved, its pipeline is rebuilt
//! there — root at the identity at the written pose, at rest, the committed joints, its clock
//! from 0; a committed joint change teleports it to the committed q, which puts the root back
//! at the identity (the base where the object stands), at rest. Refused by name (the daemon
//! stops with the pipeline's error, `DaemonError::Pipeline`): kinematic motion without the
//! dynamics effect and the collision effect; a `target` command for it is refused (`simctl`'s
//! answer) — command joint torques (one per joint) instead.
//!
//! Entry points: [`run`] (the process) with its [`Options`], [`ctl`] (`robosim simctl`),
//! [`Mode`], [`Counters`].
//!
//! **After `kill -9`:** the high-rate state is the daemon's alone and is not journaled; a
//! restarted daemon starts again from the joint values committed in the Instance Space, at
//! t = 0, with a new record sequence (seq 1). The keeper and the Instance Space do not notice
//! either event. Readers see the state service go silent and then resume (tested).

#![forbid(unsafe_code)]

pub mod bench;
mod ctl;
mod follow;
mod ops;
pub mod recording;
mod space;
pub mod status;
mod swap;

pub use ctl::ctl;

use nalgebra::DVector;
use robosim_instance_space::layout::PoseRec;
use robosim_instance_space::state::{CommandReceiver, JointStateRec, StatePublisher};
use robosim_instance_space::{FollowTrouble, Kind, Reader, Session, Snapshot};
use robosim_library::Library;
use robosim_model::Options as SceneEffects;
use robosim_model::parts::SceneParts;
use robosim_record::{Level, time_ns};
use robosim_scene::{CompiledScene, Origin, Sync, link_poses};
use robosim_simulator::{Command, Pipeline, SceneGeometry};
use serde_json::Value;
use std::collections::HashSet;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Why the daemon (or `simctl`) stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum DaemonError {
    #[error(transparent)]
    Session(#[from] robosim_instance_space::SessionError),
    #[error(transparent)]
    Reader(#[from] robosim_instance_space::ReaderError),
    #[error(transparent)]
    State(#[from] robosim_instance_space::state::StateError),
    /// The scene's effects cannot be had (the message).
    #[error("{0}")]
    Effects(String),
    /// The scene object's origin record does not parse (the JSON error, kept).
    #[error("{0}")]
    OriginRecord(#[source] serde_json::Error),
    /// The session's library publication does not load.
    #[error(transparent)]
    Library(#[from] robosim_scene::SceneError),
    /// An `--effects` file cannot be read.
    #[error(transparent)]
    Read(#[from] robosim_input::InputError),
    /// An `--effects` file's declaration was refused.
    #[error("{file}: {source}")]
    EffectsFile {
        file: String,
        source: robosim_model::OptionsError,
    },
    /// A scene-level stage (`stage`: space, swap) cannot be built from the declaration.
    #[error("the {stage} stage: {source}")]
    Stage {
        stage: &'static str,
        source: StageError,
    },
    /// A robot's pipeline cannot be built from the declared effects.
    #[error("robot {robot}: {source}")]
    Pipeline {
        robot: String,
        source: robosim_simulator::BuildError,
    },
    /// A robot's pipeline refused the committed q.
    #[error("robot {robot}: {source}")]
    Robot {
        robot: String,
        source: robosim_simulator::StepError,
    },
    #[error("{0}")]
    Usage(String),
    #[error("the simulator refused {command}: {reason}")]
    Refused { command: String, reason: String },
    #[error(transparent)]
    Record(#[from] robosim_record::RecordError),
    /// A robot's CSV log could not be written.
    #[error("simulator log: robot {robot}: {source}")]
    Log {
        robot: String,
        source: robosim_simulator::StepError,
    },
}

/// Why a scene-level stage (space, swap) was not built: the declaration's problem in words,
/// or the orbit's typed error.
#[derive(Debug, thiserror::Error)]
pub enum StageError {
    #[error("{0}")]
    Refused(String),
    #[error(transparent)]
    Orbit(#[from] robosim_simulator::orbit::OrbitError),
    /// The swap's plan, robot, object or first target (its error kept).
    #[error(transparent)]
    Swap(#[from] swap::SwapStageError),
    /// The attitude model refused the declaration (its error kept).
    #[error(transparent)]
    Attitude(#[from] robosim_simulator::attitude::AttitudeError),
}

impl From<String> for StageError {
    fn from(message: String) -> Self {
        StageError::Refused(message)
    }
}

type Result<T> = std::result::Result<T, DaemonError>;

/// How the daemon steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// One step per `dt` of wall time.
    Realtime,
    /// As fast as possible.
    Fast,
    /// Only when a client says `step`.
    Lockstep,
}

impl Mode {
    /// The name `--mode` takes.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Realtime => "realtime",
            Mode::Fast => "fast",
            Mode::Lockstep => "lockstep",
        }
    }
}

/// How `robosim simulator` runs.
#[derive(Debug, Clone)]
pub struct Options {
    pub mode: Mode,
    /// The effects to simulate (the simulator's JSON form); `None`: the scene's declaration.
    pub effects: Option<String>,
    /// State publication rate, Hz (lock-step publishes every step).
    pub publish_hz: f64,
    /// Record the run to this MCAP file ([`recording`]).
    pub record: Option<PathBuf>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            mode: Mode::Realtime,
            effects: None,
            publish_hz: 100.0,
            record: None,
        }
    }
}

impl std::str::FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Mode, String> {
        match s {
            "realtime" => Ok(Mode::Realtime),
            "fast" => Ok(Mode::Fast),
            "lockstep" => Ok(Mode::Lockstep),
            other => Err(format!(
                "mode {other:?}: expected realtime, fast or lockstep"
            )),
        }
    }
}

/// A floating robot's object (module docs, "Floating robots"): its id, and its pose relative
/// to its parent and joint value as committed when the pipeline was built — the pose its root
/// motion is composed with in every published step.
pub(crate) struct FloatingObject {
    id: u64,
    pose: nalgebra::Matrix4<f64>,
    joint: f64,
}

/// One robot's pipeline and what the daemon knows about it.
pub(crate) struct Sim {
    pub(crate) name: String,
    links: Vec<u64>,
    /// The robot object of a floating robot (`None`: a fixed base).
    floating: Option<FloatingObject>,
    /// Link (joint) names in chain order, from the snapshot the pipeline was built from.
    pub(crate) link_names: Vec<String>,
    /// The CSV signal log, if logging is declared.
    pub(crate) log_path: Option<PathBuf>,
    /// Why the last step failed, until the pipeline is rebuilt.
    pub(crate) error: Option<String>,
    /// Why the simulator holds this robot at its committed joints instead of stepping it (a
    /// robot with mimic joints); `None`: simulated.
    pub(crate) held: Option<String>,
    /// The collision stage's verdict at the last recorded sample.
    pub(crate) contact_was: bool,
    /// The committed joint values this pipeline last adopted.
    committed_q: Vec<f64>,
    base: nalgebra::Matrix4<f64>,
    pub(crate) pipeline: Pipeline,
}

impl Sim {
    /// Where the robot's base link stands in the world now: the committed base, moved by a
    /// floating robot's simulated root motion.
    pub(crate) fn base_now(&self) -> nalgebra::Matrix4<f64> {
        match self.pipeline.root_transform() {
            Some(m) => self.base * m,
            None => self.base,
        }
    }
}

/// What the daemon did with the changes it saw (printed when it stops; read by benches).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Pipelines built (all robots) after a structure change, a reset or at start.
    pub rebuilds: u64,
    /// Joint/pose-only versions applied in place.
    pub in_place: u64,
    /// Library Space reads (the checked encoding decoded, or the source parsed).
    pub library_parses: u64,
}

/// A scene's declared effects as the daemon runs them: the same [`SceneEffects`]
/// (`robosim_model::Options`, which the library reads typed), with a declared log written to
/// `log_path` (the declaration names no file) and left out when it names no signal the
/// simulator logs ([`not_simulated`] says which it named).
pub fn declared_effects(e: &SceneEffects, log_path: &std::path::Path) -> SceneEffects {
    let mut o = e.clone();
    o.logging = o
        .logging
        .filter(|l| !l.signals.is_empty())
        .map(|l| robosim_model::LoggingEffect {
            path: Some(log_path.to_owned()),
            ..l
        });
    o
}

/// What a declaration asks for that the daemon does not simulate (said on stderr when the
/// pipelines are built): logged signals the simulator does not know.
pub fn not_simulated(e: &SceneEffects) -> Vec<String> {
    e.logging
        .iter()
        .flat_map(|l| &l.unsupported)
        .map(|s| {
            format!(
                "logged signal {s:?} (the simulator logs t, q, qd, qdd, tau, q_measured, contact)"
            )
        })
        .collect()
}

/// The Library Space, read once (the keeper's checked encoding, else parsed from the source)
/// and again only when the session's sources change.
#[derive(Default)]
struct LibraryCache {
    sources: Vec<(String, String)>,
    library: Option<Library>,
}

impl LibraryCache {
    fn get(&mut self, reader: &mut Reader, counters: &mut Counters) -> Result<&Library> {
        let published = reader.library()?;
        if self.library.is_none() || published.files != self.sources {
            let (lib, _) = robosim_scene::library_from_publication(&published)?;
            counters.library_parses += 1;
            self.sources = published.files;
            self.library = Some(lib);
        }
        self.library
            .as_ref()
            .ok_or_else(|| DaemonError::Effects("no library".into()))
    }
}

/// The library declaration and the evaluated scene, when the effects come from the library
/// (the space stage reads them; `--effects` JSON has no orbit, so it builds none).
type Declared = Option<(SceneEffects, SceneParts, Option<ops::Geometry>)>;

/// The scene's declared effects: `--effects`, else its Library Space declaration.
fn scene_effects(
    session: &Session,
    reader: &mut Reader,
    library: &mut LibraryCache,
    counters: &mut Counters,
    snap: &Snapshot,
    file: Option<&str>,
) -> Result<(SceneEffects, String, Declared)> {
    if let Some(f) = file {
        let text = robosim_input::read_to_string(
            std::path::Path::new(f),
            "an effects file",
            robosim_input::Limit::TEXT,
        )?;
        return Ok((
            SceneEffects::from_json(&text).map_err(|source| DaemonError::EffectsFile {
                file: f.to_owned(),
                source,
            })?,
            format!("from {f}"),
            None,
        ));
    }
    let scene = (0..snap.len())
        .find(|&i| snap.object(i).kind() == Some(Kind::Scene) && !snap.origin(i).is_empty());
    if let Some(i) = scene {
        let origin = Origin::from_record(snap.origin(i)).map_err(DaemonError::OriginRecord)?;
        let lib = library.get(reader, counters)?;
        if let Ok(robosim_library::Evaluated::Scene(sc)) = origin.evaluate(lib) {
            let path = session.run_dir().join("simulator-log.csv");
            return Ok((
                declared_effects(&sc.effects, &path),
                format!("declared by scene {}", origin.declaration),
                Some((
                    sc.effects.clone(),
                    sc.parts(),
                    (sc.effects.attitude.is_some()).then(|| ops::Geometry::of(&sc)),
                )),
            ));
        }
    }
    Ok((
        SceneEffects {
            kinematics: true,
            ..SceneEffects::default()
        },
        "none declared: kinematics only".into(),
        None,
    ))
}

/// The daemon's model of the session: the compiled scene, the effects and one pipeline per
/// robot.
struct Daemon<'a> {
    session: &'a Session,
    effects_file: Option<&'a str>,
    scene: CompiledScene,
    library: LibraryCache,
    effects: SceneEffects,
    source: String,
    sims: Vec<Sim>,
    /// The orbit, sun tracking and power, when the scene declares an orbit ([`space`]).
    space: Option<space::SpaceStage>,
    /// The ORU swap, when the scene declares `oru_swap` ([`swap`]).
    swap: Option<swap::SwapStage>,
    /// Where each robot's links are in the other pipelines' obstacle scenes ([`follow`]).
    follow: Option<follow::Follow>,
    counters: Counters,
    /// Steps since the pipelines were last built (all of them).
    clock_steps: u64,
    /// [`simulated_structure`] of the snapshot the pipelines were built from.
    structure: Option<u64>,
}

/// A hash of what the simulation is built from: every object with geometry, mass or a
/// kinematic role and its ancestors (name, parent, kind, flags, geometry generation, joint
/// parameters, mass properties), in id order. Objects outside that — the automation plant's
/// units and the items holding only such — do not enter: moving one (isolating a unit, bringing
/// a spare on line) changes the Instance Space's structure but not the simulation, which then
/// keeps its pipelines, its stages and its clock (issue 38: the station's clock restarted at 0
/// when the rules brought a spare on line).
fn simulated_structure(snap: &Snapshot) -> u64 {
    use std::hash::{Hash, Hasher};
    let n = snap.len();
    let mut keep = vec![false; n];
    for i in 0..n {
        let r = snap.rec(i);
        if r.geom_gen == 0 && r.kin_tag == 0 && r.mass == 0.0 && snap.geometry(i).is_none() {
            continue;
        }
        let mut k = Some(i);
        while let Some(j) = k.filter(|&j| !keep[j]) {
            keep[j] = true;
            let parent = snap.rec(j).parent;
            k = (parent != 0).then(|| snap.index_of(parent)).flatten();
        }
    }
    let mut kept: Vec<usize> = (0..n).filter(|&i| keep[i]).collect();
    kept.sort_by_key(|&i| snap.rec(i).id);
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for i in kept {
        let r = snap.rec(i);
        (
            snap.name(i),
            r.id,
            r.parent,
            r.kind,
            r.flags,
            r.geom_gen,
            r.kin_tag,
        )
            .hash(&mut h);
        (r.joint_kind, r.convention, r.index_or_family).hash(&mut h);
        let numbers = r.dh.iter().chain(&r.tool).chain([&r.mass]).chain(&r.com);
        for x in numbers.chain(&r.inertia) {
            x.to_bits().hash(&mut h);
        }
    }
    h.finish()
}

impl Daemon<'_> {
    /// The pipeline of compiled robot `r` (shares the compiled solids).
    fn pipeline(&self, r: &robosim_scene::CompiledRobot, snap: &Snapshot) -> Result<Sim> {
        // A robot with mimic joints (URDF `<mimic>`): the pipeline would integrate every joint
        // on its own, so its followers would leave their leaders. It is held at its committed
        // joints (published, an obstacle to the others, never stepped; commands to it refused
        // with this reason) — the other robots of the session are simulated as before.
        let held = snap.robot(r.name()).and_then(|view| {
            let j = view.joints.iter().position(|j| j.mimic.is_some())?;
            Some(format!(
                "robot {}: joint {} ({}) is a mimic joint (it follows another); the simulator \
                 does not integrate a coupled robot — it would move the follower on its own — \
                 so it holds the robot at its committed joints",
                r.name(),
                j,
                snap.name(view.joints[j].index)
            ))
        });
        if let Some(why) = &held {
            eprintln!("simulator: {why}");
        }
        let around = self.scene.obstacles(r, &HashSet::new());
        if let (Some(why), Some(c)) = (around.refused.first(), self.effects.collision.as_ref())
            && c.enabled
        {
            return Err(DaemonError::Usage(format!(
                "robot {}: the collision effect cannot be simulated honestly: {why}",
                r.name()
            )));
        }
        let obstacles = around.scene;
        // One log per robot: a scene with two robots must not write one file twice.
        let mut effects = self.effects.clone();
        let run_dir = self.session.run_dir();
        if let Some(l) = effects.logging.as_mut()
            && l.path.as_ref().is_none_or(|p| p.starts_with(&run_dir))
        {
            l.path = Some(run_dir.join(format!("simulator-{}.csv", r.name())));
        }
        let geometry = SceneGeometry {
            obstacles,
            link_solids: Some(r.solids.clone()),
        };
        let pipeline = Pipeline::build(&r.robot, &r.q, &effects, geometry).map_err(|source| {
            DaemonError::Pipeline {
                robot: r.name().to_owned(),
                source,
            }
        })?;
        let floating = r.robot.root.as_ref().map(|_| {
            let rec = snap.pose(r.index);
            FloatingObject {
                id: r.id,
                pose: robosim_scene::pose::to_matrix(&rec.pose),
                joint: rec.joint,
            }
        });
        Ok(Sim {
            name: r.name().to_owned(),
            links: r.links.clone(),
            floating,
            link_names: r
                .links
                .iter()
                .map(|id| snap.index_of(*id).map_or("", |k| snap.name(k)).to_owned())
                .collect(),
            log_path: effects.logging.as_ref().and_then(|l| l.path.clone()),
            error: None,
            held,
            contact_was: false,
            committed_q: r.q.clone(),
            base: r.robot.base,
            pipeline,
        })
    }

    /// Every robot's pipeline from the compiled scene (after a structure change or a reset).
    fn rebuild(&mut self, reader: &mut Reader, snap: &Snapshot) -> Result<()> {
        let (effects, source, declared) = scene_effects(
            self.session,
            reader,
            &mut self.library,
            &mut self.counters,
            snap,
            self.effects_file,
        )?;
        self.effects = effects;
        self.source = source;
        for (name, e) in self.scene.failed() {
            eprintln!("simulator: robot {name} is not simulated: {e}");
        }
        self.sims = self
            .scene
            .robots()
            .iter()
            .map(|r| self.pipeline(r, snap))
            .collect::<Result<_>>()?;
        self.space = None;
        self.swap = None;
        if let Some((fx, scene, geometry)) = declared {
            let (fx, scene) = (&fx, &scene);
            for what in not_simulated(fx) {
                eprintln!("simulator: WARNING: declared but not simulated: {what}");
            }
            let mut notes = Vec::new();
            self.space = space::SpaceStage::build(fx, scene, geometry, &mut self.sims, &mut notes)
                .map_err(|source| DaemonError::Stage {
                    stage: "space",
                    source,
                })?;
            for n in notes {
                eprintln!("simulator: WARNING: {n}");
            }
            self.swap = swap::SwapStage::build(fx, scene, &mut self.sims, snap).map_err(|e| {
                DaemonError::Stage {
                    stage: "swap",
                    source: e.into(),
                }
            })?;
        }
        self.refollow(snap);
        self.counters.rebuilds += 1;
        self.clock_steps = 0;
        Ok(())
    }

    /// The robots' link objects in the other pipelines' scenes, from the compiled (committed)
    /// scene, leaving out what the swap stage places ([`follow`]).
    fn refollow(&mut self, snap: &Snapshot) {
        let owned = self
            .swap
            .as_ref()
            .map(|sw| {
                sw.object_ids()
                    .flat_map(|id| robosim_scene::solids::subtree(snap, id))
                    .collect()
            })
            .unwrap_or_default();
        self.follow = Some(follow::Follow::build(&self.scene, &self.sims, &owned));
    }

    /// Brings the pipelines to `snap`; returns whether anything was applied.
    fn follow(&mut self, reader: &mut Reader, snap: &Snapshot, reset: bool) -> Result<bool> {
        match self.scene.sync(snap) {
            Sync::Compiled => {
                // a structure change outside what is simulated (the plant's units): the
                // pipelines are kept and follow in place ([`simulated_structure`])
                let key = simulated_structure(snap);
                if !reset && self.structure == Some(key) {
                    self.refollow(snap);
                    self.in_place(snap)?;
                    self.counters.in_place += 1;
                    return Ok(true);
                }
                self.rebuild(reader, snap)?;
                self.structure = Some(key);
                Ok(true)
            }
            _ if reset => {
                self.rebuild(reader, snap)?;
                self.structure = Some(simulated_structure(snap));
                Ok(true)
            }
            Sync::Unchanged => Ok(false),
            Sync::Posed => {
                self.in_place(snap)?;
                self.counters.in_place += 1;
                Ok(true)
            }
        }
    }

    /// A joint/pose-only change: adopt committed joints that changed, move obstacles, rebuild
    /// only a robot whose base moved.
    fn in_place(&mut self, snap: &Snapshot) -> Result<()> {
        for k in 0..self.sims.len() {
            let Some(r) = self.scene.robots().get(k) else {
                continue;
            };
            if r.robot.base != self.sims[k].base {
                self.sims[k] = self.pipeline(r, snap)?;
                continue;
            }
            if r.q != self.sims[k].committed_q {
                self.sims[k]
                    .pipeline
                    .teleport(&r.q)
                    .map_err(|source| DaemonError::Robot {
                        robot: r.name().to_owned(),
                        source,
                    })?;
                self.sims[k].committed_q.clone_from(&r.q);
            }
            if let Some(scene) = self.sims[k].pipeline.obstacles_mut() {
                let outside = self
                    .scene
                    .objects()
                    .iter()
                    .filter(|o| !r.subtree.contains(&o.id));
                for (j, o) in outside.enumerate() {
                    if scene.objects().get(j).is_some_and(|s| s.pose != o.pose) {
                        scene.set_pose(j, o.pose);
                    }
                }
            }
        }
        // the robots' links were put back at their committed poses: shown again at their
        // simulated joints before the next step
        self.refollow(snap);
        Ok(())
    }
}

/// The most steps one `step` command may ask for, and the most that may be queued at once
/// (10⁶ steps is 1000 s of a 1 ms pipeline): a larger budget is a typo, not a request.
pub const MAX_STEPS_PER_COMMAND: u64 = 1_000_000;

/// Why a client's command was refused; the reply is `refused: {message}`.
#[derive(Debug, thiserror::Error)]
enum Refusal {
    /// The command's bytes are not JSON.
    #[error("not JSON: {0}")]
    NotJson(#[from] serde_json::Error),
    /// The command's own fields or state refuse it (the message names the field).
    #[error("{0}")]
    Command(String),
    /// The robot's pipeline refused the command (its check, kept).
    #[error(transparent)]
    Pipeline(#[from] robosim_simulator::StepError),
}

impl From<String> for Refusal {
    fn from(message: String) -> Self {
        Refusal::Command(message)
    }
}

/// Applies one command, validated as strictly as a transaction: a refused command changes
/// nothing (targets are checked against the joint limits by [`Pipeline::set_command`]).
fn apply(
    sims: &mut [Sim],
    cmd: &Value,
    running: &mut bool,
    budget: &mut u64,
    reset: &mut bool,
) -> std::result::Result<(), Refusal> {
    let robot = |v: &Value| -> std::result::Result<usize, String> {
        let name = v
            .get("robot")
            .and_then(Value::as_str)
            .ok_or("`robot` must be a string")?;
        let i = sims
            .iter()
            .position(|s| s.name == name)
            .ok_or_else(|| format!("no robot {name:?}"))?;
        match &sims[i].held {
            Some(why) => Err(why.clone()),
            None => Ok(i),
        }
    };
    let vector = |v: &Value, f: &str| -> std::result::Result<DVector<f64>, String> {
        let a = v
            .get(f)
            .and_then(Value::as_array)
            .ok_or(format!("`{f}` must be an array"))?;
        a.iter()
            .map(|x| x.as_f64().ok_or(format!("`{f}` must hold numbers")))
            .collect::<std::result::Result<Vec<_>, _>>()
            .map(DVector::from_vec)
    };
    match cmd.get("cmd").and_then(Value::as_str) {
        Some("target") => {
            let i = robot(cmd)?;
            let q = vector(cmd, "q")?;
            sims[i]
                .pipeline
                .set_command(Command::Target(q))
                .map_err(Refusal::from)
        }
        Some("torque") => {
            let i = robot(cmd)?;
            let t = vector(cmd, "tau")?;
            sims[i]
                .pipeline
                .set_command(Command::Torque(t))
                .map_err(Refusal::from)
        }
        Some("pause") => {
            *running = false;
            Ok(())
        }
        Some("resume") => {
            *running = true;
            Ok(())
        }
        Some("step") => {
            let n = match cmd.get("n") {
                None => 1,
                Some(v) => v
                    .as_u64()
                    .filter(|n| (1..=MAX_STEPS_PER_COMMAND).contains(n))
                    .ok_or(format!(
                        "`n` must be an integer from 1 to {MAX_STEPS_PER_COMMAND}, got {v}"
                    ))?,
            };
            if *budget + n > MAX_STEPS_PER_COMMAND {
                return Err(Refusal::Command(format!(
                    "{budget} steps are still queued; {n} more would exceed {MAX_STEPS_PER_COMMAND}",
                    budget = *budget
                )));
            }
            *budget += n;
            Ok(())
        }
        Some("reset") => {
            *reset = true;
            Ok(())
        }
        other => Err(Refusal::Command(format!("unknown command {other:?}"))),
    }
}

impl Daemon<'_> {
    /// The simulated time (s): the first robot's that steps. A held robot ([`Sim::held`]) is
    /// never stepped and stays at 0, so it is not the clock; with no robot stepping it is 0.
    /// The stages and the published joint state both read this one clock.
    fn clock(&self) -> f64 {
        self.sims
            .iter()
            .find(|s| s.held.is_none())
            .map_or(0.0, |s| s.pipeline.data().state.t)
    }

    /// The pipeline step (s): every robot's pipeline is built from the same effects.
    fn dt(&self) -> f64 {
        self.sims.first().map_or(0.01, |s| s.pipeline.model().dt)
    }

    /// Writes out every robot's buffered CSV log rows.
    fn flush_logs(&mut self) -> Result<()> {
        for s in &mut self.sims {
            s.pipeline.flush_log().map_err(|source| DaemonError::Log {
                robot: s.name.clone(),
                source,
            })?;
        }
        Ok(())
    }
}

/// The record of a pause beginning now, after `run_steps` steps: the newest version committed
/// to the Instance Space at this moment (the reader is refreshed first, so a transaction
/// acknowledged before the pause is counted and one committed after it is not), which orders
/// the pause against the journal's versions.
/// A reader error is said by `trouble` and the pause is recorded at the version the reader
/// last followed.
fn pause_record(
    reader: &mut Reader,
    trouble: &mut FollowTrouble,
    run_steps: u64,
    cause: &'static str,
) -> status::Pause {
    trouble.refresh("simulator", reader);
    status::Pause {
        version: reader.snapshot().map_or(0, |s| s.version()),
        run_steps,
        cause,
    }
}

/// The command's `cmd`, if it is a JSON object with one.
fn cmd_name(v: &Value) -> Option<&str> {
    v.get("cmd").and_then(Value::as_str)
}

/// The main loop's own state and its links to the session (what `get` reports besides the
/// pipelines, the reader it follows commits with, the recording).
struct Loop {
    mode: Mode,
    /// The pipeline step (s) and how many steps between two state publications.
    dt: f64,
    publish_every: u64,
    running: bool,
    /// Where the current pause began (status::Pause), `None` while running.
    paused_at: Option<status::Pause>,
    /// Steps a lock-step client queued.
    budget: u64,
    /// Steps since the daemon started.
    steps: u64,
    /// The recording's clock: run time since start, ns (recording module docs).
    run_ns: u64,
    /// Where realtime pacing counts from: a wall time and the steps taken then.
    wall_origin: (Instant, u64),
    /// Steps taken since the CSV logs were last flushed.
    logs_dirty: bool,
    /// The Instance Space version the pipelines follow.
    version: u64,
    /// The version the pipelines had taken when they last stepped (0: not yet): their robots'
    /// `contact` and `error` are from that step. A paused daemon follows commits without
    /// stepping, so this can lag `version` (status.rs).
    stepped_version: u64,
    reader: Reader,
    trouble: FollowTrouble,
    recording: Option<recording::Recording>,
}

impl Loop {
    /// Stops free running because of `cause`, recording where the pause began.
    fn pause(&mut self, cause: &'static str) {
        if self.running {
            self.paused_at = Some(pause_record(
                &mut self.reader,
                &mut self.trouble,
                self.steps,
                cause,
            ));
        }
        self.running = false;
    }

    /// An event in the recording, if one is made.
    fn event(&mut self, level: Level, source: &str, text: &str) {
        if let Some(r) = &mut self.recording {
            r.event(self.run_ns, level, source, text);
        }
    }

    /// The loop's part of a `get` answer.
    fn state(&self, d: &Daemon) -> status::LoopState {
        status::LoopState {
            mode: self.mode,
            running: self.running,
            budget: self.budget,
            run_steps: self.steps,
            clock_steps: d.clock_steps,
            dt: d.dt(),
            version: self.version,
            stepped_version: self.stepped_version,
            paused_at: self.paused_at,
        }
    }
}

/// The daemon's main loop (see the module docs); returns when the session signals it to stop
/// (SIGTERM/SIGINT), after closing the recording. Each pass: answer the queued commands, follow
/// the committed model, step every pipeline and the scene-level stages (when running or
/// stepping), publish the state, flush when idle, keep the pace.
pub fn run(session: Option<&str>, opts: &Options) -> Result<Counters> {
    let Options {
        mode, publish_hz, ..
    } = *opts;
    if !(publish_hz.is_finite() && publish_hz > 0.0) {
        return Err(DaemonError::Usage(format!(
            "--publish-hz {publish_hz} must be positive"
        )));
    }
    let session = Session::open(session)?;
    let signals = session.node("simulator-signals", true)?;
    let mut reader = Reader::attach(&session, "simulator")?;
    let mut state = StatePublisher::create(&session, "simulator")?;
    let mut commands = CommandReceiver::create(&session, "simulator")?;
    let _reg = session.register(
        "simulator",
        &[
            "space/objects",
            "space/poses",
            "space/changes",
            "state/simulator (owner)",
            "state/simulator/commands",
        ],
    )?;
    let (mut d, version) = start(&session, opts, &mut reader)?;
    announce(&d, mode);
    let recording = start_recording(&session, opts, &mut d)?;
    let dt = d.dt();
    let start = Instant::now();
    let mut l = Loop {
        mode,
        dt,
        publish_every: ((1.0 / publish_hz) / dt).round().max(1.0) as u64,
        running: mode != Mode::Lockstep,
        paused_at: None,
        budget: 0,
        steps: 0,
        run_ns: 0,
        wall_origin: (start, 0),
        logs_dirty: false,
        version,
        stepped_version: 0,
        reader,
        trouble: FollowTrouble::default(),
        recording,
    };
    while signals.wait(Duration::ZERO).is_ok() {
        let reset = answer_commands(&mut d, &mut l, &mut commands)?;
        follow_commits(&mut d, &mut l, reset)?;
        let step_now = l.budget > 0 || (l.running && step_due(&l));
        if step_now {
            step_all(&mut d, &mut l);
        }
        if step_now && (l.steps.is_multiple_of(l.publish_every) || mode == Mode::Lockstep) {
            publish(&d, l.version, &mut state)?;
        }
        let idle = flush_when_idle(&mut d, &mut l, step_now)?;
        keep_pace(&mut l, idle);
    }
    if let Some(r) = l.recording {
        r.finish()?;
    }
    let c = d.counters;
    eprintln!(
        "simulator: stopped after {} steps; {} rebuild(s), {} change(s) applied in place, {} library parse(s)",
        l.steps, c.rebuilds, c.in_place, c.library_parses
    );
    Ok(c)
}

/// The daemon with its pipelines built from the session's first snapshot, and that
/// snapshot's version.
fn start<'a>(
    session: &'a Session,
    opts: &'a Options,
    reader: &mut Reader,
) -> Result<(Daemon<'a>, u64)> {
    let snap = reader
        .snapshot()
        .ok_or_else(|| DaemonError::Usage("no snapshot".into()))?;
    let mut d = Daemon {
        session,
        effects_file: opts.effects.as_deref(),
        scene: CompiledScene::new(),
        library: LibraryCache::default(),
        effects: SceneEffects::default(),
        source: String::new(),
        sims: Vec::new(),
        space: None,
        swap: None,
        follow: None,
        counters: Counters::default(),
        clock_steps: 0,
        structure: None,
    };
    d.follow(reader, &snap, false)?;
    Ok((d, snap.version()))
}

/// Says on stderr what is simulated: the robots, each pipeline's stages, the scene-level
/// stages.
fn announce(d: &Daemon, mode: Mode) {
    eprintln!(
        "simulator: {} robot(s), mode {mode:?}, effects {}",
        d.sims.len(),
        d.source
    );
    for s in &d.sims {
        eprintln!(
            "simulator: {}: {}",
            s.name,
            s.pipeline.stage_names().join(" → ")
        );
    }
    if let Some(sp) = &d.space {
        eprintln!("simulator: space stage: {}", sp.describe());
    }
    if let Some(sw) = &d.swap {
        eprintln!("simulator: swap stage: {}", sw.describe(&d.sims));
    }
}

/// The recording `--record` asks for, with its first sample (the pipelines at rest).
fn start_recording(
    session: &Session,
    opts: &Options,
    d: &mut Daemon,
) -> Result<Option<recording::Recording>> {
    let Some(path) = &opts.record else {
        return Ok(None);
    };
    let names: Vec<&str> = d.sims.iter().map(|s| s.name.as_str()).collect();
    let source = format!(
        "simulator of session {}: {} in {} mode, effects {}",
        session.name(),
        names.join(", "),
        opts.mode.name(),
        d.source
    );
    let mut r = recording::Recording::create(path, &source)?;
    r.sample(0, &mut d.sims);
    eprintln!("simulator: recording to {}", path.display());
    Ok(Some(r))
}

/// Answers every queued command: `get` with the status, the others applied ([`apply`]) and
/// answered `ok` or `refused: …`. Returns whether one asked for a reset.
fn answer_commands(d: &mut Daemon, l: &mut Loop, commands: &mut CommandReceiver) -> Result<bool> {
    let mut reset = false;
    for cmd in commands.drain()? {
        let parsed = serde_json::from_slice::<Value>(cmd.bytes()).map_err(Refusal::from);
        if let Ok(v) = &parsed
            && cmd_name(v) == Some("get")
        {
            let rec = l.recording.as_ref().map(|r| r.status());
            let space = d.space.as_ref().map(|sp| sp.status(&d.sims));
            let mut answer = status::status(&d.sims, &l.state(d), &d.source, rec, space);
            if let Some(sw) = &d.swap {
                answer["swap"] = sw.status(&d.sims);
            }
            cmd.reply(answer.to_string().as_bytes());
            continue;
        }
        let was_running = l.running;
        let outcome = parsed.and_then(|v| {
            match d.space.as_mut().and_then(|sp| sp.command(&v)) {
                Some(r) => r.map_err(Refusal::from),
                None => apply(&mut d.sims, &v, &mut l.running, &mut l.budget, &mut reset),
            }
            .map(|()| v)
        });
        if was_running && !l.running {
            l.paused_at = Some(pause_record(
                &mut l.reader,
                &mut l.trouble,
                l.steps,
                "command",
            ));
        } else if l.running {
            l.paused_at = None;
        }
        let text = String::from_utf8_lossy(cmd.bytes()).into_owned();
        match outcome {
            Ok(v) => {
                cmd.reply(b"ok");
                l.event(Level::Info, "simulator", &v.to_string());
            }
            Err(e) => {
                eprintln!("simulator: command refused: {e}");
                cmd.reply(format!("refused: {e}").as_bytes());
                l.event(Level::Warning, "simulator", &format!("refused {text}: {e}"));
            }
        }
    }
    Ok(reset)
}

/// Follows the committed model: a structure change rebuilds, a joint/pose change is applied
/// in place (module docs). A reader error does not stop the simulator: it keeps the last
/// version it followed and tries again on the next pass (issue 34 item 4).
fn follow_commits(d: &mut Daemon, l: &mut Loop, reset: bool) -> Result<()> {
    l.trouble.refresh("simulator", &mut l.reader);
    let Some(snap) = l.reader.snapshot() else {
        return Ok(());
    };
    if !(reset || snap.version() != l.version) {
        return Ok(());
    }
    let rebuilds = d.counters.rebuilds;
    if let Some(sp) = &mut d.space {
        sp.follow_units(&snap);
    }
    if d.follow(&mut l.reader, &snap, reset)? && reset {
        l.wall_origin = (Instant::now(), l.steps);
    }
    l.version = snap.version();
    if d.counters.rebuilds != rebuilds {
        let why = if reset { "reset" } else { "structure changed" };
        let text = format!(
            "{why}: pipelines rebuilt at version {} from the committed joint values; their clock restarts at 0",
            l.version
        );
        l.event(Level::Info, "simulator", &text);
    }
    Ok(())
}

/// One step of every pipeline, then the space and swap stages; a failing one pauses the
/// daemon (its error is kept for `get`). Advances the clocks and samples the recording.
fn step_all(d: &mut Daemon, l: &mut Loop) {
    // every pipeline checks against the other robots at their simulated joints at the start
    // of this step, whatever the order it steps in ([`follow`])
    if let Some(f) = &mut d.follow {
        f.show(&mut d.sims);
    }
    for s in d.sims.iter_mut().filter(|s| s.held.is_none()) {
        if let Err(e) = s.pipeline.step() {
            eprintln!("simulator: {}: {e}; paused", s.name);
            l.event(Level::Error, &s.name, &format!("{e}; paused"));
            s.error = Some(e.to_string());
            l.pause("error");
        }
    }
    let t = d.clock();
    if let Some(sp) = &mut d.space
        && let Err(e) = sp.update(&mut d.sims, t, l.dt)
    {
        eprintln!("simulator: space stage: {e}; paused");
        l.event(Level::Error, "space", &format!("{e}; paused"));
        l.pause("error");
    }
    // after the space stage: the swap parks the robot it works on
    if let Some(sw) = &mut d.swap
        && let Err(e) = sw.update(&mut d.sims, t, l.dt)
    {
        eprintln!("simulator: swap stage: {e}; paused");
        l.event(Level::Error, "swap", &format!("{e}; paused"));
        l.pause("error");
    }
    l.stepped_version = l.version;
    l.budget = l.budget.saturating_sub(1);
    l.steps += 1;
    d.clock_steps += 1;
    l.run_ns += time_ns(1, d.dt());
    if let Some(r) = &mut l.recording {
        r.sample(l.run_ns, &mut d.sims);
    }
}

/// Publishes every robot's joint state and link poses (and the swap's ORUs) at `version`.
fn publish(d: &Daemon, version: u64, state: &mut StatePublisher) -> Result<()> {
    let mut joints = Vec::new();
    let mut bodies = Vec::new();
    for s in &d.sims {
        let (m, w) = (s.pipeline.model(), s.pipeline.data());
        // a floating robot's links relative to its base link, the base link (the robot
        // object) moved by the root: its committed pose composed with the root's motion
        let poses = link_poses(&m.robot, w.state.q.as_slice());
        let (q, qd, tau) = s.pipeline.joint_state();
        for (j, id) in s.links.iter().enumerate() {
            joints.push(JointStateRec {
                id: *id,
                q: q[j],
                qd: qd[j],
                effort: tau.get(j).copied().unwrap_or(0.0),
            });
            bodies.push(PoseRec {
                id: *id,
                pose: poses[j],
                joint: q[j],
            });
        }
        if let (Some(f), Some(root)) = (&s.floating, s.pipeline.root_transform()) {
            bodies.push(PoseRec {
                id: f.id,
                pose: robosim_scene::pose::from_matrix(&(f.pose * root)),
                joint: f.joint,
            });
        }
    }
    if let Some(sw) = &d.swap {
        bodies.extend_from_slice(sw.records());
    }
    state.publish(version, d.clock(), &joints, &bodies)?;
    Ok(())
}

/// Idle (lock-step with nothing queued, or paused): everything so far goes to disk, so
/// `get`, the CSV log and the recording agree for a reader. Returns whether idle.
fn flush_when_idle(d: &mut Daemon, l: &mut Loop, stepped: bool) -> Result<bool> {
    let idle = !l.running && l.budget == 0;
    l.logs_dirty |= stepped;
    if idle && l.logs_dirty {
        d.flush_logs()?;
        l.logs_dirty = false;
    }
    if let Some(r) = &mut l.recording {
        r.maybe_flush(idle);
    }
    Ok(idle)
}

/// How long an idle lock-step loop (nothing queued) naps before it looks for commands and
/// commits again: short, since its client waits on every `step`.
const IDLE_NAP: Duration = Duration::from_micros(200);
/// How long a paused realtime or fast loop naps: a command waits at most this long (measured:
/// a paused station daemon at ~3 % of a core, against ~8 % at [`IDLE_NAP`] and 93 % spinning).
const PAUSED_NAP: Duration = Duration::from_millis(1);

/// Waits as the mode says. Whatever the mode, an idle daemon (paused, nothing queued) naps
/// ([`IDLE_NAP`], [`PAUSED_NAP`]) instead of spinning (a paused realtime daemon used to take a whole core).
/// Realtime keeps one step per `dt` of wall time **while running**; steps asked for while
/// paused (`step n`) are taken at once, as in lock-step, and the pace counts from where they
/// end when the run resumes. Fast never waits.
fn keep_pace(l: &mut Loop, idle: bool) {
    if !l.running {
        l.wall_origin = (Instant::now(), l.steps);
    }
    if idle {
        // a lock-step client waits on every step it asks for; a paused run can wait a little
        let nap = if l.mode == Mode::Lockstep {
            IDLE_NAP
        } else {
            PAUSED_NAP
        };
        std::thread::sleep(nap);
        return;
    }
    if l.mode == Mode::Realtime && l.running {
        let now = Instant::now();
        let next = next_step_at(l);
        if next > now {
            // at most 50 ms, so that commands are still answered within that while waiting
            std::thread::sleep((next - now).min(Duration::from_millis(50)));
        }
    }
}

/// When a running realtime daemon's next step is due: one `dt` of wall time per step since
/// the pace's origin.
fn next_step_at(l: &Loop) -> Instant {
    l.wall_origin.0 + Duration::from_secs_f64((l.steps - l.wall_origin.1) as f64 * l.dt)
}

/// Whether a running daemon steps on this pass: always, but in realtime only once its step is
/// due (with `dt` over the 50 ms nap, the daemon used to step on every wake-up: 20 steps a
/// second whatever `dt` said).
fn step_due(l: &Loop) -> bool {
    l.mode != Mode::Realtime || Instant::now() >= next_step_at(l)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    /// An orbit the declaration cannot have stops the space stage with the orbit's own error
    /// kept: the message says the stage and why, and the chain reaches `OrbitError`.
    #[test]
    fn a_refused_orbit_keeps_its_error_behind_the_stage() {
        let e = robosim_simulator::orbit::Orbit::new(10.0, 0.0).expect_err("10 m is no orbit");
        let why = e.to_string();
        let e = DaemonError::Stage {
            stage: "space",
            source: e.into(),
        };
        assert_eq!(e.to_string(), format!("the space stage: {why}"));
        let stage = std::error::Error::source(&e).expect("the stage's error");
        assert!(
            matches!(
                stage.downcast_ref::<StageError>(),
                Some(StageError::Orbit(
                    robosim_simulator::orbit::OrbitError::Altitude(_)
                ))
            ),
            "{stage:?}"
        );
    }

    /// A declared log goes to the daemon's file; one naming no signal the simulator logs is
    /// left out (the pipeline would refuse an empty signal list) and its names are said.
    #[test]
    fn a_declared_log_is_placed_and_unknown_signals_are_said() {
        use robosim_model::{LoggingEffect, Signal};
        let path = std::path::Path::new("/run/x/simulator-log.csv");
        let mut fx = SceneEffects {
            logging: Some(LoggingEffect {
                signals: vec![Signal::Q, Signal::Contact],
                unsupported: vec!["energy".into()],
                ..LoggingEffect::default()
            }),
            ..SceneEffects::default()
        };
        let run = declared_effects(&fx, path);
        let log = run.logging.expect("kept");
        assert_eq!(log.path.as_deref(), Some(path));
        assert_eq!(log.signals, [Signal::Q, Signal::Contact]);
        assert_eq!(not_simulated(&fx).len(), 1);
        assert!(not_simulated(&fx)[0].contains("\"energy\""));
        fx.logging = Some(LoggingEffect {
            signals: vec![],
            unsupported: vec!["energy".into()],
            ..LoggingEffect::default()
        });
        assert!(declared_effects(&fx, path).logging.is_none());
    }

    fn step(n: Value, queued: u64) -> (std::result::Result<(), String>, u64) {
        let (mut running, mut budget, mut reset) = (false, queued, false);
        let r = apply(
            &mut [],
            &json!({"cmd": "step", "n": n}),
            &mut running,
            &mut budget,
            &mut reset,
        )
        .map_err(|e| e.to_string());
        (r, budget)
    }

    /// Issue #20 item 4 (`simctl_validates_like_a_transaction`): `n = -1` used to be read as
    /// 1 and `n = 1e12` as 1; both, and everything else that is not a step count, are refused
    /// by name and queue nothing.
    #[test]
    fn simctl_step_counts_are_validated_and_a_refusal_queues_nothing() {
        for bad in [
            json!(-1),
            json!(0),
            json!(1e12),
            json!(2.5),
            json!("3"),
            json!(null),
        ] {
            let (r, budget) = step(bad.clone(), 7);
            let e = r.expect_err("refused");
            assert!(
                e.contains("`n` must be an integer from 1 to 1000000"),
                "{bad}: {e}"
            );
            assert_eq!(budget, 7, "{bad}: nothing queued");
        }
        assert_eq!(step(json!(5), 7), (Ok(()), 12));
        let (r, budget) = step(json!(MAX_STEPS_PER_COMMAND), 1);
        assert!(
            r.expect_err("over the queue bound")
                .contains("still queued")
        );
        assert_eq!(budget, 1);
    }
}
