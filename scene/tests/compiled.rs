//! The compiled-model cache: a joint- or pose-only change is applied in place and gives exactly
//! what a fresh compile of the same snapshot gives; a structure change compiles again.

use robosim_collision::robot::{CheckResult, CollisionSettings, check_robot};
use robosim_instance_space::{Snapshot, Store, Transaction};
use robosim_scene::{CompiledScene, Sync, build_library, joint_tx, load_from, pose};
use std::collections::HashSet;

fn cell() -> Store {
    let lib = build_library(&[]).expect("standard library");
    let mut m = Store::new();
    for tx in load_from(&lib, "surgical_positioner_cell").expect("scene") {
        m.apply(&tx).expect("valid");
    }
    m
}

/// Everything a user of the cache reads, for comparing two caches.
fn fingerprint(c: &CompiledScene) -> Vec<String> {
    let mut out = Vec::new();
    for r in c.robots() {
        out.push(format!(
            "{} q={:?} base={:?} allowed={:?}",
            r.name(),
            r.q,
            r.robot.base,
            r.solids.allowed
        ));
        let obs = c.obstacles(r, &HashSet::new());
        out.push(format!("obstacles {:?}", obs.names));
        for o in obs.scene.objects() {
            out.push(format!("{} {:?}", o.name, o.pose));
        }
        let check = check_robot(
            &r.robot,
            &r.solids,
            &r.q,
            &obs.scene,
            &CollisionSettings {
                all_contacts: true,
                ..CollisionSettings::default()
            },
        )
        .expect("check runs");
        out.push(format!("clear {}", matches!(check, CheckResult::Clear)));
    }
    let mut hit: Vec<_> = c.colliding_ids().into_iter().collect();
    hit.sort_unstable();
    out.push(format!("colliding {hit:?}"));
    out
}

#[test]
fn joint_and_pose_changes_update_in_place_and_match_a_fresh_compile() {
    let mut m = cell();
    let mut cache = CompiledScene::new();
    assert_eq!(cache.sync(&Snapshot::from_store(&m)), Sync::Compiled);
    let snap = Snapshot::from_store(&m);
    assert_eq!(cache.sync(&snap), Sync::Unchanged);
    let arm = cache.robot("positioner").expect("compiled").clone();
    // 30 joint steps toward the head, then the head moved: all in place.
    for k in 1..=30 {
        let q: Vec<f64> = arm.q.iter().map(|x| x + 0.02 * k as f64).collect();
        m.apply(&joint_tx(&arm.robot, &arm.links, &q))
            .expect("joint tx");
        assert_eq!(cache.sync(&Snapshot::from_store(&m)), Sync::Posed);
    }
    let snap = Snapshot::from_store(&m);
    let head = snap.find("head").expect("the head item");
    let mut moved = snap.poses()[head].pose;
    moved[3] -= 0.25;
    let mut tx = Transaction::new();
    tx.set_pose(snap.rec(head).id, moved);
    m.apply(&tx).expect("pose tx");
    let snap = Snapshot::from_store(&m);
    assert_eq!(cache.sync(&snap), Sync::Posed);
    assert_eq!(cache.stats().compiles, 1);
    assert_eq!(cache.stats().pose_updates, 31);
    assert_eq!(fingerprint(&cache), fingerprint(&CompiledScene::of(&snap)));
    let r = cache.robot("positioner").expect("compiled");
    assert!((r.q[0] - (arm.q[0] + 0.6)).abs() < 1e-12);
    // The head's solid moved with it.
    let head_solid = cache
        .objects()
        .iter()
        .find(|o| o.path.starts_with("surgical_positioner_cell/head/"))
        .expect("head solid");
    let want = pose::to_isometry(&snap.world_pose(head_solid.index));
    assert_eq!(head_solid.pose, want);
}

#[test]
fn a_structure_change_compiles_again() {
    let mut m = cell();
    let mut cache = CompiledScene::of(&Snapshot::from_store(&m));
    let link = cache.robot("positioner").expect("compiled").links[0];
    let mut tx = Transaction::new();
    tx.set_appearance(link, robosim_instance_space::Appearance::default());
    m.apply(&tx).expect("appearance tx");
    assert_eq!(cache.sync(&Snapshot::from_store(&m)), Sync::Compiled);
    assert_eq!(cache.stats().compiles, 2);
}

#[test]
fn unknown_and_broken_robots_say_why() {
    let m = cell();
    let cache = CompiledScene::of(&Snapshot::from_store(&m));
    let e = cache.robot("nobody").err().expect("unknown").to_string();
    assert!(
        e.contains("no robot named \"nobody\"") && e.contains("positioner"),
        "{e}"
    );
}

