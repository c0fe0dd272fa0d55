//! The robot model: what a robot *is*. Never changes during a step (see [`State`] for what it
//! is doing).
//!
//! Conventions (DESIGN.md): SI units; standard (distal) DH `A_j = Rz(θ_j) Tz(d_j) Tx(a_j) Rx(α_j)`;
//! modified (Craig) DH, row j holding `a_{j-1}, α_{j-1}`: `A_j = Rx(α_{j-1}) Tx(a_{j-1}) Rz(θ_j) Tz(d_j)`.
//! Revolute: `θ_j = q_j + offset_j`; prismatic: `d_j = q_j + offset_j` with constant `theta`.
//! `T_ee = base · A_1 ⋯ A_n · tool`. `com` and `inertia` (about the centre of mass) are in link
//! frame j, the frame at the end of `A_j`.

use nalgebra::{DVector, Matrix3, Matrix4, Vector3};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Convention {
    #[default]
    Standard,
    Modified,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum JointType {
    #[default]
    Revolute,
    Prismatic,
}

/// One joint and the link it moves. Lengths in m, angles in rad, mass in kg, inertia in kg·m².
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Joint {
    #[serde(rename = "type")]
    pub joint_type: JointType,
    pub a: f64,
    pub d: f64,
    pub alpha: f64,
    /// Constant θ of a prismatic joint; ignored for a revolute one (its θ is q + offset).
    pub theta: f64,
    pub offset: f64,
    /// Joint limits [lo, hi] (rad or m).
    pub qlim: [f64; 2],
    pub mass: f64,
    pub com: Vector3<f64>,
    /// Inertia about the centre of mass, in link frame j.
    pub inertia: Matrix3<f64>,
    /// Motor (rotor) inertia reflected to the joint, kg·m² (0: none).
    pub motor_inertia: f64,
    /// Viscous friction coefficient, N·m·s/rad (0: none).
    pub viscous: f64,
    /// Coulomb friction magnitude, N·m (0: none).
    pub coulomb: f64,
}

impl Default for Joint {
    fn default() -> Self {
        Joint {
            joint_type: JointType::Revolute,
            a: 0.0,
            d: 0.0,
            alpha: 0.0,
            theta: 0.0,
            offset: 0.0,
            qlim: [-std::f64::consts::PI, std::f64::consts::PI],
            mass: 0.0,
            com: Vector3::zeros(),
            inertia: Matrix3::zeros(),
            motor_inertia: 0.0,
            viscous: 0.0,
            coulomb: 0.0,
        }
    }
}

/// A serial robot: an ordered chain of joints with base and tool transforms.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Robot {
    pub name: String,
    pub convention: Convention,
    pub joints: Vec<Joint>,
    pub base: Matrix4<f64>,
    pub tool: Matrix4<f64>,
    /// Gravity acceleration in the base frame's parent (world), m/s².
    pub gravity: Vector3<f64>,
}

impl Default for Robot {
    fn default() -> Self {
        Robot {
            name: String::new(),
            convention: Convention::Standard,
            joints: Vec::new(),
            base: Matrix4::identity(),
            tool: Matrix4::identity(),
            gravity: Vector3::new(0.0, 0.0, -9.81),
        }
    }
}

/// Why a robot model was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    #[error("joint {joint}: field `{field}` is not finite ({value})")]
    NonFinite {
        joint: usize,
        field: &'static str,
        value: f64,
    },
    #[error("joint {joint}: limits [{lo}, {hi}] are reversed")]
    ReversedLimits { joint: usize, lo: f64, hi: f64 },
    #[error("joint {joint}: mass {mass} kg is negative")]
    NegativeMass { joint: usize, mass: f64 },
    #[error("`{field}` is not a rigid transform (finite, orthonormal rotation, last row 0 0 0 1)")]
    NotRigid { field: &'static str },
    #[error("q has {got} values but the robot has {expected} joints")]
    WrongDof { expected: usize, got: usize },
    #[error("q[{index}] is not finite ({value})")]
    NonFiniteQ { index: usize, value: f64 },
}

