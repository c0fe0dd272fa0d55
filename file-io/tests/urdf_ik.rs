//! Analytic IK on robots imported from URDF: the closed-form family is recognised from the
//! joints' placements and axes (ik::equivalent), not from DH rows. The UR5 (three parallel
//! axes) gets its closed-form solutions, each checked by FK against the target to 1e-12; the
//! PUMA 560 written out as URDF and read back is a spherical wrist again; the Panda (7 joints)
//! has no family and `auto` falls back to a numeric method.

use robosim_file_io::urdf_import::{import_urdf, import_urdf_str};
use robosim_kinematics::ik::equivalent::equivalent_dh;
use robosim_kinematics::ik::family::{Family, recognise, recognised_from_axes};
use robosim_kinematics::ik::{self, IkOptions, Method};
use robosim_kinematics::{Robot, fk};
use std::path::Path;

fn urdf(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../testdata/urdf")
        .join(name)
}

/// Joint values spread over ±(π − 0.2), deterministic, none at 0 (q = 0 puts the UR5's elbow
/// and the PUMA's wrist on a singularity, where the solutions merge and q is not recoverable).
fn sample_q(n: usize, k: usize) -> Vec<f64> {
    (0..n)
        .map(|j| {
            let u = ((k * 7 + j * 5 + 3) % 17) as f64 / 16.0;
            (2.0 * u - 1.0) * (std::f64::consts::PI - 0.3) + 0.05 * (j + 1) as f64
        })
        .collect()
}

fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(std::f64::consts::TAU);
    d.min(std::f64::consts::TAU - d)
}

/// Every closed-form solution of `robot` at 20 poses: FK of each within `1e-12` of the pose,
/// the q that made the pose among them; returns (worst FK error, solutions seen).
fn check_analytic(robot: &Robot, name: &str) -> (f64, usize) {
    let options = IkOptions {
        all: true,
        ..IkOptions::default()
    };
    let (mut worst, mut seen) = (0.0_f64, 0);
    for k in 0..20 {
        let q = sample_q(robot.dof(), k);
        let target = fk::forward(robot, &q);
        let r = ik::solve(robot, &target, Method::Analytic, &options)
            .unwrap_or_else(|e| panic!("{name} at {q:?}: {e}"));
        assert_eq!(r.method, Method::Analytic);
        assert!(!r.solutions.is_empty());
        for s in &r.solutions {
            let e = (fk::forward(robot, &s.q) - target).abs().max();
            assert!(
                e <= 1e-12,
                "{name} at {q:?}: solution {:?} off by {e:e}",
                s.q
            );
            worst = worst.max(e);
        }
        seen += r.solutions.len();
        assert!(
            r.solutions
                .iter()
                .any(|s| s.q.iter().zip(&q).all(|(a, b)| angle_diff(*a, *b) < 1e-9)),
            "{name}: {q:?} is not among {:?}",
            r.solutions.iter().map(|s| &s.q).collect::<Vec<_>>()
        );
    }
    (worst, seen)
}

#[test]
fn equivalent_dh_chains_are_the_same_robots() {
    for (file, tip) in [("ur5_robot.urdf", "tool0"), ("panda.urdf", "panda_hand")] {
        let robot = import_urdf(&urdf(file), Some(tip)).expect("imports").robot;
        let dh = equivalent_dh(&robot).expect("a DH chain");
        assert!(dh.joints.iter().all(|j| !j.is_general()));
        for k in 0..20 {
            let q = sample_q(robot.dof(), k);
            let e = (fk::forward(&robot, &q) - fk::forward(&dh, &q)).abs().max();
            assert!(e <= 1e-12, "{file} at {q:?}: {e:e}");
        }
    }
}

#[test]
fn ur5_from_urdf_is_solved_in_closed_form() {
    let robot = import_urdf(&urdf("ur5_robot.urdf"), Some("tool0"))
        .expect("imports")
        .robot;
    assert!(recognised_from_axes(&robot));
    let family = recognise(&robot);
    assert_eq!(family.name(), "three_parallel", "{family:?}");
    assert_eq!(family.method(), Method::Analytic);
    let (worst, seen) = check_analytic(&robot, "ur5");
    // Away from singularities the UR type has 8 solutions; some of these poses may lose a few
    // branches to reach, never all.
    assert!(seen >= 20 * 4, "{seen} solutions at 20 poses");
    eprintln!(
        "UR5 from URDF: {seen} closed-form solutions at 20 poses, worst FK error {worst:.1e}"
    );
    // auto picks the closed form too.
    let q = sample_q(6, 3);
    let r = ik::solve(
        &robot,
        &fk::forward(&robot, &q),
        Method::Auto,
        &IkOptions::default(),
    )
    .expect("auto");
    assert_eq!(r.method, Method::Analytic);
}

#[test]
fn puma_through_urdf_is_a_spherical_wrist_again() {
    let mut dh = robosim_file_io::scene_robots("puma560", &[])
        .expect("scene")
        .pop()
        .expect("one robot");
    for j in &mut dh.joints {
        j.motor_inertia = 0.0;
        if j.mass == 0.0 {
            j.inertia = nalgebra::Matrix3::zeros();
        }
    }
    assert_eq!(recognise(&dh).name(), "spherical_wrist");
    let text = robosim_file_io::urdf::to_urdf(&dh).expect("exports");
    let general = import_urdf_str(&text, Path::new("puma560.urdf"), Some("puma560_tool"))
        .expect("imports")
        .robot;
    assert!(recognised_from_axes(&general));
    assert_eq!(recognise(&general).name(), "spherical_wrist");
    let (worst, seen) = check_analytic(&general, "puma560 from URDF");
    eprintln!("PUMA 560 through URDF: {seen} closed-form solutions, worst FK error {worst:.1e}");
}

#[test]
fn panda_has_no_closed_form_and_auto_goes_numeric() {
    let robot = import_urdf(&urdf("panda.urdf"), Some("panda_hand"))
        .expect("imports")
        .robot;
    let family = recognise(&robot);
    match &family {
        Family::General(reason) => assert!(reason.contains("7 joints"), "{reason}"),
        other => panic!("the Panda recognised as {}", other.name()),
    }
    let q = sample_q(7, 1);
    let target = fk::forward(&robot, &q);
    let e = ik::solve(&robot, &target, Method::Analytic, &IkOptions::default())
        .expect_err("no closed form");
    assert!(matches!(e, ik::IkError::NotApplicable { .. }), "{e}");
    let options = IkOptions {
        q0: Some(q.iter().map(|x| x + 0.05).collect()),
        ..IkOptions::default()
    };
    let r = ik::solve(&robot, &target, Method::Auto, &options).expect("numeric");
    assert_ne!(r.method, Method::Analytic);
    let s = &r.solutions[0];
    assert!(s.converged, "{s:?}");
    let e = (fk::forward(&robot, &s.q) - target).abs().max();
    assert!(e <= 1e-9, "numeric answer off by {e:e}");
}
