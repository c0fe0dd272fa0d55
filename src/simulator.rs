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
//!
//! The scene's effects come from `--effects FILE.json` (the simulator's JSON form), else from
//! the Library Space declaration the scene was instantiated from, else kinematics only.
//!
//! **After `kill -9`:** the high-rate state is the daemon's alone and is not journaled; a
//! restarted daemon starts again from the joint values committed in the Instance Space, at
//! t = 0, with a new record sequence (seq 1). The keeper and the Instance Space do not notice
//! either event. Readers see the state service go silent and then resume (tested).

use crate::{Result, bail, bridge, ops};
use nalgebra::DVector;
use robosim_instance_space::layout::PoseRec;
use robosim_instance_space::state::{CommandReceiver, JointStateRec, StatePublisher};
use robosim_instance_space::{Kind, Reader, Session, Snapshot};
use robosim_simulator::effects::SceneEffects;
use robosim_simulator::pipeline::{Command, Pipeline, SceneGeometry};
use serde_json::{Value, json};
use std::time::{Duration, Instant};

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Mode {
    Realtime,
    Fast,
    Lockstep,
}

struct Sim {
    name: String,
    links: Vec<u64>,
    pipeline: Pipeline,
}

/// The library's effect declaration in the simulator's JSON form.
fn effects_json(e: &robosim_library::Effects, log_path: &std::path::Path) -> Value {
    let mut v = json!({"kinematics": e.kinematics, "joint_limits": e.joint_limits});
    if let Some(c) = &e.collision {
        let mode = match c.mode {
            robosim_library::CollisionMode::Bbox => "bbox",
            robosim_library::CollisionMode::Polygon => "polygon",
            robosim_library::CollisionMode::Exact => "exact",
        };
        v["collision"] =
            json!({"mode": mode, "self": c.self_collision, "continuous": c.continuous});
    }
    if let Some(d) = &e.dynamics {
        let integrator = match d.integrator {
            robosim_library::Integrator::Euler => "euler",
            robosim_library::Integrator::SemiImplicitEuler => "semi_implicit_euler",
            robosim_library::Integrator::Rk4 => "rk4",
            robosim_library::Integrator::Dopri5 => "dopri5",
        };
        v["dynamics"] = json!({"integrator": integrator, "dt": d.step_s, "gravity": [d.gravity.x, d.gravity.y, d.gravity.z]});
    }
    if let Some(b) = e.encoder_bits {
        v["encoder"] = json!({"bits": b});
    }
    let signals: Vec<&str> = e
        .logged
        .iter()
        .filter_map(|s| match s.as_str() {
            "contacts" | "contact" => Some("contact"),
            "t" | "q" | "qd" | "qdd" | "tau" | "q_measured" => Some(s.as_str()),
            _ => None,
        })
        .collect();
    if !signals.is_empty() {
        v["logging"] = json!({"signals": signals, "path": log_path});
    }
    v
}

