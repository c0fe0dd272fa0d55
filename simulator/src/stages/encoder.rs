//! Encoder quantisation: the joint readings a controller would see, `round(q / r) · r` with
//! resolution `r = 2π / 2^bits` for a revolute joint and `(hi − lo) / 2^bits` for a prismatic
//! one, into `World::q_measured`. Depends only on q.

use crate::effects::{EffectsError, EncoderEffect};
use crate::pipeline::{Data, Model, Stage, StepError};
use robosim_kinematics::{JointType, Robot};

pub struct Encoder {
    bits: u32,
    resolution: Vec<f64>,
}

impl Encoder {
    pub fn new(robot: &Robot, e: &EncoderEffect) -> Result<Self, EffectsError> {
        if !(1..=52).contains(&e.bits) {
            return Err(EffectsError {
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
                return Err(EffectsError {
                    field: format!("encoder (joint {j})"),
                    reason: format!(
                        "prismatic joint needs a finite, non-empty qlim for its encoder range, got {:?}",
                        joint.qlim
                    ),
                });
            }
            resolution.push(r);
        }
        Ok(Encoder {
            bits: e.bits,
            resolution,
        })
    }
}

impl Stage for Encoder {
    fn name(&self) -> &'static str {
        "encoder"
    }
    fn depends_on(&self) -> &'static str {
        "q"
    }
    fn describe(&self) -> String {
        format!(
            "{} bits (revolute resolution {:.3e} rad)",
            self.bits,
            std::f64::consts::TAU / 2f64.powi(self.bits as i32)
        )
    }
    fn run(&mut self, _: &Model, d: &mut Data) -> Result<(), StepError> {
        // the builder allocates `q_measured` whenever it adds this stage
        let Some(m) = d.q_measured.as_mut() else {
            return Ok(());
        };
        for (j, r) in self.resolution.iter().enumerate() {
            m[j] = (d.state.q[j] / r).round() * r;
        }
        Ok(())
    }
}
