//! Joint limits: the inelastic stop of `robosim_dynamics::apply_joint_stops` — a joint past a
//! limit is put on it and its velocity into the limit is zeroed. Depends on q, q̇.

use crate::model::BuildError;
use robosim_dynamics::{Model, apply_joint_stops};
use robosim_kinematics::Robot;
use robosim_model::Data;

pub const NAME: &str = "joint_limits";
pub const DEPENDS_ON: &str = "q, qd";

/// The joint-stop model of `robot` (`Model::new` checks the limits: ordered, not NaN; the
/// mass properties are not used here).
pub fn build(robot: &Robot) -> Result<Model, BuildError> {
    Model::new(robot).map_err(|source| BuildError::Dynamics {
        field: "joint_limits",
        source,
    })
}

pub fn describe() -> String {
    "inelastic stops at qlim (q clamped, velocity into the limit zeroed)".into()
}

pub fn run(limits: &Model, d: &mut Data) {
    apply_joint_stops(limits, &mut d.state);
}
