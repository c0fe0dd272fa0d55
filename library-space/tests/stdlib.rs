//! The standard library against outside references (Robotics Toolbox for Python, see
//! testdata/library/README.md) and the seed's descriptions.

use nalgebra::{Matrix4, Vector3, Vector4};
use robosim_kinematics::{JointType, fk};
use robosim_library::{
    CollisionMode, DeclKind, Evaluated, Library, Params, RobotModel, SceneModel,
};
use serde_json::Value;
use std::sync::OnceLock;

fn lib() -> &'static Library {
    static LIB: OnceLock<Library> = OnceLock::new();
    LIB.get_or_init(|| {
        Library::standard().unwrap_or_else(|e| panic!("standard library fails to load:\n{e}"))
    })
}

fn robot(name: &str) -> RobotModel {
    match lib().evaluate(name, &Params::new()) {
        Ok(Evaluated::Robot(r)) => r,
        other => panic!("{name}: {other:?}"),
    }
}

fn scene(name: &str, p: &Params) -> SceneModel {
    match lib().evaluate(name, p) {
        Ok(Evaluated::Scene(s)) => s,
        other => panic!("{name}: {other:?}"),
    }
}

fn mat4(v: &Value) -> Matrix4<f64> {
    let mut m = Matrix4::zeros();
    for r in 0..4 {
        for c in 0..4 {
            m[(r, c)] = v[r][c].as_f64().expect("number");
        }
    }
    m
}

fn f(v: &Value) -> f64 {
    v.as_f64().expect("number")
}

#[test]
fn robots_match_the_robotics_toolbox_parameters_and_forward_kinematics() {
    let text = include_str!("../../testdata/library/rtb_reference.json");
    let reference: Value = serde_json::from_str(text).expect("reference JSON");
    for (name, r) in reference["robots"].as_object().expect("robots") {
        let ours = robot(name);
        let links = r["links"].as_array().expect("links");
        assert_eq!(ours.robot.dof(), links.len(), "{name}");
        for (j, (l, joint)) in links.iter().zip(&ours.robot.joints).enumerate() {
            let prismatic = l["prismatic"].as_bool().expect("bool");
            assert_eq!(
                joint.joint_type == JointType::Prismatic,
                prismatic,
                "{name} joint {j}"
            );
            let close = |a: f64, b: f64, what: &str| {
                assert!(
                    (a - b).abs() < 1e-9 * b.abs().max(1.0),
                    "{name} joint {j} {what}: {a} vs {b}"
                )
            };
            close(joint.a, f(&l["a"]), "a");
            close(joint.alpha, f(&l["alpha"]), "alpha");
            close(joint.d, f(&l["d"]), "d");
            close(joint.offset, f(&l["offset"]), "offset");
            if prismatic {
                close(joint.theta, f(&l["theta"]), "theta");
            }
            // limits are written in degrees in some files: equal to 1e-6 rad
            assert!(
                (joint.qlim[0] - f(&l["qlim"][0])).abs() < 2e-5
                    && (joint.qlim[1] - f(&l["qlim"][1])).abs() < 2e-5,
                "{name} joint {j} qlim {:?}",
                joint.qlim
            );
            close(joint.mass, f(&l["mass"]), "mass");
            for k in 0..3 {
                close(joint.com[k], f(&l["com"][k]), "com");
                for c in 0..3 {
                    close(joint.inertia[(k, c)], f(&l["inertia"][k][c]), "inertia");
                }
            }
            close(joint.motor_inertia, f(&l["motor_inertia"]), "motor inertia");
            if name == "puma560" {
                close(joint.viscous, f(&l["viscous"]), "viscous friction");
            }
        }
        for s in r["fk"].as_array().expect("fk") {
            let q: Vec<f64> = s["q"].as_array().expect("q").iter().map(f).collect();
            let pose = fk::forward(&ours.robot, &q);
            let err = (pose - mat4(&s["pose"])).abs().max();
            assert!(err < 1e-9, "{name} q={q:?}: pose differs by {err}");
        }
    }
}

#[test]
fn every_standard_robot_is_valid_with_closed_link_solids() {
    for d in lib().declarations() {
        if d.kind != DeclKind::Robot {
            continue;
        }
        let r = robot(&d.name);
        r.robot.validate().expect("valid robot");
        assert_eq!(r.frames.len(), r.robot.dof() + 1, "{}", d.name);
        assert_eq!(r.link_names.len(), r.robot.dof());
        let solids: usize = r.frames.iter().map(Vec::len).sum();
        assert!(solids > 0, "{} has no solids", d.name);
        for frame in &r.frames {
            for p in frame {
                assert!(p.polyhedron.is_closed(), "{} {}", d.name, p.name);
                assert!(p.colour.is_some(), "{} {} has no colour", d.name, p.name);
            }
        }
    }
}

