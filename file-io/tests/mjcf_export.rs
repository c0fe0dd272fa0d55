//! MJCF export against MuJoCo (issue 36 item 4): the library robots exported by robosim
//! (`to_mjcf`), read back by robosim's own MJCF import, have the tool pose and mass matrix MuJoCo
//! computed on the exported files (testdata/mjcf/exports/mujoco_exports.json, written by
//! tools/peers/check_exports.py with MuJoCo 4.0, which also checks Pinocchio and the URDF
//! export; docs/file-io.md has its table).

use crate::reference::{floats, matrix, testdata};
use nalgebra::Matrix4;
use robosim_file_io::inertial::physical_inertia;
use robosim_file_io::mjcf::import_mjcf_tree_str;
use robosim_file_io::mjcf_export::to_mjcf;
use robosim_kinematics::fk;
use std::path::Path;

fn reference() -> serde_json::Value {
    let text = std::fs::read_to_string(testdata().join("mjcf/exports/mujoco_exports.json"))
        .expect("testdata/mjcf/exports/mujoco_exports.json");
    serde_json::from_str(&text).expect("reference JSON")
}

/// The largest tool-pose difference and relative M difference of `text` (MJCF) re-imported,
/// against MuJoCo's numbers in `entry`.
fn compare(name: &str, text: &str, entry: &serde_json::Value) -> (f64, f64) {
    let r = import_mjcf_tree_str(text, Path::new("export.xml"))
        .unwrap_or_else(|e| panic!("{name}: robosim does not read its own export: {e}"));
    let tool = &r.geometry.links[&format!("{name}_tool")];
    let model = robosim_dynamics::Model::new(&r.robot).expect("dynamics model");
    let mut data = robosim_dynamics::Data::new(&model);
    let (mut ex, mut em) = (0.0f64, 0.0f64);
    for s in entry["samples"].as_array().expect("samples") {
        let q = floats(&s["q"]);
        let x = fk::link_frames(&r.robot, &q)[tool.body] * tool.in_body;
        let want = matrix(&s["tool"]);
        let want = Matrix4::from_fn(|i, j| want[(i, j)]);
        ex = ex.max((x - want).amax());
        let theirs = matrix(&s["mass_matrix"]);
        let ours = robosim_dynamics::crba(&model, &mut data, &q).expect("crba");
        em = em.max((ours - &theirs).amax() / theirs.amax().max(1.0));
    }
    (ex, em)
}

#[test]
fn library_robots_exported_to_mjcf_have_mujocos_fk_and_mass_matrix() {
    let reference = reference();
    let robots = reference["robots"].as_array().expect("robots");
    for name in ["puma560", "stanford", "weld_positioner"] {
        let entry = robots
            .iter()
            .find(|r| r["name"] == name)
            .unwrap_or_else(|| panic!("{name} in the reference"));
        let mut robot = robosim_library::standard_robot(name).expect("a library robot");
        robot.name = name.to_string();
        let (text, _notes) = to_mjcf(&robot).expect("exports");
        let (ex, em) = compare(name, &text, entry);
        eprintln!("{name}: tool {ex:.1e}, M {em:.1e}");
        assert!(
            ex < 1e-10,
            "{name}: tool pose differs from MuJoCo's by {ex:e}"
        );
        assert!(em < 1e-10, "{name}: M differs from MuJoCo's by {em:e}");
    }
}

/// The checked-in exports (URDF-imported robots included) read back the same way.
#[test]
fn checked_in_exports_read_back_with_mujocos_numbers() {
    let reference = reference();
    for entry in reference["robots"].as_array().expect("robots") {
        let name = entry["name"].as_str().expect("name");
        let path = testdata()
            .join("mjcf/exports")
            .join(entry["file"].as_str().expect("file"));
        let text = std::fs::read_to_string(&path).expect("exported file");
        let (ex, em) = compare(name, &text, entry);
        assert!(ex < 1e-10 && em < 1e-10, "{name}: tool {ex:e}, M {em:e}");
    }
}

/// The PUMA's link 3 in the library's data breaks A + B ≥ C: the export says so and writes a
/// tensor that satisfies it, with the largest moment kept.
#[test]
fn puma_link_3_is_made_physical_and_said() {
    let robot = robosim_library::standard_robot("puma560").expect("puma560");
    let (_, notes) = to_mjcf(&robot).expect("exports");
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with("link 3:") && n.contains("A + B ≥ C")),
        "{notes:?}"
    );
    let (fixed, note) = physical_inertia(&robot.joints[2].inertia, "link 3");
    assert!(note.is_some());
    let mut e: Vec<f64> = fixed
        .symmetric_eigen()
        .eigenvalues
        .iter()
        .copied()
        .collect();
    e.sort_by(f64::total_cmp);
    assert!(e[0] + e[1] >= e[2], "{e:?}");
}

