//! A URDF robot through the Instance Space (`robosim import urdf`, `robosim render FILE.urdf`):
//! the objects the file interface writes must be the robot Pinocchio reads from the same file —
//! read back through the records, the scene compiler and the kinematics and dynamics cores — and
//! its geometry must be there, drawn and collided as the URDF says.

use crate::reference;

use nalgebra::DMatrix;
use reference::{floats, matrix, rel};
use robosim_file_io::urdf_import::import_urdf_tree;
use robosim_file_io::urdf_session::{UrdfPlacement, urdf_store, urdf_tx};
use robosim_instance_space::{Kind, Snapshot, Store, Transaction};
use robosim_kinematics::fk;
use robosim_kinematics::jacobian::{Frame, link_jacobian};
use robosim_scene::CompiledScene;
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    reference::testdata().join("urdf")
}

/// The Panda of testdata/urdf without its `<visual>`s (their meshes are Collada), its collision
/// meshes named by absolute path, in `tmp`.
fn collision_only_panda(tmp: &Path) -> PathBuf {
    let text = std::fs::read_to_string(dir().join("panda.urdf")).expect("panda.urdf");
    let mut out = String::new();
    let mut rest = text.as_str();
    while let Some(start) = rest.find("<visual>") {
        out.push_str(&rest[..start]);
        let end = rest[start..].find("</visual>").expect("closed") + start + "</visual>".len();
        // Keep the line count, so that lines in errors still point at the original's.
        out.push_str(&"\n".repeat(rest[start..end].matches('\n').count()));
        rest = &rest[end..];
    }
    out.push_str(rest);
    let root = dir().join("example-robot-data");
    let out = out.replace(
        "package://example-robot-data/",
        &format!("file://{}/", root.display()),
    );
    let path = tmp.join("panda_collision_only.urdf");
    std::fs::write(&path, out).expect("write");
    path
}

/// The Panda imported into a local Instance Space and compiled back (records → view → scene
/// compiler → kinematics model) is the robot Pinocchio 4.1 reads from panda.urdf: every link
/// pose and both Jacobians ≤ 1e-12, RNEA, mass matrix, ABA and gravity ≤ 1e-10 relative, at the
/// reference's 10 states (testdata/urdf/pinocchio_reference.json, "trees").
#[test]
fn a_urdf_tree_through_the_instance_space_matches_pinocchio() {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = collision_only_panda(tmp.path());
    let store = urdf_store(&path).expect("imports into a local model");
    let snap = Snapshot::from_store(&store);
    let scene = CompiledScene::of(&snap);
    assert!(scene.failed().is_empty(), "{:?}", scene.failed());
    let robot = scene.robot("panda").expect("compiled").robot.clone();
    let reference: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir().join("pinocchio_reference.json")).expect("reference"),
    )
    .expect("JSON");
    let r = &reference["trees"]["panda"];
    let parents: Vec<usize> = floats(&r["parents"]).iter().map(|&p| p as usize).collect();
    assert_eq!(
        robot.parents, parents,
        "the tree survives the Instance Space"
    );
    let n = robot.dof();
    assert_eq!(n, 9);
    // Link objects are named after the joints' child links, in q order.
    let view = snap.robot("panda").expect("view");
    let names: Vec<&str> = view.joints.iter().map(|j| snap.name(j.index)).collect();
    let links: Vec<String> = r["links"]
        .as_array()
        .expect("links")
        .iter()
        .map(|l| l.as_str().expect("name").to_owned())
        .collect();
    assert_eq!(names, links);
    let model = robosim_dynamics::Model::new(&robot).expect("dynamics model");
    let mut data = robosim_dynamics::Data::new(&model);
    let mut worst = [0.0_f64; 2];
    for s in r["samples"].as_array().expect("samples") {
        let q = floats(&s["q"]);
        let frames = fk::link_frames(&robot, &q);
        for (k, l) in s["links"].as_array().expect("links").iter().enumerate() {
            let ours = DMatrix::from_column_slice(4, 4, frames[k + 1].as_slice());
            worst[0] = worst[0].max((ours - matrix(&l["pose"])).abs().max());
            for (frame, key) in [(Frame::Base, "jacobian"), (Frame::Tool, "jacobian_tool")] {
                let (_, j) = link_jacobian(&robot, &q, k + 1, frame);
                let ours = DMatrix::from_column_slice(6, n, j.as_slice());
                worst[1] = worst[1].max((ours - matrix(&l[key])).abs().max());
            }
        }
        let (qd, qdd, tau) = (floats(&s["qd"]), floats(&s["qdd"]), floats(&s["tau"]));
        let t = robosim_dynamics::rnea(&model, &mut data, &q, &qd, &qdd).expect("rnea");
        let e_rnea = rel(t.as_slice(), &floats(&s["rnea"]));
        let m = robosim_dynamics::crba(&model, &mut data, &q).expect("crba");
        let e_m = rel(
            m.as_slice(),
            matrix(&s["mass_matrix"]).transpose().as_slice(),
        );
        let a = robosim_dynamics::aba(&model, &mut data, &q, &qd, &tau).expect("aba");
        let e_aba = rel(a.as_slice(), &floats(&s["aba"]));
        let g = robosim_dynamics::gravity(&model, &mut data, &q).expect("gravity");
        let e_g = rel(g.as_slice(), &floats(&s["gravity"]));
        assert!(
            e_rnea <= 1e-10 && e_m <= 1e-10 && e_aba <= 1e-10 && e_g <= 1e-10,
            "dynamics at {q:?}: rnea {e_rnea:e}, M {e_m:e}, aba {e_aba:e}, g {e_g:e}"
        );
    }
    assert!(worst[0] <= 1e-12, "link poses: {:e}", worst[0]);
    assert!(worst[1] <= 1e-12, "Jacobians: {:e}", worst[1]);
    // The Instance Space's link poses at q = 0 are the link frames (relative to the robot).
    let zero = fk::link_frames(&robot, &vec![0.0; n]);
    for (k, j) in view.joints.iter().enumerate() {
        let p = robosim_scene::pose::to_matrix(&snap.poses()[j.index].pose);
        assert!(
            (p - zero[k + 1]).abs().max() <= 1e-15,
            "link {k} pose at q = 0"
        );
    }
}

