//! The reference robots shipped with the crate, usable by name before the library language
//! lands. Their parameters are those of `testdata/kinematics/*.json` (generated from Robotics
//! Toolbox for Python 1.5.0 by `testdata/kinematics/generate.py`; sources in the README there),
//! written out here as Rust so the numbers need no file: each number is the f64 the JSON reader
//! makes of the file (the `json` module's test `builtin_robots_match_their_json` checks that
//! each robot equals its file as read, bit for bit). The standard library's
//! `library-space/stdlib/{puma560,stanford,panda}.rsl` define the same robots;
//! `library-space/tests/builtin_tables.rs` checks that each compiles to its table here.
//!
//! Entry points: [`builtin_robot`], [`BUILTIN_NAMES`].
#![expect(
    clippy::approx_constant,
    reason = "the numbers are the data files' as read, digit for digit (some of them are π/2 or π/4)"
)]

use crate::model::{Convention, Joint, JointType, Robot};
use nalgebra::{Matrix3, Matrix4, Vector3};

/// The names [`builtin_robot`] knows.
pub const BUILTIN_NAMES: &[&str] = &["puma560", "stanford", "panda"];

/// A shipped robot by name: `"puma560"` (standard DH, Corke & Armstrong-Helouvry 1994 kinematics
/// and dynamics, with the 0.672 m pedestal as d1), `"stanford"` (standard DH, RRPRRR) or
/// `"panda"` (Franka Emika Panda, modified DH, 7 DOF, with inertial parameters). `None` for any
/// other name.
pub fn builtin_robot(name: &str) -> Option<Robot> {
    match name {
        "puma560" => Some(puma560()),
        "stanford" => Some(stanford()),
        "panda" => Some(panda()),
        _ => None,
    }
}

/// `testdata/kinematics/puma560.json`.
fn puma560() -> Robot {
    Robot {
        name: "puma560".to_owned(),
        convention: Convention::Standard,
        parents: Vec::new(),
        root: None,
        joints: vec![
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0,
                // 26.45 in, exactly 0.67183 m (RTB computes 26.45 * 0.0254 and rounds to
                // 0.6718299999999999, one unit in the last place low).
                d: 0.67183,
                alpha: 1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-2.792526803190927, 2.792526803190927],
                mass: 0.0,
                com: Vector3::new(0.0, 0.0, 0.0),
                inertia: Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.35, 0.0, 0.0, 0.0, 0.0),
                motor_inertia: 0.784029968642,
                viscous: 5.801821767950799,
                coulomb: 25.983606500000004,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.4318,
                d: 0.0,
                alpha: 0.0,
                theta: 0.0,
                offset: 0.0,
                qlim: [-0.7853981633974483, 3.9269908169872414],
                mass: 17.4,
                com: Vector3::new(-0.3638, 0.006, 0.2275),
                inertia: Matrix3::new(0.13, 0.0, 0.0, 0.0, 0.524, 0.0, 0.0, 0.0, 0.539),
                motor_inertia: 2.324814845,
                viscous: 9.496868641825,
                coulomb: 10.6197775,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0203,
                d: 0.15005,
                alpha: -1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-3.9269908169872414, 0.7853981633974483],
                mass: 4.8,
                com: Vector3::new(-0.0203, -0.0141, 0.07),
                inertia: Matrix3::new(0.066, 0.0, 0.0, 0.0, 0.086, 0.0, 0.0, 0.0, 0.0125),
                motor_inertia: 0.5768733319380001,
                viscous: 3.9804259903721997,
                coulomb: 6.36419655,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0,
                d: 0.4318,
                alpha: 1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-1.9198621771937625, 2.9670597283903604],
                mass: 0.82,
                com: Vector3::new(0.0, 0.019, 0.0),
                inertia: Matrix3::new(0.0018, 0.0, 0.0, 0.0, 0.0013, 0.0, 0.0, 0.0, 0.0018),
                motor_inertia: 0.19079062612368,
                viscous: 0.411645229697152,
                coulomb: 1.06831142,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0,
                d: 0.0,
                alpha: -1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-1.7453292519943295, 1.7453292519943295],
                mass: 0.34,
                com: Vector3::new(0.0, 0.0, 0.0),
                inertia: Matrix3::new(0.0003, 0.0, 0.0, 0.0, 0.0004, 0.0, 0.0, 0.0, 0.0003),
                motor_inertia: 0.17070629165700002,
                viscous: 0.4272830209354,
                coulomb: 0.85444524,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0,
                d: 0.0,
                alpha: 0.0,
                theta: 0.0,
                offset: 0.0,
                qlim: [-4.642575810304916, 4.642575810304916],
                mass: 0.09,
                com: Vector3::new(0.0, 0.0, 0.032),
                inertia: Matrix3::new(0.00015, 0.0, 0.0, 0.0, 0.00015, 0.0, 0.0, 0.0, 4e-5),
                motor_inertia: 0.19406450566800004,
                viscous: 0.2158232532732,
                coulomb: 0.55443978,
                origin: None,
                spherical: false,
            },
        ],
        gravity: Vector3::new(0.0, 0.0, -9.81),
        base: Matrix4::identity(),
        tool: Matrix4::identity(),
    }
}

