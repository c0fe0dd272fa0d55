//! Spherical (ball) joints: FK and frame Jacobians of a tree robot with joints of more than one
//! coordinate ([`crate::Joint::spherical`]), and the quaternion arithmetic of their q.
//!
//! # Layout
//!
//! A spherical joint is Pinocchio's `JointModelSpherical`: **q = a unit quaternion `qx qy qz
//! qw`** (4 entries, the rotation of the child frame in the joint frame), **v = the angular
//! velocity `ωx ωy ωz` in the child frame** (3 entries). MuJoCo's `ball` joint stores the same
//! rotation as `w x y z` in `qpos` and the same child-frame angular velocity in `qvel`: robosim's
//! q segment is MuJoCo's `(qpos[1], qpos[2], qpos[3], qpos[0])`; v is MuJoCo's `qvel` unchanged.
//! Joint j's q starts at [`crate::Robot::q_index`], its v (and its Jacobian columns, its τ and
//! q̈ entries) at [`crate::Robot::v_index`].
//!
//! # Which algorithms take a spherical joint
//!
//! The general (tree, URDF/MJCF-style) algorithms: [`crate::fk`] (`link_frames`, `forward`,
//! `link_pose`), [`crate::jacobian`] (`fk_and_jacobian`, `link_jacobian`, `jacobian`), and the
//! dynamics crate's RNEA, CRBA, ABA, gravity, energy and explicit integrators. The compiled
//! [`crate::KinematicModel`] keeps such a robot uncompiled and runs these functions (same
//! numbers). A robot without spherical joints never reaches this module (one scan of the
//! joints' flags decides, one `Option` test in the compiled model), so its numbers are bit for
//! bit what they were. **Refused** with [`crate::ModelError::SphericalUnsupported`] naming the
//! joint: IK ([`crate::ik::solve`]), the mimic coupling ([`crate::mimic`]), the encoder bounds
//! and MOVEJ; DH rows cannot be spherical ([`crate::ModelError::SphericalNotGeneral`]).
//!
//! # Jacobian columns
//!
//! The columns of a spherical joint are `[ω_i × (p_e − o); ω_i]` with `ω_i = R_child e_i` the
//! child frame's i-th axis in the world and `o` the joint's origin: the columns of Pinocchio's
//! `LOCAL_WORLD_ALIGNED` frame Jacobian.

use crate::compiled::{Jacobian, link_transform, root_columns};
use crate::model::Robot;
use nalgebra::{Matrix3, Matrix4, Quaternion, UnitQuaternion, Vector3};

/// The rotation of a quaternion `q = [qx, qy, qz, qw]` (normalised where it is read; a zero
/// quaternion gives the identity).
pub fn quat_rotation(q: &[f64]) -> Matrix3<f64> {
    UnitQuaternion::try_new(Quaternion::new(q[3], q[0], q[1], q[2]), 0.0)
        .map_or_else(Matrix3::identity, |u| *u.to_rotation_matrix().matrix())
}

/// `dq/dt = ½ q ⊗ (ω, 0)` for a quaternion `q` (x y z w) turning at `w`, an angular velocity in
/// the rotated (child) frame: the derivative in the embedding ℝ⁴, for Runge–Kutta stages.
pub fn quat_dot(q: &[f64], w: &[f64], dq: &mut [f64]) {
    let (x, y, z, qw) = (q[0], q[1], q[2], q[3]);
    let (wx, wy, wz) = (w[0], w[1], w[2]);
    dq[0] = 0.5 * (qw * wx + y * wz - z * wy);
    dq[1] = 0.5 * (qw * wy + z * wx - x * wz);
    dq[2] = 0.5 * (qw * wz + x * wy - y * wx);
    dq[3] = -0.5 * (x * wx + y * wy + z * wz);
}

