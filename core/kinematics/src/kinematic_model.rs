//! [`KinematicModel`]: a robot compiled once for FK and Jacobians (see [`crate::compiled`] for
//! the compiled joints and the kernels, which the `&Robot` functions of [`crate::fk`] and
//! [`crate::jacobian`] run too). A robot with a spherical joint is kept whole and runs the
//! general functions of [`crate::spherical`].

use crate::compiled::{
    CompiledJoint, Jacobian, Joints, Se3, fk_and_jacobian_kernel, forward_kernel, frames_kernel,
    link_jacobian_kernel,
};
use crate::model::Robot;
use crate::root::RootKind;
use nalgebra::Matrix4;

/// A robot compiled for kinematics (see the module docs): build once with
/// [`KinematicModel::new`], then call FK and Jacobians at any q without allocating.
#[derive(Debug, Clone, PartialEq)]
pub struct KinematicModel {
    joints: Vec<CompiledJoint>,
    /// [`Robot::parents`] (empty: a serial chain).
    parents: Vec<usize>,
    base: Matrix4<f64>,
    tool: Se3,
    chain: bool,
    /// A floating robot's root joint ([`Robot::root`]).
    root: Option<RootKind>,
    /// A robot with a spherical joint, kept whole: the compiled kernels take one-coordinate
    /// joints, so every call runs the general functions of [`crate::spherical`] on it (`None`
    /// for every other robot: one test per call).
    general: Option<Box<Robot>>,
}

impl KinematicModel {
    /// Compiles `robot` (assumed valid: [`Robot::validate`]). A snapshot: a later change to
    /// `robot` is not seen. A robot with a spherical joint ([`crate::Joint::spherical`]) is not
    /// compiled: the model keeps it and runs [`crate::spherical`]'s general FK and Jacobians
    /// (the same numbers as the `&Robot` functions).
    pub fn new(robot: &Robot) -> KinematicModel {
        KinematicModel {
            joints: robot
                .joints
                .iter()
                .map(|j| CompiledJoint::new(j, robot.convention))
                .collect(),
            parents: robot.parents.clone(),
            base: robot.base,
            tool: Se3::from_matrix(&robot.tool),
            chain: robot.is_chain(),
            root: robot.root.as_ref().map(|r| r.kind),
            general: robot.has_spherical().then(|| Box::new(robot.clone())),
        }
    }

    /// Number of (one-coordinate) joints, the root joint not counted ([`Robot::dof`]).
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// Configuration dimension ([`Robot::nq`]): what q's length must be.
    pub fn nq(&self) -> usize {
        if let Some(r) = &self.general {
            return r.nq();
        }
        self.root.map_or(0, RootKind::nq) + self.joints.len()
    }

    /// Velocity dimension ([`Robot::nv`]): a Jacobian's columns.
    pub fn nv(&self) -> usize {
        if let Some(r) = &self.general {
            return r.nv();
        }
        self.root.map_or(0, RootKind::nv) + self.joints.len()
    }

    /// Whether the robot is a serial chain ([`Robot::is_chain`]).
    pub fn is_chain(&self) -> bool {
        self.chain
    }

    /// Every link frame into `frames` (`dof() + 2` entries): see [`crate::fk::link_frames_into`]
    /// (the same frames, bit for bit). Panics if the slice is shorter.
    pub fn link_frames_into(&self, q: &[f64], frames: &mut [Matrix4<f64>]) {
        if let Some(r) = &self.general {
            return crate::spherical::link_frames_into(r, q, frames);
        }
        frames_kernel(self, q, frames);
    }

    /// The tool pose: see [`crate::fk::forward`].
    pub fn forward(&self, q: &[f64]) -> Matrix4<f64> {
        if let Some(r) = &self.general {
            return crate::spherical::forward(r, q);
        }
        forward_kernel(self, q)
    }

    /// Tool pose and base-frame Jacobian (6 × `dof()`) in one pass: see
    /// [`crate::jacobian::fk_and_jacobian_into`].
    pub fn fk_and_jacobian_into(&self, q: &[f64], jac: &mut Jacobian) -> Matrix4<f64> {
        if let Some(r) = &self.general {
            return crate::spherical::jacobian_into(r, q, r.dof(), Some(&r.tool), jac);
        }
        fk_and_jacobian_kernel(self, q, jac)
    }

    /// Pose and base-frame Jacobian of link frame `link`: see
    /// [`crate::jacobian::link_jacobian_into`]. Panics if `link > dof()`.
    pub fn link_jacobian_into(&self, q: &[f64], link: usize, jac: &mut Jacobian) -> Matrix4<f64> {
        if let Some(r) = &self.general {
            return crate::spherical::jacobian_into(r, q, link, None, jac);
        }
        link_jacobian_kernel(&self, q, link, jac)
    }
}

impl<'a> Joints for &'a KinematicModel {
    type J = &'a CompiledJoint;
    #[inline(always)]
    fn len(&self) -> usize {
        self.joints.len()
    }
    #[inline(always)]
    fn joint(&self, j: usize) -> &'a CompiledJoint {
        &self.joints[j]
    }
    #[inline(always)]
    fn revolute(&self, j: usize) -> bool {
        self.joints[j].revolute
    }
    fn parents(&self) -> &[usize] {
        &self.parents
    }
    fn is_chain(&self) -> bool {
        self.chain
    }
    fn base(&self) -> &Matrix4<f64> {
        &self.base
    }
    fn tool(&self) -> Se3 {
        self.tool
    }
    fn root(&self) -> Option<RootKind> {
        self.root
    }
}