/// The scene's declared effects: `--effects`, else its Library Space declaration.
fn scene_effects(
    session: &Session,
    reader: &mut Reader,
    snap: &Snapshot,
    file: Option<&str>,
) -> Result<(SceneEffects, String)> {
    if let Some(f) = file {
        let text = std::fs::read_to_string(f).map_err(|e| crate::CliError(format!("{f}: {e}")))?;
        return Ok((
            SceneEffects::from_json(&text).map_err(|e| crate::CliError(format!("{f}: {e}")))?,
            format!("from {f}"),
        ));
    }
    let scene = (0..snap.len())
        .find(|&i| snap.object(i).kind() == Some(Kind::Scene) && !snap.origin(i).is_empty());
    if let Some(i) = scene {
        let origin: crate::instantiate::Origin =
            serde_json::from_str(snap.origin(i)).map_err(|e| crate::CliError(e.to_string()))?;
        let lib = robosim_library::Library::from_sources(&reader.library_files()?)
            .map_err(|e| crate::CliError(e.to_string()))?;
        let mut params = robosim_library::Params::new();
        for (k, v) in &origin.params {
            params = params.expr(k, v);
        }
        if let Ok(robosim_library::Evaluated::Scene(sc)) =
            lib.evaluate(&origin.declaration, &params)
        {
            let path = session.run_dir().join("simulator-log.csv");
            let v = effects_json(&sc.effects, &path);
            let e = SceneEffects::from_json(&v.to_string())
                .map_err(|e| crate::CliError(format!("scene {}: {e}", origin.declaration)))?;
            return Ok((e, format!("declared by scene {}", origin.declaration)));
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

fn build(
    session: &Session,
    reader: &mut Reader,
    effects_file: Option<&str>,
) -> Result<(Vec<Sim>, u64, String)> {
    let snap = reader
        .snapshot()
        .ok_or_else(|| crate::CliError("no snapshot".into()))?;
    let (effects, source) = scene_effects(session, reader, &snap, effects_file)?;
    let mut sims = Vec::new();
    for r in bridge::robots(&snap) {
        let p = ops::placed(&snap, &r.robot.name)
            .map_err(|(k, m)| crate::CliError(format!("{k}: {m}")))?;
        let (obstacles, _, _) = ops::obstacles(&snap, &p, &Default::default());
        // One log per robot: a scene with two robots must not write one file twice.
        let mut effects = effects.clone();
        if let Some(l) = effects.logging.as_mut()
            && (l
                .path
                .as_ref()
                .is_some_and(|p| p.starts_with(session.run_dir()))
                || l.path.is_none())
        {
            l.path = Some(
                session
                    .run_dir()
                    .join(format!("simulator-{}.csv", r.robot.name)),
            );
        }
        let geometry = SceneGeometry {
            obstacles,
            link_solids: Some(p.solids.clone()),
        };
        let pipeline = Pipeline::build(&p.robot, &p.q, &effects, geometry)
            .map_err(|e| crate::CliError(format!("robot {}: {e}", r.robot.name)))?;
        sims.push(Sim {
            name: r.robot.name.clone(),
            links: p.links.clone(),
            pipeline,
        });
    }
    Ok((sims, snap.version(), source))
}

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
            *budget += cmd.get("n").and_then(Value::as_u64).unwrap_or(1);
            Ok(())
        }
        Some("reset") => {
            *reset = true;
            Ok(())
        }
        other => Err(format!("unknown command {other:?}")),
    }
}

pub fn run(
    session: Option<&str>,
    mode: Mode,
    effects_file: Option<&str>,
    publish_hz: f64,
) -> Result<()> {
    if !(publish_hz.is_finite() && publish_hz > 0.0) {
        bail!("--publish-hz {publish_hz} must be positive");
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
    let (mut sims, mut version, source) = build(&session, &mut reader, effects_file)?;
    eprintln!(
        "simulator: {} robot(s), mode {mode:?}, effects {source}",
        sims.len()
    );
    for s in &sims {
        eprintln!(
            "simulator: {}: {}",
            s.name,
            s.pipeline.stage_names().join(" → ")
        );
    }
    let dt = sims.first().map_or(0.01, |s| s.pipeline.world.dt);
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
                .and_then(|v| apply(&mut sims, &v, &mut running, &mut budget, &mut reset));
            match outcome {
                Ok(()) => cmd.reply(b"ok"),
                Err(e) => {
                    eprintln!("simulator: command refused: {e}");
                    cmd.reply(format!("refused: {e}").as_bytes());
                }
            }
        }
        // A structure change (a robot moved by a writer, a new instance) rebuilds the pipelines
        // from the committed model; pose-only changes of other objects do too (obstacles moved).
        reader.refresh()?;
        let current = reader.snapshot().map_or(version, |s| s.version());
        if reset || current != version {
            let (s, v, _) = build(&session, &mut reader, effects_file)?;
            sims = s;
            version = v;
            wall_origin = (Instant::now(), steps);
        }
        let step_now = running || budget > 0;
        if step_now {
            for s in &mut sims {
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
            for s in &sims {
                let w = &s.pipeline.world;
                t = w.state.t;
                let poses = bridge::link_poses(&w.robot, w.state.q.as_slice());
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
    eprintln!("simulator: stopped after {steps} steps");
    Ok(())
}

/// `robosim simctl --session S JSON…`: send commands to the session's simulator.
pub fn ctl(session: Option<&str>, commands: &[String]) -> Result<()> {
    let session = Session::open(session)?;
    let mut sender =
        robosim_instance_space::state::CommandSender::open(&session, "simulator", "simctl")?;
    for c in commands {
        let v: Value = serde_json::from_str(c)
            .map_err(|e| crate::CliError(format!("command {c:?} is not JSON: {e}")))?;
        if v.get("cmd").and_then(Value::as_str).is_none() {
            bail!("command {c} has no \"cmd\"");
        }
        let answer = sender.send(c.as_bytes(), Duration::from_secs(10))?;
        let answer = String::from_utf8_lossy(&answer).into_owned();
        println!("{answer}");
        if answer != "ok" {
            bail!("simulator: {answer}");
        }
    }
    Ok(())
}
