//! The robot model: what a robot *is*. Never changes during a step (see [`State`] for what it
//! is doing).
//!
//! # One joint model
//!
//! Every joint, however it was described, is the same thing to the algorithms (FK, Jacobians,
//! IK, encoder error, MOVEJ, RNEA/CRBA/ABA): a [`JointGeometry`]
//!
//! ```text
//! A_j(q) = P_j · M_j(q_j + offset_j) · T_j
//! ```
//!
//! * `P_j` — the fixed **placement**: parent link frame j−1 → joint frame j, a rigid transform;
//! * `M_j` — the **motion** about the unit **axis** `u_j` (given in the joint frame, through its
//!   origin): a rotation by the angle for a revolute joint, a translation along `u_j` by the
//!   distance for a prismatic one;
//! * `T_j` — a fixed **trailing** transform from the moved joint frame to link frame j.
//!
//! `T_ee = base · A_1 ⋯ A_n · tool`. Link frame j is the frame at the end of `A_j`; `com` and
//! `inertia` (about the centre of mass) are given in it. SI units: m, rad, kg, kg·m².
//!
//! A joint is filled in one of two ways:
//! * **General** ([`Joint::origin`] is `Some`): URDF's `<origin>` and `<axis>`. `P_j` is
//!   `origin.placement`, `u_j` is `origin.axis`, `T_j = 1`, so link frame j *is* the moved joint
//!   frame (URDF's child link frame). `a`, `d`, `alpha` and `theta` are ignored.
//! * **DH** (`origin` is `None`, the default), by the robot's [`Convention`]:
//!   - standard (distal) DH `A_j = Rz(θ_j) Tz(d_j) Tx(a_j) Rx(α_j)`: revolute `P = 1`,
//!     `u = z`, `T = Tz(d) Tx(a) Rx(α)`; prismatic `P = Rz(θ)`, `u = z`, `T = Tx(a) Rx(α)`;
//!   - modified (Craig) DH, row j holding `a_{j-1}, α_{j-1}`:
//!     `A_j = Rx(α_{j-1}) Tx(a_{j-1}) Rz(θ_j) Tz(d_j)`: revolute `P = Rx(α) Tx(a)`, `u = z`,
//!     `T = Tz(d)`; prismatic `P = Rx(α) Tx(a) Rz(θ)`, `u = z`, `T = 1`.
//!
//!   Revolute: `θ_j = q_j + offset_j`; prismatic: `d_j = q_j + offset_j` with constant `theta`.
//!   The products are formed so that DH rows give bit-for-bit the closed-form DH matrices.
//!
//! Joint kinds: revolute, prismatic; a **continuous** joint is a revolute one with limits
//! `[−∞, ∞]`; a **fixed** joint has no coordinate and is folded when a chain is built
//! ([`crate::chain`]): its transform joins the next joint's placement (or the tool) and the
//! inertia of what it carries is lumped into the link it hangs from — as Pinocchio's URDF
//! reader does, so q, M(q) and τ are those of the chain with the fixed joints.
//!
//! A **spherical** (ball) joint ([`Joint::spherical`]) has three rotational degrees of freedom
//! about its joint frame's origin: `A_j = P_j · R(quat_j)`, 4 q entries (a unit quaternion
//! `qx qy qz qw`) and 3 v entries (the angular velocity in the child frame) — Pinocchio's
//! `JointModelSpherical`. It must be general (an [`Origin`]; its `axis`, `offset`, `qlim` and
//! `joint_type` are not read). Joint j's coordinates then start at [`Robot::q_index`] /
//! [`Robot::v_index`] instead of `root + j`; see [`crate::spherical`] for which algorithms take
//! such a robot and which refuse it ([`ModelError::SphericalUnsupported`]).

