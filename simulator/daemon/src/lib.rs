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
//! command it on `state/simulator/commands` with JSON lines (`robosim simctl`):
//! `{"cmd": "target", "robot": NAME, "q": [...]}`, `{"cmd": "torque", "robot", "tau"}`,
//! `{"cmd": "pause"}`, `{"cmd": "resume"}`, `{"cmd": "step", "n": N}`, `{"cmd": "reset"}`.
//! Every command is validated like a transaction, and a refused one changes nothing: `n` is an
//! integer in 1..=[`MAX_STEPS_PER_COMMAND`], a target lies inside the joint limits
//! ([`Pipeline::set_command`]).
//!
//! The scene's effects come from `--effects FILE.json` (the simulator's JSON form), else from
//! the Library Space declaration the scene was instantiated from (converted type to type,
//! [`declared_effects`]), else kinematics only.
//!
//! **Work follows the change.** The robots and obstacles come from a [`CompiledScene`]: a new
//! structure version (or a keeper restart) compiles the scene and rebuilds the pipelines; the
//! Library Space is parsed only when its sources differ from the last parse. A joint- or
//! pose-only change (MOVEJ, MOVEJI, a planner's set_joints, an obstacle moved) updates in place:
//! a robot whose committed joints changed is put there at rest ([`Pipeline::teleport`]), a
//! moved obstacle is moved in the collision stage's scene, a moved robot base rebuilds that
//! robot's pipeline only. Robots that were not touched keep simulating undisturbed.
//!
//! Entry points: [`run`] (the process), [`ctl`] (`robosim simctl`), [`Mode`], [`Counters`].
//!
//! **After `kill -9`:** the high-rate state is the daemon's alone and is not journaled; a
//! restarted daemon starts again from the joint values committed in the Instance Space, at
//! t = 0, with a new record sequence (seq 1). The keeper and the Instance Space do not notice
//! either event. Readers see the state service go silent and then resume (tested).

pub mod bench;

use nalgebra::DVector;
use robosim_instance_space::layout::PoseRec;
use robosim_instance_space::state::{CommandReceiver, JointStateRec, StatePublisher};
use robosim_instance_space::{Kind, Reader, Session, Snapshot};
use robosim_library::Library;
use robosim_scene::{CompiledScene, Origin, Sync, link_poses};
use robosim_simulator::effects::{
    CollisionEffect, DynamicsEffect, EncoderEffect, LoggingEffect, SceneEffects, Signal,
};
use robosim_simulator::pipeline::{Command, Pipeline, SceneGeometry};
use serde_json::Value;
use std::collections::HashSet;
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
    #[error("simulator: {0}")]
    Refused(String),
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

struct Sim {
    name: String,
    links: Vec<u64>,
    /// The committed joint values this pipeline last adopted.
    committed_q: Vec<f64>,
    base: nalgebra::Matrix4<f64>,
    pipeline: Pipeline,
}

/// What the daemon did with the changes it saw (printed when it stops; read by benches).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Pipelines built (all robots) after a structure change, a reset or at start.
    pub rebuilds: u64,
    /// Joint/pose-only versions applied in place.
    pub in_place: u64,
    /// Library Space parses.
    pub library_parses: u64,
}