/// Every `<collision>` is a solid under the body it is rigid with; without visuals the solids
/// are what is drawn; the robot collides with a box placed on its link 4 and not with one far
/// away, and is free of itself at q = 0 (the tree's parent links are allowed pairs).
#[test]
fn a_urdf_robots_collision_shapes_are_solids_that_collide() {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = collision_only_panda(tmp.path());
    let u = import_urdf_tree(&path).expect("imports");
    let (visuals, collisions, _) = u.geometry.counts();
    assert_eq!(visuals, 0);
    let mut store = Store::default();
    let mut tx = Transaction::new();
    tx.create(Kind::Scene, "lab", None);
    store.apply(&tx).expect("scene");
    let lab = Snapshot::from_store(&store).objects()[0].id;
    let mut at = robosim_instance_space::IDENTITY;
    at[3] = 1.0;
    let imp = urdf_tx(
        &u,
        &UrdfPlacement {
            name: "arm".into(),
            pose: at,
            parent: Some(lab),
            visuals: true,
            mimic: false,
        },
    )
    .expect("transaction");
    assert_eq!((imp.visuals, imp.solids, imp.joints), (0, collisions, 9));
    assert!(imp.triangles > 1000, "the collision STLs were read");
    store.apply(&imp.tx).expect("the keeper's checks pass");
    let snap = Snapshot::from_store(&store);
    let solids: Vec<usize> = (0..snap.len())
        .filter(|&i| snap.object(i).kind() == Some(Kind::Solid))
        .collect();
    assert_eq!(solids.len(), collisions);
    for &i in &solids {
        assert_eq!(snap.rec(i).color[3], 1.0, "{} is drawn", snap.name(i));
    }
    // link4's collision solid hangs from link4's link object.
    let l4 = snap.find("panda_link4").expect("link 4");
    let c4 = snap.find("panda_link4-collision0").expect("its solid");
    assert_eq!(snap.rec(c4).parent, snap.rec(l4).id);
    let scene = CompiledScene::of(&snap);
    let arm = scene.robot("arm").expect("compiled");
    let settings = robosim_collision::robot::CollisionSettings {
        all_contacts: true,
        self_collision: false,
        ..Default::default()
    };
    let q = vec![0.0; 9];
    let free = robosim_collision::robot::check_robot(
        &arm.robot,
        &arm.solids,
        &q,
        &robosim_collision::robot::Scene::new(),
        &robosim_collision::robot::CollisionSettings {
            self_collision: true,
            ..settings
        },
    )
    .expect("checks");
    assert!(
        matches!(free, robosim_collision::robot::CheckResult::Clear),
        "self-collision at q = 0: {free:?}"
    );
    // A 10 cm box at link 4's origin (world), and one 3 m away.
    let frame4 = snap.world_pose(l4);
    let mut obstacles = robosim_collision::robot::Scene::new();
    let cube = std::sync::Arc::new(
        robosim_collision::Solid::cuboid(nalgebra::Vector3::new(0.1, 0.1, 0.1)).expect("cube"),
    );
    let at4 = nalgebra::Isometry3::translation(frame4[3], frame4[7], frame4[11]);
    obstacles.add("box", cube.clone(), at4);
    let hit =
        robosim_collision::robot::check_robot(&arm.robot, &arm.solids, &q, &obstacles, &settings)
            .expect("checks");
    assert!(
        matches!(hit, robosim_collision::robot::CheckResult::Contact(_)),
        "a box on link 4: {hit:?}"
    );
    let mut far = robosim_collision::robot::Scene::new();
    far.add("far", cube, nalgebra::Isometry3::translation(4.0, 0.0, 0.5));
    let clear = robosim_collision::robot::check_robot(&arm.robot, &arm.solids, &q, &far, &settings)
        .expect("checks");
    assert!(matches!(
        clear,
        robosim_collision::robot::CheckResult::Clear
    ));
}

