//! The root joint of a floating-base robot: the joint between the world (the robot's `base`
//! frame) and link frame 0 (the base link), with more than one coordinate and a configuration
//! space that is not a vector space — Pinocchio's `JointModelFreeFlyer` and
//! `JointModelPlanar`, with the same q and v layouts so numbers compare directly:
//!
//! | kind | nq | q | nv | v |
//! |---|---|---|---|---|
//! | free-flyer | 7 | `x y z` (m), unit quaternion `qx qy qz qw` | 6 | `vx vy vz ωx ωy ωz` |
//! | planar | 4 | `x y` (m), `cos θ`, `sin θ` | 3 | `vx vy ωz` |
//!
//! v is the base link's velocity in its **own** frame (Pinocchio's joint velocity, "LOCAL"):
//! linear velocity of link frame 0's origin and angular velocity, both on link frame 0's axes.
//! A floating robot's q is `[q_root (nq_root), q_joints (n)]`, its v, τ and q̈ are
//! `[v_root (nv_root), joints (n)]` (`nq = nq_root + n`, `nv = nv_root + n`).
//!
//! The root's motion is `M(q_root)`: link frame 0 = `base · M(q_root)`. A free-flyer's
//! quaternion is normalised where it is read (a rotation is always a rotation); inputs are
//! checked unit to 1e-6 ([`crate::Robot::check_q`]). Integration on the manifold:
//! [`RootKind::integrate`] is `q ⊕ v·h` (the exponential of SE(3) or SE(2), as Pinocchio's
//! `integrate`); [`RootKind::q_dot`] is the time derivative of q in its embedding (ℝ⁷ or ℝ⁴),
//! for Runge–Kutta stages, after which [`RootKind::normalize`] puts q back on the manifold.

use nalgebra::{Matrix3, Matrix4, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// What a floating robot's root joint is (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RootKind {
    /// Six degrees of freedom: position and unit quaternion (Pinocchio's free-flyer).
    FreeFlyer,
    /// Motion in the base frame's x–y plane: x, y and a rotation about z (Pinocchio's planar).
    Planar,
}

/// A floating robot's root joint and the inertial of the base link it moves (link frame 0:
/// mass in kg, centre of mass in m and inertia about the centre of mass in kg·m², in link
/// frame 0).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RootJoint {
    pub kind: RootKind,
    pub mass: f64,
    pub com: Vector3<f64>,
    pub inertia: Matrix3<f64>,
}

impl RootJoint {
    /// A massless root of `kind`.
    pub fn new(kind: RootKind) -> RootJoint {
        RootJoint {
            kind,
            mass: 0.0,
            com: Vector3::zeros(),
            inertia: Matrix3::zeros(),
        }
    }
}

impl RootKind {
    /// Configuration dimension: 7 (free-flyer) or 4 (planar).
    pub fn nq(self) -> usize {
        match self {
            RootKind::FreeFlyer => 7,
            RootKind::Planar => 4,
        }
    }

    /// Velocity dimension: 6 (free-flyer) or 3 (planar).
    pub fn nv(self) -> usize {
        match self {
            RootKind::FreeFlyer => 6,
            RootKind::Planar => 3,
        }
    }

