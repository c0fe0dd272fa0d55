//! The one conversion between the Instance Space's poses (3×4 row-major `[R | t]`, the last
//! row 0 0 0 1 implied, acting on column vectors) and nalgebra's types.

use nalgebra::{Isometry3, Matrix4};
use robosim_instance_space::Pose;

/// The pose as a 4×4 homogeneous matrix.
pub fn to_matrix(p: &Pose) -> Matrix4<f64> {
    Matrix4::new(
        p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11], 0.0, 0.0, 0.0,
        1.0,
    )
}

/// The pose as an isometry (the collision core's conversion: the rotation block is taken as
/// a rotation, its quaternion extracted).
pub fn to_isometry(p: &Pose) -> Isometry3<f64> {
    robosim_collision::robot::isometry_from_matrix(&to_matrix(p))
}

/// The top 3×4 of a rigid 4×4 as an Instance Space pose.
pub fn from_matrix(m: &Matrix4<f64>) -> Pose {
    let mut p = [0.0; 12];
    for r in 0..3 {
        for c in 0..4 {
            p[r * 4 + c] = m[(r, c)];
        }
    }
    p
}

/// An isometry as an Instance Space pose.
pub fn from_isometry(i: &Isometry3<f64>) -> Pose {
    from_matrix(&i.to_homogeneous())
}

/// The pose as the protocol's nested rows (4×4, row-major, last row 0 0 0 1).
pub fn rows(p: &Pose) -> [[f64; 4]; 4] {
    [
        [p[0], p[1], p[2], p[3]],
        [p[4], p[5], p[6], p[7]],
        [p[8], p[9], p[10], p[11]],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn conversions_are_inverse() {
        let iso = Isometry3::new(Vector3::new(0.1, -2.0, 3.5), Vector3::new(0.3, -0.2, 1.1));
        let p = from_isometry(&iso);
        let back = to_isometry(&p);
        assert!((back.to_homogeneous() - iso.to_homogeneous()).abs().max() < 1e-15);
        assert_eq!(from_matrix(&to_matrix(&p)), p);
        assert_eq!(rows(&p)[1][3], -2.0);
        assert_eq!(rows(&p)[3], [0.0, 0.0, 0.0, 1.0]);
    }
}
