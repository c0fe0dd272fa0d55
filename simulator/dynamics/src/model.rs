//! The dynamics model: what a robot *is*, precomputed once from a validated
//! [`robosim_kinematics::Robot`] — per link its constant joint axis (motion subspace) in link
//! frame j, its spatial inertia about the link-frame origin, motor inertia, friction and limits;
//! and gravity in the base frame. Never changes during a step ([`crate::Data`] holds what does).
//!
//! Frames (DESIGN.md): link frame j is the frame at the end of `A_j`. In standard (distal) DH the
//! joint j axis is `z_{j-1}`; in link frame j it is the constant line with direction
//! `u = (0, sin α, cos α)` through `(−a, 0, 0)`. In modified (Craig) DH it is `z_j` through the
//! origin of frame j. Either way the motion subspace `S_j` is constant in link frame j, so one
//! set of algorithms serves both conventions (Featherstone 2008, §3.5 and §4.4).

use crate::spatial::{Motion, RigidInertia, skew};
use nalgebra::{Matrix3, Matrix4, SymmetricEigen, Vector3};
use robosim_kinematics::{Convention, Joint, JointType, ModelError, Robot};

/// Why a model, an input vector or a simulation was refused or stopped.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DynamicsError {
    /// The robot failed [`Robot::validate`].
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A link inertia is not symmetric: fix the robot description.
    #[error("joint {joint}: inertia is not symmetric (|I - Iᵀ| = {asymmetry:e} kg·m²)")]
    AsymmetricInertia { joint: usize, asymmetry: f64 },
    /// A link inertia has a negative principal moment: no rigid body has it.
    #[error("joint {joint}: inertia has a negative principal moment ({eigenvalue:e} kg·m²)")]
    NegativeInertia { joint: usize, eigenvalue: f64 },
    /// An input vector (q, qd, qdd, tau, …) has the wrong length.
    #[error("`{field}` has {got} values but the robot has {expected} joints")]
    WrongLength {
        field: &'static str,
        expected: usize,
        got: usize,
    },
    /// An input vector holds NaN or an infinity.
    #[error("`{field}`[{index}] is not finite ({value})")]
    NonFinite {
        field: &'static str,
        index: usize,
        value: f64,
    },
    /// The joint-space inertia is singular at this configuration: the links outboard of `joint`
    /// carry no inertia about its axis and it has no motor inertia. Forward dynamics is undefined;
    /// give the link mass or the joint a motor inertia.
    #[error(
        "joint {joint}: no inertia about the joint axis (articulated inertia {inertia:e}); forward dynamics is undefined"
    )]
    SingularInertia { joint: usize, inertia: f64 },
    /// A result is infinite or NaN although every input was finite: a product of the inputs
    /// left the range of f64 (q̇ = 1e200 squares to 1e400 in the velocity-product terms).
    /// Nothing is returned; scale the inputs to physical magnitudes.
    #[error(
        "`{field}`[{index}] overflowed ({value}) from finite inputs: a product of the inputs exceeds the range of f64"
    )]
    Overflow {
        field: &'static str,
        index: usize,
        value: f64,
    },
    /// The integrated state became NaN or infinite (step too large for a stiff system).
    #[error(
        "state became non-finite at t = {t} s (joint {joint}); reduce the step or tighten the tolerances"
    )]
    Diverged { t: f64, joint: usize },
    /// The implicit momentum update of the symplectic Euler step did not converge.
    #[error("symplectic Euler step at t = {t} s (h = {h:e} s) did not converge; reduce the step")]
    NoConvergence { t: f64, h: f64 },
    /// The adaptive integrator could not meet the tolerances with a step above the floor.
    #[error("step size underflow at t = {t} s (h = {h:e} s): tolerances cannot be met")]
    StepUnderflow { t: f64, h: f64 },
    /// The simulation exceeded its step budget.
    #[error("more than {max_steps} steps before t = {t_end} s; raise dt or the tolerances")]
    TooManySteps { max_steps: u64, t_end: f64 },
    /// A simulation option is out of range.
    #[error("option `{field}`: {reason}")]
    BadOption { field: &'static str, reason: String },
}

/// One link of the dynamics model (link frame j quantities).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Link {
    pub joint: Joint,
    /// Motion subspace (joint axis as a unit twist) in link frame j.
    pub s: Motion,
    /// Spatial inertia about the link-frame origin.
    pub inertia: RigidInertia,
    pub motor_inertia: f64,
    pub viscous: f64,
    pub coulomb: f64,
}

/// A robot ready for the dynamics algorithms (Pinocchio's `Model`). Build it once with
/// [`Model::new`]; pair it with a [`crate::Data`] workspace.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    pub(crate) convention: Convention,
    pub(crate) links: Vec<Link>,
    /// Gravity in the base frame (m/s²): the robot's world gravity rotated by `base`ᵀ.
    pub(crate) gravity_base: Vector3<f64>,
    pub(crate) robot: Robot,
}

