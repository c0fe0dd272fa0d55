//! The arithmetic of MJCF frames and geoms, as MuJoCo's compiler does it (user_util.cc,
//! user_objects.cc): orientations from `quat`, `axisangle`, `euler` (with the compiler's
//! `eulerseq`), `xyaxes` and `zaxis`; the `fromto` placement of a geom; and the volume and
//! inertia of the primitive geoms MuJoCo infers a body's inertia from. No XML here:
//! [`crate::mjcf`] reads the attributes and calls these.

use nalgebra::{Matrix3, Matrix4, Quaternion, Rotation3, UnitQuaternion, Vector3};
use robosim_kinematics::chain::Inertial;
use std::f64::consts::PI;

/// A rigid transform from a position and a unit quaternion.
pub fn transform(pos: &Vector3<f64>, quat: &UnitQuaternion<f64>) -> Matrix4<f64> {
    let mut m = quat.to_homogeneous();
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(pos);
    m
}

/// A translation.
pub fn translation(p: &Vector3<f64>) -> Matrix4<f64> {
    Matrix4::new_translation(p)
}

/// `quat="w x y z"`, normalised (MuJoCo normalises every quaternion it reads). `None` for the
/// zero quaternion.
pub fn from_wxyz(q: [f64; 4]) -> Option<UnitQuaternion<f64>> {
    let q = Quaternion::new(q[0], q[1], q[2], q[3]);
    (q.norm() > 0.0).then(|| UnitQuaternion::from_quaternion(q))
}

/// `axisangle="x y z a"`, `a` already in radians. `None` for a zero axis.
pub fn from_axis_angle(axis: Vector3<f64>, angle: f64) -> Option<UnitQuaternion<f64>> {
    let n = axis.norm();
    (n > 0.0).then(|| {
        let a = axis / n;
        let (s, c) = (angle / 2.0).sin_cos();
        UnitQuaternion::new_unchecked(Quaternion::new(c, a.x * s, a.y * s, a.z * s))
    })
}

/// `euler="a b c"` (radians) in the sequence `seq` (three of `xyzXYZ`): a lower-case letter
/// rotates about the moving (intrinsic) axis — the quaternion is multiplied on the right — an
/// upper-case one about the fixed axis (on the left), in MuJoCo's order. `None` when `seq` is
/// not three such letters.
pub fn from_euler(angles: [f64; 3], seq: &str) -> Option<UnitQuaternion<f64>> {
    let seq = seq.as_bytes();
    if seq.len() != 3 {
        return None;
    }
    let mut q = Quaternion::identity();
    for (i, &c) in seq.iter().enumerate() {
        let (s, co) = (angles[i] / 2.0).sin_cos();
        let r = match c.to_ascii_lowercase() {
            b'x' => Quaternion::new(co, s, 0.0, 0.0),
            b'y' => Quaternion::new(co, 0.0, s, 0.0),
            b'z' => Quaternion::new(co, 0.0, 0.0, s),
            _ => return None,
        };
        q = if c.is_ascii_lowercase() { q * r } else { r * q };
    }
    Some(UnitQuaternion::from_quaternion(q))
}

/// `xyaxes="x1 x2 x3 y1 y2 y3"`: x normalised, y made orthogonal to it and normalised,
/// z = x × y. `None` when x is zero or y is parallel to it.
pub fn from_xyaxes(x: Vector3<f64>, y: Vector3<f64>) -> Option<UnitQuaternion<f64>> {
    let nx = x.norm();
    if nx == 0.0 {
        return None;
    }
    let x = x / nx;
    let y = y - x * x.dot(&y);
    let ny = y.norm();
    if ny < 1e-10 {
        return None;
    }
    let y = y / ny;
    let z = x.cross(&y);
    let r = Matrix3::from_columns(&[x, y, z]);
    // Shepperd's closed form: `UnitQuaternion::from_matrix` iterates from the identity and
    // returns it for a half-turn.
    Some(UnitQuaternion::from_rotation_matrix(
        &Rotation3::from_matrix_unchecked(r),
    ))
}

/// The shortest rotation taking z to `v` (MuJoCo's `mju_z2quat`; `zaxis` and `fromto`): a half
/// turn about x when `v` points along −z. `None` for a zero vector.
pub fn z_to(v: Vector3<f64>) -> Option<UnitQuaternion<f64>> {
    if v.norm() == 0.0 {
        return None;
    }
    let axis = Vector3::z().cross(&v);
    let s = axis.norm();
    let axis = if s < 1e-10 { Vector3::x() } else { axis / s };
    let angle = s.atan2(v.z);
    from_axis_angle(axis, angle)
}

/// A primitive geom's shape, MuJoCo's `size` read per type (half sizes, m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Primitive {
    Sphere {
        r: f64,
    },
    /// Radius and half length of the cylindrical part, axis z.
    Capsule {
        r: f64,
        h: f64,
    },
    /// Radius and half length, axis z.
    Cylinder {
        r: f64,
        h: f64,
    },
    /// Half extents.
    Box {
        half: Vector3<f64>,
    },
    /// Semi-axes.
    Ellipsoid {
        abc: Vector3<f64>,
    },
}

