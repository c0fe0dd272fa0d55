//! `robosim sim --robot puma560 --effects scene.json [--steps N] [--q0 …]` builds the pipeline
//! the scene declares, prints it, and optionally runs it headless for N steps (reporting the
//! final state and the time per step).
//!
//! Entry points: [`SimArgs`], [`run`].

use super::CommandError;
use crate::robot_json::robot_from_json;
use robosim_kinematics::{Robot, builtin_robot};
use robosim_simulator::{Pipeline, SceneEffects, SceneGeometry};
use std::path::PathBuf;
use std::time::Instant;

/// `robosim sim`: build a scene's effect pipeline, print it, optionally run it.
#[derive(Debug, Clone)]
pub struct SimArgs {
    /// A library robot name (puma560, stanford, panda, …) or a robot JSON file (inline format).
    pub robot: String,
    /// The scene's effect declaration: a JSON file, or JSON text starting with `{`.
    /// Default: kinematics only.
    pub effects: Option<String>,
    /// Initial joint values (rad or m), comma-separated; default all zero.
    pub q0: Option<Vec<f64>>,
    /// Steps to run headless after printing the pipeline (0: print only).
    pub steps: u64,
}

fn load_robot(spec: &str, robots: &dyn Fn(&str) -> Option<Robot>) -> Result<Robot, CommandError> {
    if spec.ends_with(".json") {
        let path = PathBuf::from(spec);
        let text =
            robosim_input::read_to_string(&path, "a robot file", robosim_input::Limit::TEXT)?;
        let v: serde_json::Value =
            serde_json::from_str(&text).map_err(|source| CommandError::Json {
                path: path.clone(),
                source,
            })?;
        return robot_from_json(&v).map_err(|source| CommandError::Robot { path, source });
    }
    robots(spec)
        .or_else(|| builtin_robot(spec))
        .ok_or_else(|| CommandError::Refused(format!("no robot named {spec:?}")))
}

/// Runs `robosim sim`; `robots` resolves library names (falls back to the built-in robots).
/// Prints to stdout; returns a message naming what failed.
pub fn run(args: &SimArgs, robots: &dyn Fn(&str) -> Option<Robot>) -> Result<(), CommandError> {
    let robot = load_robot(&args.robot, robots)?;
    let effects = match &args.effects {
        None => SceneEffects {
            kinematics: true,
            ..SceneEffects::default()
        },
        Some(s) if s.trim_start().starts_with('{') => SceneEffects::from_json(s)?,
        Some(path) => {
            let text = robosim_input::read_to_string(
                std::path::Path::new(path),
                "an effects file",
                robosim_input::Limit::TEXT,
            )?;
            SceneEffects::from_json(&text).map_err(|source| CommandError::EffectsFile {
                path: path.clone(),
                source,
            })?
        }
    };
    let q0 = args.q0.clone().unwrap_or_else(|| vec![0.0; robot.dof()]);
    let mut pipe = Pipeline::build(&robot, &q0, &effects, SceneGeometry::default())?;
    print!("{pipe}");
    if args.steps > 0 {
        let start = Instant::now();
        for k in 0..args.steps {
            pipe.step()
                .map_err(|source| CommandError::Step { step: k, source })?;
        }
        let wall = start.elapsed().as_secs_f64();
        let s = &pipe.data().state;
        println!(
            "ran {} steps to t = {} s in {:.3} s wall ({:.3} µs per step)",
            args.steps,
            s.t,
            wall,
            wall / args.steps as f64 * 1e6
        );
        println!("q  = {:?}", s.q.as_slice());
        println!("qd = {:?}", s.qd.as_slice());
    }
    Ok(())
}
