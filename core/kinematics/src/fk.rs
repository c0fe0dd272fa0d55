//! Forward kinematics on the one joint model (see [`crate::Robot`] and the `model` module docs:
//! `A_j = P_j · M_j(q_j) · T_j`). Depends only on q.

use crate::compiled::{OnTheFly, forward_kernel, frames_kernel};
use crate::model::Robot;
use nalgebra::Matrix4;

pub use crate::compiled::link_transform;

/// Every link frame in the world: `frames[0]` is the base, `frames[j]` the frame at the end of
/// `A_j` (j = 1..=n), and the last entry the tool frame — n + 2 matrices in all (n =
/// `robot.dof()`). `q` must have `robot.nq()` entries (spherical joints: see
/// [`crate::spherical`]) (check with [`Robot::check_q`]); for a
/// floating robot `frames[0]` is the base link, `base · M_root(q_root)`.
pub fn link_frames(robot: &Robot, q: &[f64]) -> Vec<Matrix4<f64>> {
    let mut frames = vec![Matrix4::identity(); robot.dof() + 2];
    link_frames_into(robot, q, &mut frames);
    frames
}

/// [`link_frames`] into a caller-owned slice of `robot.dof() + 2` frames (no allocation; see
/// [`crate::Data`]). Panics if the slice is shorter: its size is the caller's invariant.
/// Compiles each joint as it goes; [`crate::KinematicModel::link_frames_into`] gives the same
/// frames from a model compiled once.
pub fn link_frames_into(robot: &Robot, q: &[f64], frames: &mut [Matrix4<f64>]) {
    if robot.has_spherical() {
        return crate::spherical::link_frames_into(robot, q, frames);
    }
    frames_kernel(OnTheFly(robot), q, frames);
}

/// The tool pose `T_ee = base · A_1 ⋯ A_n · tool` in the world (for a tree, the product along
/// the last joint's support path).
pub fn forward(robot: &Robot, q: &[f64]) -> Matrix4<f64> {
    if robot.has_spherical() {
        return crate::spherical::forward(robot, q);
    }
    forward_kernel(OnTheFly(robot), q)
}

/// The world pose of link frame `link` (0 = base, k = the end of joint k−1; see
/// [`Robot::parents`]): the product of the link transforms along its support path.
/// Panics if `link > robot.dof()`.
pub fn link_pose(robot: &Robot, q: &[f64], link: usize) -> Matrix4<f64> {
    assert!(
        link <= robot.dof(),
        "link_pose: link frame {link} of {}",
        robot.dof()
    );
    if robot.has_spherical() {
        return crate::spherical::link_pose(robot, q, link);
    }
    let nq_root = robot.root_nq();
    let mut t = match &robot.root {
        Some(r) => robot.base * r.kind.transform(&q[..nq_root]),
        None => robot.base,
    };
    for j in robot.support(link) {
        t *= link_transform(robot.convention, &robot.joints[j], q[nq_root + j]);
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Convention, Joint};
    use nalgebra::Vector4;

    #[test]
    fn planar_two_link_reaches_where_trigonometry_says() {
        let robot = Robot {
            joints: vec![
                Joint {
                    a: 1.0,
                    ..Joint::default()
                },
                Joint {
                    a: 0.5,
                    ..Joint::default()
                },
            ],
            ..Robot::default()
        };
        let (q1, q2) = (0.3_f64, -1.1_f64);
        let t = forward(&robot, &[q1, q2]);
        let p = t * Vector4::new(0.0, 0.0, 0.0, 1.0);
        assert!((p.x - (q1.cos() + 0.5 * (q1 + q2).cos())).abs() < 1e-15);
        assert!((p.y - (q1.sin() + 0.5 * (q1 + q2).sin())).abs() < 1e-15);
    }

    #[test]
    fn modified_and_standard_agree_on_a_chain_written_both_ways() {
        // A standard chain (a_j, α_j) equals a modified chain whose row j+1 holds (a_j, α_j),
        // up to the last link's Tx(a_n) Rx(α_n), which we put in the tool.
        let std_rows = [(0.1, 0.4, 0.7), (0.2, -0.3, 0.0), (0.05, 0.0, 1.2)]; // (a, d, alpha)
        let standard = Robot {
            joints: std_rows
                .iter()
                .map(|&(a, d, alpha)| Joint {
                    a,
                    d,
                    alpha,
                    ..Joint::default()
                })
                .collect(),
            ..Robot::default()
        };
        let mut modified_joints = Vec::new();
        let mut prev = (0.0, 0.0);
        for &(a, d, alpha) in &std_rows {
            modified_joints.push(Joint {
                a: prev.0,
                alpha: prev.1,
                d,
                ..Joint::default()
            });
            prev = (a, alpha);
        }
        let last = Joint {
            a: prev.0,
            alpha: prev.1,
            ..Joint::default()
        };
        let modified = Robot {
            convention: Convention::Modified,
            joints: modified_joints,
            tool: link_transform(Convention::Modified, &last, 0.0),
            ..Robot::default()
        };
        let q = [0.4, -0.9, 2.0];
        assert!(
            (forward(&standard, &q) - forward(&modified, &q))
                .abs()
                .max()
                < 1e-14
        );
    }
}