use crate::root::RootJoint;
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
    /// A general (non-DH) joint's placement and axis; `None` (the default): a DH row, read by
    /// the robot's [`Convention`] (see the module docs).
    /// (Always serialised, `null` when absent: bincode, which carries robots between
    /// processes, cannot skip fields.)
    pub origin: Option<Origin>,
    /// A spherical (ball) joint: 4 q (unit quaternion `qx qy qz qw`, the rotation of the child
    /// frame in the joint frame) and 3 v (angular velocity in the child frame), Pinocchio's
    /// `JointModelSpherical` (see the module docs). `false` (the default): a one-coordinate
    /// joint of `joint_type`.
    pub spherical: bool,
}

/// A general joint's geometry, as URDF's `<origin>` and `<axis>`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Origin {
    /// Parent link frame → joint frame, a rigid 4×4 transform (m).
    pub placement: Matrix4<f64>,
    /// The joint axis in the joint frame, a unit vector: the rotation axis (through the joint
    /// frame's origin) of a revolute joint, the direction of travel of a prismatic one.
    pub axis: Vector3<f64>,
}

/// The canonical form every algorithm uses: `A(q) = P · M(q + offset) · T` (see the module
/// docs). `None` for `placement` or `trailing` means the identity (skipped, not multiplied).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointGeometry {
    pub joint_type: JointType,
    pub placement: Option<Matrix4<f64>>,
    /// Unit axis in the joint frame.
    pub axis: Vector3<f64>,
    pub offset: f64,
    pub trailing: Option<Matrix4<f64>>,
}

impl JointGeometry {
    /// The motion `M(q + offset)` alone: rotation about / translation along the axis.
    pub fn motion(&self, q: f64) -> Matrix4<f64> {
        let x = q + self.offset;
        let mut m = Matrix4::identity();
        match self.joint_type {
            JointType::Revolute => {
                m.fixed_view_mut::<3, 3>(0, 0)
                    .copy_from(&axis_rotation(&self.axis, x));
            }
            JointType::Prismatic => {
                m.fixed_view_mut::<3, 1>(0, 3).copy_from(&(self.axis * x));
            }
        }
        m
    }

    /// The link transform `A(q) = P · M(q + offset) · T`.
    pub fn transform(&self, q: f64) -> Matrix4<f64> {
        let m = match &self.trailing {
            Some(t) => self.motion(q) * t,
            None => self.motion(q),
        };
        match &self.placement {
            Some(p) => p * m,
            None => m,
        }
    }
}

/// The rotation by `angle` about the unit `axis`. Exact (no rounding beyond sin and cos) when
/// the axis is ±x, ±y or ±z, as DH and most URDF axes are; Rodrigues' formula otherwise.
pub fn axis_rotation(axis: &Vector3<f64>, angle: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    let aligned =
        |i: usize| axis[i].abs() == 1.0 && axis[(i + 1) % 3] == 0.0 && axis[(i + 2) % 3] == 0.0;
    for i in 0..3 {
        if aligned(i) {
            let s = s * axis[i];
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            let mut r = Matrix3::zeros();
            r[(i, i)] = 1.0;
            r[(j, j)] = c;
            r[(k, k)] = c;
            r[(j, k)] = -s;
            r[(k, j)] = s;
            return r;
        }
    }
    let u = axis;
    let k = Matrix3::new(0.0, -u.z, u.y, u.z, 0.0, -u.x, -u.y, u.x, 0.0);
    Matrix3::identity() * c + k * s + (u * u.transpose()) * (1.0 - c)
}

