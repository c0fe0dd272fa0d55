//! One source of truth for the shipped robots (issue #35, "two sources of truth"): the PUMA 560,
//! the Stanford arm and the Panda are written twice — as library source
//! (`library-space/stdlib/*.rsl`, what a scene and the query protocol's robot names get) and as
//! Rust tables (`robosim_kinematics::builtin_robot`, the fallback of crates that have no library,
//! equal bit for bit to `testdata/kinematics/*.json`, generated from Robotics Toolbox for Python).
//! This compiles each stdlib robot and compares it with its builtin table, field by field.
//!
//! Equality is exact except where the .rsl source writes a value as arithmetic (degrees,
//! millimetres, `Jm · G²`), which the evaluator rounds once more than the JSON reader did:
//! there a difference of at most [`MAX_ULPS`] units in the last place is the same number.
//! A field that is a plain decimal literal in both sources must match to the last bit.

use nalgebra::{Matrix3, Matrix4, Vector3};
use robosim_kinematics::{BUILTIN_NAMES, Joint, JointType, Robot, builtin_robot};
use robosim_library::{Evaluated, Library, Params};

/// The most the evaluator's extra rounding moves a value written as arithmetic in the source.
const MAX_ULPS: u64 = 4;

fn stdlib_robot(name: &str) -> Robot {
    let lib = Library::standard().unwrap_or_else(|e| panic!("standard library: {e}"));
    match lib.evaluate(name, &Params::new()) {
        Ok(Evaluated::Robot(r)) => r.robot,
        other => panic!("{name}: not a robot: {other:?}"),
    }
}

/// Units in the last place between two finite floats of the same sign (0 = the same bits;
/// +0 and -0 count as equal).
fn ulps(a: f64, b: f64) -> u64 {
    if a == b {
        return 0;
    }
    if a.is_sign_negative() != b.is_sign_negative() || !a.is_finite() || !b.is_finite() {
        return u64::MAX;
    }
    a.to_bits().abs_diff(b.to_bits())
}

/// The differences found, each "robot joint field: stdlib vs builtin (n ulps)".
#[derive(Default)]
struct Diffs(Vec<String>);

impl Diffs {
    fn num(&mut self, at: &str, ours: f64, builtin: f64, max_ulps: u64) {
        let d = ulps(ours, builtin);
        if d > max_ulps {
            self.0.push(format!(
                "{at}: stdlib {ours:?} vs builtin {builtin:?} ({} ulps, {max_ulps} allowed)",
                if d == u64::MAX {
                    "sign or finiteness differs".to_owned()
                } else {
                    d.to_string()
                }
            ));
        }
    }

    fn vec3(&mut self, at: &str, ours: &Vector3<f64>, builtin: &Vector3<f64>, max_ulps: u64) {
        for i in 0..3 {
            self.num(&format!("{at}[{i}]"), ours[i], builtin[i], max_ulps);
        }
    }

    fn mat3(&mut self, at: &str, ours: &Matrix3<f64>, builtin: &Matrix3<f64>, max_ulps: u64) {
        for i in 0..3 {
            for j in 0..3 {
                self.num(
                    &format!("{at}[{i}][{j}]"),
                    ours[(i, j)],
                    builtin[(i, j)],
                    max_ulps,
                );
            }
        }
    }

    fn mat4(&mut self, at: &str, ours: &Matrix4<f64>, builtin: &Matrix4<f64>, max_ulps: u64) {
        for i in 0..4 {
            for j in 0..4 {
                self.num(
                    &format!("{at}[{i}][{j}]"),
                    ours[(i, j)],
                    builtin[(i, j)],
                    max_ulps,
                );
            }
        }
    }

    fn same<T: PartialEq + std::fmt::Debug>(&mut self, at: &str, ours: &T, builtin: &T) {
        if ours != builtin {
            self.0
                .push(format!("{at}: stdlib {ours:?} vs builtin {builtin:?}"));
        }
    }
}

