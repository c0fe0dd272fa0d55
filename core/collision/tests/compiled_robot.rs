//! The robot checks on a `KinematicModel` compiled once (issue 37 item 1: MOVEJ's steps and the
//! simulator's collision stage) against the `&Robot` path they replaced: the same link poses
//! and the same answers, compared with `==`.

use nalgebra::{Isometry3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robosim_collision::Solid;
use robosim_collision::robot::{
    CollisionSettings, LinkSolids, Scene, check_robot, check_robot_compiled, link_poses,
    link_poses_compiled,
};
use robosim_kinematics::{KinematicModel, builtin_robot};
use std::sync::Arc;

#[test]
fn compiled_link_poses_and_checks_equal_the_robot_path_on_every_builtin_robot() {
    let mut rng = ChaCha8Rng::seed_from_u64(37_1);
    let mut scene = Scene::new();
    for i in 0..12 {
        let s = Solid::cuboid(Vector3::new(
            rng.random_range(0.05..0.3),
            rng.random_range(0.05..0.3),
            rng.random_range(0.05..0.3),
        ))
        .expect("box");
        let pose = Isometry3::translation(
            rng.random_range(-0.8..0.8),
            rng.random_range(-0.8..0.8),
            rng.random_range(-0.2..1.0),
        );
        scene.add(format!("b{i}"), Arc::new(s), pose);
    }
    let settings = CollisionSettings {
        self_collision: true,
        all_contacts: true,
        ..CollisionSettings::default()
    };
    let mut contacts = 0;
    for name in ["puma560", "stanford", "panda"] {
        let robot = builtin_robot(name).expect("builtin");
        let links = LinkSolids::from_dh(&robot, 0.05).expect("links");
        let kin = KinematicModel::new(&robot);
        for _ in 0..40 {
            let q: Vec<f64> = robot
                .joints
                .iter()
                .map(|j| rng.random_range(j.qlim[0].max(-3.0)..j.qlim[1].min(3.0)))
                .collect();
            assert_eq!(
                link_poses_compiled(&kin, &links, &q),
                link_poses(&robot, &links, &q),
                "{name} at {q:?}"
            );
            let old = check_robot(&robot, &links, &q, &scene, &settings).expect("check");
            let new =
                check_robot_compiled(&kin, &robot, &links, &q, &scene, &settings).expect("check");
            contacts += usize::from(!old.is_clear());
            assert_eq!(new, old, "{name} at {q:?}");
        }
    }
    // The scene is dense enough that both answers occur.
    assert!(
        contacts > 0 && contacts < 120,
        "{contacts} contacts in 120 checks"
    );
}
