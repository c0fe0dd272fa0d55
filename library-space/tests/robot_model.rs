//! One robot, two readers, one model: a URDF read by the importer
//! (`robosim_model::Model::from_imported`) and the same file declared `from_urdf` in the
//! Library Space (`RobotModel::model`) give the same geometry model (the same objects on the
//! same frames at the same placements) and the same collision answers — the solids of both
//! come from the one builder (`robosim_model::geometry::link_solids`).

use nalgebra::{Isometry3, Vector3};
use robosim_collision::exact::{ExactOptions, collide};
use robosim_collision::robot::isometry_from_matrix;
use robosim_collision::{PairResult, Solid};
use robosim_kinematics::fk::link_frames;
use robosim_library::{Evaluated, Library, Params};
use robosim_model::{Model, Role, Shape};
use std::path::{Path, PathBuf};

const SMALL: &str = r#"<?xml version="1.0"?>
<robot name="small">
  <material name="orange"><color rgba="1 0.5 0 1"/></material>
  <link name="base">
    <collision><origin xyz="0 0 0.05"/><geometry><box size="0.4 0.2 0.1"/></geometry></collision>
  </link>
  <link name="upper">
    <visual><geometry><box size="1 1 1"/></geometry><material name="orange"/></visual>
    <collision><origin xyz="0 0 0.25"/><geometry><cylinder radius="0.05" length="0.5"/></geometry></collision>
    <collision><origin xyz="0.05 0 0.5" rpy="0 0.3 0"/><geometry><box size="0.1 0.1 0.2"/></geometry></collision>
  </link>
  <link name="hand">
    <collision><geometry><sphere radius="0.08"/></geometry></collision>
  </link>
  <link name="finger">
    <collision><origin xyz="0 0 0.04"/><geometry><box size="0.02 0.02 0.08"/></geometry></collision>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="10" velocity="1"/>
  </joint>
  <joint name="wrist" type="continuous">
    <parent link="upper"/><child link="hand"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="finger_fix" type="fixed">
    <parent link="hand"/><child link="finger"/>
    <origin xyz="0.06 0 0.05" rpy="0.2 0 0"/>
  </joint>
</robot>
"#;

fn panda_urdf() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/urdf/panda.urdf")
}

/// The robot `name` of a library declaring `rsl` (written beside `urdf`'s folder).
fn library_model(dir: &Path, rsl: &str, name: &str) -> Model {
    let path = dir.join("robots.rsl");
    std::fs::write(&path, rsl).expect("write");
    let lib = Library::load(&path).expect("loads");
    match lib.evaluate(name, &Params::new()).expect("evaluates") {
        Evaluated::Robot(r) => r.model(),
        other => panic!("{name} is not a robot: {other:?}"),
    }
}

/// Round primitives without their facet counts (the library states its own; the importer
/// leaves the collision crate's default, which the exact distances do not depend on).
fn without_facets(s: &Shape) -> Shape {
    match s.clone() {
        Shape::Cylinder { radius, length, .. } => Shape::Cylinder {
            radius,
            length,
            facets: None,
        },
        Shape::Sphere { radius, .. } => Shape::Sphere {
            radius,
            facets: None,
        },
        Shape::Cone { radius, height, .. } => Shape::Cone {
            radius,
            height,
            facets: None,
        },
        other => other,
    }
}

/// The exact distance (m) from each link solid at q to a small probe sphere at `at` (`None`
/// where the probe touches the link), base first; `None` for links without a solid too,
/// marked apart by the outer `Option`.
fn distances(m: &Model, q: &[f64], at: Vector3<f64>) -> Vec<Option<Option<f64>>> {
    let ls = m.collision_solids().expect("collision solids");
    let frames = link_frames(&m.robot, q);
    let probe = Solid::sphere(0.01, None).expect("probe");
    let probe_at = Isometry3::translation(at.x, at.y, at.z);
    ls.links
        .iter()
        .enumerate()
        .map(|(j, l)| {
            l.as_ref().map(|l| {
                let pose = isometry_from_matrix(&frames[j]) * l.offset;
                match collide(&l.solid, &pose, &probe, &probe_at, ExactOptions::default()) {
                    PairResult::Clear {
                        distance: Some(d), ..
                    } => Some(d),
                    PairResult::Clear { distance: None, .. } => panic!("no distance"),
                    _ => None,
                }
            })
        })
        .collect()
}

