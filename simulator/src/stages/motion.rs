//! Kinematic motion (the kinematics effect without dynamics): each joint moves towards its target
//! at most `max_speed · dt` per step; q̇ is the resulting finite difference. Depends on q and the
//! command.

use crate::model::Model;
use robosim_model::{Command, Data};

pub const NAME: &str = "motion";
pub const DEPENDS_ON: &str = "q, command";

pub fn describe(max_speed: f64) -> String {
    format!("kinematic, towards joint targets at ≤ {max_speed} rad/s")
}

/// One step towards the commanded target at `max_speed` (rad/s or m/s); at rest otherwise.
pub fn run(m: &Model, max_speed: f64, d: &mut Data) {
    let max_step = max_speed * m.dt;
    match &d.command {
        Command::Target(target) => {
            for j in 0..d.state.q.len() {
                let dq = (target[j] - d.state.q[j]).clamp(-max_step, max_step);
                d.state.q[j] += dq;
                d.state.qd[j] = dq / m.dt;
            }
        }
        // a torque command cannot be set without dynamics (Pipeline::set_command)
        Command::Idle | Command::Torque(_) => d.state.qd.fill(0.0),
    }
}
