//! Encoder quantisation: the joint readings a controller would see, `round(q / r) · r` with
//! resolution `r = 2π / 2^bits` for a revolute joint and `(hi − lo) / 2^bits` for a prismatic
//! one, into `Data::q_measured`. Depends only on q.

use crate::model::EncoderModel;
use robosim_kinematics::{JointType, Robot};
use robosim_model::{Data, EncoderEffect, OptionsError};

pub const NAME: &str = "encoder";
pub const DEPENDS_ON: &str = "q";

pub fn build(robot: &Robot, e: &EncoderEffect) -> Result<EncoderModel, OptionsError> {
    if !(1..=52).contains(&e.bits) {
        return Err(OptionsError {
            field: "encoder.bits".into(),
            reason: format!("must be 1..=52, got {}", e.bits),
        });
    }
    let counts = 2f64.powi(e.bits as i32);
    let mut resolution = Vec::with_capacity(robot.dof());
    for (j, joint) in robot.joints.iter().enumerate() {
        let r = match joint.joint_type {
            JointType::Revolute => std::f64::consts::TAU / counts,
            JointType::Prismatic => (joint.qlim[1] - joint.qlim[0]) / counts,
        };
        if !(r > 0.0 && r.is_finite()) {
            return Err(OptionsError {
                field: format!("encoder (joint {j})"),
                reason: format!(
                    "prismatic joint needs a finite, non-empty qlim for its encoder range, got {:?}",
                    joint.qlim
                ),
            });
        }
        resolution.push(r);
    }
    Ok(EncoderModel {
        bits: e.bits,
        resolution,
    })
}

pub fn describe(e: &EncoderModel) -> String {
    format!(
        "{} bits (revolute resolution {:.3e} rad)",
        e.bits,
        std::f64::consts::TAU / 2f64.powi(e.bits as i32)
    )
}

/// Fills `d.q_measured` (allocated whenever the pipeline declares this stage).
pub fn run(e: &EncoderModel, d: &mut Data) {
    let Some(m) = d.q_measured.as_mut() else {
        return;
    };
    // a floating robot's q has its root first: the encoders read the joints
    let joints = &d.state.q.as_slice()[d.state.q.len() - e.resolution.len()..];
    for (j, (r, q)) in e.resolution.iter().zip(joints).enumerate() {
        m[j] = (q / r).round() * r;
    }
}
