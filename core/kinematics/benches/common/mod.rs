//! Shared by the FK bench and the `peer_timing` example: the robots of
//! `testdata/kinematics/peers/` (written by `tools/peers/kinematics.py`) and the previous FK and
//! Jacobian (4×4 products through `Joint::geometry` per call), kept as the "before" of the
//! before/after comparison.
#![allow(dead_code)]

use nalgebra::Matrix4;
use robosim_kinematics::jacobian::Jacobian;
use robosim_kinematics::{JointType, Robot, builtin_robot, json::robot_from_json};
use serde_json::Value;

/// A peer fixture: the robot and its 16 joint vectors.
pub struct Fixture {
    pub name: String,
    pub robot: Robot,
    pub qs: Vec<Vec<f64>>,
}

/// Reads `testdata/kinematics/peers/<name>.json` or any such file.
pub fn load(path: &str) -> Fixture {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let doc: Value = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{path}: {e}"));
    let r = &doc["robot"];
    let robot = match r["builtin"].as_str() {
        Some(name) => builtin_robot(name).expect("builtin"),
        None => robot_from_json(r).unwrap_or_else(|e| panic!("{path}: {e}")),
    };
    let qs = doc["samples"]
        .as_array()
        .expect("samples")
        .iter()
        .map(|s| {
            s["q"]
                .as_array()
                .expect("q")
                .iter()
                .map(|x| x.as_f64().expect("number"))
                .collect()
        })
        .collect();
    let name = std::path::Path::new(path)
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("robot")
        .to_string();
    Fixture { name, robot, qs }
}

/// The four peer robots, from the repository's testdata.
pub fn fixtures() -> Vec<Fixture> {
    ["puma560", "ur10", "xarm7", "panda"]
        .iter()
        .map(|n| {
            load(&format!(
                "{}/../../testdata/kinematics/peers/{n}.json",
                env!("CARGO_MANIFEST_DIR")
            ))
        })
        .collect()
}

/// The previous `fk::link_frames_into`: `frames[j+1] = frames[parent] · P·(M·T)` in 4×4.
pub fn legacy_frames(robot: &Robot, q: &[f64], frames: &mut [Matrix4<f64>]) {
    let n = robot.joints.len();
    frames[0] = robot.base;
    for (j, (joint, &qj)) in robot.joints.iter().zip(q).enumerate() {
        frames[j + 1] = frames[robot.parent(j)] * joint.geometry(robot.convention).transform(qj);
    }
    frames[n + 1] = frames[n] * robot.tool;
}

/// The previous `jacobian::fk_and_jacobian_into` of a chain (two passes, `W_j = T · P_j`).
pub fn legacy_fk_and_jacobian(robot: &Robot, q: &[f64], jac: &mut Jacobian) -> Matrix4<f64> {
    let mut t = robot.base;
    for (j, (joint, &qj)) in robot.joints.iter().zip(q).enumerate() {
        let g = joint.geometry(robot.convention);
        let w = match &g.placement {
            Some(p) => t * p,
            None => t,
        };
        let axis = w.fixed_view::<3, 3>(0, 0) * g.axis;
        for i in 0..3 {
            jac[(i, j)] = w[(i, 3)];
            jac[(i + 3, j)] = axis[i];
        }
        t *= g.transform(qj);
    }
    let tee = t * robot.tool;
    let pe = tee.fixed_view::<3, 1>(0, 3).into_owned();
    for (j, joint) in robot.joints.iter().enumerate() {
        let o = nalgebra::Vector3::new(jac[(0, j)], jac[(1, j)], jac[(2, j)]);
        let z = nalgebra::Vector3::new(jac[(3, j)], jac[(4, j)], jac[(5, j)]);
        let (v, w) = match joint.joint_type {
            JointType::Revolute => (z.cross(&(pe - o)), z),
            JointType::Prismatic => (z, nalgebra::Vector3::zeros()),
        };
        for i in 0..3 {
            jac[(i, j)] = v[i];
            jac[(i + 3, j)] = w[i];
        }
    }
    tee
}
