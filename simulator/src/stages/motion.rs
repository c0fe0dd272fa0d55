//! Kinematic motion (the kinematics effect without dynamics): each joint moves towards its target
//! at most `max_speed · dt` per step; q̇ is the resulting finite difference. Depends on q and the
//! command.

use crate::pipeline::{Command, Data, Model, Stage, StepError};

pub struct KinematicMotion {
    max_speed: f64,
}

impl KinematicMotion {
    pub fn new(max_speed: f64) -> Self {
        KinematicMotion { max_speed }
    }
}

impl Stage for KinematicMotion {
    fn name(&self) -> &'static str {
        "motion"
    }
    fn depends_on(&self) -> &'static str {
        "q, command"
    }
    fn describe(&self) -> String {
        format!(
            "kinematic, towards joint targets at ≤ {} rad/s",
            self.max_speed
        )
    }
    fn run(&mut self, m: &Model, d: &mut Data) -> Result<(), StepError> {
        let max_step = self.max_speed * m.dt;
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
        Ok(())
    }
}