/// Solo-12 with a free-flyer base (issue 36 items 2 and 4): the numbers MuJoCo 4.0 computed on
/// the session's MJCF export (testdata/mjcf/exports/solo_floating.json, written by
/// tools/peers/check_exports.py) are robosim's — its tool pose and mass matrix at each recorded
/// q, on the robot as imported (`import_urdf_tree_floating`) and on its MJCF export made now
/// and read back. The JSON's q is robosim's layout (x y z qx qy qz qw, joints) and its M is
/// MuJoCo's in robosim's velocity layout (TᵀMT), so a change of the free joint's writing, of the
/// quaternion order or of the base's inertial fails here.
#[test]
fn solo_floating_export_has_mujocos_tool_pose_and_mass_matrix() {
    let text = std::fs::read_to_string(testdata().join("mjcf/exports/solo_floating.json"))
        .expect("testdata/mjcf/exports/solo_floating.json");
    let reference: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    let solo = testdata().join("urdf_corpus/robots/solo_description/solo12.urdf");
    let mut u = robosim_file_io::urdf_import::import_urdf_tree_floating(
        &solo,
        robosim_kinematics::RootKind::FreeFlyer,
    )
    .expect("Solo imports floating");
    u.robot.name = "solo".into();
    let (mjcf, _) = to_mjcf(&u.robot).expect("exports");
    assert!(mjcf.contains("<freejoint name=\"solo_root\"/>"));
    let back = import_mjcf_tree_str(&mjcf, Path::new("solo.xml")).expect("reads back");
    assert!(
        back.robot.root.is_some(),
        "the export's free joint is a floating base"
    );
    let tool = &back.geometry.links["solo_tool"];
    let samples = reference["samples"].as_array().expect("samples");
    assert_eq!(samples.len(), 5);
    let (mut ex, mut em) = (0.0f64, 0.0f64);
    for (label, robot) in [("imported", &u.robot), ("exported", &back.robot)] {
        let model = robosim_dynamics::Model::new(robot).expect("dynamics model");
        let mut data = robosim_dynamics::Data::new(&model);
        for s in samples {
            let q = floats(&s["q"]);
            assert_eq!(q.len(), robot.nq(), "{label}: q");
            let x = if label == "imported" {
                fk::forward(robot, &q)
            } else {
                fk::link_frames(robot, &q)[tool.body] * tool.in_body
            };
            let want = matrix(&s["tool"]);
            ex = ex.max((x - Matrix4::from_fn(|i, j| want[(i, j)])).amax());
            let theirs = matrix(&s["mass_matrix"]);
            let ours = robosim_dynamics::crba(&model, &mut data, &q).expect("crba");
            em = em.max((ours - &theirs).amax() / theirs.amax().max(1.0));
        }
        eprintln!("solo {label}: tool {ex:.1e}, M {em:.1e}");
    }
    assert!(ex < 1e-10, "tool pose differs from MuJoCo's by {ex:e}");
    assert!(em < 1e-10, "M differs from MuJoCo's by {em:e}");
}

/// Ball joints (issue 36 item 4): the MJCF export writes a spherical joint as `type="ball"`
/// (MuJoCo's qpos w x y z is robosim's x y z w reordered, by the importer) and reads back as the
/// same robot — every link frame and M at random q, three balls in a tree. URDF has no ball
/// joint: its export refuses the robot by name (mjcf_import.rs). MuJoCo's own numbers on the
/// exported chain are in mujoco_exports.json (`ball_chain`, checked above).
#[test]
fn ball_joints_are_exported_as_mujoco_balls() {
    use rand::{Rng, SeedableRng};
    let path = testdata().join("ball/ball_tree.xml");
    let mut u = robosim_file_io::mjcf::import_mjcf_tree(&path).expect("ball_tree imports");
    u.robot.name = "b".into();
    let (text, _) = to_mjcf(&u.robot).expect("a ball joint exports");
    assert_eq!(text.matches("type=\"ball\"").count(), 3, "{text}");
    let back = import_mjcf_tree_str(&text, Path::new("b.xml")).expect("reads back");
    assert_eq!(
        (back.robot.nq(), back.robot.nv()),
        (u.robot.nq(), u.robot.nv())
    );
    let (a, b) = (&u.robot, &back.robot);
    let ma = robosim_dynamics::Model::new(a).expect("model");
    let mb = robosim_dynamics::Model::new(b).expect("model");
    let (mut da, mut db) = (
        robosim_dynamics::Data::new(&ma),
        robosim_dynamics::Data::new(&mb),
    );
    let mut rng = rand::rngs::StdRng::seed_from_u64(364);
    let (mut ex, mut em) = (0.0f64, 0.0f64);
    for _ in 0..10 {
        let mut q: Vec<f64> = (0..a.nq()).map(|_| rng.random_range(-1.0..1.0)).collect();
        for (j, joint) in a.joints.iter().enumerate() {
            if joint.spherical {
                let s = &mut q[a.q_index(j)..a.q_index(j) + 4];
                let n = s.iter().map(|x| x * x).sum::<f64>().sqrt();
                s.iter_mut().for_each(|x| *x /= n);
            }
        }
        for (x, y) in fk::link_frames(a, &q).iter().zip(&fk::link_frames(b, &q)) {
            ex = ex.max((x - y).amax());
        }
        let m1 = robosim_dynamics::crba(&ma, &mut da, &q).expect("crba");
        let m2 = robosim_dynamics::crba(&mb, &mut db, &q).expect("crba");
        em = em.max((m1 - m2).amax());
    }
    assert!(ex < 1e-12 && em < 1e-12, "frames {ex:e}, M {em:e}");
}