impl Joint {
    /// This joint in the canonical form (see the module docs); `convention` is the robot's
    /// and matters only for a DH row.
    pub fn geometry(&self, convention: Convention) -> JointGeometry {
        if let Some(o) = &self.origin {
            return JointGeometry {
                joint_type: self.joint_type,
                placement: Some(o.placement),
                axis: o.axis,
                offset: self.offset,
                trailing: None,
            };
        }
        let z = Vector3::z();
        let (sa, ca) = self.alpha.sin_cos();
        // Tx(a) Rx(α) with a translation `dz` along z first: Tz(dz) Tx(a) Rx(α).
        let tz_tx_rx = |dz: f64| {
            Matrix4::new(
                1.0, 0.0, 0.0, self.a, //
                0.0, ca, -sa, 0.0, //
                0.0, sa, ca, dz, //
                0.0, 0.0, 0.0, 1.0,
            )
        };
        let rx_tx = Matrix4::new(
            1.0, 0.0, 0.0, self.a, //
            0.0, ca, -sa, 0.0, //
            0.0, sa, ca, 0.0, //
            0.0, 0.0, 0.0, 1.0,
        );
        let rz = |theta: f64| {
            let (st, ct) = theta.sin_cos();
            Matrix4::new(
                ct, -st, 0.0, 0.0, //
                st, ct, 0.0, 0.0, //
                0.0, 0.0, 1.0, 0.0, //
                0.0, 0.0, 0.0, 1.0,
            )
        };
        let tz = |d: f64| {
            let mut m = Matrix4::identity();
            m[(2, 3)] = d;
            m
        };
        let (placement, trailing) = match (convention, self.joint_type) {
            (Convention::Standard, JointType::Revolute) => (None, Some(tz_tx_rx(self.d))),
            (Convention::Standard, JointType::Prismatic) => {
                (Some(rz(self.theta)), Some(tz_tx_rx(0.0)))
            }
            (Convention::Modified, JointType::Revolute) => (Some(rx_tx), Some(tz(self.d))),
            (Convention::Modified, JointType::Prismatic) => (Some(rx_tx * rz(self.theta)), None),
        };
        JointGeometry {
            joint_type: self.joint_type,
            placement,
            axis: z,
            offset: self.offset,
            trailing,
        }
    }

    /// Whether this joint is a general one (has an [`Origin`]) rather than a DH row.
    pub fn is_general(&self) -> bool {
        self.origin.is_some()
    }

    /// The fixed lengths this joint contributes to the arm's size (m): `|a| + |d|` for a DH
    /// row, the placement's translation length for a general joint.
    pub fn length(&self) -> f64 {
        match &self.origin {
            Some(o) => o.placement.fixed_view::<3, 1>(0, 3).norm(),
            None => self.a.abs() + self.d.abs(),
        }
    }
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
            origin: None,
            spherical: false,
        }
    }
}

/// A robot: joints with base and tool transforms — a serial chain, or a kinematic **tree**
/// (a Panda's fingers, Baxter's two arms) when [`Robot::parents`] says so.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Robot {
    pub name: String,
    pub convention: Convention,
    pub joints: Vec<Joint>,
    /// The tree, Pinocchio's `parents` in link-frame numbers: link frame 0 is the base, link
    /// frame k (k = 1..=n) the frame at the end of joint k−1 (0-based joint index), and joint j
    /// hangs from link frame `parents[j]`, which must be ≤ j (parents come first). **Empty: a
    /// serial chain**, the same as `parents[j] = j` (Pinocchio's `parents[i] = i − 1`). For a
    /// tree, `A_j`'s placement `P_j` is given in link frame `parents[j]`; a DH row's placement
    /// is read the same way (its trailing `T_j` ends link frame j). The tool hangs from the
    /// last joint's link frame. (Always serialised, like every field.)
    pub parents: Vec<usize>,
    pub base: Matrix4<f64>,
    pub tool: Matrix4<f64>,
    /// Gravity acceleration in the base frame's parent (world), m/s².
    pub gravity: Vector3<f64>,
    /// A floating base: the root joint between `base` and link frame 0 and the base link's
    /// inertial (see [`crate::root`]); `None` (the default): link frame 0 is fixed at `base`.
    /// With a root, q is `[q_root, q_joints]` ([`Robot::nq`]) and v, τ, q̈ are
    /// `[v_root, joints]` ([`Robot::nv`]).
    pub root: Option<RootJoint>,
}