/// A mesh that is not there fails the import with the file, line and element, before anything
/// is written (FK and dynamics of the same file still work: they need no mesh).
#[test]
fn a_missing_mesh_fails_the_import_and_names_where() {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = collision_only_panda(tmp.path());
    let text = std::fs::read_to_string(&path)
        .expect("read")
        .replace("collision/link3.stl", "collision/link3_gone.stl");
    std::fs::write(&path, &text).expect("write");
    let line = text
        .lines()
        .position(|l| l.contains("link3_gone.stl"))
        .expect("there")
        + 1;
    assert!(import_urdf_tree(&path).is_ok(), "the model needs no mesh");
    let e = urdf_store(&path).expect_err("geometry needs the mesh");
    let msg = e.to_string();
    assert!(
        msg.contains(&format!("panda_collision_only.urdf:{line}")),
        "names file and line: {msg}"
    );
    assert!(msg.contains("link3_gone.stl"), "names the mesh: {msg}");
    assert!(msg.contains("<mesh>"), "names the element: {msg}");
}

/// A mesh whose triangles all have (next to) no area makes no geometry: the import fails with
/// the URDF's file, line and element and the mesh importer's reason, kept as the error's source
/// (`UrdfTxError::MeshGeometry`), and the message is the one it was when the reason was a string
/// (`MeshProblem::Shape`).
#[test]
fn a_mesh_without_area_fails_the_import_with_its_cause_kept() {
    use robosim_file_io::FileError;
    use robosim_file_io::urdf_geometry::MeshProblem;
    use robosim_file_io::urdf_import::{UrdfError, UrdfErrorKind};
    use robosim_file_io::urdf_session::UrdfTxError;
    let tmp = tempfile::tempdir().expect("tmp");
    std::fs::write(
        tmp.path().join("flat.stl"),
        "solid flat\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0.5 1e-12 0\n  endloop\n endfacet\nendsolid flat\n",
    )
    .expect("stl");
    let text = r#"<robot name="flat">
  <link name="base"/>
  <link name="arm">
    <visual><geometry><mesh filename="flat.stl"/></geometry></visual>
  </link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"#;
    let urdf = tmp.path().join("flat.urdf");
    std::fs::write(&urdf, text).expect("urdf");
    let u = import_urdf_tree(&urdf).expect("imports");
    let place = UrdfPlacement {
        name: "flat".into(),
        pose: robosim_instance_space::IDENTITY,
        parent: None,
        visuals: true,
        mimic: false,
    };
    let e = urdf_tx(&u, &place).expect_err("no geometry");
    let UrdfTxError::MeshGeometry {
        file,
        line,
        element,
        role,
        source,
    } = &e
    else {
        panic!("{e:?}")
    };
    let mesh_line = text
        .lines()
        .position(|l| l.contains("flat.stl"))
        .expect("there")
        + 1;
    assert_eq!((file, *line as usize), (&urdf, mesh_line), "{e}");
    assert!(element.contains("<mesh>"), "{e}");
    assert!(
        matches!(&**source, FileError::Mesh { reason, .. } if reason.contains("zero area")),
        "{source}"
    );
    let cause = std::error::Error::source(&e).expect("the importer's error as the source");
    assert_eq!(cause.to_string(), source.to_string());
    // The mesh is a <visual>: the message says so (it said "collision solid" for either).
    assert_eq!(*role, "visual geometry");
    // Otherwise the message the user read before the error was typed.
    let before = UrdfError {
        file: file.clone(),
        line: *line,
        element: element.clone(),
        kind: UrdfErrorKind::Mesh(MeshProblem::Shape(source.to_string())),
    }
    .to_string()
    .replace("collision solid", "visual geometry");
    assert_eq!(e.to_string(), before);
    // Through the file interface's error (`robosim render FILE.urdf`), the same message.
    let e = robosim_file_io::urdf_session::urdf_store(&urdf).expect_err("no geometry");
    assert_eq!(e.to_string(), before);
}

