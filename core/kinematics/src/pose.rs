//! Pose arithmetic shared by the Jacobian and the IK solvers: rigid inverses, the rotation
//! logarithm, and the 6-vector pose error (rows x y z, then rotation vector), all in SI units.

use nalgebra::{Matrix3, Matrix4, Rotation3, UnitQuaternion, Vector3, Vector6};

/// Inverse of a rigid transform `[R p; 0 1]`: `[Rᵀ −Rᵀp; 0 1]` (no general matrix inversion, so
/// no loss of orthonormality).
pub fn rigid_inverse(m: &Matrix4<f64>) -> Matrix4<f64> {
    let r = m.fixed_view::<3, 3>(0, 0).transpose();
    let p = -(r * m.fixed_view::<3, 1>(0, 3));
    let mut out = Matrix4::identity();
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    out.fixed_view_mut::<3, 1>(0, 3).copy_from(&p);
    out
}

/// Rotation part of a homogeneous transform.
pub fn rotation(m: &Matrix4<f64>) -> Matrix3<f64> {
    m.fixed_view::<3, 3>(0, 0).into_owned()
}

/// Translation part of a homogeneous transform.
pub fn translation(m: &Matrix4<f64>) -> Vector3<f64> {
    m.fixed_view::<3, 1>(0, 3).into_owned()
}

/// The rotation vector (axis · angle, angle in [0, π]) of a rotation matrix. Goes through a unit
/// quaternion (Shepperd's method in nalgebra) and `2·atan2(|v|, w)`, which stays accurate near
/// 0 and near π where `acos((tr − 1)/2)` loses digits.
pub fn rotation_log(r: &Matrix3<f64>) -> Vector3<f64> {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*r));
    let (w, v) = if q.w < 0.0 {
        (-q.w, -q.imag())
    } else {
        (q.w, q.imag())
    };
    let s = v.norm();
    if s < 1e-300 {
        return Vector3::zeros();
    }
    let angle = 2.0 * s.atan2(w);
    v * (angle / s)
}

/// Pose error of `current` against `target`, both in the world frame: rows 0..3 the position
/// difference `p_target − p_current` (m), rows 3..6 the rotation vector of `R_target · R_currentᵀ`
/// (rad), both in world axes. Zero exactly when the poses agree.
pub fn pose_error(current: &Matrix4<f64>, target: &Matrix4<f64>) -> Vector6<f64> {
    let dp = translation(target) - translation(current);
    let w = rotation_log(&(rotation(target) * rotation(current).transpose()));
    Vector6::new(dp.x, dp.y, dp.z, w.x, w.y, w.z)
}

/// How far a pose is from its target: position distance (m) and rotation angle (rad).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Residual {
    /// ‖p_target − p‖, m.
    pub position: f64,
    /// Angle of `R_target · Rᵀ`, rad, in [0, π].
    pub orientation: f64,
}

impl Residual {
    pub fn between(current: &Matrix4<f64>, target: &Matrix4<f64>) -> Residual {
        let e = pose_error(current, target);
        Residual {
            position: e.fixed_rows::<3>(0).norm(),
            orientation: e.fixed_rows::<3>(3).norm(),
        }
    }
}

/// Per-axis tolerances on the pose error, in the **target** frame's axes (as TRAC-IK's bounds):
/// `position` in m for x, y, z; `orientation` in rad for rotations about x, y, z. An infinite
/// entry frees that axis (e.g. `orientation[2] = ∞` for a tool symmetric about its z axis).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerances {
    pub position: [f64; 3],
    pub orientation: [f64; 3],
}

impl Default for Tolerances {
    /// 1e-9 m and 1e-9 rad on every axis.
    fn default() -> Self {
        Tolerances::uniform(1e-9, 1e-9)
    }
}

impl Tolerances {
    pub fn uniform(position: f64, orientation: f64) -> Self {
        Tolerances {
            position: [position; 3],
            orientation: [orientation; 3],
        }
    }

    /// The six tolerances in error-row order (x y z rx ry rz).
    pub fn as_array(&self) -> [f64; 6] {
        let (p, o) = (self.position, self.orientation);
        [p[0], p[1], p[2], o[0], o[1], o[2]]
    }

    /// Whether every component of the target-frame error `e_target` is within tolerance.
    pub fn accept(&self, e_target: &Vector6<f64>) -> bool {
        self.as_array()
            .iter()
            .zip(e_target.iter())
            .all(|(t, e)| e.abs() <= *t)
    }

    /// Whether a whole pose is within tolerance of the target.
    pub fn accept_pose(&self, current: &Matrix4<f64>, target: &Matrix4<f64>) -> bool {
        self.accept(&to_target_frame(&pose_error(current, target), target))
    }
}

/// Re-expresses a world-frame pose error in the target frame's axes.
pub fn to_target_frame(e_world: &Vector6<f64>, target: &Matrix4<f64>) -> Vector6<f64> {
    let rt = rotation(target).transpose();
    let p = rt * e_world.fixed_rows::<3>(0);
    let w = rt * e_world.fixed_rows::<3>(3);
    Vector6::new(p.x, p.y, p.z, w.x, w.y, w.z)
}

/// Checks a target pose from outside: finite, orthonormal rotation (to 1e-9), last row 0 0 0 1.
pub fn is_rigid(m: &Matrix4<f64>) -> bool {
    if !m.iter().all(|v| v.is_finite()) {
        return false;
    }
    let r = rotation(m);
    let err = (r.transpose() * r - Matrix3::identity()).abs().max();
    err < 1e-9
        && (r.determinant() - 1.0).abs() < 1e-9
        && m[(3, 0)] == 0.0
        && m[(3, 1)] == 0.0
        && m[(3, 2)] == 0.0
        && m[(3, 3)] == 1.0
}

/// Elementary transforms used to build chains by hand.
pub fn rot_x(angle: f64) -> Matrix4<f64> {
    let (s, c) = angle.sin_cos();
    Matrix4::new(
        1.0, 0.0, 0.0, 0.0, 0.0, c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}

pub fn rot_z(angle: f64) -> Matrix4<f64> {
    let (s, c) = angle.sin_cos();
    Matrix4::new(
        c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}

pub fn trans(x: f64, y: f64, z: f64) -> Matrix4<f64> {
    Matrix4::new(
        1.0, 0.0, 0.0, x, 0.0, 1.0, 0.0, y, 0.0, 0.0, 1.0, z, 0.0, 0.0, 0.0, 1.0,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_log_is_accurate_near_pi_and_zero() {
        for angle in [
            0.0,
            1e-12,
            0.3,
            std::f64::consts::PI - 1e-9,
            std::f64::consts::PI,
        ] {
            let axis = Vector3::new(0.3, -0.5, 0.8).normalize();
            let r = Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
            let w = rotation_log(r.matrix());
            assert!(
                (w.norm() - angle).abs() < 1e-14,
                "angle {angle}: got {}",
                w.norm()
            );
            if angle > 1e-6 {
                assert!(
                    (w.normalize() - axis).norm() < 1e-8 || (w.normalize() + axis).norm() < 1e-8
                );
            }
        }
    }

    #[test]
    fn rigid_inverse_inverts() {
        let m = trans(0.1, -2.0, 3.0) * rot_z(0.7) * rot_x(-1.2);
        assert!((rigid_inverse(&m) * m - Matrix4::identity()).abs().max() < 1e-15);
    }
}