/// The library's effect declaration as the simulator's (type to type; what the library
/// language does not say takes the simulator's defaults). Logged signals the simulator does
/// not know are left out.
pub fn declared_effects(e: &robosim_library::Effects, log_path: &std::path::Path) -> SceneEffects {
    let collision = e.collision.as_ref().map(|c| CollisionEffect {
        mode: match c.mode {
            robosim_library::CollisionMode::Bbox => robosim_collision::Mode::BBox,
            robosim_library::CollisionMode::Polygon => robosim_collision::Mode::Polygon,
            robosim_library::CollisionMode::Exact => robosim_collision::Mode::Exact,
        },
        self_collision: c.self_collision,
        continuous: c.continuous,
        ..CollisionEffect::default()
    });
    let dynamics = e.dynamics.as_ref().map(|d| DynamicsEffect {
        integrator: match d.integrator {
            robosim_library::Integrator::Euler => "euler",
            robosim_library::Integrator::SemiImplicitEuler => "semi_implicit_euler",
            robosim_library::Integrator::Rk4 => "rk4",
            robosim_library::Integrator::Dopri5 => "dopri5",
        }
        .to_owned(),
        dt: d.step_s,
        gravity: Some([d.gravity.x, d.gravity.y, d.gravity.z]),
        ..DynamicsEffect::default()
    });
    let signals: Vec<Signal> = e
        .logged
        .iter()
        .filter_map(|s| match s.as_str() {
            "contacts" | "contact" => Some(Signal::Contact),
            "t" => Some(Signal::T),
            "q" => Some(Signal::Q),
            "qd" => Some(Signal::Qd),
            "qdd" => Some(Signal::Qdd),
            "tau" => Some(Signal::Tau),
            "q_measured" => Some(Signal::QMeasured),
            _ => None,
        })
        .collect();
    SceneEffects {
        kinematics: e.kinematics,
        joint_limits: e.joint_limits,
        collision,
        dynamics,
        encoder: e.encoder_bits.map(|bits| EncoderEffect { bits }),
        logging: (!signals.is_empty()).then(|| LoggingEffect {
            signals,
            path: Some(log_path.to_owned()),
            ..LoggingEffect::default()
        }),
        ..SceneEffects::default()
    }
}

/// The Library Space, parsed once and again only when the session's sources change.
#[derive(Default)]
struct LibraryCache {
    sources: Vec<(String, String)>,
    library: Option<Library>,
}

impl LibraryCache {
    fn get(&mut self, reader: &mut Reader, counters: &mut Counters) -> Result<&Library> {
        let sources = reader.library_files()?;
        if self.library.is_none() || sources != self.sources {
            let lib = Library::from_sources(&sources)
                .map_err(|e| DaemonError::Effects(format!("the session's Library Space: {e}")))?;
            counters.library_parses += 1;
            self.sources = sources;
            self.library = Some(lib);
        }
        self.library
            .as_ref()
            .ok_or_else(|| DaemonError::Effects("no library".into()))
    }
}