/// `out = q ⊗ exp(ω h)`: the quaternion moved by the constant child-frame angular velocity `w`
/// for `h` seconds (Pinocchio's `integrate` of a spherical joint), renormalised.
pub fn quat_integrate(q: &[f64], w: &[f64], h: f64, out: &mut [f64]) {
    let step = UnitQuaternion::from_scaled_axis(Vector3::new(w[0], w[1], w[2]) * h);
    let r = Quaternion::new(q[3], q[0], q[1], q[2]) * *step.quaternion();
    out[0] = r.i;
    out[1] = r.j;
    out[2] = r.k;
    out[3] = r.w;
    quat_normalize(out);
}

/// Divides a quaternion by its norm (a zero or non-finite norm leaves it as it is).
pub fn quat_normalize(q: &mut [f64]) {
    let n = q[..4].iter().map(|x| x * x).sum::<f64>().sqrt();
    if n > 0.0 && n.is_finite() {
        q[..4].iter_mut().for_each(|x| *x /= n);
    }
}

/// Joint `j`'s link transform at its q segment `qj` (1 entry, or 4 for a spherical joint):
/// `P_j · R(quat)` for a spherical joint, [`crate::fk::link_transform`] otherwise.
fn joint_transform(robot: &Robot, j: usize, qj: &[f64]) -> Matrix4<f64> {
    let joint = &robot.joints[j];
    if joint.spherical {
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&quat_rotation(qj));
        match &joint.origin {
            Some(o) => o.placement * m,
            None => m,
        }
    } else {
        link_transform(robot.convention, joint, qj[0])
    }
}

/// Link frame 0 in the world: `base`, times the root's motion for a floating robot.
fn frame0(robot: &Robot, q: &[f64]) -> Matrix4<f64> {
    match &robot.root {
        Some(r) => robot.base * r.kind.transform(&q[..r.kind.nq()]),
        None => robot.base,
    }
}

/// Per joint, where its q and v start (see [`Robot::q_v_index`]), in one pass.
fn offsets(robot: &Robot) -> impl Iterator<Item = (usize, usize)> + '_ {
    let (mut iq, mut iv) = (robot.root_nq(), robot.root_nv());
    robot.joints.iter().map(move |j| {
        let at = (iq, iv);
        let (nq, nv) = if j.spherical { (4, 3) } else { (1, 1) };
        iq += nq;
        iv += nv;
        at
    })
}

/// [`crate::fk::link_frames_into`] for a robot with spherical joints.
pub(crate) fn link_frames_into(robot: &Robot, q: &[f64], frames: &mut [Matrix4<f64>]) {
    let n = robot.dof();
    assert!(
        frames.len() >= n + 2,
        "link_frames_into: {} frames for {n} joints (needs n + 2)",
        frames.len()
    );
    frames[0] = frame0(robot, q);
    for (j, (iq, _)) in offsets(robot).enumerate() {
        frames[j + 1] = frames[robot.parent(j)] * joint_transform(robot, j, &q[iq..]);
    }
    frames[n + 1] = frames[n] * robot.tool;
}

/// [`crate::fk::link_pose`] for a robot with spherical joints.
pub(crate) fn link_pose(robot: &Robot, q: &[f64], link: usize) -> Matrix4<f64> {
    let mut t = frame0(robot, q);
    for j in robot.support(link) {
        t *= joint_transform(robot, j, &q[robot.q_index(j)..]);
    }
    t
}

/// [`crate::fk::forward`] for a robot with spherical joints.
pub(crate) fn forward(robot: &Robot, q: &[f64]) -> Matrix4<f64> {
    link_pose(robot, q, robot.dof()) * robot.tool
}

