//! Geometric Jacobians and distance to singularity. Depends only on q.
//!
//! Entry points: [`jacobian`] (world/base or tool frame), [`fk_and_jacobian`] (both at once, for
//! solvers), [`singularity`] (smallest singular value, manipulability, condition number).
//!
//! Rows are vx vy vz ωx ωy ωz: the linear velocity of the tool-frame origin and the angular
//! velocity of the tool (DESIGN.md), for every joint of the one joint model (revolute column
//! `[u × (p_e − o); u]` with `u` the world axis through the joint frame's origin `o`, prismatic
//! `[u; 0]`). "Base" means the world frame in which
//! `T_ee = base · A_1 ⋯ A_n · tool` is expressed (as Robotics Toolbox's `jacob0`); "tool"
//! re-expresses both velocities in the tool frame's axes (as `jacobe`).
//!
//! A floating robot ([`Robot::root`]) has `nv = root_nv + n` columns: first its root joint's
//! (its velocity is the base link's own, in the base link's axes, so a linear coordinate along
//! axis `e_i` of the base link is the column `[R₀ e_i; 0]` and a rotation about it
//! `[R₀ e_i × (p_e − p₀); R₀ e_i]`), then the joints'. These are Pinocchio's frame Jacobians in
//! `LOCAL_WORLD_ALIGNED`. A spherical joint has three columns, at [`Robot::v_index`]: the
//! child frame's axes as rotation axes through the joint's origin (see [`crate::spherical`]).

use crate::compiled::{OnTheFly, fk_and_jacobian_kernel, link_jacobian_kernel};
use crate::model::Robot;
use crate::pose::rotation;
use nalgebra::{DMatrix, Matrix4};

pub use crate::compiled::Jacobian;

/// The frame a Jacobian's rows are expressed in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Frame {
    /// The world frame (the frame `base` is given in).
    #[default]
    Base,
    /// The tool frame at `q`.
    Tool,
}

/// Tool pose and base-frame Jacobian in one pass over the chain (what an IK iteration needs).
/// `q` must have `robot.nq()` entries. Returns `(T_ee, J)` with `J` 6 × `robot.nv()`.
pub fn fk_and_jacobian(robot: &Robot, q: &[f64]) -> (Matrix4<f64>, Jacobian) {
    let mut jac = Jacobian::zeros(robot.nv());
    let tee = fk_and_jacobian_into(robot, q, &mut jac);
    (tee, jac)
}

/// [`fk_and_jacobian`] into a caller-owned 6 × n buffer (no allocation). Returns `T_ee`.
/// Compiles each joint as it goes; [`crate::KinematicModel::fk_and_jacobian_into`] gives the
/// same numbers from a model compiled once.
pub fn fk_and_jacobian_into(robot: &Robot, q: &[f64], jac: &mut Jacobian) -> Matrix4<f64> {
    if robot.has_spherical() {
        return crate::spherical::jacobian_into(robot, q, robot.dof(), Some(&robot.tool), jac);
    }
    fk_and_jacobian_kernel(OnTheFly(robot), q, jac)
}

/// The world pose of link frame `link` (0 = base, k = the end of joint k−1, see
/// [`Robot::parents`]) and the base-frame Jacobian of its origin into `jac` (6 × n): the
/// columns of the joints on its support path as in the module docs, every other column zero.
/// Works for chains and trees, in one pass along the support path (no allocation). Panics if
/// `link > robot.dof()`.
pub fn link_jacobian_into(
    robot: &Robot,
    q: &[f64],
    link: usize,
    jac: &mut Jacobian,
) -> Matrix4<f64> {
    if robot.has_spherical() {
        return crate::spherical::jacobian_into(robot, q, link, None, jac);
    }
    link_jacobian_kernel(&OnTheFly(robot), q, link, jac)
}

/// [`link_jacobian_into`] allocating, with the rows in `frame` ([`Frame::Tool`]: the link
/// frame's own axes). Returns the link pose and the 6 × n Jacobian.
pub fn link_jacobian(
    robot: &Robot,
    q: &[f64],
    link: usize,
    frame: Frame,
) -> (Matrix4<f64>, Jacobian) {
    let mut jac = Jacobian::zeros(robot.nv());
    let pose = link_jacobian_into(robot, q, link, &mut jac);
    if frame == Frame::Tool {
        to_tool_frame(&mut jac, &pose);
    }
    (pose, jac)
}

/// The geometric Jacobian at `q` in `frame` (see the module docs). `q` must have `robot.dof()`
/// entries (check with [`Robot::check_q`]).
pub fn jacobian(robot: &Robot, q: &[f64], frame: Frame) -> Jacobian {
    let (tee, mut jac) = fk_and_jacobian(robot, q);
    if frame == Frame::Tool {
        to_tool_frame(&mut jac, &tee);
    }
    jac
}

