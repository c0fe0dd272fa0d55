//! The workspace the algorithms write into (Pinocchio's `Data`, MuJoCo's `mjData`): allocated once
//! per model by [`Data::new`], then reused, so RNEA, CRBA, ABA and the integrators allocate
//! nothing per call.

use crate::model::{Model, Motor};
use crate::spatial::{Force, Motion, RigidInertia, Xform};
use crate::spherical::BallScratch;
use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, Vector3, Vector6};
use robosim_kinematics::axis_rotation;
use robosim_kinematics::spherical::quat_rotation;

/// Per-call results and scratch space for one [`Model`]. Results are public fields named after
/// what fills them: [`crate::rnea`] fills `tau`, [`crate::crba`] fills `mass_matrix`,
/// [`crate::aba`] fills `qdd`.
#[derive(Debug, Clone)]
pub struct Data {
    /// Joint torques/forces (N·m or N), dim `dof`.
    pub tau: DVector<f64>,
    /// Joint accelerations (rad/s² or m/s²), dim `dof`.
    pub qdd: DVector<f64>,
    /// Joint-space inertia matrix `M(q)`, `dof × dof`, both triangles filled.
    pub mass_matrix: DMatrix<f64>,
    /// The torque joint friction applies (N·m or N), dim `dof`: filled by
    /// [`crate::friction_torque`] (and the stepper when a friction effect is declared).
    pub passive: DVector<f64>,
    pub(crate) x: Vec<Xform>,
    pub(crate) v: Vec<Motion>,
    pub(crate) a: Vec<Motion>,
    pub(crate) f: Vec<Force>,
    pub(crate) ic: Vec<RigidInertia>,
    pub(crate) ia: Vec<Matrix6<f64>>,
    pub(crate) pa: Vec<Vector6<f64>>,
    pub(crate) c: Vec<Vector6<f64>>,
    pub(crate) u6: Vec<Vector6<f64>>,
    pub(crate) d: Vec<f64>,
    pub(crate) u: Vec<f64>,
    /// World rotation and position of each body (energy's potential term).
    pub(crate) world: Vec<(Matrix3<f64>, Vector3<f64>)>,
    /// Cholesky factor scratch (lower triangle) and a right-hand side.
    pub(crate) chol: DMatrix<f64>,
    pub(crate) rhs: DVector<f64>,
    /// A floating robot's root body (link frame 0): its transform from the base frame, velocity,
    /// acceleration, force, composite and articulated inertia, bias force.
    pub(crate) root: RootData,
    /// ABA's per-joint quantities of spherical joints (empty without one).
    pub(crate) ball: Vec<BallScratch>,
}

/// The root body's per-call quantities (unused for a fixed base).
#[derive(Debug, Clone)]
pub(crate) struct RootData {
    pub x: Xform,
    pub v: Motion,
    pub a: Motion,
    pub f: Force,
    pub ic: RigidInertia,
    pub ia: Matrix6<f64>,
    pub pa: Vector6<f64>,
}

impl Data {
    /// A workspace sized for `model`.
    pub fn new(model: &Model) -> Data {
        let n = model.dof();
        let nv = model.nv();
        Data {
            tau: DVector::zeros(nv),
            qdd: DVector::zeros(nv),
            mass_matrix: DMatrix::zeros(nv, nv),
            passive: DVector::zeros(nv),
            x: vec![Xform::default(); n],
            v: vec![Motion::zero(); n],
            a: vec![Motion::zero(); n],
            f: vec![Force::zero(); n],
            ic: vec![RigidInertia::zero(); n],
            ia: vec![Matrix6::zeros(); n],
            pa: vec![Vector6::zeros(); n],
            c: vec![Vector6::zeros(); n],
            u6: vec![Vector6::zeros(); n],
            d: vec![0.0; n],
            u: vec![0.0; n],
            world: vec![(Matrix3::identity(), Vector3::zeros()); n],
            chol: DMatrix::zeros(nv, nv),
            rhs: DVector::zeros(nv),
            root: RootData {
                x: Xform::default(),
                v: Motion::zero(),
                a: Motion::zero(),
                f: Force::zero(),
                ic: RigidInertia::zero(),
                ia: Matrix6::zeros(),
                pa: Vector6::zeros(),
            },
            ball: if model.spherical {
                vec![BallScratch::default(); n]
            } else {
                Vec::new()
            },
        }
    }

    /// Fills the parent-to-child transforms `x[j]` at `q`: the constant `C_j` followed by the
    /// joint's motion (see the model's module docs), and a floating root's `root.x` (base frame
    /// → link frame 0). Depends only on q. `q.len() == model.nq()` is the caller's invariant.
    pub(crate) fn update_transforms(&mut self, model: &Model, q: &[f64]) {
        if model.spherical {
            return spherical_update_transforms(self, model, q);
        }
        let q = match &model.root {
            Some(root) => {
                let (qr, qj) = q.split_at(root.kind.nq());
                let (r, t) = root.kind.rotation_translation(qr);
                self.root.x = Xform {
                    e: r.transpose(),
                    r: t,
                };
                qj
            }
            None => q,
        };
        for ((x, link), &qj) in self.x.iter_mut().zip(&model.links).zip(q) {
            let t = qj + link.offset;
            match link.motor {
                Motor::Aligned { i, sign } => {
                    // e = Rm(t)ᵀ e_c: rows j, k of e_c turn by −t about axis i.
                    let (s, c) = t.sin_cos();
                    let s = s * sign;
                    let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                    let rj = link.e_c.row(j);
                    let rk = link.e_c.row(k);
                    x.e.set_row(i, &link.e_c.row(i));
                    x.e.set_row(j, &(rj * c + rk * s));
                    x.e.set_row(k, &(rk * c - rj * s));
                    x.r = link.r_c;
                }
                Motor::Revolute => {
                    x.e = axis_rotation(&link.axis, t).transpose() * link.e_c;
                    x.r = link.r_c;
                }
                Motor::Prismatic => {
                    x.e = link.e_c;
                    x.r = link.r_c + link.e_c.tr_mul(&link.axis) * t;
                }
            }
        }
    }
}

/// [`Data::update_transforms`] for a model with spherical joints: the parent-to-child transforms
/// at `q` (q's layout: the root's, then each joint's 1 or 4).
pub(crate) fn spherical_update_transforms(data: &mut Data, model: &Model, q: &[f64]) {
    if let Some(root) = &model.root {
        let (r, t) = root.kind.rotation_translation(&q[..root.kind.nq()]);
        data.root.x = Xform {
            e: r.transpose(),
            r: t,
        };
    }
    for (x, link) in data.x.iter_mut().zip(&model.links) {
        let qj = &q[link.iq..];
        if link.spherical {
            // child in parent: R_c · R(quat), so e = R(quat)ᵀ e_c
            x.e = quat_rotation(qj).transpose() * link.e_c;
            x.r = link.r_c;
        } else {
            let t = qj[0] + link.offset;
            match link.motor {
                crate::model::Motor::Prismatic => {
                    x.e = link.e_c;
                    x.r = link.r_c + link.e_c.tr_mul(&link.axis) * t;
                }
                _ => {
                    x.e = robosim_kinematics::axis_rotation(&link.axis, t).transpose() * link.e_c;
                    x.r = link.r_c;
                }
            }
        }
    }
}