/// Which fields of a joint each robot's .rsl writes as a plain decimal literal in the
/// builtin's units (so they must be bit-equal); the others are arithmetic in the source.
struct Literal {
    /// a, d (metres written as `m`), mass, com, inertia, motor_inertia.
    lengths_and_inertials: bool,
    /// joint limits written in rad (the Panda) rather than degrees.
    limits: bool,
    /// The one known difference: the PUMA's .rsl leaves Coulomb friction out, while the builtin
    /// table carries |G| (|Tc+| + |Tc-|) / 2, the mean of Corke & Armstrong-Helouvry's
    /// asymmetric motor-side values (testdata/kinematics/generate.py). Giving the .rsl the
    /// mean would change what the query protocol's `id`/`fd`/`simulate` answer for `puma560`
    /// (docs/query.md's examples), so it is left to a decision; the stdlib value must be 0
    /// and the builtin's the mean (`the_pumas_coulomb_friction_is_the_known_difference`).
    coulomb_left_out: bool,
}

fn compare_joint(d: &mut Diffs, at: &str, ours: &Joint, builtin: &Joint, lit: &Literal) {
    let exact = |literal: bool| if literal { 0 } else { MAX_ULPS };
    d.same(&format!("{at}.type"), &ours.joint_type, &builtin.joint_type);
    let l = exact(lit.lengths_and_inertials);
    d.num(&format!("{at}.a"), ours.a, builtin.a, l);
    d.num(&format!("{at}.d"), ours.d, builtin.d, l);
    // alpha and theta are written in degrees in every .rsl.
    d.num(&format!("{at}.alpha"), ours.alpha, builtin.alpha, MAX_ULPS);
    d.num(&format!("{at}.theta"), ours.theta, builtin.theta, MAX_ULPS);
    d.num(&format!("{at}.offset"), ours.offset, builtin.offset, 0);
    let q = exact(lit.limits);
    d.num(&format!("{at}.qlim[0]"), ours.qlim[0], builtin.qlim[0], q);
    d.num(&format!("{at}.qlim[1]"), ours.qlim[1], builtin.qlim[1], q);
    d.num(&format!("{at}.mass"), ours.mass, builtin.mass, l);
    d.vec3(&format!("{at}.com"), &ours.com, &builtin.com, l);
    d.mat3(&format!("{at}.inertia"), &ours.inertia, &builtin.inertia, l);
    // The PUMA's drive parameters are Jm·G² and B·G² in the source.
    d.num(
        &format!("{at}.motor_inertia"),
        ours.motor_inertia,
        builtin.motor_inertia,
        MAX_ULPS,
    );
    d.num(
        &format!("{at}.viscous"),
        ours.viscous,
        builtin.viscous,
        MAX_ULPS,
    );
    if lit.coulomb_left_out {
        // Not compared: the .rsl leaves it out (see [`Literal::coulomb_left_out`]).
        d.num(&format!("{at}.coulomb (left out)"), ours.coulomb, 0.0, 0);
    } else {
        d.num(&format!("{at}.coulomb"), ours.coulomb, builtin.coulomb, 0);
    }
    d.same(&format!("{at}.origin"), &ours.origin, &builtin.origin);
}

fn compare(name: &str, ours: &Robot, builtin: &Robot, lit: &Literal) -> Vec<String> {
    let mut d = Diffs::default();
    d.same(
        &format!("{name}.convention"),
        &ours.convention,
        &builtin.convention,
    );
    d.same(&format!("{name}.parents"), &ours.parents, &builtin.parents);
    d.same(&format!("{name}.dof"), &ours.dof(), &builtin.dof());
    d.vec3(
        &format!("{name}.gravity"),
        &ours.gravity,
        &builtin.gravity,
        0,
    );
    d.mat4(&format!("{name}.base"), &ours.base, &builtin.base, 0);
    // The Panda's tool is translate · rotate_z(-45 deg) in the source.
    d.mat4(&format!("{name}.tool"), &ours.tool, &builtin.tool, MAX_ULPS);
    for (j, (o, b)) in ours.joints.iter().zip(&builtin.joints).enumerate() {
        compare_joint(&mut d, &format!("{name}.joints[{j}]"), o, b, lit);
    }
    d.0
}

