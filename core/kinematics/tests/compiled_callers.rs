//! The IK solvers on a `KinematicModel` compiled once per solve (issue 37 item 1) against the
//! `&Robot` FK they called before: each solution's residual, computed by the solver on the
//! compiled model, equals with `==` the one the `&Robot` path gives for the same q, for every
//! method on every builtin robot (a solver judging its answer on a stale or wrong model, or on
//! another q than the one it returns, fails here).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robosim_kinematics::ik::{self, IkError, IkOptions, Method};
use robosim_kinematics::pose::Residual;
use robosim_kinematics::{BUILTIN_NAMES, builtin_robot, fk};

#[test]
fn ik_residuals_equal_the_robot_path_for_every_method() {
    let mut rng = ChaCha8Rng::seed_from_u64(371);
    let mut checked = 0;
    for name in BUILTIN_NAMES {
        let robot = builtin_robot(name).expect("builtin");
        for _ in 0..8 {
            let q: Vec<f64> = robot
                .joints
                .iter()
                .map(|j| rng.random_range(j.qlim[0].max(-3.0)..j.qlim[1].min(3.0)))
                .collect();
            let target = fk::forward(&robot, &q);
            let near: Vec<f64> = q.iter().map(|x| x + 0.05).collect();
            for method in [Method::Auto, Method::Analytic, Method::Dls, Method::Newton] {
                let options = IkOptions {
                    q0: (method == Method::Newton).then(|| near.clone()),
                    all: method == Method::Analytic,
                    ..IkOptions::default()
                };
                let solutions = match ik::solve(&robot, &target, method, &options) {
                    Ok(r) => r.solutions,
                    Err(IkError::NotConverged { best, .. }) => vec![*best],
                    Err(IkError::NotApplicable { .. }) => continue,
                    Err(e) => panic!("{name} {method:?}: {e}"),
                };
                for s in solutions {
                    let want = Residual::between(&fk::forward(&robot, &s.q), &target);
                    assert_eq!(s.residual, want, "{name} {method:?} at {:?}", s.q);
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 100, "{checked} solutions checked");
}