/// The UR5's collision meshes: those whose hull is far from them (closed meshes, hull > 1.25 ×
/// their volume, measured) arrive as several convex solids `LINK-collisionK.P`, the others as
/// their hull; the decomposed parts hold less volume than the hull and at least the mesh's
/// (they cover it: conservative for collision). Without visuals the solids are drawn.
#[test]
fn concave_collision_meshes_arrive_decomposed() {
    let u = import_urdf_tree(&dir().join("ur5_robot.urdf")).expect("imports");
    let imp = urdf_tx(
        &u,
        &UrdfPlacement {
            name: "ur5".into(),
            pose: robosim_instance_space::IDENTITY,
            parent: None,
            visuals: false,
            mimic: false,
        },
    )
    .expect("transaction");
    let (_, collisions, _) = u.geometry.counts();
    assert!(imp.decomposed >= 1, "{imp:?}");
    assert!(imp.solids > collisions, "{} > {collisions}", imp.solids);
    let mut store = Store::default();
    store.apply(&imp.tx).expect("the keeper's checks pass");
    let snap = Snapshot::from_store(&store);
    let mut checked = 0;
    for g in u.geometry.links.values() {
        for s in &g.collision {
            let robosim_file_io::urdf_geometry::Geometry::Mesh(m) = &s.geometry else {
                continue;
            };
            let tris = m.load().expect("mesh");
            let d = robosim_collision::decompose::convex_parts(
                &tris,
                robosim_collision::decompose::DEFAULT_EXCESS,
            )
            .expect("parts");
            if !d.decomposed {
                continue;
            }
            let v = d.mesh_volume.expect("closed");
            let parts: f64 = d
                .parts
                .iter()
                .map(|p| {
                    robosim_collision::Solid::convex(p)
                        .expect("part")
                        .faceted_volume()
                })
                .sum();
            assert!(d.hull_volume > 1.25 * v, "hull {} mesh {v}", d.hull_volume);
            assert!(
                parts < d.hull_volume && parts >= v,
                "parts {parts}, mesh {v}, hull {}",
                d.hull_volume
            );
            checked += 1;
        }
    }
    assert_eq!(checked, imp.decomposed);
    let drawn = (0..snap.len())
        .filter(|&i| snap.object(i).kind() == Some(Kind::Solid))
        .all(|i| snap.rec(i).color[3] == 1.0);
    assert!(drawn, "without visuals the solids are drawn");
    assert!(
        (0..snap.len()).any(|i| snap.name(i).ends_with(".1")),
        "decomposed parts are named LINK-collisionK.P"
    );
}

/// A tree's chain to one tip (`Robot::chain_to`, what the session's kinv and jacob use with
/// `tip`): its tip frame and its Jacobian at its own q are the tree's at any q that agrees on
/// the chain's joints, to rounding.
#[test]
fn a_trees_chain_to_a_tip_is_the_tree_along_that_path() {
    let u = import_urdf_tree(&dir().join("panda.urdf")).expect("imports");
    let tree = &u.robot;
    let q = [0.3, -0.4, 0.2, -1.9, 0.5, 1.4, -0.6, 0.02, 0.035];
    let tree_frames = fk::link_frames(tree, &q);
    for (link, tree_frame) in tree_frames.iter().enumerate().take(tree.dof() + 1).skip(1) {
        let (chain, joints) = tree.chain_to(link).expect("a link");
        let qc: Vec<f64> = joints.iter().map(|&j| q[j]).collect();
        assert_eq!(joints, tree.support(link));
        let frames = fk::link_frames(&chain, &qc);
        let e = (frames[chain.dof()] - tree_frame).abs().max();
        assert!(e < 1e-15, "link {link}: tip frame {e:e}");
        let (_, jt) = link_jacobian(tree, &q, link, Frame::Base);
        let (_, jc) = link_jacobian(&chain, &qc, chain.dof(), Frame::Base);
        for (k, &j) in joints.iter().enumerate() {
            let e = (jc.column(k) - jt.column(j)).abs().max();
            assert!(e < 1e-15, "link {link}, joint {j}: Jacobian column {e:e}");
        }
    }
    // The two fingers: chains of 8 joints sharing the arm's 7.
    assert_eq!(
        tree.chain_to(8).expect("left").1,
        vec![0, 1, 2, 3, 4, 5, 6, 7]
    );
    assert_eq!(
        tree.chain_to(9).expect("right").1,
        vec![0, 1, 2, 3, 4, 5, 6, 8]
    );
    assert!(tree.chain_to(0).is_none() && tree.chain_to(10).is_none());
}