/// Re-expresses a base-frame Jacobian in the axes of the tool pose `tee` (in place).
pub fn to_tool_frame(jac: &mut Jacobian, tee: &Matrix4<f64>) {
    let rt = rotation(tee).transpose();
    for mut col in jac.column_iter_mut() {
        let v = rt * col.fixed_rows::<3>(0);
        let w = rt * col.fixed_rows::<3>(3);
        col.fixed_rows_mut::<3>(0).copy_from(&v);
        col.fixed_rows_mut::<3>(3).copy_from(&w);
    }
}

/// Distance to singularity of a Jacobian.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Singularity {
    /// Smallest of the min(6, n) singular values (0 at a singularity). Mixed units: the
    /// linear rows are m/rad, the angular rows dimensionless.
    pub sigma_min: f64,
    /// Largest singular value.
    pub sigma_max: f64,
    /// Yoshikawa's manipulability √det(J Jᵀ) (the product of the singular values; 0 for n < 6).
    pub manipulability: f64,
    /// σ_max / σ_min (∞ at a singularity).
    pub condition: f64,
}

/// Singular-value measures of `jac` (any 6 × n). Uses an SVD of `jac` scaled by its largest
/// entry (singular values scale with the matrix), so entries near `f64::MAX` (links of 1e308 m)
/// cannot overflow inside the decomposition; a measure whose value itself leaves f64's range
/// is `inf`. Never NaN or a panic for finite input; a non-finite entry gives NaN measures (the
/// caller checks the Jacobian first, as the query protocol does).
pub fn singularity(jac: &Jacobian) -> Singularity {
    let n = jac.ncols();
    if n == 0 {
        return Singularity {
            sigma_min: 0.0,
            sigma_max: 0.0,
            manipulability: 0.0,
            condition: f64::INFINITY,
        };
    }
    if jac.iter().any(|x| !x.is_finite()) {
        return Singularity {
            sigma_min: f64::NAN,
            sigma_max: f64::NAN,
            manipulability: f64::NAN,
            condition: f64::NAN,
        };
    }
    let scale = jac.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let scale = if scale > 0.0 { scale } else { 1.0 };
    let m: DMatrix<f64> = DMatrix::from_iterator(6, n, jac.iter().map(|x| x / scale));
    let sv = m.singular_values();
    let unit_min = sv.iter().copied().fold(f64::INFINITY, f64::min);
    let unit_max = sv.iter().copied().fold(0.0, f64::max);
    let (sigma_min, sigma_max) = (unit_min * scale, unit_max * scale);
    let manipulability = if n < 6 {
        0.0
    } else {
        sv.iter().map(|s| s * scale).product()
    };
    // the ratio of the scaled values: the scale cancels and cannot overflow here
    let condition = if unit_min > 0.0 {
        unit_max / unit_min
    } else {
        f64::INFINITY
    };
    Singularity {
        sigma_min,
        sigma_max,
        manipulability,
        condition,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::builtin::builtin_robot;

    #[test]
    fn tool_frame_jacobian_is_the_rotated_base_one() {
        let robot = builtin_robot("panda").expect("builtin");
        let q = [0.1, -0.4, 0.3, -1.8, 0.2, 1.2, -0.5];
        let jb = jacobian(&robot, &q, Frame::Base);
        let jt = jacobian(&robot, &q, Frame::Tool);
        let r = rotation(&crate::fk::forward(&robot, &q));
        for c in 0..7 {
            let v = r * jt.fixed_view::<3, 1>(0, c);
            let w = r * jt.fixed_view::<3, 1>(3, c);
            assert!((v - jb.fixed_view::<3, 1>(0, c)).norm() < 1e-14);
            assert!((w - jb.fixed_view::<3, 1>(3, c)).norm() < 1e-14);
        }
    }

    #[test]
    fn singularity_measure_vanishes_at_the_puma_wrist_singularity() {
        let robot = builtin_robot("puma560").expect("builtin");
        let s = singularity(&jacobian(
            &robot,
            &[0.0, 0.5, -1.0, 0.3, 0.0, 0.1],
            Frame::Base,
        ));
        assert!(s.sigma_min < 1e-12 && s.manipulability < 1e-12);
        let s = singularity(&jacobian(
            &robot,
            &[0.0, 0.5, -1.0, 0.3, 0.8, 0.1],
            Frame::Base,
        ));
        assert!(s.sigma_min > 1e-3 && s.condition.is_finite() && s.manipulability > 0.0);
    }
}