impl Default for Robot {
    fn default() -> Self {
        Robot {
            name: String::new(),
            convention: Convention::Standard,
            joints: Vec::new(),
            parents: Vec::new(),
            base: Matrix4::identity(),
            tool: Matrix4::identity(),
            gravity: Vector3::new(0.0, 0.0, -9.81),
            root: None,
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
    #[error(
        "joint {joint}: origin placement is not a rigid transform (finite, orthonormal rotation, last row 0 0 0 1)"
    )]
    NotRigidOrigin { joint: usize },
    #[error("joint {joint}: axis {axis:?} is not a finite unit vector")]
    BadAxis { joint: usize, axis: [f64; 3] },
    #[error(
        "`parents` has {got} entries but the robot has {expected} joints (empty for a serial chain)"
    )]
    ParentsLength { expected: usize, got: usize },
    #[error(
        "joint {joint}: parent link frame {parent} is not before it (parents[j] must be at most j)"
    )]
    ParentAfterChild { joint: usize, parent: usize },
    #[error("q has {got} values but the robot has {expected} joints")]
    WrongDof { expected: usize, got: usize },
    #[error("q[{index}] is not finite ({value})")]
    NonFiniteQ { index: usize, value: f64 },
    #[error(
        "q[{start}..{end}]: the root joint's rotation is not unit (norm {norm}); a free-flyer's quaternion (qx qy qz qw) and a planar joint's (cos θ, sin θ) must have norm 1"
    )]
    NonUnitRoot { start: usize, end: usize, norm: f64 },
    #[error("the root joint's {field} is not finite or negative")]
    BadRootInertial { field: &'static str },
    #[error(
        "q[{start}..{end}]: spherical joint {joint}'s quaternion (qx qy qz qw) is not unit (norm {norm})"
    )]
    NonUnitSpherical {
        joint: usize,
        start: usize,
        end: usize,
        norm: f64,
    },
    #[error(
        "joint {joint} is spherical but has no origin: a spherical joint must be general (an origin placement), not a DH row"
    )]
    SphericalNotGeneral { joint: usize },
    #[error("joint {joint} is spherical (a ball joint): {what} handles one-coordinate joints only")]
    SphericalUnsupported { joint: usize, what: &'static str },
}

impl Robot {
    /// Number of (one-coordinate) joints, the root joint not counted: `nq` and `nv` of a
    /// fixed-base robot.
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// The root joint's configuration dimension (0 for a fixed base).
    pub fn root_nq(&self) -> usize {
        self.root.as_ref().map_or(0, |r| r.kind.nq())
    }

    /// The root joint's velocity dimension (0 for a fixed base).
    pub fn root_nv(&self) -> usize {
        self.root.as_ref().map_or(0, |r| r.kind.nv())
    }

    /// Configuration dimension: the length of q (`root_nq + dof`, plus 3 per spherical joint).
    pub fn nq(&self) -> usize {
        self.root_nq() + self.dof() + 3 * self.spherical_count()
    }

    /// Velocity dimension: the length of v, τ, q̈ and a Jacobian's columns (`root_nv + dof`,
    /// plus 2 per spherical joint).
    pub fn nv(&self) -> usize {
        self.root_nv() + self.dof() + 2 * self.spherical_count()
    }

    /// The number of spherical joints ([`Joint::spherical`]).
    pub fn spherical_count(&self) -> usize {
        self.joints.iter().filter(|j| j.spherical).count()
    }

    /// Whether any joint is spherical.
    pub fn has_spherical(&self) -> bool {
        self.joints.iter().any(|j| j.spherical)
    }

    /// The first spherical joint, as the typed refusal of an algorithm (`what`) that handles
    /// one-coordinate joints only; `Ok` when there is none.
    pub fn refuse_spherical(&self, what: &'static str) -> Result<(), ModelError> {
        match self.joints.iter().position(|j| j.spherical) {
            Some(joint) => Err(ModelError::SphericalUnsupported { joint, what }),
            None => Ok(()),
        }
    }

    /// Where joint `j`'s coordinates start in q and in v (the root's first): `(root_nq + j,
    /// root_nv + j)` without spherical joints, each spherical joint before `j` adding 3 and 2.
    /// O(j).
    pub fn q_v_index(&self, j: usize) -> (usize, usize) {
        let balls = self.joints[..j].iter().filter(|x| x.spherical).count();
        (
            self.root_nq() + j + 3 * balls,
            self.root_nv() + j + 2 * balls,
        )
    }