    /// The protocol name: `free_flyer`, `planar`.
    pub fn name(self) -> &'static str {
        match self {
            RootKind::FreeFlyer => "free_flyer",
            RootKind::Planar => "planar",
        }
    }

    /// The kind named `free_flyer` (or `floating`) or `planar`.
    pub fn from_name(name: &str) -> Option<RootKind> {
        match name {
            "free_flyer" | "floating" => Some(RootKind::FreeFlyer),
            "planar" => Some(RootKind::Planar),
            _ => None,
        }
    }

    /// The neutral configuration (Pinocchio's `neutral`): at the origin, no rotation.
    pub fn neutral(self, q: &mut [f64]) {
        q.fill(0.0);
        match self {
            RootKind::FreeFlyer => q[6] = 1.0,
            RootKind::Planar => q[2] = 1.0,
        }
    }

    /// The root's rotation and translation at `q` (nq values; the quaternion or (cos, sin)
    /// pair normalised; a zero pair gives the identity rotation).
    pub fn rotation_translation(self, q: &[f64]) -> (Matrix3<f64>, Vector3<f64>) {
        match self {
            RootKind::FreeFlyer => {
                let quat = nalgebra::Quaternion::new(q[6], q[3], q[4], q[5]);
                let r = UnitQuaternion::try_new(quat, 0.0)
                    .map_or_else(Matrix3::identity, |u| *u.to_rotation_matrix().matrix());
                (r, Vector3::new(q[0], q[1], q[2]))
            }
            RootKind::Planar => {
                let n = q[2].hypot(q[3]);
                let (c, s) = if n > 0.0 {
                    (q[2] / n, q[3] / n)
                } else {
                    (1.0, 0.0)
                };
                let r = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
                (r, Vector3::new(q[0], q[1], 0.0))
            }
        }
    }

    /// The root's motion `M(q)` as a 4×4 rigid transform.
    pub fn transform(self, q: &[f64]) -> Matrix4<f64> {
        let (r, t) = self.rotation_translation(q);
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&t);
        m
    }

    /// Whether `q`'s rotation part is a unit quaternion / unit (cos, sin) pair to `tol`;
    /// returns its norm when it is not.
    pub fn unit_error(self, q: &[f64], tol: f64) -> Option<f64> {
        let n = match self {
            RootKind::FreeFlyer => (q[3] * q[3] + q[4] * q[4] + q[5] * q[5] + q[6] * q[6]).sqrt(),
            RootKind::Planar => q[2].hypot(q[3]),
        };
        ((n - 1.0).abs() > tol || !n.is_finite()).then_some(n)
    }

    /// Puts `q` back on the manifold: the quaternion / (cos, sin) pair divided by its norm.
    pub fn normalize(self, q: &mut [f64]) {
        let range = match self {
            RootKind::FreeFlyer => 3..7,
            RootKind::Planar => 2..4,
        };
        let n = q[range.clone()].iter().map(|x| x * x).sum::<f64>().sqrt();
        if n > 0.0 && n.is_finite() {
            q[range].iter_mut().for_each(|x| *x /= n);
        }
    }

    /// `dq = dq/dt` at (q, v): the time derivative of the configuration in its embedding.
    /// Free-flyer: `ṗ = R v`, `q̇uat = ½ quat ⊗ (ω, 0)`; planar: `(ẋ, ẏ) = R(θ) (vx, vy)`,
    /// `(ċ, ṡ) = ω (−s, c)`.
    pub fn q_dot(self, q: &[f64], v: &[f64], dq: &mut [f64]) {
        match self {
            RootKind::FreeFlyer => {
                let (r, _) = self.rotation_translation(q);
                let p = r * Vector3::new(v[0], v[1], v[2]);
                let (x, y, z, w) = (q[3], q[4], q[5], q[6]);
                let (wx, wy, wz) = (v[3], v[4], v[5]);
                dq[0] = p.x;
                dq[1] = p.y;
                dq[2] = p.z;
                // ½ (w ω + q_vec × ω), −½ q_vec · ω
                dq[3] = 0.5 * (w * wx + y * wz - z * wy);
                dq[4] = 0.5 * (w * wy + z * wx - x * wz);
                dq[5] = 0.5 * (w * wz + x * wy - y * wx);
                dq[6] = -0.5 * (x * wx + y * wy + z * wz);
            }
            RootKind::Planar => {
                let (c, s) = (q[2], q[3]);
                dq[0] = c * v[0] - s * v[1];
                dq[1] = s * v[0] + c * v[1];
                dq[2] = -s * v[2];
                dq[3] = c * v[2];
            }
        }
    }

    /// `out = q ⊕ v·h`: the root moved by the constant body velocity `v` for `h` seconds, the
    /// group exponential (Pinocchio's `integrate`: `M(q) · exp(v h)`), renormalised.
    pub fn integrate(self, q: &[f64], v: &[f64], h: f64, out: &mut [f64]) {
        match self {
            RootKind::FreeFlyer => {
                let w = Vector3::new(v[3], v[4], v[5]) * h;
                let u = Vector3::new(v[0], v[1], v[2]) * h;
                let theta2 = w.norm_squared();
                let theta = theta2.sqrt();
                // V(ω) = 1 + (1 − cos θ)/θ² [ω]× + (θ − sin θ)/θ³ [ω]×², series near 0
                let (b, c) = if theta < 1e-4 {
                    (0.5 - theta2 / 24.0, 1.0 / 6.0 - theta2 / 120.0)
                } else {
                    (
                        (1.0 - theta.cos()) / theta2,
                        (theta - theta.sin()) / (theta2 * theta),
                    )
                };
                let wu = w.cross(&u);
                let local = u + wu * b + w.cross(&wu) * c;
                let (r, p) = self.rotation_translation(q);
                let p = p + r * local;
                let quat = nalgebra::Quaternion::new(q[6], q[3], q[4], q[5])
                    * *UnitQuaternion::from_scaled_axis(w).quaternion();
                out[0] = p.x;
                out[1] = p.y;
                out[2] = p.z;
                out[3] = quat.i;
                out[4] = quat.j;
                out[5] = quat.k;
                out[6] = quat.w;
            }
            RootKind::Planar => {
                let (vx, vy, th) = (v[0] * h, v[1] * h, v[2] * h);
                let (s, c) = th.sin_cos();
                // V(θ) = [[sin θ/θ, −(1 − cos θ)/θ], [(1 − cos θ)/θ, sin θ/θ]]
                let (a, b) = if th.abs() < 1e-4 {
                    (1.0 - th * th / 6.0, th / 2.0 - th * th * th / 24.0)
                } else {
                    (s / th, (1.0 - c) / th)
                };
                let lx = a * vx - b * vy;
                let ly = b * vx + a * vy;
                let (c0, s0) = (q[2], q[3]);
                out[0] = q[0] + c0 * lx - s0 * ly;
                out[1] = q[1] + s0 * lx + c0 * ly;
                out[2] = c0 * c - s0 * s;
                out[3] = s0 * c + c0 * s;
            }
        }
        self.normalize(out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `integrate` over a small step agrees with the embedding derivative `q_dot` (first order)
    /// and keeps the rotation unit; a full turn about z returns to the start.
    #[test]
    fn integrate_matches_q_dot_and_stays_unit() {
        for kind in [RootKind::FreeFlyer, RootKind::Planar] {
            let mut q = vec![0.0; kind.nq()];
            kind.neutral(&mut q);
            q[0] = 0.3;
            q[1] = -0.2;
            // a rotated start
            let v0: Vec<f64> = (0..kind.nv()).map(|i| 0.7 - 0.3 * i as f64).collect();
            let mut start = vec![0.0; kind.nq()];
            kind.integrate(&q, &v0, 1.0, &mut start);
            let v: Vec<f64> = (0..kind.nv()).map(|i| 0.2 + 0.1 * i as f64).collect();
            let h = 1e-6;
            let mut moved = vec![0.0; kind.nq()];
            kind.integrate(&start, &v, h, &mut moved);
            let mut dq = vec![0.0; kind.nq()];
            kind.q_dot(&start, &v, &mut dq);
            for i in 0..kind.nq() {
                let fd = (moved[i] - start[i]) / h;
                assert!(
                    (fd - dq[i]).abs() < 1e-5,
                    "{kind:?} q[{i}]: {fd} vs {}",
                    dq[i]
                );
            }
            assert!(kind.unit_error(&moved, 1e-14).is_none());
        }
        let kind = RootKind::Planar;
        let q = [0.0, 0.0, 1.0, 0.0];
        let mut out = [0.0; 4];
        kind.integrate(&q, &[1.0, 0.0, 2.0 * std::f64::consts::PI], 1.0, &mut out);
        // a full turn while moving at 1 m/s along the turning x axis: back at the start
        for (a, b) in out.iter().zip(&q) {
            assert!((a - b).abs() < 1e-12, "{out:?}");
        }
    }

    /// A floating robot's Jacobian (root columns first) is the derivative of its FK along
    /// `q ⊕ e_i h`, for the tool and for every link frame, free-flyer and planar, chain and tree
    /// (the root columns are what Pinocchio's LOCAL_WORLD_ALIGNED frame Jacobian holds).
    #[test]
    fn floating_jacobian_is_the_derivative_of_fk_on_the_manifold() {
        use crate::pose::{rotation, rotation_log, translation};
        use crate::{Joint, KinematicModel, Origin, Robot};
        let joint = |axis: Vector3<f64>, x: f64| Joint {
            origin: Some(Origin {
                placement: crate::pose::trans(x, 0.1, -0.2) * crate::pose::rot_x(0.3),
                axis,
            }),
            mass: 1.0,
            ..Joint::default()
        };
        for kind in [RootKind::FreeFlyer, RootKind::Planar] {
            for parents in [vec![], vec![0, 1, 0]] {
                let robot = Robot {
                    joints: vec![
                        joint(Vector3::z(), 0.2),
                        joint(Vector3::new(0.0, 0.6, 0.8), -0.1),
                        joint(Vector3::x(), 0.3),
                    ],
                    parents,
                    base: crate::pose::trans(0.1, 0.2, 0.3) * crate::pose::rot_z(0.4),
                    tool: crate::pose::trans(0.0, 0.0, 0.1),
                    root: Some(RootJoint::new(kind)),
                    ..Robot::default()
                };
                robot.validate().expect("valid");
                let mut q = robot.neutral_q();
                let v0: Vec<f64> = (0..robot.nv()).map(|i| 0.4 - 0.15 * i as f64).collect();
                let mut moved = q.clone();
                kind.integrate(q.as_slice(), &v0, 1.0, moved.as_mut_slice());
                for j in 0..robot.dof() {
                    moved[kind.nq() + j] = q[kind.nq() + j] + v0[kind.nv() + j];
                }
                q = moved;
                robot.check_q(q.as_slice()).expect("unit");
                let model = KinematicModel::new(&robot);
                let (tee, jac) = crate::jacobian::fk_and_jacobian(&robot, q.as_slice());
                let mut jm = crate::jacobian::Jacobian::zeros(robot.nv());
                assert_eq!(model.fk_and_jacobian_into(q.as_slice(), &mut jm), tee);
                assert_eq!(jm, jac);
                let h = 1e-7;
                let perturbed = |i: usize, sign: f64| {
                    let mut dv = vec![0.0; robot.nv()];
                    dv[i] = sign * h;
                    let mut out = q.clone();
                    kind.integrate(
                        q.as_slice(),
                        &dv[..kind.nv()],
                        1.0,
                        &mut out.as_mut_slice()[..kind.nq()],
                    );
                    for j in 0..robot.dof() {
                        out[kind.nq() + j] += dv[kind.nv() + j];
                    }
                    out
                };
                for link in 0..=robot.dof() {
                    let (pose, jl) = crate::jacobian::link_jacobian(
                        &robot,
                        q.as_slice(),
                        link,
                        crate::jacobian::Frame::Base,
                    );
                    assert_eq!(pose, crate::fk::link_pose(&robot, q.as_slice(), link));
                    for i in 0..robot.nv() {
                        let (qp, qm) = (perturbed(i, 1.0), perturbed(i, -1.0));
                        let (tp, tm) = (
                            crate::fk::link_pose(&robot, qp.as_slice(), link),
                            crate::fk::link_pose(&robot, qm.as_slice(), link),
                        );
                        let lin = (translation(&tp) - translation(&tm)) / (2.0 * h);
                        let ang =
                            rotation_log(&(rotation(&tp) * rotation(&tm).transpose())) / (2.0 * h);
                        let col = jl.column(i);
                        assert!(
                            (lin - col.fixed_rows::<3>(0)).norm() < 1e-6
                                && (ang - col.fixed_rows::<3>(3)).norm() < 1e-6,
                            "{kind:?} link {link} column {i}: {lin:?} {ang:?} vs {col:?}"
                        );
                    }
                }
                let frames = crate::fk::link_frames(&robot, q.as_slice());
                assert_eq!(frames[robot.dof() + 1], tee);
            }
        }
    }

    /// IK's chain from the base link (`Robot::chain_to`) of a floating robot: the root locked,
    /// the indices past the root's coordinates, and the chain's FK equal to the robot's link
    /// pose expressed in the base link's frame.
    #[test]
    fn a_floating_robots_chain_starts_at_the_base_link() {
        use crate::{Joint, Origin, Robot};
        let joint = |x: f64| Joint {
            origin: Some(Origin {
                placement: crate::pose::trans(x, 0.1, 0.0),
                axis: Vector3::y(),
            }),
            ..Joint::default()
        };
        let robot = Robot {
            joints: vec![joint(0.2), joint(0.3), joint(0.1)],
            parents: vec![0, 1, 0],
            root: Some(RootJoint::new(RootKind::FreeFlyer)),
            ..Robot::default()
        };
        let mut q = robot.neutral_q();
        let mut moved = q.clone();
        kind_integrate(&q, &mut moved);
        moved[7] = 0.4;
        moved[8] = -0.7;
        moved[9] = 0.2;
        q = moved;
        let (chain, idx) = robot.chain_to(2).expect("link 2");
        assert_eq!(idx, vec![7, 8]);
        assert!(chain.root.is_none());
        let qc: Vec<f64> = idx.iter().map(|&i| q[i]).collect();
        let base = crate::fk::link_pose(&robot, q.as_slice(), 0);
        let tip = crate::fk::link_pose(&robot, q.as_slice(), 2);
        let in_base = crate::pose::rigid_inverse(&base) * tip;
        assert!((crate::fk::forward(&chain, &qc) - in_base).abs().max() < 1e-14);
    }

    fn kind_integrate(q: &nalgebra::DVector<f64>, out: &mut nalgebra::DVector<f64>) {
        let v = [0.3, -0.1, 0.2, 0.5, 0.4, -0.6];
        RootKind::FreeFlyer.integrate(&q.as_slice()[..7], &v, 1.0, &mut out.as_mut_slice()[..7]);
    }
}