/// The scene's declared effects: `--effects`, else its Library Space declaration.
fn scene_effects(
    session: &Session,
    reader: &mut Reader,
    library: &mut LibraryCache,
    counters: &mut Counters,
    snap: &Snapshot,
    file: Option<&str>,
) -> Result<(SceneEffects, String)> {
    if let Some(f) = file {
        let text =
            std::fs::read_to_string(f).map_err(|e| DaemonError::Effects(format!("{f}: {e}")))?;
        return Ok((
            SceneEffects::from_json(&text)
                .map_err(|e| DaemonError::Effects(format!("{f}: {e}")))?,
            format!("from {f}"),
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
            ));
        }
    }
    Ok((
        SceneEffects {
            kinematics: true,
            ..SceneEffects::default()
        },
        "none declared: kinematics only".into(),
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
    counters: Counters,
}

impl Daemon<'_> {
    /// The pipeline of compiled robot `r` (shares the compiled solids).
    fn pipeline(&self, r: &robosim_scene::CompiledRobot) -> Result<Sim> {
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
            committed_q: r.q.clone(),
            base: r.robot.base,
            pipeline,
        })
    }

    /// Every robot's pipeline from the compiled scene (after a structure change or a reset).
    fn rebuild(&mut self, reader: &mut Reader, snap: &Snapshot) -> Result<()> {
        let (effects, source) = scene_effects(
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
            .map(|r| self.pipeline(r))
            .collect::<Result<_>>()?;
        self.counters.rebuilds += 1;
        Ok(())
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
                self.in_place()?;
                self.counters.in_place += 1;
                Ok(true)
            }
        }
    }

    /// A joint/pose-only change: adopt committed joints that changed, move obstacles, rebuild
    /// only a robot whose base moved.
    fn in_place(&mut self) -> Result<()> {
        for k in 0..self.sims.len() {
            let Some(r) = self.scene.robots().get(k) else {
                continue;
            };
            if r.robot.base != self.sims[k].base {
                self.sims[k] = self.pipeline(r)?;
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

/// The daemon's main loop (see the module docs); returns when the session signals it to stop
/// (SIGTERM/SIGINT).
pub fn run(
    session: Option<&str>,
    mode: Mode,
    effects_file: Option<&str>,
    publish_hz: f64,
) -> Result<Counters> {
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
    let snap = reader
        .snapshot()
        .ok_or_else(|| DaemonError::Usage("no snapshot".into()))?;
    let mut d = Daemon {
        session: &session,
        effects_file,
        scene: CompiledScene::new(),
        library: LibraryCache::default(),
        effects: SceneEffects::default(),
        source: String::new(),
        sims: Vec::new(),
        counters: Counters::default(),
    };
    d.follow(&mut reader, &snap, false)?;
    let mut version = snap.version();
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
    let dt = d.sims.first().map_or(0.01, |s| s.pipeline.model().dt);
    let publish_every = ((1.0 / publish_hz) / dt).round().max(1.0) as u64;
    let mut running = mode != Mode::Lockstep;
    let mut budget = 0u64;
    let start = Instant::now();
    let mut steps = 0u64;
    let mut wall_origin = (start, 0u64);
    while signals.wait(Duration::ZERO).is_ok() {
        let mut reset = false;
        for cmd in commands.drain()? {
            let outcome = serde_json::from_slice::<Value>(cmd.bytes())
                .map_err(|e| format!("not JSON: {e}"))
                .and_then(|v| apply(&mut d.sims, &v, &mut running, &mut budget, &mut reset));
            match outcome {
                Ok(()) => cmd.reply(b"ok"),
                Err(e) => {
                    eprintln!("simulator: command refused: {e}");
                    cmd.reply(format!("refused: {e}").as_bytes());
                }
            }
        }
        // Follow the committed model: a structure change rebuilds, a joint/pose change is
        // applied in place (module docs).
        reader.refresh()?;
        if let Some(snap) = reader.snapshot()
            && (reset || snap.version() != version)
        {
            if d.follow(&mut reader, &snap, reset)? && reset {
                wall_origin = (Instant::now(), steps);
            }
            version = snap.version();
        }
        let step_now = running || budget > 0;
        if step_now {
            for s in &mut d.sims {
                if let Err(e) = s.pipeline.step() {
                    eprintln!("simulator: {}: {e}; paused", s.name);
                    running = false;
                }
            }
            budget = budget.saturating_sub(1);
            steps += 1;
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
            state.publish(version, t, &joints, &bodies)?;
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
                if budget == 0 && !running {
                    std::thread::sleep(Duration::from_micros(200));
                }
            }
        }
    }
    let c = d.counters;
    eprintln!(
        "simulator: stopped after {steps} steps; {} rebuild(s), {} change(s) applied in place, {} library parse(s)",
        c.rebuilds, c.in_place, c.library_parses
    );
    Ok(c)
}

/// `robosim simctl --session S JSON…`: send commands to the session's simulator.
pub fn ctl(session: Option<&str>, commands: &[String]) -> Result<()> {
    let session = Session::open(session)?;
    let mut sender =
        robosim_instance_space::state::CommandSender::open(&session, "simulator", "simctl")?;
    for c in commands {
        let v: Value = serde_json::from_str(c)
            .map_err(|e| DaemonError::Usage(format!("command {c:?} is not JSON: {e}")))?;
        if v.get("cmd").and_then(Value::as_str).is_none() {
            return Err(DaemonError::Usage(format!("command {c} has no \"cmd\"")));
        }
        let answer = sender.send(c.as_bytes(), Duration::from_secs(10))?;
        let answer = String::from_utf8_lossy(&answer).into_owned();
        println!("{answer}");
        if answer != "ok" {
            return Err(DaemonError::Refused(answer));
        }
    }
    Ok(())
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
