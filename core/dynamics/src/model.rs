//! The dynamics model: what a robot *is*, precomputed once from a validated
//! [`robosim_kinematics::Robot`] — per link its constant joint axis (motion subspace) in link
//! frame j, its spatial inertia about the link-frame origin, motor inertia, friction and limits;
//! and gravity in the base frame. Never changes during a step ([`crate::Data`] holds what does).
//!
//! Frames: the one joint model of `robosim_kinematics` (`A_j = P_j · M_j(q_j) · T_j`, DH rows and
//! general joints alike). The dynamics works in the **joint frames**: body j's frame is joint
//! frame j moved by q_j (`P_j · M_j`), not link frame j — so the parent-to-child transform is a
//! constant `C_j = T_{j−1} · P_j` followed by the motion about the axis (Pinocchio's layout), the
//! motion subspace `S_j` is the bare axis (`[u; 0]` revolute, `[0; u]` prismatic), and each link's
//! inertia is moved once, at build time, from link frame j into joint frame j by `T_j`. Joint
//! torques, `M(q)` and `q̈` do not depend on the frames chosen; only the rounding does.
//!
//! Trees: every body has a parent ([`robosim_kinematics::Robot::parents`]; Pinocchio's
//! `parents`), `C_j = T_parent · P_j`, and the algorithms run their outward passes in joint
//! order (parents come first) and their inward passes in reverse, accumulating into the parent
//! — one code path; a chain is the tree whose parent is the previous joint.

use crate::spatial::{Motion, RigidInertia, skew};
use nalgebra::{Matrix3, Matrix4, SymmetricEigen, Vector3};
use robosim_kinematics::chain::Inertial;
use robosim_kinematics::{Joint, JointType, ModelError, Robot, RootKind};

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

/// How the motion of a joint is applied to its constant transform (see [`Data`]'s
/// `update_transforms`): an axis along ±x, ±y or ±z rotates two rows (exact and cheap), any
/// other axis goes through the full rotation matrix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Motor {
    /// Revolute about coordinate axis `i` with sign `sign`.
    Aligned { i: usize, sign: f64 },
    /// Revolute about a unit axis.
    Revolute,
    /// Prismatic along a unit axis.
    Prismatic,
}

/// One link of the dynamics model (joint frame j quantities; see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Link {
    pub joint: Joint,
    /// The parent body (0-based joint index); `None`: the base. A chain has `Some(j − 1)`.
    pub parent: Option<usize>,
    /// `C_j = T_{j−1} · P_j`: the parent body's frame → joint frame j before the motion, as
    /// `e_c = Rᵀ` (parent coordinates → joint coordinates) and `r_c` (joint origin in parent).
    pub e_c: Matrix3<f64>,
    pub r_c: Vector3<f64>,
    /// The joint axis (unit, joint frame), its offset and how its motion is applied.
    pub axis: Vector3<f64>,
    pub offset: f64,
    pub motor: Motor,
    /// Motion subspace (joint axis as a unit twist) in joint frame j.
    pub s: Motion,
    /// Spatial inertia about the joint-frame origin.
    pub inertia: RigidInertia,
    pub motor_inertia: f64,
    pub viscous: f64,
    pub coulomb: f64,
    /// A spherical joint (3 v, 4 q; see [`crate::spherical`]): `axis`, `offset`, `motor` and
    /// `s` are not read.
    pub spherical: bool,
    /// Where this joint's coordinates start in q and in v (the root's first).
    pub iq: usize,
    pub iv: usize,
}

/// A floating robot's root body (link frame 0) and its joint (see `robosim_kinematics::root`):
/// the joint's motion subspace, one unit twist per velocity coordinate in link frame 0
/// (Pinocchio's order: linear coordinates first), and the base link's spatial inertia about
/// link frame 0's origin.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct RootBody {
    pub kind: RootKind,
    pub s: Vec<Motion>,
    pub inertia: RigidInertia,
}

impl RootBody {
    fn new(root: &robosim_kinematics::RootJoint) -> RootBody {
        let e = |i: usize| Vector3::ith(i, 1.0);
        let z = Vector3::zeros();
        let lin = |i: usize| Motion { w: z, v: e(i) };
        let ang = |i: usize| Motion { w: e(i), v: z };
        let s = match root.kind {
            RootKind::FreeFlyer => vec![lin(0), lin(1), lin(2), ang(0), ang(1), ang(2)],
            RootKind::Planar => vec![lin(0), lin(1), ang(2)],
        };
        let sym = (root.inertia + root.inertia.transpose()) * 0.5;
        RootBody {
            kind: root.kind,
            s,
            inertia: RigidInertia::from_com(root.mass, &root.com, &sym),
        }
    }

