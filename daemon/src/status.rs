//! The answer to `{"cmd": "get"}` (`robosim simctl get`, the query protocol's `sim_state`):
//! the simulator's state as one JSON object.
//!
//! ```json
//! {"t_s": 0.5, "steps": 50, "run_steps": 50, "dt_s": 0.01, "mode": "lockstep",
//!  "state": "paused", "running": false, "queued_steps": 0, "version": 3, "stepped_version": 3,
//!  "paused_at": {"version": 3, "run_steps": 50, "cause": "command"},
//!  "effects": "from effects.json", "recording": {"path": "run.mcap", "messages": 153,
//!  "state": "recording", "stopped": null},
//!  "robots": [{"name": "puma560", "t_s": 0.5, "steps": 50,
//!              "stages": ["motion", "joint_limits", "link_frames", "logging"],
//!              "joints": ["link1", …], "joint_types": ["revolute", …],
//!              "q": […], "qd": […], "tau": […], "target": […], "torque": null,
//!              "contact": null, "contact_steps": 0, "error": null, "held": null,
//!              "log": "/…/run/simulator-puma560.csv"}]}
//! ```
//!
//! Units: `t_s`, `dt_s` s; `q`, `target` rad (revolute) or m (prismatic), as `joint_types`
//! says; `qd` rad/s or m/s; `tau`, `torque` N·m or N. `t_s`/`steps`: since the pipelines were
//! last built (start, `reset`, a structure change); `run_steps`: since the daemon started (the
//! recording's clock). `state`: `running` (free-running), `stepping` (lock-step steps queued)
//! or `paused`. `contact`: `null` when the robot's pipeline does not check collisions. `error`:
//! why the robot's last step failed (the daemon then pauses), else `null`. `held`: why the
//! simulator holds the robot at its committed joints instead of stepping it (a robot with mimic
//! joints: its pipeline would move a follower on its own), else `null`; commands to it are
//! refused with that reason.
//!
//! `version`: the Instance Space version the pipelines follow (joint values and structure
//! taken from it); `stepped_version`: the version they had taken when they last stepped, 0
//! before the first step. Each robot's `contact` and `error` come from that step: a paused
//! daemon follows commits without stepping, so a commit made while it is paused is in
//! `version` and not yet in `stepped_version` — a reader that wants the simulator's word on a
//! commit waits for `stepped_version` to reach it.
//!
//! `paused_at`: where the current pause of a free-running daemon began — `version`, the newest
//! version committed to the Instance Space at that moment (so a transaction whose acknowledged
//! version is greater was committed after the pause, one at most `version` before it);
//! `run_steps` at the pause; `cause`, `command` (a `pause`) or `error` (a failed step). `null`
//! while running, and in lock-step until the daemon has been resumed and paused again. The
//! simulator's state travels on its own channel, not in the journal: this is how a reader
//! orders a pause against commits. The daemon runs no
//! automation layer, so there are no alarms besides contacts and step errors.
//!
//! `root`: `null` for a fixed base; for a floating robot (issue 36) `{"kind": "free_flyer" |
//! "planar", "q": [7 | 4], "v": [6 | 3], "base": 4×4}` — the root's coordinates relative to
//! where the robot object stood when its pipeline was built (the layouts of
//! `robosim_kinematics::root`), and the base link's world pose now (row-major rows); `q`, `qd`
//! and `tau` above are the joints' only.
//!
//! A scene that declares `orbit` (and `sun_tracking`, `power`) adds a `"space"` object (absent
//! otherwise):
//! ```json
//! "space": {"t_s": 2.0, "orbit": {"altitude_m": 4e5, "beta_deg": 20, "period_s": 5553.6,
//!           "angle_deg": 0.13}, "sun_body": [x, y, z], "eclipse": false, "sun_tracking": true,
//!           "arrays": [{"robot": "port_outboard", "q": […], "incidence_deg": 0.01,
//!                       "area_m2": 1200, "power_w": 2.3e5}],
//!           "power": {"efficiency": 0.14, "power_w": 3.0e5, "energy_kwh": 0.17,
//!                     "battery_soc": 0.8, "battery_kwh": 120.1, "battery_capacity_kwh": 150,
//!                     "load_w": 1e5, "unserved_kwh": 0}}
//! ```
//! (`power` is `null` when the scene declares no power effect.)