/// A link with a fixed joint record is refused with its name, not read as revolute (the old
/// bridge decoded every joint kind but prismatic as revolute).
#[test]
fn regression_fixed_joint_record_is_not_read_as_revolute() {
    use robosim_instance_space::{DhConvention, JointKind, Kind, Kinematics};
    let mut tx = Transaction::new();
    let r = tx.create(Kind::Robot, "arm", None);
    tx.set_kinematics(
        r,
        Some(Kinematics::Robot {
            convention: DhConvention::Standard,
            ik_family: 0,
            tool: robosim_instance_space::IDENTITY,
        }),
    );
    let l = tx.create(Kind::Link, "wrist", Some(r));
    tx.set_kinematics(
        l,
        Some(Kinematics::Joint {
            index: 0,
            joint: JointKind::Fixed,
            convention: DhConvention::Standard,
            a: 0.1,
            d: 0.0,
            alpha: 0.0,
            theta: 0.0,
            offset: 0.0,
            qlim: [0.0, 0.0],
        }),
    );
    let mut m = Store::new();
    m.apply(&tx).expect("valid");
    let cache = CompiledScene::of(&Snapshot::from_store(&m));
    assert!(cache.robots().is_empty());
    let e = cache.robot("arm").err().expect("refused").to_string();
    assert!(e.contains("wrist") && e.contains("fixed"), "{e}");
}

/// Issue #20 item 7 (`flat_geometry_is_a_surface_not_absent`): a zero-thickness plate (one
/// polygon) has no volume, so it makes no convex solid; it used to become "no collision body"
/// without a word (`.ok()`). It is now a triangle surface that collides: a plate cutting
/// through the positioner's base is a contact, and nothing is refused.
#[test]
fn flat_geometry_is_a_surface_that_collides_not_an_absent_body() {
    use robosim_instance_space::{GeometryInput, IDENTITY, Kind};
    let mut m = cell();
    let base = {
        let c = CompiledScene::of(&Snapshot::from_store(&m));
        let r = c.robot("positioner").expect("compiled");
        nalgebra::Vector3::new(
            r.robot.base[(0, 3)],
            r.robot.base[(1, 3)],
            r.robot.base[(2, 3)],
        )
    };
    let mut tx = Transaction::new();
    let plate = tx.create(Kind::Solid, "plate", None);
    tx.set_geometry(
        plate,
        Some(GeometryInput {
            vertices: vec![
                [-5.0, -5.0, 0.0],
                [5.0, -5.0, 0.0],
                [5.0, 5.0, 0.0],
                [-5.0, 5.0, 0.0],
            ],
            polygons: vec![vec![0, 1, 2, 3]],
        }),
    );
    let mut pose = IDENTITY;
    pose[3] = base.x;
    pose[7] = base.y;
    pose[11] = base.z + 0.05;
    tx.set_pose(plate, pose);
    m.apply(&tx).expect("a one-polygon plate is valid geometry");
    let c = CompiledScene::of(&Snapshot::from_store(&m));
    assert!(c.refused().is_empty(), "{:?}", c.refused());
    assert!(
        c.objects().iter().any(|o| o.path.ends_with("plate")),
        "the plate is a body"
    );
    let r = c.robot("positioner").expect("compiled");
    let obs = c.obstacles(r, &HashSet::new());
    assert!(obs.refused.is_empty());
    let check = check_robot(
        &r.robot,
        &r.solids,
        &r.q,
        &obs.scene,
        &CollisionSettings::default(),
    )
    .expect("check runs");
    assert!(
        matches!(check, CheckResult::Contact(_)),
        "the plate cuts the base: {check:?}"
    );
}

/// Issue 35 item 4: an instance whose origin record does not parse is refused by name, with
/// serde_json's error kept as the source (not flattened into text).
#[test]
fn an_unreadable_origin_record_keeps_the_json_error() {
    use std::error::Error as _;
    let mut m = Store::new();
    let mut tx = Transaction::new();
    let s = tx.create(robosim_instance_space::Kind::Scene, "cell", None);
    tx.set_origin(s, "{not json");
    m.apply(&tx).expect("valid");
    let e = robosim_scene::find_instance(&Snapshot::from_store(&m), "cell")
        .err()
        .expect("refused");
    let json = robosim_scene::Origin::from_record("{not json").expect_err("not json");
    assert_eq!(
        e.to_string(),
        format!("instance cell: unreadable origin record: {json}")
    );
    assert!(
        matches!(e, robosim_scene::SceneError::Origin { .. }),
        "{e:?}"
    );
    let cause = e.source().expect("the JSON error as the source");
    // shared (SceneError is Clone), so the source is the Arc around serde_json's error
    assert!(
        cause
            .downcast_ref::<std::sync::Arc<serde_json::Error>>()
            .is_some(),
        "{cause:?}"
    );
}
