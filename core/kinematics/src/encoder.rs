//! Encoder quantisation error bounds from the Jacobian (seed §2.7, the surgical positioner's
//! twelve-bit study).
//!
//! A joint read by a b-bit encoder over a range R is off by at most δ = R / 2^b (the seed uses
//! R = 2π for revolute joints). Through the base-frame Jacobian each joint's error moves the
//! tool by J_ij δ_j; with every joint off in its worst direction the error on axis i is at most
//! Σ_j |J_ij| δ_j (the seed's `error()` routine), and the seed's "distance error" is the norm
//! of the three linear bounds. We also give the tight worst case: the largest tool displacement
//! ‖Σ_j s_j δ_j J_v,j‖ over all sign choices s ∈ {−1, 1}ⁿ (a convex function of the joint errors
//! peaks at a corner of the error box), and the same for rotation.
//!
//! Entry point: [`encoder_error`].

use crate::jacobian::{Frame, jacobian};
use crate::model::{JointType, ModelError, Robot};
use nalgebra::Vector3;
use std::f64::consts::PI;

/// Error bounds for one configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct EncoderError {
    /// Resolution of each joint, rad or m.
    pub resolution: Vec<f64>,
    /// Σ_j |J_ij| δ_j for i = x, y, z (m) and rx, ry, rz (rad), base frame (seed §2.7).
    pub per_axis: [f64; 6],
    /// The seed's distance error: the norm of the three linear bounds, m.
    pub position: f64,
    /// The norm of the three angular bounds, rad.
    pub orientation: f64,
    /// The exact worst-case tool displacement over all joint error signs, m (≤ `position`).
    pub position_worst_case: f64,
    /// The exact worst-case first-order rotation over all joint error signs, rad.
    pub orientation_worst_case: f64,
}

/// Why the bound could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EncoderErrorError {
    #[error("{0}")]
    Model(#[from] ModelError),
    #[error("bits has {got} entries but the robot has {expected} joints")]
    WrongBits { expected: usize, got: usize },
    #[error("bits[{joint}] = {bits}: expected 1 to 52")]
    BadBits { joint: usize, bits: u32 },
    #[error("joint {joint} is prismatic with unbounded limits: its encoder range is undefined")]
    UnboundedRange { joint: usize },
}