fn literal_fields(name: &str) -> Literal {
    match name {
        // Lengths in `m`, inertials in SI; limits in degrees, drive terms as Jm·G².
        "puma560" => Literal {
            lengths_and_inertials: true,
            limits: false,
            coulomb_left_out: true,
        },
        // Lengths in `m`, inertials in SI; limits in degrees and metres.
        "stanford" => Literal {
            lengths_and_inertials: true,
            limits: false,
            coulomb_left_out: false,
        },
        // Lengths in `m` and inertials in SI; limits in rad.
        "panda" => Literal {
            lengths_and_inertials: true,
            limits: true,
            coulomb_left_out: false,
        },
        other => panic!("no literal-field table for builtin robot {other}"),
    }
}

#[test]
fn every_builtin_robot_equals_its_stdlib_source() {
    let mut all = Vec::new();
    for name in BUILTIN_NAMES {
        let builtin = builtin_robot(name).expect("a builtin name");
        let ours = stdlib_robot(name);
        all.extend(compare(name, &ours, &builtin, &literal_fields(name)));
    }
    assert!(
        all.is_empty(),
        "the stdlib robots and robosim_kinematics::builtin_robot disagree:\n{}",
        all.join("\n")
    );
}

/// The comparison catches what it should: a joint type, a length off by one bit where both are
/// literals, a limit off by more than the rounding allowance, a missing joint.
#[test]
fn the_comparison_sees_a_one_bit_change() {
    let builtin = builtin_robot("panda").expect("panda");
    let lit = literal_fields("panda");
    assert!(compare("panda", &builtin, &builtin, &lit).is_empty());
    let mut changed = builtin.clone();
    changed.joints[3].a = f64::from_bits(changed.joints[3].a.to_bits() + 1);
    let d = compare("panda", &changed, &builtin, &lit);
    assert_eq!(d.len(), 1, "{d:?}");
    assert!(d[0].starts_with("panda.joints[3].a:"), "{d:?}");
    let mut changed = builtin.clone();
    changed.joints[0].joint_type = JointType::Prismatic;
    changed.tool[(2, 3)] += 1e-9;
    changed.joints.pop();
    let d = compare("panda", &changed, &builtin, &lit);
    assert!(
        d.iter().any(|m| m.starts_with("panda.joints[0].type")),
        "{d:?}"
    );
    assert!(d.iter().any(|m| m.starts_with("panda.tool[2][3]")), "{d:?}");
    assert!(d.iter().any(|m| m.starts_with("panda.dof")), "{d:?}");
}

/// The PUMA's Coulomb friction, the one field the two sources hold differently on purpose:
/// 0 in the .rsl, and in the builtin table |G| (|Tc+| + |Tc-|) / 2 of Corke's drive parameters
/// (gear ratio G, motor-side Tc+ and Tc-, per joint).
#[test]
fn the_pumas_coulomb_friction_is_the_known_difference() {
    let drive: [(f64, f64, f64); 6] = [
        (62.6111, 0.395, -0.435),
        (107.815, 0.126, -0.071),
        (53.7063, 0.132, -0.105),
        (76.0364, 11.2e-3, -16.9e-3),
        (71.923, 9.26e-3, -14.5e-3),
        (76.686, 3.96e-3, -10.5e-3),
    ];
    let builtin = builtin_robot("puma560").expect("puma560");
    let ours = stdlib_robot("puma560");
    for (j, (g, tp, tm)) in drive.iter().enumerate() {
        let mean = g.abs() * (tp.abs() + tm.abs()) / 2.0;
        assert_eq!(builtin.joints[j].coulomb, mean, "builtin joint {j}");
        assert_eq!(ours.joints[j].coulomb, 0.0, "stdlib joint {j}");
    }
}
