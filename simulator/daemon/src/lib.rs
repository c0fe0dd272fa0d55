//! `robosim simulator`: the headless simulator daemon of a session.
//!
//! For every robot of the Instance Space it builds the per-step pipeline the scene declares
//! (`robosim_simulator::Pipeline`: dynamics with its integrator, joint limits, collision with
//! its mode, encoder quantisation, logging — only what is declared) and steps it:
//! * `--mode realtime` (default): one step per `dt` of wall time;
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
    #[error("{0}")]
    Effects(String),
    #[error("robot {robot}: {reason}")]
    Robot { robot: String, reason: String },
    #[error("{0}")]
    Usage(String),
    #[error("the simulator refused {command}: {reason}")]
    Refused { command: String, reason: String },
    #[error(transparent)]
    Record(#[from] robosim_record::RecordError),
    #[error("simulator log: {0}")]
    Log(String),
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

/// One robot's pipeline and what the daemon knows about it.
pub(crate) struct Sim {
    pub(crate) name: String,
    links: Vec<u64>,
    /// Link (joint) names in chain order, from the snapshot the pipeline was built from.
    pub(crate) link_names: Vec<String>,
    /// The CSV signal log, if logging is declared.
    pub(crate) log_path: Option<PathBuf>,
    /// Why the last step failed, until the pipeline is rebuilt.
    pub(crate) error: Option<String>,
    /// The collision stage's verdict at the last recorded sample.
    pub(crate) contact_was: bool,
    /// The committed joint values this pipeline last adopted.
    committed_q: Vec<f64>,
    base: nalgebra::Matrix4<f64>,
    pub(crate) pipeline: Pipeline,
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
            let (lib, _) = robosim_scene::library_from_publication(&published)
                .map_err(|e| DaemonError::Effects(e.to_string()))?;
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
type Declared = Option<(SceneEffects, SceneParts)>;

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
        )
        .map_err(|e| DaemonError::Effects(e.to_string()))?;
        return Ok((
            SceneEffects::from_json(&text)
                .map_err(|e| DaemonError::Effects(format!("{f}: {e}")))?,
            format!("from {f}"),
            None,
        ));
    }
    let scene = (0..snap.len())
        .find(|&i| snap.object(i).kind() == Some(Kind::Scene) && !snap.origin(i).is_empty());
    if let Some(i) = scene {
        let origin = Origin::from_record(snap.origin(i)).map_err(DaemonError::Effects)?;
        let lib = library.get(reader, counters)?;
        if let Ok(robosim_library::Evaluated::Scene(sc)) = origin.evaluate(lib) {
            let path = session.run_dir().join("simulator-log.csv");
            return Ok((
                declared_effects(&sc.effects, &path),
                format!("declared by scene {}", origin.declaration),
                Some((sc.effects.clone(), sc.parts())),
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
}

impl Daemon<'_> {
    /// The pipeline of compiled robot `r` (shares the compiled solids).
    fn pipeline(&self, r: &robosim_scene::CompiledRobot, snap: &Snapshot) -> Result<Sim> {
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
        let pipeline = Pipeline::build(&r.robot, &r.q, &effects, geometry).map_err(|e| {
            DaemonError::Robot {
                robot: r.name().to_owned(),
                reason: e.to_string(),
            }
        })?;
        Ok(Sim {
            name: r.name().to_owned(),
            links: r.links.clone(),
            link_names: r
                .links
                .iter()
                .map(|id| snap.index_of(*id).map_or("", |k| snap.name(k)).to_owned())
                .collect(),
            log_path: effects.logging.as_ref().and_then(|l| l.path.clone()),
            error: None,
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
        if let Some((fx, scene)) = &declared {
            for what in not_simulated(fx) {
                eprintln!("simulator: WARNING: declared but not simulated: {what}");
            }
            let mut notes = Vec::new();
            self.space = space::SpaceStage::build(fx, scene, &mut self.sims, &mut notes)
                .map_err(|e| DaemonError::Effects(format!("the space stage: {e}")))?;
            for n in notes {
                eprintln!("simulator: WARNING: {n}");
            }
            self.swap = swap::SwapStage::build(fx, scene, &mut self.sims, snap)
                .map_err(|e| DaemonError::Effects(format!("the swap stage: {e}")))?;
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
                self.rebuild(reader, snap)?;
                Ok(true)
            }
            _ if reset => {
                self.rebuild(reader, snap)?;
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
                    .map_err(|e| DaemonError::Robot {
                        robot: r.name().to_owned(),
                        reason: e.to_string(),
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

/// Applies one command, validated as strictly as a transaction: a refused command changes
/// nothing (targets are checked against the joint limits by [`Pipeline::set_command`]).
fn apply(
    sims: &mut [Sim],
    cmd: &Value,
    running: &mut bool,
    budget: &mut u64,
    reset: &mut bool,
) -> std::result::Result<(), String> {
    let robot = |v: &Value| -> std::result::Result<usize, String> {
        let name = v
            .get("robot")
            .and_then(Value::as_str)
            .ok_or("`robot` must be a string")?;
        sims.iter()
            .position(|s| s.name == name)
            .ok_or_else(|| format!("no robot {name:?}"))
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
                .map_err(|e| e.to_string())
        }
        Some("torque") => {
            let i = robot(cmd)?;
            let t = vector(cmd, "tau")?;
            sims[i]
                .pipeline
                .set_command(Command::Torque(t))
                .map_err(|e| e.to_string())
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
                return Err(format!(
                    "{budget} steps are still queued; {n} more would exceed {MAX_STEPS_PER_COMMAND}",
                    budget = *budget
                ));
            }
            *budget += n;
            Ok(())
        }
        Some("reset") => {
            *reset = true;
            Ok(())
        }
        other => Err(format!("unknown command {other:?}")),
    }
}

impl Daemon<'_> {
    /// The pipeline step (s): every robot's pipeline is built from the same effects.
    fn dt(&self) -> f64 {
        self.sims.first().map_or(0.01, |s| s.pipeline.model().dt)
    }

    /// Writes out every robot's buffered CSV log rows.
    fn flush_logs(&mut self) -> Result<()> {
        for s in &mut self.sims {
            s.pipeline
                .flush_log()
                .map_err(|e| DaemonError::Log(format!("robot {}: {e}", s.name)))?;
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

/// The daemon's main loop (see the module docs); returns when the session signals it to stop
/// (SIGTERM/SIGINT), after closing the recording.
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
    let mut trouble = FollowTrouble::default();
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
    let snap = reader
        .snapshot()
        .ok_or_else(|| DaemonError::Usage("no snapshot".into()))?;
    let mut d = Daemon {
        session: &session,
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
    };
    d.follow(&mut reader, &snap, false)?;
    let mut version = snap.version();
    // The version the pipelines had taken when they last stepped (0: not yet): their robots'
    // `contact` and `error` are from that step. A paused daemon follows commits without
    // stepping, so this can lag `version` (status.rs).
    let mut stepped_version = 0;
    drop(snap);
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
    let mut recording = match &opts.record {
        Some(path) => {
            let names: Vec<&str> = d.sims.iter().map(|s| s.name.as_str()).collect();
            let source = format!(
                "simulator of session {}: {} in {} mode, effects {}",
                session.name(),
                names.join(", "),
                mode.name(),
                d.source
            );
            let mut r = recording::Recording::create(path, &source)?;
            r.sample(0, &mut d.sims);
            eprintln!("simulator: recording to {}", path.display());
            Some(r)
        }
        None => None,
    };
    let dt = d.dt();
    let publish_every = ((1.0 / publish_hz) / dt).round().max(1.0) as u64;
    let mut running = mode != Mode::Lockstep;
    // Where the current pause began (status::Pause), `None` while running.
    let mut paused_at: Option<status::Pause> = None;
    let mut budget = 0u64;
    let start = Instant::now();
    let mut steps = 0u64;
    // The recording's clock: run time since start, ns (recording module docs).
    let mut run_ns = 0u64;
    let mut wall_origin = (start, 0u64);
    // Steps taken since the CSV logs were last flushed.
    let mut logs_dirty = false;
    while signals.wait(Duration::ZERO).is_ok() {
        let mut reset = false;
        for cmd in commands.drain()? {
            let parsed =
                serde_json::from_slice::<Value>(cmd.bytes()).map_err(|e| format!("not JSON: {e}"));
            if let Ok(v) = &parsed
                && cmd_name(v) == Some("get")
            {
                let l = status::LoopState {
                    mode,
                    running,
                    budget,
                    run_steps: steps,
                    clock_steps: d.clock_steps,
                    dt: d.dt(),
                    version,
                    stepped_version,
                    paused_at,
                };
                let rec = recording.as_ref().map(|r| r.status());
                let space = d.space.as_ref().map(|sp| sp.status(&d.sims));
                let mut answer = status::status(&d.sims, &l, &d.source, rec, space);
                if let Some(sw) = &d.swap {
                    answer["swap"] = sw.status(&d.sims);
                }
                cmd.reply(answer.to_string().as_bytes());
                continue;
            }
            let was_running = running;
            let outcome = parsed.and_then(|v| {
                apply(&mut d.sims, &v, &mut running, &mut budget, &mut reset).map(|()| v)
            });
            if was_running && !running {
                paused_at = Some(pause_record(&mut reader, &mut trouble, steps, "command"));
            } else if running {
                paused_at = None;
            }
            let text = String::from_utf8_lossy(cmd.bytes()).into_owned();
            match outcome {
                Ok(v) => {
                    cmd.reply(b"ok");
                    if let Some(r) = &mut recording {
                        r.event(run_ns, Level::Info, "simulator", &v.to_string());
                    }
                }
                Err(e) => {
                    eprintln!("simulator: command refused: {e}");
                    cmd.reply(format!("refused: {e}").as_bytes());
                    if let Some(r) = &mut recording {
                        r.event(
                            run_ns,
                            Level::Warning,
                            "simulator",
                            &format!("refused {text}: {e}"),
                        );
                    }
                }
            }
        }
        // Follow the committed model: a structure change rebuilds, a joint/pose change is
        // applied in place (module docs). A reader error does not stop the simulator: it keeps
        // the last version it followed and tries again on the next pass (issue 34 item 4).
        trouble.refresh("simulator", &mut reader);
        if let Some(snap) = reader.snapshot()
            && (reset || snap.version() != version)
        {
            let rebuilds = d.counters.rebuilds;
            if d.follow(&mut reader, &snap, reset)? && reset {
                wall_origin = (Instant::now(), steps);
            }
            version = snap.version();
            if let Some(r) = &mut recording
                && d.counters.rebuilds != rebuilds
            {
                let why = if reset { "reset" } else { "structure changed" };
                r.event(
                    run_ns,
                    Level::Info,
                    "simulator",
                    &format!(
                        "{why}: pipelines rebuilt at version {version} from the committed joint values; their clock restarts at 0"
                    ),
                );
            }
        }
        let step_now = running || budget > 0;
        if step_now {
            // every pipeline checks against the other robots at their simulated joints at the
            // start of this step, whatever the order it steps in ([`follow`])
            if let Some(f) = &mut d.follow {
                f.show(&mut d.sims);
            }
            for s in &mut d.sims {
                if let Err(e) = s.pipeline.step() {
                    eprintln!("simulator: {}: {e}; paused", s.name);
                    if let Some(r) = &mut recording {
                        r.event(run_ns, Level::Error, &s.name, &format!("{e}; paused"));
                    }
                    s.error = Some(e.to_string());
                    if running {
                        paused_at = Some(pause_record(&mut reader, &mut trouble, steps, "error"));
                    }
                    running = false;
                }
            }
            let t = d.sims.first().map_or(0.0, |s| s.pipeline.data().state.t);
            if let Some(sp) = &mut d.space
                && let Err(e) = sp.update(&mut d.sims, t, dt)
            {
                eprintln!("simulator: space stage: {e}; paused");
                if let Some(r) = &mut recording {
                    r.event(run_ns, Level::Error, "space", &format!("{e}; paused"));
                }
                if running {
                    paused_at = Some(pause_record(&mut reader, &mut trouble, steps, "error"));
                }
                running = false;
            }
            // after the space stage: the swap parks the robot it works on
            if let Some(sw) = &mut d.swap
                && let Err(e) = sw.update(&mut d.sims, t, dt)
            {
                eprintln!("simulator: swap stage: {e}; paused");
                if let Some(r) = &mut recording {
                    r.event(run_ns, Level::Error, "swap", &format!("{e}; paused"));
                }
                if running {
                    paused_at = Some(pause_record(&mut reader, &mut trouble, steps, "error"));
                }
                running = false;
            }
            stepped_version = version;
            budget = budget.saturating_sub(1);
            steps += 1;
            d.clock_steps += 1;
            run_ns += time_ns(1, d.dt());
            if let Some(r) = &mut recording {
                r.sample(run_ns, &mut d.sims);
            }
        }
        if step_now && (steps.is_multiple_of(publish_every) || mode == Mode::Lockstep) {
            let mut joints = Vec::new();
            let mut bodies = Vec::new();
            let mut t = 0.0;
            for s in &d.sims {
                let (m, w) = (s.pipeline.model(), s.pipeline.data());
                t = w.state.t;
                let poses = link_poses(&m.robot, w.state.q.as_slice());
                for (j, id) in s.links.iter().enumerate() {
                    joints.push(JointStateRec {
                        id: *id,
                        q: w.state.q[j],
                        qd: w.state.qd[j],
                        effort: w.tau.get(j).copied().unwrap_or(0.0),
                    });
                    bodies.push(PoseRec {
                        id: *id,
                        pose: poses[j],
                        joint: w.state.q[j],
                    });
                }
            }
            if let Some(sw) = &d.swap {
                bodies.extend_from_slice(sw.records());
            }
            state.publish(version, t, &joints, &bodies)?;
        }
        // Idle (lock-step with nothing queued, or paused): everything so far goes to disk, so
        // `get`, the CSV log and the recording agree for a reader.
        let idle = !running && budget == 0;
        logs_dirty |= step_now;
        if idle && logs_dirty {
            d.flush_logs()?;
            logs_dirty = false;
        }
        if let Some(r) = &mut recording {
            r.maybe_flush(idle);
        }
        match mode {
            Mode::Fast => {}
            Mode::Realtime => {
                let next =
                    wall_origin.0 + Duration::from_secs_f64((steps - wall_origin.1) as f64 * dt);
                let now = Instant::now();
                if next > now {
                    std::thread::sleep((next - now).min(Duration::from_millis(50)));
                }
            }
            Mode::Lockstep => {
                if idle {
                    std::thread::sleep(Duration::from_micros(200));
                }
            }
        }
    }
    if let Some(r) = recording {
        r.finish()?;
    }
    let c = d.counters;
    eprintln!(
        "simulator: stopped after {steps} steps; {} rebuild(s), {} change(s) applied in place, {} library parse(s)",
        c.rebuilds, c.in_place, c.library_parses
    );
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn step(n: Value, queued: u64) -> (std::result::Result<(), String>, u64) {
        let (mut running, mut budget, mut reset) = (false, queued, false);
        let r = apply(
            &mut [],
            &json!({"cmd": "step", "n": n}),
            &mut running,
            &mut budget,
            &mut reset,
        );
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
