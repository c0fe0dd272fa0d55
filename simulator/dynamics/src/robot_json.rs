//! Reading a robot in the query protocol's inline format (DESIGN.md, "The query protocol") from
//! JSON — used for the checked-in fixtures (`testdata/dynamics/robots/*.json`) and inline robots
//! in queries, delegating to the workspace's `robosim_kinematics::robot_from_json`.
//!
//! Entry point: [`robot_from_value`].

use robosim_kinematics::{Robot, robot_from_json};
use serde_json::Value;

/// A robot description that could not be read: `path` names the field (`joints[2].inertia`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("robot description, `{path}`: {reason}")]
pub struct RobotJsonError {
    pub path: String,
    pub reason: String,
}

/// Parses a robot in the inline format by `robosim_kinematics::robot_from_json` (unknown fields
/// refused, missing ones defaulted, the robot validated) and names the failing field.
pub fn robot_from_value(v: &Value) -> Result<Robot, RobotJsonError> {
    robot_from_json(v).map_err(|e| RobotJsonError {
        path: e.path,
        reason: e.reason,
    })
}

/// The checked-in fixtures (`testdata/dynamics/robots/`), compiled in: the PUMA 560, Stanford arm
/// and Panda with roboticstoolbox-python's dynamic parameters (motor inertia and friction zero),
/// used by the reports and as a fallback library for queries. `None` for other names.
pub fn fixture_robot(name: &str) -> Option<Robot> {
    let text = match name {
        "puma560" => include_str!("../../../testdata/dynamics/robots/puma560.json"),
        "stanford" => include_str!("../../../testdata/dynamics/robots/stanford.json"),
        "panda" => include_str!("../../../testdata/dynamics/robots/panda.json"),
        _ => return None,
    };
    // The fixtures are checked in and parsed by the tests; a parse failure here is a broken checkout.
    let value: Value = serde_json::from_str(text).ok()?;
    robot_from_value(&value).ok()
}