/// `testdata/kinematics/stanford.json`.
fn stanford() -> Robot {
    Robot {
        name: "stanford".to_owned(),
        convention: Convention::Standard,
        parents: Vec::new(),
        root: None,
        joints: vec![
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0,
                d: 0.412,
                alpha: -1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-2.9670597283903604, 2.9670597283903604],
                mass: 9.29,
                com: Vector3::new(0.0, 0.0175, -0.1105),
                inertia: Matrix3::new(0.276, 0.0, 0.0, 0.0, 0.255, 0.0, 0.0, 0.0, 0.071),
                motor_inertia: 0.953,
                viscous: 0.0,
                coulomb: 0.0,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0,
                d: 0.154,
                alpha: 1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-2.9670597283903604, 2.9670597283903604],
                mass: 5.01,
                com: Vector3::new(0.0, -1.054, 0.0),
                inertia: Matrix3::new(0.108, 0.0, 0.0, 0.0, 0.018, 0.0, 0.0, 0.0, 0.1),
                motor_inertia: 2.193,
                viscous: 0.0,
                coulomb: 0.0,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Prismatic,
                a: 0.0203,
                d: 0.0,
                alpha: 0.0,
                theta: -1.5707963267948966,
                offset: 0.0,
                qlim: [0.30479999999999996, 1.27],
                mass: 4.25,
                com: Vector3::new(0.0, 0.0, -6.447),
                inertia: Matrix3::new(2.51, 0.0, 0.0, 0.0, 2.51, 0.0, 0.0, 0.0, 0.006),
                motor_inertia: 0.782,
                viscous: 0.0,
                coulomb: 0.0,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0,
                d: 0.0,
                alpha: -1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-2.9670597283903604, 2.9670597283903604],
                mass: 1.08,
                com: Vector3::new(0.0, 0.092, -0.054),
                inertia: Matrix3::new(0.002, 0.0, 0.0, 0.0, 0.001, 0.0, 0.0, 0.0, 0.001),
                motor_inertia: 0.106,
                viscous: 0.0,
                coulomb: 0.0,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0,
                d: 0.0,
                alpha: 1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-1.5707963267948966, 1.5707963267948966],
                mass: 0.63,
                com: Vector3::new(0.0, 0.566, 0.003),
                inertia: Matrix3::new(0.003, 0.0, 0.0, 0.0, 0.0004, 0.0, 0.0, 0.0, 0.0),
                motor_inertia: 0.097,
                viscous: 0.0,
                coulomb: 0.0,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0,
                d: 0.0,
                alpha: 0.0,
                theta: 0.0,
                offset: 0.0,
                qlim: [-2.9670597283903604, 2.9670597283903604],
                mass: 0.51,
                com: Vector3::new(0.0, 0.0, 1.554),
                inertia: Matrix3::new(0.013, 0.0, 0.0, 0.0, 0.013, 0.0, 0.0, 0.0, 0.0003),
                motor_inertia: 0.02,
                viscous: 0.0,
                coulomb: 0.0,
                origin: None,
                spherical: false,
            },
        ],
        gravity: Vector3::new(0.0, 0.0, -9.81),
        base: Matrix4::identity(),
        tool: Matrix4::identity(),
    }
}