    /// The root's velocity `Σ sᵢ vᵢ` from its coordinates (an empty `v`: zero).
    pub fn motion(&self, v: &[f64]) -> Motion {
        let mut m = Motion::zero();
        for (s, &x) in self.s.iter().zip(v) {
            m = m.add(&s.scale(x));
        }
        m
    }
}

/// A robot ready for the dynamics algorithms (Pinocchio's `Model`). Build it once with
/// [`Model::new`]; pair it with a [`crate::Data`] workspace.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    pub(crate) links: Vec<Link>,
    /// Gravity in the base frame (m/s²): the robot's world gravity rotated by `base`ᵀ.
    pub(crate) gravity_base: Vector3<f64>,
    pub(crate) robot: Robot,
    /// A floating robot's root body; `None`: fixed base.
    pub(crate) root: Option<RootBody>,
    /// Whether a joint is spherical: the passes then run [`crate::spherical`]'s multi-coordinate
    /// recursions (one flag test; a robot without one takes the one-coordinate code unchanged).
    pub(crate) spherical: bool,
}

impl Model {
    /// Validates `robot` ([`Robot::validate`], plus symmetric, positive semi-definite link
    /// inertias) and precomputes the per-link constants.
    pub fn new(robot: &Robot) -> Result<Model, DynamicsError> {
        robot.validate()?;
        let mut links: Vec<Link> = Vec::with_capacity(robot.dof());
        // T_k of every body so far (index 0: the base, identity), for C_j = T_parent · P_j.
        let mut trailings: Vec<Matrix4<f64>> = Vec::with_capacity(robot.dof() + 1);
        trailings.push(Matrix4::identity());
        let (mut iq, mut iv) = (robot.root_nq(), robot.root_nv());
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
            let g = jt.geometry(robot.convention);
            let parent_frame = robot.parent(j);
            let prev_trailing = trailings[parent_frame];
            let c = match &g.placement {
                Some(p) => prev_trailing * p,
                None => prev_trailing,
            };
            let trailing = g.trailing.unwrap_or_else(Matrix4::identity);
            trailings.push(trailing);
            // The link's inertial, moved from link frame j into joint frame j by T_j.
            let inertial = Inertial {
                mass: jt.mass,
                com: jt.com,
                inertia: sym,
            }
            .transformed(&trailing);
            let u = g.axis;
            let (motor, s) = match g.joint_type {
                JointType::Revolute => (
                    aligned(&u).map_or(Motor::Revolute, |(i, sign)| Motor::Aligned { i, sign }),
                    Motion {
                        w: u,
                        v: Vector3::zeros(),
                    },
                ),
                JointType::Prismatic => (
                    Motor::Prismatic,
                    Motion {
                        w: Vector3::zeros(),
                        v: u,
                    },
                ),
            };
            links.push(Link {
                joint: jt.clone(),
                parent: parent_frame.checked_sub(1),
                e_c: c.fixed_view::<3, 3>(0, 0).transpose(),
                r_c: c.fixed_view::<3, 1>(0, 3).into_owned(),
                axis: u,
                offset: g.offset,
                motor,
                s,
                inertia: RigidInertia::from_com(
                    inertial.mass,
                    &inertial.com,
                    &((inertial.inertia + inertial.inertia.transpose()) * 0.5),
                ),
                motor_inertia: jt.motor_inertia,
                viscous: jt.viscous,
                coulomb: jt.coulomb,
                spherical: jt.spherical,
                iq,
                iv,
            });
            let (nq, nv) = if jt.spherical { (4, 3) } else { (1, 1) };
            iq += nq;
            iv += nv;
        }
        let rot = robot.base.fixed_view::<3, 3>(0, 0).into_owned();
        if let Some(r) = &robot.root {
            let sym = (r.inertia + r.inertia.transpose()) * 0.5;
            let min_eig = SymmetricEigen::new(sym).eigenvalues.min();
            if min_eig < -1e-12 * (1.0 + sym.abs().max()) {
                // the base link's inertia; reported as the first velocity coordinate's
                return Err(DynamicsError::NegativeInertia {
                    joint: 0,
                    eigenvalue: min_eig,
                });
            }
        }
        Ok(Model {
            links,
            gravity_base: rot.tr_mul(&robot.gravity),
            robot: robot.clone(),
            root: robot.root.as_ref().map(RootBody::new),
            spherical: robot.has_spherical(),
        })
    }

    /// Number of joints, the root joint not counted; `nq = nv = dof` for a fixed-base robot
    /// without spherical joints (each has 4 q and 3 v).
    pub fn dof(&self) -> usize {
        self.links.len()
    }

    /// Configuration dimension (q's length): `dof` plus a floating root's 7 (free-flyer) or 4
    /// (planar) coordinates.
    pub fn nq(&self) -> usize {
        self.robot.nq()
    }

    /// Velocity dimension (q̇, q̈, τ and `M`'s size): `dof` plus a floating root's 6 or 3.
    pub fn nv(&self) -> usize {
        self.robot.nv()
    }

    /// A floating root's (nq, nv); (0, 0) for a fixed base.
    #[inline]
    pub(crate) fn root_dims(&self) -> (usize, usize) {
        match &self.root {
            Some(r) => (r.kind.nq(), r.kind.nv()),
            None => (0, 0),
        }
    }

    /// The robot this model was built from.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// Gravity in world coordinates, m/s².
    pub fn gravity(&self) -> Vector3<f64> {
        self.robot.gravity
    }

    /// Checks a configuration: [`Model::nq`] finite values, a floating root's rotation unit
    /// ([`Robot::check_q`]).
    pub fn check_q(&self, q: &[f64]) -> Result<(), DynamicsError> {
        self.check_len("q", q, self.nq())?;
        if self.root.is_some() || self.spherical {
            self.robot.check_q(q)?;
        }
        Ok(())
    }

    /// Checks that `x` has one finite value per velocity coordinate ([`Model::nv`]; a
    /// configuration is checked by [`Model::check_q`], and `field` "q" is sent there);
    /// `field` names it in the error.
    pub fn check_vector(&self, field: &'static str, x: &[f64]) -> Result<(), DynamicsError> {
        if field == "q" {
            return self.check_q(x);
        }
        self.check_len(field, x, self.nv())
    }

    fn check_len(
        &self,
        field: &'static str,
        x: &[f64],
        expected: usize,
    ) -> Result<(), DynamicsError> {
        if x.len() != expected {
            return Err(DynamicsError::WrongLength {
                field,
                expected,
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
}

/// `Some((i, ±1))` when `u` is exactly ±e_i.
fn aligned(u: &Vector3<f64>) -> Option<(usize, f64)> {
    (0..3).find_map(|i| {
        (u[i].abs() == 1.0 && u[(i + 1) % 3] == 0.0 && u[(i + 2) % 3] == 0.0).then(|| (i, u[i]))
    })
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

    /// The motion subspace must be the body twist of the transform the algorithms use:
    /// differentiate the parent-to-child transform of every joint of DH and general chains.
    #[test]
    fn motion_subspace_matches_differentiated_transforms() {
        use robosim_kinematics::{Convention, Origin};
        let general = Joint {
            origin: Some(Origin {
                placement: robosim_kinematics::pose::trans(0.1, -0.2, 0.3)
                    * robosim_kinematics::pose::rot_x(0.4),
                axis: Vector3::new(0.36, 0.48, 0.8),
            }),
            ..Joint::default()
        };
        for convention in [Convention::Standard, Convention::Modified] {
            for joint_type in [JointType::Revolute, JointType::Prismatic] {
                let dh = Joint {
                    joint_type,
                    a: 0.3,
                    d: -0.2,
                    alpha: 0.7,
                    theta: 0.4,
                    offset: 0.1,
                    ..Joint::default()
                };
                let gen_joint = Joint {
                    joint_type,
                    ..general.clone()
                };
                let robot = Robot {
                    convention,
                    joints: vec![dh.clone(), dh.clone(), gen_joint.clone(), dh],
                    ..Robot::default()
                };
                let model = Model::new(&robot).expect("valid");
                let mut data = crate::Data::new(&model);
                let as4 = |x: &crate::spatial::Xform| {
                    let mut m = Matrix4::identity();
                    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&x.e.transpose());
                    m.fixed_view_mut::<3, 1>(0, 3).copy_from(&x.r);
                    m
                };
                let q = [0.9, -0.3, 0.5, 1.1];
                let h = 1e-6;
                for k in 0..4 {
                    let mut qp = q;
                    let mut qm = q;
                    qp[k] += h;
                    qm[k] -= h;
                    data.update_transforms(&model, &q);
                    let a0 = as4(&data.x[k]);
                    data.update_transforms(&model, &qp);
                    let a1 = as4(&data.x[k]);
                    data.update_transforms(&model, &qm);
                    let a_1 = as4(&data.x[k]);
                    let inv = a0.try_inverse().expect("rigid transform is invertible");
                    let tw = inv * (a1 - a_1) / (2.0 * h);
                    let w = Vector3::new(tw[(2, 1)], tw[(0, 2)], tw[(1, 0)]);
                    let v = Vector3::new(tw[(0, 3)], tw[(1, 3)], tw[(2, 3)]);
                    let s = &model.links[k].s;
                    assert!(
                        (s.w - w).norm() < 1e-8 && (s.v - v).norm() < 1e-8,
                        "{convention:?} {joint_type:?} joint {k}: s {s:?} vs w {w:?} v {v:?}"
                    );
                }
            }
        }
    }
}