use crate::{Mode, Sim};
use robosim_kinematics::JointType;
use robosim_simulator::Command;
use serde_json::{Value, json};

/// The daemon's loop state that `get` reports.
pub(crate) struct LoopState {
    pub mode: Mode,
    pub running: bool,
    pub budget: u64,
    /// Steps since the daemon started.
    pub run_steps: u64,
    /// Steps since the pipelines were last built.
    pub clock_steps: u64,
    pub dt: f64,
    /// The Instance Space version the pipelines follow.
    pub version: u64,
    /// The version they had taken at their last step (0: no step yet).
    pub stepped_version: u64,
    /// Where the current pause began; `None` while running (and in lock-step until the daemon
    /// has run free and been paused).
    pub paused_at: Option<Pause>,
}

/// A pause of a free-running daemon, placed in the Instance Space's history (module docs).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pause {
    /// The newest version committed when the daemon paused.
    pub version: u64,
    /// `run_steps` when it paused.
    pub run_steps: u64,
    /// `command` (a `pause`) or `error` (a failed step).
    pub cause: &'static str,
}

fn robot(s: &Sim) -> Value {
    let (m, w) = (s.pipeline.model(), s.pipeline.data());
    let types: Vec<&str> = m
        .robot
        .joints
        .iter()
        .map(|j| match j.joint_type {
            JointType::Revolute => "revolute",
            JointType::Prismatic => "prismatic",
        })
        .collect();
    let (target, torque) = match &w.command {
        Command::Idle => (None, None),
        Command::Target(q) => (Some(q.as_slice()), None),
        Command::Torque(t) => (None, Some(t.as_slice())),
    };
    let (q, qd, tau) = s.pipeline.joint_state();
    let root = m.robot.root.as_ref().map(|r| {
        let (nq, nv) = (r.kind.nq(), r.kind.nv());
        let base = s.base_now();
        json!({
            "kind": r.kind.name(),
            "q": &w.state.q.as_slice()[..nq],
            "v": &w.state.qd.as_slice()[..nv],
            "base": base.row_iter().map(|row| row.iter().copied().collect::<Vec<f64>>()).collect::<Vec<_>>(),
        })
    });
    json!({
        "name": s.name,
        "t_s": w.state.t,
        "steps": w.step,
        "stages": s.pipeline.stage_names(),
        "joints": s.link_names,
        "joint_types": types,
        "q": q,
        "qd": qd,
        "tau": tau,
        "root": root,
        "target": target,
        "torque": torque,
        "contact": w.contact,
        "contact_steps": w.contact_steps,
        "error": s.error,
        "held": s.held,
        "log": s.log_path.as_ref().map(|p| p.display().to_string()),
    })
}

/// The `get` answer (module docs).
pub(crate) fn status(
    sims: &[Sim],
    l: &LoopState,
    effects: &str,
    recording: Option<Value>,
    space: Option<Value>,
) -> Value {
    let state = if l.running {
        "running"
    } else if l.budget > 0 {
        "stepping"
    } else {
        "paused"
    };
    let mut v = json!({
        "t_s": l.clock_steps as f64 * l.dt,
        "steps": l.clock_steps,
        "run_steps": l.run_steps,
        "dt_s": l.dt,
        "mode": l.mode.name(),
        "state": state,
        "running": l.running,
        "queued_steps": l.budget,
        "version": l.version,
        "stepped_version": l.stepped_version,
        "paused_at": l.paused_at.map(|p| json!({
            "version": p.version, "run_steps": p.run_steps, "cause": p.cause,
        })),
        "effects": effects,
        "recording": recording,
        "robots": sims.iter().map(robot).collect::<Vec<_>>(),
    });
    if let (Some(space), Some(m)) = (space, v.as_object_mut()) {
        m.insert("space".into(), space);
    }
    v
}
