//! Robots against scenes: CHECK, USE/DONTUSE, self-collision and its switch, allowed pairs,
//! MOVEJI stopping at the last safe step, and the continuous sweep's guarantee.

use nalgebra::{Isometry3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robosim_collision::ccd::{Sweep, SweepOptions, sweep_robot};
use robosim_collision::robot::{
    Body, CheckResult, CollisionSettings, LinkSolid, LinkSolids, Scene, check_robot, move_checked,
};
use robosim_collision::{Mode, Solid};
use robosim_kinematics::{Joint, Robot, builtin_robot};
use std::sync::Arc;

/// A planar 3R arm with 1 m links along x, each link a 1 × 0.1 × 0.1 box from its joint to the
/// next.
fn planar3() -> (Robot, LinkSolids) {
    let robot = Robot {
        joints: vec![
            Joint {
                a: 1.0,
                ..Joint::default()
            };
            3
        ],
        ..Robot::default()
    };
    let bar = Arc::new(Solid::cuboid(Vector3::new(1.0, 0.1, 0.1)).expect("bar"));
    let mut links = vec![None];
    for _ in 0..3 {
        links.push(Some(LinkSolid {
            solid: bar.clone(),
            offset: Isometry3::translation(-0.5, 0.0, 0.0),
        }));
    }
    (
        robot,
        LinkSolids {
            links,
            allowed: vec![],
        },
    )
}

#[test]
fn check_reports_link_and_object_and_respects_use_list() {
    let (robot, links) = planar3();
    let mut scene = Scene::new();
    let post = scene.add(
        "post",
        Arc::new(Solid::cylinder(0.1, 1.0, None).expect("post")),
        Isometry3::translation(2.5, 0.0, 0.0),
    );
    scene.add(
        "far",
        Arc::new(Solid::sphere(0.2, None).expect("ball")),
        Isometry3::translation(-5.0, 0.0, 0.0),
    );
    for mode in [Mode::BBox, Mode::Polygon, Mode::Exact] {
        let s = CollisionSettings {
            mode,
            ..CollisionSettings::default()
        };
        match check_robot(&robot, &links, &[0.0, 0.0, 0.0], &scene, &s).expect("check") {
            CheckResult::Contact(c) => {
                assert_eq!(c[0].a, Body::Link(3), "{mode:?}");
                assert_eq!(
                    c[0].b,
                    Body::Object {
                        index: post,
                        name: "post".into()
                    }
                );
            }
            other => panic!("{mode:?}: {other:?}"),
        }
        assert!(
            check_robot(&robot, &links, &[1.2, 0.0, 0.0], &scene, &s)
                .expect("check")
                .is_clear(),
            "{mode:?}"
        );
    }
    scene.dont_use(post);
    assert!(
        check_robot(
            &robot,
            &links,
            &[0.0, 0.0, 0.0],
            &scene,
            &CollisionSettings::default()
        )
        .expect("check")
        .is_clear()
    );
    scene.use_object(post);
    assert!(
        !check_robot(
            &robot,
            &links,
            &[0.0, 0.0, 0.0],
            &scene,
            &CollisionSettings::default()
        )
        .expect("check")
        .is_clear()
    );
}

#[test]
fn self_collision_skips_adjacent_links_obeys_its_switch_and_allowed_pairs() {
    let (robot, mut links) = planar3();
    let scene = Scene::new();
    // Straight: adjacent links overlap at their joints' ends but are never tested.
    assert!(
        check_robot(
            &robot,
            &links,
            &[0.0, 0.0, 0.0],
            &scene,
            &CollisionSettings::default()
        )
        .expect("check")
        .is_clear()
    );
    // Folded twice: link 3 lies back on link 1.
    let folded = [0.0, 3.0, 3.0];
    let on = CollisionSettings {
        all_contacts: true,
        ..CollisionSettings::default()
    };
    match check_robot(&robot, &links, &folded, &scene, &on).expect("check") {
        CheckResult::Contact(c) => {
            assert_eq!(c.len(), 1);
            assert_eq!(
                (c[0].a.clone(), c[0].b.clone()),
                (Body::Link(3), Body::Link(1))
            );
            assert!(c[0].signed_distance.expect("depth") < 0.0);
        }
        other => panic!("{other:?}"),
    }
    let off = CollisionSettings {
        self_collision: false,
        ..CollisionSettings::default()
    };
    assert!(
        check_robot(&robot, &links, &folded, &scene, &off)
            .expect("check")
            .is_clear()
    );
    links.allowed.push((3, 1));
    assert!(
        check_robot(&robot, &links, &folded, &scene, &on)
            .expect("check")
            .is_clear()
    );
}

#[test]
fn movej_stops_at_the_last_safe_step_and_names_the_pair() {
    let (robot, links) = planar3();
    let mut scene = Scene::new();
    scene.add(
        "wall",
        Arc::new(Solid::cuboid(Vector3::new(0.2, 2.0, 1.0)).expect("wall")),
        Isometry3::translation(0.0, 2.5, 0.0),
    );
    let (from, to) = ([-0.5, 0.0, 0.0], [2.0, 0.0, 0.0]);
    let s = CollisionSettings::default();
    let m = move_checked(&robot, &links, &from, &to, 25, &scene, &s).expect("move");
    assert!(!m.completed && m.steps_done > 0 && m.steps_done < 25);
    // The answer is the last safe step: it is clear, and the next one is not.
    assert!(
        check_robot(&robot, &links, &m.q, &scene, &s)
            .expect("check")
            .is_clear()
    );
    let k = m.steps_done + 1;
    let next: Vec<f64> = from
        .iter()
        .zip(&to)
        .map(|(a, b)| a + (b - a) * k as f64 / 25.0)
        .collect();
    assert!(
        !check_robot(&robot, &links, &next, &scene, &s)
            .expect("check")
            .is_clear()
    );
    match m.stopped_by {
        Some(CheckResult::Contact(c)) => assert_eq!(
            c[0].b,
            Body::Object {
                index: 0,
                name: "wall".into()
            }
        ),
        other => panic!("{other:?}"),
    }
    // C_SWITCH off: the move goes through.
    let off = CollisionSettings {
        enabled: false,
        ..s
    };
    assert!(
        move_checked(&robot, &links, &from, &to, 25, &scene, &off)
            .expect("move")
            .completed
    );
    // Bad input is refused with a typed error.
    assert!(move_checked(&robot, &links, &from, &[0.0, 0.0], 5, &scene, &s).is_err());
    assert!(move_checked(&robot, &links, &from, &to, 0, &scene, &s).is_err());
}

#[test]
fn sweep_clear_means_no_contact_along_the_path_and_contact_is_never_late() {
    let (robot, links) = planar3();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let opts = SweepOptions::default();
    let s = CollisionSettings {
        self_collision: false,
        ..CollisionSettings::default()
    };
    let (mut clears, mut contacts) = (0, 0);
    for _ in 0..60 {
        let mut scene = Scene::new();
        let r = rng.random_range(0.05..0.2);
        let p = Isometry3::translation(
            rng.random_range(-2.5..2.5),
            rng.random_range(-2.5..2.5),
            0.0,
        );
        scene.add("ball", Arc::new(Solid::sphere(r, None).expect("ball")), p);
        let q0: Vec<f64> = (0..3).map(|_| rng.random_range(-3.0..3.0)).collect();
        let q1: Vec<f64> = q0.iter().map(|q| q + rng.random_range(-1.5..1.5)).collect();
        if !check_robot(&robot, &links, &q0, &scene, &s)
            .expect("check")
            .is_clear()
        {
            continue;
        }
        let samples = |a: f64, b: f64| -> Option<f64> {
            (0..=400)
                .map(|i| a + (b - a) * i as f64 / 400.0)
                .find(|&t| {
                    let q: Vec<f64> = q0.iter().zip(&q1).map(|(x, y)| x + (y - x) * t).collect();
                    !check_robot(&robot, &links, &q, &scene, &s)
                        .expect("check")
                        .is_clear()
                })
        };
        match sweep_robot(&robot, &links, &q0, &q1, &scene, false, &opts).expect("sweep") {
            Sweep::Clear => {
                clears += 1;
                assert_eq!(
                    samples(0.0, 1.0),
                    None,
                    "sweep said clear, sampling found contact"
                );
            }
            Sweep::Contact { s: t, .. } => {
                contacts += 1;
                if let Some(first) = samples(0.0, 1.0) {
                    assert!(
                        t <= first + 1e-9,
                        "sweep contact at {t}, sampled contact already at {first}"
                    );
                }
            }
            Sweep::Unknown { reason, .. } => panic!("{reason}"),
        }
    }
    assert!(
        clears > 5 && contacts > 5,
        "{clears} clear, {contacts} contact"
    );
}

#[test]
fn puma_with_assumed_link_boxes_against_a_table() {
    let robot = builtin_robot("puma560").expect("puma");
    let links = LinkSolids::from_dh(&robot, 0.04).expect("links");
    assert_eq!(links.links.len(), 7);
    let mut scene = Scene::new();
    // A table top in front of the pedestal, its top 0.17 m below the shoulder (z = 0.672 m).
    scene.add(
        "table",
        Arc::new(Solid::cuboid(Vector3::new(1.0, 2.0, 0.05)).expect("table")),
        Isometry3::translation(0.8, 0.0, 0.475),
    );
    let s = CollisionSettings::default();
    // q = 0: upper arm level at shoulder height, forearm pointing up — clear of the table.
    assert!(
        check_robot(&robot, &links, &[0.0; 6], &scene, &s)
            .expect("check")
            .is_clear()
    );
    // Shoulder down 0.6 rad: the elbow dips to z ≈ 0.43 over the table.
    match check_robot(&robot, &links, &[0.0, -0.6, 0.0, 0.0, 0.0, 0.0], &scene, &s).expect("check")
    {
        CheckResult::Contact(c) => assert!(matches!(c[0].a, Body::Link(2..=4)), "{c:?}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn two_robots_meet_only_when_their_boxes_do() {
    use robosim_collision::robot::{RobotAt, check_robots};
    let (r1, links) = planar3();
    // The second arm stands 5 m away along x, facing the first (base turned by π).
    let base = Isometry3::new(
        Vector3::new(5.0, 0.0, 0.0),
        Vector3::new(0.0, 0.0, std::f64::consts::PI),
    );
    let r2 = Robot {
        base: base.to_homogeneous(),
        ..r1.clone()
    };
    let scene = Scene::new();
    let s = CollisionSettings::default();
    let apart = [1.5, 0.0, 0.0];
    let reach = [0.0, 0.0, 0.0];
    let both = |q1: &[f64], q2: &[f64]| {
        check_robots(
            &[
                RobotAt {
                    robot: &r1,
                    links: &links,
                    q: q1,
                },
                RobotAt {
                    robot: &r2,
                    links: &links,
                    q: q2,
                },
            ],
            &scene,
            &s,
        )
        .expect("check")
    };
    assert!(both(&apart, &apart).is_clear());
    // Both stretched towards each other: 3 m each over a 5 m gap — the tips overlap by 1 m.
    match both(&reach, &reach) {
        CheckResult::Contact(c) => {
            assert_eq!(c[0].a, Body::RobotLink { robot: 0, link: 3 });
            assert_eq!(c[0].b, Body::RobotLink { robot: 1, link: 3 });
        }
        other => panic!("{other:?}"),
    }
    assert!(both(&reach, &apart).is_clear());
}

/// Issue 37 item 2: the boolean-first check (mid-phase box test, certified boolean, depth only
/// for reported pairs) finds exactly the pairs that the full exact query on every link × object
/// pair finds in contact — no pair culled that touches, none invented — at random q of the
/// PUMA among rotated boxes, cylinders, cones and spheres (with facet counts that are not
/// multiples of 4, whose faceted boxes are smaller than the exact solids); and the answer with
/// `depth: None` names the same pairs, without depths.
#[test]
fn boolean_first_check_finds_exactly_the_pairs_exact_mode_finds() {
    let robot = builtin_robot("puma560").expect("puma");
    let links = LinkSolids::from_dh(&robot, 0.05).expect("links");
    let mut rng = ChaCha8Rng::seed_from_u64(3702);
    let mut scene = Scene::new();
    for i in 0..40 {
        let s = match i % 4 {
            0 => Solid::cuboid(Vector3::new(
                rng.random_range(0.05..0.4),
                rng.random_range(0.05..0.4),
                rng.random_range(0.05..0.4),
            )),
            1 => Solid::cylinder(
                rng.random_range(0.03..0.2),
                rng.random_range(0.1..0.5),
                Some(6),
            ),
            2 => Solid::cone(
                rng.random_range(0.03..0.2),
                rng.random_range(0.1..0.5),
                Some(7),
            ),
            _ => Solid::sphere(rng.random_range(0.03..0.2), Some(5)),
        }
        .expect("solid");
        let pose = Isometry3::new(
            Vector3::new(
                rng.random_range(-0.9..0.9),
                rng.random_range(-0.9..0.9),
                rng.random_range(-0.3..1.2),
            ),
            Vector3::new(
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
            ),
        );
        scene.add(format!("o{i}"), Arc::new(s), pose);
    }
    let with_depth = CollisionSettings {
        self_collision: false,
        all_contacts: true,
        ..CollisionSettings::default()
    };
    let boolean = CollisionSettings {
        depth: None,
        ..with_depth
    };
    let mut contacts_seen = 0;
    for _ in 0..150 {
        let q: Vec<f64> = robot
            .joints
            .iter()
            .map(|j| rng.random_range(j.qlim[0]..j.qlim[1]))
            .collect();
        let lp = robosim_collision::robot::link_poses(&robot, &links, &q);
        let mut expected = Vec::new();
        for (oi, o) in scene.objects().iter().enumerate() {
            for (j, (l, p)) in links.links.iter().zip(&lp).enumerate() {
                let (Some(l), Some(p)) = (l, p) else { continue };
                let r = robosim_collision::collide(&l.solid, p, &o.solid, &o.pose, Mode::Exact);
                assert!(r.intersects().is_some(), "{r:?}");
                if r.intersects() == Some(true) {
                    expected.push((j, oi));
                }
            }
        }
        expected.sort();
        let pairs = |r: &CheckResult| -> Vec<(usize, usize)> {
            let mut v: Vec<(usize, usize)> = match r {
                CheckResult::Contact(cs) => cs
                    .iter()
                    .map(|c| match (&c.a, &c.b) {
                        (Body::Link(j), Body::Object { index, .. }) => (*j, *index),
                        other => panic!("unexpected bodies {other:?}"),
                    })
                    .collect(),
                CheckResult::Clear => Vec::new(),
                CheckResult::Unknown { .. } => panic!("unknown: {r:?}"),
            };
            v.sort();
            v
        };
        let full = check_robot(&robot, &links, &q, &scene, &with_depth).expect("check");
        let bare = check_robot(&robot, &links, &q, &scene, &boolean).expect("check");
        assert_eq!(pairs(&full), expected, "q = {q:?}");
        assert_eq!(pairs(&bare), expected, "q = {q:?}");
        if let CheckResult::Contact(cs) = &bare {
            assert!(
                cs.iter()
                    .all(|c| c.signed_distance.is_none() && c.witness.is_none())
            );
        }
        if let CheckResult::Contact(cs) = &full {
            assert!(
                cs.iter()
                    .all(|c| c.signed_distance.is_some_and(|d| d <= 0.0))
            );
        }
        contacts_seen += expected.len();
    }
    assert!(
        contacts_seen > 20,
        "the scene is too sparse to test: {contacts_seen}"
    );
}
