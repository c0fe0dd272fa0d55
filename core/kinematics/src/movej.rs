//! Joint-space moves (appendix 2.2: MOVEJ sets the joints, MOVEJI interpolates in N steps
//! checking the joint limits at each step). The Instance-Space side is wired elsewhere; this is
//! the plain function. Collision checks plug in per step when that effect is on.
//!
//! Entry point: [`movej_interpolate`].

use crate::model::{ModelError, Robot};

/// A step of a joint move that leaves a joint's limits.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("step {step}: joint {joint} at {value} is outside its limits [{lo}, {hi}]")]
pub struct LimitViolation {
    /// 1-based step index (step N is the goal).
    pub step: usize,
    pub joint: usize,
    pub value: f64,
    pub lo: f64,
    pub hi: f64,
}

/// Why a joint move was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MoveJError {
    #[error("q_from: {0}")]
    From(ModelError),
    #[error("q_to: {0}")]
    To(ModelError),
    #[error("steps must be at least 1")]
    ZeroSteps,
    #[error("{0}")]
    Limit(#[from] LimitViolation),
}

/// The configurations of MOVEJI: `q_from + k/steps · (q_to − q_from)` for k = 1..=steps (the
/// start, where the robot already is, is not repeated; the last entry is exactly `q_to`). Each
/// is checked against the joint limits; the first violation (lowest step, then lowest joint)
/// is returned instead. Linear in joint space; units of q (rad or m).
pub fn movej_interpolate(
    robot: &Robot,
    q_from: &[f64],
    q_to: &[f64],
    steps: usize,
) -> Result<Vec<Vec<f64>>, MoveJError> {
    robot
        .refuse_spherical("MOVEJ's joint-space interpolation")
        .map_err(MoveJError::From)?;
    robot.check_q(q_from).map_err(MoveJError::From)?;
    robot.check_q(q_to).map_err(MoveJError::To)?;
    if steps == 0 {
        return Err(MoveJError::ZeroSteps);
    }
    let mut out = Vec::with_capacity(steps);
    for k in 1..=steps {
        let s = k as f64 / steps as f64;
        let q: Vec<f64> = if k == steps {
            q_to.to_vec()
        } else {
            q_from
                .iter()
                .zip(q_to)
                .map(|(a, b)| a + s * (b - a))
                .collect()
        };
        if let Some((joint, value, [lo, hi])) = robot.outside_limits(&q) {
            return Err(LimitViolation {
                step: k,
                joint,
                value,
                lo,
                hi,
            }
            .into());
        }
        out.push(q);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Joint;

    #[test]
    fn moveji_stops_at_the_first_step_over_a_limit() {
        let robot = Robot {
            joints: vec![
                Joint {
                    qlim: [-1.0, 1.0],
                    ..Joint::default()
                };
                2
            ],
            ..Robot::default()
        };
        let path = movej_interpolate(&robot, &[0.0, 0.0], &[0.5, -1.0], 4).expect("within limits");
        assert_eq!(path.len(), 4);
        assert_eq!(path[3], vec![0.5, -1.0]);
        assert_eq!(path[0], vec![0.125, -0.25]);
        let err =
            movej_interpolate(&robot, &[0.0, 0.0], &[2.0, 0.0], 4).expect_err("over the limit");
        assert_eq!(
            err,
            MoveJError::Limit(LimitViolation {
                step: 3,
                joint: 0,
                value: 1.5,
                lo: -1.0,
                hi: 1.0
            })
        );
        assert_eq!(
            movej_interpolate(&robot, &[0.0], &[0.0, 0.0], 1),
            Err(MoveJError::From(ModelError::WrongDof {
                expected: 2,
                got: 1
            }))
        );
        assert_eq!(
            movej_interpolate(&robot, &[0.0, 0.0], &[0.0, 0.0], 0),
            Err(MoveJError::ZeroSteps)
        );
    }
}