impl Primitive {
    /// Volume, m³.
    pub fn volume(&self) -> f64 {
        match *self {
            Primitive::Sphere { r } => 4.0 / 3.0 * PI * r.powi(3),
            Primitive::Capsule { r, h } => PI * r * r * 2.0 * h + 4.0 / 3.0 * PI * r.powi(3),
            Primitive::Cylinder { r, h } => PI * r * r * 2.0 * h,
            Primitive::Box { half } => 8.0 * half.x * half.y * half.z,
            Primitive::Ellipsoid { abc } => 4.0 / 3.0 * PI * abc.x * abc.y * abc.z,
        }
    }

    /// The principal moments of a solid of `mass` kg about its centre, in its own frame
    /// (MuJoCo's formulas: a capsule is a cylinder and two hemispheres moved out along z).
    pub fn principal_inertia(&self, mass: f64) -> Vector3<f64> {
        match *self {
            Primitive::Sphere { r } => Vector3::repeat(0.4 * mass * r * r),
            Primitive::Capsule { r, h } => {
                let height = 2.0 * h;
                let sphere_mass = mass * 4.0 * r / (4.0 * r + 3.0 * height);
                let cylinder_mass = mass - sphere_mass;
                let side = cylinder_mass * (3.0 * r * r + height * height) / 12.0;
                let axial = cylinder_mass * r * r / 2.0;
                let sphere = 2.0 * sphere_mass * r * r / 5.0;
                let shift = sphere_mass * height * (3.0 * r + 2.0 * height) / 8.0;
                Vector3::new(side + sphere + shift, side + sphere + shift, axial + sphere)
            }
            Primitive::Cylinder { r, h } => {
                let height = 2.0 * h;
                let side = mass * (3.0 * r * r + height * height) / 12.0;
                Vector3::new(side, side, mass * r * r / 2.0)
            }
            Primitive::Box { half } => {
                let s = half.component_mul(&half);
                Vector3::new(s.y + s.z, s.x + s.z, s.x + s.y) * (mass / 3.0)
            }
            Primitive::Ellipsoid { abc } => {
                let s = abc.component_mul(&abc);
                Vector3::new(s.y + s.z, s.x + s.z, s.x + s.y) * (mass / 5.0)
            }
        }
    }

    /// The solid's inertial placed at `frame` (the geom's frame in the body's).
    pub fn inertial(&self, mass: f64, frame: &Matrix4<f64>) -> Inertial {
        Inertial {
            mass,
            com: Vector3::zeros(),
            inertia: Matrix3::from_diagonal(&self.principal_inertia(mass)),
        }
        .transformed(frame)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xyaxes_of_a_half_turn_is_a_half_turn() {
        // 180° about z: x → −x, y → −y (nalgebra's iterative from_matrix gave the identity).
        let q = from_xyaxes(-Vector3::x(), -Vector3::y()).expect("valid");
        assert!((q * Vector3::x() + Vector3::x()).norm() < 1e-15);
        assert!((q * Vector3::y() + Vector3::y()).norm() < 1e-15);
        // 180° about x.
        let q = from_xyaxes(Vector3::x(), -Vector3::y()).expect("valid");
        assert!((q * Vector3::z() + Vector3::z()).norm() < 1e-15);
    }

    #[test]
    fn euler_sequences_compose_as_mujoco_does() {
        // Intrinsic xyz = extrinsic ZYX with the angles reversed.
        let a = [0.3, -0.7, 1.1];
        let intrinsic = from_euler(a, "xyz").expect("valid");
        let extrinsic = from_euler([a[2], a[1], a[0]], "ZYX").expect("valid");
        assert!(intrinsic.angle_to(&extrinsic) < 1e-14);
        let rx = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), a[0]);
        let ry = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), a[1]);
        let rz = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a[2]);
        assert!(intrinsic.angle_to(&(rx * ry * rz)) < 1e-14);
        assert!(from_euler(a, "xyw").is_none());
    }

    #[test]
    fn z_to_takes_z_to_the_vector_also_backwards() {
        for v in [
            Vector3::new(1.0, 2.0, 3.0),
            Vector3::new(0.0, 0.0, -2.0),
            Vector3::z(),
        ] {
            let q = z_to(v).expect("non-zero");
            assert!((q * Vector3::z() - v.normalize()).norm() < 1e-14, "{v}");
        }
    }

    #[test]
    fn a_capsule_of_no_length_is_a_sphere() {
        let (m, r) = (2.0, 0.3);
        let c = Primitive::Capsule { r, h: 0.0 };
        let s = Primitive::Sphere { r };
        assert!((c.volume() - s.volume()).abs() < 1e-15);
        assert!((c.principal_inertia(m) - s.principal_inertia(m)).norm() < 1e-15);
    }
}