impl Model {
    /// Validates `robot` ([`Robot::validate`], plus symmetric, positive semi-definite link
    /// inertias) and precomputes the per-link constants.
    pub fn new(robot: &Robot) -> Result<Model, DynamicsError> {
        robot.validate()?;
        let mut links = Vec::with_capacity(robot.dof());
        for (j, jt) in robot.joints.iter().enumerate() {
            let asym = (jt.inertia - jt.inertia.transpose()).abs().max();
            if asym > 1e-9 * (1.0 + jt.inertia.abs().max()) {
                return Err(DynamicsError::AsymmetricInertia {
                    joint: j,
                    asymmetry: asym,
                });
            }
            let sym = (jt.inertia + jt.inertia.transpose()) * 0.5;
            let min_eig = SymmetricEigen::new(sym).eigenvalues.min();
            if min_eig < -1e-12 * (1.0 + sym.abs().max()) {
                return Err(DynamicsError::NegativeInertia {
                    joint: j,
                    eigenvalue: min_eig,
                });
            }
            links.push(Link {
                joint: jt.clone(),
                s: motion_subspace(robot.convention, jt),
                inertia: RigidInertia::from_com(jt.mass, &jt.com, &sym),
                motor_inertia: jt.motor_inertia,
                viscous: jt.viscous,
                coulomb: jt.coulomb,
            });
        }
        let rot = robot.base.fixed_view::<3, 3>(0, 0).into_owned();
        Ok(Model {
            convention: robot.convention,
            links,
            gravity_base: rot.tr_mul(&robot.gravity),
            robot: robot.clone(),
        })
    }

    /// Number of joints (`nq = nv`).
    pub fn dof(&self) -> usize {
        self.links.len()
    }

    /// The robot this model was built from.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// Gravity in world coordinates, m/s².
    pub fn gravity(&self) -> Vector3<f64> {
        self.robot.gravity
    }

    /// Checks that `x` has one finite value per joint; `field` names it in the error.
    pub fn check_vector(&self, field: &'static str, x: &[f64]) -> Result<(), DynamicsError> {
        if x.len() != self.dof() {
            return Err(DynamicsError::WrongLength {
                field,
                expected: self.dof(),
                got: x.len(),
            });
        }
        match x.iter().position(|v| !v.is_finite()) {
            Some(index) => Err(DynamicsError::NonFinite {
                field,
                index,
                value: x[index],
            }),
            None => Ok(()),
        }
    }

    /// Checks a result vector: every value finite, else [`DynamicsError::Overflow`] naming the
    /// first that is not (inputs were checked finite before, so the cause is overflow).
    pub(crate) fn check_result(field: &'static str, x: &[f64]) -> Result<(), DynamicsError> {
        match x.iter().position(|v| !v.is_finite()) {
            Some(index) => Err(DynamicsError::Overflow {
                field,
                index,
                value: x[index],
            }),
            None => Ok(()),
        }
    }

    /// Joint friction torque (N·m or N) at joint velocity `qd`: viscous `b·qd` plus Coulomb
    /// `c·sign(qd)` with `sign(0) = 0` (no stiction model: a joint at rest feels no Coulomb term).
    #[inline]
    pub(crate) fn friction(link: &Link, qd: f64) -> f64 {
        let sign = if qd > 0.0 {
            1.0
        } else if qd < 0.0 {
            -1.0
        } else {
            0.0
        };
        link.viscous * qd + link.coulomb * sign
    }
}

/// The joint axis as a unit twist in link frame j (see the module docs).
fn motion_subspace(convention: Convention, joint: &Joint) -> Motion {
    let z = Vector3::z();
    match (convention, joint.joint_type) {
        (Convention::Standard, jt) => {
            let (sa, ca) = joint.alpha.sin_cos();
            let u = Vector3::new(0.0, sa, ca);
            match jt {
                JointType::Revolute => {
                    let r = Vector3::new(-joint.a, 0.0, 0.0);
                    Motion {
                        w: u,
                        v: r.cross(&u),
                    }
                }
                JointType::Prismatic => Motion {
                    w: Vector3::zeros(),
                    v: u,
                },
            }
        }
        (Convention::Modified, JointType::Revolute) => Motion {
            w: z,
            v: Vector3::zeros(),
        },
        (Convention::Modified, JointType::Prismatic) => Motion {
            w: Vector3::zeros(),
            v: z,
        },
    }
}