    /// Where joint `j`'s coordinates start in q ([`Robot::q_v_index`]).
    pub fn q_index(&self, j: usize) -> usize {
        self.q_v_index(j).0
    }

    /// Where joint `j`'s coordinates start in v, τ, q̈ and the Jacobian's columns
    /// ([`Robot::q_v_index`]).
    pub fn v_index(&self, j: usize) -> usize {
        self.q_v_index(j).1
    }

    /// The neutral configuration (nq values): the root at the origin unrotated, joints at 0,
    /// spherical joints at the identity quaternion (0 0 0 1).
    pub fn neutral_q(&self) -> DVector<f64> {
        let mut q = DVector::zeros(self.nq());
        if let Some(r) = &self.root {
            r.kind.neutral(&mut q.as_mut_slice()[..r.kind.nq()]);
        }
        if self.has_spherical() {
            for (j, joint) in self.joints.iter().enumerate() {
                if joint.spherical {
                    q[self.q_index(j) + 3] = 1.0;
                }
            }
        }
        q
    }

    /// Whether the robot is a serial chain (no branches).
    pub fn is_chain(&self) -> bool {
        self.parents.iter().enumerate().all(|(j, &p)| p == j)
    }

    /// The link frame joint `j` (0-based) hangs from: 0 = the base, k = the end of joint k−1
    /// (see [`Robot::parents`]).
    #[inline]
    pub fn parent(&self, j: usize) -> usize {
        self.parents.get(j).copied().unwrap_or(j)
    }

    /// The joints that move link frame `link` (1..=n; 0, the base, has none), root first:
    /// the support path (Pinocchio's `supports`). For a chain, `0..link`.
    pub fn support(&self, link: usize) -> Vec<usize> {
        let mut path = Vec::new();
        let mut k = link;
        while k > 0 {
            path.push(k - 1);
            k = self.parent(k - 1);
        }
        path.reverse();
        path
    }

    /// The serial chain from the base to link frame `link` (1..=n) of a tree — its support
    /// path's joints, in order, as a robot of their own — and those joints' indices in this
    /// robot's q. A floating robot's chain starts at its base link, the root joint locked (the
    /// chain has no root: its `base` is this robot's, so its frames are in the base link's frame
    /// when the root is at the neutral q), and the indices are past the root's coordinates. Every joint keeps its geometry (a joint's placement is in the link frame it
    /// hangs from, which is the previous joint's of the chain), so the chain's link frames and
    /// Jacobian at its q are this robot's at any q that agrees on those joints: what IK and the
    /// query protocol use for one tip of a branching robot. The tool is this robot's when `link`
    /// is the last link frame (where the tool hangs), else the identity (the tip link's frame).
    /// `None` for `link` 0 or past n, or when a joint on the path is spherical (a chain is of
    /// one-coordinate joints).
    pub fn chain_to(&self, link: usize) -> Option<(Robot, Vec<usize>)> {
        if link == 0 || link > self.dof() {
            return None;
        }
        let path = self.support(link);
        if path.iter().any(|&j| self.joints[j].spherical) {
            return None;
        }
        let path_q: Vec<usize> = path.iter().map(|&j| self.q_index(j)).collect();
        let chain = Robot {
            name: self.name.clone(),
            convention: self.convention,
            joints: path.iter().map(|&j| self.joints[j].clone()).collect(),
            parents: Vec::new(),
            base: self.base,
            tool: if link == self.dof() {
                self.tool
            } else {
                Matrix4::identity()
            },
            gravity: self.gravity,
            root: None,
        };
        Some((chain, path_q))
    }

