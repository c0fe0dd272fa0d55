//! Joint limits: the inelastic stop of `robosim_dynamics::apply_joint_stops` — a joint past a
//! limit is put on it and its velocity into the limit is zeroed. Depends on q, q̇.

use crate::effects::EffectsError;
use crate::pipeline::{self, Stage, StepError};
use robosim_dynamics::{Model, apply_joint_stops};
use robosim_kinematics::Robot;

pub struct JointLimits {
    model: Model,
}

impl JointLimits {
    pub fn new(robot: &Robot) -> Result<Self, EffectsError> {
        // Model::new checks the limits (ordered, not NaN); mass properties are not used here
        let model = Model::new(robot).map_err(|e| EffectsError {
            field: "joint_limits".into(),
            reason: e.to_string(),
        })?;
        Ok(JointLimits { model })
    }
}

impl Stage for JointLimits {
    fn name(&self) -> &'static str {
        "joint_limits"
    }
    fn depends_on(&self) -> &'static str {
        "q, qd"
    }
    fn describe(&self) -> String {
        "inelastic stops at qlim (q clamped, velocity into the limit zeroed)".into()
    }
    fn run(&mut self, _: &pipeline::Model, d: &mut pipeline::Data) -> Result<(), StepError> {
        apply_joint_stops(&self.model, &mut d.state);
        Ok(())
    }
}