#[test]
fn names_required_by_the_issue_exist() {
    let names: Vec<String> = lib().declarations().into_iter().map(|d| d.name).collect();
    for key in ["puma", "stanford", "surgical", "weld", "station"] {
        assert!(
            names.iter().any(|n| n.contains(key)),
            "no declaration containing `{key}`"
        );
    }
}

#[test]
fn space_station_has_the_sub_models_of_section_4_1() {
    let s = scene("space_station", &Params::new());
    assert_eq!(s.solids.len(), 1, "the middle truss assembly");
    let middle = &s.solids[0].solid;
    assert!(
        middle
            .parts
            .iter()
            .filter(|p| p.name.starts_with("truss/"))
            .count()
            >= 12 * 12,
        "12 bays of 12 beams"
    );
    assert!(
        middle.parts.iter().any(|p| p.name.starts_with("lab"))
            && middle.parts.iter().any(|p| p.name.starts_with("hab"))
    );
    assert_eq!(
        middle
            .parts
            .iter()
            .filter(|p| p.name.starts_with("antenna"))
            .count(),
        4,
        "2 antennas, mast + dish"
    );
    let dofs: Vec<(String, usize)> = s
        .robots
        .iter()
        .map(|r| (r.name.clone(), r.model.robot.dof()))
        .collect();
    assert_eq!(
        dofs,
        vec![
            ("port_outboard".into(), 2),
            ("starboard_outboard".into(), 2),
            ("port_solar".into(), 1),
            ("starboard_solar".into(), 1),
            ("servicer".into(), 6)
        ]
    );
    let servicer = &s.robots[4].model.robot;
    assert_eq!(servicer.joints[0].joint_type, JointType::Prismatic);
    assert!(
        servicer.joints[1..]
            .iter()
            .all(|j| j.joint_type == JointType::Revolute)
    );
    // the servicer's rail runs along the truss (station y): moving q1 moves the carriage along y
    let mut q = s.robots[4].q.clone();
    let p0 = fk::link_frames(servicer, &q)[1] * Vector4::new(0.0, 0.0, 0.0, 1.0);
    q[0] += 5.0;
    let p1 = fk::link_frames(servicer, &q)[1] * Vector4::new(0.0, 0.0, 0.0, 1.0);
    assert!(((p1 - p0).xyz() - Vector3::new(0.0, 5.0, 0.0)).norm() < 1e-12);
    assert!(
        s.effects
            .dynamics
            .is_some_and(|d| d.gravity == Some([0.0; 3]))
    );
    assert_eq!(
        s.effects.collision.map(|c| c.mode),
        Some(CollisionMode::BBox)
    );
    // manipulators have mass properties computed from density
    assert!(
        s.robots
            .iter()
            .all(|r| r.model.robot.joints.iter().all(|j| j.mass > 0.0))
    );
}

#[test]
fn space_station_parameters_turn_the_assemblies() {
    let s = scene(
        "space_station",
        &Params::new()
            .expr("panel_angle", "30 deg")
            .si("servicer_position", 10.0),
    );
    assert!((s.robots[0].q[1] - 30f64.to_radians()).abs() < 1e-15);
    assert_eq!(s.robots[4].q[0], 10.0);
}

#[test]
fn surgical_positioner_link_lengths_are_parameters() {
    let info = lib().params("surgical_positioner").expect("params");
    let upper = info
        .iter()
        .find(|p| p.name == "upper_arm")
        .expect("upper_arm");
    assert_eq!((upper.unit.as_str(), upper.default_si), ("m", Some(0.22)));
    let longer = match lib().evaluate(
        "surgical_positioner",
        &Params::new().expr("upper_arm", "30 cm"),
    ) {
        Ok(Evaluated::Robot(r)) => r,
        other => panic!("{other:?}"),
    };
    assert!((longer.robot.joints[1].a - 0.30).abs() < 1e-15);
    assert_eq!(longer.ik.as_deref(), Some("spherical_wrist"));
    // PUMA-like: the wrist axes meet in a point (a4 = a5 = a6 = 0, d5 = 0)
    assert!(longer.robot.joints[3..].iter().all(|j| j.a == 0.0) && longer.robot.joints[4].d == 0.0);
    let cell = scene("surgical_positioner_cell", &Params::new());
    assert_eq!(cell.effects.encoder.map(|e| e.bits), Some(12));
    assert_eq!(cell.solids[0].name, "head");
    // the head is a cylinder of radius 20 cm, its axis turned onto y
    let head = &cell.solids[0].solid.parts[0];
    assert!((head.polyhedron.bbox.half.x - 0.20).abs() < 1e-12);
}