impl Robot {
    /// Number of joints.
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// Checks every field a user or a planner could get wrong; the algorithms assume a
    /// validated robot.
    pub fn validate(&self) -> Result<(), ModelError> {
        for (j, jt) in self.joints.iter().enumerate() {
            for (field, value) in [
                ("a", jt.a),
                ("d", jt.d),
                ("alpha", jt.alpha),
                ("theta", jt.theta),
                ("offset", jt.offset),
                ("mass", jt.mass),
                ("motor_inertia", jt.motor_inertia),
                ("viscous", jt.viscous),
                ("coulomb", jt.coulomb),
            ] {
                if !value.is_finite() {
                    return Err(ModelError::NonFinite {
                        joint: j,
                        field,
                        value,
                    });
                }
            }
            for v in jt.com.iter() {
                if !v.is_finite() {
                    return Err(ModelError::NonFinite {
                        joint: j,
                        field: "com",
                        value: *v,
                    });
                }
            }
            for v in jt.inertia.iter() {
                if !v.is_finite() {
                    return Err(ModelError::NonFinite {
                        joint: j,
                        field: "inertia",
                        value: *v,
                    });
                }
            }
            if jt.qlim[0].is_nan() || jt.qlim[1].is_nan() {
                return Err(ModelError::NonFinite {
                    joint: j,
                    field: "qlim",
                    value: f64::NAN,
                });
            }
            if jt.qlim[0] > jt.qlim[1] {
                return Err(ModelError::ReversedLimits {
                    joint: j,
                    lo: jt.qlim[0],
                    hi: jt.qlim[1],
                });
            }
            if jt.mass < 0.0 {
                return Err(ModelError::NegativeMass {
                    joint: j,
                    mass: jt.mass,
                });
            }
        }
        for (field, m) in [("base", &self.base), ("tool", &self.tool)] {
            if !is_rigid(m) {
                return Err(ModelError::NotRigid { field });
            }
        }
        Ok(())
    }

    /// The first joint whose value in `q` lies outside its limits: (index, value, [lo, hi]).
    pub fn outside_limits(&self, q: &[f64]) -> Option<(usize, f64, [f64; 2])> {
        self.joints
            .iter()
            .zip(q)
            .enumerate()
            .find(|(_, (jt, v))| !(jt.qlim[0]..=jt.qlim[1]).contains(*v))
            .map(|(j, (jt, v))| (j, *v, jt.qlim))
    }

    /// Checks a joint vector against this robot: right length, all finite.
    pub fn check_q(&self, q: &[f64]) -> Result<(), ModelError> {
        if q.len() != self.dof() {
            return Err(ModelError::WrongDof {
                expected: self.dof(),
                got: q.len(),
            });
        }
        for (index, &value) in q.iter().enumerate() {
            if !value.is_finite() {
                return Err(ModelError::NonFiniteQ { index, value });
            }
        }
        Ok(())
    }
}

fn is_rigid(m: &Matrix4<f64>) -> bool {
    if !m.iter().all(|v| v.is_finite()) {
        return false;
    }
    let r = m.fixed_view::<3, 3>(0, 0);
    let err = (r.transpose() * r - Matrix3::identity()).abs().max();
    err < 1e-9
        && (r.determinant() - 1.0).abs() < 1e-9
        && m[(3, 0)] == 0.0
        && m[(3, 1)] == 0.0
        && m[(3, 2)] == 0.0
        && m[(3, 3)] == 1.0
}

/// What a robot is doing: joint positions, velocities, accelerations, simulated time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct State {
    pub q: DVector<f64>,
    pub qd: DVector<f64>,
    pub qdd: DVector<f64>,
    /// Simulated time, s.
    pub t: f64,
}

impl State {
    /// Rest at q = 0.
    pub fn zeros(dof: usize) -> Self {
        State {
            q: DVector::zeros(dof),
            qd: DVector::zeros(dof),
            qdd: DVector::zeros(dof),
            t: 0.0,
        }
    }
}