/// The pose and base-frame Jacobian of link frame `link` (with `tool`, of the tool frame hung
/// from it) for a robot with spherical joints; columns off the support path are zero.
pub(crate) fn jacobian_into(
    robot: &Robot,
    q: &[f64],
    link: usize,
    tool: Option<&Matrix4<f64>>,
    jac: &mut Jacobian,
) -> Matrix4<f64> {
    assert!(
        link <= robot.dof(),
        "link_jacobian: link frame {link} of {}",
        robot.dof()
    );
    jac.fill(0.0);
    let f0 = frame0(robot, q);
    let path = robot.support(link);
    // the frame each joint on the path hangs from, then the link's
    let mut hung = Vec::with_capacity(path.len());
    let mut t = f0;
    for &j in &path {
        hung.push(t);
        t *= joint_transform(robot, j, &q[robot.q_index(j)..]);
    }
    let moved = t;
    if let Some(tool) = tool {
        t *= tool;
    }
    let pe: Vector3<f64> = t.fixed_view::<3, 1>(0, 3).into_owned();
    if let Some(r) = &robot.root {
        root_columns(r.kind, &f0, &pe, jac);
    }
    for (k, &j) in path.iter().enumerate() {
        let joint = &robot.joints[j];
        let iv = robot.v_index(j);
        let parent = &hung[k];
        // the joint frame before its motion: parent · P_j (a DH row: its own placement)
        let g = joint.geometry(robot.convention);
        let jf = match &g.placement {
            Some(p) => parent * p,
            None => *parent,
        };
        let o: Vector3<f64> = jf.fixed_view::<3, 1>(0, 3).into_owned();
        if joint.spherical {
            // the child frame's axes: the joint frame after its rotation
            let child = match path.get(k + 1) {
                Some(_) => hung[k + 1],
                None => moved,
            };
            for i in 0..3 {
                let w: Vector3<f64> = child.fixed_view::<3, 1>(0, i).into_owned();
                let mut col = jac.column_mut(iv + i);
                col.fixed_rows_mut::<3>(0).copy_from(&w.cross(&(pe - o)));
                col.fixed_rows_mut::<3>(3).copy_from(&w);
            }
        } else {
            let u = jf.fixed_view::<3, 3>(0, 0) * g.axis;
            let mut col = jac.column_mut(iv);
            match g.joint_type {
                crate::JointType::Revolute => {
                    col.fixed_rows_mut::<3>(0).copy_from(&u.cross(&(pe - o)));
                    col.fixed_rows_mut::<3>(3).copy_from(&u);
                }
                crate::JointType::Prismatic => {
                    col.fixed_rows_mut::<3>(0).copy_from(&u);
                }
            }
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::{rot_x, rotation, rotation_log, trans, translation};
    use crate::{Joint, JointType, Origin, RootJoint, RootKind};

    fn ball_robot(root: Option<RootKind>) -> Robot {
        let joint = |spherical: bool, jt: JointType, axis: Vector3<f64>, x: f64| Joint {
            joint_type: jt,
            spherical,
            origin: Some(Origin {
                placement: trans(x, 0.1, -0.2) * rot_x(0.3),
                axis,
            }),
            mass: 1.0,
            ..Joint::default()
        };
        Robot {
            joints: vec![
                joint(true, JointType::Revolute, Vector3::z(), 0.2),
                joint(
                    false,
                    JointType::Revolute,
                    Vector3::new(0.0, 0.6, 0.8),
                    -0.1,
                ),
                joint(true, JointType::Revolute, Vector3::z(), 0.3),
                joint(false, JointType::Prismatic, Vector3::x(), 0.1),
            ],
            parents: vec![0, 1, 0, 3],
            base: trans(0.1, 0.2, 0.3) * crate::pose::rot_z(0.4),
            tool: trans(0.0, 0.0, 0.1),
            root: root.map(RootJoint::new),
            ..Robot::default()
        }
    }

    /// `q ⊕ v`: the root and the spherical joints on their manifolds, the rest added.
    fn integrate(robot: &Robot, q: &[f64], v: &[f64]) -> Vec<f64> {
        let mut out = q.to_vec();
        if let Some(r) = &robot.root {
            let (nq, nv) = (r.kind.nq(), r.kind.nv());
            r.kind.integrate(&q[..nq], &v[..nv], 1.0, &mut out[..nq]);
        }
        for (j, joint) in robot.joints.iter().enumerate() {
            let (iq, iv) = robot.q_v_index(j);
            if joint.spherical {
                quat_integrate(&q[iq..iq + 4], &v[iv..iv + 3], 1.0, &mut out[iq..iq + 4]);
            } else {
                out[iq] = q[iq] + v[iv];
            }
        }
        out
    }

    /// The layout: nq, nv and the offsets; the neutral q has identity quaternions.
    #[test]
    fn layout_counts_four_q_and_three_v_per_ball() {
        let robot = ball_robot(Some(RootKind::FreeFlyer));
        robot.validate().expect("valid");
        assert_eq!(
            (robot.nq(), robot.nv()),
            (7 + 4 + 1 + 4 + 1, 6 + 3 + 1 + 3 + 1)
        );
        assert_eq!(robot.q_v_index(2), (12, 10));
        assert_eq!(robot.q_v_index(3), (16, 13));
        let q = robot.neutral_q();
        assert_eq!((q[10], q[15]), (1.0, 1.0));
        robot.check_q(q.as_slice()).expect("unit");
        let mut bad = q.clone();
        bad[15] = 0.5;
        assert!(matches!(
            robot.check_q(bad.as_slice()),
            Err(crate::ModelError::NonUnitSpherical {
                joint: 2,
                start: 12,
                end: 16,
                ..
            })
        ));
        let mut dh = robot.clone();
        dh.joints[1].origin = None;
        dh.joints[1].spherical = true;
        assert_eq!(
            dh.validate(),
            Err(crate::ModelError::SphericalNotGeneral { joint: 1 })
        );
    }

    /// Every link's Jacobian (tool's too) is the derivative of FK along `q ⊕ e_i h`, for fixed,
    /// free-flyer and planar roots: the spherical columns are the child-frame angular velocity's.
    #[test]
    fn jacobian_is_the_derivative_of_fk_on_the_manifold() {
        for root in [None, Some(RootKind::FreeFlyer), Some(RootKind::Planar)] {
            let robot = ball_robot(root);
            let v0: Vec<f64> = (0..robot.nv()).map(|i| 0.4 - 0.15 * i as f64).collect();
            let q = integrate(&robot, robot.neutral_q().as_slice(), &v0);
            robot.check_q(&q).expect("unit");
            let frames = crate::fk::link_frames(&robot, &q);
            let (tee, jt) = crate::jacobian::fk_and_jacobian(&robot, &q);
            assert_eq!(frames[robot.dof() + 1], tee);
            assert_eq!(crate::fk::forward(&robot, &q), tee);
            let h = 1e-7;
            for link in 0..=robot.dof() + 1 {
                let pose_at = |qq: &[f64]| {
                    if link > robot.dof() {
                        crate::fk::forward(&robot, qq)
                    } else {
                        crate::fk::link_pose(&robot, qq, link)
                    }
                };
                let jl = if link > robot.dof() {
                    jt.clone()
                } else {
                    let (pose, jl) = crate::jacobian::link_jacobian(
                        &robot,
                        &q,
                        link,
                        crate::jacobian::Frame::Base,
                    );
                    assert_eq!(pose, frames[link]);
                    jl
                };
                for i in 0..robot.nv() {
                    let mut dv = vec![0.0; robot.nv()];
                    dv[i] = h;
                    let tp = pose_at(&integrate(&robot, &q, &dv));
                    dv[i] = -h;
                    let tm = pose_at(&integrate(&robot, &q, &dv));
                    let lin = (translation(&tp) - translation(&tm)) / (2.0 * h);
                    let ang =
                        rotation_log(&(rotation(&tp) * rotation(&tm).transpose())) / (2.0 * h);
                    let col = jl.column(i);
                    assert!(
                        (lin - col.fixed_rows::<3>(0)).norm() < 1e-6
                            && (ang - col.fixed_rows::<3>(3)).norm() < 1e-6,
                        "{root:?} link {link} column {i}: {lin:?} {ang:?} vs {col:?}"
                    );
                }
            }
        }
    }

    /// The compiled model gives the `&Robot` functions' numbers; IK, the chain and the mimic
    /// coupling refuse a spherical robot by name.
    #[test]
    fn one_coordinate_algorithms_refuse_a_ball_joint() {
        let robot = ball_robot(Some(RootKind::FreeFlyer));
        let model = crate::KinematicModel::new(&robot);
        assert_eq!((model.nq(), model.nv()), (robot.nq(), robot.nv()));
        let v0: Vec<f64> = (0..robot.nv()).map(|i| 0.3 - 0.1 * i as f64).collect();
        let q = integrate(&robot, robot.neutral_q().as_slice(), &v0);
        let mut frames = vec![Matrix4::identity(); robot.dof() + 2];
        model.link_frames_into(&q, &mut frames);
        assert_eq!(frames, crate::fk::link_frames(&robot, &q));
        assert_eq!(model.forward(&q), crate::fk::forward(&robot, &q));
        let mut jm = Jacobian::zeros(robot.nv());
        let tee = model.fk_and_jacobian_into(&q, &mut jm);
        assert_eq!((tee, jm), crate::jacobian::fk_and_jacobian(&robot, &q));
        let mut jl = Jacobian::zeros(robot.nv());
        let pose = model.link_jacobian_into(&q, 3, &mut jl);
        let (p, j) = crate::jacobian::link_jacobian(&robot, &q, 3, crate::jacobian::Frame::Base);
        assert_eq!((pose, jl), (p, j));
        let robot = ball_robot(None);
        assert!(robot.chain_to(2).is_none());
        // the ball on the other branch only shifts the chain's indices
        let mut other = robot.clone();
        other.joints[0].spherical = false;
        other.joints[1].spherical = true;
        other.joints[2].spherical = false;
        assert!(other.chain_to(2).is_none());
        let (chain, idx) = other.chain_to(4).expect("no ball on the path to link 4");
        assert_eq!(idx, vec![5, 6]);
        assert!(!chain.has_spherical());
        let err = crate::ik::solve(
            &robot,
            &Matrix4::identity(),
            crate::ik::Method::Dls,
            &crate::ik::IkOptions::default(),
        )
        .err()
        .expect("refused");
        assert!(err.to_string().contains("joint 0 is spherical"), "{err}");
    }

    /// The inline JSON form carries the flag (written only when set) and reads it back.
    #[test]
    fn json_round_trips_a_ball_joint() {
        let robot = ball_robot(Some(RootKind::FreeFlyer));
        let v = crate::json::robot_to_json(&robot);
        assert_eq!(v["joints"][0]["spherical"], serde_json::Value::Bool(true));
        assert!(v["joints"][1].get("spherical").is_none());
        assert_eq!(crate::json::robot_from_json(&v).expect("reads back"), robot);
    }

    /// The quaternion step agrees with its derivative and a quarter turn about x is exact.
    #[test]
    fn quaternion_integration_matches_its_derivative() {
        let q0 = [0.1, -0.2, 0.3, 0.9];
        let mut q = [0.0; 4];
        q.copy_from_slice(&q0);
        quat_normalize(&mut q);
        let w = [0.7, -0.4, 0.2];
        let h = 1e-6;
        let mut moved = [0.0; 4];
        quat_integrate(&q, &w, h, &mut moved);
        let mut dq = [0.0; 4];
        quat_dot(&q, &w, &mut dq);
        for i in 0..4 {
            assert!(((moved[i] - q[i]) / h - dq[i]).abs() < 1e-5);
        }
        let mut out = [0.0; 4];
        quat_integrate(
            &[0.0, 0.0, 0.0, 1.0],
            &[std::f64::consts::FRAC_PI_2, 0.0, 0.0],
            1.0,
            &mut out,
        );
        let r = quat_rotation(&out);
        assert!(
            (r - Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0))
                .abs()
                .max()
                < 1e-15
        );
    }
}