#[test]
fn welding_cell_positioner_table_is_level_at_zero_and_tilts() {
    let s = scene("downhand_welding_cell", &Params::new());
    assert_eq!(
        s.robots
            .iter()
            .map(|r| r.model.robot.dof())
            .collect::<Vec<_>>(),
        vec![2, 6]
    );
    let pos = &s.robots[0].model.robot;
    let t = fk::forward(pos, &[0.0, 0.0]);
    assert!(
        (t.fixed_view::<3, 1>(0, 2) - Vector3::z()).norm() < 1e-12,
        "table normal {t}"
    );
    assert!(
        (t[(2, 3)] - 0.95).abs() < 1e-12,
        "table at axis height + 0.15 m"
    );
    let tilted = fk::forward(pos, &[30f64.to_radians(), 0.0]);
    assert!((tilted[(2, 2)] - 30f64.to_radians().cos()).abs() < 1e-12);
    assert!(s.effects.collision.is_some_and(|c| c.self_collision));
}

#[test]
fn evaluating_with_a_facet_override_changes_only_round_solids() {
    let coarse = robosim_library::EvalOptions {
        facets: Some(8),
        max_polygons: None,
    };
    let fine = robosim_library::EvalOptions {
        facets: Some(64),
        max_polygons: None,
    };
    let count = |o| match lib().evaluate_with("puma560", &Params::new(), o) {
        Ok(Evaluated::Robot(r)) => r
            .frames
            .iter()
            .flatten()
            .map(|p| p.polyhedron.polygons.len())
            .sum::<usize>(),
        other => panic!("{other:?}"),
    };
    assert!(count(&fine) > 4 * count(&coarse) / 2);
}

#[test]
fn posed_solids_put_the_station_together() {
    let s = scene("space_station", &Params::new());
    let posed = s.posed_solids();
    let total: usize = s.solids.iter().map(|i| i.solid.parts.len()).sum::<usize>()
        + s.robots
            .iter()
            .map(|r| r.model.frames.iter().map(Vec::len).sum::<usize>())
            .sum::<usize>();
    assert_eq!(posed.len(), total);
    // the port outboard truss starts where the middle truss ends (y = 30 m) and runs outward
    let port: Vec<f64> = posed
        .iter()
        .filter(|p| p.path.0 == "port_outboard" && p.path.2.starts_with("truss/"))
        .map(|p| p.world[(1, 3)])
        .collect();
    assert!(!port.is_empty());
    let (lo, hi) = port
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &y| (a.min(y), b.max(y)));
    assert!(
        lo > 29.0 && hi < 61.0 && hi > 55.0,
        "port truss spans y in [{lo}, {hi}]"
    );
}

#[test]
fn changing_one_scene_parameter_changes_only_the_items_it_reaches() {
    let old = scene("space_station", &Params::new());
    let new = scene(
        "space_station",
        &Params::new().si("servicer_position", 12.0),
    );
    let c = old.changes_to(&new);
    assert_eq!(c.robots, vec!["servicer"]);
    assert!(c.solids.is_empty() && c.added.is_empty() && c.removed.is_empty() && !c.effects);
    let turned = scene(
        "space_station",
        &Params::new().expr("panel_angle", "15 deg"),
    );
    assert_eq!(
        old.changes_to(&turned).robots,
        vec!["port_outboard", "starboard_outboard"]
    );
    assert!(old.changes_to(&old).is_empty());
    assert_eq!(
        old.robots[4].declaration.as_deref(),
        Some("station_servicer")
    );
}

#[test]
fn declared_ik_families_match_the_geometry() {
    assert_eq!(robot("puma560").ik.as_deref(), Some("spherical_wrist"));
    assert_eq!(robot("stanford").ik.as_deref(), Some("rrp_spherical_wrist"));
    assert_eq!(robot("panda").ik, None, "7 joints: no closed form");
    // a wrong declaration is refused where it is written
    let src = "robot r {\n  ik: spherical_wrist\n  link a {\n    joint: revolute\n  }\n}\n";
    let e = Library::from_source("ik.rsl", src).expect_err("wrong family");
    assert_eq!(e.kind, robosim_library::ErrorKind::OutOfRange);
    assert_eq!((e.location.line, e.location.column), (2, 7));
    assert_eq!(
        e.message,
        "robot `r` declares `ik: spherical_wrist`, but its geometry is `general` (1 joints; the closed forms are for 6)"
    );
}
