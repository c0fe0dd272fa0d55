//! Standard DH parameters recovered from a general model (joint placements and axes, as a URDF
//! gives them), so that [`super::family::recognise`] finds the closed-form families in robots
//! that were not typed in as DH rows.
//!
//! Any serial chain of revolute and prismatic joints has an equivalent standard-DH chain with
//! the same joint values: FK is the product of the joints' screws at q = 0 times the pose at
//! q = 0 (product of exponentials), and a DH chain whose frame j−1 has its z along joint j's
//! axis line, in the same direction, has the same screws. [`equivalent_dh`] builds those frames
//! at q = 0 — z_{j−1} on axis j, x_j along the common normal of axes j and j+1 (from axis j to
//! axis j+1, so a_j ≥ 0; for parallel axes the normal through the previous origin, d_j = 0; for
//! intersecting axes x_j = z_{j−1} × z_j) — and reads a, α, d and θ (the offset at q = 0) off
//! them; the last frame is the previous one (a_n = d_n = α_n = 0) and the rest goes to the
//! tool. Axes count as parallel when |z_{j−1} × z_j| ≤ [`PARALLEL`].

use crate::model::{Convention, Joint, JointType, Robot};
use crate::pose::rigid_inverse;
use nalgebra::{Matrix4, Vector3};

/// |z_{j−1} × z_j| (the sine of the angle between two unit axes) at or below which they are
/// treated as parallel.
pub const PARALLEL: f64 = 1e-9;

/// The tolerance of family recognition on a recovered chain: angles within this many rad of
/// 0 or ±π/2, lengths within this fraction of the arm's size of 0. URDFs write π/2 as
/// 1.57079632679 (off by 4.9e-12), so the 1e-12 used for DH rows would miss them; the closed
/// forms' answers are then polished by Newton steps on the true model
/// ([`super::analytic::Analytic`]).
pub const RECOVERED_TOLERANCE: f64 = 1e-9;

fn frame(o: &Vector3<f64>, x: &Vector3<f64>, z: &Vector3<f64>) -> Matrix4<f64> {
    let y = z.cross(x);
    Matrix4::new(
        x.x, y.x, z.x, o.x, //
        x.y, y.y, z.y, o.y, //
        x.z, y.z, z.z, o.z, //
        0.0, 0.0, 0.0, 1.0,
    )
}

/// The equivalent standard-DH robot (same joint values, same FK up to rounding, base = frame 0
/// on joint 1's axis, tool adjusted), or `None` for a robot without joints or with non-finite
/// geometry. Limits are copied; inertial data are not (the result is for kinematics).
pub fn equivalent_dh(robot: &Robot) -> Option<Robot> {
    let n = robot.joints.len();
    // a tree has no one chain of axes to read DH rows from
    if n == 0 || !robot.is_chain() {
        return None;
    }
    let scale = robot
        .joints
        .iter()
        .map(Joint::length)
        .sum::<f64>()
        .max(f64::MIN_POSITIVE);
    // Axis lines at q = 0 in the base frame: (a point, the unit direction).
    let mut f = robot.base;
    let mut lines = Vec::with_capacity(n);
    for j in &robot.joints {
        let g = j.geometry(robot.convention);
        let jf = g.placement.map_or(f, |p| f * p);
        let u = jf.fixed_view::<3, 3>(0, 0) * g.axis;
        let norm = u.norm();
        if !(norm > 0.0 && norm.is_finite()) {
            return None;
        }
        lines.push((jf.fixed_view::<3, 1>(0, 3).into_owned(), u / norm));
        f *= g.transform(0.0);
    }
    let t0 = f * robot.tool;
    // Frame 0: on axis 1, at the foot of the base origin, x from the base's x (or y).
    let b = robot.base.fixed_view::<3, 1>(0, 3).into_owned();
    let (p1, z0) = lines[0];
    let o0 = p1 + z0 * (b - p1).dot(&z0);
    let bx = robot.base.fixed_view::<3, 1>(0, 0).into_owned();
    let by = robot.base.fixed_view::<3, 1>(0, 1).into_owned();
    let mut x0 = bx - z0 * bx.dot(&z0);
    if x0.norm() < 1e-6 {
        x0 = by - z0 * by.dot(&z0);
    }
    let x0 = x0.normalize();
    let mut frames = vec![(o0, x0, z0)];
    // Per joint: (θ at q = 0, d at q = 0, a, α).
    let mut rows = Vec::with_capacity(n);
    for (pj, uj) in lines.iter().skip(1) {
        let (op, xp, zp) = frames[frames.len() - 1];
        let r = pj - op;
        let w = zp.cross(uj);
        let (o, x, a, d) = if w.norm() > PARALLEL {
            let c = zp.dot(uj);
            let denom = 1.0 - c * c;
            let s = (r.dot(&zp) - c * r.dot(uj)) / denom;
            let t = (c * r.dot(&zp) - r.dot(uj)) / denom;
            let (foot_prev, foot) = (op + zp * s, pj + uj * t);
            let mut x = w.normalize();
            let mut a = (foot - foot_prev).dot(&x);
            if a < 0.0 {
                x = -x;
                a = -a;
            }
            (foot, x, a, s)
        } else {
            let v = r - uj * r.dot(uj);
            if v.norm() > 1e-12 * scale {
                (op + v, v.normalize(), v.norm(), 0.0)
            } else {
                (op, xp, 0.0, 0.0)
            }
        };
        let alpha = zp.cross(uj).dot(&x).atan2(zp.dot(uj));
        let theta = xp.cross(&x).dot(&zp).atan2(xp.dot(&x));
        rows.push((theta, d, a, alpha));
        frames.push((o, x, *uj));
    }
    rows.push((0.0, 0.0, 0.0, 0.0));
    let (ol, xl, zl) = frames[n - 1];
    let base = frame(&o0, &x0, &z0);
    let tool = rigid_inverse(&frame(&ol, &xl, &zl)) * t0;
    let joints = robot
        .joints
        .iter()
        .zip(rows)
        .map(|(j, (theta, d, a, alpha))| match j.joint_type {
            JointType::Revolute => Joint {
                joint_type: JointType::Revolute,
                a,
                d,
                alpha,
                offset: theta,
                qlim: j.qlim,
                ..Joint::default()
            },
            JointType::Prismatic => Joint {
                joint_type: JointType::Prismatic,
                a,
                alpha,
                theta,
                offset: d,
                qlim: j.qlim,
                ..Joint::default()
            },
        })
        .collect();
    let all_finite = base.iter().chain(tool.iter()).all(|x| x.is_finite());
    all_finite.then(|| Robot {
        name: robot.name.clone(),
        convention: Convention::Standard,
        joints,
        gravity: robot.gravity,
        base,
        tool,
        parents: Vec::new(),
        root: None,
    })
}