    /// Checks every field a user or a planner could get wrong; the algorithms assume a
    /// validated robot.
    pub fn validate(&self) -> Result<(), ModelError> {
        if !self.parents.is_empty() {
            if self.parents.len() != self.dof() {
                return Err(ModelError::ParentsLength {
                    expected: self.dof(),
                    got: self.parents.len(),
                });
            }
            if let Some((joint, &parent)) = self.parents.iter().enumerate().find(|(j, p)| **p > *j)
            {
                return Err(ModelError::ParentAfterChild { joint, parent });
            }
        }
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
            if jt.spherical && jt.origin.is_none() {
                return Err(ModelError::SphericalNotGeneral { joint: j });
            }
            if let Some(o) = &jt.origin {
                if !is_rigid(&o.placement) {
                    return Err(ModelError::NotRigidOrigin { joint: j });
                }
                let n = o.axis.norm();
                if !n.is_finite() || (n - 1.0).abs() > 1e-9 {
                    return Err(ModelError::BadAxis {
                        joint: j,
                        axis: [o.axis.x, o.axis.y, o.axis.z],
                    });
                }
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
        if let Some(r) = &self.root {
            if !(r.mass.is_finite() && r.mass >= 0.0) {
                return Err(ModelError::BadRootInertial { field: "mass" });
            }
            if !r.com.iter().all(|x| x.is_finite()) {
                return Err(ModelError::BadRootInertial { field: "com" });
            }
            if !r.inertia.iter().all(|x| x.is_finite()) {
                return Err(ModelError::BadRootInertial { field: "inertia" });
            }
        }
        Ok(())
    }

    /// The first joint whose value in `q` lies outside its limits: (index, value, [lo, hi]);
    /// a floating root's coordinates have no limits, nor have a spherical joint's (its cone
    /// limit is not enforced); `index` is the joint's.
    pub fn outside_limits(&self, q: &[f64]) -> Option<(usize, f64, [f64; 2])> {
        if self.has_spherical() {
            return self
                .joints
                .iter()
                .enumerate()
                .filter(|(_, jt)| !jt.spherical)
                .find_map(|(j, jt)| {
                    let v = *q.get(self.q_index(j))?;
                    (!(jt.qlim[0]..=jt.qlim[1]).contains(&v)).then_some((j, v, jt.qlim))
                });
        }
        self.joints
            .iter()
            .zip(q.get(self.root_nq()..).unwrap_or(&[]))
            .enumerate()
            .find(|(_, (jt, v))| !(jt.qlim[0]..=jt.qlim[1]).contains(*v))
            .map(|(j, (jt, v))| (j, *v, jt.qlim))
    }

    /// Checks a configuration against this robot: right length ([`Robot::nq`]), all finite,
    /// a floating root's rotation and every spherical joint's quaternion unit to 1e-6.
    pub fn check_q(&self, q: &[f64]) -> Result<(), ModelError> {
        if q.len() != self.nq() {
            return Err(ModelError::WrongDof {
                expected: self.nq(),
                got: q.len(),
            });
        }
        for (index, &value) in q.iter().enumerate() {
            if !value.is_finite() {
                return Err(ModelError::NonFiniteQ { index, value });
            }
        }
        if let Some(r) = &self.root
            && let Some(norm) = r.kind.unit_error(q, UNIT_TOLERANCE)
        {
            let (start, end) = match r.kind {
                crate::RootKind::FreeFlyer => (3, 7),
                crate::RootKind::Planar => (2, 4),
            };
            return Err(ModelError::NonUnitRoot { start, end, norm });
        }
        if self.has_spherical() {
            for (j, jt) in self.joints.iter().enumerate() {
                if !jt.spherical {
                    continue;
                }
                let start = self.q_index(j);
                let norm = q[start..start + 4]
                    .iter()
                    .map(|x| x * x)
                    .sum::<f64>()
                    .sqrt();
                if (norm - 1.0).abs() > UNIT_TOLERANCE {
                    return Err(ModelError::NonUnitSpherical {
                        joint: j,
                        start,
                        end: start + 4,
                        norm,
                    });
                }
            }
        }
        Ok(())
    }
}

/// How far from 1 a root's quaternion (or cos/sin pair) given as input may be.
pub const UNIT_TOLERANCE: f64 = 1e-6;

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