/// The seed's pseudo-inertia matrix of a link (ROBOSIM's per-link `inertia` matrix, seed §2 and
/// appendix 2.1; Paul 1981): `J = ∫ x̃ x̃ᵀ dm` with `x̃ = (x, 1)` in link frame j, i.e.
/// `[[Σ, m c], [m cᵀ, m]]` with `Σ = ½ tr(Ī) 1 − Ī` and `Ī` the inertia about the frame origin.
pub fn pseudo_inertia(joint: &Joint) -> Matrix4<f64> {
    let ri = RigidInertia::from_com(joint.mass, &joint.com, &joint.inertia);
    let sigma = Matrix3::identity() * (0.5 * ri.ibar.trace()) - ri.ibar;
    let mut j = Matrix4::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&sigma);
    j.fixed_view_mut::<3, 1>(0, 3).copy_from(&ri.h);
    j.fixed_view_mut::<1, 3>(3, 0).copy_from(&ri.h.transpose());
    j[(3, 3)] = ri.m;
    j
}

/// Mass (kg), centre of mass (m, link frame j) and inertia about the centre of mass (kg·m²) from
/// a pseudo-inertia matrix; `None` when the mass is not positive (no centre of mass).
pub fn from_pseudo_inertia(j: &Matrix4<f64>) -> Option<(f64, Vector3<f64>, Matrix3<f64>)> {
    let m = j[(3, 3)];
    if m <= 0.0 || !m.is_finite() {
        return None;
    }
    let h: Vector3<f64> = j.fixed_view::<3, 1>(0, 3).into_owned();
    let sigma = j.fixed_view::<3, 3>(0, 0).into_owned();
    let ibar = Matrix3::identity() * sigma.trace() - sigma;
    let c = h / m;
    let cx = skew(&c);
    Some((m, c, ibar + cx * cx * m))
}

/// Whether a link's inertial parameters are physically consistent: its pseudo-inertia is
/// positive semi-definite (Wensing, Kim & Slotine, "Linear matrix inequalities for physically
/// consistent inertial parameter identification", IEEE RA-L 2017) — non-negative mass and
/// principal moments that satisfy the triangle inequality. Not enforced by [`Model::new`]: some
/// published models (the Stanford arm's wrist) violate it slightly and still simulate.
pub fn physically_consistent(joint: &Joint) -> bool {
    let j = pseudo_inertia(joint);
    let scale = 1e-12 * (1.0 + j.abs().max());
    SymmetricEigen::new(j)
        .eigenvalues
        .iter()
        .all(|&e| e >= -scale)
}

#[cfg(test)]
mod tests {
    use super::*;
    use robosim_kinematics::fk::link_transform;

    #[test]
    fn pseudo_inertia_round_trips() {
        let joint = Joint {
            mass: 2.5,
            com: Vector3::new(0.1, -0.2, 0.05),
            inertia: Matrix3::new(0.3, 0.01, -0.02, 0.01, 0.25, 0.03, -0.02, 0.03, 0.2),
            ..Joint::default()
        };
        let (m, c, i) = from_pseudo_inertia(&pseudo_inertia(&joint)).expect("positive mass");
        assert!((m - 2.5).abs() < 1e-15);
        assert!((c - joint.com).norm() < 1e-15);
        assert!((i - joint.inertia).abs().max() < 1e-14);
        assert!(physically_consistent(&joint));
        let thin = Joint {
            mass: 1.0,
            inertia: Matrix3::from_diagonal(&Vector3::new(1.0, 0.1, 0.1)),
            ..Joint::default()
        };
        assert!(
            !physically_consistent(&thin),
            "1.0 > 0.1 + 0.1 violates the triangle inequality"
        );
    }

    /// The joint axis in link frame j must be the one the kinematics moves: differentiate FK.
    #[test]
    fn motion_subspace_matches_differentiated_link_transform() {
        for convention in [Convention::Standard, Convention::Modified] {
            for joint_type in [JointType::Revolute, JointType::Prismatic] {
                let joint = Joint {
                    joint_type,
                    a: 0.3,
                    d: -0.2,
                    alpha: 0.7,
                    theta: 0.4,
                    offset: 0.1,
                    ..Joint::default()
                };
                let q = 0.9;
                let h = 1e-6;
                let a0 = link_transform(convention, &joint, q);
                let a1 = link_transform(convention, &joint, q + h);
                let a_1 = link_transform(convention, &joint, q - h);
                // body twist of frame j: A⁻¹ dA/dq
                let inv = a0.try_inverse().expect("rigid transform is invertible");
                let tw = inv * (a1 - a_1) / (2.0 * h);
                let w = Vector3::new(tw[(2, 1)], tw[(0, 2)], tw[(1, 0)]);
                let v = Vector3::new(tw[(0, 3)], tw[(1, 3)], tw[(2, 3)]);
                let s = motion_subspace(convention, &joint);
                assert!(
                    (s.w - w).norm() < 1e-8,
                    "{convention:?} {joint_type:?}: w {:?} vs {:?}",
                    s.w,
                    w
                );
                assert!(
                    (s.v - v).norm() < 1e-8,
                    "{convention:?} {joint_type:?}: v {:?} vs {:?}",
                    s.v,
                    v
                );
            }
        }
    }
}
