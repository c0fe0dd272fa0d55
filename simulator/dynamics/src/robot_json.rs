//! Reading a robot in the query protocol's inline format (DESIGN.md, "The query protocol") from
//! JSON — used for the checked-in fixtures (`testdata/dynamics/robots/*.json`) and inline robots
//! in queries. Interim: `robosim-kinematics` is getting the workspace's `robot_from_json`; once it
//! lands this module should delegate to it.
//!
//! Entry point: [`robot_from_value`].

use nalgebra::{Matrix3, Matrix4, Vector3};
use robosim_kinematics::{Convention, Joint, JointType, Robot};
use serde_json::Value;

/// A robot description that could not be read: `path` names the field (`joints[2].inertia`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("robot description, `{path}`: {reason}")]
pub struct RobotJsonError {
    pub path: String,
    pub reason: String,
}

fn err(path: impl Into<String>, reason: impl Into<String>) -> RobotJsonError {
    RobotJsonError {
        path: path.into(),
        reason: reason.into(),
    }
}

fn number(v: &Value, path: &str) -> Result<f64, RobotJsonError> {
    v.as_f64()
        .ok_or_else(|| err(path, format!("expected a number, got {v}")))
}

fn numbers<const N: usize>(v: &Value, path: &str) -> Result<[f64; N], RobotJsonError> {
    let arr = v
        .as_array()
        .ok_or_else(|| err(path, format!("expected an array of {N} numbers")))?;
    if arr.len() != N {
        return Err(err(
            path,
            format!("expected {N} numbers, got {}", arr.len()),
        ));
    }
    let mut out = [0.0; N];
    for (i, x) in arr.iter().enumerate() {
        out[i] = number(x, &format!("{path}[{i}]"))?;
    }
    Ok(out)
}

fn matrix<const N: usize>(v: &Value, path: &str) -> Result<[[f64; N]; N], RobotJsonError> {
    let rows = v
        .as_array()
        .ok_or_else(|| err(path, format!("expected {N} rows of {N} numbers")))?;
    if rows.len() != N {
        return Err(err(path, format!("expected {N} rows, got {}", rows.len())));
    }
    let mut out = [[0.0; N]; N];
    for (i, row) in rows.iter().enumerate() {
        out[i] = numbers::<N>(row, &format!("{path}[{i}]"))?;
    }
    Ok(out)
}

/// Parses a robot: `{"name"?, "convention"?: "standard"|"modified", "joints": [{"type"?, "a"?,
/// "d"?, "alpha"?, "theta"?, "offset"?, "qlim"?, "mass"?, "com"?, "inertia"? (3×3 rows),
/// "motor_inertia"?, "viscous"?, "coulomb"?}], "gravity"?, "base"? (4×4 rows), "tool"?}`.
/// Missing fields take [`Joint::default`] / [`Robot::default`] values; unknown fields are
/// refused (a typo must not silently become a default). Does not run [`Robot::validate`].
pub fn robot_from_value(v: &Value) -> Result<Robot, RobotJsonError> {
    let obj = v.as_object().ok_or_else(|| err("", "expected an object"))?;
    let mut robot = Robot::default();
    let mut joints_seen = false;
    for (key, val) in obj {
        match key.as_str() {
            "name" => {
                robot.name = val
                    .as_str()
                    .ok_or_else(|| err("name", "expected a string"))?
                    .to_string()
            }
            "convention" => {
                robot.convention = match val.as_str() {
                    Some("standard") => Convention::Standard,
                    Some("modified") => Convention::Modified,
                    _ => {
                        return Err(err(
                            "convention",
                            format!("expected \"standard\" or \"modified\", got {val}"),
                        ));
                    }
                }
            }
            "gravity" => robot.gravity = Vector3::from(numbers::<3>(val, "gravity")?),
            "base" | "tool" => {
                let m = matrix::<4>(val, key)?;
                let mat = Matrix4::from_fn(|i, j| m[i][j]);
                if key == "base" {
                    robot.base = mat;
                } else {
                    robot.tool = mat;
                }
            }
            "joints" => {
                joints_seen = true;
                let arr = val
                    .as_array()
                    .ok_or_else(|| err("joints", "expected an array"))?;
                for (j, jv) in arr.iter().enumerate() {
                    robot.joints.push(joint_from_value(jv, j)?);
                }
            }
            other => return Err(err(other, "unknown field")),
        }
    }
    if !joints_seen {
        return Err(err("joints", "missing"));
    }
    Ok(robot)
}

fn joint_from_value(v: &Value, j: usize) -> Result<Joint, RobotJsonError> {
    let at = |f: &str| format!("joints[{j}].{f}");
    let obj = v
        .as_object()
        .ok_or_else(|| err(format!("joints[{j}]"), "expected an object"))?;
    let mut joint = Joint::default();
    for (key, val) in obj {
        let p = at(key);
        match key.as_str() {
            "type" => {
                joint.joint_type = match val.as_str() {
                    Some("revolute") => JointType::Revolute,
                    Some("prismatic") => JointType::Prismatic,
                    _ => {
                        return Err(err(
                            p,
                            format!("expected \"revolute\" or \"prismatic\", got {val}"),
                        ));
                    }
                }
            }
            "a" => joint.a = number(val, &p)?,
            "d" => joint.d = number(val, &p)?,
            "alpha" => joint.alpha = number(val, &p)?,
            "theta" => joint.theta = number(val, &p)?,
            "offset" => joint.offset = number(val, &p)?,
            "qlim" => joint.qlim = numbers::<2>(val, &p)?,
            "mass" => joint.mass = number(val, &p)?,
            "com" => joint.com = Vector3::from(numbers::<3>(val, &p)?),
            "inertia" => {
                let m = matrix::<3>(val, &p)?;
                joint.inertia = Matrix3::from_fn(|r, c| m[r][c]);
            }
            "motor_inertia" => joint.motor_inertia = number(val, &p)?,
            "viscous" => joint.viscous = number(val, &p)?,
            "coulomb" => joint.coulomb = number(val, &p)?,
            _ => return Err(err(p, "unknown field")),
        }
    }
    Ok(joint)
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