/// `testdata/kinematics/panda.json`.
fn panda() -> Robot {
    Robot {
        name: "panda".to_owned(),
        convention: Convention::Modified,
        parents: Vec::new(),
        root: None,
        joints: vec![
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0,
                d: 0.333,
                alpha: 0.0,
                theta: 0.0,
                offset: 0.0,
                qlim: [-2.8973, 2.8973],
                mass: 4.970684,
                com: Vector3::new(0.003875, 0.002081, 0.0),
                inertia: Matrix3::new(
                    0.70337, -0.000139, 0.006772, -0.000139, 0.70661, 0.019169, 0.006772, 0.019169,
                    0.009117,
                ),
                motor_inertia: 0.0,
                viscous: 0.0,
                coulomb: 0.0,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0,
                d: 0.0,
                alpha: -1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-1.7628, 1.7628],
                mass: 0.646926,
                com: Vector3::new(-0.003141, -0.02872, 0.003495),
                inertia: Matrix3::new(
                    0.007962, -0.003925, 0.010254, -0.003925, 0.02811, 0.000704, 0.010254,
                    0.000704, 0.025995,
                ),
                motor_inertia: 0.0,
                viscous: 0.0,
                coulomb: 0.0,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0,
                d: 0.316,
                alpha: 1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-2.8973, 2.8973],
                mass: 3.228604,
                com: Vector3::new(0.027518, 0.039252, -0.066502),
                inertia: Matrix3::new(
                    0.037242, -0.004761, -0.011396, -0.004761, 0.036155, -0.012805, -0.011396,
                    -0.012805, 0.01083,
                ),
                motor_inertia: 0.0,
                viscous: 0.0,
                coulomb: 0.0,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0825,
                d: 0.0,
                alpha: 1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-3.0718, -0.0698],
                mass: 3.587895,
                com: Vector3::new(-0.05317, 0.104419, 0.027454),
                inertia: Matrix3::new(
                    0.025853, 0.007796, -0.001332, 0.007796, 0.019552, 0.008641, -0.001332,
                    0.008641, 0.028323,
                ),
                motor_inertia: 0.0,
                viscous: 0.0,
                coulomb: 0.0,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: -0.0825,
                d: 0.384,
                alpha: -1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-2.8973, 2.8973],
                mass: 1.225946,
                com: Vector3::new(-0.011953, 0.041065, -0.038437),
                inertia: Matrix3::new(
                    0.035549, -0.002117, -0.004037, -0.002117, 0.029474, 0.000229, -0.004037,
                    0.000229, 0.008627,
                ),
                motor_inertia: 0.0,
                viscous: 0.0,
                coulomb: 0.0,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.0,
                d: 0.0,
                alpha: 1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-0.0175, 3.7525],
                mass: 1.666555,
                com: Vector3::new(0.060149, -0.014117, -0.010517),
                inertia: Matrix3::new(
                    0.001964, 0.000109, -0.001158, 0.000109, 0.004354, 0.000341, -0.001158,
                    0.000341, 0.005433,
                ),
                motor_inertia: 0.0,
                viscous: 0.0,
                coulomb: 0.0,
                origin: None,
                spherical: false,
            },
            Joint {
                joint_type: JointType::Revolute,
                a: 0.088,
                d: 0.107,
                alpha: 1.5707963267948966,
                theta: 0.0,
                offset: 0.0,
                qlim: [-2.8973, 2.8973],
                mass: 0.735522,
                com: Vector3::new(0.010517, -0.004252, -0.045403),
                inertia: Matrix3::new(
                    0.012516, -0.000428, -0.001196, -0.000428, 0.010027, -0.000741, -0.001196,
                    -0.000741, 0.004815,
                ),
                motor_inertia: 0.0,
                viscous: 0.0,
                coulomb: 0.0,
                origin: None,
                spherical: false,
            },
        ],
        gravity: Vector3::new(0.0, 0.0, -9.81),
        base: Matrix4::identity(),
        tool: Matrix4::new(
            0.7071067811865476,
            0.7071067811865475,
            0.0,
            0.0,
            -0.7071067811865475,
            0.7071067811865476,
            0.0,
            0.0,
            0.0,
            0.0,
            1.0,
            0.10300000000000001,
            0.0,
            0.0,
            0.0,
            1.0,
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_robots_parse() {
        for name in BUILTIN_NAMES {
            let robot = builtin_robot(name).expect("a builtin name");
            robot.validate().expect("shipped robot is valid");
            assert_eq!(robot.name, *name);
        }
        assert_eq!(builtin_robot("puma560").map(|r| r.dof()), Some(6));
        assert_eq!(builtin_robot("panda").map(|r| r.dof()), Some(7));
        assert!(builtin_robot("nope").is_none());
    }
}