/// Both models give the same answer at every q of `qs` for probes on a grid around the robot:
/// the same links touched, distances equal within `tol` m. Returns the largest difference.
fn same_answers(a: &Model, b: &Model, qs: &[Vec<f64>], half: f64, tol: f64) -> f64 {
    let mut worst: f64 = 0.0;
    let mut touched = 0;
    for q in qs {
        for i in 0..5 {
            for j in 0..5 {
                for k in 0..5 {
                    let s = |n: usize| -half + 2.0 * half * n as f64 / 4.0;
                    let at = Vector3::new(s(i), s(j), s(k) + half);
                    let (da, db) = (distances(a, q, at), distances(b, q, at));
                    assert_eq!(da.len(), db.len());
                    for (x, y) in da.iter().zip(&db) {
                        match (x, y) {
                            (Some(Some(x)), Some(Some(y))) => {
                                worst = worst.max((x - y).abs());
                                assert!((x - y).abs() <= tol, "q {q:?} at {at}: {x} vs {y}");
                            }
                            (Some(None), Some(None)) => touched += 1,
                            (None, None) => {}
                            _ => panic!("q {q:?} at {at}: {x:?} vs {y:?}"),
                        }
                    }
                }
            }
        }
    }
    assert!(
        touched > 0,
        "the grid touches some link (the test can fail)"
    );
    worst
}

#[test]
fn a_urdf_read_by_the_importer_and_by_the_library_is_one_geometry_model() {
    let tmp = tempfile::tempdir().expect("tmp");
    let urdf = tmp.path().join("small.urdf");
    std::fs::write(&urdf, SMALL).expect("write");
    let imported = Model::from(&robosim_urdf::import_urdf(&urdf, None).expect("imports"));
    let library = library_model(
        tmp.path(),
        "robot small from_urdf \"small.urdf\" { facets: 16 }\n",
        "small",
    );
    assert_eq!(imported.link_names, library.link_names);
    assert_eq!(imported.robot.joints, library.robot.joints);
    // The library draws what it collides: compare the collision objects.
    let coll = |m: &Model| -> Vec<(String, usize, Shape)> {
        m.geometry
            .of(Role::Collision)
            .map(|o| (o.name.clone(), o.frame, without_facets(&o.shape)))
            .collect()
    };
    assert_eq!(coll(&imported), coll(&library));
    assert_eq!(coll(&imported).len(), 5);
    for (a, b) in imported
        .geometry
        .of(Role::Collision)
        .zip(library.geometry.of(Role::Collision))
    {
        assert!(
            (a.placement - b.placement).abs().max() < 1e-15,
            "{}: {} vs {}",
            a.name,
            a.placement,
            b.placement
        );
    }
    // The finger is lumped into the hand (a fixed joint): frame 2, placed by the joint.
    let finger = (imported.geometry.objects.iter())
        .find(|o| o.name == "finger/collision0")
        .expect("finger");
    assert_eq!(finger.frame, 2);
    let qs = vec![vec![0.0, 0.0], vec![0.7, -1.2], vec![-1.3, 2.5]];
    let worst = same_answers(&imported, &library, &qs, 0.6, 1e-12);
    eprintln!("small robot, importer vs library: worst distance difference {worst:e} m");
}

#[test]
fn the_panda_read_by_the_importer_and_by_the_library_gives_the_same_collision_answers() {
    let tmp = tempfile::tempdir().expect("tmp");
    let imported = Model::from(
        &robosim_urdf::import_urdf(&panda_urdf(), Some("panda_hand")).expect("imports"),
    );
    let library = library_model(
        tmp.path(),
        &format!(
            "robot panda from_urdf \"{}\" {{ tip: \"panda_hand\" }}\n",
            panda_urdf().display()
        ),
        "panda",
    );
    // The same objects on the same frames: the importer names the mesh files, the library
    // holds their hulls.
    let names = |m: &Model| -> Vec<(String, usize)> {
        m.geometry
            .of(Role::Collision)
            .map(|o| (o.name.clone(), o.frame))
            .collect()
    };
    assert_eq!(names(&imported), names(&library));
    // The arm's links are mesh files (the fingers' may be primitives).
    let meshes =
        (imported.geometry.of(Role::Collision)).filter(|o| matches!(o.shape, Shape::Mesh(_)));
    assert!(meshes.count() >= 8);
    let qs = vec![vec![0.0; 7], vec![0.3, -0.4, 0.5, -1.6, 0.2, 1.1, -0.7]];
    let worst = same_answers(&imported, &library, &qs, 0.8, 1e-9);
    eprintln!("panda, importer vs library: worst distance difference {worst:e} m");
}