/// Bounds at `q` for `bits` per joint. Range per joint: 2π for a revolute joint (the seed's
/// choice), the limit span `qlim[1] − qlim[0]` for a prismatic one.
pub fn encoder_error(
    robot: &Robot,
    q: &[f64],
    bits: &[u32],
) -> Result<EncoderError, EncoderErrorError> {
    robot.refuse_spherical("the encoder bounds")?;
    robot.check_q(q)?;
    if bits.len() != robot.dof() {
        return Err(EncoderErrorError::WrongBits {
            expected: robot.dof(),
            got: bits.len(),
        });
    }
    let mut resolution = Vec::with_capacity(bits.len());
    for (j, (joint, &b)) in robot.joints.iter().zip(bits).enumerate() {
        if !(1..=52).contains(&b) {
            return Err(EncoderErrorError::BadBits { joint: j, bits: b });
        }
        let range = match joint.joint_type {
            JointType::Revolute => 2.0 * PI,
            JointType::Prismatic => {
                let r = joint.qlim[1] - joint.qlim[0];
                if !r.is_finite() {
                    return Err(EncoderErrorError::UnboundedRange { joint: j });
                }
                r
            }
        };
        resolution.push(range / 2f64.powi(b as i32));
    }
    let jac = jacobian(robot, q, Frame::Base);
    let mut per_axis = [0.0; 6];
    for (i, axis) in per_axis.iter_mut().enumerate() {
        *axis = (0..robot.dof())
            .map(|j| jac[(i, j)].abs() * resolution[j])
            .sum();
    }
    let position = Vector3::new(per_axis[0], per_axis[1], per_axis[2]).norm();
    let orientation = Vector3::new(per_axis[3], per_axis[4], per_axis[5]).norm();
    // Corners of the error box; 2^(n−1) by symmetry. Beyond 20 joints the corner count is
    // impractical and the per-axis bound is returned as the worst case (still an upper bound).
    let n = robot.dof();
    let (mut pw, mut ow) = (0.0_f64, 0.0_f64);
    if n == 0 {
    } else if n <= 20 {
        for mask in 0u32..(1u32 << (n - 1)) {
            let mut v = Vector3::zeros();
            let mut w = Vector3::zeros();
            for (j, &delta) in resolution.iter().enumerate() {
                let s = if j > 0 && mask & (1 << (j - 1)) != 0 {
                    -1.0
                } else {
                    1.0
                };
                v += jac.fixed_view::<3, 1>(0, j) * (s * delta);
                w += jac.fixed_view::<3, 1>(3, j) * (s * delta);
            }
            pw = pw.max(v.norm());
            ow = ow.max(w.norm());
        }
    } else {
        pw = position;
        ow = orientation;
    }
    Ok(EncoderError {
        resolution,
        per_axis,
        position,
        orientation,
        position_worst_case: pw,
        orientation_worst_case: ow,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::builtin::builtin_robot;
    use crate::model::{Joint, JointType};

    #[test]
    fn twelve_bit_bound_is_the_seeds_sum_and_the_worst_case_is_tighter() {
        let robot = builtin_robot("puma560").expect("builtin");
        let q = [0.2, 0.7, -1.9, 0.4, 1.1, -0.3];
        let e = encoder_error(&robot, &q, &[12; 6]).expect("valid");
        let delta = 2.0 * PI / 4096.0;
        assert!(e.resolution.iter().all(|r| (r - delta).abs() < 1e-18));
        let j = jacobian(&robot, &q, Frame::Base);
        for i in 0..6 {
            let seed_sum: f64 = (0..6).map(|c| (j[(i, c)] * delta).abs()).sum();
            assert!((e.per_axis[i] - seed_sum).abs() < 1e-15);
        }
        assert!(e.position_worst_case <= e.position && e.position_worst_case > 0.5 * e.position);
        // A worst case is attained: push every joint by ±δ and compare to the first-order value.
        let t0 = crate::fk::forward(&robot, &q);
        let mut max_seen = 0.0_f64;
        for mask in 0..64u32 {
            let qq: Vec<f64> = q
                .iter()
                .enumerate()
                .map(|(k, x)| {
                    if mask & (1 << k) != 0 {
                        x + delta
                    } else {
                        x - delta
                    }
                })
                .collect();
            let t = crate::fk::forward(&robot, &qq);
            max_seen =
                max_seen.max((t.fixed_view::<3, 1>(0, 3) - t0.fixed_view::<3, 1>(0, 3)).norm());
        }
        assert!((max_seen - e.position_worst_case).abs() < 1e-2 * e.position_worst_case);
        let e13 = encoder_error(&robot, &q, &[13; 6]).expect("valid");
        assert!((2.0 * e13.position - e.position).abs() < 1e-15);
    }

    #[test]
    fn bad_bits_and_unbounded_prismatic_are_errors() {
        let robot = builtin_robot("puma560").expect("builtin");
        let q = [0.0; 6];
        assert_eq!(
            encoder_error(&robot, &q, &[12; 5]),
            Err(EncoderErrorError::WrongBits {
                expected: 6,
                got: 5
            })
        );
        assert_eq!(
            encoder_error(&robot, &q, &[12, 12, 0, 12, 12, 12]),
            Err(EncoderErrorError::BadBits { joint: 2, bits: 0 })
        );
        let slider = Robot {
            joints: vec![Joint {
                joint_type: JointType::Prismatic,
                qlim: [f64::NEG_INFINITY, 1.0],
                ..Joint::default()
            }],
            ..Robot::default()
        };
        assert_eq!(
            encoder_error(&slider, &[0.0], &[12]),
            Err(EncoderErrorError::UnboundedRange { joint: 0 })
        );
    }
}
